//! Participating media: `<medium>`, `<phase>`, `<volume>` as Mitsuba 3 reads them, and the
//! errors and warnings of bad media input.

mod common;

use common::{assert_err, parse, parse_in, parse_ok, pos_of, temp_dir};
use torrey_parser::vol::write_vol;
use torrey_parser::{IntegratorKind, Phase, Volume};

fn scene(body: &str) -> String {
    format!(
        r#"<scene version="3.0.0">
<integrator type="volpathmis"><integer name="max_depth" value="7"/></integrator>
{body}
</scene>"#
    )
}

#[test]
fn media_shapes_and_sensor() {
    let xml = scene(
        r#"<medium type="homogeneous" id="fog">
    <rgb name="sigma_t" value="0.5, 1, 2"/><float name="scale" value="2"/>
    <phase type="blendphase"><float name="weight" value="0.25"/>
        <phase type="rayleigh" name="b"/><phase type="hg" name="a"><float name="g" value="-0.5"/></phase>
    </phase>
</medium>
<sensor type="perspective"><ref id="fog"/></sensor>
<shape type="sphere">
    <bsdf type="null"/>
    <ref name="exterior" id="fog"/>
    <medium type="heterogeneous" name="interior"><float name="albedo" value="0.5"/></medium>
</shape>"#,
    );
    let s = parse_ok(&xml);
    assert!(matches!(
        s.integrator.kind,
        IntegratorKind::VolPath { mis: true, params } if params.max_depth == 7
    ));
    assert_eq!(s.media.len(), 2);
    let fog = &s.media[0];
    assert!(fog.homogeneous && fog.sample_emitters);
    assert_eq!(
        fog.sigma_t,
        Volume::Constant(glam::Vec3::new(0.5, 1.0, 2.0))
    );
    assert_eq!(fog.scale, 2.0);
    assert_eq!(fog.albedo, Volume::Constant(glam::Vec3::splat(0.75)));
    // In document order, whatever the names (Mitsuba 3.9.1 does so).
    assert_eq!(
        fog.phase,
        Phase::Blend(0.25, Box::new(Phase::Rayleigh), Box::new(Phase::Hg(-0.5)))
    );
    assert_eq!(s.camera.medium, Some(0));
    assert_eq!(
        (s.shapes[0].interior, s.shapes[0].exterior),
        (Some(1), Some(0))
    );
    assert!(!s.media[1].homogeneous);
    assert!(s.warnings.is_empty(), "{:?}", s.warnings);
}

#[test]
fn bad_media_values() {
    let xml =
        scene(r#"<medium type="homogeneous"><rgb name="sigma_t" value="1, -1, 1"/></medium>"#);
    let e = parse(&xml).unwrap_err();
    assert_err(
        &e,
        "parameter 'sigma_t' of medium 'homogeneous' must not be negative",
        pos_of(&xml, "1, -1, 1"),
    );

    let xml = scene(r#"<shape type="sphere"><ref name="interior" id="nowhere"/></shape>"#);
    let e = parse(&xml).unwrap_err();
    assert_err(
        &e,
        "reference to undefined id 'nowhere'",
        pos_of(&xml, "nowhere"),
    );

    let xml = scene(r#"<shape type="sphere"><medium type="homogeneous"/></shape>"#);
    let e = parse(&xml).unwrap_err();
    assert_err(
        &e,
        "a shape's medium must be named 'interior' or 'exterior'",
        pos_of(&xml, "<medium"),
    );

    let xml = scene(
        r#"<medium type="homogeneous"><phase type="hg"><float name="g" value="1"/></phase></medium>"#,
    );
    let e = parse(&xml).unwrap_err();
    assert_err(
        &e,
        "parameter 'g' of phase 'hg' must be in (-1, 1)",
        pos_of(&xml, "1\"/></phase>"),
    );

    let xml = scene(r#"<medium type="foggy"/>"#);
    assert!(parse(&xml)
        .unwrap_err()
        .message
        .starts_with("unknown medium type 'foggy'"));

    // An albedo above 1 is clamped, with a warning.
    let s = parse_ok(&scene(
        r#"<medium type="homogeneous"><rgb name="albedo" value="0.5, 1.5, 1"/></medium>"#,
    ));
    assert_eq!(
        s.media[0].albedo,
        Volume::Constant(glam::Vec3::new(0.5, 1.0, 1.0))
    );
    assert!(
        s.warnings[0].message.contains("above 1; clamped"),
        "{:?}",
        s.warnings
    );
}

fn grid_scene(dir: &std::path::Path, file: &str, extra: &str) -> String {
    std::fs::create_dir_all(dir).unwrap();
    scene(&format!(
        r#"<medium type="{}">
    <volume type="gridvolume" name="sigma_t"><string name="filename" value="{file}"/>{extra}</volume>
</medium>"#,
        if extra.contains("homogeneous") {
            "homogeneous"
        } else {
            "heterogeneous"
        }
    ))
}

#[test]
fn grid_volumes() {
    let dir = temp_dir("media-grid");
    let data: Vec<f32> = (0..24).map(|i| i as f32 * 0.5 - 1.0).collect();
    std::fs::write(
        dir.join("g.vol"),
        write_vol([2, 3, 4], 1, [[0.0; 3], [2.0, 3.0, 4.0]], &data),
    )
    .unwrap();
    let s = parse_in(
        &dir,
        &grid_scene(&dir, "g.vol", r#"<boolean name="use_grid_bbox" value="true"/><string name="filter_type" value="nearest"/>"#),
    )
    .unwrap();
    let Volume::Grid(g) = &s.media[0].sigma_t else {
        panic!("a grid")
    };
    assert_eq!(
        (g.size, g.channels, g.nearest, g.max),
        ([2, 3, 4], 1, true, 10.5)
    );
    // Negative values clamped to 0, with a warning.
    assert_eq!(g.data[0], 0.0);
    assert!(s
        .warnings
        .iter()
        .any(|w| w.message.contains("2 negative values clamped to 0")));
    // The file's box maps to the unit cube.
    let p = g.to_local.transform_point3(glam::Vec3::new(1.0, 1.5, 2.0));
    assert!((p - glam::Vec3::splat(0.5)).length() < 1e-6, "{p}");

    // A header that lies about its size: a clear error at the file name, nothing allocated.
    let mut lying = write_vol([2, 2, 2], 1, [[0.0; 3], [1.0; 3]], &[1.0; 8]);
    lying[8..12].copy_from_slice(&100_000i32.to_le_bytes());
    std::fs::write(dir.join("lying.vol"), lying).unwrap();
    let xml = grid_scene(&dir, "lying.vol", "");
    let e = parse_in(&dir, &xml).unwrap_err();
    assert_err(
        &e,
        "in volume file 'lying.vol': the header announces",
        pos_of(&xml, "lying.vol"),
    );

    let mut nan = write_vol([2, 2, 2], 1, [[0.0; 3], [1.0; 3]], &[1.0; 8]);
    nan[48..52].copy_from_slice(&f32::NAN.to_le_bytes());
    std::fs::write(dir.join("nan.vol"), nan).unwrap();
    let e = parse_in(&dir, &grid_scene(&dir, "nan.vol", "")).unwrap_err();
    assert!(e.message.contains("is NaN"), "{e}");

    std::fs::write(
        dir.join("two.vol"),
        write_vol([1, 1, 1], 2, [[0.0; 3], [1.0; 3]], &[1.0; 2]),
    )
    .unwrap();
    let e = parse_in(&dir, &grid_scene(&dir, "two.vol", "")).unwrap_err();
    assert!(e.message.contains("2 channels; a volume has 1 or 3"), "{e}");

    let e = parse_in(&dir, &grid_scene(&dir, "missing.vol", "")).unwrap_err();
    assert!(e.message.contains("missing.vol"), "{e}");

    // `homogeneous` needs a constant extinction.
    let xml = grid_scene(&dir, "g.vol", "<!-- homogeneous -->");
    let e = parse_in(&dir, &xml).unwrap_err();
    assert!(e.message.contains("needs a constant sigma_t"), "{e}");
}
