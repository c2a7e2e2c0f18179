//! Warps from the unit square to directions and shapes, with their pdfs, plus the shading frame
//! and the multiple-importance-sampling heuristic.
//!
//! Every warp comes with the density it produces (over solid angle for directions, over area for
//! shapes) so that estimators can divide by exactly the density they sampled from; the unit tests
//! check each pair against each other with chi-square tests.

// Comparisons are written `!(x > 0.0)` on purpose: they also reject NaN.
#![allow(clippy::neg_cmp_op_on_partial_ord)]

use glam::{Vec2, Vec3A};
use std::f32::consts::{FRAC_1_PI, FRAC_PI_4, PI, TAU};
use torrey_fastmath::{expm1, ln, powf, sin_cos_2pi, sin_cos_eighth, swap_if};

/// Maps the unit square to the unit disk with Shirley and Chiu's concentric mapping, which keeps
/// strata compact (unlike the polar map) so stratified samples stay well spread on the disk.
pub fn square_to_concentric_disk(u: Vec2) -> Vec2 {
    let a = 2.0 * u.x - 1.0;
    let b = 2.0 * u.y - 1.0;
    if a == 0.0 && b == 0.0 {
        return Vec2::ZERO;
    }
    // φ = π/4 · (b/a), or π/2 − π/4 · (a/b): both need only sin and cos on [−π/4, π/4]. The two
    // cases share one evaluation through selects: which one applies is random from sample to
    // sample, and a branch on it mispredicted half the time.
    let wide = a.abs() > b.abs();
    let (r, other) = if wide { (a, b) } else { (b, a) };
    let (sin, cos) = sin_cos_eighth(FRAC_PI_4 * (other / r));
    let (x, y) = swap_if(wide, sin, cos);
    Vec2::new(r * x, r * y)
}

/// Cosine-weighted direction on the +z hemisphere (Malley's method): the importance-sampling
/// density for diffuse reflection, pdf = cos θ / π ([`cosine_hemisphere_pdf`]).
pub fn square_to_cosine_hemisphere(u: Vec2) -> Vec3A {
    let d = square_to_concentric_disk(u);
    let z = (1.0 - d.length_squared()).max(0.0).sqrt();
    Vec3A::new(d.x, d.y, z)
}

/// Solid-angle density of [`square_to_cosine_hemisphere`]; zero below the horizon.
pub fn cosine_hemisphere_pdf(cos_theta: f32) -> f32 {
    if cos_theta > 0.0 {
        cos_theta * FRAC_1_PI
    } else {
        0.0
    }
}

/// Uniformly distributed direction on the unit sphere, for isotropic sampling (point-light
/// emission, test quadrature); pdf = 1 / 4π ([`uniform_sphere_pdf`]).
pub fn square_to_uniform_sphere(u: Vec2) -> Vec3A {
    let z = 1.0 - 2.0 * u.x;
    let r = (1.0 - z * z).max(0.0).sqrt();
    let (sin, cos) = sin_cos_2pi(u.y);
    Vec3A::new(r * cos, r * sin, z)
}

/// Solid-angle density of [`square_to_uniform_sphere`].
pub fn uniform_sphere_pdf() -> f32 {
    1.0 / (4.0 * PI)
}

/// Direction on the +z hemisphere with density ∝ cos^exponent θ: the Phong lobe (around the
/// mirror direction) and the Blinn half-vector distribution. pdf = (n + 1)/(2π) cos^n θ
/// ([`cosine_power_pdf`]). Written so that large exponents keep their precision near the pole.
pub fn square_to_cosine_power(u: Vec2, exponent: f32) -> Vec3A {
    // cos θ = u^(1/(n+1)); 1 − cos θ computed with expm1 so sin θ stays accurate for sharp lobes.
    let log_cos = ln(u.x) / (exponent + 1.0);
    let one_minus_cos = -expm1(log_cos);
    let cos_theta = 1.0 - one_minus_cos;
    let sin_theta = (one_minus_cos * (1.0 + cos_theta)).max(0.0).sqrt();
    let (sin, cos) = sin_cos_2pi(u.y);
    Vec3A::new(sin_theta * cos, sin_theta * sin, cos_theta)
}

/// Solid-angle density of [`square_to_cosine_power`]; zero below the horizon.
pub fn cosine_power_pdf(cos_theta: f32, exponent: f32) -> f32 {
    if cos_theta > 0.0 {
        (exponent + 1.0) / TAU * powf(cos_theta, exponent)
    } else {
        0.0
    }
}

/// An orthonormal shading frame: `n` is the shading normal (local +z), `s` and `t` span the
/// tangent plane (local +x, +y). BSDFs work in this frame so they only ever see z = cos θ.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Frame {
    pub s: Vec3A,
    pub t: Vec3A,
    pub n: Vec3A,
}

impl Frame {
    /// Builds a frame around a unit normal with Duff et al.'s branchless construction
    /// ("Building an Orthonormal Basis, Revisited", JCGT 2017): continuous except across the
    /// z = 0 plane, no normalisation, no precision loss near the poles.
    pub fn from_normal(n: Vec3A) -> Self {
        let sign = 1.0f32.copysign(n.z);
        let a = -1.0 / (sign + n.z);
        let b = n.x * n.y * a;
        let s = Vec3A::new(1.0 + sign * n.x * n.x * a, sign * b, -sign * n.x);
        let t = Vec3A::new(b, sign + n.y * n.y * a, -n.y);
        Frame { s, t, n }
    }

    /// Builds a frame whose `s` follows a tangent (e.g. dp/du) projected into the tangent plane
    /// (Gram-Schmidt), so anisotropic or normal-mapped shading keeps a texture-aligned frame.
    /// Falls back to [`Frame::from_normal`] when the tangent is (nearly) parallel to `n`.
    pub fn from_normal_tangent(n: Vec3A, tangent: Vec3A) -> Self {
        let s = tangent - n * n.dot(tangent);
        let len2 = s.length_squared();
        if !(len2 > 1e-10 * tangent.length_squared()) || !len2.is_finite() {
            return Self::from_normal(n);
        }
        let s = s / len2.sqrt();
        Frame {
            s,
            t: n.cross(s),
            n,
        }
    }

    /// World direction to local coordinates (z = component along the normal).
    pub fn to_local(self, v: Vec3A) -> Vec3A {
        Vec3A::new(v.dot(self.s), v.dot(self.t), v.dot(self.n))
    }

    /// Local coordinates back to a world direction.
    pub fn to_world(self, v: Vec3A) -> Vec3A {
        self.s * v.x + self.t * v.y + self.n * v.z
    }
}

/// Veach's power heuristic (β = 2): the MIS weight of a sample drawn from the strategy with
/// density `pdf_a` when strategy b (density `pdf_b`) could also have produced it. Robust to the
/// edge cases an integrator meets: an infinite `pdf_a` (a delta lobe) gets weight 1, an infinite
/// `pdf_b` weight 0, both zero gives 0, and huge finite densities do not overflow when squared.
pub fn power_heuristic(pdf_a: f32, pdf_b: f32) -> f32 {
    if pdf_a.is_infinite() {
        return if pdf_b.is_infinite() { 0.5 } else { 1.0 };
    }
    if pdf_b.is_infinite() || !(pdf_a > 0.0) {
        return 0.0;
    }
    if !(pdf_b > 0.0) {
        return 1.0;
    }
    if pdf_a >= pdf_b {
        let r = pdf_b / pdf_a;
        1.0 / (1.0 + r * r)
    } else {
        let r = pdf_a / pdf_b;
        let r2 = r * r;
        r2 / (1.0 + r2)
    }
}

/// Helpers shared by the sampling and BSDF tests: quadrature of densities over cells and the
/// sphere, plus the RNG and chi-square test of `torrey-testkit`.
#[cfg(test)]
pub(crate) mod testutil {
    pub use torrey_testkit::{chi2_test, Rng};

    /// Composite 4-point Gauss-Legendre rule of `f(x, y)` over [x0, x1] × [y0, y1] with `m`
    /// sub-intervals per axis. It never evaluates on cell edges, so a pdf that jumps exactly at a
    /// bin boundary (a horizon, a cone edge) is integrated without edge bias.
    pub fn gauss_2d(
        f: &mut impl FnMut(f64, f64) -> f64,
        (x0, x1): (f64, f64),
        (y0, y1): (f64, f64),
        m: usize,
    ) -> f64 {
        const X: [f64; 4] = [
            -0.861_136_311_594_052_6,
            -0.339_981_043_584_856_3,
            0.339_981_043_584_856_3,
            0.861_136_311_594_052_6,
        ];
        const W: [f64; 4] = [
            0.347_854_845_137_453_9,
            0.652_145_154_862_546_1,
            0.652_145_154_862_546_1,
            0.347_854_845_137_453_9,
        ];
        let hx = (x1 - x0) / m as f64;
        let hy = (y1 - y0) / m as f64;
        let mut sum = 0.0;
        for i in 0..m {
            let cx = x0 + hx * (i as f64 + 0.5);
            for (xi, wi) in X.iter().zip(W) {
                let x = cx + 0.5 * hx * xi;
                for j in 0..m {
                    let cy = y0 + hy * (j as f64 + 0.5);
                    for (yj, wj) in X.iter().zip(W) {
                        sum += wi * wj * f(x, cy + 0.5 * hy * yj);
                    }
                }
            }
        }
        sum * 0.25 * hx * hy
    }

    /// Stratified estimate of ∫ f(ω) dω over the unit sphere, with `nz` × `np` equal-area strata
    /// in (z, φ) (finest around the equator): one jittered sample per stratum with `Some(seed)`,
    /// the stratum centre (a midpoint rule, far more accurate for smooth lobes) with `None`.
    pub fn stratified_sphere_integral(
        mut f: impl FnMut(glam::Vec3A) -> f64,
        nz: usize,
        np: usize,
        seed: Option<u64>,
    ) -> f64 {
        let mut rng = seed.map(Rng::new);
        let mut jitter = || rng.as_mut().map_or(0.5, |r| r.f32());
        let mut sum = 0.0;
        for i in 0..nz {
            for j in 0..np {
                let u = glam::Vec2::new(
                    (i as f32 + jitter()) / nz as f32,
                    (j as f32 + jitter()) / np as f32,
                );
                sum += f(super::square_to_uniform_sphere(u));
            }
        }
        sum * 4.0 * std::f64::consts::PI / (nz * np) as f64
    }
}

#[cfg(test)]
mod tests {
    use super::testutil::*;
    use super::*;

    fn assert_orthonormal(f: &Frame) {
        for (a, b) in [(f.s, f.t), (f.t, f.n), (f.n, f.s)] {
            assert!(a.dot(b).abs() < 1e-5, "{f:?}");
        }
        for v in [f.s, f.t, f.n] {
            assert!((v.length() - 1.0).abs() < 1e-5, "{f:?}");
        }
        // Right-handed: s × t = n, so local +z maps to the normal with positive orientation.
        assert!((f.s.cross(f.t) - f.n).length() < 1e-5, "{f:?}");
    }

    #[test]
    fn frame_is_orthonormal_and_round_trips() {
        let mut rng = Rng::new(1);
        let mut normals = vec![
            Vec3A::Z,
            -Vec3A::Z,
            Vec3A::X,
            -Vec3A::Y,
            Vec3A::new(0.0, 1e-7, -1.0).normalize(),
            Vec3A::new(1e-8, 0.0, 1.0).normalize(),
        ];
        for _ in 0..1000 {
            normals.push(square_to_uniform_sphere(rng.vec2()));
        }
        for n in normals {
            let f = Frame::from_normal(n);
            assert_eq!(f.n, n);
            assert_orthonormal(&f);
            let v = square_to_uniform_sphere(rng.vec2());
            assert!((f.to_world(f.to_local(v)) - v).length() < 1e-5);
            assert!((f.to_local(n) - Vec3A::Z).length() < 1e-5);
            let tangent = square_to_uniform_sphere(rng.vec2());
            let g = Frame::from_normal_tangent(n, tangent);
            assert_orthonormal(&g);
            assert_eq!(g.n, n);
            let projected = (tangent - n * n.dot(tangent)).normalize();
            assert!((g.s - projected).length() < 1e-4, "{g:?} {tangent}");
        }
        // Degenerate tangent falls back instead of producing NaNs.
        assert_orthonormal(&Frame::from_normal_tangent(Vec3A::Z, Vec3A::Z * 2.0));
        assert_orthonormal(&Frame::from_normal_tangent(Vec3A::Z, Vec3A::ZERO));
    }

    #[test]
    fn warps_map_to_their_domains() {
        let mut rng = Rng::new(2);
        let mut us: Vec<Vec2> = (0..20_000).map(|_| rng.vec2()).collect();
        us.extend([
            Vec2::ZERO,
            Vec2::ONE,
            Vec2::new(0.0, 1.0),
            Vec2::new(1.0, 0.5),
        ]);
        for u in us {
            let d = square_to_concentric_disk(u);
            assert!(d.length() <= 1.0 + 1e-6);
            let w = square_to_cosine_hemisphere(u);
            assert!((w.length() - 1.0).abs() < 1e-5 && w.z >= 0.0, "{w}");
            let w = square_to_uniform_sphere(u);
            assert!((w.length() - 1.0).abs() < 1e-5, "{w}");
            for e in [0.0, 1.0, 1000.0, 1e6] {
                let w = square_to_cosine_power(u, e);
                assert!((w.length() - 1.0).abs() < 1e-5 && w.z >= 0.0, "{w}");
                assert!(w.is_finite());
            }
        }
    }

    /// Bins directions on a (cos θ, φ) grid, which has equal-area cells, and compares the
    /// counts with the pdf integrated over each cell.
    fn chi2_direction_warp(
        warp: impl Fn(Vec2) -> Vec3A,
        pdf: impl Fn(Vec3A) -> f64,
        seed: u64,
    ) -> f64 {
        const NZ: usize = 20;
        const NP: usize = 40;
        const N: usize = 400_000;
        let mut rng = Rng::new(seed);
        let mut observed = vec![0.0; NZ * NP];
        for _ in 0..N {
            let w = warp(rng.vec2());
            let iz = (((w.z as f64 + 1.0) * 0.5 * NZ as f64) as usize).min(NZ - 1);
            let phi = (w.y as f64)
                .atan2(w.x as f64)
                .rem_euclid(std::f64::consts::TAU);
            let ip = ((phi / std::f64::consts::TAU * NP as f64) as usize).min(NP - 1);
            observed[iz * NP + ip] += 1.0;
        }
        let mut expected = vec![0.0; NZ * NP];
        let mut f = |z: f64, phi: f64| {
            let r = (1.0 - z * z).max(0.0).sqrt();
            let w = Vec3A::new((r * phi.cos()) as f32, (r * phi.sin()) as f32, z as f32);
            pdf(w)
        };
        for iz in 0..NZ {
            for ip in 0..NP {
                let z0 = -1.0 + 2.0 * iz as f64 / NZ as f64;
                let z1 = -1.0 + 2.0 * (iz + 1) as f64 / NZ as f64;
                let p0 = std::f64::consts::TAU * ip as f64 / NP as f64;
                let p1 = std::f64::consts::TAU * (ip + 1) as f64 / NP as f64;
                expected[iz * NP + ip] = N as f64 * gauss_2d(&mut f, (z0, z1), (p0, p1), 2);
            }
        }
        let (p, stat, dof) = chi2_test(&observed, &expected).unwrap();
        eprintln!("chi2 = {stat:.1}, dof = {dof}, p = {p:.3}");
        p
    }

    #[test]
    fn direction_warps_pass_chi2() {
        let p = chi2_direction_warp(square_to_uniform_sphere, |_| uniform_sphere_pdf() as f64, 3);
        assert!(p > 1e-3);
        let p = chi2_direction_warp(
            square_to_cosine_hemisphere,
            |w| cosine_hemisphere_pdf(w.z) as f64,
            5,
        );
        assert!(p > 1e-3);
        for (e, seed) in [(0.0, 7), (1.0, 8), (4.0, 9), (20.0, 10)] {
            let p = chi2_direction_warp(
                |u| square_to_cosine_power(u, e),
                |w| cosine_power_pdf(w.z, e) as f64,
                seed,
            );
            assert!(p > 1e-3, "exponent {e}");
        }
    }

    #[test]
    fn chi2_rejects_a_mismatched_warp() {
        // Cosine-power samples against a slightly wrong exponent must be caught.
        let p = chi2_direction_warp(
            |u| square_to_cosine_power(u, 4.0),
            |w| cosine_power_pdf(w.z, 4.4) as f64,
            11,
        );
        assert!(p < 1e-3, "p = {p}");
    }

    #[test]
    fn warp_pdfs_integrate_to_one() {
        // Lobes are turned to point along +x (the equator of the stratification) so that even the
        // exponent-1000 lobe spans many strata.
        type Pdf = Box<dyn Fn(Vec3A) -> f64>;
        let checks: [(&str, Pdf); 3] = [
            ("cosine", Box::new(|w| cosine_hemisphere_pdf(w.x) as f64)),
            ("power 10", Box::new(|w| cosine_power_pdf(w.x, 10.0) as f64)),
            (
                "power 1000",
                Box::new(|w| cosine_power_pdf(w.x, 1000.0) as f64),
            ),
        ];
        for (name, pdf) in checks {
            let integral = stratified_sphere_integral(pdf, 1024, 1024, Some(12));
            assert!((integral - 1.0).abs() < 2e-3, "{name}: {integral}");
        }
    }

    #[test]
    fn power_heuristic_edge_cases() {
        assert_eq!(power_heuristic(f32::INFINITY, 3.0), 1.0);
        assert_eq!(power_heuristic(3.0, f32::INFINITY), 0.0);
        assert_eq!(power_heuristic(0.0, 0.0), 0.0);
        assert_eq!(power_heuristic(0.0, 2.0), 0.0);
        assert_eq!(power_heuristic(2.0, 0.0), 1.0);
        assert!((power_heuristic(1.0, 1.0) - 0.5).abs() < 1e-7);
        assert!((power_heuristic(1.0, 2.0) - 0.2).abs() < 1e-7);
        assert!((power_heuristic(2.0, 1.0) - 0.8).abs() < 1e-7);
        // Would overflow if squared naively.
        assert!((power_heuristic(1e30, 1e30) - 0.5).abs() < 1e-7);
        assert!((power_heuristic(3e25, 1e25) - 0.9).abs() < 1e-6);
        // The two weights of a pair sum to one.
        for (a, b) in [(0.3, 7.0), (1e-20, 1e-21), (5.0, 5e10)] {
            assert!((power_heuristic(a, b) + power_heuristic(b, a) - 1.0).abs() < 1e-6);
        }
        assert_eq!(power_heuristic(f32::NAN, 1.0), 0.0);
    }
}
