//! Participating media: the scene's media ([`Medium`]: extinction, albedo, phase function),
//! which medium each side of a shape holds, and which the camera sits in ([`Media`]).
//!
//! As in Mitsuba, a ray knows its medium. Crossing a shape that declares an interior or an
//! exterior medium, it enters the medium on the side its direction points to (the exterior
//! along the geometric normal, the interior against it; an undeclared side is vacuum); crossing
//! a shape that declares neither keeps the ray's medium (a glass sphere inside fog).

// Comparisons are written `!(x > 0.0)` on purpose: they also reject NaN.
#![allow(clippy::neg_cmp_op_on_partial_ord)]

mod grid;
mod medium;
pub mod phase;
mod tracking;
mod walk;

pub use medium::{Flight, Medium};

use glam::Vec3A;
use torrey_parser as desc;

/// The scene's media and where they are.
#[derive(Clone, Debug, Default)]
pub struct Media {
    pub list: Vec<Medium>,
    /// Per shape (the renderer's shape index: the world's shapes, then the groups'), its
    /// interior and exterior media; empty when no shape declares one.
    sides: Vec<[Option<u32>; 2]>,
    /// The medium the camera sits in.
    pub camera: Option<u32>,
    /// Some material may let light straight through (`null`, `thindielectric`, `mask`): shadow
    /// rays of the volumetric path tracer must look at what they hit.
    pub passable: bool,
}

impl Media {
    /// The media of `scene`; `passable`: whether any of its materials may let light straight
    /// through. A scene with media and an integrator that ignores them gets a warning.
    pub fn build(scene: &desc::Scene, passable: bool, warnings: &mut Vec<String>) -> Self {
        let groups = scene.shape_groups.iter().flat_map(|g| &g.shapes);
        let sides: Vec<[Option<u32>; 2]> = scene
            .shapes
            .iter()
            .chain(groups)
            .map(|s| [s.interior.map(|m| m as u32), s.exterior.map(|m| m as u32)])
            .collect();
        let any = sides.iter().any(|s| s[0].is_some() || s[1].is_some());
        let volumetric = matches!(scene.integrator.kind, desc::IntegratorKind::VolPath { .. });
        if (any || scene.camera.medium.is_some()) && !volumetric {
            warnings.push(format!(
                "integrator '{}' renders the scene's media as vacuum, as Mitsuba's does: use 'volpath' or 'volpathmis'",
                scene.integrator.type_name
            ));
        }
        Media {
            list: scene.media.iter().map(Medium::from_desc).collect(),
            sides: if any { sides } else { Vec::new() },
            camera: scene.camera.medium.map(|m| m as u32),
            passable,
        }
    }

    /// The medium of a ray that leaves a hit on `shape` (geometric normal `ng`) along `dir`,
    /// having arrived in `current`.
    #[inline]
    pub fn after_crossing(
        &self,
        current: Option<u32>,
        shape: u32,
        ng: Vec3A,
        dir: Vec3A,
    ) -> Option<u32> {
        match self.sides.get(shape as usize) {
            Some(&[None, None]) | None => current,
            Some(&[interior, exterior]) => {
                if dir.dot(ng) > 0.0 {
                    exterior
                } else {
                    interior
                }
            }
        }
    }
}
