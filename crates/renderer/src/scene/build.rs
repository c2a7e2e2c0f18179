//! Building a [`RenderScene`] from the parser's description: each concept by its own builder
//! (camera and textures: build_textures.rs; shapes, their primitives and area lights:
//! build_shapes.rs; the other lights: build_lights.rs; materials: material.rs), then the BVHs
//! over every primitive and the light selection.

use super::build_lights::build_light;
use super::build_shapes::{build_shapes, ShapeSet};
use super::build_textures::{build_camera, build_textures, emission_texture};
use super::{Material, RenderScene};
use crate::accel::instances::{GroupAccel, Instances};
use crate::accel::{Accel, AccelOptions, BvhWidth, PrimGeom};
use crate::bsdfs::{BsdfParams, DiffuseParams};
use crate::lights::Light;
use crate::textures::{ColorSource, Texture};
use glam::Vec3A;
use torrey_parser as desc;

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
    /// Prepares `scene` for a `width` x `height` film, rendered at the spp of its sampler.
    pub fn build(scene: &desc::Scene, width: u32, height: u32) -> Result<Self, BuildError> {
        let samples = u64::from(width) * u64::from(height) * u64::from(scene.sampler.sample_count);
        Self::build_with(
            scene,
            width,
            height,
            AccelOptions {
                width: BvhWidth::Auto,
                samples,
            },
        )
    }

    /// [`RenderScene::build`] with the BVH's options: its node width (for comparing them; the
    /// images are the same up to which of two triangles at exactly equal distance is reported)
    /// and the render's camera samples, which size the build's effort.
    pub fn build_with(
        scene: &desc::Scene,
        width: u32,
        height: u32,
        accel: AccelOptions,
    ) -> Result<Self, BuildError> {
        let camera = build_camera(&scene.camera, width, height)?;
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

        // The textures and the other lights (decoding images, building mip-maps and sampling
        // tables) beside the shapes and their BVHs: the two halves share nothing, and a
        // textured interior spends as long on the one as on the other.
        let (textures_and_lights, geometry) = rayon::join(
            || -> Result<_, BuildError> {
                let mut warnings = Vec::new();
                let textures = build_textures(&scene.textures, &mut warnings)?;
                let mut lights = Vec::new();
                for light in &scene.lights {
                    if let Some(light) = build_light(light, scene, &textures, &mut warnings)? {
                        lights.push(light);
                    }
                }
                Ok((textures, lights, warnings))
            },
            || -> Result<_, BuildError> {
                let mut area_lights = Vec::new();
                let mut warnings = Vec::new();
                let set = build_shapes(scene, default_material, &mut area_lights, &mut warnings)?;
                debug_assert!(set.world_geoms.iter().all(PrimGeom::is_finite));
                let bvh = Accel::build_with(&set.world_geoms, &set.mesh.sdf_voxels, accel);
                let instances = build_instances(
                    scene,
                    &set.group_geoms,
                    &set.group_first_prim,
                    &set.mesh.sdf_voxels,
                    accel,
                );
                Ok((set, area_lights, bvh, instances, warnings))
            },
        );
        let (mut textures, other_lights, mut warnings) = textures_and_lights?;
        let (
            ShapeSet {
                mesh,
                prims,
                shapes,
                attributes,
                textured_emitters,
                ..
            },
            mut lights,
            accel,
            instances,
            shape_warnings,
        ) = geometry?;
        warnings.extend(shape_warnings);
        for e in textured_emitters {
            if let Light::Area(light) = &mut lights[e.light] {
                light.texture = light.texture.as_ref().map(|t| {
                    emission_texture(
                        t.texture,
                        &textures,
                        &scene.shapes[e.shape],
                        &shapes[e.shape].kind,
                        &prims[e.prims],
                    )
                });
            }
        }
        let mut infinite_lights = Vec::new();
        for light in other_lights {
            if light.is_infinite() {
                infinite_lights.push(lights.len() as u32);
            }
            lights.push(light);
        }

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
            light_selection: crate::lights::LightSelection::new(&lights),
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
    sdf_voxels: &[crate::shapes::sdfgrid::SdfVoxel],
    accel: AccelOptions,
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
                .then(|| GroupAccel::build_with(geoms, sdf_voxels, first, accel))
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
