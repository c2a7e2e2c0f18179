//! Integrators, one file per plugin with its parameter table: `path` ([`path`]; also the types
//! rendered by the path tracer), `direct` ([`direct`]); the wrappers `moment` and `aov` are read
//! through to the integrator inside them.
//!
//! | type | read as |
//! | --- | --- |
//! | `path` | the path tracer |
//! | `direct` | direct illumination with several emitter and BSDF samples |
//! | `volpath`, `volpathmis` | the volumetric path tracer (the parameters of `path`) |
//! | `ptracer`, `prb`, `prb_basic` | the path tracer (one warning; the same expected image) |
//! | `moment` | its first nested `<integrator>` |
//! | `aov` | its nested `<integrator>` (`path` without one); `aovs` is not written (warning) |

mod direct;
mod path;

use crate::context::{plugin_type, unknown_type, Ctx};
use crate::error::Result;
use crate::props::Props;
use crate::scene::{Integrator, IntegratorKind};
use crate::xml::Element;

/// Integrator types read.
pub(crate) const INTEGRATORS: &[&str] = &[
    "path",
    "direct",
    "moment",
    "aov",
    "ptracer",
    "volpath",
    "volpathmis",
    "prb",
    "prb_basic",
];

/// Types rendered by the path tracer, with a warning (their estimators converge to the path
/// tracer's image where the scene has no media).
const READ_AS_PATH: &[&str] = &["ptracer", "prb", "prb_basic"];

/// The integrator of a scene without an `<integrator>`: Mitsuba's default, `path`.
pub(crate) fn default_integrator() -> Integrator {
    Integrator {
        type_name: "path".into(),
        kind: IntegratorKind::Path(path::DEFAULT),
    }
}

/// Reads an `<integrator>` element (see the module's table).
pub(crate) fn parse_integrator(ctx: &mut Ctx, elem: &Element) -> Result<Integrator> {
    let ty = plugin_type(ctx, elem)?;
    if !INTEGRATORS.contains(&ty) {
        return Err(unknown_type(ctx, elem, "integrator", INTEGRATORS));
    }
    let mut props = Props::new(ctx, elem, format!("integrator '{ty}'"))?;
    if ty == "moment" || ty == "aov" {
        return parse_wrapper(ctx, elem, ty, props);
    }
    if READ_AS_PATH.contains(&ty) {
        ctx.warn(
            elem.pos,
            format!("integrator '{ty}' is rendered by the path tracer (the same expected image)"),
        );
    }
    let kind = match ty {
        "direct" => IntegratorKind::Direct(direct::parse(ctx, elem, &mut props)?),
        "volpath" | "volpathmis" => IntegratorKind::VolPath {
            params: path::parse(ctx, &mut props)?,
            mis: ty == "volpathmis",
        },
        _ => IntegratorKind::Path(path::parse(ctx, &mut props)?),
    };
    props.finish(ctx);
    Ok(Integrator {
        type_name: ty.to_string(),
        kind,
    })
}

/// `moment` and `aov`: the integrator nested inside.
fn parse_wrapper(ctx: &mut Ctx, elem: &Element, ty: &str, mut props: Props) -> Result<Integrator> {
    if ty == "aov" {
        ctx.warn(
            elem.pos,
            "integrator 'aov': its AOV images are not written; the integrator inside it renders the image",
        );
        props.ignore(&["aovs"]);
    }
    let inner = props.take_tag("integrator");
    let result = match inner.first() {
        Some(i) => parse_integrator(ctx, i)?,
        None if ty == "aov" => default_integrator(),
        None => return Err(ctx.err(elem.pos, "integrator 'moment' needs a nested <integrator>")),
    };
    for extra in inner.iter().skip(1) {
        ctx.warn(
            extra.pos,
            format!("integrator '{ty}': only the first nested integrator is read"),
        );
    }
    props.finish(ctx);
    Ok(result)
}
