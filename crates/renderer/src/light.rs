//! The scene's lights and next-event estimation: sampling a point (or direction) on a light from a
//! shading point, and the solid-angle pdf of the same event for multiple importance sampling.
//! Lights are chosen uniformly, as Mitsuba 3 does, so the pdfs here include the 1/N factor only
//! where the integrator multiplies it in.

use glam::{Vec2, Vec3A};
use torrey_light::{
    sample_sphere_solid_angle, sample_triangle_uniform, sphere_solid_angle_pdf, AliasTable, EnvMap,
};

/// One triangle of a mesh emitter, stored with the light so that sampling it reads one record
/// instead of following primitive, index and vertex lists.
#[derive(Clone, Copy, Debug)]
pub struct EmitterTriangle {
    pub p0: Vec3A,
    pub e1: Vec3A,
    pub e2: Vec3A,
    /// The unit face normal (before `flip_normals`).
    pub normal: Vec3A,
}

/// Geometry an area light samples from.
pub enum AreaShape {
    /// Triangles chosen by area, from an alias table: one lookup instead of a cdf search.
    Mesh {
        total_area: f32,
        triangles: AliasTable,
        geometry: Vec<EmitterTriangle>,
    },
    Sphere {
        center: Vec3A,
        radius: f32,
    },
}

pub enum LightKind {
    Point {
        position: Vec3A,
        intensity: Vec3A,
    },
    /// One-sided diffuse emitter on a shape: radiance along the (possibly flipped) normal only.
    Area {
        shape: u32,
        radiance: Vec3A,
        area: AreaShape,
        flip_normals: bool,
    },
    Constant {
        radiance: Vec3A,
    },
    Env(Box<EnvMap>),
}

pub struct Light {
    pub kind: LightKind,
}

/// A sampled light connection from a shading point.
#[derive(Clone, Copy, Debug)]
pub struct LightSample {
    /// Unit direction from the shading point towards the light.
    pub wi: Vec3A,
    /// Distance to the sampled point (infinite for lights at infinity).
    pub dist: f32,
    /// Emitted radiance (or intensity / r² for point lights) arriving along -wi.
    pub radiance: Vec3A,
    /// Solid-angle pdf of this light's sampling (not including light selection).
    pub pdf: f32,
    /// Point lights cannot be hit by BSDF samples: no MIS.
    pub is_delta: bool,
}

/// The shading-point-independent part of a light sample ([`Light::draw`]).
#[derive(Clone, Copy, Debug)]
pub enum LightDraw {
    /// Nothing drawn yet: [`Light::connect`] samples with these random numbers.
    Deferred(Vec2),
    /// A point on an emitting triangle and the light's normal there (after `flipNormals`).
    MeshPoint { q: Vec3A, n: Vec3A },
}

/// Importance-samples an environment map. Kept out of [`Light::connect`] (whose other arms are
/// small) so that inlining the map's sampling does not bloat the area-light path.
#[inline(never)]
fn sample_env(env: &EnvMap, u: Vec2) -> Option<LightSample> {
    let s = env.sample(u)?;
    Some(LightSample {
        wi: s.direction.into(),
        dist: f32::INFINITY,
        radiance: s.radiance.into(),
        pdf: s.pdf,
        is_delta: false,
    })
}

impl Light {
    pub fn is_infinite(&self) -> bool {
        matches!(self.kind, LightKind::Constant { .. } | LightKind::Env(_))
    }

    /// Next-event estimation samples a light in two steps, `connect(draw(u), p, uniform_env)`.
    /// This first step is the part that does not depend on the shading point `p`, for lights
    /// where that part is worth drawing early: a point on an emitting mesh. The integrator draws it
    /// before tracing the ray that finds the shading point, so that its chain of dependent
    /// operations (alias pick, square root, interpolation) overlaps the traversal: cbox renders
    /// 4% faster. Other lights defer everything to [`Light::connect`]: drawn early, a sample of
    /// an environment map is wasted on every path that escapes, which cost envmap_sky 21%, and
    /// one of a constant background cost textured_mesh 2%.
    #[inline(always)]
    pub fn draw(&self, u: Vec2) -> LightDraw {
        match &self.kind {
            LightKind::Area {
                area:
                    AreaShape::Mesh {
                        triangles,
                        geometry,
                        ..
                    },
                flip_normals,
                ..
            } => {
                let (index, u_rest) = triangles.sample(u.x);
                let tri = &geometry[index];
                let (b1, b2) = sample_triangle_uniform(Vec2::new(u_rest, u.y));
                let q = tri.p0 + b1 * tri.e1 + b2 * tri.e2;
                let n = if *flip_normals {
                    -tri.normal
                } else {
                    tri.normal
                };
                LightDraw::MeshPoint { q, n }
            }
            _ => LightDraw::Deferred(u),
        }
    }

    /// Finishes a sample that [`Light::draw`] started: a connection from `p`, None when it
    /// carries no energy. `uniform_env` samples environment maps uniformly over the sphere
    /// instead of by luminance (only for measuring what importance sampling gains).
    #[inline(always)]
    pub fn connect(&self, draw: LightDraw, p: Vec3A, uniform_env: bool) -> Option<LightSample> {
        match draw {
            LightDraw::MeshPoint { q, n } => {
                let LightKind::Area {
                    radiance,
                    area: AreaShape::Mesh { total_area, .. },
                    ..
                } = &self.kind
                else {
                    unreachable!("mesh points come from mesh lights");
                };
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
                    radiance: *radiance,
                    pdf: dist2 / (cos_light * total_area),
                    is_delta: false,
                })
            }
            LightDraw::Deferred(u) => self.sample_deferred(p, u, uniform_env),
        }
    }

    /// The lights that [`Light::draw`] leaves entirely to [`Light::connect`].
    #[inline(always)]
    fn sample_deferred(&self, p: Vec3A, u: Vec2, uniform_env: bool) -> Option<LightSample> {
        match &self.kind {
            LightKind::Point {
                position,
                intensity,
            } => {
                let d = *position - p;
                let dist2 = d.length_squared();
                if dist2 == 0.0 {
                    return None;
                }
                let dist = dist2.sqrt();
                Some(LightSample {
                    wi: d / dist,
                    dist,
                    radiance: *intensity / dist2,
                    pdf: 1.0,
                    is_delta: true,
                })
            }
            LightKind::Area {
                radiance,
                area: AreaShape::Sphere { center, radius },
                flip_normals,
                ..
            } => {
                let s = sample_sphere_solid_angle((*center).into(), *radius, p.into(), u)?;
                let mut n: Vec3A = s.normal.into();
                if *flip_normals {
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
                    radiance: *radiance,
                    pdf: s.pdf,
                    is_delta: false,
                })
            }
            LightKind::Constant { radiance } => {
                let wi = crate::sampling::square_to_uniform_sphere(u);
                Some(LightSample {
                    wi,
                    dist: f32::INFINITY,
                    radiance: *radiance,
                    pdf: crate::sampling::uniform_sphere_pdf(),
                    is_delta: false,
                })
            }
            LightKind::Env(env) if uniform_env => {
                let wi = crate::sampling::square_to_uniform_sphere(u);
                Some(LightSample {
                    wi,
                    dist: f32::INFINITY,
                    radiance: env.eval(wi.into(), 0.0).into(),
                    pdf: crate::sampling::uniform_sphere_pdf(),
                    is_delta: false,
                })
            }
            LightKind::Env(env) => sample_env(env, u),
            LightKind::Area {
                area: AreaShape::Mesh { .. },
                ..
            } => unreachable!("mesh lights are drawn by `Light::draw`"),
        }
    }

    /// Solid-angle pdf that [`Light::connect`] from `p` produces direction `wi` hitting this
    /// (area) light at distance `dist` where the light's normal is `n_light`.
    #[inline]
    pub fn pdf_area_hit(&self, p: Vec3A, wi: Vec3A, dist: f32, n_light: Vec3A) -> f32 {
        match &self.kind {
            LightKind::Area {
                area: AreaShape::Mesh { total_area, .. },
                ..
            } => {
                let cos = n_light.dot(wi).abs();
                if cos == 0.0 {
                    0.0
                } else {
                    dist * dist / (cos * total_area)
                }
            }
            LightKind::Area {
                area: AreaShape::Sphere { center, radius },
                ..
            } => sphere_solid_angle_pdf((*center).into(), *radius, p.into(), wi.into()),
            _ => 0.0,
        }
    }

    /// Radiance from an infinite light along a ray leaving the scene in direction `dir`, and the pdf
    /// its own sampling gives that direction.
    #[inline]
    pub fn eval_infinite(&self, dir: Vec3A, spread: f32) -> (Vec3A, f32) {
        match &self.kind {
            LightKind::Constant { radiance } => (*radiance, crate::sampling::uniform_sphere_pdf()),
            LightKind::Env(env) => {
                let (l, p) = env.eval_pdf(dir.into(), spread);
                (l.into(), p)
            }
            _ => (Vec3A::ZERO, 0.0),
        }
    }

    /// [`Light::eval_infinite`]'s radiance alone, for rays whose MIS weight is 1 (camera rays and
    /// rays after a delta bounce): an environment map then skips its density lookup.
    #[inline]
    pub fn radiance_infinite(&self, dir: Vec3A, spread: f32) -> Vec3A {
        match &self.kind {
            LightKind::Constant { radiance } => *radiance,
            LightKind::Env(env) => env.eval(dir.into(), spread).into(),
            _ => Vec3A::ZERO,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use torrey_testkit::{assert_chi_square, Rng};

    /// A one-sided emitter facing +z made of two triangles in the z = 0 plane: areas 1 and 3.
    fn two_triangle_light() -> Light {
        let geometry = vec![
            EmitterTriangle {
                p0: Vec3A::ZERO,
                e1: Vec3A::new(2.0, 0.0, 0.0),
                e2: Vec3A::new(0.0, 1.0, 0.0),
                normal: Vec3A::Z,
            },
            EmitterTriangle {
                p0: Vec3A::new(3.0, 0.0, 0.0),
                e1: Vec3A::new(3.0, 0.0, 0.0),
                e2: Vec3A::new(0.0, 2.0, 0.0),
                normal: Vec3A::Z,
            },
        ];
        Light {
            kind: LightKind::Area {
                shape: 0,
                radiance: Vec3A::ONE,
                area: AreaShape::Mesh {
                    total_area: 4.0,
                    triangles: AliasTable::new(&[1.0, 3.0]),
                    geometry,
                },
                flip_normals: false,
            },
        }
    }

    /// Points drawn before the shading point is known, then connected to it, are uniform over
    /// the mesh's area (chi-square over unit strips in x), and the pdf they report is the one
    /// MIS uses when a BSDF sample hits the light.
    #[test]
    fn mesh_light_points_are_uniform_by_area_and_match_the_hit_pdf() {
        let light = two_triangle_light();
        let p = Vec3A::new(1.5, 0.7, 2.0);
        let mut rng = Rng::new(17);
        // Strips x in [0,1], [1,2] (first triangle), [3,4], [4,5], [5,6] (second): their areas.
        let expected_area = [0.75, 0.25, 5.0 / 3.0, 1.0, 1.0 / 3.0];
        let mut counts = [0.0f64; 5];
        let n = 50_000;
        for _ in 0..n {
            let u = rng.vec2();
            let ls = light
                .connect(light.draw(u), p, false)
                .expect("the light faces p");
            let q = p + ls.wi * ls.dist;
            assert!(q.z.abs() < 1e-4, "{q}");
            let strip = match q.x {
                x if x < 1.0 => 0,
                x if x < 2.0 => 1,
                x if x < 4.0 => 2,
                x if x < 5.0 => 3,
                _ => 4,
            };
            counts[strip] += 1.0;
            let hit_pdf = light.pdf_area_hit(p, ls.wi, ls.dist, Vec3A::Z);
            assert!(
                (ls.pdf - hit_pdf).abs() <= 1e-4 * hit_pdf,
                "{} vs {hit_pdf}",
                ls.pdf
            );
        }
        let expected: Vec<f64> = expected_area.iter().map(|a| a / 4.0 * n as f64).collect();
        assert_chi_square("mesh light strips", &counts, &expected);
    }

    /// Behind a one-sided emitter nothing is sampled.
    #[test]
    fn mesh_light_is_dark_from_behind() {
        let light = two_triangle_light();
        let mut rng = Rng::new(5);
        for _ in 0..1000 {
            let u = rng.vec2();
            let below = Vec3A::new(2.0, 0.5, -1.0);
            assert!(light.connect(light.draw(u), below, false).is_none());
        }
    }
}
