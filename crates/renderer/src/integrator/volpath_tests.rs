//! White furnaces of the volumetric path tracer: a non-absorbing medium (albedo 1) inside an
//! index-matched sphere under a constant sky of radiance 1 neither adds nor removes light, so
//! every pixel's expectation is exactly 1, whatever the medium's density, colour or grid.

use crate::render::{render, Overrides, RenderSettings};
use crate::sampler::SamplerKind;

/// A 12×12 view of a sphere of `radius` with a `null` (index-matched) boundary around `medium`,
/// under a constant sky of radiance 1, rendered by `volpath`.
fn null_sphere_scene(
    radius: f32,
    medium: &str,
) -> (torrey_parser::Scene, crate::scene::RenderScene) {
    let xml = format!(
        r#"<scene version="3.0.0">
        <integrator type="volpath"/>
        <sensor type="perspective">
            <float name="fov" value="40"/>
            <transform name="to_world"><lookat origin="0, 0, 4" target="0, 0, 0" up="0, 1, 0"/></transform>
            <film type="hdrfilm"><integer name="width" value="12"/><integer name="height" value="12"/>
                <rfilter type="box"/></film>
        </sensor>
        <emitter type="constant"><rgb name="radiance" value="1"/></emitter>
        <shape type="sphere"><float name="radius" value="{radius}"/><bsdf type="null"/>
            {medium}</shape>
        </scene>"#
    );
    let desc = torrey_parser::parse_scene_str(&xml, std::path::Path::new("sphere.xml"), &[])
        .expect("null-sphere scene");
    let scene = crate::scene::RenderScene::build(&desc, 12, 12).expect("scene");
    (desc, scene)
}

/// The mean of each channel over the image and the largest |pixel − 1| relative to the pixel's
/// standard error.
fn furnace(medium: &str) -> ([f32; 3], f32) {
    let (desc, scene) = null_sphere_scene(1.2, medium);
    let mut settings = RenderSettings::new(
        &desc,
        &Overrides {
            spp: Some(256),
            sampler: Some(SamplerKind::Independent),
            ..Default::default()
        },
    );
    settings.seed = 5;
    let out = render(&scene, &settings, &|_, _| {});
    assert_eq!(out.nonfinite_samples, 0);
    let n = out.image.pixels.len() as f32;
    let mut mean = [0.0f32; 3];
    let mut worst = 0.0f32;
    for (p, v) in out.image.pixels.iter().zip(&out.variance.pixels) {
        for c in 0..3 {
            mean[c] += p[c] / n;
            worst = worst.max((p[c] - 1.0).abs() / v[c].sqrt().max(1e-3));
        }
    }
    (mean, worst)
}

fn assert_furnace(name: &str, medium: &str) {
    let (mean, worst) = furnace(medium);
    for m in mean {
        assert!((m - 1.0).abs() < 0.01, "{name}: mean {mean:?}");
    }
    assert!(
        worst < 5.0,
        "{name}: a pixel {worst} standard errors from 1"
    );
}

#[test]
fn white_furnace_homogeneous() {
    assert_furnace(
        "grey",
        r#"<medium type="homogeneous" name="interior"><float name="sigma_t" value="3"/>
            <float name="albedo" value="1"/><phase type="hg"><float name="g" value="0.5"/></phase></medium>"#,
    );
    assert_furnace(
        "chromatic",
        r#"<medium type="homogeneous" name="interior"><rgb name="sigma_t" value="0.1, 0.5, 1"/>
            <float name="scale" value="4"/><float name="albedo" value="1"/><phase type="rayleigh"/></medium>"#,
    );
}

#[test]
fn white_furnace_grid() {
    let dir = std::env::temp_dir().join(format!("torrey-furnace-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let n = 6u32;
    let data: Vec<f32> = (0..n * n * n * 3)
        .map(|i| ((i * 7919) % 13) as f32 / 6.0 * if i % 3 == 2 { 0.3 } else { 1.0 })
        .collect();
    let path = dir.join("furnace.vol");
    let bbox = [[0.0; 3], [1.0; 3]];
    std::fs::write(
        &path,
        torrey_parser::vol::write_vol([n, n, n], 3, bbox, &data),
    )
    .unwrap();
    let medium = format!(
        r#"<medium type="heterogeneous" name="interior">
            <volume type="gridvolume" name="sigma_t"><string name="filename" value="{}"/>
                <transform name="to_world"><scale value="2"/><translate value="-1, -1, -1"/></transform></volume>
            <float name="scale" value="3"/><float name="albedo" value="1"/></medium>"#,
        path.display()
    );
    assert_furnace("grid", &medium);
}

/// The denoiser's guides in a medium seen through an index-matched boundary (a `null` surface,
/// which takes none): a dense medium scatters every ray that enters it, so where the whole pixel
/// sees the sphere the albedo guide is the medium's albedo (the scattering's weight, exactly for
/// a grey extinction) and the normal faces the camera; where it sees only the sky, both are 0.
#[test]
fn a_scattering_in_a_medium_takes_the_denoiser_guides() {
    let (desc, scene) = null_sphere_scene(
        1.0,
        r#"<medium type="homogeneous" name="interior"><float name="sigma_t" value="200"/>
            <rgb name="albedo" value="0.2, 0.5, 0.8"/><phase type="isotropic"/></medium>"#,
    );
    let mut settings = RenderSettings::new(
        &desc,
        &Overrides {
            spp: Some(16),
            ..Default::default()
        },
    );
    settings.channels.guides = true;
    let out = render(&scene, &settings, &|_, _| {});
    assert_eq!(out.channels, crate::integrator::aov::GUIDE_CHANNELS);
    let pixel = |x: usize, y: usize| &out.extras[(y * 12 + x) * 6..][..6];
    for (x, y) in [(5, 5), (6, 6), (5, 6)] {
        let g = pixel(x, y);
        for (a, want) in g[..3].iter().zip([0.2, 0.5, 0.8]) {
            assert!((a - want).abs() < 1e-4, "albedo {:?} at {x},{y}", &g[..3]);
        }
        assert!(g[5] > 0.99, "the normal faces the camera: {:?}", &g[3..]);
    }
    assert!(pixel(0, 0).iter().all(|&v| v == 0.0), "{:?}", pixel(0, 0));
}
