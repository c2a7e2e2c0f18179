//! One piece of a render: its metadata and its pixels.

use crate::meta::PartMeta;
use glam::Vec3;
use torrey_renderer::RenderOutput;

/// A render part: per-pixel mean radiance and variance of the mean over the part's samples,
/// row by row over its crop window.
#[derive(Clone, Debug)]
pub struct Part {
    pub meta: PartMeta,
    pub mean: Vec<Vec3>,
    pub variance: Vec<Vec3>,
    /// Samples that counted in each pixel (a filter offset can leave the film): the merge's
    /// per-pixel weights.
    pub count: Vec<u32>,
    /// Sum of the sample weights in each pixel: `count` for importance-sampled filters (weight
    /// one each), the splats' filter weights for splatted ones (mitchell, catmullrom, lanczos).
    pub weight: Vec<f32>,
    /// Per-pixel means of the other values the samples wrote (Mitsuba's AOVs, the denoiser's
    /// guides), by EXR channel name: `extras` holds `channels.len()` values per pixel.
    pub channels: Vec<String>,
    pub extras: Vec<f32>,
    /// The denoised image, when the part was denoised (its EXR's RGB; `mean` is then the noisy
    /// image, in `noisy.R/G/B`). Merging drops it: denoising does not commute with merging.
    pub denoised: Option<Vec<Vec3>>,
}

impl Part {
    /// The part a [`torrey_renderer::render_slice`] output makes; `meta` describes it (its
    /// `nonfinite` count is taken from the output).
    pub fn from_output(mut meta: PartMeta, out: &RenderOutput) -> Self {
        meta.nonfinite = out.nonfinite_samples;
        meta.clamped = out.clamped_pixels;
        Part {
            meta,
            mean: out.image.pixels.clone(),
            variance: out.variance.pixels.clone(),
            count: out.counts.clone(),
            weight: out.weights.clone(),
            channels: out.channels.clone(),
            extras: out.extras.clone(),
            denoised: None,
        }
    }

    /// The picture: the denoised image if there is one, else the mean, of the crop's size.
    pub fn image(&self) -> torrey_texture::Image {
        let pixels = self.denoised.as_ref().unwrap_or(&self.mean).clone();
        torrey_texture::Image::new(self.meta.crop.2, self.meta.crop.3, pixels)
    }

    /// The per-pixel values of the channels `names` (in that order, row by row), if the part
    /// has them all.
    pub fn channel_values(&self, names: &[&str]) -> Option<Vec<f32>> {
        let index: Vec<usize> = names
            .iter()
            .map(|n| self.channels.iter().position(|c| c == n))
            .collect::<Option<_>>()?;
        let ch = self.channels.len();
        Some(
            self.extras
                .chunks_exact(ch.max(1))
                .take(self.mean.len())
                .flat_map(|p| index.iter().map(move |&i| p[i]))
                .collect(),
        )
    }

    /// Samples per pixel in this part.
    pub fn sample_count(&self) -> u32 {
        self.meta.samples.1 - self.meta.samples.0
    }
}
