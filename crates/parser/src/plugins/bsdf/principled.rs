//! Mitsuba 3's `principled` and `principledthin`.

use super::color_param;
use super::params::float_texture;
use crate::context::Ctx;
use crate::error::Result;
use crate::props::Props;
use crate::scene::{ColorParam, PrincipledDesc, PrincipledThinDesc};
use crate::xml::Element;
use glam::Vec3;

/// Whether a lobe parameter is switched on, as Mitsuba's `get_flag`: given, and not a constant 0.
fn lobe_on(p: &ColorParam) -> bool {
    !matches!(p, ColorParam::Constant(c) if *c == Vec3::ZERO)
}

/// Mitsuba's `principled` (src/bsdfs/principled.cpp): `eta` or `specular` (not both); with
/// transmission on, η = 1 becomes 1.001 and specular 0 becomes 0.001.
pub(super) fn principled(
    ctx: &mut Ctx,
    props: &mut Props,
    elem: &Element,
) -> Result<PrincipledDesc> {
    let base_color = color_param(ctx, props, &["base_color"], Vec3::splat(0.5))?;
    let mut f = |name: &str, default: f32| float_texture(ctx, props, name, default);
    let roughness = f("roughness", 0.5)?;
    let anisotropic = f("anisotropic", 0.0)?;
    let metallic = f("metallic", 0.0)?;
    let spec_trans = f("spec_trans", 0.0)?;
    let spec_tint = f("spec_tint", 0.0)?;
    let sheen = f("sheen", 0.0)?;
    let sheen_tint = f("sheen_tint", 0.0)?;
    let flatness = f("flatness", 0.0)?;
    let clearcoat = f("clearcoat", 0.0)?;
    let clearcoat_gloss = f("clearcoat_gloss", 0.0)?;
    let transmits = lobe_on(&spec_trans);
    if props.has(&["eta"]) && props.has(&["specular"]) {
        return Err(ctx.err(
            elem.pos,
            "bsdf 'principled': give either eta or specular, not both",
        ));
    }
    let eta = if props.has(&["eta"]) {
        let eta = props.float_where(ctx, &["eta"], 1.5, "positive", |v| v > 0.0)?;
        if transmits && eta == 1.0 {
            1.001
        } else {
            eta
        }
    } else {
        let mut specular = props.float_where(ctx, &["specular"], 0.5, "in [0, 12.5)", |v| {
            (0.0..12.5).contains(&v)
        })?;
        if transmits && specular == 0.0 {
            specular = 1e-3;
        }
        2.0 / (1.0 - (0.08 * specular).sqrt()) - 1.0
    };
    let rate = |props: &mut Props, name: &str| {
        props.float_where(ctx, &[name], 1.0, "at least 0", |v| v >= 0.0)
    };
    Ok(PrincipledDesc {
        base_color,
        roughness,
        anisotropic,
        metallic,
        spec_trans,
        spec_tint,
        sheen,
        sheen_tint,
        flatness,
        clearcoat,
        clearcoat_gloss,
        eta,
        main_specular_sampling_rate: rate(props, "main_specular_sampling_rate")?,
        clearcoat_sampling_rate: rate(props, "clearcoat_sampling_rate")?,
        diffuse_reflectance_sampling_rate: rate(props, "diffuse_reflectance_sampling_rate")?,
    })
}

/// Mitsuba's `principledthin` (src/bsdfs/principledthin.cpp).
pub(super) fn principled_thin(ctx: &mut Ctx, props: &mut Props) -> Result<PrincipledThinDesc> {
    let base_color = color_param(ctx, props, &["base_color"], Vec3::splat(0.5))?;
    let mut f = |name: &str, default: f32| float_texture(ctx, props, name, default);
    let roughness = f("roughness", 0.5)?;
    let anisotropic = f("anisotropic", 0.0)?;
    let spec_trans = f("spec_trans", 0.0)?;
    let spec_tint = f("spec_tint", 0.0)?;
    let sheen = f("sheen", 0.0)?;
    let sheen_tint = f("sheen_tint", 0.0)?;
    let flatness = f("flatness", 0.0)?;
    let diff_trans = f("diff_trans", 0.0)?;
    let eta = f("eta", 1.5)?;
    let rate = |props: &mut Props, name: &str| {
        props.float_where(ctx, &[name], 1.0, "at least 0", |v| v >= 0.0)
    };
    Ok(PrincipledThinDesc {
        base_color,
        roughness,
        anisotropic,
        spec_trans,
        spec_tint,
        sheen,
        sheen_tint,
        flatness,
        diff_trans,
        eta,
        specular_reflectance_sampling_rate: rate(props, "specular_reflectance_sampling_rate")?,
        specular_transmittance_sampling_rate: rate(props, "specular_transmittance_sampling_rate")?,
        diffuse_reflectance_sampling_rate: rate(props, "diffuse_reflectance_sampling_rate")?,
        diffuse_transmittance_sampling_rate: rate(props, "diffuse_transmittance_sampling_rate")?,
    })
}
