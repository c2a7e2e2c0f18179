//! Denoising a rendered image with Intel Open Image Denoise (OIDN 2.x, its `RT` filter in HDR
//! mode with albedo and normal guides, the guides prefiltered), through the `oidn` crate's
//! device and OIDN's C API. No denoiser is written here.
//!
//! The library is optional: built without the `oidn` feature, [`denoise`] is an error that says
//! how to get it ([`HOW_TO_GET`]). `bash crates/denoise/install-oidn.sh` installs OIDN 2.5.1 from
//! the PyPI wheel `pyoidn` into `.oidn/`, where `.cargo/config.toml` points `OIDN_DIR`; then
//! `cargo build --release --features denoise` builds torrey with it.

/// What to do to denoise with a torrey built without OIDN.
pub const HOW_TO_GET: &str = "this torrey was built without Intel Open Image Denoise: run `bash crates/denoise/install-oidn.sh` (installs OIDN 2.5.1 from the PyPI wheel pyoidn into .oidn/), then build with `cargo build --release --features denoise` (Python: `pip install ./python` with MATURIN_PEP517_ARGS=\"--features denoise\")";

/// Whether this build can denoise.
pub const AVAILABLE: bool = cfg!(feature = "oidn");

/// How [`denoise`] treats its guides, Cycles' choices by Cycles' names.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum Prefilter {
    /// Each guide is denoised on its own first and the image's filter told they are clean:
    /// OIDN's recommended setting for noisy guides (4-27% lower relMSE on real scenes at 16
    /// spp), for about four times the denoiser's time (OIDN 2.5.1, CPU).
    #[default]
    Accurate,
    /// The guides go in as they are, denoised with the image.
    Fast,
}

impl std::str::FromStr for Prefilter {
    type Err = String;
    fn from_str(s: &str) -> Result<Self, String> {
        match s {
            "accurate" => Ok(Prefilter::Accurate),
            "fast" => Ok(Prefilter::Fast),
            _ => Err(format!(
                "unknown denoise prefilter '{s}' (expected 'accurate' or 'fast')"
            )),
        }
    }
}

/// The guides of [`denoise`]: per pixel, the albedo (RGB in [0, 1]) and the normal (any length,
/// world space), row by row, interleaved like the colour.
pub struct Guides<'a> {
    pub albedo: &'a [f32],
    pub normal: &'a [f32],
}

/// The denoised `color` (linear HDR RGB, `width * height * 3` floats, row by row), with the
/// guides if given, treated as `prefilter` says. Errors without the library ([`HOW_TO_GET`]) or
/// when OIDN reports one.
pub fn denoise(
    width: usize,
    height: usize,
    color: &[f32],
    guides: Option<Guides>,
    prefilter: Prefilter,
) -> Result<Vec<f32>, String> {
    let n = width * height * 3;
    if color.len() != n {
        return Err(format!(
            "denoise: {} floats for a {width}x{height} RGB image",
            color.len()
        ));
    }
    if let Some(g) = &guides {
        if g.albedo.len() != n || g.normal.len() != n {
            return Err("denoise: the guides do not have the image's size".into());
        }
    }
    // OIDN's network sees no context past the image's edge and bends its outermost pixels (a
    // flat image's by up to 20%, 4% one pixel in): the image goes in mirrored out by PAD pixels
    // on every side, and only its own pixels come back.
    let pad = PAD.min(width - 1).min(height - 1);
    let (pw, ph) = (width + 2 * pad, height + 2 * pad);
    let padded = |v: &[f32]| mirror(v, width, height, pad);
    let (albedo, normal) = match &guides {
        Some(g) => (padded(g.albedo), padded(g.normal)),
        None => (Vec::new(), Vec::new()),
    };
    let guides = guides.map(|_| Guides {
        albedo: &albedo,
        normal: &normal,
    });
    let out = imp::denoise(pw, ph, &padded(color), guides, prefilter)?;
    Ok((pad..pad + height)
        .flat_map(|y| {
            out[(y * pw + pad) * 3..(y * pw + pad + width) * 3]
                .iter()
                .copied()
        })
        .collect())
}

/// Pixels the image is extended by on each side for the denoiser.
const PAD: usize = 16;

/// `v` (RGB rows of `width`) extended by `pad` pixels on every side, mirrored about the edge
/// pixels.
fn mirror(v: &[f32], width: usize, height: usize, pad: usize) -> Vec<f32> {
    let reflect = |i: isize, n: usize| -> usize {
        let n = n as isize;
        let i = if i < 0 { -i } else { i };
        (if i >= n { 2 * (n - 1) - i } else { i }) as usize
    };
    let (pw, ph) = (width + 2 * pad, height + 2 * pad);
    let mut out = Vec::with_capacity(pw * ph * 3);
    for y in 0..ph {
        let sy = reflect(y as isize - pad as isize, height);
        for x in 0..pw {
            let sx = reflect(x as isize - pad as isize, width);
            out.extend_from_slice(&v[(sy * width + sx) * 3..(sy * width + sx) * 3 + 3]);
        }
    }
    out
}

#[cfg(feature = "oidn")]
mod imp {
    use super::{Guides, Prefilter};
    use oidn::sys;
    use std::ffi::CStr;

    /// OIDN's quality settings (`OIDNQuality`).
    const BALANCED: i32 = 5;
    const HIGH: i32 = 6;

    pub fn denoise(
        width: usize,
        height: usize,
        color: &[f32],
        guides: Option<Guides>,
        prefilter: Prefilter,
    ) -> Result<Vec<f32>, String> {
        let device = oidn::Device::cpu().map_err(fail)?;
        let rt = |images: &[(&CStr, &[f32])], hdr: bool, clean_aux: bool, quality: i32| {
            run_rt(&device, width, height, images, hdr, clean_aux, quality)
        };
        match (guides, prefilter) {
            // The guides are Monte Carlo estimates too (the albedo is a BSDF sample's weight):
            // each is denoised on its own first (OIDN's auxiliary-image mode), and the image's
            // filter is told they are clean. The guides' filters at balanced quality: the
            // image's error is the same as with high (real scenes, OIDN 2.5.1) in half their
            // time.
            (Some(g), Prefilter::Accurate) => {
                let albedo = rt(&[(c"albedo", g.albedo)], false, false, BALANCED)?;
                let normal = rt(&[(c"normal", g.normal)], false, false, BALANCED)?;
                rt(
                    &[
                        (c"color", color),
                        (c"albedo", &albedo),
                        (c"normal", &normal),
                    ],
                    true,
                    true,
                    HIGH,
                )
            }
            (Some(g), Prefilter::Fast) => rt(
                &[
                    (c"color", color),
                    (c"albedo", g.albedo),
                    (c"normal", g.normal),
                ],
                true,
                false,
                HIGH,
            ),
            (None, _) => rt(&[(c"color", color)], true, false, HIGH),
        }
    }

    fn fail(e: oidn::Error) -> String {
        format!("Open Image Denoise: {e:?}")
    }

    /// OIDN's `RT` filter on `images` (each `width * height` RGB floats, named as OIDN names its
    /// inputs), its output returned; `hdr`, `cleanAux` and `quality` as given. Driven through
    /// OIDN's C API: the `oidn` crate cannot run the filter on a guide alone (it always sets a
    /// colour) and sets `cleanAux` under a name OIDN does not know (`clean_aux`, oidn 2.5.1).
    fn run_rt(
        device: &oidn::Device,
        width: usize,
        height: usize,
        images: &[(&CStr, &[f32])],
        hdr: bool,
        clean_aux: bool,
        quality: i32,
    ) -> Result<Vec<f32>, String> {
        let n = width * height * 3;
        assert!(images.iter().all(|(_, data)| data.len() == n));
        let mut out = vec![0.0f32; n];
        // SAFETY: the device handle is alive for the call (borrowed); the filter is created,
        // used and released here; every image is `width * height` densely packed FLOAT3 pixels
        // (strides 0) that outlive the synchronous execution (the CPU device works on the
        // shared memory in place and only writes the output).
        unsafe {
            let filter = sys::oidnNewFilter(device.raw(), c"RT".as_ptr());
            if filter.is_null() {
                device.get_error().map_err(fail)?;
                return Err("Open Image Denoise: no RT filter".into());
            }
            let set = |name: &CStr, ptr: *mut f32| {
                sys::oidnSetSharedFilterImage(
                    filter,
                    name.as_ptr(),
                    ptr.cast(),
                    sys::OIDNFormat_OIDN_FORMAT_FLOAT3,
                    width,
                    height,
                    0,
                    0,
                    0,
                )
            };
            for (name, data) in images {
                set(name, data.as_ptr().cast_mut());
            }
            set(c"output", out.as_mut_ptr());
            sys::oidnSetFilterBool(filter, c"hdr".as_ptr(), hdr);
            sys::oidnSetFilterBool(filter, c"cleanAux".as_ptr(), clean_aux);
            sys::oidnSetFilterInt(filter, c"quality".as_ptr(), quality);
            sys::oidnCommitFilter(filter);
            sys::oidnExecuteFilter(filter);
            sys::oidnReleaseFilter(filter);
        }
        device.get_error().map_err(fail)?;
        Ok(out)
    }
}

#[cfg(not(feature = "oidn"))]
mod imp {
    use super::{Guides, Prefilter};

    pub fn denoise(
        _: usize,
        _: usize,
        _: &[f32],
        _: Option<Guides>,
        _: Prefilter,
    ) -> Result<Vec<f32>, String> {
        Err(super::HOW_TO_GET.to_string())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The mirrored border: the image's own pixels in the middle, reflected about the edges.
    #[test]
    fn mirror_padding() {
        let v: Vec<f32> = (0..3 * 2).flat_map(|i| [i as f32; 3]).collect();
        let m = mirror(&v, 3, 2, 1);
        let firsts: Vec<f32> = m.chunks(3).map(|p| p[0]).collect();
        assert_eq!(
            firsts,
            [4., 3., 4., 5., 4., 1., 0., 1., 2., 1., 4., 3., 4., 5., 4., 1., 0., 1., 2., 1.]
        );
    }

    /// A flat colour with noise-free guides stays flat, to the edges (OIDN alone bends the
    /// outermost pixels by up to 20%), and keeps its level; a noisy flat colour comes out much
    /// flatter than it went in, also with a noisy albedo guide, whose noise the accurate
    /// prefilter keeps out of the image. Without the library the call is an error that says how to get
    /// it.
    #[test]
    fn a_flat_image_stays_flat() {
        let (w, h) = (64, 48);
        let flat = vec![0.25f32; w * h * 3];
        let albedo = vec![0.5f32; w * h * 3];
        let normal: Vec<f32> = (0..w * h).flat_map(|_| [0.0, 0.0, 1.0]).collect();
        let guides = || Guides {
            albedo: &albedo,
            normal: &normal,
        };
        let result = denoise(w, h, &flat, Some(guides()), Prefilter::Accurate);
        if !AVAILABLE {
            let err = result.unwrap_err();
            assert!(err.contains("install-oidn.sh"), "{err}");
            return;
        }
        let out = result.unwrap();
        let (lo, hi) = out
            .iter()
            .fold((f32::MAX, f32::MIN), |(a, b), &v| (a.min(v), b.max(v)));
        assert!(
            lo > 0.2475 && hi < 0.2525,
            "a flat 0.25 came out in {lo}..{hi}"
        );

        // The same level with ±50% grey noise (a hash per pixel): the spread shrinks fourfold.
        let noise = |seed: u64, level: f32, amplitude: f32| -> Vec<f32> {
            (0..w * h)
                .flat_map(|i| {
                    let mut x = (i as u64 + seed).wrapping_mul(0x9E37_79B9_7F4A_7C15);
                    x ^= x >> 29;
                    x = x.wrapping_mul(0xBF58_476D_1CE4_E5B9);
                    x ^= x >> 32;
                    let u = (x >> 40) as f32 / (1u64 << 24) as f32;
                    [level * (1.0 + amplitude * (2.0 * u - 1.0)); 3]
                })
                .collect()
        };
        let noisy = noise(1, 0.25, 0.5);
        let out = denoise(w, h, &noisy, Some(guides()), Prefilter::Accurate).unwrap();
        let sd = |v: &[f32]| {
            let m = v.iter().sum::<f32>() / v.len() as f32;
            (v.iter().map(|x| (x - m) * (x - m)).sum::<f32>() / v.len() as f32).sqrt()
        };
        let mean = out.iter().sum::<f32>() / out.len() as f32;
        assert!((mean - 0.25).abs() < 0.01, "mean {mean}");
        assert!(
            sd(&out) < sd(&noisy) / 4.0,
            "{} vs {}",
            sd(&out),
            sd(&noisy)
        );
        // A noisy albedo guide (it is a BSDF sample's weight, noisy at low sample counts): the
        // guides are denoised first, so their noise does not come back into the image.
        let noisy_albedo = noise(0x51ed_270b, 0.5, 1.0);
        let with = |prefilter| {
            let guides = Guides {
                albedo: &noisy_albedo,
                normal: &normal,
            };
            denoise(w, h, &noisy, Some(guides), prefilter).unwrap()
        };
        let (accurate, fast) = (with(Prefilter::Accurate), with(Prefilter::Fast));
        // OIDN 2.5.1: 0.0041 with the guides denoised first, 0.0099 without.
        assert!(
            sd(&accurate) < sd(&noisy) / 11.0 && sd(&accurate) < sd(&fast) / 1.5,
            "noisy guides: accurate {}, fast {}, input {}",
            sd(&accurate),
            sd(&fast),
            sd(&noisy)
        );
    }
}
