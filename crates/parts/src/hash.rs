//! The scene content hash: which scene a part was rendered from, whatever folder it was read in.

use std::collections::HashMap;
use std::path::Path;
use torrey_parser::{Light, Scene, TextureKind};

/// 64-bit FNV-1a: simple, stable across builds and platforms (unlike std's `DefaultHasher`), and
/// fast enough for scene files (about 1 GB/s).
struct Fnv(u64);

impl Fnv {
    fn new() -> Self {
        Fnv(0xcbf2_9ce4_8422_2325)
    }
    fn bytes(&mut self, data: &[u8]) {
        for &b in data {
            self.0 = (self.0 ^ b as u64).wrapping_mul(0x0100_0000_01b3);
        }
    }
    fn u64(&mut self, v: u64) {
        self.bytes(&v.to_le_bytes());
    }
}

/// Hash of a scene's contents, as 16 hex digits: the scene file's text, the `-D` overrides and the
/// bytes of every file it names (`Scene::files`, in order), but no paths, so a copy of the scene
/// in another folder (a worker's) hashes the same. A missing image is reported at the place in
/// the scene file that names it.
pub fn scene_hash(scene: &Scene, defines: &[(String, String)]) -> Result<String, String> {
    let read = |p: &Path| {
        std::fs::read(p).map_err(|e| match named_at(scene, p) {
            Some(location) => format!(
                "{location}: error: cannot read image file '{}': {e}",
                p.display()
            ),
            None => format!("cannot read {}: {e}", p.display()),
        })
    };
    let files = &scene.files;
    let mut h = Fnv::new();
    let text = read(&scene.path)?;
    h.u64(text.len() as u64);
    h.bytes(&text);
    h.u64(defines.len() as u64);
    for (k, v) in defines {
        for s in [k, v] {
            h.u64(s.len() as u64);
            h.bytes(s.as_bytes());
        }
    }
    // Each distinct file hashed once, in parallel (a furnished interior names tens of megabytes
    // of meshes and images), then their hashes taken in the scene's order.
    use rayon::prelude::*;
    let mut distinct: Vec<&Path> = files.iter().map(|f| f.as_path()).collect();
    distinct.sort_unstable();
    distinct.dedup();
    let hashes: HashMap<&Path, Result<u64, String>> = distinct
        .par_iter()
        .map(|&f| {
            let hash = read(f).map(|data| {
                let mut g = Fnv::new();
                g.u64(data.len() as u64);
                g.bytes(&data);
                g.0
            });
            (f, hash)
        })
        .collect();
    h.u64(files.len() as u64);
    // The first file in the scene's order that cannot be read is the one reported.
    for f in files {
        h.u64(hashes[f.as_path()].clone()?);
    }
    Ok(format!("{:016x}", h.0))
}

/// Where the scene names image `file` (a bitmap texture or an environment map).
fn named_at(scene: &Scene, file: &Path) -> Option<String> {
    let textures = scene.textures.iter().filter_map(|t| match &t.kind {
        TextureKind::Bitmap(b) => Some(b),
        _ => None,
    });
    let envmaps = scene.lights.iter().filter_map(|l| match l {
        Light::Envmap { bitmap, .. } => Some(bitmap),
        _ => None,
    });
    textures
        .chain(envmaps)
        .find(|b| b.filename == file)
        .map(|b| b.location.to_string())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn hash_covers_contents_and_defines_but_not_the_folder() {
        let dir = std::env::temp_dir().join(format!("torrey-hash-{}", std::process::id()));
        let (a, b) = (dir.join("a"), dir.join("b"));
        let xml = r#"<scene version="0.6.0">
  <texture type="bitmap" id="t"><string name="filename" value="t.png"/></texture>
</scene>"#;
        for d in [&a, &b] {
            std::fs::create_dir_all(d).unwrap();
            std::fs::write(d.join("s.xml"), xml).unwrap();
            std::fs::write(d.join("t.png"), "not really a png").unwrap();
        }
        let load = |d: &Path| torrey_parser::load_scene(&d.join("s.xml"), &[]).unwrap();
        let h = |d: &Path, defines: &[(String, String)]| scene_hash(&load(d), defines).unwrap();
        assert_eq!(h(&a, &[]), h(&b, &[]));
        assert_eq!(h(&a, &[]).len(), 16);
        assert_ne!(h(&a, &[]), h(&a, &[("spp".into(), "4".into())]));
        std::fs::write(b.join("t.png"), "another image").unwrap();
        assert_ne!(h(&a, &[]), h(&b, &[]));
        // (The parser checks that images exist; one removed after parsing is found when hashing.)
        let scene = load(&b);
        std::fs::remove_file(b.join("t.png")).unwrap();
        let missing = scene_hash(&scene, &[]).unwrap_err();
        let expected = format!(
            "{}:2:64: error: cannot read image file",
            b.join("s.xml").display()
        );
        assert!(missing.starts_with(&expected), "{missing}");
        std::fs::remove_dir_all(&dir).unwrap();
    }
}
