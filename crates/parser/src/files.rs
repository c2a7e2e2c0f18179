//! Input files named by a scene. Only regular files are read: a device (`/dev/zero`), a FIFO
//! or a folder would make a reader block or read forever, and a regular file's size bounds
//! what reading it can allocate.

use crate::context::Ctx;
use crate::error::Result;
use crate::xml::Attr;
use std::path::{Path, PathBuf};

/// The size of `path` if it is a regular file (symbolic links are followed); otherwise why not.
pub(crate) fn regular_file_size(path: &Path) -> std::result::Result<u64, String> {
    let meta = std::fs::metadata(path).map_err(|e| e.to_string())?;
    if !meta.is_file() {
        return Err(format!("'{}' is not a regular file", path.display()));
    }
    Ok(meta.len())
}

/// Resolves a file name given in the scene (`kind` is "mesh" or "texture") and checks that it
/// is a regular file; errors point at the attribute.
pub(crate) fn input_file(ctx: &Ctx, attr: &Attr, kind: &str) -> Result<PathBuf> {
    let path = ctx.resolve(&attr.value, attr.value_pos).map_err(|looked| {
        ctx.err(
            attr.value_pos,
            format!("{kind} file '{}' not found ({looked})", attr.value),
        )
    })?;
    match std::fs::metadata(&path) {
        Ok(meta) if meta.is_file() => Ok(path),
        Ok(_) => Err(ctx.err(
            attr.value_pos,
            format!(
                "{kind} file '{}' is not a regular file (looked at '{}')",
                attr.value,
                path.display()
            ),
        )),
        Err(e) if e.kind() == std::io::ErrorKind::NotFound => Err(ctx.err(
            attr.value_pos,
            format!(
                "{kind} file '{}' not found (looked for '{}')",
                attr.value,
                path.display()
            ),
        )),
        Err(e) => Err(ctx.err(
            attr.value_pos,
            format!("cannot read {kind} file '{}': {e}", attr.value),
        )),
    }
}
