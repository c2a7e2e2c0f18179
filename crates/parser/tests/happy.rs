//! Happy-path parsing of small inline scenes, checked against hand-computed values.

mod common;
use common::*;
use glam::{Mat4, Vec2, Vec3};
use std::path::Path;
use torrey_parser::*;

fn close(a: Vec3, b: Vec3) -> bool {
    (a - b).length() < 1e-5
}

const CAMERA: &str = r#"<scene version="0.6.0">
  <sensor type="perspective">
    <string name="fovAxis" value="y"/>
    <float name="fov" value="45"/>
    <transform name="toWorld">
      <lookAt origin="0, 0, 0" target="0, 0, -1" up="0, 1, 0"/>
    </transform>
    <sampler type="independent"><integer name="sampleCount" value="64"/></sampler>
    <film type="hdrfilm">
      <integer name="width" value="640"/>
      <integer name="height" value="480"/>
      <rfilter type="gaussian"/>
    </film>
  </sensor>
</scene>"#;

#[test]
fn lookat_frame_matches_mitsuba() {
    let s = parse_ok(CAMERA);
    let m = s.camera.to_world;
    // left = normalize(up x d) = (-1, 0, 0): camera +x maps to world -x.
    assert!(close(
        m.transform_vector3(Vec3::X),
        Vec3::new(-1.0, 0.0, 0.0)
    ));
    assert!(close(m.transform_vector3(Vec3::Y), Vec3::Y));
    assert!(close(
        m.transform_vector3(Vec3::Z),
        Vec3::new(0.0, 0.0, -1.0)
    ));
    assert_eq!(s.camera.fov_axis, FovAxis::Y);
    assert_eq!(s.camera.fov_degrees, 45.0);
    assert_eq!(s.sampler.sample_count, 64);
    assert_eq!((s.film.width, s.film.height), (640, 480));
    assert_eq!(s.film.filter, PixelFilter::Gaussian { stddev: 0.5 });
    assert_eq!(
        s.integrator,
        Integrator {
            type_name: "path".into(),
            kind: IntegratorKind::Path(PathParams {
                max_depth: -1,
                rr_depth: 5,
                hide_emitters: false,
            }),
            aovs: None,
        }
    );
    assert!(s.warnings.is_empty(), "{:?}", s.warnings);
}

#[test]
fn lookat_with_tilted_up_is_orthonormal() {
    let xml = r#"<scene version="3.0.0"><sensor type="perspective"><transform name="to_world">
        <lookat origin="1, 2, 3" target="4, 6, 3" up="0, 0.3, 1"/></transform></sensor></scene>"#;
    let m = parse_ok(xml).camera.to_world;
    let d = Vec3::new(0.6, 0.8, 0.0);
    assert!(close(m.transform_vector3(Vec3::Z), d));
    assert!(close(
        m.transform_point3(Vec3::ZERO),
        Vec3::new(1.0, 2.0, 3.0)
    ));
    let left = Vec3::new(0.0, 0.3, 1.0).cross(d).normalize();
    assert!(close(m.transform_vector3(Vec3::X), left));
    assert!(close(m.transform_vector3(Vec3::Y), d.cross(left)));
}

#[test]
fn transform_ops_compose_in_document_order() {
    let xml = r#"<scene version="0.6.0"><shape type="sphere"><transform name="toWorld">
        <scale value="2"/>
        <rotate z="1" angle="90"/>
        <translate x="1" y="0" z="0"/>
    </transform></shape></scene>"#;
    let m = parse_ok(xml).shapes[0].to_world;
    // (1,0,0) -> scale 2 -> (2,0,0) -> rotate 90 about z -> (0,2,0) -> translate -> (1,2,0)
    assert!(close(m.transform_point3(Vec3::X), Vec3::new(1.0, 2.0, 0.0)));
    let xml = r#"<scene version="0.6.0"><shape type="sphere"><transform name="to_world">
        <matrix value="1 0 0 5, 0 1 0 6, 0 0 1 7, 0 0 0 1"/>
        <scale x="2" y="3"/>
    </transform></shape></scene>"#;
    let m = parse_ok(xml).shapes[0].to_world;
    assert!(close(
        m.transform_point3(Vec3::ONE),
        Vec3::new(12.0, 21.0, 8.0)
    ));
}

#[test]
fn defaults_and_overrides() {
    let xml = r#"<scene version="3.0.0">
      <default name="spp" value="8"/>
      <default name="res" value="32"/>
      <sensor type="perspective">
        <sampler type="independent"><integer name="sample_count" value="$spp"/></sampler>
        <film type="hdrfilm"><integer name="width" value="$res"/><integer name="height" value="$res"/></film>
      </sensor>
    </scene>"#;
    let s = parse_ok(xml);
    assert_eq!(s.sampler.sample_count, 8);
    assert_eq!(s.film.width, 32);
    let s = parse_scene_str(xml, Path::new("t.xml"), &[("spp".into(), "128".into())]).unwrap();
    assert_eq!(s.sampler.sample_count, 128);
    assert_eq!(s.film.height, 32);
    // Mitsuba 3 scenes get no implicit background.
    assert!(s.lights.is_empty());
    assert_eq!(s.dialect, Dialect::Mitsuba3);
}

#[test]
fn colours_and_refs() {
    let xml = r##"<scene version="0.6.0">
      <texture type="checkerboard" id="checks">
        <rgb name="color0" value="0.1"/>
        <transform name="to_uv"><scale x="8" y="4"/><translate x="0.5"/></transform>
      </texture>
      <bsdf type="diffuse" id="a"><rgb name="reflectance" value="0.1 0.2 0.3"/></bsdf>
      <bsdf type="diffuse" id="b"><srgb name="reflectance" value="#ff0000"/></bsdf>
      <bsdf type="mirror" id="c"><spectrum name="reflectance" value="0.25"/></bsdf>
      <bsdf type="diffuse" id="d"><ref name="reflectance" id="checks"/></bsdf>
      <bsdf type="phong" id="e"/>
      <shape type="sphere"><ref id="d"/></shape>
      <shape type="rectangle"/>
    </scene>"##;
    let s = parse_ok(xml);
    let k = |i: usize| s.bsdfs[i].kind.clone();
    assert_eq!(
        k(0),
        BsdfKind::Diffuse {
            reflectance: ColorParam::Constant(Vec3::new(0.1, 0.2, 0.3))
        }
    );
    assert_eq!(
        k(1),
        BsdfKind::Diffuse {
            reflectance: ColorParam::Constant(Vec3::new(1.0, 0.0, 0.0))
        }
    );
    assert_eq!(
        k(2),
        BsdfKind::Mirror {
            reflectance: ColorParam::Constant(Vec3::splat(0.25))
        }
    );
    assert_eq!(
        k(3),
        BsdfKind::Diffuse {
            reflectance: ColorParam::Texture(0)
        }
    );
    assert_eq!(
        k(4),
        BsdfKind::Phong {
            reflectance: ColorParam::Constant(Vec3::splat(0.5)),
            exponent: 5.0
        }
    );
    assert_eq!(s.shapes[0].bsdf, Some(3));
    assert_eq!(s.shapes[1].bsdf, None);
    assert_eq!(s.shapes[1].geometry, Geometry::Rectangle);
    let TextureKind::Checkerboard {
        color0,
        color1,
        to_uv,
    } = s.textures[0].kind
    else {
        panic!()
    };
    assert_eq!((color0, color1), (Vec3::splat(0.1), Vec3::splat(0.2)));
    assert!((to_uv.transform_point2(Vec2::new(0.5, 0.5)) - Vec2::new(4.5, 2.0)).length() < 1e-6);
    // The checkerboard is not a texture the course's renderer reads: a Mitsuba 0.6 file (the
    // course's mirror and phong notwithstanding), so no implicit grey environment.
    assert_eq!(s.dialect, torrey_parser::Dialect::Mitsuba3);
    assert!(
        s.dialect_reason
            .contains("texture 'checkerboard' at test.xml:2:7"),
        "{}",
        s.dialect_reason
    );
    assert_eq!(s.lights, vec![]);
    // Without it, a course file: the course's 0.5 grey environment.
    let start = xml.find("<texture").unwrap();
    let end = xml.find("</texture>").unwrap() + "</texture>".len();
    let course = format!("{}{}", &xml[..start], &xml[end..])
        .replace(r#"<ref name="reflectance" id="checks"/>"#, "");
    let s = parse_ok(&course);
    assert_eq!(
        s.dialect,
        torrey_parser::Dialect::Torrey,
        "{}",
        s.dialect_reason
    );
    assert_eq!(
        s.lights,
        vec![Light::Constant {
            radiance: Vec3::splat(0.5)
        }]
    );
}

#[test]
fn twosided_and_plastic_dialects() {
    let xml = r#"<scene version="2.1.0">
      <bsdf type="twosided" id="ts"><bsdf type="blinn_microfacet"><float name="exponent" value="40"/></bsdf></bsdf>
      <bsdf type="plastic" id="p1"><rgb name="reflectance" value="0.3"/></bsdf>
      <bsdf type="plastic" id="p2"><rgb name="diffuse_reflectance" value="0.3"/><float name="int_ior" value="1.5"/><string name="ext_ior" value="water"/></bsdf>
      <shape type="sphere"><ref name="bsdf" id="ts"/></shape>
    </scene>"#;
    let s = parse_ok(xml);
    assert!(s.bsdfs[0].two_sided);
    assert_eq!(s.bsdfs[0].id.as_deref(), Some("ts"));
    assert_eq!(
        s.bsdfs[0].kind,
        BsdfKind::BlinnMicrofacet {
            reflectance: ColorParam::Constant(Vec3::splat(0.5)),
            exponent: 40.0
        }
    );
    assert_eq!(
        s.bsdfs[1].kind,
        BsdfKind::Plastic {
            reflectance: ColorParam::Constant(Vec3::splat(0.3)),
            // Mitsuba's default IORs (polypropylene over air) in a Mitsuba 3 scene.
            eta: 1.49 / 1.000277,
            specular_reflectance: ColorParam::Constant(Vec3::ONE),
            nonlinear: false,
        }
    );
    let BsdfKind::Plastic { eta, .. } = s.bsdfs[2].kind else {
        panic!()
    };
    assert!((eta - 1.5 / 1.333).abs() < 1e-6);
    let plastic_warnings = |s: &torrey_parser::Scene| -> Vec<u32> {
        s.warnings
            .iter()
            .filter(|w| w.message.contains("plastic"))
            .map(|w| w.location.line)
            .collect()
    };
    // In a Mitsuba 3 scene plastic is Mitsuba's: nothing to warn about.
    assert_eq!(plastic_warnings(&s), Vec::<u32>::new(), "{:?}", s.warnings);
    assert_eq!(s.shapes[0].bsdf, Some(0));
    // In the torrey dialect plastic is the course's (default eta 1.5), and Mitsuba's spelling
    // is warned about.
    let s = parse_ok(&xml.replace("2.1.0", "0.6.0"));
    let BsdfKind::Plastic { eta, .. } = s.bsdfs[1].kind else {
        panic!()
    };
    assert_eq!(eta, 1.5);
    assert_eq!(plastic_warnings(&s), vec![4], "{:?}", s.warnings);
}

#[test]
fn normal_maps_are_raw_bitmaps() {
    let dir = temp_dir("normal-maps");
    std::fs::write(dir.join("n.png"), b"not really a png").unwrap();
    let xml = r#"<scene version="3.0.0">
      <texture type="bitmap" id="shared"><string name="filename" value="n.png"/></texture>
      <bsdf type="normalmap" id="m3">
        <texture type="bitmap" name="normalmap"><string name="filename" value="n.png"/></texture>
        <bsdf type="diffuse"><ref name="reflectance" id="shared"/></bsdf>
      </bsdf>
      <bsdf type="plastic" id="seed">
        <ref name="normal_map" id="shared"/>
      </bsdf>
    </scene>"#;
    let s = parse_in(&dir, xml).unwrap();
    let raw = |t: TextureId| match &s.textures[t].kind {
        TextureKind::Bitmap(b) => b.raw,
        _ => panic!(),
    };
    let m3 = &s.bsdfs[0];
    assert_eq!(m3.id.as_deref(), Some("m3"));
    assert_eq!(
        m3.kind,
        BsdfKind::Diffuse {
            reflectance: ColorParam::Texture(0)
        }
    );
    assert!(raw(m3.normal_map.unwrap()));
    // A shared texture stays as it is for colour use; the normal map gets a raw copy.
    let seed = s.bsdfs[1].normal_map.unwrap();
    assert!(raw(seed) && !raw(0) && seed != 0);
}

#[test]
fn lights_and_envmaps() {
    let dir = temp_dir("lights");
    std::fs::write(dir.join("sky.exr"), b"x").unwrap();
    let xml = r#"<scene version="0.6.0">
      <emitter type="point">
        <rgb name="intensity" value="10"/>
        <transform name="toWorld"><translate x="1" y="2" z="3"/></transform>
      </emitter>
      <emitter type="envmap">
        <float name="intensity_scale" value="2"/>
        <texture type="bitmap" name="reflectance"><string name="filename" value="sky.exr"/><float name="uscale" value="2"/></texture>
        <transform name="toWorld"><rotate y="1" angle="90"/></transform>
      </emitter>
      <shape type="sphere">
        <emitter type="area"><rgb name="radiance" value="1, 2, 3"/></emitter>
        <boolean name="flipNormals" value="true"/>
      </shape>
    </scene>"#;
    let s = parse_in(&dir, xml).unwrap();
    assert_eq!(
        s.lights.len(),
        2,
        "an envmap replaces the implicit background"
    );
    assert_eq!(
        s.lights[0],
        Light::Point {
            position: Vec3::new(1.0, 2.0, 3.0),
            intensity: Vec3::splat(10.0)
        }
    );
    let Light::Envmap {
        bitmap,
        scale,
        to_world,
    } = &s.lights[1]
    else {
        panic!()
    };
    assert_eq!(*scale, 2.0);
    assert!(bitmap.filename.ends_with("sky.exr"));
    assert_eq!(bitmap.to_uv.matrix2.x_axis.x, 2.0);
    assert!(close(
        to_world.transform_vector3(Vec3::X),
        Vec3::new(0.0, 0.0, -1.0)
    ));
    assert_eq!(s.shapes[0].emitter, Some(Vec3::new(1.0, 2.0, 3.0)));
    assert!(s.shapes[0].flip_normals);
}

#[test]
fn unknown_parameters_warn_with_position() {
    let xml = "<scene version=\"0.6.0\">\n  <bsdf type=\"diffuse\">\n    <float name=\"roughness\" value=\"0.1\"/>\n  </bsdf>\n  <subsurface type=\"dipole\"/>\n</scene>";
    let s = parse_ok(xml);
    assert_eq!(s.warnings.len(), 2);
    assert_eq!(
        s.warnings[0].message,
        "unknown parameter 'roughness' of bsdf 'diffuse'; ignored"
    );
    assert_eq!(
        (s.warnings[0].location.line, s.warnings[0].location.column),
        (3, 5)
    );
    assert_eq!(s.warnings[1].location.line, 5);
    assert_eq!(
        s.warnings[0].to_string(),
        "test.xml:3:5: warning: unknown parameter 'roughness' of bsdf 'diffuse'; ignored"
    );
}

#[test]
fn integrators() {
    let s = parse_ok(r#"<scene version="0.5.0"><integrator type="direct"/></scene>"#);
    assert_eq!(
        (s.integrator.max_depth(), s.integrator.type_name.as_str()),
        (2, "direct")
    );
    let s = parse_ok(
        r#"<scene version="0.5.0"><integrator type="path"><integer name="maxDepth" value="7"/><integer name="rrDepth" value="3"/></integrator></scene>"#,
    );
    assert_eq!((s.integrator.max_depth(), s.integrator.rr_depth()), (7, 3));
}

const TRI_OBJ: &str = "v 0 0 0\nv 1 0 0\nv 0 1 0\nv 1 1 0.5\nvt 0 0\nvt 1 0.25\nvt 0 1\nvt 1 1\nf 1/1 2/2 3/3\nf 2/2 4/4 3/3\n";

fn mesh_of(s: &Scene, i: usize) -> &TriangleMesh {
    match &s.shapes[i].geometry {
        Geometry::Mesh(m) => m,
        g => panic!("{g:?}"),
    }
}

#[test]
fn obj_flips_v_and_computes_smooth_normals() {
    let dir = temp_dir("obj");
    std::fs::write(dir.join("t.obj"), TRI_OBJ).unwrap();
    let xml = r#"<scene version="0.6.0">
      <shape type="obj"><string name="filename" value="t.obj"/></shape>
      <shape type="obj"><string name="filename" value="t.obj"/><boolean name="flipTexCoords" value="false"/><boolean name="faceNormals" value="true"/></shape>
    </scene>"#;
    let s = parse_in(&dir, xml).unwrap();
    let m = mesh_of(&s, 0);
    assert_eq!(m.indices.len(), 2);
    let i1 = m.positions.iter().position(|&p| p == Vec3::X).unwrap();
    assert_eq!(m.uvs[i1], Vec2::new(1.0, 0.75));
    let i0 = m.positions.iter().position(|&p| p == Vec3::ZERO).unwrap();
    assert!(close(m.normals[i0], Vec3::Z));
    // Vertex 2 is shared by both faces: the unit face normals weighted by the faces' angles
    // there (45 degrees in the first face; about 50.8 degrees in the second), as Mitsuba does.
    let f2 = (Vec3::new(0.0, 1.0, 0.5))
        .cross(Vec3::new(-1.0, 1.0, 0.0))
        .normalize();
    let a2 = Vec3::new(1.0, -1.0, 0.0).angle_between(Vec3::new(1.0, 0.0, 0.5));
    let n2 = Vec3::Z * std::f32::consts::FRAC_PI_4 + f2 * a2;
    let i2 = m.positions.iter().position(|&p| p == Vec3::Y).unwrap();
    assert!(close(m.normals[i2], n2.normalize()), "{:?}", m.normals[i2]);
    let m = mesh_of(&s, 1);
    assert!(m.normals.is_empty());
    assert_eq!(m.uvs[i1], Vec2::new(1.0, 0.25));
}

fn ply_header(format: &str) -> String {
    format!("ply\nformat {format} 1.0\nelement vertex 4\nproperty float x\nproperty float y\nproperty float z\nproperty float nx\nproperty float ny\nproperty float nz\nproperty float u\nproperty float v\nproperty uchar intensity\nelement face 1\nproperty list uchar uint vertex_indices\nend_header\n")
}

const QUAD: [[f32; 8]; 4] = [
    [0.0, 0.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0],
    [1.0, 0.0, 0.0, 0.0, 0.0, 1.0, 1.0, 0.0],
    [1.0, 1.0, 0.0, 0.0, 0.0, 1.0, 1.0, 1.0],
    [0.0, 1.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.25],
];

fn binary_ply(big_endian: bool) -> Vec<u8> {
    let mut d = ply_header(if big_endian {
        "binary_big_endian"
    } else {
        "binary_little_endian"
    })
    .into_bytes();
    for v in QUAD {
        for x in v {
            d.extend_from_slice(&if big_endian {
                x.to_be_bytes()
            } else {
                x.to_le_bytes()
            });
        }
        d.push(7);
    }
    d.push(4);
    for i in 0u32..4 {
        d.extend_from_slice(&if big_endian {
            i.to_be_bytes()
        } else {
            i.to_le_bytes()
        });
    }
    d
}

#[test]
fn ply_ascii_and_binary_quads() {
    let dir = temp_dir("ply");
    let mut ascii = ply_header("ascii");
    for v in QUAD {
        let line: Vec<String> = v.iter().map(|x| x.to_string()).collect();
        ascii += &format!("{} 7\n", line.join(" "));
    }
    ascii += "4 0 1 2 3\n";
    std::fs::write(dir.join("a.ply"), ascii).unwrap();
    std::fs::write(dir.join("le.ply"), binary_ply(false)).unwrap();
    std::fs::write(dir.join("be.ply"), binary_ply(true)).unwrap();
    let xml = r#"<scene version="3.0.0">
      <shape type="ply"><string name="filename" value="a.ply"/></shape>
      <shape type="ply"><string name="filename" value="le.ply"/></shape>
      <shape type="ply"><string name="filename" value="be.ply"/></shape>
    </scene>"#;
    let s = parse_in(&dir, xml).unwrap();
    for i in 0..3 {
        let m = mesh_of(&s, i);
        assert_eq!(m.indices, vec![[0, 1, 2], [0, 2, 3]], "shape {i}");
        assert_eq!(m.positions[2], Vec3::new(1.0, 1.0, 0.0));
        assert_eq!(m.normals, vec![Vec3::Z; 4]);
        // PLY texture coordinates are not flipped.
        assert_eq!(m.uvs[3], Vec2::new(0.0, 0.25));
    }
    assert_eq!(s.shapes[0].to_world, Mat4::IDENTITY);
}

#[test]
fn serialized_roundtrip() {
    // One v4 shape: flags (single precision + normals), name, 3 vertices, 1 triangle.
    let mut raw = Vec::new();
    raw.extend_from_slice(&(0x1000u32 | 0x0001).to_le_bytes());
    raw.extend_from_slice(b"tri\0");
    raw.extend_from_slice(&3u64.to_le_bytes());
    raw.extend_from_slice(&1u64.to_le_bytes());
    for p in [[0.0f32, 0.0, 0.0], [2.0, 0.0, 0.0], [0.0, 3.0, 0.0]] {
        for x in p {
            raw.extend_from_slice(&x.to_le_bytes());
        }
    }
    for _ in 0..3 {
        for x in [0.0f32, 0.0, 1.0] {
            raw.extend_from_slice(&x.to_le_bytes());
        }
    }
    for i in 0u32..3 {
        raw.extend_from_slice(&i.to_le_bytes());
    }
    let mut file = vec![0x1C, 0x04, 4, 0];
    file.extend(miniz_oxide::deflate::compress_to_vec_zlib(&raw, 6));
    file.extend_from_slice(&0u64.to_le_bytes());
    file.extend_from_slice(&1u32.to_le_bytes());
    let dir = temp_dir("serialized");
    std::fs::write(dir.join("m.serialized"), file).unwrap();
    let xml = r#"<scene version="3.0.0">
      <shape type="serialized"><string name="filename" value="m.serialized"/><integer name="shape_index" value="0"/></shape>
    </scene>"#;
    let s = parse_in(&dir, xml).unwrap();
    let m = mesh_of(&s, 0);
    assert_eq!(m.positions[2], Vec3::new(0.0, 3.0, 0.0));
    assert_eq!(m.indices, vec![[0, 1, 2]]);
    assert_eq!(m.normals, vec![Vec3::Z; 3]);
    // Mitsuba 3.9.1's serialized has no flip_tex_coords (it refuses the parameter): unused.
    let flip = xml.replace(
        "</shape>",
        "<boolean name=\"flip_tex_coords\" value=\"true\"/></shape>",
    );
    let s = parse_in(&dir, &flip).unwrap();
    assert!(
        s.warnings.iter().any(|w| w
            .message
            .contains("unknown parameter 'flip_tex_coords' of shape 'serialized'")),
        "{:?}",
        s.warnings
    );
    let xml = xml.replace("value=\"0\"", "value=\"1\"");
    let e = parse_in(&dir, &xml).unwrap_err();
    assert!(
        e.message
            .contains("shape_index 1 is out of range: the file holds 1 shapes"),
        "{e}"
    );
}

/// `Scene::files` lists every file the scene names, resolved against its folder, in order (a
/// mesh named twice is listed twice): what a copy of the scene must carry.
#[test]
fn scene_lists_the_files_it_refers_to() {
    let dir = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("../../scenes");
    let scene = torrey_parser::load_scene(&dir.join("textured_mesh.xml"), &[]).unwrap();
    let names: Vec<String> = scene
        .files
        .iter()
        .map(|f| {
            assert!(f.is_absolute(), "{}", f.display());
            let canon = f.canonicalize().unwrap();
            let root = dir.join("..").canonicalize().unwrap();
            canon.strip_prefix(root).unwrap().display().to_string()
        })
        .collect();
    assert_eq!(names, ["textures/checker.png", "scenes/meshes/torus.obj"]);
    let cbox = torrey_parser::load_scene(&dir.join("cbox.xml"), &[]).unwrap();
    assert_eq!(cbox.files.len(), 2);
    assert!(cbox.files.iter().all(|f| f.ends_with("meshes/cube.obj")));
}

/// Mitsuba's film crop parameters give a crop window (offsets default to 0, sizes to the film's);
/// a window outside the film is an error at the first crop parameter.
#[test]
fn film_crop_parameters_give_a_window() {
    let film = |params: &str| {
        format!(
            r#"<scene version="3.0.0"><sensor type="perspective"><film type="hdrfilm">
  <integer name="width" value="64"/><integer name="height" value="48"/>{params}
</film></sensor></scene>"#
        )
    };
    assert_eq!(parse_ok(&film("")).film.crop, None);
    let xml = film(
        r#"<integer name="crop_offset_x" value="8"/><integer name="crop_offset_y" value="4"/>
  <integer name="crop_width" value="16"/><integer name="crop_height" value="20"/>"#,
    );
    assert_eq!(
        parse_ok(&xml).film.crop.map(|c| c.rect()),
        Some((8, 4, 16, 20))
    );
    let xml = film(r#"<integer name="crop_height" value="10"/>"#);
    assert_eq!(
        parse_ok(&xml).film.crop.map(|c| c.rect()),
        Some((0, 0, 64, 10))
    );
    let xml = film(r#"<integer name="crop_offset_x" value="8"/>"#);
    let e = parse(&xml).unwrap_err();
    assert!(
        e.message
            .contains("the crop window (8, 0) + 64 x 48 does not fit the 64 x 48 film"),
        "{e}"
    );
    assert_eq!(e.location.line, 1); // the film element
}

#[test]
fn bumpmap_and_perturb_options() {
    let dir = temp_dir("bumpmap");
    std::fs::write(dir.join("h.png"), b"not really a png").unwrap();
    let xml = r#"<scene version="3.0.0">
      <texture type="bitmap" id="height"><string name="filename" value="h.png"/></texture>
      <bsdf type="bumpmap" id="inline">
        <texture type="bitmap" name="arbitrary"><string name="filename" value="h.png"/></texture>
        <float name="scale" value="0.25"/>
        <boolean name="use_shadowing_function" value="false"/>
        <bsdf type="roughconductor"><boolean name="sample_visible" value="false"/></bsdf>
      </bsdf>
      <bsdf type="bumpmap" id="by_ref">
        <bsdf type="diffuse"/>
        <ref id="height"/>
      </bsdf>
      <bsdf type="normalmap" id="nm">
        <texture type="bitmap" name="normalmap"><string name="filename" value="h.png"/></texture>
        <boolean name="flip_invalid_normals" value="false"/>
        <bsdf type="roughplastic"/>
      </bsdf>
    </scene>"#;
    let s = parse_in(&dir, xml).unwrap();
    let inline = &s.bsdfs[0];
    assert_eq!(
        inline.bump_map,
        Some(BumpMap {
            texture: 1,
            scale: 0.25
        })
    );
    assert_eq!(
        inline.perturb,
        PerturbOptions {
            flip_invalid_normals: true,
            use_shadowing_function: false
        }
    );
    assert!(matches!(
        inline.kind,
        BsdfKind::RoughConductor {
            sample_visible: false,
            ..
        }
    ));
    let by_ref = &s.bsdfs[1];
    assert_eq!(
        by_ref.bump_map,
        Some(BumpMap {
            texture: 0,
            scale: 1.0
        })
    );
    assert_eq!(by_ref.perturb, PerturbOptions::default());
    let nm = &s.bsdfs[2];
    assert!(nm.normal_map.is_some() && nm.bump_map.is_none());
    assert!(!nm.perturb.flip_invalid_normals && nm.perturb.use_shadowing_function);
    assert!(matches!(
        nm.kind,
        BsdfKind::RoughPlastic {
            sample_visible: true,
            ..
        }
    ));
}
