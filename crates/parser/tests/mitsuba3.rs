//! Mitsuba 3 scene files as Mitsuba reads them: include/path/alias/default, dialect detection,
//! Mitsuba's camera and film defaults, integrator wrappers, samplers. Expected numbers come from
//! Mitsuba 3.9.1 where noted.

mod common;

use common::{assert_err, parse_in, parse_ok, pos_of, temp_dir};
use glam::{Mat4, Vec3, Vec4};
use torrey_parser::{
    parse_scene_str_with, BsdfKind, CameraKind, ColorParam, Dialect, FovAxis, IntegratorKind,
    Light, LoadOptions, PixelFilter,
};

fn write(dir: &std::path::Path, name: &str, text: &str) {
    let p = dir.join(name);
    std::fs::create_dir_all(p.parent().unwrap()).unwrap();
    std::fs::write(p, text).unwrap();
}

#[test]
fn include_path_alias_and_defaults() {
    let dir = temp_dir("include");
    write(
        &dir,
        "parts/mats.xml",
        r#"<scene version="3.0.0">
  <bsdf type="diffuse" id="red"><rgb name="reflectance" value="$r, 0, 0"/></bsdf>
  <default name="g" value="0.7"/>
</scene>"#,
    );
    write(
        &dir,
        "parts/inner.xml",
        r#"<scene version="3.0.0">
  <bsdf type="diffuse"><rgb name="reflectance" value="0, $g, 0"/></bsdf>
  <float name="radius" value="5"/>
</scene>"#,
    );
    let xml = r#"<scene version="3.0.0">
  <default name="r" value="0.9"/>
  <path value="parts"/>
  <include filename="mats.xml"/>
  <alias id="red" as="crimson"/>
  <shape type="sphere"><ref id="crimson"/></shape>
  <shape type="sphere"><include filename="inner.xml"/></shape>
  <default name="r" value="0.1"/>
</scene>"#;
    let s = parse_in(&dir, xml).unwrap_or_else(|e| panic!("{e}"));
    let color = |i: usize| match &s.bsdfs[s.shapes[i].bsdf.unwrap()].kind {
        BsdfKind::Diffuse {
            reflectance: ColorParam::Constant(c),
        } => *c,
        k => panic!("{k:?}"),
    };
    // The first <default name="r"> wins; a default from an included file applies too.
    assert_eq!(color(0), Vec3::new(0.9, 0.0, 0.0));
    assert_eq!(color(1), Vec3::new(0.0, 0.7, 0.0));
    // Inside an object, an included value tag is dropped with a warning (as Mitsuba).
    assert!(matches!(
        s.shapes[1].geometry,
        torrey_parser::Geometry::Sphere { radius, .. } if radius == 1.0
    ));
    let w = s
        .warnings
        .iter()
        .find(|w| w.message.contains("<float name=\"radius\">"))
        .expect("warning about the dropped float");
    assert!(w.location.file.ends_with("parts/inner.xml"), "{w}");
    assert_eq!((w.location.line, w.location.column), (3, 3));
    assert!(w.message.contains("included from"), "{w}");
}

#[test]
fn errors_in_included_files_name_the_file_and_the_chain() {
    let dir = temp_dir("include-errors");
    write(
        &dir,
        "a.xml",
        "<scene version=\"3.0.0\">\n  <include filename=\"b.xml\"/>\n</scene>",
    );
    write(
        &dir,
        "b.xml",
        "<scene version=\"3.0.0\">\n\n  <shape type=\"cone\"/>\n</scene>",
    );
    let xml = "<scene version=\"3.0.0\">\n    <include filename=\"a.xml\"/>\n</scene>";
    let e = parse_in(&dir, xml).unwrap_err();
    assert!(e.location.file.ends_with("b.xml"), "{e}");
    assert_err(&e, "unknown shape type 'cone'", (3, 16));
    let main = dir.join("scene.xml");
    assert!(
        e.message.ends_with(&format!(
            "(included from {}:2:3, included from {}:2:5)",
            dir.join("a.xml").display(),
            main.display()
        )),
        "{e}"
    );

    // Malformed XML inside an include, a missing include, a cycle, an unknown alias.
    write(
        &dir,
        "bad.xml",
        "<scene version=\"3.0.0\">\n  <shape>\n</scene>",
    );
    let e = parse_in(
        &dir,
        "<scene version=\"3.0.0\"><include filename=\"bad.xml\"/></scene>",
    )
    .unwrap_err();
    assert!(
        e.location.file.ends_with("bad.xml") && e.message.contains("included from"),
        "{e}"
    );
    let xml = "<scene version=\"3.0.0\">\n  <include filename=\"nope.xml\"/></scene>";
    assert_err(
        &parse_in(&dir, xml).unwrap_err(),
        "cannot read included file 'nope.xml'",
        pos_of(xml, "nope.xml"),
    );
    write(
        &dir,
        "loop.xml",
        "<scene version=\"3.0.0\"><include filename=\"loop.xml\"/></scene>",
    );
    let e = parse_in(
        &dir,
        "<scene version=\"3.0.0\"><include filename=\"loop.xml\"/></scene>",
    )
    .unwrap_err();
    assert!(e.message.contains("include cycle"), "{e}");
    let xml = "<scene version=\"3.0.0\">\n  <alias id=\"x\" as=\"y\"/></scene>";
    assert_err(
        &parse_in(&dir, xml).unwrap_err(),
        "<alias> of undefined id 'x'",
        pos_of(xml, "x\""),
    );
    let xml = "<scene version=\"3.0.0\">\n  <path value=\"missing\"/></scene>";
    assert_err(
        &parse_in(&dir, xml).unwrap_err(),
        "<path> folder 'missing' does not exist",
        pos_of(xml, "missing"),
    );
}

#[test]
fn dialect_detection_and_override() {
    // A 0.6 file with only plugins the course's renderer reads is a course file: both sides
    // shaded and the course's 0.5 grey sky, although nothing in it is the course's alone.
    let plain06 = r#"<scene version="0.6.0"><shape type="sphere"/></scene>"#;
    let s = parse_ok(plain06);
    assert_eq!(s.dialect, Dialect::Torrey, "{}", s.dialect_reason);
    assert_eq!(
        s.dialect_reason,
        "scene version 0.6.0, every plugin (1) one the torrey course's renderer reads"
    );
    assert_eq!(
        s.lights,
        vec![Light::Constant {
            radiance: Vec3::splat(0.5)
        }],
        "the course's 0.5 grey sky"
    );
    // One plugin the course does not read makes it a Mitsuba 0.6 file, whatever else it has
    // (here the course's own phong): no grey sky. The reason names the plugin and its position.
    let mixed = r#"<scene version="0.6.0">
  <shape type="sphere"><bsdf type="phong"/></shape>
  <shape type="sphere"><bsdf type="roughconductor"/></shape>
</scene>"#;
    let s = parse_ok(mixed);
    assert_eq!(s.dialect, Dialect::Mitsuba3);
    let (line, column) = pos_of(mixed, "<bsdf type=\"roughconductor");
    assert_eq!(
        s.dialect_reason,
        format!("scene version 0.6.0 with bsdf 'roughconductor' at test.xml:{line}:{column}, which the torrey course's renderer does not read: Mitsuba's rules")
    );
    assert!(s.lights.is_empty(), "no grey sky in a Mitsuba 0.6 scene");
    // What the course's parser skips does not decide: an integrator, a filter, media.
    let skipped = r#"<scene version="0.5.0">
  <integrator type="volpath"/>
  <medium type="homogeneous" id="m"/>
  <sensor type="perspective"><film type="hdrfilm"><rfilter type="gaussian"/></film></sensor>
  <shape type="sphere"><ref name="interior" id="m"/></shape>
</scene>"#;
    assert_eq!(parse_ok(skipped).dialect, Dialect::Torrey);
    // Version 2 and up is Mitsuba 3 whatever its plugins.
    let s = parse_ok(
        r#"<scene version="3.0.0"><shape type="sphere"><bsdf type="mirror"/></shape></scene>"#,
    );
    assert_eq!(s.dialect, Dialect::Mitsuba3);
    // --dialect overrides, both ways, and says what it overrode.
    let force = |xml: &str, d: Dialect| {
        parse_scene_str_with(
            xml,
            std::path::Path::new("t.xml"),
            &LoadOptions {
                dialect: Some(d),
                ..Default::default()
            },
        )
        .unwrap()
    };
    let forced = force(plain06, Dialect::Mitsuba3);
    assert_eq!(forced.dialect, Dialect::Mitsuba3);
    assert!(
        forced
            .dialect_reason
            .starts_with("forced (detected scene version 0.6.0, every plugin"),
        "{}",
        forced.dialect_reason
    );
    assert!(forced.lights.is_empty());
    let forced = force(mixed, Dialect::Torrey);
    assert_eq!(forced.dialect, Dialect::Torrey);
    assert!(
        forced
            .dialect_reason
            .starts_with("forced (detected scene version 0.6.0 with bsdf 'roughconductor'"),
        "{}",
        forced.dialect_reason
    );
    assert_eq!(forced.lights.len(), 1);
}

#[test]
fn dialect_decided_in_an_included_file_names_that_file() {
    let dir = temp_dir("dialect-include");
    write(
        &dir,
        "parts/metal.xml",
        "<scene version=\"0.6.0\">\n  <bsdf type=\"conductor\" id=\"metal\"/>\n</scene>\n",
    );
    let xml = r#"<scene version="0.6.0">
  <include filename="parts/metal.xml"/>
  <shape type="sphere"><ref id="metal"/></shape>
</scene>"#;
    let s = parse_in(&dir, xml).unwrap();
    assert_eq!(s.dialect, Dialect::Mitsuba3);
    let metal = dir.join("parts/metal.xml");
    assert!(
        s.dialect_reason
            .contains(&format!("bsdf 'conductor' at {}:2:3,", metal.display())),
        "{}",
        s.dialect_reason
    );
    // The same file with a course bsdf included: a course file.
    write(
        &dir,
        "parts/metal.xml",
        "<scene version=\"0.6.0\"><bsdf type=\"mirror\" id=\"metal\"/></scene>",
    );
    assert_eq!(parse_in(&dir, xml).unwrap().dialect, Dialect::Torrey);
}

#[test]
fn mitsuba_camera_and_film_defaults() {
    let s = parse_ok(
        r#"<scene version="3.0.0"><sensor type="perspective">
  <film type="hdrfilm"><integer name="width" value="64"/><integer name="height" value="48"/></film>
</sensor></scene>"#,
    );
    // 50 mm on 36 x 24 mm film, along the diagonal: Mitsuba's x_fov is 38.1848 at 64 x 48.
    assert_eq!(s.camera.fov_axis, FovAxis::Diagonal);
    assert!(
        (s.camera.fov_degrees - 46.793).abs() < 1e-3,
        "{}",
        s.camera.fov_degrees
    );
    let t = (s.camera.fov_degrees.to_radians() / 2.0).tan() * 64.0 / 80.0;
    assert!((2.0 * t.atan().to_degrees() - 38.18484).abs() < 1e-3);
    assert_eq!(s.film.filter, PixelFilter::Gaussian { stddev: 0.5 });
    // 35 mm: Mitsuba's x_fov 52.6225 at 64 x 48.
    let s = parse_ok(
        r#"<scene version="3.0.0"><sensor type="perspective"><string name="focal_length" value="35mm"/>
  <film type="hdrfilm"><integer name="width" value="64"/><integer name="height" value="48"/>
  <rfilter type="lanczos"/></film></sensor></scene>"#,
    );
    let t = (s.camera.fov_degrees.to_radians() / 2.0).tan() * 64.0 / 80.0;
    assert!((2.0 * t.atan().to_degrees() - 52.62254).abs() < 1e-3);
    assert_eq!(s.film.filter, PixelFilter::Lanczos { lobes: 3 });
    // The torrey dialect keeps the box filter and 45 degrees along x.
    let s = parse_ok(r#"<scene version="0.6.0"><background/><sensor type="perspective"/></scene>"#);
    assert_eq!(s.film.filter, PixelFilter::Box);
    assert_eq!(
        (s.camera.fov_degrees, s.camera.fov_axis),
        (45.0, FovAxis::X)
    );
    // Thin lens, crop window.
    let s = parse_ok(
        r#"<scene version="3.0.0"><sensor type="thinlens">
  <float name="aperture_radius" value="0.1"/><float name="focus_distance" value="4"/>
  <film type="hdrfilm"><integer name="crop_offset_x" value="8"/><integer name="crop_width" value="16"/></film>
</sensor></scene>"#,
    );
    assert_eq!(
        s.camera.kind,
        CameraKind::ThinLens {
            aperture_radius: 0.1,
            focus_distance: 4.0
        }
    );
    let crop = s.film.crop.unwrap();
    assert_eq!((crop.offset_x, crop.width, crop.height), (8, 16, 576));
}

/// `lookat` without `up`: the matrices Mitsuba 3.9.1 builds.
#[test]
fn lookat_without_up_matches_mitsuba() {
    for (origin, target, mitsuba) in [
        (
            "1, 2, 3",
            "0, 0, 0",
            [
                [-0.0792865, 0.960357, -0.267261, 1.0],
                [0.841427, -0.0792865, -0.534522, 2.0],
                [-0.534522, -0.267261, -0.801784, 3.0],
            ],
        ),
        (
            "0, 5, 0",
            "0, 0, 0",
            [
                [0.0, 1.0, 0.0, 0.0],
                [0.0, 0.0, -1.0, 5.0],
                [-1.0, 0.0, 0.0, 0.0],
            ],
        ),
        (
            "0, 0, 0",
            "0, 0, -1",
            [
                [0.0, 1.0, 0.0, 0.0],
                [1.0, 0.0, 0.0, 0.0],
                [0.0, 0.0, -1.0, 0.0],
            ],
        ),
    ] {
        let s = parse_ok(&format!(
            r#"<scene version="3.0.0"><sensor type="perspective"><transform name="to_world">
  <lookat origin="{origin}" target="{target}"/></transform></sensor></scene>"#
        ));
        let m: Mat4 = s.camera.to_world;
        for (r, row) in mitsuba.iter().enumerate() {
            let got: Vec4 = m.row(r);
            assert!(
                (got - Vec4::from(*row)).abs().max_element() < 1e-5,
                "{origin} -> {target}: row {r} {got} vs {row:?}"
            );
        }
    }
}

#[test]
fn integrators_and_samplers() {
    let s = parse_ok(
        r#"<scene version="3.0.0">
  <integrator type="moment"><integrator type="path"><integer name="max_depth" value="7"/>
    <boolean name="hide_emitters" value="true"/></integrator></integrator>
  <sensor type="perspective"><sampler type="stratified"><integer name="sample_count" value="10"/>
    <integer name="seed" value="3"/></sampler></sensor>
</scene>"#,
    );
    assert_eq!(
        (s.integrator.type_name.as_str(), s.integrator.max_depth()),
        ("path", 7)
    );
    assert!(s.integrator.hide_emitters());
    assert_eq!((s.sampler.sample_count, s.sampler.seed), (16, 3));
    assert_eq!(s.sampler.kind, "stratified");
    assert_eq!(
        s.warnings.len(),
        1,
        "one warning for the sampler: {:?}",
        s.warnings
    );
    let s = parse_ok(
        r#"<scene version="3.0.0"><integrator type="aov"><string name="aovs" value="nn:sh_normal"/>
  <integrator type="direct"><integer name="emitter_samples" value="4"/></integrator></integrator>
  <sensor type="perspective"><sampler type="orthogonal"><integer name="sample_count" value="10"/></sampler></sensor>
</scene>"#,
    );
    assert_eq!(s.integrator.type_name, "direct");
    let IntegratorKind::Direct(direct) = s.integrator.kind else {
        panic!("{:?}", s.integrator)
    };
    assert_eq!((direct.emitter_samples, direct.bsdf_samples), (4, 1));
    assert_eq!(s.sampler.sample_count, 25);
    // ptracer is read as path, with a warning; volpath is rendered as itself.
    for (ty, warnings) in [("ptracer", 1), ("volpath", 0)] {
        let s = parse_ok(&format!(
            r#"<scene version="3.0.0"><integrator type="{ty}"><integer name="max_depth" value="3"/></integrator></scene>"#
        ));
        assert_eq!(s.integrator.max_depth(), 3);
        assert_eq!(s.warnings.len(), warnings, "{ty}: {:?}", s.warnings);
    }
}

#[test]
fn emitter_spectra_and_mitsuba06_names() {
    let s = parse_ok(
        r#"<scene version="3.0.0">
  <emitter type="point"><spectrum name="intensity" value="2"/></emitter>
  <shape type="sphere"><bsdf type="diffuse"><spectrum name="reflectance" value="0.25"/></bsdf></shape>
</scene>"#,
    );
    let Light::Point { intensity, .. } = s.lights[0] else {
        panic!()
    };
    assert!(
        (intensity - 2.0 * Vec3::new(1.204794, 0.948291, 0.908916))
            .abs()
            .max_element()
            < 1e-5
    );
    assert!(matches!(
        s.bsdfs[0].kind,
        BsdfKind::Diffuse { reflectance: ColorParam::Constant(c) } if c == Vec3::splat(0.25)
    ));
    let s = parse_ok(
        r#"<scene version="0.6.0">
  <sensor type="perspective"><transform name="toWorld"><lookAt origin="0,0,5" target="0,0,0" up="0,1,0"/></transform>
    <sampler type="ldsampler"><integer name="sampleCount" value="5"/></sampler>
    <film type="ldrfilm"><integer name="width" value="8"/></film></sensor>
  <shape type="sphere"><bsdf type="roughdiffuse"><float name="alpha" value="0.3"/></bsdf></shape>
</scene>"#,
    );
    assert_eq!(s.dialect, Dialect::Mitsuba3);
    assert_eq!(s.sampler.sample_count, 8);
    assert!(s
        .warnings
        .iter()
        .any(|w| w.message.contains("roughdiffuse")));
}

/// Media are read (a top-level one and one nested in a shape); what torrey does not render (a
/// `<phase>` outside a medium, a `<subsurface>`) gives one warning for the whole scene, at the
/// first such element.
#[test]
fn unrendered_elements_give_one_warning() {
    let xml = r#"<scene version="3.0.0">
  <medium type="homogeneous" id="fog"/>
  <shape type="sphere"><medium name="interior" type="homogeneous"/></shape>
  <phase type="hg"/>
  <subsurface type="dipole"/>
</scene>"#;
    let s = parse_ok(xml);
    assert_eq!(s.media.len(), 2);
    assert_eq!(s.shapes[0].interior, Some(1));
    assert_eq!(s.warnings.len(), 1, "{:?}", s.warnings);
    let w = &s.warnings[0];
    assert_eq!(
        (w.location.line, w.location.column),
        pos_of(xml, "<phase type")
    );
    assert!(w.message.contains("is not supported"), "{w}");
}

/// Mitsuba's cube (its vertex layout and uvs, from Mitsuba 3.9.1), and shapegroups placed by
/// instances (the group's shapes stored once, not copied).
#[test]
fn cube_shapegroup_and_instances() {
    let s = parse_ok(
        r#"<scene version="3.0.0">
  <shape type="cube"/>
  <shape type="shapegroup" id="g">
    <shape type="sphere"><float name="radius" value="0.5"/></shape>
    <shape type="cube"><transform name="to_world"><translate x="2"/></transform></shape>
  </shape>
  <shape type="instance"><ref id="g"/><transform name="to_world"><translate y="3"/></transform></shape>
  <shape type="instance"><ref id="g"/></shape>
</scene>"#,
    );
    assert_eq!(
        s.shapes.len(),
        1,
        "the cube; the group's shapes are not copied"
    );
    assert_eq!(s.shape_groups.len(), 1);
    assert_eq!(s.shape_groups[0].id, "g");
    assert_eq!(s.shape_groups[0].shapes.len(), 2);
    assert_eq!(s.instances.len(), 2);
    assert!(s.instances.iter().all(|i| i.group == 0));
    let torrey_parser::Geometry::Mesh(m) = &s.shapes[0].geometry else {
        panic!()
    };
    assert_eq!((m.positions.len(), m.indices.len()), (24, 12));
    // Mitsuba's first face: y = -1, vertices (1,-1,-1) (1,-1,1) (-1,-1,1) (-1,-1,-1), uvs
    // (0,1) (1,1) (1,0) (0,0), triangles (0,1,2) (3,0,2).
    assert_eq!(m.positions[1], Vec3::new(1.0, -1.0, 1.0));
    assert_eq!(m.uvs[1], glam::Vec2::new(1.0, 1.0));
    assert_eq!(m.normals[3], Vec3::new(0.0, -1.0, 0.0));
    assert_eq!(m.indices[1], [3, 0, 2]);
    // Every triangle winds counter-clockwise around its outward normal.
    for t in &m.indices {
        let [a, b, c] = t.map(|i| m.positions[i as usize]);
        let n = (b - a).cross(c - a).normalize();
        assert!((n - m.normals[t[0] as usize]).length() < 1e-6, "{t:?}");
    }
    // The group's cube keeps its own transform; the instance's comes on top.
    let cube = &s.shape_groups[0].shapes[1];
    assert_eq!(
        cube.to_world.transform_point3(Vec3::ZERO),
        Vec3::new(2.0, 0.0, 0.0)
    );
    let moved = (s.instances[0].to_world * cube.to_world).transform_point3(Vec3::ZERO);
    assert_eq!(moved, Vec3::new(2.0, 3.0, 0.0));
    assert_eq!(s.instances[1].to_world, glam::Mat4::IDENTITY);
    assert!(s.warnings.is_empty(), "{:?}", s.warnings);
}

/// Mitsuba's rules for groups and instances: no emitters, groups or instances inside a group, one
/// group per instance, an invertible transform, a known id; a group nobody instances is a warning.
#[test]
fn shapegroup_and_instance_rules() {
    let group = |inner: &str| {
        format!("<scene version=\"3.0.0\">\n  <shape type=\"shapegroup\" id=\"g\">\n    {inner}\n  </shape>\n</scene>")
    };
    for (inner, message, at) in [
        (
            r#"<shape type="sphere"><emitter type="area"/></shape>"#,
            "shapes in a shapegroup cannot be emitters",
            "<shape type=\"sphere\">",
        ),
        (
            r#"<shape type="shapegroup" id="h"/>"#,
            "a shapegroup cannot contain a 'shapegroup'",
            "<shape type=\"shapegroup\" id=\"h\"",
        ),
        (
            r#"<shape type="instance"><ref id="g"/></shape>"#,
            "a shapegroup cannot contain a 'instance'",
            "<shape type=\"instance\">",
        ),
    ] {
        let xml = group(inner);
        assert_err(&common::parse(&xml).unwrap_err(), message, pos_of(&xml, at));
    }
    let base = r#"<scene version="3.0.0">
  <shape type="shapegroup" id="g"><shape type="sphere"/></shape>
  <bsdf type="diffuse" id="b"/>
"#;
    for (instance, message, at) in [
        (
            r#"<shape type="instance"><ref id="b"/></shape>"#,
            "<ref id=\"b\"> in an instance must name a shapegroup",
            "<ref id=\"b\"",
        ),
        (
            r#"<shape type="instance"><ref id="missing"/></shape>"#,
            "reference to undefined id 'missing'",
            "missing",
        ),
        (
            r#"<shape type="instance"/>"#,
            "shape 'instance' needs a <ref id=\"...\"/> to a shapegroup",
            "<shape type=\"instance\"",
        ),
        (
            r#"<shape type="instance"><ref id="g"/><ref id="g"/></shape>"#,
            "shape 'instance' takes a single shapegroup",
            "<ref id=\"g\"/></shape>",
        ),
        (
            r#"<shape type="instance"><ref id="g"/><transform name="to_world"><scale x="0"/></transform></shape>"#,
            "the to_world of shape 'instance' is degenerate",
            "<shape type=\"instance\"",
        ),
        (
            r#"<shape type="instance"><ref id="g"/><transform name="to_world"><translate x="1e15"/></transform></shape>"#,
            "shape 'instance': moved to world space by its to_world",
            "<shape type=\"instance\"",
        ),
    ] {
        let xml = format!("{base}  {instance}\n</scene>");
        assert_err(&common::parse(&xml).unwrap_err(), message, pos_of(&xml, at));
    }
    // A group without instances draws nothing, as in Mitsuba, and says so.
    let xml = format!("{base}</scene>");
    let s = parse_ok(&xml);
    assert!(s.instances.is_empty() && s.shapes.is_empty());
    assert_eq!(s.warnings.len(), 1, "{:?}", s.warnings);
    assert!(s.warnings[0]
        .message
        .contains("shapegroup 'g' is not instanced"));
    assert_eq!(
        (s.warnings[0].location.line, s.warnings[0].location.column),
        pos_of(&xml, "<shape type=\"shapegroup\"")
    );
}

#[test]
fn shapes_and_emitters_not_supported_yet_are_clear_errors() {
    let xml = "<scene version=\"3.0.0\">\n  <emitter type=\"sunsky\"/></scene>";
    assert_err(
        &common::parse(xml).unwrap_err(),
        "emitter 'sunsky' is not supported yet",
        pos_of(xml, "sunsky"),
    );
    let xml = r#"<scene version="3.0.0">
  <bsdf type="diffuse" id="b"/>
  <shape type="sphere"><emitter type="area"><ref id="b" name="radiance"/></emitter></shape>
</scene>"#;
    assert_err(
        &common::parse(xml).unwrap_err(),
        "<ref id=\"b\"> must name a texture here",
        pos_of(xml, "<ref"),
    );
    let xml =
        "<scene version=\"3.0.0\">\n  <shape type=\"instance\"><ref id=\"nope\"/></shape></scene>";
    assert_err(
        &common::parse(xml).unwrap_err(),
        "reference to undefined id 'nope'",
        pos_of(xml, "nope"),
    );
}

#[test]
fn area_emitters_take_a_textured_radiance() {
    let xml = r#"<scene version="3.0.0">
  <texture type="checkerboard" id="t"/>
  <shape type="rectangle"><emitter type="area"><ref id="t" name="radiance"/></emitter></shape>
  <shape type="sphere"><emitter type="area"><texture type="checkerboard" name="radiance"/></emitter></shape>
  <shape type="sphere"><emitter type="area"><rgb name="radiance" value="2"/></emitter></shape>
</scene>"#;
    let s = common::parse(xml).unwrap();
    assert_eq!(s.shapes[0].emitter, Some(glam::Vec3::ONE));
    assert_eq!(s.shapes[0].emitter_texture, Some(0));
    assert_eq!(s.shapes[1].emitter_texture, Some(1));
    assert_eq!(s.shapes[2].emitter, Some(glam::Vec3::splat(2.0)));
    assert_eq!(s.shapes[2].emitter_texture, None);
}

/// `<ref>` resolves every kind of object Mitsuba lets a scene name by id: bsdfs (in shapes and
/// bsdf wrappers), textures (colour parameters, an area emitter's radiance, a projector's
/// irradiance), area emitters declared outside shapes (attached to shapes), media (in a shape's
/// interior/exterior; ignored with the media warning), shapegroups (in instances). A missing id
/// and a ref to the wrong kind are errors at the ref.
#[test]
fn refs_resolve_every_kind_mitsuba_allows() {
    let xml = r#"<scene version="3.0.0">
  <texture type="checkerboard" id="tex"/>
  <bsdf type="diffuse" id="b"><ref name="reflectance" id="tex"/></bsdf>
  <bsdf type="twosided" id="two"><ref id="b"/></bsdf>
  <emitter type="area" id="lamp"><rgb name="radiance" value="2, 3, 4"/></emitter>
  <emitter type="area" id="texlamp"><ref name="radiance" id="tex"/></emitter>
  <emitter type="projector"><ref name="irradiance" id="tex"/><float name="fov" value="30"/></emitter>
  <medium type="homogeneous" id="fog"/>
  <shape type="shapegroup" id="g"><shape type="sphere"><ref id="two"/></shape></shape>
  <shape type="instance"><ref id="g"/></shape>
  <shape type="sphere"><ref id="lamp"/><ref id="b"/><ref name="interior" id="fog"/></shape>
  <shape type="rectangle"><ref id="texlamp"/></shape>
</scene>"#;
    let s = common::parse(xml).unwrap();
    // The group's sphere is kept once, placed by the instance (not copied into the shapes).
    assert_eq!(s.shape_groups.len(), 1);
    assert_eq!(s.instances.len(), 1);
    assert_eq!(s.shapes.len(), 2);
    assert_eq!(s.shapes[0].emitter, Some(glam::Vec3::new(2.0, 3.0, 4.0)));
    assert_eq!(s.shapes[0].emitter_texture, None);
    assert!(s.shapes[0].bsdf.is_some());
    assert_eq!(s.shapes[1].emitter, Some(glam::Vec3::ONE));
    assert_eq!(s.shapes[1].emitter_texture, Some(0));
    assert!(matches!(
        s.lights[0],
        torrey_parser::Light::Projector {
            irradiance: torrey_parser::ColorParam::Texture(0),
            ..
        }
    ));
    // The sphere's interior is the medium it refers to.
    assert!(s.warnings.is_empty(), "{:?}", s.warnings);
    assert_eq!(s.shapes[0].interior, Some(0));

    let cases = [
        (
            "<scene version=\"3.0.0\">\n  <shape type=\"sphere\"><ref id=\"nope\"/></shape></scene>",
            "reference to undefined id 'nope'",
            "nope",
        ),
        (
            "<scene version=\"3.0.0\">\n  <texture type=\"checkerboard\" id=\"t\"/>\n  <shape type=\"sphere\"><ref id=\"t\"/></shape></scene>",
            "<ref id=\"t\"> in a shape must name a bsdf, an area emitter or a medium",
            "<ref",
        ),
        (
            "<scene version=\"3.0.0\">\n  <emitter type=\"area\" id=\"e\"/>\n  <shape type=\"sphere\"><emitter type=\"area\"/><ref id=\"e\"/></shape></scene>",
            "shape 'sphere' has more than one emitter",
            "<ref",
        ),
        (
            "<scene version=\"3.0.0\">\n  <bsdf type=\"diffuse\" id=\"b\"/>\n  <emitter type=\"projector\"><ref name=\"irradiance\" id=\"b\"/></emitter></scene>",
            "<ref id=\"b\"> must name a texture here",
            "<ref",
        ),
        (
            "<scene version=\"3.0.0\">\n  <emitter type=\"area\"/></scene>",
            "an area emitter must be nested inside a <shape>",
            "<emitter",
        ),
    ];
    for (xml, message, at) in cases {
        let e = common::parse(xml).unwrap_err();
        assert_err(&e, message, pos_of(xml, at));
    }
}

#[test]
fn spectrum_errors_point_at_the_value_or_file() {
    let xml = "<scene version=\"3.0.0\">\n  <emitter type=\"constant\"><spectrum name=\"radiance\" value=\"500:1, 400:2\"/></emitter></scene>";
    assert_err(
        &common::parse(xml).unwrap_err(),
        "the wavelengths of a spectrum must increase",
        pos_of(xml, "500:1"),
    );
    let dir = temp_dir("spd");
    write(&dir, "bad.spd", "400 1\n500 x\n");
    let xml = "<scene version=\"3.0.0\">\n  <emitter type=\"constant\"><spectrum name=\"radiance\" filename=\"bad.spd\"/></emitter></scene>";
    assert_err(
        &parse_in(&dir, xml).unwrap_err(),
        "in spectrum file 'bad.spd': line 2:",
        pos_of(xml, "bad.spd"),
    );
    let xml = "<scene version=\"3.0.0\">\n  <emitter type=\"constant\"><spectrum name=\"radiance\" filename=\"none.spd\"/></emitter></scene>";
    assert_err(
        &parse_in(&dir, xml).unwrap_err(),
        "cannot read spectrum file 'none.spd'",
        pos_of(xml, "none.spd"),
    );
    // Mitsuba 0.6's <blackbody> and Mitsuba 3's plugin form give the same colour.
    let a = parse_ok(
        r#"<scene version="3.0.0"><emitter type="constant"><blackbody name="radiance" temperature="4000" scale="2"/></emitter></scene>"#,
    );
    let b = parse_ok(
        r#"<scene version="3.0.0"><emitter type="constant"><spectrum type="blackbody" name="radiance"><float name="temperature" value="4000"/><float name="scale" value="2"/></spectrum></emitter></scene>"#,
    );
    let (Light::Constant { radiance: ra }, Light::Constant { radiance: rb }) =
        (&a.lights[0], &b.lights[0])
    else {
        panic!()
    };
    assert_eq!(ra, rb);
    assert!(ra.x > ra.z, "a 4000 K blackbody is warm: {ra}");
}

#[test]
fn spot_and_directional_emitters_read_mitsubas_parameters() {
    let s = parse_ok(
        r#"<scene version="3.0.0">
  <emitter type="spot"><rgb name="intensity" value="2, 3, 4"/><float name="cutoff_angle" value="40"/></emitter>
  <emitter type="directional"><vector name="direction" x="0" y="-2" z="0"/></emitter>
  <emitter type="directional"><transform name="to_world"><rotate x="1" angle="90"/></transform></emitter>
</scene>"#,
    );
    let Light::Spot {
        intensity,
        cutoff_angle,
        beam_width,
        to_world,
        texture: None,
    } = s.lights[0]
    else {
        panic!("{:?}", s.lights[0]);
    };
    assert_eq!(intensity, Vec3::new(2.0, 3.0, 4.0));
    assert!((cutoff_angle - 40f32.to_radians()).abs() < 1e-6);
    // beam_width defaults to three quarters of the cutoff.
    assert!((beam_width - 30f32.to_radians()).abs() < 1e-6);
    assert_eq!(to_world, glam::Mat4::IDENTITY);
    assert_eq!(
        s.lights[1],
        Light::Directional {
            direction: Vec3::new(0.0, -1.0, 0.0),
            irradiance: Vec3::ONE
        }
    );
    let Light::Directional { direction, .. } = s.lights[2] else {
        panic!("{:?}", s.lights[2]);
    };
    // +z turned 90 degrees about x points along -y.
    assert!(
        (direction - Vec3::new(0.0, -1.0, 0.0)).length() < 1e-6,
        "{direction}"
    );
}

#[test]
fn spot_and_directional_errors_name_the_parameter() {
    for (xml, message, at) in [
        (
            "<scene version=\"3.0.0\">\n  <emitter type=\"spot\"><float name=\"beam_width\" value=\"30\"/></emitter></scene>",
            "the spot light's beam_width must be in [0, cutoff_angle = 20] degrees, found 30",
            "30\"/>",
        ),
        (
            "<scene version=\"3.0.0\">\n  <emitter type=\"spot\"><float name=\"cutoff_angle\" value=\"0\"/></emitter></scene>",
            "the spot light's cutoff_angle must be in (0, 180] degrees, found 0",
            "0\"/>",
        ),
        (
            "<scene version=\"3.0.0\">\n  <emitter type=\"directional\"><vector name=\"direction\" x=\"1\"/><transform name=\"to_world\"/></emitter></scene>",
            "a directional emitter takes 'direction' or 'to_world', not both",
            "<transform",
        ),
        (
            "<scene version=\"3.0.0\">\n  <emitter type=\"spot\"><rgb name=\"texture\" value=\"1\"/></emitter></scene>",
            "a spot light's texture must be a spatially varying <texture> (bitmap, checkerboard), found <rgb>",
            "<rgb",
        ),
        (
            "<scene version=\"3.0.0\">\n  <emitter type=\"spot\"><transform name=\"to_world\"><scale value=\"0\"/></transform></emitter></scene>",
            "the spot light's to_world cannot place a light: it scales an axis by",
            "<transform",
        ),
        (
            "<scene version=\"3.0.0\">\n  <emitter type=\"directional\"><vector name=\"direction\"/></emitter></scene>",
            "the directional emitter's direction is",
            "<emitter",
        ),
    ] {
        let e = common::parse(xml).unwrap_err();
        assert_err(&e, message, pos_of(xml, at));
    }
}

#[test]
fn principled_parameters_and_defaults() {
    let xml = r#"<scene version="3.0.0">
  <bsdf type="principled" id="a"/>
  <bsdf type="principled" id="b"><float name="specular" value="0"/><float name="spec_trans" value="0.5"/>
    <texture type="checkerboard" name="metallic"/><float name="clearcoat_sampling_rate" value="0"/></bsdf>
  <bsdf type="principled" id="c"><float name="eta" value="1"/><float name="spec_trans" value="0"/></bsdf>
  <bsdf type="principledthin" id="d"><float name="diff_trans" value="1.5"/><float name="eta" value="1.33"/></bsdf>
</scene>"#;
    let s = parse_ok(xml);
    assert!(s.warnings.is_empty(), "{:?}", s.warnings);
    let BsdfKind::Principled(a) = &s.bsdfs[0].kind else {
        panic!("{:?}", s.bsdfs[0].kind)
    };
    // specular 0.5: η = 2 / (1 − √0.04) − 1 = 1.5.
    assert!((a.eta - 1.5).abs() < 1e-6, "{}", a.eta);
    assert_eq!(a.base_color, ColorParam::Constant(Vec3::splat(0.5)));
    assert_eq!(a.roughness, ColorParam::Constant(Vec3::splat(0.5)));
    assert_eq!(a.clearcoat_sampling_rate, 1.0);
    let BsdfKind::Principled(b) = &s.bsdfs[1].kind else {
        panic!()
    };
    // With transmission, specular 0 becomes 0.001 (η = 1 is not plausible), as in Mitsuba.
    let eta = 2.0 / (1.0 - (0.08f32 * 1e-3).sqrt()) - 1.0;
    assert!((b.eta - eta).abs() < 1e-6 && b.eta > 1.0, "{}", b.eta);
    assert!(matches!(b.metallic, ColorParam::Texture(_)));
    assert_eq!(b.clearcoat_sampling_rate, 0.0);
    let BsdfKind::Principled(c) = &s.bsdfs[2].kind else {
        panic!()
    };
    assert_eq!(c.eta, 1.0, "no transmission: η stays 1");
    let BsdfKind::PrincipledThin(d) = &s.bsdfs[3].kind else {
        panic!()
    };
    assert_eq!(d.diff_trans, ColorParam::Constant(Vec3::splat(1.5)));
    assert_eq!(d.eta, ColorParam::Constant(Vec3::splat(1.33)));
    assert_eq!(d.roughness, ColorParam::Constant(Vec3::splat(0.5)));
}

#[test]
fn principled_errors_point_at_the_problem() {
    for (xml, message, at) in [
        (
            "<scene version=\"3.0.0\">\n  <bsdf type=\"principled\"><float name=\"eta\" value=\"1.4\"/><float name=\"specular\" value=\"0.3\"/></bsdf></scene>",
            "bsdf 'principled': give either eta or specular, not both",
            "<bsdf",
        ),
        (
            "<scene version=\"3.0.0\">\n  <bsdf type=\"principled\"><float name=\"eta\" value=\"-2\"/></bsdf></scene>",
            "parameter 'eta' of bsdf 'principled' must be positive, found -2",
            "-2\"/>",
        ),
        (
            "<scene version=\"3.0.0\">\n  <bsdf type=\"principledthin\"><boolean name=\"sample_visible\" value=\"false\"/></bsdf></scene>",
            "sample_visible",
            "<boolean",
        ),
    ] {
        match common::parse(xml) {
            Err(e) => assert_err(&e, message, pos_of(xml, at)),
            Ok(s) => {
                // Unknown parameters are warnings, naming the parameter and its position.
                let w = s.warnings.iter().find(|w| w.message.contains(message));
                let w = w.unwrap_or_else(|| panic!("{message}: {:?}", s.warnings));
                assert_eq!((w.location.line, w.location.column), pos_of(xml, at), "{w}");
            }
        }
    }
}

/// Sensor options: the principal point offset, clip planes and filter parameters are read with
/// Mitsuba's names; thinlens has no principal point in Mitsuba (one warning, at the sensor, and
/// the offset is dropped).
#[test]
fn principal_point_clip_planes_and_filter_parameters() {
    let s = parse_ok(
        r#"<scene version="3.0.0"><sensor type="perspective">
  <float name="principal_point_offset_x" value="0.12"/><float name="principal_point_offset_y" value="-0.08"/>
  <float name="near_clip" value="3.1"/><float name="far_clip" value="7.5"/>
  <film type="hdrfilm"><rfilter type="mitchell"><float name="B" value="0.3"/><float name="C" value="0.35"/></rfilter></film>
</sensor></scene>"#,
    );
    assert_eq!(
        s.camera.principal_point_offset,
        glam::Vec2::new(0.12, -0.08)
    );
    assert_eq!((s.camera.near_clip, s.camera.far_clip), (3.1, 7.5));
    assert_eq!(s.film.filter, PixelFilter::Mitchell { b: 0.3, c: 0.35 });
    assert!(s.warnings.is_empty(), "{:?}", s.warnings);
    let xml = r#"<scene version="3.0.0"><sensor type="thinlens">
  <float name="aperture_radius" value="0.1"/><float name="focus_distance" value="4"/>
  <float name="principal_point_offset_x" value="0.2"/>
  <film type="hdrfilm"><rfilter type="catmullrom"/></film>
</sensor></scene>"#;
    let s = parse_ok(xml);
    assert_eq!(s.camera.principal_point_offset, glam::Vec2::ZERO);
    assert_eq!(s.film.filter, PixelFilter::CatmullRom);
    assert_eq!(s.warnings.len(), 1, "{:?}", s.warnings);
    let w = &s.warnings[0];
    assert_eq!(
        (w.location.line, w.location.column),
        pos_of(xml, "<sensor type")
    );
    assert!(
        w.message.contains("principal_point_offset is ignored"),
        "{w}"
    );
}

#[test]
fn disk_and_cylinder_parameters_and_errors() {
    let s = parse_ok(
        r#"<scene version="3.0.0">
  <shape type="disk"><boolean name="flip_normals" value="true"/></shape>
  <shape type="cylinder"><point name="p0" x="1" y="0" z="0"/><point name="p1" x="1" y="2" z="0"/><float name="radius" value="0.3"/></shape>
  <shape type="cylinder"/>
</scene>"#,
    );
    assert_eq!(s.shapes[0].geometry, torrey_parser::Geometry::Disk);
    assert!(s.shapes[0].flip_normals);
    assert_eq!(
        s.shapes[1].geometry,
        torrey_parser::Geometry::Cylinder {
            p0: Vec3::X,
            p1: Vec3::new(1.0, 2.0, 0.0),
            radius: 0.3
        }
    );
    assert_eq!(
        s.shapes[2].geometry,
        torrey_parser::Geometry::Cylinder {
            p0: Vec3::ZERO,
            p1: Vec3::Z,
            radius: 1.0
        }
    );
    let xml = "<scene version=\"3.0.0\">\n  <shape type=\"cylinder\"><float name=\"radius\" value=\"-1\"/></shape></scene>";
    assert_err(
        &common::parse(xml).unwrap_err(),
        "cylinder radius must be positive, found -1",
        pos_of(xml, "-1"),
    );
    let xml = "<scene version=\"3.0.0\">\n  <shape type=\"cylinder\">\n    <point name=\"p1\" x=\"0\" y=\"0\" z=\"0\"/></shape></scene>";
    assert_err(
        &common::parse(xml).unwrap_err(),
        "cylinder p0 and p1 must differ",
        pos_of(xml, "<point"),
    );
}

/// PLY attributes reach the scene; a mesh_attribute naming an attribute the shape lacks is an
/// error at the shape that names the texture; a name without `vertex_`/`face_` is refused.
#[test]
fn mesh_attribute_textures_are_checked_against_their_shapes() {
    let dir = temp_dir("mesh-attribute");
    write(
        &dir,
        "m.ply",
        "ply\nformat ascii 1.0\nelement vertex 3\nproperty float x\nproperty float y\nproperty float z\nproperty float r\nproperty float g\nproperty float b\nelement face 1\nproperty list uchar int vertex_indices\nproperty float w_0\nend_header\n0 0 0 1 0 0\n1 0 0 0 1 0\n0 1 0 0 0 1\n3 0 1 2 0.5\n",
    );
    let shape = |name: &str| {
        format!(
            "<scene version=\"3.0.0\">\n  <shape type=\"ply\"><string name=\"filename\" value=\"m.ply\"/>\n    <bsdf type=\"diffuse\"><texture type=\"mesh_attribute\" name=\"reflectance\"><string name=\"name\" value=\"{name}\"/></texture></bsdf></shape></scene>"
        )
    };
    let s = parse_in(&dir, &shape("vertex_color")).unwrap();
    let torrey_parser::Geometry::Mesh(m) = &s.shapes[0].geometry else {
        panic!("a mesh");
    };
    let names: Vec<_> = m.attributes.iter().map(|a| a.name.as_str()).collect();
    assert_eq!(names, ["vertex_color", "face_w"]);
    assert!(parse_in(&dir, &shape("face_w")).is_ok());
    let xml = shape("vertex_colour");
    let e = parse_in(&dir, &xml).unwrap_err();
    assert_err(
        &e,
        "shape 'ply' has no attribute 'vertex_colour' for the mesh_attribute texture at",
        pos_of(&xml, "<shape"),
    );
    assert!(e.message.contains("it has vertex_color, face_w"), "{e}");
    let xml = shape("color");
    assert_err(
        &parse_in(&dir, &xml).unwrap_err(),
        "invalid mesh attribute name 'color': it must start with 'vertex_' or 'face_'",
        pos_of(&xml, "color\"/>"),
    );
    // A three-channel attribute as a float parameter (Mitsuba: "eval_attribute_1(): Attribute
    // \"vertex_color\" requested but had size 3"); a one-channel one is fine.
    let rough = |name: &str| {
        format!(
            "<scene version=\"3.0.0\">\n  <shape type=\"ply\"><string name=\"filename\" value=\"m.ply\"/>\n    <bsdf type=\"roughconductor\"><texture type=\"mesh_attribute\" name=\"alpha\"><string name=\"name\" value=\"{name}\"/></texture></bsdf></shape></scene>"
        )
    };
    assert!(parse_in(&dir, &rough("face_w")).is_ok());
    let xml = rough("vertex_color");
    let e = parse_in(&dir, &xml).unwrap_err();
    assert_err(&e, "the mesh_attribute texture at", pos_of(&xml, "<shape"));
    assert!(
        e.message
            .contains("as a float parameter, but it has 3 channels"),
        "{e}"
    );
    // Through a referenced bsdf, on a shape that is not a mesh.
    let xml = "<scene version=\"3.0.0\">\n  <bsdf type=\"diffuse\" id=\"b\"><texture type=\"mesh_attribute\" name=\"reflectance\"><string name=\"name\" value=\"vertex_color\"/></texture></bsdf>\n  <shape type=\"sphere\"><ref id=\"b\"/></shape></scene>";
    let e = common::parse(xml).unwrap_err();
    assert_err(
        &e,
        "shape 'sphere' has no attribute 'vertex_color'",
        pos_of(xml, "<shape"),
    );
    assert!(e.message.contains("only meshes have attributes"), "{e}");
}
