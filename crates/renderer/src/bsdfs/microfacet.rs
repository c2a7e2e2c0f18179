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
use torrey_fastmath::{acos, erf, erfinv, exp, ln, powf, sin_cos_2pi};

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

    /// [`Microfacet::pdf`] given `d` = [`Microfacet::d`]`(m)`, for callers that need D as well
    /// (a BSDF's `sample` weighs its value by its pdf): the same operations, the same bits.
    #[inline]
    pub fn pdf_given_d(&self, wi: Vec3A, m: Vec3A, d: f32) -> f32 {
        if self.visible {
            let c = wi.dot(m);
            if !(wi.z > 0.0 && c > 0.0) {
                return 0.0;
            }
            d * self.smith_g1_exact(wi, m) * c / wi.z
        } else {
            d * m.z.max(0.0)
        }
    }

    /// A normal drawn from D(m) cos θm: the slopes of the distribution stretched to α = 1 are
    /// isotropic (Beckmann: a unit Gaussian, r² = −ln(1 − u); GGX: r² = u / (1 − u)), so draw
    /// their length and azimuth and stretch back by (α_u, α_v). The density of m is then the
    /// slope density P22 over cos³θm, which is D(m) cos θm.
    #[inline]
    pub fn sample_all(&self, u: Vec2) -> Vec3A {
        let r2 = match self.kind {
            MicrofacetKind::Beckmann => -ln((1.0 - u.x).max(1e-12)),
            MicrofacetKind::Ggx => u.x / (1.0 - u.x).max(1e-12),
        };
        let r = r2.sqrt();
        let (s, c) = sin_cos_2pi(u.y);
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
            MicrofacetKind::Beckmann => exp(-r / c2) / (PI * ax * ay * c2 * c2),
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
                // a = 1 / sqrt(t2) >= 3.5: Λ < 1.6e-8, and 1 / (1 + Λ) rounds to 1 in f32.
                if t2 <= 1.0 / 12.25 {
                    return 1.0;
                }
                let a = 1.0 / t2.sqrt();
                let lambda = 0.5 * (erf(a) - 1.0) + exp(-a * a) / (2.0 * a * PI.sqrt());
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
        let (s_phi, c_phi) = sin_cos_2pi(u.y);
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
        let frame = BeckmannStretch::new(self, wi);
        let (sx, sy) = beckmann_sample11(frame.cos_t, u.x, u.y);
        frame.normal(self, sx, sy)
    }

    /// `f(i, j, m)` for the normal m = [`Microfacet::sample_visible`]`(wi, (us[i], us[j]))` of
    /// every point of the grid `us` × `us`, the same bits as those calls. For Beckmann away from
    /// normal incidence the x slope depends on u.x alone and the y slope on u.y alone, so each is
    /// inverted once per grid line instead of once per point: what makes the rough plastic's
    /// coating tables cheap to build.
    pub fn visible_normals_grid(
        &self,
        wi: Vec3A,
        us: &[f32],
        mut f: impl FnMut(usize, usize, Vec3A),
    ) {
        let frame = BeckmannStretch::new(self, wi);
        if self.kind == MicrofacetKind::Ggx || frame.cos_t > BECKMANN_NORMAL_INCIDENCE {
            for (i, &ux) in us.iter().enumerate() {
                for (j, &uy) in us.iter().enumerate() {
                    f(i, j, self.sample_visible(wi, Vec2::new(ux, uy)));
                }
            }
            return;
        }
        let sx: Vec<f32> = us
            .iter()
            .map(|&u| beckmann_slope_x(frame.cos_t, u))
            .collect();
        let sy: Vec<f32> = us.iter().map(|&u| beckmann_slope_y(u)).collect();
        for (i, &x) in sx.iter().enumerate() {
            for (j, &y) in sy.iter().enumerate() {
                f(i, j, frame.normal(self, x, y));
            }
        }
    }
}

/// A direction stretched to the α = 1 Beckmann configuration: its cosine and azimuth.
struct BeckmannStretch {
    cos_t: f32,
    cos_phi: f32,
    sin_phi: f32,
}

impl BeckmannStretch {
    #[inline(always)]
    fn new(distr: &Microfacet, wi: Vec3A) -> Self {
        let (ax, ay) = (distr.alpha_u, distr.alpha_v);
        let ws = Vec3A::new(ax * wi.x, ay * wi.y, wi.z).normalize();
        let sin_t = (1.0 - ws.z * ws.z).max(0.0).sqrt();
        let (cos_phi, sin_phi) = if sin_t > 1e-7 {
            (ws.x / sin_t, ws.y / sin_t)
        } else {
            (1.0, 0.0)
        };
        Self {
            cos_t: ws.z,
            cos_phi,
            sin_phi,
        }
    }

    /// The normal of the α = 1 slopes (sx, sy): rotated to the direction's azimuth and
    /// unstretched.
    #[inline(always)]
    fn normal(&self, distr: &Microfacet, sx: f32, sy: f32) -> Vec3A {
        let (c, s) = (self.cos_phi, self.sin_phi);
        let (sx, sy) = (c * sx - s * sy, s * sx + c * sy);
        Vec3A::new(-sx * distr.alpha_u, -sy * distr.alpha_v, 1.0).normalize()
    }
}

/// Above this stretched cosine [`beckmann_sample11`] samples the slopes of normal incidence.
const BECKMANN_NORMAL_INCIDENCE: f32 = 0.9999;

/// At most this many Newton steps in [`beckmann_slope_x`] (the old loop allowed 16): from the
/// initial guess, three leave the CDF within 4e-9 of its target at every angle, two within
/// 2.3e-6 at grazing ones; near-normal incidence needs one or none.
const BECKMANN_NEWTON_STEPS: usize = 4;
/// The CDF residual at which [`beckmann_slope_x`] stops (the old loop's): a few times the f32
/// rounding of the residual itself. Quadratic convergence puts the step after a miss far below.
const BECKMANN_NEWTON_TOLERANCE: f32 = 1e-6;

/// Slopes of the α = 1 Beckmann normals visible from a direction with cosine `cos_t` in the
/// xz plane (Heitz and d'Eon 2014): at normal incidence the Gaussian itself (polar), otherwise
/// [`beckmann_slope_x`] and [`beckmann_slope_y`].
fn beckmann_sample11(cos_t: f32, u1: f32, u2: f32) -> (f32, f32) {
    if cos_t > BECKMANN_NORMAL_INCIDENCE {
        let r = (-ln((1.0 - u1).max(1e-12))).sqrt();
        let (s, c) = sin_cos_2pi(u2);
        return (r * c, r * s);
    }
    (beckmann_slope_x(cos_t, u1), beckmann_slope_y(u2))
}

/// The y slope of the visible α = 1 Beckmann normals: a unit Gaussian (by inverse erf).
#[inline(always)]
fn beckmann_slope_y(u2: f32) -> f32 {
    erfinv(2.0 * u2.clamp(1e-6, 1.0 - 1e-6) - 1.0)
}

/// The x slope of the α = 1 Beckmann normals visible from a direction with cosine `cos_t` in
/// the xz plane. It inverts its CDF, written over b = erf(slope) on [-1, erf(cot θ)], by Newton
/// steps (kept inside the bracket that each step's sign narrows) from Heitz's fitted initial
/// guess, stopping once the residual is below the tolerance: the slope is then the erfinv that
/// step computed. Every libm call is [`torrey_fastmath`]'s f32 function.
fn beckmann_slope_x(cos_t: f32, u1: f32) -> f32 {
    const INV_SQRT_PI: f32 = 0.564_189_6;
    let sin_t = (1.0 - cos_t * cos_t).max(0.0).sqrt();
    let tan_t = sin_t / cos_t;
    let cot_t = 1.0 / tan_t;
    let (mut a, mut c) = (-1.0f32, erf(cot_t));
    let x = u1.max(1e-6);
    let theta = acos(cos_t);
    let fit = 1.0 + theta * (-0.876 + theta * (0.4265 - 0.0594 * theta));
    let mut b = c - (1.0 + c) * powf(1.0 - x, fit);
    let norm = 1.0 / (1.0 + c + INV_SQRT_PI * tan_t * exp(-cot_t * cot_t));
    for _ in 0..BECKMANN_NEWTON_STEPS {
        if !(b >= a && b <= c) {
            b = 0.5 * (a + c);
        }
        let inv = erfinv(b);
        let value = norm * (1.0 + b + INV_SQRT_PI * tan_t * exp(-inv * inv)) - x;
        if value.abs() < BECKMANN_NEWTON_TOLERANCE {
            return inv;
        }
        let derivative = norm * (1.0 - inv * tan_t);
        if value > 0.0 {
            c = b;
        } else {
            a = b;
        }
        b -= value / derivative;
    }
    if !(b >= a && b <= c) {
        b = 0.5 * (a + c);
    }
    erfinv(b)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::sampling::testutil::{stratified_sphere_integral, Rng};

    /// The grid of normals is exactly what `sample_visible` gives point by point.
    #[test]
    fn visible_normals_grid_matches_sample_visible() {
        let us: Vec<f32> = (0..13).map(|i| (i as f32 + 0.3) / 13.0).collect();
        for kind in [MicrofacetKind::Beckmann, MicrofacetKind::Ggx] {
            for (au, av) in [(0.005, 0.005), (0.3, 0.3), (0.5, 0.15)] {
                let d = Microfacet::new(kind, au, av);
                for wi in [
                    Vec3A::Z,
                    Vec3A::new(0.6, 0.0, 0.8),
                    Vec3A::new(0.3, -0.4, 0.1).normalize(),
                    Vec3A::new(0.999, 0.0, 0.02).normalize(),
                ] {
                    let mut count = 0;
                    d.visible_normals_grid(wi, &us, |i, j, m| {
                        let want = d.sample_visible(wi, Vec2::new(us[i], us[j]));
                        assert_eq!(
                            m.to_array().map(f32::to_bits),
                            want.to_array().map(f32::to_bits)
                        );
                        count += 1;
                    });
                    assert_eq!(count, us.len() * us.len());
                }
            }
        }
    }

    extern "C" {
        /// The C library's double-precision erf: the reference.
        #[link_name = "erf"]
        fn libm_erf(x: f64) -> f64;
    }

    fn erf64(x: f64) -> f64 {
        // SAFETY: a pure C function of one double, linked with std's libm on every unix target.
        unsafe { libm_erf(x) }
    }

    /// The x slope's CDF at the sampled slope is the random number it was drawn with: the fixed
    /// Newton steps converge from the initial guess over the whole square, at every angle (the
    /// residual evaluated in f64 at the f32 slope, less what the slope's own f32 rounding and
    /// erfinv's error account for).
    /// (Two steps at most leave 2e-6 beyond it; no early stop, 2e-7.)
    #[test]
    fn beckmann_sampling_converges() {
        let mut worst = 0.0f64;
        for i in 0..=200 {
            let cos_t = 0.005 + 0.99 * i as f32 / 200.0;
            let (ct, st) = (cos_t as f64, (1.0 - (cos_t as f64).powi(2)).sqrt());
            let (tan, cot) = (st / ct, ct / st);
            let c = erf64(cot);
            let norm = 1.0 / (1.0 + c + tan * (-cot * cot).exp() / std::f64::consts::PI.sqrt());
            let tails = [1e-5f32, 1e-4, 1e-3, 0.999, 0.9999];
            for u in (0..=50).map(|j| j as f32 / 50.0).chain(tails) {
                let u = u.clamp(1e-6, 1.0 - 1e-6);
                let (sx, _) = beckmann_sample11(cos_t, u, 0.5);
                let sx = sx as f64;
                let cdf =
                    norm * (1.0 + erf64(sx) + tan * (-sx * sx).exp() / std::f64::consts::PI.sqrt());
                // The slope's own f32 rounding, in CDF units.
                let density =
                    norm * (1.0 - sx * tan) * 2.0 / std::f64::consts::PI.sqrt() * (-sx * sx).exp();
                // erfinv's relative 5e-7 and b's own rounding.
                let slack = density * (sx.abs() * 5e-7 + 1e-7);
                worst = worst.max((cdf - u as f64).abs() - slack);
            }
        }
        println!("worst CDF residual beyond f32 rounding: {worst:e}");
        // The tolerance, plus the f32 rounding of the residual the sampler computes.
        assert!(worst <= 1.5e-6, "CDF residual {worst:e}");
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
