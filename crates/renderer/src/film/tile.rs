//! The film of one tile: where a tile's samples are accumulated, with one entry point,
//! [`TileFilm::add_sample`].

use super::filter::Filter;
use super::pixel::{PixelMean, SplatSum};
use glam::{Vec2, Vec3A};

/// The most pixels a splat spans along x: 2 radius + 1 for lanczos' largest `lobes` (64).
const MAX_SPLAT_WIDTH: usize = 130;

/// A window of film pixels that one tile's samples go to: the tile itself for importance-sampled
/// filters; for splatted filters the tile grown by the filter's border (and clipped to the
/// rendered window), since splats reach the neighbouring pixels.
#[derive(Clone, Debug)]
pub struct TileFilm {
    filter: Filter,
    /// The part of the film that samples may land in (the film, or its crop window): its
    /// corners, in film pixels.
    min: Vec2,
    max: Vec2,
    /// The accumulated window `(x, y, width, height)` in film pixels.
    pub(crate) window: (u32, u32, u32, u32),
    pub(crate) means: Vec<PixelMean>,
    pub(crate) splats: Vec<SplatSum>,
    /// Samples whose value was NaN or infinite (added as zero).
    pub(crate) nonfinite: u64,
    /// Values per sample besides the radiance (AOVs, denoising guides; see
    /// [`TileFilm::add_sample_with`]), and each pixel's sums of them, `channels` per pixel,
    /// weighted as the radiance is.
    pub(crate) channels: usize,
    pub(crate) extras: Vec<f32>,
}

impl TileFilm {
    /// `bounds` `(x, y, width, height)`: where samples may land (see [`super::Film::new`]).
    pub(crate) fn new(
        filter: Filter,
        bounds: (u32, u32, u32, u32),
        window: (u32, u32, u32, u32),
        channels: usize,
    ) -> Self {
        let pixels = window.2 as usize * window.3 as usize;
        let (means, splats) = if filter.splats() {
            (Vec::new(), vec![SplatSum::default(); pixels])
        } else {
            (vec![PixelMean::default(); pixels], Vec::new())
        };
        Self {
            filter,
            min: Vec2::new(bounds.0 as f32, bounds.1 as f32),
            max: Vec2::new((bounds.0 + bounds.2) as f32, (bounds.1 + bounds.3) as f32),
            window,
            means,
            splats,
            nonfinite: 0,
            channels,
            extras: vec![0.0; pixels * channels],
        }
    }

    /// The filter that places and weighs this tile's samples.
    pub fn filter(&self) -> Filter {
        self.filter
    }

    /// The film position of a sample `offset` from the centre of `pixel`, and whether it lies on
    /// the film (inside its crop window, if it has one). Mitsuba places samples there only
    /// (hdrfilm's `sample_border` is false): an importance-sampled offset that leaves it does not
    /// count (the pixel's estimate is over the part of the filter inside, as Mitsuba's weight
    /// division gives).
    #[inline]
    pub fn film_position(&self, (x, y): (u32, u32), offset: Vec2) -> (Vec2, bool) {
        let centre = Vec2::new(x as f32 + 0.5, y as f32 + 0.5);
        // Judged on the offset, against the bounds moved to the pixel centre (exact: halves of
        // integers below 2^23): the position rounds, and a box filter's offset just under 0.5
        // put the last column's and row's samples on the film's edge, outside (about one
        // sample in 10^6 of those pixels was traced nowhere and counted nowhere).
        let inside = offset.cmpge(self.min - centre).all() && offset.cmplt(self.max - centre).all();
        (centre + offset, inside)
    }

    /// [`TileFilm::add_sample`] for each `(film position, value)` of `samples`, all of `pixel`,
    /// in order: the same film to the bit. For importance-sampled filters the pixel's running
    /// mean stays in registers from one sample to the next instead of going through memory
    /// (its division per sample already makes a chain of waits).
    #[inline]
    pub fn add_samples(&mut self, pixel: (u32, u32), samples: impl Iterator<Item = (Vec2, Vec3A)>) {
        if self.filter.splats() {
            for (film, value) in samples {
                self.add_sample(pixel, film, value);
            }
            return;
        }
        let (wx, wy, ww, _) = self.window;
        let i = (pixel.1 - wy) as usize * ww as usize + (pixel.0 - wx) as usize;
        let mut mean = self.means[i];
        let mut nonfinite = 0;
        for (_, value) in samples {
            let value = if value.is_finite() {
                value
            } else {
                nonfinite += 1;
                Vec3A::ZERO
            };
            mean.add(value);
        }
        self.means[i] = mean;
        self.nonfinite += nonfinite;
    }

    /// Adds the radiance `value` of a sample of `pixel` (which must lie in the tile) at film
    /// position `film`, which [`TileFilm::film_position`] found on the film (the render loops
    /// check it before tracing, so neither the position nor the check is computed twice).
    /// Importance-sampled filters add it with weight one to `pixel`; splatted filters add it to
    /// every pixel of the window whose centre is within the filter's radius, weighted by the
    /// filter. A NaN or infinite value is counted and added as zero.
    #[inline]
    pub fn add_sample(&mut self, pixel: (u32, u32), film: Vec2, value: Vec3A) {
        let value = if value.is_finite() {
            value
        } else {
            self.nonfinite += 1;
            Vec3A::ZERO
        };
        let (wx, wy, ww, wh) = self.window;
        if !self.filter.splats() {
            let i = (pixel.1 - wy) as usize * ww as usize + (pixel.0 - wx) as usize;
            self.means[i].add(value);
            return;
        }
        // Pixels whose centres (i + 0.5) lie within the radius of the sample, as Mitsuba's
        // ImageBlock::put picks them, clipped to the window.
        let r = self.filter.radius();
        let lo = (film - Vec2::splat(0.5 + r))
            .ceil()
            .max(Vec2::new(wx as f32, wy as f32));
        let hi = (film + Vec2::splat(r - 0.5))
            .floor()
            .min(Vec2::new((wx + ww - 1) as f32, (wy + wh - 1) as f32));
        if lo.x > hi.x || lo.y > hi.y {
            return;
        }
        let (x0, x1, y0, y1) = (lo.x as u32, hi.x as u32, lo.y as u32, hi.y as u32);
        // The profile along x, once per column (lanczos' 64 lobes at most reach 129 pixels).
        let mut wxs = [0.0f32; MAX_SPLAT_WIDTH];
        for (w, px) in wxs.iter_mut().zip(x0..=x1) {
            *w = self.filter.eval(px as f32 + 0.5 - film.x);
        }
        for py in y0..=y1 {
            let fy = self.filter.eval(py as f32 + 0.5 - film.y);
            if fy == 0.0 {
                continue;
            }
            let row = (py - wy) as usize * ww as usize + (x0 - wx) as usize;
            let pixels = &mut self.splats[row..=row + (x1 - x0) as usize];
            for (pixel, &fx) in pixels.iter_mut().zip(&wxs) {
                let w = fx * fy;
                if w != 0.0 {
                    pixel.add(w, value);
                }
            }
        }
    }
}

impl TileFilm {
    /// [`TileFilm::add_sample`] with the sample's other values (`extras`, one per channel of
    /// the film): they are added to the same pixels with the same weights, so that each pixel
    /// holds their mean over its samples (non-finite ones count as zero).
    #[inline]
    pub fn add_sample_with(&mut self, pixel: (u32, u32), film: Vec2, value: Vec3A, extras: &[f32]) {
        debug_assert_eq!(extras.len(), self.channels);
        self.add_sample(pixel, film, value);
        let ch = self.channels;
        let (wx, wy, ww, wh) = self.window;
        let mut add = |index: usize, w: f32| {
            let sums = &mut self.extras[index * ch..(index + 1) * ch];
            for (s, &e) in sums.iter_mut().zip(extras) {
                if e.is_finite() {
                    *s += w * e;
                }
            }
        };
        if !self.filter.splats() {
            add(
                (pixel.1 - wy) as usize * ww as usize + (pixel.0 - wx) as usize,
                1.0,
            );
            return;
        }
        // The pixels and weights of `add_sample`'s splat.
        let r = self.filter.radius();
        let lo = (film - Vec2::splat(0.5 + r))
            .ceil()
            .max(Vec2::new(wx as f32, wy as f32));
        let hi = (film + Vec2::splat(r - 0.5))
            .floor()
            .min(Vec2::new((wx + ww - 1) as f32, (wy + wh - 1) as f32));
        if lo.x > hi.x || lo.y > hi.y {
            return;
        }
        for py in lo.y as u32..=hi.y as u32 {
            let fy = self.filter.eval(py as f32 + 0.5 - film.y);
            for px in lo.x as u32..=hi.x as u32 {
                let w = self.filter.eval(px as f32 + 0.5 - film.x) * fy;
                if w != 0.0 {
                    add((py - wy) as usize * ww as usize + (px - wx) as usize, w);
                }
            }
        }
    }

    /// The pixel's current estimate (the samples added so far); `pixel` in the tile's window.
    pub fn pixel_value(&self, pixel: (u32, u32)) -> super::PixelValue {
        let (wx, wy, ww, _) = self.window;
        let i = (pixel.1 - wy) as usize * ww as usize + (pixel.0 - wx) as usize;
        if self.filter.splats() {
            self.splats[i].finish()
        } else {
            self.means[i].finish()
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use torrey_parser::PixelFilter;

    /// A box filter's offset just under half a pixel keeps the last column's and row's sample
    /// on the film (in f32, 319.5 + 0.49999997 rounds to 320, the film's edge).
    #[test]
    fn box_samples_at_the_film_edge_count() {
        let film = super::super::Film::new(PixelFilter::Box, (0, 0, 320, 240), (0, 0, 320, 240));
        let tile = film.tile((304, 224, 320, 240));
        let just_under = 0.5f32.next_down();
        for pixel in [(319, 239), (319, 0), (0, 239)] {
            let (_, inside) = tile.film_position(pixel, Vec2::splat(just_under));
            assert!(inside, "{pixel:?}");
        }
        let (_, inside) = tile.film_position((319, 239), Vec2::new(0.5, 0.0));
        assert!(!inside, "half a pixel out is off the film");
        let (_, inside) = tile.film_position((0, 0), Vec2::splat(-0.5));
        assert!(inside, "the film's first edge is on it");
    }

    /// `add_samples` leaves the film `add_sample` leaves, bit for bit (means, variances,
    /// counts, weights, non-finite samples), for a plain mean and a splatting filter, with NaN
    /// and infinite values among the samples and runs of one pixel after another.
    #[test]
    fn add_samples_is_add_sample_in_order() {
        let mut rng = torrey_testkit::Rng::new(5);
        for kind in [
            PixelFilter::Box,
            PixelFilter::Gaussian { stddev: 0.5 },
            PixelFilter::Lanczos { lobes: 3 },
        ] {
            let filter = Filter::new(kind);
            let (mut one, mut many) = (
                TileFilm::new(filter, (0, 0, 8, 6), (0, 0, 8, 6), 0),
                TileFilm::new(filter, (0, 0, 8, 6), (0, 0, 8, 6), 0),
            );
            for run in 0..40 {
                let pixel = (rng.next_u64() % 8) as u32;
                let pixel = (pixel, (rng.next_u64() % 6) as u32);
                let samples: Vec<(Vec2, Vec3A)> = (0..(run % 7) + 1)
                    .map(|k| {
                        let offset = Vec2::new(rng.range(-0.5, 0.5), rng.range(-0.5, 0.5));
                        let value = match (run + k) % 11 {
                            3 => Vec3A::new(f32::NAN, 1.0, 2.0),
                            7 => Vec3A::splat(f32::INFINITY),
                            _ => Vec3A::new(rng.f32(), rng.range(0.0, 1e4), rng.f32() * 1e-3),
                        };
                        (one.film_position(pixel, offset).0, value)
                    })
                    .collect();
                for &(film, value) in &samples {
                    one.add_sample(pixel, film, value);
                }
                many.add_samples(pixel, samples.iter().copied());
            }
            assert_eq!(one.nonfinite, many.nonfinite);
            assert!(one.nonfinite > 0);
            let bits = |t: &TileFilm| -> Vec<u32> {
                let values: Vec<_> = if filter.splats() {
                    t.splats.iter().map(|s| s.finish()).collect()
                } else {
                    t.means.iter().map(|m| m.finish()).collect()
                };
                values
                    .iter()
                    .flat_map(|v| {
                        let (m, var) = (v.mean.to_array(), v.variance.to_array());
                        m.into_iter()
                            .chain(var)
                            .chain([v.weight])
                            .map(f32::to_bits)
                            .chain([v.count])
                    })
                    .collect()
            };
            assert_eq!(bits(&one), bits(&many), "{kind:?}");
        }
    }
}
