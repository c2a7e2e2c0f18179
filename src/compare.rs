//! `torrey compare A.exr B.exr`: image-difference metrics, heatmaps and side-by-side pictures.
