//! torrey's scene parser: Mitsuba-style XML (torrey 0.5/0.6 and Mitsuba 3 dialects) to a plain
//! [`Scene`] description. No rendering types live here.
//!
//! Every error carries `file:line:column`; harmless oddities (unknown parameters, media) become
//! [`Warning`]s in [`Scene::warnings`]. See `docs/scene-format.md` for all plugins and
//! parameters.

mod cie_table;
mod context;
mod error;
mod files;
mod include;
mod limits;
pub mod media;
mod mesh;
mod plugins;
mod props;
pub mod scene;
mod spectrum;
mod transform;
mod values;
pub mod vol;
mod xml;

pub use error::ParseError;
pub use limits::Limits;
pub use media::{GridVolume, Medium, MediumId, Phase, Volume};
pub use mesh::smooth_normals;
pub use scene::*;

use std::path::Path;

/// Every plugin type the parser accepts, per element kind (`bsdf`, `shape`, `emitter`,
/// `texture`, `sensor`, `film`, `rfilter`, `sampler`, `integrator`, `medium`, `phase`,
/// `volume`): what docs/scene-format.md
/// must document.
pub fn accepted_plugins() -> Vec<(&'static str, &'static [&'static str])> {
    vec![
        ("bsdf", plugins::bsdf::KNOWN),
        ("shape", plugins::shape::KNOWN),
        ("emitter", plugins::emitter::KNOWN),
        ("texture", plugins::texture::KNOWN),
        ("sensor", plugins::sensor::SENSORS),
        ("film", plugins::sensor::FILMS),
        ("rfilter", plugins::sensor::RFILTERS),
        ("sampler", plugins::sensor::SAMPLERS),
        ("integrator", plugins::integrator::INTEGRATORS),
        ("medium", plugins::medium::MEDIA),
        ("phase", plugins::medium::PHASES),
        ("volume", plugins::medium::VOLUMES),
    ]
}

/// How to read a scene: `-D` overrides, an optional dialect that replaces the detected one, and
/// the caps on what the scene may make us read and allocate.
#[derive(Clone, Debug, Default)]
pub struct LoadOptions {
    /// `-D name=value` pairs: they win over every `<default>`.
    pub overrides: Vec<(String, String)>,
    /// `Some` forces the dialect (the command line's `--dialect`).
    pub dialect: Option<Dialect>,
    pub limits: Limits,
}

/// Reads a scene file; `overrides` are `-D name=value` pairs that replace `<default>` values.
/// Relative file names inside are found as Mitsuba 3's file resolver finds them (the scene file's
/// `<path>` folders, then its folder; see docs/scene-format.md).
pub fn load_scene(path: &Path, overrides: &[(String, String)]) -> Result<Scene, ParseError> {
    load_scene_with(
        path,
        &LoadOptions {
            overrides: overrides.to_vec(),
            ..LoadOptions::default()
        },
    )
}

/// [`load_scene`] with caps other than the default ones.
pub fn load_scene_with_limits(
    path: &Path,
    overrides: &[(String, String)],
    limits: &Limits,
) -> Result<Scene, ParseError> {
    load_scene_with(
        path,
        &LoadOptions {
            overrides: overrides.to_vec(),
            dialect: None,
            limits: limits.clone(),
        },
    )
}

/// Reads a scene file with [`LoadOptions`]. Only regular files no larger than the limit are
/// read.
pub fn load_scene_with(path: &Path, options: &LoadOptions) -> Result<Scene, ParseError> {
    let limits = &options.limits;
    let fail = |message: String| ParseError {
        location: SourceLocation {
            file: path.to_path_buf(),
            line: 1,
            column: 1,
        },
        message,
    };
    let size =
        files::regular_file_size(path).map_err(|m| fail(format!("cannot read scene file: {m}")))?;
    if size > limits.scene_bytes {
        return Err(fail(format!(
            "the scene file is {size} bytes, more than the limit of {} (raise with --limit scene_bytes=N)",
            limits.scene_bytes
        )));
    }
    let text =
        std::fs::read_to_string(path).map_err(|e| fail(format!("cannot read scene file: {e}")))?;
    parse_scene_str_with(&text, path, options)
}

/// Same, from a string; `path` names the file for messages and resolving relative file names.
pub fn parse_scene_str(
    xml: &str,
    path: &Path,
    overrides: &[(String, String)],
) -> Result<Scene, ParseError> {
    parse_scene_str_with(
        xml,
        path,
        &LoadOptions {
            overrides: overrides.to_vec(),
            ..LoadOptions::default()
        },
    )
}

/// [`parse_scene_str`] with caps other than the default ones.
pub fn parse_scene_str_with_limits(
    xml: &str,
    path: &Path,
    overrides: &[(String, String)],
    limits: &Limits,
) -> Result<Scene, ParseError> {
    parse_scene_str_with(
        xml,
        path,
        &LoadOptions {
            overrides: overrides.to_vec(),
            dialect: None,
            limits: limits.clone(),
        },
    )
}

/// Same, with [`LoadOptions`].
pub fn parse_scene_str_with(
    xml: &str,
    path: &Path,
    options: &LoadOptions,
) -> Result<Scene, ParseError> {
    let root = xml::parse_document(xml, path, options.limits.nesting_depth)?;
    plugins::parse_scene(
        root,
        path,
        &options.overrides,
        options.dialect,
        &options.limits,
    )
}
