//! BSDF models in the local shading frame (z = shading normal).
