//! Mitsuba's `aov` integrator: arbitrary output variables of the camera rays' first hits,
//! written as EXR channels beside the image of the integrator it wraps.
//!
//! | name | type | default |
//! | --- | --- | --- |
//! | `aovs` | string: `name:type` pairs separated by commas (or spaces) | none |
//! | (nested) | `<integrator>`: renders the image; its `name` names its layer (`_arg_0` without) | none: a black image |
//!
//! Types: `albedo` (`name.R/G/B`), `depth` (`name.T`), `position`, `geo_normal`, `sh_normal`,
//! `dp_du`, `dp_dv` (`name.X/Y/Z`), `uv`, `duv_dx`, `duv_dy` (`name.U/V`), `prim_index`,
//! `shape_index` (`name.I`), as Mitsuba 3.9.1 names them. Mitsuba's `boundary_test` is refused.

use super::{parse_integrator, path, warn_extra_integrators};
use crate::context::Ctx;
use crate::error::Result;
use crate::props::Props;
use crate::scene::{Aov, AovKind, Aovs, Integrator, IntegratorKind, PathParams};
use crate::xml::Element;

pub(super) fn parse(ctx: &mut Ctx, elem: &Element, mut props: Props) -> Result<Integrator> {
    let mut list = Vec::new();
    if let Some(attr) = props.string(ctx, &["aovs"])? {
        // Mitsuba's `string::tokenize`: commas and spaces separate, empty tokens are skipped.
        for token in attr.value.split([',', ' ']).filter(|t| !t.is_empty()) {
            let aov = match token.split(':').collect::<Vec<_>>()[..] {
                [name, ty] if !name.is_empty() && !ty.is_empty() => {
                    let kind = match ty {
                        "boundary_test" => {
                            return Err(ctx.err(
                                attr.value_pos,
                                format!("AOV '{token}': torrey does not compute Mitsuba's boundary_test"),
                            ))
                        }
                        _ => AovKind::from_name(ty).ok_or_else(|| {
                            ctx.err(
                                attr.value_pos,
                                format!("AOV '{token}': unknown type '{ty}' (albedo, depth, position, uv, geo_normal, sh_normal, dp_du, dp_dv, duv_dx, duv_dy, prim_index, shape_index)"),
                            )
                        })?,
                    };
                    Aov {
                        name: name.to_string(),
                        kind,
                    }
                }
                _ => {
                    return Err(ctx.err(
                        attr.value_pos,
                        format!("AOV '{token}' is not a <name>:<type> pair"),
                    ))
                }
            };
            list.push(aov);
        }
    }
    if list.is_empty() {
        ctx.warn(elem.pos, "integrator 'aov': no AOVs were specified");
    }
    let inner = props.take_tag("integrator");
    warn_extra_integrators(ctx, "aov", &inner);
    let result = match inner.first() {
        Some(i) => {
            let mut integrator = parse_integrator(ctx, i)?;
            if integrator.aovs.is_some() {
                return Err(ctx.err(i.pos, "integrator 'aov' inside another 'aov'"));
            }
            let name = i
                .attr_value("name")
                .map_or("_arg_0".to_string(), str::to_string);
            integrator.aovs = Some(Aovs {
                inner: Some(name),
                list,
            });
            integrator
        }
        // Mitsuba's image is black without a nested integrator: a path of no segment.
        None => Integrator {
            type_name: "aov".into(),
            kind: IntegratorKind::Path(PathParams {
                max_depth: 0,
                ..path::DEFAULT
            }),
            aovs: Some(Aovs { inner: None, list }),
        },
    };
    props.finish(ctx);
    Ok(result)
}

#[cfg(test)]
mod tests {
    use crate::scene::AovKind;

    fn load(integrator: &str) -> Result<crate::Scene, crate::ParseError> {
        let xml = format!(r#"<scene version="3.0.0">{integrator}<shape type="sphere"/></scene>"#);
        crate::parse_scene_str(&xml, std::path::Path::new("aov.xml"), &[])
    }

    /// Names, types and channels as Mitsuba 3.9.1 writes them; the inner integrator's
    /// parameters are read; `_arg_0` names an unnamed inner integrator.
    #[test]
    fn aovs_and_the_inner_integrator_are_read() {
        let s = load(
            r#"<integrator type="aov">
                <string name="aovs" value="dd.y:depth,nn:sh_normal, aa:albedo pi:prim_index"/>
                <integrator type="path" name="my_image"><integer name="max_depth" value="3"/></integrator>
            </integrator>"#,
        )
        .unwrap();
        assert_eq!(s.integrator.max_depth(), 3);
        let aovs = s.integrator.aovs.as_ref().unwrap();
        assert_eq!(aovs.inner.as_deref(), Some("my_image"));
        let kinds: Vec<_> = aovs.list.iter().map(|a| a.kind).collect();
        assert_eq!(
            kinds,
            [
                AovKind::Depth,
                AovKind::ShNormal,
                AovKind::Albedo,
                AovKind::PrimIndex
            ]
        );
        assert_eq!(
            aovs.channel_names(),
            ["dd.y.T", "nn.X", "nn.Y", "nn.Z", "aa.R", "aa.G", "aa.B", "pi.I"]
        );
        assert!(s.warnings.is_empty(), "{:?}", s.warnings);

        let s = load(r#"<integrator type="aov"><string name="aovs" value="u:uv"/><integrator type="direct"/></integrator>"#).unwrap();
        assert_eq!(s.integrator.aovs.unwrap().inner.as_deref(), Some("_arg_0"));
        let s = load(r#"<integrator type="aov"><string name="aovs" value="u:uv"/></integrator>"#)
            .unwrap();
        assert_eq!(s.integrator.aovs.as_ref().unwrap().inner, None);
        assert_eq!(s.integrator.max_depth(), 0);
    }

    #[test]
    fn bad_aovs_are_refused_with_their_position() {
        for (value, message) in [
            ("dd:depthh", "unknown type 'depthh'"),
            ("dd", "is not a <name>:<type> pair"),
            (":depth", "is not a <name>:<type> pair"),
            ("b:boundary_test", "boundary_test"),
        ] {
            let err = load(&format!(
                r#"<integrator type="aov"><string name="aovs" value="{value}"/></integrator>"#
            ))
            .unwrap_err()
            .to_string();
            assert!(err.contains(message) && err.contains("aov.xml:1:"), "{err}");
        }
    }
}
