//! Tests of renders in passes and of what samples write besides the radiance: adaptive sampling
//! (unbiased, exact under crops and sample ranges), time limits, and the AOVs and guides (the
//! same from both path loops).

use super::tests::{assert_bits_eq, packet_scene, settings};
use super::*;
use crate::integrator::aov::SampleChannels;
use std::path::Path;
use torrey_parser::{Aov, AovKind, Aovs};

fn adaptive(spp: u32, sampler: SamplerKind, threshold: f32) -> RenderSettings {
    RenderSettings {
        noise_threshold: Some(threshold),
        ..settings(spp, sampler, true)
    }
}

/// Adaptive sampling's image has the uniform render's expectation: over the image, the mean
/// difference between an adaptive render and a uniform one (other seeds, independent samples)
/// is within four standard errors, and per pixel the differences are within their noise (few
/// pixels past 3.5 sigma). The pixels' counts do vary (16 to 256).
#[test]
fn adaptive_sampling_keeps_the_expected_image() {
    let scene = packet_scene();
    let uniform = render(
        &scene,
        &RenderSettings {
            seed: 11,
            ..settings(96, SamplerKind::Independent, true)
        },
        &|_, _| {},
    );
    let adaptive = render(
        &scene,
        &RenderSettings {
            seed: 12,
            ..adaptive(256, SamplerKind::Independent, 0.05)
        },
        &|_, _| {},
    );
    let (lo, hi) = adaptive
        .counts
        .iter()
        .fold((u32::MAX, 0), |(a, b), &c| (a.min(c), b.max(c)));
    assert_eq!((lo, hi), (16, 256), "the counts adapt");
    assert_eq!(adaptive.passes, 2);
    let (mut sum, mut var, mut outliers) = (0.0f64, 0.0f64, 0);
    let n = uniform.image.pixels.len();
    for i in 0..n {
        for c in 0..3 {
            let d = adaptive.image.pixels[i][c] as f64 - uniform.image.pixels[i][c] as f64;
            let v = adaptive.variance.pixels[i][c] as f64 + uniform.variance.pixels[i][c] as f64;
            sum += d;
            var += v;
            if v > 0.0 && d.abs() > 3.5 * v.sqrt() {
                outliers += 1;
            }
        }
    }
    let z = sum / var.sqrt();
    assert!(
        z.abs() < 4.0,
        "mean difference {sum} is {z} standard errors"
    );
    assert!(
        outliers <= n * 3 / 100,
        "{outliers} of {} values past 3.5 sigma",
        n * 3
    );
}

/// A crop of an adaptive render is the one-piece render's window, bit for bit (pixels, counts,
/// variances): its pilot covers a ring around it. Sample ranges hold exactly the one-piece
/// render's samples: their counts add up to its counts, pixel by pixel.
#[test]
fn adaptive_slices_hold_the_one_piece_samples() {
    let scene = packet_scene();
    for sampler in [SamplerKind::Sobol, SamplerKind::Independent] {
        let set = adaptive(64, sampler, 0.1);
        let full = render(&scene, &set, &|_, _| {});
        assert!(full.counts.iter().any(|&c| c != 64));
        let slice = RenderSlice {
            crop: (5, 3, 11, 9),
            samples: 0..64,
        };
        let part = render_slice(&scene, &set, &slice, &|_, _| {}).unwrap();
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
        assert_bits_eq(&part.image, &window(&full.image), "adaptive crop");
        assert_bits_eq(&part.variance, &window(&full.variance), "adaptive crop");
        let all = &full.counts;
        let counts: Vec<u32> = (3..12)
            .flat_map(|y| (5..16).map(move |x| all[y * 24 + x]))
            .collect();
        assert_eq!(part.counts, counts);

        let ranges: Vec<RenderOutput> = [0..5, 5..40, 40..64]
            .into_iter()
            .map(|samples| {
                let slice = RenderSlice {
                    crop: (0, 0, 24, 20),
                    samples,
                };
                render_slice(&scene, &set, &slice, &|_, _| {}).unwrap()
            })
            .collect();
        for i in 0..full.counts.len() {
            let sum: u32 = ranges.iter().map(|r| r.counts[i]).sum();
            assert_eq!(sum, full.counts[i], "pixel {i}");
        }
    }
}

/// A time limit stops at a pass boundary: the render ends within the limit plus its last pass
/// (the pass it could not know would overrun), in several passes of samples added in index
/// order, all pixels with the same count; the pass reports count up.
#[test]
fn time_limits_are_honoured_within_a_pass() {
    let scene = packet_scene();
    let limit = Duration::from_millis(400);
    let set = RenderSettings {
        time_limit: Some(limit),
        ..settings(1 << 20, SamplerKind::Sobol, true)
    };
    let reports = std::sync::Mutex::new(Vec::new());
    let slice = RenderSlice::full(24, 20, set.spp);
    let out = render_slice_reporting(&scene, &set, &slice, &|_, _| {}, &|r| {
        reports.lock().unwrap().push(r.clone())
    })
    .unwrap();
    let reports = reports.into_inner().unwrap();
    assert!(out.passes >= 3, "{} passes", out.passes);
    assert_eq!(reports.len() as u32, out.passes);
    let last_pass = reports[reports.len() - 1].elapsed - reports[reports.len() - 2].elapsed;
    assert!(
        out.elapsed <= limit + last_pass + Duration::from_millis(50),
        "{:?} for a limit of {limit:?} (last pass {last_pass:?})",
        out.elapsed
    );
    let n = out.counts[0];
    assert!(
        n > 1 && out.counts.iter().all(|&c| c == n),
        "uniform counts"
    );
    assert_eq!(reports.last().unwrap().samples, n as u64 * 24 * 20);
    assert!(reports.iter().all(|r| r.time_left.is_some()));
}

/// The AOVs and the denoiser's guides are the same from the scalar and the wavefront loop, bit
/// for bit, as the radiance is; guides are unit normals and albedos in [0, 1] where a path met
/// a surface; an AOV of a miss is zero.
#[test]
fn aovs_and_guides_are_the_same_from_both_loops() {
    let sky = {
        let path = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../scenes/envmap_sky.xml");
        let desc = torrey_parser::load_scene(&path, &[]).unwrap();
        RenderScene::build(&desc, 24, 16).unwrap()
    };
    let aovs = Aovs {
        inner: Some("img".into()),
        list: [
            AovKind::Depth,
            AovKind::Albedo,
            AovKind::DuvDx,
            AovKind::ShNormal,
            AovKind::PrimIndex,
        ]
        .into_iter()
        .map(|kind| Aov {
            name: format!("{kind:?}"),
            kind,
        })
        .collect(),
    };
    for scene in [&packet_scene(), &sky] {
        for sampler in [SamplerKind::Sobol, SamplerKind::Independent] {
            let base = RenderSettings {
                channels: SampleChannels {
                    aovs: Some(aovs.clone()),
                    guides: true,
                },
                ..settings(12, sampler, true)
            };
            let scalar = render(scene, &base, &|_, _| {});
            let wave = render(
                scene,
                &RenderSettings {
                    path_loop: PathLoop::Wavefront,
                    ..base.clone()
                },
                &|_, _| {},
            );
            assert_bits_eq(&scalar.image, &wave.image, "radiance");
            assert_eq!(scalar.channels, wave.channels);
            let bits = |v: &[f32]| v.iter().map(|x| x.to_bits()).collect::<Vec<_>>();
            assert_eq!(bits(&scalar.extras), bits(&wave.extras), "{sampler:?}");
            let ch = scalar.channels.len();
            assert_eq!(ch, 4 + 1 + 3 + 2 + 3 + 1 + 6);
            let mut surfaced = 0;
            for (p, e) in scalar.extras.chunks(ch).enumerate() {
                // The inner image is the image.
                assert_eq!(e[..3], scalar.image.pixels[p].to_array()[..]);
                let (albedo, normal) = (&e[ch - 6..ch - 3], &e[ch - 3..]);
                assert!(albedo.iter().all(|&a| (0.0..=1.0).contains(&a)));
                let len = normal.iter().map(|v| v * v).sum::<f32>().sqrt();
                assert!(len <= 1.0 + 1e-4);
                if e[3] == 0.0 {
                    assert!(
                        e[4..ch - 6].iter().all(|&v| v == 0.0),
                        "a miss has zero AOVs"
                    );
                }
                if len > 0.99 {
                    surfaced += 1;
                }
            }
            assert!(
                surfaced > scalar.extras.len() / ch / 4,
                "{surfaced} pixels with guides"
            );
        }
    }
}
