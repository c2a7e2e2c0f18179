//! Geometry, BVH, camera, materials, path integrator and film.
