//! Part EXRs: linear float RGB (the mean, so a part is an ordinary image to look at), the
//! variance of the mean in `variance.R/G/B`, and the [`PartMeta`] as text header attributes.

use crate::meta::PartMeta;
use crate::part::Part;
use exr::prelude::*;
use glam::Vec3;
use std::io::Cursor;
use std::path::Path;

const CHANNELS: [&str; 6] = ["R", "G", "B", "variance.R", "variance.G", "variance.B"];
/// Samples counted per pixel, as floats (exact below 2^24).
const COUNT: &str = "count";

fn text(s: &str) -> Text {
    // EXR text is bytes; keep UTF-8 (paths) as it is.
    Text::from_slice_unchecked(s.as_bytes())
}

fn image(part: &Part, encoding: Encoding) -> Image<Layer<AnyChannels<FlatSamples>>> {
    let (_, _, w, h) = part.meta.crop;
    let column = |data: &[Vec3], c: usize| FlatSamples::F32(data.iter().map(|p| p[c]).collect());
    let mut channels: SmallVec<[AnyChannel<FlatSamples>; 4]> = CHANNELS
        .iter()
        .enumerate()
        .map(|(i, name)| {
            let data = if i < 3 { &part.mean } else { &part.variance };
            AnyChannel::new(*name, column(data, i % 3))
        })
        .collect();
    channels.push(AnyChannel::new(
        COUNT,
        FlatSamples::F32(part.count.iter().map(|&n| n as f32).collect()),
    ));
    let mut attributes = LayerAttributes::default();
    for (name, value) in part.meta.attributes() {
        attributes
            .other
            .insert(text(name), AttributeValue::Text(text(&value)));
    }
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
    let meta = PartMeta::from_attributes(|key| match layer.attributes.other.get(&text(key)) {
        Some(AttributeValue::Text(t)) => Some(String::from_utf8_lossy(t.as_slice()).into_owned()),
        _ => None,
    })
    .map_err(err)?;
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
    Ok(Part {
        meta,
        mean: gather(0),
        variance: gather(3),
        count,
    })
}
