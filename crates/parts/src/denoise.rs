//! Denoising a part (`--denoise`, `torrey merge --denoise`, Python's `denoise=True`): its mean
//! denoised by Intel Open Image Denoise with its albedo and normal guides (the `albedo.*` and
//! `normal.*` channels the render took at each path's first non-delta hit), in HDR mode.

use crate::Part;
use glam::Vec3;
use std::time::Instant;
use torrey_denoise::Prefilter;
use torrey_renderer::GUIDE_CHANNELS;

/// Denoises `part` (its `denoised` image; the mean stays as the noisy one), its guides treated
/// as `prefilter` says; returns the seconds the denoiser took.
pub fn denoise_part(part: &mut Part, prefilter: Prefilter) -> Result<f64, String> {
    let (w, h) = (part.meta.crop.2 as usize, part.meta.crop.3 as usize);
    let guide = |names: &[&str]| {
        part.channel_values(names).ok_or_else(|| {
            "cannot denoise: the image has no albedo.R/G/B and normal.X/Y/Z guides (render it with --denoise)".to_string()
        })
    };
    let albedo = guide(&GUIDE_CHANNELS[..3])?;
    let normal = guide(&GUIDE_CHANNELS[3..])?;
    let color: Vec<f32> = part.mean.iter().flat_map(|p| p.to_array()).collect();
    let start = Instant::now();
    let out = torrey_denoise::denoise(
        w,
        h,
        &color,
        Some(torrey_denoise::Guides {
            albedo: &albedo,
            normal: &normal,
        }),
        prefilter,
    )?;
    let seconds = start.elapsed().as_secs_f64();
    part.denoised = Some(out.chunks_exact(3).map(Vec3::from_slice).collect());
    Ok(seconds)
}
