//! The scene as the integrator sees it: world-space geometry in one BVH, resolved materials and
//! textures, and the light list. Built once from the parser's plain description.

use crate::accel::{Accel, BvhWidth, ClosestHit, PrimGeom, PACKET};
use crate::bsdf::BsdfModel;
use crate::camera::Camera;
use crate::geometry::{sphere_uv, Ray};
use crate::light::{AreaShape, EmitterTriangle, Light, LightKind};
use crate::texture::{ColorSource, Texture};
use glam::{Mat3, Mat4, Vec2, Vec3A};
use torrey_light::{AliasTable, EnvMap};
use torrey_parser as desc;
use torrey_texture::{BitmapTexture, MipMap};

/// Why a parsed scene could not be prepared for rendering (texture files that do not decode, say).
#[derive(Debug, thiserror::Error)]
pub enum BuildError {
    #[error("{location}: error: {message}")]
    Texture { location: String, message: String },
    #[error("{0}")]
    Other(String),
}

/// A material ready to shade: the model, where its reflectance comes from, and its sidedness.
#[derive(Clone, Copy, Debug)]
pub struct Material {
    pub model: BsdfModel,
    pub reflectance: ColorSource,
    /// Shades both sides (torrey-dialect scenes, or Mitsuba's `twosided`).
    pub two_sided: bool,
    pub normal_map: Option<u32>,
}

impl Material {
    /// Whether shading reads any texture, i.e. needs a ray-cone footprint.
    #[inline]
    pub fn is_textured(&self) -> bool {
        self.normal_map.is_some() || matches!(self.reflectance, ColorSource::Texture(_))
    }
}

#[derive(Clone, Copy, Debug)]
pub enum ShapeKind {
    Mesh {
        has_normals: bool,
        /// Every triangle's three vertex normals are the same (flat-shaded faces, as in box
        /// meshes with one normal per face): the shading normal is that normal, without the
        /// interpolation and normalisation (a square root and a division on the path from a
        /// hit to its shading).
        flat_normals: bool,
        has_uvs: bool,
    },
    /// World-space centre and radius, and the world-to-object rotation that fixes the uv poles.
    Sphere {
        center: Vec3A,
        radius: f32,
        to_object: Mat3,
    },
}

#[derive(Clone, Copy, Debug)]
pub struct ShapeInfo {
    pub material: u32,
    pub area_light: Option<u32>,
    pub kind: ShapeKind,
    pub flip_normals: bool,
}

/// What a hit needs to know about a BVH primitive, one load away from the hit's primitive index:
/// its shape and, for a triangle, its unit geometric normal and vertex indices into [`MeshData`].
/// (Indices and normal in a separate per-triangle array would put one more dependent load
/// between a hit and its shading.)
#[derive(Clone, Copy, Debug)]
pub struct PrimInfo {
    /// (p1 − p0) × (p2 − p0), normalised; zero for a sphere.
    pub ng: Vec3A,
    /// Zero for a sphere.
    pub indices: [u32; 3],
    pub shape: u32,
}

/// All triangles of the scene in world space, concatenated.
#[derive(Default)]
pub struct MeshData {
    pub positions: Vec<Vec3A>,
    pub normals: Vec<Vec3A>,
    pub uvs: Vec<Vec2>,
    /// Triangles kept (degenerate ones are dropped); their indices are in [`PrimInfo`].
    pub triangle_count: usize,
}

/// The differential geometry at a ray hit.
#[derive(Clone, Copy, Debug)]
pub struct SurfaceHit {
    pub t: f32,
    pub p: Vec3A,
    /// Geometric normal (after `flipNormals`), not turned towards the ray.
    pub ng: Vec3A,
    /// Shading normal (interpolated vertex normal, or `ng`), not turned towards the ray.
    pub ns: Vec3A,
    /// Texture coordinates and their position derivatives; only computed when the material reads
    /// a texture (zero otherwise: nothing else uses them, and spheres pay two inverse
    /// trigonometric functions for them).
    pub uv: Vec2,
    pub dpdu: Vec3A,
    pub dpdv: Vec3A,
    pub shape: u32,
    pub prim: u32,
}

pub struct RenderScene {
    pub camera: Camera,
    pub accel: Accel,
    pub mesh: MeshData,
    pub prims: Vec<PrimInfo>,
    pub shapes: Vec<ShapeInfo>,
    pub materials: Vec<Material>,
    pub textures: Vec<Texture>,
    pub lights: Vec<Light>,
    /// Indices of lights at infinity (constant background, environment maps).
    pub infinite_lights: Vec<u32>,
    /// Whether any shape emits. Without area lights, a surface hit never adds emission, so a
    /// path's last segment only needs to know whether it escapes (an any-hit query).
    pub has_area_lights: bool,
    pub warnings: Vec<String>,
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
        let camera = Camera::new(
            scene.camera.to_world,
            scene.camera.fov_degrees,
            scene.camera.fov_axis,
            width,
            height,
        );
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
            .map(|b| build_material(b, torrey_dialect))
            .collect();
        // Shapes without a bsdf get Mitsuba's default: diffuse, reflectance 0.5.
        let default_material = materials.len() as u32;
        materials.push(Material {
            model: BsdfModel::Diffuse,
            reflectance: ColorSource::Constant(Vec3A::splat(0.5)),
            two_sided: torrey_dialect,
            normal_map: None,
        });

        let mut mesh = MeshData::default();
        let mut geoms = Vec::new();
        let mut prims = Vec::new();
        let mut shapes = Vec::new();
        let mut lights = Vec::new();
        for (shape_index, shape) in scene.shapes.iter().enumerate() {
            let shape_id = shape_index as u32;
            let first_prim = prims.len() as u32;
            let kind = match &shape.geometry {
                desc::Geometry::Mesh(m) => add_mesh(
                    &mut mesh,
                    &mut geoms,
                    &mut prims,
                    shape_id,
                    m,
                    shape.to_world,
                ),
                desc::Geometry::Rectangle => add_mesh(
                    &mut mesh,
                    &mut geoms,
                    &mut prims,
                    shape_id,
                    &rectangle_mesh(),
                    shape.to_world,
                ),
                desc::Geometry::Sphere { center, radius } => {
                    // Mitsuba: to_world * translate(center) * scale(radius); scale must be uniform.
                    let m = shape.to_world;
                    let c = m.transform_point3(*center);
                    let linear = Mat3::from_mat4(m);
                    let scale = linear.x_axis.length();
                    let r = radius * scale;
                    let rot = if scale > 0.0 {
                        linear * (1.0 / scale)
                    } else {
                        Mat3::IDENTITY
                    };
                    geoms.push(PrimGeom::Sphere {
                        center: c.into(),
                        radius: r,
                    });
                    prims.push(PrimInfo {
                        ng: Vec3A::ZERO,
                        indices: [0; 3],
                        shape: shape_id,
                    });
                    ShapeKind::Sphere {
                        center: c.into(),
                        radius: r,
                        to_object: rot.transpose(),
                    }
                }
            };
            let prim_count = prims.len() as u32 - first_prim;
            let area_light = match shape.emitter {
                Some(radiance) if radiance.max_element() > 0.0 && prim_count > 0 => {
                    let area_shape = match kind {
                        ShapeKind::Sphere { center, radius, .. } => {
                            AreaShape::Sphere { center, radius }
                        }
                        ShapeKind::Mesh { .. } => {
                            let tris: Vec<EmitterTriangle> = (first_prim..first_prim + prim_count)
                                .map(|p| {
                                    let prim = &prims[p as usize];
                                    let [a, b, c] = prim.indices;
                                    let (a, b, c) = (
                                        mesh.positions[a as usize],
                                        mesh.positions[b as usize],
                                        mesh.positions[c as usize],
                                    );
                                    EmitterTriangle {
                                        p0: a,
                                        e1: b - a,
                                        e2: c - a,
                                        normal: prim.ng,
                                    }
                                })
                                .collect();
                            let areas: Vec<f32> = tris
                                .iter()
                                .map(|t| 0.5 * t.e1.cross(t.e2).length())
                                .collect();
                            let total: f32 = areas.iter().sum();
                            AreaShape::Mesh {
                                total_area: total,
                                triangles: AliasTable::new(&areas),
                                geometry: tris,
                            }
                        }
                    };
                    lights.push(Light {
                        kind: LightKind::Area {
                            shape: shape_id,
                            radiance: radiance.into(),
                            area: area_shape,
                            flip_normals: shape.flip_normals,
                        },
                    });
                    Some(lights.len() as u32 - 1)
                }
                _ => None,
            };
            shapes.push(ShapeInfo {
                material: shape.bsdf.map_or(default_material, |b| b as u32),
                area_light,
                kind,
                flip_normals: shape.flip_normals,
            });
        }

        let mut infinite_lights = Vec::new();
        for light in &scene.lights {
            let kind = match light {
                desc::Light::Point {
                    position,
                    intensity,
                } => LightKind::Point {
                    position: (*position).into(),
                    intensity: (*intensity).into(),
                },
                // A black background emits nothing: keeping it would only waste light samples.
                desc::Light::Constant { radiance } if radiance.max_element() <= 0.0 => continue,
                desc::Light::Constant { radiance } => LightKind::Constant {
                    radiance: (*radiance).into(),
                },
                desc::Light::Envmap {
                    bitmap,
                    scale,
                    to_world,
                } => {
                    let image = load_bitmap_image(bitmap, &mut warnings)?;
                    let rotation = Mat3::from_mat4(*to_world);
                    LightKind::Env(Box::new(EnvMap::new(image, *scale, rotation)))
                }
            };
            if matches!(kind, LightKind::Constant { .. } | LightKind::Env(_)) {
                infinite_lights.push(lights.len() as u32);
            }
            lights.push(Light { kind });
        }

        let accel = Accel::build_with_width(&geoms, bvh_width);
        let has_area_lights = shapes.iter().any(|s| s.area_light.is_some());
        Ok(Self {
            camera,
            accel,
            mesh,
            prims,
            shapes,
            materials,
            textures,
            lights,
            infinite_lights,
            has_area_lights,
            warnings,
        })
    }

    pub fn triangle_count(&self) -> usize {
        self.mesh.triangle_count
    }

    /// Closest surface along the ray, with its differential geometry.
    #[inline]
    pub fn intersect(&self, ray: &Ray) -> Option<SurfaceHit> {
        let hit = self.accel.intersect(ray)?;
        Some(self.surface_hit(ray, &hit))
    }

    /// Closest hits of rays from one origin (the samples of a pixel), traced as one packet; None
    /// when they cannot be ([`crate::bvh::Bvh::intersect_packet`]). [`RenderScene::surface`]
    /// turns a hit into its differential geometry.
    #[inline]
    pub fn intersect_packet(
        &self,
        origin: Vec3A,
        dirs: &[Vec3A; PACKET],
    ) -> Option<[Option<ClosestHit>; PACKET]> {
        self.accel.intersect_packet(origin, dirs)
    }

    /// The differential geometry of `hit`, a closest hit along `ray`.
    #[inline(never)]
    pub fn surface(&self, ray: &Ray, hit: &ClosestHit) -> SurfaceHit {
        self.surface_hit(ray, hit)
    }

    #[inline(always)]
    fn surface_hit(&self, ray: &Ray, hit: &ClosestHit) -> SurfaceHit {
        let prim = &self.prims[hit.prim as usize];
        let shape = &self.shapes[prim.shape as usize];
        let needs_uv = self.materials[shape.material as usize].is_textured();
        let mut sh = match shape.kind {
            ShapeKind::Mesh {
                has_normals,
                flat_normals,
                has_uvs,
            } => {
                let [i0, i1, i2] = prim.indices;
                let (i0, i1, i2) = (i0 as usize, i1 as usize, i2 as usize);
                let (p0, p1, p2) = (
                    self.mesh.positions[i0],
                    self.mesh.positions[i1],
                    self.mesh.positions[i2],
                );
                let b0 = 1.0 - hit.b1 - hit.b2;
                let p = b0 * p0 + hit.b1 * p1 + hit.b2 * p2;
                let e1 = p1 - p0;
                let e2 = p2 - p0;
                let ng = prim.ng;
                let ns = if flat_normals {
                    self.mesh.normals[i0]
                } else if has_normals {
                    let n = b0 * self.mesh.normals[i0]
                        + hit.b1 * self.mesh.normals[i1]
                        + hit.b2 * self.mesh.normals[i2];
                    n.normalize_or(ng)
                } else {
                    ng
                };
                // Without uvs Mitsuba uses the barycentrics as uv, so dp/du = e1, dp/dv = e2.
                let (uv, dpdu, dpdv) = if !needs_uv {
                    (Vec2::ZERO, Vec3A::ZERO, Vec3A::ZERO)
                } else if has_uvs {
                    let (t0, t1, t2) = (self.mesh.uvs[i0], self.mesh.uvs[i1], self.mesh.uvs[i2]);
                    let uv = b0 * t0 + hit.b1 * t1 + hit.b2 * t2;
                    let (d1, d2) = (t1 - t0, t2 - t0);
                    let det = d1.x * d2.y - d1.y * d2.x;
                    if det.abs() > 1e-12 {
                        let inv = 1.0 / det;
                        let dpdu = (d2.y * e1 - d1.y * e2) * inv;
                        let dpdv = (d1.x * e2 - d2.x * e1) * inv;
                        (uv, dpdu, dpdv)
                    } else {
                        let (s, t) = orthonormal_basis(ng);
                        (uv, s, t)
                    }
                } else {
                    (Vec2::new(hit.b1, hit.b2), e1, e2)
                };
                SurfaceHit {
                    t: hit.t,
                    p,
                    ng,
                    ns,
                    uv,
                    dpdu,
                    dpdv,
                    shape: prim.shape,
                    prim: hit.prim,
                }
            }
            ShapeKind::Sphere {
                center,
                radius,
                to_object,
            } => {
                let p_ray = ray.origin + hit.t * ray.dir;
                let n = (p_ray - center).normalize_or(Vec3A::Z);
                // Re-project onto the surface: the ray's point carries the cancellation error.
                let p = center + radius * n;
                let (uv, dpdu, dpdv) = if needs_uv {
                    let (uv, dpdu_l, dpdv_l) = sphere_uv(to_object * n);
                    let to_world = to_object.transpose();
                    (uv, to_world * dpdu_l * radius, to_world * dpdv_l * radius)
                } else {
                    (Vec2::ZERO, Vec3A::ZERO, Vec3A::ZERO)
                };
                SurfaceHit {
                    t: hit.t,
                    p,
                    ng: n,
                    ns: n,
                    uv,
                    dpdu,
                    dpdv,
                    shape: prim.shape,
                    prim: hit.prim,
                }
            }
        };
        if shape.flip_normals {
            sh.ng = -sh.ng;
            sh.ns = -sh.ns;
        }
        sh
    }

    /// True when nothing blocks the segment from `origin` along `dir` up to `tmax`.
    #[inline]
    pub fn visible(&self, origin: Vec3A, dir: Vec3A, tmax: f32) -> bool {
        !self.accel.occluded(&Ray { origin, dir, tmax })
    }
}

/// Any orthonormal pair perpendicular to `n` (Duff et al.'s branchless construction).
pub fn orthonormal_basis(n: Vec3A) -> (Vec3A, Vec3A) {
    let sign = 1f32.copysign(n.z);
    let a = -1.0 / (sign + n.z);
    let b = n.x * n.y * a;
    (
        Vec3A::new(1.0 + sign * n.x * n.x * a, sign * b, -sign * n.x),
        Vec3A::new(b, sign + n.y * n.y * a, -n.y),
    )
}

/// Mitsuba's rectangle: [-1,1]^2 at z = 0, normal +z, uv = ((x+1)/2, (y+1)/2).
fn rectangle_mesh() -> desc::TriangleMesh {
    let positions = vec![
        glam::Vec3::new(-1.0, -1.0, 0.0),
        glam::Vec3::new(1.0, -1.0, 0.0),
        glam::Vec3::new(1.0, 1.0, 0.0),
        glam::Vec3::new(-1.0, 1.0, 0.0),
    ];
    let uvs = positions
        .iter()
        .map(|p| Vec2::new((p.x + 1.0) * 0.5, (p.y + 1.0) * 0.5))
        .collect();
    desc::TriangleMesh {
        positions,
        normals: vec![glam::Vec3::Z; 4],
        uvs,
        indices: vec![[0, 1, 2], [0, 2, 3]],
    }
}

/// Transforms a mesh to world space and appends it. Degenerate (zero-area) triangles are dropped:
/// they can never be hit and would only cost traversal time.
fn add_mesh(
    mesh: &mut MeshData,
    geoms: &mut Vec<PrimGeom>,
    prims: &mut Vec<PrimInfo>,
    shape: u32,
    m: &desc::TriangleMesh,
    to_world: Mat4,
) -> ShapeKind {
    let base = mesh.positions.len() as u32;
    let has_normals = m.normals.len() == m.positions.len() && !m.normals.is_empty();
    let has_uvs = m.uvs.len() == m.positions.len() && !m.uvs.is_empty();
    mesh.positions.extend(
        m.positions
            .iter()
            .map(|&p| Vec3A::from(to_world.transform_point3(p))),
    );
    // Normals transform with the inverse transpose.
    let normal_matrix = Mat3::from_mat4(to_world).inverse().transpose();
    if has_normals {
        mesh.normals.extend(
            m.normals
                .iter()
                .map(|&n| Vec3A::from(normal_matrix * n).normalize_or(Vec3A::Z)),
        );
    } else {
        mesh.normals
            .extend(std::iter::repeat_n(Vec3A::Z, m.positions.len()));
    }
    if has_uvs {
        mesh.uvs.extend(m.uvs.iter().copied());
    } else {
        mesh.uvs
            .extend(std::iter::repeat_n(Vec2::ZERO, m.positions.len()));
    }
    let normal = |i: u32| mesh.normals[(i + base) as usize];
    let flat_normals = has_normals
        && m.indices
            .iter()
            .all(|t| normal(t[0]) == normal(t[1]) && normal(t[0]) == normal(t[2]));
    for tri in &m.indices {
        let idx = [tri[0] + base, tri[1] + base, tri[2] + base];
        let p0 = mesh.positions[idx[0] as usize];
        let p1 = mesh.positions[idx[1] as usize];
        let p2 = mesh.positions[idx[2] as usize];
        if (p1 - p0).cross(p2 - p0).length_squared() == 0.0 {
            continue;
        }
        prims.push(PrimInfo {
            ng: (p1 - p0).cross(p2 - p0).normalize_or(Vec3A::Z),
            indices: idx,
            shape,
        });
        mesh.triangle_count += 1;
        geoms.push(PrimGeom::Triangle { p0, p1, p2 });
    }
    ShapeKind::Mesh {
        has_normals,
        flat_normals,
        has_uvs,
    }
}

fn build_material(b: &desc::Bsdf, torrey_dialect: bool) -> Material {
    let color = |c: &desc::ColorParam| match c {
        desc::ColorParam::Constant(v) => ColorSource::Constant((*v).into()),
        desc::ColorParam::Texture(t) => ColorSource::Texture(*t as u32),
    };
    let (model, reflectance) = BsdfModel::from_kind(&b.kind);
    let reflectance = color(reflectance);
    Material {
        model,
        reflectance,
        two_sided: b.two_sided || torrey_dialect,
        normal_map: b.normal_map.map(|t| t as u32),
    }
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
            ShapeKind::Mesh {
                flat_normals: true,
                ..
            }
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
            ShapeKind::Mesh {
                has_normals: true,
                flat_normals: false,
                ..
            }
        ));
    }
}
