//! Mitsuba's statistical verdict for Mitsuba 3's BSDFs (as src/render/tests/test_renders.py
//! judges renders): each scene of tests/scenes/mitsuba_bsdfs/ is rendered at
//! spp = 2,000,000 / pixels with seed 0 and compared with Mitsuba 3.9.1's render and per-sample
//! variance (`moment` integrator; tests/mitsuba/make_bsdf_references.py):
//! - image and reference are converted from linear sRGB to CIE XYZ; the variance is already XYZ
//!   (what `moment` records) and is floored at 1e-4;
//! - per pixel and channel z = |img − ref| √(spp / var) and p = 2 (1 − Φ(z));
//! - with the Šidák-corrected level α = 1 − 0.99^(1 / pixels), the render passes when
//!   count(p > α) / 3 ≥ 0.9975 · pixels.
//!
//! The references are rendered with 8x the test's samples, so their own noise is small against
//! the test render's.

mod common;

use glam::{DVec3, Vec3};
use std::path::Path;

/// Rows of the linear sRGB to CIE XYZ matrix Mitsuba's test uses.
const RGB_TO_XYZ: [[f64; 3]; 3] = [
    [0.412453, 0.357580, 0.180423],
    [0.212671, 0.715160, 0.072169],
    [0.019334, 0.119193, 0.950227],
];

fn to_xyz(c: Vec3) -> DVec3 {
    let c = c.as_dvec3();
    DVec3::new(
        RGB_TO_XYZ[0][0] * c.x + RGB_TO_XYZ[0][1] * c.y + RGB_TO_XYZ[0][2] * c.z,
        RGB_TO_XYZ[1][0] * c.x + RGB_TO_XYZ[1][1] * c.y + RGB_TO_XYZ[1][2] * c.z,
        RGB_TO_XYZ[2][0] * c.x + RGB_TO_XYZ[2][1] * c.y + RGB_TO_XYZ[2][2] * c.z,
    )
}

/// The verdict's outcome for one render.
struct Verdict {
    pixels: usize,
    /// count(p > α) / 3.
    passing: f64,
    /// Mean over the image, ours / reference, per XYZ channel.
    mean_ratio: DVec3,
}

impl Verdict {
    fn passed(&self) -> bool {
        self.passing >= 0.9975 * self.pixels as f64
    }
}

/// Mitsuba's verdict of `image` (linear sRGB, `spp` samples per pixel) against `reference`
/// (linear sRGB) and its per-sample `variance` (XYZ).
fn verdict(image: &[Vec3], reference: &[Vec3], variance: &[Vec3], spp: u32) -> Verdict {
    assert_eq!(image.len(), reference.len());
    assert_eq!(image.len(), variance.len());
    let pixels = image.len();
    let alpha = 1.0 - 0.99f64.powf(1.0 / pixels as f64);
    let mut count = 0usize;
    let (mut sum_img, mut sum_ref) = (DVec3::ZERO, DVec3::ZERO);
    for ((img, r), v) in image.iter().zip(reference).zip(variance) {
        let (a, b) = (to_xyz(*img), to_xyz(*r));
        sum_img += a;
        sum_ref += b;
        let v = v.as_dvec3().max(DVec3::splat(1e-4));
        for c in 0..3 {
            let z = (a[c] - b[c]).abs() * (spp as f64 / v[c]).sqrt();
            // p = 2 (1 − Φ(z)) = erfc(z / √2).
            let p = common::verdict::erfc(z / std::f64::consts::SQRT_2);
            if p > alpha {
                count += 1;
            }
        }
    }
    Verdict {
        pixels,
        passing: count as f64 / 3.0,
        mean_ratio: sum_img / sum_ref,
    }
}

fn load(path: &Path) -> Vec<Vec3> {
    torrey_texture::load_image(path, false)
        .unwrap_or_else(|e| panic!("{e}"))
        .image
        .pixels
}

/// Renders scene `name` and judges it against its reference.
fn check(name: &str) {
    let root = common::root();
    let scene = root
        .join("tests/scenes/mitsuba_bsdfs")
        .join(format!("{name}.xml"));
    let refs = root.join("tests/references/verdict_bsdfs");
    let reference = load(&refs.join(format!("{name}.exr")));
    let variance = load(&refs.join(format!("{name}_var.exr")));
    let (w, h) = (48, 48);
    let spp = 2_000_000 / (w * h);
    // Mitsuba does not mip-map (bitmaps and environment maps are looked up bilinearly).
    let r = common::render_scene_opts(&scene, w, h, spp, None, 0, false);
    assert_eq!(r.nonfinite, 0, "{name}: non-finite samples");
    let v = verdict(&r.image.pixels, &reference, &variance, spp);
    eprintln!(
        "verdict {name}: {:.2}% of pixels pass (need 99.75%), mean ratio XYZ {:.4} {:.4} {:.4}",
        100.0 * v.passing / v.pixels as f64,
        v.mean_ratio.x,
        v.mean_ratio.y,
        v.mean_ratio.z
    );
    assert!(
        v.passed(),
        "{name}: only {:.2}% of pixels pass Mitsuba's verdict (mean ratio {:?})",
        100.0 * v.passing / v.pixels as f64,
        v.mean_ratio
    );
}

macro_rules! verdict_tests {
    ($($name:ident),* $(,)?) => {
        $(
            #[test]
            fn $name() {
                check(stringify!($name));
            }
        )*
    };
}

verdict_tests!(
    dielectric_env,
    dielectric_area,
    thindielectric_env,
    thindielectric_area,
    roughdielectric_env,
    roughdielectric_area,
    conductor_env,
    conductor_area,
    roughconductor_env,
    roughconductor_area,
    plastic_env,
    plastic_area,
    roughplastic_env,
    roughplastic_area,
    twosided_env,
    twosided_area,
    blendbsdf_env,
    blendbsdf_area,
    mask_env,
    principled_env,
    principled_area,
    principledthin_env,
    principledthin_area,
    bumpmap_env,
    bumpmap_area,
    normalmap_env,
    normalmap_area,
    normalmap_twosided_env,
    sample_visible_env,
    sample_visible_area,
);

/// `mask` under an area light is judged against the truth rather than Mitsuba: with direct light
/// only (max_depth 2), a sphere masked at opacity 0.5 over a two-sided diffuse of reflectance ρ
/// must look exactly like a two-sided diffuse sphere of reflectance ρ/2 (the other half of the
/// camera rays pass into the sphere and end). torrey does (top of the sphere 0.0284 vs 0.0284);
/// Mitsuba 3.9.1 renders the masked sphere 25% darker there (0.0214), which is why `mask_area`
/// is not in the verdict list (docs/validation.md).
#[test]
fn mask_area_direct_light_is_half_the_reflectance() {
    let root = common::root();
    let dir = std::env::temp_dir().join(format!("torrey-mask-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let masked_src =
        std::fs::read_to_string(root.join("tests/scenes/mitsuba_bsdfs/mask_area.xml")).unwrap();
    let mask = r#"<bsdf type="mask"><float name="opacity" value="0.5"/><bsdf type="twosided"><bsdf type="diffuse"><rgb name="reflectance" value="0.2, 0.5, 0.7"/></bsdf></bsdf></bsdf>"#;
    let half = r#"<bsdf type="twosided"><bsdf type="diffuse"><rgb name="reflectance" value="0.1, 0.25, 0.35"/></bsdf></bsdf>"#;
    assert!(masked_src.contains(mask));
    let masked = dir.join("masked.xml");
    let halved = dir.join("halved.xml");
    std::fs::write(&masked, &masked_src).unwrap();
    std::fs::write(&halved, masked_src.replace(mask, half)).unwrap();
    let a = common::render_scene_opts(&masked, 48, 48, 512, Some(2), 1, false);
    let b = common::render_scene_opts(&halved, 48, 48, 512, Some(2), 2, false);
    let ref_sigma = (b
        .variance
        .pixels
        .iter()
        .map(|v| v.max_element() as f64)
        .sum::<f64>()
        / b.variance.pixels.len() as f64)
        .sqrt();
    let c =
        common::compare_with_noise(&a.image, &a.variance, &b.image, 4, 0.0, 0.0, ref_sigma, 5.0);
    eprintln!("mask vs half reflectance: {c:?}");
    assert!(c.outlier_blocks <= 2.0 / c.blocks as f64, "{c:?}");
    for ch in 0..3 {
        assert!(
            (c.mean_ratio[ch] - 1.0).abs() < 4.0 * c.mean_ratio_sigma[ch] + 1e-3,
            "{c:?}"
        );
    }
}

/// The verdict itself must reject a render that is off by a few percent where it is well
/// resolved, and accept the reference judged against itself.
#[test]
fn verdict_rejects_a_biased_image() {
    let n = 48 * 48;
    let reference: Vec<Vec3> = (0..n)
        .map(|i| Vec3::splat(0.2 + (i % 7) as f32 * 0.05))
        .collect();
    let variance = vec![Vec3::splat(0.01); n];
    assert!(verdict(&reference, &reference, &variance, 868).passed());
    let biased: Vec<Vec3> = reference.iter().map(|c| *c * 1.03).collect();
    assert!(!verdict(&biased, &reference, &variance, 868).passed());
    // erfc against known values.
    assert!((common::verdict::erfc(0.0) - 1.0).abs() < 1e-7);
    assert!((common::verdict::erfc(1.0) - 0.157_299_207).abs() < 1e-7);
    assert!((common::verdict::erfc(3.0) / 2.209_049_7e-5 - 1.0).abs() < 1e-6);
}
