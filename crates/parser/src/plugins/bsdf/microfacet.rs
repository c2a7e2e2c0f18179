//! The microfacet bsdfs' `distribution` and roughness (`roughdielectric`, `roughconductor`,
//! `roughplastic`).

use super::{float_param, Bound};
use crate::context::Ctx;
use crate::error::Result;
use crate::props::Props;
use crate::scene::{ColorParam, MicrofacetType};
use crate::xml::Element;

/// Mitsuba's microfacet `distribution` (default beckmann), roughness (`alpha` for both axes, or
/// `alpha_u` and `alpha_v` together; default 0.1) and `sample_visible` (default true).
pub(super) fn roughness(
    ctx: &mut Ctx,
    props: &mut Props,
    elem: &Element,
    anisotropic: bool,
) -> Result<(MicrofacetType, ColorParam, ColorParam, bool)> {
    let distribution = match props.string(ctx, &["distribution"])? {
        None => MicrofacetType::Beckmann,
        Some(a) => match a.value.to_ascii_lowercase().as_str() {
            "beckmann" => MicrofacetType::Beckmann,
            "ggx" => MicrofacetType::Ggx,
            other => {
                return Err(ctx.err(
                    a.value_pos,
                    format!(
                    "unknown microfacet distribution '{other}' in {} (expected beckmann or ggx)",
                    props.owner
                ),
                ))
            }
        },
    };
    let sample_visible = props.boolean(ctx, &["sample_visible"], true)?;
    if anisotropic && props.has(&["alpha_u", "alpha_v"]) {
        if props.has(&["alpha"]) || !(props.has(&["alpha_u"]) && props.has(&["alpha_v"])) {
            return Err(ctx.err(
                elem.pos,
                format!(
                    "{}: give either alpha or both alpha_u and alpha_v",
                    props.owner
                ),
            ));
        }
        let u = float_param(ctx, props, &["alpha_u"], 0.1, Bound::None)?;
        let v = float_param(ctx, props, &["alpha_v"], 0.1, Bound::None)?;
        return Ok((distribution, u, v, sample_visible));
    }
    let a = float_param(ctx, props, &["alpha"], 0.1, Bound::None)?;
    Ok((distribution, a.clone(), a, sample_visible))
}
