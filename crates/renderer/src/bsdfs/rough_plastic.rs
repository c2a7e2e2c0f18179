//! Mitsuba's `roughplastic`: a diffuse base under a rough dielectric coating. The coating's
//! glossy reflection is the microfacet model with exact Fresnel; the base is seen through the
//! coating's directional transmittance T(μ) (tabulated at 64 cosines when the material is
//! built, as Mitsuba does), with internal reflection from the cosine-weighted average of the
//! coating's reflectance seen from inside.

use super::fresnel::{fresnel_dielectric, refract};
use super::microfacet::{Microfacet, MicrofacetKind};
use super::{BsdfFlags, BsdfSample};
use crate::sampling::{cosine_hemisphere_pdf, square_to_cosine_hemisphere};
use crate::textures::{ColorSource, TextureQuery};
use glam::{Vec2, Vec3A};

/// Resolution of the transmittance table (Mitsuba's `MI_ROUGH_TRANSMITTANCE_RES`).
pub const TABLE_RES: usize = 64;

/// The material's parameters, with the coating's precomputed transmittance.
#[derive(Clone, Copy, Debug)]
pub struct RoughPlasticParams {
    pub diffuse_reflectance: ColorSource,
    pub specular_reflectance: ColorSource,
    pub distr: Microfacet,
    pub eta: f32,
    pub nonlinear: bool,
    pub specular_sampling_weight: f32,
    /// The coating's transmittance T(μ) at μ = i / 63 for incidence from outside.
    pub external_transmittance: [f32; TABLE_RES],
    /// Cosine-weighted average of the coating's reflectance seen from inside (η → 1/η).
    pub internal_reflectance: f32,
}

/// The coating seen from incidence at cos θ = μ: the energy it reflects (`transmit` false) or
/// transmits (true), as the mean over the normals m visible from there (their density already
/// carries D G1(wi)) of F(wi·m) G1(wr, m) or (1 − F) G1(wt, m), by a midpoint rule over the
/// sampler's unit square (Mitsuba's `eval_reflectance` / `eval_transmittance` use
/// Gauss-Legendre; both converge to the same integral). With single scattering the two need not
/// sum to 1.
fn coating_energy(distr: &Microfacet, mu: f32, eta: f32, transmit: bool) -> f32 {
    let n = if eta > 1.0 { 32 } else { 64 };
    let wi = Vec3A::new((1.0 - mu * mu).max(0.0).sqrt(), 0.0, mu);
    let mut sum = 0.0f64;
    for i in 0..n {
        for j in 0..n {
            let u = Vec2::new((i as f32 + 0.5) / n as f32, (j as f32 + 0.5) / n as f32);
            let m = distr.sample_visible(wi, u);
            let (f, cos_t, _, eta_ti) = fresnel_dielectric(wi.dot(m), eta);
            let v = if transmit {
                let wt = refract(wi, m, cos_t, eta_ti);
                if wt.z >= 0.0 {
                    continue;
                }
                (1.0 - f) * distr.smith_g1(wt, m)
            } else {
                let wr = m * (2.0 * wi.dot(m)) - wi;
                if wr.z <= 0.0 {
                    continue;
                }
                f * distr.smith_g1(wr, m)
            };
            sum += v as f64;
        }
    }
    (sum / (n * n) as f64) as f32
}

impl RoughPlasticParams {
    /// The parameters with the coating's tables computed.
    pub fn new(
        diffuse_reflectance: ColorSource,
        specular_reflectance: ColorSource,
        kind: MicrofacetKind,
        alpha: f32,
        eta: f32,
        nonlinear: bool,
    ) -> Self {
        let distr = Microfacet::new(kind, alpha, alpha);
        let mut external_transmittance = [0.0; TABLE_RES];
        let mut internal = 0.0f64;
        for (i, t) in external_transmittance.iter_mut().enumerate() {
            let mu = (i as f32 / (TABLE_RES - 1) as f32).max(1e-6);
            *t = coating_energy(&distr, mu, eta, true);
            internal += (coating_energy(&distr, mu, 1.0 / eta, false) * mu) as f64;
        }
        Self {
            diffuse_reflectance,
            specular_reflectance,
            distr,
            eta,
            nonlinear,
            specular_sampling_weight: super::smooth_plastic::specular_sampling_weight(
                diffuse_reflectance,
                specular_reflectance,
            ),
            external_transmittance,
            internal_reflectance: (2.0 * internal / TABLE_RES as f64) as f32,
        }
    }

    #[inline(always)]
    pub fn resolve<'a>(&'a self, q: &TextureQuery) -> RoughPlastic<'a> {
        RoughPlastic {
            diffuse_reflectance: q.color(self.diffuse_reflectance),
            specular_reflectance: q.color(self.specular_reflectance),
            params: self,
        }
    }

    pub fn is_textured(&self) -> bool {
        self.diffuse_reflectance.is_textured() || self.specular_reflectance.is_textured()
    }

    /// T(μ), linearly interpolated in the table.
    #[inline]
    fn transmittance(&self, mu: f32) -> f32 {
        let x = mu.clamp(0.0, 1.0) * (TABLE_RES - 1) as f32;
        let i = (x as usize).min(TABLE_RES - 2);
        let w = x - i as f32;
        let t = &self.external_transmittance;
        t[i] * (1.0 - w) + t[i + 1] * w
    }
}

/// Mitsuba's roughplastic at a hit.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct RoughPlastic<'a> {
    pub diffuse_reflectance: Vec3A,
    pub specular_reflectance: Vec3A,
    pub params: &'a RoughPlasticParams,
}

impl PartialEq for RoughPlasticParams {
    fn eq(&self, other: &Self) -> bool {
        std::ptr::eq(self, other)
    }
}

impl RoughPlastic<'_> {
    pub const FLAGS: BsdfFlags = BsdfFlags::GLOSSY_REFLECTION.union(BsdfFlags::DIFFUSE_REFLECTION);

    #[inline]
    fn prob_specular(&self, t_o: f32) -> f32 {
        let w = self.params.specular_sampling_weight;
        let s = (1.0 - t_o) * w;
        let d = t_o * (1.0 - w);
        s / (s + d)
    }

    #[inline]
    pub fn eval(&self, wo: Vec3A, wi: Vec3A) -> Vec3A {
        if !(wo.z > 0.0 && wi.z > 0.0) {
            return Vec3A::ZERO;
        }
        let p = self.params;
        let h = (wo + wi).normalize();
        let distr = &p.distr;
        let f = fresnel_dielectric(wo.dot(h), p.eta).0;
        let spec = self.specular_reflectance * (f * distr.d(h) * distr.g(wo, wi, h) / (4.0 * wo.z));
        let d = self.diffuse_reflectance;
        let base = if p.nonlinear {
            d / (Vec3A::ONE - d * p.internal_reflectance)
        } else {
            d / (1.0 - p.internal_reflectance)
        };
        let (t_o, t_i) = (p.transmittance(wo.z), p.transmittance(wi.z));
        spec + base * (cosine_hemisphere_pdf(wi.z) * t_o * t_i / (p.eta * p.eta))
    }

    #[inline]
    pub fn pdf(&self, wo: Vec3A, wi: Vec3A) -> f32 {
        if !(wo.z > 0.0 && wi.z > 0.0) {
            return 0.0;
        }
        let ps = self.prob_specular(self.params.transmittance(wo.z));
        let h = (wo + wi).normalize();
        let c = wo.dot(h);
        let spec = if c > 0.0 {
            self.params.distr.pdf(wo, h) / (4.0 * c)
        } else {
            0.0
        };
        ps * spec + (1.0 - ps) * cosine_hemisphere_pdf(wi.z)
    }

    #[inline]
    pub fn sample(&self, wo: Vec3A, u: Vec2, u_lobe: f32) -> Option<BsdfSample> {
        if !(wo.z > 0.0) {
            return None;
        }
        let ps = self.prob_specular(self.params.transmittance(wo.z));
        let (wi, lobe) = if u_lobe < ps {
            let m = self.params.distr.sample(wo, u);
            (
                (m * (2.0 * wo.dot(m)) - wo).normalize(),
                BsdfFlags::GLOSSY_REFLECTION,
            )
        } else {
            (
                square_to_cosine_hemisphere(u),
                BsdfFlags::DIFFUSE_REFLECTION,
            )
        };
        if !(wi.z > 0.0) {
            return None;
        }
        let pdf = self.pdf(wo, wi);
        (pdf > 0.0).then(|| BsdfSample::reflection(wi, self.eval(wo, wi) / pdf, pdf, lobe))
    }

    pub fn roughness(&self) -> f32 {
        1.0
    }
}
