//! The plain description of participating media (Mitsuba 3's `<medium>`, `<phase>` and
//! `<volume>` plugins): parsed by `plugins/medium.rs`, rendered by the renderer's `media`.

use glam::{Mat4, Vec3};
use std::sync::Arc;

/// Index into [`crate::Scene::media`].
pub type MediumId = usize;

/// A participating medium: extinction and albedo (each a volume), a phase function.
#[derive(Clone, Debug, PartialEq)]
pub struct Medium {
    pub id: Option<String>,
    /// `homogeneous`: the extinction is read once (a constant); `heterogeneous`: it varies in
    /// space and is tracked against a majorant.
    pub homogeneous: bool,
    /// Extinction per unit length before `scale`.
    pub sigma_t: Volume,
    /// Single-scattering albedo σs / σt, in [0, 1].
    pub albedo: Volume,
    /// Multiplies `sigma_t`.
    pub scale: f32,
    pub phase: Phase,
    /// Next-event estimation at scattering events in this medium (Mitsuba's
    /// `sample_emitters`); false: light is found by phase-function sampling alone.
    pub sample_emitters: bool,
}

/// Mitsuba's volume plugins: a value at every point of space.
#[derive(Clone, Debug, PartialEq)]
pub enum Volume {
    /// `constvolume` (or a plain float / rgb / spectrum value).
    Constant(Vec3),
    /// `gridvolume`.
    Grid(Arc<GridVolume>),
}

/// Mitsuba's `gridvolume`: samples on a regular grid spanning the unit cube of its local space.
#[derive(Clone, Debug, PartialEq)]
pub struct GridVolume {
    /// Samples along x, y, z.
    pub size: [u32; 3],
    /// 1 or 3.
    pub channels: u32,
    /// `size[0] · size[1] · size[2] · channels` values, x fastest, then y, then z, a sample's
    /// channels together; finite and not negative (negative values are clamped to 0 with a
    /// warning when read).
    pub data: Vec<f32>,
    /// World to the grid's unit cube ([0, 1]^3): the inverse of `to_world`, after the file's
    /// bounding box with `use_grid_bbox`.
    pub to_local: Mat4,
    /// `filter_type`: trilinear (false) or nearest (true).
    pub nearest: bool,
    /// The largest value (every channel), or `max_value` when given: what a majorant is built on.
    pub max: f32,
}

/// Mitsuba's phase functions.
#[derive(Clone, Debug, PartialEq)]
pub enum Phase {
    Isotropic,
    /// Henyey-Greenstein with mean cosine `g` in (-1, 1): positive scatters forward.
    Hg(f32),
    Rayleigh,
    /// `blendphase`: (1 - weight) · first + weight · second.
    Blend(f32, Box<Phase>, Box<Phase>),
}
