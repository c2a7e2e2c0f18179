//! The plain scene description: what a scene file says, with every name resolved and every
//! default applied, but no rendering types. Both XML dialects (torrey 0.5/0.6 camelCase and
//! Mitsuba 3 snake_case) map onto these types, so the renderer never sees the dialect except
//! through [`Dialect`], which decides the sidedness convention.
//!
//! Geometry is stored in object space together with its `to_world` transform; the renderer
//! applies it. Colours are linear RGB.

mod bsdf;
mod camera;
mod integrator;
mod light;
mod shape;
mod texture;

pub use bsdf::*;
pub use camera::*;
pub use integrator::*;
pub use light::*;
pub use shape::*;
pub use texture::*;

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
