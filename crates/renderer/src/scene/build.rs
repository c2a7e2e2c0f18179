//! Building a [`RenderScene`] from the parser's description: each concept by its own
//! constructor (camera, textures, materials, shapes, lights), then the BVH over every primitive.

use super::{Material, RenderScene};
use crate::accel::instances::{GroupAccel, Instances};
use crate::accel::{Accel, BvhWidth, PrimGeom};
use crate::bsdfs::{BsdfParams, DiffuseParams};
use crate::cameras::{Camera, OrthographicCamera, PerspectiveCamera, ThinLensCamera};
use crate::lights::{
    AreaEmitter, AreaLight, ConstantLight, DirectionalLight, EmissionTexture, EnvLight, Light,
    PointLight, ProjectorLight, SpotLight, TexelDistribution, UvMap,
};
use crate::shapes::mesh::{MeshData, MeshEmitter, MeshShape};
use crate::shapes::sphere::Sphere;
use crate::shapes::{PrimInfo, Shape, ShapeKind};
use crate::textures::{ColorSource, Texture};
use glam::{Mat3, Mat4, Vec3A};
use torrey_light::EnvMap;
use torrey_parser as desc;
use torrey_texture::{BitmapTexture, MipMap};

/// Why a parsed scene could not be prepared for rendering (texture files that do not decode, a
/// camera that cannot form an image, say).
#[derive(Debug, thiserror::Error)]
pub enum BuildError {
    #[error("{location}: error: {message}")]
    Texture { location: String, message: String },
    #[error("{0}")]
    Other(String),
}

impl RenderScene {
    /// Prepares `scene` for a `width` x `height` film.
    pub fn build(scene: &desc::Scene, width: u32, height: u32) -> Result<Self, BuildError> {
        Self::build_with_width(scene, width, height, BvhWidth::Auto)
    }

    /// [`RenderScene::build`] with a chosen BVH node width (for comparing them; the images are
    /// the same up to which of two triangles at exactly equal distance is reported).
    pub fn build_with_width(
        scene: &desc::Scene,
        width: u32,
        height: u32,
        bvh_width: BvhWidth,
    ) -> Result<Self, BuildError> {
        let camera = build_camera(&scene.camera, width, height)?;
        let mut warnings = Vec::new();
        let textures = scene
            .textures
            .iter()
            .map(|t| build_texture(t, &mut warnings))
            .collect::<Result<Vec<_>, _>>()?;
        let torrey_dialect = scene.dialect == desc::Dialect::Torrey;
        let mut materials: Vec<Material> = scene
            .bsdfs
            .iter()
            .map(|b| Material::from_desc(b, torrey_dialect))
            .collect();
        // Shapes without a bsdf get Mitsuba's default: diffuse, reflectance 0.5.
        let default_material = materials.len() as u32;
        materials.push(Material::new(
            BsdfParams::Diffuse(DiffuseParams {
                reflectance: ColorSource::Constant(Vec3A::splat(0.5)),
            }),
            None,
            torrey_dialect,
            None,
            false,
        ));

        let mut mesh = MeshData::default();
        let mut world_geoms = Vec::new();
        let mut prims = Vec::new();
        let mut shapes = Vec::new();
        let mut lights = Vec::new();
        let mut dropped = 0usize;
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
                desc::Geometry::Mesh(m) => ShapeKind::Mesh(MeshShape::add(
                    &mut mesh,
                    geoms,
                    &mut prims,
                    shape_id,
                    m,
                    shape.to_world,
                )),
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
            };
            let shape_prims = &prims[first_prim..];
            let area_light = match shape.emitter {
                // Shapes in groups do not emit (the parser refuses them, as Mitsuba does).
                Some(radiance)
                    if radiance.max_element() > 0.0
                        && !shape_prims.is_empty()
                        && group.is_none() =>
                {
                    let textured = shape.emitter_texture.is_some();
                    let emitter = match kind {
                        ShapeKind::Sphere(sphere) => AreaEmitter::Sphere(sphere),
                        ShapeKind::Mesh(_) if textured => {
                            AreaEmitter::Mesh(MeshEmitter::with_uvs(&mesh, shape_prims))
                        }
                        ShapeKind::Mesh(_) => {
                            AreaEmitter::Mesh(MeshEmitter::new(&mesh, shape_prims))
                        }
                    };
                    let texture = shape
                        .emitter_texture
                        .map(|t| emission_texture(t as u32, &textures, shape, &kind, shape_prims));
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
        if dropped > 0 {
            warnings.push(format!(
                "{dropped} sphere(s) with a zero or non-finite size or position after their \
                 transform were left out"
            ));
        }

        let mut infinite_lights = Vec::new();
        for light in &scene.lights {
            let light = match light {
                desc::Light::Point {
                    position,
                    intensity,
                } => Light::Point(PointLight {
                    position: (*position).into(),
                    intensity: (*intensity).into(),
                }),
                desc::Light::Spot {
                    to_world,
                    intensity,
                    cutoff_angle,
                    beam_width,
                    texture,
                } => {
                    // The light keeps its own copy: lights are sampled without the scene's
                    // texture list at hand.
                    let texture = texture
                        .map(|t| build_texture(&scene.textures[t], &mut warnings).map(Box::new))
                        .transpose()?;
                    Light::Spot(SpotLight::new(
                        *to_world,
                        (*intensity).into(),
                        *cutoff_angle,
                        *beam_width,
                        texture,
                    ))
                }
                desc::Light::Directional {
                    direction,
                    irradiance,
                } => Light::Directional(DirectionalLight {
                    to_light: -Vec3A::from(*direction),
                    irradiance: (*irradiance).into(),
                }),
                // A black background emits nothing: keeping it would only waste light samples.
                desc::Light::Constant { radiance } if radiance.max_element() <= 0.0 => continue,
                desc::Light::Constant { radiance } => Light::Constant(ConstantLight {
                    radiance: (*radiance).into(),
                }),
                desc::Light::Projector {
                    to_world,
                    irradiance,
                    scale,
                    fov_degrees,
                    fov_axis,
                } => {
                    let (irradiance, (w, h)) = match irradiance {
                        desc::ColorParam::Constant(c) => {
                            (ColorSource::Constant((*c).into()), (1, 1))
                        }
                        desc::ColorParam::Texture(t) => (
                            ColorSource::Texture(*t as u32),
                            match &textures[*t] {
                                Texture::Bitmap(b) => (b.mip().width(), b.mip().height()),
                                _ => (1, 1),
                            },
                        ),
                    };
                    // The field of view as a perspective camera of the texture's size has it.
                    let camera =
                        PerspectiveCamera::new(Mat4::IDENTITY, *fov_degrees, *fov_axis, w, h);
                    Light::Projector(ProjectorLight::new(
                        *to_world,
                        irradiance,
                        *scale,
                        camera.tan_half_x(),
                        w as f32 / h as f32,
                    ))
                }
                desc::Light::Envmap {
                    bitmap,
                    scale,
                    to_world,
                } => {
                    let image = load_bitmap_image(bitmap, &mut warnings)?;
                    let rotation = Mat3::from_mat4(*to_world);
                    Light::Env(Box::new(EnvLight {
                        map: EnvMap::new(image, *scale, rotation),
                    }))
                }
            };
            if light.is_infinite() {
                infinite_lights.push(lights.len() as u32);
            }
            lights.push(light);
        }

        debug_assert!(world_geoms.iter().all(PrimGeom::is_finite));
        let accel = Accel::build(&world_geoms, bvh_width);
        let instances = build_instances(scene, &group_geoms, &group_first_prim, bvh_width);
        let has_area_lights = shapes.iter().any(|s| s.area_light.is_some());
        Ok(Self {
            camera,
            accel,
            instances,
            mesh,
            prims,
            shapes,
            materials,
            textures,
            lights,
            infinite_lights,
            has_area_lights,
            hide_emitters: scene.integrator.hide_emitters,
            // The crop window counts only for the film it was written for (not under `--size`).
            sample_window: match scene.film.crop {
                Some(c) if (width, height) == (scene.film.width, scene.film.height) => c.rect(),
                _ => (0, 0, width, height),
            },
            warnings,
        })
    }
}

/// The top level over the scene's instances and the bottom-level BVHs of the groups they place;
/// None without instances (or when every instanced group is empty).
fn build_instances(
    scene: &desc::Scene,
    group_geoms: &[Vec<PrimGeom>],
    group_first_prim: &[u32],
    bvh_width: BvhWidth,
) -> Option<Box<Instances>> {
    if scene.instances.is_empty() {
        return None;
    }
    let mut placed = vec![false; group_geoms.len()];
    for i in &scene.instances {
        placed[i.group] = true;
    }
    let groups = group_geoms
        .iter()
        .zip(group_first_prim)
        .zip(placed)
        .map(|((geoms, &first), placed)| {
            debug_assert!(geoms.iter().all(PrimGeom::is_finite));
            placed
                .then(|| GroupAccel::build(geoms, first, bvh_width))
                .flatten()
        })
        .collect();
    let placements: Vec<_> = scene
        .instances
        .iter()
        .map(|i| (i.to_world, i.group))
        .collect();
    Instances::build(groups, &placements).map(Box::new)
}

/// The camera of the scene for a `width` x `height` film. Its transform must be finite and
/// invertible: a degenerate one (a zero scale, say) maps every pixel to the same non-finite ray.
fn build_camera(c: &desc::Camera, width: u32, height: u32) -> Result<Camera, BuildError> {
    let linear = Mat3::from_mat4(c.to_world);
    let det = linear.determinant();
    if !(c.to_world.is_finite() && det.is_finite() && det != 0.0) {
        return Err(BuildError::Other(
            "error: the camera's transform is degenerate (zero scale, or non-finite)".into(),
        ));
    }
    if !(c.fov_degrees.is_finite() && c.fov_degrees > 0.0 && c.fov_degrees < 180.0) {
        return Err(BuildError::Other(format!(
            "error: the camera's field of view must be in (0, 180) degrees, found {}",
            c.fov_degrees
        )));
    }
    let pinhole = PerspectiveCamera::new(c.to_world, c.fov_degrees, c.fov_axis, width, height)
        .with_clip(c.near_clip, c.far_clip);
    Ok(match c.kind {
        desc::CameraKind::ThinLens {
            aperture_radius,
            focus_distance,
        } => Camera::ThinLens(ThinLensCamera::new(
            pinhole,
            aperture_radius,
            focus_distance,
        )),
        desc::CameraKind::Orthographic => Camera::Orthographic(
            OrthographicCamera::new(c.to_world, c.near_clip, width, height)
                .with_far_clip(c.far_clip),
        ),
        // Mitsuba's thinlens has no principal point offset; its perspective camera does.
        desc::CameraKind::Perspective => {
            Camera::Perspective(pinhole.with_principal_point(c.principal_point_offset))
        }
    })
}

fn load_bitmap_image(
    bitmap: &desc::Bitmap,
    warnings: &mut Vec<String>,
) -> Result<torrey_texture::Image, BuildError> {
    let loaded = torrey_texture::load_image(&bitmap.filename, bitmap.raw).map_err(|e| {
        BuildError::Texture {
            location: bitmap.location.to_string(),
            message: e.to_string(),
        }
    })?;
    warnings.extend(loaded.warnings);
    Ok(loaded.image)
}

/// A texture of the scene from its description, its bitmap loaded and mip-mapped.
/// A textured area emitter's radiance: texture `index`, sampled by its luminance where Mitsuba
/// inverts the shape's uv map (a bitmap without a uv transform on a rectangle or a sphere).
fn emission_texture(
    index: u32,
    textures: &[Texture],
    shape: &desc::Shape,
    kind: &ShapeKind,
    prims: &[PrimInfo],
) -> EmissionTexture {
    let map = match (&shape.geometry, kind) {
        (desc::Geometry::Rectangle, _) => prims.first().map(|prim| UvMap::Rectangle {
            origin: shape.to_world.transform_point3(glam::Vec3::ZERO).into(),
            ax: shape.to_world.transform_vector3(glam::Vec3::X).into(),
            ay: shape.to_world.transform_vector3(glam::Vec3::Y).into(),
            normal: prim.ng,
        }),
        (_, ShapeKind::Sphere(sphere)) => Some(UvMap::Sphere {
            center: sphere.center,
            radius: sphere.radius,
            to_world: sphere.to_object.transpose(),
        }),
        _ => None,
    };
    let sampling = match (&textures[index as usize], map) {
        (Texture::Bitmap(b), Some(map)) if b.to_uv() == glam::Affine2::IDENTITY => {
            TexelDistribution::new(b.mip().level(0)).map(|d| (d, map))
        }
        _ => None,
    };
    EmissionTexture {
        texture: index,
        sampling,
    }
}

fn build_texture(t: &desc::Texture, warnings: &mut Vec<String>) -> Result<Texture, BuildError> {
    Ok(match &t.kind {
        desc::TextureKind::Bitmap(bitmap) => {
            let image = load_bitmap_image(bitmap, warnings)?;
            let wrap = match bitmap.wrap {
                desc::WrapMode::Repeat => torrey_texture::WrapMode::Repeat,
                desc::WrapMode::Mirror => torrey_texture::WrapMode::Mirror,
                desc::WrapMode::Clamp => torrey_texture::WrapMode::Clamp,
            };
            let filter = match bitmap.filter {
                desc::FilterType::Bilinear => torrey_texture::FilterType::Bilinear,
                desc::FilterType::Nearest => torrey_texture::FilterType::Nearest,
            };
            Texture::Bitmap(BitmapTexture::new(
                MipMap::new(image, wrap, filter),
                bitmap.to_uv,
            ))
        }
        desc::TextureKind::Checkerboard {
            color0,
            color1,
            to_uv,
        } => Texture::Checkerboard {
            color0: (*color0).into(),
            color1: (*color1).into(),
            to_uv: *to_uv,
        },
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::ray::Ray;
    use crate::shapes::mesh::MeshShape;
    use crate::shapes::ShapeKind;
    use glam::Vec3A;
    use std::path::Path;

    fn scene(shapes: &str) -> RenderScene {
        let xml = format!(
            r#"<scene version="0.6.0">
                <sensor type="perspective"><film type="hdrfilm">
                    <integer name="width" value="8"/><integer name="height" value="8"/>
                </film></sensor>
                {shapes}
            </scene>"#
        );
        let desc = torrey_parser::parse_scene_str(&xml, Path::new("test.xml"), &[]).unwrap();
        RenderScene::build(&desc, 8, 8).unwrap()
    }

    /// Rectangles (one normal for all four vertices) take the flat-normal path, and a hit's
    /// shading normal there is exactly the vertex normal; a smooth mesh does not.
    #[test]
    fn flat_shaded_meshes_are_recognised() {
        let s = scene(
            r#"<shape type="rectangle"><transform name="toWorld">
                   <rotate x="1" angle="-90"/><scale value="2"/>
               </transform></shape>"#,
        );
        assert!(matches!(
            s.shapes[0].kind,
            ShapeKind::Mesh(MeshShape {
                flat_normals: true,
                ..
            })
        ));
        let ray = Ray {
            origin: Vec3A::new(0.3, 1.0, -0.2),
            dir: -Vec3A::Y,
            tmax: f32::INFINITY,
        };
        let hit = s.intersect(&ray).expect("the floor is below");
        assert_eq!(hit.ns, s.mesh.normals[0]);
        assert!((hit.ns - Vec3A::Y).length() < 1e-6, "{}", hit.ns);

        // The project's torus has smooth vertex normals (tests run in the crate's directory).
        let s = scene(
            r#"<shape type="obj"><string name="filename" value="../../scenes/meshes/torus.obj"/></shape>"#,
        );
        assert!(matches!(
            s.shapes[0].kind,
            ShapeKind::Mesh(MeshShape {
                has_normals: true,
                flat_normals: false,
                ..
            })
        ));
    }
}
