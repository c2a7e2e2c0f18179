//! Mitsuba's binary grid volume format (`.vol`), the one reader for every plugin that loads one:
//! the `sdfgrid` shape now, grid-based participating media (`gridvolume`, one or three
//! channels) later.
//!
//! The format, as Mitsuba 3 reads it (`VolumeGrid::read`), all little-endian:
//!
//! | bytes | content |
//! | --- | --- |
//! | 0-2 | `VOL` |
//! | 3 | version: 3 |
//! | 4-7 | encoding, i32: 1 = float32 (the only one Mitsuba 3 reads) |
//! | 8-19 | size along x, y, z, i32 each |
//! | 20-23 | channels per sample, i32 |
//! | 24-47 | bounding box: min x, y, z, max x, y, z, f32 each |
//! | 48- | x · y · z · channels f32 values: x fastest, then y, then z; the channels of a sample together |
//!
//! Files come from strangers, so the header is checked before anything is allocated: sizes and
//! channels must be positive, the values they announce must fit the caller's cap and must be in
//! the file (a truncated file is an error, not a short read), every value must be finite, and
//! the reader never allocates more than the file holds. Bytes after the last value (Mitsuba
//! ignores them) are counted in [`VolumeGrid::trailing_bytes`] for the caller to report.

use std::io::Read;
use std::path::Path;

/// The size of the header, in bytes.
pub const HEADER_BYTES: u64 = 48;

/// A grid of samples read from a `.vol` file.
#[derive(Clone, Debug, PartialEq)]
pub struct VolumeGrid {
    /// Samples along x, y, z (each at least 1).
    pub size: [u32; 3],
    /// Values per sample.
    pub channels: u32,
    /// The bounding box the file declares: min, then max. (Mitsuba's `sdfgrid` ignores it and
    /// maps the grid onto [0, 1]^3; `gridvolume` places the grid in it.)
    pub bbox: [[f32; 3]; 2],
    /// `size[0] * size[1] * size[2] * channels` finite values, x fastest, then y, then z, the
    /// channels of one sample together.
    pub data: Vec<f32>,
    /// Bytes after the last value: Mitsuba ignores them; a caller may warn.
    pub trailing_bytes: u64,
}

impl VolumeGrid {
    /// The number of samples, x · y · z.
    pub fn sample_count(&self) -> usize {
        self.size.iter().map(|&s| s as usize).product()
    }

    /// Channel `c` of the sample at (x, y, z); indices must be in range.
    #[inline]
    pub fn value(&self, x: u32, y: u32, z: u32, c: u32) -> f32 {
        let [nx, ny, _] = self.size;
        let i = ((z as usize * ny as usize + y as usize) * nx as usize + x as usize)
            * self.channels as usize
            + c as usize;
        self.data[i]
    }
}

/// Why a `.vol` file cannot be read: a message for the user, naming what is wrong.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct VolError(pub String);

impl std::fmt::Display for VolError {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(&self.0)
    }
}

impl std::error::Error for VolError {}

fn err<T>(message: impl Into<String>) -> Result<T, VolError> {
    Err(VolError(message.into()))
}

/// The checked header: sizes, channels, bounding box, and the number of values.
struct Header {
    size: [u32; 3],
    channels: u32,
    bbox: [[f32; 3]; 2],
    values: u64,
}

fn i32_at(h: &[u8], at: usize) -> i32 {
    i32::from_le_bytes([h[at], h[at + 1], h[at + 2], h[at + 3]])
}

fn f32_at(h: &[u8], at: usize) -> f32 {
    f32::from_le_bytes([h[at], h[at + 1], h[at + 2], h[at + 3]])
}

/// Checks the 48-byte header of a file of `file_len` bytes against `max_values`.
fn header(h: &[u8], file_len: u64, max_values: u64) -> Result<Header, VolError> {
    if h.len() < HEADER_BYTES as usize {
        return err(format!(
            "not a .vol file: {} bytes, shorter than the {HEADER_BYTES}-byte header",
            h.len()
        ));
    }
    if &h[0..3] != b"VOL" {
        return err("not a .vol file: it does not start with 'VOL'");
    }
    if h[3] != 3 {
        return err(format!(
            "unsupported .vol version {} (only version 3 is read, as in Mitsuba 3)",
            h[3]
        ));
    }
    let encoding = i32_at(h, 4);
    if encoding != 1 {
        return err(format!(
            "unsupported .vol encoding {encoding} (only 1, float32, is read, as in Mitsuba 3)"
        ));
    }
    let mut size = [0u32; 3];
    for (i, axis) in ["x", "y", "z"].iter().enumerate() {
        let s = i32_at(h, 8 + 4 * i);
        if s < 1 {
            return err(format!(
                "the header gives {s} samples along {axis}; it must be at least 1"
            ));
        }
        size[i] = s as u32;
    }
    let channels = i32_at(h, 20);
    if channels < 1 {
        return err(format!(
            "the header gives {channels} channels; it must be at least 1"
        ));
    }
    let channels = channels as u32;
    let mut bbox = [[0.0f32; 3]; 2];
    for (i, v) in bbox.iter_mut().flatten().enumerate() {
        *v = f32_at(h, 24 + 4 * i);
    }
    if !bbox.iter().flatten().all(|v| v.is_finite()) {
        return err("the header's bounding box is not finite");
    }
    // At most 2^31 · 2^31 · 2^31 · 2^31: computed in u128, it cannot overflow.
    let values = size.iter().map(|&s| s as u128).product::<u128>() * channels as u128;
    let announced = format!(
        "{} x {} x {} samples of {channels} channel(s)",
        size[0], size[1], size[2]
    );
    if values > max_values as u128 {
        return err(format!(
            "the header announces {announced} = {values} values, more than the limit of {max_values} (raise with --limit volume_values=N)"
        ));
    }
    let values = values as u64;
    let needed = HEADER_BYTES + 4 * values;
    if file_len < needed {
        return err(format!(
            "the header announces {announced} = {values} values ({needed} bytes with the header), but the file has {file_len} bytes"
        ));
    }
    Ok(Header {
        size,
        channels,
        bbox,
        values,
    })
}

/// Reads a `.vol` grid from `reader`, which holds `len` bytes; at most `max_values` values.
pub fn read_vol<R: Read>(mut reader: R, len: u64, max_values: u64) -> Result<VolumeGrid, VolError> {
    let mut h = [0u8; HEADER_BYTES as usize];
    let got = read_up_to(&mut reader, &mut h)?;
    let head = header(&h[..got], len, max_values)?;
    // The file holds every value (checked against its length), so this allocates at most the
    // file's size.
    let mut data = Vec::with_capacity(head.values as usize);
    let mut buf = vec![0u8; 1 << 16];
    let mut remaining = head.values as usize * 4;
    while remaining > 0 {
        let want = remaining.min(buf.len());
        let got = read_up_to(&mut reader, &mut buf[..want])?;
        if got < want {
            return err(format!(
                "the file ends after {} of the {} values its header announces",
                data.len() + got / 4,
                head.values
            ));
        }
        data.extend(
            buf[..got]
                .chunks_exact(4)
                .map(|b| f32::from_le_bytes([b[0], b[1], b[2], b[3]])),
        );
        remaining -= got;
    }
    if let Some(i) = data.iter().position(|v| !v.is_finite()) {
        let c = head.channels as usize;
        let s = i / c;
        let [nx, ny, _] = head.size.map(|v| v as usize);
        let (x, y, z) = (s % nx, (s / nx) % ny, s / (nx * ny));
        let what = if data[i].is_nan() { "NaN" } else { "infinite" };
        return err(format!(
            "value {i} (sample x {x}, y {y}, z {z}, channel {}) is {what}",
            i % c
        ));
    }
    Ok(VolumeGrid {
        size: head.size,
        channels: head.channels,
        bbox: head.bbox,
        data,
        trailing_bytes: len - HEADER_BYTES - 4 * head.values,
    })
}

/// Reads as much of `buf` as the reader has; fewer bytes only at its end.
fn read_up_to<R: Read>(reader: &mut R, buf: &mut [u8]) -> Result<usize, VolError> {
    let mut got = 0;
    while got < buf.len() {
        match reader.read(&mut buf[got..]) {
            Ok(0) => break,
            Ok(n) => got += n,
            Err(e) if e.kind() == std::io::ErrorKind::Interrupted => {}
            Err(e) => return err(format!("cannot read the file: {e}")),
        }
    }
    Ok(got)
}

/// Reads the `.vol` file at `path` (a regular file), at most `max_values` values.
pub fn read_vol_file(path: &Path, max_values: u64) -> Result<VolumeGrid, VolError> {
    let len = crate::files::regular_file_size(path).map_err(VolError)?;
    let file = std::fs::File::open(path).map_err(|e| VolError(format!("cannot open: {e}")))?;
    read_vol(std::io::BufReader::new(file), len, max_values)
}

/// The bytes of a `.vol` file holding `data` (x fastest, then y, z, channels together):
/// for tests and tools.
pub fn write_vol(size: [u32; 3], channels: u32, bbox: [[f32; 3]; 2], data: &[f32]) -> Vec<u8> {
    let mut out = Vec::with_capacity(HEADER_BYTES as usize + 4 * data.len());
    out.extend_from_slice(b"VOL");
    out.push(3);
    out.extend_from_slice(&1i32.to_le_bytes());
    for s in size {
        out.extend_from_slice(&(s as i32).to_le_bytes());
    }
    out.extend_from_slice(&(channels as i32).to_le_bytes());
    for v in bbox.iter().flatten() {
        out.extend_from_slice(&v.to_le_bytes());
    }
    for v in data {
        out.extend_from_slice(&v.to_le_bytes());
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    const BOX: [[f32; 3]; 2] = [[0.0; 3], [1.0; 3]];

    fn read(bytes: &[u8]) -> Result<VolumeGrid, VolError> {
        read_vol(bytes, bytes.len() as u64, 1 << 20)
    }

    fn message(bytes: &[u8]) -> String {
        read(bytes).unwrap_err().0
    }

    #[test]
    fn reads_what_it_writes() {
        let data: Vec<f32> = (0..2 * 3 * 4 * 3).map(|i| i as f32 * 0.5 - 3.0).collect();
        let bytes = write_vol([2, 3, 4], 3, [[-1.0, 0.0, 2.0], [1.0, 5.0, 3.0]], &data);
        assert_eq!(bytes.len(), 48 + 4 * data.len());
        let g = read(&bytes).unwrap();
        assert_eq!(g.size, [2, 3, 4]);
        assert_eq!(g.channels, 3);
        assert_eq!(g.bbox, [[-1.0, 0.0, 2.0], [1.0, 5.0, 3.0]]);
        assert_eq!(g.data, data);
        assert_eq!(g.trailing_bytes, 0);
        // x fastest, then y, then z; channels together.
        assert_eq!(g.value(1, 2, 3, 2), data[((3 * 3 + 2) * 2 + 1) * 3 + 2]);
        let mut longer = bytes.clone();
        longer.extend_from_slice(&[0; 6]);
        assert_eq!(read(&longer).unwrap().trailing_bytes, 6);
    }

    /// Hostile headers: each is a clear error, before anything of the announced size is
    /// allocated (2^31 cubed values would be 32 EiB).
    #[test]
    fn hostile_headers() {
        let good = write_vol([2, 2, 2], 1, BOX, &[1.0; 8]);
        let with = |at: usize, bytes: &[u8]| {
            let mut b = good.clone();
            b[at..at + bytes.len()].copy_from_slice(bytes);
            b
        };
        assert!(message(b"VO").contains("shorter than the 48-byte header"));
        assert!(message(&with(0, b"XYZ")).contains("does not start with 'VOL'"));
        assert!(message(&with(3, &[2])).contains("unsupported .vol version 2"));
        assert!(message(&with(4, &2i32.to_le_bytes())).contains("unsupported .vol encoding 2"));
        assert!(message(&with(8, &0i32.to_le_bytes())).contains("0 samples along x"));
        assert!(message(&with(16, &(-5i32).to_le_bytes())).contains("-5 samples along z"));
        assert!(message(&with(20, &0i32.to_le_bytes())).contains("0 channels"));
        assert!(message(&with(24, &f32::NAN.to_le_bytes())).contains("bounding box is not finite"));
        // Sizes that lie: more values than the file holds, more than the cap.
        let huge = with(8, &[i32::MAX.to_le_bytes(); 3].concat());
        assert!(
            message(&huge).contains("more than the limit"),
            "{}",
            message(&huge)
        );
        let big = with(8, &[64i32.to_le_bytes(); 3].concat());
        let m = message(&big);
        assert!(
            m.contains("announces 64 x 64 x 64 samples of 1 channel(s)"),
            "{m}"
        );
        assert!(m.contains("but the file has 80 bytes"), "{m}");
        let lying_channels = with(20, &1000i32.to_le_bytes());
        assert!(message(&lying_channels).contains("8000 values"));
        // The length given by the caller is checked too: a stream that ends early.
        let g = read_vol(&good[..60], good.len() as u64, 1 << 20)
            .unwrap_err()
            .0;
        assert!(g.contains("the file ends after 3 of the 8 values"), "{g}");
    }

    #[test]
    fn non_finite_values_are_errors() {
        let mut data = vec![0.5f32; 2 * 2 * 2];
        data[6] = f32::NAN;
        let m = message(&write_vol([2, 2, 2], 1, BOX, &data));
        assert_eq!(m, "value 6 (sample x 0, y 1, z 1, channel 0) is NaN");
        data[6] = f32::INFINITY;
        let m = message(&write_vol([2, 2, 2], 1, BOX, &data));
        assert!(m.ends_with("is infinite"), "{m}");
    }
}
