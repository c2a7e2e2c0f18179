//! The scene's shapes from their descriptions: their geometry, their primitives for the BVH
//! (the world's, and each shape group's in its own space), mesh attributes that textures read,
//! and the area lights of emitting shapes.

use super::build::BuildError;
use crate::lights::{AreaEmitter, AreaLight, EmissionTexture, Light};
use crate::shapes::attributes::{AttributeData, MeshAttributes};
use crate::shapes::cylinder::Cylinder;
use crate::shapes::disk::Disk;
use crate::shapes::mesh::{MeshData, MeshEmitter, MeshShape};
use crate::shapes::sdfgrid::{SdfGridData, SdfGridShape};
use crate::shapes::sphere::Sphere;
use crate::shapes::{PrimGeom, PrimInfo, Shape, ShapeKind};
use glam::Vec3A;
use torrey_parser as desc;

/// The shapes of a scene and what was built with them.
pub(super) struct ShapeSet {
    pub mesh: MeshData,
    pub prims: Vec<PrimInfo>,
    pub shapes: Vec<Shape>,
    /// The world's primitives, for its BVH.
    pub world_geoms: Vec<PrimGeom>,
    /// Each shape group's primitives (in the group's space) and the first of its records in
    /// `prims` (group primitive i is record first + i).
    pub group_geoms: Vec<Vec<PrimGeom>>,
    pub group_first_prim: Vec<u32>,
    pub attributes: MeshAttributes,
    /// The area lights whose radiance is a texture: their [`EmissionTexture`]'s sampling is
    /// filled in once the textures are built (they are built beside the shapes).
    pub textured_emitters: Vec<TexturedEmitter>,
}

/// An area light with a textured radiance, and the shape and primitives it emits from.
pub(super) struct TexturedEmitter {
    pub light: usize,
    pub shape: usize,
    pub prims: std::ops::Range<usize>,
}

/// Builds every shape of `scene` (the world's, then each shape group's), appending the area
/// lights of emitting shapes to `lights`; shapes without a bsdf get `default_material`. Needs no
/// texture: a textured emitter's sampling is left to be filled in (`textured_emitters`).
pub(super) fn build_shapes(
    scene: &desc::Scene,
    default_material: u32,
    lights: &mut Vec<Light>,
    warnings: &mut Vec<String>,
) -> Result<ShapeSet, BuildError> {
    let mut mesh = MeshData::default();
    let mut world_geoms = Vec::new();
    let mut prims = Vec::new();
    let mut shapes = Vec::new();
    let mut dropped = 0usize;
    let mut dropped_analytic = 0usize;
    let mut dropped_sdf = 0usize;
    // Attributes are kept only when a mesh_attribute texture may read them.
    let attribute_names: Vec<&str> = scene
        .textures
        .iter()
        .filter_map(|t| match &t.kind {
            desc::TextureKind::MeshAttribute { name, .. } => Some(name.as_str()),
            _ => None,
        })
        .collect();
    let mut attributes = MeshAttributes::default();
    let mut textured_emitters = Vec::new();
    // The world's shapes, then each shape group's (in the group's space): a group's
    // primitives get their own list (its BVH's) and contiguous records in `prims` from
    // `group_first_prim`, so that group primitive i is record group_first_prim + i.
    let mut group_geoms = vec![Vec::new(); scene.shape_groups.len()];
    let mut group_first_prim = vec![0u32; scene.shape_groups.len()];
    let group_shapes = scene
        .shape_groups
        .iter()
        .enumerate()
        .flat_map(|(g, group)| group.shapes.iter().map(move |s| (Some(g), s)));
    let all_shapes = scene.shapes.iter().map(|s| (None, s)).chain(group_shapes);
    for (shape_index, (group, shape)) in all_shapes.enumerate() {
        let shape_id = shape_index as u32;
        let first_prim = prims.len();
        let geoms: &mut Vec<PrimGeom> = match group {
            Some(g) => {
                if group_geoms[g].is_empty() {
                    group_first_prim[g] = first_prim as u32;
                }
                &mut group_geoms[g]
            }
            None => &mut world_geoms,
        };
        let kind = match &shape.geometry {
            desc::Geometry::Mesh(m) => {
                let base = mesh.positions.len() as u32;
                let kind =
                    MeshShape::add(&mut mesh, geoms, &mut prims, shape_id, m, shape.to_world);
                for a in &m.attributes {
                    if !attribute_names.contains(&a.name.as_str()) {
                        continue;
                    }
                    let per_face = a.per_face();
                    let values = if per_face {
                        // One tuple per kept triangle, in primitive order.
                        m.indices
                            .iter()
                            .enumerate()
                            .filter(|(_, t)| mesh.keeps_triangle(t.map(|i| i + base)))
                            .flat_map(|(f, _)| {
                                a.values[f * a.channels..(f + 1) * a.channels].iter()
                            })
                            .copied()
                            .collect()
                    } else {
                        a.values.clone()
                    };
                    attributes.list.push(AttributeData {
                        name: a.name.clone(),
                        shape: shape_id,
                        channels: a.channels as u32,
                        per_face,
                        offset: if per_face { first_prim as u32 } else { base },
                        values,
                    });
                }
                ShapeKind::Mesh(kind)
            }
            desc::Geometry::Rectangle => ShapeKind::Mesh(MeshShape::add(
                &mut mesh,
                geoms,
                &mut prims,
                shape_id,
                &MeshShape::rectangle(),
                shape.to_world,
            )),
            desc::Geometry::Sphere { center, radius } => {
                let sphere = Sphere::new(*center, *radius, shape.to_world);
                if sphere.prim_geom().is_finite() && sphere.radius > 0.0 {
                    geoms.push(sphere.prim_geom());
                    prims.push(PrimInfo {
                        ng: Vec3A::ZERO,
                        indices: [0; 3],
                        shape: shape_id,
                    });
                } else {
                    dropped += 1;
                }
                ShapeKind::Sphere(sphere)
            }
            desc::Geometry::Disk => {
                match Disk::new(shape.to_world).filter(|d| d.prim_geom().is_finite()) {
                    Some(disk) => {
                        geoms.push(disk.prim_geom());
                        prims.push(PrimInfo {
                            ng: Vec3A::ZERO,
                            indices: [0; 3],
                            shape: shape_id,
                        });
                        ShapeKind::Disk(disk)
                    }
                    None => {
                        dropped_analytic += 1;
                        ShapeKind::Mesh(MeshShape::EMPTY)
                    }
                }
            }
            desc::Geometry::Cylinder { p0, p1, radius } => {
                match Cylinder::new(*p0, *p1, *radius, shape.to_world)
                    .filter(|c| c.prim_geom().is_finite())
                {
                    Some(cylinder) => {
                        geoms.push(cylinder.prim_geom());
                        prims.push(PrimInfo {
                            ng: Vec3A::ZERO,
                            indices: [0; 3],
                            shape: shape_id,
                        });
                        ShapeKind::Cylinder(cylinder)
                    }
                    None => {
                        dropped_analytic += 1;
                        ShapeKind::Mesh(MeshShape::EMPTY)
                    }
                }
            }
            desc::Geometry::SdfGrid(grid) => match SdfGridData::new(grid.clone(), shape.to_world) {
                Some(data) => {
                    let voxels = data.primitives(&mut mesh.sdf_voxels, &mut mesh.sdf_cells);
                    for geom in voxels {
                        if let PrimGeom::SdfVoxel { index, .. } = geom {
                            if geom.is_finite() {
                                geoms.push(geom);
                                prims.push(PrimInfo {
                                    ng: Vec3A::ZERO,
                                    indices: [index, 0, 0],
                                    shape: shape_id,
                                });
                            }
                        }
                    }
                    mesh.sdf_grids.push(data);
                    ShapeKind::SdfGrid(SdfGridShape {
                        grid: mesh.sdf_grids.len() as u32 - 1,
                    })
                }
                None => {
                    dropped_sdf += 1;
                    ShapeKind::Mesh(MeshShape::EMPTY)
                }
            },
        };
        let shape_prims = &prims[first_prim..];
        let area_light = match shape.emitter {
            // Shapes in groups do not emit (the parser refuses them, as Mitsuba does).
            // An sdfgrid cannot emit (the parser refuses it, as Mitsuba cannot sample it).
            Some(radiance)
                if radiance.max_element() > 0.0
                    && !shape_prims.is_empty()
                    && group.is_none()
                    && !matches!(kind, ShapeKind::SdfGrid(_)) =>
            {
                let textured = shape.emitter_texture.is_some();
                let emitter = match kind {
                    ShapeKind::Sphere(sphere) => AreaEmitter::Sphere(sphere),
                    ShapeKind::Mesh(_) if textured => {
                        AreaEmitter::Mesh(MeshEmitter::with_uvs(&mesh, shape_prims))
                    }
                    ShapeKind::Disk(disk) => AreaEmitter::Disk(Box::new(disk)),
                    ShapeKind::Cylinder(cylinder) => AreaEmitter::Cylinder(Box::new(cylinder)),
                    ShapeKind::Mesh(_) | ShapeKind::SdfGrid(_) => {
                        AreaEmitter::Mesh(MeshEmitter::new(&mesh, shape_prims))
                    }
                };
                let texture = shape.emitter_texture.map(|t| {
                    textured_emitters.push(TexturedEmitter {
                        light: lights.len(),
                        shape: shape_index,
                        prims: first_prim..prims.len(),
                    });
                    EmissionTexture {
                        texture: t as u32,
                        sampling: None,
                    }
                });
                lights.push(Light::Area(AreaLight {
                    radiance: radiance.into(),
                    texture,
                    emitter,
                    flip_normals: shape.flip_normals,
                }));
                Some(lights.len() as u32 - 1)
            }
            _ => None,
        };
        shapes.push(Shape {
            kind,
            material: shape.bsdf.map_or(default_material, |b| b as u32),
            area_light,
            textured_emission: area_light.is_some() && shape.emitter_texture.is_some(),
            flip_normals: shape.flip_normals,
        });
    }
    if dropped_sdf > 0 {
        warnings.push(format!(
            "{dropped_sdf} sdfgrid(s) with a degenerate or non-finite transform were left out"
        ));
    }
    if dropped_analytic > 0 {
        warnings.push(format!(
            "{dropped_analytic} disk(s) or cylinder(s) with a degenerate or non-finite \
             transform (a zero scale or radius, p0 = p1) were left out"
        ));
    }
    if dropped > 0 {
        warnings.push(format!(
            "{dropped} sphere(s) with a zero or non-finite size or position after their \
             transform were left out"
        ));
    }
    Ok(ShapeSet {
        mesh,
        prims,
        shapes,
        world_geoms,
        group_geoms,
        group_first_prim,
        attributes,
        textured_emitters,
    })
}
