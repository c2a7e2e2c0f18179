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
        }
    }

    /// The mean as an image of the crop's size.
    pub fn image(&self) -> torrey_texture::Image {
        torrey_texture::Image::new(self.meta.crop.2, self.meta.crop.3, self.mean.clone())
    }

    /// Samples per pixel in this part.
    pub fn sample_count(&self) -> u32 {
        self.meta.samples.1 - self.meta.samples.0
    }
}
