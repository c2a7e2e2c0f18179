//! Cameras (Mitsuba's sensors): from a point on the film and one on the lens to a primary ray.
//!
//! The contract with the render loop: [`Camera::lens_requests`] says how many 2D sampler draws a
//! ray uses beyond the film position (so that low-discrepancy samplers can resume a sample at the
//! right dimension), and [`Camera::rays_share_origin`] says whether a pixel's rays leave one point
//! (packets of camera rays rely on it and are switched off for cameras whose rays do not).
//! A new camera is a file, a [`Camera`] variant with one-line arms, the parser mapping and docs.

mod orthographic;
mod perspective;
mod thinlens;

pub use orthographic::OrthographicCamera;
pub use perspective::PerspectiveCamera;
pub use thinlens::ThinLensCamera;

#[cfg(test)]
pub(crate) use perspective::look_at;

use glam::{Vec2, Vec3A};

/// Where on the film (in pixels, (0, 0) = top-left corner) and where on the lens (a point of the
/// unit square) a camera ray starts.
#[derive(Clone, Copy, Debug)]
pub struct CameraSample {
    pub film: Vec2,
    pub lens: Vec2,
}

/// The scene's camera.
#[derive(Clone, Debug)]
pub enum Camera {
    Perspective(PerspectiveCamera),
    ThinLens(ThinLensCamera),
    Orthographic(OrthographicCamera),
}

impl Camera {
    pub fn width(&self) -> u32 {
        match self {
            Camera::Perspective(c) => c.width(),
            Camera::ThinLens(c) => c.pinhole.width(),
            Camera::Orthographic(c) => c.width(),
        }
    }

    pub fn height(&self) -> u32 {
        match self {
            Camera::Perspective(c) => c.height(),
            Camera::ThinLens(c) => c.pinhole.height(),
            Camera::Orthographic(c) => c.height(),
        }
    }

    /// Angle one pixel subtends at the image centre: the ray cone's initial spread (0 for
    /// parallel rays: their cones start as points, and textures seen directly are read at the
    /// finest level).
    pub fn pixel_spread(&self) -> f32 {
        match self {
            Camera::Perspective(c) => c.pixel_spread(),
            Camera::ThinLens(c) => c.pinhole.pixel_spread(),
            Camera::Orthographic(_) => 0.0,
        }
    }

    /// 2D sampler draws a ray takes for the lens, after the one for the film position.
    pub fn lens_requests(&self) -> u32 {
        match self {
            Camera::Perspective(_) => 0,
            Camera::ThinLens(_) => 1,
            Camera::Orthographic(_) => 0,
        }
    }

    /// Whether all rays leave from one point (a pinhole, or a thin lens of zero aperture): only
    /// then are a pixel's camera rays traced as a packet.
    pub fn rays_share_origin(&self) -> bool {
        match self {
            Camera::Perspective(_) => true,
            Camera::ThinLens(c) => c.is_pinhole(),
            Camera::Orthographic(_) => false,
        }
    }

    /// Distances along a camera ray of direction `dir` (from [`Camera::generate_ray`]) between
    /// which it sees geometry: Mitsuba's near and far clip planes for the perspective and thin
    /// lens cameras (whose rays start on the near plane and end on the far one); for the
    /// orthographic camera, whose rays start on the near plane, `far_clip - near_clip`.
    #[inline]
    pub fn clip_range(&self, dir: Vec3A) -> (f32, f32) {
        match self {
            Camera::Perspective(c) => c.clip_range(dir),
            Camera::ThinLens(c) => c.pinhole.clip_range(dir),
            Camera::Orthographic(c) => c.clip_range(),
        }
    }

    /// The primary ray for `sample`: its origin and normalised world direction.
    #[inline]
    pub fn generate_ray(&self, sample: &CameraSample) -> (Vec3A, Vec3A) {
        match self {
            Camera::Perspective(c) => c.generate_ray(sample.film),
            Camera::ThinLens(c) => c.generate_ray(sample.film, sample.lens),
            Camera::Orthographic(c) => c.generate_ray(sample.film),
        }
    }

    /// A packet's rays (at most [`MAX_RAYS`]; the camera's [`Camera::rays_share_origin`]):
    /// the directions of [`Camera::generate_ray`] for the film positions `films` and lens
    /// points `lenses` (read only by cameras with a lens) into `dirs`, to the bit, and the
    /// origin of the last ray (every ray's, for cameras whose rays share it). The perspective
    /// camera computes them together ([`PerspectiveCamera::generate_dirs`]).
    #[inline]
    pub fn generate_packet(&self, films: &[Vec2], lenses: &[Vec2], dirs: &mut [Vec3A]) -> Vec3A {
        match self {
            Camera::Perspective(c) => c.generate_dirs(films, dirs),
            _ => {
                let mut origin = Vec3A::ZERO;
                for ((d, &film), &lens) in dirs.iter_mut().zip(films).zip(lenses) {
                    (origin, *d) = self.generate_ray(&CameraSample { film, lens });
                }
                origin
            }
        }
    }
}

/// The most rays [`Camera::generate_packet`] takes at once: the widest packet.
pub const MAX_RAYS: usize = 16;
