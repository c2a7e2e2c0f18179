//! Mitsuba's `path` integrator (and `volpath`, `volpathmis` and the types rendered by the path
//! tracer):
//!
//! | name | type | default |
//! | --- | --- | --- |
//! | `max_depth` (`maxDepth`) | integer | -1 (unbounded) |
//! | `rr_depth` (`rrDepth`) | integer | 5 |
//! | `hide_emitters` (`hideEmitters`) | boolean | false |
//!
//! `samples_per_pass` and `timeout` are accepted and ignored.

use crate::context::Ctx;
use crate::error::Result;
use crate::props::Props;
use crate::scene::PathParams;

/// Mitsuba's defaults.
pub(super) const DEFAULT: PathParams = PathParams {
    max_depth: -1,
    rr_depth: 5,
    hide_emitters: false,
};

pub(super) fn parse(ctx: &mut Ctx, props: &mut Props) -> Result<PathParams> {
    let max_depth = match props.opt_int_pos(ctx, &["max_depth"])? {
        None => DEFAULT.max_depth,
        Some((d, pos)) if d < -1 || d > i32::MAX as i64 => {
            return Err(ctx.err(
                pos,
                format!("max_depth must be -1 (unbounded) or at least 0, found {d}"),
            ))
        }
        Some((d, _)) => d as i32,
    };
    let rr_depth = match props.opt_int_pos(ctx, &["rr_depth"])? {
        None => DEFAULT.rr_depth,
        Some((d, pos)) if d <= 0 || d > i32::MAX as i64 => {
            return Err(ctx.err(pos, format!("rr_depth must be positive, found {d}")))
        }
        Some((d, _)) => d as i32,
    };
    props.ignore(&["samples_per_pass", "timeout"]);
    let hide_emitters = props.boolean(ctx, &["hide_emitters"], false)?;
    Ok(PathParams {
        max_depth,
        rr_depth,
        hide_emitters,
    })
}
