//! Shapes, shape groups and instances, and their geometry.

use super::{BsdfId, SourceLocation, TextureId};
use glam::{Mat4, Vec2, Vec3};

#[derive(Clone, Debug, PartialEq)]
pub struct Shape {
    pub geometry: Geometry,
    /// Object to world.
    pub to_world: Mat4,
    /// `None` means Mitsuba's default: a diffuse bsdf with reflectance 0.5.
    pub bsdf: Option<BsdfId>,
    /// Area emitter radiance, if the shape is an area light (one-sided, along the normal).
    /// With [`Shape::emitter_texture`] it is 1 and the texture gives the radiance.
    pub emitter: Option<Vec3>,
    /// Mitsuba's textured `radiance` of an area emitter: the texture, evaluated at the surface's
    /// uv, is the emitted radiance.
    pub emitter_texture: Option<TextureId>,
    pub flip_normals: bool,
    /// The media inside (against the geometric normal) and outside the surface; None: the
    /// crossing keeps the ray's medium when neither is given, else vacuum on that side.
    pub interior: Option<crate::media::MediumId>,
    pub exterior: Option<crate::media::MediumId>,
    /// Where the shape was declared, for renderer-side diagnostics.
    pub location: SourceLocation,
}

/// Mitsuba's `shapegroup`: shapes (no emitters, groups or instances) stored once and drawn only
/// where an [`Instance`] places them.
#[derive(Clone, Debug, PartialEq)]
pub struct ShapeGroup {
    pub id: String,
    /// Each shape's `to_world` maps it into the group's space.
    pub shapes: Vec<Shape>,
    pub location: SourceLocation,
}

/// Mitsuba's `instance`: shape group [`Instance::group`] (an index into [`Scene::shape_groups`](super::Scene::shape_groups))
/// placed by `to_world` (invertible).
#[derive(Clone, Debug, PartialEq)]
pub struct Instance {
    pub group: usize,
    pub to_world: Mat4,
    pub location: SourceLocation,
}

#[derive(Clone, Debug, PartialEq)]
pub enum Geometry {
    Mesh(TriangleMesh),
    /// Mitsuba sphere: `center` and `radius` in object space (then `to_world`); pole axis +z.
    Sphere {
        center: Vec3,
        radius: f32,
    },
    /// Mitsuba rectangle: [-1,1]^2 in the z = 0 plane, normal +z, uv = ((x+1)/2, (y+1)/2).
    Rectangle,
    /// Mitsuba disk: the unit disk in the z = 0 plane, normal +z, uv = (radius, angle / 2π).
    Disk,
    /// Mitsuba cylinder: the open tube of `radius` from `p0` to `p1` (object space, then
    /// `to_world`), uv = (angle / 2π, height fraction).
    Cylinder {
        p0: Vec3,
        p1: Vec3,
        radius: f32,
    },
    /// Mitsuba's `sdfgrid`: the zero set of the trilinear interpolant of a signed distance
    /// function sampled on a grid that spans [0, 1]^3 in object space (then `to_world`).
    SdfGrid(std::sync::Arc<SdfGrid>),
}

/// The samples of an `sdfgrid` (Mitsuba 3.9.1's conventions). Sample (i, j, k) sits at
/// (i / (nx − 1), j / (ny − 1), k / (nz − 1)) of the unit cube, whatever bounding box the
/// `.vol` file declares; the values between samples are the trilinear interpolant; the surface
/// is where it is zero, and its normal points where the values grow.
#[derive(Clone, Debug, PartialEq)]
pub struct SdfGrid {
    /// Samples along x, y, z: at least 2 each.
    pub size: [u32; 3],
    /// nx · ny · nz finite values, x fastest, then y, then z.
    pub values: Vec<f32>,
    /// Mitsuba's `normals`: `smooth` (true, the default) blends the gradients of the voxels
    /// around the hit (Hansson-Söderlund et al. 2022); `analytic` is the gradient of the
    /// interpolant, continuous within a voxel only.
    pub smooth_normals: bool,
    /// Voxels whose corner samples are not all of one sign (some ≥ 0 and some ≤ 0): those that
    /// can hold surface; at least one.
    pub surface_voxels: u64,
}

impl SdfGrid {
    /// The value of sample (i, j, k).
    #[inline]
    pub fn value(&self, i: u32, j: u32, k: u32) -> f32 {
        let [nx, ny, _] = self.size;
        self.values[(k as usize * ny as usize + j as usize) * nx as usize + i as usize]
    }

    /// The eight corner samples of voxel (i, j, k), corner c at (i + (c & 1), j + (c >> 1 & 1),
    /// k + (c >> 2)).
    #[inline]
    pub fn corners(&self, i: u32, j: u32, k: u32) -> [f32; 8] {
        std::array::from_fn(|c| {
            let c = c as u32;
            self.value(i + (c & 1), j + (c >> 1 & 1), k + (c >> 2))
        })
    }

    /// Whether voxel (i, j, k) can hold surface: its corners are not all > 0 nor all < 0.
    #[inline]
    pub fn voxel_has_surface(&self, i: u32, j: u32, k: u32) -> bool {
        let f = self.corners(i, j, k);
        f.iter().any(|&v| v >= 0.0) && f.iter().any(|&v| v <= 0.0)
    }
}

/// A triangle mesh in object space. Texture coordinates are already in Mitsuba's convention
/// (OBJ v flipped on load). `normals` is empty when the shape asked for face normals;
/// otherwise it holds the file's normals or, when the file has none, angle-weighted smooth ones (as Mitsuba).
#[derive(Clone, Debug, PartialEq, Default)]
pub struct TriangleMesh {
    pub positions: Vec<Vec3>,
    pub normals: Vec<Vec3>,
    pub uvs: Vec<Vec2>,
    pub indices: Vec<[u32; 3]>,
    /// Named per-vertex and per-face attributes (from PLY files), for `mesh_attribute`.
    pub attributes: Vec<MeshAttribute>,
}

/// A mesh attribute as Mitsuba names it: `vertex_<name>` (one tuple per vertex) or
/// `face_<name>` (one per triangle; a polygon's triangles share its tuple).
#[derive(Clone, Debug, PartialEq)]
pub struct MeshAttribute {
    pub name: String,
    /// 1 or 3 values per vertex or triangle.
    pub channels: usize,
    pub values: Vec<f32>,
}

impl MeshAttribute {
    pub fn per_face(&self) -> bool {
        self.name.starts_with("face_")
    }
}
