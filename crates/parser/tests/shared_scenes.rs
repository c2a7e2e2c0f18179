//! Loads every third-party scene in ../shared (skipped with a note when the data kit is absent).

use std::path::{Path, PathBuf};
use torrey_parser::{load_scene, BsdfKind, ColorParam, Dialect, Geometry, Light};

fn shared() -> Option<PathBuf> {
    let p = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../../shared");
    if p.is_dir() {
        Some(p)
    } else {
        eprintln!(
            "note: {} is absent; skipping shared-scene tests",
            p.display()
        );
        None
    }
}

fn xml_files(dir: &Path, out: &mut Vec<PathBuf>) {
    for e in std::fs::read_dir(dir).unwrap() {
        let p = e.unwrap().path();
        if p.is_dir() {
            xml_files(&p, out);
        } else if p.extension().is_some_and(|x| x == "xml") {
            out.push(p);
        }
    }
}

#[test]
fn every_torrey_scene_loads() {
    let Some(shared) = shared() else { return };
    let mut files = Vec::new();
    xml_files(&shared.join("scenes/torrey"), &mut files);
    files.sort();
    assert!(files.len() >= 30, "found only {} scenes", files.len());
    for f in &files {
        let result = load_scene(f, &[]);
        if f.ends_with("living-room-Wig42/scene_bgonly.xml") {
            let e = result.expect_err("scene_bgonly.xml references missing meshes");
            // Mesh015 is the first absent mesh in document order.
            assert!(
                e.message
                    .starts_with("mesh file 'models/Mesh015.obj' not found"),
                "{e}"
            );
            assert_eq!((e.location.line, e.location.column), (207, 34));
            continue;
        }
        let scene = result.unwrap_or_else(|e| panic!("{e}"));
        // Every course scene uses only plugins the course's renderer reads: all are read
        // with the course's rules (both sides shaded, the 0.5 grey sky without <background>).
        assert_eq!(
            scene.dialect,
            Dialect::Torrey,
            "{}: {}",
            f.display(),
            scene.dialect_reason
        );
        assert!(
            scene
                .dialect_reason
                .contains("one the torrey course's renderer reads"),
            "{}",
            scene.dialect_reason
        );
        assert!(!scene.shapes.is_empty(), "{}", f.display());
        for w in &scene.warnings {
            eprintln!("{w}");
        }
    }
}

#[test]
fn torrey_scene_details() {
    let Some(shared) = shared() else { return };
    let s = load_scene(
        &shared.join("scenes/torrey/texture_test/texture_scaled.xml"),
        &[],
    )
    .unwrap();
    // Nothing only the torrey course has, but only plugins the course reads: the course's
    // rules, so its 0.5 grey environment follows the point light...
    assert_eq!(s.dialect, Dialect::Torrey, "{}", s.dialect_reason);
    assert_eq!(s.lights.len(), 2);
    assert!(
        matches!(s.lights[1], Light::Constant { radiance } if radiance == glam::Vec3::splat(0.5))
    );
    // ... unless Mitsuba's rules are asked for: then no grey sky.
    let forced = torrey_parser::load_scene_with(
        &shared.join("scenes/torrey/texture_test/texture_scaled.xml"),
        &torrey_parser::LoadOptions {
            dialect: Some(Dialect::Mitsuba3),
            ..Default::default()
        },
    )
    .unwrap();
    assert!(forced.dialect_reason.starts_with("forced"));
    assert_eq!(forced.lights.len(), 1);
    let torrey_parser::TextureKind::Bitmap(b) = &s.textures[0].kind else {
        panic!()
    };
    let uv = b.to_uv.transform_point2(glam::Vec2::new(0.5, 0.25));
    assert!((uv - glam::Vec2::new(2.2, 1.3)).length() < 1e-6, "{uv}");
    assert!(b.filename.is_absolute() && b.filename.ends_with("grid.exr"));

    let room = load_scene(
        &shared.join("scenes/torrey/living-room-Wig42/scene_bgonly_available.xml"),
        &[],
    )
    .unwrap();
    assert_eq!(room.integrator.max_depth(), 2);
    assert_eq!(room.integrator.type_name, "direct");
    assert!(room
        .bsdfs
        .iter()
        .any(|b| b.two_sided && b.id.as_deref() == Some("Floor")));
    // The interior media are read (its `direct` integrator ignores them, as Mitsuba's does).
    assert_eq!(room.media.len(), 2);
    let tris: usize = room
        .shapes
        .iter()
        .map(|s| match &s.geometry {
            Geometry::Mesh(m) => m.indices.len(),
            _ => 0,
        })
        .sum();
    assert!(tris > 100_000, "{tris}");
}

#[test]
fn matpreview_mitsuba3_scene() {
    let Some(shared) = shared() else { return };
    let path = shared.join("scenes/mitsuba/matpreview/matpreview.xml");
    let s = load_scene(&path, &[("spp".into(), "16".into())]).unwrap();
    assert_eq!(s.dialect, Dialect::Mitsuba3);
    assert_eq!(s.sampler.sample_count, 16);
    assert_eq!((s.film.width, s.film.height), (683, 512));
    assert_eq!(s.shapes.len(), 3);
    assert_eq!(
        s.lights.len(),
        1,
        "no implicit background in Mitsuba 3 scenes"
    );
    let Light::Envmap { scale, .. } = &s.lights[0] else {
        panic!()
    };
    assert_eq!(*scale, 3.0);
    for shape in &s.shapes {
        let Geometry::Mesh(m) = &shape.geometry else {
            panic!()
        };
        assert!(!m.indices.is_empty() && m.positions.len() == m.normals.len());
    }
    let plastic = &s.bsdfs[s.shapes[2].bsdf.unwrap()];
    match &plastic.kind {
        BsdfKind::Plastic {
            reflectance: ColorParam::Constant(c),
            eta,
            ..
        } => {
            assert!((c.x - 0.94).abs() < 1e-6);
            assert!((eta - 1.9 / 1.000277).abs() < 1e-6);
        }
        k => panic!("{k:?}"),
    }
    // Mitsuba's plastic in a Mitsuba 3 scene: nothing to warn about.
    assert!(!s.warnings.iter().any(|w| w.message.contains("plastic")));
}

#[test]
fn shared_ply_meshes() {
    let Some(shared) = shared() else { return };
    let dir = shared.join("meshes");
    for (name, verts, faces) in [
        ("teapot.ply", 1177, 2256),
        ("bunny_lowres.ply", 453, 948),
        ("sphere.ply", 422, 840),
    ] {
        let xml = format!(
            r#"<scene version="3.0.0"><shape type="ply"><string name="filename" value="{name}"/></shape></scene>"#
        );
        let s = torrey_parser::parse_scene_str(&xml, &dir.join("scene.xml"), &[]).unwrap();
        let Geometry::Mesh(m) = &s.shapes[0].geometry else {
            panic!()
        };
        assert_eq!(
            (m.positions.len(), m.indices.len()),
            (verts, faces),
            "{name}"
        );
        assert_eq!(m.normals.len(), verts);
    }
}
