//! The scene as the integrator sees it: world-space geometry in one BVH, shapes, materials,
//! textures, the camera and the light list. Built once from the parser's plain description
//! ([`build`]), each concept by its own constructor.

mod build;
mod build_lights;
mod build_shapes;
mod build_textures;
mod material;
mod perturb;

pub use build::BuildError;
pub use material::Material;

use crate::accel::instances::Instances;
use crate::accel::{Accel, ClosestHit, PrimGeom, SHADOW_BATCH};
use crate::cameras::Camera;
use crate::lights::Light;
use crate::ray::Ray;
use crate::shapes::attributes::{AttributePoint, MeshAttributes};
use crate::shapes::mesh::MeshData;
use crate::shapes::{PrimInfo, Shape, ShapeKind, SurfaceHit};
use crate::textures::Texture;
use glam::Vec3A;
use std::mem::MaybeUninit;

/// A scene ready to render. Shapes, primitives, materials, textures and lights refer to each
/// other by index; the build establishes that every index is valid, so the fields are private.
pub struct RenderScene {
    pub(crate) camera: Camera,
    pub(crate) accel: Accel,
    /// The top level over the scene's instances (their shape groups' primitives, stored once in
    /// `prims`, `shapes` and `mesh` after the world's, have BVHs of their own); None without
    /// instances, so that such scenes take the one-level path alone.
    pub(crate) instances: Option<Box<Instances>>,
    pub(crate) mesh: MeshData,
    pub(crate) prims: Vec<PrimInfo>,
    pub(crate) shapes: Vec<Shape>,
    pub(crate) materials: Vec<Material>,
    pub(crate) textures: Vec<Texture>,
    /// Mesh attributes for `mesh_attribute` textures (empty when no texture reads them).
    pub(crate) attributes: MeshAttributes,
    pub(crate) lights: Vec<Light>,
    /// How next-event estimation chooses among `lights`.
    pub(crate) light_selection: crate::lights::LightSelection,
    /// Indices of lights at infinity (constant background, environment maps).
    pub(crate) infinite_lights: Vec<u32>,
    /// Participating media, the media on the shapes' sides and the camera's.
    pub(crate) media: crate::media::Media,
    /// Whether any shape emits. Without area lights, a surface hit never adds emission, so a
    /// path's last segment only needs to know whether it escapes (an any-hit query).
    pub(crate) has_area_lights: bool,
    /// Whether ray cones filter anything: a material reads a texture, or a light at infinity is
    /// an environment map. Without, the path loop does not track them.
    pub(crate) uses_cones: bool,
    /// Whether any shape's hits need uv (a textured or anisotropic material, a textured
    /// emission). Without, hits skip the material look-up that decides it.
    pub(crate) any_uv: bool,
    /// The film window whose pixels receive samples, `(x, y, width, height)`: the film's crop
    /// window, else the whole film. Mitsuba places samples inside the crop window only, so a
    /// filter offset that leaves it does not count, as at the film's edges.
    pub(crate) sample_window: (u32, u32, u32, u32),
    /// What the build found worth telling the user (each once).
    pub warnings: Vec<String>,
}

impl RenderScene {
    pub fn camera(&self) -> &Camera {
        &self.camera
    }

    /// The film window whose pixels receive samples (see the field).
    pub fn sample_window(&self) -> (u32, u32, u32, u32) {
        self.sample_window
    }

    pub fn accel(&self) -> &Accel {
        &self.accel
    }

    /// Triangles stored (a shape group's once, however many instances place it).
    pub fn triangle_count(&self) -> usize {
        self.mesh.triangle_count
    }

    /// The instances of shape groups the scene places.
    pub fn instance_count(&self) -> usize {
        self.instances.as_ref().map_or(0, |i| i.len())
    }

    /// The top level over the instances, if the scene has any.
    pub fn instances(&self) -> Option<&Instances> {
        self.instances.as_deref()
    }

    /// Rays per camera-ray packet ([`Accel::packet_width`]); 0 for scenes with instances, whose
    /// camera rays are traced one by one (through both levels).
    pub fn packet_width(&self) -> usize {
        if self.instances.is_some() {
            0
        } else {
            self.accel.packet_width()
        }
    }

    /// World-space geometry of the BVH's primitive `prim` (as in [`ClosestHit::prim`], below
    /// [`Accel::primitive_count`]): lets another ray tracer be built over the same primitives
    /// (the traversal bench's Embree comparison).
    pub fn prim_geom(&self, prim: u32) -> PrimGeom {
        let info = &self.prims[prim as usize];
        match &self.shapes[info.shape as usize].kind {
            ShapeKind::Sphere(sphere) => sphere.prim_geom(),
            ShapeKind::Disk(disk) => disk.prim_geom(),
            ShapeKind::Cylinder(cylinder) => cylinder.prim_geom(),
            ShapeKind::SdfGrid(_) => {
                let index = info.indices[0];
                let c = &self.mesh.sdf_cells[index as usize];
                PrimGeom::SdfVoxel {
                    min: c.min,
                    max: c.max,
                    index,
                }
            }
            ShapeKind::Mesh(_) => {
                let [p0, p1, p2] = info.indices.map(|i| self.mesh.positions[i as usize]);
                PrimGeom::Triangle { p0, p1, p2 }
            }
        }
    }

    /// Closest surface along the ray, with its differential geometry.
    #[inline]
    pub fn intersect(&self, ray: &Ray) -> Option<SurfaceHit> {
        let hit = self.accel.intersect(ray);
        if let Some(instances) = &self.instances {
            return self.intersect_instances(instances, ray, hit);
        }
        Some(self.surface_hit(ray, &hit?))
    }

    /// [`RenderScene::intersect`] in a scene with instances: the closest of `world` (the world's
    /// own closest hit) and the instances' hits before it.
    #[inline(never)]
    fn intersect_instances(
        &self,
        instances: &Instances,
        ray: &Ray,
        world: Option<ClosestHit>,
    ) -> Option<SurfaceHit> {
        let tmax = world.map_or(ray.tmax, |h| h.t);
        match instances.intersect(&Ray { tmax, ..*ray }) {
            Some((hit, i)) => {
                let instance = instances.instance(i);
                let local = self.surface_hit(&instance.local_ray(ray), &hit);
                Some(instance.surface_to_world(local))
            }
            None => world.map(|hit| self.surface_hit(ray, &hit)),
        }
    }

    /// The differential geometry of `hit`, a closest hit of [`RenderScene::accel`] (the world's
    /// own primitives, not the instances') along `ray`.
    #[inline(never)]
    pub fn surface(&self, ray: &Ray, hit: &ClosestHit) -> SurfaceHit {
        self.surface_hit(ray, hit)
    }

    /// [`RenderScene::surface`] written into `out` (a caller that keeps hits in a buffer gets
    /// them without a copy through the stack).
    #[inline(never)]
    pub fn surface_into(&self, ray: &Ray, hit: &ClosestHit, out: &mut SurfaceHit) {
        *out = self.surface_hit(ray, hit);
    }

    /// [`RenderScene::surface_into`] for an `Option` slot: the surface written straight into `out` (e.g. a camera path in the render
    /// loop's batch): returned by value, the surface went through a temporary whose fields,
    /// just stored in pieces smaller than the copy's loads, could not be forwarded to them.
    #[inline(never)]
    pub(crate) fn surface_into_some(
        &self,
        ray: &Ray,
        hit: &ClosestHit,
        out: &mut Option<SurfaceHit>,
    ) {
        *out = Some(self.surface_hit(ray, hit));
    }

    #[inline(always)]
    fn surface_hit(&self, ray: &Ray, hit: &ClosestHit) -> SurfaceHit {
        let prim = &self.prims[hit.prim as usize];
        let shape = &self.shapes[prim.shape as usize];
        // Anisotropic BSDFs need dp/du for their tangent frame.
        let needs_uv = self.any_uv && {
            let material = &self.materials[shape.material as usize];
            material.is_textured() || material.anisotropic || shape.textured_emission
        };
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
        let ray = Ray { origin, dir, tmax };
        !self.accel.occluded(&ray) && self.instances.as_ref().is_none_or(|i| !i.occluded(&ray))
    }

    /// [`RenderScene::visible`] of `count` rays (`ray(i)` the i-th), calling `visible(i)` for
    /// each unblocked one, in order: the same answers, the rays traced together as packets
    /// where that pays ([`Accel::shadow_packets_pay`], [`Accel::occluded_batch`]).
    pub fn visible_batch(
        &self,
        count: usize,
        ray: impl Fn(usize) -> Ray,
        mut visible: impl FnMut(usize),
    ) {
        if !self.accel.shadow_packets_pay(count) {
            for k in 0..count {
                let r = ray(k);
                if self.visible(r.origin, r.dir, r.tmax) {
                    visible(k);
                }
            }
            return;
        }
        // Uninitialised: zeroing the whole array on every call (a wavefront stage's few dozen
        // rays) cost more than the packets saved.
        let mut rays = [const { MaybeUninit::<Ray>::uninit() }; SHADOW_BATCH];
        let mut occluded = [false; SHADOW_BATCH];
        for start in (0..count).step_by(SHADOW_BATCH) {
            let n = (count - start).min(SHADOW_BATCH);
            for (k, r) in rays[..n].iter_mut().enumerate() {
                r.write(ray(start + k));
            }
            // SAFETY: the first `n` entries were written just above.
            let rays = unsafe { std::slice::from_raw_parts(rays.as_ptr().cast::<Ray>(), n) };
            self.accel.occluded_batch(rays, &mut occluded[..n]);
            for k in 0..n {
                if !occluded[k]
                    && self
                        .instances
                        .as_ref()
                        .is_none_or(|i| !i.occluded(&rays[k]))
                {
                    visible(start + k);
                }
            }
        }
    }
}

/// A scene from XML text, built for a `width`×`height` film; relative paths in it (meshes,
/// textures) resolve from the project's scenes/ directory (tests).
#[cfg(test)]
pub(crate) fn scene_from_xml(xml: &str, width: u32, height: u32) -> RenderScene {
    let desc = torrey_parser::parse_scene_str(
        xml,
        &std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("../../scenes/packets.xml"),
        &[],
    )
    .unwrap();
    RenderScene::build(&desc, width, height).unwrap()
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::accel::BvhWidth;
    use crate::cameras::CameraSample;
    use glam::Vec2;

    /// A BVH rebuilt from `prim_geom` finds the scene's hits: same primitive, same distance.
    #[test]
    fn prim_geom_rebuilds_the_scene_geometry() {
        let xml = r#"<scene version="0.6.0">
            <sensor type="perspective">
                <float name="fov" value="50"/>
                <transform name="toWorld"><lookAt origin="0, 1, 4" target="0, 0.6, 0" up="0, 1, 0"/></transform>
                <film type="hdrfilm"><integer name="width" value="32"/><integer name="height" value="24"/></film>
            </sensor>
            <shape type="rectangle">
                <transform name="toWorld"><scale value="3"/><rotate x="1" angle="-90"/></transform>
            </shape>
            <shape type="sphere"><point name="center" x="0.4" y="0.5" z="0"/><float name="radius" value="0.5"/>
                <transform name="toWorld"><scale value="1.5"/><translate x="0.2"/></transform></shape>
            <shape type="obj"><string name="filename" value="meshes/torus.obj"/>
                <transform name="toWorld"><scale value="0.5"/><translate x="-0.7" y="0.4"/></transform></shape>
        </scene>"#;
        let scene = scene_from_xml(xml, 32, 24);
        let count = scene.accel().primitive_count() as u32;
        let geoms: Vec<PrimGeom> = (0..count).map(|i| scene.prim_geom(i)).collect();
        assert!(geoms.iter().any(|g| matches!(g, PrimGeom::Sphere { .. })));
        let rebuilt = Accel::build(&geoms, BvhWidth::Four);
        let (mut hits, mut sphere_hits) = (0, 0);
        for y in 0..24 {
            for x in 0..32 {
                let (origin, dir) = scene.camera().generate_ray(&CameraSample {
                    film: Vec2::new(x as f32 + 0.5, y as f32 + 0.5),
                    lens: Vec2::ZERO,
                });
                let ray = Ray {
                    origin,
                    dir,
                    tmax: f32::INFINITY,
                };
                let a = scene.accel().intersect(&ray).map(|h| (h.prim, h.t));
                let b = rebuilt.intersect(&ray).map(|h| (h.prim, h.t));
                assert_eq!(a, b, "pixel ({x}, {y})");
                hits += a.is_some() as usize;
                sphere_hits += a
                    .is_some_and(|(p, _)| matches!(geoms[p as usize], PrimGeom::Sphere { .. }))
                    as usize;
            }
        }
        assert!(
            hits > 300 && sphere_hits > 20,
            "{hits} hits, {sphere_hits} on the sphere"
        );
    }
}
