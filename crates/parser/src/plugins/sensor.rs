//! The camera side: sensors `perspective`, `thinlens`, `orthographic`; film `hdrfilm`
//! (`ldrfilm` alike); rfilters; samplers.

use crate::context::{plugin_type, unknown_type, Ctx, IdTarget};
use crate::error::Result;
use crate::props::Props;
use crate::scene::{Camera, CameraKind, CropWindow, Dialect, Film, FovAxis, PixelFilter, Sampler};
use crate::transform::frame_problem;
use crate::xml::{Attr, Element, Pos};
use glam::{Mat4, Vec2};

/// Sensor types read (see [`parse_sensor`]).
pub(crate) const SENSORS: &[&str] = &["perspective", "thinlens", "orthographic"];
/// Film types read.
pub(crate) const FILMS: &[&str] = &["hdrfilm", "ldrfilm"];
/// Reconstruction filter types read.
pub(crate) const RFILTERS: &[&str] = &[
    "box",
    "tent",
    "gaussian",
    "mitchell",
    "catmullrom",
    "lanczos",
];
/// Sampler types read (all drawn with torrey's own sampler).
pub(crate) const SAMPLERS: &[&str] = &[
    "independent",
    "stratified",
    "multijitter",
    "orthogonal",
    "ldsampler",
];
/// Diagonal of 35 mm film (36 x 24 mm), along which Mitsuba measures `focal_length`.
const FILM_DIAGONAL_MM: f32 = 43.266_617;

/// Mitsuba's field of view for a focal length in mm (35 mm film equivalent), along the
/// diagonal: 2 atan(diagonal / (2 f)); 50 mm gives 46.79 degrees.
pub(crate) fn focal_length_fov(mm: f32) -> f32 {
    2.0 * (FILM_DIAGONAL_MM / (2.0 * mm)).atan().to_degrees()
}

/// A `fov` in degrees, checked to lie strictly between 0 and 180.
pub(crate) fn checked_fov(ctx: &Ctx, f: f32, pos: Pos) -> Result<f32> {
    if f > 0.0 && f < 180.0 {
        Ok(f)
    } else {
        Err(ctx.err(
            pos,
            format!("fov must be between 0 and 180 degrees, found {f}"),
        ))
    }
}

/// Mitsuba's `focal_length` (`"50mm"`) as a field of view along the diagonal, in degrees.
pub(crate) fn focal_length_param(ctx: &Ctx, a: &Attr) -> Result<f32> {
    let mm = a
        .value
        .trim()
        .strip_suffix("mm")
        .and_then(|s| s.trim().parse::<f32>().ok())
        .filter(|&v| v > 0.0 && v.is_finite())
        .ok_or_else(|| {
            ctx.err(
                a.value_pos,
                format!(
                    "cannot parse focal_length '{}' (expected e.g. 50mm)",
                    a.value
                ),
            )
        })?;
    Ok(focal_length_fov(mm))
}

/// Mitsuba's `fov_axis`: x, y, diagonal, smaller or larger (any case).
pub(crate) fn fov_axis_param(ctx: &Ctx, a: &Attr) -> Result<FovAxis> {
    Ok(match a.value.to_ascii_lowercase().as_str() {
        "x" => FovAxis::X,
        "y" => FovAxis::Y,
        "diagonal" => FovAxis::Diagonal,
        "smaller" => FovAxis::Smaller,
        "larger" => FovAxis::Larger,
        v => {
            return Err(ctx.err(
                a.value_pos,
                format!("unknown fov_axis '{v}' (expected x, y, diagonal, smaller or larger)"),
            ))
        }
    })
}

/// The camera used when a scene has no sensor (and the fov when a sensor gives none):
/// torrey's 45 degrees along x, or Mitsuba's 50 mm lens (46.79 degrees along the diagonal).
pub(crate) fn default_camera(dialect: Dialect) -> Camera {
    let (fov_degrees, fov_axis) = match dialect {
        Dialect::Torrey => (45.0, FovAxis::X),
        Dialect::Mitsuba3 => (focal_length_fov(50.0), FovAxis::Diagonal),
    };
    Camera {
        kind: CameraKind::Perspective,
        to_world: Mat4::IDENTITY,
        fov_degrees,
        fov_axis,
        near_clip: 1e-2,
        far_clip: 1e4,
        principal_point_offset: Vec2::ZERO,
        medium: None,
    }
}

/// The film defaults: 768 x 576; Mitsuba's gaussian filter (stddev 0.5) in Mitsuba-dialect
/// scenes, a box in the torrey dialect (the course's renderer).
pub(crate) fn default_film(dialect: Dialect) -> Film {
    Film {
        width: 768,
        height: 576,
        filename: None,
        filter: match dialect {
            Dialect::Torrey => PixelFilter::Box,
            Dialect::Mitsuba3 => PixelFilter::Gaussian { stddev: 0.5 },
        },
        crop: None,
    }
}

pub(crate) fn default_sampler() -> Sampler {
    Sampler {
        sample_count: 4,
        seed: 0,
        kind: "independent".into(),
    }
}

/// Reconstruction filters, with Mitsuba's parameters and radii:
///
/// | type | name | type | default | radius |
/// | --- | --- | --- | --- | --- |
/// | `box` | | | | 0.5 |
/// | `tent` | `radius` | float | 1 | radius |
/// | `gaussian` | `stddev` | float | 0.5 | 4 stddev |
/// | `mitchell` | `B`, `C` | float | 1/3, 1/3 | 2 |
/// | `catmullrom` | | | | 2 |
/// | `lanczos` | `lobes` | integer | 3 | lobes |
fn parse_rfilter(ctx: &mut Ctx, f: &Element) -> Result<PixelFilter> {
    let fty = plugin_type(ctx, f)?;
    if !RFILTERS.contains(&fty) {
        return Err(unknown_type(ctx, f, "rfilter", RFILTERS));
    }
    let mut fp = Props::new(ctx, f, format!("rfilter '{fty}'"))?;
    let filter = match fty {
        "box" => PixelFilter::Box,
        "gaussian" => PixelFilter::Gaussian {
            stddev: fp.float_where(ctx, &["stddev"], 0.5, "positive", |v| v > 0.0)?,
        },
        "tent" => PixelFilter::Tent {
            radius: fp.float_where(ctx, &["radius"], 1.0, "positive", |v| v > 0.0)?,
        },
        "mitchell" => PixelFilter::Mitchell {
            b: fp.float(ctx, &["B", "b"], 1.0 / 3.0)?,
            c: fp.float(ctx, &["C", "c"], 1.0 / 3.0)?,
        },
        "catmullrom" => PixelFilter::CatmullRom,
        _ => PixelFilter::Lanczos {
            lobes: fp.positive(ctx, "lobes", 3, 64, None)?,
        },
    };
    fp.finish(ctx);
    Ok(filter)
}

/// Film `hdrfilm` (`ldrfilm` accepted alike):
///
/// | name | type | default |
/// | --- | --- | --- |
/// | `width`, `height` | integer | 768, 576 |
/// | `filename` | string | none |
/// | `crop_offset_x`, `crop_offset_y`, `crop_width`, `crop_height` | integer | 0, 0, width, height |
/// | nested `<rfilter>` | see [`parse_rfilter`] | Mitsuba dialect: gaussian (stddev 0.5); torrey: box |
/// | `pixel_format`, `component_format`, `file_format`, `banner`, `high_quality_edges`, `attach_log`, `sample_border`, `compensate`, `tonemap_method`, `gamma`, `exposure`, `key`, `burn` | any | accepted, no effect |
fn parse_film(ctx: &mut Ctx, elem: &Element) -> Result<Film> {
    let ty = plugin_type(ctx, elem)?;
    if !FILMS.contains(&ty) {
        return Err(unknown_type(ctx, elem, "film", FILMS));
    }
    let mut props = Props::new(ctx, elem, format!("film '{ty}'"))?;
    let mut film = default_film(ctx.dialect);
    let max = ctx.limits.film_pixels;
    let pixels = Some("film_pixels");
    film.width = props.positive(ctx, "width", 768, max, pixels)?;
    film.height = props.positive(ctx, "height", 576, max, pixels)?;
    if film.width as u64 * film.height as u64 > max {
        return Err(ctx.err(
            elem.pos,
            format!(
                "the film has {} x {} pixels, more than the limit of {max} (raise with --limit film_pixels=N)",
                film.width, film.height
            ),
        ));
    }
    film.filename = props.string(ctx, &["filename"])?.map(|a| a.value.clone());
    let cx = props.non_negative(ctx, "crop_offset_x")?;
    let cy = props.non_negative(ctx, "crop_offset_y")?;
    let cw = props.non_negative(ctx, "crop_width")?;
    let ch = props.non_negative(ctx, "crop_height")?;
    if cx.is_some() || cy.is_some() || cw.is_some() || ch.is_some() {
        let (x, y) = (cx.unwrap_or(0), cy.unwrap_or(0));
        let crop = CropWindow {
            offset_x: x,
            offset_y: y,
            // Mitsuba's defaults: the film's size (an offset without a size does not fit).
            width: cw.unwrap_or(film.width),
            height: ch.unwrap_or(film.height),
        };
        if crop.width == 0
            || crop.height == 0
            || x as u64 + crop.width as u64 > film.width as u64
            || y as u64 + crop.height as u64 > film.height as u64
        {
            return Err(ctx.err(
                elem.pos,
                format!(
                    "the crop window ({x}, {y}) + {} x {} does not fit the {} x {} film",
                    crop.width, crop.height, film.width, film.height
                ),
            ));
        }
        film.crop = Some(crop);
    }
    props.ignore(&[
        "pixel_format",
        "component_format",
        "file_format",
        "banner",
        "high_quality_edges",
        "attach_log",
        "sample_border",
        "compensate",
        "tonemap_method",
        "gamma",
        "exposure",
        "key",
        "burn",
    ]);
    let filters = props.take_tag("rfilter");
    if let Some(f) = filters.first() {
        film.filter = parse_rfilter(ctx, f)?;
    }
    props.finish(ctx);
    Ok(film)
}

fn next_prime(mut n: u32) -> u32 {
    let is_prime = |n: u32| {
        n >= 2
            && (2..)
                .take_while(|d| d * d <= n)
                .all(|d| !n.is_multiple_of(d))
    };
    while !is_prime(n) {
        n += 1;
    }
    n
}

/// Samplers: every type is drawn with torrey's own sampler (one warning for types other than
/// `independent`: the same expected image, other noise); the sample count is rounded as
/// Mitsuba's sampler rounds it.
///
/// | type | name | type | default |
/// | --- | --- | --- | --- |
/// | all | `sample_count` (`sampleCount`) | integer | 4 |
/// | all | `seed` | integer | 0 |
/// | `stratified`, `multijitter` | `jitter` | boolean | accepted; count rounded up to a square |
/// | `orthogonal` | `strength`, `jitter` | integer, boolean | accepted; count rounded up to a prime's square |
/// | `ldsampler` | | | count rounded up to a power of two |
fn parse_sampler(ctx: &mut Ctx, elem: &Element) -> Result<Sampler> {
    let ty = plugin_type(ctx, elem)?;
    if !SAMPLERS.contains(&ty) {
        return Err(unknown_type(ctx, elem, "sampler", SAMPLERS));
    }
    if ty != "independent" {
        let pos = elem.attr("type").map_or(elem.pos, |a| a.value_pos);
        ctx.warn(
            pos,
            format!("sampler '{ty}' is drawn with torrey's own sampler (same expected image, other noise)"),
        );
    }
    let mut props = Props::new(ctx, elem, format!("sampler '{ty}'"))?;
    let mut sample_count = props.positive(ctx, "sample_count", 4, u32::MAX as u64, None)?;
    let root = |n: u32| (n as f64).sqrt().ceil() as u32;
    sample_count = match ty {
        "stratified" | "multijitter" => root(sample_count).pow(2),
        "orthogonal" => next_prime(root(sample_count)).pow(2),
        "ldsampler" => sample_count.next_power_of_two(),
        _ => sample_count,
    };
    let seed = match props.opt_int_pos(ctx, &["seed"])? {
        None => 0,
        Some((s, pos)) if s < 0 => {
            return Err(ctx.err(pos, format!("sampler seed must not be negative, found {s}")))
        }
        Some((s, _)) => s as u64,
    };
    props.ignore(&["jitter", "strength", "dimension"]);
    props.finish(ctx);
    Ok(Sampler {
        sample_count,
        seed,
        kind: ty.to_string(),
    })
}

/// Sensors `perspective`, `thinlens` and `orthographic`.
///
/// | types | name | type | default |
/// | --- | --- | --- | --- |
/// | perspective, thinlens | `fov` | float | Mitsuba: from `focal_length`; torrey: 45 |
/// | perspective, thinlens | `focal_length` (`focalLength`) | string like `50mm` | `50mm` (Mitsuba dialect); fov along the diagonal of 36 x 24 mm film: 2 atan(43.27 / (2 f)) |
/// | perspective, thinlens | `fov_axis` (`fovAxis`) | string: x, y, diagonal, smaller, larger | x (with `fov`) |
/// | perspective | `principal_point_offset_x`, `_y` | float | 0; the film position's fractions (x/w, y/h) are shifted by it before they become directions (thinlens: ignored, with a warning, as Mitsuba has none) |
/// | thinlens | `aperture_radius` (`apertureRadius`) | float | required |
/// | thinlens | `focus_distance` (`focusDistance`) | float | required (perspective: accepted, ignored) |
/// | orthographic | `to_world` scales the view: x in [-1, 1], y in [-1/aspect, 1/aspect] before it | | |
/// | all | `to_world` (`toWorld`) | transform | identity |
/// | all | `near_clip`, `far_clip` (`nearClip`, `farClip`) | float | 0.01, 10000; camera rays see geometry between these depths along the view axis (perspective, thinlens: t = clip / cos to the axis, as Mitsuba starts rays on the near plane; orthographic: rays start on the near plane and end far - near later) |
/// | all | nested `<film>`, `<sampler>` | | see film and sampler |
/// | all | nested `<medium>` or medium `<ref>` | medium | none: the medium the camera sits in |
pub(crate) fn parse_sensor(ctx: &mut Ctx, elem: &Element) -> Result<(Camera, Film, Sampler)> {
    let ty = plugin_type(ctx, elem)?;
    if !SENSORS.contains(&ty) {
        return Err(unknown_type(ctx, elem, "sensor", SENSORS));
    }
    let mut props = Props::new(ctx, elem, format!("sensor '{ty}'"))?;
    ctx.register_id(elem, IdTarget::Other)?;
    let mut camera = default_camera(ctx.dialect);
    if ty != "orthographic" {
        let fov = props.opt_float_pos(ctx, &["fov"])?;
        let focal = props.string(ctx, &["focal_length"])?;
        let axis = props.string(ctx, &["fov_axis"])?;
        match (fov, focal) {
            (Some((f, pos)), _) => {
                camera.fov_degrees = checked_fov(ctx, f, pos)?;
                camera.fov_axis = FovAxis::X;
            }
            (None, Some(a)) => {
                camera.fov_degrees = focal_length_param(ctx, a)?;
                camera.fov_axis = FovAxis::Diagonal;
            }
            (None, None) => {}
        }
        if let Some(a) = axis {
            if fov.is_none() && ctx.dialect == Dialect::Mitsuba3 {
                ctx.warn(
                    a.value_pos,
                    "fov_axis without fov is ignored: Mitsuba measures focal_length along the diagonal",
                );
            } else {
                camera.fov_axis = fov_axis_param(ctx, a)?;
            }
        }
        camera.principal_point_offset = Vec2::new(
            props.float(ctx, &["principal_point_offset_x"], 0.0)?,
            props.float(ctx, &["principal_point_offset_y"], 0.0)?,
        );
        if ty == "thinlens" && camera.principal_point_offset != Vec2::ZERO {
            ctx.warn(
                elem.pos,
                "sensor 'thinlens': principal_point_offset is ignored (Mitsuba's thinlens has none)",
            );
            camera.principal_point_offset = Vec2::ZERO;
        }
    }
    camera.kind = match ty {
        "thinlens" => {
            let mut required = |name: &str| -> Result<f32> {
                match props.opt_float_pos(ctx, &[name])? {
                    Some((v, pos)) if !(v >= 0.0 && v.is_finite()) => Err(ctx.err(
                        pos,
                        format!("{name} must be a finite non-negative number, found {v}"),
                    )),
                    Some((v, _)) => Ok(v),
                    None => Err(ctx.err(
                        elem.pos,
                        format!("missing required parameter '{name}' of sensor 'thinlens'"),
                    )),
                }
            };
            CameraKind::ThinLens {
                aperture_radius: required("aperture_radius")?,
                focus_distance: required("focus_distance")?,
            }
        }
        "orthographic" => CameraKind::Orthographic,
        _ => {
            props.ignore(&["focus_distance"]);
            CameraKind::Perspective
        }
    };
    if let Some((m, pos)) = props.transform_pos(ctx, &["to_world"], false)? {
        if let Some(problem) = frame_problem(m) {
            return Err(ctx.err(
                pos,
                format!("the camera's to_world cannot place a camera: {problem}"),
            ));
        }
        camera.to_world = m;
    }
    camera.near_clip =
        props.float_where(ctx, &["near_clip"], camera.near_clip, "positive", |v| {
            v > 0.0
        })?;
    let near = camera.near_clip;
    camera.far_clip = props.float_where(
        ctx,
        &["far_clip"],
        camera.far_clip,
        "greater than near_clip",
        |v| v > near,
    )?;
    let film = match props.take_tag("film").first() {
        Some(f) => parse_film(ctx, f)?,
        None => default_film(ctx.dialect),
    };
    let sampler = match props.take_tag("sampler").first() {
        Some(s) => parse_sampler(ctx, s)?,
        None => default_sampler(),
    };
    let mut media = props.take_tag("medium");
    for r in props.take_tag("ref") {
        media.push(r);
    }
    if let Some(second) = media.get(1) {
        return Err(ctx.err(second.pos, "a sensor sits in one medium"));
    }
    if let Some(m) = media.first() {
        camera.medium = Some(super::medium::medium_of(ctx, m, &props.owner)?);
    }
    props.ignore(&["srf", "shutter_open", "shutter_close", "shutter_open_time"]);
    props.finish(ctx);
    Ok((camera, film, sampler))
}
