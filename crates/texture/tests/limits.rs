//! Image size caps: headers that declare more pixels than allowed, or more data than the file
//! can hold, are refused before anything of that size is allocated. In its own test binary
//! because the cap is process-wide.

use std::path::PathBuf;
use torrey_texture::{image_pixel_limit, load_image, set_image_pixel_limit, write_exr, Image};

fn scratch(name: &str) -> PathBuf {
    let dir = std::env::temp_dir().join(format!("torrey-texture-limits-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    dir.join(name)
}

/// A valid 1x1 EXR whose dataWindow is then rewritten to claim `w` x `h` pixels.
fn lying_exr(name: &str, w: i32, h: i32) -> PathBuf {
    let path = scratch(name);
    write_exr(&path, &Image::filled(1, 1, glam::Vec3::ONE)).unwrap();
    let mut bytes = std::fs::read(&path).unwrap();
    let key = b"dataWindow\0box2i\0";
    let at = bytes
        .windows(key.len())
        .position(|w| w == key)
        .expect("dataWindow attribute")
        + key.len()
        + 4;
    bytes[at + 8..at + 12].copy_from_slice(&(w - 1).to_le_bytes());
    bytes[at + 12..at + 16].copy_from_slice(&(h - 1).to_le_bytes());
    std::fs::write(&path, &bytes).unwrap();
    path
}

/// A valid 1x1 PNG whose IHDR (with a correct CRC) then claims `w` x `h` pixels.
fn lying_png(name: &str, w: u32, h: u32) -> PathBuf {
    let path = scratch(name);
    image::RgbImage::from_pixel(1, 1, image::Rgb([1, 2, 3]))
        .save(&path)
        .unwrap();
    let mut bytes = std::fs::read(&path).unwrap();
    // Signature (8), IHDR length (4), "IHDR" (4), width, height, 5 more bytes, CRC.
    bytes[16..20].copy_from_slice(&w.to_be_bytes());
    bytes[20..24].copy_from_slice(&h.to_be_bytes());
    let crc = torrey_testkit::crc32(&bytes[12..29]);
    bytes[29..33].copy_from_slice(&crc.to_be_bytes());
    std::fs::write(&path, &bytes).unwrap();
    path
}

fn error_of(path: &std::path::Path) -> String {
    match load_image(path, false) {
        Ok(img) => panic!(
            "{} loaded as {}x{}",
            path.display(),
            img.image.width,
            img.image.height
        ),
        Err(e) => e.to_string(),
    }
}

#[test]
fn lying_headers_are_refused_before_decoding() {
    assert_eq!(image_pixel_limit(), 1 << 25);

    // The reproducer: 313 bytes claiming 100000 x 100000 pixels (40 GB as floats).
    let exr = lying_exr("huge.exr", 100_000, 100_000);
    let e = error_of(&exr);
    assert!(
        e.contains("OpenEXR header declares 100000 x 100000 pixels, more than the limit of 33554432 (raise with --limit image_pixels=N)"),
        "{e}"
    );
    // Within the pixel cap, but 256 scan-line blocks cannot fit in a file this small.
    let exr = lying_exr("big.exr", 4096, 4096);
    let e = error_of(&exr);
    assert!(e.contains("chunks, but the file has only"), "{e}");

    let png = lying_png("huge.png", 8000, 8000);
    let e = error_of(&png);
    assert!(
        e.contains("image header declares 8000 x 8000 pixels, more than the limit of 33554432"),
        "{e}"
    );

    // The cap is adjustable: a lower one refuses a real (small) image, the default takes it.
    let ok = scratch("ok.png");
    image::RgbImage::from_pixel(64, 64, image::Rgb([1, 2, 3]))
        .save(&ok)
        .unwrap();
    set_image_pixel_limit(1000);
    let e = error_of(&ok);
    assert!(
        e.contains("64 x 64 pixels, more than the limit of 1000"),
        "{e}"
    );
    let small_exr = scratch("ok.exr");
    write_exr(&small_exr, &Image::filled(64, 64, glam::Vec3::ONE)).unwrap();
    let e = error_of(&small_exr);
    assert!(
        e.contains("64 x 64 pixels, more than the limit of 1000"),
        "{e}"
    );
    // A file far larger than any allowed image is refused unread (a sparse 70 MB file).
    let big = scratch("big.png");
    std::fs::copy(&ok, &big).unwrap();
    std::fs::OpenOptions::new()
        .write(true)
        .open(&big)
        .unwrap()
        .set_len(70 << 20)
        .unwrap();
    let e = error_of(&big);
    assert!(
        e.contains(
            "the file has 73400320 bytes, more than an image within the limit of 1000 pixels needs"
        ),
        "{e}"
    );
    set_image_pixel_limit(1 << 25);
    assert!(load_image(&ok, false).is_ok());
    assert!(load_image(&small_exr, false).is_ok());
}

#[test]
fn only_regular_files_are_read() {
    if std::path::Path::new("/dev/zero").exists() {
        let e = load_image(std::path::Path::new("/dev/zero"), false)
            .unwrap_err()
            .to_string();
        assert_eq!(e, "/dev/zero: cannot read image file: not a regular file");
    }
    let e = load_image(&std::env::temp_dir(), false)
        .unwrap_err()
        .to_string();
    assert!(
        e.ends_with("cannot read image file: not a regular file"),
        "{e}"
    );
}
