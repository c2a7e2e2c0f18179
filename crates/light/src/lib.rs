//! Alias tables and environment-map importance sampling.
//!
//! Everything here is renderer-agnostic: the renderer owns the scene and its rays, this crate owns
//! the densities. Every sampler has a matching pdf so that multiple importance sampling can weigh
//! strategies consistently, and every routine works in f32 without allocating on the hot path.

#![deny(missing_docs)]

pub mod alias;
pub mod envmap;
pub mod unit;

pub use alias::AliasTable;
pub use envmap::{luminance, BatchSimd, EnvMap, EnvSample, BATCH_LANES};
