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
/// order; the pass reports count up. With Sobol samples every count is a power of two: the last
/// pass takes some pixels the whole way to the next level rather than all of them part of it
/// (`last_pass_pixels`), with a noise threshold too; with independent samples all pixels end with
/// the same count.
#[test]
fn time_limits_are_honoured_within_a_pass() {
    let scene = packet_scene();
    let limit = Duration::from_millis(400);
    for (sampler, threshold) in [
        (SamplerKind::Sobol, None),
        (SamplerKind::Independent, None),
        (SamplerKind::Sobol, Some(1e-4)),
    ] {
        let set = RenderSettings {
            time_limit: Some(limit),
            noise_threshold: threshold,
            ..settings(1 << 20, sampler, true)
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
        if threshold.is_none() {
            // One sample, then straight to 16 (`MIN_PASS_LEVEL`): small passes cost more per
            // sample. (The time easily allows it here.)
            let pixels = 24 * 20;
            assert_eq!(
                (reports[0].samples, reports[1].samples),
                (pixels, 16 * pixels)
            );
        }
        let last_pass = reports[reports.len() - 1].elapsed - reports[reports.len() - 2].elapsed;
        assert!(
            out.elapsed <= limit + last_pass + Duration::from_millis(50),
            "{:?} for a limit of {limit:?} (last pass {last_pass:?})",
            out.elapsed
        );
        let (lo, hi) = (
            *out.counts.iter().min().unwrap(),
            *out.counts.iter().max().unwrap(),
        );
        assert!(lo > 1, "{sampler:?}: {lo} samples");
        match (sampler, threshold) {
            (SamplerKind::Sobol, None) => assert!(
                lo.is_power_of_two() && (hi == lo || hi == 2 * lo),
                "counts {lo}..={hi}"
            ),
            // The pilot (64 samples here) first, whole doublings, then the noisiest pixels.
            (SamplerKind::Sobol, Some(_)) => assert!(
                out.counts.iter().all(|c| c.is_power_of_two()) && lo >= (hi / 2).min(64),
                "counts {lo}..={hi}"
            ),
            _ => assert_eq!(lo, hi, "uniform counts"),
        }
        let total: u64 = out.counts.iter().map(|&c| c as u64).sum();
        assert_eq!(reports.last().unwrap().samples, total);
        assert!(reports.iter().all(|r| r.time_left.is_some()));
    }
}

/// A time limit's last pass with Sobol samples takes the pixels of the highest counts first,
/// then of the next ones; within the group it cannot take whole, as many as the budget allows,
/// spread evenly over the pixel index (a quarter of the budget in each quarter of the image).
/// Before it, every pixel goes through the whole doublings that fit.
#[test]
fn the_last_pass_takes_whole_pixels_spread_evenly() {
    // 400 pixels with 64 to reach, 3600 with 32; from level 16 to 32.
    let caps: Vec<u32> = (0..4000)
        .map(|i| if i % 10 == 3 { 64 } else { 32 })
        .collect();
    let chosen = super::passes::last_pass_pixels(&caps, 16, 32, 16 * (400 + 1800));
    let high = (0..4000).filter(|&i| chosen[i] && caps[i] == 64).count();
    assert_eq!(high, 400, "every pixel of the highest count");
    let low: Vec<usize> = (0..4000).filter(|&i| chosen[i] && caps[i] == 32).collect();
    assert!((1795..=1805).contains(&low.len()), "{} of 1800", low.len());
    for q in 0..4 {
        let n = low.iter().filter(|&&i| i / 1000 == q).count();
        assert!((445..=455).contains(&n), "quarter {q}: {n} of about 450");
    }
    assert!(!super::passes::last_pass_pixels(&caps, 16, 32, 15).contains(&true));

    // From a pilot's first sample toward its 64: whole doublings for every pixel while they
    // fit (20 samples per pixel: to 16), then the next doubling for part of them.
    use super::passes::whole_prefix_pass;
    let caps = vec![1024u32; 100];
    assert_eq!(whole_prefix_pass(&caps, 0, 1, 64, 20 * 100), (16, None));
    let (to, chosen) = whole_prefix_pass(&caps, 0, 16, 64, 10 * 100);
    let chosen = chosen.expect("a part of the pixels");
    assert_eq!(to, 32);
    let n = chosen.iter().filter(|&&c| c).count();
    assert!(
        (60..=63).contains(&n),
        "{n} pixels of 16 more samples in 1000"
    );
    assert!(super::passes::last_pass_pixels(&caps, 16, 32, u64::MAX)
        .iter()
        .all(|&c| c));
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
