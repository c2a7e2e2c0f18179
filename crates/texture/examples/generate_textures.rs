//! Writes the project's procedural textures into the workspace `textures/` folder.
//!
//! Run with `cargo run --release -p torrey-texture --example generate_textures`. The outputs are
//! deterministic, so re-running it reproduces the committed files byte for byte.
//!
//! * `checker.png`: 256x256, 8x8 checkerboard, off-white (230,220,200) at the top-left square and
//!   dark teal (40,90,100). 8-bit sRGB.
//! * `checker_fine.png`: 1024x1024, 64x64 checkerboard with the same colours; a high-frequency
//!   pattern for grazing-view ground planes where mip filtering matters.
//! * `normal_bumps.png`: 256x256 tangent-space normal map of a 4x4 grid of smooth round bumps,
//!   encoded rgb = (n + 1) / 2 (flat = (128,128,255)). Red is +u (image right), green is +v
//!   (image down, since v = 0 is the top row), blue is the surface normal.

use std::path::{Path, PathBuf};

fn workspace_textures() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("../../textures")
}

fn checker(size: u32, squares: u32) -> image::RgbImage {
    let light = image::Rgb([230u8, 220, 200]);
    let dark = image::Rgb([40u8, 90, 100]);
    let cell = size / squares;
    image::RgbImage::from_fn(size, size, |x, y| {
        if ((x / cell) + (y / cell)).is_multiple_of(2) {
            light
        } else {
            dark
        }
    })
}

/// Height field of one bump: h(s) = H (1 - s^2)^2 for s = r / R < 1, zero outside. It has a
/// round top like a hemisphere but a zero slope at the rim, so the normal map has no seams.
fn normal_bumps(size: u32, bumps: u32) -> image::RgbImage {
    let cell = size as f64 / bumps as f64;
    let radius = 0.42 * cell;
    let height = 0.35 * cell;
    image::RgbImage::from_fn(size, size, |x, y| {
        // Pixel centre relative to its cell's centre, in pixels.
        let px = x as f64 + 0.5;
        let py = y as f64 + 0.5;
        let dx = px - (px / cell).floor() * cell - 0.5 * cell;
        let dy = py - (py / cell).floor() * cell - 0.5 * cell;
        let r = (dx * dx + dy * dy).sqrt();
        let s = r / radius;
        let (gx, gy) = if s < 1.0 && r > 0.0 {
            // dh/dr = H * 2 (1 - s^2) * (-2 s) / R; split along dx/r, dy/r.
            let dhdr = -4.0 * height * s * (1.0 - s * s) / radius;
            (dhdr * dx / r, dhdr * dy / r)
        } else {
            (0.0, 0.0)
        };
        let n = [-gx, -gy, 1.0];
        let len = (n[0] * n[0] + n[1] * n[1] + n[2] * n[2]).sqrt();
        let enc = |c: f64| ((c / len + 1.0) * 0.5 * 255.0).round().clamp(0.0, 255.0) as u8;
        image::Rgb([enc(n[0]), enc(n[1]), enc(n[2])])
    })
}

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let dir = workspace_textures();
    std::fs::create_dir_all(&dir)?;
    let outputs = [
        ("checker.png", checker(256, 8)),
        ("checker_fine.png", checker(1024, 64)),
        ("normal_bumps.png", normal_bumps(256, 4)),
    ];
    for (name, img) in outputs {
        let path = dir.join(name);
        img.save(&path)
            .map_err(|e| format!("writing {}: {e}", path.display()))?;
        println!("wrote {}", path.display());
    }
    Ok(())
}
