//! Mitsuba's `direct` integrator: the emission the camera sees plus light and BSDF samples at the
//! first hit, combined by multiple importance sampling.
//!
//! | name | type | default |
//! | --- | --- | --- |
//! | `shading_samples` | integer | 1 |
//! | `emitter_samples` | integer | `shading_samples` |
//! | `bsdf_samples` | integer | `shading_samples` |
//! | `hide_emitters` (`hideEmitters`) | boolean | false |

use crate::context::Ctx;
use crate::error::Result;
use crate::props::Props;
use crate::scene::DirectParams;
use crate::xml::Element;

pub(super) fn parse(ctx: &mut Ctx, elem: &Element, props: &mut Props) -> Result<DirectParams> {
    let shading = props.positive(ctx, "shading_samples", 1, u32::MAX as u64, None)?;
    let emitter_samples = props
        .non_negative(ctx, "emitter_samples")?
        .unwrap_or(shading);
    let bsdf_samples = props.non_negative(ctx, "bsdf_samples")?.unwrap_or(shading);
    if emitter_samples + bsdf_samples == 0 {
        return Err(ctx.err(
            elem.pos,
            "integrator 'direct' needs emitter_samples or bsdf_samples above 0",
        ));
    }
    let hide_emitters = props.boolean(ctx, &["hide_emitters"], false)?;
    Ok(DirectParams {
        emitter_samples,
        bsdf_samples,
        hide_emitters,
    })
}
