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
            // The ray hit the sphere: the cone's density, even where a ray from the offset
            // origin hit just outside the cone seen from `p` (`sphere_hit_pdf`).
            AreaEmitter::Sphere(sphere) => sphere.hit_pdf(p, wi),
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

#[cfg(test)]
mod tests {
    use super::*;
    use crate::ray::{offset_origin, Ray};
    use crate::shapes::sphere::intersect_sphere;
    use crate::textures::Texture;
    use glam::{Mat4, Vec3};
    use torrey_testkit::{assert_chi_square, Rng};

    fn sphere_light(center: Vec3, radius: f32) -> AreaLight {
        AreaLight {
            radiance: Vec3A::splat(3040.0),
            texture: None,
            emitter: AreaEmitter::Sphere(Sphere::new(center, radius, Mat4::IDENTITY)),
            flip_normals: false,
        }
    }

    /// The cone density of a sphere seen from `p` outside it, in f64.
    fn cone_pdf(center: Vec3, radius: f32, p: Vec3) -> f64 {
        let sin2 = (radius as f64).powi(2) / (center - p).as_dvec3().length_squared();
        1.0 / (std::f64::consts::TAU * (1.0 - (1.0 - sin2).sqrt()))
    }

    /// A basis around `w` built independently of the code under test.
    fn basis(w: Vec3) -> (Vec3, Vec3) {
        let a = if w.x.abs() < 0.9 { Vec3::X } else { Vec3::Y };
        let t1 = a.cross(w).normalize();
        (t1, w.cross(t1))
    }

    /// Every ray a path traces towards a sphere light and that hits it gets a positive light pdf,
    /// the density light sampling gives that direction, from shading points far from the origin
    /// (where the ray's origin is moved off the surface by 2e-5 x (1 + |p|)) aimed at the
    /// sphere's silhouette. Before `sphere_hit_pdf`, hits just outside the cone seen from the
    /// shading point itself got pdf 0, hence MIS weight 1: the fireflies of issue 34.
    #[test]
    fn every_ray_that_hits_a_sphere_light_has_its_sampling_density() {
        let mut rng = Rng::new(34);
        let (mut hits, mut outside_cone) = (0, 0);
        for &(center, radius) in &[
            (Vec3::new(-3.75, 0.0, 0.0), 0.05),
            (Vec3::new(-1.25, 0.0, 0.0), 0.15),
            (Vec3::new(3.75, 0.0, 0.0), 1.0),
        ] {
            let light = sphere_light(center, radius);
            for _ in 0..4000 {
                // A shading point on a wall or floor 4 to 12 units away, its normal towards the
                // sphere's side.
                let p = center
                    + Vec3::new(
                        rng.range(-8.0, 8.0),
                        rng.range(-6.0, -4.0),
                        rng.range(-6.0, 6.0),
                    );
                let ng = if rng.f32() < 0.5 {
                    Vec3A::Y
                } else {
                    Vec3A::from((center - p).normalize() + Vec3::new(0.3, 0.0, 0.0)).normalize()
                };
                // Aim within 2% of the radius of the silhouette seen from p.
                let w = (center - p).normalize();
                let (t1, t2) = basis(w);
                let phi = rng.range(0.0, std::f32::consts::TAU);
                let rim =
                    center + (t1 * phi.cos() + t2 * phi.sin()) * radius * rng.range(0.98, 1.02);
                let dir = Vec3A::from((rim - p).normalize());
                let origin = offset_origin(p.into(), ng, dir);
                let ray = Ray {
                    origin,
                    dir,
                    tmax: f32::INFINITY,
                };
                let Some(t) = intersect_sphere(&ray, center.into(), radius, 0.0, f32::INFINITY)
                else {
                    continue;
                };
                hits += 1;
                let q = origin + t * dir;
                let n = (q - Vec3A::from(center)).normalize();
                let pdf = light.pdf_hit(p.into(), dir, t, n, Vec2::ZERO) as f64;
                let want = cone_pdf(center, radius, p);
                assert!(
                    (pdf - want).abs() <= 2e-3 * want,
                    "p {p} dir {dir}: pdf {pdf}, light sampling's density {want}"
                );
                // Whether the line from p itself along dir misses the sphere (in f64).
                let (o, d, c) = (p.as_dvec3(), Vec3::from(dir).as_dvec3(), center.as_dvec3());
                let b = (o - c).dot(d);
                if b * b - ((o - c).length_squared() - (radius as f64).powi(2)) < 0.0 {
                    outside_cone += 1;
                }
            }
        }
        // The case that mattered occurs: hits whose direction lies outside the cone from p.
        assert!(hits > 5000, "{hits} hits");
        assert!(
            outside_cone > hits / 200,
            "{outside_cone} of {hits} outside the cone"
        );
    }

    /// Light sampling's directions towards a sphere are distributed as the pdf MIS uses for the
    /// rays that hit it: a histogram of sampled directions over (1 - cos, phi) bins around the
    /// axis against the hit pdf integrated over the directions of each bin that hit the sphere
    /// (chi-square); and each sample reports that pdf. Near (the Taylor branch's far side of
    /// 1.5 degrees) and far, small spheres.
    #[test]
    fn sphere_light_samples_follow_the_hit_pdf() {
        let textures: [Texture; 0] = [];
        for (k, &(center, radius, p)) in [
            (Vec3::new(0.0, 0.0, 0.0), 0.4, Vec3::new(1.0, -3.0, 2.0)),
            (Vec3::new(-3.75, 0.0, 0.0), 0.05, Vec3::new(2.0, -4.1, 3.0)),
        ]
        .iter()
        .enumerate()
        {
            let light = sphere_light(center, radius);
            let w = (center - p).normalize();
            let (t1, t2) = basis(w);
            let dist = (center - p).length() as f64;
            let omc_max = 1.0 - (1.0 - (radius as f64 / dist).powi(2)).sqrt();
            let (nt, np) = (8usize, 8usize);
            let range = 1.2; // bins over (1 - cos) / omc_max in [0, 1.2)
            let samples = 80_000;
            let mut hist = vec![0.0f64; nt * np];
            let mut rng = Rng::new(100 + k as u64);
            for _ in 0..samples {
                let ls = light
                    .sample_deferred(p.into(), rng.vec2(), &textures)
                    .expect("the sphere faces p");
                let d = Vec3::from(ls.wi);
                let n = (Vec3A::from(p) + ls.wi * ls.dist - Vec3A::from(center)).normalize();
                let hit_pdf = light.pdf_hit(p.into(), ls.wi, ls.dist, n, Vec2::ZERO);
                assert!(hit_pdf > 0.0 && (ls.pdf - hit_pdf).abs() <= 1e-4 * hit_pdf);
                let omc = 0.5 * (d - w).as_dvec3().length_squared() / omc_max;
                let phi = (d.dot(t2) as f64)
                    .atan2(d.dot(t1) as f64)
                    .rem_euclid(std::f64::consts::TAU);
                let it = ((omc / range * nt as f64) as usize).min(nt - 1);
                let ip = ((phi / std::f64::consts::TAU * np as f64) as usize).min(np - 1);
                hist[it * np + ip] += 1.0;
            }
            // Expected: the hit pdf over the directions of each bin whose ray from p hits.
            let sub = 16;
            let mut expected = vec![0.0f64; nt * np];
            let mut total = 0.0;
            for it in 0..nt {
                for ip in 0..np {
                    let mut acc = 0.0;
                    for a in 0..sub {
                        for b in 0..sub {
                            let omc = (it as f64 + (a as f64 + 0.5) / sub as f64) / nt as f64
                                * range
                                * omc_max;
                            let phi = (ip as f64 + (b as f64 + 0.5) / sub as f64) / np as f64
                                * std::f64::consts::TAU;
                            let sin = (omc * (2.0 - omc)).sqrt();
                            let d = w.as_dvec3() * (1.0 - omc)
                                + (t1.as_dvec3() * phi.cos() + t2.as_dvec3() * phi.sin()) * sin;
                            let ray = Ray {
                                origin: p.into(),
                                dir: Vec3A::from(d.as_vec3()),
                                tmax: f32::INFINITY,
                            };
                            if let Some(t) =
                                intersect_sphere(&ray, center.into(), radius, 0.0, f32::INFINITY)
                            {
                                let q = ray.origin + t * ray.dir;
                                let n = (q - Vec3A::from(center)).normalize();
                                acc += light.pdf_hit(p.into(), ray.dir, t, n, Vec2::ZERO) as f64;
                            }
                        }
                    }
                    let dw = omc_max * range / nt as f64 * std::f64::consts::TAU / np as f64;
                    let mass = acc / (sub * sub) as f64 * dw;
                    total += mass;
                    expected[it * np + ip] = mass * samples as f64;
                }
            }
            assert!(
                (total - 1.0).abs() < 5e-3,
                "the hit pdf integrates to {total}"
            );
            assert_chi_square("sphere light directions", &hist, &expected);
        }
    }
}
