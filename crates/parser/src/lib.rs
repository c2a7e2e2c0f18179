//! torrey's scene parser: Mitsuba-style XML (torrey 0.5/0.6 and Mitsuba 3 dialects) to a plain
//! [`Scene`] description. No rendering types live here.
//!
//! Every error carries `file:line:column`; harmless oddities (unknown parameters, media) become
//! [`Warning`]s in [`Scene::warnings`]. See `docs/scene-format.md` for all plugins and
//! parameters.

mod cie_table;
mod context;
mod error;
mod include;
mod mesh;
mod plugins;
mod props;
pub mod scene;
mod spectrum;
mod transform;
mod values;
mod xml;

pub use error::ParseError;
pub use mesh::smooth_normals;
pub use scene::*;

use std::path::Path;

/// Every plugin type the parser accepts, per element kind (`bsdf`, `shape`, `emitter`,
/// `texture`, `sensor`, `film`, `rfilter`, `sampler`, `integrator`): what docs/scene-format.md
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
        ("integrator", plugins::sensor::INTEGRATORS),
    ]
}

/// How to read a scene: `-D` overrides and an optional dialect that replaces the detected one.
#[derive(Clone, Debug, Default)]
pub struct LoadOptions {
    /// `-D name=value` pairs: they win over every `<default>`.
    pub overrides: Vec<(String, String)>,
    /// `Some` forces the dialect (the command line's `--dialect`).
    pub dialect: Option<Dialect>,
}

/// Reads a scene file; `overrides` are `-D name=value` pairs that replace `<default>` values.
/// Relative file names inside are resolved against the scene file's folder.
pub fn load_scene(path: &Path, overrides: &[(String, String)]) -> Result<Scene, ParseError> {
    load_scene_with(
        path,
        &LoadOptions {
            overrides: overrides.to_vec(),
            dialect: None,
        },
    )
}

/// Reads a scene file with [`LoadOptions`].
pub fn load_scene_with(path: &Path, options: &LoadOptions) -> Result<Scene, ParseError> {
    let text = std::fs::read_to_string(path).map_err(|e| ParseError {
        location: SourceLocation {
            file: path.to_path_buf(),
            line: 1,
            column: 1,
        },
        message: format!("cannot read scene file: {e}"),
    })?;
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
            dialect: None,
        },
    )
}

/// Same, with [`LoadOptions`].
pub fn parse_scene_str_with(
    xml: &str,
    path: &Path,
    options: &LoadOptions,
) -> Result<Scene, ParseError> {
    let root = xml::parse_document(xml, path)?;
    plugins::parse_scene(root, path, &options.overrides, options.dialect)
}
