//! The sensor: camera, film, pixel filter and sampler.

use glam::{Mat4, Vec2};

/// The camera, Mitsuba 3 semantics: camera space looks along +z, +x is left, +y is up;
/// `to_world` maps camera space to world space.
#[derive(Clone, Debug, PartialEq)]
pub struct Camera {
    /// Projection: perspective pinhole, thin lens or orthographic.
    pub kind: CameraKind,
    pub to_world: Mat4,
    /// Full field of view in degrees along `fov_axis` (perspective and thin lens).
    pub fov_degrees: f32,
    pub fov_axis: FovAxis,
    pub near_clip: f32,
    pub far_clip: f32,
    /// Mitsuba's `principal_point_offset_x/_y`: the image centre moved by these fractions of the
    /// film size (perspective and thin lens).
    pub principal_point_offset: Vec2,
    /// The medium the camera sits in (a `<medium>` or medium `<ref>` in the sensor).
    pub medium: Option<crate::media::MediumId>,
}

#[derive(Clone, Copy, Debug, PartialEq)]
pub enum CameraKind {
    Perspective,
    /// Depth of field: a lens of `aperture_radius` focused at `focus_distance`.
    ThinLens {
        aperture_radius: f32,
        focus_distance: f32,
    },
    /// Parallel rays; `to_world`'s scale sets the visible extent (Mitsuba: [-1, 1]^2 before it).
    Orthographic,
}

#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum FovAxis {
    X,
    Y,
    Diagonal,
    Smaller,
    Larger,
}

#[derive(Clone, Debug, PartialEq)]
pub struct Film {
    pub width: u32,
    pub height: u32,
    /// Output file name from the scene, if it names one.
    pub filename: Option<String>,
    pub filter: PixelFilter,
    /// Mitsuba's crop window: only this part of the `width` x `height` film is rendered.
    pub crop: Option<CropWindow>,
}

/// A sub-rectangle of the film in pixels (`crop_offset_x/y`, `crop_width/height`).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct CropWindow {
    pub offset_x: u32,
    pub offset_y: u32,
    pub width: u32,
    pub height: u32,
}

impl CropWindow {
    /// `(offset x, offset y, width, height)`.
    pub fn rect(&self) -> (u32, u32, u32, u32) {
        (self.offset_x, self.offset_y, self.width, self.height)
    }
}

#[derive(Clone, Copy, Debug, PartialEq)]
pub enum PixelFilter {
    /// One pixel wide box: torrey's default and the references'.
    Box,
    /// Mitsuba's gaussian (stddev in pixels; Mitsuba's default 0.5).
    Gaussian { stddev: f32 },
    /// Mitsuba's tent filter (radius in pixels).
    Tent { radius: f32 },
    /// Mitchell-Netravali with parameters B and C (Mitsuba's defaults 1/3, 1/3), radius 2.
    Mitchell { b: f32, c: f32 },
    /// Catmull-Rom: Mitchell-Netravali with B = 0, C = 1/2, radius 2.
    CatmullRom,
    /// Windowed sinc with `lobes` lobes (Mitsuba's default 3); radius = lobes.
    Lanczos { lobes: u32 },
}

#[derive(Clone, Debug, PartialEq)]
pub struct Sampler {
    /// Mitsuba's sample count after its sampler's rounding (a square for `stratified` and
    /// `multijitter`, a power of two for `ldsampler`, a prime's square for `orthogonal`).
    pub sample_count: u32,
    pub seed: u64,
    /// The scene's sampler type; torrey draws its own samples whatever it is.
    pub kind: String,
}
