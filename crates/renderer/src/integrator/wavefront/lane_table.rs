//! Which surfaces the wavefront shades in SIMD lanes, decided once per scene: a shape whose
//! material is a plain `diffuse` or torrey `mirror` of constant or textured reflectance (no
//! normal or bump map, no second BSDF behind) and which emits nothing or a constant radiance sampled by area (a mesh,
//! disk or cylinder emitter), with light samples of such emitters, of point lights, of a
//! constant background or of an environment map (its batched draws).
//! The lane path repeats the scalar shading of exactly these cases;
//! every other BSDF and light keeps the scalar `shade` (BSDFs move to lanes one by one).

use crate::bsdfs::{BsdfParams, DiffuseParams, MirrorParams};
use crate::lights::{AreaEmitter, Light};
use crate::scene::Material;
use crate::shapes::Shape;
use crate::textures::ColorSource;

/// A shape shaded in lanes: its reflectance and sidedness, and what it emits.
#[derive(Clone, Copy, Debug, PartialEq)]
pub(crate) struct LaneShape {
    /// A torrey `mirror` (Schlick Fresnel of F0 `reflectance`, a delta lobe), else a `diffuse`.
    pub mirror: bool,
    /// The constant reflectance (unused with `texture`).
    pub reflectance: [f32; 3],
    /// The reflectance's texture: looked up per path by the scalar [`crate::textures::TextureQuery`]
    /// as `shade` does, with the ray cone's footprint, before the lanes take the rest.
    pub texture: Option<u32>,
    /// Shades its back as its front (mirrored), as [`Material::bsdf_facing`] does.
    pub two_sided: bool,
    /// The emitter's (constant) radiance and area, if the shape emits.
    pub emitter: Option<LaneEmitter>,
}

/// A constant-radiance area light sampled uniformly by area: what its `connect_point` and
/// `pdf_hit` read.
#[derive(Clone, Copy, Debug, PartialEq)]
pub(crate) struct LaneEmitter {
    pub radiance: [f32; 3],
    pub area: f32,
}

/// Per shape and per light, whether (and with what) the lanes shade it.
#[derive(Clone, Debug, Default)]
pub(crate) struct LaneTable {
    /// Indexed by shape; None: the scalar `shade`.
    pub shapes: Vec<Option<LaneShape>>,
    /// Indexed by light: the lights whose samples the lanes take.
    pub lights: Vec<Option<LaneLight>>,
    /// Any shape takes the lanes.
    pub any: bool,
    /// Some shape takes the lanes and every light's samples do.
    pub covers_lights: bool,
    /// Some light is an environment map or a point light (the kernel's selects for them).
    pub env_or_point: bool,
    /// Some lane shape is a mirror (the kernel's selects for it).
    pub any_mirror: bool,
}

impl LaneTable {
    pub fn new(shapes: &[Shape], materials: &[Material], lights: &[Light]) -> Self {
        let lights: Vec<Option<LaneLight>> = lights.iter().map(lane_light).collect();
        let shapes: Vec<Option<LaneShape>> = shapes
            .iter()
            .map(|shape| {
                let (mirror, reflectance, texture) = materials
                    .get(shape.material as usize)
                    .and_then(lane_reflectance)?;
                let emitter = match shape.area_light {
                    None => None,
                    Some(li) => match lights.get(li as usize)? {
                        Some(LaneLight::Area(e)) => Some(*e),
                        _ => return None,
                    },
                };
                Some(LaneShape {
                    mirror,
                    reflectance,
                    texture,
                    two_sided: materials[shape.material as usize].two_sided,
                    emitter,
                })
            })
            .collect();
        let any = shapes.iter().any(Option::is_some);
        let covers_lights = any && lights.iter().all(Option::is_some);
        let env_or_point = lights
            .iter()
            .any(|l| matches!(l, Some(LaneLight::Point { .. } | LaneLight::Env)));
        let any_mirror = shapes.iter().flatten().any(|s| s.mirror);
        LaneTable {
            shapes,
            lights,
            any,
            covers_lights,
            env_or_point,
            any_mirror,
        }
    }
}

impl LaneTable {
    /// Whether the wavefront loop beats the scalar one on this scene thanks to the lanes (what
    /// `PathLoop::Auto` reads): they cover every light and run vectorised (AVX2 or AVX-512).
    /// On cbox and the living room the wavefront is then 7% faster than the scalar loop, on
    /// textured_mesh (point lights, textured diffuse) 1-2%.
    pub fn wavefront_pays(&self) -> bool {
        self.covers_lights && super::lanes::lanes_enabled()
    }
}

/// The reflectance of a material the lanes shade: a `diffuse` or `mirror` without a second
/// BSDF, normal map or perturbation, whose reflectance is a finite constant or a texture
/// (whether a mirror, the constant, the texture).
fn lane_reflectance(m: &Material) -> Option<(bool, [f32; 3], Option<u32>)> {
    let (mirror, reflectance) = match m.bsdf {
        BsdfParams::Diffuse(DiffuseParams { reflectance }) => (false, reflectance),
        BsdfParams::Mirror(MirrorParams { reflectance }) => (true, reflectance),
        _ => return None,
    };
    let plain = m.back.is_none() && m.normal_map.is_none() && m.perturb.is_none() && !m.anisotropic;
    match reflectance {
        ColorSource::Constant(c) => {
            (plain && c.is_finite()).then_some((mirror, c.to_array(), None))
        }
        ColorSource::Texture(t) => plain.then_some((mirror, [0.0; 3], Some(t))),
    }
}

/// A light whose samples the lanes take.
#[derive(Clone, Copy, Debug, PartialEq)]
pub(crate) enum LaneLight {
    /// An untextured area light sampled by area: its draws are points
    /// ([`crate::lights::LightDraw::MeshPoint`]).
    Area(LaneEmitter),
    /// A constant background (`ConstantLight`): its draws are deferred, a direction uniform
    /// over the sphere; the radiance.
    Constant([f32; 3]),
    /// A point light (`PointLight`): its draws are deferred; its position and intensity.
    Point {
        position: [f32; 3],
        intensity: [f32; 3],
    },
    /// An environment map: its draws are sampled for many paths at once by the wavefront
    /// ([`crate::lights::LightDraw::EnvSampled`]: direction, radiance, density); one sampled
    /// alone at shading time (`Deferred`) takes the scalar `shade`.
    Env,
}

/// The lanes' form of `light`: area lights of constant radiance sampled by area (spheres sample
/// by solid angle, textures by texel: scalar), point lights, constant backgrounds and
/// environment maps.
fn lane_light(light: &Light) -> Option<LaneLight> {
    match light {
        Light::Area(area)
            if area.texture.is_none() && !matches!(area.emitter, AreaEmitter::Sphere(_)) =>
        {
            Some(LaneLight::Area(LaneEmitter {
                radiance: area.radiance.to_array(),
                area: area.area(),
            }))
        }
        Light::Constant(c) => Some(LaneLight::Constant(c.radiance.to_array())),
        Light::Env(_) => Some(LaneLight::Env),
        Light::Point(p) => Some(LaneLight::Point {
            position: p.position.to_array(),
            intensity: p.intensity.to_array(),
        }),
        _ => None,
    }
}
