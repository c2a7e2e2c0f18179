//! The scene as the integrator sees it: world-space geometry in one BVH, shapes, materials,
//! textures, the camera and the light list. Built once from the parser's plain description
//! ([`build`]), each concept by its own constructor.

mod build;
mod material;

pub use build::BuildError;
pub use material::Material;

use crate::accel::{Accel, ClosestHit};
use crate::cameras::Camera;
use crate::lights::Light;
use crate::ray::Ray;
use crate::shapes::attributes::{AttributePoint, MeshAttributes};
use crate::shapes::mesh::MeshData;
use crate::shapes::{PrimInfo, Shape, SurfaceHit};
use crate::textures::Texture;
use glam::Vec3A;

/// A scene ready to render. Shapes, primitives, materials, textures and lights refer to each
/// other by index; the build establishes that every index is valid, so the fields are private.
pub struct RenderScene {
    pub(crate) camera: Camera,
    pub(crate) accel: Accel,
    pub(crate) mesh: MeshData,
    pub(crate) prims: Vec<PrimInfo>,
    pub(crate) shapes: Vec<Shape>,
    pub(crate) materials: Vec<Material>,
    pub(crate) textures: Vec<Texture>,
    /// Mesh attributes for `mesh_attribute` textures (empty when no texture reads them).
    pub(crate) attributes: MeshAttributes,
    pub(crate) lights: Vec<Light>,
    /// Indices of lights at infinity (constant background, environment maps).
    pub(crate) infinite_lights: Vec<u32>,
    /// Whether any shape emits. Without area lights, a surface hit never adds emission, so a
    /// path's last segment only needs to know whether it escapes (an any-hit query).
    pub(crate) has_area_lights: bool,
    /// The integrator's `hide_emitters`: camera rays see no emission (neither emitting shapes
    /// nor the lights at infinity), as Mitsuba's path integrator; emitters seen after a bounce,
    /// even a mirror's, and the light they cast stay.
    pub(crate) hide_emitters: bool,
    /// What the build found worth telling the user (each once).
    pub warnings: Vec<String>,
}

impl RenderScene {
    pub fn camera(&self) -> &Camera {
        &self.camera
    }

    pub fn accel(&self) -> &Accel {
        &self.accel
    }

    pub fn triangle_count(&self) -> usize {
        self.mesh.triangle_count
    }

    /// Closest surface along the ray, with its differential geometry.
    #[inline]
    pub fn intersect(&self, ray: &Ray) -> Option<SurfaceHit> {
        let hit = self.accel.intersect(ray)?;
        Some(self.surface_hit(ray, &hit))
    }

    /// The differential geometry of `hit`, a closest hit along `ray`.
    #[inline(never)]
    pub fn surface(&self, ray: &Ray, hit: &ClosestHit) -> SurfaceHit {
        self.surface_hit(ray, hit)
    }

    #[inline(always)]
    fn surface_hit(&self, ray: &Ray, hit: &ClosestHit) -> SurfaceHit {
        let prim = &self.prims[hit.prim as usize];
        let shape = &self.shapes[prim.shape as usize];
        let material = &self.materials[shape.material as usize];
        // Anisotropic BSDFs need dp/du for their tangent frame.
        let needs_uv = material.is_textured() || material.anisotropic;
        shape.surface(&self.mesh, prim, ray, hit, needs_uv)
    }

    /// Where `mesh_attribute` textures are evaluated at `hit`; None when the scene has none.
    #[inline(always)]
    pub(crate) fn attribute_point(&self, hit: &SurfaceHit) -> Option<AttributePoint<'_>> {
        if self.attributes.list.is_empty() {
            return None;
        }
        Some(AttributePoint {
            attributes: &self.attributes,
            prims: &self.prims,
            shape: hit.shape,
            prim: hit.prim,
            bary: hit.bary,
        })
    }

    /// True when nothing blocks the segment from `origin` along `dir` up to `tmax`.
    #[inline]
    pub fn visible(&self, origin: Vec3A, dir: Vec3A, tmax: f32) -> bool {
        !self.accel.occluded(&Ray { origin, dir, tmax })
    }
}
