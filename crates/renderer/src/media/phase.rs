//! Phase functions, Mitsuba 3's: `isotropic`, `hg` (Henyey-Greenstein), `rayleigh`, and
//! `blendphase`. Directions are propagation directions: `d_in` travels towards the scattering
//! point, `d_out` away from it; the angle between them is 0 for forward scattering (so `hg`
//! with g > 0 scatters forward, as in Mitsuba). Every phase function is normalised over the
//! sphere, sampled exactly (value = pdf, weight 1).

use crate::sampling::Frame;
use glam::{Vec2, Vec3A};
use std::f32::consts::PI;
use torrey_parser as desc;

const INV_4PI: f32 = 0.25 / PI;

#[derive(Clone, Debug, PartialEq)]
pub enum PhaseFunction {
    Isotropic,
    Hg(f32),
    Rayleigh,
    /// (1 - weight) · first + weight · second.
    Blend(f32, Box<[PhaseFunction; 2]>),
}

impl PhaseFunction {
    pub fn from_desc(p: &desc::Phase) -> Self {
        match p {
            desc::Phase::Isotropic => PhaseFunction::Isotropic,
            desc::Phase::Hg(g) => PhaseFunction::Hg(*g),
            desc::Phase::Rayleigh => PhaseFunction::Rayleigh,
            desc::Phase::Blend(w, a, b) => {
                PhaseFunction::Blend(*w, Box::new([Self::from_desc(a), Self::from_desc(b)]))
            }
        }
    }

    /// The density (per steradian) of scattering from `d_in` into `d_out`.
    pub fn eval(&self, d_in: Vec3A, d_out: Vec3A) -> f32 {
        self.eval_cos(d_in.dot(d_out).clamp(-1.0, 1.0))
    }

    fn eval_cos(&self, cos: f32) -> f32 {
        match self {
            PhaseFunction::Isotropic => INV_4PI,
            PhaseFunction::Hg(g) => {
                let denom = 1.0 + g * g - 2.0 * g * cos;
                INV_4PI * (1.0 - g * g) / (denom * denom.max(0.0).sqrt())
            }
            PhaseFunction::Rayleigh => 3.0 / (16.0 * PI) * (1.0 + cos * cos),
            PhaseFunction::Blend(w, p) => (1.0 - w) * p[0].eval_cos(cos) + w * p[1].eval_cos(cos),
        }
    }

    /// A direction scattered from `d_in` and its density: `u` places it, `u_lobe` chooses the
    /// component of a blend.
    pub fn sample(&self, d_in: Vec3A, u: Vec2, u_lobe: f32) -> (Vec3A, f32) {
        let cos = self.sample_cos(u.x, u_lobe);
        let sin = (1.0 - cos * cos).max(0.0).sqrt();
        let (sin_phi, cos_phi) = (2.0 * PI * u.y).sin_cos();
        let local = Vec3A::new(sin * cos_phi, sin * sin_phi, cos);
        let d_out = Frame::from_normal(d_in).to_world(local).normalize();
        // The density at the sampled cosine (what eval of d_out gives, to rounding).
        (d_out, self.eval_cos(cos))
    }

    /// The cosine to `d_in` of a sampled direction (its azimuth is uniform for every model).
    fn sample_cos(&self, u: f32, u_lobe: f32) -> f32 {
        match self {
            PhaseFunction::Isotropic => 1.0 - 2.0 * u,
            PhaseFunction::Hg(g) => {
                let g = *g;
                if g.abs() < 1e-3 {
                    return 1.0 - 2.0 * u;
                }
                let s = (1.0 - g * g) / (1.0 - g + 2.0 * g * u);
                ((1.0 + g * g - s * s) / (2.0 * g)).clamp(-1.0, 1.0)
            }
            PhaseFunction::Rayleigh => {
                // The cdf (3/8)(μ + μ³/3) + 1/2 inverted: μ³ + 3μ = 2z with z = 4u − 2
                // (Cardano; one real root).
                let z = 4.0 * u - 2.0;
                let r = (z * z + 1.0).sqrt();
                ((z + r).cbrt() + (z - r).cbrt()).clamp(-1.0, 1.0)
            }
            PhaseFunction::Blend(w, p) => {
                if u_lobe < *w {
                    p[1].sample_cos(u, u_lobe / w)
                } else {
                    p[0].sample_cos(u, ((u_lobe - w) / (1.0 - w)).min(1.0 - f32::EPSILON))
                }
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use torrey_testkit::{assert_chi_square, Rng};

    fn models() -> Vec<(&'static str, PhaseFunction)> {
        vec![
            ("isotropic", PhaseFunction::Isotropic),
            ("hg +0.7", PhaseFunction::Hg(0.7)),
            ("hg -0.5", PhaseFunction::Hg(-0.5)),
            ("hg 0.0005", PhaseFunction::Hg(0.0005)),
            ("rayleigh", PhaseFunction::Rayleigh),
            (
                "blend",
                PhaseFunction::Blend(
                    0.3,
                    Box::new([PhaseFunction::Hg(0.8), PhaseFunction::Rayleigh]),
                ),
            ),
        ]
    }

    /// Each model integrates to one over the sphere (midpoint rule in cos and azimuth).
    #[test]
    fn phase_functions_are_normalised() {
        for (name, p) in models() {
            let n = 4000;
            let sum: f64 = (0..n)
                .map(|i| p.eval_cos(-1.0 + 2.0 * (i as f32 + 0.5) / n as f32) as f64)
                .sum();
            let integral = sum * 2.0 / n as f64 * 2.0 * std::f64::consts::PI;
            assert!((integral - 1.0).abs() < 2e-3, "{name}: {integral}");
        }
    }

    /// Chi-square of sampled directions against the pdf, binned in (cos θ, φ) around a tilted
    /// incoming direction; the returned density must be `eval`'s.
    #[test]
    fn sampling_matches_the_pdf() {
        let d_in = Vec3A::new(0.3, -0.5, 0.8).normalize();
        let frame = Frame::from_normal(d_in);
        let (nc, np) = (20usize, 8usize);
        for (name, p) in models() {
            let mut rng = Rng::new(7);
            let samples = 200_000;
            let mut observed = vec![0.0f64; nc * np];
            for _ in 0..samples {
                let (d, pdf) = p.sample(d_in, rng.vec2(), rng.f32());
                assert!(
                    (pdf - p.eval(d_in, d)).abs() <= 1e-4 * pdf.max(1.0),
                    "{name}"
                );
                let l = frame.to_local(d);
                let c = (((l.z + 1.0) * 0.5 * nc as f32) as usize).min(nc - 1);
                let phi = l.y.atan2(l.x).rem_euclid(2.0 * PI);
                let k = ((phi / (2.0 * PI) * np as f32) as usize).min(np - 1);
                observed[c * np + k] += 1.0;
            }
            let mut expected = vec![0.0f64; nc * np];
            for c in 0..nc {
                // The bin's mass: the midpoint rule on 256 pieces of its cos range, times 2π.
                let a = -1.0 + 2.0 * c as f64 / nc as f64;
                let h = 2.0 / nc as f64 / 256.0;
                let f = |x: f64| p.eval_cos(x as f32) as f64;
                let mass: f64 = (0..256)
                    .map(|i| f(a + (i as f64 + 0.5) * h) * h)
                    .sum::<f64>()
                    * 2.0
                    * std::f64::consts::PI;
                for k in 0..np {
                    expected[c * np + k] = mass / np as f64 * samples as f64;
                }
            }
            assert_chi_square(name, &observed, &expected);
        }
    }
}
