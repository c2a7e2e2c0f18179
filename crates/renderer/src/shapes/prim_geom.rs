//! The geometry of one BVH primitive, as each shape hands it to the acceleration structure
//! (which intersects it in its leaves): the shapes define their primitives, the BVH reads them.

use super::object_rows::ObjectRows;
use glam::Vec3A;

/// Geometry of one BVH primitive, in world space.
#[derive(Clone, Copy, Debug)]
pub enum PrimGeom {
    Triangle {
        p0: Vec3A,
        p1: Vec3A,
        p2: Vec3A,
    },
    Sphere {
        center: Vec3A,
        radius: f32,
    },
    /// Mitsuba's disk: the unit disk at z = 0 of the object space `to_object` maps to.
    Disk {
        to_object: ObjectRows,
    },
    /// Mitsuba's cylinder: the open unit tube, 0 <= z <= 1, of that object space.
    Cylinder {
        to_object: ObjectRows,
    },
    /// A voxel of an `sdfgrid` with surface in it: the box of that surface and the voxel's
    /// record in the table the BVH is built with ([`crate::accel::Accel::build_with`]), which
    /// holds its samples and placement.
    SdfVoxel {
        min: Vec3A,
        max: Vec3A,
        index: u32,
    },
}
