//! Sidedness: [`SidedBsdf`], what the path loop shades with, and the test-only [`SurfaceBsdf`]
//! it is checked against.

use super::{Bsdf, BsdfFlags, BsdfSample, Perturbation};
use glam::{Vec2, Vec3A};

/// What a viewer behind a surface (wo.z < 0) sees.
#[cfg(test)]
#[derive(Clone, Copy, Debug)]
pub enum BackSide<'a> {
    /// The front BSDF itself decides (black for the reflection-only models; a dielectric
    /// refracts).
    Front,
    /// The front BSDF with both directions mirrored to the front (Mitsuba's `twosided` with one
    /// BSDF, every material of a torrey-dialect scene).
    Mirrored,
    /// Another BSDF, mirrored to the front (Mitsuba's `twosided` with two).
    Other(Bsdf<'a>),
}

/// A BSDF at a hit with its sidedness. Both loops shade with [`SidedBsdf`]; this whole
/// surface is compiled for the tests only, as the reference they check [`SidedBsdf`] against.
#[cfg(test)]
#[derive(Clone, Copy, Debug)]
pub struct SurfaceBsdf<'a> {
    pub front: Bsdf<'a>,
    pub back: BackSide<'a>,
    /// Mitsuba's `normalmap` / `bumpmap` adapter (None: no tilted frame, or torrey's normal map).
    pub perturbation: Option<Perturbation>,
}

/// `w` mirrored through the tangent plane.
#[inline(always)]
fn flip_z(w: Vec3A) -> Vec3A {
    Vec3A::new(w.x, w.y, -w.z)
}

#[cfg(test)]
impl<'a> SurfaceBsdf<'a> {
    /// The BSDF facing `wo`, and whether directions must be mirrored for it.
    #[inline(always)]
    fn side(&self, wo: Vec3A) -> (&Bsdf<'a>, bool) {
        if wo.z < 0.0 {
            match &self.back {
                BackSide::Front => {}
                BackSide::Mirrored => return (&self.front, true),
                BackSide::Other(back) => return (back, true),
            }
        }
        (&self.front, false)
    }

    #[inline(always)]
    pub fn eval(&self, wo: Vec3A, wi: Vec3A) -> Vec3A {
        let f = match self.side(wo) {
            (b, false) => b.eval(wo, wi),
            (b, true) => b.eval(flip_z(wo), flip_z(wi)),
        };
        match &self.perturbation {
            None => f,
            Some(p) => f * p.factor(wi),
        }
    }

    #[inline(always)]
    pub fn pdf(&self, wo: Vec3A, wi: Vec3A) -> f32 {
        if let Some(p) = &self.perturbation {
            if !p.same_side(wi) {
                return 0.0;
            }
        }
        match self.side(wo) {
            (b, false) => b.pdf(wo, wi),
            (b, true) => b.pdf(flip_z(wo), flip_z(wi)),
        }
    }

    #[inline(always)]
    pub fn sample(&self, wo: Vec3A, u: Vec2, u_lobe: f32) -> Option<BsdfSample> {
        let s = match self.side(wo) {
            (b, false) => b.sample(wo, u, u_lobe),
            (b, true) => b.sample(flip_z(wo), u, u_lobe).map(|s| BsdfSample {
                wi: flip_z(s.wi),
                ..s
            }),
        };
        match &self.perturbation {
            None => s,
            Some(p) => s.and_then(|s| {
                let k = p.factor(s.wi);
                (k > 0.0).then(|| BsdfSample {
                    weight: s.weight * k,
                    ..s
                })
            }),
        }
    }

    /// The lobes seen from `wo`'s side.
    #[inline(always)]
    pub fn flags(&self, wo: Vec3A) -> BsdfFlags {
        self.side(wo).0.flags()
    }

    /// [`Bsdf::roughness`] of the side `wo` sees.
    #[inline(always)]
    pub fn roughness(&self, wo: Vec3A) -> f32 {
        self.side(wo).0.roughness()
    }
}

/// The side of a [`SurfaceBsdf`] that one viewing direction `wo` sees, chosen once per hit: what
/// the path loop shades with. Only that side's parameters are resolved (textures of the other
/// side are not looked up), the side is not decided again at every call, and it is half the size
/// of a [`SurfaceBsdf`] with a second BSDF. Every method must be given that same `wo`; they
/// return exactly what [`SurfaceBsdf`]'s do for it.
#[derive(Clone, Copy, Debug)]
pub struct SidedBsdf<'a> {
    pub bsdf: Bsdf<'a>,
    /// `wo` is behind a two-sided material: both directions are mirrored to the front for `bsdf`.
    pub mirrored: bool,
    /// Mitsuba's `normalmap` / `bumpmap` adapter, as in [`SurfaceBsdf`].
    pub perturbation: Option<Perturbation>,
}

impl SidedBsdf<'_> {
    /// `w` as `bsdf` sees it.
    #[inline(always)]
    fn local(&self, w: Vec3A) -> Vec3A {
        if self.mirrored {
            flip_z(w)
        } else {
            w
        }
    }

    #[inline(always)]
    pub fn eval(&self, wo: Vec3A, wi: Vec3A) -> Vec3A {
        let f = self.bsdf.eval(self.local(wo), self.local(wi));
        match &self.perturbation {
            None => f,
            Some(p) => f * p.factor(wi),
        }
    }

    /// [`SidedBsdf::eval`] and [`SidedBsdf::pdf`] together ([`Bsdf::eval_pdf`]; the same bits).
    #[inline(always)]
    pub fn eval_pdf(&self, wo: Vec3A, wi: Vec3A) -> (Vec3A, f32) {
        let (f, pdf) = self.bsdf.eval_pdf(self.local(wo), self.local(wi));
        match &self.perturbation {
            None => (f, pdf),
            Some(p) => (f * p.factor(wi), if p.same_side(wi) { pdf } else { 0.0 }),
        }
    }

    #[inline(always)]
    pub fn sample(&self, wo: Vec3A, u: Vec2, u_lobe: f32) -> Option<BsdfSample> {
        let s = if self.mirrored {
            self.bsdf.sample(flip_z(wo), u, u_lobe).map(|s| BsdfSample {
                wi: flip_z(s.wi),
                ..s
            })
        } else {
            self.bsdf.sample(wo, u, u_lobe)
        };
        match &self.perturbation {
            None => s,
            Some(p) => s.and_then(|s| {
                let k = p.factor(s.wi);
                (k > 0.0).then(|| BsdfSample {
                    weight: s.weight * k,
                    ..s
                })
            }),
        }
    }

    /// The lobes of the side seen.
    #[inline(always)]
    pub fn flags(&self) -> BsdfFlags {
        self.bsdf.flags()
    }

    /// [`Bsdf::roughness`] of the side seen.
    #[inline(always)]
    pub fn roughness(&self) -> f32 {
        self.bsdf.roughness()
    }

    /// [`Bsdf::null_transmission`] of the side `wo` sees.
    pub fn null_transmission(&self, wo: Vec3A) -> Vec3A {
        self.bsdf.null_transmission(self.local(wo))
    }
}
