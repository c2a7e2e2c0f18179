//! Mitsuba's `principled` and `principledthin`: eval and pdf against Mitsuba 3.9.1's numbers,
//! sampled directions against `pdf` by chi-square over the whole sphere (reflection and
//! transmission, from outside and inside), sample weights against eval/pdf, the pdf's mass
//! against the acceptance rate and the sampled albedo against quadrature.

use super::tests_mitsuba::{chi2_sphere, draw, sphere_quadrature};
use super::*;
use crate::textures::{ColorSource, FloatSource};

fn no_textures() -> crate::textures::TextureQuery<'static> {
    crate::textures::TextureQuery {
        textures: &[],
        at: None,
        uv: Vec2::ZERO,
        footprint: torrey_texture::Footprint::POINT,
    }
}

/// Parameters of a `principled` (Mitsuba's defaults unless set by `f`).
fn principled_params(base: [f32; 3], f: impl FnOnce(&mut PrincipledParams)) -> PrincipledParams {
    let c = FloatSource::Constant;
    let mut p = PrincipledParams {
        base_color: ColorSource::Constant(Vec3A::from(base)),
        roughness: c(0.5),
        anisotropic: c(0.0),
        metallic: c(0.0),
        spec_trans: c(0.0),
        spec_tint: c(0.0),
        sheen: c(0.0),
        sheen_tint: c(0.0),
        flatness: c(0.0),
        clearcoat: c(0.0),
        clearcoat_gloss: c(0.0),
        eta: specular_to_eta(0.5),
        main_specular_sampling_rate: 1.0,
        clearcoat_sampling_rate: 1.0,
        diffuse_reflectance_sampling_rate: 1.0,
    };
    f(&mut p);
    p
}

fn specular_to_eta(s: f32) -> f32 {
    2.0 / (1.0 - (0.08 * s).sqrt()) - 1.0
}

fn thin_params(base: [f32; 3], f: impl FnOnce(&mut PrincipledThinParams)) -> PrincipledThinParams {
    let c = FloatSource::Constant;
    let mut p = PrincipledThinParams {
        base_color: ColorSource::Constant(Vec3A::from(base)),
        roughness: c(0.5),
        anisotropic: c(0.0),
        spec_trans: c(0.0),
        spec_tint: c(0.0),
        sheen: c(0.0),
        sheen_tint: c(0.0),
        flatness: c(0.0),
        diff_trans: c(0.0),
        eta: c(1.5),
        specular_reflectance_sampling_rate: 1.0,
        specular_transmittance_sampling_rate: 1.0,
        diffuse_reflectance_sampling_rate: 1.0,
        diffuse_transmittance_sampling_rate: 1.0,
    };
    f(&mut p);
    p
}

/// The parameters live as long as the test (leaked: a few hundred bytes).
fn resolve(p: BsdfParams) -> Bsdf<'static> {
    let p: &'static BsdfParams = Box::leak(Box::new(p));
    p.resolve(&no_textures())
}

/// The models of the Mitsuba value table (tests/mitsuba/principled_values.py).
fn mitsuba_model(name: &str) -> Bsdf<'static> {
    let c = FloatSource::Constant;
    resolve(match name {
        "principled_coat" => BsdfParams::Principled(principled_params([0.8, 0.3, 0.2], |p| {
            p.roughness = c(0.4);
            p.metallic = c(0.3);
            p.spec_tint = c(0.5);
            p.sheen = c(0.6);
            p.sheen_tint = c(0.4);
            p.clearcoat = c(0.7);
            p.clearcoat_gloss = c(0.6);
            p.flatness = c(0.3);
            p.eta = specular_to_eta(0.6);
        })),
        "principled_glass" => BsdfParams::Principled(principled_params([0.6, 0.8, 0.9], |p| {
            p.roughness = c(0.3);
            p.spec_trans = c(0.7);
            p.anisotropic = c(0.5);
            p.eta = 1.4;
            p.metallic = c(0.1);
            p.sheen = c(0.3);
        })),
        "principled_metal" => BsdfParams::Principled(principled_params([0.9, 0.6, 0.3], |p| {
            p.roughness = c(0.25);
            p.metallic = c(1.0);
            p.anisotropic = c(0.8);
        })),
        "thin_glossy" => BsdfParams::PrincipledThin(thin_params([0.7, 0.1, 0.1], |p| {
            p.roughness = c(0.15);
            p.spec_tint = c(0.1);
            p.anisotropic = c(0.5);
            p.spec_trans = c(0.8);
            p.diff_trans = c(0.3);
            p.eta = c(1.33);
        })),
        "thin_diffuse" => BsdfParams::PrincipledThin(thin_params([0.3, 0.6, 0.4], |p| {
            p.roughness = c(0.6);
            p.diff_trans = c(1.2);
            p.sheen = c(0.5);
            p.sheen_tint = c(0.5);
            p.flatness = c(0.5);
            p.spec_trans = c(0.3);
        })),
        _ => unreachable!("{name}"),
    })
}

/// eval and pdf of Mitsuba 3.9.1 (`llvm_ad_rgb`, `BSDF.eval`/`BSDF.pdf` with `si.wi` = our
/// wo), directions as (θ degrees, φ radians): (name, wo, wi, eval, pdf).
type MitsubaValue = (&'static str, (f32, f32), (f32, f32), [f32; 3], f32);

#[rustfmt::skip]
const MITSUBA_VALUES: &[MitsubaValue] = &[
    ("principled_coat", (30.0, 0.3), (40.0, 3.5), [7.65492e-01, 3.27798e-01, 2.40259e-01], 1.35948e+00),
    ("principled_coat", (60.0, 0.1), (20.0, 3.0), [2.18394e-01, 8.58466e-02, 5.93371e-02], 2.23227e-01),
    ("principled_coat", (10.0, 1.0), (75.0, 2.0), [4.87086e-02, 1.84965e-02, 1.24541e-02], 3.89642e-02),
    ("principled_coat", (30.0, 0.3), (160.0, 3.3), [0.00000e+00, 0.00000e+00, 0.00000e+00], 0.00000e+00),
    ("principled_coat", (45.0, 0.2), (150.0, 0.4), [0.00000e+00, 0.00000e+00, 0.00000e+00], 0.00000e+00),
    ("principled_coat", (150.0, 0.5), (20.0, 3.9), [0.00000e+00, 0.00000e+00, 0.00000e+00], 0.00000e+00),
    ("principled_coat", (170.0, 0.5), (120.0, 2.0), [0.00000e+00, 0.00000e+00, 0.00000e+00], 2.53953e-02),
    ("principled_coat", (130.0, 2.0), (140.0, 5.0), [0.00000e+00, 0.00000e+00, 0.00000e+00], 2.20488e+00),
    ("principled_coat", (80.0, 0.0), (85.0, 3.0), [1.01856e-01, 7.50049e-02, 6.96346e-02], 1.29425e-01),
    ("principled_glass", (30.0, 0.3), (40.0, 3.5), [3.16615e-01, 3.93230e-01, 4.31538e-01], 1.02635e+00),
    ("principled_glass", (60.0, 0.1), (20.0, 3.0), [6.42647e-02, 8.38942e-02, 9.37089e-02], 1.18239e-01),
    ("principled_glass", (10.0, 1.0), (75.0, 2.0), [1.31759e-02, 1.75526e-02, 1.97410e-02], 1.78879e-02),
    ("principled_glass", (30.0, 0.3), (160.0, 3.3), [1.78026e+00, 2.05567e+00, 2.18036e+00], 3.54869e+00),
    ("principled_glass", (45.0, 0.2), (150.0, 0.4), [0.00000e+00, 0.00000e+00, 0.00000e+00], 0.00000e+00),
    ("principled_glass", (150.0, 0.5), (20.0, 3.9), [5.01260e-02, 5.78805e-02, 6.13916e-02], 5.24243e-02),
    ("principled_glass", (170.0, 0.5), (120.0, 2.0), [6.59364e-05, 6.59364e-05, 6.59364e-05], 1.05148e-04),
    ("principled_glass", (130.0, 2.0), (140.0, 5.0), [7.07097e-01, 7.07097e-01, 7.07097e-01], 1.12342e+00),
    ("principled_glass", (80.0, 0.0), (85.0, 3.0), [1.96724e-02, 2.06724e-02, 2.11724e-02], 1.56283e-02),
    ("principled_metal", (30.0, 0.3), (40.0, 3.5), [1.76176e+00, 1.17463e+00, 5.87506e-01], 1.96173e+00),
    ("principled_metal", (60.0, 0.1), (20.0, 3.0), [1.38420e-01, 9.23140e-02, 4.62078e-02], 1.53859e-01),
    ("principled_metal", (10.0, 1.0), (75.0, 2.0), [1.42294e-04, 9.48723e-05, 4.74510e-05], 1.59908e-04),
    ("principled_metal", (30.0, 0.3), (160.0, 3.3), [0.00000e+00, 0.00000e+00, 0.00000e+00], 0.00000e+00),
    ("principled_metal", (45.0, 0.2), (150.0, 0.4), [0.00000e+00, 0.00000e+00, 0.00000e+00], 0.00000e+00),
    ("principled_metal", (150.0, 0.5), (20.0, 3.9), [0.00000e+00, 0.00000e+00, 0.00000e+00], 0.00000e+00),
    ("principled_metal", (170.0, 0.5), (120.0, 2.0), [0.00000e+00, 0.00000e+00, 0.00000e+00], 3.83116e-04),
    ("principled_metal", (130.0, 2.0), (140.0, 5.0), [0.00000e+00, 0.00000e+00, 0.00000e+00], 1.51182e+00),
    ("principled_metal", (80.0, 0.0), (85.0, 3.0), [1.76519e-03, 1.45614e-03, 1.14709e-03], 2.49414e-03),
    ("thin_glossy", (30.0, 0.3), (40.0, 3.5), [4.51964e-02, 1.70600e-02, 1.70600e-02], 3.50778e-01),
    ("thin_glossy", (60.0, 0.1), (20.0, 3.0), [3.55301e-02, 5.27230e-03, 5.27230e-03], 5.61362e-02),
    ("thin_glossy", (10.0, 1.0), (75.0, 2.0), [9.15152e-03, 1.30841e-03, 1.30841e-03], 1.40362e-02),
    ("thin_glossy", (30.0, 0.3), (160.0, 3.3), [3.30397e-02, 4.71996e-03, 4.71996e-03], 2.84870e-02),
    ("thin_glossy", (45.0, 0.2), (150.0, 0.4), [5.82732e-03, 8.32474e-04, 8.32474e-04], 8.29790e-03),
    ("thin_glossy", (150.0, 0.5), (20.0, 3.9), [5.43206e-02, 7.76009e-03, 7.76009e-03], 4.40058e-02),
    ("thin_glossy", (170.0, 0.5), (120.0, 2.0), [1.87807e-02, 2.68540e-03, 2.68540e-03], 2.71314e-02),
    ("thin_glossy", (130.0, 2.0), (140.0, 5.0), [4.08961e-02, 1.40494e-02, 1.40494e-02], 2.33973e-01),
    ("thin_glossy", (80.0, 0.0), (85.0, 3.0), [2.27642e-03, 6.98311e-04, 6.98311e-04], 5.26493e-03),
    ("thin_diffuse", (30.0, 0.3), (40.0, 3.5), [2.60847e-02, 4.41773e-02, 3.21156e-02], 1.63044e-01),
    ("thin_diffuse", (60.0, 0.1), (20.0, 3.0), [2.81475e-02, 5.16633e-02, 3.59861e-02], 1.34318e-01),
    ("thin_diffuse", (10.0, 1.0), (75.0, 2.0), [7.40997e-03, 1.44124e-02, 9.74410e-03], 2.93509e-02),
    ("thin_diffuse", (30.0, 0.3), (160.0, 3.3), [2.34051e-01, 4.68102e-01, 3.12068e-01], 4.67000e-01),
    ("thin_diffuse", (45.0, 0.2), (150.0, 0.4), [3.60510e-02, 7.21019e-02, 4.80679e-02], 1.18070e-01),
    ("thin_diffuse", (150.0, 0.5), (20.0, 3.9), [2.05166e-01, 4.10332e-01, 2.73555e-01], 4.16779e-01),
    ("thin_diffuse", (170.0, 0.5), (120.0, 2.0), [1.32876e-02, 2.56594e-02, 1.74115e-02], 5.65617e-02),
    ("thin_diffuse", (130.0, 2.0), (140.0, 5.0), [3.09481e-02, 5.03352e-02, 3.74105e-02], 1.85134e-01),
    ("thin_diffuse", (80.0, 0.0), (85.0, 3.0), [2.41984e-02, 2.82938e-02, 2.55635e-02], 5.91168e-02),
];

fn dir(deg: f32, phi: f32) -> Vec3A {
    let t = deg.to_radians();
    Vec3A::new(t.sin() * phi.cos(), t.sin() * phi.sin(), t.cos())
}

#[test]
fn eval_and_pdf_match_mitsuba() {
    let mut failures = Vec::new();
    for &(name, wo, wi, value, pdf) in MITSUBA_VALUES {
        let b = mitsuba_model(name);
        let (wo, wi) = (dir(wo.0, wo.1), dir(wi.0, wi.1));
        let ours = b.eval(wo, wi);
        let theirs = Vec3A::from(value);
        if (ours - theirs).abs().max_element() > 2e-3 * theirs.max_element() + 1e-7 {
            failures.push(format!(
                "{name} eval wo {wo} wi {wi}: ours {ours}, Mitsuba {theirs}"
            ));
        }
        let p = b.pdf(wo, wi);
        if (p - pdf).abs() > 2e-3 * pdf + 1e-7 {
            failures.push(format!(
                "{name} pdf wo {wo} wi {wi}: ours {p}, Mitsuba {pdf}"
            ));
        }
    }
    assert!(failures.is_empty(), "{}", failures.join("\n"));
}

/// Models for the statistical tests (lobes wide enough for the sphere's quadrature grid) and
/// the viewing angles to test them from (beyond 90°: from inside).
fn models() -> Vec<(&'static str, Bsdf<'static>, Vec<f32>)> {
    let c = FloatSource::Constant;
    let front = vec![0.0, 45.0, 80.0];
    let both = vec![0.0, 50.0, 85.0, 100.0, 180.0];
    vec![
        (
            "principled coat",
            mitsuba_model("principled_coat"),
            front.clone(),
        ),
        (
            "principled glass anisotropic",
            resolve(BsdfParams::Principled(principled_params(
                [0.6, 0.8, 0.9],
                |p| {
                    p.roughness = c(0.55);
                    p.spec_trans = c(0.7);
                    p.anisotropic = c(0.6);
                    p.eta = 1.4;
                    p.metallic = c(0.1);
                    p.clearcoat = c(0.5);
                    p.clearcoat_gloss = c(0.2);
                },
            ))),
            both.clone(),
        ),
        (
            "principled spec_trans 1",
            resolve(BsdfParams::Principled(principled_params(
                [0.9, 0.9, 0.9],
                |p| {
                    p.roughness = c(0.5);
                    p.spec_trans = c(1.0);
                    p.sheen = c(0.5);
                },
            ))),
            both.clone(),
        ),
        (
            "principled metal anisotropic",
            resolve(BsdfParams::Principled(principled_params(
                [0.9, 0.6, 0.3],
                |p| {
                    p.roughness = c(0.45);
                    p.metallic = c(1.0);
                    p.anisotropic = c(0.8);
                },
            ))),
            front,
        ),
        (
            "principledthin glossy",
            // Roughness 0.75: the transmission lobe's is scaled by 0.65 η − 0.35 to 0.6 (sharper lobes
            // than that near the horizon are beyond the chi-square grid's quadrature).
            resolve(BsdfParams::PrincipledThin(thin_params(
                [0.7, 0.3, 0.1],
                |p| {
                    p.roughness = c(0.75);
                    p.spec_tint = c(0.3);
                    p.anisotropic = c(0.5);
                    p.spec_trans = c(0.7);
                    p.diff_trans = c(0.6);
                    p.eta = c(1.5);
                },
            ))),
            both.clone(),
        ),
        (
            "principledthin diffuse",
            mitsuba_model("thin_diffuse"),
            both,
        ),
    ]
}

#[test]
fn sampling_matches_pdf_over_the_sphere() {
    let mut seed = 5000;
    for (name, b, angles) in models() {
        for deg in angles {
            seed += 1;
            let wo = dir(deg, 0.7);
            let s = draw(name, &b, wo, 120_000, seed);
            let what = format!("{name} at {deg}°");
            let p = chi2_sphere(&s.dirs, |w| b.pdf(wo, w) as f64, &what);
            eprintln!("chi2 {what}: p = {p:.4}, accepted {:.4}", s.accepted);
            assert!(p > 1e-3, "{what}: chi-square p = {p}");
        }
    }
}

#[test]
fn pdf_mass_and_albedo_match_the_samples() {
    let mut seed = 6000;
    for (name, b, angles) in models() {
        for deg in angles {
            seed += 1;
            let wo = dir(deg, 0.7);
            let mass = sphere_quadrature(|w| b.pdf(wo, w) as f64);
            let albedo = sphere_quadrature(|w| b.eval(wo, w).x as f64);
            let n = 60_000;
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
            let sampled = s.mean_weight.x;
            assert!(
                (sampled - albedo).abs() < 0.02 * albedo.max(0.05) + 3e-3,
                "{name} at {deg}°: sampled albedo {sampled} vs quadrature {albedo}"
            );
        }
    }
}

/// The thin sheet is the same from both sides, and without spec_trans or metal the principled
/// back side is black.
#[test]
fn sidedness() {
    let thin = mitsuba_model("thin_glossy");
    let (wo, wi) = (dir(35.0, 0.4), dir(120.0, 2.5));
    let flip = |w: Vec3A| -w;
    assert!(
        (thin.eval(wo, wi) - thin.eval(flip(wo), flip(wi)))
            .abs()
            .max_element()
            < 1e-6
    );
    assert!((thin.pdf(wo, wi) - thin.pdf(flip(wo), flip(wi))).abs() < 1e-6);
    let coat = mitsuba_model("principled_coat");
    assert_eq!(coat.eval(dir(150.0, 0.1), dir(130.0, 2.0)), Vec3A::ZERO);
    assert!(coat
        .sample(dir(150.0, 0.1), Vec2::new(0.3, 0.6), 0.5)
        .is_none());
}

/// Textured parameters are looked up per hit: a checkerboard metallic switches the lobes.
#[test]
fn textured_metallic_is_resolved_per_hit() {
    let p = principled_params([0.9, 0.6, 0.3], |p| p.metallic = FloatSource::Constant(1.0));
    let q = principled_params([0.9, 0.6, 0.3], |_| {});
    let (a, b) = (
        resolve(BsdfParams::Principled(p)),
        resolve(BsdfParams::Principled(q)),
    );
    let (wo, wi) = (dir(30.0, 0.3), dir(50.0, 2.0));
    // A metal has no diffuse base: away from the specular peak it is much darker.
    assert!(a.eval(wo, wi).x < 0.5 * b.eval(wo, wi).x);
    assert!(BsdfParams::Principled(principled_params([0.5; 3], |p| {
        p.metallic = FloatSource::Texture(0)
    }))
    .is_textured());
}

/// The per-hit principled BSDFs are no larger than the largest other variant (a blend), so
/// adding them left `Bsdf`, copied at every hit of every scene, as large as it was (80 bytes).
#[test]
fn per_hit_size_does_not_grow_bsdf() {
    use std::mem::size_of;
    assert!(size_of::<Principled>() <= size_of::<Blend>());
    assert!(size_of::<PrincipledThin>() <= size_of::<Blend>());
    assert!(size_of::<Bsdf>() <= 80, "{}", size_of::<Bsdf>());
}
