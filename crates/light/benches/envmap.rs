//! Environment-map sampling and lookup throughput: `cargo bench -p torrey-light --bench envmap`.
//!
//! Renders are too noisy on a shared machine to see a few percent, so this times the two
//! environment-map operations of a path tracer alone, single-threaded, on the project's sky
//! (`textures/sky_sun.exr`, 512x256 with a sun): importance sampling a direction
//! (`EnvMap::sample`, next-event estimation) and evaluating radiance and pdf along a direction
//! (`EnvMap::eval_pdf`, an escaped BSDF-sampled ray). Inputs are generated once and replayed; the
//! best of 15 passes is reported in millions of calls per second and nanoseconds per call.
//! The same sky box-filtered to 64x32 (its tables then fit in the first-level cache) shows how
//! much of each call is waiting for memory.
//! A plain `harness = false` bench: no extra dependency in the test build.

use glam::{Mat3, Vec2, Vec3};
use std::hint::black_box;
use std::path::Path;
use std::time::Instant;
use torrey_light::EnvMap;
use torrey_testkit::Rng;

const CALLS: usize = 1 << 20;
const PASSES: usize = 15;

/// Best time of `PASSES` runs of `pass`, in seconds.
fn best_of(mut pass: impl FnMut() -> f32) -> f64 {
    let mut best = f64::INFINITY;
    for _ in 0..PASSES {
        let t = Instant::now();
        black_box(pass());
        best = best.min(t.elapsed().as_secs_f64());
    }
    best
}

fn report(name: &str, seconds: f64) {
    println!(
        "{name:<34} {:>8.1} M/s {:>8.1} ns/call",
        CALLS as f64 / seconds / 1e6,
        seconds / CALLS as f64 * 1e9
    );
}

fn main() {
    let path = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../textures/sky_sun.exr");
    let image = torrey_texture::io::load_image(&path, true)
        .unwrap_or_else(|e| panic!("{}: {e}", path.display()))
        .image;
    let mut rng = Rng::new(7);
    let us: Vec<Vec2> = (0..CALLS).map(|_| rng.vec2()).collect();
    // Directions over the whole sphere (an escaped ray may leave in any direction).
    let dirs: Vec<Vec3> = (0..CALLS)
        .map(|_| {
            let z = rng.range(-1.0, 1.0);
            let phi = rng.range(0.0, std::f32::consts::TAU);
            let r = (1.0 - z * z).max(0.0).sqrt();
            Vec3::new(r * phi.cos(), z, r * phi.sin())
        })
        .collect();
    println!("{:<34} {:>12} {:>16}", "operation", "rate", "time");
    let small = torrey_texture::MipMap::new(
        image.clone(),
        torrey_texture::WrapMode::Repeat,
        torrey_texture::FilterType::Bilinear,
    )
    .level(3)
    .into_owned();
    for (label, image, to_world) in [
        ("512x256, identity", &image, Mat3::IDENTITY),
        ("512x256, rotated", &image, Mat3::from_rotation_y(0.7)),
        ("64x32, identity", &small, Mat3::IDENTITY),
    ] {
        let env = EnvMap::new(image.clone(), 1.0, to_world);
        let sample = best_of(|| {
            us.iter()
                .map(|&u| env.sample(u).map_or(0.0, |s| s.pdf))
                .sum()
        });
        report(&format!("sample, {label}"), sample);
        let eval = best_of(|| {
            dirs.iter()
                .map(|&d| {
                    let (l, pdf) = env.eval_pdf(d, 0.0);
                    l.x + pdf
                })
                .sum()
        });
        report(&format!("eval_pdf, {label}"), eval);
    }
}
