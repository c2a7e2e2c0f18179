//! Reading textures and environment maps from disk, and writing renders back out.
//!
//! Every loader produces the same linear-RGB [`Image`], so the renderer never cares where a
//! texture came from. Bad files give a [`TextureError`] that names the file and the reason.

use std::io::Cursor;
use std::panic::{catch_unwind, AssertUnwindSafe};
use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicU64, Ordering};

use glam::{Mat3, Vec3};

use crate::color::{
    srgb8_lut, srgb_to_linear, to_rec709_matrix, unorm8_lut, Chromaticities, WhiteAdaptation,
};
use crate::image::{Codes8, Image};

/// What went wrong while reading or writing an image; the `Display` text always names the file.
#[derive(Debug, thiserror::Error)]
pub enum TextureError {
    /// The file could not be opened or read at all (missing, permissions, ...).
    #[error("{path}: cannot read image file: {source}")]
    Io {
        /// The file.
        path: PathBuf,
        /// What the operating system said.
        #[source]
        source: std::io::Error,
    },
    /// The bytes are not a recognised image format.
    #[error("{path}: unrecognised image format ({reason})")]
    UnknownFormat {
        /// The file.
        path: PathBuf,
        /// Why it was not recognised.
        reason: String,
    },
    /// The format was recognised but decoding failed (truncated, corrupt, unsupported variant).
    #[error("{path}: cannot decode image: {reason}")]
    Decode {
        /// The file.
        path: PathBuf,
        /// The decoder's complaint.
        reason: String,
    },
    /// Writing an output image failed.
    #[error("{path}: cannot write image: {reason}")]
    Write {
        /// The output file.
        path: PathBuf,
        /// The encoder's or file system's complaint.
        reason: String,
    },
}

/// A decoded image plus non-fatal problems found while loading it (e.g. clamped NaN texels), so
/// the caller can decide how loudly to report them.
#[derive(Clone, Debug)]
pub struct LoadedImage {
    /// The pixels, linear RGB with Rec.709 primaries.
    pub image: Image,
    /// Non-fatal problems, each naming the file; empty for a clean file.
    pub warnings: Vec<String>,
    /// An 8-bit image's codes, from which `image` was decoded (None for other images).
    pub codes: Option<Codes8>,
}

const EXR_MAGIC: [u8; 4] = [0x76, 0x2f, 0x31, 0x01];

/// Default of [`image_pixel_limit`]: 2^25 = 33,554,432 pixels (an 8192 × 4096 environment map).
pub const DEFAULT_IMAGE_PIXEL_LIMIT: u64 = 1 << 25;

static IMAGE_PIXEL_LIMIT: AtomicU64 = AtomicU64::new(DEFAULT_IMAGE_PIXEL_LIMIT);

/// The most pixels an image file may declare (width × height) for [`load_image`] to decode
/// it. Checked against the file's header before any pixel is allocated, so a lying header (a
/// 313-byte EXR that claims 100000 × 100000 pixels) is an error, not a 40 GB allocation. Decoding
/// costs up to about 60 bytes per pixel at the peak (decoder buffers, linear floats, mip
/// pyramid), so the default keeps one image under 2 GB. Process-wide, because images are
/// loaded deep inside scene building; `torrey --limit image_pixels=N` sets it.
pub fn image_pixel_limit() -> u64 {
    IMAGE_PIXEL_LIMIT.load(Ordering::Relaxed)
}

/// Sets [`image_pixel_limit`] for the whole process.
pub fn set_image_pixel_limit(pixels: u64) {
    IMAGE_PIXEL_LIMIT.store(pixels, Ordering::Relaxed);
}

/// Bytes of decoded samples per allowed pixel: RGBA in 32-bit floats.
const BYTES_PER_PIXEL_BUDGET: u64 = 16;

/// Loads PNG, JPEG, BMP, TGA, Radiance HDR or OpenEXR into linear RGB.
///
/// 8-bit and 16-bit integer images are sRGB-decoded unless `raw` (normal maps, roughness maps,
/// which store data rather than colour); float images (EXR, HDR) are already linear and `raw`
/// does not change them. An EXR `chromaticities` attribute is honoured by converting to Rec.709
/// primaries exactly as Mitsuba 3 does (RGB→XYZ→Rec.709 with no white-point adaptation, see
/// [`WhiteAdaptation::None`]) regardless of `raw`. Gray images give r=g=b and
/// alpha is dropped. NaN, infinite and negative texels become 0 with one warning per file. The
/// format is detected from the file's bytes, not its extension. Only regular files are read,
/// and images larger than [`image_pixel_limit`] (or files larger than such an image's samples
/// plus 64 MiB) are refused before decoding.
pub fn load_image(path: &Path, raw: bool) -> Result<LoadedImage, TextureError> {
    let (mut image, mut warnings, source) = load_unchecked(path, raw)?;
    // Integer texels decode to finite, non-negative values: only float images are checked.
    let bad = match source {
        Samples::Float => sanitize(&mut image.pixels),
        Samples::Integer | Samples::Codes8(_) => 0,
    };
    let codes = match source {
        Samples::Codes8(codes) => Some(codes),
        Samples::Float | Samples::Integer => None,
    };
    if bad > 0 {
        warnings.push(format!(
            "{}: {bad} texel channel(s) were NaN, infinite or negative and were clamped to 0",
            path.display()
        ));
    }
    Ok(LoadedImage {
        image,
        warnings,
        codes,
    })
}

/// Like [`load_image`] (8-bit images sRGB-decoded), but NaN, infinite and negative values are
/// kept as the file stores them: for comparing images, where they must be seen, not hidden.
pub fn load_image_as_stored(path: &Path) -> Result<LoadedImage, TextureError> {
    let (image, warnings, _) = load_unchecked(path, false)?;
    Ok(LoadedImage {
        image,
        warnings,
        codes: None,
    })
}

fn load_unchecked(path: &Path, raw: bool) -> Result<Decoded, TextureError> {
    let io_err = |source| TextureError::Io {
        path: path.to_path_buf(),
        source,
    };
    let decode_err = |reason: String| TextureError::Decode {
        path: path.to_path_buf(),
        reason,
    };
    // A device or FIFO (/dev/zero) would be read forever; a regular file's size bounds the read.
    let meta = std::fs::metadata(path).map_err(io_err)?;
    if !meta.is_file() {
        return Err(io_err(std::io::Error::new(
            std::io::ErrorKind::InvalidInput,
            "not a regular file",
        )));
    }
    let limit = image_pixel_limit();
    // No accepted image needs more than its decoded samples plus room for metadata (previews,
    // attributes): a bigger file is refused unread.
    let max_bytes = limit
        .saturating_mul(BYTES_PER_PIXEL_BUDGET)
        .saturating_add(64 << 20);
    if meta.len() > max_bytes {
        return Err(decode_err(format!(
            "the file has {} bytes, more than an image within the limit of {limit} pixels needs ({RAISE})",
            meta.len()
        )));
    }
    let bytes = std::fs::read(path).map_err(io_err)?;
    // Decoders are third-party code fed untrusted bytes: a panic inside one must still come
    // back as an error naming the file.
    let decoded = catch_unwind(AssertUnwindSafe(|| {
        if bytes.starts_with(&EXR_MAGIC) {
            check_exr_header(&bytes, limit).map_err(decode_err)?;
            decode_exr(&bytes, path)
        } else {
            decode_with_image_crate(&bytes, raw, path, limit)
        }
    }))
    .map_err(|payload| {
        let msg = payload
            .downcast_ref::<&str>()
            .map(|s| s.to_string())
            .or_else(|| payload.downcast_ref::<String>().cloned())
            .unwrap_or_else(|| "unknown".to_string());
        decode_err(format!("decoder panicked: {msg}"))
    })??;
    let (image, _, _) = &decoded;
    if image.width == 0 || image.height == 0 {
        return Err(decode_err(format!(
            "image has zero size ({}x{})",
            image.width, image.height
        )));
    }
    Ok(decoded)
}

/// The "raise it" hint appended to limit errors.
const RAISE: &str = "raise with --limit image_pixels=N";

/// Checks what an OpenEXR file's headers declare before anything is decoded: every layer's
/// pixel count against `limit`, its decoded samples against 16 bytes per allowed pixel, and
/// its size against the file's: each chunk (a block of scan lines or a tile) needs an 8-byte
/// entry in the offset table, and uncompressed, RLE and ZIP data cannot shrink by more than
/// 1, 64 and 1032 (deflate's bound) times.
fn check_exr_header(bytes: &[u8], limit: u64) -> Result<(), String> {
    use exr::compression::Compression as C;
    let meta = exr::meta::MetaData::read_from_buffered(Cursor::new(bytes), false)
        .map_err(|e| format!("OpenEXR: {e}"))?;
    let file_len = bytes.len() as u64;
    for h in meta.headers.iter().filter(|h| !h.deep) {
        let (w, ht) = (h.layer_size.0 as u64, h.layer_size.1 as u64);
        let pixels = w.saturating_mul(ht);
        if pixels > limit {
            return Err(format!(
                "OpenEXR header declares {w} x {ht} pixels, more than the limit of {limit} ({RAISE})"
            ));
        }
        let samples: u64 = h
            .channels
            .list
            .iter()
            .map(|c| {
                let (sx, sy) = (c.sampling.0.max(1) as u64, c.sampling.1.max(1) as u64);
                w.div_ceil(sx)
                    .saturating_mul(ht.div_ceil(sy))
                    .saturating_mul(c.sample_type.bytes_per_sample() as u64)
            })
            .fold(0u64, u64::saturating_add);
        if samples > limit.saturating_mul(BYTES_PER_PIXEL_BUDGET) {
            return Err(format!(
                "OpenEXR header declares {} channels of {w} x {ht} pixels ({samples} bytes), more than {BYTES_PER_PIXEL_BUDGET} bytes per allowed pixel ({RAISE})",
                h.channels.list.len()
            ));
        }
        let chunks = h.chunk_count as u64;
        if chunks.saturating_mul(8) > file_len {
            return Err(format!(
                "OpenEXR header declares {chunks} chunks, but the file has only {file_len} bytes (each chunk needs at least 8)"
            ));
        }
        let ratio = match h.compression {
            C::Uncompressed => Some(1),
            C::RLE => Some(64),
            C::ZIP1 | C::ZIP16 => Some(1032),
            _ => None,
        };
        if let Some(r) = ratio {
            if samples > file_len.saturating_mul(r) {
                return Err(format!(
                    "OpenEXR header declares {samples} bytes of samples, more than a {file_len}-byte file can hold with {:?} compression",
                    h.compression
                ));
            }
        }
    }
    Ok(())
}

/// Replaces NaN/inf/negative channels with 0 and returns how many were replaced.
fn sanitize(pixels: &mut [Vec3]) -> usize {
    use rayon::prelude::*;
    pixels
        .par_chunks_mut(1 << 14)
        .map(|chunk| {
            let mut bad = 0;
            for p in chunk {
                for c in [&mut p.x, &mut p.y, &mut p.z] {
                    if !(c.is_finite() && *c >= 0.0) {
                        *c = 0.0;
                        bad += 1;
                    }
                }
            }
            bad
        })
        .sum()
}

/// A decoded image, the decoder's warnings, and what its samples were.
type Decoded = (Image, Vec<String>, Samples);

/// What a decoded image's samples were in the file.
enum Samples {
    /// Floats, which may be NaN, infinite or negative.
    Float,
    /// 16-bit integers: finite, non-negative values.
    Integer,
    /// 8-bit codes, kept: the image holds their table's values.
    Codes8(Codes8),
}

fn decode_with_image_crate(
    bytes: &[u8],
    raw: bool,
    path: &Path,
    limit: u64,
) -> Result<Decoded, TextureError> {
    use image::DynamicImage as D;
    let new_reader = || {
        image::ImageReader::new(Cursor::new(bytes))
            .with_guessed_format()
            .map_err(|e| TextureError::Decode {
                path: path.to_path_buf(),
                reason: e.to_string(),
            })
    };
    let mut reader = new_reader()?;
    if reader.format().is_none() {
        let ext = path
            .extension()
            .map(|e| e.to_string_lossy().into_owned())
            .unwrap_or_default();
        return Err(TextureError::UnknownFormat {
            path: path.to_path_buf(),
            reason: format!("content is not PNG, JPEG, BMP, TGA, HDR or EXR (extension \"{ext}\")"),
        });
    }
    if reader.format() == Some(image::ImageFormat::Jpeg) {
        jpeg_complete(bytes).map_err(|reason| TextureError::Decode {
            path: path.to_path_buf(),
            reason,
        })?;
    }
    // The header's size first, then decode with the crate's own allocation cap as well.
    let (w, h) = new_reader()?
        .into_dimensions()
        .map_err(|e| TextureError::Decode {
            path: path.to_path_buf(),
            reason: e.to_string(),
        })?;
    if w as u64 * h as u64 > limit {
        return Err(TextureError::Decode {
            path: path.to_path_buf(),
            reason: format!(
                "image header declares {w} x {h} pixels, more than the limit of {limit} ({RAISE})"
            ),
        });
    }
    let mut caps = image::Limits::default();
    caps.max_alloc = Some(limit.saturating_mul(BYTES_PER_PIXEL_BUDGET).max(1 << 20));
    reader.limits(caps);
    let dynimg = reader.decode().map_err(|e| TextureError::Decode {
        path: path.to_path_buf(),
        reason: e.to_string(),
    })?;
    let (w, h) = (dynimg.width(), dynimg.height());
    let mut samples = Samples::Float;
    let pixels: Vec<Vec3> = match dynimg {
        D::ImageLuma8(_) | D::ImageLumaA8(_) | D::ImageRgb8(_) | D::ImageRgba8(_) => {
            // The texels are filled below; the table first, for their values.
            let mut codes = Codes8 {
                texels: Box::default(),
                table: if raw { unorm8_lut() } else { srgb8_lut() },
            };
            let rgb = dynimg.into_rgb8();
            use rayon::prelude::*;
            // One pass: each texel's codes, and its value through the table the lookups use.
            let (texels, pixels): (Vec<[u8; 3]>, Vec<Vec3>) = rgb
                .as_raw()
                .par_chunks_exact(3)
                .with_min_len(1 << 14)
                .map(|p| {
                    let c = [p[0], p[1], p[2]];
                    (c, Vec3::from_array(codes.value(c)))
                })
                .unzip();
            codes.texels = texels.into_boxed_slice();
            samples = Samples::Codes8(codes);
            pixels
        }
        D::ImageLuma16(_) | D::ImageLumaA16(_) | D::ImageRgb16(_) | D::ImageRgba16(_) => {
            let conv = |v: u16| {
                let x = v as f32 / 65535.0;
                if raw {
                    x
                } else {
                    srgb_to_linear(x)
                }
            };
            samples = Samples::Integer;
            let rgb = dynimg.into_rgb16();
            rgb.pixels()
                .map(|p| Vec3::new(conv(p[0]), conv(p[1]), conv(p[2])))
                .collect()
        }
        // Float images (Radiance HDR, and anything else the crate decodes to f32) are linear.
        other => {
            let rgb = other.into_rgb32f();
            rgb.pixels().map(|p| Vec3::new(p[0], p[1], p[2])).collect()
        }
    };
    Ok((Image::new(w, h, pixels), Vec::new(), samples))
}

/// The JPEG decoder fills a truncated scan with filler and reports success, so check the
/// structure ourselves: after the last start-of-scan marker (FF DA) there must be an
/// end-of-image marker (FF D9). Inside entropy-coded data an FF byte is always followed by 00 or
/// a restart marker, so FF D9 there can only be the real end; trailing bytes after it are fine.
fn jpeg_complete(bytes: &[u8]) -> Result<(), String> {
    let last_sos = bytes
        .windows(2)
        .rposition(|w| w == [0xFF, 0xDA])
        .ok_or_else(|| "JPEG has no image data (no start-of-scan marker)".to_string())?;
    if bytes[last_sos..].windows(2).any(|w| w == [0xFF, 0xD9]) {
        Ok(())
    } else {
        Err("JPEG data ends without an end-of-image marker (file truncated?)".to_string())
    }
}

/// Finds a channel by name: an exact match first, else one whose last `.`-separated component
/// matches (a layered file's `beauty.R`).
fn find_channel(names: &[String], want: &str) -> Option<usize> {
    names
        .iter()
        .position(|n| n.eq_ignore_ascii_case(want))
        .or_else(|| {
            names.iter().position(|n| {
                n.rsplit('.')
                    .next()
                    .is_some_and(|last| last.eq_ignore_ascii_case(want))
            })
        })
}

fn decode_exr(bytes: &[u8], path: &Path) -> Result<Decoded, TextureError> {
    use exr::prelude::*;
    let err = |reason: String| TextureError::Decode {
        path: path.to_path_buf(),
        reason,
    };
    let img = read()
        .no_deep_data()
        .largest_resolution_level()
        .all_channels()
        .first_valid_layer()
        .all_attributes()
        .pedantic()
        .non_parallel()
        .from_buffered(Cursor::new(bytes))
        .map_err(|e| err(format!("OpenEXR: {e}")))?;
    let layer = &img.layer_data;
    let (w, h) = (layer.size.width(), layer.size.height());
    let n = w * h;
    let channels = &layer.channel_data.list;
    let names: Vec<String> = channels.iter().map(|c| c.name.to_string()).collect();
    let rgb = [
        find_channel(&names, "R"),
        find_channel(&names, "G"),
        find_channel(&names, "B"),
    ];
    let chosen: [usize; 3] = match rgb {
        [Some(r), Some(g), Some(b)] => [r, g, b],
        _ => {
            let y = find_channel(&names, "Y").or(if channels.len() == 1 { Some(0) } else { None });
            match y {
                Some(y) => [y, y, y],
                None => {
                    return Err(err(format!(
                        "OpenEXR layer has no R,G,B or Y channels (found: {})",
                        names.join(", ")
                    )))
                }
            }
        }
    };
    let mut planes: Vec<Vec<f32>> = Vec::with_capacity(3);
    for &c in &chosen {
        let ch = &channels[c];
        if ch.sample_data.len() != n {
            return Err(err(format!(
                "OpenEXR channel {} is subsampled ({} samples for {}x{} pixels), not supported",
                names[c],
                ch.sample_data.len(),
                w,
                h
            )));
        }
        planes.push(ch.sample_data.values_as_f32().collect());
    }
    let mut pixels: Vec<Vec3> = (0..n)
        .map(|i| Vec3::new(planes[0][i], planes[1][i], planes[2][i]))
        .collect();
    let mut warnings = Vec::new();
    if let Some(c) = img.attributes.chromaticities {
        let chroma = Chromaticities {
            red: [c.red.0 as f64, c.red.1 as f64],
            green: [c.green.0 as f64, c.green.1 as f64],
            blue: [c.blue.0 as f64, c.blue.1 as f64],
            white: [c.white.0 as f64, c.white.1 as f64],
        };
        if !chroma.approx_eq(&Chromaticities::REC709, 1e-4) {
            match to_rec709_matrix(&chroma, WhiteAdaptation::None) {
                Some(m) => convert(&mut pixels, m),
                None => warnings.push(format!(
                    "{}: degenerate chromaticities attribute {chroma:?} ignored",
                    path.display()
                )),
            }
        }
    }
    let (w, h) = (
        u32::try_from(w).map_err(|_| err("width too large".into()))?,
        u32::try_from(h).map_err(|_| err("height too large".into()))?,
    );
    Ok((
        crate::image::Image::new(w, h, pixels),
        warnings,
        Samples::Float,
    ))
}

fn convert(pixels: &mut [Vec3], m: Mat3) {
    for p in pixels {
        *p = m * *p;
    }
}

/// Writes a linear float32 RGB OpenEXR (ZIP compressed): the lossless output for comparisons.
pub fn write_exr(path: &Path, image: &Image) -> Result<(), TextureError> {
    use exr::prelude::{Encoding, Layer, LayerAttributes, SpecificChannels, Vec2, WritableImage};
    let w = image.width as usize;
    let channels = SpecificChannels::rgb(|Vec2(x, y): Vec2<usize>| {
        let p = image.pixels[y * w + x];
        (p.x, p.y, p.z)
    });
    let layer = Layer::new(
        (w, image.height as usize),
        LayerAttributes::default(),
        Encoding::SMALL_LOSSLESS,
        channels,
    );
    exr::prelude::Image::from_layer(layer)
        .write()
        .to_file(path)
        .map_err(|e| TextureError::Write {
            path: path.to_path_buf(),
            reason: e.to_string(),
        })
}

/// Writes an 8-bit sRGB PNG: each channel is clamped to [0, 1] (NaN → 0), sRGB-encoded and
/// rounded. Tonemapping, if any, is the caller's job.
pub fn write_png_srgb(path: &Path, image: &Image) -> Result<(), TextureError> {
    let mut buf = Vec::with_capacity(image.pixels.len() * 3);
    for p in &image.pixels {
        for c in [p.x, p.y, p.z] {
            let c = if c.is_nan() { 0.0 } else { c.clamp(0.0, 1.0) };
            buf.push((crate::color::linear_to_srgb(c) * 255.0 + 0.5) as u8);
        }
    }
    image::save_buffer_with_format(
        path,
        &buf,
        image.width,
        image.height,
        image::ColorType::Rgb8,
        image::ImageFormat::Png,
    )
    .map_err(|e| TextureError::Write {
        path: path.to_path_buf(),
        reason: e.to_string(),
    })
}
