//! Generates `textures/sky_sun.exr`: a 512x256 lat-long sky in Mitsuba 3's orientation (+y up,
//! row 0 = zenith) with a blue-to-white gradient, a darker ground, and a small sun disk of
//! radiance ~2000 at 35 degrees elevation. It exercises environment importance sampling: almost
//! all of the energy sits in a few texels.
//!
//! `cargo run --release -p torrey-light --example generate_sky [output.exr [preview.png]]`
//! (the optional PNG is a tonemapped preview, exposure 1, clamped: not committed).

use glam::{Vec2, Vec3};
use std::f32::consts::PI;
use std::path::PathBuf;
use torrey_texture::{write_exr, write_png_srgb, Image};

const WIDTH: u32 = 512;
const HEIGHT: u32 = 256;
/// Sun elevation above the horizon and azimuth as a u coordinate of the map.
const SUN_ELEVATION_DEG: f32 = 35.0;
const SUN_U: f32 = 0.3;
/// Angular radius of the sun disk (a texel is 180/256 = 0.7 degrees tall): about 4 texels across.
const SUN_RADIUS_DEG: f32 = 1.5;
const SUN_RADIANCE: Vec3 = Vec3::new(2000.0, 1900.0, 1700.0);

/// Local direction of a lat-long uv (CONVENTIONS.md, "Environment map").
fn uv_to_dir(uv: Vec2) -> Vec3 {
    let (st, ct) = (PI * uv.y).sin_cos();
    let (sp, cp) = (2.0 * PI * uv.x).sin_cos();
    Vec3::new(sp * st, ct, -cp * st)
}

fn smoothstep(e0: f32, e1: f32, x: f32) -> f32 {
    let t = ((x - e0) / (e1 - e0)).clamp(0.0, 1.0);
    t * t * (3.0 - 2.0 * t)
}

fn sun_dir() -> Vec3 {
    let e = SUN_ELEVATION_DEG.to_radians();
    uv_to_dir(Vec2::new(SUN_U, 0.5 - e / PI))
}

/// Radiance of the sky model in local direction `d`.
fn radiance(d: Vec3) -> Vec3 {
    let elevation = d.y.clamp(-1.0, 1.0).asin();
    let horizon = Vec3::new(0.95, 0.97, 1.0);
    let zenith = Vec3::new(0.25, 0.45, 0.95);
    let t = (elevation / (0.5 * PI)).max(0.0).sqrt();
    let mut sky = horizon.lerp(zenith, t);
    // A soft glow around the sun.
    let cos_sun = d.dot(sun_dir()).clamp(-1.0, 1.0);
    let angle = cos_sun.acos();
    sky *= 1.0 + 1.5 * (-(angle * angle) / (2.0 * 0.1 * 0.1)).exp();
    let ground = Vec3::new(0.18, 0.15, 0.12);
    // Blend over about one degree so the horizon does not alias.
    let s = smoothstep(-0.01, 0.01, elevation);
    let mut c = ground.lerp(sky, s);
    if angle < SUN_RADIUS_DEG.to_radians() {
        c = SUN_RADIANCE;
    }
    c
}

fn main() {
    let out = std::env::args()
        .nth(1)
        .map(PathBuf::from)
        .unwrap_or_else(|| {
            PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../../textures/sky_sun.exr")
        });
    // 4x4 supersampling per texel so the sun disk and the horizon are area-averaged.
    let ss = 4;
    let mut pixels = Vec::with_capacity((WIDTH * HEIGHT) as usize);
    for j in 0..HEIGHT {
        for i in 0..WIDTH {
            let mut acc = Vec3::ZERO;
            for a in 0..ss {
                for b in 0..ss {
                    let uv = Vec2::new(
                        (i as f32 + (b as f32 + 0.5) / ss as f32) / WIDTH as f32,
                        (j as f32 + (a as f32 + 0.5) / ss as f32) / HEIGHT as f32,
                    );
                    acc += radiance(uv_to_dir(uv));
                }
            }
            let p = acc / (ss * ss) as f32;
            // Round to half precision: the values stay well within half's range and the file
            // compresses far better, which keeps the committed asset small.
            pixels.push(Vec3::new(round_half(p.x), round_half(p.y), round_half(p.z)));
        }
    }
    let image = Image::new(WIDTH, HEIGHT, pixels);
    if let Err(e) = write_exr(&out, &image) {
        eprintln!("error: {e}");
        std::process::exit(1);
    }
    if let Some(preview) = std::env::args().nth(2) {
        if let Err(e) = write_png_srgb(std::path::Path::new(&preview), &image) {
            eprintln!("error: {e}");
            std::process::exit(1);
        }
    }
    // Report the sun's share of the map's power (radiance x solid angle).
    let (mut total, mut sun) = (0.0f64, 0.0f64);
    for j in 0..HEIGHT {
        let theta = PI * (j as f32 + 0.5) / HEIGHT as f32;
        let dw = (2.0 * PI / WIDTH as f32) * (PI / HEIGHT as f32) * theta.sin();
        for i in 0..WIDTH {
            let l = image.pixels[(j * WIDTH + i) as usize].y as f64 * dw as f64;
            total += l;
            if image.pixels[(j * WIDTH + i) as usize].y > 100.0 {
                sun += l;
            }
        }
    }
    let s = sun_dir();
    println!(
        "wrote {} ({WIDTH}x{HEIGHT}); sun direction ({:.4}, {:.4}, {:.4}); sun texels carry {:.1}% of the green-channel power",
        out.display(),
        s.x,
        s.y,
        s.z,
        100.0 * sun / total
    );
}

/// Rounds an f32 to the nearest value representable as an IEEE half (for positive normal
/// values in half's range, which is all this sky produces).
fn round_half(x: f32) -> f32 {
    if x <= 0.0 || !x.is_finite() {
        return 0.0;
    }
    let bits = x.to_bits();
    // Keep 10 mantissa bits of the 23, rounding to nearest.
    let rounded = (bits + (1 << 12)) & !((1 << 13) - 1);
    f32::from_bits(rounded)
}
