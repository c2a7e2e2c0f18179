//! A render in passes: with a time limit (`RenderSettings::time_limit`), adaptive sampling
//! (`RenderSettings::noise_threshold`), or both. Without either, a render is one pass.
//!
//! Every pass takes the pixels from `level` samples to a higher `next` (each pixel capped at its
//! own count), adding samples in global index order, so a pixel's accumulated mean is that of a
//! one-pass render of the same samples, bit for bit. The image is complete after every pass.
//!
//! - Adaptive sampling: a uniform pilot pass to the pilot size, then each pixel's count is
//!   decided once from its neighbours' pilot ([`super::adaptive`]), then one pass renders every
//!   pixel to its count. The counts depend only on the pilot samples, which are those of any
//!   window or sample range of the same render: a `--crop` renders the pilot of a two-pixel ring
//!   around it too and gives the one-piece render's pixels bit for bit; a `--sample-range` part
//!   renders the whole pilot for its decisions (counting in its image only the samples of its
//!   range) and holds exactly the one-piece render's samples of that range.
//! - A time limit: passes grow geometrically (1 sample, then 16 ([`MIN_PASS_LEVEL`]), then
//!   doubling the samples rendered), each shrunk to what the time left allows at the last pass's
//!   speed; the render stops at a pass boundary when the next pass would not fit (or every pixel
//!   has its samples). The first pass always runs. With adaptive sampling, the passes after the
//!   pilot raise each pixel to min(its count, the level), so the time left goes to the pixels
//!   that need the most samples: the noisiest.

use super::adaptive;
use super::{Ranges, RenderSlice, Tracer};
use crate::film::{Film, PixelValue, TileFilm};
use crate::sampler::SamplerKind;
use std::ops::Range;
use std::time::{Duration, Instant};

/// The samples per pixel a time limit's second pass aims for (then doubling; it still shrinks
/// to what the time allows). A pass costs more per sample the fewer samples it takes: a pixel's
/// Sobol columns are computed in vectors of 8 or 16 samples, its camera rays traced in packets
/// of 8 or 16. Passes 1, 2, 4, ..., 64 cost 6.0% more render instructions than one 64-sample
/// pass; 1, 16, 32, 64 cost 2.3% more (matpreview-copper, callgrind).
const MIN_PASS_LEVEL: u32 = 16;

/// What a render in passes reports after each pass.
#[derive(Clone, Debug)]
pub struct PassReport {
    /// Passes finished.
    pub pass: u32,
    /// Samples rendered in the window so far, and its pixels.
    pub samples: u64,
    pub pixels: u64,
    /// The median of the pixels' relative standard errors ([`adaptive::relative_error`]).
    pub median_error: f32,
    /// With a noise threshold: the share of pixels whose relative error is under it.
    pub under_threshold: Option<f32>,
    pub elapsed: Duration,
    /// With a time limit: the time left.
    pub time_left: Option<Duration>,
}

/// How a render in passes went.
pub(super) struct Summary {
    pub passes: u32,
}

/// Renders `slice` into `tiles` (over `rects`) in one pass, or in passes (see the module).
#[allow(clippy::too_many_arguments)]
pub(super) fn run(
    tracer: &Tracer,
    film: &Film,
    rects: &[(u32, u32, u32, u32)],
    tiles: &mut [TileFilm],
    slice: &RenderSlice,
    start: Instant,
    progress: &(dyn Fn(u64, u64) + Sync),
    report: &(dyn Fn(&PassReport) + Sync),
) -> Result<Summary, String> {
    let settings = tracer.settings;
    let Range {
        start: first,
        end: last,
    } = slice.samples.clone();
    if settings.noise_threshold.is_none() && settings.time_limit.is_none() {
        tracer.pass(rects, tiles, &Ranges::All(first..last), start, progress);
        return Ok(Summary { passes: 1 });
    }
    if settings.noise_threshold.is_some() && film.splats() {
        return Err(format!(
            "--noise-threshold needs a pixel filter without negative lobes (box, tent, gaussian), not {:?}: a splatting filter mixes the neighbours' samples into a pixel",
            settings.filter
        ));
    }
    let crop = slice.crop;
    let pixels = crop.2 as usize * crop.3 as usize;
    let deadline = settings.time_limit.map(|l| start + l);
    // Sobol points are stratified over power-of-two prefixes: a pixel stopped at 66 samples has
    // a larger error than at 64 (veach-direct: relMSE 0.00173 against 0.00139). With Sobol the
    // counts adaptive sampling decides are powers of two (a time limit's last pass still ends
    // where the time does: stopping at the previous power of two wasted more than it saved).
    let whole_prefixes = settings.sampler == SamplerKind::Sobol;
    // Each pixel's count (its last sample index + 1), known once the pilot has decided it.
    let mut caps = vec![last; pixels];
    let mut pilot = settings
        .noise_threshold
        .map(|_| adaptive::pilot_size(settings.spp));
    if let (Some(n0), Some(t)) = (pilot, settings.noise_threshold) {
        if first > 0 || last < n0 {
            // The image does not hold the pilot: render it apart, for the decisions only.
            let (window, values) = adaptive::pilot(tracer, crop, n0, None, start, progress);
            decide(
                &mut caps,
                window,
                &values,
                crop,
                t,
                n0,
                settings.spp,
                first..last,
                whole_prefixes,
            );
            pilot = None;
        }
    }
    let (mut level, mut passes, mut rendered) = (first, 0u32, 0u64);
    // The last pass's time and samples: its speed prices the next pass. (The mean since the
    // start would count the fixed costs of the first passes, a sample or two over every pixel,
    // and shrink the last pass: matpreview-copper rendered 47-54 samples per pixel in the time
    // of 64.)
    let mut last_pass = (Duration::ZERO, 0u64);
    loop {
        let top = caps.iter().copied().max().unwrap_or(first);
        if level >= top {
            break;
        }
        // The next level: the pilot's end first; without a time limit every pixel's count,
        // with one the samples rendered so far doubled, then shrunk to fit the time left.
        let mut next = match (pilot, deadline) {
            (Some(n0), _) if level < n0 => n0,
            (_, None) => top,
            (_, Some(_)) if passes == 0 => level + 1,
            (_, Some(_)) => first + (2 * (level - first)).max(MIN_PASS_LEVEL),
        };
        if let (Some(n0), Some(_)) = (pilot, deadline) {
            if level < n0 {
                next = next.min(if passes == 0 { level + 1 } else { n0 });
            }
        }
        next = next.min(top);
        // With Sobol samples, the pixels the last pass takes to `next` when the time left
        // cannot take them all (see `last_pass_pixels`).
        let mut subset: Option<Vec<bool>> = None;
        if let (Some(deadline), true) = (deadline, passes > 0) {
            let per_sample = last_pass.0.as_secs_f64() / last_pass.1.max(1) as f64;
            let left = deadline
                .saturating_duration_since(Instant::now())
                .as_secs_f64();
            let cost = |to: u32| added(&caps, level, to) as f64 * per_sample;
            if whole_prefixes && cost(next) > left {
                let budget = (left / per_sample) as u64;
                let (to, chosen) = whole_prefix_pass(&caps, first, level, next, budget);
                if chosen.as_ref().is_some_and(|c| !c.contains(&true)) {
                    break;
                }
                (next, subset) = (to, chosen);
            } else if cost(level + 1) > left {
                break;
            } else if cost(next) > left {
                // The highest level that fits (the cost grows with the level).
                let (mut lo, mut hi) = (level + 1, next);
                while lo < hi {
                    let mid = lo + (hi - lo).div_ceil(2);
                    if cost(mid) <= left {
                        lo = mid;
                    } else {
                        hi = mid - 1;
                    }
                }
                next = lo;
            }
        }
        let ranges: Vec<Range<u32>> = caps
            .iter()
            .enumerate()
            .map(|(i, &c)| match &subset {
                Some(chosen) if !chosen[i] => level.min(c)..level.min(c),
                _ => level.min(c)..next.min(c),
            })
            .collect();
        let pass_start = Instant::now();
        tracer.pass(
            rects,
            tiles,
            &Ranges::PerPixel {
                window: crop,
                ranges: &ranges,
            },
            start,
            progress,
        );
        last_pass = (
            pass_start.elapsed(),
            ranges.iter().map(|r| r.len() as u64).sum(),
        );
        rendered += last_pass.1;
        level = next;
        passes += 1;
        let mut values = vec![PixelValue::default(); pixels];
        adaptive::gather(rects, tiles, crop, &mut values);
        if let (Some(n0), Some(t), None) = (pilot, settings.noise_threshold, &subset) {
            if level == n0 {
                let (window, all) =
                    adaptive::pilot(tracer, crop, n0, Some((rects, tiles)), start, progress);
                decide(
                    &mut caps,
                    window,
                    &all,
                    crop,
                    t,
                    n0,
                    settings.spp,
                    first..last,
                    whole_prefixes,
                );
                pilot = None;
            }
        }
        report(&pass_report(
            &values,
            passes,
            rendered,
            settings.noise_threshold,
            start,
            deadline,
        ));
        if subset.is_some() {
            // The pixels left out stay at the level before: the time is up.
            break;
        }
    }
    Ok(Summary { passes })
}

/// With Sobol samples, the pass a time limit allows from `level` toward `next` when the `budget`
/// samples left cannot take every pixel there: every pixel through whole doublings (power-of-two
/// counts, from the render's `first` sample) while they fit, to the level returned; or, when not
/// even one fits, the next doubling for the pixels [`last_pass_pixels`] picks (returned too).
/// (Never a jump past one doubling for a few pixels: a pilot's 1 to 64 would leave the others at
/// one sample.)
pub(super) fn whole_prefix_pass(
    caps: &[u32],
    first: u32,
    level: u32,
    next: u32,
    budget: u64,
) -> (u32, Option<Vec<bool>>) {
    let double = |l: u32| (first + 2 * (l - first).max(1)).min(next);
    let mut to = double(level);
    if added(caps, level, to) > budget {
        return (to, Some(last_pass_pixels(caps, level, to, budget)));
    }
    while to < next && added(caps, level, double(to)) <= budget {
        to = double(to);
    }
    (to, None)
}

/// The pixels a time limit's last pass takes from `level` to `next` when the `budget` samples
/// left cannot take them all, with Sobol samples. A Sobol prefix is stratified only whole (a
/// power of two): rather than every pixel to a count between two levels (veach-direct: relMSE
/// 0.00226 at 58 spp, 0.00138 at 64), as many pixels as the budget allows go the whole way and
/// the others stay. The choice looks at no pixel's samples (which would bias its mean): pixels of
/// higher counts first (adaptive sampling decided them from the neighbours' pilots: the
/// noisiest), and among equal counts those a golden-ratio sequence over the pixel index picks,
/// which spreads them evenly over the image.
pub(super) fn last_pass_pixels(caps: &[u32], level: u32, next: u32, budget: u64) -> Vec<bool> {
    let mut chosen = vec![false; caps.len()];
    // The distinct counts still to reach (a few powers of two), highest first.
    let counts: std::collections::BTreeSet<u32> =
        caps.iter().copied().filter(|&c| c > level).collect();
    let mut left = budget;
    for count in counts.into_iter().rev() {
        let add = (next.min(count) - level) as u64;
        let group = caps.iter().filter(|&&c| c == count).count() as u64;
        // The share of the group the budget takes, as a threshold on the golden-ratio sequence
        // i·φ mod 1 (in 32-bit fixed point): the pixels under it are that share, spread evenly.
        let share = (left as f64 / (add * group) as f64).min(1.0);
        let threshold = (share * 4_294_967_296.0) as u64;
        for (i, _) in caps.iter().enumerate().filter(|&(_, &c)| c == count) {
            if ((i as u32).wrapping_mul(0x9E37_79B9) as u64) < threshold && add <= left {
                chosen[i] = true;
                left = left.saturating_sub(add);
            }
        }
        if share < 1.0 {
            break;
        }
    }
    chosen
}

/// Samples a pass from `level` to `to` adds, every pixel capped at its count.
fn added(caps: &[u32], level: u32, to: u32) -> u64 {
    caps.iter()
        .map(|&c| (to.min(c) - level.min(c)) as u64)
        .sum()
}

/// Sets each crop pixel's last sample (+ 1) within the slice's `samples` from its count, decided
/// from the pilot `values` over `window` (the pilot's `n0` samples of a render of `spp`).
#[allow(clippy::too_many_arguments)]
fn decide(
    caps: &mut [u32],
    window: (u32, u32, u32, u32),
    values: &[PixelValue],
    crop: (u32, u32, u32, u32),
    threshold: f32,
    n0: u32,
    spp: u32,
    samples: Range<u32>,
    whole_prefixes: bool,
) {
    let cap = spp.max(n0);
    let targets = adaptive::targets(window, values, crop, threshold, n0, cap);
    for (c, target) in caps.iter_mut().zip(targets) {
        let target = match whole_prefixes {
            true => target.checked_next_power_of_two().unwrap_or(cap).min(cap),
            false => target,
        };
        *c = target.clamp(samples.start, samples.end);
    }
}

fn pass_report(
    values: &[PixelValue],
    pass: u32,
    samples: u64,
    threshold: Option<f32>,
    start: Instant,
    deadline: Option<Instant>,
) -> PassReport {
    let mut errors: Vec<f32> = values
        .iter()
        .map(|p| adaptive::relative_error(p.mean.into(), p.variance.into()))
        .collect();
    errors.sort_by(f32::total_cmp);
    let median_error = errors.get(errors.len() / 2).copied().unwrap_or(0.0);
    PassReport {
        pass,
        samples,
        pixels: values.len() as u64,
        median_error,
        under_threshold: threshold
            .map(|t| errors.iter().filter(|&&e| e < t).count() as f32 / errors.len().max(1) as f32),
        elapsed: start.elapsed(),
        time_left: deadline.map(|d| d.saturating_duration_since(Instant::now())),
    }
}
