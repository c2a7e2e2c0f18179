//! `--limit NAME=VALUE`: the safety caps a user may change. Each cap stops a hostile or broken
//! input (a lying header, a film of 2^31 pixels) before it allocates; the defaults keep any
//! accepted render under about 2 GB. docs/robustness.md lists them.

use torrey_parser::Limits as ParserLimits;

/// Default of the `threads` cap: far more than any machine's cores, far fewer than would
/// exhaust the process's memory for stacks.
pub const DEFAULT_MAX_THREADS: u64 = 1024;

/// Every cap of a render.
#[derive(Clone, Debug)]
pub struct Limits {
    pub parser: ParserLimits,
    /// Pixels of one texture or environment map (width × height).
    pub image_pixels: u64,
    /// `--threads` at most this.
    pub threads: u64,
}

/// The names `--limit` accepts, with a line of help each.
pub const NAMES: &[(&str, &str)] = &[
    (
        "film_pixels",
        "film width x height, from the scene or --size",
    ),
    ("image_pixels", "pixels of one texture or environment map"),
    ("mesh_triangles", "triangles of all meshes together"),
    ("mesh_vertices", "vertices of all meshes together"),
    ("scene_bytes", "size of the scene file"),
    ("nesting_depth", "how deep XML elements may nest"),
    (
        "volume_values",
        "values of all grid volumes (.vol files) together",
    ),
    ("threads", "the most --threads may ask for"),
];

/// Parses `NAME=VALUE`; VALUE is a whole number, `_` separators and exponents (`1e9`) allowed.
pub fn parse_limit(s: &str) -> Result<(String, u64), String> {
    let (name, value) = s
        .split_once('=')
        .ok_or_else(|| format!("expected NAME=VALUE, got '{s}'"))?;
    let name = name.trim().replace('-', "_");
    if !NAMES.iter().any(|(n, _)| *n == name) {
        let known: Vec<&str> = NAMES.iter().map(|(n, _)| *n).collect();
        return Err(format!(
            "unknown limit '{name}' (known: {})",
            known.join(", ")
        ));
    }
    let text = value.trim().replace('_', "");
    let v = text
        .parse::<u64>()
        .ok()
        .or_else(|| {
            text.parse::<f64>()
                .ok()
                .filter(|f| f.is_finite() && *f >= 1.0 && f.fract() == 0.0 && *f < 1.8e19)
                .map(|f| f as u64)
        })
        .filter(|&v| v >= 1)
        .ok_or_else(|| {
            format!("limit {name} must be a whole number of at least 1, got '{value}'")
        })?;
    Ok((name, v))
}

impl Limits {
    /// The defaults with `--limit` settings applied in order.
    pub fn from_args(settings: &[(String, u64)]) -> Result<Self, String> {
        let mut l = Limits {
            parser: ParserLimits::default(),
            image_pixels: torrey_texture::DEFAULT_IMAGE_PIXEL_LIMIT,
            threads: DEFAULT_MAX_THREADS,
        };
        for (name, v) in settings {
            let v = *v;
            match name.as_str() {
                "film_pixels" => l.parser.film_pixels = v,
                "image_pixels" => l.image_pixels = v,
                "mesh_triangles" => l.parser.mesh_triangles = v,
                "mesh_vertices" => l.parser.mesh_vertices = v,
                "scene_bytes" => l.parser.scene_bytes = v,
                "nesting_depth" => l.parser.nesting_depth = v.min(u32::MAX as u64) as u32,
                "volume_values" => l.parser.volume_values = v,
                "threads" => l.threads = v,
                _ => return Err(format!("unknown limit '{name}'")),
            }
        }
        Ok(l)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn parses_names_and_numbers() {
        assert_eq!(
            parse_limit("film_pixels=1e9").unwrap(),
            ("film_pixels".into(), 1_000_000_000)
        );
        assert_eq!(
            parse_limit("image-pixels=67_108_864").unwrap(),
            ("image_pixels".into(), 1 << 26)
        );
        assert!(parse_limit("film_pixels=0").is_err());
        assert!(parse_limit("film_pixels=1.5").is_err());
        assert!(parse_limit("film_pixels=nan").is_err());
        assert!(parse_limit("bogus=3")
            .unwrap_err()
            .starts_with("unknown limit 'bogus'"));
        let l =
            Limits::from_args(&[("threads".into(), 8), ("nesting_depth".into(), 1 << 40)]).unwrap();
        assert_eq!(l.threads, 8);
        assert_eq!(l.parser.nesting_depth, u32::MAX);
        assert_eq!(l.parser.film_pixels, 1 << 25);
    }
}
