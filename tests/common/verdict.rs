//! Mitsuba 3's statistical verdict on a render (its src/render/tests/test_renders.py), used by the
//! acceptance tests of Mitsuba-syntax scenes (tests/mitsuba_verdict.rs).
//!
//! The reference is Mitsuba's render with the per-sample variance image of its `moment`
//! integrator (tests/mitsuba/make_verdict_references.py). Image, reference and variance are taken
//! from linear sRGB to XYZ with the same matrix. That is what Mitsuba's test does for the variance
//! too: its variance is computed in XYZ (second moment minus squared mean of X, Y, Z) and stored
//! through the inverse matrix, so the plain matrix recovers the XYZ variance exactly (squared
//! matrix entries would be the rule for the variance of a linear combination, which this is not).
//! The variance is floored at 1e-4; per pixel and channel z = |img - ref| sqrt(spp / var) and
//! p = 2 (1 - Phi(z)); with Sidak's alpha = 1 - 0.99^(1 / pixels), the render passes when
//! count(p > alpha) / 3 >= 0.9975 pixels.

use glam::Vec3;
use std::path::Path;

/// sRGB (linear, D65) to CIE XYZ, the matrix Mitsuba uses (`srgb_to_xyz`).
pub const SRGB_TO_XYZ: [[f64; 3]; 3] = [
    [0.412453, 0.357580, 0.180423],
    [0.212671, 0.715160, 0.072169],
    [0.019334, 0.119193, 0.950227],
];

/// Mitsuba's samples budget for a render test: spp = 2,000,000 / pixels (integer division).
pub const SAMPLE_BUDGET: u64 = 2_000_000;

/// A float RGB image read without any clamping (a variance image stored through a matrix with
/// negative entries has negative channels that must survive the round trip).
pub struct RawImage {
    pub width: usize,
    pub height: usize,
    /// Row-major, top row first.
    pub pixels: Vec<[f64; 3]>,
}

impl RawImage {
    pub fn from_vec3(width: usize, height: usize, pixels: &[Vec3]) -> Self {
        RawImage {
            width,
            height,
            pixels: pixels
                .iter()
                .map(|p| [p.x as f64, p.y as f64, p.z as f64])
                .collect(),
        }
    }

    /// Reads the R, G, B channels of an EXR's first layer as they are.
    pub fn load_exr(path: &Path) -> Self {
        let image = exr::prelude::read_first_rgba_layer_from_file(
            path,
            |res, _| {
                (
                    res.width(),
                    res.height(),
                    vec![[0f64; 3]; res.width() * res.height()],
                )
            },
            |(w, _, px), pos, (r, g, b, _a): (f32, f32, f32, f32)| {
                px[pos.y() * *w + pos.x()] = [r as f64, g as f64, b as f64];
            },
        )
        .unwrap_or_else(|e| panic!("{}: {e}", path.display()));
        let (width, height, pixels) = image.layer_data.channel_data.pixels;
        RawImage {
            width,
            height,
            pixels,
        }
    }

    /// Every pixel times `s` (for negative checks).
    pub fn scaled(&self, s: f64) -> Self {
        RawImage {
            width: self.width,
            height: self.height,
            pixels: self.pixels.iter().map(|p| p.map(|c| c * s)).collect(),
        }
    }
}

fn to_xyz(p: [f64; 3]) -> [f64; 3] {
    SRGB_TO_XYZ.map(|row| row[0] * p[0] + row[1] * p[1] + row[2] * p[2])
}

/// The complementary error function, |relative error| < 1.2e-7 everywhere (the Chebyshev fit of
/// Numerical Recipes' `erfcc`): p-values near alpha (~1e-6) are then accurate to 1e-7 relative.
pub fn erfc(x: f64) -> f64 {
    // Coefficients of the polynomial in t, highest power first (Horner's rule as a fold: the
    // nested form made rustfmt take seconds per file that includes this module).
    const C: [f64; 10] = [
        0.17087277,
        -0.82215223,
        1.48851587,
        -1.13520398,
        0.27886807,
        -0.18628806,
        0.09678418,
        0.37409196,
        1.00002368,
        -1.26551223,
    ];
    let z = x.abs();
    let t = 1.0 / (1.0 + 0.5 * z);
    let poly = C.iter().fold(0.0, |acc, c| acc * t + c) - z * z;
    let r = t * poly.exp();
    if x >= 0.0 {
        r
    } else {
        2.0 - r
    }
}

/// The outcome of [`verdict`].
#[derive(Debug, Clone)]
pub struct MitsubaVerdict {
    pub pass: bool,
    /// count(p > alpha) / 3 / pixels; passing needs >= 0.9975.
    pub passing_fraction: f64,
    pub min_p: f64,
    pub alpha: f64,
    /// Pixels with at least one failing channel (x, y), at most 20, for messages.
    pub failing: Vec<(usize, usize)>,
    /// Mean of the image over the mean of the reference, per XYZ channel (for messages).
    pub mean_ratio: [f64; 3],
    /// Beyond Mitsuba's test: the difference of the image means in standard errors of the
    /// render's mean (from the reference's per-sample variance, floored like the test's), per
    /// XYZ channel. The per-pixel test cannot see a bias of a fraction of a percent; this can.
    pub mean_z: [f64; 3],
}

impl std::fmt::Display for MitsubaVerdict {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(
            f,
            "{} ({:.4}% of pixel channels pass, need 99.75%; min p {:.3e}, alpha {:.3e}; mean XYZ ratio [{:.4} {:.4} {:.4}], z [{:.2} {:.2} {:.2}]; first failing pixels {:?})",
            if self.pass { "pass" } else { "FAIL" },
            self.passing_fraction * 100.0,
            self.min_p,
            self.alpha,
            self.mean_ratio[0],
            self.mean_ratio[1],
            self.mean_ratio[2],
            self.mean_z[0],
            self.mean_z[1],
            self.mean_z[2],
            self.failing
        )
    }
}

/// Mitsuba's z-test of `img` (rendered at `spp` samples per pixel) against `reference` with its
/// per-sample variance `ref_var`, all linear sRGB.
pub fn verdict(
    img: &RawImage,
    reference: &RawImage,
    ref_var: &RawImage,
    spp: u64,
) -> MitsubaVerdict {
    assert_eq!(
        (img.width, img.height),
        (reference.width, reference.height),
        "image and reference sizes differ"
    );
    assert_eq!(
        (ref_var.width, ref_var.height),
        (reference.width, reference.height),
        "reference and variance sizes differ"
    );
    let pixels = img.pixels.len();
    let alpha = 1.0 - 0.99f64.powf(1.0 / pixels as f64);
    let mut passing = 0usize;
    let mut min_p = f64::INFINITY;
    let mut failing = Vec::new();
    let mut sums = [[0f64; 3]; 2];
    let mut var_sum = [0f64; 3];
    for (i, ((a, r), v)) in img
        .pixels
        .iter()
        .zip(&reference.pixels)
        .zip(&ref_var.pixels)
        .enumerate()
    {
        let (a, r, v) = (to_xyz(*a), to_xyz(*r), to_xyz(*v));
        let mut pixel_fails = false;
        for c in 0..3 {
            sums[0][c] += a[c];
            sums[1][c] += r[c];
            var_sum[c] += v[c].max(1e-4);
            let z = (a[c] - r[c]).abs() * (spp as f64 / v[c].max(1e-4)).sqrt();
            // p = 2 (1 - Phi(z)) = erfc(z / sqrt 2); NaN fails.
            let p = erfc(z / std::f64::consts::SQRT_2);
            min_p = min_p.min(p);
            if p > alpha {
                passing += 1;
            } else {
                pixel_fails = true;
            }
        }
        if pixel_fails && failing.len() < 20 {
            failing.push((i % img.width, i / img.width));
        }
    }
    let passing_fraction = passing as f64 / 3.0 / pixels as f64;
    MitsubaVerdict {
        pass: passing as f64 / 3.0 >= 0.9975 * pixels as f64,
        passing_fraction,
        min_p,
        alpha,
        failing,
        mean_ratio: [0, 1, 2].map(|c| sums[0][c] / sums[1][c].max(1e-12)),
        mean_z: [0, 1, 2].map(|c| (sums[0][c] - sums[1][c]) / (var_sum[c] / spp as f64).sqrt()),
    }
}
