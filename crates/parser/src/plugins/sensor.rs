//! The camera side: sensor `perspective`, film `hdrfilm`/`ldrfilm`, rfilters, samplers, and
//! integrators `path`/`direct`.

use crate::context::{plugin_type, unknown_type, Ctx, IdTarget};
use crate::error::Result;
use crate::props::Props;
use crate::scene::{Camera, Dialect, Film, FovAxis, Integrator, PixelFilter, Sampler};
use crate::transform::frame_problem;
use crate::xml::Element;
use glam::Mat4;

/// The camera used when a scene has no sensor (and the fov when a sensor gives none):
/// torrey's 45 degrees, or Mitsuba 3's 50mm lens (39.6 degrees along x).
pub(crate) fn default_camera(dialect: Dialect) -> Camera {
    Camera {
        to_world: Mat4::IDENTITY,
        fov_degrees: match dialect {
            Dialect::Torrey => 45.0,
            Dialect::Mitsuba3 => focal_length_fov(50.0),
        },
        fov_axis: FovAxis::X,
        near_clip: 1e-2,
        far_clip: 1e4,
    }
}

/// Mitsuba's film defaults: 768 x 576, box filter (torrey's, not Mitsuba 3's gaussian).
pub(crate) fn default_film() -> Film {
    Film {
        width: 768,
        height: 576,
        filename: None,
        filter: PixelFilter::Box,
    }
}

pub(crate) fn default_sampler() -> Sampler {
    Sampler {
        sample_count: 4,
        seed: 0,
    }
}

pub(crate) fn default_integrator() -> Integrator {
    Integrator {
        max_depth: -1,
        rr_depth: 5,
        kind: "path".into(),
    }
}

/// Horizontal fov of a 35mm-film lens of focal length `mm`.
fn focal_length_fov(mm: f32) -> f32 {
    2.0 * (18.0 / mm).atan().to_degrees()
}

/// An integer parameter in 1..=`max`; `limit` names the `--limit` that raises `max`, if any.
fn positive(
    ctx: &Ctx,
    props: &mut Props,
    name: &str,
    default: i64,
    max: u64,
    limit: Option<&str>,
) -> Result<u32> {
    let max = max.min(u32::MAX as u64) as i64;
    match props.opt_int_pos(ctx, &[name])? {
        None => Ok(default as u32),
        Some((v, pos)) if v <= 0 => Err(ctx.err(
            pos,
            format!(
                "parameter '{name}' of {} must be positive, found {v}",
                props.owner
            ),
        )),
        Some((v, pos)) if v > max => Err(ctx.err(
            pos,
            format!(
                "parameter '{name}' of {} must be at most {max}, found {v}{}",
                props.owner,
                limit.map_or(String::new(), |l| format!(" (raise with --limit {l}=N)"))
            ),
        )),
        Some((v, _)) => Ok(v as u32),
    }
}

/// Film `hdrfilm` (`ldrfilm` accepted alike):
///
/// | name | type | default |
/// | --- | --- | --- |
/// | `width`, `height` | integer | 768, 576 |
/// | `filename` | string | none |
/// | nested `<rfilter>` | `box`, `gaussian` (`stddev` 0.5), `tent` (`radius` 1) | box |
/// | `pixel_format`, `component_format`, `file_format`, `banner`, `high_quality_edges`, `attach_log`, `sample_border` | any | accepted, no effect |
fn parse_film(ctx: &mut Ctx, elem: &Element) -> Result<Film> {
    let ty = plugin_type(ctx, elem)?;
    if ty != "hdrfilm" && ty != "ldrfilm" {
        return Err(unknown_type(ctx, elem, "film", &["hdrfilm", "ldrfilm"]));
    }
    let mut props = Props::new(ctx, elem, format!("film '{ty}'"))?;
    let mut film = default_film();
    let max = ctx.limits.film_pixels;
    let pixels = Some("film_pixels");
    film.width = positive(ctx, &mut props, "width", 768, max, pixels)?;
    film.height = positive(ctx, &mut props, "height", 576, max, pixels)?;
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
    props.ignore(&[
        "pixel_format",
        "component_format",
        "file_format",
        "banner",
        "high_quality_edges",
        "attach_log",
        "sample_border",
    ]);
    let filters = props.take_tag("rfilter");
    if let Some(f) = filters.first() {
        let fty = plugin_type(ctx, f)?;
        let mut fp = Props::new(ctx, f, format!("rfilter '{fty}'"))?;
        film.filter = match fty {
            "box" => PixelFilter::Box,
            "gaussian" => PixelFilter::Gaussian {
                stddev: fp.float_where(ctx, &["stddev"], 0.5, "positive", |v| v > 0.0)?,
            },
            "tent" => PixelFilter::Tent {
                radius: fp.float_where(ctx, &["radius"], 1.0, "positive", |v| v > 0.0)?,
            },
            _ => {
                return Err(unknown_type(
                    ctx,
                    f,
                    "rfilter",
                    &["box", "gaussian", "tent"],
                ))
            }
        };
        fp.finish(ctx);
    }
    props.finish(ctx);
    Ok(film)
}

/// Sampler: any type is read as `independent` (others get a warning).
///
/// | name | type | default |
/// | --- | --- | --- |
/// | `sample_count` (`sampleCount`) | integer | 4 |
/// | `seed` | integer | 0 |
fn parse_sampler(ctx: &mut Ctx, elem: &Element) -> Result<Sampler> {
    let ty = plugin_type(ctx, elem)?;
    if ty != "independent" {
        let pos = elem.attr("type").map_or(elem.pos, |a| a.value_pos);
        ctx.warn(pos, format!("sampler '{ty}' is treated as 'independent'"));
    }
    let mut props = Props::new(ctx, elem, format!("sampler '{ty}'"))?;
    let sample_count = positive(ctx, &mut props, "sample_count", 4, u32::MAX as u64, None)?;
    let seed = match props.opt_int_pos(ctx, &["seed"])? {
        None => 0,
        Some((s, pos)) if s < 0 => {
            return Err(ctx.err(pos, format!("sampler seed must not be negative, found {s}")))
        }
        Some((s, _)) => s as u64,
    };
    props.finish(ctx);
    Ok(Sampler { sample_count, seed })
}

/// Sensor `perspective`.
///
/// | name | type | default |
/// | --- | --- | --- |
/// | `fov` | float | 45 (torrey) / 39.6 = 50mm (Mitsuba 3) |
/// | `focal_length` | string like `50mm` | used when `fov` is absent; sets fov along x |
/// | `fov_axis` (`fovAxis`) | string: x, y, diagonal, smaller, larger | x |
/// | `to_world` (`toWorld`) | transform | identity |
/// | `near_clip`, `far_clip` (`nearClip`, `farClip`) | float | 0.01, 10000 |
/// | `focus_distance` (`focusDistance`) | float | accepted, ignored (pinhole) |
/// | nested `<film>`, `<sampler>` | | see film and sampler |
pub(crate) fn parse_sensor(ctx: &mut Ctx, elem: &Element) -> Result<(Camera, Film, Sampler)> {
    let ty = plugin_type(ctx, elem)?;
    if ty != "perspective" {
        return Err(unknown_type(ctx, elem, "sensor", &["perspective"]));
    }
    let mut props = Props::new(ctx, elem, format!("sensor '{ty}'"))?;
    ctx.register_id(elem, IdTarget::Other)?;
    let mut camera = default_camera(ctx.dialect);
    let fov = props.opt_float_pos(ctx, &["fov"])?;
    let focal = props.string(ctx, &["focal_length"])?;
    match (fov, focal) {
        (Some((f, pos)), _) => {
            if !(f > 0.0 && f < 180.0) {
                return Err(ctx.err(
                    pos,
                    format!("fov must be between 0 and 180 degrees, found {f}"),
                ));
            }
            camera.fov_degrees = f;
        }
        (None, Some(a)) => {
            let mm = a
                .value
                .trim()
                .strip_suffix("mm")
                .and_then(|s| s.trim().parse::<f32>().ok())
                .filter(|&v| v > 0.0)
                .ok_or_else(|| {
                    ctx.err(
                        a.value_pos,
                        format!(
                            "cannot parse focal_length '{}' (expected e.g. 50mm)",
                            a.value
                        ),
                    )
                })?;
            camera.fov_degrees = focal_length_fov(mm);
        }
        (None, None) => {}
    }
    if let Some(a) = props.string(ctx, &["fov_axis"])? {
        camera.fov_axis = match a.value.to_ascii_lowercase().as_str() {
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
        };
    }
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
    props.ignore(&["focus_distance"]);
    let film = match props.take_tag("film").first() {
        Some(f) => parse_film(ctx, f)?,
        None => default_film(),
    };
    let sampler = match props.take_tag("sampler").first() {
        Some(s) => parse_sampler(ctx, s)?,
        None => default_sampler(),
    };
    props.finish(ctx);
    Ok((camera, film, sampler))
}

/// Integrators: `path` and `direct` (= path with max_depth 2); `volpath` is read as `path`
/// with a warning.
///
/// | name | type | default |
/// | --- | --- | --- |
/// | `max_depth` (`maxDepth`) | integer | -1 (unbounded; 2 for `direct`) |
/// | `rr_depth` (`rrDepth`) | integer | 5 |
pub(crate) fn parse_integrator(ctx: &mut Ctx, elem: &Element) -> Result<Integrator> {
    let ty = plugin_type(ctx, elem)?;
    if !["path", "direct", "volpath"].contains(&ty) {
        return Err(unknown_type(ctx, elem, "integrator", &["path", "direct"]));
    }
    if ty == "volpath" {
        ctx.warn(
            elem.pos,
            "integrator 'volpath' is read as 'path' (media are not rendered)",
        );
    }
    let mut props = Props::new(ctx, elem, format!("integrator '{ty}'"))?;
    let max_depth = if ty == "direct" {
        2
    } else {
        match props.opt_int_pos(ctx, &["max_depth"])? {
            None => -1,
            Some((d, pos)) if d < -1 || d > i32::MAX as i64 => {
                return Err(ctx.err(
                    pos,
                    format!("max_depth must be -1 (unbounded) or at least 0, found {d}"),
                ))
            }
            Some((d, _)) => d as i32,
        }
    };
    let rr_depth = match props.opt_int_pos(ctx, &["rr_depth"])? {
        None => 5,
        Some((d, pos)) if d <= 0 || d > i32::MAX as i64 => {
            return Err(ctx.err(pos, format!("rr_depth must be positive, found {d}")))
        }
        Some((d, _)) => d as i32,
    };
    props.finish(ctx);
    Ok(Integrator {
        max_depth,
        rr_depth,
        kind: ty.to_string(),
    })
}
