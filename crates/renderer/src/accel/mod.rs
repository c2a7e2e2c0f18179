//! The acceleration structure: one BVH over every primitive of the scene, triangles and analytic
//! spheres alike, with closest-hit, any-hit and packet queries.
//!
//! obvhs builds a high-quality binary BVH (PLOC, reinsertion, SAH leaf collapsing); [`build`]
//! flattens it into wide nodes whose child boxes are stored structure-of-arrays, so one ray is
//! tested against all of a node's boxes with a handful of SIMD instructions, and into leaves of
//! precomputed [`triangle4::Triangle4`] blocks. The traversal loops ([`traversal`]) are written
//! once, generic over the node layout ([`traversal::InnerNodes`]):
//! - [`nodes4`]: four-wide nodes through glam's `Vec4` (SSE2 on x86-64, scalar or NEON
//!   elsewhere): the portable layout, on every CPU.
//! - [`x86_64::avx2`]: eight-wide nodes tested with AVX2 and FMA, and camera-ray packets of
//!   eight. Two thirds of the levels, each one 8-wide test: 11-28% more rays per second than
//!   four-wide nodes on the project's scenes (`cargo bench --bench traversal`).
//! - [`x86_64::avx512`]: sixteen-wide nodes tested with AVX-512, on request
//!   (`BvhWidth::Sixteen`): on a Zen 5 CPU they measured no faster than eight-wide ones, which
//!   stay the default there; and camera-ray packets of sixteen through either wide layout (the
//!   default there: the node tests of a packet are shared by twice the rays).
//!
//! The instruction set is chosen once, at start-up ([`Simd::detect`]); a layout for a new ISA is a
//! node file implementing [`traversal::InnerNodes`] plus a variant of [`Layout`].
//!
//! Every child reference a node holds is valid by construction: unused lanes point at an empty
//! leaf, not at a sentinel. The slab test rejects those lanes for finite rays, but a ray with a
//! NaN component passes every box test (the SIMD min/max return an operand that is not NaN), so
//! the traversal must never depend on geometry to avoid an invalid reference.

mod build;
pub mod instances;
mod leaves;
mod nodes4;
mod ploc;
mod shadow_batch;
#[cfg(test)]
mod shadow_tests;
#[cfg(test)]
mod tests;
pub(crate) mod traversal;
mod triangle4;
#[cfg(target_arch = "x86_64")]
pub(crate) mod x86_64;

use crate::ray::Ray;
use glam::Vec3A;
use leaves::Leaves;
use nodes4::Nodes4;
pub use shadow_batch::SHADOW_BATCH;
use std::mem::MaybeUninit;
use std::sync::OnceLock;
use traversal::{any_hit, closest_hit, ChildRef, InnerNodes, EMPTY, STACK_SIZE};

pub use crate::ray::ClosestHit;
pub use crate::shapes::PrimGeom;

/// Which node width to build.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum BvhWidth {
    /// The default of the instruction set chosen at start-up ([`Simd::auto_width`]).
    Auto,
    Four,
    /// Eight-wide nodes; falls back to four without AVX2 and FMA.
    Eight,
    /// Sixteen-wide nodes; falls back to eight without AVX-512 (and to four without AVX2).
    Sixteen,
}

/// How a BVH is to be built: its node width, and the work it will serve.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct AccelOptions {
    pub width: BvhWidth,
    /// Camera samples of the whole render (film pixels × spp; a part of a split render counts
    /// the whole render's, so that every part traces the same tree): how much build effort
    /// pays off is judged by them per primitive ([`build::HIGH_QUALITY_SAMPLES_PER_PRIM`]).
    pub samples: u64,
}

impl AccelOptions {
    /// The highest-quality build whatever its cost (tests, and callers that trace many rays).
    pub fn best(width: BvhWidth) -> Self {
        Self {
            width,
            samples: u64::MAX,
        }
    }
}

/// The instruction set the traversal kernels use, chosen once per process.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Simd {
    /// Baseline code only (SSE2 on x86-64): four-wide nodes, no packets.
    Portable,
    /// AVX2 and FMA: eight-wide nodes and packets of eight camera rays.
    Avx2,
    /// AVX-512 (F, BW, VL, with AVX2 and FMA): the Sobol sampler's columns sixteen lanes wide,
    /// packets of sixteen camera rays, and sixteen-wide nodes on request.
    Avx512,
}

impl Simd {
    /// The best level this CPU runs, unless the environment variable `TORREY_SIMD` caps it:
    /// `portable` forces the portable kernels (CI runs the test suite both ways), `avx2` stops
    /// below AVX-512.
    pub fn detect() -> Simd {
        static LEVEL: OnceLock<Simd> = OnceLock::new();
        *LEVEL.get_or_init(|| {
            if std::env::var("TORREY_SIMD").is_ok_and(|v| v.eq_ignore_ascii_case("portable")) {
                return Simd::Portable;
            }
            #[cfg(target_arch = "x86_64")]
            if std::env::var("TORREY_SIMD").is_ok_and(|v| v.eq_ignore_ascii_case("avx2")) {
                if x86_64::avx2::available() {
                    return Simd::Avx2;
                }
                return Simd::Portable;
            }
            #[cfg(target_arch = "x86_64")]
            if x86_64::avx512::available() {
                return Simd::Avx512;
            }
            #[cfg(target_arch = "x86_64")]
            if x86_64::avx2::available() {
                return Simd::Avx2;
            }
            Simd::Portable
        })
    }

    /// The name printed in render summaries and benchmark tables.
    pub fn name(self) -> &'static str {
        match self {
            Simd::Portable => "portable",
            Simd::Avx2 => "avx2+fma",
            Simd::Avx512 => "avx512",
        }
    }

    /// The node width [`BvhWidth::Auto`] builds at this level for `primitives` primitives.
    pub fn auto_width(self, primitives: usize) -> usize {
        match self {
            Simd::Portable => 4,
            Simd::Avx2 => 8,
            Simd::Avx512 if primitives >= AVX512_SIXTEEN_FROM => 16,
            Simd::Avx512 => 8,
        }
    }
}

/// From how many primitives the default on AVX-512 CPUs is sixteen-wide nodes (eight below).
/// Measured on an Intel Xeon (Sapphire Rapids), render CPU seconds, one thread, the fastest of
/// five alternated runs, 16 against 8: staircase (263k triangles) +10%, matpreview-glass and
/// -copper (62k) +10% and +6%, bunny-sss (70k) +10%, clover-banner (62k) +12%, stage-lights
/// (112k) +3%, the living room (296k, two bounces, mostly camera packets) 0%; on small scenes
/// no gain or a loss: textured_mesh (4k) 0%, cbox (38) -5%. A node test covers twice the boxes
/// for a quarter fewer levels, which pays where deep trees are walked by incoherent rays (an
/// earlier measurement on an AMD EPYC, Zen 5, found 16 no faster on the four benchmark scenes,
/// all below 10k primitives but the living room). `--bvh-width` overrides.
const AVX512_SIXTEEN_FROM: usize = 10_000;

/// Whether camera packets are sixteen rays wide: on CPUs with AVX-512, unless the environment
/// variable `TORREY_PACKET=8` asks for eight.
#[cfg(target_arch = "x86_64")]
fn packet16() -> bool {
    static SIXTEEN: OnceLock<bool> = OnceLock::new();
    *SIXTEEN.get_or_init(|| {
        Simd::detect() == Simd::Avx512 && std::env::var("TORREY_PACKET").map_or(true, |v| v != "8")
    })
}

/// The node layout a BVH was built with: one variant per width and instruction set.
enum Layout {
    Four(Nodes4),
    #[cfg(target_arch = "x86_64")]
    Eight(x86_64::avx2::Nodes8),
    #[cfg(target_arch = "x86_64")]
    Sixteen(x86_64::avx512::Nodes16),
}

/// The scene's BVH.
pub struct Accel {
    layout: Layout,
    leaves: Leaves,
    root: ChildRef,
    /// The largest stack a traversal can need: width - 1 pushes per level below the root,
    /// plus one.
    stack_needed: usize,
    primitive_count: usize,
}

impl Accel {
    /// Builds the BVH over `geoms`; primitive indices in hits refer to positions in `geoms`. An
    /// empty scene gives an accelerator that every ray misses. Primitives with non-finite bounds
    /// must have been removed by the caller (obvhs's builder cannot order them).
    pub fn build(geoms: &[PrimGeom], width: BvhWidth) -> Self {
        Self::build_with(geoms, &[], AccelOptions::best(width))
    }

    /// [`Accel::build`] over primitives that include `sdfgrid` voxels: each
    /// [`PrimGeom::SdfVoxel`]'s `index` is a position in `sdf_voxels`.
    pub fn build_with(
        geoms: &[PrimGeom],
        sdf_voxels: &[crate::shapes::sdfgrid::SdfVoxel],
        options: AccelOptions,
    ) -> Self {
        let simd = Simd::detect();
        let widest = match simd {
            Simd::Portable => 4,
            Simd::Avx2 => 8,
            Simd::Avx512 => 16,
        };
        let width = match options.width {
            BvhWidth::Auto => simd.auto_width(geoms.len()),
            BvhWidth::Four => 4,
            BvhWidth::Eight => 8,
            BvhWidth::Sixteen => 16,
        }
        .min(widest);
        let (layout, leaves, root, depth) = build::build(geoms, sdf_voxels, width, options.samples);
        Self {
            // A node pushes at most all but one of its children, at each level below the root.
            stack_needed: (layout.width() - 1) * depth + 1,
            layout,
            leaves,
            root,
            primitive_count: geoms.len(),
        }
    }

    /// Children per inner node (4, 8 or 16).
    pub fn bvh_width(&self) -> usize {
        self.layout.width()
    }

    pub fn primitive_count(&self) -> usize {
        self.primitive_count
    }

    /// Closest hit with t in (0, ray.tmax).
    #[inline]
    pub fn intersect(&self, ray: &Ray) -> Option<ClosestHit> {
        if self.root == EMPTY {
            return None;
        }
        if self.stack_needed > STACK_SIZE {
            return self.intersect_deep(ray);
        }
        // Uninitialised: zeroing the stack per ray showed up in profiles as 3% memset.
        let stack = &mut [const { MaybeUninit::uninit() }; STACK_SIZE];
        // SAFETY: the stack holds STACK_SIZE >= stack_needed entries.
        unsafe { self.layout.closest_hit(&self.leaves, self.root, ray, stack) }
    }

    /// True when anything lies along the ray with t in (0, ray.tmax); stops at the first hit.
    #[inline]
    pub fn occluded(&self, ray: &Ray) -> bool {
        if self.root == EMPTY {
            return false;
        }
        if self.stack_needed > STACK_SIZE {
            return self.occluded_deep(ray);
        }
        let stack = &mut [const { MaybeUninit::uninit() }; STACK_SIZE];
        // SAFETY: the stack holds STACK_SIZE >= stack_needed entries.
        unsafe { self.layout.any_hit(&self.leaves, self.root, ray, stack) }
    }

    /// Rays per packet this layout prefers to trace together (0: no packet traversal): sixteen
    /// with AVX-512 (`TORREY_PACKET=8` asks for eight), eight with AVX2. Packets of eight are
    /// traced wherever packets are.
    pub fn packet_width(&self) -> usize {
        match &self.layout {
            #[cfg(target_arch = "x86_64")]
            Layout::Eight(_) | Layout::Sixteen(_) if self.stack_needed <= STACK_SIZE => {
                if packet16() {
                    x86_64::avx512::packet16::PACKET16
                } else {
                    x86_64::avx2::PACKET
                }
            }
            _ => 0,
        }
    }

    /// Closest hits, in (0, ∞), of rays from one `origin` along the unit directions `dirs`
    /// (eight of them, or sixteen on CPUs with AVX-512), written to `hits`. False when they were
    /// not traced (no packet layout, another count, or directions in different octants or with
    /// different largest axes): the caller then traces them one by one. Each ray finds the hit it
    /// finds alone.
    #[inline]
    pub fn intersect_packet(
        &self,
        origin: Vec3A,
        dirs: &[Vec3A],
        hits: &mut [Option<ClosestHit>],
    ) -> bool {
        #[cfg(not(target_arch = "x86_64"))]
        {
            let _ = (origin, dirs, hits); // no packet layout on this target
            false
        }
        #[cfg(target_arch = "x86_64")]
        {
            if self.packet_width() == 0 || dirs.len() != hits.len() {
                return false;
            }
            if dirs.len() == x86_64::avx512::packet16::PACKET16 {
                if Simd::detect() != Simd::Avx512 {
                    return false;
                }
                let (Ok(dirs), Ok(hits)) = (dirs.try_into(), hits.try_into()) else {
                    return false;
                };
                // SAFETY: checked for AVX-512 above, and as below.
                return match &self.layout {
                    // SAFETY: AVX-512 was detected above (it includes AVX2 and FMA, which `Nodes8`
                    // needed to exist); eight-wide nodes exist only under an inner root (never for
                    // an empty scene), and `packet_width` checked that the tree fits the packet
                    // stack.
                    Layout::Eight(nodes) => unsafe {
                        x86_64::avx512::packet16::closest_hits16_8(
                            nodes,
                            &self.leaves,
                            self.root,
                            origin,
                            dirs,
                            hits,
                        )
                    },
                    // SAFETY: AVX-512 was detected above (which `Nodes16` needed to exist too);
                    // sixteen-wide nodes exist only under an inner root (never for an empty scene),
                    // and `packet_width` checked that the tree fits the packet stack.
                    Layout::Sixteen(nodes) => unsafe {
                        x86_64::avx512::packet16::closest_hits16_16(
                            nodes,
                            &self.leaves,
                            self.root,
                            origin,
                            dirs,
                            hits,
                        )
                    },
                    Layout::Four(_) => false,
                };
            }
            let (Ok(dirs), Ok(hits)) = (dirs.try_into(), hits.try_into()) else {
                return false;
            };
            // SAFETY: the node layouts exist only on CPUs with their instruction sets (AVX2 and
            // FMA; AVX-512 too for sixteen-wide nodes), wide nodes only under an inner root
            // (never for an empty scene), and `packet_width` checked that the tree fits the
            // packet stack.
            match &self.layout {
                // SAFETY: `Nodes8` exists only on CPUs with AVX2 and FMA, only under an inner root,
                // and `packet_width` checked that the tree fits the packet stack.
                Layout::Eight(nodes) => unsafe {
                    x86_64::avx2::packet::closest_hits(
                        nodes,
                        &self.leaves,
                        self.root,
                        origin,
                        dirs,
                        hits,
                    )
                },
                // SAFETY: `Nodes16` exists only on CPUs with AVX-512 (with AVX2 and FMA), only
                // under an inner root, and `packet_width` checked that the tree fits the packet
                // stack.
                Layout::Sixteen(nodes) => unsafe {
                    x86_64::avx2::packet::closest_hits16(
                        nodes,
                        &self.leaves,
                        self.root,
                        origin,
                        dirs,
                        hits,
                    )
                },
                Layout::Four(_) => false,
            }
        }
    }

    /// [`Accel::intersect`] for trees too deep for the fixed stack (never seen in practice).
    #[cold]
    #[inline(never)]
    fn intersect_deep(&self, ray: &Ray) -> Option<ClosestHit> {
        let stack = &mut vec![MaybeUninit::uninit(); self.stack_needed];
        // SAFETY: the stack holds stack_needed entries.
        unsafe { self.layout.closest_hit(&self.leaves, self.root, ray, stack) }
    }

    #[cold]
    #[inline(never)]
    fn occluded_deep(&self, ray: &Ray) -> bool {
        let stack = &mut vec![MaybeUninit::uninit(); self.stack_needed];
        // SAFETY: the stack holds stack_needed entries.
        unsafe { self.layout.any_hit(&self.leaves, self.root, ray, stack) }
    }
}

impl Layout {
    /// [`closest_hit`] on this layout's nodes.
    ///
    /// # Safety
    /// `stack` must hold the tree's `stack_needed` entries.
    #[inline(always)]
    unsafe fn closest_hit(
        &self,
        leaves: &Leaves,
        root: ChildRef,
        ray: &Ray,
        stack: &mut [MaybeUninit<(ChildRef, f32)>],
    ) -> Option<ClosestHit> {
        match self {
            // SAFETY: (all arms) the stack holds `stack_needed` entries (the caller's contract).
            Layout::Four(nodes) => unsafe { closest_hit4(nodes, leaves, root, ray, stack) },
            // SAFETY: `Nodes8` exists only on CPUs with AVX2 and FMA (checked in its build).
            #[cfg(target_arch = "x86_64")]
            Layout::Eight(nodes) => unsafe {
                x86_64::avx2::closest_hit(nodes, leaves, root, ray, stack)
            },
            // SAFETY: `Nodes16` exists only on CPUs with AVX-512 (checked in its build).
            #[cfg(target_arch = "x86_64")]
            Layout::Sixteen(nodes) => unsafe {
                x86_64::avx512::closest_hit(nodes, leaves, root, ray, stack)
            },
        }
    }

    /// [`any_hit`] on this layout's nodes.
    ///
    /// # Safety
    /// As for [`Layout::closest_hit`].
    #[inline(always)]
    unsafe fn any_hit(
        &self,
        leaves: &Leaves,
        root: ChildRef,
        ray: &Ray,
        stack: &mut [MaybeUninit<(ChildRef, f32)>],
    ) -> bool {
        match self {
            // SAFETY: (all arms) the stack holds `stack_needed` entries (the caller's contract).
            Layout::Four(nodes) => unsafe { any_hit4(nodes, leaves, root, ray, stack) },
            // SAFETY: as in `closest_hit`.
            #[cfg(target_arch = "x86_64")]
            Layout::Eight(nodes) => unsafe {
                x86_64::avx2::any_hit(nodes, leaves, root, ray, stack)
            },
            // SAFETY: as in `closest_hit`.
            #[cfg(target_arch = "x86_64")]
            Layout::Sixteen(nodes) => unsafe {
                x86_64::avx512::any_hit(nodes, leaves, root, ray, stack)
            },
        }
    }

    /// Children per inner node.
    fn width(&self) -> usize {
        match self {
            Layout::Four(_) => <Nodes4 as InnerNodes>::WIDTH,
            #[cfg(target_arch = "x86_64")]
            Layout::Eight(_) => <x86_64::avx2::Nodes8 as InnerNodes>::WIDTH,
            #[cfg(target_arch = "x86_64")]
            Layout::Sixteen(_) => <x86_64::avx512::Nodes16 as InnerNodes>::WIDTH,
        }
    }
}

/// [`closest_hit`] over four-wide nodes, out of line like the other layouts' kernels: inlined
/// into [`Accel::intersect`], its registers made every query save and restore six more.
///
/// # Safety
/// As for [`closest_hit`].
#[inline(never)]
unsafe fn closest_hit4(
    nodes: &Nodes4,
    leaves: &Leaves,
    root: ChildRef,
    ray: &Ray,
    stack: &mut [MaybeUninit<(ChildRef, f32)>],
) -> Option<ClosestHit> {
    // SAFETY: the caller's contract.
    unsafe { closest_hit(nodes, leaves, root, ray, stack) }
}

/// [`any_hit`] over four-wide nodes, out of line as [`closest_hit4`].
///
/// # Safety
/// As for [`any_hit`].
#[inline(never)]
unsafe fn any_hit4(
    nodes: &Nodes4,
    leaves: &Leaves,
    root: ChildRef,
    ray: &Ray,
    stack: &mut [MaybeUninit<(ChildRef, f32)>],
) -> bool {
    // SAFETY: the caller's contract.
    unsafe { any_hit(nodes, leaves, root, ray, stack) }
}
