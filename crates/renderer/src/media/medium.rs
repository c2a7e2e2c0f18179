//! One participating medium: where a path's next interaction in it is, and the transmittance of
//! a segment through it.
//!
//! Both estimators are unbiased for every colour channel at once, whatever the extinction's
//! colour, so their expectation is Mitsuba's (`volpath` and `volpathmis` differ only in noise):
//!
//! - Homogeneous: a distance is drawn from one channel's exponential, the channel chosen in
//!   proportion to the path's throughput, and weighted by the mixture of the three channels'
//!   densities (one-sample spectral MIS, the balance heuristic). For a grey medium the weight
//!   is the albedo at a scattering event and one past the segment, exactly Mitsuba's (computed
//!   so, without exponentials). The transmittance of a shadow segment is exp(−σt d), exactly
//!   (Mitsuba ratio-tracks it: its estimate is 0 or 1 per shadow ray).
//! - Heterogeneous ([`GridDensity`]): delta tracking against the majorant grid's local majorant
//!   μ (one scalar for all channels), with Kutz et al.'s spectral tracking at each tentative
//!   collision: a real event with probability P = ⟨w σt⟩ / (⟨w σt⟩ + ⟨w σn⟩) (⟨⟩ the channel
//!   mean, w the throughput, σn = μ − σt), weighted σs / (μ P), else a null event weighted
//!   σn / (μ (1 − P)). For a grey medium this is Mitsuba's delta tracking with albedo
//!   weighting. Shadow segments use residual ratio tracking against the cells' minorants.

use super::grid::Grid;
use super::phase::PhaseFunction;
use super::tracking::GridDensity;
use glam::{Vec2, Vec3A};
use torrey_parser as desc;

/// A volume field: constant or a grid.
#[derive(Clone, Debug)]
pub(super) enum Field {
    Constant(Vec3A),
    Grid(Box<Grid>),
}

impl Field {
    fn from_desc(v: &desc::Volume) -> Self {
        match v {
            desc::Volume::Constant(c) => Field::Constant((*c).into()),
            desc::Volume::Grid(g) => Field::Grid(Box::new(Grid::from_desc(g))),
        }
    }

    #[inline]
    pub(super) fn eval(&self, p: Vec3A) -> Vec3A {
        match self {
            Field::Constant(c) => *c,
            Field::Grid(g) => g.eval(p),
        }
    }
}

/// The extinction of a medium, `scale` applied.
#[derive(Clone, Debug)]
enum Density {
    Homogeneous(Vec3A),
    Grid(Box<GridDensity>),
}

#[derive(Clone, Debug)]
pub struct Medium {
    density: Density,
    albedo: Field,
    pub phase: PhaseFunction,
    pub sample_emitters: bool,
}

/// Where a path's free flight ended.
pub enum Flight {
    /// A real scattering event at this distance (the throughput already weighted).
    Scatter(f32),
    /// Past the segment's end (the throughput weighted by the transmittance estimate).
    Pass,
}

impl Medium {
    pub fn from_desc(m: &desc::Medium) -> Self {
        let density = match &m.sigma_t {
            desc::Volume::Constant(c) => Density::Homogeneous(Vec3A::from(*c) * m.scale),
            desc::Volume::Grid(g) => {
                Density::Grid(Box::new(GridDensity::new(Grid::from_desc(g), m.scale)))
            }
        };
        Medium {
            density,
            albedo: Field::from_desc(&m.albedo),
            phase: PhaseFunction::from_desc(&m.phase),
            sample_emitters: m.sample_emitters,
        }
    }

    /// In a homogeneous medium, the tentative free-flight distance of a path with `throughput`,
    /// drawn before its ray is traced so that the ray need only be traced that far (a dense
    /// medium's short rays stop early, as Mitsuba traces them); [`Medium::sample`] then weighs
    /// it. `u`: the channel's number (x) and the distance's (y). None in a grid medium (its
    /// flights are drawn along the traced segment).
    pub fn draw_distance(&self, throughput: Vec3A, u: Vec2) -> Option<f32> {
        let Density::Homogeneous(sigma) = &self.density else {
            return None;
        };
        let total = throughput.element_sum();
        if !(sigma.max_element() > 0.0 && total > 0.0) {
            return Some(f32::INFINITY);
        }
        // The channel, in proportion to the throughput.
        let pick = u.x * total;
        let c = if pick < throughput.x {
            0
        } else if pick < throughput.x + throughput.y {
            1
        } else {
            2
        };
        Some(if sigma[c] > 0.0 {
            -(1.0 - u.y).ln() / sigma[c]
        } else {
            f32::INFINITY
        })
    }

    /// Samples the next interaction along `o + t d` for t in [0, `tmax`] (`tmax` may be
    /// infinite), weighting `throughput`; `drawn` is [`Medium::draw_distance`]'s distance (with
    /// the same throughput), `u` draws numbers.
    pub fn sample(
        &self,
        o: Vec3A,
        d: Vec3A,
        tmax: f32,
        drawn: Option<f32>,
        throughput: &mut Vec3A,
        u: &mut impl FnMut() -> f32,
    ) -> Flight {
        match &self.density {
            Density::Homogeneous(sigma) => {
                let t = drawn.unwrap_or_else(|| {
                    self.draw_distance(*throughput, Vec2::new(u(), u()))
                        .expect("homogeneous media draw distances")
                });
                self.weigh_homogeneous(*sigma, o, d, t, tmax, throughput)
            }
            Density::Grid(g) => g.sample(o, d, tmax, &self.albedo, throughput, u),
        }
    }

    /// Weighs a homogeneous medium's drawn distance `t` (a scattering event before `tmax`, else
    /// the segment's end) by the mixture of the channels' densities.
    fn weigh_homogeneous(
        &self,
        sigma: Vec3A,
        o: Vec3A,
        d: Vec3A,
        t: f32,
        tmax: f32,
        throughput: &mut Vec3A,
    ) -> Flight {
        let w = *throughput;
        let total = w.element_sum();
        if !(sigma.max_element() > 0.0 && total > 0.0) {
            return Flight::Pass;
        }
        if sigma.x == sigma.y && sigma.y == sigma.z {
            // Grey: the mixture is the one exponential, whose density cancels the
            // transmittance (no exponentials to evaluate).
            if t < tmax {
                *throughput *= self.albedo.eval(o + d * t);
                return Flight::Scatter(t);
            }
            return Flight::Pass;
        }
        let probs = w / total;
        if t < tmax {
            let tr = (-sigma * t).exp();
            let pdf = (probs * sigma * tr).element_sum();
            let sigma_s = sigma * self.albedo.eval(o + d * t);
            *throughput *= if pdf > 0.0 {
                tr * sigma_s / pdf
            } else {
                Vec3A::ZERO
            };
            return Flight::Scatter(t);
        }
        let tr = (-sigma * tmax).exp();
        let p_pass = (probs * tr).element_sum();
        *throughput *= if p_pass > 0.0 {
            tr / p_pass
        } else {
            Vec3A::ZERO
        };
        Flight::Pass
    }

    /// An unbiased estimate of the transmittance of `o + t d`, t in [0, `tmax`].
    pub fn transmittance(
        &self,
        o: Vec3A,
        d: Vec3A,
        tmax: f32,
        u: &mut impl FnMut() -> f32,
    ) -> Vec3A {
        match &self.density {
            Density::Homogeneous(sigma) => {
                if sigma.max_element() > 0.0 {
                    (-*sigma * tmax).exp()
                } else {
                    Vec3A::ONE
                }
            }
            Density::Grid(g) => g.transmittance(o, d, tmax, u),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use torrey_testkit::Rng;

    fn homogeneous(sigma: Vec3A, albedo: Vec3A) -> Medium {
        Medium {
            density: Density::Homogeneous(sigma),
            albedo: Field::Constant(albedo),
            phase: PhaseFunction::Isotropic,
            sample_emitters: true,
        }
    }

    /// A grey medium skips the exponentials: its weights are the general mixture's (a medium
    /// whose one channel differs by a millionth), at scattering events and past the segment.
    #[test]
    fn grey_weights_are_the_mixtures() {
        let albedo = Vec3A::new(0.85, 0.97, 0.5);
        let grey = homogeneous(Vec3A::splat(3.0), albedo);
        let almost = homogeneous(Vec3A::new(3.0, 3.0, 3.0 * (1.0 + 1e-6)), albedo);
        let mut rng = Rng::new(5);
        for _ in 0..1000 {
            let w = Vec3A::new(rng.f32(), rng.f32(), rng.f32()) + Vec3A::splat(0.01);
            let (t, tmax) = (rng.range(0.0, 2.0), rng.range(0.0, 2.0));
            let (mut a, mut b) = (w, w);
            let fa =
                grey.weigh_homogeneous(Vec3A::splat(3.0), Vec3A::ZERO, Vec3A::X, t, tmax, &mut a);
            let sigma = Vec3A::new(3.0, 3.0, 3.0 * (1.0 + 1e-6));
            let fb = almost.weigh_homogeneous(sigma, Vec3A::ZERO, Vec3A::X, t, tmax, &mut b);
            assert_eq!(matches!(fa, Flight::Pass), matches!(fb, Flight::Pass));
            assert!(
                (a - b).abs().max_element() <= 1e-4 * b.max_element(),
                "{a} vs {b}"
            );
        }
    }

    /// A chromatic slab: the mean weight of passing paths is the transmittance per channel, and
    /// the mean scattered weight integrates σs·T over the slab, for both tracking methods.
    #[test]
    fn free_flights_are_unbiased_per_channel() {
        let sigma = Vec3A::new(0.5, 2.0, 6.0);
        let albedo = Vec3A::new(0.9, 0.5, 0.2);
        let d = 0.7f32;
        let grid = Grid::from_desc(&desc::GridVolume {
            size: [2, 2, 2],
            channels: 3,
            data: (0..8).flat_map(|_| [0.5f32, 2.0, 6.0]).collect(),
            to_local: glam::Mat4::IDENTITY,
            nearest: false,
            max: 6.0,
        });
        let heterogeneous = Medium {
            density: Density::Grid(Box::new(GridDensity::new(grid, 1.0))),
            albedo: Field::Constant(albedo),
            phase: PhaseFunction::Isotropic,
            sample_emitters: true,
        };
        let o = Vec3A::new(0.2, 0.5, 0.5);
        let dir = Vec3A::X;
        for (name, m) in [
            ("homogeneous", homogeneous(sigma, albedo)),
            ("grid", heterogeneous),
        ] {
            let mut rng = Rng::new(11);
            let n = 400_000;
            let (mut pass, mut scatter) = (Vec3A::ZERO, Vec3A::ZERO);
            let mut tr_est = Vec3A::ZERO;
            for _ in 0..n {
                let mut w = Vec3A::ONE;
                match m.sample(o, dir, d, None, &mut w, &mut || rng.f32()) {
                    Flight::Pass => pass += w,
                    Flight::Scatter(_) => scatter += w,
                }
                tr_est += m.transmittance(o, dir, d, &mut || rng.f32());
            }
            let tr = (-sigma * d).exp();
            let scattered = albedo * (Vec3A::ONE - tr);
            for c in 0..3 {
                let check = |what: &str, got: f32, want: f32| {
                    assert!(
                        (got / n as f32 - want).abs() < 0.01,
                        "{name} {what} channel {c}: {} vs {want}",
                        got / n as f32
                    );
                };
                check("passing", pass[c], tr[c]);
                check("scattered", scatter[c], scattered[c]);
                check("transmittance", tr_est[c], tr[c]);
            }
        }
    }
}
