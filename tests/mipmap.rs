//! What ray-cone mip-mapping buys: on the grazing checkerboard (scenes/checker_grazing.xml, lit by
//! a point light only, so pixel position is the only randomness), a 1-spp render with mip-mapping
//! must be much closer to a 1024-spp supersampled reference than a 1-spp render without it.

mod common;

fn rmse(a: &torrey_texture::Image, b: &torrey_texture::Image) -> f64 {
    let s: f64 = a
        .pixels
        .iter()
        .zip(&b.pixels)
        .map(|(p, q)| (*p - *q).length_squared() as f64)
        .sum();
    (s / (3 * a.pixels.len()) as f64).sqrt()
}

#[test]
fn mipmapping_reduces_one_spp_error_at_grazing_angles() {
    let scene = common::root().join("scenes/checker_grazing.xml");
    let (w, h) = (160, 80);
    // The supersampled reference: no mip-mapping, many jittered samples per pixel, i.e. the box-
    // filtered pixel integral of the point-sampled texture.
    let reference = common::render_scene_opts(&scene, w, h, 1024, None, 11, false).image;
    let with_mip = common::render_scene_opts(&scene, w, h, 1, None, 3, true).image;
    let without = common::render_scene_opts(&scene, w, h, 1, None, 3, false).image;
    let (e_mip, e_plain) = (rmse(&with_mip, &reference), rmse(&without, &reference));
    println!("1-spp RMSE vs 1024-spp reference: mip-mapped {e_mip:.5}, point-sampled {e_plain:.5} (ratio {:.2})", e_plain / e_mip);
    assert!(
        e_mip < 0.6 * e_plain,
        "mip-mapping must clearly lower the error: {e_mip} vs {e_plain}"
    );
    // Mip-mapping only filters: the mean brightness stays that of the reference.
    let (m_mip, m_ref) = (common::mean(&with_mip), common::mean(&reference));
    assert!(
        ((m_mip - m_ref).length() / m_ref.length()) < 0.01,
        "{m_mip} vs {m_ref}"
    );
}
