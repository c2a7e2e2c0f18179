//! AVX2 and FMA: eight-wide BVH nodes ([`Nodes8`]), camera-ray packets of eight ([`packet`]) and
//! the eight lanes of shadow-ray packets ([`Lanes8`]). The traversal loops are the generic ones of [`crate::accel::traversal`],
//! instantiated here inside functions compiled with these features enabled. (The same loops
//! compiled with AVX-512VL too, for its 32 vector registers and no spills around the leaf tests,
//! measured no faster on a Zen 5 CPU: renders within 1-3%, not kept.)

mod lanes8;
mod nodes8;
pub(crate) mod packet;

pub(crate) use lanes8::Lanes8;
pub(crate) use nodes8::Nodes8;
pub(crate) use packet::PACKET;

use crate::accel::leaves::Leaves;
use crate::accel::traversal::{self, ChildRef};
use crate::accel::ClosestHit;
use crate::ray::Ray;
use std::mem::MaybeUninit;

/// True when this CPU can run these kernels (AVX2 and FMA, which every AVX2 CPU from Intel and
/// AMD also has).
pub fn available() -> bool {
    is_x86_feature_detected!("avx2") && is_x86_feature_detected!("fma")
}

/// [`traversal::closest_hit`] over eight-wide nodes, compiled with AVX2 and FMA.
///
/// # Safety
/// The CPU must have AVX2 and FMA ([`available`]); `Nodes8` values exist only then. `stack`
/// must hold the tree's `stack_needed` entries.
#[target_feature(enable = "avx2,fma")]
pub(crate) unsafe fn closest_hit(
    nodes: &Nodes8,
    leaves: &Leaves,
    root: ChildRef,
    ray: &Ray,
    stack: &mut [MaybeUninit<(ChildRef, f32)>],
) -> Option<ClosestHit> {
    // SAFETY: the caller's contract.
    unsafe { traversal::closest_hit(nodes, leaves, root, ray, stack) }
}

/// [`traversal::any_hit`] over eight-wide nodes, compiled with AVX2 and FMA.
///
/// # Safety
/// As for [`closest_hit`].
#[target_feature(enable = "avx2,fma")]
pub(crate) unsafe fn any_hit(
    nodes: &Nodes8,
    leaves: &Leaves,
    root: ChildRef,
    ray: &Ray,
    stack: &mut [MaybeUninit<(ChildRef, f32)>],
) -> bool {
    // SAFETY: the caller's contract.
    unsafe { traversal::any_hit(nodes, leaves, root, ray, stack) }
}
