//! Colour transfer functions and primaries conversion.
//!
//! Textures are stored and filtered in linear Rec.709/sRGB-primaries RGB; these helpers get
//! 8-bit sRGB files and EXRs with other primaries into that space (and back out for PNG output).

use glam::{DMat3, DVec3, Mat3};

/// sRGB electro-optical transfer: an encoded value in [0, 1] to linear light. 8-bit textures are
/// stored encoded, but filtering and shading must happen on linear values.
#[inline]
pub fn srgb_to_linear(c: f32) -> f32 {
    if c <= 0.04045 {
        c / 12.92
    } else {
        ((c + 0.055) / 1.055).powf(2.4)
    }
}

/// Inverse of [`srgb_to_linear`]: linear light to the sRGB encoding used by 8-bit outputs.
#[inline]
pub fn linear_to_srgb(c: f32) -> f32 {
    if c <= 0.003_130_8 {
        c * 12.92
    } else {
        1.055 * c.powf(1.0 / 2.4) - 0.055
    }
}

/// [`srgb8_table`] computed once.
pub(crate) fn srgb8_lut() -> &'static [f32; 256] {
    static TABLE: std::sync::OnceLock<[f32; 256]> = std::sync::OnceLock::new();
    TABLE.get_or_init(srgb8_table)
}

/// Each 8-bit code's value as raw data (`code / 255`), computed once.
pub(crate) fn unorm8_lut() -> &'static [f32; 256] {
    static TABLE: std::sync::OnceLock<[f32; 256]> = std::sync::OnceLock::new();
    TABLE.get_or_init(|| std::array::from_fn(|v| v as f32 / 255.0))
}

/// Lookup table for 8-bit sRGB decoding, so loading a large JPEG costs no `powf` per channel.
pub(crate) fn srgb8_table() -> [f32; 256] {
    let mut t = [0.0; 256];
    for (i, v) in t.iter_mut().enumerate() {
        *v = srgb_to_linear(i as f32 / 255.0);
    }
    t
}

/// CIE xy chromaticities of an RGB colour space: the three primaries and the white point, in the
/// form OpenEXR's `chromaticities` header attribute stores them.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Chromaticities {
    /// xy of the red primary.
    pub red: [f64; 2],
    /// xy of the green primary.
    pub green: [f64; 2],
    /// xy of the blue primary.
    pub blue: [f64; 2],
    /// xy of the white point (RGB = 1,1,1).
    pub white: [f64; 2],
}

impl Chromaticities {
    /// Rec. ITU-R BT.709 primaries with a D65 white: the space every torrey texture is stored in
    /// (and what an EXR without the attribute is assumed to use).
    pub const REC709: Chromaticities = Chromaticities {
        red: [0.64, 0.33],
        green: [0.30, 0.60],
        blue: [0.15, 0.06],
        white: [0.3127, 0.3290],
    };

    /// Whether two spaces agree to within header rounding, so the no-op conversion is skipped.
    pub fn approx_eq(&self, other: &Chromaticities, tol: f64) -> bool {
        let pairs = [
            (self.red, other.red),
            (self.green, other.green),
            (self.blue, other.blue),
            (self.white, other.white),
        ];
        pairs
            .iter()
            .all(|(a, b)| (a[0] - b[0]).abs() <= tol && (a[1] - b[1]).abs() <= tol)
    }

    /// Matrix from linear RGB in this space to CIE XYZ (white maps to Y = 1), or `None` when the
    /// primaries are degenerate (collinear, or a zero y), which a corrupt header could contain.
    pub fn rgb_to_xyz(&self) -> Option<DMat3> {
        let xyz = |c: [f64; 2]| -> Option<DVec3> {
            if c[1].abs().partial_cmp(&1e-12) != Some(std::cmp::Ordering::Greater)
                || !c[0].is_finite()
                || !c[1].is_finite()
            {
                return None;
            }
            Some(DVec3::new(c[0] / c[1], 1.0, (1.0 - c[0] - c[1]) / c[1]))
        };
        let prim = DMat3::from_cols(xyz(self.red)?, xyz(self.green)?, xyz(self.blue)?);
        let det = prim.determinant();
        if !det.is_finite() || det.abs() <= 1e-12 {
            return None;
        }
        // Scale each primary so that RGB = (1,1,1) lands on the white point.
        let s = prim.inverse() * xyz(self.white)?;
        Some(DMat3::from_cols(
            prim.x_axis * s.x,
            prim.y_axis * s.y,
            prim.z_axis * s.z,
        ))
    }
}

/// Bradford cone-response matrix (XYZ to sharpened LMS), used for white-point adaptation.
fn bradford() -> DMat3 {
    // Rows of the usual Bradford matrix, given here as columns of the transpose.
    DMat3::from_cols(
        DVec3::new(0.8951, -0.7502, 0.0389),
        DVec3::new(0.2664, 1.7135, -0.0685),
        DVec3::new(-0.1614, 0.0367, 1.0296),
    )
}

/// XYZ of a white point with luminance 1.
fn white_xyz(w: [f64; 2]) -> DVec3 {
    DVec3::new(w[0] / w[1], 1.0, (1.0 - w[0] - w[1]) / w[1])
}

/// How a file whose white point differs from D65 is brought to Rec.709.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Default)]
pub enum WhiteAdaptation {
    /// No chromatic adaptation: RGB→XYZ with the file's primaries and white, then XYZ→Rec.709.
    /// This is what Mitsuba 3 does (`RGBtoXYZ(file) * XYZtoRGB(Rec.709)`), so a D50-white file
    /// comes out warmer than it was stored; it is the default so pixels match Mitsuba.
    #[default]
    None,
    /// Bradford cone-space adaptation of the file's white to D65 in between, so the file's white
    /// maps to RGB (1,1,1): the colour-science-correct reading.
    Bradford,
}

/// Matrix taking linear RGB in `src` to linear RGB with Rec.709 primaries and D65 white:
/// RGB→XYZ from the file's primaries, optional Bradford adaptation when its white differs from
/// D65, then XYZ→Rec.709. Returns `None` for degenerate chromaticities.
pub fn to_rec709_matrix(src: &Chromaticities, adaptation: WhiteAdaptation) -> Option<Mat3> {
    let to_xyz = src.rgb_to_xyz()?;
    let dst = Chromaticities::REC709;
    let from_xyz = dst.rgb_to_xyz()?.inverse();
    let mut adapt = DMat3::IDENTITY;
    let white_differs =
        (src.white[0] - dst.white[0]).abs() > 1e-5 || (src.white[1] - dst.white[1]).abs() > 1e-5;
    if adaptation == WhiteAdaptation::Bradford && white_differs {
        let b = bradford();
        let ls = b * white_xyz(src.white);
        let ld = b * white_xyz(dst.white);
        if ls.min_element().abs() < 1e-12 {
            return None;
        }
        adapt = b.inverse() * DMat3::from_diagonal(ld / ls) * b;
    }
    let m = from_xyz * adapt * to_xyz;
    m.is_finite().then(|| m.as_mat3())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn srgb_known_values_and_round_trip() {
        assert!((srgb_to_linear(128.0 / 255.0) - 0.215_860_5).abs() < 1e-6);
        assert_eq!(srgb_to_linear(0.0), 0.0);
        assert!((srgb_to_linear(1.0) - 1.0).abs() < 1e-6);
        for i in 0..=1000 {
            let x = i as f32 / 1000.0;
            assert!(
                (linear_to_srgb(srgb_to_linear(x)) - x).abs() < 2e-6,
                "x={x}"
            );
            assert!(
                (srgb_to_linear(linear_to_srgb(x)) - x).abs() < 2e-6,
                "x={x}"
            );
        }
        let t = srgb8_table();
        assert!((t[128] - 0.215_860_5).abs() < 1e-6);
    }

    #[test]
    fn rec709_matrix_matches_published_values() {
        let m = Chromaticities::REC709.rgb_to_xyz().unwrap();
        // sRGB → XYZ, first row 0.4124 0.3576 0.1805 (IEC 61966-2-1).
        assert!((m.x_axis.x - 0.4124).abs() < 1e-3);
        assert!((m.y_axis.x - 0.3576).abs() < 1e-3);
        assert!((m.z_axis.x - 0.1805).abs() < 1e-3);
        assert!((m.x_axis.y - 0.2126).abs() < 1e-3);
        let id = to_rec709_matrix(&Chromaticities::REC709, WhiteAdaptation::Bradford).unwrap();
        assert!(id.abs_diff_eq(Mat3::IDENTITY, 1e-6));
    }

    #[test]
    fn white_maps_to_white_after_adaptation() {
        // A D50-white space (ProPhoto-like primaries): its white must come out as RGB (1,1,1)
        // in Rec.709 after Bradford adaptation to D65.
        let src = Chromaticities {
            red: [0.7347, 0.2653],
            green: [0.1596, 0.8404],
            blue: [0.0366, 0.0001],
            white: [0.3457, 0.3585],
        };
        let m = to_rec709_matrix(&src, WhiteAdaptation::Bradford).unwrap();
        let w = m * glam::Vec3::ONE;
        assert!(w.abs_diff_eq(glam::Vec3::ONE, 1e-4), "{w}");
        // Without adaptation (Mitsuba 3) the D50 white becomes D50 in Rec.709: XYZ
        // (0.9642, 1, 0.8251) → RGB ≈ (1.176, 0.976, 0.722), warmer than white.
        let m0 = to_rec709_matrix(&src, WhiteAdaptation::None).unwrap();
        let w0 = m0 * glam::Vec3::ONE;
        assert!(
            w0.abs_diff_eq(glam::Vec3::new(1.176, 0.976, 0.722), 3e-3),
            "{w0}"
        );
        // Pure red of a wide gamut lies outside Rec.709: more red than 1, negative elsewhere.
        let r = m * glam::Vec3::X;
        assert!(r.x > 1.0 && r.y < 0.0, "{r}");
    }

    #[test]
    fn degenerate_chromaticities_are_rejected() {
        let bad = Chromaticities {
            red: [0.3, 0.3],
            green: [0.3, 0.3],
            blue: [0.3, 0.3],
            white: [0.3127, 0.329],
        };
        assert!(to_rec709_matrix(&bad, WhiteAdaptation::None).is_none());
        let zero_y = Chromaticities {
            white: [0.3, 0.0],
            ..Chromaticities::REC709
        };
        assert!(to_rec709_matrix(&zero_y, WhiteAdaptation::Bradford).is_none());
    }
}
