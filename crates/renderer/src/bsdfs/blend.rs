//! Mitsuba's `blendbsdf`: a linear mix (1 − w) f₀ + w f₁ of two BSDFs, the weight a float or a
//! texture. The children are resolved where they are used (their textures are looked up again
//! at each call), so a blend adds no per-hit storage.

use super::{Bsdf, BsdfFlags, BsdfParams, BsdfSample};
use crate::textures::{FloatSource, TextureQuery};
use glam::{Vec2, Vec3A};

/// The material's parameters: the weight and the two children.
#[derive(Clone, Debug)]
pub struct BlendParams {
    pub weight: FloatSource,
    pub children: Box<[BsdfParams; 2]>,
}

impl BlendParams {
    #[inline]
    pub fn resolve<'a>(&'a self, q: &TextureQuery<'a>) -> Blend<'a> {
        Blend {
            weight: q.float(self.weight).clamp(0.0, 1.0),
            children: &self.children,
            q: *q,
        }
    }

    pub fn is_textured(&self) -> bool {
        self.weight.is_textured() || self.children.iter().any(|c| c.is_textured())
    }
}

/// A blend at a hit.
#[derive(Clone, Copy)]
pub struct Blend<'a> {
    pub weight: f32,
    pub children: &'a [BsdfParams; 2],
    pub q: TextureQuery<'a>,
}

impl std::fmt::Debug for Blend<'_> {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("Blend")
            .field("weight", &self.weight)
            .field("children", &self.children)
            .finish()
    }
}

impl PartialEq for Blend<'_> {
    fn eq(&self, other: &Self) -> bool {
        self.weight == other.weight && std::ptr::eq(self.children, other.children)
    }
}

impl<'a> Blend<'a> {
    #[inline]
    fn child(&self, i: usize) -> Bsdf<'a> {
        self.children[i].resolve(&self.q)
    }

    pub fn flags(&self) -> BsdfFlags {
        self.child(0).flags() | self.child(1).flags()
    }

    pub fn eval(&self, wo: Vec3A, wi: Vec3A) -> Vec3A {
        let w = self.weight;
        let mut f = Vec3A::ZERO;
        if w < 1.0 {
            f += self.child(0).eval(wo, wi) * (1.0 - w);
        }
        if w > 0.0 {
            f += self.child(1).eval(wo, wi) * w;
        }
        f
    }

    pub fn pdf(&self, wo: Vec3A, wi: Vec3A) -> f32 {
        let w = self.weight;
        let mut p = 0.0;
        if w < 1.0 {
            p += self.child(0).pdf(wo, wi) * (1.0 - w);
        }
        if w > 0.0 {
            p += self.child(1).pdf(wo, wi) * w;
        }
        p
    }

    /// Picks a child with probability 1 − w / w (`u_lobe` rescaled for its own lobe choice). A
    /// delta sample keeps the child's weight (its selection probability cancels the mix
    /// weight); a smooth one is weighted by the mixture's eval over the mixture's pdf, so that
    /// it agrees with light sampling's MIS.
    pub fn sample(&self, wo: Vec3A, u: Vec2, u_lobe: f32) -> Option<BsdfSample> {
        let w = self.weight;
        let (i, u_child) = if u_lobe < w {
            (1, u_lobe / w)
        } else {
            (0, ((u_lobe - w) / (1.0 - w)).min(1.0 - f32::EPSILON))
        };
        let s = self.child(i).sample(wo, u, u_child)?;
        if s.is_delta() {
            return Some(s);
        }
        let pdf = self.pdf(wo, s.wi);
        if !(pdf > 0.0) {
            return None;
        }
        Some(BsdfSample {
            weight: self.eval(wo, s.wi) / pdf,
            pdf,
            ..s
        })
    }

    /// The mix of the children's straight-through transmission (a `mask`: 1 − opacity of it).
    pub fn null_transmission(&self, wo: Vec3A) -> Vec3A {
        let w = self.weight;
        self.child(0).null_transmission(wo) * (1.0 - w) + self.child(1).null_transmission(wo) * w
    }

    pub fn roughness(&self) -> f32 {
        self.child(0).roughness().max(self.child(1).roughness())
    }
}
