//! Exact slicing: `--crop` and `--sample-range` parts merged by `torrey merge` equal the one-piece
//! render (crops bit for bit, sample ranges to float rounding), with both samplers, sample ranges
//! that cut packets of eight, and a textured scene; parts that do not belong together are refused.

use std::path::{Path, PathBuf};
use std::process::Command;
use torrey_parts::{read_part, Part};

fn temp_dir(name: &str) -> PathBuf {
    let dir = std::env::temp_dir().join(format!("torrey-slicing-{}-{name}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    dir
}

fn scene(name: &str) -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("scenes")
        .join(name)
}

/// Runs torrey with `args`; panics with its stderr if it fails.
fn run(args: &[&str]) {
    let out = Command::new(env!("CARGO_BIN_EXE_torrey"))
        .args(args)
        .output()
        .unwrap();
    assert!(
        out.status.success(),
        "torrey {args:?}: {}",
        String::from_utf8_lossy(&out.stderr)
    );
}

fn fails(args: &[&str]) -> String {
    let out = Command::new(env!("CARGO_BIN_EXE_torrey"))
        .args(args)
        .output()
        .unwrap();
    assert!(!out.status.success(), "torrey {args:?} should fail");
    String::from_utf8_lossy(&out.stderr).into_owned()
}

/// Largest per-pixel, per-channel relative difference of mean and variance.
fn max_relative_difference(a: &Part, b: &Part) -> f64 {
    assert_eq!(a.mean.len(), b.mean.len());
    let pairs = a
        .mean
        .iter()
        .zip(&b.mean)
        .chain(a.variance.iter().zip(&b.variance));
    let mut worst = 0.0f64;
    for (p, q) in pairs {
        for c in 0..3 {
            let (x, y) = (p[c] as f64, q[c] as f64);
            worst = worst.max((x - y).abs() / x.abs().max(y.abs()).max(1e-30));
        }
    }
    worst
}

/// Renders `scene` whole and in parts (`slices`: crop and sample range arguments), merges the
/// parts and returns (one-piece part, merged part).
fn split_and_merge(
    dir: &Path,
    scene: &Path,
    common: &[&str],
    slices: &[(&str, &str)],
) -> (Part, Part) {
    let full = dir.join("full.exr");
    let scene = scene.to_str().unwrap();
    let mut args = vec![scene, "--quiet", "-o", full.to_str().unwrap()];
    args.extend(common);
    run(&args);
    let mut merge_args = vec!["merge".to_string()];
    for (i, (crop, range)) in slices.iter().enumerate() {
        let part = dir.join(format!("part{i}.exr"));
        let part = part.to_str().unwrap();
        let mut args = vec![
            scene,
            "--quiet",
            "-o",
            part,
            "--crop",
            crop,
            "--sample-range",
            range,
        ];
        args.extend(common);
        run(&args);
        merge_args.push(part.to_string());
    }
    let merged = dir.join("merged.exr");
    merge_args.extend(["-o".to_string(), merged.to_str().unwrap().to_string()]);
    let merge_refs: Vec<&str> = merge_args.iter().map(String::as_str).collect();
    run(&merge_refs);
    assert!(merged.with_extension("png").exists());
    (read_part(&full).unwrap(), read_part(&merged).unwrap())
}

#[test]
fn split_renders_merge_into_the_one_piece_render() {
    let dir = temp_dir("merge");
    let mut worst = 0.0f64;
    for sampler in ["sobol", "independent"] {
        let common = ["--size", "20x14", "--spp", "21", "--sampler", sampler];
        // Four unequal tiles, the sample ranges cutting the packet groups 0..8, 8..16, 16..21
        // differently in each tile.
        let slices = [
            ("0,0,13,9", "0..21"),
            ("13,0,7,9", "0..3"),
            ("13,0,7,9", "3..11"),
            ("13,0,7,9", "11..21"),
            ("0,9,13,5", "0..8"),
            ("0,9,13,5", "8..9"),
            ("0,9,13,5", "9..21"),
            ("13,9,7,5", "0..17"),
            ("13,9,7,5", "17..21"),
        ];
        let (full, merged) = split_and_merge(&dir, &scene("textured_mesh.xml"), &common, &slices);
        assert_eq!(
            merged.meta, full.meta,
            "{sampler}: the merged part is the whole render"
        );
        assert!(full.mean.iter().any(|p| p.max_element() > 0.0));
        // The whole-range tile is the one-piece render's pixels bit for bit.
        for y in 0..9 {
            for x in 0..13 {
                assert_eq!(merged.mean[y * 20 + x], full.mean[y * 20 + x]);
            }
        }
        let d = max_relative_difference(&full, &merged);
        eprintln!("{sampler}: merged vs one-piece, max relative difference {d:e}");
        assert!(d < 1e-4, "{sampler}: {d}");
        worst = worst.max(d);
    }
    eprintln!("max relative difference over both samplers: {worst:e}");
    std::fs::remove_dir_all(&dir).ok();
}

/// A filter with negative lobes (lanczos, 3 lobes) splats every sample into the pixels up to
/// three away: a crop's render also draws the samples around it, and sample ranges merge by
/// their weight sums. The whole-range crop is the one-piece render's pixels bit for bit (means
/// and variances); the merged means are the one-piece means to float rounding; the merged
/// variance (that of the merged mean, from the parts' variances) agrees over the image.
#[test]
fn split_renders_merge_with_a_negative_lobed_filter() {
    let dir = temp_dir("lanczos");
    let lanczos =
        Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/scenes/mitsuba/filter_lanczos.xml");
    let common = ["--size", "20x14", "--spp", "21", "--sampler", "independent"];
    let slices = [
        ("0,0,13,9", "0..21"),
        ("13,0,7,9", "0..3"),
        ("13,0,7,9", "3..11"),
        ("13,0,7,9", "11..21"),
        ("0,9,20,5", "0..8"),
        ("0,9,20,5", "8..21"),
    ];
    let (full, merged) = split_and_merge(&dir, &lanczos, &common, &slices);
    assert_eq!(merged.meta, full.meta);
    // Splat weights are not counts (the merge weighs by them).
    assert!(full
        .weight
        .iter()
        .zip(&full.count)
        .any(|(&w, &n)| w != n as f32));
    for y in 0..9 {
        for x in 0..13 {
            let i = y * 20 + x;
            assert_eq!(merged.mean[i], full.mean[i], "pixel {x},{y}");
            assert_eq!(merged.variance[i], full.variance[i], "pixel {x},{y}");
        }
    }
    let (mut worst, mut merged_var, mut one_var) = (0.0f64, 0.0f64, 0.0f64);
    for (i, (a, b)) in full.mean.iter().zip(&merged.mean).enumerate() {
        // Relative to the pixel's scale: signed weights can cancel within a channel.
        let scale = a.abs().max_element().max(1e-3) as f64;
        worst = worst.max((*a - *b).abs().max_element() as f64 / scale);
        merged_var += merged.variance[i].element_sum() as f64;
        one_var += full.variance[i].element_sum() as f64;
    }
    eprintln!(
        "lanczos: merged vs one-piece means {worst:e}, variance ratio {}",
        merged_var / one_var
    );
    assert!(worst < 1e-4, "{worst}");
    assert!(
        (0.8..1.25).contains(&(merged_var / one_var)),
        "{}",
        merged_var / one_var
    );
    std::fs::remove_dir_all(&dir).ok();
}

#[test]
fn part_exrs_record_scene_settings_and_slice() {
    let dir = temp_dir("meta");
    let out = dir.join("p.exr");
    let cbox = scene("cbox.xml");
    run(&[
        cbox.to_str().unwrap(),
        "--quiet",
        "--size",
        "16x12",
        "--spp",
        "9",
        "--seed",
        "7",
        "--max-depth",
        "3",
        "--crop",
        "2,3,5,4",
        "--sample-range",
        "4..9",
        "-o",
        out.to_str().unwrap(),
    ]);
    let m = read_part(&out).unwrap().meta;
    assert_eq!(m.scene, cbox.display().to_string());
    assert_eq!(m.scene_hash.len(), 16);
    assert_eq!((m.width, m.height, m.spp), (16, 12, 9));
    assert_eq!((m.samples, m.crop), ((4, 9), (2, 3, 5, 4)));
    assert!(
        m.settings.starts_with("seed=7 max_depth=3 "),
        "{}",
        m.settings
    );
    assert!(m.settings.contains("sampler=sobol"), "{}", m.settings);
    std::fs::remove_dir_all(&dir).ok();
}

#[test]
fn merge_refuses_parts_that_do_not_belong_together() {
    let dir = temp_dir("refuse");
    let cbox = scene("cbox.xml");
    let spheres = scene("cbox_spheres.xml");
    let part = |name: &str, scene: &Path, extra: &[&str]| {
        let out = dir.join(name);
        let mut args = vec![
            scene.to_str().unwrap(),
            "--quiet",
            "--size",
            "8x6",
            "--spp",
            "4",
            "-o",
            out.to_str().unwrap(),
        ];
        args.extend(extra);
        run(&args);
        out.to_str().unwrap().to_string()
    };
    let a = part("a.exr", &cbox, &["--sample-range", "0..2"]);
    let b = part("b.exr", &cbox, &["--sample-range", "2..4"]);
    let overlap = part("o.exr", &cbox, &["--sample-range", "1..3"]);
    let seed = part("s.exr", &cbox, &["--sample-range", "2..4", "--seed", "9"]);
    let other = part("x.exr", &spheres, &["--sample-range", "2..4"]);
    let tile = part("t.exr", &cbox, &["--crop", "0,0,4,6"]);
    let out = dir.join("m.exr");
    let out = out.to_str().unwrap();
    let merge = |parts: &[&str]| {
        let mut args = vec!["merge"];
        args.extend(parts);
        args.extend(["-o", out]);
        fails(&args)
    };
    assert!(merge(&[&a, &overlap]).contains("overlap: both hold samples 1..2"));
    assert!(merge(&[&a]).contains("missing samples 2..4 of crop 0,0,8,6"));
    assert!(merge(&[&a, &seed]).contains("other settings"));
    assert!(merge(&[&a, &other]).contains("other scene contents"));
    let missing = merge(&[&a, &b, &tile]);
    assert!(missing.contains("overlap at pixel 0,0"), "{missing}");
    let t2 = part("t2.exr", &cbox, &["--crop", "4,0,4,5"]);
    let hole = merge(&[&tile, &t2]);
    assert!(
        hole.contains("missing pixels: no part covers 4 pixels of the 8x6 film, the first at 4,5"),
        "{hole}"
    );
    assert!(!Path::new(out).exists(), "no output on error");
    std::fs::remove_dir_all(&dir).ok();
}

/// Mitsuba's film crop parameters render the window, as `--crop` does; `--size` drops them.
#[test]
fn film_crop_parameters_render_a_window() {
    let dir = temp_dir("filmcrop");
    let scene = |crop: &str| {
        format!(
            r#"<scene version="3.0.0">
  <sensor type="perspective"><float name="fov" value="40"/>
    <transform name="to_world"><lookat origin="0, 0, 4" target="0, 0, 0" up="0, 1, 0"/></transform>
    <film type="hdrfilm"><integer name="width" value="20"/><integer name="height" value="16"/>{crop}</film>
  </sensor>
  <shape type="sphere"><bsdf type="diffuse"/></shape>
  <emitter type="constant"><rgb name="radiance" value="1, 1, 1"/></emitter>
</scene>"#
        )
    };
    let cropped = dir.join("cropped.xml");
    std::fs::write(
        &cropped,
        scene(
            r#"<integer name="crop_offset_x" value="3"/><integer name="crop_offset_y" value="5"/>
    <integer name="crop_width" value="9"/><integer name="crop_height" value="7"/>"#,
        ),
    )
    .unwrap();
    let plain = dir.join("plain.xml");
    std::fs::write(&plain, scene("")).unwrap();
    let (a, b) = (dir.join("a.exr"), dir.join("b.exr"));
    let s = |p: &Path| p.to_str().unwrap().to_string();
    run(&[&s(&cropped), "--quiet", "--spp", "4", "-o", &s(&a)]);
    run(&[
        &s(&plain),
        "--quiet",
        "--spp",
        "4",
        "--crop",
        "3,5,9,7",
        "-o",
        &s(&b),
    ]);
    let (a, b) = (read_part(&a).unwrap(), read_part(&b).unwrap());
    assert_eq!(a.meta.crop, (3, 5, 9, 7));
    assert!(a.mean.iter().any(|p| p.max_element() > 0.0));
    // The same samples, except that the crop window's samples stay inside it (as Mitsuba's):
    // pixels beyond the gaussian's reach (2 px) of its edges are identical, edge pixels are not.
    let (mut same, mut edge_differs) = (0, false);
    for y in 0..7 {
        for x in 0..9 {
            let i = y * 9 + x;
            if (2..7).contains(&x) && (2..5).contains(&y) {
                assert_eq!(a.mean[i], b.mean[i], "pixel ({x}, {y})");
                same += 1;
            } else if x == 0 || y == 0 || x == 8 || y == 6 {
                edge_differs |= a.mean[i] != b.mean[i];
            }
        }
    }
    assert_eq!(same, 15);
    assert!(
        edge_differs,
        "the crop window's edge pixels kept samples from outside it"
    );
    // A --crop outside the film's crop window is refused.
    let err = fails(&[
        &s(&cropped),
        "--quiet",
        "--crop",
        "0,0,4,4",
        "-o",
        &s(&dir.join("d.exr")),
    ]);
    assert!(
        err.contains("not inside the film's crop window 9x7 at (3, 5)"),
        "{err}"
    );
    let out = Command::new(env!("CARGO_BIN_EXE_torrey"))
        .args([
            &s(&cropped),
            "--quiet",
            "--spp",
            "1",
            "--size",
            "10x8",
            "-o",
            &s(&dir.join("c.exr")),
        ])
        .output()
        .unwrap();
    assert!(out.status.success());
    assert!(String::from_utf8_lossy(&out.stderr).contains("crop window is ignored"));
    assert_eq!(
        read_part(&dir.join("c.exr")).unwrap().meta.crop,
        (0, 0, 10, 8)
    );
    std::fs::remove_dir_all(&dir).ok();
}
