//! Loading and writing images: round trips, decoding rules, bad input, and the shared data kit.

use std::path::{Path, PathBuf};

use glam::Vec3;
use torrey_texture::{load_image, srgb_to_linear, write_exr, write_png_srgb, Image, TextureError};

/// A per-test scratch file in the system temp dir (no extra dependency needed).
fn scratch(name: &str) -> PathBuf {
    let dir = std::env::temp_dir().join(format!("torrey-texture-tests-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    dir.join(name)
}

fn shared_dir() -> Option<PathBuf> {
    let p = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../../shared");
    if p.is_dir() {
        Some(p)
    } else {
        println!("note: {} absent, skipping shared-data test", p.display());
        None
    }
}

fn mean(img: &Image) -> Vec3 {
    let s: glam::DVec3 = img.pixels.iter().map(|p| p.as_dvec3()).sum();
    (s / img.pixels.len() as f64).as_vec3()
}

#[test]
fn png_decodes_known_srgb_value() {
    let path = scratch("gray128.png");
    image::RgbImage::from_pixel(3, 2, image::Rgb([128, 0, 255]))
        .save(&path)
        .unwrap();
    let img = load_image(&path, false).unwrap();
    assert!(img.warnings.is_empty());
    assert_eq!((img.image.width, img.image.height), (3, 2));
    let p = img.image.get(2, 1);
    assert!((p.x - 0.215_860_5).abs() < 1e-6, "{p}");
    assert_eq!(p.y, 0.0);
    assert!((p.z - 1.0).abs() < 1e-6);
    let raw = load_image(&path, true).unwrap();
    assert!((raw.image.get(0, 0).x - 128.0 / 255.0).abs() < 1e-6);
    // The 8-bit codes come along, their table giving the image's values exactly.
    for loaded in [&img, &raw] {
        let codes = loaded
            .codes
            .as_ref()
            .expect("an 8-bit image keeps its codes");
        assert_eq!(codes.texels[5], [128, 0, 255]);
        assert_eq!(
            codes.value(codes.texels[5]),
            loaded.image.get(2, 1).to_array()
        );
    }
}

#[test]
fn gray_rgba_and_16bit_inputs() {
    let gray = scratch("gray.png");
    image::GrayImage::from_pixel(2, 2, image::Luma([128]))
        .save(&gray)
        .unwrap();
    let g = load_image(&gray, false).unwrap().image.get(1, 1);
    assert!(g.abs_diff_eq(Vec3::splat(0.215_860_5), 1e-6), "{g}");

    let rgba = scratch("rgba.png");
    image::RgbaImage::from_pixel(2, 2, image::Rgba([255, 128, 0, 7]))
        .save(&rgba)
        .unwrap();
    let c = load_image(&rgba, false).unwrap().image.get(0, 1);
    assert!(c.abs_diff_eq(Vec3::new(1.0, 0.215_860_5, 0.0), 1e-6), "{c}");

    let deep = scratch("deep.png");
    image::ImageBuffer::<image::Rgb<u16>, Vec<u16>>::from_pixel(
        1,
        1,
        image::Rgb([32768, 0, 65535]),
    )
    .save(&deep)
    .unwrap();
    let d = load_image(&deep, false).unwrap().image.get(0, 0);
    assert!((d.x - srgb_to_linear(32768.0 / 65535.0)).abs() < 1e-6);
    let d = load_image(&deep, true).unwrap().image.get(0, 0);
    assert!((d.x - 32768.0 / 65535.0).abs() < 1e-6);
    assert!(load_image(&deep, false).unwrap().codes.is_none());
}

#[test]
fn write_exr_round_trip_is_exact() {
    let px: Vec<Vec3> = (0..35)
        .map(|i| Vec3::new(i as f32 * 0.37, 1e-6 * i as f32, 1000.0 + i as f32 * 3.25))
        .collect();
    let img = Image::new(7, 5, px);
    let path = scratch("round.exr");
    write_exr(&path, &img).unwrap();
    // raw must not matter for float images.
    for raw in [false, true] {
        let back = load_image(&path, raw).unwrap();
        assert!(back.warnings.is_empty());
        assert_eq!(back.image, img);
    }
}

#[test]
fn write_png_srgb_round_trip() {
    let px: Vec<Vec3> = (0..16)
        .map(|i| Vec3::new(i as f32 / 15.0, 0.5, if i == 3 { f32::NAN } else { 2.0 }))
        .collect();
    let img = Image::new(4, 4, px);
    let path = scratch("round.png");
    write_png_srgb(&path, &img).unwrap();
    let back = load_image(&path, false).unwrap().image;
    for (a, b) in img.pixels.iter().zip(&back.pixels) {
        // 8-bit quantisation in sRGB space: under 1/255 of the encoded value, i.e. a small
        // linear error; out-of-range and NaN are clamped.
        assert!((a.x - b.x).abs() < 0.01, "{a} {b}");
        assert!((b.y - 0.5).abs() < 0.005);
    }
    assert_eq!(back.get(3, 0).z, 0.0);
    assert_eq!(back.get(0, 0).z, 1.0);
}

fn write_exr_channels(path: &Path, w: usize, h: usize, chans: &[(&str, Vec<f32>)]) {
    use exr::prelude::*;
    let list: SmallVec<[AnyChannel<FlatSamples>; 4]> = chans
        .iter()
        .map(|(n, v)| AnyChannel::new(*n, FlatSamples::F32(v.clone())))
        .collect();
    let layer = Layer::new(
        (w, h),
        LayerAttributes::default(),
        Encoding::FAST_LOSSLESS,
        AnyChannels::sort(list),
    );
    Image::from_layer(layer).write().to_file(path).unwrap();
}

#[test]
fn bad_float_texels_are_clamped_with_one_warning() {
    let path = scratch("bad.exr");
    let r = vec![1.0, f32::NAN, -2.0, f32::INFINITY];
    write_exr_channels(
        &path,
        2,
        2,
        &[
            ("R", r),
            ("G", vec![0.5; 4]),
            ("B", vec![-0.1, 0.0, 0.0, 0.0]),
        ],
    );
    let img = load_image(&path, false).unwrap();
    assert_eq!(img.warnings.len(), 1, "{:?}", img.warnings);
    assert!(img.warnings[0].contains("bad.exr") && img.warnings[0].contains('4'));
    let xs: Vec<f32> = img.image.pixels.iter().map(|p| p.x).collect();
    assert_eq!(xs, vec![1.0, 0.0, 0.0, 0.0]);
    assert_eq!(img.image.get(0, 0).z, 0.0);
}

#[test]
fn exr_luminance_only_and_half_channels() {
    let path = scratch("y.exr");
    write_exr_channels(&path, 3, 1, &[("Y", vec![0.25, 2.0, 7.5])]);
    let img = load_image(&path, false).unwrap().image;
    assert_eq!(img.get(1, 0), Vec3::splat(2.0));

    use exr::prelude::*;
    let half = scratch("half.exr");
    write_rgba_file(&half, 2, 1, |x, _| {
        (
            f16::from_f32(0.5 + x as f32),
            f16::from_f32(3.0),
            f16::from_f32(0.125),
            f16::ONE,
        )
    })
    .unwrap();
    let img = load_image(&half, false).unwrap().image;
    assert_eq!(img.get(1, 0), Vec3::new(1.5, 3.0, 0.125));
}

#[test]
fn exr_chromaticities_are_converted() {
    use exr::meta::attribute::Chromaticities as C;
    use exr::prelude::*;
    let path = scratch("chroma.exr");
    let write = |c: C| {
        let channels = SpecificChannels::rgb(|Vec2(x, _): Vec2<usize>| {
            if x == 0 {
                (1.0f32, 1.0f32, 1.0f32)
            } else {
                (1.0f32, 0.0f32, 0.0f32)
            }
        });
        let mut image = Image::from_channels((2, 1), channels);
        image.attributes.chromaticities = Some(c);
        image.write().to_file(&path).unwrap();
    };
    // Rec.709 chromaticities: untouched.
    write(C {
        red: Vec2(0.64, 0.33),
        green: Vec2(0.30, 0.60),
        blue: Vec2(0.15, 0.06),
        white: Vec2(0.3127, 0.3290),
    });
    let img = load_image(&path, false).unwrap().image;
    assert_eq!(img.get(1, 0), Vec3::X);
    // Adobe RGB (D65 white): white stays white; red has the same xy as Rec.709 red but a larger
    // share of the white's luminance (0.2974 vs 0.2126), so pure red becomes (1.399, 0, 0).
    write(C {
        red: Vec2(0.64, 0.33),
        green: Vec2(0.21, 0.71),
        blue: Vec2(0.15, 0.06),
        white: Vec2(0.3127, 0.3290),
    });
    let img = load_image(&path, false).unwrap().image;
    assert!(
        img.get(0, 0).abs_diff_eq(Vec3::ONE, 1e-4),
        "{}",
        img.get(0, 0)
    );
    assert!(
        img.get(1, 0).abs_diff_eq(Vec3::new(1.399, 0.0, 0.0), 2e-3),
        "{}",
        img.get(1, 0)
    );
    // Rec.709-like primaries with a D50 white: like Mitsuba 3, no white adaptation, so the file's
    // white becomes the D50 white point expressed in Rec.709, XYZ (0.9642, 1, 0.8251) →
    // RGB (1.176, 0.976, 0.722).
    write(C {
        red: Vec2(0.64, 0.33),
        green: Vec2(0.30, 0.60),
        blue: Vec2(0.15, 0.06),
        white: Vec2(0.3457, 0.3585),
    });
    let img = load_image(&path, false).unwrap().image;
    assert!(
        img.get(0, 0)
            .abs_diff_eq(Vec3::new(1.176, 0.976, 0.722), 3e-3),
        "{}",
        img.get(0, 0)
    );
}

fn assert_decode_error(path: &Path) {
    match load_image(path, false) {
        Err(e) => {
            let msg = e.to_string();
            let name = path.file_name().unwrap().to_string_lossy().into_owned();
            assert!(msg.contains(&name), "error does not name the file: {msg}");
            assert!(
                matches!(
                    e,
                    TextureError::Decode { .. } | TextureError::UnknownFormat { .. }
                ),
                "{msg}"
            );
        }
        Ok(_) => panic!("{} loaded although it is broken", path.display()),
    }
}

#[test]
fn truncated_and_garbage_files_give_errors() {
    // Truncated PNG.
    let png = scratch("full.png");
    image::RgbImage::from_fn(64, 64, |x, y| image::Rgb([x as u8, y as u8, 7]))
        .save(&png)
        .unwrap();
    let bytes = std::fs::read(&png).unwrap();
    let cut = scratch("truncated.png");
    std::fs::write(&cut, &bytes[..bytes.len() / 2]).unwrap();
    assert_decode_error(&cut);
    // Truncated EXR (cut inside the pixel data and inside the header).
    let exr = scratch("full.exr");
    write_exr(&exr, &Image::filled(64, 64, Vec3::ONE)).unwrap();
    let bytes = std::fs::read(&exr).unwrap();
    for (name, len) in [("truncated.exr", bytes.len() * 2 / 3), ("header.exr", 40)] {
        let cut = scratch(name);
        std::fs::write(&cut, &bytes[..len]).unwrap();
        assert_decode_error(&cut);
    }
    // Truncated JPEG and Radiance HDR.
    let jpg = scratch("full.jpg");
    image::RgbImage::from_fn(64, 64, |x, y| image::Rgb([x as u8 * 3, y as u8 * 2, 7]))
        .save(&jpg)
        .unwrap();
    let bytes = std::fs::read(&jpg).unwrap();
    assert!(load_image(&jpg, false).is_ok());
    let cut = scratch("truncated.jpg");
    std::fs::write(&cut, &bytes[..bytes.len() * 2 / 3]).unwrap();
    assert_decode_error(&cut);
    let hdr = scratch("full.hdr");
    image::Rgb32FImage::from_pixel(32, 32, image::Rgb([1.0, 2.0, 0.5]))
        .save(&hdr)
        .unwrap();
    let bytes = std::fs::read(&hdr).unwrap();
    assert_eq!(
        load_image(&hdr, false).unwrap().image.get(5, 5),
        Vec3::new(1.0, 2.0, 0.5)
    );
    let cut = scratch("truncated.hdr");
    std::fs::write(&cut, &bytes[..bytes.len() / 2]).unwrap();
    assert_decode_error(&cut);
    // Garbage with an image extension, and an empty file.
    let junk = scratch("junk.jpg");
    std::fs::write(&junk, b"this is not an image at all").unwrap();
    assert_decode_error(&junk);
    let empty = scratch("empty.png");
    std::fs::write(&empty, b"").unwrap();
    assert_decode_error(&empty);
    // Missing file: an Io error that names it.
    let missing = scratch("does-not-exist.png");
    let e = load_image(&missing, false).unwrap_err();
    assert!(matches!(e, TextureError::Io { .. }));
    assert!(e.to_string().contains("does-not-exist.png"));
}

/// Every image in the shared data kit loads with the documented size.
#[test]
fn shared_images_load() {
    let Some(shared) = shared_dir() else { return };
    let expect: &[(&str, u32, u32)] = &[
        ("textures/floor_tiles.jpg", 2048, 2048),
        ("textures/floor_tiles_normalmap.jpg", 2048, 2048),
        ("textures/wood.jpg", 2048, 1571),
        ("envmaps/museum.exr", 512, 256),
        ("envmaps/sunset.exr", 1024, 512),
        ("envmaps/forest.exr", 1024, 512),
        ("envmaps/courtyard.exr", 1024, 512),
        ("envmaps/studio.exr", 1024, 512),
        ("envmaps/city.exr", 1024, 512),
        ("envmaps/sunset.hdr", 1024, 512),
        ("scenes/mitsuba/matpreview/envmap.exr", 512, 256),
        ("scenes/torrey/cbox/brick.png", 512, 512),
        ("scenes/torrey/teapot/default.png", 256, 256),
        ("scenes/torrey/teapot/default_colored.png", 256, 256),
        ("scenes/torrey/texture_test/grid.exr", 512, 512),
        ("scenes/torrey/head/lambertian.jpg", 1024, 1024),
        (
            "scenes/torrey/living-room-Wig42/textures/Abstract.jpg",
            768,
            1024,
        ),
        (
            "scenes/torrey/living-room-Wig42/textures/Fabric.jpg",
            512,
            512,
        ),
        (
            "scenes/torrey/living-room-Wig42/textures/WoodFloor.jpg",
            1024,
            786,
        ),
    ];
    for &(rel, w, h) in expect {
        let path = shared.join(rel);
        let raw = rel.contains("normalmap");
        let img = load_image(&path, raw).unwrap_or_else(|e| panic!("{e}"));
        assert_eq!((img.image.width, img.image.height), (w, h), "{rel}");
        assert!(
            img.image
                .pixels
                .iter()
                .all(|p| p.is_finite() && p.min_element() >= 0.0),
            "{rel}"
        );
        let m = mean(&img.image);
        assert!(m.max_element() > 0.0, "{rel} is black");
        // Envmaps with the documented small negative values report them once.
        if ["sunset.exr", "forest.exr", "courtyard.exr", "studio.exr"]
            .iter()
            .any(|n| rel.ends_with(n))
        {
            assert_eq!(img.warnings.len(), 1, "{rel}: {:?}", img.warnings);
        }
    }
    // The grid stand-in: quadrants top-left red, top-right blue, bottom-left green,
    // bottom-right white (DATA.md), so row 0 is the top of the image.
    let grid = load_image(&shared.join(expect[14].0), false).unwrap().image;
    let quad = |qx: u32, qy: u32| {
        let mut s = Vec3::ZERO;
        for y in 0..256 {
            for x in 0..256 {
                s += grid.get(qx * 256 + x, qy * 256 + y);
            }
        }
        s / 65536.0
    };
    let (tl, tr, bl, br) = (quad(0, 0), quad(1, 0), quad(0, 1), quad(1, 1));
    println!("grid.exr quadrant means {tl} {tr} {bl} {br}");
    assert!(tl.x > 1.5 * tl.y && tl.x > 1.5 * tl.z, "{tl}");
    assert!(tr.z > 1.5 * tr.x && tr.z > 1.5 * tr.y, "{tr}");
    assert!(bl.y > 1.5 * bl.x && bl.y > 1.5 * bl.z, "{bl}");
    assert!(
        br.min_element() > 0.5 * br.max_element() && br.min_element() > 0.3,
        "{br}"
    );
    // sunset.hdr holds the pixels of sunset.exr up to RGBE quantisation (1/256 of the max channel).
    let a = load_image(&shared.join("envmaps/sunset.hdr"), false)
        .unwrap()
        .image;
    let b = load_image(&shared.join("envmaps/sunset.exr"), false)
        .unwrap()
        .image;
    for (p, q) in a.pixels.iter().zip(&b.pixels).step_by(97) {
        assert!(
            (*p - *q).abs().max_element() <= q.max_element() / 128.0 + 1e-6,
            "{p} {q}"
        );
    }
}

/// city.exr declares sRGB primaries Bradford-adapted to a D50 white. Mitsuba 3 converts with no
/// white adaptation, so its (and our) reading is warmer than the raw channels: about 20% more red
/// and 26% less blue relative to green. With Bradford adaptation the conversion is nearly the
/// identity, which confirms what the header encodes.
#[test]
fn city_exr_chromaticity_conversion() {
    let Some(shared) = shared_dir() else { return };
    let path = shared.join("envmaps/city.exr");
    let converted = mean(&load_image(&path, false).unwrap().image);
    // The raw channel values, read straight through the exr crate.
    use exr::prelude::*;
    let raw = read_first_rgba_layer_from_file(
        &path,
        |res, _| vec![Vec3::ZERO; res.width() * res.height()],
        |px: &mut Vec<Vec3>, pos, (r, g, b, _a): (f32, f32, f32, f32)| {
            px[pos.y() * 1024 + pos.x()] = Vec3::new(r, g, b).max(Vec3::ZERO);
        },
    )
    .unwrap();
    let c = raw
        .attributes
        .chromaticities
        .expect("city.exr has chromaticities");
    assert!(
        (c.white.0 - 0.3457).abs() < 1e-3,
        "expected a D50 white, got {c:?}"
    );
    let px = &raw.layer_data.channel_data.pixels;
    let raw_mean =
        (px.iter().map(|p| p.as_dvec3()).sum::<glam::DVec3>() / px.len() as f64).as_vec3();
    let (rc, bc) = (converted.x / converted.y, converted.z / converted.y);
    let (rr, br) = (raw_mean.x / raw_mean.y, raw_mean.z / raw_mean.y);
    println!(
        "city.exr mean raw {raw_mean} converted {converted}; R/G {rr} -> {rc}, B/G {br} -> {bc}"
    );
    assert!(rc > rr * 1.15 && rc < rr * 1.25, "R/G {rr} -> {rc}");
    assert!(bc < br * 0.8 && bc > br * 0.7, "B/G {br} -> {bc}");
    // Bradford-adapted reading: white is preserved and the mean barely moves.
    let chroma = torrey_texture::Chromaticities {
        red: [c.red.0 as f64, c.red.1 as f64],
        green: [c.green.0 as f64, c.green.1 as f64],
        blue: [c.blue.0 as f64, c.blue.1 as f64],
        white: [c.white.0 as f64, c.white.1 as f64],
    };
    let m =
        torrey_texture::color::to_rec709_matrix(&chroma, torrey_texture::WhiteAdaptation::Bradford)
            .unwrap();
    let adapted = m * raw_mean;
    assert!(
        adapted.abs_diff_eq(raw_mean, 0.01 * raw_mean.max_element()),
        "{adapted}"
    );
}
