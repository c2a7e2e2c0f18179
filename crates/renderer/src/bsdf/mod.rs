//! BSDF models in the local shading frame (z = shading normal).
//!
//! These are torrey's own materials as the UCSD CSE 168 course defines them (handouts
//! homework3.tex: Schlick Fresnel, `mirror`, `plastic`; homework4.tex: `phong`, `blinnphong`,
//! `blinn_microfacet`). The course's ρ already includes the cosine of the light direction, so
//! [`BsdfModel::eval`] returns exactly that ρ: f(wo, wi)·cos θi.
//!
//! Naming: `wo` is the direction towards the viewer (the course's ωi), `wi` the sampled/light
//! direction (the course's ωo). Both point away from the surface.

// Comparisons are written `!(x > 0.0)` on purpose: they also reject NaN.
#![allow(clippy::neg_cmp_op_on_partial_ord)]

use crate::sampling::{
    cosine_hemisphere_pdf, cosine_power_pdf, square_to_cosine_hemisphere, square_to_cosine_power,
    Frame,
};
use glam::{Vec2, Vec3A};
use std::f32::consts::{FRAC_1_PI, PI, TAU};
use torrey_parser::scene::{BsdfKind, ColorParam};

#[cfg(test)]
mod tests;

/// A reflection model, without its (possibly textured) reflectance, which callers look up per
/// hit and pass to every method. All directions are in the local shading frame: z = shading
/// normal, both pointing away from the surface. The integrator flips the frame for two-sided
/// shading, so callers guarantee `wo.z > 0`; every method returns black / zero pdf / `None`
/// when `wo.z <= 0`, or `wi.z <= 0` (these are reflection-only models).
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum BsdfModel {
    /// Lambertian: reflectance / π.
    Diffuse,
    /// Perfect specular reflection weighted by Schlick Fresnel with F0 = reflectance.
    Mirror,
    /// White Schlick-Fresnel mirror (F0 = ((η−1)/(η+1))², F at the view angle) over a diffuse
    /// base weighted by 1 − F.
    Plastic { eta: f32 },
    /// Normalised Phong lobe around the mirror direction: ρ = R (n+1)/(2π) max(r·wi, 0)^n.
    Phong { exponent: f32 },
    /// Normalised Blinn-Phong with Schlick Fresnel at the half vector:
    /// ρ = (n+2)/(4π(2−2^(−n/2))) F(h) (n·h)^n.
    Blinn { exponent: f32 },
    /// Microfacet BRDF with a Blinn NDF, Schlick Fresnel (F0 = reflectance) and Walter et al.'s
    /// rational fit of Smith shadowing: ρ = F D G / (4 cos θo).
    BlinnMicrofacet { exponent: f32 },
}

/// One sampled scattering direction.
#[derive(Clone, Copy, Debug)]
pub struct BsdfSample {
    /// The sampled direction (local frame), above the surface.
    pub wi: Vec3A,
    /// f·|cos θi| / pdf, including the probability of the lobe choice: the path throughput
    /// multiplier. For delta lobes it is the lobe's reflectance divided by its selection
    /// probability.
    pub weight: Vec3A,
    /// Solid-angle density of `wi` (non-delta lobes, times their selection probability, exactly
    /// what [`BsdfModel::pdf`] returns); `f32::INFINITY` for a delta lobe, so that
    /// [`crate::sampling::power_heuristic`] gives such samples MIS weight 1.
    pub pdf: f32,
    /// The sample came from a delta lobe: skip light-sampling MIS, emission is taken unweighted.
    pub is_delta: bool,
}

/// Schlick's approximation of Fresnel reflectance, F0 + (1 − F0)(1 − cos θ)^5, the course's
/// choice for every model (cos θ clamped to [0, 1]).
pub fn schlick_fresnel(f0: Vec3A, cos_theta: f32) -> Vec3A {
    f0 + (Vec3A::ONE - f0) * schlick_weight(cos_theta)
}

/// (1 − cos θ)^5, the angular part of [`schlick_fresnel`], shared with the scalar (plastic) form.
fn schlick_weight(cos_theta: f32) -> f32 {
    let m = (1.0 - cos_theta).clamp(0.0, 1.0);
    let m2 = m * m;
    m2 * m2 * m
}

/// Mirror reflection of a local direction about the shading normal (+z).
fn reflect_z(w: Vec3A) -> Vec3A {
    Vec3A::new(-w.x, -w.y, w.z)
}

/// Walter et al.'s rational fit (EGSR 2007) of Smith's Beckmann G1, with the Blinn exponent
/// mapped to the equivalent Beckmann roughness α = sqrt(2/(n+2)), so a = sqrt(n/2+1)/tan θ.
/// `cos_theta` is the direction's cosine with the normal; the caller checks ω·h > 0.
fn smith_g1_walter(cos_theta: f32, exponent: f32) -> f32 {
    if cos_theta <= 0.0 {
        return 0.0;
    }
    let sin_theta = (1.0 - cos_theta * cos_theta).max(0.0).sqrt();
    // a = sqrt(n/2 + 1) cos θ / sin θ; compare a < 1.6 without dividing by a zero sine.
    let num = (0.5 * exponent + 1.0).sqrt() * cos_theta;
    if num >= 1.6 * sin_theta {
        return 1.0;
    }
    let a = num / sin_theta;
    (3.535 * a + 2.181 * a * a) / (1.0 + 2.276 * a + 2.577 * a * a)
}

/// Blinn-Phong normalisation (Gotanda 2010), as the course gives it: (n+2)/(4π(2−2^(−n/2))).
fn blinn_norm(exponent: f32) -> f32 {
    (exponent + 2.0) / (4.0 * PI * (2.0 - (-0.5 * exponent).exp2()))
}

impl BsdfModel {
    /// Converts the parser's description, returning the model and its reflectance parameter
    /// (which the renderer resolves per hit, constant or texture).
    pub fn from_kind(kind: &BsdfKind) -> (BsdfModel, &ColorParam) {
        match kind {
            BsdfKind::Diffuse { reflectance } => (BsdfModel::Diffuse, reflectance),
            BsdfKind::Mirror { reflectance } => (BsdfModel::Mirror, reflectance),
            BsdfKind::Plastic { reflectance, eta } => {
                (BsdfModel::Plastic { eta: *eta }, reflectance)
            }
            BsdfKind::Phong {
                reflectance,
                exponent,
            } => (
                BsdfModel::Phong {
                    exponent: *exponent,
                },
                reflectance,
            ),
            BsdfKind::Blinn {
                reflectance,
                exponent,
            } => (
                BsdfModel::Blinn {
                    exponent: *exponent,
                },
                reflectance,
            ),
            BsdfKind::BlinnMicrofacet {
                reflectance,
                exponent,
            } => (
                BsdfModel::BlinnMicrofacet {
                    exponent: *exponent,
                },
                reflectance,
            ),
        }
    }

    /// Plastic's scalar Fresnel at the view angle: the weight of its specular lobe and the
    /// probability with which [`BsdfModel::sample`] picks it.
    fn plastic_fresnel(eta: f32, cos_o: f32) -> f32 {
        let r = (eta - 1.0) / (eta + 1.0);
        let f0 = r * r;
        f0 + (1.0 - f0) * schlick_weight(cos_o)
    }

    /// f(wo, wi)·|cos θi| (non-delta parts only) — the course's ρ. Zero for mirror, and for
    /// either direction below the surface.
    pub fn eval(&self, reflectance: Vec3A, wo: Vec3A, wi: Vec3A) -> Vec3A {
        if !(wo.z > 0.0 && wi.z > 0.0) {
            return Vec3A::ZERO;
        }
        match *self {
            BsdfModel::Diffuse => reflectance * (FRAC_1_PI * wi.z),
            BsdfModel::Mirror => Vec3A::ZERO,
            BsdfModel::Plastic { eta } => {
                let f = Self::plastic_fresnel(eta, wo.z);
                reflectance * ((1.0 - f) * FRAC_1_PI * wi.z)
            }
            BsdfModel::Phong { exponent } => {
                let c = reflect_z(wo).dot(wi);
                if c <= 0.0 {
                    return Vec3A::ZERO;
                }
                reflectance * ((exponent + 1.0) / TAU * c.powf(exponent))
            }
            BsdfModel::Blinn { exponent } => {
                let Some(h) = (wo + wi).try_normalize() else {
                    return Vec3A::ZERO;
                };
                let fresnel = schlick_fresnel(reflectance, h.dot(wi));
                fresnel * (blinn_norm(exponent) * h.z.powf(exponent))
            }
            BsdfModel::BlinnMicrofacet { exponent } => {
                let Some(h) = (wo + wi).try_normalize() else {
                    return Vec3A::ZERO;
                };
                let d = (exponent + 2.0) / TAU * h.z.powf(exponent);
                // wo·h = wi·h > 0 for two directions above the surface, so G1's ω·h test holds.
                let g = smith_g1_walter(wo.z, exponent) * smith_g1_walter(wi.z, exponent);
                let fresnel = schlick_fresnel(reflectance, h.dot(wi));
                fresnel * (d * g / (4.0 * wo.z))
            }
        }
    }

    /// Solid-angle pdf of [`BsdfModel::sample`] producing `wi` (non-delta parts, times their
    /// selection probability). Where sampling can propose directions below the surface (phong,
    /// blinn) and rejects them, this density integrates to the acceptance rate, below one.
    pub fn pdf(&self, _reflectance: Vec3A, wo: Vec3A, wi: Vec3A) -> f32 {
        if !(wo.z > 0.0 && wi.z > 0.0) {
            return 0.0;
        }
        match *self {
            BsdfModel::Diffuse => cosine_hemisphere_pdf(wi.z),
            BsdfModel::Mirror => 0.0,
            BsdfModel::Plastic { eta } => {
                (1.0 - Self::plastic_fresnel(eta, wo.z)) * cosine_hemisphere_pdf(wi.z)
            }
            BsdfModel::Phong { exponent } => cosine_power_pdf(reflect_z(wo).dot(wi), exponent),
            BsdfModel::Blinn { exponent } | BsdfModel::BlinnMicrofacet { exponent } => {
                let Some(h) = (wo + wi).try_normalize() else {
                    return 0.0;
                };
                half_vector_pdf(h, exponent) / (4.0 * wo.dot(h))
            }
        }
    }

    /// A cosine-weighted direction, for a diffuse surface seen from above.
    #[inline(always)]
    fn sample_diffuse(reflectance: Vec3A, u: Vec2) -> Option<BsdfSample> {
        let wi = square_to_cosine_hemisphere(u);
        (wi.z > 0.0).then(|| BsdfSample {
            wi,
            weight: reflectance,
            pdf: cosine_hemisphere_pdf(wi.z),
            is_delta: false,
        })
    }

    /// [`BsdfModel::sample`] with the diffuse case inline: the common case in most scenes
    /// skips the call into the full sampler (whose size keeps it out of line).
    #[inline(always)]
    pub fn sample_inline_diffuse(
        &self,
        reflectance: Vec3A,
        wo: Vec3A,
        u: Vec2,
        u_lobe: f32,
    ) -> Option<BsdfSample> {
        if let BsdfModel::Diffuse = self {
            if !(wo.z > 0.0) {
                return None;
            }
            return Self::sample_diffuse(reflectance, u);
        }
        self.sample(reflectance, wo, u, u_lobe)
    }

    /// Samples a direction: `u` picks the direction, `u_lobe` the lobe for multi-lobe models
    /// (plastic: specular with probability F). `None` when `wo` is below the surface or the
    /// proposed direction falls below it (phong and blinn lobes can reach under the horizon).
    pub fn sample(
        &self,
        reflectance: Vec3A,
        wo: Vec3A,
        u: Vec2,
        u_lobe: f32,
    ) -> Option<BsdfSample> {
        if !(wo.z > 0.0) {
            return None;
        }
        match *self {
            BsdfModel::Diffuse => Self::sample_diffuse(reflectance, u),
            BsdfModel::Mirror => Some(BsdfSample {
                wi: reflect_z(wo),
                weight: schlick_fresnel(reflectance, wo.z),
                pdf: f32::INFINITY,
                is_delta: true,
            }),
            BsdfModel::Plastic { eta } => {
                let f = Self::plastic_fresnel(eta, wo.z);
                if u_lobe < f {
                    // Specular: value F (white), chosen with probability F.
                    Some(BsdfSample {
                        wi: reflect_z(wo),
                        weight: Vec3A::ONE,
                        pdf: f32::INFINITY,
                        is_delta: true,
                    })
                } else {
                    // Diffuse: (1 − F) R cos/π over (1 − F) cos/π.
                    let wi = square_to_cosine_hemisphere(u);
                    (wi.z > 0.0).then(|| BsdfSample {
                        wi,
                        weight: reflectance,
                        pdf: (1.0 - f) * cosine_hemisphere_pdf(wi.z),
                        is_delta: false,
                    })
                }
            }
            BsdfModel::Phong { exponent } => {
                let r = reflect_z(wo);
                let local = square_to_cosine_power(u, exponent);
                let wi = Frame::from_normal(r).to_world(local);
                let pdf = cosine_power_pdf(local.z, exponent);
                // ρ / pdf = R exactly: the lobe is sampled perfectly, only the horizon rejects.
                (wi.z > 0.0 && pdf > 0.0).then_some(BsdfSample {
                    wi,
                    weight: reflectance,
                    pdf,
                    is_delta: false,
                })
            }
            BsdfModel::Blinn { exponent } | BsdfModel::BlinnMicrofacet { exponent } => {
                let h = square_to_cosine_power(u, exponent);
                let wo_h = wo.dot(h);
                if wo_h <= 0.0 {
                    return None;
                }
                let wi = (2.0 * wo_h) * h - wo;
                let pdf = half_vector_pdf(h, exponent) / (4.0 * wo_h);
                if wi.z <= 0.0 || !(pdf > 0.0) {
                    return None;
                }
                let fresnel = schlick_fresnel(reflectance, wo_h);
                let weight = if let BsdfModel::Blinn { .. } = self {
                    // ρ / pdf with the (n·h)^n factors cancelled.
                    fresnel * (blinn_norm(exponent) * TAU / (exponent + 1.0) * 4.0 * wo_h)
                } else {
                    // F D G / (4 cos θo) over (n+1)/(2π) (n·h)^n / (4 wo·h).
                    let g = smith_g1_walter(wo.z, exponent) * smith_g1_walter(wi.z, exponent);
                    fresnel * ((exponent + 2.0) / (exponent + 1.0) * g * wo_h / wo.z)
                };
                Some(BsdfSample {
                    wi,
                    weight,
                    pdf,
                    is_delta: false,
                })
            }
        }
    }

    /// True when the model has only delta lobes (mirror): light sampling cannot contribute.
    pub fn is_delta(&self) -> bool {
        matches!(self, BsdfModel::Mirror)
    }

    /// True when it has any delta lobe (mirror, plastic): some samples come back with
    /// `is_delta` and need the delta treatment in MIS.
    pub fn has_delta(&self) -> bool {
        matches!(self, BsdfModel::Mirror | BsdfModel::Plastic { .. })
    }

    /// A rough measure of the angular width (radians, at most 1) of the widest non-delta lobe,
    /// for growing ray-cone spread: 0 for a mirror, 1 for diffuse and plastic's diffuse base,
    /// about sqrt(2/(n+2)) (the lobe's standard deviation) for phong and twice that for the
    /// half-vector lobes, whose reflected directions spread twice as wide. Callers should use 0
    /// for a sample with `is_delta` set.
    pub fn roughness(&self) -> f32 {
        match *self {
            BsdfModel::Diffuse | BsdfModel::Plastic { .. } => 1.0,
            BsdfModel::Mirror => 0.0,
            BsdfModel::Phong { exponent } => (2.0 / (exponent.max(0.0) + 2.0)).sqrt().min(1.0),
            BsdfModel::Blinn { exponent } | BsdfModel::BlinnMicrofacet { exponent } => {
                (2.0 * (2.0 / (exponent.max(0.0) + 2.0)).sqrt()).min(1.0)
            }
        }
    }
}

/// Density of the half vector h ∝ (n·h)^n that blinn and blinn_microfacet sample, as the course
/// prescribes (it reuses the Blinn-Phong sampler for the microfacet model): (n+1)/(2π) (n·h)^n.
fn half_vector_pdf(h: Vec3A, exponent: f32) -> f32 {
    cosine_power_pdf(h.z, exponent)
}
