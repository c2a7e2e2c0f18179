//! Part EXRs: linear float RGB (the mean, so a part is an ordinary image to look at; the
//! denoised image when there is one, the mean then in `noisy.R/G/B`), the variance of the mean in
//! `variance.R/G/B`, the sample count and weight sum per pixel, the other values the samples
//! wrote (AOVs, guides) under their own channel names, and the [`PartMeta`] as text header
//! attributes.

use crate::meta::PartMeta;
use crate::part::Part;
use exr::prelude::*;
use glam::Vec3;
use std::io::Cursor;
use std::path::Path;

const CHANNELS: [&str; 6] = ["R", "G", "B", "variance.R", "variance.G", "variance.B"];
/// The mean's channels in a denoised part (whose `R`, `G`, `B` are the denoised image).
const NOISY: [&str; 3] = ["noisy.R", "noisy.G", "noisy.B"];
/// The header attribute that holds the [`PartMeta`].
const META_ATTRIBUTE: &str = "torrey";

fn escape(value: &str) -> String {
    value.replace('\\', "\\\\").replace('\n', "\\n")
}

fn unescape(value: &str) -> String {
    let mut out = String::with_capacity(value.len());
    let mut chars = value.chars();
    while let Some(c) = chars.next() {
        match (c, c == '\\') {
            (_, true) => match chars.next() {
                Some('n') => out.push('\n'),
                Some(other) => out.push(other),
                None => {}
            },
            (c, false) => out.push(c),
        }
    }
    out
}

/// Samples counted per pixel, as floats (exact below 2^24).
const COUNT: &str = "count";
/// Sum of the sample weights per pixel (absent in parts written before it: then `count`).
const WEIGHT: &str = "weight";

fn text(s: &str) -> Text {
    // EXR text is bytes; keep UTF-8 (paths) as it is.
    Text::from_slice_unchecked(s.as_bytes())
}

fn image(part: &Part, encoding: Encoding) -> Image<Layer<AnyChannels<FlatSamples>>> {
    let (_, _, w, h) = part.meta.crop;
    let column = |data: &[Vec3], c: usize| FlatSamples::F32(data.iter().map(|p| p[c]).collect());
    let rgb = part.denoised.as_ref().unwrap_or(&part.mean);
    let mut channels: SmallVec<[AnyChannel<FlatSamples>; 4]> = CHANNELS
        .iter()
        .enumerate()
        .map(|(i, name)| {
            let data = if i < 3 { rgb } else { &part.variance };
            AnyChannel::new(*name, column(data, i % 3))
        })
        .collect();
    if part.denoised.is_some() {
        for (c, name) in NOISY.iter().enumerate() {
            channels.push(AnyChannel::new(*name, column(&part.mean, c)));
        }
    }
    channels.push(AnyChannel::new(
        COUNT,
        FlatSamples::F32(part.count.iter().map(|&n| n as f32).collect()),
    ));
    channels.push(AnyChannel::new(
        WEIGHT,
        FlatSamples::F32(part.weight.clone()),
    ));
    let ch = part.channels.len();
    for (k, name) in part.channels.iter().enumerate() {
        let values = part.extras.iter().skip(k).step_by(ch).copied().collect();
        channels.push(AnyChannel::new(name.as_str(), FlatSamples::F32(values)));
    }
    let mut attributes = LayerAttributes::default();
    // One text attribute holding every field, one `name=value` line each (newlines and
    // backslashes escaped): the EXR crate keeps attributes in a hash map, whose order changes
    // from process to process, and the same render must give the same bytes.
    let fields: Vec<String> = part
        .meta
        .attributes()
        .into_iter()
        .map(|(name, value)| format!("{name}={}", escape(&value)))
        .collect();
    attributes.other.insert(
        text(META_ATTRIBUTE),
        AttributeValue::Text(text(&fields.join("\n"))),
    );

    let layer = Layer::new(
        (w as usize, h as usize),
        attributes,
        encoding,
        AnyChannels::sort(channels),
    );
    Image::from_layer(layer)
}

/// Writes a part EXR (ZIP-compressed).
pub fn write_part(path: &Path, part: &Part) -> std::result::Result<(), String> {
    image(part, Encoding::SMALL_LOSSLESS)
        .write()
        .to_file(path)
        .map_err(|e| format!("cannot write {}: {e}", path.display()))
}

/// A part EXR in memory (what a distributed render task sends back), uncompressed: compressing
/// noisy floats took 0.85 s per million pixels and saved only half the bytes.
pub fn write_part_bytes(part: &Part) -> std::result::Result<Vec<u8>, String> {
    let mut out = Cursor::new(Vec::new());
    image(part, Encoding::UNCOMPRESSED)
        .write()
        .to_buffered(&mut out)
        .map_err(|e| format!("cannot encode EXR: {e}"))?;
    Ok(out.into_inner())
}

/// Reads a part EXR written by [`write_part`].
pub fn read_part(path: &Path) -> std::result::Result<Part, String> {
    let bytes = std::fs::read(path).map_err(|e| format!("{}: {e}", path.display()))?;
    read_part_bytes(&bytes, &path.display().to_string())
}

/// Reads a part EXR from memory; `name` labels errors.
pub fn read_part_bytes(bytes: &[u8], name: &str) -> std::result::Result<Part, String> {
    let err = |m: String| format!("{name}: {m}");
    let image = read()
        .no_deep_data()
        .largest_resolution_level()
        .all_channels()
        .first_valid_layer()
        .all_attributes()
        .from_buffered(Cursor::new(bytes))
        .map_err(|e| err(format!("not a readable EXR: {e}")))?;
    let layer = &image.layer_data;
    let fields: std::collections::HashMap<String, String> =
        match layer.attributes.other.get(&text(META_ATTRIBUTE)) {
            Some(AttributeValue::Text(t)) => String::from_utf8_lossy(t.as_slice())
                .lines()
                .filter_map(|line| {
                    let (name, value) = line.split_once('=')?;
                    Some((name.to_string(), unescape(value)))
                })
                .collect(),
            _ => Default::default(),
        };
    let meta = PartMeta::from_attributes(|key| fields.get(key).cloned()).map_err(err)?;
    let (w, h) = (layer.size.width(), layer.size.height());
    if (w, h) != (meta.crop.2 as usize, meta.crop.3 as usize) {
        return Err(err(format!(
            "{w}x{h} pixels, but its crop says {}x{}",
            meta.crop.2, meta.crop.3
        )));
    }
    let channel = |n: &str| -> std::result::Result<Vec<f32>, String> {
        let c = layer
            .channel_data
            .list
            .iter()
            .find(|c| c.name == text(n))
            .ok_or_else(|| err(format!("no '{n}' channel")))?;
        Ok(c.sample_data.values_as_f32().collect())
    };
    let columns: Vec<Vec<f32>> = CHANNELS
        .iter()
        .map(|n| channel(n))
        .collect::<std::result::Result<_, _>>()?;
    // Renders and merges write finite values only (the film clamps to f32's range): a part
    // holding NaN or infinity was not written by torrey, and would spread it into the merge.
    let finite = |names: &[&str], columns: &[Vec<f32>]| -> std::result::Result<(), String> {
        for (name, column) in names.iter().zip(columns) {
            if let Some(bad) = column.iter().find(|v| !v.is_finite()) {
                return Err(err(format!("a value of {bad} in the '{name}' channel")));
            }
        }
        Ok(())
    };
    finite(&CHANNELS, &columns)?;
    let gather = |k: usize| {
        (0..w * h)
            .map(|i| Vec3::new(columns[k][i], columns[k + 1][i], columns[k + 2][i]))
            .collect()
    };
    let count = channel(COUNT)?
        .into_iter()
        .map(|n| {
            (n.is_finite() && n >= 0.0 && n <= (1u32 << 24) as f32 && n.fract() == 0.0)
                .then_some(n as u32)
                .ok_or_else(|| err(format!("a sample count of {n} in the 'count' channel")))
        })
        .collect::<std::result::Result<Vec<u32>, String>>()?;
    let weight = match channel(WEIGHT) {
        Ok(w) => {
            if let Some(bad) = w.iter().find(|v| !v.is_finite()) {
                return Err(err(format!("a weight of {bad} in the 'weight' channel")));
            }
            w
        }
        Err(_) => count.iter().map(|&n| n as f32).collect(),
    };
    let (mean, denoised) = match channel(NOISY[0]) {
        Ok(_) => {
            let noisy: Vec<Vec<f32>> = NOISY
                .iter()
                .map(|n| channel(n))
                .collect::<std::result::Result<_, _>>()?;
            finite(&NOISY, &noisy)?;
            let mean = (0..w * h)
                .map(|i| Vec3::new(noisy[0][i], noisy[1][i], noisy[2][i]))
                .collect();
            (mean, Some(gather(0)))
        }
        Err(_) => (gather(0), None),
    };
    // Every other channel is a value the samples wrote (AOVs, guides), in the file's order.
    let known = |n: &str| CHANNELS.contains(&n) || NOISY.contains(&n) || n == COUNT || n == WEIGHT;
    let mut names = Vec::new();
    let mut columns_extra = Vec::new();
    for c in &layer.channel_data.list {
        let name = String::from_utf8_lossy(c.name.as_slice()).into_owned();
        if !known(&name) {
            columns_extra.push(c.sample_data.values_as_f32().collect::<Vec<f32>>());
            names.push(name);
        }
    }
    let extras = (0..w * h)
        .flat_map(|i| columns_extra.iter().map(move |col| col[i]))
        .collect();
    Ok(Part {
        meta,
        mean,
        variance: gather(3),
        count,
        weight,
        channels: names,
        extras,
        denoised,
    })
}
