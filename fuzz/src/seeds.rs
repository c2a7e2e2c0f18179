//! Seed inputs: the project's scenes, meshes and textures, and small generated files in the
//! formats the project has none of.

use crate::target::Target;
use std::path::{Path, PathBuf};

/// One input: its bytes and the file extension it is written with.
#[derive(Clone)]
pub(crate) struct Input {
    pub(crate) ext: String,
    pub(crate) bytes: Vec<u8>,
}

pub(crate) fn project_root() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("..")
}

pub(crate) fn read_dir_files(dir: &Path, exts: &[&str]) -> Vec<Input> {
    let mut out = Vec::new();
    let Ok(entries) = std::fs::read_dir(dir) else {
        return out;
    };
    let mut paths: Vec<PathBuf> = entries.flatten().map(|e| e.path()).collect();
    paths.sort();
    for p in paths {
        let ext = p
            .extension()
            .map(|e| e.to_string_lossy().to_ascii_lowercase())
            .unwrap_or_default();
        if exts.contains(&ext.as_str()) {
            if let Ok(bytes) = std::fs::read(&p) {
                out.push(Input { ext, bytes });
            }
        }
    }
    out
}

/// A quad as ASCII and binary PLY, and a triangle as a serialized (v4) file.
pub(crate) fn generated_meshes() -> Vec<Input> {
    let header = |format: &str| {
        format!(
            "ply\nformat {format} 1.0\nelement vertex 4\nproperty float x\nproperty float y\nproperty float z\nproperty float nx\nproperty float ny\nproperty float nz\nproperty float u\nproperty float v\nelement face 1\nproperty list uchar int vertex_indices\nend_header\n"
        )
    };
    let verts = [
        [0.0f32, 0.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0],
        [1.0, 0.0, 0.0, 0.0, 0.0, 1.0, 1.0, 0.0],
        [1.0, 1.0, 0.0, 0.0, 0.0, 1.0, 1.0, 1.0],
        [0.0, 1.0, 0.0, 0.0, 0.0, 1.0, 0.0, 1.0],
    ];
    let mut ascii = header("ascii");
    for v in &verts {
        let t: Vec<String> = v.iter().map(|x| x.to_string()).collect();
        ascii += &t.join(" ");
        ascii += "\n";
    }
    ascii += "4 0 1 2 3\n";
    let mut binary = header("binary_little_endian").into_bytes();
    for v in &verts {
        for x in v {
            binary.extend_from_slice(&x.to_le_bytes());
        }
    }
    binary.push(4);
    for i in 0..4i32 {
        binary.extend_from_slice(&i.to_le_bytes());
    }
    let mut payload = Vec::new();
    payload.extend_from_slice(&(0x1000u32 | 0x1 | 0x2).to_le_bytes());
    payload.extend_from_slice(b"tri\0");
    payload.extend_from_slice(&3u64.to_le_bytes());
    payload.extend_from_slice(&1u64.to_le_bytes());
    for p in [[0.0f32, 0.0, 0.0], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0]] {
        for x in p {
            payload.extend_from_slice(&x.to_le_bytes());
        }
    }
    for _ in 0..3 {
        for x in [0.0f32, 0.0, 1.0] {
            payload.extend_from_slice(&x.to_le_bytes());
        }
    }
    for uv in [[0.0f32, 0.0], [1.0, 0.0], [0.0, 1.0]] {
        for x in uv {
            payload.extend_from_slice(&x.to_le_bytes());
        }
    }
    for i in 0..3u32 {
        payload.extend_from_slice(&i.to_le_bytes());
    }
    let mut ser = Vec::new();
    ser.extend_from_slice(&0x041Cu16.to_le_bytes());
    ser.extend_from_slice(&4u16.to_le_bytes());
    ser.extend_from_slice(&miniz_oxide::deflate::compress_to_vec_zlib(&payload, 6));
    ser.extend_from_slice(&0u64.to_le_bytes());
    ser.extend_from_slice(&1u32.to_le_bytes());
    vec![
        Input {
            ext: "ply".into(),
            bytes: ascii.into_bytes(),
        },
        Input {
            ext: "ply".into(),
            bytes: binary,
        },
        Input {
            ext: "serialized".into(),
            bytes: ser,
        },
    ]
}

/// Small JPEG, BMP, TGA, HDR and 16-bit PNG files made with the image crate.
pub(crate) fn generated_images() -> Vec<Input> {
    let rgb = image::RgbImage::from_fn(8, 6, |x, y| {
        image::Rgb([(x * 30) as u8, (y * 40) as u8, 99])
    });
    let mut out = Vec::new();
    for (fmt, ext) in [
        (image::ImageFormat::Jpeg, "jpg"),
        (image::ImageFormat::Bmp, "bmp"),
        (image::ImageFormat::Tga, "tga"),
        (image::ImageFormat::Png, "png"),
    ] {
        let mut buf = std::io::Cursor::new(Vec::new());
        if image::DynamicImage::ImageRgb8(rgb.clone())
            .write_to(&mut buf, fmt)
            .is_ok()
        {
            out.push(Input {
                ext: ext.into(),
                bytes: buf.into_inner(),
            });
        }
    }
    let hdr = image::DynamicImage::ImageRgb8(rgb.clone()).into_rgb32f();
    let mut buf = std::io::Cursor::new(Vec::new());
    if image::DynamicImage::ImageRgb32F(hdr)
        .write_to(&mut buf, image::ImageFormat::Hdr)
        .is_ok()
    {
        out.push(Input {
            ext: "hdr".into(),
            bytes: buf.into_inner(),
        });
    }
    let rgb16 = image::DynamicImage::ImageRgb8(rgb).into_rgb16();
    let mut buf = std::io::Cursor::new(Vec::new());
    if image::DynamicImage::ImageRgb16(rgb16)
        .write_to(&mut buf, image::ImageFormat::Png)
        .is_ok()
    {
        out.push(Input {
            ext: "png".into(),
            bytes: buf.into_inner(),
        });
    }
    out
}

pub(crate) fn seeds(target: Target) -> Vec<Input> {
    let root = project_root();
    match target {
        Target::Xml | Target::Render => read_dir_files(&root.join("scenes"), &["xml"]),
        Target::Mesh => {
            let mut s = read_dir_files(&root.join("scenes/meshes"), &["obj", "ply", "serialized"]);
            s.extend(generated_meshes());
            s
        }
        Target::Image => {
            let mut s = read_dir_files(
                &root.join("textures"),
                &["png", "jpg", "jpeg", "exr", "hdr", "bmp", "tga"],
            );
            s.extend(generated_images());
            s
        }
    }
}
