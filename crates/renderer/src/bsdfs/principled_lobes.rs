//! Pieces shared by Mitsuba 3's `principled` and `principledthin` (its principledhelpers.h):
//! the Disney roughness mapping, Schlick Fresnel as Mitsuba applies it (with the transmitted
//! angle when η < 1), the tinted Fresnel blends, the macro/micro-surface side test, the
//! clearcoat's GTR1 distribution and separable GGX shadowing, and the diffuse/retro-reflection/
//! fake-subsurface/sheen lobe. Mitsuba's formulas are kept as written (for example the
//! clearcoat's missing 1/(4 cos θi cos θo)), because the renders are judged against its pixels.

use super::fresnel::schlick_weight;
use glam::Vec3A;
use std::f32::consts::{FRAC_1_PI, PI};
use torrey_fastmath::{ln, powf, sin_cos_2pi};

/// Luminance of a linear sRGB colour (Mitsuba's `luminance` in its RGB variants).
#[inline]
pub fn luminance(c: Vec3A) -> f32 {
    0.212671 * c.x + 0.715160 * c.y + 0.072169 * c.z
}

/// The colour normalised by its luminance (white when the luminance is 0): the hue a tint
/// blends towards.
#[inline]
pub fn tint_color(c: Vec3A) -> Vec3A {
    let lum = luminance(c);
    if lum > 0.0 {
        c / lum
    } else {
        Vec3A::ONE
    }
}

/// GGX roughness (α_u, α_v) from Disney's roughness and anisotropy (`calc_dist_params`):
/// α = roughness², stretched by √(1 − 0.9 anisotropic), at least 0.001.
#[inline]
pub fn disney_alphas(anisotropic: f32, roughness: f32) -> (f32, f32) {
    let r2 = roughness * roughness;
    let aspect = (1.0 - 0.9 * anisotropic).sqrt();
    ((r2 / aspect).max(0.001), (r2 * aspect).max(0.001))
}

/// ((η − 1) / (η + 1))², Schlick's reflectance at normal incidence.
#[inline]
pub fn schlick_r0(eta: f32) -> f32 {
    let r = (eta - 1.0) / (eta + 1.0);
    r * r
}

/// Schlick's Fresnel with reflectance `r0` at normal incidence, as Mitsuba's `calc_schlick`:
/// `cos_i` is the cosine with the microfacet normal (negative: from inside), `eta` the
/// interior/exterior ratio; when the relative IOR seen from `cos_i`'s side is below 1 the angle
/// of the transmitted ray is used.
#[inline]
pub fn schlick_eta(r0: Vec3A, cos_i: f32, eta: f32) -> Vec3A {
    let (eta_it, eta_ti) = if cos_i >= 0.0 {
        (eta, 1.0 / eta)
    } else {
        (1.0 / eta, eta)
    };
    let w = if eta_it > 1.0 {
        schlick_weight(cos_i.abs())
    } else {
        let cos_t2 = 1.0 - (1.0 - cos_i * cos_i) * eta_ti * eta_ti;
        schlick_weight(cos_t2.max(0.0).sqrt())
    };
    r0 + (Vec3A::ONE - r0) * w
}

/// Whether `wi` and `wo` are on the sides of the microfacet `m` that a reflection
/// (`reflection`) or a refraction requires, `m` taken on `wi`'s side of the macro-surface
/// (Mitsuba's `mac_mic_compatibility`; `cos_i` is wi's cosine with the macro normal).
#[inline]
pub fn mac_mic_compatible(m: Vec3A, wi: Vec3A, wo: Vec3A, cos_i: f32, reflection: bool) -> bool {
    let m = if cos_i < 0.0 { -m } else { m };
    let o = wo.dot(m);
    wi.dot(m) > 0.0 && if reflection { o > 0.0 } else { o < 0.0 }
}

/// Mirror reflection of `w` about `m`.
#[inline]
pub fn reflect(w: Vec3A, m: Vec3A) -> Vec3A {
    m * (2.0 * w.dot(m)) - w
}

/// Burley's GTR1 distribution (isotropic, γ = 1) of the clearcoat lobe, sampled in proportion
/// to D(m) cos θm.
#[derive(Clone, Copy, Debug)]
pub struct Gtr1 {
    alpha: f32,
}

impl Gtr1 {
    /// The clearcoat's distribution: α from 0.1 (gloss 0) to 0.001 (gloss 1).
    #[inline]
    pub fn clearcoat(gloss: f32) -> Self {
        Self {
            alpha: 0.1 + gloss * (0.001 - 0.1),
        }
    }

    #[inline]
    pub fn d(&self, m: Vec3A) -> f32 {
        let a2 = self.alpha * self.alpha;
        let c2 = m.z * m.z;
        let v = (a2 - 1.0) / (PI * ln(a2) * (1.0 + (a2 - 1.0) * c2));
        if v * m.z > 1e-20 {
            v
        } else {
            0.0
        }
    }

    /// Density of [`Gtr1::sample`] per solid angle of m: D(m) cos θm.
    #[inline]
    pub fn pdf(&self, m: Vec3A) -> f32 {
        if m.z < 0.0 {
            0.0
        } else {
            m.z * self.d(m)
        }
    }

    #[inline]
    pub fn sample(&self, u: glam::Vec2) -> Vec3A {
        let (sin_phi, cos_phi) = sin_cos_2pi(u.x);
        let a2 = self.alpha * self.alpha;
        let cos2 = (1.0 - powf(a2, 1.0 - u.y)) / (1.0 - a2);
        let sin_t = (1.0 - cos2).max(0.0).sqrt();
        let cos_t = cos2.max(0.0).sqrt();
        Vec3A::new(cos_phi * sin_t, sin_phi * sin_t, cos_t)
    }
}

/// Smith's G1 of an isotropic GGX of roughness `alpha` (`smith_ggx1`), zero when `v` sees the
/// back of `m`.
#[inline]
fn smith_ggx1(v: Vec3A, m: Vec3A, alpha: f32) -> f32 {
    if v.dot(m) * v.z <= 0.0 {
        return 0.0;
    }
    if v.z == 1.0 {
        return 1.0;
    }
    let c2 = v.z * v.z;
    let t2 = (1.0 - c2) / c2;
    2.0 / (1.0 + (1.0 + alpha * alpha * t2).sqrt())
}

/// The clearcoat's separable shadowing-masking (`clearcoat_G`, α = 0.25).
#[inline]
pub fn clearcoat_g(wi: Vec3A, wo: Vec3A, m: Vec3A) -> f32 {
    smith_ggx1(wi, m, 0.25) * smith_ggx1(wo, m, 0.25)
}

/// The clearcoat lobe's f·|cos θo|: Mitsuba's 0.25·clearcoat·F_schlick(0.04)·D·G·|cos θo|.
#[inline]
pub fn clearcoat_eval(
    clearcoat: f32,
    gloss: f32,
    eta: f32,
    wi: Vec3A,
    wo: Vec3A,
    wh: Vec3A,
) -> f32 {
    let f = schlick_eta(Vec3A::splat(0.04), wi.dot(wh), eta).x;
    let d = Gtr1::clearcoat(gloss).d(wh);
    0.25 * clearcoat * f * d * clearcoat_g(wi, wo, wh) * wo.z.abs()
}

/// Parameters of the diffuse-side lobes (both models).
#[derive(Clone, Copy, Debug)]
pub struct DiffuseLobes {
    pub base_color: Vec3A,
    pub roughness: f32,
    pub flatness: f32,
    pub sheen: f32,
    pub sheen_tint: f32,
}

impl DiffuseLobes {
    /// Burley's diffuse with retro-reflection, blended by `flatness` into the Hanrahan-Krueger
    /// fake subsurface, times |cos θo|/π (without the model's weight), and the sheen lobe's
    /// f·|cos θo| (without the model's weight). `cos_d` is the half vector's cosine with `wo`.
    #[inline]
    pub fn eval(&self, cos_i: f32, cos_o: f32, cos_d: f32) -> (Vec3A, Vec3A) {
        let (ci, co) = (cos_i.abs(), cos_o.abs());
        let fo = schlick_weight(co);
        let fi = schlick_weight(ci);
        let f_diff = (1.0 - 0.5 * fi) * (1.0 - 0.5 * fo);
        let rr = 2.0 * self.roughness * cos_d * cos_d;
        let f_retro = rr * (fo + fi + fo * fi * (rr - 1.0));
        let mut shape = f_diff + f_retro;
        if self.flatness != 0.0 {
            let fss90 = 0.5 * rr;
            let fss = (1.0 + (fss90 - 1.0) * fo) * (1.0 + (fss90 - 1.0) * fi);
            let f_ss = 1.25 * (fss * (1.0 / (co + ci) - 0.5) + 0.5);
            shape += (f_ss - shape) * self.flatness;
        }
        let diffuse = self.base_color * (co * FRAC_1_PI * shape);
        let sheen = if self.sheen > 0.0 {
            let fd = schlick_weight(cos_d.abs());
            let tint = Vec3A::ONE + (tint_color(self.base_color) - Vec3A::ONE) * self.sheen_tint;
            tint * (self.sheen * fd * co)
        } else {
            Vec3A::ZERO
        };
        (diffuse, sheen)
    }
}

/// Density of cosine-weighted hemisphere sampling about +z (0 below).
#[inline]
pub fn cosine_pdf(w: Vec3A) -> f32 {
    w.z.max(0.0) * FRAC_1_PI
}
