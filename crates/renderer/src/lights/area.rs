//! A diffuse area emitter on a shape (Mitsuba's `area`): constant radiance, one-sided (along the
//! possibly flipped normal only). Meshes, disks and cylinders are sampled uniformly by area,
//! spheres by the solid angle they subtend; each shape's file holds its sampling and pdf.

use super::{LightDraw, LightSample};
use crate::shapes::cylinder::Cylinder;
use crate::shapes::disk::Disk;
use crate::shapes::mesh::MeshEmitter;
use crate::shapes::sphere::Sphere;
use glam::{Vec2, Vec3A};

/// The geometry an area light samples from.
pub enum AreaEmitter {
    Mesh(MeshEmitter),
    Sphere(Sphere),
    Disk(Disk),
    Cylinder(Cylinder),
}

/// An emitting shape.
pub struct AreaLight {
    pub radiance: Vec3A,
    pub emitter: AreaEmitter,
    pub flip_normals: bool,
}

impl AreaLight {
    /// The part of a sample that does not depend on the shading point: a point on an emitting
    /// mesh ([`super::Light::draw`]); spheres sample by solid angle, so they defer.
    #[inline(always)]
    pub fn draw(&self, u: Vec2) -> LightDraw {
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
    fn area(&self) -> f32 {
        match &self.emitter {
            AreaEmitter::Mesh(mesh) => mesh.total_area(),
            AreaEmitter::Disk(disk) => disk.area,
            AreaEmitter::Cylinder(cylinder) => cylinder.area,
            AreaEmitter::Sphere(_) => unreachable!("spheres are sampled by solid angle"),
        }
    }

    /// The connection from `p` to point `q` (normal `n`) drawn on an emitting mesh, disk or
    /// cylinder.
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

    /// A sample of a sphere emitter from `p` (mesh emitters are drawn by [`AreaLight::draw`]).
    #[inline(always)]
    pub fn sample_deferred(&self, p: Vec3A, u: Vec2) -> Option<LightSample> {
        let AreaEmitter::Sphere(sphere) = &self.emitter else {
            unreachable!("mesh lights are drawn by `AreaLight::draw`");
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
        Some(LightSample {
            wi,
            dist,
            radiance: self.radiance,
            pdf: s.pdf,
            is_delta: false,
        })
    }

    /// Solid-angle pdf that sampling from `p` produces direction `wi` hitting this light at
    /// distance `dist` where its normal is `n_light`.
    #[inline]
    pub fn pdf_hit(&self, p: Vec3A, wi: Vec3A, dist: f32, n_light: Vec3A) -> f32 {
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
