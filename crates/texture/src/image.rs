//! A linear RGB float image: the one pixel type every loader produces and every lookup reads.

use glam::Vec3;

/// Row-major linear RGB image; row 0 is the top of the picture (Mitsuba's v = 0).
#[derive(Clone, Debug, PartialEq)]
pub struct Image {
    /// Width in pixels.
    pub width: u32,
    /// Height in pixels.
    pub height: u32,
    /// `width * height` linear RGB values, row by row from the top.
    pub pixels: Vec<Vec3>,
}

impl Image {
    /// Wraps existing pixels; panics if the count does not match (a programming error, never
    /// reachable from file input: loaders build the vector from the decoded size).
    pub fn new(width: u32, height: u32, pixels: Vec<Vec3>) -> Self {
        assert_eq!(pixels.len(), width as usize * height as usize);
        Self {
            width,
            height,
            pixels,
        }
    }

    /// A constant image, e.g. a stand-in for a missing texture or a test fixture.
    pub fn filled(width: u32, height: u32, value: Vec3) -> Self {
        Self::new(width, height, vec![value; width as usize * height as usize])
    }

    /// The pixel at column `x`, row `y` (row 0 = top); panics when out of range.
    #[inline]
    pub fn get(&self, x: u32, y: u32) -> Vec3 {
        self.pixels[y as usize * self.width as usize + x as usize]
    }
}

/// An 8-bit image's texels as the file stores them, with the table that gives each code's
/// linear value: the [`Image`] loaded from it holds exactly `table[code]` per channel. A pyramid
/// keeps its finest level this way ([`crate::MipMap::with_packed_texels_from`]): 3 bytes a texel
/// instead of 16, the same values to the bit.
#[derive(Clone, Debug)]
pub struct Codes8 {
    /// `width * height` RGB codes, row by row from the top.
    pub texels: Box<[[u8; 3]]>,
    /// The linear value of each code (sRGB-decoded, or code / 255 for raw data).
    pub table: &'static [f32; 256],
}

impl Codes8 {
    /// The linear value of the texel with `codes`.
    #[inline(always)]
    pub fn value(&self, codes: [u8; 3]) -> [f32; 3] {
        codes.map(|c| self.table[c as usize])
    }
}
