//! Distribution1D/2D, environment-map importance sampling, point and area light sampling.
