//! Adaptive sampling's decisions: how many samples each pixel gets, from a uniform pilot of its
//! neighbours.
//!
//! Every pixel first gets the same `pilot` samples (global indices `0..pilot`). Each pixel's
//! total is then decided once, from the pilot samples of the 24 pixels around it (5 x 5) and not from
//! its own: their pooled per-sample standard deviation s and mean m (channel averages) predict
//! the samples N that bring the pixel's relative standard error s / (m sqrt(N)) under the
//! threshold T, N = SAFETY (s / (m T))², clamped to `pilot..spp`. Since a pixel's count depends
//! only on other pixels' samples, which are independent of its own (every pixel draws its own
//! sample streams), its mean over samples `0..N` is an unbiased estimate whatever N is, as a
//! uniform render's: adaptive sampling stays unbiased, and a pixel's error is judged with its
//! neighbours (a lucky pilot of its own does not stop it early; a firefly nearby keeps it going).
//! The decision is made once: counts decided again from later samples would depend, through
//! the neighbours' counts, on the pixel's own samples.

use super::Ranges;
use crate::film::{Film, PixelValue, TileFilm};
use crate::render::Tracer;
use std::time::Instant;

/// Predicted sample counts are raised by this factor: the pooled variance of a few dozen
/// samples is itself noisy, and a count too low leaves the pixel over the threshold.
const SAFETY: f32 = 2.0;

/// The pilot's samples per pixel for a render of `spp`: a sixteenth of them, rounded up to a
/// power of two (a whole Sobol prefix, and whole packets of eight camera rays), between 8 and 64
/// (at most `spp`).
pub(super) fn pilot_size(spp: u32) -> u32 {
    (spp / 16)
        .max(1)
        .next_power_of_two()
        .clamp(8, 64)
        .min(spp.max(1))
}

/// Below this brightness a pixel's error is judged against it instead of its mean: the floor of
/// the relMSE that the project measures error with ((img - ref)² / (ref² + 0.01)). Without it
/// dark pixels (shadows, a black sky with a few lamps) asked for the most samples although an
/// error of 0.01 on a pixel of 0.02 is invisible (stage-lights: adaptive at equal time was 0.86x
/// as efficient as uniform).
const DARK: f32 = 0.1;

/// A pixel's relative standard error, from its `mean` and the `variance` of that mean: the
/// channel-averaged standard deviation over the channel-averaged mean, the mean taken as at
/// least [`DARK`] (sqrt(mean² + DARK²)). What `--noise-threshold` bounds.
pub fn relative_error(mean: glam::Vec3, variance: glam::Vec3) -> f32 {
    let sd = variance.max(glam::Vec3::ZERO).to_array().map(f32::sqrt);
    let sd = (sd[0] + sd[1] + sd[2]) / 3.0;
    let mean = (mean.x + mean.y + mean.z) / 3.0;
    sd / (mean * mean + DARK * DARK).sqrt()
}

/// The pixels of `window` (x, y, w, h) as far as `tiles` (rendered over `rects`) hold them,
/// written into `out` (row by row over the window).
pub(super) fn gather(
    rects: &[(u32, u32, u32, u32)],
    tiles: &[TileFilm],
    window: (u32, u32, u32, u32),
    out: &mut [PixelValue],
) {
    let (wx, wy, ww, wh) = window;
    for (&(x0, y0, x1, y1), tile) in rects.iter().zip(tiles) {
        for y in y0.max(wy)..y1.min(wy + wh) {
            for x in x0.max(wx)..x1.min(wx + ww) {
                out[((y - wy) * ww + (x - wx)) as usize] = tile.pixel_value((x, y));
            }
        }
    }
}

/// The output film's tiles: each tile's corners (x0, y0, x1, y1; ends exclusive) and its film.
type OutputTiles<'a> = (&'a [(u32, u32, u32, u32)], &'a [TileFilm]);

/// The half-side of the square of neighbours whose pooled pilot variance decides a pixel's count:
/// 5 x 5. With the eight pixels around it (3 x 3), the pixels whose variance comes from rare
/// paths were stopped early when no neighbour's pilot had caught one (interior_openings at
/// T = 0.1, the --spp cap out of the way: 89.4% of pixels under T with 3 x 3, 97.8% with 5 x 5
/// for 11% more samples; docs/clean-image.md).
const RADIUS: u32 = 2;

/// The pilot's pixels over the crop grown by [`RADIUS`] (clipped to where samples land), and
/// that window. With `output` (the output film's tiles, holding the pilot of the crop's
/// pixels), only the ring around the crop is rendered; otherwise every pixel's pilot is.
pub(super) fn pilot(
    tracer: &Tracer,
    crop: (u32, u32, u32, u32),
    pilot: u32,
    output: Option<OutputTiles>,
    start: Instant,
    progress: &(dyn Fn(u64, u64) + Sync),
) -> ((u32, u32, u32, u32), Vec<PixelValue>) {
    let (bx, by, bw, bh) = tracer.scene.sample_window();
    let (cx, cy, cw, ch) = crop;
    let (x0, y0) = (
        cx.saturating_sub(RADIUS).max(bx),
        cy.saturating_sub(RADIUS).max(by),
    );
    let (x1, y1) = (
        (cx + cw + RADIUS).min(bx + bw),
        (cy + ch + RADIUS).min(by + bh),
    );
    let window = (x0, y0, x1 - x0, y1 - y0);
    let inside = |x: u32, y: u32| x >= cx && x < cx + cw && y >= cy && y < cy + ch;
    let ranges: Vec<_> = (y0..y1)
        .flat_map(|y| (x0..x1).map(move |x| (x, y)))
        .map(|(x, y)| match output {
            Some(_) if inside(x, y) => 0..0,
            _ => 0..pilot,
        })
        .collect();
    let film = Film::new(tracer.settings.filter, (bx, by, bw, bh), window);
    let rects = film.tiles(tracer.settings.tile_size);
    let mut tiles: Vec<TileFilm> = rects.iter().map(|&r| film.tile(r)).collect();
    tracer.pass(
        &rects,
        &mut tiles,
        &Ranges::PerPixel {
            window,
            ranges: &ranges,
        },
        start,
        progress,
    );
    let mut values = vec![PixelValue::default(); (window.2 * window.3) as usize];
    gather(&rects, &tiles, window, &mut values);
    if let Some((rects, tiles)) = output {
        gather(rects, tiles, window, &mut values);
    }
    (window, values)
}

/// Each crop pixel's sample count (row by row over `crop`), from the pilot `values` over
/// `window`: see the module's comment. `threshold` is T, `pilot..cap` the allowed counts.
pub(super) fn targets(
    window: (u32, u32, u32, u32),
    values: &[PixelValue],
    crop: (u32, u32, u32, u32),
    threshold: f32,
    pilot: u32,
    cap: u32,
) -> Vec<u32> {
    let (wx, wy, ww, wh) = window;
    let (cx, cy, cw, ch) = crop;
    let mut out = Vec::with_capacity((cw * ch) as usize);
    for y in cy..cy + ch {
        for x in cx..cx + cw {
            let at = |qx: u32, qy: u32| &values[((qy - wy) * ww + (qx - wx)) as usize];
            let side = 2 * RADIUS as usize + 1;
            let mut ring: Vec<&PixelValue> = Vec::with_capacity(side * side - 1);
            for qy in y.saturating_sub(RADIUS)..=y + RADIUS {
                for qx in x.saturating_sub(RADIUS)..=x + RADIUS {
                    let outside = qx < wx || qy < wy || qx >= wx + ww || qy >= wy + wh;
                    if (qx, qy) != (x, y) && !outside {
                        ring.push(at(qx, qy));
                    }
                }
            }
            if ring.is_empty() {
                // A film of one pixel: no neighbour to judge it by.
                ring.push(at(x, y));
            }
            let (mut mean, mut var) = (0.0f64, 0.0f64);
            for q in &ring {
                mean += (q.mean.x + q.mean.y + q.mean.z) as f64 / 3.0;
                let sd = q.variance.max(glam::Vec3A::ZERO).to_array().map(f32::sqrt);
                // Per-sample deviation: the mean's times the root of the samples.
                let sd = (sd[0] + sd[1] + sd[2]) as f64 / 3.0 * (q.count as f64).sqrt();
                var += sd * sd;
            }
            let n = ring.len();
            let (mean, sd) = (mean / n as f64, (var / n as f64).sqrt());
            let floor = (mean * mean + (DARK * DARK) as f64).sqrt();
            let needed = SAFETY as f64 * (sd / (floor * threshold as f64)).powi(2);
            out.push(needed.ceil().clamp(pilot as f64, cap as f64) as u32);
        }
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;
    use glam::Vec3A;

    fn pixel(mean: f32, sd_of_mean: f32, count: u32) -> PixelValue {
        PixelValue {
            mean: Vec3A::splat(mean),
            variance: Vec3A::splat(sd_of_mean * sd_of_mean),
            count,
            weight: count as f32,
            clamped: false,
        }
    }

    /// A pixel's count comes from its neighbours' pilot, not its own: a noisy pixel among quiet
    /// ones stops at the pilot, the quiet pixels around a noisy one go on; the prediction is
    /// SAFETY (s / (m T))² with s the per-sample deviation.
    #[test]
    fn counts_follow_the_neighbours() {
        // 3x3 window, pilot 16: per-sample sd 0.4 (of the mean 0.1), mean 1 (1.005 with the
        // dark floor), T 0.05: 2 (0.4 / (1.005 x 0.05))² = 126.7.
        let mut values = vec![pixel(1.0, 0.1, 16); 9];
        values[4] = pixel(1.0, 5.0, 16);
        let t = targets((0, 0, 3, 3), &values, (0, 0, 3, 3), 0.05, 16, 1024);
        assert!(
            (127..=128).contains(&t[4]),
            "the noisy centre is judged by its quiet neighbours: {t:?}"
        );
        assert!(t[0] > 128 && t[1] == 1024, "{t:?}");
        // Black and noiseless: the pilot is enough; black with noise: judged against the dark
        // floor, 2 (0.8 / (0.1 x 0.05))², over the cap.
        let t = targets(
            (0, 0, 3, 3),
            &[pixel(0.0, 0.0, 16); 9],
            (1, 1, 1, 1),
            0.05,
            16,
            1024,
        );
        assert_eq!(t, [16]);
        let t = targets(
            (0, 0, 3, 3),
            &[pixel(0.0, 0.2, 16); 9],
            (1, 1, 1, 1),
            0.05,
            16,
            1024,
        );
        assert_eq!(t, [1024]);
    }

    #[test]
    fn pilot_sizes() {
        assert_eq!(pilot_size(16), 8);
        assert_eq!(pilot_size(4), 4);
        assert_eq!(pilot_size(256), 16);
        assert_eq!(pilot_size(1024), 64);
        assert_eq!(pilot_size(100_000), 64);
        let e = relative_error(glam::Vec3::splat(2.0), glam::Vec3::splat(0.01));
        assert!((e - 0.1 / 4.01f32.sqrt()).abs() < 1e-7, "{e}");
        assert_eq!(relative_error(glam::Vec3::ZERO, glam::Vec3::ZERO), 0.0);
        // A dark pixel's error is judged against the floor, not its mean.
        let e = relative_error(glam::Vec3::splat(0.001), glam::Vec3::splat(1e-4));
        assert!((e - 0.01 / (1e-6f32 + 0.01).sqrt()).abs() < 1e-6, "{e}");
    }
}
