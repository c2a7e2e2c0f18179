//! Mitsuba's models at fixed directions: reciprocity, the dielectric's refraction and eta, eval
//! and pdf against Mitsuba 3.9.1's own values, and `eval_pdf` against the two.

use super::tests_mitsuba::{
    dir_at, glossy_models, rough_conductor, rough_dielectric, rough_plastic, smooth_plastic,
    GOLD_ETA, GOLD_K,
};
use super::*;
use crate::sampling::testutil::Rng;

/// f(wo, wi)/|cos θi| is symmetric for reflection; across a dielectric interface, in radiance
/// units, f(wo → wi)/η_o² is (Veach 5.2), η_o the IOR on wo's side.
#[test]
fn reciprocity() {
    let mut rng = Rng::new(77);
    let mut checked = 0;
    for (name, b, _) in glossy_models() {
        let eta = match b {
            Bsdf::RoughDielectric(d) => d.eta,
            Bsdf::Blend(bl) => match &bl.children[0] {
                BsdfParams::RoughDielectric(d) => d.eta,
                _ => 1.0,
            },
            _ => 1.0,
        };
        let side_eta = |w: Vec3A| if w.z < 0.0 { eta } else { 1.0 };
        for _ in 0..4000 {
            // Pairs from the BSDF's own sampling, so that they lie in its lobes.
            let a = crate::sampling::square_to_uniform_sphere(rng.vec2());
            let Some(s) = b.sample(a, rng.vec2(), rng.f32()) else {
                continue;
            };
            if s.is_delta() {
                continue;
            }
            let c = s.wi;
            let f_ac = b.eval(a, c) / c.z.abs() / (side_eta(a) * side_eta(a));
            let f_ca = b.eval(c, a) / a.z.abs() / (side_eta(c) * side_eta(c));
            let scale = f_ac.max_element().max(f_ca.max_element());
            // Far tails (f < 1e-4, where wo·m + η wi·m cancels) only carry rounding error.
            if !scale.is_finite() || scale < 1e-4 || a.z.abs() < 0.02 || c.z.abs() < 0.02 {
                continue;
            }
            assert!(
                (f_ac - f_ca).abs().max_element() <= 1e-2 * scale,
                "{name}: {a} {c}: {f_ac} vs {f_ca}"
            );
            checked += 1;
        }
    }
    assert!(checked > 20_000, "{checked}");
}

/// The pdf of roughdielectric integrates to 1 on both sides (no lobe is lost but by rejected
/// proposals), and smooth dielectric refraction obeys Snell's law with η reported as Mitsuba's.
#[test]
fn dielectric_refraction_and_eta() {
    let glass = Bsdf::Dielectric(Dielectric {
        eta: 1.5,
        specular_reflectance: Vec3A::ONE,
        specular_transmittance: Vec3A::ONE,
    });
    let wo = dir_at(40.0);
    let t = glass.sample(wo, Vec2::ZERO, 0.999).unwrap();
    assert_eq!(t.lobe, BsdfFlags::DELTA_TRANSMISSION);
    assert_eq!(t.eta, 1.5);
    let sin_i = (1.0 - wo.z * wo.z).sqrt();
    let sin_t = (1.0 - t.wi.z * t.wi.z).sqrt();
    assert!((sin_i - 1.5 * sin_t).abs() < 1e-5 && t.wi.z < 0.0);
    assert!((t.weight.x - 1.0 / 2.25).abs() < 1e-6);
    // Leaving: η = 1/1.5, radiance scaled up by 2.25.
    // Seen from inside along the refracted direction: η = 1/1.5, radiance scaled up by 2.25,
    // and the light came from wo.
    let back = glass.sample(t.wi, Vec2::ZERO, 0.999).unwrap();
    assert!((back.eta - 1.0 / 1.5).abs() < 1e-6 && (back.weight.x - 2.25).abs() < 1e-4);
    assert!((back.wi - wo).length() < 1e-4, "{back:?}");
}

/// eval and pdf against Mitsuba 3.9.1 (`scalar_rgb`, `BSDF.eval`/`BSDF.pdf` with `si.wi` = our
/// wo), at directions given as (θ degrees, φ radians): (name, wo, wi, eval, pdf).
type MitsubaValue = (&'static str, (f32, f32), (f32, f32), [f32; 3], f32);

#[rustfmt::skip]
const MITSUBA_VALUES: &[MitsubaValue] = &[
    ("roughconductor_beckmann", (30.0, 0.3), (40.0, 3.5), [1.84360e+00, 1.52913e+00, 6.25964e-01], 1.90811e+00),
    ("roughconductor_beckmann", (60.0, 0.1), (20.0, 3.0), [1.48125e-01, 1.22861e-01, 5.07539e-02], 1.53362e-01),
    ("roughconductor_beckmann", (10.0, 1.0), (75.0, 2.0), [5.44968e-08, 4.52012e-08, 1.85010e-08], 5.65605e-08),
    ("roughconductor_beckmann", (30.0, 0.3), (160.0, 3.3), [0.00000e+00, 0.00000e+00, 0.00000e+00], 0.00000e+00),
    ("roughconductor_beckmann", (150.0, 0.5), (20.0, 3.9), [0.00000e+00, 0.00000e+00, 0.00000e+00], 0.00000e+00),
    ("roughconductor_beckmann", (170.0, 0.5), (120.0, 2.0), [0.00000e+00, 0.00000e+00, 0.00000e+00], 0.00000e+00),
    ("roughconductor_ggx_aniso", (30.0, 0.3), (40.0, 3.5), [8.08476e-01, 5.26429e-01, 4.34899e-01], 8.56461e-01),
    ("roughconductor_ggx_aniso", (60.0, 0.1), (20.0, 3.0), [5.99670e-02, 3.90618e-02, 3.23365e-02], 6.31200e-02),
    ("roughconductor_ggx_aniso", (10.0, 1.0), (75.0, 2.0), [4.83853e-02, 3.15054e-02, 2.60267e-02], 7.22260e-02),
    ("roughconductor_ggx_aniso", (30.0, 0.3), (160.0, 3.3), [0.00000e+00, 0.00000e+00, 0.00000e+00], 0.00000e+00),
    ("roughconductor_ggx_aniso", (150.0, 0.5), (20.0, 3.9), [0.00000e+00, 0.00000e+00, 0.00000e+00], 0.00000e+00),
    ("roughconductor_ggx_aniso", (170.0, 0.5), (120.0, 2.0), [0.00000e+00, 0.00000e+00, 0.00000e+00], 0.00000e+00),
    ("roughdielectric_beckmann", (30.0, 0.3), (40.0, 3.5), [4.08375e-02, 4.08375e-02, 4.08375e-02], 4.08375e-02),
    ("roughdielectric_beckmann", (60.0, 0.1), (20.0, 3.0), [2.19424e-02, 2.19424e-02, 2.19424e-02], 2.19424e-02),
    ("roughdielectric_beckmann", (10.0, 1.0), (75.0, 2.0), [3.02414e-05, 3.02414e-05, 3.02414e-05], 3.14234e-05),
    ("roughdielectric_beckmann", (30.0, 0.3), (160.0, 3.3), [9.01467e+00, 9.01467e+00, 9.01467e+00], 2.02830e+01),
    ("roughdielectric_beckmann", (150.0, 0.5), (20.0, 3.9), [1.79241e-05, 1.79241e-05, 1.79241e-05], 7.96627e-06),
    ("roughdielectric_beckmann", (170.0, 0.5), (120.0, 2.0), [1.61326e-03, 1.61326e-03, 1.61326e-03], 1.61326e-03),
    ("roughdielectric_ggx", (30.0, 0.3), (40.0, 3.5), [6.88881e-02, 6.88881e-02, 6.88881e-02], 6.93698e-02),
    ("roughdielectric_ggx", (60.0, 0.1), (20.0, 3.0), [1.12090e-02, 1.12090e-02, 1.12090e-02], 1.12238e-02),
    ("roughdielectric_ggx", (10.0, 1.0), (75.0, 2.0), [6.15442e-04, 6.15442e-04, 6.15442e-04], 6.91710e-04),
    ("roughdielectric_ggx", (30.0, 0.3), (160.0, 3.3), [1.17409e+01, 1.17409e+01, 1.17409e+01], 2.64519e+01),
    ("roughdielectric_ggx", (150.0, 0.5), (20.0, 3.9), [2.16310e-01, 2.16310e-01, 2.16310e-01], 9.62652e-02),
    ("roughdielectric_ggx", (170.0, 0.5), (120.0, 2.0), [1.96706e-03, 1.96706e-03, 1.96706e-03], 2.02440e-03),
    ("plastic", (30.0, 0.3), (40.0, 3.5), [1.96918e-01, 1.23074e-01, 4.92296e-02], 2.25005e-01),
    ("plastic", (60.0, 0.1), (20.0, 3.0), [2.30954e-01, 1.44346e-01, 5.77386e-02], 2.51004e-01),
    ("plastic", (10.0, 1.0), (75.0, 2.0), [5.22192e-02, 3.26370e-02, 1.30548e-02], 7.62475e-02),
    ("plastic", (30.0, 0.3), (160.0, 3.3), [0.00000e+00, 0.00000e+00, 0.00000e+00], 0.00000e+00),
    ("plastic", (150.0, 0.5), (20.0, 3.9), [0.00000e+00, 0.00000e+00, 0.00000e+00], 0.00000e+00),
    ("plastic", (170.0, 0.5), (120.0, 2.0), [0.00000e+00, 0.00000e+00, 0.00000e+00], 0.00000e+00),
    ("plastic_nonlinear", (30.0, 0.3), (40.0, 3.5), [1.52842e-01, 7.15157e-02, 2.28603e-02], 2.25005e-01),
    ("plastic_nonlinear", (60.0, 0.1), (20.0, 3.0), [1.79260e-01, 8.38766e-02, 2.68115e-02], 2.51004e-01),
    ("plastic_nonlinear", (10.0, 1.0), (75.0, 2.0), [4.05310e-02, 1.89646e-02, 6.06212e-03], 7.62475e-02),
    ("plastic_nonlinear", (30.0, 0.3), (160.0, 3.3), [0.00000e+00, 0.00000e+00, 0.00000e+00], 0.00000e+00),
    ("plastic_nonlinear", (150.0, 0.5), (20.0, 3.9), [0.00000e+00, 0.00000e+00, 0.00000e+00], 0.00000e+00),
    ("plastic_nonlinear", (170.0, 0.5), (120.0, 2.0), [0.00000e+00, 0.00000e+00, 0.00000e+00], 0.00000e+00),
    ("roughplastic_beckmann", (30.0, 0.3), (40.0, 3.5), [2.07430e-01, 1.44471e-01, 8.15110e-02], 3.01490e-01),
    ("roughplastic_beckmann", (60.0, 0.1), (20.0, 3.0), [2.17434e-01, 1.43871e-01, 7.03091e-02], 3.31376e-01),
    ("roughplastic_beckmann", (10.0, 1.0), (75.0, 2.0), [4.86675e-02, 3.04282e-02, 1.21888e-02], 7.62385e-02),
    ("roughplastic_beckmann", (30.0, 0.3), (160.0, 3.3), [0.00000e+00, 0.00000e+00, 0.00000e+00], 0.00000e+00),
    ("roughplastic_beckmann", (150.0, 0.5), (20.0, 3.9), [0.00000e+00, 0.00000e+00, 0.00000e+00], 0.00000e+00),
    ("roughplastic_beckmann", (170.0, 0.5), (120.0, 2.0), [0.00000e+00, 0.00000e+00, 0.00000e+00], 0.00000e+00),
    ("roughplastic_ggx", (30.0, 0.3), (40.0, 3.5), [1.06768e-01, 1.63720e-01, 2.20672e-01], 3.68524e-01),
    ("roughplastic_ggx", (60.0, 0.1), (20.0, 3.0), [5.56566e-02, 1.22349e-01, 1.89041e-01], 2.89423e-01),
    ("roughplastic_ggx", (10.0, 1.0), (75.0, 2.0), [1.15101e-02, 2.78533e-02, 4.41964e-02], 7.69097e-02),
    ("roughplastic_ggx", (30.0, 0.3), (160.0, 3.3), [0.00000e+00, 0.00000e+00, 0.00000e+00], 0.00000e+00),
    ("roughplastic_ggx", (150.0, 0.5), (20.0, 3.9), [0.00000e+00, 0.00000e+00, 0.00000e+00], 0.00000e+00),
    ("roughplastic_ggx", (170.0, 0.5), (120.0, 2.0), [0.00000e+00, 0.00000e+00, 0.00000e+00], 0.00000e+00),
];

#[test]
fn eval_and_pdf_match_mitsuba() {
    use MicrofacetKind::{Beckmann, Ggx};
    let cu_eta = Vec3A::new(0.201005, 0.92375, 1.10222);
    let cu_k = Vec3A::new(3.91326, 2.45305, 2.14209);
    let model = |name: &str| match name {
        "roughconductor_beckmann" => rough_conductor(Beckmann, 0.2, 0.2, GOLD_ETA, GOLD_K),
        "roughconductor_ggx_aniso" => rough_conductor(Ggx, 0.15, 0.45, cu_eta, cu_k),
        "roughdielectric_beckmann" => rough_dielectric(Beckmann, 0.3, 0.3, 1.5),
        "roughdielectric_ggx" => rough_dielectric(Ggx, 0.2, 0.2, 1.5),
        "plastic" => smooth_plastic(Vec3A::new(0.8, 0.5, 0.2), 1.49 / 1.000277, false),
        "plastic_nonlinear" => smooth_plastic(Vec3A::new(0.8, 0.5, 0.2), 1.49 / 1.000277, true),
        "roughplastic_beckmann" => {
            rough_plastic(Beckmann, 0.3, Vec3A::new(0.8, 0.5, 0.2), 1.49 / 1.000277)
        }
        "roughplastic_ggx" => rough_plastic(Ggx, 0.2, Vec3A::new(0.2, 0.5, 0.8), 1.5 / 1.000277),
        _ => unreachable!(),
    };
    let dir = |(deg, phi): (f32, f32)| {
        let t = deg.to_radians();
        Vec3A::new(t.sin() * phi.cos(), t.sin() * phi.sin(), t.cos())
    };
    let mut failures = Vec::new();
    for &(name, wo, wi, value, pdf) in MITSUBA_VALUES {
        let b = model(name);
        let (wo, wi) = (dir(wo), dir(wi));
        let ours = b.eval(wo, wi);
        let theirs = Vec3A::from(value);
        if (ours - theirs).abs().max_element() > 1e-2 * theirs.max_element() + 1e-7 {
            failures.push(format!(
                "{name} eval wo {wo} wi {wi}: ours {ours}, Mitsuba {theirs}"
            ));
        }
        let p = b.pdf(wo, wi);
        if (p - pdf).abs() > 1e-2 * pdf + 1e-7 {
            failures.push(format!(
                "{name} pdf wo {wo} wi {wi}: ours {p}, Mitsuba {pdf}"
            ));
        }
    }
    assert!(failures.is_empty(), "{}", failures.join("\n"));
}

/// Next-event estimation takes f and the pdf from one [`Bsdf::eval_pdf`]: the same bits as
/// [`Bsdf::eval`] and [`Bsdf::pdf`] apart, over the whole sphere, for every model.
#[test]
fn eval_pdf_is_eval_and_pdf() {
    let mut rng = Rng::new(77);
    for (name, b, _) in glossy_models() {
        for _ in 0..2000 {
            let mut dir = || {
                let u = rng.vec2();
                crate::sampling::square_to_uniform_sphere(u)
            };
            let (wo, wi) = (dir(), dir());
            assert_eq!(
                b.eval_pdf(wo, wi),
                (b.eval(wo, wi), b.pdf(wo, wi)),
                "{name}"
            );
        }
    }
}
