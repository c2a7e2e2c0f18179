//! Microfacet distributions as Mitsuba 3's `MicrofacetDistribution`: Beckmann and GGX
//! (Trowbridge-Reitz), anisotropic (α_u along the tangent x, α_v along y), Smith shadowing and
//! sampling of the visible normals (Heitz and d'Eon 2014; for GGX Heitz 2018's closed form) or,
//! with Mitsuba's `sample_visible = false`, of the whole distribution D(m) cos θm.
//!
//! Mitsuba evaluates Beckmann's Smith G1 with Walter et al.'s rational fit; `eval`-side code
//! uses that ([`Microfacet::smith_g1`]) so the BSDF values are Mitsuba's. The pdf of visible
//! normals uses the exact G1 ([`Microfacet::smith_g1_exact`]), which is what the sampler draws
//! from, so that weights and MIS stay consistent (Mitsuba uses the fit in both; the difference
//! is below 0.4% of a term that only affects noise).

use glam::{Vec2, Vec3A};
use std::f32::consts::{FRAC_1_PI, PI};

/// Which normal distribution.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum MicrofacetKind {
    Beckmann,
    Ggx,
}

/// A distribution of microfacet normals with roughness α_u (x) and α_v (y).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Microfacet {
    pub kind: MicrofacetKind,
    pub alpha_u: f32,
    pub alpha_v: f32,
    /// Sample the normals visible from the incident direction (Mitsuba's `sample_visible`,
    /// default true) rather than D(m) cos θm: the same BSDF, less noise.
    pub visible: bool,
}

impl Microfacet {
    /// Roughness below this is clamped (a near-delta lobe would overflow D).
    const MIN_ALPHA: f32 = 1e-4;

    pub fn new(kind: MicrofacetKind, alpha_u: f32, alpha_v: f32) -> Self {
        Self {
            kind,
            alpha_u: alpha_u.max(Self::MIN_ALPHA),
            alpha_v: alpha_v.max(Self::MIN_ALPHA),
            visible: true,
        }
    }

    /// The same distribution, sampled as `visible` says (Mitsuba's `sample_visible`).
    #[inline(always)]
    pub fn with_visible(self, visible: bool) -> Self {
        Self { visible, ..self }
    }

    /// A normal drawn by the configured strategy: the normals visible from `wi` (wi.z > 0) or
    /// the whole distribution.
    #[inline]
    pub fn sample(&self, wi: Vec3A, u: Vec2) -> Vec3A {
        if self.visible {
            self.sample_visible(wi, u)
        } else {
            self.sample_all(u)
        }
    }

    /// The density (solid angle of m) of [`Microfacet::sample`].
    #[inline]
    pub fn pdf(&self, wi: Vec3A, m: Vec3A) -> f32 {
        if self.visible {
            self.pdf_visible(wi, m)
        } else {
            self.d(m) * m.z.max(0.0)
        }
    }

    /// A normal drawn from D(m) cos θm: the slopes of the distribution stretched to α = 1 are
    /// isotropic (Beckmann: a unit Gaussian, r² = −ln(1 − u); GGX: r² = u / (1 − u)), so draw
    /// their length and azimuth and stretch back by (α_u, α_v). The density of m is then the
    /// slope density P22 over cos³θm, which is D(m) cos θm.
    #[inline]
    pub fn sample_all(&self, u: Vec2) -> Vec3A {
        let r2 = match self.kind {
            MicrofacetKind::Beckmann => -(1.0 - u.x).max(1e-12).ln(),
            MicrofacetKind::Ggx => u.x / (1.0 - u.x).max(1e-12),
        };
        let r = r2.sqrt();
        let (s, c) = (2.0 * PI * u.y).sin_cos();
        Vec3A::new(-self.alpha_u * r * c, -self.alpha_v * r * s, 1.0).normalize()
    }

    /// D(m): the density of normals m per unit projected area (m in the +z hemisphere).
    #[inline]
    pub fn d(&self, m: Vec3A) -> f32 {
        if !(m.z > 0.0) {
            return 0.0;
        }
        let (ax, ay) = (self.alpha_u, self.alpha_v);
        let c2 = m.z * m.z;
        let r = (m.x / ax).powi(2) + (m.y / ay).powi(2);
        let v = match self.kind {
            MicrofacetKind::Beckmann => (-r / c2).exp() / (PI * ax * ay * c2 * c2),
            MicrofacetKind::Ggx => FRAC_1_PI / (ax * ay * (r + c2).powi(2)),
        };
        if v * m.z > 1e-20 {
            v
        } else {
            0.0
        }
    }

    /// tan²θ scaled by the roughness in v's azimuth: α(φ)² tan²θ.
    #[inline]
    fn alpha_tan2(&self, v: Vec3A) -> f32 {
        let xy = (self.alpha_u * v.x).powi(2) + (self.alpha_v * v.y).powi(2);
        xy / (v.z * v.z)
    }

    /// Smith's G1 as Mitsuba evaluates it (Beckmann: Walter et al.'s rational fit); zero when v
    /// sees the back of m.
    #[inline]
    pub fn smith_g1(&self, v: Vec3A, m: Vec3A) -> f32 {
        if !(v.dot(m) * v.z > 0.0) {
            return 0.0;
        }
        let t2 = self.alpha_tan2(v);
        if t2 <= 0.0 {
            return 1.0;
        }
        match self.kind {
            MicrofacetKind::Beckmann => {
                let a = 1.0 / t2.sqrt();
                if a >= 1.6 {
                    1.0
                } else {
                    let a2 = a * a;
                    (3.535 * a + 2.181 * a2) / (1.0 + 2.276 * a + 2.577 * a2)
                }
            }
            MicrofacetKind::Ggx => 2.0 / (1.0 + (1.0 + t2).sqrt()),
        }
    }

    /// Smith's G1 with the exact Beckmann Λ (GGX is exact already): the normalisation of the
    /// visible-normal distribution that [`Microfacet::sample_visible`] draws from.
    #[inline]
    pub fn smith_g1_exact(&self, v: Vec3A, m: Vec3A) -> f32 {
        if !(v.dot(m) * v.z > 0.0) {
            return 0.0;
        }
        match self.kind {
            MicrofacetKind::Ggx => self.smith_g1(v, m),
            MicrofacetKind::Beckmann => {
                let t2 = self.alpha_tan2(v);
                if t2 <= 0.0 {
                    return 1.0;
                }
                let a = 1.0 / t2.sqrt();
                let lambda = 0.5 * (erf(a) - 1.0) + (-a * a).exp() / (2.0 * a * PI.sqrt());
                1.0 / (1.0 + lambda)
            }
        }
    }

    /// G(wi, wo, m) = G1(wi) G1(wo), Mitsuba's separable Smith term.
    #[inline]
    pub fn g(&self, wi: Vec3A, wo: Vec3A, m: Vec3A) -> f32 {
        self.smith_g1(wi, m) * self.smith_g1(wo, m)
    }

    /// Density (solid angle of m) of the normals visible from `wi` (wi.z > 0):
    /// D(m) G1(wi, m) max(0, wi·m) / wi.z.
    #[inline]
    pub fn pdf_visible(&self, wi: Vec3A, m: Vec3A) -> f32 {
        let c = wi.dot(m);
        if !(wi.z > 0.0 && c > 0.0) {
            return 0.0;
        }
        self.d(m) * self.smith_g1_exact(wi, m) * c / wi.z
    }

    /// A normal drawn from the distribution of normals visible from `wi` (wi.z > 0).
    #[inline]
    pub fn sample_visible(&self, wi: Vec3A, u: Vec2) -> Vec3A {
        match self.kind {
            MicrofacetKind::Ggx => self.sample_ggx_visible(wi, u),
            MicrofacetKind::Beckmann => self.sample_beckmann_visible(wi, u),
        }
    }

    /// Heitz 2018: visible normals of the stretched (α = 1) GGX are a projected hemisphere.
    fn sample_ggx_visible(&self, wi: Vec3A, u: Vec2) -> Vec3A {
        let (ax, ay) = (self.alpha_u, self.alpha_v);
        let vh = Vec3A::new(ax * wi.x, ay * wi.y, wi.z).normalize();
        let lensq = vh.x * vh.x + vh.y * vh.y;
        let t1 = if lensq > 0.0 {
            Vec3A::new(-vh.y, vh.x, 0.0) / lensq.sqrt()
        } else {
            Vec3A::X
        };
        let t2 = vh.cross(t1);
        let r = u.x.sqrt();
        let phi = 2.0 * PI * u.y;
        let (s_phi, c_phi) = phi.sin_cos();
        let p1 = r * c_phi;
        let s = 0.5 * (1.0 + vh.z);
        let p2 = (1.0 - s) * (1.0 - p1 * p1).max(0.0).sqrt() + s * r * s_phi;
        let nh = t1 * p1 + t2 * p2 + vh * (1.0 - p1 * p1 - p2 * p2).max(0.0).sqrt();
        Vec3A::new(ax * nh.x, ay * nh.y, nh.z.max(1e-6)).normalize()
    }

    /// Heitz and d'Eon 2014: stretch to α = 1, sample the slopes visible from a direction at
    /// θ (x by inverting the slope CDF with Newton-bisection steps, y from a Gaussian), rotate
    /// to wi's azimuth and unstretch.
    fn sample_beckmann_visible(&self, wi: Vec3A, u: Vec2) -> Vec3A {
        let (ax, ay) = (self.alpha_u, self.alpha_v);
        let ws = Vec3A::new(ax * wi.x, ay * wi.y, wi.z).normalize();
        let sin_t = (1.0 - ws.z * ws.z).max(0.0).sqrt();
        let (cos_phi, sin_phi) = if sin_t > 1e-7 {
            (ws.x / sin_t, ws.y / sin_t)
        } else {
            (1.0, 0.0)
        };
        let (sx, sy) = beckmann_sample11(ws.z, u.x, u.y);
        let (sx, sy) = (cos_phi * sx - sin_phi * sy, sin_phi * sx + cos_phi * sy);
        Vec3A::new(-sx * ax, -sy * ay, 1.0).normalize()
    }
}

/// Slopes of the α = 1 Beckmann normals visible from a direction with cosine `cos_t` in the
/// xz plane.
fn beckmann_sample11(cos_t: f32, u1: f32, u2: f32) -> (f32, f32) {
    const INV_SQRT_PI: f32 = 0.564_189_6;
    if cos_t > 0.9999 {
        // Normal incidence: the slope distribution is the Gaussian itself.
        let r = (-(1.0 - u1).max(1e-12).ln()).sqrt();
        let (s, c) = (2.0 * PI * u2).sin_cos();
        return (r * c, r * s);
    }
    let sin_t = (1.0 - cos_t * cos_t).max(0.0).sqrt();
    let tan_t = sin_t / cos_t;
    let cot_t = 1.0 / tan_t;
    // The CDF of the x slope, as a function of b = erf(slope), on [-1, erf(cot θ)].
    let (mut a, mut c) = (-1.0f32, erf(cot_t));
    let x = u1.max(1e-6);
    let theta = cos_t.acos();
    let fit = 1.0 + theta * (-0.876 + theta * (0.4265 - 0.0594 * theta));
    let mut b = c - (1.0 + c) * (1.0 - x).powf(fit);
    let norm = 1.0 / (1.0 + c + INV_SQRT_PI * tan_t * (-cot_t * cot_t).exp());
    for _ in 0..16 {
        if !(b >= a && b <= c) {
            b = 0.5 * (a + c);
        }
        let inv = erfinv(b);
        let value = norm * (1.0 + b + INV_SQRT_PI * tan_t * (-inv * inv).exp()) - x;
        let derivative = norm * (1.0 - inv * tan_t);
        if value.abs() < 1e-6 {
            break;
        }
        if value > 0.0 {
            c = b;
        } else {
            a = b;
        }
        b -= value / derivative;
    }
    let sx = erfinv(b);
    let sy = erfinv(2.0 * u2.clamp(1e-6, 1.0 - 1e-6) - 1.0);
    (sx, sy)
}

/// The error function (Abramowitz and Stegun 7.1.26, |error| < 1.5e-7).
pub fn erf(x: f32) -> f32 {
    let s = x.signum();
    let x = x.abs() as f64;
    let t = 1.0 / (1.0 + 0.327_591_1 * x);
    let y = 1.0
        - (((((1.061_405_429 * t - 1.453_152_027) * t) + 1.421_413_741) * t - 0.284_496_736) * t
            + 0.254_829_592)
            * t
            * (-x * x).exp();
    s * y as f32
}

/// The inverse error function on (-1, 1) (Giles 2010, single precision).
pub fn erfinv(x: f32) -> f32 {
    let x = x.clamp(-0.999_999_9, 0.999_999_9);
    let mut w = -((1.0 - x) * (1.0 + x)).ln();
    let p = if w < 5.0 {
        w -= 2.5;
        let mut p = 2.810_226_4e-8;
        p = 3.432_739_4e-7 + p * w;
        p = -3.523_387_7e-6 + p * w;
        p = -4.391_506_5e-6 + p * w;
        p = 0.000_218_580_87 + p * w;
        p = -0.001_253_725 + p * w;
        p = -0.004_177_681_6 + p * w;
        p = 0.246_640_73 + p * w;
        1.501_409_4 + p * w
    } else {
        w = w.sqrt() - 3.0;
        let mut p = -0.000_200_214_26;
        p = 0.000_100_950_56 + p * w;
        p = 0.001_349_343_2 + p * w;
        p = -0.003_673_428_4 + p * w;
        p = 0.005_739_507_7 + p * w;
        p = -0.007_622_461_3 + p * w;
        p = 0.009_438_870_5 + p * w;
        p = 1.001_674 + p * w;
        2.832_976_8 + p * w
    };
    p * x
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::sampling::testutil::{stratified_sphere_integral, Rng};

    #[test]
    fn erf_and_its_inverse() {
        for &x in &[-2.0f32, -0.7, -0.1, 0.0, 0.3, 1.0, 1.8] {
            let y = erf(x);
            assert!((erfinv(y) - x).abs() < 2e-3 * (1.0 + x.abs()), "{x} {y}");
        }
        assert!((erf(0.5) - 0.520_499_9).abs() < 1e-6);
    }

    /// ∫ D(m) cos θm dm = 1, and the visible normals' density integrates to 1 for every
    /// direction (which also checks the exact G1).
    #[test]
    fn distributions_are_normalised() {
        for kind in [MicrofacetKind::Beckmann, MicrofacetKind::Ggx] {
            for (au, av) in [(0.3, 0.3), (0.5, 0.15), (1.0, 0.8)] {
                let d = Microfacet::new(kind, au, av);
                let proj =
                    stratified_sphere_integral(|m| (d.d(m) * m.z.max(0.0)) as f64, 800, 400, None);
                assert!((proj - 1.0).abs() < 5e-3, "{kind:?} {au} {av}: {proj}");
                for theta in [0.0f32, 0.8, 1.4] {
                    let wi = Vec3A::new(theta.sin() * 0.6, theta.sin() * 0.8, theta.cos());
                    let vis =
                        stratified_sphere_integral(|m| d.pdf_visible(wi, m) as f64, 800, 400, None);
                    assert!(
                        (vis - 1.0).abs() < 5e-3,
                        "{kind:?} {au} {av} {theta}: {vis}"
                    );
                }
            }
        }
    }

    /// Walter's fit stays within 0.4% of the exact Beckmann G1.
    #[test]
    fn beckmann_fit_is_close_to_exact() {
        let d = Microfacet::new(MicrofacetKind::Beckmann, 0.4, 0.4);
        let mut rng = Rng::new(3);
        for _ in 0..1000 {
            let t = rng.f32() * 1.5;
            let v = Vec3A::new(t.sin(), 0.0, t.cos());
            let (a, b) = (d.smith_g1(v, Vec3A::Z), d.smith_g1_exact(v, Vec3A::Z));
            assert!((a - b).abs() < 4e-3, "{t}: {a} {b}");
        }
    }
}
