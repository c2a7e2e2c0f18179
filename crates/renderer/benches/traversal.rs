//! Ray traversal throughput: `cargo bench -p torrey-renderer --bench traversal`.
//!
//! For each project scene, traces camera rays, then from every primary hit a diffuse-like
//! secondary ray (closest hit) and a shadow ray towards a random point of the scene's hit cloud
//! (any hit), single-threaded, and prints millions of rays per second. The rays are generated
//! once and replayed, so only the BVH queries are timed (not the surface reconstruction). The
//! last two columns trace eight jittered camera rays per pixel, as a render's samples, one by
//! one and in packets (`torrey_renderer::packet`; eight-wide nodes only).
//! `cargo bench -p torrey-renderer --bench traversal -- cbox` runs only scenes whose file name
//! contains "cbox". Each scene is measured with 4-wide and, on CPUs with AVX2, 8-wide BVH nodes
//! (and 16-wide ones on CPUs with AVX-512).
//! A plain `harness = false` bench: no extra dependency in the test build.

use glam::{Vec2, Vec3A};
use std::path::Path;
use std::time::Instant;
use torrey_renderer::{offset_origin, CameraSample, Ray};
use torrey_renderer::{BvhWidth, RenderScene};

fn main() {
    let root = Path::new(env!("CARGO_MANIFEST_DIR")).join("../..");
    let mut scenes = vec![
        root.join("scenes/cbox.xml"),
        root.join("scenes/textured_mesh.xml"),
        root.join("scenes/envmap_sky.xml"),
    ];
    let living = root.join("../shared/scenes/torrey/living-room-Wig42/scene_bgonly_available.xml");
    if living.exists() {
        scenes.push(living);
    }
    let filters: Vec<String> = std::env::args()
        .skip(1)
        .filter(|a| !a.starts_with('-'))
        .collect();
    scenes.retain(|p| {
        let name = p.file_name().unwrap().to_string_lossy();
        filters.is_empty() || filters.iter().any(|f| name.contains(f.as_str()))
    });
    println!(
        "{:<34} {:>10} {:>12} {:>12} {:>12} {:>12} {:>12}",
        "scene", "triangles", "primary", "secondary", "shadow", "camera x8", "packets"
    );
    for (path, bvh_width, nodes) in scenes.iter().flat_map(|p| {
        [
            (p, BvhWidth::Four, 4),
            (p, BvhWidth::Eight, 8),
            (p, BvhWidth::Sixteen, 16),
        ]
    }) {
        let desc = torrey_parser::load_scene(path, &[]).expect("scene loads");
        let scene =
            RenderScene::build_with_width(&desc, 256, 256, bvh_width).expect("scene builds");
        if scene.accel().bvh_width() != nodes {
            continue; // the CPU lacks AVX2 (8) or AVX-512 (16)
        }
        let (primary, secondary, shadow) = make_rays(&scene);
        let (origin, pixels) = camera_samples(&scene);
        let one_by_one = |dirs: &[Vec3A; PACKET]| {
            dirs.iter()
                .filter(|&&dir| {
                    let ray = Ray {
                        origin,
                        dir,
                        tmax: f32::INFINITY,
                    };
                    scene.accel().intersect(&ray).is_some()
                })
                .count()
        };
        let singly = || pixels.iter().map(one_by_one).sum();
        let packed = || {
            pixels
                .iter()
                .map(|dirs| {
                    let mut hits = [None; PACKET];
                    if scene.accel().intersect_packet(origin, dirs, &mut hits) {
                        hits.iter().flatten().count()
                    } else {
                        one_by_one(dirs)
                    }
                })
                .sum()
        };
        let samples = pixels.len() * PACKET;
        let closest = |rays: &[Ray]| {
            let mut hits = 0usize;
            for r in rays {
                hits += scene.accel().intersect(r).is_some() as usize;
            }
            hits
        };
        let any = |rays: &[Ray]| {
            rays.iter()
                .filter(|r| !scene.visible(r.origin, r.dir, r.tmax))
                .count()
        };
        let rate = |count: usize, f: &dyn Fn() -> usize| {
            let mut best = f64::INFINITY;
            for _ in 0..15 {
                let t = Instant::now();
                std::hint::black_box(f());
                best = best.min(t.elapsed().as_secs_f64());
            }
            format!("{:.1} Mray/s", count as f64 / best / 1e6)
        };
        println!(
            "{:<34} {:>10} {:>12} {:>12} {:>12} {:>12} {:>12}",
            format!(
                "{} ({}-wide)",
                path.file_name().unwrap().to_string_lossy(),
                scene.accel().bvh_width()
            ),
            scene.triangle_count(),
            rate(primary.len(), &|| closest(&primary)),
            rate(secondary.len(), &|| closest(&secondary)),
            rate(shadow.len(), &|| any(&shadow)),
            rate(samples, &singly),
            if scene.accel().packet_width() == PACKET {
                rate(samples, &packed)
            } else {
                "-".to_string()
            },
        );
    }
}

/// Primary rays through every pixel, and from each primary hit one random hemisphere ray and one
/// shadow segment to another primary hit point.
fn make_rays(scene: &RenderScene) -> (Vec<Ray>, Vec<Ray>, Vec<Ray>) {
    let (w, h) = (scene.camera().width(), scene.camera().height());
    let mut rnd = uniform(0x2545_f491_4f6c_dd1du64);
    let mut primary = Vec::new();
    let mut hits = Vec::new();
    for y in 0..h {
        for x in 0..w {
            let (origin, dir) = scene.camera().generate_ray(&CameraSample {
                film: Vec2::new(x as f32 + 0.5, y as f32 + 0.5),
                lens: Vec2::ZERO,
            });
            let ray = Ray {
                origin,
                dir,
                tmax: f32::INFINITY,
            };
            primary.push(ray);
            if let Some(hit) = scene.intersect(&ray) {
                let n = if hit.ng.dot(dir) < 0.0 {
                    hit.ng
                } else {
                    -hit.ng
                };
                hits.push((hit.p, n));
            }
        }
    }
    let mut secondary = Vec::new();
    let mut shadow = Vec::new();
    for i in 0..hits.len() {
        let (p, n) = hits[i];
        let d = loop {
            let v = Vec3A::new(rnd() * 2.0 - 1.0, rnd() * 2.0 - 1.0, rnd() * 2.0 - 1.0);
            if v.length_squared() <= 1.0 && v.length_squared() > 1e-4 {
                break (v.normalize() + n).normalize_or(n);
            }
        };
        secondary.push(Ray {
            origin: offset_origin(p, n, d),
            dir: d,
            tmax: f32::INFINITY,
        });
        let (q, _) = hits[(rnd() * hits.len() as f32) as usize % hits.len()];
        let to = q - p;
        let dist = to.length();
        if dist > 1e-3 {
            let d = to / dist;
            shadow.push(Ray {
                origin: offset_origin(p, n, d),
                dir: d,
                tmax: dist * (1.0 - 2e-4),
            });
        }
    }
    (primary, secondary, shadow)
}

/// Eight camera rays through random points of every pixel: the camera's origin and each
/// pixel's directions.
fn camera_samples(scene: &RenderScene) -> (Vec3A, Vec<[Vec3A; PACKET]>) {
    let (w, h) = (scene.camera().width(), scene.camera().height());
    let mut rnd = uniform(0x9e37_79b9_7f4a_7c15u64);
    let mut origin = Vec3A::ZERO;
    let mut pixels = Vec::new();
    for y in 0..h {
        for x in 0..w {
            pixels.push(std::array::from_fn(|_| {
                let film = Vec2::new(x as f32 + rnd(), y as f32 + rnd());
                let (o, d) = scene.camera().generate_ray(&CameraSample {
                    film,
                    lens: Vec2::ZERO,
                });
                origin = o;
                d
            }));
        }
    }
    (origin, pixels)
}

/// Camera rays per packet (the eight-wide AVX2 layout's).
const PACKET: usize = 8;

/// Uniform numbers in [0, 1) from a xorshift generator started at `state`.
fn uniform(mut state: u64) -> impl FnMut() -> f32 {
    move || {
        state ^= state << 13;
        state ^= state >> 7;
        state ^= state << 17;
        (state >> 40) as f32 / (1u64 << 24) as f32
    }
}
