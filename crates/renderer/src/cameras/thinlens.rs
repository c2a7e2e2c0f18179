//! Mitsuba 3's `thinlens` camera: a perspective camera whose rays start on a disk-shaped
//! aperture and converge on the plane at `focus_distance`, giving depth of field.

use super::perspective::PerspectiveCamera;
use crate::sampling::square_to_concentric_disk;
use glam::{Vec2, Vec3A};

/// A thin lens: the pinhole camera's film and field of view, an aperture radius and a focus
/// distance (both in world units along the camera's axis).
#[derive(Clone, Debug)]
pub struct ThinLensCamera {
    pub(crate) pinhole: PerspectiveCamera,
    aperture_radius: f32,
    focus_distance: f32,
}

impl ThinLensCamera {
    pub fn new(pinhole: PerspectiveCamera, aperture_radius: f32, focus_distance: f32) -> Self {
        Self {
            pinhole,
            aperture_radius,
            focus_distance,
        }
    }

    /// Whether the aperture is a point: then every ray leaves the lens centre.
    pub fn is_pinhole(&self) -> bool {
        self.aperture_radius == 0.0
    }

    /// The ray through film position `film` from aperture position `lens` (a point of the unit
    /// square, mapped to the disk concentrically): it starts on the aperture and passes through
    /// the point the pinhole ray meets on the plane of focus.
    #[inline]
    pub fn generate_ray(&self, film: Vec2, lens: Vec2) -> (Vec3A, Vec3A) {
        let local = self.pinhole.local_direction(film);
        let aperture = square_to_concentric_disk(lens) * self.aperture_radius;
        let aperture_p = Vec3A::new(aperture.x, aperture.y, 0.0);
        let focus_p = local * self.focus_distance;
        let to_world = self.pinhole.to_world();
        let origin = to_world.transform_point3a(aperture_p);
        let dir = to_world
            .transform_vector3a(focus_p - aperture_p)
            .normalize();
        (origin, dir)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::cameras::look_at;
    use torrey_parser::FovAxis;

    fn pinhole() -> PerspectiveCamera {
        let m = look_at(Vec3A::new(0.5, 1.0, 3.0), Vec3A::ZERO, Vec3A::Y);
        PerspectiveCamera::new(m, 40.0, FovAxis::X, 64, 48)
    }

    /// Every lens position's ray through a film point meets the pinhole ray through it on the
    /// plane of focus; a zero aperture gives the pinhole ray itself.
    #[test]
    fn rays_converge_on_the_plane_of_focus() {
        let focus = 2.5;
        let lens = ThinLensCamera::new(pinhole(), 0.2, focus);
        let axis = pinhole().to_world().transform_vector3a(Vec3A::Z);
        for film in [
            Vec2::new(3.5, 40.25),
            Vec2::new(32.0, 24.0),
            Vec2::new(60.0, 2.0),
        ] {
            let (o0, d0) = pinhole().generate_ray(film);
            // The pinhole ray reaches the plane of focus (depth `focus` along the axis) at t0.
            let p0 = o0 + d0 * (focus / d0.dot(axis));
            for u in [
                Vec2::new(0.1, 0.9),
                Vec2::new(0.5, 0.5),
                Vec2::new(0.99, 0.02),
            ] {
                let (o, d) = lens.generate_ray(film, u);
                assert!((o - o0).length() <= 0.2 + 1e-5);
                assert!(
                    ((o - o0).dot(axis)).abs() < 1e-5,
                    "origins lie on the lens plane"
                );
                let p = o + d * ((focus - (o - o0).dot(axis)) / d.dot(axis));
                assert!((p - p0).length() < 1e-4, "{p} vs {p0}");
            }
            let (o, d) =
                ThinLensCamera::new(pinhole(), 0.0, focus).generate_ray(film, Vec2::new(0.3, 0.8));
            assert!((o - o0).length() < 1e-6 && (d - d0).length() < 1e-6);
        }
    }
}
