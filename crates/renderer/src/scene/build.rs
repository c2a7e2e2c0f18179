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
use crate::shapes::attributes::{AttributeData, MeshAttributes};
use crate::shapes::cylinder::Cylinder;
use crate::shapes::disk::Disk;
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
        let mut dropped_analytic = 0usize;
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
                        ShapeKind::Disk(disk) => AreaEmitter::Disk(Box::new(disk)),
                        ShapeKind::Cylinder(cylinder) => AreaEmitter::Cylinder(Box::new(cylinder)),
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

        let mut textures = textures;
        for (t, desc_texture) in textures.iter_mut().zip(&scene.textures) {
            if let (
                Texture::MeshAttribute { by_shape, .. },
                desc::TextureKind::MeshAttribute { name, .. },
            ) = (t, &desc_texture.kind)
            {
                *by_shape = (0..shapes.len() as u32)
                    .map(|s| attributes.find(s, name).unwrap_or(u32::MAX))
                    .collect();
            }
        }

        debug_assert!(world_geoms.iter().all(PrimGeom::is_finite));
        let accel = Accel::build(&world_geoms, bvh_width);
        let instances = build_instances(scene, &group_geoms, &group_first_prim, bvh_width);
        let has_area_lights = shapes.iter().any(|s| s.area_light.is_some());
        let any_uv = shapes.iter().any(|s| {
            materials
                .get(s.material as usize)
                .is_none_or(|m| m.is_textured() || m.anisotropic)
                || s.textured_emission
        });
        let uses_cones = materials.iter().any(Material::is_textured)
            || lights.iter().any(|l| matches!(l, Light::Env(_)));
        if let desc::IntegratorKind::Direct(d) = scene.integrator.kind {
            if d.emitter_samples > 1 && lights.iter().any(Light::is_delta) {
                warnings.push(format!(
                    "integrator 'direct' with emitter_samples {}: point, spot, directional and projector lights count {} times, as in Mitsuba 3.9.1 (its direct integrator does not divide their samples by the count)",
                    d.emitter_samples, d.emitter_samples
                ));
            }
        }
        let passable = materials.iter().any(|m| m.bsdf.may_pass());
        let media = crate::media::Media::build(scene, passable, &mut warnings);
        Ok(Self {
            camera,
            accel,
            instances,
            mesh,
            prims,
            shapes,
            materials,
            textures,
            attributes,
            lights,
            infinite_lights,
            media,
            has_area_lights,
            uses_cones,
            any_uv,
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
        (_, ShapeKind::Disk(disk)) => Some(UvMap::Disk(Box::new(*disk))),
        (_, ShapeKind::Cylinder(cylinder)) => Some(UvMap::Cylinder(Box::new(*cylinder))),
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
        // Its table of shapes is filled once the shapes are built.
        desc::TextureKind::MeshAttribute { scale, .. } => Texture::MeshAttribute {
            by_shape: Vec::new(),
            scale: *scale,
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

    /// A triangle in OBJ and PLY with per-vertex normals and uvs, in a folder of its own.
    fn triangle_files() -> (String, String) {
        // One folder per call: tests run in parallel, and one rewriting the files while another
        // reads them gave a truncated PLY.
        static CALLS: std::sync::atomic::AtomicUsize = std::sync::atomic::AtomicUsize::new(0);
        let call = CALLS.fetch_add(1, std::sync::atomic::Ordering::Relaxed);
        let dir = std::env::temp_dir().join(format!(
            "torrey-shape-options-{}-{call}",
            std::process::id()
        ));
        std::fs::create_dir_all(&dir).unwrap();
        let obj = dir.join("tri.obj");
        std::fs::write(
            &obj,
            "v 0 0 0\nv 1 0 0\nv 0 1 0\nvt 0.1 0.2\nvt 0.9 0.2\nvt 0.1 0.7\nvn 0.3 0 1\nvn 0 0.3 1\nvn 0 0 1\nf 1/1/1 2/2/2 3/3/3\n",
        )
        .unwrap();
        let ply = dir.join("tri.ply");
        std::fs::write(
            &ply,
            "ply\nformat ascii 1.0\nelement vertex 3\nproperty float x\nproperty float y\nproperty float z\nproperty float nx\nproperty float ny\nproperty float nz\nproperty float u\nproperty float v\nelement face 1\nproperty list uchar int vertex_indices\nend_header\n0 0 0 0.3 0 1 0.1 0.2\n1 0 0 0 0.3 1 0.9 0.2\n0 1 0 0 0 1 0.1 0.7\n3 0 1 2\n",
        )
        .unwrap();
        (obj.display().to_string(), ply.display().to_string())
    }

    /// The hit of a ray from `origin` along `dir` on the scene's only shape, given with a
    /// textured bsdf (so that the hit carries uv) and `params` inside.
    fn probe(
        shape: &str,
        params: &str,
        origin: [f32; 3],
        dir: [f32; 3],
    ) -> crate::shapes::SurfaceHit {
        let s = scene(&format!(
            r#"<shape type="{shape}">{params}<bsdf type="diffuse"><texture type="checkerboard" name="reflectance"/></bsdf></shape>"#
        ));
        let ray = Ray {
            origin: Vec3A::from(origin),
            dir: Vec3A::from(dir),
            tmax: f32::INFINITY,
        };
        s.intersect(&ray).expect("the ray hits the shape")
    }

    fn near(a: Vec3A, b: [f32; 3]) -> bool {
        (a - Vec3A::from(b)).length() < 1e-4
    }

    const MITSUBA_SHADING_NORMAL: [f32; 3] = [0.175354, 0.058451, 0.982769];

    /// `flip_normals` negates the geometric and shading normals and keeps uv and dp/du, for
    /// every shape kind (Mitsuba 3.9.1 prints the same for these rays).
    #[test]
    fn flip_normals_negates_both_normals_for_every_shape() {
        let (obj, ply) = triangle_files();
        let down = [0.0, 0.0, -1.0];
        let cases = [
            (
                "obj",
                format!(r#"<string name="filename" value="{obj}"/>"#),
                [0.2, 0.2, 5.0],
                down,
            ),
            (
                "ply",
                format!(r#"<string name="filename" value="{ply}"/>"#),
                [0.2, 0.2, 5.0],
                down,
            ),
            ("rectangle", String::new(), [0.2, 0.2, 5.0], down),
            ("cube", String::new(), [0.2, 0.2, 5.0], down),
            ("sphere", String::new(), [0.2, 0.2, 5.0], down),
            ("disk", String::new(), [0.2, 0.3, 5.0], down),
            ("cylinder", String::new(), [5.0, 0.2, 0.5], [-1.0, 0.0, 0.0]),
        ];
        for (shape, params, o, d) in cases {
            let plain = probe(shape, &params, o, d);
            let flip = format!(r#"{params}<boolean name="flip_normals" value="true"/>"#);
            let flipped = probe(shape, &flip, o, d);
            assert_eq!(flipped.ng, -plain.ng, "{shape}");
            assert_eq!(flipped.ns, -plain.ns, "{shape}");
            assert_eq!(
                (flipped.uv, flipped.dpdu),
                (plain.uv, plain.dpdu),
                "{shape}"
            );
            assert!(
                plain.ng.dot(Vec3A::from(d)) < 0.0,
                "{shape}: outward before flipping"
            );
        }
        let (o, d) = ([0.2, 0.2, 5.0], down);
        let obj_params = format!(r#"<string name="filename" value="{obj}"/>"#);
        assert!(near(
            probe("obj", &obj_params, o, d).ns,
            MITSUBA_SHADING_NORMAL
        ));
    }

    /// `face_normals` drops the vertex normals: the shading normal is the face's (Mitsuba
    /// 3.9.1: (0, 0, 1) here, and the interpolated normal without it).
    #[test]
    fn face_normals_shade_flat() {
        let (obj, ply) = triangle_files();
        for file in [obj, ply] {
            let f = format!(r#"<string name="filename" value="{file}"/>"#);
            let smooth = probe(
                if file.ends_with("obj") { "obj" } else { "ply" },
                &f,
                [0.2, 0.2, 5.0],
                [0.0, 0.0, -1.0],
            );
            assert!(
                near(smooth.ns, MITSUBA_SHADING_NORMAL),
                "{file}: {}",
                smooth.ns
            );
            let flat = format!(r#"{f}<boolean name="face_normals" value="true"/>"#);
            let flat = probe(
                if file.ends_with("obj") { "obj" } else { "ply" },
                &flat,
                [0.2, 0.2, 5.0],
                [0.0, 0.0, -1.0],
            );
            assert_eq!(flat.ns, flat.ng);
            assert!(near(flat.ns, [0.0, 0.0, 1.0]));
        }
    }

    /// `flip_tex_coords`: v' = 1 - v, by default for OBJ and not for PLY (Mitsuba 3.9.1's uv at
    /// this hit: (0.26, 0.7) flipped, (0.26, 0.3) not).
    #[test]
    fn flip_tex_coords_defaults_and_overrides() {
        let (obj, ply) = triangle_files();
        let uv = |shape: &str, file: &str, flip: Option<bool>| {
            let mut p = format!(r#"<string name="filename" value="{file}"/>"#);
            if let Some(f) = flip {
                p += &format!(r#"<boolean name="flip_tex_coords" value="{f}"/>"#);
            }
            probe(shape, &p, [0.2, 0.2, 5.0], [0.0, 0.0, -1.0]).uv
        };
        let close = |a: glam::Vec2, b: [f32; 2]| (a - glam::Vec2::from(b)).length() < 1e-5;
        assert!(close(uv("obj", &obj, None), [0.26, 0.7]));
        assert!(close(uv("obj", &obj, Some(false)), [0.26, 0.3]));
        assert!(close(uv("ply", &ply, None), [0.26, 0.3]));
        assert!(close(uv("ply", &ply, Some(true)), [0.26, 0.7]));
    }

    /// `to_world` moves mesh normals by the inverse transpose (Mitsuba 3.9.1 for scale (2, 1, 1):
    /// shading normal (0.089848, 0.058014, 0.994264) at the same point of the triangle).
    #[test]
    fn to_world_transforms_normals_by_the_inverse_transpose() {
        let (obj, _) = triangle_files();
        let p = format!(
            r#"<string name="filename" value="{obj}"/><transform name="to_world"><scale x="2" y="1" z="1"/></transform>"#
        );
        let hit = probe("obj", &p, [0.4, 0.2, 5.0], [0.0, 0.0, -1.0]);
        assert!(near(hit.ns, [0.089848, 0.058014, 0.994264]), "{}", hit.ns);
        assert!((hit.uv - glam::Vec2::new(0.26, 0.7)).length() < 1e-5);
    }
}
