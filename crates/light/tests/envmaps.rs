//! EnvMap on real maps: the committed sky (textures/sky_sun.exr) and, when present, the shared
//! HDR envmaps in ../shared (skipped with a note otherwise).

use glam::{DVec3, Mat3, Vec2, Vec3};
use std::path::{Path, PathBuf};
use std::time::Instant;
use torrey_light::EnvMap;
use torrey_testkit::Rng;
use torrey_texture::load_image;

fn root() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../..")
}

/// Midpoint quadrature over the sphere of world directions (pole +z, unlike the map's +y).
fn integrate(f: impl Fn(Vec3) -> DVec3, nt: usize, np: usize) -> DVec3 {
    let mut acc = DVec3::ZERO;
    for it in 0..nt {
        let theta = (it as f64 + 0.5) / nt as f64 * std::f64::consts::PI;
        let mut row = DVec3::ZERO;
        for ip in 0..np {
            let phi = (ip as f64 + 0.5) / np as f64 * std::f64::consts::TAU;
            let d = DVec3::new(
                theta.sin() * phi.cos(),
                theta.sin() * phi.sin(),
                theta.cos(),
            );
            row += f(d.as_vec3());
        }
        acc += row * theta.sin();
    }
    acc * (std::f64::consts::PI / nt as f64) * (std::f64::consts::TAU / np as f64)
}

/// Checks pdf normalisation, sample/pdf consistency, and that the env-sampled irradiance at a
/// normal matches quadrature of the map; prints timings.
fn check_map(path: &Path, to_world: Mat3) {
    let t0 = Instant::now();
    let image = load_image(path, false).expect("load").image;
    let (w, h) = (image.width, image.height);
    let t1 = Instant::now();
    let env = EnvMap::new(image, 1.0, to_world);
    let build = t1.elapsed();

    let total = integrate(|d| DVec3::splat(env.pdf(d) as f64), 600, 1200).x;
    assert!(
        (total - 1.0).abs() < 5e-3,
        "{}: pdf integrates to {total}",
        path.display()
    );

    // Irradiance at normal n: quadrature of eval vs env-sampled Monte Carlo (luminance channel).
    let n = to_world * Vec3::new(0.2, 0.9, 0.1).normalize();
    let reference = integrate(
        |d| (env.eval(d, 0.0) * d.dot(n).max(0.0)).as_dvec3(),
        1200,
        2400,
    );
    let count = 200_000;
    let mut rng = Rng::new(7);
    let (mut sum, mut sum2) = (0.0f64, 0.0f64);
    // The density is continuous (piecewise bilinear) but steep next to a sun: the f32 round trip
    // uv -> direction -> uv may move it by a few 1e-3 there. Rare small differences are allowed,
    // none beyond 2%.
    let mut mismatches = 0;
    let mut large = 0;
    let t2 = Instant::now();
    for _ in 0..count {
        let s = env.sample(rng.vec2()).expect("non-black map samples");
        let pdf = env.pdf(s.direction);
        if (pdf - s.pdf).abs() > 2e-2 * s.pdf {
            large += 1;
        }
        if (pdf - s.pdf).abs() > 2e-3 * s.pdf {
            mismatches += 1;
            if mismatches < 5 {
                let uv = env.dir_to_uv(s.direction);
                println!(
                    "mismatch {pdf} vs {} at uv {} texel {}",
                    s.pdf,
                    uv,
                    uv * Vec2::new(w as f32, h as f32)
                );
            }
        }
        let f = (s.radiance.y * s.direction.dot(n).max(0.0) / s.pdf) as f64;
        sum += f;
        sum2 += f * f;
    }
    let per_sample = t2.elapsed() / count;
    assert!(
        large == 0 && mismatches <= count / 10_000,
        "{}: pdf(sample.direction) != sample.pdf ({mismatches} beyond 0.2%, {large} beyond 2%)",
        path.display()
    );
    let mean = sum / count as f64;
    let sigma = ((sum2 / count as f64 - mean * mean) / count as f64).sqrt();
    // Tolerance: 4 sigma plus the quadrature error of a sharp sun on the 1200x2400 grid.
    let tol = 4.0 * sigma + 5e-3 * reference.y;
    println!(
        "{}: {w}x{h}, load {:?}, build {:?}, sample+pdf {:?}/sample, E = {mean:.4} ± {sigma:.4} (quadrature {:.4})",
        path.display(),
        t1 - t0,
        build,
        per_sample,
        reference.y
    );
    assert!(
        (mean - reference.y).abs() < tol,
        "{}: env-sampled irradiance {mean} ± {sigma} vs quadrature {}",
        path.display(),
        reference.y
    );
}

#[test]
fn committed_sky_has_sun_where_expected() {
    let path = root().join("textures/sky_sun.exr");
    if !path.exists() {
        println!("skipping: {} not generated", path.display());
        return;
    }
    let image = load_image(&path, false).unwrap().image;
    assert_eq!((image.width, image.height), (512, 256));
    // Brightest texel: the sun at u = 0.3, elevation 35 degrees (v = 0.5 - 35/180).
    let (k, max) = image
        .pixels
        .iter()
        .enumerate()
        .max_by(|a, b| a.1.y.total_cmp(&b.1.y))
        .unwrap();
    let (i, j) = (k % 512, k / 512);
    let uv = Vec2::new((i as f32 + 0.5) / 512.0, (j as f32 + 0.5) / 256.0);
    assert!((uv.x - 0.3).abs() < 3.0 / 512.0, "sun at u {}", uv.x);
    assert!(
        (uv.y - (0.5 - 35.0 / 180.0)).abs() < 3.0 / 256.0,
        "sun at v {}",
        uv.y
    );
    assert!(max.y > 1500.0 && max.y < 2100.0, "sun radiance {}", max.y);
    // Sky above is bluish, ground below is darker.
    let zenith = image.get(100, 5);
    let ground = image.get(100, 200);
    assert!(zenith.z > zenith.x && ground.length() < zenith.length());

    let env = EnvMap::new(image, 1.0, Mat3::IDENTITY);
    let sun = env.uv_to_dir(Vec2::new(0.3, 0.5 - 35.0 / 180.0));
    let elevation = sun.y.asin().to_degrees();
    assert!((elevation - 35.0).abs() < 1e-3);
    assert!(env.eval(sun, 0.0).y > 1500.0);
    // Importance sampling sends a large share of samples towards the sun (about its share of
    // luminance x solid angle, 40-45%).
    let mut rng = Rng::new(3);
    let near = (0..20_000)
        .filter(|_| {
            env.sample(rng.vec2()).unwrap().direction.dot(sun) > (3.0f32).to_radians().cos()
        })
        .count();
    let share = near as f32 / 20_000.0;
    assert!(share > 0.35 && share < 0.55, "sun share of samples {share}");
    check_map(
        &root().join("textures/sky_sun.exr"),
        Mat3::from_rotation_y(0.7),
    );
}

#[test]
fn shared_envmaps() {
    let shared = root().join("../shared/envmaps");
    if !shared.exists() {
        println!("skipping: {} is absent", shared.display());
        return;
    }
    let rot = Mat3::from_axis_angle(Vec3::new(0.3, 1.0, 0.2).normalize(), 1.1);
    check_map(&shared.join("museum.exr"), Mat3::IDENTITY);
    check_map(&shared.join("sunset.exr"), rot);
}
