//! Integrators, one file per plugin with its parameter table: `path` ([`path`]; also the types
//! rendered by the path tracer), `direct` ([`direct`]), `aov` ([`aov`]: its AOVs and the
//! integrator inside it); the wrapper `moment` is read through to the integrator inside it.
//!
//! | type | read as |
//! | --- | --- |
//! | `path` | the path tracer |
//! | `direct` | direct illumination with several emitter and BSDF samples |
//! | `volpath`, `volpathmis` | the volumetric path tracer (the parameters of `path`) |
//! | `ptracer`, `prb`, `prb_basic` | the path tracer (one warning; the same expected image) |
//! | `moment` | its first nested `<integrator>` |
//! | `aov` | its `aovs`, written beside the image of its nested `<integrator>` (black without one, as in Mitsuba) |

mod aov;
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
        aovs: None,
    }
}

/// Reads an `<integrator>` element (see the module's table).
pub(crate) fn parse_integrator(ctx: &mut Ctx, elem: &Element) -> Result<Integrator> {
    let ty = plugin_type(ctx, elem)?;
    if !INTEGRATORS.contains(&ty) {
        return Err(unknown_type(ctx, elem, "integrator", INTEGRATORS));
    }
    let mut props = Props::new(ctx, elem, format!("integrator '{ty}'"))?;
    if ty == "aov" {
        return aov::parse(ctx, elem, props);
    }
    if ty == "moment" {
        return parse_moment(ctx, elem, props);
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
        aovs: None,
    })
}

/// `moment`: the integrator nested inside.
fn parse_moment(ctx: &mut Ctx, elem: &Element, mut props: Props) -> Result<Integrator> {
    let inner = props.take_tag("integrator");
    let Some(first) = inner.first() else {
        return Err(ctx.err(elem.pos, "integrator 'moment' needs a nested <integrator>"));
    };
    let result = parse_integrator(ctx, first)?;
    warn_extra_integrators(ctx, "moment", &inner);
    props.finish(ctx);
    Ok(result)
}

/// Warns about nested integrators past the first, which are not read.
fn warn_extra_integrators(ctx: &mut Ctx, ty: &str, inner: &[&Element]) {
    for extra in inner.iter().skip(1) {
        ctx.warn(
            extra.pos,
            format!("integrator '{ty}': only the first nested integrator is read"),
        );
    }
}
