//! AVX-512 (F, with AVX2 and FMA): sixteen-wide BVH nodes ([`Nodes16`]), through which the
//! camera-ray packets of eight trace with [`super::avx2::packet::closest_hits16`], and camera-ray
//! packets of sixteen through eight- or sixteen-wide nodes ([`packet16`]), and the sixteen lanes
//! of shadow-ray packets ([`Lanes16`]). The traversal loops
//! are the generic ones of [`crate::accel::traversal`], instantiated here inside functions
//! compiled with these features enabled.

mod lanes16;
mod nodes16;
pub(crate) mod packet16;

pub(crate) use lanes16::Lanes16;
pub(crate) use nodes16::Nodes16;

use crate::accel::leaves::Leaves;
use crate::accel::traversal::{self, ChildRef};
use crate::accel::ClosestHit;
use crate::ray::Ray;
use std::mem::MaybeUninit;

/// True when this CPU can run these kernels: AVX-512 Foundation with the byte/word and
/// vector-length extensions (every AVX-512 CPU since Skylake-SP; other kernels at this level,
/// such as the Sobol sampler's columns, use them), and the AVX2 and FMA of the eight-wide kernels.
pub fn available() -> bool {
    is_x86_feature_detected!("avx512f")
        && is_x86_feature_detected!("avx512bw")
        && is_x86_feature_detected!("avx512vl")
        && super::avx2::available()
}

/// [`traversal::closest_hit`] over sixteen-wide nodes, compiled with AVX-512.
///
/// # Safety
/// The CPU must have AVX-512F, AVX2 and FMA ([`available`]); `Nodes16` values exist only then.
/// `stack` must hold the tree's `stack_needed` entries.
#[target_feature(enable = "avx512f,avx2,fma")]
pub(crate) unsafe fn closest_hit(
    nodes: &Nodes16,
    leaves: &Leaves,
    root: ChildRef,
    ray: &Ray,
    stack: &mut [MaybeUninit<(ChildRef, f32)>],
) -> Option<ClosestHit> {
    // SAFETY: the caller's contract.
    unsafe { traversal::closest_hit(nodes, leaves, root, ray, stack) }
}

/// [`traversal::any_hit`] over sixteen-wide nodes, compiled with AVX-512.
///
/// # Safety
/// As for [`closest_hit`].
#[target_feature(enable = "avx512f,avx2,fma")]
pub(crate) unsafe fn any_hit(
    nodes: &Nodes16,
    leaves: &Leaves,
    root: ChildRef,
    ray: &Ray,
    stack: &mut [MaybeUninit<(ChildRef, f32)>],
) -> bool {
    // SAFETY: the caller's contract.
    unsafe { traversal::any_hit(nodes, leaves, root, ray, stack) }
}
