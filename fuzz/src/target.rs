//! The four harnesses and how their outcomes are classed.

use std::path::{Path, PathBuf};

use crate::seeds::Input;

#[derive(Clone, Copy, PartialEq, Eq, Debug)]
pub(crate) enum Target {
    Xml,
    Mesh,
    Image,
    Render,
}

impl Target {
    pub(crate) fn name(self) -> &'static str {
        match self {
            Target::Xml => "xml",
            Target::Mesh => "mesh",
            Target::Image => "image",
            Target::Render => "render",
        }
    }
    pub(crate) fn is_text(self, ext: &str) -> bool {
        matches!(ext, "xml" | "obj" | "ply")
    }
}

/// Outcome classes for the corpus: success, or the error with file names and digits dropped,
/// cut short.
pub(crate) fn signature(result: &Result<String, String>, dir: &Path) -> String {
    match result {
        Ok(s) => format!("ok {s}"),
        Err(e) => {
            let e = e.replace(&dir.display().to_string(), "");
            let e = e.split_once("error: ").map_or(e.as_str(), |(_, m)| m);
            let e = e.strip_prefix("in mesh file '/current.").unwrap_or(e);
            // Numbers, hex values and quoted tokens vary without meaning another code path.
            let mut out = String::new();
            let mut quoted = false;
            for word in e.split_whitespace() {
                let quotes = word.matches(['\'', '`', '"']).count();
                let skip = quoted || quotes > 0 || word.chars().any(|c| c.is_ascii_digit());
                if quotes % 2 == 1 {
                    quoted = !quoted;
                }
                if !skip {
                    out.push_str(word);
                    out.push(' ');
                }
                if out.len() >= 80 {
                    break;
                }
            }
            out
        }
    }
}

/// What kinds of things an accepted scene holds, for outcome classes: shape, bsdf and light
/// kinds and whether there were warnings.
pub(crate) fn scene_summary(s: &torrey_parser::Scene) -> String {
    use std::collections::BTreeSet;
    let mut kinds = BTreeSet::new();
    for sh in &s.shapes {
        kinds.insert(match sh.geometry {
            torrey_parser::Geometry::Mesh(_) => "mesh",
            torrey_parser::Geometry::Sphere { .. } => "sphere",
            torrey_parser::Geometry::Rectangle => "rectangle",
            torrey_parser::Geometry::Disk => "disk",
            torrey_parser::Geometry::Cylinder { .. } => "cylinder",
            torrey_parser::Geometry::SdfGrid(_) => "sdfgrid",
        });
        if sh.emitter.is_some() {
            kinds.insert("area");
        }
    }
    for b in &s.bsdfs {
        kinds.insert(match b.kind {
            torrey_parser::BsdfKind::Diffuse { .. } => "diffuse",
            torrey_parser::BsdfKind::Mirror { .. } => "mirror",
            torrey_parser::BsdfKind::Plastic { .. } => "plastic",
            torrey_parser::BsdfKind::Phong { .. } => "phong",
            torrey_parser::BsdfKind::Blinn { .. } => "blinn",
            torrey_parser::BsdfKind::BlinnMicrofacet { .. } => "microfacet",
            torrey_parser::BsdfKind::Dielectric { .. } => "dielectric",
            torrey_parser::BsdfKind::RoughDielectric { .. } => "roughdielectric",
            torrey_parser::BsdfKind::Conductor { .. } => "conductor",
            torrey_parser::BsdfKind::RoughConductor { .. } => "roughconductor",
            torrey_parser::BsdfKind::RoughPlastic { .. } => "roughplastic",
            torrey_parser::BsdfKind::TwoSided { .. } => "twosided",
            torrey_parser::BsdfKind::Blend { .. } => "blendbsdf",
            torrey_parser::BsdfKind::Null => "null",
            torrey_parser::BsdfKind::Mask { .. } => "mask",
            torrey_parser::BsdfKind::Principled(_) => "principled",
            torrey_parser::BsdfKind::PrincipledThin(_) => "principledthin",
        });
        if b.normal_map.is_some() {
            kinds.insert("normalmap");
        }
    }
    for l in &s.lights {
        kinds.insert(match l {
            torrey_parser::Light::Point { .. } => "point",
            torrey_parser::Light::Constant { .. } => "constant",
            torrey_parser::Light::Directional { .. } => "directional",
            torrey_parser::Light::Spot { .. } => "spot",
            torrey_parser::Light::Envmap { .. } => "envmap",
            torrey_parser::Light::Projector { .. } => "projector",
        });
    }
    if !s.textures.is_empty() {
        kinds.insert("texture");
    }
    if !s.warnings.is_empty() {
        kinds.insert("warnings");
    }
    kinds.into_iter().collect::<Vec<_>>().join(",")
}

pub(crate) struct Harness {
    pub(crate) target: Target,
    pub(crate) dir: PathBuf,
    pub(crate) scenes: PathBuf,
    pub(crate) limits: torrey_parser::Limits,
}

impl Harness {
    pub(crate) fn scene_for_mesh(&self, file: &Path, ext: &str) -> String {
        let ty = match ext {
            "obj" => "obj",
            "ply" => "ply",
            _ => "serialized",
        };
        format!(
            "<scene version=\"2.0.0\"><shape type=\"{ty}\"><string name=\"filename\" value=\"{}\"/></shape></scene>",
            file.display()
        )
    }

    /// Runs one input (already written to `file`); Ok/Err summarise the outcome.
    pub(crate) fn run(&self, input: &Input, file: &Path, variant: u64) -> Result<String, String> {
        let parse = |xml: &str| {
            torrey_parser::parse_scene_str_with_limits(
                xml,
                &self.scenes.join("fuzz.xml"),
                &[],
                &self.limits,
            )
            .map_err(|e| e.to_string())
        };
        match self.target {
            Target::Xml => {
                let text = String::from_utf8_lossy(&input.bytes);
                parse(&text).map(|s| scene_summary(&s))
            }
            Target::Mesh => {
                let xml = self.scene_for_mesh(file, &input.ext);
                parse(&xml).map(|s| format!("{} warnings", s.warnings.len().min(3)))
            }
            Target::Image => {
                let img = torrey_texture::load_image(file, variant.is_multiple_of(2))
                    .map_err(|e| e.to_string())?;
                let mip = torrey_texture::MipMap::new(
                    img.image,
                    torrey_texture::WrapMode::Repeat,
                    torrey_texture::FilterType::Bilinear,
                );
                let _ = mip;
                Ok(format!("{} warnings", img.warnings.len()))
            }
            Target::Render => {
                let text = String::from_utf8_lossy(&input.bytes);
                let scene = parse(&text)?;
                let width = if variant.is_multiple_of(3) {
                    torrey_renderer::BvhWidth::Four
                } else {
                    torrey_renderer::BvhWidth::Auto
                };
                // Both build efforts: the best one, or the one a tiny render gets.
                let accel = torrey_renderer::AccelOptions {
                    width,
                    samples: if variant % 7 == 3 { 8 * 6 } else { u64::MAX },
                };
                let built = torrey_renderer::RenderScene::build_with(&scene, 8, 6, accel)
                    .map_err(|e| e.to_string())?;
                let settings = torrey_renderer::RenderSettings::new(
                    &scene,
                    &torrey_renderer::Overrides {
                        spp: Some(1 + (variant % 2) as u32),
                        max_depth: Some(scene.integrator.max_depth().clamp(-1, 6)),
                        seed: Some(variant),
                        sampler: Some(if variant.is_multiple_of(2) {
                            torrey_renderer::SamplerKind::Sobol
                        } else {
                            torrey_renderer::SamplerKind::Independent
                        }),
                        mipmapping: Some(variant % 4 != 1),
                        packets: Some(variant % 5 != 2),
                        path_loop: Some(if variant % 3 == 1 {
                            torrey_renderer::PathLoop::Wavefront
                        } else {
                            torrey_renderer::PathLoop::Scalar
                        }),
                        tile_size: Some(4),
                        guides: Some(variant % 7 == 3),
                        // Adaptive sampling needs a filter that does not splat.
                        noise_threshold: (variant % 6 == 5
                            && !matches!(
                                scene.film.filter,
                                torrey_parser::PixelFilter::Mitchell { .. }
                                    | torrey_parser::PixelFilter::CatmullRom
                                    | torrey_parser::PixelFilter::Lanczos { .. }
                            ))
                        .then_some(0.2),
                        time_limit: None,
                    },
                );
                let out = torrey_renderer::render(&built, &settings, &|_, _| {});
                if out.image.pixels.iter().any(|p| !p.is_finite()) {
                    panic!("render produced a NaN or infinite pixel");
                }
                if out.variance.pixels.iter().any(|p| !p.is_finite()) {
                    panic!("render produced a NaN or infinite variance pixel");
                }
                Ok(format!(
                    "rendered, {} nonfinite, {} clamped",
                    out.nonfinite_samples.min(1),
                    out.clamped_pixels.min(1)
                ))
            }
        }
    }
}
