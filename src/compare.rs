//! `torrey compare A.exr B.exr`: image-difference metrics, heatmaps and side-by-side pictures.
//!
//! Used to check torrey renders against reference renders (Mitsuba 3, Blender Cycles):
//!
//! ```sh
//! torrey compare out/cbox.exr tests/references/blender/cbox.exr
//! torrey compare a.exr b.exr --json --heatmap diff.png --side-by-side sbs.png
//! torrey compare a.exr ref.exr --variance a_variance.exr   # share of pixels outside 3 sigma
//! ```
//!
//! `B` is the reference: the relative error divides by B and the brightness ratio is A / B.

use clap::Args;
use glam::Vec3;
use std::fmt::Write as _;
use std::path::{Path, PathBuf};
use torrey_texture::{srgb_to_linear, Image};

/// Added to B^2 in the relative error so black reference pixels do not divide by zero.
const REL_EPSILON: f64 = 0.01;

/// The heatmap's colour ramp covers per-pixel relative error from 10^HEAT_LOG_MIN to 10^HEAT_LOG_MAX.
const HEAT_LOG_MIN: f64 = -3.0;
const HEAT_LOG_MAX: f64 = 0.0;

/// Arguments of `torrey compare`.
#[derive(Args, Debug)]
pub struct CompareArgs {
    /// The image under test (EXR, HDR or any 8-bit format torrey reads).
    pub a: PathBuf,
    /// The reference image; must have the same size as A.
    pub b: PathBuf,
    /// Print the metrics as one JSON object instead of a table.
    #[arg(long)]
    pub json: bool,
    /// Per-pixel variance of A - B (A's estimate variance, plus B's if B is noisy; same size):
    /// enables the share of pixels outside 3 sigma.
    #[arg(long)]
    pub variance: Option<PathBuf>,
    /// Write a false-colour PNG of the per-pixel relative error (log scale, 0.1% .. 100%).
    #[arg(long)]
    pub heatmap: Option<PathBuf>,
    /// Write a PNG with A | B | heatmap side by side (A and B clamped and sRGB-encoded).
    #[arg(long)]
    pub side_by_side: Option<PathBuf>,
    /// Change a safety cap, NAME=VALUE; here only image_pixels applies (docs/robustness.md).
    #[arg(long = "limit", value_parser = crate::limits::parse_limit)]
    pub limits: Vec<(String, u64)>,
}

/// Difference metrics between an image A and a reference B, over the pixels where both (and
/// the variance image, if any) are finite; the others are counted and fail the comparison.
#[derive(Clone, Debug, PartialEq)]
pub struct Metrics {
    /// Pixels with a NaN or infinite channel in A, B and the variance image.
    pub nonfinite: [usize; 3],
    /// Root mean squared difference over all pixels and channels.
    pub rmse: f64,
    /// Mean over all pixels and channels of (a - b)^2 / (b^2 + 0.01).
    pub rel_mse: f64,
    /// mean(A) / mean(B) per channel (1 when both means are 0, infinite when only B's is).
    pub mean_ratio: [f64; 3],
    /// Share (0..1) of pixels where |a - b| > 3 sqrt(var) in any channel; only with a variance image.
    pub outside_3_sigma: Option<f64>,
    pub width: u32,
    pub height: u32,
}

/// Computes [`Metrics`] for A against the reference B. `variance` is the per-pixel variance of
/// A's estimate (of the pixel mean, not of single samples). All images must have the same size.
pub fn compare_images(a: &Image, b: &Image, variance: Option<&Image>) -> Result<Metrics, String> {
    if (a.width, a.height) != (b.width, b.height) {
        return Err(format!(
            "image sizes differ: A is {}x{}, B is {}x{}",
            a.width, a.height, b.width, b.height
        ));
    }
    if let Some(v) = variance {
        if (v.width, v.height) != (a.width, a.height) {
            return Err(format!(
                "variance image is {}x{} but the images are {}x{}",
                v.width, v.height, a.width, a.height
            ));
        }
    }
    let n = a.pixels.len();
    if n == 0 {
        return Err("images are empty (0 pixels)".to_string());
    }
    let bad = |i: &Image| i.pixels.iter().filter(|p| !p.is_finite()).count();
    let nonfinite = [bad(a), bad(b), variance.map_or(0, bad)];
    let usable = |i: usize| {
        a.pixels[i].is_finite()
            && b.pixels[i].is_finite()
            && variance.is_none_or(|v| v.pixels[i].is_finite())
    };
    let n_usable = (0..n).filter(|&i| usable(i)).count();
    let mut sq = 0.0f64;
    let mut rel = 0.0f64;
    let mut sum_a = [0.0f64; 3];
    let mut sum_b = [0.0f64; 3];
    for (i, (pa, pb)) in a.pixels.iter().zip(&b.pixels).enumerate() {
        if !usable(i) {
            continue;
        }
        for c in 0..3 {
            let (x, y) = (pa[c] as f64, pb[c] as f64);
            let d2 = (x - y) * (x - y);
            sq += d2;
            rel += d2 / (y * y + REL_EPSILON);
            sum_a[c] += x;
            sum_b[c] += y;
        }
    }
    let count = (3 * n_usable).max(1) as f64;
    let mut mean_ratio = [0.0; 3];
    for c in 0..3 {
        mean_ratio[c] = if sum_a[c] == sum_b[c] {
            1.0
        } else {
            sum_a[c] / sum_b[c]
        };
    }
    let outside_3_sigma = variance.map(|v| {
        let outside = a
            .pixels
            .iter()
            .zip(&b.pixels)
            .zip(&v.pixels)
            .enumerate()
            .filter(|&(i, _)| usable(i))
            .map(|(_, x)| x)
            .filter(|((pa, pb), pv)| {
                (0..3).any(|c| {
                    let d = (pa[c] as f64 - pb[c] as f64).abs();
                    d > 3.0 * (pv[c].max(0.0) as f64).sqrt()
                })
            })
            .count();
        outside as f64 / n_usable.max(1) as f64
    });
    Ok(Metrics {
        nonfinite,
        rmse: (sq / count).sqrt(),
        rel_mse: rel / count,
        mean_ratio,
        outside_3_sigma,
        width: a.width,
        height: a.height,
    })
}

/// Per-pixel relative error sqrt(mean_c (a - b)^2 / (b^2 + 0.01)): the heatmap's quantity.
pub fn relative_error_image(a: &Image, b: &Image) -> Vec<f64> {
    a.pixels
        .iter()
        .zip(&b.pixels)
        .map(|(pa, pb)| {
            let mut s = 0.0;
            for c in 0..3 {
                let (x, y) = (pa[c] as f64, pb[c] as f64);
                s += (x - y) * (x - y) / (y * y + REL_EPSILON);
            }
            (s / 3.0).sqrt()
        })
        .collect()
}

/// A viridis-like ramp: t in [0, 1] → display (sRGB-encoded) colour, dark purple to yellow.
/// Non-finite t (NaN pixels) maps to magenta so it stands out.
pub fn ramp(t: f64) -> [f64; 3] {
    const STOPS: [[f64; 3]; 5] = [
        [0.267, 0.005, 0.329],
        [0.229, 0.322, 0.546],
        [0.128, 0.567, 0.551],
        [0.369, 0.789, 0.383],
        [0.993, 0.906, 0.144],
    ];
    if !t.is_finite() {
        return [1.0, 0.0, 1.0];
    }
    let x = t.clamp(0.0, 1.0) * (STOPS.len() - 1) as f64;
    let i = (x.floor() as usize).min(STOPS.len() - 2);
    let f = x - i as f64;
    let mut out = [0.0; 3];
    for c in 0..3 {
        out[c] = STOPS[i][c] * (1.0 - f) + STOPS[i + 1][c] * f;
    }
    out
}

/// False-colour image of the per-pixel relative error, log scale from 0.1% (dark) to 100% (yellow).
/// Pixels are linear so that an sRGB PNG writer reproduces the ramp's display colours.
pub fn heatmap(a: &Image, b: &Image) -> Image {
    let pixels = relative_error_image(a, b)
        .into_iter()
        .map(|e| {
            let t = if e.is_nan() {
                f64::NAN
            } else if e <= 0.0 {
                0.0
            } else {
                (e.log10() - HEAT_LOG_MIN) / (HEAT_LOG_MAX - HEAT_LOG_MIN)
            };
            let c = ramp(t);
            Vec3::new(
                srgb_to_linear(c[0] as f32),
                srgb_to_linear(c[1] as f32),
                srgb_to_linear(c[2] as f32),
            )
        })
        .collect();
    Image::new(a.width, a.height, pixels)
}

/// Places images of equal height left to right with a 2-pixel black gap.
pub fn side_by_side(images: &[&Image]) -> Image {
    const GAP: u32 = 2;
    let height = images.iter().map(|i| i.height).max().unwrap_or(0);
    let width =
        images.iter().map(|i| i.width).sum::<u32>() + GAP * (images.len().saturating_sub(1)) as u32;
    let mut out = Image::filled(width, height, Vec3::ZERO);
    let mut x0 = 0u32;
    for img in images {
        for y in 0..img.height {
            for x in 0..img.width {
                let p = img.get(x, y);
                // Keep NaN / inf out of the PNG writer.
                let p = Vec3::select(p.is_finite_mask(), p, Vec3::new(1.0, 0.0, 1.0));
                out.pixels[(y * width + x0 + x) as usize] = p;
            }
        }
        x0 += img.width + GAP;
    }
    out
}

fn json_number(v: f64) -> String {
    if v.is_finite() {
        format!("{v:e}")
    } else {
        "null".to_string()
    }
}

fn json_string(s: &str) -> String {
    let mut out = String::with_capacity(s.len() + 2);
    out.push('"');
    for ch in s.chars() {
        match ch {
            '"' => out.push_str("\\\""),
            '\\' => out.push_str("\\\\"),
            '\n' => out.push_str("\\n"),
            '\r' => out.push_str("\\r"),
            '\t' => out.push_str("\\t"),
            c if (c as u32) < 0x20 => {
                let _ = write!(out, "\\u{:04x}", c as u32);
            }
            c => out.push(c),
        }
    }
    out.push('"');
    out
}

/// The metrics as one JSON object (non-finite numbers become `null`).
pub fn metrics_json(m: &Metrics, a: &Path, b: &Path) -> String {
    format!(
        "{{\"a\": {}, \"b\": {}, \"width\": {}, \"height\": {}, \"rmse\": {}, \"rel_mse\": {}, \
         \"mean_ratio\": [{}, {}, {}], \"outside_3_sigma\": {}, \"nonfinite_pixels\": [{}, {}, {}]}}",
        json_string(&a.display().to_string()),
        json_string(&b.display().to_string()),
        m.width,
        m.height,
        json_number(m.rmse),
        json_number(m.rel_mse),
        json_number(m.mean_ratio[0]),
        json_number(m.mean_ratio[1]),
        json_number(m.mean_ratio[2]),
        m.outside_3_sigma.map_or("null".to_string(), json_number),
        m.nonfinite[0],
        m.nonfinite[1],
        m.nonfinite[2],
    )
}

/// The metrics as a human-readable table.
pub fn metrics_text(m: &Metrics, a: &Path, b: &Path) -> String {
    let mut s = String::new();
    let _ = writeln!(s, "A: {} ({}x{})", a.display(), m.width, m.height);
    let _ = writeln!(s, "B: {} (reference)", b.display());
    let _ = writeln!(s, "RMSE             {:.6e}", m.rmse);
    let _ = writeln!(s, "relative MSE     {:.6e}", m.rel_mse);
    let ratio = |r: f64| {
        if r.is_finite() {
            format!("{r:.5}")
        } else {
            "undefined (B's mean is 0)".to_string()
        }
    };
    let _ = writeln!(
        s,
        "mean ratio A/B   {} {} {}",
        ratio(m.mean_ratio[0]),
        ratio(m.mean_ratio[1]),
        ratio(m.mean_ratio[2])
    );
    if m.nonfinite.iter().any(|&c| c > 0) {
        let _ = writeln!(
            s,
            "NaN/inf pixels   A {}, B {}, variance {} (left out of the numbers above)",
            m.nonfinite[0], m.nonfinite[1], m.nonfinite[2]
        );
    }
    if let Some(o) = m.outside_3_sigma {
        let _ = writeln!(
            s,
            "outside 3 sigma  {:.3}% of pixels (about 0.8% expected for Gaussian noise in 3 channels)",
            100.0 * o
        );
    }
    s
}

/// Loads with torrey's own loader (the same decoding the renderer uses), keeping NaN,
/// infinite and negative values as stored: a broken render must show, not be clamped away.
fn load(path: &Path) -> Result<Image, String> {
    let loaded = torrey_texture::load_image_as_stored(path).map_err(|e| e.to_string())?;
    for w in &loaded.warnings {
        eprintln!("warning: {}: {w}", path.display());
    }
    Ok(loaded.image)
}

/// Runs `torrey compare`: loads both images (and the variance image), writes the requested PNGs
/// (so that a failed write is reported before any number), then prints the report to stdout.
/// NaN or infinite pixels in any input fail the comparison after the report.
pub fn run(args: &CompareArgs) -> Result<(), String> {
    let limits = crate::limits::Limits::from_args(&args.limits)?;
    torrey_texture::set_image_pixel_limit(limits.image_pixels);
    let a = load(&args.a)?;
    let b = load(&args.b)?;
    let variance = match &args.variance {
        Some(p) => Some(load(p)?),
        None => None,
    };
    let m = compare_images(&a, &b, variance.as_ref())
        .map_err(|e| format!("{e} ({} vs {})", args.a.display(), args.b.display()))?;
    if args.heatmap.is_some() || args.side_by_side.is_some() {
        let heat = heatmap(&a, &b);
        let sbs = args
            .side_by_side
            .as_ref()
            .map(|_| side_by_side(&[&a, &b, &heat]));
        let mut outputs = Vec::new();
        if let Some(p) = &args.heatmap {
            outputs.push(crate::output::png(p, &heat));
        }
        if let (Some(p), Some(img)) = (&args.side_by_side, &sbs) {
            outputs.push(crate::output::png(p, img));
        }
        crate::output::write_all(&outputs)?;
    }
    if args.json {
        println!("{}", metrics_json(&m, &args.a, &args.b));
    } else {
        print!("{}", metrics_text(&m, &args.a, &args.b));
    }
    if m.nonfinite.iter().any(|&c| c > 0) {
        return Err(format!(
            "comparison failed: NaN or infinite pixels (A: {}, B: {}, variance: {})",
            m.nonfinite[0], m.nonfinite[1], m.nonfinite[2]
        ));
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    fn img(w: u32, h: u32, f: impl Fn(u32, u32) -> Vec3) -> Image {
        let mut px = Vec::new();
        for y in 0..h {
            for x in 0..w {
                px.push(f(x, y));
            }
        }
        Image::new(w, h, px)
    }

    fn close(a: f64, b: f64) -> bool {
        (a - b).abs() <= 1e-9 * (1.0 + a.abs().max(b.abs()))
    }

    #[test]
    fn identical_images_have_zero_error_and_unit_ratio() {
        let a = img(7, 5, |x, y| Vec3::new(x as f32 * 0.1, y as f32 * 0.3, 0.25));
        let m = compare_images(&a, &a.clone(), None).unwrap();
        assert_eq!(m.rmse, 0.0);
        assert_eq!(m.rel_mse, 0.0);
        assert_eq!(m.mean_ratio, [1.0, 1.0, 1.0]);
        assert_eq!(m.outside_3_sigma, None);
        assert_eq!((m.width, m.height), (7, 5));
    }

    #[test]
    fn constant_offset_gives_analytic_numbers() {
        // A = 0.75 everywhere, B = 0.5 (exact in f32): d = 0.25 in every channel.
        let a = Image::filled(4, 3, Vec3::splat(0.75));
        let b = Image::filled(4, 3, Vec3::splat(0.5));
        let m = compare_images(&a, &b, None).unwrap();
        assert!(close(m.rmse, 0.25), "{}", m.rmse);
        assert!(close(m.rel_mse, 0.0625 / (0.25 + 0.01)), "{}", m.rel_mse);
        for r in m.mean_ratio {
            assert!(close(r, 1.5), "{r}");
        }
    }

    #[test]
    fn per_channel_and_per_pixel_differences() {
        // B = (1, 0, 2) everywhere; A differs only in pixel 0: red +1, blue -2 (= 0).
        let b = Image::filled(2, 2, Vec3::new(1.0, 0.0, 2.0));
        let mut a = b.clone();
        a.pixels[0] = Vec3::new(2.0, 0.0, 0.0);
        let m = compare_images(&a, &b, None).unwrap();
        // 12 channel values; squared differences 1 and 4.
        assert!(close(m.rmse, (5.0f64 / 12.0).sqrt()));
        let rel = (1.0 / (1.0 + 0.01) + 4.0 / (4.0 + 0.01)) / 12.0;
        assert!(close(m.rel_mse, rel));
        assert!(close(m.mean_ratio[0], 5.0 / 4.0));
        assert_eq!(m.mean_ratio[1], 1.0); // both means 0
        assert!(close(m.mean_ratio[2], 6.0 / 8.0));
        // Heatmap quantity for pixel 0: sqrt(rel sum / 3); others 0.
        let e = relative_error_image(&a, &b);
        assert!(close(e[0], (rel * 12.0 / 3.0).sqrt()));
        assert_eq!(&e[1..], &[0.0, 0.0, 0.0]);
    }

    #[test]
    fn ratio_is_infinite_when_only_reference_is_black() {
        let a = Image::filled(1, 1, Vec3::splat(0.5));
        let b = Image::filled(1, 1, Vec3::ZERO);
        let m = compare_images(&a, &b, None).unwrap();
        assert!(m.mean_ratio[0].is_infinite());
        assert!(metrics_json(&m, Path::new("a"), Path::new("b")).contains("\"mean_ratio\": [null"));
    }

    #[test]
    fn outside_three_sigma_counts_pixels() {
        // Variance 0.01 → sigma 0.1, threshold 0.3. Four pixels: differences 0, 0.2, 0.35 (green), 1.
        let b = Image::filled(4, 1, Vec3::ZERO);
        let a = Image::new(
            4,
            1,
            vec![
                Vec3::ZERO,
                Vec3::splat(0.2),
                Vec3::new(0.0, 0.35, 0.0),
                Vec3::splat(1.0),
            ],
        );
        let v = Image::filled(4, 1, Vec3::splat(0.01));
        let m = compare_images(&a, &b, Some(&v)).unwrap();
        assert_eq!(m.outside_3_sigma, Some(0.5));
    }

    #[test]
    fn nan_and_inf_pixels_are_counted_and_left_out() {
        let b = Image::filled(4, 1, Vec3::splat(0.5));
        let mut a = b.clone();
        a.pixels[0] = Vec3::new(f32::NAN, 0.5, 0.5);
        a.pixels[1] = Vec3::new(0.5, f32::INFINITY, 0.5);
        a.pixels[2] = Vec3::splat(1.0);
        let m = compare_images(&a, &b, None).unwrap();
        assert_eq!(m.nonfinite, [2, 0, 0]);
        // Two usable pixels (6 channels), one off by 0.5 in every channel.
        assert!(close(m.rmse, (3.0 * 0.25f64 / 6.0).sqrt()), "{}", m.rmse);
        assert!(close(m.mean_ratio[0], 1.5 / 1.0));
        // A NaN image against a NaN image is not a perfect match.
        let nan = Image::filled(2, 2, Vec3::splat(f32::NAN));
        let m = compare_images(&nan, &nan, None).unwrap();
        assert_eq!(m.nonfinite, [4, 4, 0]);
        assert!(
            metrics_text(&m, Path::new("a"), Path::new("b")).contains("NaN/inf pixels   A 4, B 4")
        );
    }

    #[test]
    fn zero_reference_gives_finite_errors_and_an_undefined_ratio() {
        let a = Image::filled(2, 2, Vec3::splat(0.5));
        let b = Image::filled(2, 2, Vec3::ZERO);
        let m = compare_images(&a, &b, None).unwrap();
        assert!(close(m.rmse, 0.5));
        assert!(close(m.rel_mse, 0.25 / 0.01));
        let text = metrics_text(&m, Path::new("a"), Path::new("b"));
        assert!(
            text.contains("mean ratio A/B   undefined (B's mean is 0)"),
            "{text}"
        );
    }

    #[test]
    fn size_mismatch_names_both_sizes() {
        let a = Image::filled(64, 48, Vec3::ONE);
        let b = Image::filled(96, 96, Vec3::ONE);
        let e = compare_images(&a, &b, None).unwrap_err();
        assert!(e.contains("64x48") && e.contains("96x96"), "{e}");
        let v = Image::filled(3, 3, Vec3::ONE);
        let e = compare_images(&a, &a, Some(&v)).unwrap_err();
        assert!(e.contains("3x3") && e.contains("64x48"), "{e}");
    }

    #[test]
    fn json_is_well_formed() {
        let m = Metrics {
            nonfinite: [0, 1, 2],
            rmse: 0.5,
            rel_mse: 0.25,
            mean_ratio: [1.0, 2.0, 0.5],
            outside_3_sigma: Some(0.125),
            width: 3,
            height: 2,
        };
        let j = metrics_json(&m, Path::new("a \"q\".exr"), Path::new("b\\c.exr"));
        assert_eq!(
            j,
            "{\"a\": \"a \\\"q\\\".exr\", \"b\": \"b\\\\c.exr\", \"width\": 3, \"height\": 2, \
             \"rmse\": 5e-1, \"rel_mse\": 2.5e-1, \"mean_ratio\": [1e0, 2e0, 5e-1], \
             \"outside_3_sigma\": 1.25e-1, \"nonfinite_pixels\": [0, 1, 2]}"
        );
    }

    #[test]
    fn heatmap_ramp_is_monotone_in_error_and_marks_nan() {
        let b = Image::filled(4, 1, Vec3::splat(1.0));
        let a = Image::new(
            4,
            1,
            vec![
                Vec3::splat(1.0),
                Vec3::splat(1.01),
                Vec3::splat(1.5),
                Vec3::splat(f32::NAN),
            ],
        );
        let h = heatmap(&a, &b);
        let lum = |p: Vec3| p.x + p.y + p.z;
        assert!(lum(h.pixels[0]) < lum(h.pixels[1]));
        assert!(lum(h.pixels[1]) < lum(h.pixels[2]));
        assert_eq!(h.pixels[3], Vec3::new(1.0, 0.0, 1.0));
        let s = side_by_side(&[&a, &b, &h]);
        assert_eq!((s.width, s.height), (4 * 3 + 4, 1));
        assert!(s.pixels.iter().all(|p| p.is_finite()));
    }
}
