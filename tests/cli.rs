//! The `torrey` command line as a user meets it: bad input fails with file:line:column and writes
//! no image; a good scene writes an EXR and a PNG; renders are identical whatever the thread count.

use std::path::PathBuf;
use std::process::Command;

fn torrey() -> Command {
    Command::new(env!("CARGO_BIN_EXE_torrey"))
}

fn temp_dir(name: &str) -> PathBuf {
    let dir = std::env::temp_dir().join(format!("torrey-cli-{}-{name}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    dir
}

/// Runs torrey on a scene that must be rejected; checks that it exits non-zero and writes no
/// image, and returns what it printed on stderr.
fn expect_failure(scene: &std::path::Path, out: &std::path::Path) -> String {
    let result = torrey()
        .arg(scene)
        .arg("-o")
        .arg(out)
        .arg("--quiet")
        .output()
        .unwrap();
    assert!(!result.status.success());
    assert!(
        !out.exists() && !out.with_extension("png").exists(),
        "no image on error"
    );
    String::from_utf8_lossy(&result.stderr).into_owned()
}

const GOOD: &str = r#"<scene version="0.6.0">
  <sensor type="perspective"><float name="fov" value="40"/>
    <transform name="toWorld"><lookat origin="0, 0, 4" target="0, 0, 0" up="0, 1, 0"/></transform>
    <sampler type="independent"><integer name="sampleCount" value="4"/></sampler>
    <film type="hdrfilm"><integer name="width" value="24"/><integer name="height" value="16"/></film>
  </sensor>
  <bsdf type="diffuse" id="d"><rgb name="reflectance" value="0.5"/></bsdf>
  <shape type="sphere"><float name="radius" value="1"/><ref id="d"/></shape>
  <background/>
</scene>"#;

#[test]
fn bad_scene_fails_with_position_and_writes_nothing() {
    let dir = temp_dir("bad");
    let scene = dir.join("bad.xml");
    // Line 3: a shape with an unknown type; the position is that of the type attribute value.
    std::fs::write(&scene, "<scene version=\"0.6.0\">\n  <bsdf type=\"diffuse\" id=\"d\"/>\n  <shape type=\"teapot\"/>\n</scene>\n").unwrap();
    let out = dir.join("bad.exr");
    let stderr = expect_failure(&scene, &out);
    assert!(
        stderr.contains("bad.xml:3:16:"),
        "error must name file:line:column: {stderr}"
    );
    assert!(
        stderr.contains("teapot"),
        "error must name the problem: {stderr}"
    );
}

#[test]
fn good_scene_writes_exr_and_png_and_reports_speed() {
    let dir = temp_dir("good");
    let scene = dir.join("good.xml");
    std::fs::write(&scene, GOOD).unwrap();
    let out = dir.join("img.exr");
    let result = torrey()
        .arg(&scene)
        .arg("-o")
        .arg(&out)
        .arg("--quiet")
        .output()
        .unwrap();
    assert!(
        result.status.success(),
        "{}",
        String::from_utf8_lossy(&result.stderr)
    );
    let stderr = String::from_utf8_lossy(&result.stderr);
    assert!(
        stderr.contains("24x16 px, 4 spp") && stderr.contains("samples/s"),
        "{stderr}"
    );
    // Only plugins the torrey course's renderer reads (sensor, bsdf, shape): the course's rules.
    assert!(
        stderr.contains(
            "torrey dialect (scene version 0.6.0, every plugin (3) one the torrey course's renderer reads)"
        ),
        "{stderr}"
    );
    // One it does not read makes a Mitsuba 0.6 file, and the summary names it with its place.
    let metal = dir.join("metal.xml");
    std::fs::write(
        &metal,
        GOOD.replace(r#"<bsdf type="diffuse""#, r#"<bsdf type="conductor""#),
    )
    .unwrap();
    let result = torrey()
        .arg(&metal)
        .args(["--quiet", "-o"])
        .arg(&out)
        .output()
        .unwrap();
    let stderr = String::from_utf8_lossy(&result.stderr);
    assert!(
        result.status.success()
            && stderr.contains(&format!(
                "mitsuba dialect (scene version 0.6.0 with bsdf 'conductor' at {}:7:3, which the torrey course's renderer does not read: Mitsuba's rules)",
                metal.display()
            )),
        "{stderr}"
    );
    // --dialect overrides the detection, and the summary says so.
    let forced = torrey()
        .arg(&scene)
        .args(["--dialect", "mitsuba", "--quiet", "-o"])
        .arg(&out)
        .output()
        .unwrap();
    let stderr = String::from_utf8_lossy(&forced.stderr);
    assert!(
        forced.status.success() && stderr.contains("mitsuba dialect (forced (detected"),
        "{stderr}"
    );
    let img = torrey_texture::load_image(&out, false).unwrap().image;
    assert_eq!((img.width, img.height), (24, 16));
    assert!(out.with_extension("png").exists());
}

#[test]
fn renders_do_not_depend_on_thread_count() {
    let dir = temp_dir("threads");
    let scene = dir.join("s.xml");
    std::fs::write(&scene, GOOD).unwrap();
    let mut images = Vec::new();
    for threads in ["1", "2", "3"] {
        let out = dir.join(format!("t{threads}.exr"));
        let status = torrey()
            .arg(&scene)
            .args(["--threads", threads, "--seed", "5", "--quiet", "-o"])
            .arg(&out)
            .status()
            .unwrap();
        assert!(status.success());
        images.push(torrey_texture::load_image(&out, false).unwrap().image);
    }
    assert_eq!(images[0], images[1]);
    assert_eq!(images[0], images[2]);
    // A different seed gives a different (noisy) image.
    let out = dir.join("other.exr");
    torrey()
        .arg(&scene)
        .args(["--seed", "6", "--quiet", "-o"])
        .arg(&out)
        .status()
        .unwrap();
    assert_ne!(
        images[0],
        torrey_texture::load_image(&out, false).unwrap().image
    );
}

#[test]
fn undecodable_texture_is_reported_at_its_place_in_the_scene() {
    let dir = temp_dir("badtex");
    std::fs::write(dir.join("broken.png"), b"\x89PNG\r\n\x1a\nnot really a png").unwrap();
    let scene = dir.join("tex.xml");
    let xml = GOOD.replace(
        r#"<bsdf type="diffuse" id="d"><rgb name="reflectance" value="0.5"/></bsdf>"#,
        "<bsdf type=\"diffuse\" id=\"d\">\n    <texture type=\"bitmap\" name=\"reflectance\"><string name=\"filename\" value=\"broken.png\"/></texture>\n  </bsdf>",
    );
    std::fs::write(&scene, xml).unwrap();
    let out = dir.join("tex.exr");
    let stderr = expect_failure(&scene, &out);
    assert!(
        stderr.contains("tex.xml:8:"),
        "the texture's scene position: {stderr}"
    );
    assert!(stderr.contains("broken.png"), "the image file: {stderr}");
}
