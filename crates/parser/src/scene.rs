//! The plain scene description: what a scene file says, with every name resolved and every
//! default applied, but no rendering types. Both XML dialects (torrey 0.5/0.6 camelCase and
//! Mitsuba 3 snake_case) map onto these types, so the renderer never sees the dialect except
//! through [`Dialect`], which decides the sidedness convention.
//!
//! Geometry is stored in object space together with its `to_world` transform; the renderer
//! applies it. Colours are linear RGB.

use glam::{Affine2, Mat4, Vec2, Vec3};
use std::path::PathBuf;

/// Index into [`Scene::bsdfs`].
pub type BsdfId = usize;
/// Index into [`Scene::textures`].
pub type TextureId = usize;

/// Which rules a scene is read with. Version 2.0 and up is Mitsuba 3; 1.x is the torrey
/// course's; 0.5/0.6 files are the torrey dialect when every plugin in them is one the course's
/// renderer reads, otherwise Mitsuba's (`plugins/dialect.rs`).
/// [`crate::LoadOptions::dialect`] overrides the detection.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Dialect {
    /// The torrey course: surfaces shade on both sides; a 0.5 grey sky when no emitter is at
    /// infinity.
    Torrey,
    /// Mitsuba: one-sided bsdfs unless wrapped in `twosided`; no implicit sky.
    Mitsuba3,
}

impl std::fmt::Display for Dialect {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(match self {
            Dialect::Torrey => "torrey",
            Dialect::Mitsuba3 => "mitsuba",
        })
    }
}

/// A position in a scene file, for diagnostics. Lines and columns count from 1.
#[derive(Clone, Debug, PartialEq, Eq, Default)]
pub struct SourceLocation {
    pub file: PathBuf,
    pub line: u32,
    pub column: u32,
}

impl std::fmt::Display for SourceLocation {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(f, "{}:{}:{}", self.file.display(), self.line, self.column)
    }
}

/// A non-fatal remark about the scene (an unknown but harmless parameter, say).
#[derive(Clone, Debug, PartialEq)]
pub struct Warning {
    pub location: SourceLocation,
    pub message: String,
}

impl std::fmt::Display for Warning {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        let message = crate::error::one_line(&self.message);
        write!(f, "{}: warning: {message}", self.location)
    }
}

#[derive(Clone, Debug)]
pub struct Scene {
    /// The scene file this was read from (relative file names inside were found from its folder and its `<path>`s).
    pub path: PathBuf,
    pub dialect: Dialect,
    /// Why [`Scene::dialect`] was chosen (the version, the first plugin the torrey course does
    /// not read with its file:line:column, or an override), for the command line's summary.
    pub dialect_reason: String,
    pub camera: Camera,
    pub film: Film,
    pub sampler: Sampler,
    pub integrator: Integrator,
    pub textures: Vec<Texture>,
    pub bsdfs: Vec<Bsdf>,
    pub shapes: Vec<Shape>,
    /// Every `shapegroup`, its shapes in the group's own space; drawn only through
    /// [`Scene::instances`], which share its geometry.
    pub shape_groups: Vec<ShapeGroup>,
    /// Every `instance`: a shape group placed by a transform.
    pub instances: Vec<Instance>,
    /// Point lights, environment maps and constant backgrounds. Area lights live on their shapes.
    pub lights: Vec<Light>,
    /// Participating media, referred to by shapes and the camera.
    pub media: Vec<crate::media::Medium>,
    /// Every file the scene refers to (meshes, images), resolved, in the order named: what a
    /// copy of the scene must carry along, and what its content hash covers.
    pub files: Vec<PathBuf>,
    pub warnings: Vec<Warning>,
}

/// The camera, Mitsuba 3 semantics: camera space looks along +z, +x is left, +y is up;
/// `to_world` maps camera space to world space.
#[derive(Clone, Debug, PartialEq)]
pub struct Camera {
    /// Projection: perspective pinhole, thin lens or orthographic.
    pub kind: CameraKind,
    pub to_world: Mat4,
    /// Full field of view in degrees along `fov_axis` (perspective and thin lens).
    pub fov_degrees: f32,
    pub fov_axis: FovAxis,
    pub near_clip: f32,
    pub far_clip: f32,
    /// Mitsuba's `principal_point_offset_x/_y`: the image centre moved by these fractions of the
    /// film size (perspective and thin lens).
    pub principal_point_offset: Vec2,
    /// The medium the camera sits in (a `<medium>` or medium `<ref>` in the sensor).
    pub medium: Option<crate::media::MediumId>,
}

#[derive(Clone, Copy, Debug, PartialEq)]
pub enum CameraKind {
    Perspective,
    /// Depth of field: a lens of `aperture_radius` focused at `focus_distance`.
    ThinLens {
        aperture_radius: f32,
        focus_distance: f32,
    },
    /// Parallel rays; `to_world`'s scale sets the visible extent (Mitsuba: [-1, 1]^2 before it).
    Orthographic,
}

#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum FovAxis {
    X,
    Y,
    Diagonal,
    Smaller,
    Larger,
}

#[derive(Clone, Debug, PartialEq)]
pub struct Film {
    pub width: u32,
    pub height: u32,
    /// Output file name from the scene, if it names one.
    pub filename: Option<String>,
    pub filter: PixelFilter,
    /// Mitsuba's crop window: only this part of the `width` x `height` film is rendered.
    pub crop: Option<CropWindow>,
}

/// A sub-rectangle of the film in pixels (`crop_offset_x/y`, `crop_width/height`).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct CropWindow {
    pub offset_x: u32,
    pub offset_y: u32,
    pub width: u32,
    pub height: u32,
}

impl CropWindow {
    /// `(offset x, offset y, width, height)`.
    pub fn rect(&self) -> (u32, u32, u32, u32) {
        (self.offset_x, self.offset_y, self.width, self.height)
    }
}

#[derive(Clone, Copy, Debug, PartialEq)]
pub enum PixelFilter {
    /// One pixel wide box: torrey's default and the references'.
    Box,
    /// Mitsuba's gaussian (stddev in pixels; Mitsuba's default 0.5).
    Gaussian { stddev: f32 },
    /// Mitsuba's tent filter (radius in pixels).
    Tent { radius: f32 },
    /// Mitchell-Netravali with parameters B and C (Mitsuba's defaults 1/3, 1/3), radius 2.
    Mitchell { b: f32, c: f32 },
    /// Catmull-Rom: Mitchell-Netravali with B = 0, C = 1/2, radius 2.
    CatmullRom,
    /// Windowed sinc with `lobes` lobes (Mitsuba's default 3); radius = lobes.
    Lanczos { lobes: u32 },
}

#[derive(Clone, Debug, PartialEq)]
pub struct Sampler {
    /// Mitsuba's sample count after its sampler's rounding (a square for `stratified` and
    /// `multijitter`, a power of two for `ldsampler`, a prime's square for `orthogonal`).
    pub sample_count: u32,
    pub seed: u64,
    /// The scene's sampler type; torrey draws its own samples whatever it is.
    pub kind: String,
}

/// The integrator: which one, with its parameters (one parser file per plugin:
/// plugins/integrator/).
#[derive(Clone, Debug, PartialEq)]
pub struct Integrator {
    /// The plugin's type as written (`path`, `direct`, `volpath`, ...; a wrapper's inner one),
    /// for messages.
    pub type_name: String,
    pub kind: IntegratorKind,
    /// Mitsuba's `aov` integrator around it: the AOVs to write beside its image.
    pub aovs: Option<Aovs>,
}

/// Mitsuba's `aov` integrator: the arbitrary output variables it writes, each a per-pixel mean
/// over the camera rays' first hits, beside the image of the integrator it wraps.
#[derive(Clone, Debug, PartialEq)]
pub struct Aovs {
    /// The layer name of the wrapped integrator's image (its `name` attribute, Mitsuba's
    /// `_arg_0` without one); None when the `aov` wraps no integrator (its image is then black,
    /// as in Mitsuba).
    pub inner: Option<String>,
    /// In the order of the `aovs` string.
    pub list: Vec<Aov>,
}

/// One entry `name:type` of the `aovs` string.
#[derive(Clone, Debug, PartialEq)]
pub struct Aov {
    pub name: String,
    pub kind: AovKind,
}

/// The AOV types torrey writes (Mitsuba's, less `boundary_test`).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum AovKind {
    Albedo,
    Depth,
    Position,
    Uv,
    GeoNormal,
    ShNormal,
    DpDu,
    DpDv,
    DuvDx,
    DuvDy,
    PrimIndex,
    ShapeIndex,
}

impl AovKind {
    /// The type as the `aovs` string names it.
    pub fn from_name(name: &str) -> Option<Self> {
        Some(match name {
            "albedo" => AovKind::Albedo,
            "depth" => AovKind::Depth,
            "position" => AovKind::Position,
            "uv" => AovKind::Uv,
            "geo_normal" => AovKind::GeoNormal,
            "sh_normal" => AovKind::ShNormal,
            "dp_du" => AovKind::DpDu,
            "dp_dv" => AovKind::DpDv,
            "duv_dx" => AovKind::DuvDx,
            "duv_dy" => AovKind::DuvDy,
            "prim_index" => AovKind::PrimIndex,
            "shape_index" => AovKind::ShapeIndex,
            _ => return None,
        })
    }

    /// The channel suffixes Mitsuba gives the type: `name.T` for a depth, `name.X/Y/Z` for a
    /// position, ...
    pub fn suffixes(self) -> &'static [&'static str] {
        match self {
            AovKind::Albedo => &["R", "G", "B"],
            AovKind::Depth => &["T"],
            AovKind::Uv | AovKind::DuvDx | AovKind::DuvDy => &["U", "V"],
            AovKind::Position
            | AovKind::GeoNormal
            | AovKind::ShNormal
            | AovKind::DpDu
            | AovKind::DpDv => &["X", "Y", "Z"],
            AovKind::PrimIndex | AovKind::ShapeIndex => &["I"],
        }
    }
}

impl Aovs {
    /// The EXR channel names of the AOVs, in order (`dd.y:depth` gives `dd.y.T`).
    pub fn channel_names(&self) -> Vec<String> {
        self.list
            .iter()
            .flat_map(|a| a.kind.suffixes().iter().map(|s| format!("{}.{s}", a.name)))
            .collect()
    }
}

/// The integrators torrey renders.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum IntegratorKind {
    /// Mitsuba's `path`, and the types rendered by the path tracer.
    Path(PathParams),
    /// Mitsuba's `direct`.
    Direct(DirectParams),
    /// Mitsuba's `volpath` (`mis` false) and `volpathmis` (true): the path tracer with
    /// participating media; both converge to the same image.
    VolPath { params: PathParams, mis: bool },
}

/// The path tracer's parameters.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct PathParams {
    /// Mitsuba's `max_depth`: path segments; 1 = emitters seen directly, 2 = direct light,
    /// -1 = unbounded.
    pub max_depth: i32,
    /// Russian roulette starts at this depth (Mitsuba's `rr_depth`, default 5).
    pub rr_depth: i32,
    /// Mitsuba's `hide_emitters`: emitters seen directly by the camera are black.
    pub hide_emitters: bool,
}

/// `direct`'s parameters: emitter and BSDF samples per shading point (Mitsuba's
/// `emitter_samples`, `bsdf_samples`, both defaulting to `shading_samples`, 1).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct DirectParams {
    pub emitter_samples: u32,
    pub bsdf_samples: u32,
    pub hide_emitters: bool,
}

impl Integrator {
    /// Path segments followed: `direct` follows two (the camera ray and one bounce).
    pub fn max_depth(&self) -> i32 {
        match self.kind {
            IntegratorKind::Path(p) | IntegratorKind::VolPath { params: p, .. } => p.max_depth,
            IntegratorKind::Direct(_) => 2,
        }
    }

    /// Where Russian roulette starts (`direct` never reaches it).
    pub fn rr_depth(&self) -> i32 {
        match self.kind {
            IntegratorKind::Path(p) | IntegratorKind::VolPath { params: p, .. } => p.rr_depth,
            IntegratorKind::Direct(_) => 5,
        }
    }

    pub fn hide_emitters(&self) -> bool {
        match self.kind {
            IntegratorKind::Path(p) | IntegratorKind::VolPath { params: p, .. } => p.hide_emitters,
            IntegratorKind::Direct(d) => d.hide_emitters,
        }
    }
}

/// A colour that may be a constant or come from a texture.
#[derive(Clone, Debug, PartialEq)]
pub enum ColorParam {
    Constant(Vec3),
    Texture(TextureId),
}

#[derive(Clone, Debug, PartialEq)]
pub struct Texture {
    pub id: Option<String>,
    pub kind: TextureKind,
}

#[derive(Clone, Debug, PartialEq)]
pub enum TextureKind {
    Bitmap(Bitmap),
    /// Mitsuba's checkerboard: color0 where floor(u') + floor(v') is even, else color1.
    Checkerboard {
        color0: Vec3,
        color1: Vec3,
        to_uv: Affine2,
    },
    /// Mitsuba's `mesh_attribute`: the attribute `name` (`vertex_...`, interpolated with the
    /// hit's barycentrics, or `face_...`, constant per face) of the mesh it is evaluated on,
    /// times `scale`. One channel is read as grey.
    MeshAttribute {
        name: String,
        scale: f32,
        location: SourceLocation,
    },
    /// Mitsuba's `rawconstant`: `value` returned as it is, without colour conversion or range
    /// checks (negative values too); one channel (`<float>`) is read as grey, three
    /// (`<vector>`) cannot be read as a float parameter. Where a bsdf or an emitter reads it,
    /// the parser puts the value in place as a [`ColorParam::Constant`].
    RawConstant {
        value: Vec3,
        channels: u8,
    },
}

#[derive(Clone, Debug, PartialEq)]
pub struct Bitmap {
    /// Absolute (resolved) path of the image.
    pub filename: PathBuf,
    /// Texture-coordinate transform: uv' = to_uv(uv). torrey's uscale/vscale/uoffset/voffset
    /// give `Affine2::from_scale_angle_translation((uscale, vscale), 0, (uoffset, voffset))`;
    /// Mitsuba 3's `to_uv` transform maps directly.
    pub to_uv: Affine2,
    /// Do not sRGB-decode 8-bit images (normal maps are always raw).
    pub raw: bool,
    pub filter: FilterType,
    pub wrap: WrapMode,
    /// Where the `filename` parameter was given, so that an image that fails to decode at render
    /// time is reported at its place in the scene file.
    pub location: SourceLocation,
}

#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum FilterType {
    Bilinear,
    Nearest,
}

#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum WrapMode {
    Repeat,
    Mirror,
    Clamp,
}

#[derive(Clone, Debug, PartialEq)]
pub struct Bsdf {
    pub id: Option<String>,
    pub kind: BsdfKind,
    /// Wrapped in `twosided`. In torrey-dialect scenes every bsdf is two-sided anyway.
    pub two_sided: bool,
    /// Tangent-space normal map (a raw bitmap texture), from the seed dialect's
    /// `<texture name="normal_map">` or Mitsuba 3's `normalmap` wrapper.
    pub normal_map: Option<TextureId>,
    /// Mitsuba 3's `bumpmap` wrapper.
    pub bump_map: Option<BumpMap>,
    /// The options of Mitsuba 3's `normalmap` and `bumpmap` wrappers.
    pub perturb: PerturbOptions,
}

/// Mitsuba 3's `bumpmap`: a height texture whose uv gradient, times `scale`, tilts the
/// shading normal.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct BumpMap {
    pub texture: TextureId,
    pub scale: f32,
}

/// What Mitsuba 3's `normalmap` and `bumpmap` do besides tilting the normal.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct PerturbOptions {
    /// `flip_invalid_normals` (default true): a tilted normal that the incident direction sees
    /// from the other side is mirrored about the unperturbed normal.
    pub flip_invalid_normals: bool,
    /// `use_shadowing_function` (default true): Estevez et al.'s microfacet shadowing term.
    pub use_shadowing_function: bool,
}

impl Default for PerturbOptions {
    fn default() -> Self {
        Self {
            flip_invalid_normals: true,
            use_shadowing_function: true,
        }
    }
}

#[derive(Clone, Debug, PartialEq)]
pub enum BsdfKind {
    Diffuse {
        reflectance: ColorParam,
    },
    /// torrey's mirror: perfect reflection weighted by Schlick Fresnel with F0 = reflectance.
    Mirror {
        reflectance: ColorParam,
    },
    /// `plastic`: in torrey-dialect scenes the course's Schlick-Fresnel (F0 from `eta`)
    /// weighted mirror over a diffuse base; in Mitsuba-dialect scenes Mitsuba's smooth plastic
    /// (`reflectance` is its diffuse_reflectance, `eta` = int_ior / ext_ior).
    Plastic {
        reflectance: ColorParam,
        eta: f32,
        /// Mitsuba's specular_reflectance (1 by default).
        specular_reflectance: ColorParam,
        /// Mitsuba's `nonlinear`.
        nonlinear: bool,
    },
    /// Normalised Phong lobe around the mirror direction: reflectance (a+1)/(2pi) cos^a.
    Phong {
        reflectance: ColorParam,
        exponent: f32,
    },
    /// Normalised Blinn-Phong: reflectance (a+2)/(4pi(2-2^(-a/2))) (n.h)^a.
    Blinn {
        reflectance: ColorParam,
        exponent: f32,
    },
    /// Microfacet with a Blinn distribution, Schlick Fresnel (F0 = reflectance) and Walter et
    /// al.'s rational Smith shadowing fit.
    BlinnMicrofacet {
        reflectance: ColorParam,
        exponent: f32,
    },
    /// Mitsuba's `dielectric` (`thin`: `thindielectric`); `eta` = int_ior / ext_ior.
    Dielectric {
        eta: f32,
        thin: bool,
        specular_reflectance: ColorParam,
        specular_transmittance: ColorParam,
    },
    /// Mitsuba's `roughdielectric`. Float parameters that may be textured are `ColorParam`s
    /// whose first channel is read.
    RoughDielectric {
        distribution: MicrofacetType,
        alpha_u: ColorParam,
        alpha_v: ColorParam,
        /// Mitsuba's `sample_visible`: sample the visible normals (true) or D(m) cos θm.
        sample_visible: bool,
        eta: f32,
        specular_reflectance: ColorParam,
        specular_transmittance: ColorParam,
    },
    /// Mitsuba's `conductor`: complex IOR eta + i k relative to the outside.
    Conductor {
        eta: ColorParam,
        k: ColorParam,
        specular_reflectance: ColorParam,
    },
    /// Mitsuba's `roughconductor`.
    RoughConductor {
        distribution: MicrofacetType,
        alpha_u: ColorParam,
        alpha_v: ColorParam,
        /// Mitsuba's `sample_visible`: sample the visible normals (true) or D(m) cos θm.
        sample_visible: bool,
        eta: ColorParam,
        k: ColorParam,
        specular_reflectance: ColorParam,
    },
    /// Mitsuba's `twosided` with two nested bsdfs: `front` seen from the normal's side,
    /// `back` from the other (evaluated with directions mirrored to its front).
    TwoSided {
        front: Box<Bsdf>,
        back: Box<Bsdf>,
    },
    /// Mitsuba's `blendbsdf`: (1 − weight) · first + weight · second.
    Blend {
        weight: ColorParam,
        first: Box<Bsdf>,
        second: Box<Bsdf>,
    },
    /// Mitsuba's `null`: an invisible surface; rays pass straight through (a bounce).
    Null,
    /// Mitsuba's `mask`: `nested` with probability `opacity`, else passed through as `null`.
    Mask {
        opacity: ColorParam,
        nested: Box<Bsdf>,
    },
    /// Mitsuba's `roughplastic` (isotropic).
    RoughPlastic {
        distribution: MicrofacetType,
        alpha: f32,
        /// Mitsuba's `sample_visible`.
        sample_visible: bool,
        diffuse_reflectance: ColorParam,
        specular_reflectance: ColorParam,
        eta: f32,
        nonlinear: bool,
    },
    /// Mitsuba's `principled` (the Disney BSDF).
    Principled(Box<PrincipledDesc>),
    /// Mitsuba's `principledthin` (the thin-sheet Disney BSDF).
    PrincipledThin(Box<PrincipledThinDesc>),
}

/// Mitsuba's `principled` parameters; the float ones may be textures (first channel).
#[derive(Clone, Debug, PartialEq)]
pub struct PrincipledDesc {
    pub base_color: ColorParam,
    pub roughness: ColorParam,
    pub anisotropic: ColorParam,
    pub metallic: ColorParam,
    pub spec_trans: ColorParam,
    pub spec_tint: ColorParam,
    pub sheen: ColorParam,
    pub sheen_tint: ColorParam,
    pub flatness: ColorParam,
    pub clearcoat: ColorParam,
    pub clearcoat_gloss: ColorParam,
    /// Interior/exterior IOR, given or derived from `specular`.
    pub eta: f32,
    pub main_specular_sampling_rate: f32,
    pub clearcoat_sampling_rate: f32,
    pub diffuse_reflectance_sampling_rate: f32,
}

/// Mitsuba's `principledthin` parameters; the float ones may be textures (first channel).
#[derive(Clone, Debug, PartialEq)]
pub struct PrincipledThinDesc {
    pub base_color: ColorParam,
    pub roughness: ColorParam,
    pub anisotropic: ColorParam,
    pub spec_trans: ColorParam,
    pub spec_tint: ColorParam,
    pub sheen: ColorParam,
    pub sheen_tint: ColorParam,
    pub flatness: ColorParam,
    pub diff_trans: ColorParam,
    pub eta: ColorParam,
    pub specular_reflectance_sampling_rate: f32,
    pub specular_transmittance_sampling_rate: f32,
    pub diffuse_reflectance_sampling_rate: f32,
    pub diffuse_transmittance_sampling_rate: f32,
}

/// Mitsuba's microfacet `distribution`.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum MicrofacetType {
    Beckmann,
    Ggx,
}

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

/// Mitsuba's `instance`: shape group [`Instance::group`] (an index into [`Scene::shape_groups`])
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

#[derive(Clone, Debug, PartialEq)]
pub enum Light {
    /// Radiant intensity in W/sr.
    Point { position: Vec3, intensity: Vec3 },
    /// Constant radiance from every direction (torrey's `<background>`, Mitsuba's `constant`).
    Constant { radiance: Vec3 },
    /// A light at infinity (Mitsuba's `directional`): `irradiance` (W/m²) on a surface facing
    /// it, arriving along the unit `direction` the light travels.
    Directional { direction: Vec3, irradiance: Vec3 },
    /// Mitsuba's `spot`: a point light at the origin of `to_world` shining along its +z with
    /// radiant `intensity` (W/sr) on the axis, full out to `beam_width` and falling linearly in
    /// angle to zero at `cutoff_angle` (both radians).
    Spot {
        to_world: Mat4,
        intensity: Vec3,
        cutoff_angle: f32,
        beam_width: f32,
        /// Mitsuba's `texture`: projected through the cone, multiplying the intensity; uv
        /// (0.5 + x / (2 z tan(cutoff)), 0.5 + y / (2 z tan(cutoff))) of the light-local direction.
        texture: Option<TextureId>,
    },
    /// Lat-long environment map in Mitsuba 3's orientation, rotated by `to_world`.
    Envmap {
        bitmap: Bitmap,
        scale: f32,
        to_world: Mat4,
    },
    /// Mitsuba's `projector`: a pinhole at `to_world`'s origin projecting `irradiance` along its
    /// +z, the field of view given as a perspective camera's (`fov_degrees` along `fov_axis` of
    /// the irradiance texture's image), times `scale`.
    Projector {
        to_world: Mat4,
        irradiance: ColorParam,
        scale: f32,
        fov_degrees: f32,
        fov_axis: FovAxis,
    },
}
