//! Text-to-value conversions for attribute values, and `$name` substitution. The functions
//! return plain messages; callers attach the position.

use glam::Vec3;
use std::collections::HashMap;

/// Replaces every `$name` (name = letters, digits, `_`) by its value from `defaults`.
/// Returns the first undefined name as the error.
pub(crate) fn substitute(
    value: &str,
    defaults: &HashMap<String, String>,
) -> Result<String, String> {
    if !value.contains('$') {
        return Ok(value.to_string());
    }
    let mut out = String::with_capacity(value.len());
    let mut rest = value;
    while let Some(i) = rest.find('$') {
        out.push_str(&rest[..i]);
        let after = &rest[i + 1..];
        let len = after
            .find(|c: char| !(c.is_ascii_alphanumeric() || c == '_'))
            .unwrap_or(after.len());
        let name = &after[..len];
        match defaults.get(name) {
            Some(v) if !name.is_empty() => out.push_str(v),
            _ => return Err(name.to_string()),
        }
        rest = &after[len..];
    }
    out.push_str(rest);
    Ok(out)
}

/// Parses one finite floating-point number (Rust syntax plus a leading `+`). `nan`, `inf` and
/// numbers beyond f32's range (1e39) are errors: no scene parameter means anything with them,
/// and they would reach the renderer as NaN geometry or radiance.
pub(crate) fn float(s: &str) -> Result<f32, String> {
    let t = s.trim();
    let t = t.strip_prefix('+').unwrap_or(t);
    let v = t
        .parse::<f32>()
        .map_err(|_| format!("cannot parse '{s}' as a number"))?;
    if v.is_finite() {
        Ok(v)
    } else if t.parse::<f64>().is_ok_and(f64::is_finite) {
        Err(format!(
            "'{s}' is too large for a 32-bit float (at most 3.4e38)"
        ))
    } else {
        Err(format!("'{s}' is not a finite number"))
    }
}

/// Parses one integer.
pub(crate) fn integer(s: &str) -> Result<i64, String> {
    let t = s.trim();
    let t = t.strip_prefix('+').unwrap_or(t);
    t.parse::<i64>()
        .map_err(|_| format!("cannot parse '{s}' as an integer"))
}

/// Parses `true`/`false` (any case), as Mitsuba does.
pub(crate) fn boolean(s: &str) -> Result<bool, String> {
    match s.trim().to_ascii_lowercase().as_str() {
        "true" => Ok(true),
        "false" => Ok(false),
        _ => Err(format!(
            "cannot parse '{s}' as a boolean (expected true or false)"
        )),
    }
}

/// Splits a list of numbers separated by commas and/or whitespace.
pub(crate) fn floats(s: &str) -> Result<Vec<f32>, String> {
    s.split(|c: char| c == ',' || c.is_whitespace())
        .filter(|t| !t.is_empty())
        .map(float)
        .collect()
}

/// Parses "a, b, c", "a b c" or a single "a" (broadcast to all three).
pub(crate) fn vec3(s: &str) -> Result<Vec3, String> {
    let v = floats(s)?;
    match v.len() {
        1 => Ok(Vec3::splat(v[0])),
        3 => Ok(Vec3::new(v[0], v[1], v[2])),
        n => Err(format!("expected 1 or 3 numbers in '{s}', found {n}")),
    }
}

/// sRGB transfer function decode of one channel.
pub(crate) fn srgb_to_linear(c: f32) -> f32 {
    if c <= 0.04045 {
        c / 12.92
    } else {
        ((c + 0.055) / 1.055).powf(2.4)
    }
}

/// Parses an `srgb` value: `#rrggbb` hex or 1/3 numbers in [0, 1]; returns linear RGB.
pub(crate) fn srgb(s: &str) -> Result<Vec3, String> {
    let t = s.trim();
    let encoded = if let Some(hex) = t.strip_prefix('#') {
        if hex.len() != 6 {
            return Err(format!(
                "cannot parse '{s}' as an sRGB hex colour (#rrggbb)"
            ));
        }
        let v = u32::from_str_radix(hex, 16)
            .map_err(|_| format!("cannot parse '{s}' as an sRGB hex colour (#rrggbb)"))?;
        Vec3::new(
            ((v >> 16) & 255) as f32,
            ((v >> 8) & 255) as f32,
            (v & 255) as f32,
        ) / 255.0
    } else {
        vec3(t)?
    };
    Ok(Vec3::new(
        srgb_to_linear(encoded.x),
        srgb_to_linear(encoded.y),
        srgb_to_linear(encoded.z),
    ))
}

/// Converts camelCase parameter names to snake_case so both dialects' spellings match:
/// `toWorld` → `to_world`, `intIOR` → `int_ior`, `flipTexCoords` → `flip_tex_coords`.
pub(crate) fn snake_case(name: &str) -> String {
    let chars: Vec<char> = name.chars().collect();
    let mut out = String::with_capacity(name.len() + 4);
    for (i, &c) in chars.iter().enumerate() {
        if c.is_ascii_uppercase() {
            let prev_lower =
                i > 0 && (chars[i - 1].is_ascii_lowercase() || chars[i - 1].is_ascii_digit());
            let next_lower = chars.get(i + 1).is_some_and(|n| n.is_ascii_lowercase());
            let prev_upper = i > 0 && chars[i - 1].is_ascii_uppercase();
            if i > 0 && chars[i - 1] != '_' && (prev_lower || (prev_upper && next_lower)) {
                out.push('_');
            }
            out.push(c.to_ascii_lowercase());
        } else {
            out.push(c);
        }
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn substitution() {
        let mut d = HashMap::new();
        d.insert("spp".to_string(), "64".to_string());
        d.insert("s".to_string(), "x".to_string());
        assert_eq!(substitute("$spp", &d).unwrap(), "64");
        assert_eq!(substitute("a$s-$spp", &d).unwrap(), "ax-64");
        assert_eq!(substitute("$sp", &d).unwrap_err(), "sp");
        assert_eq!(substitute("plain", &d).unwrap(), "plain");
    }

    #[test]
    fn numbers_and_vectors() {
        assert_eq!(float("-1.5e2").unwrap(), -150.0);
        assert_eq!(float(".5").unwrap(), 0.5);
        assert!(float("1,0").is_err());
        assert_eq!(float("nan").unwrap_err(), "'nan' is not a finite number");
        assert_eq!(
            float(" -inf").unwrap_err(),
            "' -inf' is not a finite number"
        );
        assert_eq!(
            float("1e39").unwrap_err(),
            "'1e39' is too large for a 32-bit float (at most 3.4e38)"
        );
        assert!(vec3("1 NaN 2").is_err());
        assert_eq!(vec3("1, 2, 3").unwrap(), Vec3::new(1.0, 2.0, 3.0));
        assert_eq!(vec3("1 2  3").unwrap(), Vec3::new(1.0, 2.0, 3.0));
        assert_eq!(vec3("1,2,3").unwrap(), Vec3::new(1.0, 2.0, 3.0));
        assert_eq!(vec3("0.4").unwrap(), Vec3::splat(0.4));
        assert!(vec3("1 2").is_err());
        assert_eq!(integer("-7").unwrap(), -7);
        assert!(boolean("yes").is_err());
        assert!(boolean("True").unwrap());
    }

    #[test]
    fn srgb_decoding() {
        let c = srgb("#ff8000").unwrap();
        assert!((c.x - 1.0).abs() < 1e-6);
        // 128/255 = 0.50196 → ((0.50196+0.055)/1.055)^2.4 = 0.21586
        assert!((c.y - 0.21586).abs() < 1e-4, "{}", c.y);
        assert_eq!(c.z, 0.0);
        let g = srgb("0.04").unwrap();
        assert!((g.x - 0.04 / 12.92).abs() < 1e-7);
    }

    #[test]
    fn snake_case_names() {
        assert_eq!(snake_case("toWorld"), "to_world");
        assert_eq!(snake_case("to_world"), "to_world");
        assert_eq!(snake_case("fovAxis"), "fov_axis");
        assert_eq!(snake_case("intIOR"), "int_ior");
        assert_eq!(snake_case("flipTexCoords"), "flip_tex_coords");
        assert_eq!(snake_case("rrDepth"), "rr_depth");
        assert_eq!(snake_case("uvscale"), "uvscale");
        assert_eq!(snake_case("intensity_scale"), "intensity_scale");
    }
}
