//! Warps from the unit square to directions and shapes, with their pdfs.
