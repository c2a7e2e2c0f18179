//! One test per error case: message text and exact line:column.

mod common;
use common::*;
use std::path::Path;
use torrey_parser::parse_scene_str;

#[test]
fn display_format_is_file_line_column() {
    let e = parse("<scene version=\"0.6.0\">\n  <bogus/>\n</scene>").unwrap_err();
    assert_eq!(
        e.to_string(),
        "test.xml:2:3: error: unknown tag <bogus> in <scene>"
    );
}

#[test]
fn malformed_xml() {
    let xml = "<scene version=\"0.6.0\">\n  <shape type=\"sphere\">\n  </bsdf>\n</scene>";
    let e = parse(xml).unwrap_err();
    assert_err(
        &e,
        "malformed XML: ill-formed document: expected `</shape>`, but `</bsdf>` was found",
        (3, 3),
    );
}

#[test]
fn unclosed_element() {
    let xml = "<scene version=\"0.6.0\">\n  <shape type=\"sphere\">\n";
    let e = parse(xml).unwrap_err();
    assert!(e.message.starts_with("malformed XML"), "{e}");
}

#[test]
fn unknown_tag_inside_plugin() {
    let xml = "<scene version=\"0.6.0\">\n  <shape type=\"sphere\">\n    <colour name=\"x\" value=\"1\"/>\n  </shape>\n</scene>";
    let e = parse(xml).unwrap_err();
    assert_err(
        &e,
        "unknown tag <colour> in shape 'sphere'",
        pos_of(xml, "<colour"),
    );
}

#[test]
fn unknown_plugin_type() {
    let xml = "<scene version=\"0.6.0\">\n  <bsdf type=\"velvet\" id=\"a\"/>\n</scene>";
    let e = parse(xml).unwrap_err();
    assert_err(
        &e,
        "unknown bsdf type 'velvet' (supported: diffuse, mirror",
        pos_of(xml, "velvet"),
    );
}

#[test]
fn missing_required_attribute() {
    let xml = "<scene version=\"0.6.0\">\n  <shape type=\"sphere\">\n    <float value=\"1\"/>\n  </shape>\n</scene>";
    let e = parse(xml).unwrap_err();
    assert_err(
        &e,
        "missing required attribute 'name' on <float>",
        pos_of(xml, "<float"),
    );

    let xml = "<scene version=\"0.6.0\">\n  <shape>\n  </shape>\n</scene>";
    let e = parse(xml).unwrap_err();
    assert_err(&e, "missing required attribute 'type' on <shape>", (2, 3));

    let xml = "<scene>\n</scene>";
    let e = parse(xml).unwrap_err();
    assert_err(
        &e,
        "missing required attribute 'version' on <scene>",
        (1, 1),
    );
}

#[test]
fn unparsable_number() {
    let xml = "<scene version=\"0.6.0\">\n  <shape type=\"sphere\">\n    <float name=\"radius\" value=\"1.O\"/>\n  </shape>\n</scene>";
    let e = parse(xml).unwrap_err();
    assert_err(
        &e,
        "cannot parse '1.O' as a number in parameter 'radius' of shape 'sphere'",
        pos_of(xml, "1.O"),
    );
}

#[test]
fn missing_mesh_file() {
    let dir = temp_dir("missing-mesh");
    let xml = "<scene version=\"0.6.0\">\n  <shape type=\"obj\">\n    <string name=\"filename\" value=\"meshes/none.obj\"/>\n  </shape>\n</scene>";
    let e = parse_in(&dir, xml).unwrap_err();
    assert_err(
        &e,
        "mesh file 'meshes/none.obj' not found (looked for '",
        pos_of(xml, "meshes/none"),
    );
    assert!(e.location.file.ends_with("scene.xml"));
}

#[test]
fn malformed_mesh_file_names_file_and_line() {
    let dir = temp_dir("bad-ply");
    std::fs::write(
        dir.join("bad.ply"),
        "ply\nformat ascii 1.0\nelement vertex 3\nproperty float x\nproperty float y\nproperty float z\nelement face 1\nproperty list uchar int vertex_indices\nend_header\n0 0 0\n1 0 0\n0 one 0\n3 0 1 2\n",
    )
    .unwrap();
    let xml = "<scene version=\"2.0.0\">\n  <shape type=\"ply\"><string name=\"filename\" value=\"bad.ply\"/></shape>\n</scene>";
    let e = parse_in(&dir, xml).unwrap_err();
    assert_err(
        &e,
        "in mesh file 'bad.ply': line 12: cannot parse 'one'",
        pos_of(xml, "bad.ply"),
    );
}

#[test]
fn malformed_obj_file_names_file_line_and_column() {
    let dir = temp_dir("bad-obj");
    let xml = "<scene version=\"2.0.0\">\n  <shape type=\"obj\"><string name=\"filename\" value=\"bad.obj\"/></shape>\n</scene>";
    for (obj, message) in [
        (
            "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 9\n",
            "in mesh file 'bad.obj': line 4, column 7: face refers to vertex 9, but 3 vertices are defined before this line",
        ),
        (
            "v 0 0 0\nv 1 0 0\nv 0 1.5.2 0\nf 1 2 3\n",
            "in mesh file 'bad.obj': line 3, column 5: cannot parse '1.5.2' as a vertex coordinate",
        ),
    ] {
        std::fs::write(dir.join("bad.obj"), obj).unwrap();
        let e = parse_in(&dir, xml).unwrap_err();
        assert_err(&e, message, pos_of(xml, "bad.obj"));
    }
}

#[test]
fn missing_texture_file() {
    let dir = temp_dir("missing-texture");
    let xml = "<scene version=\"0.6.0\">\n  <bsdf type=\"diffuse\">\n    <texture type=\"bitmap\" name=\"reflectance\">\n      <string name=\"filename\" value=\"brick.png\"/>\n    </texture>\n  </bsdf>\n</scene>";
    let e = parse_in(&dir, xml).unwrap_err();
    assert_err(
        &e,
        "texture file 'brick.png' not found",
        pos_of(xml, "brick.png"),
    );
}

#[test]
fn empty_mesh() {
    let dir = temp_dir("empty-mesh");
    std::fs::write(dir.join("empty.obj"), "# nothing\nv 0 0 0\n").unwrap();
    let xml = "<scene version=\"0.6.0\">\n  <shape type=\"obj\">\n    <string name=\"filename\" value=\"empty.obj\"/>\n  </shape>\n</scene>";
    let e = parse_in(&dir, xml).unwrap_err();
    assert_err(
        &e,
        "mesh file 'empty.obj' has no triangles",
        pos_of(xml, "empty.obj"),
    );
}

#[test]
fn dangling_ref() {
    let xml = "<scene version=\"0.6.0\">\n  <shape type=\"sphere\">\n    <ref id=\"nowhere\"/>\n  </shape>\n</scene>";
    let e = parse(xml).unwrap_err();
    assert_err(
        &e,
        "reference to undefined id 'nowhere'",
        pos_of(xml, "nowhere"),
    );
}

#[test]
fn ref_to_wrong_kind() {
    let xml = "<scene version=\"0.6.0\">\n  <texture type=\"checkerboard\" id=\"c\"/>\n  <shape type=\"sphere\">\n    <ref id=\"c\"/>\n  </shape>\n</scene>";
    let e = parse(xml).unwrap_err();
    assert_err(
        &e,
        "<ref id=\"c\"> in a shape must name a bsdf",
        pos_of(xml, "<ref"),
    );
}

#[test]
fn duplicate_id() {
    let xml = "<scene version=\"0.6.0\">\n  <bsdf type=\"diffuse\" id=\"red\"/>\n  <bsdf type=\"mirror\" id=\"red\"/>\n</scene>";
    let e = parse(xml).unwrap_err();
    assert_err(
        &e,
        "duplicate id 'red' (a <bsdf> already has it at line 2, column 3)",
        pos_of(xml, "red\"/>\n</scene>"),
    );
}

#[test]
fn negative_radius() {
    let xml = "<scene version=\"0.6.0\">\n  <shape type=\"sphere\">\n    <float name=\"radius\" value=\"-2\"/>\n  </shape>\n</scene>";
    let e = parse(xml).unwrap_err();
    assert_err(
        &e,
        "sphere radius must be positive, found -2",
        pos_of(xml, "-2"),
    );
}

#[test]
fn wrong_matrix_entry_count() {
    let xml = "<scene version=\"0.6.0\">\n  <shape type=\"sphere\">\n    <transform name=\"toWorld\">\n      <matrix value=\"1 0 0 0 0 1 0 0 0 0 1 0\"/>\n    </transform>\n  </shape>\n</scene>";
    let e = parse(xml).unwrap_err();
    assert_err(
        &e,
        "<matrix> needs 16 numbers (row-major 4x4), found 12",
        pos_of(xml, "1 0 0 0"),
    );
}

#[test]
fn undefined_default() {
    let xml = "<scene version=\"3.0.0\">\n  <default name=\"spp\" value=\"4\"/>\n  <sensor type=\"perspective\">\n    <sampler type=\"independent\">\n      <integer name=\"sample_count\" value=\"$sample_count\"/>\n    </sampler>\n  </sensor>\n</scene>";
    let e = parse(xml).unwrap_err();
    assert_err(
        &e,
        "undefined parameter '$sample_count' in attribute 'value' of <integer>",
        pos_of(xml, "$sample_count"),
    );
}

#[test]
fn top_level_area_emitter() {
    let xml = "<scene version=\"0.6.0\">\n  <emitter type=\"area\"/>\n</scene>";
    let e = parse(xml).unwrap_err();
    assert_err(
        &e,
        "an area emitter must be nested inside a <shape>",
        (2, 3),
    );
}

#[test]
fn wrong_value_type() {
    let xml = "<scene version=\"0.6.0\">\n  <shape type=\"sphere\">\n    <rgb name=\"radius\" value=\"1\"/>\n  </shape>\n</scene>";
    let e = parse(xml).unwrap_err();
    assert_err(
        &e,
        "parameter 'radius' of shape 'sphere' must be a <float>, found <rgb>",
        (3, 5),
    );
}

#[test]
fn missing_scene_file() {
    let e = torrey_parser::load_scene(Path::new("/nonexistent/dir/scene.xml"), &[]).unwrap_err();
    assert_err(&e, "cannot read scene file", (1, 1));
}

#[test]
fn root_must_be_scene() {
    let e = parse_scene_str("<sceen version=\"1\"/>", Path::new("x.xml"), &[]).unwrap_err();
    assert_err(
        &e,
        "the root element must be <scene>, found <sceen>",
        (1, 1),
    );
}

#[test]
fn substitution_cannot_inflate_the_scene_past_its_limit() {
    // 1 KiB default referenced 2,000 times in one attribute: 2 MB from a 5 KB file.
    let xml = format!(
        "<scene version=\"0.6.0\">\n  <default name=\"a\" value=\"{}\"/>\n  <integer name=\"x\" value=\"{}\"/>\n</scene>",
        "x".repeat(1024),
        "$a".repeat(2000)
    );
    let limits = torrey_parser::Limits {
        scene_bytes: 1 << 20,
        ..Default::default()
    };
    let e = torrey_parser::parse_scene_str_with_limits(&xml, Path::new("test.xml"), &[], &limits)
        .unwrap_err();
    assert_err(
        &e,
        "substituting <default> values makes the scene larger than the scene_bytes limit",
        pos_of(&xml, "$a"),
    );
}

#[test]
fn bumpmap_needs_one_height_texture_and_one_bsdf() {
    let xml = "<scene version=\"3.0.0\">\n  <bsdf type=\"bumpmap\" id=\"b\">\n    <bsdf type=\"diffuse\"/>\n  </bsdf>\n</scene>";
    let e = parse(xml).unwrap_err();
    assert_err(
        &e,
        "bsdf 'bumpmap' needs exactly one nested height <texture>, found 0",
        pos_of(xml, "<bsdf type=\"bumpmap\""),
    );
    let xml = "<scene version=\"3.0.0\">\n  <bsdf type=\"bumpmap\" id=\"b\">\n    <texture type=\"checkerboard\"/>\n  </bsdf>\n</scene>";
    let e = parse(xml).unwrap_err();
    assert_err(
        &e,
        "bsdf 'bumpmap' needs exactly one nested bsdf, found 0",
        pos_of(xml, "<bsdf type=\"bumpmap\""),
    );
}

/// Range warnings and errors name the parameter they test, as the file spells it, at its value.
/// (Issue 34: a roughconductor's eta warned "reflectance ... is above 1".)
#[test]
fn range_messages_name_the_parameter_they_test() {
    // A conductor's eta and k are indices of refraction: values above 1 are normal (gold here).
    // Nor is a roughness above 1 an albedo. None of them is warned about.
    let xml = r#"<scene version="3.0.0">
  <bsdf type="roughconductor"><rgb name="eta" value="0.2004, 0.9240, 1.1022"/><rgb name="k" value="3.9129, 2.4528, 2.1421"/><float name="alpha" value="1.5"/></bsdf>
  <bsdf type="conductor"><rgb name="eta" value="0.2004, 0.9240, 1.1022"/><rgb name="k" value="3.9129, 2.4528, 2.1421"/></bsdf>
  <bsdf type="roughconductor"><float name="alpha_u" value="2"/><float name="alpha_v" value="3"/></bsdf>
</scene>"#;
    let s = parse_ok(xml);
    assert_eq!(s.warnings, vec![], "no range warning for eta, k or alpha");

    // Albedos above 1: the warning names the parameter (its spelling in the file) and its owner.
    for (bsdf, name) in [
        (
            r#"<bsdf type="diffuse"><rgb name="reflectance" value="1.2"/></bsdf>"#,
            "reflectance",
        ),
        (
            r#"<bsdf type="dielectric"><rgb name="specular_transmittance" value="1.2"/></bsdf>"#,
            "specular_transmittance",
        ),
        (
            r#"<bsdf type="plastic"><rgb name="diffuseReflectance" value="1.2"/></bsdf>"#,
            "diffuseReflectance",
        ),
        (
            r#"<bsdf type="principled"><rgb name="base_color" value="1.2"/></bsdf>"#,
            "base_color",
        ),
    ] {
        let xml = format!("<scene version=\"3.0.0\">\n  {bsdf}\n</scene>");
        let s = parse_ok(&xml);
        let ty = bsdf.split('"').nth(1).unwrap();
        assert_eq!(s.warnings.len(), 1, "{bsdf}: {:?}", s.warnings);
        let w = &s.warnings[0];
        assert_eq!(
            w.message,
            format!("parameter '{name}' of bsdf '{ty}' is 1.2 1.2 1.2, above 1: the surface scatters more light than it receives"),
            "{bsdf}"
        );
        assert_eq!((w.location.line, w.location.column), pos_of(&xml, "1.2"));
    }

    // Mitsuba clamps blendbsdf's weight and mask's opacity to [0, 1]: named, and read as 1.
    let xml = r#"<scene version="3.0.0">
  <bsdf type="blendbsdf"><float name="weight" value="1.5"/><bsdf type="diffuse"/><bsdf type="conductor"/></bsdf>
  <bsdf type="mask"><float name="opacity" value="2"/><bsdf type="diffuse"/></bsdf>
</scene>"#;
    let s = parse_ok(xml);
    let messages: Vec<&str> = s.warnings.iter().map(|w| w.message.as_str()).collect();
    assert_eq!(
        messages,
        [
            "parameter 'weight' of bsdf 'blendbsdf' is 1.5, above 1: read as 1 (Mitsuba clamps it to [0, 1])",
            "parameter 'opacity' of bsdf 'mask' is 2, above 1: read as 1 (Mitsuba clamps it to [0, 1])",
        ]
    );
    assert_eq!(
        (s.warnings[1].location.line, s.warnings[1].location.column),
        pos_of(xml, "2\"/>")
    );

    // An error names the alias the file used: phong's exponent given as alpha.
    let xml = "<scene version=\"0.6.0\">\n  <bsdf type=\"phong\"><float name=\"alpha\" value=\"-1\"/></bsdf>\n</scene>";
    assert_err(
        &parse(xml).unwrap_err(),
        "parameter 'alpha' of bsdf 'phong' must be at least 0, found -1",
        pos_of(xml, "-1"),
    );
    let xml = "<scene version=\"0.6.0\">\n  <bsdf type=\"phong\"><float name=\"exponent\" value=\"-2\"/></bsdf>\n</scene>";
    assert_err(
        &parse(xml).unwrap_err(),
        "parameter 'exponent' of bsdf 'phong' must be at least 0, found -2",
        pos_of(xml, "-2"),
    );
}
