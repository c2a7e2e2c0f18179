//! Tests of the render loops: packets, slices and the two path loops give the same pixels.

use super::pixel::render_pixel;
use super::*;
use crate::cameras::{Camera, ThinLensCamera};
use crate::film::Film;
use crate::integrator::{EnvStrategy, PathSettings, RayCount};
use crate::sampler::{Sampler, SamplerKind};
use glam::Vec2;
use std::path::Path;
use torrey_parser::PixelFilter;
use torrey_texture::spp_scale;

/// A small scene with meshes, a sphere and an area light (24x20).
pub(super) fn packet_scene() -> RenderScene {
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
    crate::scene::scene_from_xml(xml, 24, 20)
}

pub(super) fn settings(spp: u32, sampler: SamplerKind, packets: bool) -> RenderSettings {
    RenderSettings {
        spp,
        integrator: Integrator::Path(crate::integrator::PathIntegrator {
            max_depth: 5,
            rr_depth: 5,
            hide_emitters: false,
        }),
        seed: 3,
        filter: PixelFilter::Box,
        tile_size: 8,
        mipmapping: true,
        env_strategy: EnvStrategy::default(),
        sampler,
        packets,
        path_loop: PathLoop::Scalar,
        channels: Default::default(),
        noise_threshold: None,
        time_limit: None,
    }
}

pub(super) fn assert_bits_eq(a: &Image, b: &Image, what: &str) {
    assert_eq!((a.width, a.height), (b.width, b.height), "{what}");
    for (i, (p, q)) in a.pixels.iter().zip(&b.pixels).enumerate() {
        assert_eq!(
            p.to_array().map(f32::to_bits),
            q.to_array().map(f32::to_bits),
            "{what}: pixel {i}"
        );
    }
}

/// Camera rays traced in packets give the image traced ray by ray, bit for bit, with both
/// samplers (each resumes a sample's numbers where its camera ray left them): meshes, a
/// sphere, an area light; 12 spp, so a whole packet and four single samples per pixel.
#[test]
fn packets_render_the_image_of_single_rays() {
    let scene = packet_scene();
    for sampler in [SamplerKind::Sobol, SamplerKind::Independent] {
        let packed = render(&scene, &settings(12, sampler, true), &|_, _| {});
        let single = render(&scene, &settings(12, sampler, false), &|_, _| {});
        assert!(packed.image.pixels.iter().any(|p| p.max_element() > 0.0));
        assert_eq!(packed.rays.closest, single.rays.closest);
        assert_bits_eq(&packed.image, &single.image, &format!("{sampler:?}"));
        assert_bits_eq(&packed.variance, &single.variance, &format!("{sampler:?}"));
    }
}

/// Slices hold the samples of the one-piece render: crop windows give its pixels bit for
/// bit; sample ranges that cut packet groups (0..5, 5..13, 13..20 of 20 spp) give, merged
/// by count-weighted mean and the parallel variance formula, its mean and variance to float
/// rounding; a range rendered with and without packets is bit-identical. Both samplers.
#[test]
fn slices_hold_the_samples_of_the_one_piece_render() {
    let scene = packet_scene();
    // A gaussian filter's offsets can leave the film at its border: those samples do not
    // count, so border pixels hold fewer, and the merge weighs each pixel by its count.
    // Lanczos splats across pixels with signed weights: the merge weighs by weight sums.
    for (sampler, filter) in [
        (SamplerKind::Sobol, PixelFilter::Box),
        (SamplerKind::Independent, PixelFilter::Box),
        (SamplerKind::Sobol, PixelFilter::Gaussian { stddev: 0.5 }),
        (SamplerKind::Independent, PixelFilter::Lanczos { lobes: 3 }),
    ] {
        let set = RenderSettings {
            filter,
            ..settings(20, sampler, true)
        };
        let splats = matches!(filter, PixelFilter::Lanczos { .. });
        let full = render(&scene, &set, &|_, _| {});
        if filter != PixelFilter::Box {
            assert!(
                full.counts.iter().any(|&n| n != 20),
                "some samples leave the film, or splat into neighbours"
            );
        }
        // Crops: a window's pixels are the full render's pixels.
        let crop = RenderSlice {
            crop: (5, 3, 11, 9),
            samples: 0..20,
        };
        let part = render_slice(&scene, &set, &crop, &|_, _| {}).unwrap();
        let window = |img: &Image| {
            Image::new(
                11,
                9,
                (3..12)
                    .flat_map(|y| (5..16).map(move |x| (x, y)))
                    .map(|(x, y)| img.get(x, y))
                    .collect(),
            )
        };
        assert_bits_eq(
            &part.image,
            &window(&full.image),
            &format!("{sampler:?} crop"),
        );
        assert_bits_eq(
            &part.variance,
            &window(&full.variance),
            &format!("{sampler:?} crop variance"),
        );
        // Sample ranges.
        let parts: Vec<RenderOutput> = [0..5, 5..13, 13..20]
            .into_iter()
            .map(|samples| {
                let slice = RenderSlice {
                    crop: (0, 0, 24, 20),
                    samples,
                };
                render_slice(&scene, &set, &slice, &|_, _| {}).unwrap()
            })
            .collect();
        let mut worst = 0.0f64;
        let (mut merged_var, mut one_var) = (0.0f64, 0.0f64);
        for i in 0..full.image.pixels.len() {
            let rel = |merged: f64, one: f32| {
                let one = one as f64;
                (merged - one).abs() / merged.abs().max(one.abs()).max(1e-30)
            };
            if splats {
                // By weight sums; the variance of the merged mean.
                let w: f64 = parts.iter().map(|p| p.weights[i] as f64).sum();
                for c in 0..3 {
                    let s: f64 = parts
                        .iter()
                        .map(|p| p.weights[i] as f64 * p.image.pixels[i][c] as f64)
                        .sum();
                    let v: f64 = parts
                        .iter()
                        .map(|p| (p.weights[i] as f64).powi(2) * p.variance.pixels[i][c] as f64)
                        .sum();
                    // Means: relative to the pixel's scale (signed weights can cancel).
                    let scale = full.image.pixels[i].abs().max_element().max(1e-3) as f64;
                    worst = worst.max((s / w - full.image.pixels[i][c] as f64).abs() / scale);
                    merged_var += v / (w * w);
                    one_var += full.variance.pixels[i][c] as f64;
                }
                continue;
            }
            let (mut n, mut mean, mut m2) = (0.0f64, [0.0f64; 3], [0.0f64; 3]);
            for p in &parts {
                let nb = p.counts[i] as f64;
                if nb == 0.0 {
                    continue;
                }
                let (mb, vb) = (p.image.pixels[i], p.variance.pixels[i]);
                for c in 0..3 {
                    let m2b = vb[c] as f64 * nb * (nb - 1.0);
                    let delta = mb[c] as f64 - mean[c];
                    let total = n + nb;
                    mean[c] += delta * nb / total;
                    m2[c] += m2b + delta * delta * n * nb / total;
                }
                n += nb;
            }
            for c in 0..3 {
                let var = m2[c] / (n * (n - 1.0));
                worst = worst.max(rel(mean[c], full.image.pixels[i][c]));
                worst = worst.max(rel(var, full.variance.pixels[i][c]));
            }
        }
        assert!(
            worst < 1e-5,
            "{sampler:?} {filter:?}: merged ranges differ by {worst:e}"
        );
        // Splatted: the merged variance estimates the same variance from other sums: over the
        // image, they agree to 10%.
        if splats {
            let ratio = merged_var / one_var;
            assert!(
                (0.9..1.1).contains(&ratio),
                "{filter:?}: variance ratio {ratio}"
            );
        }
        // A range that cuts groups renders the same with and without packets.
        let slice = RenderSlice {
            crop: (0, 0, 24, 20),
            samples: 3..19,
        };
        let packed = render_slice(&scene, &set, &slice, &|_, _| {}).unwrap();
        let unpacked = RenderSettings {
            packets: false,
            ..set.clone()
        };
        let single = render_slice(&scene, &unpacked, &slice, &|_, _| {}).unwrap();
        assert_bits_eq(&packed.image, &single.image, &format!("{sampler:?} 3..19"));
    }
}

/// The wavefront loop renders the scalar loop's image bit for bit (the same numbers, rays,
/// MIS weights and Russian roulette, summed in the same order): both samplers, with packets
/// and without, a gaussian filter whose offsets leave the film at the border, splatted
/// filters (lanczos, mitchell) whose samples reach neighbouring pixels, a crop and a sample
/// range that cuts packet groups and crosses a batch boundary (60..70 of 70 spp), and a film
/// with a crop window (its bounds: samples leaving it do not count); meshes, a sphere and an
/// area light here, an environment map with a sun, a mirror and a microfacet sphere in
/// `envmap_sky.xml`.
#[test]
fn wavefront_renders_the_image_of_the_scalar_loop() {
    let sky = {
        let path = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../scenes/envmap_sky.xml");
        let desc = torrey_parser::load_scene(&path, &[]).unwrap();
        RenderScene::build(&desc, 24, 20).unwrap()
    };
    let windowed = {
        let mut scene = packet_scene();
        scene.sample_window = (4, 3, 14, 12);
        scene
    };
    let window = Some(RenderSlice {
        crop: (4, 3, 14, 12),
        samples: 0..12,
    });
    for (name, scene) in [
        ("packets", packet_scene()),
        ("envmap_sky", sky),
        ("film crop window", windowed),
    ] {
        let cases: Vec<(SamplerKind, PixelFilter, bool, u32, Option<RenderSlice>)> =
            if name == "film crop window" {
                vec![
                    (
                        SamplerKind::Sobol,
                        PixelFilter::Box,
                        true,
                        12,
                        window.clone(),
                    ),
                    (
                        SamplerKind::Independent,
                        PixelFilter::Gaussian { stddev: 0.5 },
                        true,
                        12,
                        window.clone(),
                    ),
                    (
                        SamplerKind::Sobol,
                        PixelFilter::Lanczos { lobes: 3 },
                        true,
                        12,
                        window.clone(),
                    ),
                    (
                        SamplerKind::Independent,
                        PixelFilter::Lanczos { lobes: 3 },
                        false,
                        12,
                        Some(RenderSlice {
                            crop: (6, 5, 7, 6),
                            samples: 3..12,
                        }),
                    ),
                ]
            } else {
                vec![
                    (SamplerKind::Sobol, PixelFilter::Box, true, 12, None),
                    (SamplerKind::Independent, PixelFilter::Box, true, 12, None),
                    (SamplerKind::Sobol, PixelFilter::Box, false, 12, None),
                    (
                        SamplerKind::Independent,
                        PixelFilter::Gaussian { stddev: 0.5 },
                        true,
                        9,
                        None,
                    ),
                    (
                        SamplerKind::Sobol,
                        PixelFilter::Lanczos { lobes: 3 },
                        true,
                        12,
                        None,
                    ),
                    (
                        SamplerKind::Independent,
                        PixelFilter::Mitchell {
                            b: 1.0 / 3.0,
                            c: 1.0 / 3.0,
                        },
                        false,
                        70,
                        Some(RenderSlice {
                            crop: (2, 4, 10, 8),
                            samples: 60..70,
                        }),
                    ),
                    (SamplerKind::Sobol, PixelFilter::Box, true, 12, None),
                    (SamplerKind::Independent, PixelFilter::Box, true, 12, None),
                    (SamplerKind::Sobol, PixelFilter::Box, false, 12, None),
                    (
                        SamplerKind::Independent,
                        PixelFilter::Gaussian { stddev: 0.5 },
                        true,
                        9,
                        None,
                    ),
                    (
                        SamplerKind::Sobol,
                        PixelFilter::Gaussian { stddev: 0.5 },
                        true,
                        70,
                        Some(RenderSlice {
                            crop: (3, 2, 9, 7),
                            samples: 60..70,
                        }),
                    ),
                    (
                        SamplerKind::Independent,
                        PixelFilter::Box,
                        true,
                        70,
                        Some(RenderSlice {
                            crop: (17, 9, 6, 5),
                            samples: 5..67,
                        }),
                    ),
                ]
            };
        for (sampler, filter, packets, spp, slice) in cases {
            let scalar = RenderSettings {
                filter,
                ..settings(spp, sampler, packets)
            };
            let wave = RenderSettings {
                path_loop: PathLoop::Wavefront,
                ..scalar.clone()
            };
            let slice = slice.unwrap_or(RenderSlice::full(24, 20, spp));
            let a = render_slice(&scene, &scalar, &slice, &|_, _| {}).unwrap();
            let b = render_slice(&scene, &wave, &slice, &|_, _| {}).unwrap();
            let what = format!("{name} {sampler:?} {filter:?} packets {packets} {slice:?}");
            assert!(
                a.image.pixels.iter().any(|p| p.max_element() > 0.0),
                "{what}"
            );
            assert_eq!(a.rays.closest, b.rays.closest, "{what}");
            assert_eq!(a.rays.shadow, b.rays.shadow, "{what}");
            assert_eq!(a.counts, b.counts, "{what}");
            assert_eq!(
                a.weights.iter().map(|w| w.to_bits()).collect::<Vec<_>>(),
                b.weights.iter().map(|w| w.to_bits()).collect::<Vec<_>>(),
                "{what}"
            );
            assert_eq!(a.nonfinite_samples, b.nonfinite_samples, "{what}");
            assert_bits_eq(&a.image, &b.image, &what);
            assert_bits_eq(&a.variance, &b.variance, &what);
        }
    }
}

/// The wavefront loop renders the scalar loop's image bit for bit on the verdict scenes of
/// the features the path loop touches: a sphere lamp (shadow rays aimed at the sampled
/// point), textured area emitters (radiance and pdf at the hit's uv), instances (two-level
/// BVH, no packets), bump and normal maps (the perturbation), clip planes and a principal
/// point, a film crop window, a splatted filter, a projector, a thin lens, disks and cylinders,
/// mesh attributes as textures, Mitsuba's BSDFs (rough conductor, rough plastic, rough and
/// smooth dielectrics, blend, mask, principled, principledthin), `hide_emitters`, an
/// environment map with a sun, a textured spot light. Each scene at its own film size and
/// filter, 3 spp, both samplers.
#[test]
fn wavefront_renders_the_scalar_image_of_the_feature_scenes() {
    let root = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../tests/scenes");
    for name in [
        "mitsuba/area_reflective.xml",
        "mitsuba/area_textured.xml",
        "mitsuba/instances_two_level.xml",
        "mitsuba/principal_point_clip.xml",
        "mitsuba/crop_window.xml",
        "mitsuba/filter_lanczos.xml",
        "mitsuba/projector.xml",
        "mitsuba/thinlens.xml",
        "mitsuba/disk_cylinder.xml",
        "mitsuba/mesh_attribute.xml",
        "mitsuba_bsdfs/bumpmap_env.xml",
        "mitsuba_bsdfs/normalmap_twosided_env.xml",
        "mitsuba_bsdfs/principled_area.xml",
        "mitsuba_bsdfs/principledthin_env.xml",
        "mitsuba_bsdfs/roughconductor_area.xml",
        "mitsuba_bsdfs/roughplastic_area.xml",
        "mitsuba_bsdfs/roughdielectric_env.xml",
        "mitsuba_bsdfs/dielectric_area.xml",
        "mitsuba_bsdfs/blendbsdf_area.xml",
        "mitsuba_bsdfs/mask_env.xml",
        "mitsuba/hide_emitters.xml",
        "mitsuba/envmap_sun.xml",
        "mitsuba/spot_textured.xml",
    ] {
        let desc = torrey_parser::load_scene(&root.join(name), &[]).unwrap();
        let scene = RenderScene::build(&desc, desc.film.width, desc.film.height).unwrap();
        let slice = RenderSlice {
            crop: desc
                .film
                .crop
                .map_or((0, 0, desc.film.width, desc.film.height), |c| c.rect()),
            samples: 0..3,
        };
        for sampler in [SamplerKind::Sobol, SamplerKind::Independent] {
            let scalar = RenderSettings {
                filter: desc.film.filter,
                integrator: Integrator::from_desc(&desc.integrator),
                ..settings(3, sampler, true)
            };
            let wave = RenderSettings {
                path_loop: PathLoop::Wavefront,
                ..scalar.clone()
            };
            let a = render_slice(&scene, &scalar, &slice, &|_, _| {}).unwrap();
            let b = render_slice(&scene, &wave, &slice, &|_, _| {}).unwrap();
            let what = format!("{name} {sampler:?}");
            assert!(
                a.image.pixels.iter().any(|p| p.max_element() > 0.0),
                "{what}"
            );
            assert_eq!(a.rays.closest, b.rays.closest, "{what}");
            assert_eq!(a.rays.shadow, b.rays.shadow, "{what}");
            assert_eq!(a.counts, b.counts, "{what}");
            assert_bits_eq(&a.image, &b.image, &what);
            assert_bits_eq(&a.variance, &b.variance, &what);
        }
    }
}

#[test]
fn bad_slices_are_refused() {
    let scene = packet_scene();
    let set = settings(8, SamplerKind::Sobol, true);
    for (crop, samples, message) in [
        ((20, 0, 5, 4), 0..8, "outside the 24x20 film"),
        ((0, 0, 0, 4), 0..8, "is empty"),
        ((0, 0, 4, 4), 4..4, "sample range 4..4 is empty"),
        ((0, 0, 4, 4), 0..9, "beyond the render's 8 spp"),
    ] {
        let slice = RenderSlice { crop, samples };
        let err = render_slice(&scene, &set, &slice, &|_, _| {})
            .err()
            .expect("refused");
        assert!(err.contains(message), "{err}");
    }
}

/// A sampler that records, for every draw, the sample it belongs to and its dimension (the
/// count of draws since the sample started or resumed), and returns fixed numbers.
struct DimensionRecorder {
    sample: u32,
    dimension: u32,
    draws: Vec<(u32, u32)>,
}

impl Sampler for DimensionRecorder {
    fn start_sample(&mut self, index: u32) {
        self.sample = index;
        self.dimension = 0;
    }
    fn resume_sample(&mut self, index: u32, requests: u32) {
        self.sample = index;
        self.dimension = requests;
    }
    fn next_1d(&mut self) -> f32 {
        self.draws.push((self.sample, self.dimension));
        self.dimension += 1;
        0.37
    }
    fn next_2d(&mut self) -> Vec2 {
        Vec2::new(self.next_1d(), 0.61)
    }
}

/// Each sample's draws are its dimensions 0, 1, 2, ... in order, none skipped or repeated,
/// whether its camera ray was drawn in a packet first or not, for a camera that takes one
/// 2D draw (pinhole) and one that takes two (thin lens: film, then lens). With the thin lens
/// of zero aperture (rays share the origin, so packets stay on) the path must resume at
/// dimension 2, not 1.
#[test]
fn cameras_keep_sampler_dimensions_aligned() {
    let mut scene = packet_scene();
    let pinhole = match scene.camera() {
        Camera::Perspective(c) => c.clone(),
        _ => unreachable!(),
    };
    for (camera, lens_draws) in [
        (Camera::Perspective(pinhole.clone()), 0),
        (
            Camera::ThinLens(ThinLensCamera::new(pinhole.clone(), 0.0, 3.0)),
            1,
        ),
        (
            Camera::ThinLens(ThinLensCamera::new(pinhole.clone(), 0.05, 3.0)),
            1,
        ),
    ] {
        assert_eq!(camera.lens_requests(), lens_draws);
        scene.camera = camera;
        for packets in [true, false] {
            let mut recorder = DimensionRecorder {
                sample: 0,
                dimension: 0,
                draws: Vec::new(),
            };
            let path = PathSettings {
                max_depth: 5,
                rr_depth: 5,
                hide_emitters: false,
                mipmapping: true,
                footprint_scale: spp_scale(12),
                env_strategy: EnvStrategy::default(),
                guides: false,
            };
            let mut rays = RayCount::default();
            let set = settings(12, SamplerKind::Sobol, packets);
            let film = Film::new(set.filter, (0, 0, 24, 20), (12, 10, 1, 1));
            render_pixel(
                &scene,
                (12, 10),
                &set,
                0..12,
                path,
                &mut recorder,
                &mut rays,
                &mut film.tile((12, 10, 13, 11)),
                None,
            );
            let mut next = vec![0u32; 12];
            for &(sample, dimension) in &recorder.draws {
                assert_eq!(
                    dimension, next[sample as usize],
                    "sample {sample} (packets {packets}, lens draws {lens_draws})"
                );
                next[sample as usize] += 1;
            }
            // Film (and lens) draws, then at least one bounce's four.
            assert!(next.iter().all(|&n| n >= 1 + lens_draws + 4), "{next:?}");
        }
    }
}

/// A camera whose rays do not share an origin (a thin lens with an aperture) is not traced
/// in packets: asked for packets, the render is the single-ray render, bit for bit.
#[test]
fn cameras_without_a_shared_origin_disable_packets() {
    let mut scene = packet_scene();
    let pinhole = match scene.camera() {
        Camera::Perspective(c) => c.clone(),
        _ => unreachable!(),
    };
    scene.camera = Camera::ThinLens(ThinLensCamera::new(pinhole, 0.1, 3.5));
    assert!(!scene.camera().rays_share_origin());
    for sampler in [SamplerKind::Sobol, SamplerKind::Independent] {
        let packed = render(&scene, &settings(12, sampler, true), &|_, _| {});
        let single = render(&scene, &settings(12, sampler, false), &|_, _| {});
        assert!(packed.image.pixels.iter().any(|p| p.max_element() > 0.0));
        assert_eq!(packed.rays.closest, single.rays.closest);
        assert_bits_eq(&packed.image, &single.image, &format!("{sampler:?}"));
    }
}
