//! Statistical tests of Mitsuba's models over the whole sphere (reflection and transmission):
//! chi-square of sampled directions against `pdf`, sample weights against eval/pdf, the pdf's
//! mass against the acceptance rate, the sampled albedo against quadrature, white-furnace
//! energy checks and reciprocity.

use super::microfacet::Microfacet;
use super::*;
use crate::sampling::testutil::{chi2_test, gauss_2d, Rng};
use std::f64::consts::PI;

pub(super) const GOLD_ETA: Vec3A = Vec3A::new(0.143036, 0.375307, 1.44205);
pub(super) const GOLD_K: Vec3A = Vec3A::new(3.983, 2.38556, 1.60336);

pub(super) fn rough_conductor(
    kind: MicrofacetKind,
    au: f32,
    av: f32,
    eta: Vec3A,
    k: Vec3A,
) -> Bsdf<'static> {
    Bsdf::RoughConductor(RoughConductor {
        distr: Microfacet::new(kind, au, av),
        eta,
        k,
        specular_reflectance: Vec3A::ONE,
    })
}

pub(super) fn rough_dielectric(kind: MicrofacetKind, au: f32, av: f32, eta: f32) -> Bsdf<'static> {
    Bsdf::RoughDielectric(RoughDielectric {
        distr: Microfacet::new(kind, au, av),
        eta,
        specular_reflectance: Vec3A::ONE,
        specular_transmittance: Vec3A::ONE,
    })
}

pub(super) fn smooth_plastic(d: Vec3A, eta: f32, nonlinear: bool) -> Bsdf<'static> {
    let p = SmoothPlasticParams {
        diffuse_reflectance: crate::textures::ColorSource::Constant(d),
        specular_reflectance: crate::textures::ColorSource::Constant(Vec3A::ONE),
        eta,
        nonlinear,
        specular_sampling_weight: 1.0 / (1.0 + d.element_sum() / 3.0),
    };
    Bsdf::SmoothPlastic(p.resolve(&no_textures()))
}

fn no_textures() -> crate::textures::TextureQuery<'static> {
    crate::textures::TextureQuery {
        textures: &[],
        at: None,
        uv: Vec2::ZERO,
        footprint: torrey_texture::Footprint::POINT,
    }
}

/// `b` (a rough conductor, dielectric or plastic) sampling D(m) cos θm instead of the visible
/// normals (Mitsuba's `sample_visible = false`).
fn all_normals(b: Bsdf<'static>) -> Bsdf<'static> {
    match b {
        Bsdf::RoughConductor(mut c) => {
            c.distr.visible = false;
            Bsdf::RoughConductor(c)
        }
        Bsdf::RoughDielectric(mut d) => {
            d.distr.visible = false;
            Bsdf::RoughDielectric(d)
        }
        Bsdf::RoughPlastic(p) => {
            let mut params = *p.params;
            params.distr.visible = false;
            let params: &'static RoughPlasticParams = Box::leak(Box::new(params));
            Bsdf::RoughPlastic(params.resolve(&no_textures()))
        }
        other => panic!("no microfacet distribution in {other:?}"),
    }
}

/// Rough plastic parameters live as long as the test (leaked: a few hundred bytes).
pub(super) fn rough_plastic(kind: MicrofacetKind, alpha: f32, d: Vec3A, eta: f32) -> Bsdf<'static> {
    use crate::textures::ColorSource::Constant;
    let p: &'static RoughPlasticParams = Box::leak(Box::new(RoughPlasticParams::new(
        Constant(d),
        Constant(Vec3A::ONE),
        kind,
        alpha,
        eta,
        false,
    )));
    Bsdf::RoughPlastic(p.resolve(&no_textures()))
}

/// A blend (leaked, as [`rough_plastic`]) of two parameter sets with a constant weight.
fn blend(weight: f32, a: BsdfParams, b: BsdfParams) -> Bsdf<'static> {
    let p: &'static BlendParams = Box::leak(Box::new(BlendParams {
        weight: crate::textures::FloatSource::Constant(weight),
        children: Box::new([a, b]),
    }));
    Bsdf::Blend(p.resolve(&no_textures()))
}

fn blend_models() -> [Bsdf<'static>; 2] {
    use crate::textures::{ColorSource::Constant, FloatSource};
    let conductor = BsdfParams::RoughConductor(RoughConductorParams {
        kind: MicrofacetKind::Ggx,
        alpha_u: FloatSource::Constant(0.3),
        alpha_v: FloatSource::Constant(0.3),
        sample_visible: true,
        eta: Constant(GOLD_ETA),
        k: Constant(GOLD_K),
        specular_reflectance: Constant(Vec3A::ONE),
    });
    let plastic = BsdfParams::SmoothPlastic(SmoothPlasticParams {
        diffuse_reflectance: Constant(Vec3A::new(0.8, 0.5, 0.2)),
        specular_reflectance: Constant(Vec3A::ONE),
        eta: 1.49,
        nonlinear: false,
        specular_sampling_weight: 0.6,
    });
    let glass = BsdfParams::RoughDielectric(RoughDielectricParams {
        kind: MicrofacetKind::Beckmann,
        alpha_u: FloatSource::Constant(0.3),
        alpha_v: FloatSource::Constant(0.3),
        sample_visible: false,
        eta: 1.5,
        specular_reflectance: Constant(Vec3A::ONE),
        specular_transmittance: Constant(Vec3A::ONE),
    });
    let diffuse = BsdfParams::Diffuse(DiffuseParams {
        reflectance: Constant(Vec3A::splat(0.7)),
    });
    [blend(0.4, conductor, plastic), blend(0.7, glass, diffuse)]
}

/// A direction at `deg` from +z (beyond 90°: below the surface) at an arbitrary azimuth.
pub(super) fn dir_at(deg: f32) -> Vec3A {
    let t = deg.to_radians();
    let phi = 0.7f32;
    Vec3A::new(t.sin() * phi.cos(), t.sin() * phi.sin(), t.cos())
}

/// The non-delta models under test, each with the viewing angles to test it from.
pub(super) fn glossy_models() -> Vec<(&'static str, Bsdf<'static>, Vec<f32>)> {
    use MicrofacetKind::{Beckmann, Ggx};
    let front = vec![0.0, 40.0, 80.0];
    let both = vec![0.0, 40.0, 80.0, 100.0, 150.0, 180.0];
    vec![
        (
            "roughconductor beckmann 0.2",
            rough_conductor(Beckmann, 0.2, 0.2, GOLD_ETA, GOLD_K),
            front.clone(),
        ),
        (
            "roughconductor ggx 0.3",
            rough_conductor(Ggx, 0.3, 0.3, GOLD_ETA, GOLD_K),
            front.clone(),
        ),
        (
            "roughconductor ggx 0.15/0.45",
            rough_conductor(Ggx, 0.15, 0.45, GOLD_ETA, GOLD_K),
            front.clone(),
        ),
        (
            "roughconductor beckmann 0.5/0.2",
            rough_conductor(Beckmann, 0.5, 0.2, GOLD_ETA, GOLD_K),
            front.clone(),
        ),
        (
            "roughdielectric beckmann 0.3",
            rough_dielectric(Beckmann, 0.3, 0.3, 1.5),
            both.clone(),
        ),
        (
            "roughdielectric ggx 0.2",
            rough_dielectric(Ggx, 0.2, 0.2, 1.5),
            both.clone(),
        ),
        (
            "roughdielectric ggx 0.2/0.5 water",
            rough_dielectric(Ggx, 0.2, 0.5, 1.333),
            both.clone(),
        ),
        (
            "roughdielectric beckmann 0.6 eta<1",
            rough_dielectric(Beckmann, 0.6, 0.6, 1.0 / 1.4),
            both.clone(),
        ),
        (
            "plastic",
            smooth_plastic(Vec3A::new(0.8, 0.5, 0.2), 1.49, false),
            front.clone(),
        ),
        (
            "plastic nonlinear",
            smooth_plastic(Vec3A::new(0.8, 0.5, 0.2), 1.49, true),
            front.clone(),
        ),
        (
            "roughplastic beckmann 0.3",
            rough_plastic(Beckmann, 0.3, Vec3A::new(0.8, 0.5, 0.2), 1.49),
            front.clone(),
        ),
        (
            "roughplastic ggx 0.2",
            rough_plastic(Ggx, 0.2, Vec3A::new(0.2, 0.5, 0.8), 1.5),
            front.clone(),
        ),
        (
            "roughconductor beckmann 0.5/0.2, sample_visible false",
            all_normals(rough_conductor(Beckmann, 0.5, 0.2, GOLD_ETA, GOLD_K)),
            front.clone(),
        ),
        (
            "roughconductor ggx 0.3, sample_visible false",
            all_normals(rough_conductor(Ggx, 0.3, 0.3, GOLD_ETA, GOLD_K)),
            front.clone(),
        ),
        (
            "roughdielectric beckmann 0.3, sample_visible false",
            all_normals(rough_dielectric(Beckmann, 0.3, 0.3, 1.5)),
            both.clone(),
        ),
        (
            "roughdielectric ggx 0.2/0.5, sample_visible false",
            all_normals(rough_dielectric(Ggx, 0.2, 0.5, 1.333)),
            both.clone(),
        ),
        (
            "roughplastic ggx 0.2, sample_visible false",
            all_normals(rough_plastic(Ggx, 0.2, Vec3A::new(0.2, 0.5, 0.8), 1.5)),
            front.clone(),
        ),
        ("blend roughconductor/plastic", blend_models()[0], front),
        (
            "blend roughdielectric/diffuse",
            blend_models()[1],
            vec![0.0, 40.0, 80.0, 100.0, 150.0],
        ),
    ]
}

/// A blend with a delta child: its delta samples keep the child's weight, its smooth ones the
/// mixture's; in a white furnace the expected weight is (1 − w)·1 + w·ρ exactly.
#[test]
fn blend_with_a_delta_child_conserves_its_parts() {
    use crate::textures::ColorSource::Constant;
    let glass = BsdfParams::Dielectric(DielectricParams {
        eta: 1.5,
        specular_reflectance: Constant(Vec3A::ONE),
        specular_transmittance: Constant(Vec3A::ONE),
    });
    let diffuse = BsdfParams::Diffuse(DiffuseParams {
        reflectance: Constant(Vec3A::splat(0.5)),
    });
    let b = blend(0.5, glass, diffuse);
    let s = draw("blend dielectric/diffuse", &b, dir_at(40.0), 200_000, 31);
    // Delta samples (the glass half) return weight·η² = 1, the diffuse half 0.5.
    assert!(
        (s.mean_eta_weight - 0.75).abs() < 4.0 * s.stderr + 1e-3,
        "{} ± {}",
        s.mean_eta_weight,
        s.stderr
    );
}

pub(super) struct Drawn {
    /// Accepted non-delta sample directions; None for rejected or delta samples.
    pub(super) dirs: Vec<Option<Vec3A>>,
    /// Mean sample weight (all samples, rejected ones counting 0).
    pub(super) mean_weight: glam::DVec3,
    /// Mean of weight·η² (what a white furnace conserves through refraction).
    pub(super) mean_eta_weight: f64,
    pub(super) stderr: f64,
    pub(super) accepted: f64,
}

/// Draws `n` samples, checking each one's bookkeeping: unit direction, finite non-negative
/// weight, lobe flags matching the side of `wi`, η = 1 for reflections, and for non-delta
/// samples the returned pdf equal to `pdf()` and the weight equal to eval/pdf.
pub(super) fn draw(name: &str, b: &Bsdf, wo: Vec3A, n: usize, seed: u64) -> Drawn {
    let mut rng = Rng::new(seed);
    let mut dirs = Vec::with_capacity(n);
    let (mut sum, mut sum_eta, mut sum2, mut accepted) = (glam::DVec3::ZERO, 0.0, 0.0, 0usize);
    for _ in 0..n {
        let (u, u_lobe) = (rng.vec2(), rng.f32());
        let Some(s) = b.sample(wo, u, u_lobe) else {
            dirs.push(None);
            continue;
        };
        assert!((s.wi.length() - 1.0).abs() < 1e-3, "{name} {s:?}");
        assert!(
            s.weight.is_finite() && s.weight.min_element() >= 0.0,
            "{name} {s:?}"
        );
        let transmitted = s.wi.z * wo.z < 0.0;
        assert_eq!(
            transmitted,
            s.lobe.contains(BsdfFlags::TRANSMISSION),
            "{name}: lobe flags {:?} for wo {wo} wi {}",
            s.lobe,
            s.wi
        );
        if !transmitted {
            assert_eq!(s.eta, 1.0, "{name}");
        }
        sum += s.weight.as_dvec3();
        let ew = (s.weight.x * s.eta * s.eta) as f64;
        sum_eta += ew;
        sum2 += ew * ew;
        if s.is_delta() {
            assert!(s.pdf.is_infinite(), "{name}");
            dirs.push(None);
            continue;
        }
        accepted += 1;
        let pdf = b.pdf(wo, s.wi);
        assert!(
            (s.pdf - pdf).abs() <= 2e-3 * pdf,
            "{name} wo {wo} wi {}: sample pdf {} vs pdf() {pdf}",
            s.wi,
            s.pdf
        );
        let expected = b.eval(wo, s.wi) / pdf;
        assert!(
            (s.weight - expected).abs().max_element() <= 2e-3 * expected.max_element() + 1e-6,
            "{name} wo {wo} wi {}: weight {} vs eval/pdf {expected}",
            s.wi,
            s.weight
        );
        dirs.push(Some(s.wi));
    }
    let mean_eta = sum_eta / n as f64;
    Drawn {
        dirs,
        mean_weight: sum / n as f64,
        mean_eta_weight: mean_eta,
        stderr: ((sum2 / n as f64 - mean_eta * mean_eta).max(0.0) / n as f64).sqrt(),
        accepted: accepted as f64 / n as f64,
    }
}

/// Chi-square test of directions against `pdf` on a (θ, φ) grid over the whole sphere, about
/// +z: `KT` θ bins and `KP` φ bins, each cell's expectation the pdf integrated over it; rejected
/// and delta samples form one extra cell expecting the pdf's missing mass. Returns the p-value.
pub(super) fn chi2_sphere(dirs: &[Option<Vec3A>], pdf: impl Fn(Vec3A) -> f64, what: &str) -> f64 {
    const KT: usize = 60;
    const KP: usize = 30;
    let n = dirs.len() as f64;
    let mut observed = vec![0.0; KT * KP + 1];
    for d in dirs {
        let Some(w) = d else {
            observed[KT * KP] += 1.0;
            continue;
        };
        let l = w.as_dvec3();
        let theta = l.x.hypot(l.y).atan2(l.z);
        let phi = (l.y.atan2(l.x) - 0.7).rem_euclid(2.0 * PI);
        let it = ((theta / PI * KT as f64) as usize).min(KT - 1);
        let ip = ((phi / (2.0 * PI) * KP as f64) as usize).min(KP - 1);
        observed[it * KP + ip] += 1.0;
    }
    // φ measured from the viewing azimuth (0.7 rad) so lobes sit across bin edges the same way
    // whatever the angle.
    let mut integrand = |theta: f64, phi: f64| {
        let (st, ct) = theta.sin_cos();
        let (sp, cp) = (phi + 0.7).sin_cos();
        let w = Vec3A::new((st * cp) as f32, (st * sp) as f32, ct as f32);
        pdf(w) * st
    };
    let mut expected = vec![0.0; KT * KP + 1];
    let mut total = 0.0;
    for it in 0..KT {
        for ip in 0..KP {
            let t = (PI * it as f64 / KT as f64, PI * (it + 1) as f64 / KT as f64);
            let p = (
                2.0 * PI * ip as f64 / KP as f64,
                2.0 * PI * (ip + 1) as f64 / KP as f64,
            );
            // The horizon (θ = 90°, a bin edge) is where transmission lobes jump: finer there.
            let m = if it + 1 == KT / 2 || it == KT / 2 {
                8
            } else {
                4
            };
            let mass = gauss_2d(&mut integrand, t, p, m);
            total += mass;
            expected[it * KP + ip] = n * mass;
        }
    }
    expected[KT * KP] = n * (1.0 - total).max(0.0);
    match chi2_test(&observed, &expected) {
        Ok((p, _, _)) => p,
        Err(e) => panic!("{what}: {e}"),
    }
}

#[test]
fn sampling_matches_pdf_over_the_sphere() {
    let mut seed = 1000;
    for (name, b, angles) in glossy_models() {
        for deg in angles {
            seed += 1;
            let wo = dir_at(deg);
            let s = draw(name, &b, wo, 200_000, seed);
            let what = format!("{name} at {deg}°");
            let p = chi2_sphere(&s.dirs, |w| b.pdf(wo, w) as f64, &what);
            eprintln!("chi2 {what}: p = {p:.4}, accepted {:.4}", s.accepted);
            assert!(p > 1e-3, "{what}: chi-square p = {p}");
        }
    }
}

#[test]
fn chi2_catches_a_wrong_visible_normal_pdf() {
    // Sampling GGX α = 0.3 visible normals but testing against α = 0.33 must fail.
    let b = rough_conductor(MicrofacetKind::Ggx, 0.3, 0.3, GOLD_ETA, GOLD_K);
    let wrong = rough_conductor(MicrofacetKind::Ggx, 0.33, 0.33, GOLD_ETA, GOLD_K);
    let wo = dir_at(40.0);
    let s = draw("ggx", &b, wo, 200_000, 9);
    let p = chi2_sphere(&s.dirs, |w| wrong.pdf(wo, w) as f64, "wrong");
    assert!(p < 1e-3, "p = {p}");
    // Sampling D(m) cos θm (sample_visible false) but testing against the visible normals'
    // pdf must fail, and the other way round.
    let b = rough_conductor(MicrofacetKind::Beckmann, 0.4, 0.4, GOLD_ETA, GOLD_K);
    let all = all_normals(b);
    let wo = dir_at(60.0);
    let s = draw("all", &all, wo, 200_000, 11);
    let p = chi2_sphere(&s.dirs, |w| b.pdf(wo, w) as f64, "visible pdf");
    assert!(p < 1e-3, "p = {p}");
    let s = draw("visible", &b, wo, 200_000, 12);
    let p = chi2_sphere(&s.dirs, |w| all.pdf(wo, w) as f64, "all-normals pdf");
    assert!(p < 1e-3, "p = {p}");
    let wo = dir_at(40.0);
    // A refraction pdf without its Jacobian's dependence on the half vector must fail too.
    let b = rough_dielectric(MicrofacetKind::Beckmann, 0.3, 0.3, 1.5);
    let s = draw("beckmann", &b, wo, 200_000, 10);
    let no_jacobian = |w: Vec3A| {
        let p = b.pdf(wo, w) as f64;
        if w.z < 0.0 {
            p * (1.0 + 0.2 * w.x as f64)
        } else {
            p
        }
    };
    let p = chi2_sphere(&s.dirs, no_jacobian, "wrong");
    assert!(p < 1e-3, "p = {p}");
}

/// ∫ f(ω) dω over the sphere by Gauss-Legendre in (θ, φ), fine enough for lobes compressed
/// near the poles by refraction.
pub(super) fn sphere_quadrature(f: impl Fn(Vec3A) -> f64) -> f64 {
    let mut g = |theta: f64, phi: f64| {
        let (st, ct) = theta.sin_cos();
        let (sp, cp) = phi.sin_cos();
        f(Vec3A::new((st * cp) as f32, (st * sp) as f32, ct as f32)) * st
    };
    gauss_2d(&mut g, (0.0, PI), (0.0, 2.0 * PI), 200)
}

#[test]
fn pdf_mass_and_albedo_match_the_samples() {
    let mut seed = 2000;
    for (name, b, angles) in glossy_models() {
        for deg in angles {
            seed += 1;
            let wo = dir_at(deg);
            let mass = sphere_quadrature(|w| b.pdf(wo, w) as f64);
            let albedo = sphere_quadrature(|w| b.eval(wo, w).x as f64);
            let n = 100_000;
            let s = draw(name, &b, wo, n, seed);
            let sigma = (s.accepted * (1.0 - s.accepted) / n as f64).sqrt();
            eprintln!(
                "{name} at {deg}°: ∫pdf {mass:.4} accepted {:.4}; albedo {albedo:.4} sampled {:.4}",
                s.accepted, s.mean_weight.x
            );
            assert!(
                (mass - s.accepted).abs() < 5.0 * sigma + 5e-3,
                "{name} at {deg}°: ∫pdf = {mass}, accepted {}",
                s.accepted
            );
            // Delta lobes (plastic's coating) are not in the quadrature.
            if !b.flags().contains(BsdfFlags::DELTA) {
                let sampled = s.mean_weight.x;
                assert!(
                    (sampled - albedo).abs() < 0.02 * albedo.max(0.05) + 3e-3,
                    "{name} at {deg}°: sampled albedo {sampled} vs quadrature {albedo}"
                );
            }
        }
    }
}

/// White furnaces: a non-absorbing smooth dielectric, thin dielectric and a conductor of
/// material `none` return all energy (weight·η² = 1 per sample: radiance is scaled by 1/η²
/// entering a denser medium); rough ones lose only what single scattering misses.
#[test]
fn white_furnace() {
    let mut seed = 3000;
    let smooth: [(&str, Bsdf, Vec<f32>); 3] = [
        (
            "dielectric",
            Bsdf::Dielectric(Dielectric {
                eta: 1.5,
                specular_reflectance: Vec3A::ONE,
                specular_transmittance: Vec3A::ONE,
            }),
            vec![0.0, 30.0, 60.0, 89.0, 120.0, 135.0, 150.0, 180.0],
        ),
        (
            "thindielectric",
            Bsdf::ThinDielectric(ThinDielectric {
                eta: 1.5,
                specular_reflectance: Vec3A::ONE,
                specular_transmittance: Vec3A::ONE,
            }),
            vec![0.0, 60.0, 120.0],
        ),
        (
            "conductor none",
            Bsdf::Conductor(Conductor {
                eta: Vec3A::ZERO,
                k: Vec3A::ONE,
                specular_reflectance: Vec3A::ONE,
            }),
            vec![0.0, 45.0, 89.0],
        ),
    ];
    for (name, b, angles) in smooth {
        for deg in angles {
            seed += 1;
            let s = draw(name, &b, dir_at(deg), 20_000, seed);
            assert!(
                (s.mean_eta_weight - 1.0).abs() < 1e-5 && s.stderr < 1e-5,
                "{name} at {deg}°: {}",
                s.mean_eta_weight
            );
        }
    }
    // Total internal reflection: beyond the critical angle inside glass everything reflects.
    let glass = Bsdf::Dielectric(Dielectric {
        eta: 1.5,
        specular_reflectance: Vec3A::ONE,
        specular_transmittance: Vec3A::ONE,
    });
    let wo = dir_at(135.0);
    for u in [0.0, 0.5, 0.999] {
        let s = glass.sample(wo, Vec2::ZERO, u).unwrap();
        assert!(
            s.wi.z < 0.0 && s.lobe == BsdfFlags::DELTA_REFLECTION,
            "{s:?}"
        );
    }
    use MicrofacetKind::{Beckmann, Ggx};
    let rough = [
        (
            "roughdielectric ggx 0.1",
            rough_dielectric(Ggx, 0.1, 0.1, 1.5),
            0.95,
        ),
        (
            "roughdielectric beckmann 0.3",
            rough_dielectric(Beckmann, 0.3, 0.3, 1.5),
            0.9,
        ),
        (
            "roughconductor none ggx 0.1",
            rough_conductor(Ggx, 0.1, 0.1, Vec3A::ZERO, Vec3A::ONE),
            0.95,
        ),
        (
            "roughconductor none beckmann 0.3",
            rough_conductor(Beckmann, 0.3, 0.3, Vec3A::ZERO, Vec3A::ONE),
            0.9,
        ),
    ];
    for (name, b, min) in rough {
        for deg in [0.0, 30.0, 60.0, 150.0] {
            if deg > 90.0
                && b.flags().contains(BsdfFlags::REFLECTION)
                && !b.flags().contains(BsdfFlags::TRANSMISSION)
            {
                continue;
            }
            seed += 1;
            let s = draw(name, &b, dir_at(deg), 100_000, seed);
            eprintln!(
                "furnace {name} at {deg}°: {:.4} ± {:.4}",
                s.mean_eta_weight, s.stderr
            );
            assert!(
                s.mean_eta_weight < 1.0 + 4.0 * s.stderr + 1e-3 && s.mean_eta_weight > min,
                "{name} at {deg}°: {} ± {}",
                s.mean_eta_weight,
                s.stderr
            );
        }
    }
}
