//! Mitsuba 3's `principledthin`: the thin-surface variant of the Disney BSDF (Burley 2015) as
//! Mitsuba implements it (src/bsdfs/principledthin.cpp). A two-dimensional sheet, the same from
//! both sides (directions are mirrored to the front first); lobes, weighted by spec_trans t and
//! diff_trans/2 = d:
//! - GGX specular reflection, weight t/2·2 = t, Fresnel of the sheet's `eta` blended towards a
//!   tinted Schlick by `spec_tint`;
//! - GGX "transmission" without bending: a reflection mirrored through the sheet, roughness
//!   scaled by 0.65 η − 0.35 (Burley 2015, figure 15), tinted by base_color, weight t(1 − F);
//! - Burley's diffuse with retro-reflection (and fake subsurface by `flatness`) plus sheen,
//!   weight (1 − t)(1 − d);
//! - Lambertian transmission, weight (1 − t) d.
//!
//! Directions: `wo` here is Mitsuba's `si.wi` (towards the viewer), `wi` its sampled `wo`.

use super::fresnel::fresnel_dielectric;
use super::microfacet::{Microfacet, MicrofacetKind};
use super::principled_lobes::{
    cosine_pdf, disney_alphas, mac_mic_compatible, reflect, schlick_eta, schlick_r0, tint_color,
    DiffuseLobes,
};
use super::{BsdfFlags, BsdfSample};
use crate::sampling::square_to_cosine_hemisphere;
use crate::textures::{ColorSource, FloatSource, TextureQuery};
use glam::{Vec2, Vec3A};
use std::f32::consts::FRAC_1_PI;

/// The material's parameters (Mitsuba's names; every float but the sampling rates may be a
/// texture).
#[derive(Clone, Copy, Debug)]
pub struct PrincipledThinParams {
    pub base_color: ColorSource,
    pub roughness: FloatSource,
    pub anisotropic: FloatSource,
    pub spec_trans: FloatSource,
    pub spec_tint: FloatSource,
    pub sheen: FloatSource,
    pub sheen_tint: FloatSource,
    pub flatness: FloatSource,
    /// 0 to 2: the share of the diffuse energy transmitted (Mitsuba halves it).
    pub diff_trans: FloatSource,
    /// The sheet's relative IOR.
    pub eta: FloatSource,
    pub specular_reflectance_sampling_rate: f32,
    pub specular_transmittance_sampling_rate: f32,
    pub diffuse_reflectance_sampling_rate: f32,
    pub diffuse_transmittance_sampling_rate: f32,
}

impl PartialEq for PrincipledThinParams {
    fn eq(&self, other: &Self) -> bool {
        std::ptr::eq(self, other)
    }
}

impl PrincipledThinParams {
    #[inline]
    pub fn resolve<'a>(&'a self, q: &TextureQuery) -> PrincipledThin<'a> {
        PrincipledThin {
            base_color: q.color(self.base_color),
            p: self,
            roughness: q.float(self.roughness),
            anisotropic: q.float(self.anisotropic),
            spec_trans: q.float(self.spec_trans),
            spec_tint: q.float(self.spec_tint),
            sheen: q.float(self.sheen),
            sheen_tint: q.float(self.sheen_tint),
            flatness: q.float(self.flatness),
            diff_trans: 0.5 * q.float(self.diff_trans),
            eta: q.float(self.eta),
        }
    }

    pub fn is_textured(&self) -> bool {
        self.base_color.is_textured()
            || [
                self.roughness,
                self.anisotropic,
                self.spec_trans,
                self.spec_tint,
                self.sheen,
                self.sheen_tint,
                self.flatness,
                self.diff_trans,
                self.eta,
            ]
            .iter()
            .any(|f| f.is_textured())
    }

    pub fn anisotropic(&self) -> bool {
        !matches!(self.anisotropic, FloatSource::Constant(a) if a == 0.0)
    }
}

/// A thin principled sheet at a hit.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct PrincipledThin<'a> {
    pub base_color: Vec3A,
    pub p: &'a PrincipledThinParams,
    pub roughness: f32,
    pub anisotropic: f32,
    pub spec_trans: f32,
    pub spec_tint: f32,
    pub sheen: f32,
    pub sheen_tint: f32,
    pub flatness: f32,
    /// Already halved: 0 to 1.
    pub diff_trans: f32,
    pub eta: f32,
}

/// Normalised probabilities of specular reflection, specular transmission, diffuse reflection
/// and diffuse transmission.
struct LobeProbs {
    spec_reflect: f32,
    spec_trans: f32,
    diff_reflect: f32,
    diff_trans: f32,
}

impl PrincipledThin<'_> {
    pub const FLAGS: BsdfFlags = BsdfFlags::DIFFUSE_REFLECTION
        .union(BsdfFlags::GLOSSY_REFLECTION)
        .union(BsdfFlags::GLOSSY_TRANSMISSION)
        .union(BsdfFlags::DIFFUSE)
        .union(BsdfFlags::TRANSMISSION);

    /// The reflection lobe's distribution.
    #[inline]
    fn distr(&self) -> Microfacet {
        let (ax, ay) = disney_alphas(self.anisotropic, self.roughness);
        Microfacet::new(MicrofacetKind::Ggx, ax, ay)
    }

    /// The transmission lobe's: roughness scaled by 0.65 η − 0.35.
    #[inline]
    fn distr_trans(&self) -> Microfacet {
        let r = (0.65 * self.eta - 0.35) * self.roughness;
        let (ax, ay) = disney_alphas(self.anisotropic, r);
        Microfacet::new(MicrofacetKind::Ggx, ax, ay)
    }

    #[inline]
    fn probs(&self) -> LobeProbs {
        let p = self.p;
        let (t, d) = (self.spec_trans, self.diff_trans);
        let mut l = LobeProbs {
            spec_reflect: t * p.specular_reflectance_sampling_rate * 0.5,
            spec_trans: t * p.specular_transmittance_sampling_rate * 0.5,
            diff_reflect: p.diffuse_reflectance_sampling_rate * (1.0 - t) * (1.0 - d),
            diff_trans: p.diffuse_transmittance_sampling_rate * (1.0 - t) * d,
        };
        let inv = 1.0 / (l.spec_reflect + l.spec_trans + l.diff_reflect + l.diff_trans);
        l.spec_reflect *= inv;
        l.spec_trans *= inv;
        l.diff_reflect *= inv;
        l.diff_trans *= inv;
        l
    }

    /// Both directions mirrored so that `wo` is on the front, and the half vector of `wo` and
    /// `wi` mirrored to `wo`'s side.
    #[inline]
    fn to_front(wo: Vec3A, wi: Vec3A) -> (Vec3A, Vec3A, Vec3A) {
        let (v, l) = if wo.z < 0.0 { (-wo, -wi) } else { (wo, wi) };
        let l_r = Vec3A::new(l.x, l.y, l.z.abs());
        (v, l, (v + l_r).normalize())
    }

    /// f(wo, wi)·|cos θi| (Mitsuba's `eval`).
    #[inline(never)]
    pub fn eval(&self, wo: Vec3A, wi: Vec3A) -> Vec3A {
        if wo.z == 0.0 {
            return Vec3A::ZERO;
        }
        let (v, l, wh) = Self::to_front(wo, wi);
        let (t, d) = (self.spec_trans, self.diff_trans);
        let reflect = l.z > 0.0;
        let refract = l.z < 0.0;
        let mut value = Vec3A::ZERO;
        if t > 0.0 {
            let vh = v.dot(wh);
            let f = fresnel_dielectric(vh, self.eta).0;
            if reflect && mac_mic_compatible(wh, v, l, v.z, true) {
                let mut f_thin = Vec3A::splat(f);
                if self.spec_tint != 0.0 {
                    let f0 = tint_color(self.base_color) * schlick_r0(self.eta);
                    let schlick = schlick_eta(f0, vh, self.eta);
                    f_thin += (schlick - f_thin) * self.spec_tint;
                }
                let distr = self.distr();
                let dg = distr.d(wh) * distr.g(v, l, wh);
                value += f_thin * (t * dg / (4.0 * v.z));
            }
            if refract && mac_mic_compatible(wh, v, l, v.z, false) {
                let distr = self.distr_trans();
                let dg = distr.d(wh) * distr.g(v, l, wh);
                value += self.base_color * (t * (1.0 - f) * dg / (4.0 * v.z));
            }
        }
        if reflect && t < 1.0 && d < 1.0 {
            let lobes = DiffuseLobes {
                base_color: self.base_color,
                roughness: self.roughness,
                flatness: self.flatness,
                sheen: self.sheen,
                sheen_tint: self.sheen_tint,
            };
            let (diffuse, sheen) = lobes.eval(v.z, l.z, wh.dot(l));
            value += (diffuse + sheen) * ((1.0 - t) * (1.0 - d));
        }
        if refract && t < 1.0 && d > 0.0 {
            value += self.base_color * ((1.0 - t) * d * FRAC_1_PI * l.z.abs());
        }
        value
    }

    /// The solid-angle density of [`PrincipledThin::sample`] (Mitsuba's `pdf`).
    #[inline(never)]
    pub fn pdf(&self, wo: Vec3A, wi: Vec3A) -> f32 {
        if wo.z == 0.0 {
            return 0.0;
        }
        let (v, l, wh) = Self::to_front(wo, wi);
        let probs = self.probs();
        let reflect = l.z > 0.0;
        let refract = l.z < 0.0;
        let mut pdf = 0.0;
        if self.spec_trans > 0.0 {
            let l_r = Vec3A::new(l.x, l.y, l.z.abs());
            let jacobian = (1.0 / (4.0 * l_r.dot(wh))).abs();
            if reflect && mac_mic_compatible(wh, v, l, v.z, true) {
                pdf += probs.spec_reflect * self.distr().pdf_visible(v, wh) * jacobian;
            }
            if refract && mac_mic_compatible(wh, v, l, v.z, false) {
                pdf += probs.spec_trans * self.distr_trans().pdf_visible(v, wh) * jacobian;
            }
        }
        if reflect {
            pdf += probs.diff_reflect * cosine_pdf(l);
        }
        if refract {
            pdf += probs.diff_trans * cosine_pdf(-l);
        }
        pdf
    }

    /// A lobe chosen by `u_lobe` with the probabilities of [`PrincipledThin::pdf`], its
    /// direction from `u`; weight eval/pdf of the mixture. Nothing bends: η is 1.
    #[inline(never)]
    pub fn sample(&self, wo: Vec3A, u: Vec2, u_lobe: f32) -> Option<BsdfSample> {
        if wo.z == 0.0 || !wo.z.is_finite() {
            return None;
        }
        let s = if wo.z < 0.0 { -1.0 } else { 1.0 };
        let v = wo * s;
        let probs = self.probs();
        let (l, lobe) = if u_lobe < probs.spec_reflect {
            let m = self.distr().sample_visible(v, u);
            let l = reflect(v, m);
            if !(l.z > 0.0 && mac_mic_compatible(m, v, l, v.z, true)) {
                return None;
            }
            (l, BsdfFlags::GLOSSY_REFLECTION)
        } else if u_lobe < probs.spec_reflect + probs.spec_trans {
            let m = self.distr_trans().sample_visible(v, u);
            let r = reflect(v, m);
            let l = Vec3A::new(r.x, r.y, -r.z);
            if !(l.z < 0.0 && mac_mic_compatible(m, v, l, v.z, false)) {
                return None;
            }
            (l, BsdfFlags::GLOSSY_TRANSMISSION)
        } else if u_lobe < probs.spec_reflect + probs.spec_trans + probs.diff_reflect {
            (
                square_to_cosine_hemisphere(u),
                BsdfFlags::DIFFUSE_REFLECTION,
            )
        } else if probs.diff_trans > 0.0 {
            (
                -square_to_cosine_hemisphere(u),
                BsdfFlags::DIFFUSE | BsdfFlags::TRANSMISSION,
            )
        } else {
            return None;
        };
        let wi = l * s;
        let pdf = self.pdf(wo, wi);
        if !(pdf > 0.0) {
            return None;
        }
        Some(BsdfSample::reflection(
            wi,
            self.eval(wo, wi) / pdf,
            pdf,
            lobe,
        ))
    }

    /// About the widest lobe's angular width: diffuse unless the sheet is all specular.
    pub fn roughness(&self) -> f32 {
        if self.spec_trans < 1.0 {
            1.0
        } else {
            let d = self.distr();
            d.alpha_u.max(d.alpha_v).min(1.0)
        }
    }
}
