//! Mutations: byte-level ones for any input, structure-aware ones for XML (whole elements,
//! scene snippets, plugin vocabulary) and for OBJ/PLY lines, and number tokens replaced by
//! interesting values.

use crate::rng::Rng;

pub(crate) const INTERESTING_NUMBERS: &[&str] = &[
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
pub(crate) const SNIPPETS: &[&str] = &[
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
pub(crate) const WORDS: &[&str] = &[
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

pub(crate) const INTERESTING_INTS: &[u32] = &[
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

/// Byte range [a, b) of `len` bytes, short ranges favoured.
pub(crate) fn range(rng: &mut Rng, len: usize) -> (usize, usize) {
    let a = rng.below(len + 1);
    let max = (len - a).min(if rng.chance(4) { 4096 } else { 64 });
    (a, a + rng.below(max + 1))
}

/// Applies one random mutation to `data`; `other` is another corpus entry for splicing.
pub(crate) fn mutate_once(rng: &mut Rng, data: &mut Vec<u8>, other: &[u8], ext: &str) {
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
pub(crate) fn unit(rng: &mut Rng, data: &[u8], open: u8, close: u8) -> (usize, usize) {
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
pub(crate) fn element(rng: &mut Rng, data: &[u8]) -> Option<(usize, usize)> {
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

pub(crate) fn duplicate_unit(rng: &mut Rng, data: &mut Vec<u8>, open: u8, close: u8) {
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
pub(crate) fn replace_number(rng: &mut Rng, data: &mut Vec<u8>) {
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
