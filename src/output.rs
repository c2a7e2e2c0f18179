//! Writing result images so that a reader never sees a half-written file: each image goes to a
//! temporary file in the target folder (same file system, so a rename is atomic) and is renamed
//! into place only when every image of the set is complete. A full disk or a failed encoder
//! leaves the previous files untouched and no temporary behind; several renders writing the same
//! path leave one complete set of files, never a mixture inside one file.

use std::path::{Path, PathBuf};
use torrey_texture::Image;

/// What an output file holds.
pub enum Content<'a> {
    /// An 8-bit sRGB PNG.
    Png(&'a Image),
    /// A render part's EXR: mean, variance, sample counts and the metadata that merging needs.
    Part(&'a torrey_parts::Part),
}

/// One image to write: where, and what.
pub struct Output<'a> {
    pub path: PathBuf,
    pub content: Content<'a>,
}

impl Output<'_> {
    fn write(&self, to: &Path) -> Result<(), String> {
        match self.content {
            Content::Png(image) => {
                torrey_texture::write_png_srgb(to, image).map_err(|e| e.to_string())
            }
            Content::Part(part) => torrey_parts::write_part(to, part),
        }
    }
}

/// A temporary name beside `path`: hidden, unique to this process and output.
fn temporary(path: &Path, index: usize) -> PathBuf {
    let name = path
        .file_name()
        .map_or("output".into(), |n| n.to_string_lossy().into_owned());
    path.with_file_name(format!(".{name}.{}-{index}.tmp", std::process::id()))
}

/// Writes every output to its temporary file, then renames them all into place. If any write
/// fails, the temporaries are removed and nothing is renamed; if a rename fails (a target that
/// is a folder is refused before any), the images already moved are removed: all or none.
pub fn write_all(outputs: &[Output]) -> Result<(), String> {
    let remove_all = |paths: &[PathBuf]| {
        for p in paths {
            let _ = std::fs::remove_file(p);
        }
    };
    for out in outputs {
        if out.path.is_dir() {
            return Err(format!(
                "{}: cannot write image: it is a folder (no image was written)",
                out.path.display()
            ));
        }
    }
    // Encoded side by side (the EXR's deflate and the PNG's each take tens of milliseconds
    // for a small film, seconds at 4K), each to a temporary beside its target.
    use rayon::prelude::*;
    let temporaries: Vec<PathBuf> = (0..outputs.len())
        .map(|i| temporary(&outputs[i].path, i))
        .collect();
    let results: Vec<Result<(), String>> = outputs
        .par_iter()
        .zip(&temporaries)
        .map(|(out, tmp)| out.write(tmp))
        .collect();
    if let Some((e, (out, tmp))) = results
        .into_iter()
        .zip(outputs.iter().zip(&temporaries))
        .find_map(|(r, o)| r.err().map(|e| (e, o)))
    {
        remove_all(&temporaries);
        // Name the file the user asked for, not the temporary.
        let e = e.replace(&tmp.display().to_string(), &out.path.display().to_string());
        return Err(format!("{e} (no image was written)"));
    }
    let written = temporaries;
    let mut moved: Vec<PathBuf> = Vec::new();
    for (out, tmp) in outputs.iter().zip(&written) {
        if let Err(e) = std::fs::rename(tmp, &out.path) {
            remove_all(&written);
            remove_all(&moved);
            return Err(format!(
                "{}: cannot move the finished image into place: {e} (no image was written)",
                out.path.display()
            ));
        }
        moved.push(out.path.clone());
    }
    Ok(())
}

/// A PNG alone (for `torrey compare`'s pictures).
pub fn png<'a>(path: &Path, image: &'a Image) -> Output<'a> {
    png_output(path, image)
}

fn png_output<'a>(path: &Path, image: &'a Image) -> Output<'a> {
    Output {
        path: path.to_path_buf(),
        content: Content::Png(image),
    }
}
