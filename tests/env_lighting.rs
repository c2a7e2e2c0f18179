//! Environment-map lighting end to end: a furnace test with a constant-valued map, and the error
//! of the three env sampling strategies at equal sample count against a high-spp reference.

mod common;

use glam::Vec3;
use std::path::{Path, PathBuf};
use torrey_renderer::EnvStrategy;
use torrey_texture::Image;

fn temp_dir(name: &str) -> PathBuf {
    let dir = std::env::temp_dir().join(format!("torrey-env-{}-{name}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    dir
}

fn render(
    path: &Path,
    w: u32,
    h: u32,
    spp: u32,
    seed: u64,
    strategy: EnvStrategy,
) -> common::Rendered {
    let desc = torrey_parser::load_scene(path, &[]).unwrap_or_else(|e| panic!("{e}"));
    let rs = torrey_renderer::RenderScene::build(&desc, w, h).unwrap_or_else(|e| panic!("{e}"));
    let settings = torrey_renderer::RenderSettings {
        env_strategy: strategy,
        ..torrey_renderer::RenderSettings::new(
            &desc,
            &torrey_renderer::Overrides {
                spp: Some(spp),
                seed: Some(seed),
                sampler: Some(torrey_renderer::SamplerKind::Independent),
                ..Default::default()
            },
        )
    };
    let out = torrey_renderer::render(&rs, &settings, &|_, _| {});
    assert_eq!(out.nonfinite_samples, 0);
    common::Rendered {
        image: out.image,
        variance: out.variance,
        nonfinite: 0,
    }
}

/// A white-ish diffuse sphere inside a constant-valued environment map reflects rho * L
/// (the sphere cannot see itself), whatever the map's rotation.
#[test]
fn furnace_with_constant_envmap() {
    let dir = temp_dir("furnace");
    let map = dir.join("constant.exr");
    torrey_texture::write_exr(&map, &Image::filled(64, 32, Vec3::new(0.7, 0.7, 0.7))).unwrap();
    let xml = format!(
        r#"<scene version="0.6.0">
             <sensor type="perspective"><float name="fov" value="30"/>
               <transform name="toWorld"><lookat origin="0, 0, 5" target="0, 0, 0" up="0, 1, 0"/></transform>
               <film type="hdrfilm"><integer name="width" value="32"/><integer name="height" value="32"/></film>
             </sensor>
             <emitter type="envmap"><string name="filename" value="{}"/><float name="scale" value="2"/>
               <transform name="toWorld"><rotate x="1" y="1" angle="37"/></transform></emitter>
             <bsdf type="diffuse" id="d"><rgb name="reflectance" value="0.8, 0.5, 0.2"/></bsdf>
             <shape type="sphere"><float name="radius" value="1"/><ref id="d"/></shape>
           </scene>"#,
        map.display()
    );
    let scene = dir.join("furnace.xml");
    std::fs::write(&scene, xml).unwrap();
    let r = render(&scene, 32, 32, 64, 1, EnvStrategy::ImportanceMis);
    let l = 0.7 * 2.0;
    let expected = Vec3::new(0.8, 0.5, 0.2) * l;
    let (mut sum, mut var) = (Vec3::ZERO, Vec3::ZERO);
    for y in 12..20 {
        for x in 12..20 {
            sum += r.image.get(x, y);
            var += r.variance.get(x, y);
        }
    }
    let mean = sum / 64.0;
    let sigma = (var / (64.0 * 64.0)).powf(0.5);
    for c in 0..3 {
        assert!(
            (mean[c] - expected[c]).abs() < 4.0 * sigma[c] + 2e-3,
            "channel {c}: {} vs {} (sigma {})",
            mean[c],
            expected[c],
            sigma[c]
        );
    }
    // The background is the map itself, exactly.
    assert!((r.image.get(0, 0) - Vec3::splat(l)).abs().max_element() < 1e-4);
}

fn rel_rmse(a: &Image, b: &Image) -> f64 {
    let mut s = 0.0;
    for (p, q) in a.pixels.iter().zip(&b.pixels) {
        for c in 0..3 {
            s += ((p[c] - q[c]) as f64).powi(2) / ((q[c] as f64).powi(2) + 1e-2);
        }
    }
    (s / (a.pixels.len() * 3) as f64).sqrt()
}

/// Equal-spp error of (a) uniform sphere sampling, (b) luminance importance sampling, (c) (b) with
/// MIS, on the project's sky with a small bright sun: each must be lower than the one before.
#[test]
fn importance_sampling_and_mis_reduce_error() {
    let scene = common::root().join("scenes/envmap_sky.xml");
    let scene = if scene.exists() {
        scene
    } else {
        // Fallback while the project scene is absent: a minimal sky-lit scene.
        let dir = temp_dir("strategies");
        let xml = format!(
            r#"<scene version="0.6.0">
                 <sensor type="perspective"><float name="fov" value="40"/>
                   <transform name="toWorld"><lookat origin="0, 1.5, 5" target="0, 0.5, 0" up="0, 1, 0"/></transform>
                   <film type="hdrfilm"><integer name="width" value="48"/><integer name="height" value="32"/></film>
                 </sensor>
                 <emitter type="envmap"><string name="filename" value="{}"/></emitter>
                 <bsdf type="diffuse" id="d"><rgb name="reflectance" value="0.6"/></bsdf>
                 <bsdf type="phong" id="g"><rgb name="reflectance" value="0.6"/><float name="exponent" value="30"/></bsdf>
                 <shape type="sphere"><point name="center" x="-1.1" y="1" z="0"/><float name="radius" value="1"/><ref id="d"/></shape>
                 <shape type="sphere"><point name="center" x="1.1" y="1" z="0"/><float name="radius" value="1"/><ref id="g"/></shape>
                 <shape type="rectangle"><transform name="toWorld"><rotate x="1" angle="-90"/><scale value="10"/></transform><ref id="d"/></shape>
               </scene>"#,
            common::root().join("textures/sky_sun.exr").display()
        );
        let p = dir.join("sky.xml");
        std::fs::write(&p, xml).unwrap();
        p
    };
    let (w, h) = (48, 32);
    let reference = render(&scene, w, h, 2048, 99, EnvStrategy::ImportanceMis).image;
    let spp = 16;
    let errors: Vec<f64> = [
        EnvStrategy::Uniform,
        EnvStrategy::Importance,
        EnvStrategy::ImportanceMis,
    ]
    .iter()
    .map(|&s| rel_rmse(&render(&scene, w, h, spp, 5, s).image, &reference))
    .collect();
    println!(
        "relative RMSE at {spp} spp: uniform {:.4}, importance {:.4}, importance+MIS {:.4}",
        errors[0], errors[1], errors[2]
    );
    assert!(
        errors[0] > errors[1],
        "importance sampling must beat uniform: {errors:?}"
    );
    assert!(
        errors[1] > errors[2],
        "MIS must beat importance sampling alone: {errors:?}"
    );
}
