//! Spectra as Mitsuba 3's RGB variants read them (its `spectrum_list_to_srgb` and parser):
//!
//! - `<spectrum value="v"/>`, a constant: for a reflectance (any parameter outside an emitter)
//!   the grey v; for an emitter's radiance/intensity/irradiance the equal-energy spectrum v,
//!   whose XYZ is (v, v, v): linear sRGB v × (1.204794, 0.948291, 0.908916).
//! - `<spectrum value="400:0.1, 500:0.2, ..."/>` (increasing wavelengths in nm) and
//!   `<spectrum filename="x.spd"/>` (lines "wavelength value", `#` comments): the piecewise
//!   linear spectrum (zero outside its first and last wavelength) is integrated against the
//!   CIE 1931 matching functions with 1000 evenly spaced points over [360, 830] nm, times
//!   (830 - 360) / 1000 and 1 / the integral of y, then taken from XYZ to linear sRGB. For
//!   reflectances the integrand also has the D65 illuminant and the result is clamped to
//!   [0, 1]; for emitters it is not weighted, and negative channels become 0.
//! - blackbody (`<spectrum type="blackbody">` with `temperature` in kelvin, or Mitsuba 0.6's
//!   `<blackbody temperature=".." scale="..">`): Mitsuba 3's RGB variants refuse it ("not
//!   implemented for non-spectral modes"); torrey reduces Planck's law (W m^-2 sr^-1 nm^-1,
//!   times `scale`) to RGB like an emitter's wavelength list, which is what Mitsuba's spectral
//!   variants would show on an sRGB film.

use crate::cie_table::{CIE_MAX, CIE_MIN, CIE_TABLE, CIE_Y_NORMALIZATION};
use glam::Vec3;

/// Mitsuba's XYZ to linear sRGB matrix (`xyz_to_srgb`).
const XYZ_TO_SRGB: [[f64; 3]; 3] = [
    [3.240479, -1.537150, -0.498535],
    [-0.969256, 1.875991, 0.041556],
    [0.055648, -0.204043, 1.057311],
];

/// What a spectrum describes: Mitsuba converts reflectances and emission differently.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(crate) enum SpectrumUse {
    Reflectance,
    Illuminant,
}

fn xyz_to_srgb(xyz: [f64; 3]) -> [f64; 3] {
    XYZ_TO_SRGB.map(|r| r[0] * xyz[0] + r[1] * xyz[1] + r[2] * xyz[2])
}

/// The CIE table at `w` nm, linearly interpolated: (x, y, z, D65).
fn cie(w: f64) -> [f64; 4] {
    let t = (w - CIE_MIN).clamp(0.0, CIE_MAX - CIE_MIN);
    let i = (t.floor() as usize).min(CIE_TABLE.len() - 2);
    let f = t - i as f64;
    let (a, b) = (CIE_TABLE[i], CIE_TABLE[i + 1]);
    [0, 1, 2, 3].map(|k| a[k] + (b[k] - a[k]) * f)
}

/// A constant spectrum.
pub(crate) fn constant(v: f32, usage: SpectrumUse) -> Vec3 {
    match usage {
        SpectrumUse::Reflectance => Vec3::splat(v),
        SpectrumUse::Illuminant => {
            let c = xyz_to_srgb([v as f64; 3]);
            Vec3::new(c[0] as f32, c[1] as f32, c[2] as f32)
        }
    }
}

/// Reduces a function of wavelength (nm) that is zero outside `[lo, hi]` to linear sRGB.
fn integrate(lo: f64, hi: f64, f: impl Fn(f64) -> f64, usage: SpectrumUse) -> Vec3 {
    let steps = 1000;
    let mut xyz = [0f64; 3];
    for i in 0..steps {
        let w = CIE_MIN + (i as f64 / (steps - 1) as f64) * (CIE_MAX - CIE_MIN);
        if w < lo || w > hi {
            continue;
        }
        let c = cie(w);
        let weight = f(w)
            * match usage {
                SpectrumUse::Reflectance => c[3],
                SpectrumUse::Illuminant => 1.0,
            };
        for k in 0..3 {
            xyz[k] += c[k] * weight;
        }
    }
    let scale = (CIE_MAX - CIE_MIN) / steps as f64 * CIE_Y_NORMALIZATION;
    let rgb = xyz_to_srgb(xyz.map(|v| v * scale));
    let rgb = match usage {
        SpectrumUse::Reflectance => rgb.map(|v| v.clamp(0.0, 1.0)),
        SpectrumUse::Illuminant => rgb.map(|v| v.max(0.0)),
    };
    Vec3::new(rgb[0] as f32, rgb[1] as f32, rgb[2] as f32)
}

/// A tabulated spectrum (wavelengths in nm, increasing) to linear sRGB.
pub(crate) fn list_to_rgb(
    wavelengths: &[f64],
    values: &[f64],
    usage: SpectrumUse,
) -> Result<Vec3, String> {
    if wavelengths.len() != values.len() || wavelengths.len() < 2 {
        return Err("a spectrum needs at least two wavelength:value pairs".into());
    }
    if wavelengths.windows(2).any(|w| w[1] <= w[0]) {
        return Err("the wavelengths of a spectrum must increase".into());
    }
    if wavelengths.iter().chain(values).any(|v| !v.is_finite()) {
        return Err("a spectrum's wavelengths and values must be finite numbers".into());
    }
    let f = |w: f64| {
        let i = wavelengths
            .partition_point(|&x| x <= w)
            .clamp(1, wavelengths.len() - 1)
            - 1;
        let (w0, w1, v0, v1) = (wavelengths[i], wavelengths[i + 1], values[i], values[i + 1]);
        v0 + (v1 - v0) * (w - w0) / (w1 - w0)
    };
    Ok(integrate(
        wavelengths[0],
        wavelengths[wavelengths.len() - 1],
        f,
        usage,
    ))
}

/// Parses a `value`: one number (a constant) or `wavelength:value` pairs.
pub(crate) fn parse_value(s: &str, usage: SpectrumUse) -> Result<Vec3, String> {
    if !s.contains(':') {
        let v = crate::values::floats(s)?;
        return match v.len() {
            1 => Ok(constant(v[0], usage)),
            n => Err(format!(
                "expected one value or wavelength:value pairs in spectrum '{s}', found {n} numbers"
            )),
        };
    }
    let mut wl = Vec::new();
    let mut vals = Vec::new();
    for pair in s.split(',').map(str::trim).filter(|p| !p.is_empty()) {
        let (w, v) = pair.split_once(':').ok_or_else(|| {
            format!("expected wavelength:value, found '{pair}' in spectrum '{s}'")
        })?;
        wl.push(crate::values::float(w)? as f64);
        vals.push(crate::values::float(v)? as f64);
    }
    list_to_rgb(&wl, &vals, usage)
}

/// Reads an `.spd` file: one "wavelength value" pair per line, `#` starts a comment.
pub(crate) fn read_spd(text: &str) -> Result<(Vec<f64>, Vec<f64>), String> {
    let mut wl = Vec::new();
    let mut vals = Vec::new();
    for (i, line) in text.lines().enumerate() {
        let line = line.split('#').next().unwrap_or("").trim();
        if line.is_empty() {
            continue;
        }
        let nums = crate::values::floats(line).map_err(|e| format!("line {}: {e}", i + 1))?;
        if nums.len() != 2 {
            return Err(format!(
                "line {}: expected 'wavelength value', found {} numbers",
                i + 1,
                nums.len()
            ));
        }
        wl.push(nums[0] as f64);
        vals.push(nums[1] as f64);
    }
    Ok((wl, vals))
}

/// Planck's law at `temperature` K as an emitter's RGB (see the module notes), times `scale`.
pub(crate) fn blackbody(temperature: f32, scale: f32) -> Result<Vec3, String> {
    if !(temperature > 0.0 && temperature.is_finite()) {
        return Err(format!(
            "a blackbody temperature must be positive, found {temperature}"
        ));
    }
    const C: f64 = 299_792_458.0;
    const H: f64 = 6.626_070_15e-34;
    const K: f64 = 1.380_649e-23;
    let t = temperature as f64;
    let planck = |w_nm: f64| {
        let l = w_nm * 1e-9;
        // W m^-2 sr^-1 m^-1, then per nm.
        2.0 * H * C * C / l.powi(5) / ((H * C / (l * K * t)).exp() - 1.0) * 1e-9
    };
    Ok(integrate(CIE_MIN, CIE_MAX, planck, SpectrumUse::Illuminant) * scale)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn close(a: Vec3, b: [f32; 3], tol: f32) {
        let b = Vec3::from(b);
        assert!(
            (a - b).abs().max_element() <= tol * b.abs().max_element(),
            "{a} vs {b}"
        );
    }

    /// Numbers from Mitsuba 3.9.1 (scalar_rgb): the constant emitter radiance 1, and
    /// mi.spectrum_list_to_srgb for a four-point list as radiance and as reflectance.
    #[test]
    fn matches_mitsuba() {
        close(
            constant(1.0, SpectrumUse::Illuminant),
            [1.204_794, 0.948_291, 0.908_916],
            1e-5,
        );
        assert_eq!(constant(0.3, SpectrumUse::Reflectance), Vec3::splat(0.3));
        let s = "400:0.5, 500:1, 600:2, 700:0.2";
        close(
            parse_value(s, SpectrumUse::Illuminant).unwrap(),
            [2.138_85, 1.398_1, 0.592_663],
            1e-5,
        );
        // As a reflectance Mitsuba gets [1.83946, 1.45439, 0.672154] and clamps it to [0, 1].
        close(
            parse_value(s, SpectrumUse::Reflectance).unwrap(),
            [1.0, 1.0, 0.672_154],
            1e-5,
        );
        close(
            parse_value("400:1, 700:1", SpectrumUse::Illuminant).unwrap(),
            [1.199_69, 0.949_52, 0.903_443],
            1e-5,
        );
    }

    #[test]
    fn spd_files_and_errors() {
        let (w, v) = read_spd("# comment\n400 0.5\n500 1 # c\n\n600 2\n700 0.2\n").unwrap();
        close(
            list_to_rgb(&w, &v, SpectrumUse::Illuminant).unwrap(),
            [2.138_85, 1.398_1, 0.592_663],
            1e-5,
        );
        assert!(read_spd("400 1 2").is_err());
        assert!(parse_value("500:1, 400:1", SpectrumUse::Illuminant).is_err());
        assert!(parse_value("1 2", SpectrumUse::Illuminant).is_err());
    }

    /// A 6504 K blackbody is close to D65: nearly neutral in sRGB.
    #[test]
    fn blackbody_is_warm_to_cold() {
        let warm = blackbody(3000.0, 1.0).unwrap();
        let d65 = blackbody(6504.0, 1.0).unwrap();
        assert!(warm.x > warm.z * 3.0, "{warm}");
        let n = d65 / d65.y;
        assert!((n - Vec3::ONE).abs().max_element() < 0.1, "{n}");
        assert!(blackbody(-1.0, 1.0).is_err());
    }
}
