//! Checks on the third-party scenes in ../shared (skipped when it is absent, as on a fresh clone).
//!
//! - Every torrey scene renders (tiny, 1 spp) without error or NaN, except
//!   living-room-Wig42/scene_bgonly.xml, whose first missing mesh must be named.
//! - `--ignored`: every Mitsuba 3 render found in out/mitsuba_shared/ (made by
//!   tests/mitsuba/make_references.py, not committed) is compared with a torrey render of the same
//!   scene, size and depth, with the noise-derived tolerance of tests/common.

mod common;

use std::path::{Path, PathBuf};

fn torrey_scenes(shared: &Path) -> Vec<PathBuf> {
    let mut out = Vec::new();
    let mut stack = vec![shared.join("scenes/torrey")];
    while let Some(dir) = stack.pop() {
        for entry in std::fs::read_dir(&dir).unwrap() {
            let p = entry.unwrap().path();
            if p.is_dir() {
                stack.push(p);
            } else if p.extension().is_some_and(|e| e == "xml") {
                out.push(p);
            }
        }
    }
    out.sort();
    out
}

#[test]
fn every_shared_torrey_scene_renders() {
    let Some(shared) = common::shared() else {
        println!("skipped: ../shared is absent");
        return;
    };
    let scenes = torrey_scenes(&shared);
    assert!(
        scenes.len() >= 30,
        "expected the whole torrey scene kit, found {}",
        scenes.len()
    );
    for path in scenes {
        let name = path.file_name().unwrap().to_string_lossy().into_owned();
        let result = torrey_parser::load_scene(&path, &[]);
        if name == "scene_bgonly.xml" {
            let err = result
                .expect_err("scene_bgonly.xml references missing meshes")
                .to_string();
            assert!(
                err.contains("Mesh015.obj"),
                "must name the first missing mesh: {err}"
            );
            assert!(
                err.contains("scene_bgonly.xml:207:"),
                "must give the position: {err}"
            );
            continue;
        }
        let scene = result.unwrap_or_else(|e| panic!("{e}"));
        let rs =
            torrey_renderer::RenderScene::build(&scene, 24, 16).unwrap_or_else(|e| panic!("{e}"));
        let settings = torrey_renderer::RenderSettings::new(
            &scene,
            &torrey_renderer::Overrides {
                spp: Some(1),
                max_depth: Some(scene.integrator.max_depth().min(4)),
                seed: Some(0),
                // Independent samples: the per-pixel variance then estimates the error exactly.
                sampler: Some(torrey_renderer::SamplerKind::Independent),
                ..Default::default()
            },
        );
        let out = torrey_renderer::render(&rs, &settings, &|_, _| {});
        assert_eq!(out.nonfinite_samples, 0, "{name}: NaN or infinite samples");
        assert!(
            out.image.pixels.iter().any(|p| p.max_element() > 0.0),
            "{name}: black image"
        );
    }
}

/// Scenes whose Mitsuba reference cannot settle the question at affordable spp: a point light
/// 0.8 units under the ceiling makes a hotspot whose two brightest pixels carry ~10% of the image
/// and vary by ±15% between seeds at 1024 spp, for either renderer (docs/validation.md). They are
/// reported but do not fail the comparison.
const NOISE_LIMITED: &[&str] = &["cbox__cbox_point_light", "cbox__cbox_point_light_spheres"];

/// Slow (minutes): run with `cargo test --release --test shared_scenes -- --ignored --nocapture`
/// after `tests/mitsuba/make_references.py` has filled out/mitsuba_shared/.
#[test]
#[ignore]
fn shared_scenes_match_mitsuba() {
    let dir = common::root().join("out/mitsuba_shared");
    let Ok(entries) = std::fs::read_dir(&dir) else {
        println!("skipped: {} is absent", dir.display());
        return;
    };
    let spp: u32 = std::env::var("TORREY_SHARED_SPP")
        .ok()
        .and_then(|s| s.parse().ok())
        .unwrap_or(256);
    let mut jsons: Vec<PathBuf> = entries
        .map(|e| e.unwrap().path())
        .filter(|p| p.extension().is_some_and(|e| e == "json"))
        .collect();
    jsons.sort();
    let mut failures = Vec::new();
    for json in jsons {
        let meta: serde_json::Value =
            serde_json::from_str(&std::fs::read_to_string(&json).unwrap()).unwrap();
        let source = common::root().join(meta["source"].as_str().unwrap());
        let (w, h) = (
            meta["width"].as_u64().unwrap() as u32,
            meta["height"].as_u64().unwrap() as u32,
        );
        let depth = meta["max_depth"].as_i64().map(|d| d as i32);
        let reference = common::load(&json.with_extension("exr"));
        // Mitsuba does not mip-map: compare like with like here; what mip-mapping changes is
        // measured separately (docs/validation.md).
        // tests/mitsuba/torrey_to_mitsuba.py converts with the torrey course's rules (two-sided
        // surfaces, the implicit grey sky); torrey detects them (every plugin in these scenes is
        // one the course's renderer reads), so the scenes are loaded as the command line loads
        // them.
        let options = torrey_parser::LoadOptions::default();
        let r = common::render_scene_with(&source, &options, (w, h), spp, depth, 3, false);
        let name = json.file_stem().unwrap().to_string_lossy().into_owned();
        let v = common::compare_to_reference(
            &name,
            &r,
            &reference,
            meta["noise_rel"].as_f64().unwrap_or(0.0),
        );
        println!("{}", v.summary);
        if !v.pass && !NOISE_LIMITED.contains(&name.as_str()) {
            failures.push(v.summary);
        }
    }
    assert!(failures.is_empty(), "differences:\n{}", failures.join("\n"));
}
