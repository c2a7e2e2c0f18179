//! Mitsuba 3's perspective pinhole camera. Camera space looks along +z with +x to the left and
//! +y up, so image x grows towards camera -x; pixel (0, 0) is the top-left of the film.

use glam::{Mat4, Vec2, Vec3A};
use torrey_parser::FovAxis;

/// A pinhole camera: every ray starts at the camera's origin.
#[derive(Clone, Debug)]
pub struct PerspectiveCamera {
    origin: Vec3A,
    /// Camera-to-world rotation/scale columns, for directions.
    to_world: Mat4,
    /// tan(fov_x / 2) and tan(fov_y / 2).
    tan_half: Vec2,
    width: u32,
    height: u32,
    /// The film's size in pixels as floats, kept so that each ray does not convert it.
    film_size: Vec2,
    /// Angle one pixel subtends at the image centre: the ray cone's initial spread.
    pixel_spread: f32,
    /// Mitsuba's `principal_point_offset_x/_y`: the film position's fractions of the film are
    /// shifted by it before they become directions (the image centre moves by this fraction).
    principal_point: Vec2,
    /// The camera's forward axis (camera z) in world space, unit length.
    axis: Vec3A,
    /// Mitsuba's `near_clip` and `far_clip`: depths along the axis between which camera rays
    /// see geometry.
    near_clip: f32,
    far_clip: f32,
}

impl PerspectiveCamera {
    pub fn new(to_world: Mat4, fov_degrees: f32, axis: FovAxis, width: u32, height: u32) -> Self {
        let (w, h) = (width as f32, height as f32);
        let t = (fov_degrees.to_radians() * 0.5).tan();
        // Express the given fov as the horizontal half-extent of the image plane at z = 1.
        let tan_x = match axis {
            FovAxis::X => t,
            FovAxis::Y => t * w / h,
            FovAxis::Diagonal => t * w / (w * w + h * h).sqrt(),
            FovAxis::Smaller => {
                if w <= h {
                    t
                } else {
                    t * w / h
                }
            }
            FovAxis::Larger => {
                if w >= h {
                    t
                } else {
                    t * w / h
                }
            }
        };
        let tan_half = Vec2::new(tan_x, tan_x * h / w);
        let origin = to_world.transform_point3(glam::Vec3::ZERO).into();
        Self {
            origin,
            to_world,
            tan_half,
            width,
            height,
            film_size: Vec2::new(w, h),
            pixel_spread: (2.0 * tan_half.y / h).atan(),
            principal_point: Vec2::ZERO,
            axis: to_world.transform_vector3a(Vec3A::Z).normalize(),
            near_clip: 0.0,
            far_clip: f32::INFINITY,
        }
    }

    /// tan of half the horizontal field of view (the image plane's half width at z = 1).
    pub fn tan_half_x(&self) -> f32 {
        self.tan_half.x
    }

    /// The camera with Mitsuba's `principal_point_offset_x/_y` (fractions of the film).
    pub fn with_principal_point(mut self, offset: Vec2) -> Self {
        self.principal_point = offset;
        self
    }

    /// The camera with Mitsuba's `near_clip` and `far_clip`.
    pub fn with_clip(mut self, near: f32, far: f32) -> Self {
        self.near_clip = near;
        self.far_clip = far;
        self
    }

    /// Distances along a ray of world direction `dir` (unit length, leaving the camera's
    /// origin or aperture) between which it sees geometry: Mitsuba starts the ray at depth
    /// `near_clip` along the camera's axis (t = near / cos) and ends it at depth `far_clip`.
    #[inline]
    pub fn clip_range(&self, dir: Vec3A) -> (f32, f32) {
        let inv_z = 1.0 / dir.dot(self.axis);
        (self.near_clip * inv_z, self.far_clip * inv_z)
    }

    pub fn width(&self) -> u32 {
        self.width
    }

    pub fn height(&self) -> u32 {
        self.height
    }

    /// Angle one pixel subtends at the image centre: the ray cone's initial spread.
    pub fn pixel_spread(&self) -> f32 {
        self.pixel_spread
    }

    /// The direction through film position `film` in camera space (on the z = 1 plane, not
    /// normalised), shared with [`super::ThinLensCamera`].
    #[inline(always)]
    pub(crate) fn local_direction(&self, film: Vec2) -> Vec3A {
        let sx = film.x / self.film_size.x + self.principal_point.x;
        let sy = film.y / self.film_size.y + self.principal_point.y;
        Vec3A::new(
            (1.0 - 2.0 * sx) * self.tan_half.x,
            (1.0 - 2.0 * sy) * self.tan_half.y,
            1.0,
        )
    }

    /// The camera-to-world transform.
    pub(crate) fn to_world(&self) -> Mat4 {
        self.to_world
    }

    /// The primary ray through film position `film` (in pixels, (0,0) = top-left corner).
    /// Returns the origin and the normalised world direction.
    #[inline]
    pub fn generate_ray(&self, film: Vec2) -> (Vec3A, Vec3A) {
        let local = self.local_direction(film);
        let dir = self.to_world.transform_vector3a(local).normalize();
        (self.origin, dir)
    }

    /// [`PerspectiveCamera::generate_ray`]'s directions for the film positions `films` (at
    /// most [`super::MAX_RAYS`]) into `dirs`, to the bit; returns the shared origin. In
    /// structure-of-arrays form (one array per component), so the divisions and square roots
    /// of a packet's rays run as whole vectors instead of one latency chain per ray: every lane
    /// does `generate_ray`'s IEEE operations in its order (glam's SSE `transform_vector3a`
    /// adds `x_axis * x + y_axis * y` then `z_axis * 1`, its dot `(x x + y y) + z z`, and
    /// `normalize` divides by the square root; Rust never fuses them).
    #[inline]
    pub fn generate_dirs(&self, films: &[Vec2], dirs: &mut [Vec3A]) -> Vec3A {
        const N: usize = super::MAX_RAYS;
        let n = films.len().min(dirs.len()).min(N);
        let (mut x, mut y) = ([0.0f32; N], [0.0f32; N]);
        for (k, f) in films[..n].iter().enumerate() {
            (x[k], y[k]) = (f.x, f.y);
        }
        let (c0, c1, c2) = (
            self.to_world.x_axis,
            self.to_world.y_axis,
            self.to_world.z_axis,
        );
        let (size, pp, tan) = (self.film_size, self.principal_point, self.tan_half);
        let (mut dx, mut dy, mut dz) = ([0.0f32; N], [0.0f32; N], [0.0f32; N]);
        for k in 0..N {
            let lx = (1.0 - 2.0 * (x[k] / size.x + pp.x)) * tan.x;
            let ly = (1.0 - 2.0 * (y[k] / size.y + pp.y)) * tan.y;
            // z_axis * 1.0 is z_axis exactly.
            let wx = (c0.x * lx + c1.x * ly) + c2.x;
            let wy = (c0.y * lx + c1.y * ly) + c2.y;
            let wz = (c0.z * lx + c1.z * ly) + c2.z;
            let len = ((wx * wx + wy * wy) + wz * wz).sqrt();
            (dx[k], dy[k], dz[k]) = (wx / len, wy / len, wz / len);
        }
        for (k, d) in dirs[..n].iter_mut().enumerate() {
            *d = Vec3A::new(dx[k], dy[k], dz[k]);
        }
        self.origin
    }

    /// The film position (pixels) a world direction from the camera origin projects to, if it is
    /// in front of the camera. Used by tests to check orientation.
    pub fn project(&self, dir_world: Vec3A) -> Option<Vec2> {
        let local = self.to_world.inverse().transform_vector3a(dir_world);
        if local.z <= 0.0 {
            return None;
        }
        let x = local.x / local.z / self.tan_half.x;
        let y = local.y / local.z / self.tan_half.y;
        Some(Vec2::new(
            ((1.0 - x) * 0.5 - self.principal_point.x) * self.width as f32,
            ((1.0 - y) * 0.5 - self.principal_point.y) * self.height as f32,
        ))
    }
}

/// Mitsuba's look-at frame: d = normalize(target - origin), left = normalize(cross(up, d)),
/// up' = cross(d, left); the camera-to-world matrix has columns (left, up', d, origin).
#[cfg(test)]
pub(crate) fn look_at(origin: Vec3A, target: Vec3A, up: Vec3A) -> Mat4 {
    let d = (target - origin).normalize();
    let left = up.cross(d).normalize();
    let new_up = d.cross(left);
    Mat4::from_cols(
        left.extend(0.0),
        new_up.extend(0.0),
        d.extend(0.0),
        origin.extend(1.0),
    )
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn world_x_is_on_the_right() {
        let cam = PerspectiveCamera::new(
            look_at(Vec3A::ZERO, -Vec3A::Z, Vec3A::Y),
            90.0,
            FovAxis::X,
            100,
            50,
        );
        let p = cam.project(Vec3A::new(0.5, 0.0, -1.0)).unwrap();
        assert!(p.x > 50.0, "world +x should land right of centre, got {p}");
        let p = cam.project(Vec3A::new(0.0, 0.2, -1.0)).unwrap();
        assert!(p.y < 25.0, "world +y should land above centre, got {p}");
    }

    #[test]
    fn fov_axes() {
        let m = look_at(Vec3A::ZERO, Vec3A::Z, Vec3A::Y);
        // fov 90 along x: the right edge of the film at x = width is 45 degrees off-axis.
        let cam = PerspectiveCamera::new(m, 90.0, FovAxis::X, 200, 100);
        let (_, d) = cam.generate_ray(Vec2::new(200.0, 50.0));
        assert!((d.x.abs() - d.z).abs() < 1e-6);
        // fov 90 along y: the top edge is 45 degrees off-axis.
        let cam = PerspectiveCamera::new(m, 90.0, FovAxis::Y, 200, 100);
        let (_, d) = cam.generate_ray(Vec2::new(100.0, 0.0));
        assert!((d.y - d.z).abs() < 1e-6);
        // smaller = y for a landscape film, larger = x.
        let a = PerspectiveCamera::new(m, 60.0, FovAxis::Smaller, 200, 100)
            .generate_ray(Vec2::new(100.0, 0.0))
            .1;
        let b = PerspectiveCamera::new(m, 60.0, FovAxis::Y, 200, 100)
            .generate_ray(Vec2::new(100.0, 0.0))
            .1;
        assert!((a - b).length() < 1e-6);
        let a = PerspectiveCamera::new(m, 60.0, FovAxis::Larger, 200, 100)
            .generate_ray(Vec2::new(0.0, 50.0))
            .1;
        let b = PerspectiveCamera::new(m, 60.0, FovAxis::X, 200, 100)
            .generate_ray(Vec2::new(0.0, 50.0))
            .1;
        assert!((a - b).length() < 1e-6);
        // diagonal: the corner ray is fov/2 off-axis.
        let cam = PerspectiveCamera::new(m, 90.0, FovAxis::Diagonal, 300, 400);
        let (_, d) = cam.generate_ray(Vec2::new(0.0, 0.0));
        assert!((d.z - (45f32).to_radians().cos()).abs() < 1e-5);
    }

    /// Mitsuba's principal point offset: the film position (x/w + ox, y/h + oy) gives the ray,
    /// so an offset of (0.25, -0.1) moves the ray through the image centre to the one that went
    /// through film fraction (0.75, 0.4); the clip range is near and far over the cosine to the
    /// axis.
    #[test]
    fn principal_point_and_clip_range() {
        let m = look_at(Vec3A::ZERO, Vec3A::Z, Vec3A::Y);
        let plain = PerspectiveCamera::new(m, 50.0, FovAxis::X, 64, 48);
        let shifted = plain
            .clone()
            .with_principal_point(Vec2::new(0.25, -0.1))
            .with_clip(0.5, 20.0);
        let (_, a) = shifted.generate_ray(Vec2::new(32.0, 24.0));
        let (_, b) = plain.generate_ray(Vec2::new(48.0, 19.2));
        assert!((a - b).length() < 1e-6, "{a} vs {b}");
        let p = shifted.project(a).unwrap();
        assert!((p - Vec2::new(32.0, 24.0)).length() < 1e-3, "{p}");
        let (near, far) = shifted.clip_range(a);
        let cos = a.dot(Vec3A::Z);
        assert!((near - 0.5 / cos).abs() < 1e-5 && (far - 20.0 / cos).abs() < 1e-3);
        assert_eq!(plain.clip_range(a), (0.0, f32::INFINITY));
    }

    /// A packet's directions are `generate_ray`'s, bit for bit: any packet size up to 16, film
    /// positions inside, on the edges of and far outside the film, principal point offsets and
    /// camera matrices with scales and shears (Mitsuba's `toWorld` may hold them).
    #[test]
    fn packet_directions_are_those_of_single_rays() {
        let mut rng = torrey_testkit::Rng::new(11);
        let frames = [
            look_at(Vec3A::ZERO, -Vec3A::Z, Vec3A::Y),
            look_at(
                Vec3A::new(1.0, 2.0, 3.0),
                Vec3A::new(-1.0, 0.5, 0.0),
                Vec3A::new(0.1, 1.0, 0.0),
            ),
            Mat4::from_cols_array(&[
                1.7, 0.2, -0.3, 0.0, 0.1, -2.5, 0.4, 0.0, 0.3, 0.6, 1.1, 0.0, 4.0, -1.0, 2.0, 1.0,
            ]),
        ];
        let edges = [
            Vec2::ZERO,
            Vec2::new(64.0, 48.0),
            Vec2::new(0.5, 47.999_996),
            Vec2::new(-1e30, 3.0),
            Vec2::new(1e-40, -0.0),
            Vec2::new(1e7, -1e7),
        ];
        for (f, frame) in frames.iter().enumerate() {
            for pp in [Vec2::ZERO, Vec2::new(0.25, -0.1)] {
                let cam =
                    PerspectiveCamera::new(*frame, 39.3 + 20.0 * f as f32, FovAxis::Y, 64, 48)
                        .with_principal_point(pp);
                for n in 1..=super::super::MAX_RAYS {
                    let films: Vec<Vec2> = (0..n)
                        .map(|k| match k % 3 {
                            0 => edges[(k / 3 + n) % edges.len()],
                            _ => Vec2::new(rng.range(-2.0, 66.0), rng.range(-2.0, 50.0)),
                        })
                        .collect();
                    let mut dirs = [Vec3A::NAN; super::super::MAX_RAYS];
                    let origin = cam.generate_dirs(&films, &mut dirs[..n]);
                    for (k, &film) in films.iter().enumerate() {
                        let (o, d) = cam.generate_ray(film);
                        assert_eq!(
                            origin.to_array().map(f32::to_bits),
                            o.to_array().map(f32::to_bits)
                        );
                        assert_eq!(
                            dirs[k].to_array().map(f32::to_bits),
                            d.to_array().map(f32::to_bits),
                            "frame {f} pp {pp} lane {k} of {n} film {film}"
                        );
                    }
                    assert!(
                        dirs[n..].iter().all(|d| d.is_nan()),
                        "wrote past the packet"
                    );
                }
            }
        }
    }

    #[test]
    fn generate_and_project_round_trip() {
        let m = look_at(
            Vec3A::new(1.0, 2.0, 3.0),
            Vec3A::new(-1.0, 0.5, 0.0),
            Vec3A::new(0.1, 1.0, 0.0),
        );
        let cam = PerspectiveCamera::new(m, 39.3, FovAxis::Y, 64, 48);
        for &(x, y) in &[(0.5, 0.5), (10.25, 40.0), (63.0, 1.0)] {
            let (_, d) = cam.generate_ray(Vec2::new(x, y));
            let p = cam.project(d).unwrap();
            assert!((p - Vec2::new(x, y)).length() < 1e-3);
        }
    }
}
