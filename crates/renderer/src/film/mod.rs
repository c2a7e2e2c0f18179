//! The film: reconstruction filters ([`Filter`]), the accumulation of one tile's samples
//! ([`TileFilm::add_sample`], the one entry point of the render loop) and the rendered window
//! that tiles are gathered into ([`Film`]).
//!
//! Filters without negative lobes are importance-sampled (each sample counts once, in its own
//! pixel); filters with negative lobes are splatted into the pixels around the sample with
//! signed weights, each pixel being sum(w L) / sum(w), as Mitsuba's film gives (see
//! docs/conventions.md, "Pixel filter"). For splatting, a tile's film covers the tile grown by the
//! filter's border; tiles lie on a grid fixed to the film (not to the rendered window) and are
//! added in grid order, so a pixel's sums are the same, bit for bit, whichever window of the film
//! is rendered, and a window's render also draws the samples of the pixels around it that reach
//! into it.

mod filter;
mod pixel;
mod tile;

pub use filter::Filter;
pub use pixel::PixelValue;
pub use tile::TileFilm;

use pixel::SplatSum;
use torrey_parser::PixelFilter;

/// The rendered window of the film: the tiles to render and their gathered pixels.
pub struct Film {
    filter: Filter,
    /// Where samples may land, `(x, y, width, height)`: the film, or its crop window (Mitsuba
    /// places samples inside the crop window only).
    bounds: (u32, u32, u32, u32),
    /// The rendered window `(x, y, width, height)`.
    crop: (u32, u32, u32, u32),
    values: Vec<PixelValue>,
    sums: Vec<SplatSum>,
    nonfinite: u64,
    /// Values per sample besides the radiance ([`TileFilm::add_sample_with`]) and their
    /// weighted sums, `channels` per pixel.
    channels: usize,
    extras: Vec<f32>,
}

impl Film {
    /// A film whose samples land in `bounds` and whose window `crop` (inside `bounds`) is
    /// rendered, both `(x, y, width, height)`.
    pub fn new(
        filter: PixelFilter,
        bounds: (u32, u32, u32, u32),
        crop: (u32, u32, u32, u32),
    ) -> Self {
        let filter = Filter::new(filter);
        let pixels = crop.2 as usize * crop.3 as usize;
        let (values, sums) = if filter.splats() {
            (Vec::new(), vec![SplatSum::default(); pixels])
        } else {
            (vec![PixelValue::default(); pixels], Vec::new())
        };
        Self {
            filter,
            bounds,
            crop,
            values,
            sums,
            nonfinite: 0,
            channels: 0,
            extras: Vec::new(),
        }
    }

    /// The film with `channels` values per sample besides the radiance.
    pub fn with_channels(mut self, channels: usize) -> Self {
        self.channels = channels;
        self.extras = vec![0.0; self.crop.2 as usize * self.crop.3 as usize * channels];
        self
    }

    /// The tiles to render, `(x0, y0, x1, y1)` (end exclusive), of at most `ts` x `ts` pixels, in
    /// the order [`Film::add_tile`] wants them. Importance-sampled filters: the window cut from
    /// its corner. Splatted filters: the window grown by the filter's border (clipped to the
    /// film), cut along a grid fixed to the film.
    pub fn tiles(&self, ts: u32) -> Vec<(u32, u32, u32, u32)> {
        let ts = ts.max(1);
        let (cx, cy, cw, ch) = self.crop;
        let b = self.filter.border();
        if b == 0 && !self.filter.splats() {
            return (0..ch.div_ceil(ts))
                .flat_map(|ty| {
                    (0..cw.div_ceil(ts)).map(move |tx| {
                        let (x0, y0) = (cx + tx * ts, cy + ty * ts);
                        (x0, y0, (x0 + ts).min(cx + cw), (y0 + ts).min(cy + ch))
                    })
                })
                .collect();
        }
        let (bx, by, bw, bh) = self.bounds;
        let (rx0, ry0) = (cx.saturating_sub(b).max(bx), cy.saturating_sub(b).max(by));
        let rx1 = (cx as u64 + cw as u64 + b as u64).min(bx as u64 + bw as u64) as u32;
        let ry1 = (cy as u64 + ch as u64 + b as u64).min(by as u64 + bh as u64) as u32;
        let mut tiles = Vec::new();
        for ty in ry0 / ts..ry1.div_ceil(ts) {
            for tx in rx0 / ts..rx1.div_ceil(ts) {
                let x0 = (tx * ts).max(rx0);
                let y0 = (ty * ts).max(ry0);
                let x1 = (tx * ts).saturating_add(ts).min(rx1);
                let y1 = (ty * ts).saturating_add(ts).min(ry1);
                tiles.push((x0, y0, x1, y1));
            }
        }
        tiles
    }

    /// The empty film of one tile from [`Film::tiles`].
    pub fn tile(&self, (x0, y0, x1, y1): (u32, u32, u32, u32)) -> TileFilm {
        let window = if self.filter.splats() {
            let b = self.filter.border();
            let (cx, cy, cw, ch) = self.crop;
            let wx0 = x0.saturating_sub(b).max(cx);
            let wy0 = y0.saturating_sub(b).max(cy);
            let wx1 = (x1 + b).min(cx + cw);
            let wy1 = (y1 + b).min(cy + ch);
            (wx0, wy0, wx1.saturating_sub(wx0), wy1.saturating_sub(wy0))
        } else {
            (x0, y0, x1 - x0, y1 - y0)
        };
        TileFilm::new(self.filter, self.bounds, window, self.channels)
    }

    /// Gathers a rendered tile; tiles must come in the order of [`Film::tiles`] (it fixes the
    /// order in which a pixel's splat sums are added).
    pub fn add_tile(&mut self, tile: TileFilm) {
        let (cx, cy, cw, _) = self.crop;
        let (wx, wy, ww, wh) = tile.window;
        self.nonfinite += tile.nonfinite;
        let ch = self.channels;
        for row in 0..wh {
            let out = (wy + row - cy) as usize * cw as usize + (wx - cx) as usize;
            let src = row as usize * ww as usize;
            for col in 0..ww as usize {
                if self.filter.splats() {
                    self.sums[out + col].merge(&tile.splats[src + col]);
                } else {
                    self.values[out + col] = tile.means[src + col].finish();
                }
                let (o, t) = ((out + col) * ch, (src + col) * ch);
                for (a, b) in self.extras[o..o + ch]
                    .iter_mut()
                    .zip(&tile.extras[t..t + ch])
                {
                    *a += b;
                }
            }
        }
    }

    /// Whether the filter splats samples into the pixels around them.
    pub fn splats(&self) -> bool {
        self.filter.splats()
    }

    /// Samples whose value was NaN or infinite (added as zero).
    pub fn nonfinite(&self) -> u64 {
        self.nonfinite
    }

    /// The window's pixels and the means of their extra values (`channels` per pixel: the
    /// sums over the weight sums), row by row.
    pub fn finish(self) -> (Vec<PixelValue>, Vec<f32>) {
        let pixels = if self.filter.splats() {
            self.sums.iter().map(SplatSum::finish).collect()
        } else {
            self.values
        };
        let mut extras = self.extras;
        let ch = self.channels;
        if ch > 0 {
            for (p, e) in pixels.iter().zip(extras.chunks_exact_mut(ch)) {
                let w = if p.weight != 0.0 { 1.0 / p.weight } else { 0.0 };
                e.iter_mut().for_each(|v| *v *= w);
            }
        }
        (pixels, extras)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use glam::{Vec2, Vec3A};

    /// Splatting tiles cover the window grown by the border on a film-fixed grid; every sample of
    /// a splatted constant lands on the film with weight sum > 0, and the window's pixels all
    /// come out as the constant (the filter's sum(w L) / sum(w)), borders included.
    #[test]
    fn splatted_tiles_gather_a_constant() {
        let size = (20, 14);
        for filter in [
            PixelFilter::Lanczos { lobes: 3 },
            PixelFilter::CatmullRom,
            PixelFilter::Mitchell {
                b: 1.0 / 3.0,
                c: 1.0 / 3.0,
            },
            PixelFilter::Box,
            PixelFilter::Gaussian { stddev: 0.5 },
        ] {
            let crop = (3, 0, 9, 7);
            let mut film = Film::new(filter, (0, 0, size.0, size.1), crop);
            let tiles = film.tiles(4);
            let f = Filter::new(filter);
            for &(x0, y0, x1, y1) in &tiles {
                assert!(x1 <= size.0 && y1 <= size.1 && x0 < x1 && y0 < y1);
                if f.splats() {
                    assert!(x0 % 4 == 0 || x0 == 3 - f.border().min(3));
                }
                let mut t = film.tile((x0, y0, x1, y1));
                for y in y0..y1 {
                    for x in x0..x1 {
                        for k in 0..16 {
                            let u = Vec2::new((k % 4) as f32 + 0.5, (k / 4) as f32 + 0.5) / 4.0;
                            let (position, inside) = t.film_position((x, y), f.offset(u));
                            if inside {
                                t.add_sample((x, y), position, Vec3A::splat(2.5));
                            }
                        }
                    }
                }
                film.add_tile(t);
            }
            let (pixels, _) = film.finish();
            assert_eq!(pixels.len(), 63);
            for p in &pixels {
                assert!(
                    (p.mean - Vec3A::splat(2.5)).abs().max_element() < 1e-4,
                    "{filter:?} {p:?}"
                );
                assert!(p.weight > 0.0 && p.count > 0);
            }
        }
    }

    /// With a crop window as the bounds (Mitsuba's film crop), splatting tiles and sample
    /// positions stay inside it: no pixel outside draws samples, no sample lands outside.
    #[test]
    fn bounds_keep_tiles_and_samples_inside_the_crop_window() {
        let bounds = (5, 4, 8, 6);
        let film = Film::new(PixelFilter::Lanczos { lobes: 3 }, bounds, (6, 5, 4, 3));
        let tiles = film.tiles(4);
        assert!(!tiles.is_empty());
        for &(x0, y0, x1, y1) in &tiles {
            assert!(
                x0 >= 5 && y0 >= 4 && x1 <= 13 && y1 <= 10,
                "{:?}",
                (x0, y0, x1, y1)
            );
            let t = film.tile((x0, y0, x1, y1));
            assert!(!t.film_position((x0, y0), Vec2::new(-0.6, 0.0)).1 || x0 > 5);
            assert!(t.film_position((x0, y0), Vec2::new(0.4, 0.4)).1);
        }
    }
}
