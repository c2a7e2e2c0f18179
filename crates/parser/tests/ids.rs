//! Ids as Mitsuba 3.9.1 registers them: on objects at any depth, and usable by a `<ref>` before
//! the object's place in the document (Mitsuba resolves references after reading the whole
//! file). Each accepted case here loads in Mitsuba 3.9.1 the same way (checked with
//! `mi.load_file`); each error is one Mitsuba gives too.

mod common;

use common::{assert_err, parse, parse_ok, pos_of};
use glam::Vec3;
use torrey_parser::{BsdfKind, ColorParam};

fn reflectance(kind: &BsdfKind) -> Vec3 {
    match kind {
        BsdfKind::Diffuse {
            reflectance: ColorParam::Constant(c),
        } => *c,
        k => panic!("not a constant diffuse: {k:?}"),
    }
}

/// ../shared/scenes/mitsuba-real/staircase: `id="BrushedAluminium"` on a `twosided` nested in
/// an anonymous top-level `bumpmap`, referenced by shapes. Mitsuba gives the shapes the nested
/// twosided itself (without the bump map).
#[test]
fn id_on_a_bsdf_nested_in_an_anonymous_one() {
    let s = parse_ok(
        r#"<scene version="0.6.0">
  <bsdf type="bumpmap">
    <texture name="map" type="checkerboard"/>
    <bsdf type="twosided" id="BrushedAluminium">
      <bsdf type="roughconductor">
        <float name="alpha" value="0.1"/>
      </bsdf>
    </bsdf>
  </bsdf>
  <shape type="sphere"><ref id="BrushedAluminium"/></shape>
  <shape type="sphere"><ref id="BrushedAluminium"/></shape>
</scene>"#,
    );
    let b0 = s.shapes[0].bsdf.expect("a bsdf");
    assert_eq!(s.shapes[1].bsdf, Some(b0));
    let b = &s.bsdfs[b0];
    assert_eq!(b.id.as_deref(), Some("BrushedAluminium"));
    assert!(b.two_sided, "{b:?}");
    assert!(matches!(b.kind, BsdfKind::RoughConductor { .. }), "{b:?}");
    assert!(
        b.bump_map.is_none(),
        "the ref names the twosided, not the bumpmap"
    );
    // The bumpmap itself wraps a copy of it.
    assert!(s
        .bsdfs
        .iter()
        .any(|b| b.bump_map.is_some() && matches!(b.kind, BsdfKind::RoughConductor { .. })));
}

/// Textures, bsdfs, shapegroups and area emitters may be referenced before they stand; each is
/// parsed once.
#[test]
fn references_before_the_definition() {
    let s = parse_ok(
        r#"<scene version="3.0.0">
  <shape type="sphere"><ref id="later"/><ref id="lamp"/></shape>
  <shape type="instance"><ref id="group"/></shape>
  <bsdf type="diffuse" id="later"><ref name="reflectance" id="tex"/></bsdf>
  <texture type="checkerboard" id="tex"/>
  <shape type="shapegroup" id="group"><shape type="sphere"/></shape>
  <emitter type="area" id="lamp"><rgb name="radiance" value="3"/></emitter>
  <shape type="sphere"><ref id="later"/></shape>
</scene>"#,
    );
    assert_eq!(s.shapes.len(), 2);
    assert_eq!(s.shapes[0].bsdf, s.shapes[1].bsdf);
    assert_eq!(
        s.bsdfs
            .iter()
            .filter(|b| b.id.as_deref() == Some("later"))
            .count(),
        1
    );
    assert_eq!(s.textures.len(), 1);
    assert!(matches!(
        s.bsdfs[s.shapes[0].bsdf.unwrap()].kind,
        BsdfKind::Diffuse {
            reflectance: ColorParam::Texture(0)
        }
    ));
    assert_eq!(s.shape_groups.len(), 1);
    assert_eq!(s.instances.len(), 1);
    assert_eq!(s.shapes[0].emitter, Some(Vec3::splat(3.0)));
}

/// Nested objects of every kind take ids: textures inside bsdfs, bsdfs inside shapes and
/// wrappers, media inside shapes; an alias may name a nested id.
#[test]
fn nested_ids_of_other_kinds() {
    let s = parse_ok(
        r#"<scene version="3.0.0">
  <shape type="sphere">
    <bsdf type="diffuse" id="inline">
      <texture name="reflectance" type="checkerboard" id="checks"/>
    </bsdf>
    <medium type="homogeneous" name="interior" id="fog"/>
  </shape>
  <alias id="inline" as="again"/>
  <shape type="sphere"><ref id="again"/><ref name="interior" id="fog"/></shape>
  <shape type="sphere"><bsdf type="twosided"><bsdf type="diffuse" id="deep"><rgb name="reflectance" value="0.2"/></bsdf></bsdf></shape>
  <shape type="sphere"><ref id="deep"/></shape>
  <shape type="sphere"><bsdf type="diffuse"><ref name="reflectance" id="checks"/></bsdf></shape>
</scene>"#,
    );
    assert_eq!(s.shapes[0].bsdf, s.shapes[1].bsdf);
    let deep = &s.bsdfs[s.shapes[3].bsdf.unwrap()];
    assert_eq!(deep.id.as_deref(), Some("deep"));
    assert!(
        !deep.two_sided,
        "the ref names the nested diffuse, not the twosided"
    );
    assert_eq!(reflectance(&deep.kind), Vec3::splat(0.2));
    assert!(matches!(
        s.bsdfs[s.shapes[4].bsdf.unwrap()].kind,
        BsdfKind::Diffuse {
            reflectance: ColorParam::Texture(0)
        }
    ));
    assert_eq!(s.textures.len(), 1);
}

#[test]
fn id_errors() {
    // A nested id that repeats another one, nested or not (Mitsuba: "duplicate ID").
    let xml = "<scene version=\"3.0.0\">\n  <bsdf type=\"diffuse\" id=\"red\"/>\n  <bsdf type=\"twosided\"><bsdf type=\"diffuse\" id=\"red\"/></bsdf>\n</scene>";
    assert_err(
        &parse(xml).unwrap_err(),
        "duplicate id 'red' (a <bsdf> already has it at line 2, column 3)",
        pos_of(xml, "red\"/></bsdf>"),
    );
    let xml = "<scene version=\"3.0.0\">\n  <shape type=\"sphere\"><bsdf type=\"diffuse\" id=\"x\"/></shape>\n  <shape type=\"sphere\" id=\"x\"/>\n</scene>";
    assert_err(
        &parse(xml).unwrap_err(),
        "duplicate id 'x' (a <bsdf> already has it at line 2, column 24)",
        pos_of(xml, "x\"/>\n</scene>"),
    );
    // A reference cycle (Mitsuba: "circular reference detected").
    let xml = "<scene version=\"3.0.0\">\n  <bsdf type=\"twosided\" id=\"a\"><ref id=\"b\"/></bsdf>\n  <bsdf type=\"twosided\" id=\"b\"><ref id=\"a\"/></bsdf>\n</scene>";
    let e = parse(xml).unwrap_err();
    assert!(e.message.starts_with("circular reference: "), "{e}");
    assert!(
        e.message.contains("a -> b -> a") || e.message.contains("b -> a -> b"),
        "{e}"
    );
    let xml = "<scene version=\"3.0.0\">\n  <bsdf type=\"twosided\" id=\"self\"><ref id=\"self\"/></bsdf>\n</scene>";
    assert_err(
        &parse(xml).unwrap_err(),
        "circular reference: self -> self",
        pos_of(xml, "self\"/>"),
    );
    // An alias of an id that comes later (Mitsuba reads aliases in document order).
    let xml = "<scene version=\"3.0.0\">\n  <alias id=\"late\" as=\"early\"/>\n  <bsdf type=\"diffuse\" id=\"late\"/>\n</scene>";
    assert_err(
        &parse(xml).unwrap_err(),
        "<alias> of undefined id 'late'",
        pos_of(xml, "late"),
    );
    // An area emitter that belongs to one shape cannot be given to another (Mitsuba: "an
    // endpoint can be only be attached to a single shape").
    let xml = "<scene version=\"3.0.0\">\n  <shape type=\"sphere\"><emitter type=\"area\" id=\"em\"/></shape>\n  <shape type=\"sphere\"><ref id=\"em\"/></shape>\n</scene>";
    assert_err(
        &parse(xml).unwrap_err(),
        "<ref id=\"em\"> in a shape must name a bsdf, an area emitter or a medium",
        pos_of(xml, "<ref"),
    );
    // Still an error: an id no object has.
    let xml = "<scene version=\"3.0.0\">\n  <shape type=\"sphere\"><ref id=\"nowhere\"/></shape>\n</scene>";
    assert_err(
        &parse(xml).unwrap_err(),
        "reference to undefined id 'nowhere'",
        pos_of(xml, "nowhere"),
    );
}
