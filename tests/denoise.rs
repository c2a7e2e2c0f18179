//! `--denoise`: built with the `denoise` feature (Intel Open Image Denoise), a noisy render of a
//! flat image (a diffuse plane filling the view under a uniform sky: every pixel's expectation is
//! the albedo times the sky) comes out flat at its level, with the noisy image, the albedo and the
//! normal kept as layers; `torrey merge --denoise` denoises merged parts. Built without it,
//! `--denoise` is an error that says how to get the library, and writes nothing.

use std::path::PathBuf;
use std::process::{Command, Output};

const FLAT: &str = r#"<scene version="3.0.0">
    <integrator type="path"><integer name="max_depth" value="3"/></integrator>
    <sensor type="perspective">
        <float name="fov" value="40"/>
        <transform name="to_world"><lookat origin="0, 3, 0" target="0, 0, 0" up="0, 0, 1"/></transform>
        <film type="hdrfilm"><integer name="width" value="64"/><integer name="height" value="48"/>
            <rfilter type="box"/></film>
    </sensor>
    <shape type="rectangle">
        <transform name="to_world"><rotate x="1" angle="-90"/><scale value="100"/></transform>
        <bsdf type="diffuse"><rgb name="reflectance" value="0.5"/></bsdf>
    </shape>
    <emitter type="constant"><rgb name="radiance" value="1"/></emitter>
</scene>"#;

fn torrey(args: &[&str]) -> Output {
    Command::new(env!("CARGO_BIN_EXE_torrey"))
        .args(args)
        .output()
        .unwrap()
}

#[test]
fn denoise_flattens_a_flat_image_or_says_how_to_get_oidn() {
    let dir = std::env::temp_dir().join(format!("torrey-denoise-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let scene = dir.join("flat.xml");
    std::fs::write(&scene, FLAT).unwrap();
    let path = |n: &str| -> PathBuf { dir.join(n) };
    let s = |p: &PathBuf| p.to_str().unwrap().to_string();
    let out = torrey(&[
        &s(&scene),
        "--quiet",
        "--spp",
        "4",
        "--denoise",
        "-o",
        &s(&path("d.exr")),
    ]);
    let stderr = String::from_utf8_lossy(&out.stderr);
    if !cfg!(feature = "denoise") {
        assert!(!out.status.success());
        assert!(
            stderr.contains("install-oidn.sh") && stderr.contains("--features denoise"),
            "{stderr}"
        );
        assert!(!path("d.exr").exists() && !path("d.png").exists());
        return;
    }
    assert!(out.status.success(), "{stderr}");
    assert!(stderr.contains("denoised in"), "{stderr}");
    let part = torrey_parts::read_part(&path("d.exr")).unwrap();
    let denoised = part.denoised.as_ref().expect("RGB is the denoised image");
    for c in [
        "albedo.R", "albedo.G", "albedo.B", "normal.X", "normal.Y", "normal.Z",
    ] {
        assert!(
            part.channels.iter().any(|n| n == c),
            "{c} in {:?}",
            part.channels
        );
    }
    let albedo = part.channel_values(&["albedo.R"]).unwrap();
    assert!(
        albedo.iter().all(|&a| (a - 0.5).abs() < 1e-6),
        "the diffuse albedo exactly"
    );
    let normal = part.channel_values(&["normal.Y"]).unwrap();
    assert!(normal.iter().all(|&n| (n - 1.0).abs() < 1e-5));
    let spread = |v: &[glam::Vec3]| v.iter().map(|p| (p.x - 0.5).abs()).fold(0.0f32, f32::max);
    let (noisy, clean) = (spread(&part.mean), spread(denoised));
    assert!(noisy > 0.05, "the 4-spp render is noisy: {noisy}");
    assert!(
        clean < 0.02,
        "denoised, every pixel within 4% of 0.5: {clean}"
    );
    let mean = denoised.iter().map(|p| p.x).sum::<f32>() / denoised.len() as f32;
    assert!((mean - 0.5).abs() < 0.01, "mean {mean}");

    // Parts are merged from their noisy images and guides, then denoised.
    for (name, range) in [("a.exr", "0..2"), ("b.exr", "2..4")] {
        let out = torrey(&[
            &s(&scene),
            "--quiet",
            "--spp",
            "4",
            "--denoise",
            "--sample-range",
            range,
            "-o",
            &s(&path(name)),
        ]);
        assert!(out.status.success());
    }
    let out = torrey(&[
        "merge",
        &s(&path("a.exr")),
        &s(&path("b.exr")),
        "--denoise",
        "-o",
        &s(&path("m.exr")),
    ]);
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let merged = torrey_parts::read_part(&path("m.exr")).unwrap();
    let worst = merged
        .mean
        .iter()
        .zip(&part.mean)
        .map(|(a, b)| (*a - *b).abs().max_element())
        .fold(0.0f32, f32::max);
    assert!(
        worst < 1e-5,
        "the merged noisy image is the one-piece one: {worst}"
    );
    assert!(spread(merged.denoised.as_ref().unwrap()) < 0.02);
}

/// `--denoise-prefilter` takes Cycles' names; anything else is an error that lists them, before
/// anything is rendered.
#[test]
fn an_unknown_denoise_prefilter_is_a_clear_error() {
    let out = torrey(&["scene.xml", "--denoise", "--denoise-prefilter", "slow"]);
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert!(!out.status.success());
    assert!(
        stderr.contains("'--denoise-prefilter <accurate|fast>'")
            && stderr.contains("unknown denoise prefilter 'slow' (expected 'accurate' or 'fast')"),
        "{stderr}"
    );
}
