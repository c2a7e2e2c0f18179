//! Caps on what a scene may make torrey allocate. Scene files come from strangers: every count
//! a file declares (film size, mesh sizes, grid volume sizes, nesting depth) is checked against these before
//! anything of that size is allocated. The defaults keep a render of any accepted scene well
//! under 2 GB; `torrey --limit name=value` raises or lowers them (docs/robustness.md).

/// The parser's limits. [`Limits::default`] gives the documented defaults.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Limits {
    /// Film width × height (also each side): 2^25 = 33,554,432 (8192 × 4096).
    pub film_pixels: u64,
    /// Triangles of all meshes of a scene together: 2^24 = 16,777,216.
    pub mesh_triangles: u64,
    /// Vertices of all meshes of a scene together: 2^24.
    pub mesh_vertices: u64,
    /// Bytes of a scene file: 256 MiB.
    pub scene_bytes: u64,
    /// How deep XML elements may nest: 64 (real scenes nest less than 10 deep).
    pub nesting_depth: u32,
    /// Values of all grid volumes (`.vol` files) of a scene together: 2^26 = 67,108,864
    /// (256 MiB of floats; a 400^3 grid).
    pub volume_values: u64,
}

impl Default for Limits {
    fn default() -> Self {
        Limits {
            film_pixels: 1 << 25,
            mesh_triangles: 1 << 24,
            mesh_vertices: 1 << 24,
            scene_bytes: 256 << 20,
            nesting_depth: 64,
            volume_values: 1 << 26,
        }
    }
}
