//! `torrey-fuzz`: mutation fuzzing of torrey's input paths on stable Rust (no cargo-fuzz, no
//! nightly). Each target starts from the project's own files (scenes/*.xml, scenes/meshes,
//! textures/, plus small generated PLY, serialized, JPEG, BMP, TGA and HDR files), mutates them
//! (bit flips, interesting integers, byte and line duplication, deletion, splicing, and
//! replacing number tokens with NaN, inf, 1e39, 4294967296, ...) and feeds them to:
//!
//! - `xml`: the scene parser (`parse_scene_str`), meshes and textures resolved beside the scenes;
//! - `mesh`: the OBJ, PLY and serialized loaders, through a one-shape scene;
//! - `image`: the image decoders (`load_image`);
//! - `render`: parse, build (BVH, textures, lights) and render 8x8 pixels at 1 spp.
//!
//! There is no coverage instrumentation; as a cheap stand-in, an input whose outcome (the error
//! message with digits removed, or success) was not seen before joins the corpus. A panic is
//! caught, its input saved as `OUT/TARGET/panic-N.EXT` and the run exits with status 1. Before
//! each run the input is written to `OUT/TARGET/current.EXT`, so a crash that kills the process
//! (SIGSEGV, allocation abort) leaves it behind; an input running longer than `--timeout` is
//! saved as `hang.EXT` and the run exits with status 3. Run under `ulimit -v` to turn runaway
//! allocations into crashes (`.ci/fuzz.sh` does).
//!
//! ```sh
//! cargo run --profile ci -p torrey-fuzz -- xml --seconds 1800
//! ```

use std::collections::HashSet;
use std::panic::{catch_unwind, AssertUnwindSafe};
use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicU64, Ordering};
use std::time::{Duration, Instant};

/// xorshift64*: small, fast, good enough to pick mutations.
struct Rng(u64);

impl Rng {
    fn next(&mut self) -> u64 {
        self.0 ^= self.0 >> 12;
        self.0 ^= self.0 << 25;
        self.0 ^= self.0 >> 27;
        self.0.wrapping_mul(0x2545_F491_4F6C_DD1D)
    }
    fn below(&mut self, n: usize) -> usize {
        if n == 0 {
            0
        } else {
            (self.next() % n as u64) as usize
        }
    }
    fn chance(&mut self, one_in: usize) -> bool {
        self.below(one_in) == 0
    }
}

#[derive(Clone, Copy, PartialEq, Eq, Debug)]
enum Target {
    Xml,
    Mesh,
    Image,
    Render,
}

impl Target {
    fn name(self) -> &'static str {
        match self {
            Target::Xml => "xml",
            Target::Mesh => "mesh",
            Target::Image => "image",
            Target::Render => "render",
        }
    }
    fn is_text(self, ext: &str) -> bool {
        matches!(ext, "xml" | "obj" | "ply")
    }
}

/// One input: its bytes and the file extension it is written with.
#[derive(Clone)]
struct Input {
    ext: String,
    bytes: Vec<u8>,
}

const INTERESTING_NUMBERS: &[&str] = &[
    "nan",
    "inf",
    "-inf",
    "1e39",
    "-1e39",
    "1e-30",
    "1e30",
    "0",
    "-0",
    "-1",
    "1",
    "2",
    "10",
    "255",
    "65536",
    "2147483647",
    "2147483648",
    "4294967295",
    "4294967296",
    "-2147483649",
    "18446744073709551616",
    "3.4e38",
    "1e-45",
    "0.5",
    "100000",
    "0.25",
    "3",
    "1e-3",
    "1e3",
    "90",
    "-0.5",
    "1e-7",
    "0.999",
];

/// Scene fragments the `xml` and `render` mutators insert: plugins, parameters and transforms,
/// valid and borderline, naming files that exist beside the project's scenes.
const SNIPPETS: &[&str] = &[
    "<shape type=\"sphere\"><float name=\"radius\" value=\"0.5\"/></shape>",
    "<shape type=\"rectangle\"><emitter type=\"area\"><rgb name=\"radiance\" value=\"5\"/></emitter></shape>",
    "<shape type=\"obj\"><string name=\"filename\" value=\"meshes/cube.obj\"/></shape>",
    "<shape type=\"obj\"><string name=\"filename\" value=\"meshes/torus.obj\"/><boolean name=\"face_normals\" value=\"true\"/></shape>",
    "<transform name=\"to_world\"><scale value=\"0\"/></transform>",
    "<transform name=\"to_world\"><rotate y=\"1\" angle=\"90\"/><translate x=\"1e30\"/></transform>",
    "<transform name=\"to_world\"><matrix value=\"1 0 0 0 0 1 0 0 0 0 1 0 0 0 0 1\"/></transform>",
    "<transform name=\"to_world\"><lookat origin=\"0 0 5\" target=\"0 0 0\" up=\"0 1 0\"/></transform>",
    "<float name=\"radius\" value=\"1e-30\"/>",
    "<point name=\"center\" x=\"1e30\" y=\"0\" z=\"0\"/>",
    "<rgb name=\"reflectance\" value=\"10\"/>",
    "<rgb name=\"radiance\" value=\"1e30\"/>",
    "<float name=\"exponent\" value=\"1e30\"/>",
    "<float name=\"fov\" value=\"179.9\"/>",
    "<float name=\"near_clip\" value=\"1e-30\"/>",
    "<integer name=\"max_depth\" value=\"1000\"/>",
    "<integer name=\"rr_depth\" value=\"1\"/>",
    "<bsdf type=\"twosided\"><bsdf type=\"plastic\"><float name=\"eta\" value=\"1e-6\"/></bsdf></bsdf>",
    "<bsdf type=\"mirror\"/>",
    "<bsdf type=\"blinn_microfacet\"><float name=\"exponent\" value=\"0\"/></bsdf>",
    "<bsdf type=\"normalmap\"><texture type=\"bitmap\" name=\"normalmap\"><string name=\"filename\" value=\"../textures/normal_bumps.png\"/></texture><bsdf type=\"diffuse\"/></bsdf>",
    "<texture type=\"bitmap\" name=\"reflectance\"><string name=\"filename\" value=\"../textures/checker.png\"/><float name=\"uscale\" value=\"1e30\"/></texture>",
    "<texture type=\"checkerboard\" name=\"reflectance\"><transform name=\"to_uv\"><scale x=\"1e-30\"/></transform></texture>",
    "<emitter type=\"envmap\"><string name=\"filename\" value=\"../textures/sky_sun.exr\"/><float name=\"scale\" value=\"1e30\"/></emitter>",
    "<emitter type=\"point\"><point name=\"position\" x=\"0\" y=\"0\" z=\"0\"/><rgb name=\"intensity\" value=\"1e30\"/></emitter>",
    "<emitter type=\"constant\"><rgb name=\"radiance\" value=\"0\"/></emitter>",
    "<film type=\"hdrfilm\"><integer name=\"width\" value=\"1\"/><rfilter type=\"gaussian\"><float name=\"stddev\" value=\"1e-30\"/></rfilter></film>",
    "<default name=\"x\" value=\"1e30\"/>",
    "<ref id=\"missing\"/>",
];

/// Attribute values the `xml` and `render` mutators substitute.
const WORDS: &[&str] = &[
    "sphere",
    "rectangle",
    "obj",
    "ply",
    "serialized",
    "diffuse",
    "mirror",
    "plastic",
    "phong",
    "blinn",
    "blinn_microfacet",
    "twosided",
    "normalmap",
    "bitmap",
    "checkerboard",
    "envmap",
    "point",
    "constant",
    "area",
    "perspective",
    "path",
    "direct",
    "hdrfilm",
    "gaussian",
    "tent",
    "box",
    "reflectance",
    "radiance",
    "radius",
    "center",
    "to_world",
    "to_uv",
    "filename",
    "meshes/cube.obj",
    "../textures/sky_sun.exr",
    "../textures/checker.png",
    "nan",
    "1e30",
    "-1",
    "0",
    "$x",
    "true",
    "x",
    "y",
    "diagonal",
    "",
];

const INTERESTING_INTS: &[u32] = &[
    0,
    1,
    2,
    0x7f,
    0x80,
    0xff,
    0x100,
    0x7fff,
    0x8000,
    0xffff,
    0x10000,
    0x7fff_ffff,
    0x8000_0000,
    0xffff_ffff,
    100_000,
];

fn project_root() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("..")
}

fn read_dir_files(dir: &Path, exts: &[&str]) -> Vec<Input> {
    let mut out = Vec::new();
    let Ok(entries) = std::fs::read_dir(dir) else {
        return out;
    };
    let mut paths: Vec<PathBuf> = entries.flatten().map(|e| e.path()).collect();
    paths.sort();
    for p in paths {
        let ext = p
            .extension()
            .map(|e| e.to_string_lossy().to_ascii_lowercase())
            .unwrap_or_default();
        if exts.contains(&ext.as_str()) {
            if let Ok(bytes) = std::fs::read(&p) {
                out.push(Input { ext, bytes });
            }
        }
    }
    out
}

/// A quad as ASCII and binary PLY, and a triangle as a serialized (v4) file.
fn generated_meshes() -> Vec<Input> {
    let header = |format: &str| {
        format!(
            "ply\nformat {format} 1.0\nelement vertex 4\nproperty float x\nproperty float y\nproperty float z\nproperty float nx\nproperty float ny\nproperty float nz\nproperty float u\nproperty float v\nelement face 1\nproperty list uchar int vertex_indices\nend_header\n"
        )
    };
    let verts = [
        [0.0f32, 0.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0],
        [1.0, 0.0, 0.0, 0.0, 0.0, 1.0, 1.0, 0.0],
        [1.0, 1.0, 0.0, 0.0, 0.0, 1.0, 1.0, 1.0],
        [0.0, 1.0, 0.0, 0.0, 0.0, 1.0, 0.0, 1.0],
    ];
    let mut ascii = header("ascii");
    for v in &verts {
        let t: Vec<String> = v.iter().map(|x| x.to_string()).collect();
        ascii += &t.join(" ");
        ascii += "\n";
    }
    ascii += "4 0 1 2 3\n";
    let mut binary = header("binary_little_endian").into_bytes();
    for v in &verts {
        for x in v {
            binary.extend_from_slice(&x.to_le_bytes());
        }
    }
    binary.push(4);
    for i in 0..4i32 {
        binary.extend_from_slice(&i.to_le_bytes());
    }
    let mut payload = Vec::new();
    payload.extend_from_slice(&(0x1000u32 | 0x1 | 0x2).to_le_bytes());
    payload.extend_from_slice(b"tri\0");
    payload.extend_from_slice(&3u64.to_le_bytes());
    payload.extend_from_slice(&1u64.to_le_bytes());
    for p in [[0.0f32, 0.0, 0.0], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0]] {
        for x in p {
            payload.extend_from_slice(&x.to_le_bytes());
        }
    }
    for _ in 0..3 {
        for x in [0.0f32, 0.0, 1.0] {
            payload.extend_from_slice(&x.to_le_bytes());
        }
    }
    for uv in [[0.0f32, 0.0], [1.0, 0.0], [0.0, 1.0]] {
        for x in uv {
            payload.extend_from_slice(&x.to_le_bytes());
        }
    }
    for i in 0..3u32 {
        payload.extend_from_slice(&i.to_le_bytes());
    }
    let mut ser = Vec::new();
    ser.extend_from_slice(&0x041Cu16.to_le_bytes());
    ser.extend_from_slice(&4u16.to_le_bytes());
    ser.extend_from_slice(&miniz_oxide::deflate::compress_to_vec_zlib(&payload, 6));
    ser.extend_from_slice(&0u64.to_le_bytes());
    ser.extend_from_slice(&1u32.to_le_bytes());
    vec![
        Input {
            ext: "ply".into(),
            bytes: ascii.into_bytes(),
        },
        Input {
            ext: "ply".into(),
            bytes: binary,
        },
        Input {
            ext: "serialized".into(),
            bytes: ser,
        },
    ]
}

/// Small JPEG, BMP, TGA, HDR and 16-bit PNG files made with the image crate.
fn generated_images() -> Vec<Input> {
    let rgb = image::RgbImage::from_fn(8, 6, |x, y| {
        image::Rgb([(x * 30) as u8, (y * 40) as u8, 99])
    });
    let mut out = Vec::new();
    for (fmt, ext) in [
        (image::ImageFormat::Jpeg, "jpg"),
        (image::ImageFormat::Bmp, "bmp"),
        (image::ImageFormat::Tga, "tga"),
        (image::ImageFormat::Png, "png"),
    ] {
        let mut buf = std::io::Cursor::new(Vec::new());
        if image::DynamicImage::ImageRgb8(rgb.clone())
            .write_to(&mut buf, fmt)
            .is_ok()
        {
            out.push(Input {
                ext: ext.into(),
                bytes: buf.into_inner(),
            });
        }
    }
    let hdr = image::DynamicImage::ImageRgb8(rgb.clone()).into_rgb32f();
    let mut buf = std::io::Cursor::new(Vec::new());
    if image::DynamicImage::ImageRgb32F(hdr)
        .write_to(&mut buf, image::ImageFormat::Hdr)
        .is_ok()
    {
        out.push(Input {
            ext: "hdr".into(),
            bytes: buf.into_inner(),
        });
    }
    let rgb16 = image::DynamicImage::ImageRgb8(rgb).into_rgb16();
    let mut buf = std::io::Cursor::new(Vec::new());
    if image::DynamicImage::ImageRgb16(rgb16)
        .write_to(&mut buf, image::ImageFormat::Png)
        .is_ok()
    {
        out.push(Input {
            ext: "png".into(),
            bytes: buf.into_inner(),
        });
    }
    out
}

fn seeds(target: Target) -> Vec<Input> {
    let root = project_root();
    match target {
        Target::Xml | Target::Render => read_dir_files(&root.join("scenes"), &["xml"]),
        Target::Mesh => {
            let mut s = read_dir_files(&root.join("scenes/meshes"), &["obj", "ply", "serialized"]);
            s.extend(generated_meshes());
            s
        }
        Target::Image => {
            let mut s = read_dir_files(
                &root.join("textures"),
                &["png", "jpg", "jpeg", "exr", "hdr", "bmp", "tga"],
            );
            s.extend(generated_images());
            s
        }
    }
}

/// Byte range [a, b) of `len` bytes, short ranges favoured.
fn range(rng: &mut Rng, len: usize) -> (usize, usize) {
    let a = rng.below(len + 1);
    let max = (len - a).min(if rng.chance(4) { 4096 } else { 64 });
    (a, a + rng.below(max + 1))
}

/// Applies one random mutation to `data`; `other` is another corpus entry for splicing.
fn mutate_once(rng: &mut Rng, data: &mut Vec<u8>, other: &[u8], ext: &str) {
    let len = data.len();
    // Text keeps its structure most of the time (so that mutants still parse and reach the
    // code behind the parser); bytes are mangled otherwise.
    let choice = match ext {
        "xml" if !rng.chance(8) => [8, 10, 11, 12, 13][rng.below(5)],
        "obj" | "ply" if !rng.chance(5) => [8, 8, 9, 14][rng.below(4)],
        _ => rng.below(8),
    };
    match choice {
        0 if len > 0 => {
            let i = rng.below(len);
            data[i] ^= 1 << rng.below(8);
        }
        1 if len > 0 => {
            let i = rng.below(len);
            data[i] = rng.next() as u8;
        }
        2 if len > 0 => {
            let v = INTERESTING_INTS[rng.below(INTERESTING_INTS.len())];
            let width = [1, 2, 4][rng.below(3)];
            let bytes = if rng.chance(2) {
                v.to_le_bytes()
            } else {
                v.to_be_bytes()
            };
            let i = rng.below(len);
            for k in 0..width.min(len - i) {
                data[i + k] = bytes[if rng.chance(2) { k } else { 4 - width + k }];
            }
        }
        3 => {
            let (a, b) = range(rng, len);
            data.drain(a..b);
        }
        4 => {
            let (a, b) = range(rng, len);
            let chunk = data[a..b].to_vec();
            let at = rng.below(data.len() + 1);
            data.splice(at..at, chunk);
        }
        5 => {
            let n = 1 + rng.below(16);
            let at = rng.below(len + 1);
            let bytes: Vec<u8> = (0..n).map(|_| rng.next() as u8).collect();
            data.splice(at..at, bytes);
        }
        6 if !other.is_empty() => {
            let at = rng.below(len + 1);
            let from = rng.below(other.len());
            data.truncate(at);
            data.extend_from_slice(&other[from..]);
        }
        7 if len > 0 => {
            let at = rng.below(len);
            data.truncate(at);
        }
        8 => replace_number(rng, data),
        9 => duplicate_unit(rng, data, b'\n', b'\n'),
        10 => {
            // Duplicate a whole element (start tag through its end tag) in place.
            if let Some((a, b)) = element(rng, data) {
                let chunk = data[a..b].to_vec();
                data.splice(b..b, chunk);
            }
        }
        11 => {
            // Delete a whole element.
            if let Some((a, b)) = element(rng, data) {
                data.drain(a..b);
            }
        }
        14 => {
            let (a, b) = unit(rng, data, b'\n', b'\n');
            data.drain(a..b);
        }
        12 => {
            // Insert a scene snippet before an element.
            let starts: Vec<usize> = (0..len).filter(|&i| data[i] == b'<').collect();
            if let Some(&at) = starts.get(rng.below(starts.len())) {
                let snippet = SNIPPETS[rng.below(SNIPPETS.len())];
                data.splice(at..at, snippet.bytes());
            }
        }
        13 => {
            // Replace a quoted attribute value with a word from the scene vocabulary.
            let quotes: Vec<usize> = (0..len).filter(|&i| data[i] == b'"').collect();
            if quotes.len() >= 2 {
                let k = 2 * rng.below(quotes.len() / 2);
                let (a, b) = (quotes[k] + 1, quotes[k + 1]);
                let word = WORDS[rng.below(WORDS.len())];
                data.splice(a..b, word.bytes());
            }
        }
        _ => {
            let n = 1 + rng.below(4);
            let at = rng.below(len + 1);
            let bytes: Vec<u8> = (0..n).map(|_| rng.next() as u8).collect();
            data.splice(at..at, bytes);
        }
    }
}

/// A random unit of text: from just after an `open` byte through the next `close` byte.
fn unit(rng: &mut Rng, data: &[u8], open: u8, close: u8) -> (usize, usize) {
    if data.is_empty() {
        return (0, 0);
    }
    let start = rng.below(data.len());
    let a = data[..start]
        .iter()
        .rposition(|&c| c == open)
        .map_or(0, |i| if open == b'<' { i } else { i + 1 });
    let b = data[start..]
        .iter()
        .position(|&c| c == close)
        .map_or(data.len(), |i| start + i + 1);
    (a, b.max(a))
}

/// A random whole element of an XML text: from a start tag through its matching end tag (or
/// the start tag alone when it closes itself), as a byte range.
fn element(rng: &mut Rng, data: &[u8]) -> Option<(usize, usize)> {
    let starts: Vec<usize> = (0..data.len().saturating_sub(1))
        .filter(|&i| data[i] == b'<' && data[i + 1].is_ascii_alphabetic())
        .collect();
    let start = *starts.get(rng.below(starts.len()))?;
    let mut depth = 0usize;
    let mut i = start;
    while i < data.len() {
        if data[i] != b'<' {
            i += 1;
            continue;
        }
        let close = i + data[i..].iter().position(|&c| c == b'>')?;
        if data.get(i + 1) == Some(&b'/') {
            depth = depth.checked_sub(1)?;
        } else if data[close - 1] != b'/' && data[i + 1].is_ascii_alphabetic() {
            depth += 1;
        }
        i = close + 1;
        if depth == 0 {
            return Some((start, i));
        }
    }
    None
}

fn duplicate_unit(rng: &mut Rng, data: &mut Vec<u8>, open: u8, close: u8) {
    let (a, b) = unit(rng, data, open, close);
    let chunk = data[a..b].to_vec();
    let times = if rng.chance(8) { 1 + rng.below(200) } else { 1 };
    let times = times.min((1 << 16) / chunk.len().max(1)).max(1);
    let mut ins = Vec::with_capacity(chunk.len() * times);
    for _ in 0..times {
        ins.extend_from_slice(&chunk);
    }
    data.splice(b..b, ins);
}

/// Replaces a number token (digits, sign, dot, exponent) with an interesting one.
fn replace_number(rng: &mut Rng, data: &mut Vec<u8>) {
    let is_num = |c: u8| c.is_ascii_digit() || c == b'.' || c == b'-' || c == b'e' || c == b'+';
    let starts: Vec<usize> = (0..data.len())
        .filter(|&i| data[i].is_ascii_digit() && (i == 0 || !is_num(data[i - 1])))
        .collect();
    if starts.is_empty() {
        return;
    }
    let a = starts[rng.below(starts.len())];
    let b = (a..data.len())
        .find(|&i| !is_num(data[i]))
        .unwrap_or(data.len());
    let n = INTERESTING_NUMBERS[rng.below(INTERESTING_NUMBERS.len())];
    data.splice(a..b, n.bytes());
}

/// Outcome classes for the corpus: success, or the error with file names and digits dropped,
/// cut short.
fn signature(result: &Result<String, String>, dir: &Path) -> String {
    match result {
        Ok(s) => format!("ok {s}"),
        Err(e) => {
            let e = e.replace(&dir.display().to_string(), "");
            let e = e.split_once("error: ").map_or(e.as_str(), |(_, m)| m);
            let e = e.strip_prefix("in mesh file '/current.").unwrap_or(e);
            // Numbers, hex values and quoted tokens vary without meaning another code path.
            let mut out = String::new();
            let mut quoted = false;
            for word in e.split_whitespace() {
                let quotes = word.matches(['\'', '`', '"']).count();
                let skip = quoted || quotes > 0 || word.chars().any(|c| c.is_ascii_digit());
                if quotes % 2 == 1 {
                    quoted = !quoted;
                }
                if !skip {
                    out.push_str(word);
                    out.push(' ');
                }
                if out.len() >= 80 {
                    break;
                }
            }
            out
        }
    }
}

/// What kinds of things an accepted scene holds, for outcome classes: shape, bsdf and light
/// kinds and whether there were warnings.
fn scene_summary(s: &torrey_parser::Scene) -> String {
    use std::collections::BTreeSet;
    let mut kinds = BTreeSet::new();
    for sh in &s.shapes {
        kinds.insert(match sh.geometry {
            torrey_parser::Geometry::Mesh(_) => "mesh",
            torrey_parser::Geometry::Sphere { .. } => "sphere",
            torrey_parser::Geometry::Rectangle => "rectangle",
        });
        if sh.emitter.is_some() {
            kinds.insert("area");
        }
    }
    for b in &s.bsdfs {
        kinds.insert(match b.kind {
            torrey_parser::BsdfKind::Diffuse { .. } => "diffuse",
            torrey_parser::BsdfKind::Mirror { .. } => "mirror",
            torrey_parser::BsdfKind::Plastic { .. } => "plastic",
            torrey_parser::BsdfKind::Phong { .. } => "phong",
            torrey_parser::BsdfKind::Blinn { .. } => "blinn",
            torrey_parser::BsdfKind::BlinnMicrofacet { .. } => "microfacet",
        });
        if b.normal_map.is_some() {
            kinds.insert("normalmap");
        }
    }
    for l in &s.lights {
        kinds.insert(match l {
            torrey_parser::Light::Point { .. } => "point",
            torrey_parser::Light::Constant { .. } => "constant",
            torrey_parser::Light::Envmap { .. } => "envmap",
        });
    }
    if !s.textures.is_empty() {
        kinds.insert("texture");
    }
    if !s.warnings.is_empty() {
        kinds.insert("warnings");
    }
    kinds.into_iter().collect::<Vec<_>>().join(",")
}

struct Harness {
    target: Target,
    dir: PathBuf,
    scenes: PathBuf,
    limits: torrey_parser::Limits,
}

impl Harness {
    fn scene_for_mesh(&self, file: &Path, ext: &str) -> String {
        let ty = match ext {
            "obj" => "obj",
            "ply" => "ply",
            _ => "serialized",
        };
        format!(
            "<scene version=\"2.0.0\"><shape type=\"{ty}\"><string name=\"filename\" value=\"{}\"/></shape></scene>",
            file.display()
        )
    }

    /// Runs one input (already written to `file`); Ok/Err summarise the outcome.
    fn run(&self, input: &Input, file: &Path, variant: u64) -> Result<String, String> {
        let parse = |xml: &str| {
            torrey_parser::parse_scene_str_with_limits(
                xml,
                &self.scenes.join("fuzz.xml"),
                &[],
                &self.limits,
            )
            .map_err(|e| e.to_string())
        };
        match self.target {
            Target::Xml => {
                let text = String::from_utf8_lossy(&input.bytes);
                parse(&text).map(|s| scene_summary(&s))
            }
            Target::Mesh => {
                let xml = self.scene_for_mesh(file, &input.ext);
                parse(&xml).map(|s| format!("{} warnings", s.warnings.len().min(3)))
            }
            Target::Image => {
                let img = torrey_texture::load_image(file, variant.is_multiple_of(2))
                    .map_err(|e| e.to_string())?;
                let mip = torrey_texture::MipMap::new(
                    img.image,
                    torrey_texture::WrapMode::Repeat,
                    torrey_texture::FilterType::Bilinear,
                );
                let _ = mip;
                Ok(format!("{} warnings", img.warnings.len()))
            }
            Target::Render => {
                let text = String::from_utf8_lossy(&input.bytes);
                let scene = parse(&text)?;
                let width = if variant.is_multiple_of(3) {
                    torrey_renderer::BvhWidth::Four
                } else {
                    torrey_renderer::BvhWidth::Auto
                };
                let built = torrey_renderer::RenderScene::build_with_width(&scene, 8, 6, width)
                    .map_err(|e| e.to_string())?;
                let settings = torrey_renderer::RenderSettings {
                    spp: 1 + (variant % 2) as u32,
                    max_depth: scene.integrator.max_depth.clamp(-1, 6),
                    rr_depth: scene.integrator.rr_depth,
                    seed: variant,
                    filter: scene.film.filter,
                    tile_size: 4,
                    env_strategy: Default::default(),
                    sampler: if variant.is_multiple_of(2) {
                        torrey_renderer::SamplerKind::Sobol
                    } else {
                        torrey_renderer::SamplerKind::Independent
                    },
                    mipmapping: variant % 4 != 1,
                    packets: variant % 5 != 2,
                };
                let out = torrey_renderer::render(&built, &settings, &|_, _| {});
                if out.image.pixels.iter().any(|p| !p.is_finite()) {
                    panic!("render produced a NaN or infinite pixel");
                }
                Ok(format!(
                    "rendered, {} nonfinite",
                    out.nonfinite_samples.min(1)
                ))
            }
        }
    }
}

struct Args {
    target: Target,
    seconds: f64,
    seed: u64,
    out: PathBuf,
    timeout: f64,
}

fn parse_args() -> Result<Args, String> {
    let mut args = std::env::args().skip(1);
    let target = match args.next().as_deref() {
        Some("xml") => Target::Xml,
        Some("mesh") => Target::Mesh,
        Some("image") => Target::Image,
        Some("render") => Target::Render,
        other => {
            return Err(format!(
                "usage: torrey-fuzz xml|mesh|image|render [--seconds S] [--seed N] [--out DIR] [--timeout S] (got {other:?})"
            ))
        }
    };
    let mut a = Args {
        target,
        seconds: 30.0,
        seed: 0x5EED,
        out: project_root().join("target/fuzz"),
        timeout: 10.0,
    };
    while let Some(flag) = args.next() {
        let value = args.next().ok_or_else(|| format!("{flag} needs a value"))?;
        let num = || {
            value
                .parse::<f64>()
                .map_err(|_| format!("bad value for {flag}: {value}"))
        };
        match flag.as_str() {
            "--seconds" => a.seconds = num()?,
            "--seed" => a.seed = num()? as u64,
            "--out" => a.out = PathBuf::from(&value),
            "--timeout" => a.timeout = num()?,
            _ => return Err(format!("unknown flag {flag}")),
        }
    }
    Ok(a)
}

/// Milliseconds since start at which the current input began; 0 when idle.
static CURRENT_SINCE: AtomicU64 = AtomicU64::new(0);

fn main() {
    let args = match parse_args() {
        Ok(a) => a,
        Err(e) => {
            eprintln!("{e}");
            std::process::exit(2);
        }
    };
    let dir = args.out.join(args.target.name());
    std::fs::create_dir_all(&dir).expect("create the output folder");
    let mut corpus = seeds(args.target);
    if corpus.is_empty() {
        eprintln!("no seed files found under {}", project_root().display());
        std::process::exit(2);
    }
    // Keep the library's own panic message off the terminal: we report panics ourselves.
    std::panic::set_hook(Box::new(|info| {
        let msg = info.to_string();
        if let Ok(mut m) = PANIC_MESSAGE.lock() {
            *m = msg;
        }
    }));
    torrey_texture::set_image_pixel_limit(1 << 22);
    let limits = torrey_parser::Limits {
        mesh_triangles: 1 << 21,
        mesh_vertices: 1 << 21,
        ..Default::default()
    };
    let harness = Harness {
        target: args.target,
        dir: dir.clone(),
        scenes: project_root().join("scenes"),
        limits,
    };

    let start = Instant::now();
    let timeout_ms = (args.timeout * 1000.0) as u64;
    {
        let dir = dir.clone();
        std::thread::spawn(move || loop {
            std::thread::sleep(Duration::from_millis(100));
            let since = CURRENT_SINCE.load(Ordering::Relaxed);
            let now = start.elapsed().as_millis() as u64 + 1;
            if since != 0 && now.saturating_sub(since) > timeout_ms {
                let current = std::fs::read_dir(&dir).ok().and_then(|mut d| {
                    d.find_map(|e| {
                        let e = e.ok()?;
                        let name = e.file_name().to_string_lossy().into_owned();
                        name.starts_with("current.").then(|| e.path())
                    })
                });
                if let Some(c) = current {
                    let hang = c.with_file_name(
                        c.file_name()
                            .unwrap()
                            .to_string_lossy()
                            .replace("current", "hang"),
                    );
                    let _ = std::fs::copy(&c, &hang);
                    eprintln!(
                        "HANG: an input ran longer than {timeout_ms} ms; saved as {}",
                        hang.display()
                    );
                } else {
                    eprintln!("HANG: an input ran longer than {timeout_ms} ms");
                }
                std::process::exit(3);
            }
        });
    }

    let mut rng = Rng(args.seed | 1);
    let mut seen: HashSet<String> = HashSet::new();
    let mut execs: u64 = 0;
    let mut ok: u64 = 0;
    let deadline = Duration::from_secs_f64(args.seconds);
    let seed_count = corpus.len();
    while start.elapsed() < deadline {
        // The seeds themselves first, then mutants of random corpus entries.
        let input = if (execs as usize) < seed_count {
            corpus[execs as usize].clone()
        } else {
            let base = &corpus[rng.below(corpus.len())];
            let other = corpus[rng.below(corpus.len())].bytes.clone();
            let mut bytes = base.bytes.clone();
            let text = args.target.is_text(&base.ext);
            let stack = if rng.chance(4) {
                16
            } else if text {
                2
            } else {
                4
            };
            for _ in 0..1 + rng.below(stack) {
                mutate_once(&mut rng, &mut bytes, &other, &base.ext);
            }
            bytes.truncate(1 << 20);
            Input {
                ext: base.ext.clone(),
                bytes,
            }
        };
        let file = dir.join(format!("current.{}", input.ext));
        // Remove other extensions' current files so the watchdog finds this one.
        for e in [
            "xml",
            "obj",
            "ply",
            "serialized",
            "png",
            "jpg",
            "jpeg",
            "exr",
            "hdr",
            "bmp",
            "tga",
        ] {
            if e != input.ext {
                let _ = std::fs::remove_file(dir.join(format!("current.{e}")));
            }
        }
        std::fs::write(&file, &input.bytes).expect("write the current input");
        let variant = rng.next();
        CURRENT_SINCE.store(start.elapsed().as_millis() as u64 + 1, Ordering::Relaxed);
        let result = catch_unwind(AssertUnwindSafe(|| harness.run(&input, &file, variant)));
        CURRENT_SINCE.store(0, Ordering::Relaxed);
        execs += 1;
        let result = match result {
            Ok(r) => r,
            Err(_) => {
                let msg = PANIC_MESSAGE.lock().map(|m| m.clone()).unwrap_or_default();
                let saved = harness.dir.join(format!("panic-{execs}.{}", input.ext));
                let _ = std::fs::write(&saved, &input.bytes);
                eprintln!(
                    "PANIC in target {} after {execs} execs: {msg}\n  input saved as {}",
                    args.target.name(),
                    saved.display()
                );
                std::process::exit(1);
            }
        };
        ok += result.is_ok() as u64;
        let sig = signature(&result, &harness.dir);
        match std::env::var("TORREY_FUZZ_VERBOSE").as_deref() {
            Ok("all") => eprintln!("outcome: {sig}"),
            Ok(_) if !seen.contains(&sig) => eprintln!("new outcome: {sig}"),
            _ => {}
        }
        // New outcomes join the corpus; once it is full they replace a random non-seed entry,
        // and accepted inputs are kept preferentially (they reach the deepest code).
        let accepted = result.is_ok();
        // Malformed text rarely leads anywhere new: keep few of those.
        let malformed = sig.starts_with("malformed");
        if seen.insert(sig) && (execs as usize) >= seed_count && (!malformed || rng.chance(8)) {
            if corpus.len() < 4096 {
                corpus.push(input);
            } else {
                let victim = seed_count + rng.below(corpus.len() - seed_count);
                corpus[victim] = input;
            }
        } else if accepted && (execs as usize) >= seed_count && rng.chance(16) {
            let victim = seed_count + rng.below(corpus.len() - seed_count);
            if corpus.len() < 4096 {
                corpus.push(input);
            } else {
                corpus[victim] = input;
            }
        }
    }
    let secs = start.elapsed().as_secs_f64();
    println!(
        "{}: {execs} execs in {secs:.0} s ({:.0}/s), {ok} accepted, {} outcome classes, corpus {} (from {seed_count} seeds), no panic, crash or hang",
        args.target.name(),
        execs as f64 / secs,
        seen.len(),
        corpus.len()
    );
}

/// The last panic's message (from any thread: rayon workers re-raise on the caller).
static PANIC_MESSAGE: std::sync::Mutex<String> = std::sync::Mutex::new(String::new());
