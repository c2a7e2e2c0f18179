//! Helpers of the hostile-input tests (tests/robustness.rs, tests/robustness_sizes.rs): run the
//! binary on a scene written to a temporary folder, and check a rejection's one error line.

use std::path::{Path, PathBuf};
use std::process::{Command, Output};

pub fn torrey() -> Command {
    Command::new(env!("CARGO_BIN_EXE_torrey"))
}

pub fn temp_dir(name: &str) -> PathBuf {
    let dir = std::env::temp_dir().join(format!("torrey-robust-{}-{name}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(&dir).unwrap();
    dir
}

/// A tetrahedron: a mesh of several triangles (the traversal crash needed more than one).
pub const TETRAHEDRON: &str =
    "v 0 0.5 -2\nv 0 -0.3 -1\nv 1 -0.5 -3\nv -1 -0.5 -3\nf 1 2 3\nf 1 4 2\nf 1 3 4\nf 2 3 4\n";

pub fn run(dir: &Path, scene_xml: &str, args: &[&str]) -> (PathBuf, Output) {
    let scene = dir.join("scene.xml");
    std::fs::write(&scene, scene_xml).unwrap();
    let out = torrey()
        .arg(&scene)
        .args(["--quiet", "--size", "8x6", "--spp", "1", "-o"])
        .arg(dir.join("out.exr"))
        .args(args)
        .output()
        .unwrap();
    (scene, out)
}

/// Runs a scene that must be rejected: exit status 1 (not a signal), no image, and stderr is
/// exactly one line `SCENE:LINE:COLUMN: error: MESSAGE`; returns "LINE:COLUMN: MESSAGE".
pub fn rejected(dir: &Path, scene_xml: &str) -> String {
    let (scene, out) = run(dir, scene_xml, &[]);
    let stderr = String::from_utf8_lossy(&out.stderr).into_owned();
    assert_eq!(out.status.code(), Some(1), "stderr: {stderr}");
    assert!(
        !dir.join("out.exr").exists() && !dir.join("out.png").exists(),
        "no image on error: {stderr}"
    );
    let lines: Vec<&str> = stderr.lines().collect();
    assert_eq!(lines.len(), 1, "one line expected: {stderr}");
    let prefix = format!("{}:", scene.display());
    let rest = lines[0]
        .strip_prefix(&prefix)
        .unwrap_or_else(|| panic!("error must name the scene file: {stderr}"));
    let (line_col, message) = rest.split_once(": error: ").expect("an error line");
    let (line, col) = line_col.split_once(':').expect("line:column");
    assert!(
        line.parse::<u32>().is_ok() && col.parse::<u32>().is_ok(),
        "{stderr}"
    );
    format!("{line_col}: {message}")
}

pub fn scene_with(body: &str) -> String {
    format!("<scene version=\"0.6.0\">{body}</scene>")
}

pub fn column_of(xml: &str, needle: &str) -> usize {
    xml.find(needle).unwrap() + 1
}

/// A version-4 serialized file with one shape: `positions`, one triangle, then `padding` zero
/// bytes inside the zlib stream beyond what the counts account for.
pub fn serialized(positions: &[[f32; 3]], extra_counts: &[u64], padding: usize) -> Vec<u8> {
    let mut p = Vec::new();
    p.extend_from_slice(&0x1000u32.to_le_bytes());
    p.extend_from_slice(b"shape\0");
    let nv = extra_counts
        .first()
        .copied()
        .unwrap_or(positions.len() as u64);
    p.extend_from_slice(&nv.to_le_bytes());
    p.extend_from_slice(&1u64.to_le_bytes());
    for v in positions {
        for x in v {
            p.extend_from_slice(&x.to_le_bytes());
        }
    }
    for i in 0..3u32 {
        p.extend_from_slice(&i.to_le_bytes());
    }
    p.resize(p.len() + padding, 0);
    let mut d = Vec::new();
    d.extend_from_slice(&0x041Cu16.to_le_bytes());
    d.extend_from_slice(&4u16.to_le_bytes());
    d.extend_from_slice(&miniz_oxide::deflate::compress_to_vec_zlib(&p, 1));
    d.extend_from_slice(&0u64.to_le_bytes());
    d.extend_from_slice(&1u32.to_le_bytes());
    d
}
