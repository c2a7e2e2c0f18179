//! The published Mitsuba scenes of ../shared/scenes/mitsuba-real (staircase, matpreview-copper,
//! matpreview-glass, stage-lights, veach-direct; with media clover-banner and bunny-sss; not
//! volumetric-caustic, whose reference's caustic fireflies need more samples than CI can give)
//! against their Mitsuba 3.9.1 references (refs/<scene>.exr, 1024 spp, and refs/<scene>_var.exr, the variance of that
//! mean). Skipped when ../shared is absent.
//!
//! Each scene renders as it is (its film, camera, filter and integrator: no `--size`, which
//! would change the picture) at a low sample count, with independent samples and bilinear
//! textures as Mitsuba's. The images are compared by block means, over 8 x 8 and 32 x 32 pixels
//! and over the whole image: a block's mean differs from the reference's by
//! z = |ours − ref| / sigma, sigma² = (var_ours + var_ref) / n² + (0.001 ref)², from the
//! per-pixel variances of the two means (the 0.1% covers float rounding where neither has noise,
//! a light seen directly). At a few samples per pixel a render's own variance misses the rare
//! bright paths of caustics, glossy chains and hundreds of small lights, and blocks then look
//! too dark with too little noise: each pixel's variance is therefore at least what Mitsuba's
//! own render would have at this sample count (the reference's variance times 1024 / spp), so
//! that a block fails only where a Mitsuba render of the same cost could tell the difference.
//! A scene passes when at each block size at most 0.5% of the blocks (never fewer than two) lie
//! beyond 5 sigma and the image mean is within 5 sigma.
//!
//! `stage_lights_top_rows` renders a crop window of the film (the same pixels as the whole
//! film's) at 1024 spp where issue 34 §3 found pixels at 44-600 against a reference of ~0 (null
//! emitters seen against the black sky, which Mitsuba's `valid_ray` does not count).

mod common;

use serde_json::Value;
use std::path::PathBuf;
use torrey_texture::Image;

/// One test: the scene (its name in refs/ and manifest.json), samples per pixel, the crop
/// window of the film (x, y, width, height; None: the whole film), and a known issue that
/// lets it fail.
struct Case {
    name: &'static str,
    spp: u32,
    crop: Option<(u32, u32, u32, u32)>,
    known_issue: Option<&'static str>,
}

/// The block sizes compared, in pixels.
const BLOCKS: [u32; 2] = [8, 32];

/// Block statistics at one size: blocks beyond 5 sigma, blocks, the largest z.
struct Scale {
    block: u32,
    outliers: usize,
    blocks: usize,
    max_z: f64,
}

impl Scale {
    /// Up to 0.5% of the blocks, never fewer than two, may lie beyond 5 sigma. (With the noise
    /// floor below, none did in any scene: the largest z of a correct render was 3.5.)
    fn allowed(&self) -> usize {
        ((0.005 * self.blocks as f64).round() as usize).max(2)
    }
}

struct Comparison {
    scales: Vec<Scale>,
    mean_ratio: [f64; 3],
    mean_z: [f64; 3],
}

impl Comparison {
    fn pass(&self) -> bool {
        self.scales.iter().all(|s| s.outliers <= s.allowed())
            && self.mean_z.iter().all(|z| z.abs() < 5.0)
    }
}

/// Compares `ours` (per-pixel variance of the mean `var`, at `spp`) with `reference` (variance
/// of its mean `ref_var`, at `ref_spp`).
fn compare(
    ours: &Image,
    var: &Image,
    spp: u32,
    reference: &Image,
    ref_var: &Image,
    ref_spp: u32,
) -> Comparison {
    let (w, h) = (ours.width, ours.height);
    assert_eq!((w, h), (reference.width, reference.height));
    // Per pixel: ours, the reference, and the variance of their difference.
    let floor = ref_spp as f64 / spp as f64;
    let pixel = |x: u32, y: u32| {
        let (o, r, v, rv) = (
            ours.get(x, y),
            reference.get(x, y),
            var.get(x, y),
            ref_var.get(x, y),
        );
        std::array::from_fn::<_, 3, _>(|c| {
            let (rv, v) = (rv[c] as f64, v[c] as f64);
            (o[c] as f64, r[c] as f64, v.max(rv * floor) + rv)
        })
    };
    let z = |sum: &[(f64, f64, f64); 3], n: f64| -> [f64; 3] {
        std::array::from_fn(|c| {
            let (o, r, v) = sum[c];
            let sigma = (v / (n * n) + (1e-3 * r / n).powi(2)).sqrt().max(1e-12);
            (o - r) / n / sigma
        })
    };
    let mut scales = Vec::new();
    for block in BLOCKS {
        let (mut outliers, mut blocks, mut max_z) = (0, 0, 0f64);
        for by in (0..h).step_by(block as usize) {
            for bx in (0..w).step_by(block as usize) {
                let mut sum = [(0f64, 0f64, 0f64); 3];
                let mut n = 0f64;
                for y in by..(by + block).min(h) {
                    for x in bx..(bx + block).min(w) {
                        for (s, p) in sum.iter_mut().zip(pixel(x, y)) {
                            *s = (s.0 + p.0, s.1 + p.1, s.2 + p.2);
                        }
                        n += 1.0;
                    }
                }
                blocks += 1;
                let worst = z(&sum, n).iter().fold(0f64, |a, z| a.max(z.abs()));
                max_z = max_z.max(worst);
                outliers += (worst > 5.0) as usize;
            }
        }
        scales.push(Scale {
            block,
            outliers,
            blocks,
            max_z,
        });
    }
    let mut sum = [(0f64, 0f64, 0f64); 3];
    for y in 0..h {
        for x in 0..w {
            for (s, p) in sum.iter_mut().zip(pixel(x, y)) {
                *s = (s.0 + p.0, s.1 + p.1, s.2 + p.2);
            }
        }
    }
    Comparison {
        scales,
        mean_ratio: std::array::from_fn(|c| sum[c].0 / sum[c].1),
        mean_z: z(&sum, (w * h) as f64),
    }
}

fn summary(c: &Comparison) -> String {
    let scales: Vec<String> = c
        .scales
        .iter()
        .map(|s| {
            format!(
                "{0}x{0}: {1} of {2} beyond 5 sigma (allowed {3}), max z {4:.1}",
                s.block,
                s.outliers,
                s.blocks,
                s.allowed(),
                s.max_z
            )
        })
        .collect();
    format!(
        "{}; mean ratio [{:.4} {:.4} {:.4}], z [{:.1} {:.1} {:.1}]",
        scales.join("; "),
        c.mean_ratio[0],
        c.mean_ratio[1],
        c.mean_ratio[2],
        c.mean_z[0],
        c.mean_z[1],
        c.mean_z[2]
    )
}

/// The window `(x, y, w, h)` of an image.
fn window(img: &Image, (x0, y0, w, h): (u32, u32, u32, u32)) -> Image {
    let pixels = (0..h)
        .flat_map(|y| (0..w).map(move |x| img.get(x0 + x, y0 + y)))
        .collect();
    Image::new(w, h, pixels)
}

/// `img` with `f` applied to the pixels of the window `(x, y, w, h)`.
fn changed(
    img: &Image,
    (x0, y0, w, h): (u32, u32, u32, u32),
    f: impl Fn(glam::Vec3) -> glam::Vec3,
) -> Image {
    let pixels = (0..img.height)
        .flat_map(|y| (0..img.width).map(move |x| (x, y)))
        .map(|(x, y)| {
            let p = img.get(x, y);
            if (x0..x0 + w).contains(&x) && (y0..y0 + h).contains(&y) {
                f(p)
            } else {
                p
            }
        })
        .collect();
    Image::new(img.width, img.height, pixels)
}

struct Rendered {
    image: Image,
    variance: Image,
    reference: Image,
    ref_var: Image,
    ref_spp: u32,
    seconds: f64,
    label: String,
}

/// Renders `case` and loads its reference (both the window rendered); None without ../shared.
fn render(case: &Case) -> Option<Rendered> {
    let Some(shared) = common::shared() else {
        println!("skipped: ../shared is absent");
        return None;
    };
    let base: PathBuf = shared.join("scenes/mitsuba-real");
    let manifest: Value =
        serde_json::from_str(&std::fs::read_to_string(base.join("manifest.json")).unwrap())
            .expect("manifest.json");
    let entry = &manifest["scenes"][case.name];
    let xml = entry["xml"]
        .as_str()
        .expect("the scene's xml in manifest.json");
    let ref_spp = entry["spp"].as_u64().expect("the reference's spp") as u32;
    let started = std::time::Instant::now();
    let desc = torrey_parser::load_scene(&base.join(xml), &[]).unwrap_or_else(|e| panic!("{e}"));
    let (fw, fh) = (desc.film.width, desc.film.height);
    let rs = torrey_renderer::RenderScene::build(&desc, fw, fh).unwrap_or_else(|e| panic!("{e}"));
    let settings = torrey_renderer::RenderSettings::new(
        &desc,
        &torrey_renderer::Overrides {
            spp: Some(case.spp),
            seed: Some(34),
            // Independent samples: the per-pixel variance then estimates the error.
            sampler: Some(torrey_renderer::SamplerKind::Independent),
            // Mitsuba looks textures up bilinearly at full resolution.
            mipmapping: Some(false),
            ..Default::default()
        },
    );
    let rect = case.crop.unwrap_or((0, 0, fw, fh));
    let slice = torrey_renderer::RenderSlice {
        crop: rect,
        samples: 0..case.spp,
    };
    let out = torrey_renderer::render_slice(&rs, &settings, &slice, &|_, _| {})
        .unwrap_or_else(|e| panic!("{e}"));
    assert_eq!(
        out.nonfinite_samples, 0,
        "{}: NaN or infinite samples",
        case.name
    );
    let reference = common::load(&base.join(format!("refs/{}.exr", case.name)));
    let ref_var = common::load(&base.join(format!("refs/{}_var.exr", case.name)));
    assert_eq!(
        (reference.width, reference.height),
        (fw, fh),
        "{}: the reference's size is not the film's",
        case.name
    );
    Some(Rendered {
        image: out.image,
        variance: out.variance,
        reference: window(&reference, rect),
        ref_var: window(&ref_var, rect),
        ref_spp,
        seconds: started.elapsed().as_secs_f64(),
        label: format!(
            "{}: {}x{} at ({}, {}) of {fw}x{fh}, {} spp",
            case.name, rect.2, rect.3, rect.0, rect.1, case.spp
        ),
    })
}

fn run(case: &Case) -> Option<Rendered> {
    let r = render(case)?;
    let c = compare(
        &r.image,
        &r.variance,
        case.spp,
        &r.reference,
        &r.ref_var,
        r.ref_spp,
    );
    let line = format!("{} in {:.1} s: {}", r.label, r.seconds, summary(&c));
    println!("{line}");
    match case.known_issue {
        Some(issue) if !c.pass() => println!("skipped, a known failure: {issue}"),
        Some(issue) => panic!("{line}\npasses now: remove its known issue ({issue})"),
        None => assert!(c.pass(), "{line}"),
    }
    Some(r)
}

#[test]
fn staircase() {
    run(&Case {
        name: "staircase",
        spp: 32,
        crop: None,
        known_issue: None,
    });
}

#[test]
fn matpreview_copper() {
    run(&Case {
        name: "matpreview-copper",
        spp: 64,
        crop: None,
        known_issue: None,
    });
}

#[test]
fn matpreview_glass() {
    run(&Case {
        name: "matpreview-glass",
        spp: 64,
        crop: None,
        known_issue: None,
    });
}

/// A medium inside a `null` mesh, 280 instances, `hide_emitters` (volpath).
#[test]
fn clover_banner() {
    run(&Case {
        name: "clover-banner",
        spp: 32,
        crop: None,
        known_issue: None,
    });
}

/// A dense homogeneous medium inside a `roughdielectric` bunny, max_depth 64 (volpath).
#[test]
fn bunny_sss() {
    run(&Case {
        name: "bunny-sss",
        spp: 8,
        crop: None,
        known_issue: None,
    });
}

#[test]
fn stage_lights() {
    run(&Case {
        name: "stage-lights",
        spp: 64,
        crop: None,
        known_issue: None,
    });
}

/// The top rows of stage-lights' film, columns 96-247, at 1024 spp: where issue 34 §3 found
/// torrey's pixels at 44-600 against Mitsuba's 0.000-0.03 (null emitters against the black sky,
/// which Mitsuba's `valid_ray` does not count; `PathState::radiance`).
#[test]
fn stage_lights_top_rows() {
    run(&Case {
        name: "stage-lights",
        spp: 1024,
        crop: Some((96, 0, 152, 4)),
        known_issue: None,
    });
}

/// veach-direct passes, and the same render with a 3% gain or with a 25% brighter 40 x 40
/// patch fails: the comparison can tell.
#[test]
fn veach_direct() {
    let case = Case {
        name: "veach-direct",
        spp: 64,
        crop: None,
        known_issue: None,
    };
    let Some(r) = run(&case) else {
        return;
    };
    let (w, h) = (r.image.width, r.image.height);
    let gain = changed(&r.image, (0, 0, w, h), |p| p * 1.03);
    let patch = changed(&r.image, (150, 120, 40, 40), |p| p * 1.25);
    for (what, image) in [("3% gain", gain), ("25% brighter patch", patch)] {
        let c = compare(
            &image,
            &r.variance,
            case.spp,
            &r.reference,
            &r.ref_var,
            r.ref_spp,
        );
        println!("veach-direct with a {what}: {}", summary(&c));
        assert!(!c.pass(), "the comparison misses a {what}: {}", summary(&c));
    }
}
