//! Mitsuba 3's `principled`: Burley's Disney BSDF (2012, 2015) as Mitsuba implements it
//! (src/bsdfs/principled.cpp). Lobes, weighted by metallic m and spec_trans t:
//! - a diffuse base (Burley's diffuse with retro-reflection, blended by `flatness` into a fake
//!   subsurface lobe) weighted (1 − m)(1 − t), and sheen weighted (1 − m), front side only;
//! - an anisotropic GGX specular reflection on both sides whose Fresnel blends the exact
//!   dielectric Fresnel, a Schlick metal tinted by `base_color` and a Schlick `spec_tint`
//!   (from inside: (1 − m) t times the exact Fresnel);
//! - a GGX rough refraction weighted (1 − m) t and tinted by √base_color (both sides);
//! - a clearcoat (GTR1, Schlick F0 0.04, separable GGX α 0.25 shadowing), front side only.
//!
//! Sampling picks a lobe with Mitsuba's probabilities (the rates times the lobe weights; the
//! specular ones split by the exact Fresnel of the sampled visible normal), and `pdf` is the
//! matching mixture. The back side is black unless the material transmits.
//!
//! Directions: `wo` here is Mitsuba's `si.wi` (towards the viewer), `wi` its sampled `wo`.
//! `eval`/`pdf`/`sample` are not inlined: the path loop's `Bsdf` match stays as small as it was.

use super::fresnel::{fresnel_dielectric, refract};
use super::microfacet::{Microfacet, MicrofacetKind};
use super::principled_lobes::{
    clearcoat_eval, cosine_pdf, disney_alphas, mac_mic_compatible, reflect, schlick_eta,
    schlick_r0, tint_color, DiffuseLobes, Gtr1,
};
use super::{BsdfFlags, BsdfSample};
use crate::sampling::square_to_cosine_hemisphere;
use crate::textures::{ColorSource, FloatSource, TextureQuery};
use glam::{Vec2, Vec3A};

/// The material's parameters (Mitsuba's names; every float but `eta` and the sampling rates
/// may be a texture).
#[derive(Clone, Copy, Debug)]
pub struct PrincipledParams {
    pub base_color: ColorSource,
    pub roughness: FloatSource,
    pub anisotropic: FloatSource,
    pub metallic: FloatSource,
    pub spec_trans: FloatSource,
    pub spec_tint: FloatSource,
    pub sheen: FloatSource,
    pub sheen_tint: FloatSource,
    pub flatness: FloatSource,
    pub clearcoat: FloatSource,
    pub clearcoat_gloss: FloatSource,
    /// Interior/exterior IOR (from `eta`, or from `specular` s as 2 / (1 − √(0.08 s)) − 1).
    pub eta: f32,
    pub main_specular_sampling_rate: f32,
    pub clearcoat_sampling_rate: f32,
    pub diffuse_reflectance_sampling_rate: f32,
}

impl PrincipledParams {
    #[inline]
    pub fn resolve<'a>(&'a self, q: &TextureQuery) -> Principled<'a> {
        Principled {
            base_color: q.color(self.base_color),
            p: self,
            roughness: q.float(self.roughness),
            anisotropic: q.float(self.anisotropic),
            metallic: q.float(self.metallic),
            spec_trans: q.float(self.spec_trans),
            spec_tint: q.float(self.spec_tint),
            sheen: q.float(self.sheen),
            sheen_tint: q.float(self.sheen_tint),
            flatness: q.float(self.flatness),
            clearcoat: q.float(self.clearcoat),
            clearcoat_gloss: q.float(self.clearcoat_gloss),
        }
    }

    pub fn is_textured(&self) -> bool {
        self.base_color.is_textured()
            || [
                self.roughness,
                self.anisotropic,
                self.metallic,
                self.spec_trans,
                self.spec_tint,
                self.sheen,
                self.sheen_tint,
                self.flatness,
                self.clearcoat,
                self.clearcoat_gloss,
            ]
            .iter()
            .any(|f| f.is_textured())
    }

    /// Whether some hit may refract (spec_trans given and not 0).
    pub fn transmits(&self) -> bool {
        !matches!(self.spec_trans, FloatSource::Constant(t) if t == 0.0)
    }

    pub fn anisotropic(&self) -> bool {
        !matches!(self.anisotropic, FloatSource::Constant(a) if a == 0.0)
    }
}

/// A principled material at a hit (the sampling rates and η stay in the parameters).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Principled<'a> {
    pub base_color: Vec3A,
    pub p: &'a PrincipledParams,
    pub roughness: f32,
    pub anisotropic: f32,
    pub metallic: f32,
    pub spec_trans: f32,
    pub spec_tint: f32,
    pub sheen: f32,
    pub sheen_tint: f32,
    pub flatness: f32,
    pub clearcoat: f32,
    pub clearcoat_gloss: f32,
}

impl PartialEq for PrincipledParams {
    fn eq(&self, other: &Self) -> bool {
        std::ptr::eq(self, other)
    }
}

/// The half vector of a pair of directions and what depends on it alone (see
/// [`Principled::geometry`]).
struct Geometry {
    wh: Vec3A,
    reflect: bool,
    eta_path: f32,
    oh: f32,
    ih: f32,
    f_diel: f32,
    d: f32,
    distr: Microfacet,
}

/// Probabilities of the lobes (diffuse, clearcoat, specular reflection, specular
/// transmission), normalised.
struct LobeProbs {
    diffuse: f32,
    clearcoat: f32,
    reflect: f32,
    trans: f32,
}

impl Principled<'_> {
    pub const FLAGS: BsdfFlags = BsdfFlags::DIFFUSE_REFLECTION
        .union(BsdfFlags::GLOSSY_REFLECTION)
        .union(BsdfFlags::GLOSSY_TRANSMISSION);

    /// The lobes this material has (transmission only with spec_trans).
    pub fn flags(&self) -> BsdfFlags {
        if self.p.transmits() {
            Self::FLAGS
        } else {
            BsdfFlags::DIFFUSE_REFLECTION | BsdfFlags::GLOSSY_REFLECTION
        }
    }

    #[inline]
    fn distr(&self) -> Microfacet {
        let (ax, ay) = disney_alphas(self.anisotropic, self.roughness);
        Microfacet::new(MicrofacetKind::Ggx, ax, ay)
    }

    /// Weights of the reflection-only base ((1 − m)(1 − t)) and of the transmitting part
    /// ((1 − m) t).
    #[inline]
    fn weights(&self) -> (f32, f32) {
        let dielectric = 1.0 - self.metallic;
        (
            dielectric * (1.0 - self.spec_trans),
            dielectric * self.spec_trans,
        )
    }

    #[inline]
    fn probs(&self, front: bool, f: f32) -> LobeProbs {
        let p = self.p;
        let (brdf, bsdf) = self.weights();
        let mut l = if front {
            LobeProbs {
                diffuse: brdf * p.diffuse_reflectance_sampling_rate,
                clearcoat: 0.25 * self.clearcoat * p.clearcoat_sampling_rate,
                reflect: p.main_specular_sampling_rate * (1.0 - bsdf * (1.0 - f)),
                trans: p.main_specular_sampling_rate * bsdf * (1.0 - f),
            }
        } else {
            // From inside only the specular lobes are sampled (Mitsuba also normalises these
            // when the material does not transmit, where the back side is black).
            LobeProbs {
                diffuse: 0.0,
                clearcoat: 0.0,
                reflect: f,
                trans: if p.transmits() { 1.0 - f } else { 0.0 },
            }
        };
        let inv = 1.0 / (l.diffuse + l.clearcoat + l.reflect + l.trans);
        l.diffuse *= inv;
        l.clearcoat *= inv;
        l.reflect *= inv;
        l.trans *= inv;
        l
    }

    /// The half vector of a pair (pointing out of the object) and the relative IOR along the
    /// path (η from the front, 1/η from inside).
    #[inline]
    fn half_vector(&self, wo: Vec3A, wi: Vec3A) -> (Vec3A, bool, f32) {
        let reflect = wo.z * wi.z > 0.0;
        let eta_path = if wo.z > 0.0 {
            self.p.eta
        } else {
            1.0 / self.p.eta
        };
        let h = (wo + wi * if reflect { 1.0 } else { eta_path }).normalize();
        (if h.z < 0.0 { -h } else { h }, reflect, eta_path)
    }

    /// What `eval` and `pdf` share for a pair of directions: the half vector and its Fresnel
    /// term, the distribution and D there.
    #[inline(always)]
    fn geometry(&self, wo: Vec3A, wi: Vec3A) -> Geometry {
        let (wh, reflect, eta_path) = self.half_vector(wo, wi);
        let oh = wo.dot(wh);
        let distr = self.distr();
        Geometry {
            wh,
            reflect,
            eta_path,
            oh,
            ih: wi.dot(wh),
            f_diel: fresnel_dielectric(oh, self.p.eta).0,
            d: distr.d(wh),
            distr,
        }
    }

    /// f(wo, wi)·|cos θi| (Mitsuba's `eval`).
    #[inline(never)]
    pub fn eval(&self, wo: Vec3A, wi: Vec3A) -> Vec3A {
        if wo.z == 0.0 || !(wo.z * wi.z != 0.0) {
            return Vec3A::ZERO;
        }
        self.eval_at(wo, wi, &self.geometry(wo, wi))
    }

    #[inline(always)]
    fn eval_at(&self, wo: Vec3A, wi: Vec3A, geo: &Geometry) -> Vec3A {
        let cos_o = wo.z;
        let cos_i = wi.z;
        let (brdf, bsdf) = self.weights();
        let front = cos_o > 0.0;
        let Geometry {
            wh,
            reflect,
            eta_path,
            oh,
            ih,
            f_diel,
            d,
            ref distr,
        } = *geo;
        let eta = self.p.eta;
        let g = distr.g(wo, wi, wh);
        let mut value = Vec3A::ZERO;
        if reflect {
            let compatible = mac_mic_compatible(wh, wo, wi, cos_o, true);
            if compatible && f_diel > 0.0 {
                let f = if front {
                    let mut f =
                        Vec3A::splat((1.0 - self.metallic) * (1.0 - self.spec_tint) * f_diel);
                    if self.metallic != 0.0 {
                        f += self.metallic * schlick_eta(self.base_color, oh, eta);
                    }
                    if self.spec_tint != 0.0 {
                        let eta_it = if oh >= 0.0 { eta } else { 1.0 / eta };
                        let f0 = tint_color(self.base_color) * schlick_r0(eta_it);
                        f += (1.0 - self.metallic) * self.spec_tint * schlick_eta(f0, oh, eta);
                    }
                    f
                } else {
                    Vec3A::splat(bsdf * f_diel)
                };
                value += f * (d * g / (4.0 * cos_o.abs()));
            }
            if front && compatible && self.clearcoat > 0.0 {
                value += Vec3A::splat(clearcoat_eval(
                    self.clearcoat,
                    self.clearcoat_gloss,
                    eta,
                    wo,
                    wi,
                    wh,
                ));
            }
            if front {
                let lobes = DiffuseLobes {
                    base_color: self.base_color,
                    roughness: self.roughness,
                    flatness: self.flatness,
                    sheen: self.sheen,
                    sheen_tint: self.sheen_tint,
                };
                let (diffuse, sheen) = lobes.eval(cos_o, cos_i, ih);
                if brdf > 0.0 {
                    value += diffuse * brdf;
                }
                if 1.0 - self.metallic > 0.0 {
                    value += sheen * (1.0 - self.metallic);
                }
            }
        } else if bsdf > 0.0 && f_diel < 1.0 && mac_mic_compatible(wh, wo, wi, cos_o, false) {
            // Radiance is compressed by 1/η² entering the denser side.
            let scale = 1.0 / (eta_path * eta_path);
            let denom = oh + eta_path * ih;
            let t = scale * (1.0 - f_diel) * d * g * eta_path * eta_path * oh * ih
                / (cos_o * denom * denom);
            let c = self.base_color.max(Vec3A::ZERO);
            let sqrt_color = Vec3A::new(c.x.sqrt(), c.y.sqrt(), c.z.sqrt());
            value += sqrt_color * (bsdf * t.abs());
        }
        value
    }

    /// The solid-angle density of [`Principled::sample`] (Mitsuba's `pdf`).
    #[inline(never)]
    pub fn pdf(&self, wo: Vec3A, wi: Vec3A) -> f32 {
        if wo.z == 0.0 {
            return 0.0;
        }
        self.pdf_at(wo, wi, &self.geometry(wo, wi))
    }

    #[inline(always)]
    fn pdf_at(&self, wo: Vec3A, wi: Vec3A, geo: &Geometry) -> f32 {
        let cos_o = wo.z;
        let cos_i = wi.z;
        let front = cos_o > 0.0;
        let Geometry {
            wh,
            reflect,
            eta_path,
            oh,
            ih,
            f_diel: f,
            d,
            ref distr,
        } = *geo;
        let refract = cos_o * cos_i < 0.0;
        let probs = self.probs(front, f);
        let jacobian = if reflect {
            1.0 / (4.0 * ih)
        } else {
            let denom = oh + eta_path * ih;
            eta_path * eta_path * ih / (denom * denom)
        }
        .abs();
        let wo_up = if front { wo } else { -wo };
        let mut pdf = 0.0;
        if reflect {
            if mac_mic_compatible(wh, wo, wi, cos_o, true) {
                pdf += probs.reflect * distr.pdf_given_d(wo_up, wh, d) * jacobian;
                if probs.clearcoat > 0.0 {
                    pdf +=
                        probs.clearcoat * Gtr1::clearcoat(self.clearcoat_gloss).pdf(wh) * jacobian;
                }
            }
            pdf += probs.diffuse * cosine_pdf(wi);
        } else if refract && probs.trans > 0.0 && mac_mic_compatible(wh, wo, wi, cos_o, false) {
            pdf += probs.trans * distr.pdf_given_d(wo_up, wh, d) * jacobian;
        }
        pdf
    }

    /// A lobe chosen by `u_lobe` with the probabilities of [`Principled::pdf`], its direction
    /// from `u`; weight eval/pdf of the whole mixture, as Mitsuba's `sample` returns.
    #[inline(never)]
    pub fn sample(&self, wo: Vec3A, u: Vec2, u_lobe: f32) -> Option<BsdfSample> {
        let cos_o = wo.z;
        if cos_o == 0.0 || !cos_o.is_finite() {
            return None;
        }
        let front = cos_o > 0.0;
        let (_, bsdf) = self.weights();
        if !front && !(bsdf > 0.0) {
            return None;
        }
        let wo_up = if front { wo } else { -wo };
        let distr = self.distr();
        let m = distr.sample_visible(wo_up, u);
        let (f, cos_t, eta_it, eta_ti) = fresnel_dielectric(wo.dot(m), self.p.eta);
        let probs = self.probs(front, f);
        let (wi, eta, lobe) = if u_lobe < probs.diffuse {
            let wi = square_to_cosine_hemisphere(u);
            if !(wi.z * cos_o > 0.0) {
                return None;
            }
            (wi, 1.0, BsdfFlags::DIFFUSE_REFLECTION)
        } else if u_lobe < probs.diffuse + probs.clearcoat {
            let m = Gtr1::clearcoat(self.clearcoat_gloss).sample(u);
            let wi = reflect(wo, m);
            if !(wi.z * cos_o > 0.0 && mac_mic_compatible(m, wo, wi, cos_o, true)) {
                return None;
            }
            (wi, 1.0, BsdfFlags::GLOSSY_REFLECTION)
        } else if u_lobe < probs.diffuse + probs.clearcoat + probs.trans {
            let wi = refract(wo, m, cos_t, eta_ti);
            if !(wi.z * cos_o < 0.0 && mac_mic_compatible(m, wo, wi, cos_o, false)) {
                return None;
            }
            (wi, eta_it, BsdfFlags::GLOSSY_TRANSMISSION)
        } else {
            let wi = reflect(wo, m);
            if !(wi.z * cos_o > 0.0 && mac_mic_compatible(m, wo, wi, cos_o, true)) {
                return None;
            }
            (wi, 1.0, BsdfFlags::GLOSSY_REFLECTION)
        };
        // `pdf` and `eval` on one shared geometry (every branch above rejected the wi.z = 0 for
        // which `eval` returns zero).
        let geo = self.geometry(wo, wi);
        let pdf = self.pdf_at(wo, wi, &geo);
        if !(pdf > 0.0) {
            return None;
        }
        Some(BsdfSample {
            wi,
            weight: self.eval_at(wo, wi, &geo) / pdf,
            pdf,
            eta,
            lobe,
        })
    }

    /// About the widest lobe's angular width: the diffuse base, unless the material is all
    /// metal or glass.
    pub fn roughness(&self) -> f32 {
        let (brdf, _) = self.weights();
        if brdf > 0.0 {
            1.0
        } else {
            let d = self.distr();
            d.alpha_u.max(d.alpha_v).min(1.0)
        }
    }
}
