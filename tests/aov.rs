//! Mitsuba's `aov` integrator: torrey writes the channels Mitsuba 3.9.1 writes, under its names,
//! with its values (tests/scenes/aov/aov.xml against tests/references/aov/aov.exr, made by
//! tests/mitsuba/make_aov_reference.py at 1024 spp); and the AOV layers survive `--crop`,
//! `--sample-range` and `torrey merge`.

use std::collections::HashMap;
use std::path::{Path, PathBuf};
use std::process::Command;
use torrey_parts::{read_part, Part};

fn root() -> &'static Path {
    Path::new(env!("CARGO_MANIFEST_DIR"))
}

fn temp_dir(name: &str) -> PathBuf {
    let dir = std::env::temp_dir().join(format!("torrey-aov-{}-{name}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    dir
}

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

/// Every channel of an EXR, by name (row by row).
fn channels(path: &Path) -> (usize, usize, HashMap<String, Vec<f32>>) {
    use exr::prelude::*;
    let image = read()
        .no_deep_data()
        .largest_resolution_level()
        .all_channels()
        .first_valid_layer()
        .all_attributes()
        .from_file(path)
        .unwrap();
    let layer = &image.layer_data;
    let map = layer
        .channel_data
        .list
        .iter()
        .map(|c| {
            (
                c.name.to_string(),
                c.sample_data.values_as_f32().collect::<Vec<f32>>(),
            )
        })
        .collect();
    (layer.size.width(), layer.size.height(), map)
}

/// Tolerances on the pixels well inside one shape (all 3x3 neighbours on it in both renders):
/// mean and largest absolute difference per channel. They leave room for the two renders'
/// sampling of each pixel's footprint (both at 1024 spp: Mitsuba scales the uv partials by
/// 1/sqrt(spp)), and catch a wrong convention: depth from the pinhole instead of the near plane
/// is 0.01 off everywhere; the uv partials of a 256-spp render (twice Mitsuba's at 1024) fail
/// by tenfold; a wrong albedo is off by the Fresnel factors.
const TOLERANCES: &[(&str, f64, f64)] = &[
    ("dd.y.T", 0.002, 0.02),
    ("pp.", 0.002, 0.02),
    ("nn.", 0.002, 0.06),
    ("gn.", 0.002, 0.06),
    ("uv.", 0.002, 0.06),
    ("aa.", 0.002, 0.05),
    ("du.", 0.006, 0.25),
    ("dv.", 0.006, 0.25),
    ("ux.", 5e-5, 0.003),
    ("uy.", 5e-5, 0.003),
];

#[test]
fn aov_channels_match_mitsuba() {
    let dir = temp_dir("mitsuba");
    let out = dir.join("aov.exr");
    let scene = root().join("tests/scenes/aov/aov.xml");
    run(&[
        scene.to_str().unwrap(),
        "--quiet",
        "--spp",
        "1024",
        "-o",
        out.to_str().unwrap(),
    ]);
    let (w, h, ours) = channels(&out);
    let (rw, rh, theirs) = channels(&root().join("tests/references/aov/aov.exr"));
    assert_eq!((w, h), (rw, rh));

    // Mitsuba's names, every one of them: the image, the inner integrator's RGBA, the AOVs.
    let mut missing: Vec<&String> = theirs.keys().filter(|k| !ours.contains_key(*k)).collect();
    missing.sort();
    assert!(
        missing.is_empty(),
        "channels Mitsuba writes and torrey does not: {missing:?}"
    );
    for name in [
        "dd.y.T",
        "nn.X",
        "aa.R",
        "ux.U",
        "uy.V",
        "pi.I",
        "si.I",
        "my_image.A",
    ] {
        assert!(theirs.contains_key(name), "{name}");
    }

    // The inner integrator's image is the image.
    for c in ["R", "G", "B"] {
        assert_eq!(ours[c], ours[&format!("my_image.{c}")], "my_image.{c}");
    }
    // Alpha: camera rays that hit something (no environment to see).
    let alpha = |m: &HashMap<String, Vec<f32>>| m["my_image.A"].clone();
    let (a, b) = (alpha(&ours), alpha(&theirs));
    let d = a
        .iter()
        .zip(&b)
        .map(|(x, y)| (x - y).abs() as f64)
        .sum::<f64>()
        / a.len() as f64;
    assert!(d < 0.003, "alpha: mean difference {d}");
    assert!(a.contains(&0.0) && a.contains(&1.0));

    // Shapes: Mitsuba numbers them in the order its loader created them (not the file's), so
    // the regions must match up to a renaming, one to one.
    let (si, msi) = (&ours["si.I"], &theirs["si.I"]);
    let index = |v: f32| (v.fract() == 0.0).then_some(v as i32);
    let mut pairs: HashMap<i32, i32> = HashMap::new();
    let mut interior = vec![false; w * h];
    for y in 1..h - 1 {
        for x in 1..w - 1 {
            let i = y * w + x;
            let same = |m: &[f32]| (0..9).all(|k| m[(y + k / 3 - 1) * w + x + k % 3 - 1] == m[i]);
            if let (Some(a), Some(b)) = (index(si[i]), index(msi[i])) {
                if same(si) && same(msi) && a > 0 {
                    let mapped = *pairs.entry(b).or_insert(a);
                    assert_eq!(
                        mapped, a,
                        "pixel {x},{y}: Mitsuba's shape {b} is ours {a} and {mapped}"
                    );
                    interior[i] = true;
                }
            }
        }
    }
    let mut ours_seen: Vec<i32> = pairs.values().copied().collect();
    ours_seen.sort();
    ours_seen.dedup();
    assert_eq!((pairs.len(), ours_seen.len()), (4, 4), "{pairs:?}");
    let inside = interior.iter().filter(|&&b| b).count();
    assert!(inside > 500, "{inside} interior pixels");

    for (prefix, mean_tol, max_tol) in TOLERANCES {
        for (name, mine) in ours.iter().filter(|(n, _)| n.starts_with(prefix)) {
            let theirs = &theirs[name];
            let (mut sum, mut worst, mut n) = (0.0f64, 0.0f64, 0);
            for i in (0..w * h).filter(|&i| interior[i] && theirs[i].is_finite()) {
                let d = (mine[i] - theirs[i]).abs() as f64;
                sum += d;
                worst = worst.max(d);
                n += 1;
            }
            let mean = sum / n as f64;
            assert!(
                mean <= *mean_tol && worst <= *max_tol,
                "{name}: mean |difference| {mean:.3e} (at most {mean_tol:.0e}), largest {worst:.3e} (at most {max_tol:.0e}) over {n} pixels"
            );
        }
    }
    // Triangle indices: equal on the floor (12 triangles, each pixel inside one), close on
    // average where pixels straddle the torus' triangles.
    let (pi, mpi) = (&ours["pi.I"], &theirs["pi.I"]);
    let floor = pairs.iter().find(|(&m, _)| m == 3).map(|(_, &o)| o);
    let mut equal = 0;
    for i in (0..w * h).filter(|&i| interior[i]) {
        if index(si[i]) == floor && index(pi[i]).is_some() && index(mpi[i]).is_some() {
            assert_eq!(pi[i], mpi[i], "floor pixel {i}");
            equal += 1;
        }
    }
    assert!(equal > 100, "{equal} floor pixels");
}

/// AOV layers are parts' channels: a crop and a sample range merge into the one-piece render's
/// AOVs (crops bit for bit, ranges by their counts to float rounding).
#[test]
fn aov_layers_survive_slicing_and_merging() {
    let dir = temp_dir("slices");
    let scene = root().join("tests/scenes/aov/aov.xml");
    let scene = scene.to_str().unwrap();
    let path = |n: &str| dir.join(n).to_str().unwrap().to_string();
    run(&[scene, "--quiet", "--spp", "24", "-o", &path("full.exr")]);
    for (name, crop, range) in [
        ("a.exr", "0,0,48,20", "0..24"),
        ("b.exr", "0,20,48,16", "0..9"),
        ("c.exr", "0,20,48,16", "9..24"),
    ] {
        run(&[
            scene,
            "--quiet",
            "--spp",
            "24",
            "--crop",
            crop,
            "--sample-range",
            range,
            "-o",
            &path(name),
        ]);
    }
    run(&[
        "merge",
        &path("a.exr"),
        &path("b.exr"),
        &path("c.exr"),
        "-o",
        &path("merged.exr"),
    ]);
    let full: Part = read_part(Path::new(&path("full.exr"))).unwrap();
    let merged = read_part(Path::new(&path("merged.exr"))).unwrap();
    assert_eq!(full.channels, merged.channels);
    assert!(full.channels.iter().any(|c| c == "dd.y.T"));
    let ch = full.channels.len();
    for (i, (a, b)) in full.extras.iter().zip(&merged.extras).enumerate() {
        let pixel = i / ch;
        if pixel < 48 * 20 {
            assert_eq!(
                a.to_bits(),
                b.to_bits(),
                "cropped pixel {pixel}, {}",
                full.channels[i % ch]
            );
        } else {
            let tol = 2e-6 * a.abs().max(b.abs()).max(1.0);
            assert!(
                (a - b).abs() <= tol,
                "pixel {pixel}, {}: {a} vs {b}",
                full.channels[i % ch]
            );
        }
    }
}
