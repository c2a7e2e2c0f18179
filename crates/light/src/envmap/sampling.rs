//! The importance-sampling distribution (module doc of [`super`]): the texels' sampling weights,
//! the alias tables over the patches, and [`EnvMap::sample`] and [`EnvMap::pdf`].

use super::{luminance, prefetch, EnvMap, EnvSample};
use crate::alias::{self, AliasSlot};
use crate::unit::{clamp_unit, ONE_MINUS_EPSILON};
use glam::{Vec2, Vec3};
use torrey_texture::Image;

/// Each texel's sampling weight (row-major): luminance x sin(theta) of its row, theta = pi j /
/// (H - 1) (sin clamped at 0 on the poles).
pub(super) fn vertex_weights(image: &Image) -> Vec<f32> {
    let (w, h) = (image.width as usize, image.height as usize);
    let dtheta = std::f64::consts::PI / (h - 1) as f64;
    let mut weights = Vec::with_capacity(w * h);
    for j in 0..h {
        let sin_theta = (j as f64 * dtheta).sin().max(0.0) as f32;
        let row = &image.pixels[j * w..(j + 1) * w];
        weights.extend(row.iter().map(|&p| luminance(p) * sin_theta));
    }
    weights
}

/// The mean of each patch's four corner weights (row-major, `width` x (`height` - 1)): the
/// integral of the bilinear interpolant over the patch, in patch units.
pub(super) fn patch_weights(vertex: &[f32], width: usize, height: usize) -> Vec<f32> {
    let mut weights = Vec::with_capacity(width * (height - 1));
    for j in 0..height - 1 {
        let (top, bottom) = (&vertex[j * width..], &vertex[(j + 1) * width..]);
        for i in 0..width {
            let i1 = (i + 1) % width;
            weights.push(0.25 * (top[i] + top[i1] + bottom[i] + bottom[i1]));
        }
    }
    weights
}

/// Inverts the cdf of the density proportional to a (1 - t) + b t on [0, 1] (both >= 0) at `xi`,
/// in the form that stays accurate when a and b are close.
#[inline(always)]
pub(super) fn sample_linear(a: f32, b: f32, xi: f32) -> f32 {
    let denominator = a + (a * a * (1.0 - xi) + b * b * xi).sqrt();
    if denominator > 0.0 {
        (xi * (a + b) / denominator).min(ONE_MINUS_EPSILON)
    } else {
        xi
    }
}

/// The alias tables over an environment map's patch weights.
pub(super) struct SamplingTables {
    pub(super) row_slots: Vec<AliasSlot>,
    pub(super) column_slots: Vec<AliasSlot>,
    /// Sum of all weights (0: nothing to sample).
    pub(super) weight_sum: f64,
}

impl SamplingTables {
    /// `weights` row-major, `width * height` of them.
    pub(super) fn new(weights: &[f32], width: usize, height: usize) -> Self {
        let mut column_slots = Vec::with_capacity(width * height);
        let mut row_weights = Vec::with_capacity(height);
        for row in weights.chunks_exact(width) {
            alias::build_slots(row, &mut column_slots);
            row_weights.push(
                row.iter()
                    .filter(|w| w.is_finite() && **w > 0.0)
                    .map(|&w| w as f64)
                    .sum::<f64>(),
            );
        }
        let mut row_slots = Vec::with_capacity(height);
        alias::build_slots_f64(&row_weights, &mut row_slots);
        Self {
            row_slots,
            column_slots,
            weight_sum: row_weights.iter().sum(),
        }
    }
}

impl EnvMap {
    /// Starts loading the memory [`Self::sample`] will read for `u`: the row is chosen here (its
    /// table is small and cached), the column's alias slot and its own texel are prefetched.
    /// The integrator calls this before tracing the ray whose hit the sample lights, so that these
    /// cache misses (the slot and texel tables are megabytes, read at random) overlap the
    /// traversal. A hint only: nothing changes but timing, and it is free when the ray escapes.
    #[inline]
    pub fn prefetch_sample(&self, u: Vec2) {
        if !self.samplable {
            return;
        }
        let u = Vec2::new(clamp_unit(u.x), clamp_unit(u.y));
        let (row, _) = alias::pick(&self.row_slots, u.y);
        // u.x is in [0, 1): the own slot of the column pick (`size.x` is the width as f32).
        let column = ((u.x * self.size.x) as u32 as usize).min(self.width - 1);
        let cell = row * self.width + column;
        prefetch(self.column_slots.as_ptr().wrapping_add(cell));
        // The patch's top and bottom texel records (those of the slot's own column).
        prefetch(self.texels.as_ptr().wrapping_add(cell));
        prefetch(self.texels.as_ptr().wrapping_add(cell + self.width));
    }

    /// Importance-samples a direction by luminance x sin(theta) (module doc). `None` for a black
    /// map or a sample that lands exactly on a pole.
    #[inline]
    pub fn sample(&self, u: Vec2) -> Option<EnvSample> {
        if !self.samplable {
            return None;
        }
        let u = Vec2::new(clamp_unit(u.x), clamp_unit(u.y));
        let (row, v_in_patch) = alias::pick(&self.row_slots, u.y);
        let columns = &self.column_slots[row * self.width..(row + 1) * self.width];
        let (column, u_in_patch) = alias::pick(columns, u.x);
        let column1 = if column + 1 == self.width {
            0
        } else {
            column + 1
        };
        let (top, bottom) = (row * self.width, (row + 1) * self.width);
        debug_assert!(row + 1 < self.height && column < self.width && column1 < self.width);
        // SAFETY: the row table has height - 1 slots and each row's column table width slots,
        // and an alias table's pick is below its length (its own index, clamped, or an alias
        // that `build_slots` took from the same range); so both rows are below height, both
        // columns below width, and `texels` holds width x height records.
        let texel_w = |k: usize| unsafe { self.texels.get_unchecked(k).w };
        let [w00, w10, w01, w11] = [
            texel_w(top + column),
            texel_w(top + column1),
            texel_w(bottom + column),
            texel_w(bottom + column1),
        ];
        // The bilinear warp: the row position by the marginal (linear in t), then the column
        // position given it.
        let t = sample_linear(w00 + w10, w01 + w11, v_in_patch);
        let (left, right) = (w00 * (1.0 - t) + w01 * t, w10 * (1.0 - t) + w11 * t);
        let s = sample_linear(left, right, u_in_patch);
        let p_uv = left * (1.0 - s) + right * s;
        let mut su = (column as u32 as f32 + 0.5 + s) * self.inv_size.x;
        if su >= 1.0 {
            su -= 1.0;
        }
        let uv = Vec2::new(su, (row as u32 as f32 + t) * self.inv_bands)
            .min(Vec2::splat(ONE_MINUS_EPSILON));
        let (local, sin_theta) = Self::uv_to_local_dir_sin(uv);
        let pdf = Self::solid_angle_pdf(p_uv, sin_theta);
        if pdf <= 0.0 {
            return None;
        }
        Some(EnvSample {
            direction: self.to_world * local,
            radiance: self.bilinear_finest(uv) * self.scale,
            pdf,
        })
    }

    /// Density over solid angle of [`Self::sample`] producing world direction `dir`.
    #[inline]
    pub fn pdf(&self, dir: Vec3) -> f32 {
        if !self.samplable {
            return 0.0;
        }
        let (uv, sin_theta) = Self::local_dir_to_uv_sin(self.to_local * dir);
        self.pdf_uv(uv, sin_theta)
    }

    /// [`Self::pdf`] of the direction with local `uv` (in [0, 1]^2) and `sin_theta`.
    #[inline]
    pub(super) fn pdf_uv(&self, uv: Vec2, sin_theta: f32) -> f32 {
        if !self.samplable {
            return 0.0;
        }
        Self::solid_angle_pdf(self.bilinear_finest_with_density(uv).w, sin_theta)
    }
}
