//! A textured `radiance` of an area emitter (Mitsuba's `area` with a texture): the texture at the
//! surface's uv is the emitted radiance, and where Mitsuba importance-samples it (a bitmap on a
//! shape whose uv parameterisation it can invert: here rectangles, spheres, disks and cylinders), next-event
//! estimation draws points by the texture's luminance as Mitsuba's `area.cpp` does: a uv from the
//! texture's distribution (`sample_position`), mapped onto the shape (`eval_parameterization`),
//! its density divided by |dp/du x dp/dv| and converted to solid angle.
//!
//! The distribution over texels: each texel's weight is the luminance of the bilinear
//! reconstruction averaged over its cell (the 3x3 stencil 1/64, 3/32, 1/64; ... around it, with
//! the image's neighbours wrapping), uniform inside the cell. So the density is positive wherever
//! the bilinear lookup can be (no bias), and proportional to it up to the stencil's blur. Mitsuba
//! samples its bitmaps piecewise bilinearly instead; both are proper densities over the same
//! support, so only noise differs.

use crate::shapes::cylinder::Cylinder;
use crate::shapes::disk::Disk;
use glam::{Mat3, Vec2, Vec3A};
use std::f32::consts::PI;
use torrey_fastmath::sin_cos_2pi;
use torrey_light::{luminance, AliasTable};
use torrey_texture::Image;

/// How a uv of the texture maps onto the emitting shape (Mitsuba's `eval_parameterization`).
#[derive(Clone, Debug)]
pub enum UvMap {
    /// Mitsuba's rectangle: p = origin + (2u - 1) ax + (2v - 1) ay, with the geometric normal
    /// of its triangles.
    Rectangle {
        origin: Vec3A,
        ax: Vec3A,
        ay: Vec3A,
        normal: Vec3A,
    },
    /// Mitsuba's sphere: phi = 2 pi u, theta = pi v about the object frame's +z.
    Sphere {
        center: Vec3A,
        radius: f32,
        to_world: Mat3,
    },
    /// Mitsuba's disk: u = r, v = φ / 2π (boxed: the shape keeps its transforms).
    Disk(Box<Disk>),
    /// Mitsuba's cylinder: u = φ / 2π, v = height.
    Cylinder(Box<Cylinder>),
}

impl UvMap {
    /// The point, the outward unit normal (before `flip_normals`) and |dp/du x dp/dv| at `uv`.
    #[inline]
    pub fn eval(&self, uv: Vec2) -> (Vec3A, Vec3A, f32) {
        match *self {
            UvMap::Rectangle {
                origin,
                ax,
                ay,
                normal,
            } => {
                let p = origin + (2.0 * uv.x - 1.0) * ax + (2.0 * uv.y - 1.0) * ay;
                (p, normal, 4.0 * ax.cross(ay).length())
            }
            UvMap::Sphere {
                center,
                radius,
                to_world,
            } => {
                let (sin_phi, cos_phi) = sin_cos_2pi(uv.x);
                let (sin_theta, cos_theta) = sin_cos_2pi(0.5 * uv.y);
                let local = glam::Vec3::new(sin_theta * cos_phi, sin_theta * sin_phi, cos_theta);
                let n = Vec3A::from(to_world * local);
                (
                    center + radius * n,
                    n,
                    2.0 * PI * PI * radius * radius * sin_theta,
                )
            }
            UvMap::Disk(ref disk) => disk.point_at_uv(uv),
            UvMap::Cylinder(ref cylinder) => cylinder.point_at_uv(uv),
        }
    }

    /// |dp/du x dp/dv| at `uv` alone (what the pdf of a hit needs).
    #[inline]
    pub fn jacobian(&self, uv: Vec2) -> f32 {
        match *self {
            UvMap::Rectangle { ax, ay, .. } => 4.0 * ax.cross(ay).length(),
            UvMap::Sphere { radius, .. } => {
                2.0 * PI * PI * radius * radius * sin_cos_2pi(0.5 * uv.y).0
            }
            UvMap::Disk(ref disk) => disk.uv_jacobian(uv),
            UvMap::Cylinder(ref cylinder) => cylinder.uv_jacobian(uv),
        }
    }
}

/// Texels chosen by luminance, and the density over the unit uv square that gives each.
pub struct TexelDistribution {
    table: AliasTable,
    width: u32,
    height: u32,
    /// Density over uv of each texel's cell (row-major): probability x texel count.
    density: Vec<f32>,
}

impl TexelDistribution {
    /// The distribution of `image` (the finest level of the bitmap); None when it is black.
    pub fn new(image: &Image) -> Option<Self> {
        let (w, h) = (image.width as usize, image.height as usize);
        if w == 0 || h == 0 {
            return None;
        }
        let lum: Vec<f32> = image
            .pixels
            .iter()
            .map(|&p| {
                let l = luminance(p);
                if l.is_finite() && l > 0.0 {
                    l
                } else {
                    0.0
                }
            })
            .collect();
        const K: [f32; 3] = [0.125, 0.75, 0.125];
        let mut weights = Vec::with_capacity(w * h);
        for j in 0..h {
            let rows = [(j + h - 1) % h, j, (j + 1) % h];
            for i in 0..w {
                let cols = [(i + w - 1) % w, i, (i + 1) % w];
                let mut acc = 0.0;
                for (r, kr) in rows.iter().zip(K) {
                    for (c, kc) in cols.iter().zip(K) {
                        acc += kr * kc * lum[r * w + c];
                    }
                }
                weights.push(acc);
            }
        }
        let table = AliasTable::new(&weights);
        if table.weight_sum() <= 0.0 {
            return None;
        }
        let cells = (w * h) as f32;
        let density = (0..w * h).map(|k| table.probability(k) * cells).collect();
        Some(Self {
            table,
            width: w as u32,
            height: h as u32,
            density,
        })
    }

    /// A uv in [0, 1)^2 and its density over the unit square.
    #[inline]
    pub fn sample(&self, u: Vec2) -> (Vec2, f32) {
        let (k, rest) = self.table.sample(u.x);
        let (i, j) = (k as u32 % self.width, k as u32 / self.width);
        let uv = Vec2::new(
            (i as f32 + rest) / self.width as f32,
            (j as f32 + u.y) / self.height as f32,
        )
        .min(Vec2::splat(1.0 - f32::EPSILON / 2.0));
        (uv, self.density[k])
    }

    /// The density over the unit square at `uv` (wrapped into [0, 1)).
    #[inline]
    pub fn pdf(&self, uv: Vec2) -> f32 {
        let uv = uv - uv.floor();
        if !uv.is_finite() {
            return 0.0;
        }
        let i = ((uv.x * self.width as f32) as u32).min(self.width - 1);
        let j = ((uv.y * self.height as f32) as u32).min(self.height - 1);
        self.density[(j * self.width + i) as usize]
    }
}

/// The texture of a textured area emitter, and its sampling where the shape allows it.
pub struct EmissionTexture {
    /// Index into the scene's textures.
    pub texture: u32,
    /// Texel distribution and the shape's uv map, when next-event estimation samples by the
    /// texture (a bitmap without a uv transform, on a rectangle or a sphere).
    pub sampling: Option<(TexelDistribution, UvMap)>,
}

#[cfg(test)]
mod tests {
    use super::*;
    use glam::Vec3;
    use torrey_testkit::{assert_chi_square, Rng};

    /// Texels drawn in proportion to their stencil weights (chi-square over the 4x2 texels) and
    /// the reported density is the one `pdf` gives at the drawn uv.
    #[test]
    fn texels_follow_their_weights() {
        let px = (0..8)
            .map(|k| Vec3::splat([0.0, 1.0, 4.0, 0.0, 2.0, 0.0, 0.0, 8.0][k]))
            .collect();
        let image = Image::new(4, 2, px);
        let d = TexelDistribution::new(&image).unwrap();
        let mut rng = Rng::new(3);
        let n = 40_000;
        let mut counts = [0.0f64; 8];
        for _ in 0..n {
            let (uv, p) = d.sample(rng.vec2());
            assert_eq!(p, d.pdf(uv));
            let k = (uv.y * 2.0) as usize * 4 + (uv.x * 4.0) as usize;
            counts[k] += 1.0;
        }
        let expected: Vec<f64> = (0..8)
            .map(|k| d.density[k] as f64 / 8.0 * n as f64)
            .collect();
        assert_chi_square("emission texels", &counts, &expected);
        // Every texel touching a bright one has positive density; a black map has none.
        assert!(d.density.iter().all(|&p| p > 0.0));
        assert!(TexelDistribution::new(&Image::filled(3, 3, Vec3::ZERO)).is_none());
    }

    /// The uv maps' Jacobians are |dp/du x dp/dv| (finite differences) and their normals are
    /// unit and perpendicular to the surface.
    #[test]
    fn uv_maps_jacobians_match_finite_differences() {
        let maps = [
            UvMap::Rectangle {
                origin: Vec3A::new(1.0, 2.0, 3.0),
                ax: Vec3A::new(0.5, 0.0, 0.2),
                ay: Vec3A::new(0.0, 0.7, 0.0),
                normal: Vec3A::new(-0.2, 0.0, 0.5).normalize(),
            },
            UvMap::Sphere {
                center: Vec3A::new(0.0, 1.0, 0.0),
                radius: 0.8,
                to_world: Mat3::from_rotation_x(0.7),
            },
        ];
        for map in maps {
            for uv in [Vec2::new(0.3, 0.4), Vec2::new(0.8, 0.15)] {
                let (p, n, j) = map.eval(uv);
                let h = 1e-3;
                let du = (map.eval(uv + Vec2::new(h, 0.0)).0 - p) / h;
                let dv = (map.eval(uv + Vec2::new(0.0, h)).0 - p) / h;
                let fd = du.cross(dv).length();
                assert!((fd - j).abs() < 5e-3 * j, "{fd} vs {j}");
                assert!((j - map.jacobian(uv)).abs() < 1e-5 * j);
                assert!((n.length() - 1.0).abs() < 1e-5 && n.dot(du).abs() < 1e-2 * du.length());
            }
        }
    }
}
