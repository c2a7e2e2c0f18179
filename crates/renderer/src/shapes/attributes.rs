//! Mesh attributes (PLY `vertex_*` and `face_*` properties) kept for `mesh_attribute`
//! textures: each shape's values, and their evaluation at a triangle hit (vertex attributes
//! interpolated with the hit's barycentrics, face attributes constant per triangle).

use super::PrimInfo;
use glam::{Vec2, Vec3A};

/// One attribute of one shape.
pub struct AttributeData {
    pub name: String,
    pub shape: u32,
    /// 1 or 3.
    pub channels: u32,
    pub per_face: bool,
    /// The shape's first vertex in [`super::mesh::MeshData`] (vertex attributes) or its first
    /// primitive (face attributes): values are indexed relative to it.
    pub offset: u32,
    /// `channels` values per vertex, or per kept triangle.
    pub values: Vec<f32>,
}

/// Every attribute of every shape.
#[derive(Default)]
pub struct MeshAttributes {
    pub list: Vec<AttributeData>,
}

/// Where a texture is evaluated, for `mesh_attribute`: the hit's shape, primitive and
/// barycentrics, and the scene's attribute data.
#[derive(Clone, Copy)]
pub struct AttributePoint<'a> {
    pub attributes: &'a MeshAttributes,
    pub prims: &'a [PrimInfo],
    pub shape: u32,
    pub prim: u32,
    pub bary: Vec2,
}

impl MeshAttributes {
    /// The index of shape `shape`'s attribute `name`, if it has one.
    pub fn find(&self, shape: u32, name: &str) -> Option<u32> {
        self.list
            .iter()
            .position(|a| a.shape == shape && a.name == name)
            .map(|i| i as u32)
    }
}

impl AttributeData {
    #[inline]
    fn tuple(&self, i: usize) -> Vec3A {
        if self.channels == 1 {
            Vec3A::splat(self.values.get(i).copied().unwrap_or(0.0))
        } else {
            match self.values.get(3 * i..3 * i + 3) {
                Some(v) => Vec3A::new(v[0], v[1], v[2]),
                None => Vec3A::ZERO,
            }
        }
    }

    /// The value at `at` (a hit on this attribute's shape); one channel is returned as grey.
    pub fn eval(&self, at: &AttributePoint) -> Vec3A {
        if self.per_face {
            return self.tuple(at.prim.wrapping_sub(self.offset) as usize);
        }
        let [i0, i1, i2] = at.prims[at.prim as usize].indices;
        let local = |i: u32| i.wrapping_sub(self.offset) as usize;
        let (b1, b2) = (at.bary.x, at.bary.y);
        (1.0 - b1 - b2) * self.tuple(local(i0))
            + b1 * self.tuple(local(i1))
            + b2 * self.tuple(local(i2))
    }
}
