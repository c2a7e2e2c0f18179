//! The render loop: the film is cut into tiles that rayon renders in parallel; each pixel draws
//! its samples from its own PCG stream (seeded by the render seed and the pixel index), so a
//! render is deterministic for a given seed whatever the thread count or tile order.

use crate::accel::ClosestHit;
use crate::cameras::CameraSample;
use crate::integrator::{radiance, EnvStrategy, PathSettings, RayCount};
use crate::ray::Ray;
use crate::sampler::{PcgSampler, Sampler, SamplerKind, SobolSampler};
use crate::scene::RenderScene;
use glam::{Vec2, Vec3A};
use rayon::prelude::*;
use std::sync::atomic::{AtomicU64, Ordering};
use std::time::{Duration, Instant};
use torrey_parser::PixelFilter;
use torrey_texture::{Image, RayCone};

#[derive(Clone, Debug)]
pub struct RenderSettings {
    pub spp: u32,
    pub max_depth: i32,
    pub rr_depth: i32,
    pub seed: u64,
    pub filter: PixelFilter,
    pub tile_size: u32,
    /// Ray-cone mip-mapping of textures and environment maps (on by default).
    pub mipmapping: bool,
    pub env_strategy: EnvStrategy,
    pub sampler: SamplerKind,
    /// Trace each pixel's camera rays in packets of eight ([`crate::packet`]; on by default,
    /// used with eight-wide BVH nodes). Off, every ray is traced alone: the same hits, slower.
    pub packets: bool,
}

pub struct RenderOutput {
    /// Per-pixel mean radiance.
    pub image: Image,
    /// Per-pixel variance of the mean (sample variance / spp): the noise level of `image`.
    pub variance: Image,
    pub spp: u32,
    /// Samples whose value was NaN or infinite; they were dropped (counted as zero).
    pub nonfinite_samples: u64,
    pub elapsed: Duration,
    /// Rays traced, closest-hit and shadow.
    pub rays: RayCount,
    /// From the start of rendering until the first tile was finished (its pixels final).
    pub first_tile: Duration,
}

/// The most camera rays a packet holds (the widest any layout traces).
const MAX_PACKET: usize = 16;

/// A tile's origin and its pixels' (mean, variance of the mean), row by row.
type RenderedTile = ((u32, u32), Vec<(Vec3A, Vec3A)>);

/// Renders the scene. `progress(done, total)` is called after each tile from worker threads.
pub fn render(
    scene: &RenderScene,
    settings: &RenderSettings,
    progress: &(dyn Fn(u64, u64) + Sync),
) -> RenderOutput {
    let start = Instant::now();
    let (width, height) = (scene.camera().width(), scene.camera().height());
    let ts = settings.tile_size.max(1);
    let tiles: Vec<(u32, u32)> = (0..height.div_ceil(ts))
        .flat_map(|ty| (0..width.div_ceil(ts)).map(move |tx| (tx * ts, ty * ts)))
        .collect();
    let total = tiles.len() as u64;
    let done = AtomicU64::new(0);
    let nonfinite = AtomicU64::new(0);
    let closest_rays = AtomicU64::new(0);
    let shadow_rays = AtomicU64::new(0);
    let first_tile_ns = AtomicU64::new(u64::MAX);
    let path = PathSettings {
        max_depth: settings.max_depth,
        rr_depth: settings.rr_depth,
        mipmapping: settings.mipmapping,
        env_strategy: settings.env_strategy,
    };
    let spp = settings.spp.max(1);

    let rendered: Vec<RenderedTile> = tiles
        .par_iter()
        .map(|&(x0, y0)| {
            let x1 = (x0 + ts).min(width);
            let y1 = (y0 + ts).min(height);
            let mut out = Vec::with_capacity(((x1 - x0) * (y1 - y0)) as usize);
            let mut bad = 0u64;
            let mut rays = RayCount::default();
            // One Sobol sampler per tile: its table of points is reused from pixel to pixel.
            let mut sobol = (settings.sampler == SamplerKind::Sobol)
                .then(|| SobolSampler::tabled(settings.seed, 0, spp));
            for y in y0..y1 {
                for x in x0..x1 {
                    let pixel_index = y as u64 * width as u64 + x as u64;
                    let (mean, var_of_mean, dropped) = match settings.sampler {
                        SamplerKind::Independent => render_pixel(
                            scene,
                            (x, y),
                            settings,
                            path,
                            &mut PcgSampler::new(settings.seed, pixel_index),
                            &mut rays,
                        ),
                        SamplerKind::Sobol => {
                            let sampler = sobol.as_mut().expect("made for the Sobol sampler");
                            sampler.restart(settings.seed, pixel_index, spp);
                            render_pixel(scene, (x, y), settings, path, sampler, &mut rays)
                        }
                    };
                    bad += dropped;
                    out.push((mean, var_of_mean));
                }
            }
            nonfinite.fetch_add(bad, Ordering::Relaxed);
            closest_rays.fetch_add(rays.closest, Ordering::Relaxed);
            shadow_rays.fetch_add(rays.shadow, Ordering::Relaxed);
            first_tile_ns.fetch_min(start.elapsed().as_nanos() as u64, Ordering::Relaxed);
            let d = done.fetch_add(1, Ordering::Relaxed) + 1;
            progress(d, total);
            ((x0, y0), out)
        })
        .collect();

    let mut image = Image::filled(width, height, glam::Vec3::ZERO);
    let mut variance = Image::filled(width, height, glam::Vec3::ZERO);
    for ((x0, y0), pixels) in rendered {
        let x1 = (x0 + ts).min(width);
        let tile_w = (x1 - x0) as usize;
        for (i, (m, v)) in pixels.into_iter().enumerate() {
            let x = x0 as usize + i % tile_w;
            let y = y0 as usize + i / tile_w;
            image.pixels[y * width as usize + x] = m.into();
            variance.pixels[y * width as usize + x] = v.into();
        }
    }
    let elapsed = start.elapsed();
    RenderOutput {
        image,
        variance,
        spp,
        nonfinite_samples: nonfinite.into_inner(),
        elapsed,
        rays: RayCount {
            closest: closest_rays.into_inner(),
            shadow: shadow_rays.into_inner(),
        },
        first_tile: Duration::from_nanos(first_tile_ns.into_inner()).min(elapsed),
    }
}

/// Renders one pixel's `spp` samples; returns the mean, the variance of the mean (from the sample
/// variance; an overestimate for correlated low-discrepancy samples) and the count of dropped
/// non-finite samples.
#[inline]
fn render_pixel<S: Sampler>(
    scene: &RenderScene,
    (x, y): (u32, u32),
    settings: &RenderSettings,
    path: PathSettings,
    sampler: &mut S,
    rays: &mut RayCount,
) -> (Vec3A, Vec3A, u64) {
    // Welford's running mean and variance per channel.
    let mut mean = Vec3A::ZERO;
    let mut m2 = Vec3A::ZERO;
    let mut bad = 0;
    let spp = settings.spp.max(1);
    let filter = settings.filter;
    let camera = scene.camera();
    let cone = RayCone::from_pixel(camera.pixel_spread());
    // The camera's sampler draws: the film position, then its lens (if it has one).
    let camera_requests = 1 + camera.lens_requests();
    let camera_ray = |sampler: &mut S| {
        let offset = sample_filter(filter, sampler.next_2d());
        let film = Vec2::new(x as f32 + 0.5, y as f32 + 0.5) + offset;
        let lens = if camera.lens_requests() > 0 {
            sampler.next_2d()
        } else {
            Vec2::ZERO
        };
        camera.generate_ray(&CameraSample { film, lens })
    };
    let mut add = |s: u32, l: Vec3A| {
        let l = if l.is_finite() {
            l
        } else {
            bad += 1;
            Vec3A::ZERO
        };
        let n = (s + 1) as f32;
        let delta = l - mean;
        mean += delta / n;
        m2 += delta * (l - mean);
    };
    // Camera rays go in packets of eight, traced together, while whole packets fit: each
    // packet's rays are drawn first, then their paths are followed one by one from the hits.
    // (Drawing a packet's camera rays first changes which of an independent stream's numbers
    // each path gets, not their distribution; low-discrepancy samples resume their dimensions.)
    // Packets need a layout that traces them and a camera whose rays share their origin.
    let lanes = if settings.packets && camera.rays_share_origin() {
        scene.accel().packet_width().min(MAX_PACKET)
    } else {
        0
    };
    let mut origin = Vec3A::ZERO;
    let mut dirs = [Vec3A::ZERO; MAX_PACKET];
    let mut hits = [None; MAX_PACKET];
    let mut packed = false;
    let packed_samples = if lanes > 0 {
        spp - spp % lanes as u32
    } else {
        0
    };
    for s in 0..spp {
        let (o, d, first_hit) = if s < packed_samples {
            let lane = s as usize % lanes;
            if lane == 0 {
                for (k, dir) in dirs[..lanes].iter_mut().enumerate() {
                    sampler.start_sample(s + k as u32);
                    (origin, *dir) = camera_ray(sampler);
                }
                packed = scene
                    .accel()
                    .intersect_packet(origin, &dirs[..lanes], &mut hits[..lanes]);
            }
            sampler.resume_sample(s, camera_requests);
            let ray = Ray {
                origin,
                dir: dirs[lane],
                tmax: f32::INFINITY,
            };
            let first_hit =
                packed.then(|| hits[lane].map(|hit: ClosestHit| scene.surface(&ray, &hit)));
            (origin, dirs[lane], first_hit)
        } else {
            sampler.start_sample(s);
            let (o, d) = camera_ray(sampler);
            (o, d, None)
        };
        add(
            s,
            radiance(scene, o, d, cone, path, sampler, rays, first_hit),
        );
    }
    let var_of_mean = if spp > 1 {
        m2 / ((spp - 1) as f32 * spp as f32)
    } else {
        Vec3A::ZERO
    };
    (mean, var_of_mean, bad)
}

/// Offset from the pixel centre, drawn from the pixel filter (filter importance sampling: every
/// sample then counts with weight one in its own pixel, which converges to the same filtered image
/// as Mitsuba's weighted splatting).
#[inline]
fn sample_filter(filter: PixelFilter, u: Vec2) -> Vec2 {
    match filter {
        PixelFilter::Box => u - Vec2::splat(0.5),
        PixelFilter::Tent { radius } => Vec2::new(sample_tent(u.x), sample_tent(u.y)) * radius,
        PixelFilter::Gaussian { stddev } => {
            // Box-Muller, truncated at Mitsuba's radius of 4 standard deviations.
            let r = (-2.0 * (1.0 - u.x).max(1e-12).ln()).sqrt().min(4.0);
            let phi = 2.0 * std::f32::consts::PI * u.y;
            Vec2::new(phi.cos(), phi.sin()) * (r * stddev)
        }
    }
}

/// Inverse CDF of the unit tent on [-1, 1].
#[inline]
fn sample_tent(u: f32) -> f32 {
    if u < 0.5 {
        (2.0 * u).sqrt() - 1.0
    } else {
        1.0 - (2.0 - 2.0 * u).sqrt()
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::sampler::PcgSampler;
    use std::path::Path;

    #[test]
    fn tent_samples_match_the_tent() {
        let mut s = PcgSampler::new(1, 1);
        let mut bins = [0u32; 8];
        let n = 80_000;
        for _ in 0..n {
            let x = sample_tent(s.next_1d());
            assert!((-1.0..=1.0).contains(&x));
            bins[((x + 1.0) * 4.0).min(7.999) as usize] += 1;
        }
        // Expected mass of bin [a, b] under the tent: integral of 1 - |x|.
        let cdf = |x: f64| {
            if x < 0.0 {
                0.5 * (1.0 + x).powi(2)
            } else {
                1.0 - 0.5 * (1.0 - x).powi(2)
            }
        };
        let chi2: f64 = (0..8)
            .map(|i| {
                let (a, b) = (-1.0 + i as f64 * 0.25, -1.0 + (i + 1) as f64 * 0.25);
                let e = (cdf(b) - cdf(a)) * n as f64;
                (bins[i] as f64 - e).powi(2) / e
            })
            .sum();
        assert!(chi2 < 24.3, "chi2 = {chi2}"); // 7 dof, 0.999 quantile
    }

    /// Camera rays traced in packets give the image traced ray by ray, bit for bit, with the
    /// Sobol sampler (whose samples resume their dimensions): meshes, a sphere, an area light;
    /// 12 spp, so a whole packet and four single samples per pixel. (With the independent
    /// sampler a packet draws its eight camera rays first, so each path gets other numbers of
    /// the stream: a different image of the same expectation, which the reference tests check.)
    #[test]
    fn packets_render_the_image_of_single_rays() {
        let xml = r#"<scene version="0.6.0">
            <integrator type="path"><integer name="maxDepth" value="5"/></integrator>
            <sensor type="perspective">
                <float name="fov" value="50"/>
                <transform name="toWorld"><lookAt origin="0, 1, 4" target="0, 0.6, 0" up="0, 1, 0"/></transform>
                <film type="hdrfilm"><integer name="width" value="24"/><integer name="height" value="20"/></film>
            </sensor>
            <shape type="rectangle">
                <transform name="toWorld"><scale value="3"/><rotate x="1" angle="-90"/></transform>
            </shape>
            <shape type="sphere"><point name="center" x="0.4" y="0.5" z="0"/><float name="radius" value="0.5"/>
                <bsdf type="plastic"/></shape>
            <shape type="obj"><string name="filename" value="meshes/torus.obj"/>
                <transform name="toWorld"><scale value="0.5"/><translate x="-0.7" y="0.4"/></transform></shape>
            <shape type="rectangle">
                <transform name="toWorld"><rotate x="1" angle="90"/><translate y="2.5"/></transform>
                <emitter type="area"><rgb name="radiance" value="4, 4, 4"/></emitter>
            </shape>
        </scene>"#;
        let desc = torrey_parser::parse_scene_str(
            xml,
            &Path::new(env!("CARGO_MANIFEST_DIR")).join("../../scenes/packets.xml"),
            &[],
        )
        .unwrap();
        let scene = RenderScene::build(&desc, 24, 20).unwrap();
        let render_with = |packets: bool| {
            let settings = RenderSettings {
                spp: 12,
                max_depth: 5,
                rr_depth: 5,
                seed: 3,
                filter: PixelFilter::Box,
                tile_size: 8,
                mipmapping: true,
                env_strategy: EnvStrategy::default(),
                sampler: SamplerKind::Sobol,
                packets,
            };
            render(&scene, &settings, &|_, _| {})
        };
        let (packed, single) = (render_with(true), render_with(false));
        assert!(packed.image.pixels.iter().any(|p| p.max_element() > 0.0));
        assert_eq!(packed.rays.closest, single.rays.closest);
        for (a, b) in packed.image.pixels.iter().zip(&single.image.pixels) {
            assert_eq!(
                a.to_array().map(f32::to_bits),
                b.to_array().map(f32::to_bits)
            );
        }
    }
}
