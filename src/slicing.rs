//! `--crop` and `--sample-range`: rendering one slice of a render, recorded as a part EXR that
//! `torrey merge` can put back together.

use std::path::Path;
use torrey_parts::{Part, PartMeta};

/// `X,Y,W,H`: a window of the film in pixels.
pub fn parse_crop(s: &str) -> Result<(u32, u32, u32, u32), String> {
    let v: Vec<u32> = s
        .split(',')
        .map(|p| p.trim().parse::<u32>())
        .collect::<Result<_, _>>()
        .map_err(|_| format!("expected X,Y,WIDTH,HEIGHT (whole numbers), got '{s}'"))?;
    match v[..] {
        [x, y, w, h] if w > 0 && h > 0 => Ok((x, y, w, h)),
        [_, _, _, _] => Err(format!("crop width and height must be positive, got '{s}'")),
        _ => Err(format!("expected X,Y,WIDTH,HEIGHT, got '{s}'")),
    }
}

/// `FIRST..END`: samples FIRST to END-1 of every pixel.
pub fn parse_sample_range(s: &str) -> Result<(u32, u32), String> {
    let (a, b) = s
        .split_once("..")
        .ok_or_else(|| format!("expected FIRST..END, got '{s}'"))?;
    let parse = |t: &str| {
        t.trim()
            .parse::<u32>()
            .map_err(|_| format!("expected FIRST..END (whole numbers), got '{s}'"))
    };
    let (a, b) = (parse(a)?, parse(b)?);
    if a >= b {
        return Err(format!(
            "sample range '{s}' is empty (END must exceed FIRST)"
        ));
    }
    Ok((a, b))
}

/// The window to render: `--crop`, else the film's crop parameters (unless `--size` changed the
/// film, which drops them with a warning), else the whole film.
pub fn default_crop(
    crop: Option<(u32, u32, u32, u32)>,
    film: &torrey_parser::Film,
    size: Option<(u32, u32)>,
) -> (u32, u32, u32, u32) {
    let (width, height) = size.unwrap_or((film.width, film.height));
    match (crop, film.crop) {
        (Some(c), _) => c,
        (None, Some(c)) if size.is_none() => c.rect(),
        (None, Some(_)) => {
            eprintln!("warning: the film's crop window is ignored: --size changes the film");
            (0, 0, width, height)
        }
        (None, None) => (0, 0, width, height),
    }
}

/// The metadata of a render part: the scene (path and content hash), the settings, the film and
/// the slice.
pub fn part_meta(
    scene: &torrey_parser::Scene,
    scene_hash: String,
    settings: &torrey_renderer::RenderSettings,
    (width, height): (u32, u32),
    slice: &torrey_renderer::RenderSlice,
) -> Result<PartMeta, String> {
    Ok(PartMeta {
        scene: scene.path.display().to_string(),
        scene_hash,
        settings: torrey_parts::settings_text(settings),
        width,
        height,
        spp: settings.spp,
        samples: (slice.samples.start, slice.samples.end),
        crop: slice.crop,
        nonfinite: 0,
        clamped: 0,
    })
}

/// Writes a part's EXR (with its metadata) and, beside it, its PNG, both or neither
/// ([`crate::output::write_all`]); returns the PNG's path.
pub fn write_outputs(exr: &Path, part: &Part) -> Result<std::path::PathBuf, String> {
    let png = exr.with_extension("png");
    let image = part.image();
    crate::output::write_all(&[
        crate::output::Output {
            path: exr.to_path_buf(),
            content: crate::output::Content::Part(part),
        },
        crate::output::png(&png, &image),
    ])?;
    Ok(png)
}
