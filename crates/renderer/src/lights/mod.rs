//! The scene's lights and next-event estimation: sampling a point (or direction) on a light from a
//! shading point, and the solid-angle pdf of the same event for multiple importance sampling.
//! Lights are chosen uniformly, as Mitsuba 3 does, so the pdfs here include the 1/N factor only
//! where the integrator multiplies it in. One file per kind; [`Light`] dispatches with one-line
//! arms.

mod area;
mod constant;
mod directional;
mod emission_texture;
mod envmap;
mod light_bounds;
mod light_bounds4;
mod point;
mod projector;
mod selection;
mod spot;

pub use area::{AreaEmitter, AreaLight};
pub use constant::ConstantLight;
pub use directional::DirectionalLight;
pub use emission_texture::{EmissionTexture, TexelDistribution, UvMap};
pub use envmap::EnvLight;
pub use light_bounds::LightBounds;
pub use point::PointLight;
pub use projector::ProjectorLight;
pub use selection::{EarlyChoice, LightSelection};
pub use spot::SpotLight;

use crate::textures::Texture;
use glam::{Vec2, Vec3A};

/// A light of the scene.
pub enum Light {
    Point(PointLight),
    Spot(SpotLight),
    /// At infinity, but reached only by light sampling: not one of the scene's infinite lights,
    /// which escaped rays look up.
    Directional(DirectionalLight),
    /// One-sided diffuse emitter on a shape: radiance along the (possibly flipped) normal only.
    Area(AreaLight),
    Constant(ConstantLight),
    Env(Box<EnvLight>),
    /// Mitsuba's `projector`: a delta-position light projecting a texture.
    Projector(ProjectorLight),
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
    /// An environment map's sample, drawn for many paths at once in SIMD lanes (the wavefront
    /// loop's `EnvMap::sample_batch`): [`Light::connect`] only reads it. `pdf` 0: nothing was
    /// drawn (the one-sample code's `None`).
    EnvSampled {
        wi: Vec3A,
        radiance: Vec3A,
        pdf: f32,
    },
}

impl Light {
    /// A light no BSDF-sampled ray can reach (a point or a direction): delta lights.
    pub fn is_delta(&self) -> bool {
        matches!(
            self,
            Light::Point(_) | Light::Spot(_) | Light::Directional(_) | Light::Projector(_)
        )
    }

    /// The light's bounds for choosing lights by their contribution ([`LightSelection`]); None
    /// for lights at infinity, which are chosen independently of the shading point.
    pub fn bounds(&self) -> Option<LightBounds> {
        match self {
            Light::Point(l) => Some(l.bounds()),
            Light::Spot(l) => Some(l.bounds()),
            Light::Area(l) => Some(l.bounds()),
            Light::Projector(l) => Some(l.bounds()),
            Light::Directional(_) | Light::Constant(_) | Light::Env(_) => None,
        }
    }

    /// A light at infinity that escaped rays see (constant background, environment map).
    pub fn is_infinite(&self) -> bool {
        matches!(self, Light::Constant(_) | Light::Env(_))
    }

    /// Next-event estimation samples a light in two steps, `connect(draw(u), p, uniform_env)`.
    /// This first step is the part that does not depend on the shading point `p`, for lights
    /// where that part is worth drawing early: a point on an emitting mesh. The integrator draws it
    /// before tracing the ray that finds the shading point, so that its chain of dependent
    /// operations (alias pick, square root, interpolation) overlaps the traversal: cbox renders
    /// 4% faster. Other lights defer everything to [`Light::connect`]: drawn early, a sample of
    /// an environment map is wasted on every path that escapes, which cost envmap_sky 21%, and
    /// one of a constant background cost textured_mesh 2%. (The wavefront loop draws the
    /// environment map's samples of the paths that found a surface all at once, in SIMD lanes,
    /// and hands them to `connect` as [`LightDraw::EnvSampled`]; prefetching their table reads
    /// here, for every path, cost it 4%.)
    #[inline(always)]
    pub fn draw(&self, u: Vec2) -> LightDraw {
        match self {
            Light::Area(area) => area.draw(u),
            _ => LightDraw::Deferred(u),
        }
    }

    /// Finishes a sample that [`Light::draw`] started: a connection from `p`, None when it
    /// carries no energy. `uniform_env` samples environment maps uniformly over the sphere
    /// instead of by luminance (only for measuring what importance sampling gains).
    #[inline(always)]
    pub fn connect(
        &self,
        draw: LightDraw,
        p: Vec3A,
        uniform_env: bool,
        textures: &[Texture],
    ) -> Option<LightSample> {
        match (draw, self) {
            (LightDraw::MeshPoint { q, n }, Light::Area(area)) => area.connect_point(q, n, p),
            (LightDraw::MeshPoint { .. }, _) => unreachable!("mesh points come from mesh lights"),
            (LightDraw::EnvSampled { wi, radiance, pdf }, Light::Env(_)) => {
                (pdf > 0.0).then_some(LightSample {
                    wi,
                    dist: f32::INFINITY,
                    radiance,
                    pdf,
                    is_delta: false,
                })
            }
            (LightDraw::EnvSampled { .. }, _) => unreachable!("env samples come from env maps"),
            (LightDraw::Deferred(u), _) => self.sample_deferred(p, u, uniform_env, textures),
        }
    }

    /// The lights that [`Light::draw`] leaves entirely to [`Light::connect`].
    #[inline(always)]
    fn sample_deferred(
        &self,
        p: Vec3A,
        u: Vec2,
        uniform_env: bool,
        textures: &[Texture],
    ) -> Option<LightSample> {
        match self {
            Light::Point(point) => point.sample(p),
            Light::Spot(spot) => spot.sample(p),
            Light::Directional(directional) => directional.sample(),
            Light::Area(area) => area.sample_deferred(p, u, textures),
            Light::Constant(constant) => constant.sample(u),
            Light::Env(env) => env.sample(u, uniform_env),
            Light::Projector(projector) => projector.sample(p, textures),
        }
    }

    /// Solid-angle pdf that [`Light::connect`] from `p` produces direction `wi` hitting this
    /// (area) light at distance `dist` where the light's normal is `n_light` and its uv `uv`.
    #[inline]
    pub fn pdf_area_hit(&self, p: Vec3A, wi: Vec3A, dist: f32, n_light: Vec3A, uv: Vec2) -> f32 {
        match self {
            Light::Area(area) => area.pdf_hit(p, wi, dist, n_light, uv),
            _ => 0.0,
        }
    }

    /// Radiance from an infinite light along a ray leaving the scene in direction `dir`, and the
    /// pdf its own sampling gives that direction.
    #[inline]
    pub fn eval_infinite(&self, dir: Vec3A, spread: f32) -> (Vec3A, f32) {
        match self {
            Light::Constant(constant) => constant.eval(),
            Light::Env(env) => env.eval_pdf(dir, spread),
            _ => (Vec3A::ZERO, 0.0),
        }
    }

    /// [`Light::eval_infinite`]'s radiance alone, for rays whose MIS weight is 1 (camera rays and
    /// rays after a delta bounce): an environment map then skips its density lookup.
    #[inline]
    pub fn radiance_infinite(&self, dir: Vec3A, spread: f32) -> Vec3A {
        match self {
            Light::Constant(constant) => constant.radiance,
            Light::Env(env) => env.eval(dir, spread),
            _ => Vec3A::ZERO,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::shapes::mesh::{EmitterTriangle, MeshEmitter};
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
        Light::Area(AreaLight {
            radiance: Vec3A::ONE,
            texture: None,
            emitter: AreaEmitter::Mesh(MeshEmitter::from_triangles(geometry)),
            flip_normals: false,
        })
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
                .connect(light.draw(u), p, false, &[])
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
            let hit_pdf = light.pdf_area_hit(p, ls.wi, ls.dist, Vec3A::Z, Vec2::ZERO);
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
            assert!(light.connect(light.draw(u), below, false, &[]).is_none());
        }
    }
}
