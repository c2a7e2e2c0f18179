//! Mitsuba 3's `orthographic` camera: parallel rays along the camera's +z, leaving the near
//! plane. Before `to_world` the view spans x in [-1, 1] and y in [-1/aspect, 1/aspect]
//! (aspect = width / height), so `to_world`'s scale sets the visible extent. Image x grows
//! towards camera -x and image y towards camera -y, as in the perspective camera.

use glam::{Mat4, Vec2, Vec3A};

/// An orthographic camera: each ray starts at its own point of the near plane.
#[derive(Clone, Debug)]
pub struct OrthographicCamera {
    to_world: Mat4,
    /// The world direction of every ray (normalised camera +z).
    dir: Vec3A,
    /// Camera-space half extents of the view: 1 and 1/aspect.
    half: Vec2,
    near_clip: f32,
    /// Mitsuba's `far_clip`: rays end `far_clip - near_clip` after their start.
    far_clip: f32,
    width: u32,
    height: u32,
}

impl OrthographicCamera {
    pub fn new(to_world: Mat4, near_clip: f32, width: u32, height: u32) -> Self {
        let aspect = width as f32 / height as f32;
        Self {
            to_world,
            dir: to_world.transform_vector3a(Vec3A::Z).normalize(),
            half: Vec2::new(1.0, 1.0 / aspect),
            near_clip,
            far_clip: f32::INFINITY,
            width,
            height,
        }
    }

    /// The camera with Mitsuba's `far_clip`.
    pub fn with_far_clip(mut self, far: f32) -> Self {
        self.far_clip = far;
        self
    }

    /// Distances along a ray between which it sees geometry: from its start on the near plane
    /// to `far_clip - near_clip` after it, as Mitsuba's `maxt`.
    pub fn clip_range(&self) -> (f32, f32) {
        (0.0, self.far_clip - self.near_clip)
    }

    pub fn width(&self) -> u32 {
        self.width
    }

    pub fn height(&self) -> u32 {
        self.height
    }

    /// The ray through film position `film` (pixels, (0, 0) = top-left corner): its origin on
    /// the near plane and the shared world direction.
    #[inline]
    pub fn generate_ray(&self, film: Vec2) -> (Vec3A, Vec3A) {
        let sx = film.x / self.width as f32;
        let sy = film.y / self.height as f32;
        let local = Vec3A::new(
            (1.0 - 2.0 * sx) * self.half.x,
            (1.0 - 2.0 * sy) * self.half.y,
            self.near_clip,
        );
        (self.to_world.transform_point3a(local), self.dir)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use glam::Vec3;

    /// Mitsuba 3.9.1's rays for a 40 x 20 film under scale (2, 3, 1): the film's corners start
    /// at (±2, ±1.5, 0.01), its centre on the axis, all along +z.
    #[test]
    fn rays_match_mitsubas_for_a_scaled_view() {
        let cam = OrthographicCamera::new(Mat4::from_scale(Vec3::new(2.0, 3.0, 1.0)), 0.01, 40, 20);
        for (film, origin) in [
            (Vec2::ZERO, Vec3A::new(2.0, 1.5, 0.01)),
            (Vec2::new(40.0, 20.0), Vec3A::new(-2.0, -1.5, 0.01)),
            (Vec2::new(20.0, 10.0), Vec3A::new(0.0, 0.0, 0.01)),
            (Vec2::new(10.0, 10.0), Vec3A::new(1.0, 0.0, 0.01)),
        ] {
            let (o, d) = cam.generate_ray(film);
            assert!((o - origin).length() < 1e-6, "{film}: {o}");
            assert_eq!(d, Vec3A::Z);
        }
    }
}
