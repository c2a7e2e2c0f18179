//! Mitsuba's `sdfgrid` shape and `rawconstant` texture as the parser reads them: parameters,
//! the `.vol` file (through `torrey_parser::vol`), and every bad input as an error at its place.

mod common;

use common::{assert_err, parse, parse_in, pos_of, temp_dir};
use glam::Vec3;
use torrey_parser::vol::write_vol;
use torrey_parser::{BsdfKind, ColorParam, Geometry};

const UNIT: [[f32; 3]; 2] = [[0.0; 3], [1.0; 3]];

/// A sphere's distance on an n^3 grid (radius 0.3 around the centre).
fn sphere(n: u32) -> Vec<f32> {
    let mut v = Vec::new();
    for k in 0..n {
        for j in 0..n {
            for i in 0..n {
                let p = Vec3::new(i as f32, j as f32, k as f32) / (n - 1) as f32;
                v.push((p - Vec3::splat(0.5)).length() - 0.3);
            }
        }
    }
    v
}

fn sdf_xml(file: &str, extra: &str) -> String {
    format!(
        "<scene version=\"3.0.0\">\n  <shape type=\"sdfgrid\">\n    <string name=\"filename\" value=\"{file}\"/>{extra}\n  </shape>\n</scene>"
    )
}

#[test]
fn sdfgrid_reads_a_vol_file() {
    let dir = temp_dir("sdfgrid");
    // The header's box is ignored: the grid spans [0, 1]^3.
    std::fs::write(
        dir.join("s.vol"),
        write_vol([6, 6, 6], 1, [[-5.0; 3], [5.0; 3]], &sphere(6)),
    )
    .unwrap();
    let s = parse_in(&dir, &sdf_xml("s.vol", "")).unwrap_or_else(|e| panic!("{e}"));
    let Geometry::SdfGrid(g) = &s.shapes[0].geometry else {
        panic!("{:?}", s.shapes[0].geometry)
    };
    assert_eq!(g.size, [6, 6, 6]);
    assert!(g.smooth_normals, "smooth is the default");
    assert_eq!(g.values, sphere(6));
    assert!(g.surface_voxels > 0 && g.surface_voxels < 125);
    assert!(s.warnings.is_empty(), "{:?}", s.warnings);
    // analytic normals; a grid whose sides differ; flip_normals is not a parameter (Mitsuba
    // reports it unreferenced): warned about and ignored.
    let mut values = Vec::new();
    for k in 0..4 {
        for j in 0..3 {
            for i in 0..5 {
                values.push(i as f32 + j as f32 * 0.1 + k as f32 * 0.01 - 2.0);
            }
        }
    }
    std::fs::write(dir.join("r.vol"), write_vol([5, 3, 4], 1, UNIT, &values)).unwrap();
    let xml = sdf_xml(
        "r.vol",
        "\n    <string name=\"normals\" value=\"analytic\"/>\n    <boolean name=\"flip_normals\" value=\"true\"/>",
    );
    let s = parse_in(&dir, &xml).unwrap_or_else(|e| panic!("{e}"));
    let Geometry::SdfGrid(g) = &s.shapes[0].geometry else {
        panic!()
    };
    assert_eq!((g.size, g.smooth_normals), ([5, 3, 4], false));
    assert_eq!(g.value(4, 2, 3), 4.0 + 0.2 + 0.03 - 2.0);
    assert!(!s.shapes[0].flip_normals);
    assert_eq!(s.warnings.len(), 1, "{:?}", s.warnings);
    assert!(
        s.warnings[0].message.contains("flip_normals"),
        "{}",
        s.warnings[0]
    );
    // A rotation: rendered, with Mitsuba's warning about it.
    let xml = sdf_xml(
        "s.vol",
        "<transform name=\"to_world\"><rotate y=\"1\" angle=\"30\"/></transform>",
    );
    let s = parse_in(&dir, &xml).unwrap_or_else(|e| panic!("{e}"));
    assert!(
        s.warnings[0].message.contains("rotates"),
        "{:?}",
        s.warnings
    );
    // Bytes after the data: warned about, as Mitsuba ignores them.
    let mut bytes = write_vol([6, 6, 6], 1, UNIT, &sphere(6));
    bytes.extend_from_slice(&[0; 12]);
    std::fs::write(dir.join("t.vol"), bytes).unwrap();
    let s = parse_in(&dir, &sdf_xml("t.vol", "")).unwrap_or_else(|e| panic!("{e}"));
    assert!(s.warnings[0]
        .message
        .contains("12 bytes after its last value"));
}

/// Bad grids and parameters: each an error at the file name (or the parameter), never a panic
/// or a huge allocation.
#[test]
fn sdfgrid_errors() {
    let dir = temp_dir("sdfgrid-errors");
    let file = |name: &str, bytes: Vec<u8>| std::fs::write(dir.join(name), bytes).unwrap();
    let check = |name: &str, message: &str| {
        let xml = sdf_xml(name, "");
        let e = parse_in(&dir, &xml).unwrap_err();
        assert_err(
            &e,
            &format!("in sdfgrid file '{name}': {message}"),
            pos_of(&xml, name),
        );
    };
    let mut lying = write_vol([4, 4, 4], 1, UNIT, &sphere(4));
    lying[8..12].copy_from_slice(&1000i32.to_le_bytes());
    file("lying.vol", lying);
    check(
        "lying.vol",
        "the header announces 1000 x 4 x 4 samples of 1 channel(s) = 16000 values",
    );
    let mut huge = write_vol([4, 4, 4], 1, UNIT, &sphere(4));
    for at in [8, 12, 16] {
        huge[at..at + 4].copy_from_slice(&i32::MAX.to_le_bytes());
    }
    file("huge.vol", huge);
    check(
        "huge.vol",
        "the header announces 2147483647 x 2147483647 x 2147483647",
    );
    file(
        "short.vol",
        write_vol([4, 4, 4], 1, UNIT, &sphere(4))[..100].to_vec(),
    );
    check("short.vol", "the header announces 4 x 4 x 4 samples");
    let mut nan = sphere(4);
    nan[21] = f32::NAN;
    file("nan.vol", write_vol([4, 4, 4], 1, UNIT, &nan));
    check(
        "nan.vol",
        "value 21 (sample x 1, y 1, z 1, channel 0) is NaN",
    );
    file("rgb.vol", write_vol([2, 2, 2], 3, UNIT, &[0.5; 24]));
    check("rgb.vol", "it has 3 channels; an sdfgrid needs 1");
    file("flat.vol", write_vol([4, 1, 4], 1, UNIT, &[1.0; 16]));
    check(
        "flat.vol",
        "it has 4 x 1 x 4 samples; an sdfgrid needs at least 2 along each axis",
    );
    file("empty.vol", write_vol([3, 3, 3], 1, UNIT, &[1.0; 27]));
    check("empty.vol", "no voxel has corner samples of both signs");
    file(
        "text.vol",
        b"not a volume at all, but long enough for a header......".to_vec(),
    );
    check("text.vol", "not a .vol file: it does not start with 'VOL'");

    file("s.vol", write_vol([4, 4, 4], 1, UNIT, &sphere(4)));
    let xml = sdf_xml("s.vol", "\n    <string name=\"normals\" value=\"bumpy\"/>");
    assert_err(
        &parse_in(&dir, &xml).unwrap_err(),
        "unknown normals mode 'bumpy' of shape 'sdfgrid'",
        pos_of(&xml, "bumpy"),
    );
    let xml = sdf_xml("s.vol", "\n    <emitter type=\"area\"/>");
    assert_err(
        &parse_in(&dir, &xml).unwrap_err(),
        "shape 'sdfgrid' cannot be an area emitter",
        pos_of(&xml, "<emitter"),
    );
    let xml = sdf_xml("nowhere.vol", "");
    assert_err(
        &parse_in(&dir, &xml).unwrap_err(),
        "sdfgrid file 'nowhere.vol' not found",
        pos_of(&xml, "nowhere"),
    );
    let xml = "<scene version=\"3.0.0\">\n  <shape type=\"sdfgrid\"/>\n</scene>";
    assert_err(
        &parse_in(&dir, xml).unwrap_err(),
        "missing required parameter 'filename' of shape 'sdfgrid'",
        pos_of(xml, "<shape"),
    );
    // The values of all grids together are capped (--limit volume_values).
    let limits = torrey_parser::Limits {
        volume_values: 100,
        ..Default::default()
    };
    file("big.vol", write_vol([5, 5, 5], 1, UNIT, &sphere(5)));
    let xml = sdf_xml("big.vol", "");
    let e = torrey_parser::parse_scene_str_with_limits(&xml, &dir.join("scene.xml"), &[], &limits)
        .unwrap_err();
    assert!(
        e.message
            .contains("more than the limit of 100 (raise with --limit volume_values=N)"),
        "{e}"
    );
}

fn reflectance(kind: &BsdfKind) -> &ColorParam {
    match kind {
        BsdfKind::Diffuse { reflectance } => reflectance,
        k => panic!("{k:?}"),
    }
}

#[test]
fn rawconstant_values_are_put_in_place() {
    let s = common::parse_ok(
        r#"<scene version="3.0.0">
  <texture type="rawconstant" id="grey"><float name="value" value="0.25"/></texture>
  <shape type="sphere"><bsdf type="diffuse"><ref name="reflectance" id="grey"/></bsdf></shape>
  <shape type="sphere"><bsdf type="diffuse">
    <texture type="rawconstant" name="reflectance"><vector name="value" value="1.5, -0.5, 0.25"/></texture>
  </bsdf></shape>
  <shape type="sphere"><bsdf type="roughconductor">
    <texture type="rawconstant" name="alpha"><float name="value" value="0.3"/></texture>
    <texture type="rawconstant" name="k"><point name="value" value="3, 2, 1"/></texture>
  </bsdf></shape>
  <shape type="sphere">
    <emitter type="area"><texture type="rawconstant" name="radiance"><vector name="value" value="4, 5, 6"/></texture></emitter>
  </shape>
</scene>"#,
    );
    let bsdf = |i: usize| &s.bsdfs[s.shapes[i].bsdf.unwrap()].kind;
    assert_eq!(
        reflectance(bsdf(0)),
        &ColorParam::Constant(Vec3::splat(0.25))
    );
    // Raw: no range check, no "above 1" warning, negative values kept.
    assert_eq!(
        reflectance(bsdf(1)),
        &ColorParam::Constant(Vec3::new(1.5, -0.5, 0.25))
    );
    assert!(s.warnings.is_empty(), "{:?}", s.warnings);
    match bsdf(2) {
        BsdfKind::RoughConductor { alpha_u, k, .. } => {
            assert_eq!(alpha_u, &ColorParam::Constant(Vec3::splat(0.3)));
            assert_eq!(k, &ColorParam::Constant(Vec3::new(3.0, 2.0, 1.0)));
        }
        k => panic!("{k:?}"),
    }
    assert_eq!(s.shapes[3].emitter, Some(Vec3::new(4.0, 5.0, 6.0)));
    assert_eq!(s.shapes[3].emitter_texture, None);
}

#[test]
fn rawconstant_errors() {
    let tex = |inner: &str| {
        format!(
            "<scene version=\"3.0.0\">\n  <shape type=\"sphere\"><bsdf type=\"diffuse\">\n    <texture type=\"rawconstant\" name=\"reflectance\">{inner}</texture>\n  </bsdf></shape>\n</scene>"
        )
    };
    // Mitsuba: "parameter "value" has incorrect type, expected `float` or 3D `vector`".
    let xml = tex("<rgb name=\"value\" value=\"1, 2, 3\"/>");
    assert_err(
        &parse(&xml).unwrap_err(),
        "parameter 'value' of texture 'rawconstant' must be a <float> or a 3D <vector> (as in Mitsuba), found <rgb>",
        pos_of(&xml, "<rgb"),
    );
    let xml = tex("");
    assert_err(
        &parse(&xml).unwrap_err(),
        "missing required parameter 'value' of texture 'rawconstant'",
        pos_of(&xml, "<texture"),
    );
    let xml = tex("<float name=\"value\" value=\"nan\"/>");
    assert_err(
        &parse(&xml).unwrap_err(),
        "'nan' is not a finite number in parameter 'value' of texture 'rawconstant'",
        pos_of(&xml, "nan"),
    );
    // Three channels where a float is read (Mitsuba fails at render time: "eval_1() is not
    // defined for 3D-valued textures").
    let xml = "<scene version=\"3.0.0\">\n  <shape type=\"sphere\"><bsdf type=\"roughconductor\">\n    <texture type=\"rawconstant\" name=\"alpha\"><vector name=\"value\" value=\"0.1, 0.2, 0.3\"/></texture>\n  </bsdf></shape>\n</scene>";
    assert_err(
        &parse(xml).unwrap_err(),
        "'alpha' of bsdf 'roughconductor' is a float parameter, but this rawconstant texture has three channels",
        pos_of(xml, "<texture"),
    );
    // A spot light's texture must vary (a constant belongs in its intensity).
    let xml = "<scene version=\"3.0.0\">\n  <emitter type=\"spot\">\n    <texture type=\"rawconstant\" name=\"texture\"><float name=\"value\" value=\"1\"/></texture>\n  </emitter>\n</scene>";
    assert_err(
        &parse(xml).unwrap_err(),
        "a spot light's texture must be spatially varying (bitmap, checkerboard), not a rawconstant",
        pos_of(xml, "<emitter"),
    );
}
