//! Relative file names found as Mitsuba 3.9.1's file resolver finds them (`<include>`, `<path>`,
//! plugin file names, spectrum files): the module docs of `crates/parser/src/include.rs` give
//! the rules. Every expectation here was checked by loading the same layout with Mitsuba 3.9.1
//! (`mi.load_file`, `scalar_rgb`) and looking at which copy of each file it took.

mod common;

use common::{parse_in, temp_dir};
use std::path::{Path, PathBuf};
use torrey_parser::{load_scene, BsdfKind, ColorParam, Geometry, Scene};

fn write(dir: &Path, name: &str, text: &str) {
    let p = dir.join(name);
    std::fs::create_dir_all(p.parent().unwrap()).unwrap();
    std::fs::write(p, text).unwrap();
}

/// One triangle of size `size`: the size tells which copy of a file was loaded.
fn triangle(size: u32) -> String {
    format!("v 0 0 0\nv {size} 0 0\nv 0 {size} 0\nf 1 2 3\n")
}

/// The size of the triangle shape `i` was loaded from.
fn size_of(s: &Scene, i: usize) -> f32 {
    match &s.shapes[i].geometry {
        Geometry::Mesh(m) => m.positions.iter().map(|p| p.x).fold(0.0, f32::max),
        g => panic!("shape {i} is not a mesh: {g:?}"),
    }
}

fn layout() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("../../tests/scenes/resolver/docs/scenes/layout.xml")
}

/// tests/scenes/resolver: Mitsuba's documentation layout, where an included file's
/// `<path value="../../common"/>` does not exist next to it (torrey used to stop with "folder
/// '../../common' does not exist"). Mitsuba 3.9.1 takes common/meshes/plate.obj for both
/// shapes, include/part.xml, and common/spectra/grey.spd.
#[test]
fn mitsuba_documentation_layout() {
    let s = load_scene(&layout(), &[]).unwrap_or_else(|e| panic!("{e}"));
    assert_eq!(s.shapes.len(), 2);
    // Shape 0 is the included one (the include comes first), shape 1 the scene file's.
    assert_eq!(
        size_of(&s, 0),
        1.0,
        "included file's plate: common/, not include/"
    );
    assert_eq!(
        size_of(&s, 1),
        1.0,
        "scene file's plate: its <path> before its folder"
    );
    assert!(
        s.bsdfs
            .iter()
            .any(|b| b.id.as_deref() == Some("part_include")),
        "the include's own include is looked for next to it first"
    );
    assert!(!s
        .bsdfs
        .iter()
        .any(|b| b.id.as_deref() == Some("part_scenes")));
    let bsdf = &s.bsdfs[s.shapes[0].bsdf.unwrap()];
    let BsdfKind::Diffuse {
        reflectance: ColorParam::Constant(c),
    } = &bsdf.kind
    else {
        panic!("{bsdf:?}")
    };
    // Mitsuba 3.9.1: (0.248836, 0.249939, 0.248727) from common/spectra/grey.spd (flat 0.25);
    // the copy next to the included file is flat 0.75.
    assert!(
        (c.x - 0.2488).abs() < 2e-3 && (c.y - 0.2499).abs() < 2e-3,
        "{c}"
    );
    for f in &s.files {
        assert!(
            !f.to_string_lossy().contains("include/meshes")
                && !f.to_string_lossy().contains("include/spectra"),
            "{}",
            f.display()
        );
    }
}

/// The rules one by one, in a temporary copy of the same shape of layout.
#[test]
fn resolver_rules() {
    let root = temp_dir("resolver");
    let scenes = root.join("docs/scenes");
    write(&root, "common/meshes/a.obj", &triangle(1));
    write(&scenes, "meshes/a.obj", &triangle(2));
    write(&scenes, "include/meshes/a.obj", &triangle(3));
    write(&root, "docs/common/meshes/a.obj", &triangle(4));
    // An included file's shape takes the scene folder's copy (2): not the one next to it (3),
    // not the one in its own <path> folder (4; include/../../common exists here).
    write(
        &scenes,
        "include/inc.xml",
        r#"<scene version="3.0.0">
  <path value="../../common"/>
  <shape type="obj"><string name="filename" value="meshes/a.obj"/></shape>
</scene>"#,
    );
    let main = r#"<scene version="3.0.0">
  <include filename="include/inc.xml"/>
  <shape type="obj"><string name="filename" value="meshes/a.obj"/></shape>
</scene>"#;
    let s = parse_in(&scenes, main).unwrap_or_else(|e| panic!("{e}"));
    assert_eq!((size_of(&s, 0), size_of(&s, 1)), (2.0, 2.0));

    // With the scene folder's copy gone, Mitsuba fails: neither the included file's folder nor
    // its <path> count for plugin file names. The message says where the file is.
    std::fs::remove_file(scenes.join("meshes/a.obj")).unwrap();
    let e = parse_in(&scenes, main).unwrap_err();
    assert!(e.location.file.ends_with("include/inc.xml"), "{e}");
    assert!(
        e.message
            .starts_with("mesh file 'meshes/a.obj' not found (looked for '"),
        "{e}"
    );
    assert!(e.message.contains("it is next to the included file"), "{e}");
    write(&scenes, "meshes/a.obj", &triangle(2));

    // A <path> of the scene file comes before its folder, wherever it stands (1, not 2).
    let s = parse_in(
        &scenes,
        r#"<scene version="3.0.0">
  <shape type="obj"><string name="filename" value="meshes/a.obj"/></shape>
  <path value="../../common"/>
</scene>"#,
    )
    .unwrap_or_else(|e| panic!("{e}"));
    assert_eq!(size_of(&s, 0), 1.0);
    // Later <path>s come first.
    let s = parse_in(
        &scenes,
        r#"<scene version="3.0.0">
  <path value="../../common"/>
  <path value="../common"/>
  <shape type="obj"><string name="filename" value="meshes/a.obj"/></shape>
</scene>"#,
    )
    .unwrap_or_else(|e| panic!("{e}"));
    assert_eq!(size_of(&s, 0), 4.0);

    // An include is looked for next to the file holding it before the <path> folders.
    write(
        &root,
        "common/include/inc.xml",
        r#"<scene version="3.0.0"><bsdf type="diffuse" id="from_common"/></scene>"#,
    );
    let with_path = r#"<scene version="3.0.0">
  <path value="../../common"/>
  <include filename="include/inc.xml"/>
</scene>"#;
    let s = parse_in(&scenes, with_path).unwrap_or_else(|e| panic!("{e}"));
    assert!(!s
        .bsdfs
        .iter()
        .any(|b| b.id.as_deref() == Some("from_common")));
    // ... and then in them; a <path> after the include does not count for it.
    std::fs::rename(scenes.join("include/inc.xml"), root.join("inc.xml.bak")).unwrap();
    let s = parse_in(&scenes, with_path).unwrap_or_else(|e| panic!("{e}"));
    assert!(s
        .bsdfs
        .iter()
        .any(|b| b.id.as_deref() == Some("from_common")));
    let after = r#"<scene version="3.0.0">
  <include filename="include/inc.xml"/>
  <path value="../../common"/>
</scene>"#;
    let e = parse_in(&scenes, after).unwrap_err();
    assert!(
        e.message
            .starts_with("cannot read included file 'include/inc.xml': not found"),
        "{e}"
    );
    std::fs::rename(root.join("inc.xml.bak"), scenes.join("include/inc.xml")).unwrap();

    // An include inside an included file: next to that file first, then the including file's
    // folder.
    write(
        &scenes,
        "include/outer.xml",
        r#"<scene version="3.0.0"><include filename="sub.xml"/></scene>"#,
    );
    write(
        &scenes,
        "include/sub.xml",
        r#"<scene version="3.0.0"><bsdf type="diffuse" id="sub_in_include"/></scene>"#,
    );
    write(
        &scenes,
        "sub.xml",
        r#"<scene version="3.0.0"><bsdf type="diffuse" id="sub_in_scenes"/></scene>"#,
    );
    let nested = r#"<scene version="3.0.0"><include filename="include/outer.xml"/></scene>"#;
    let s = parse_in(&scenes, nested).unwrap_or_else(|e| panic!("{e}"));
    assert_eq!(s.bsdfs[0].id.as_deref(), Some("sub_in_include"));
    std::fs::remove_file(scenes.join("include/sub.xml")).unwrap();
    let s = parse_in(&scenes, nested).unwrap_or_else(|e| panic!("{e}"));
    assert_eq!(s.bsdfs[0].id.as_deref(), Some("sub_in_scenes"));

    // A spectrum file in an included file is not looked for next to it (Mitsuba 3.9.1:
    // "file does not exist").
    write(&scenes, "include/s.spd", "400 0.5\n700 0.5\n");
    write(
        &scenes,
        "include/spec.xml",
        r#"<scene version="3.0.0">
  <bsdf type="diffuse"><spectrum name="reflectance" filename="s.spd"/></bsdf>
</scene>"#,
    );
    let e = parse_in(
        &scenes,
        r#"<scene version="3.0.0"><include filename="include/spec.xml"/></scene>"#,
    )
    .unwrap_err();
    assert!(
        e.message
            .starts_with("cannot read spectrum file 's.spd': not found"),
        "{e}"
    );
}

/// `<path>` errors: a folder found nowhere, and a `<path>` inside an object (Mitsuba: "path
/// can only be child of root").
#[test]
fn path_errors() {
    let dir = temp_dir("resolver-errors");
    let xml = "<scene version=\"3.0.0\">\n  <path value=\"../../nowhere\"/></scene>";
    let e = parse_in(&dir, xml).unwrap_err();
    assert!(
        e.message
            .starts_with("<path> folder '../../nowhere' does not exist (looked for '"),
        "{e}"
    );
    assert_eq!((e.location.line, e.location.column), (2, 16));
    std::fs::create_dir_all(dir.join("sub")).unwrap();
    let xml = "<scene version=\"3.0.0\">\n  <shape type=\"sphere\">\n    <path value=\"sub\"/>\n  </shape>\n</scene>";
    let e = parse_in(&dir, xml).unwrap_err();
    assert!(
        e.message
            .starts_with("<path> must be a direct child of <scene>"),
        "{e}"
    );
    assert_eq!((e.location.line, e.location.column), (3, 5));
    // In an included file that is itself included inside an object, a <path> at its top level
    // is fine (Mitsuba reads each file with its own root).
    write(
        &dir,
        "inner.xml",
        r#"<scene version="3.0.0"><path value="sub"/><bsdf type="diffuse"/></scene>"#,
    );
    parse_in(
        &dir,
        r#"<scene version="3.0.0"><shape type="sphere"><include filename="inner.xml"/></shape></scene>"#,
    )
    .unwrap_or_else(|e| panic!("{e}"));
}
