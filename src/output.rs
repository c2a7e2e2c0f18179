//! Writing result images so that a reader never sees a half-written file: each image goes to a
//! temporary file in the target folder (same file system, so a rename is atomic) and is renamed
//! into place only when every image of the set is complete. A full disk or a failed encoder
//! leaves the previous files untouched and no temporary behind; several renders writing the same
//! path leave one complete set of files, never a mixture inside one file.

use std::path::{Path, PathBuf};
use torrey_texture::Image;

/// One image to write: where, and in which format.
pub struct Output<'a> {
    pub path: PathBuf,
    pub image: &'a Image,
    /// Linear float EXR, or 8-bit sRGB PNG.
    pub exr: bool,
}

impl Output<'_> {
    fn write(&self, to: &Path) -> Result<(), String> {
        if self.exr {
            torrey_texture::write_exr(to, self.image)
        } else {
            torrey_texture::write_png_srgb(to, self.image)
        }
        .map_err(|e| e.to_string())
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
    let mut written: Vec<PathBuf> = Vec::new();
    for (i, out) in outputs.iter().enumerate() {
        let tmp = temporary(&out.path, i);
        if let Err(e) = out.write(&tmp) {
            let _ = std::fs::remove_file(&tmp);
            remove_all(&written);
            // Name the file the user asked for, not the temporary.
            let e = e.replace(&tmp.display().to_string(), &out.path.display().to_string());
            return Err(format!("{e} (no image was written)"));
        }
        written.push(tmp);
    }
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

/// The usual pair: a linear EXR and a PNG from `png_image`.
pub fn exr_and_png<'a>(
    exr: &Path,
    image: &'a Image,
    png: &Path,
    png_image: &'a Image,
) -> Vec<Output<'a>> {
    vec![
        Output {
            path: exr.to_path_buf(),
            image,
            exr: true,
        },
        Output {
            path: png.to_path_buf(),
            image: png_image,
            exr: false,
        },
    ]
}

/// A PNG alone (for `torrey compare`'s pictures).
pub fn png<'a>(path: &Path, image: &'a Image) -> Output<'a> {
    Output {
        path: path.to_path_buf(),
        image,
        exr: false,
    }
}
