//! A linear RGB float image: the one pixel type every loader produces and every lookup reads.

use glam::Vec3;

/// Row-major linear RGB image; row 0 is the top of the picture (Mitsuba's v = 0).
#[derive(Clone, Debug, PartialEq)]
pub struct Image {
    pub width: u32,
    pub height: u32,
    pub pixels: Vec<Vec3>,
}

impl Image {
    pub fn new(width: u32, height: u32, pixels: Vec<Vec3>) -> Self {
        assert_eq!(pixels.len(), width as usize * height as usize);
        Self { width, height, pixels }
    }

    pub fn filled(width: u32, height: u32, value: Vec3) -> Self {
        Self::new(width, height, vec![value; width as usize * height as usize])
    }

    #[inline]
    pub fn get(&self, x: u32, y: u32) -> Vec3 {
        self.pixels[y as usize * self.width as usize + x as usize]
    }
}
