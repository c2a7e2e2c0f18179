//! Participating media judged by Mitsuba 3's statistical verdict (tests/common/verdict.rs), as
//! tests/mitsuba_verdict.rs judges the other scenes of tests/scenes/mitsuba/: the `media_*`
//! scenes rendered at spp = 2,000,000 / pixels with seed 0 against Mitsuba 3.9.1's references.
//! Each perturbation test shows the verdict catches a plausible bug: the scene changed the way
//! the bug would change the image must fail.

mod common;

use common::verdict::{verdict, MitsubaVerdict, RawImage, SAMPLE_BUDGET};
use serde_json::Value;
use std::path::Path;

struct Case {
    reference: RawImage,
    variance: RawImage,
    spp: u64,
}

fn case(name: &str) -> Case {
    let refs = common::root().join("tests/references/verdict");
    let reference = RawImage::load_exr(&refs.join(format!("{name}.exr")));
    let variance = RawImage::load_exr(&refs.join(format!("{name}_var.exr")));
    let spp = SAMPLE_BUDGET / (reference.width * reference.height) as u64;
    Case {
        reference,
        variance,
        spp,
    }
}

/// Renders `scene` as the verdict wants it and judges it against `name`'s reference.
fn judge_file(name: &str, scene: &Path) -> MitsubaVerdict {
    let c = case(name);
    let (w, h) = (c.reference.width as u32, c.reference.height as u32);
    let r = common::render_scene_opts(scene, w, h, c.spp as u32, None, 0, false);
    assert_eq!(r.nonfinite, 0, "{name}: NaN or infinite samples");
    let image = RawImage::from_vec3(w as usize, h as usize, &r.image.pixels);
    verdict(&image, &c.reference, &c.variance, c.spp)
}

fn scene_path(name: &str) -> std::path::PathBuf {
    let m: Value = serde_json::from_str(
        &std::fs::read_to_string(common::root().join("tests/references/verdict/manifest.json"))
            .expect("manifest"),
    )
    .expect("manifest JSON");
    common::root().join(m["references"][name]["scene"].as_str().expect("scene"))
}

/// Scenes whose image mean differs from Mitsuba's by more than the noise, and why.
/// media_dielectrics: the thin dielectric sphere holding a medium renders 0.03% (R), 0.14% (G)
/// and 0.29% (B) brighter than Mitsuba's (4096 spp each, the sphere alone; the same with
/// max_depth 64 and with an isotropic phase function, so neither path depth nor `hg`; the
/// excess follows the medium's albedo, 0.6 / 0.85 / 0.95, i.e. the number of scattering events);
/// every pixel passes the verdict. Open: docs/validation.md.
const KNOWN_MEAN_DIFFERENCES: &[&str] = &["media_dielectrics"];

macro_rules! media_verdict_tests {
    ($($name:ident),* $(,)?) => {$(
        #[test]
        fn $name() {
            let name = stringify!($name);
            let v = judge_file(name, &scene_path(name));
            println!("{name}: {v}");
            assert!(v.pass, "{name}: {v}");
            if !KNOWN_MEAN_DIFFERENCES.contains(&name) {
                assert!(
                    v.mean_z.iter().all(|z| z.abs() < 5.0),
                    "{name}: the image mean is off: {v}"
                );
            }
        }
    )*};
}

media_verdict_tests!(
    media_camera_fog,
    media_chromatic_hg,
    media_dielectrics,
    media_emitter_inside,
    media_grid,
    media_homogeneous_env,
    media_roughdielectric_spot,
);

/// `name`'s scene with `from` replaced by `to` (which must occur), written next to the original
/// (relative file names keep working) and judged against the unchanged reference.
fn judge_changed(name: &str, from: &str, to: &str) -> MitsubaVerdict {
    let path = scene_path(name);
    let xml = std::fs::read_to_string(&path).expect("scene");
    assert!(xml.contains(from), "{name}: no '{from}'");
    let changed = path.with_file_name(format!("{name}.changed-{}.xml", std::process::id()));
    std::fs::write(&changed, xml.replacen(from, to, 1)).unwrap();
    let v = judge_file(name, &changed);
    let _ = std::fs::remove_file(&changed);
    println!("{name} with '{from}' -> '{to}': {v}");
    v
}

/// What the media verdict tests reject: a failing per-pixel verdict or an image mean more than
/// five standard errors off.
fn rejected(v: &MitsubaVerdict) -> bool {
    !v.pass || v.mean_z.iter().any(|z| z.abs() >= 5.0)
}

/// A majorant below the density (what a wrong local majorant would be): `max_value` caps the
/// grid's majorant at a quarter of its largest value, and the grid scene fails.
#[test]
fn media_grid_fails_with_a_low_majorant() {
    let v = judge_changed(
        "media_grid",
        r#"<string name="filename" value="textures/cloud.vol"/>"#,
        r#"<string name="filename" value="textures/cloud.vol"/><float name="max_value" value="0.25"/>"#,
    );
    assert!(rejected(&v), "{v}");
}

/// The phase function's direction convention reversed (g negated) fails.
#[test]
fn media_hg_sign_matters() {
    let v = judge_changed("media_chromatic_hg", r#"value="0.7""#, r#"value="-0.7""#);
    assert!(rejected(&v), "{v}");
    let v = judge_changed("media_camera_fog", r#"value="-0.5""#, r#"value="0.5""#);
    assert!(rejected(&v), "{v}");
}

/// A chromatic extinction read as grey (its mean) fails.
#[test]
fn media_chromatic_extinction_matters() {
    let v = judge_changed(
        "media_chromatic_hg",
        r#"<rgb name="sigma_t" value="0.13, 0.4, 1.0"/>"#,
        r#"<float name="sigma_t" value="0.51"/>"#,
    );
    assert!(rejected(&v), "{v}");
}

/// The sensor's medium ignored (the camera in vacuum inside the fog) fails.
#[test]
fn media_camera_medium_matters() {
    let v = judge_changed("media_camera_fog", r#"<ref id="fog"/>"#, "");
    assert!(rejected(&v), "{v}");
}

/// A wrong passage through the index-matched boundary (the thin dielectric's index 2.0 instead
/// of bk7's: its slab reflects more and lets less through, on paths and shadow rays) fails.
#[test]
fn media_index_matched_boundary_matters() {
    let v = judge_changed(
        "media_dielectrics",
        r#"<bsdf type="thindielectric"/>"#,
        r#"<bsdf type="thindielectric"><float name="int_ior" value="2.0"/></bsdf>"#,
    );
    assert!(rejected(&v), "{v}");
}
