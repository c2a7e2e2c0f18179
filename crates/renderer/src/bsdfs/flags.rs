//! Lobe flags, as Mitsuba's `BSDFFlags`: which kinds of scattering a BSDF has, and which one a
//! sample came from.

/// A set of lobe kinds: reflection or transmission, each diffuse, glossy or delta.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Default)]
pub struct BsdfFlags(u8);

impl BsdfFlags {
    /// Scattering back to the side the light came from.
    pub const REFLECTION: Self = Self(1);
    /// Scattering through the surface.
    #[allow(
        dead_code,
        reason = "no transmitting model yet; the contract names the flag"
    )]
    pub const TRANSMISSION: Self = Self(2);
    /// A lobe spread over the hemisphere (Lambertian-like).
    pub const DIFFUSE: Self = Self(4);
    /// A lobe of finite, non-zero width.
    pub const GLOSSY: Self = Self(8);
    /// A Dirac delta (perfect mirror or refraction): light sampling cannot hit it.
    pub const DELTA: Self = Self(16);
    /// A pass-through, as Mitsuba's `BSDFFlags::Null`: `null` (alone or as a `mask`'s
    /// transparent part) and a `thindielectric`'s transmission, marked on top of their delta
    /// transmission. The path loops tell a crossing from a scattering by it (Mitsuba's
    /// `valid_ray`); the volumetric path tracer does not count it as a bounce, and its shadow
    /// rays pass such surfaces.
    pub const NULL: Self = Self(32);

    pub const DIFFUSE_REFLECTION: Self = Self::DIFFUSE.union(Self::REFLECTION);
    pub const GLOSSY_REFLECTION: Self = Self::GLOSSY.union(Self::REFLECTION);
    pub const DELTA_REFLECTION: Self = Self::DELTA.union(Self::REFLECTION);
    pub const GLOSSY_TRANSMISSION: Self = Self::GLOSSY.union(Self::TRANSMISSION);
    pub const DELTA_TRANSMISSION: Self = Self::DELTA.union(Self::TRANSMISSION);

    pub const fn union(self, other: Self) -> Self {
        Self(self.0 | other.0)
    }

    /// Whether every flag of `other` is set.
    pub const fn contains(self, other: Self) -> bool {
        self.0 & other.0 == other.0
    }

    /// Whether any flag of `other` is set.
    pub const fn intersects(self, other: Self) -> bool {
        self.0 & other.0 != 0
    }

    /// Whether some lobe is not a delta: light sampling can contribute (Mitsuba's `Smooth`).
    pub const fn has_smooth(self) -> bool {
        self.intersects(Self::DIFFUSE.union(Self::GLOSSY))
    }
}

impl std::ops::BitOr for BsdfFlags {
    type Output = Self;
    fn bitor(self, other: Self) -> Self {
        self.union(other)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn sets() {
        let plastic = BsdfFlags::DELTA_REFLECTION | BsdfFlags::DIFFUSE_REFLECTION;
        assert!(plastic.contains(BsdfFlags::DELTA) && plastic.has_smooth());
        assert!(!plastic.intersects(BsdfFlags::TRANSMISSION));
        let glass = BsdfFlags::DELTA | BsdfFlags::TRANSMISSION;
        assert!(!glass.has_smooth() && glass.contains(BsdfFlags::TRANSMISSION));
    }
}
