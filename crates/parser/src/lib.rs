//! torrey's scene parser: Mitsuba-style XML (torrey 0.5/0.6 and Mitsuba 3 dialects) to a plain
//! [`Scene`] description. No rendering types live here.

pub mod scene;

pub use scene::*;
