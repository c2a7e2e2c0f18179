//! A diffuse area emitter on a shape (Mitsuba's `area`): constant or textured radiance
//! (emission_texture.rs), one-sided (along the possibly flipped normal only). Meshes, disks and
//! cylinders are sampled uniformly by area, spheres by the solid angle they subtend (each shape's
//! file holds its sampling and pdf); a bitmap radiance on a rectangle or sphere by the texture's
//! luminance.

use super::emission_texture::EmissionTexture;
use super::light_bounds::{luminance, DirectionCone, LightBounds};
use super::{LightDraw, LightSample};
use crate::shapes::cylinder::Cylinder;
use crate::shapes::disk::Disk;
use crate::shapes::mesh::MeshEmitter;
use crate::shapes::sphere::Sphere;
use crate::textures::Texture;
use glam::{Vec2, Vec3A};
use std::f32::consts::PI;
use torrey_texture::Footprint;

/// The geometry an area light samples from.
pub enum AreaEmitter {
    Mesh(MeshEmitter),
    Sphere(Sphere),
    /// Boxed: their object transforms would make every light as large as these rare ones.
    Disk(Box<Disk>),
    Cylinder(Box<Cylinder>),
}

/// An emitting shape.
pub struct AreaLight {
    /// The radiance, or with `texture` its scale (1).
    pub radiance: Vec3A,
    /// A textured radiance: the texture at the surface's uv.
    pub texture: Option<EmissionTexture>,
    pub emitter: AreaEmitter,
    pub flip_normals: bool,
}

impl AreaLight {
    /// Its bounds for the light tree: the shape's box, π × area × radiance (a texture counted
    /// as its scale), and the cone of its emitting normals (a sphere or cylinder emits every way).
    pub fn bounds(&self) -> LightBounds {
        let flip = if self.flip_normals { -1.0 } else { 1.0 };
        let (min, max, area, normals) = match &self.emitter {
            AreaEmitter::Mesh(mesh) => {
                let mut min = Vec3A::splat(f32::INFINITY);
                let mut max = Vec3A::splat(f32::NEG_INFINITY);
                let mut axis = Vec3A::ZERO;
                for t in mesh.triangles() {
                    for p in [t.p0, t.p0 + t.e1, t.p0 + t.e2] {
                        min = min.min(p);
                        max = max.max(p);
                    }
                    axis += t.e1.cross(t.e2) * (0.5 * flip);
                }
                let normals = match axis.try_normalize() {
                    Some(w) => DirectionCone {
                        w,
                        cos_theta: mesh
                            .triangles()
                            .iter()
                            .map(|t| w.dot(t.normal * flip))
                            .fold(1.0f32, f32::min)
                            .max(-1.0),
                    },
                    None => DirectionCone::SPHERE,
                };
                (min, max, mesh.total_area(), normals)
            }
            AreaEmitter::Sphere(s) => (
                s.center - Vec3A::splat(s.radius),
                s.center + Vec3A::splat(s.radius),
                4.0 * PI * s.radius * s.radius,
                DirectionCone::SPHERE,
            ),
            AreaEmitter::Disk(d) => {
                let (min, max) = box_of(&d.to_world, 0.0);
                let normals = DirectionCone {
                    w: (d.normal * flip).normalize(),
                    cos_theta: 1.0,
                };
                (min, max, d.area, normals)
            }
            AreaEmitter::Cylinder(c) => {
                let (min, max) = box_of(&c.to_world, 1.0);
                (min, max, c.area, DirectionCone::SPHERE)
            }
        };
        LightBounds {
            min,
            max,
            phi: PI * area * luminance(self.radiance),
            normals,
            cos_theta_e: 0.0,
            two_sided: false,
        }
    }

    /// The radiance leaving the emitting side at surface coordinates `uv`.
    #[inline]
    pub fn radiance_at(&self, textures: &[Texture], uv: Vec2) -> Vec3A {
        match &self.texture {
            None => self.radiance,
            Some(t) => self.radiance * textures[t.texture as usize].eval(uv, Footprint::POINT),
        }
    }

    /// The part of a sample that does not depend on the shading point: a point on an emitting
    /// mesh ([`super::Light::draw`]); spheres sample by solid angle, so they defer.
    #[inline(always)]
    pub fn draw(&self, u: Vec2) -> LightDraw {
        if self.texture.is_some() {
            // A textured radiance needs the point's uv: drawn in `sample_deferred`.
            return LightDraw::Deferred(u);
        }
        match &self.emitter {
            AreaEmitter::Mesh(mesh) => {
                let (q, normal) = mesh.sample_point(u);
                let n = if self.flip_normals { -normal } else { normal };
                LightDraw::MeshPoint { q, n }
            }
            AreaEmitter::Disk(disk) => {
                let (q, normal) = disk.sample_point(u);
                let n = if self.flip_normals { -normal } else { normal };
                LightDraw::MeshPoint { q, n }
            }
            AreaEmitter::Cylinder(cylinder) => {
                let (q, normal) = cylinder.sample_point(u);
                let n = if self.flip_normals { -normal } else { normal };
                LightDraw::MeshPoint { q, n }
            }
            AreaEmitter::Sphere(_) => LightDraw::Deferred(u),
        }
    }

    /// The surface area of a shape sampled uniformly by area (not of a sphere).
    #[inline(always)]
    pub(crate) fn area(&self) -> f32 {
        match &self.emitter {
            AreaEmitter::Mesh(mesh) => mesh.total_area(),
            AreaEmitter::Disk(disk) => disk.area,
            AreaEmitter::Cylinder(cylinder) => cylinder.area,
            AreaEmitter::Sphere(_) => unreachable!("spheres are sampled by solid angle"),
        }
    }

    /// The connection from `p` to point `q` (normal `n`) drawn on an emitting mesh, disk or
    /// cylinder. A textured radiance needs the point's uv, which a point drawn by area does not
    /// carry: such shapes are not drawn early ([`AreaLight::sample_deferred`]).
    #[inline(always)]
    pub fn connect_point(&self, q: Vec3A, n: Vec3A, p: Vec3A) -> Option<LightSample> {
        let d = q - p;
        let dist2 = d.length_squared();
        let dist = dist2.sqrt();
        if dist == 0.0 {
            return None;
        }
        let wi = d / dist;
        let cos_light = -n.dot(wi);
        if cos_light <= 0.0 {
            return None; // back of a one-sided emitter
        }
        Some(LightSample {
            wi,
            dist,
            radiance: self.radiance,
            pdf: dist2 / (cos_light * self.area()),
            is_delta: false,
        })
    }

    /// A sample of a sphere emitter, or of a texture-sampled emitter, from `p` (other mesh
    /// emitters are drawn by [`AreaLight::draw`]).
    #[inline(always)]
    pub fn sample_deferred(&self, p: Vec3A, u: Vec2, textures: &[Texture]) -> Option<LightSample> {
        if let Some(t) = &self.texture {
            if let Some((texels, map)) = &t.sampling {
                // Mitsuba's area.cpp: a uv by the texture, mapped onto the shape.
                let (uv, p_uv) = texels.sample(u);
                let (q, normal, jacobian) = map.eval(uv);
                let n = if self.flip_normals { -normal } else { normal };
                let d = q - p;
                let dist2 = d.length_squared();
                let dist = dist2.sqrt();
                if !(dist > 0.0 && jacobian > 0.0 && p_uv > 0.0) {
                    return None;
                }
                let wi = d / dist;
                let cos_light = -n.dot(wi);
                if cos_light.is_nan() || cos_light <= 0.0 {
                    return None;
                }
                return Some(LightSample {
                    wi,
                    dist,
                    radiance: self.radiance_at(textures, uv),
                    pdf: p_uv / jacobian * dist2 / cos_light,
                    is_delta: false,
                });
            }
        }
        let sphere = match &self.emitter {
            AreaEmitter::Sphere(sphere) => sphere,
            AreaEmitter::Mesh(mesh) => {
                // A textured mesh sampled by area: as `connect_point`, with the point's uv.
                let (q, normal, uv) = mesh.sample_point_uv(u);
                let n = if self.flip_normals { -normal } else { normal };
                return self.connect_point(q, n, p).map(|ls| LightSample {
                    radiance: self.radiance_at(textures, uv),
                    ..ls
                });
            }
            // Textured disks and cylinders are sampled by area too, with the point's uv.
            AreaEmitter::Disk(_) | AreaEmitter::Cylinder(_) => {
                let (q, normal, uv) = match &self.emitter {
                    AreaEmitter::Disk(disk) => disk.sample_point_uv(u),
                    AreaEmitter::Cylinder(cylinder) => cylinder.sample_point_uv(u),
                    _ => unreachable!("matched above"),
                };
                let n = if self.flip_normals { -normal } else { normal };
                return self.connect_point(q, n, p).map(|ls| LightSample {
                    radiance: self.radiance_at(textures, uv),
                    ..ls
                });
            }
        };
        let s = sphere.sample_solid_angle(p, u)?;
        let mut n: Vec3A = s.normal.into();
        if self.flip_normals {
            n = -n;
        }
        let d = Vec3A::from(s.point) - p;
        let dist = d.length();
        if dist == 0.0 || s.pdf.is_nan() || s.pdf <= 0.0 {
            return None;
        }
        let wi = d / dist;
        if n.dot(wi) >= 0.0 {
            return None;
        }
        let radiance = match &self.texture {
            None => self.radiance,
            Some(_) => self.radiance_at(textures, sphere.uv_of_normal(s.normal.into())),
        };
        Some(LightSample {
            wi,
            dist,
            radiance,
            pdf: s.pdf,
            is_delta: false,
        })
    }

    /// Solid-angle pdf that sampling from `p` produces direction `wi` hitting this light at
    /// distance `dist` where its normal is `n_light` and its uv `uv`.
    #[inline]
    pub fn pdf_hit(&self, p: Vec3A, wi: Vec3A, dist: f32, n_light: Vec3A, uv: Vec2) -> f32 {
        if let Some(t) = &self.texture {
            if let Some((texels, map)) = &t.sampling {
                let cos = n_light.dot(wi).abs();
                let jacobian = map.jacobian(uv);
                return if cos > 0.0 && jacobian > 0.0 {
                    texels.pdf(uv) / jacobian * dist * dist / cos
                } else {
                    0.0
                };
            }
        }
        match &self.emitter {
            AreaEmitter::Sphere(sphere) => sphere.solid_angle_pdf(p, wi),
            _ => {
                let cos = n_light.dot(wi).abs();
                if cos == 0.0 {
                    0.0
                } else {
                    dist * dist / (cos * self.area())
                }
            }
        }
    }
}

/// The world box of the object-space box [-1, 1]² × [0, `z_max`] under `to_world`.
fn box_of(to_world: &glam::Affine3A, z_max: f32) -> (Vec3A, Vec3A) {
    let mut min = Vec3A::splat(f32::INFINITY);
    let mut max = Vec3A::splat(f32::NEG_INFINITY);
    for i in 0..8 {
        let corner = Vec3A::new(
            if i & 1 == 0 { -1.0 } else { 1.0 },
            if i & 2 == 0 { -1.0 } else { 1.0 },
            if i & 4 == 0 { 0.0 } else { z_max },
        );
        let p = to_world.transform_point3a(corner);
        min = min.min(p);
        max = max.max(p);
    }
    (min, max)
}
