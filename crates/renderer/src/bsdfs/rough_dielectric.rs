//! Mitsuba's `roughdielectric`: Walter et al.'s microfacet model of a rough interface between
//! two dielectrics (reflection and refraction on both sides), exact Fresnel, Smith shadowing,
//! visible-normal (or, with `sample_visible = false`, whole-distribution) sampling from the side
//! of `wo`.

use super::fresnel::{fresnel_dielectric, refract};
use super::microfacet::{Microfacet, MicrofacetKind};
use super::{BsdfFlags, BsdfSample};
use crate::textures::{ColorSource, FloatSource, TextureQuery};
use glam::{Vec2, Vec3A};

/// The material's parameters.
#[derive(Clone, Copy, Debug)]
pub struct RoughDielectricParams {
    pub kind: MicrofacetKind,
    pub alpha_u: FloatSource,
    pub alpha_v: FloatSource,
    /// Mitsuba's `sample_visible`: sample visible normals (true) or D(m) cos θm.
    pub sample_visible: bool,
    pub eta: f32,
    pub specular_reflectance: ColorSource,
    pub specular_transmittance: ColorSource,
}

impl RoughDielectricParams {
    #[inline(always)]
    pub fn resolve(&self, q: &TextureQuery) -> RoughDielectric {
        RoughDielectric {
            distr: Microfacet::new(self.kind, q.float(self.alpha_u), q.float(self.alpha_v))
                .with_visible(self.sample_visible),
            eta: self.eta,
            specular_reflectance: q.color(self.specular_reflectance),
            specular_transmittance: q.color(self.specular_transmittance),
        }
    }

    pub fn is_textured(&self) -> bool {
        self.alpha_u.is_textured()
            || self.alpha_v.is_textured()
            || self.specular_reflectance.is_textured()
            || self.specular_transmittance.is_textured()
    }
}

/// A rough dielectric at a hit; the normal points to the outside.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct RoughDielectric {
    pub distr: Microfacet,
    pub eta: f32,
    pub specular_reflectance: Vec3A,
    pub specular_transmittance: Vec3A,
}

/// The half vector of a pair of directions, in the +z hemisphere, and the relative IOR η_t/η_i
/// seen from `wo`'s side; None for grazing or degenerate pairs.
#[inline]
fn half_vector(eta: f32, wo: Vec3A, wi: Vec3A) -> Option<(Vec3A, bool, f32)> {
    let reflect = wo.z * wi.z > 0.0;
    let eta_o = if wo.z > 0.0 { eta } else { 1.0 / eta };
    let h = if reflect { wo + wi } else { wo + wi * eta_o };
    let len = h.length();
    if !(len > 1e-8) || wo.z == 0.0 || wi.z == 0.0 {
        return None;
    }
    let m = h / len;
    let m = if m.z < 0.0 { -m } else { m };
    // Neither direction may see the back of the microfacet.
    if !(wo.dot(m) * wo.z > 0.0 && wi.dot(m) * wi.z > 0.0) {
        return None;
    }
    Some((m, reflect, eta_o))
}

impl RoughDielectric {
    pub const FLAGS: BsdfFlags = BsdfFlags::GLOSSY_REFLECTION.union(BsdfFlags::GLOSSY_TRANSMISSION);

    /// f·|cos θi|: F D G / (4 |cos θo|) for reflection; for refraction
    /// (1 − F) D G η² |wo·m| |wi·m| / (|cos θo| (wo·m + η wi·m)²), scaled by 1/η² for radiance.
    #[inline]
    pub fn eval(&self, wo: Vec3A, wi: Vec3A) -> Vec3A {
        let Some((m, reflect, eta_o)) = half_vector(self.eta, wo, wi) else {
            return Vec3A::ZERO;
        };
        let d = self.distr.d(m);
        let f = fresnel_dielectric(wo.dot(m), self.eta).0;
        self.eval_at(wo, wi, m, reflect, eta_o, d, f)
    }

    /// [`RoughDielectric::eval`] at the half vector `m` (of [`half_vector`]) with D(m) = `d` and
    /// F(wo·m) = `f`.
    #[allow(clippy::too_many_arguments)]
    #[inline(always)]
    fn eval_at(
        &self,
        wo: Vec3A,
        wi: Vec3A,
        m: Vec3A,
        reflect: bool,
        eta_o: f32,
        d: f32,
        f: f32,
    ) -> Vec3A {
        if d == 0.0 {
            return Vec3A::ZERO;
        }
        let g = self.distr.g(wo, wi, m);
        if reflect {
            self.specular_reflectance * (f * d * g / (4.0 * wo.z.abs()))
        } else {
            let (om, im) = (wo.dot(m), wi.dot(m));
            let denom = om + eta_o * im;
            let v = (1.0 - f) * d * g * eta_o * eta_o * om * im / (wo.z * denom * denom);
            self.specular_transmittance * (v.abs() / (eta_o * eta_o))
        }
    }

    #[inline]
    pub fn pdf(&self, wo: Vec3A, wi: Vec3A) -> f32 {
        let Some((m, reflect, eta_o)) = half_vector(self.eta, wo, wi) else {
            return 0.0;
        };
        let wo_up = if wo.z < 0.0 { -wo } else { wo };
        let f = fresnel_dielectric(wo.dot(m), self.eta).0;
        self.pdf_at(wo, wi, m, reflect, eta_o, self.distr.pdf(wo_up, m), f)
    }

    /// [`RoughDielectric::pdf`] at the half vector `m` with the density of m `pm` and F(wo·m) =
    /// `f`.
    #[allow(clippy::too_many_arguments)]
    #[inline(always)]
    fn pdf_at(
        &self,
        wo: Vec3A,
        wi: Vec3A,
        m: Vec3A,
        reflect: bool,
        eta_o: f32,
        pm: f32,
        f: f32,
    ) -> f32 {
        let (om, im) = (wo.dot(m), wi.dot(m));
        let jacobian = if reflect {
            1.0 / (4.0 * im)
        } else {
            let denom = om + eta_o * im;
            eta_o * eta_o * im / (denom * denom)
        };
        let p = pm * if reflect { f } else { 1.0 - f };
        (p * jacobian).abs()
    }

    /// [`RoughDielectric::eval`] and [`RoughDielectric::pdf`] together, sharing the half
    /// vector, D and F: what `sample` weighs with (the same bits as the two calls).
    #[inline]
    pub fn eval_pdf(&self, wo: Vec3A, wi: Vec3A) -> (Vec3A, f32) {
        let Some((m, reflect, eta_o)) = half_vector(self.eta, wo, wi) else {
            return (Vec3A::ZERO, 0.0);
        };
        let d = self.distr.d(m);
        let f = fresnel_dielectric(wo.dot(m), self.eta).0;
        let wo_up = if wo.z < 0.0 { -wo } else { wo };
        let pm = self.distr.pdf_given_d(wo_up, m, d);
        (
            self.eval_at(wo, wi, m, reflect, eta_o, d, f),
            self.pdf_at(wo, wi, m, reflect, eta_o, pm, f),
        )
    }

    /// A normal (visible from wo's side unless `sample_visible` is false), then reflection with probability F, else refraction.
    #[inline]
    pub fn sample(&self, wo: Vec3A, u: Vec2, u_lobe: f32) -> Option<BsdfSample> {
        if wo.z == 0.0 || !wo.z.is_finite() {
            return None;
        }
        let wo_up = if wo.z < 0.0 { -wo } else { wo };
        let m = self.distr.sample(wo_up, u);
        if !(wo_up.dot(m) > 0.0) {
            // Only with sample_visible = false: a normal facing away from wo, whose refraction
            // would land where the pdf counts another normal.
            return None;
        }
        let (f, cos_t, eta_it, eta_ti) = fresnel_dielectric(wo.dot(m), self.eta);
        let (wi, eta, lobe) = if u_lobe <= f {
            let wi = m * (2.0 * wo.dot(m)) - wo;
            if !(wi.z * wo.z > 0.0) {
                return None;
            }
            (wi, 1.0, BsdfFlags::GLOSSY_REFLECTION)
        } else {
            let wi = refract(wo, m, cos_t, eta_ti);
            if !(wi.z * wo.z < 0.0) {
                return None;
            }
            (wi, eta_it, BsdfFlags::GLOSSY_TRANSMISSION)
        };
        let wi = wi.normalize();
        let (value, pdf) = self.eval_pdf(wo, wi);
        if !(pdf > 0.0) {
            return None;
        }
        Some(BsdfSample {
            wi,
            weight: value / pdf,
            pdf,
            eta,
            lobe,
        })
    }

    pub fn roughness(&self) -> f32 {
        self.distr.alpha_u.max(self.distr.alpha_v).min(1.0)
    }
}
