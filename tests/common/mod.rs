//! Shared helpers for the integration tests: render a scene file small, and compare an image with
//! a reference using a tolerance derived from the render's own noise.

#![allow(dead_code)]

pub mod hostile;
pub mod verdict;

use glam::Vec3;
use std::path::{Path, PathBuf};
use torrey_texture::Image;

/// The workspace root (the root package's manifest directory).
pub fn root() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR"))
}

/// `../shared` beside the workspace, if present (absent on a fresh clone).
pub fn shared() -> Option<PathBuf> {
    let p = root().join("..").join("shared");
    p.is_dir().then_some(p)
}

pub struct Rendered {
    pub image: Image,
    pub variance: Image,
    pub nonfinite: u64,
}

/// Renders `scene` at `width` x `height`, `spp` samples, optionally overriding the max depth.
pub fn render_scene(
    scene: &Path,
    width: u32,
    height: u32,
    spp: u32,
    max_depth: Option<i32>,
    seed: u64,
) -> Rendered {
    render_scene_opts(scene, width, height, spp, max_depth, seed, true)
}

/// As [`render_scene`], choosing whether textures are mip-mapped.
pub fn render_scene_opts(
    scene: &Path,
    width: u32,
    height: u32,
    spp: u32,
    max_depth: Option<i32>,
    seed: u64,
    mipmapping: bool,
) -> Rendered {
    render_scene_with(
        scene,
        &torrey_parser::LoadOptions::default(),
        (width, height),
        spp,
        max_depth,
        seed,
        mipmapping,
    )
}

/// As [`render_scene_opts`], reading the scene with `options` (a forced dialect, say).
pub fn render_scene_with(
    scene: &Path,
    options: &torrey_parser::LoadOptions,
    (width, height): (u32, u32),
    spp: u32,
    max_depth: Option<i32>,
    seed: u64,
    mipmapping: bool,
) -> Rendered {
    let desc = torrey_parser::load_scene_with(scene, options).unwrap_or_else(|e| panic!("{e}"));
    // A film with a crop window asked for at its window's size renders that window of the whole
    // film, as the command line does without `--size`.
    let crop = desc
        .film
        .crop
        .filter(|c| (c.width, c.height) == (width, height));
    let (film_width, film_height) = match crop {
        Some(_) => (desc.film.width, desc.film.height),
        None => (width, height),
    };
    let rs = torrey_renderer::RenderScene::build(&desc, film_width, film_height)
        .unwrap_or_else(|e| panic!("{e}"));
    let settings = torrey_renderer::RenderSettings::new(
        &desc,
        &torrey_renderer::Overrides {
            spp: Some(spp),
            max_depth,
            seed: Some(seed),
            // Independent samples: the per-pixel variance then estimates the error exactly.
            sampler: Some(torrey_renderer::SamplerKind::Independent),
            mipmapping: Some(mipmapping),
            ..Default::default()
        },
    );
    let out = match crop {
        Some(c) => {
            let slice = torrey_renderer::RenderSlice {
                crop: c.rect(),
                samples: 0..spp.max(1),
            };
            torrey_renderer::render_slice(&rs, &settings, &slice, &|_, _| {})
                .unwrap_or_else(|e| panic!("{e}"))
        }
        None => torrey_renderer::render(&rs, &settings, &|_, _| {}),
    };
    Rendered {
        image: out.image,
        variance: out.variance,
        nonfinite: out.nonfinite_samples,
    }
}

/// The outcome of a noise-aware comparison.
#[derive(Debug)]
pub struct NoiseComparison {
    /// Share of blocks whose mean differs from the reference by more than `z_limit` standard errors.
    pub outlier_blocks: f64,
    /// Largest |z| over all blocks.
    pub max_z: f64,
    /// Mean over the image, ours / reference, per channel.
    pub mean_ratio: [f64; 3],
    /// Standard error of that ratio from our noise, per channel.
    pub mean_ratio_sigma: [f64; 3],
    pub blocks: usize,
}

/// Compares `ours` (with per-pixel variance of the mean `var`) against `reference`, averaged over
/// `block` x `block` pixel blocks so the heavy-tailed path-tracing noise becomes near-Gaussian.
/// Each block's allowed deviation is `sqrt(sigma^2 + (rel_bias * ref)^2 + abs_bias^2)`: our noise
/// plus a small systematic allowance for documented convention differences (mip-mapping,
/// cell-centred envmap texels), and the reference's own noise, `ref_pixel_sigma` per pixel.
#[allow(clippy::too_many_arguments)]
pub fn compare_with_noise(
    ours: &Image,
    var: &Image,
    reference: &Image,
    block: u32,
    rel_bias: f64,
    abs_bias: f64,
    ref_pixel_sigma: f64,
    z_limit: f64,
) -> NoiseComparison {
    assert_eq!(
        (ours.width, ours.height),
        (reference.width, reference.height),
        "image sizes differ"
    );
    let (w, h) = (ours.width, ours.height);
    let mut outliers = 0usize;
    let mut blocks = 0usize;
    let mut max_z = 0f64;
    for by in (0..h).step_by(block as usize) {
        for bx in (0..w).step_by(block as usize) {
            let mut sum_o = [0f64; 3];
            let mut sum_r = [0f64; 3];
            let mut sum_v = [0f64; 3];
            let mut n = 0f64;
            for y in by..(by + block).min(h) {
                for x in bx..(bx + block).min(w) {
                    let (o, r, v) = (ours.get(x, y), reference.get(x, y), var.get(x, y));
                    for c in 0..3 {
                        sum_o[c] += o[c] as f64;
                        sum_r[c] += r[c] as f64;
                        sum_v[c] += v[c] as f64;
                    }
                    n += 1.0;
                }
            }
            blocks += 1;
            let mut block_out = false;
            for c in 0..3 {
                let mo = sum_o[c] / n;
                let mr = sum_r[c] / n;
                let sigma2 = sum_v[c] / (n * n) + ref_pixel_sigma * ref_pixel_sigma / n;
                let allowed = (sigma2 + (rel_bias * mr).powi(2) + abs_bias * abs_bias).sqrt();
                let z = (mo - mr).abs() / allowed.max(1e-12);
                max_z = max_z.max(z);
                block_out |= z > z_limit;
            }
            if block_out {
                outliers += 1;
            }
        }
    }
    let mut mean_ratio = [0f64; 3];
    let mut mean_ratio_sigma = [0f64; 3];
    let npx = (w * h) as f64;
    for c in 0..3 {
        let so: f64 = ours.pixels.iter().map(|p| p[c] as f64).sum();
        let sr: f64 = reference.pixels.iter().map(|p| p[c] as f64).sum();
        let sv: f64 = var.pixels.iter().map(|p| p[c] as f64).sum();
        mean_ratio[c] = so / sr.max(1e-12);
        let var_total = sv / (npx * npx) + ref_pixel_sigma * ref_pixel_sigma / npx;
        mean_ratio_sigma[c] = var_total.sqrt() / (sr / npx).max(1e-12);
    }
    NoiseComparison {
        outlier_blocks: outliers as f64 / blocks as f64,
        max_z,
        mean_ratio,
        mean_ratio_sigma,
        blocks,
    }
}

pub fn load(path: &Path) -> Image {
    torrey_texture::load_image(path, false)
        .unwrap_or_else(|e| panic!("{e}"))
        .image
}

/// Mean of an image per channel.
pub fn mean(img: &Image) -> Vec3 {
    img.pixels.iter().copied().sum::<Vec3>() / img.pixels.len() as f32
}

/// Per-pixel standard deviation of a reference from its manifest's `noise_rel` (mean |a - b| / 2
/// over the mean, for two independent half renders a and b) and mean value: for Gaussian noise
/// the full render's sigma is sqrt(pi / 2) * noise_rel * mean.
pub fn reference_sigma(noise_rel: f64, mean: f64) -> f64 {
    (std::f64::consts::PI / 2.0).sqrt() * noise_rel * mean
}

/// The verdict of [`compare_to_reference`]: a one-line summary and whether it is within tolerance.
pub struct Verdict {
    pub summary: String,
    pub pass: bool,
}

/// The project's standard comparison of a render with a reference image: 8x8 blocks within 5
/// standard errors (our noise plus the reference's, from its `noise_rel`), 1% systematic allowance;
/// it passes when at most 2% of blocks are outside and the image mean is within 4 sigma + 1%.
pub fn compare_to_reference(
    label: &str,
    r: &Rendered,
    reference: &Image,
    noise_rel: f64,
) -> Verdict {
    let ref_mean = mean(reference).element_sum() as f64 / 3.0;
    let ref_sigma = reference_sigma(noise_rel, ref_mean);
    let cmp = compare_with_noise(
        &r.image,
        &r.variance,
        reference,
        8,
        0.01,
        1e-4,
        ref_sigma,
        5.0,
    );
    let summary = format!(
        "{label}: blocks beyond 5 sigma {:.1}% of {}, max z {:.2}, mean ratio [{:.4} {:.4} {:.4}] ± [{:.4} {:.4} {:.4}]",
        cmp.outlier_blocks * 100.0,
        cmp.blocks,
        cmp.max_z,
        cmp.mean_ratio[0],
        cmp.mean_ratio[1],
        cmp.mean_ratio[2],
        cmp.mean_ratio_sigma[0],
        cmp.mean_ratio_sigma[1],
        cmp.mean_ratio_sigma[2],
    );
    let mean_ok =
        (0..3).all(|c| (cmp.mean_ratio[c] - 1.0).abs() <= 4.0 * cmp.mean_ratio_sigma[c] + 0.01);
    // Up to 2% of the blocks, but never fewer than two, may lie beyond 5 sigma: a small bright sun
    // in an environment map makes the per-block noise heavy-tailed (a block's sample variance
    // misses the rare sun paths), and over seeds 7-11 single scenes showed exactly two such blocks
    // about a third of the time with a correct renderer; a real difference moves many blocks
    // and the mean (negative control in tests/references.rs).
    let outliers = (cmp.outlier_blocks * cmp.blocks as f64).round();
    let allowed = (0.02 * cmp.blocks as f64).max(2.0);
    Verdict {
        summary,
        pass: outliers <= allowed && mean_ok,
    }
}
