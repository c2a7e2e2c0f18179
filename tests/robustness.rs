//! Issue 18's reproducers, each built in a temporary folder at test time: hostile or broken
//! input must end with exit 0 or one line `file:line:column: error: ...` (no panic, no crash,
//! no runaway memory or time), and must never leave a partial image behind.

mod common;

use common::hostile::*;
use std::path::Path;

#[test]
fn degenerate_camera_transforms_are_rejected() {
    // Issue item 1 (SIGSEGV in the 8-wide traversal); the renderer-side root cause is fixed
    // separately, the parser refuses such cameras at their <transform>.
    let dir = temp_dir("camera");
    std::fs::write(dir.join("tetrahedron.obj"), TETRAHEDRON).unwrap();
    let cases = [
        ("<scale value=\"0\"/>", "it scales an axis by 0.000e0"),
        ("<scale value=\"1e-30\"/>", "it scales an axis by 1.000e-30"),
        ("<scale value=\"inf\"/>", "'inf' is not a finite number"),
        ("<scale value=\"nan\"/>", "'nan' is not a finite number"),
        (
            "<scale x=\"1e39\"/>",
            "'1e39' is too large for a 32-bit float",
        ),
        (
            "<matrix value=\"0 0 0 0 0 0 0 0 0 0 0 0 0 0 0 0\"/>",
            "it scales an axis by 0.000e0",
        ),
        (
            "<matrix value=\"1 0 0 0 0 nan 0 0 0 0 1 0 0 0 0 1\"/>",
            "'nan' is not a finite number",
        ),
        (
            "<rotate x=\"1\" angle=\"inf\"/>",
            "'inf' is not a finite number",
        ),
        (
            "<scale value=\"1e30\"/><scale value=\"1e30\"/>",
            "<scale> makes the transform overflow",
        ),
        (
            "<lookat origin=\"0 0 nan\" target=\"0 0 1\"/>",
            "'nan' is not a finite number in attribute 'origin' of <lookat>",
        ),
        (
            "<lookat origin=\"1 1 1\" target=\"1 1 1\"/>",
            "<lookat>: origin equals target",
        ),
    ];
    for (op, expected) in cases {
        let xml = scene_with(&format!(
            "<sensor type=\"perspective\"><transform name=\"toWorld\">{op}</transform></sensor>\
             <shape type=\"obj\"><string name=\"filename\" value=\"tetrahedron.obj\"/></shape>"
        ));
        let e = rejected(&dir, &xml);
        assert!(e.contains(expected), "{op}: {e}");
    }
    // The position is that of the offending value, or of the <transform> for the whole frame.
    let xml = scene_with("<sensor type=\"perspective\"><transform name=\"toWorld\"><scale value=\"0\"/></transform></sensor>");
    let e = rejected(&dir, &xml);
    assert!(
        e.starts_with(&format!(
            "1:{}: the camera's to_world cannot place a camera",
            column_of(&xml, "<transform")
        )),
        "{e}"
    );
}

#[test]
fn non_finite_geometry_is_rejected_where_it_is_given() {
    // Issue item 2 (obvhs panics on non-finite bounds; needs several primitives).
    let dir = temp_dir("geometry");
    let spheres =
        "<shape type=\"sphere\"/><shape type=\"sphere\"><point name=\"center\" x=\"3\"/></shape>";
    let cases = [
        ("<float name=\"radius\" value=\"nan\"/>", "'nan' is not a finite number in parameter 'radius' of shape 'sphere'"),
        ("<float name=\"radius\" value=\"inf\"/>", "'inf' is not a finite number"),
        ("<float name=\"radius\" value=\"1e39\"/>", "'1e39' is too large for a 32-bit float"),
        ("<float name=\"radius\" value=\"0\"/>", "sphere radius must be positive, found 0"),
        ("<point name=\"center\" x=\"nan\"/>", "'nan' is not a finite number"),
        ("<transform name=\"toWorld\"><translate x=\"inf\"/></transform>", "'inf' is not a finite number"),
        (
            "<transform name=\"toWorld\"><scale value=\"1e30\"/></transform><float name=\"radius\" value=\"1e10\"/>",
            "moved to world space by its to_world, the geometry reaches 1.000e40, beyond the 1e14 torrey supports",
        ),
        (
            "<float name=\"radius\" value=\"2e14\"/>",
            "the geometry reaches 2.000e14, beyond the 1e14 torrey supports",
        ),
    ];
    // Found by the render fuzzer: a rectangle scaled by 3.4e38 has finite corners but an
    // infinite extent, which made obvhs's builder panic.
    let xml = scene_with("<shape type=\"rectangle\"><transform name=\"toWorld\"><scale value=\"3.4e38\"/></transform></shape><shape type=\"rectangle\"/>");
    let e = rejected(&dir, &xml);
    assert!(e.ends_with("shape 'rectangle': moved to world space by its to_world, the geometry reaches 3.400e38, beyond the 1e14 torrey supports"), "{e}");
    let xml = scene_with("<emitter type=\"point\"><point name=\"position\" x=\"1e15\"/></emitter>");
    assert!(rejected(&dir, &xml).contains("reaches 1.000e15, beyond the 1e14 torrey supports"));
    let xml = scene_with("<sensor type=\"perspective\"><transform name=\"toWorld\"><translate x=\"3e38\"/></transform></sensor>");
    assert!(rejected(&dir, &xml)
        .contains("it places the origin 3.000e38 away, beyond the 1e14 torrey supports"));
    for (param, expected) in cases {
        let xml = scene_with(&format!("<shape type=\"sphere\">{param}</shape>{spheres}"));
        let e = rejected(&dir, &xml);
        assert!(e.contains(expected), "{param}: {e}");
    }
    // Mesh vertices: OBJ (with the line and column in the OBJ), PLY, serialized.
    std::fs::write(
        dir.join("nan.obj"),
        TETRAHEDRON.replace("v 1 -0.5 -3", "v 1 nan -3"),
    )
    .unwrap();
    let xml =
        scene_with("<shape type=\"obj\"><string name=\"filename\" value=\"nan.obj\"/></shape>");
    let e = rejected(&dir, &xml);
    assert!(e.ends_with("in mesh file 'nan.obj': line 3, column 5: vertex coordinate 'nan' is not a finite 32-bit float"), "{e}");

    let ply = "ply\nformat ascii 1.0\nelement vertex 3\nproperty float x\nproperty float y\nproperty float z\nelement face 2\nproperty list uchar int vertex_indices\nend_header\n0 0 0\n1 inf 0\n0 1 0\n3 0 1 2\n3 0 2 1\n";
    std::fs::write(dir.join("inf.ply"), ply).unwrap();
    let xml =
        scene_with("<shape type=\"ply\"><string name=\"filename\" value=\"inf.ply\"/></shape>");
    let e = rejected(&dir, &xml);
    assert!(
        e.ends_with("in mesh file 'inf.ply': vertex 1 has a position that is not finite (1 inf 0)"),
        "{e}"
    );

    std::fs::write(
        dir.join("nan.serialized"),
        serialized(
            &[[0.0, 0.0, 0.0], [1.0, f32::NAN, 0.0], [0.0, 1.0, 0.0]],
            &[],
            0,
        ),
    )
    .unwrap();
    let xml = scene_with(
        "<shape type=\"serialized\"><string name=\"filename\" value=\"nan.serialized\"/></shape>",
    );
    let e = rejected(&dir, &xml);
    assert!(
        e.ends_with("vertex 1 has a position that is not finite (1 NaN 0)"),
        "{e}"
    );
}

#[test]
fn deep_nesting_is_an_error_not_a_stack_overflow() {
    // Issue item 3: 20,000 nested elements overflowed the stack in substitute_tree.
    let dir = temp_dir("nesting");
    let n = 20_000;
    let xml = scene_with(&format!("{}{}", "<a>".repeat(n), "</a>".repeat(n)));
    let e = rejected(&dir, &xml);
    // <scene> is the first level: the 64th <a> is one too deep.
    let col = "<scene version=\"0.6.0\">".len() + 63 * 3 + 1;
    assert_eq!(
        e,
        format!(
            "1:{col}: elements are nested more than 64 deep (raise with --limit nesting_depth=N)"
        )
    );
}

/// A valid 1x1 EXR whose dataWindow is rewritten to claim `w` x `h` pixels.
fn lying_exr(path: &Path, w: i32, h: i32) {
    torrey_texture::write_exr(path, &torrey_texture::Image::filled(1, 1, glam::Vec3::ONE)).unwrap();
    let mut bytes = std::fs::read(path).unwrap();
    let key = b"dataWindow\0box2i\0";
    let at = bytes.windows(key.len()).position(|w| w == key).unwrap() + key.len() + 4;
    bytes[at + 8..at + 12].copy_from_slice(&(w - 1).to_le_bytes());
    bytes[at + 12..at + 16].copy_from_slice(&(h - 1).to_le_bytes());
    std::fs::write(path, &bytes).unwrap();
}

#[test]
fn lying_exr_header_is_refused_everywhere_images_are_read() {
    // Issue item 4: a few hundred bytes claiming 100000 x 100000 pixels aborted on a 40 GB
    // allocation as a bitmap, a normal map, an environment map and in `torrey compare`.
    let dir = temp_dir("exr");
    lying_exr(&dir.join("lying.exr"), 100_000, 100_000);
    let expected = "lying.exr: cannot decode image: OpenEXR header declares 100000 x 100000 pixels, more than the limit of 33554432 (raise with --limit image_pixels=N)";
    let bitmap = "<texture type=\"bitmap\" name=\"reflectance\"><string name=\"filename\" value=\"lying.exr\"/></texture>";
    let scenes = [
        format!("<shape type=\"sphere\"><bsdf type=\"diffuse\">{bitmap}</bsdf></shape>"),
        format!("<shape type=\"sphere\"><bsdf type=\"normalmap\">{}<bsdf type=\"diffuse\"/></bsdf></shape>", bitmap.replace("reflectance", "normalmap")),
        "<emitter type=\"envmap\"><string name=\"filename\" value=\"lying.exr\"/></emitter>".to_string(),
    ];
    for body in scenes {
        let xml = scene_with(&body);
        let e = rejected(&dir, &xml);
        assert!(
            e.starts_with(&format!("1:{}:", column_of(&xml, "lying.exr"))),
            "{e}"
        );
        assert!(e.ends_with(expected), "{e}");
    }
    let good = dir.join("good.exr");
    torrey_texture::write_exr(&good, &torrey_texture::Image::filled(1, 1, glam::Vec3::ONE))
        .unwrap();
    let out = torrey()
        .arg("compare")
        .arg(dir.join("lying.exr"))
        .arg(&good)
        .output()
        .unwrap();
    assert_eq!(out.status.code(), Some(1));
    assert!(out.stdout.is_empty());
    assert!(String::from_utf8_lossy(&out.stderr).contains(expected));
}

#[test]
fn only_regular_files_are_read() {
    // Issue item 5: `mtllib /dev/zero` read forever; filename="/dev/zero" said "not found".
    let dir = temp_dir("devzero");
    std::fs::write(
        dir.join("m.obj"),
        format!("mtllib /dev/zero\n{TETRAHEDRON}"),
    )
    .unwrap();
    let xml = scene_with("<shape type=\"obj\"><string name=\"filename\" value=\"m.obj\"/></shape>");
    let (_, out) = run(&dir, &xml, &[]);
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    std::fs::remove_file(dir.join("out.exr")).unwrap();
    std::fs::remove_file(dir.join("out.png")).unwrap();
    if Path::new("/dev/zero").exists() {
        let xml = scene_with(
            "<shape type=\"obj\"><string name=\"filename\" value=\"/dev/zero\"/></shape>",
        );
        let e = rejected(&dir, &xml);
        assert!(
            e.ends_with("mesh file '/dev/zero' is not a regular file (looked at '/dev/zero')"),
            "{e}"
        );
        let xml = scene_with(
            "<emitter type=\"envmap\"><string name=\"filename\" value=\"/dev/zero\"/></emitter>",
        );
        let e = rejected(&dir, &xml);
        assert!(
            e.ends_with("texture file '/dev/zero' is not a regular file (looked at '/dev/zero')"),
            "{e}"
        );
        let out = torrey().arg("/dev/zero").output().unwrap();
        assert_eq!(out.status.code(), Some(1));
        assert_eq!(
            String::from_utf8_lossy(&out.stderr),
            "/dev/zero:1:1: error: cannot read scene file: '/dev/zero' is not a regular file\n"
        );
    }
}

const GOOD: &str = "<scene version=\"0.6.0\"><sensor type=\"perspective\"><transform name=\"toWorld\"><lookat origin=\"0 0 4\" target=\"0 0 0\"/></transform></sensor><shape type=\"sphere\"/></scene>";

#[test]
fn output_is_all_or_nothing() {
    // Issue item 10: a write that fails after the EXR left a complete EXR and a bad PNG.
    let dir = temp_dir("atomic");
    let scene = dir.join("s.xml");
    std::fs::write(&scene, GOOD).unwrap();
    // The PNG cannot be written: its path is a folder.
    std::fs::create_dir_all(dir.join("out.png")).unwrap();
    let out = torrey()
        .arg(&scene)
        .args(["--quiet", "--size", "8x6", "-o"])
        .arg(dir.join("out.exr"))
        .output()
        .unwrap();
    assert_eq!(out.status.code(), Some(1));
    assert!(String::from_utf8_lossy(&out.stderr).contains("(no image was written)"));
    let left: Vec<String> = std::fs::read_dir(&dir)
        .unwrap()
        .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
        .collect();
    let mut left = left;
    left.sort();
    assert_eq!(left, ["out.png", "s.xml"], "no EXR, no temporary files");

    // A film filename cannot place the output outside the current folder.
    let escaping = GOOD.replace("</sensor>", "<film type=\"hdrfilm\"><string name=\"filename\" value=\"../../escaped/name.exr\"/></film></sensor>");
    std::fs::create_dir_all(dir.join("cwd")).unwrap();
    std::fs::write(dir.join("cwd/e.xml"), escaping).unwrap();
    let ok = torrey()
        .current_dir(dir.join("cwd"))
        .args(["e.xml", "--quiet", "--size", "8x6"])
        .status()
        .unwrap();
    assert!(ok.success());
    assert!(dir.join("cwd/name.exr").exists() && dir.join("cwd/name.png").exists());

    // Four renders writing the same path: the result is one of them, whole.
    let shared = dir.join("shared.exr");
    let mut children = Vec::new();
    for seed in 1..=4 {
        children.push(
            torrey()
                .arg(&scene)
                .args([
                    "--quiet",
                    "--size",
                    "32x24",
                    "--spp",
                    "2",
                    "--seed",
                    &seed.to_string(),
                    "-o",
                ])
                .arg(&shared)
                .spawn()
                .unwrap(),
        );
    }
    for mut c in children {
        assert!(c.wait().unwrap().success());
    }
    let mut singles = Vec::new();
    for seed in 1..=4 {
        let p = dir.join(format!("single{seed}.exr"));
        let ok = torrey()
            .arg(&scene)
            .args([
                "--quiet",
                "--size",
                "32x24",
                "--spp",
                "2",
                "--seed",
                &seed.to_string(),
                "-o",
            ])
            .arg(&p)
            .status()
            .unwrap();
        assert!(ok.success());
        singles.push(std::fs::read(&p).unwrap());
    }
    let result = std::fs::read(&shared).unwrap();
    assert!(
        singles.contains(&result),
        "the shared EXR matches none of the renders"
    );
}

#[test]
fn compare_fails_on_nan_and_reports_write_errors_first() {
    let dir = temp_dir("compare");
    let img = |name: &str, v: f32| {
        let p = dir.join(name);
        torrey_texture::write_exr(
            &p,
            &torrey_texture::Image::filled(4, 3, glam::Vec3::splat(v)),
        )
        .unwrap();
        p
    };
    let nan = img("nan.exr", f32::NAN);
    let zero = img("zero.exr", 0.0);
    let half = img("half.exr", 0.5);
    // NaN against NaN: not "RMSE 0, ratio 1", but a failure that counts the pixels.
    let out = torrey()
        .arg("compare")
        .arg(&nan)
        .arg(&nan)
        .output()
        .unwrap();
    assert_eq!(out.status.code(), Some(1));
    let stdout = String::from_utf8_lossy(&out.stdout);
    assert!(
        stdout.contains("NaN/inf pixels   A 12, B 12, variance 0"),
        "{stdout}"
    );
    assert!(String::from_utf8_lossy(&out.stderr)
        .contains("comparison failed: NaN or infinite pixels (A: 12, B: 12, variance: 0)"));
    // A zero reference: finite errors, an undefined ratio, success.
    let out = torrey()
        .arg("compare")
        .arg(&half)
        .arg(&zero)
        .output()
        .unwrap();
    assert!(out.status.success());
    let stdout = String::from_utf8_lossy(&out.stdout);
    assert!(stdout.contains("RMSE             5.000000e-1"), "{stdout}");
    assert!(
        stdout.contains("mean ratio A/B   undefined (B's mean is 0)"),
        "{stdout}"
    );
    // A heatmap that cannot be written: the error, and no numbers.
    let out = torrey()
        .arg("compare")
        .arg(&half)
        .arg(&zero)
        .arg("--heatmap")
        .arg(dir.join("missing/dir/h.png"))
        .output()
        .unwrap();
    assert_eq!(out.status.code(), Some(1));
    assert!(
        out.stdout.is_empty(),
        "{}",
        String::from_utf8_lossy(&out.stdout)
    );
    assert!(String::from_utf8_lossy(&out.stderr).contains("h.png"));
}

#[test]
fn silent_oddities_now_speak() {
    let dir = temp_dir("oddities");
    let cases = [
        ("<emitter type=\"envmap\"><string name=\"filename\" value=\"sky.exr\"/><float name=\"scale\" value=\"-1\"/></emitter>", "parameter 'scale' of emitter 'envmap' must not be negative, found -1"),
        ("<emitter type=\"envmap\"><string name=\"filename\" value=\"sky.exr\"/><float name=\"scale\" value=\"nan\"/></emitter>", "'nan' is not a finite number"),
        ("<emitter type=\"point\"><rgb name=\"intensity\" value=\"-1 0 0\"/></emitter>", "parameter 'intensity' of emitter 'point' must not be negative, found -1 0 0"),
        ("<shape type=\"sphere\"><emitter type=\"area\"><rgb name=\"radiance\" value=\"inf\"/></emitter></shape>", "'inf' is not a finite number"),
        ("<shape type=\"sphere\"><bsdf type=\"diffuse\"><rgb name=\"reflectance\" value=\"-0.5\"/></bsdf></shape>", "must not be negative"),
        ("<bsdf type=\"plastic\"><float name=\"eta\" value=\"0\"/></bsdf>", "parameter 'eta' of bsdf 'plastic' must be positive, found 0"),
        ("<bsdf type=\"phong\"><float name=\"exponent\" value=\"-3\"/></bsdf>", "parameter 'exponent' of bsdf 'phong' must be at least 0, found -3"),
        ("<sensor type=\"perspective\"><float name=\"near_clip\" value=\"0\"/></sensor>", "parameter 'near_clip' of sensor 'perspective' must be positive, found 0"),
        ("<sensor type=\"perspective\"><film type=\"hdrfilm\"><rfilter type=\"gaussian\"><float name=\"stddev\" value=\"0\"/></rfilter></film></sensor>", "must be positive, found 0"),
    ];
    torrey_texture::write_exr(
        &dir.join("sky.exr"),
        &torrey_texture::Image::filled(4, 2, glam::Vec3::ONE),
    )
    .unwrap();
    for (body, expected) in cases {
        let e = rejected(&dir, &scene_with(body));
        assert!(e.contains(expected), "{body}: {e}");
    }
    let xml = scene_with("<emitter type=\"envmap\"><string name=\"filename\" value=\"sky.exr\"/><transform name=\"toWorld\"><scale value=\"0\"/></transform></emitter>");
    let e = rejected(&dir, &xml);
    assert!(e.starts_with(&format!("1:{}: the envmap's to_world cannot orient an environment: it scales an axis by 0.000e0", column_of(&xml, "<transform"))), "{e}");
    // Renderable but implausible: a warning, and the render goes on.
    let xml = scene_with("<default name=\"r\" value=\"10\"/><default name=\"r\" value=\"0.5\"/><shape type=\"sphere\"><bsdf type=\"diffuse\"><rgb name=\"reflectance\" value=\"$r\"/></bsdf></shape>");
    let (scene, out) = run(&dir, &xml, &[]);
    assert!(out.status.success());
    let stderr = String::from_utf8_lossy(&out.stderr);
    let s = scene.display();
    assert!(
        stderr.contains(&format!(
            "{s}:1:{}: warning: <default name=\"r\"> is given again; the first value is used",
            column_of(&xml, "<default name=\"r\" value=\"0.5\"")
        )),
        "{stderr}"
    );
    assert!(
        stderr.contains(
            "warning: parameter 'reflectance' of bsdf 'diffuse' is 10 10 10, above 1: the surface scatters more light than it receives"
        ),
        "{stderr}"
    );
    // Once per scene: a thousand such bsdfs give one line with a count.
    let many = "<bsdf type=\"diffuse\"><rgb name=\"reflectance\" value=\"2\"/></bsdf>".repeat(1000);
    let (_, out) = run(&dir, &scene_with(&many), &[]);
    assert!(out.status.success());
    let stderr = String::from_utf8_lossy(&out.stderr);
    let warnings: Vec<&str> = stderr.lines().filter(|l| l.contains("warning")).collect();
    assert_eq!(warnings.len(), 1, "{stderr}");
    assert!(
        warnings[0].ends_with(
            "scatters more light than it receives (999 more like it in this scene; not listed)"
        ),
        "{stderr}"
    );
    // A 10 MB attribute value is not echoed in full: the error stays one short line.
    std::fs::remove_file(dir.join("out.exr")).unwrap();
    std::fs::remove_file(dir.join("out.png")).unwrap();
    let xml = scene_with(&format!("<shape type=\"{}\"/>", "x".repeat(10 << 20)));
    let e = rejected(&dir, &xml);
    assert!(
        e.len() < 500 && e.contains("characters left out"),
        "{}",
        &e[..e.len().min(600)]
    );
}

/// Issue 34, item 5: finite samples whose sums or squares leave f32's range (a reflectance of
/// 1e30, an environment map or an emitted radiance with one texel near f32::MAX, a splatting
/// filter) render with exit 0 to images, means and variances, that hold no NaN or infinity: the
/// film sums in f64 and clamps to f32::MAX, and the run says how many pixels it clamped. Before,
/// the variance (f32 Welford sums of squares) came out infinite.
#[test]
fn huge_sample_values_never_make_infinite_pixels() {
    let dir = temp_dir("huge");
    let mut sky = torrey_texture::Image::filled(8, 4, glam::Vec3::splat(0.5));
    sky.pixels[9] = glam::Vec3::new(3.0e38, 1.0, 3.3e38);
    torrey_texture::write_exr(&dir.join("huge.exr"), &sky).unwrap();
    let camera = r#"<integrator type="path"><integer name="max_depth" value="3"/></integrator>
        <sensor type="perspective"><float name="fov" value="100"/>
            <transform name="to_world"><lookat origin="0,0,3" target="0,0,0" up="0,1,0"/></transform>
            <film type="hdrfilm"><integer name="width" value="8"/><integer name="height" value="6"/>FILTER</film></sensor>"#;
    let scenes = [
        (
            "reflectance 1e30",
            r#"<shape type="sphere"><bsdf type="diffuse"><rgb name="reflectance" value="1e30"/></bsdf></shape>
               <emitter type="constant"><rgb name="radiance" value="1"/></emitter>"#,
            "",
        ),
        (
            "one huge envmap texel",
            r#"<shape type="sphere"><bsdf type="diffuse"/></shape>
               <emitter type="envmap"><string name="filename" value="huge.exr"/></emitter>"#,
            "",
        ),
        (
            "one huge emitted texel, splatted by lanczos",
            r#"<shape type="rectangle"><transform name="to_world"><scale value="2"/></transform>
                 <emitter type="area"><texture type="bitmap" name="radiance"><string name="filename" value="huge.exr"/></texture></emitter></shape>
               <shape type="sphere"><transform name="to_world"><translate z="-2"/></transform><bsdf type="diffuse"/></shape>"#,
            r#"<rfilter type="lanczos"/>"#,
        ),
    ];
    for (what, body, filter) in scenes {
        let xml = format!(
            "<scene version=\"3.0.0\">{}{body}</scene>",
            camera.replace("FILTER", filter)
        );
        std::fs::write(dir.join("scene.xml"), &xml).unwrap();
        let out = torrey()
            .arg(dir.join("scene.xml"))
            .args(["--spp", "64", "-o"])
            .arg(dir.join("out.exr"))
            .output()
            .unwrap();
        let stderr = String::from_utf8_lossy(&out.stderr);
        assert!(out.status.success(), "{what}: {stderr}");
        let part =
            torrey_parts::read_part(&dir.join("out.exr")).unwrap_or_else(|e| panic!("{what}: {e}"));
        let values = || {
            part.mean
                .iter()
                .chain(&part.variance)
                .flat_map(|v| v.to_array())
        };
        assert!(values().all(f32::is_finite), "{what}");
        // Something did leave the range, was clamped, and the run says so.
        assert!(values().any(|v| v == f32::MAX), "{what}");
        assert!(part.meta.clamped > 0, "{what}");
        assert!(
            stderr.contains("pixels had a mean or variance beyond the largest 32-bit float"),
            "{what}: {stderr}"
        );
        // `torrey compare` accepts the image: no NaN or infinite pixel.
        let out = torrey()
            .arg("compare")
            .arg(dir.join("out.exr"))
            .arg(dir.join("out.exr"))
            .output()
            .unwrap();
        assert!(
            out.status.success(),
            "{what}: {}",
            String::from_utf8_lossy(&out.stdout)
        );
    }
}
