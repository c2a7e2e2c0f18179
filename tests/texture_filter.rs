//! Texture filtering measured alone (issue 22; the full measurement is bench/texture_error.py).
//!
//! scenes/checker_sky.xml, a grazing checkerboard under a constant white sky, is rendered at max
//! depth 2 twice with the same seed: textured, and with a white albedo. Both share every sample's
//! shading estimate, so textured / white is the texture value the pixel's samples looked up; its
//! RMSE against the same ratio from an unfiltered many-sample render is the texture error.
//! Anisotropic filtering must cut the 1-spp error to 0.4x that of unfiltered (Mitsuba-like) lookups,
//! and, because its footprint shrinks as 1/sqrt(spp), must add no error beyond the noise of an
//! unfiltered render at a high sample count.

mod common;

use std::path::{Path, PathBuf};
use torrey_texture::Image;

const W: u32 = 64;
const H: u32 = 32;

/// The scene with its bitmap reflectance replaced by white, written to a temp file.
fn white_variant(scene: &Path) -> PathBuf {
    let text = std::fs::read_to_string(scene).unwrap();
    let start = text
        .find("<texture type=\"bitmap\" name=\"reflectance\">")
        .unwrap();
    let end = start + text[start..].find("</texture>").unwrap() + "</texture>".len();
    let white = format!(
        "{}<rgb name=\"reflectance\" value=\"1, 1, 1\"/>{}",
        &text[..start],
        &text[end..]
    );
    let dir = std::env::temp_dir().join(format!("torrey-texfilter-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let path = dir.join("checker_sky_white.xml");
    std::fs::write(&path, white).unwrap();
    path
}

/// Per pixel and channel, textured / white (the white render is never black here: every pixel
/// sees the plane or the sky).
fn ratio(tex: &Image, white: &Image) -> Vec<f64> {
    tex.pixels
        .iter()
        .zip(&white.pixels)
        .flat_map(|(t, w)| (0..3).map(move |c| t[c] as f64 / w[c] as f64))
        .collect()
}

fn rmse(a: &[f64], b: &[f64]) -> f64 {
    let s: f64 = a.iter().zip(b).map(|(x, y)| (x - y) * (x - y)).sum();
    (s / a.len() as f64).sqrt()
}

/// The texture ratio of `scene` at `spp` with `seed`, filtered or not.
fn texture_ratio(scene: &Path, white: &Path, spp: u32, seed: u64, filtered: bool) -> Vec<f64> {
    let t = common::render_scene_opts(scene, W, H, spp, Some(2), seed, filtered).image;
    let w = common::render_scene_opts(white, W, H, spp, Some(2), seed, filtered).image;
    assert!(w.pixels.iter().all(|p| p.min_element() > 0.0));
    ratio(&t, &w)
}

#[test]
fn anisotropic_filtering_antialiases_one_spp_and_converges_unbiased() {
    let scene = common::root().join("scenes/checker_sky.xml");
    let white = white_variant(&scene);
    // The exact per-pixel average of the unfiltered texture.
    let reference = texture_ratio(&scene, &white, 2048, 101, false);

    // 1 spp: filtered over the pixel footprint vs point-sampled (what Mitsuba does). Averaged
    // over a few seeds so that the ratio of the two errors is stable.
    let (mut e_filtered, mut e_plain) = (0.0, 0.0);
    for seed in 1..=4 {
        e_filtered += rmse(&texture_ratio(&scene, &white, 1, seed, true), &reference);
        e_plain += rmse(&texture_ratio(&scene, &white, 1, seed, false), &reference);
    }
    println!("1 spp texture RMSE: filtered {e_filtered:.4}, unfiltered {e_plain:.4} (sums of 4)");
    assert!(
        e_filtered < 0.4 * e_plain,
        "1 spp: filtering must cut the texture error to 0.4x unfiltered: {e_filtered} vs {e_plain}"
    );

    // 256 spp: the footprint is 1/16 of a pixel; whatever blur is left must stay within the
    // noise. The unfiltered render's error at the same spp is pure noise (it converges to the
    // reference), so the filtered one may not exceed it (with a margin for the reference's own
    // noise and the spread of one RMSE over 6144 values, a few percent).
    let spp = 256;
    let filtered = rmse(&texture_ratio(&scene, &white, spp, 5, true), &reference);
    let plain = rmse(&texture_ratio(&scene, &white, spp, 5, false), &reference);
    println!("{spp} spp texture RMSE: filtered {filtered:.5}, unfiltered {plain:.5}");
    assert!(
        filtered < 1.1 * plain,
        "{spp} spp: the filter leaves a bias above the noise: {filtered} vs {plain}"
    );
    let _ = std::fs::remove_file(&white);
}
