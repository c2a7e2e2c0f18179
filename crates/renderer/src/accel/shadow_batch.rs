//! Shadow rays traced together: [`Accel::occluded_batch`] groups a batch's rays by octant and
//! largest axis and traces each group as any-hit packets of eight (AVX2) or sixteen (AVX-512)
//! ([`super::x86_64::shadow_packet`]), every ray getting exactly the answer of
//! [`Accel::occluded`].

use super::Accel;
use crate::ray::Ray;
use std::sync::OnceLock;

/// The most rays one call groups at once; longer batches are cut into runs of this many.
pub const SHADOW_BATCH: usize = 256;

/// Group keys: 8 octants × 3 largest axes.
#[cfg(target_arch = "x86_64")]
const KEYS: usize = 24;

/// The fewest rays of one group traced as a packet (fewer go one by one): `TORREY_SHADOW_PACKET`
/// sets it (0 turns shadow packets off), else half a packet.
fn min_lanes(width: usize) -> usize {
    static MIN: OnceLock<Option<usize>> = OnceLock::new();
    match *MIN.get_or_init(|| {
        std::env::var("TORREY_SHADOW_PACKET")
            .ok()
            .and_then(|v| v.parse().ok())
    }) {
        Some(0) => usize::MAX,
        Some(n) => n.max(1),
        None => width / 2,
    }
}

/// How far apart a packet's rays may be ([`coherent`]): `TORREY_SHADOW_SPREAD` sets it, else a
/// quarter.
fn spread() -> f32 {
    static SPREAD: OnceLock<f32> = OnceLock::new();
    *SPREAD.get_or_init(|| {
        std::env::var("TORREY_SHADOW_SPREAD")
            .ok()
            .and_then(|v| v.parse().ok())
            .unwrap_or(0.25)
    })
}

/// Whether `rays` are close enough to one another for a packet to pay: the boxes around their
/// origins and around their end points both within `spread` × their mean length (a pixel's first
/// hits towards one light, not rays scattered over the scene, which a packet would trace as the
/// union of their paths through the tree). An infinite `spread` packs any rays (tests).
#[cfg(target_arch = "x86_64")]
#[inline]
fn coherent(rays: &[Ray], spread: f32) -> bool {
    if spread == f32::INFINITY {
        return true;
    }
    let (mut o_min, mut o_max) = (rays[0].origin, rays[0].origin);
    let first_end = rays[0].origin + rays[0].dir * rays[0].tmax;
    let (mut e_min, mut e_max) = (first_end, first_end);
    let mut length = 0.0;
    for ray in rays {
        let end = ray.origin + ray.dir * ray.tmax;
        (o_min, o_max) = (o_min.min(ray.origin), o_max.max(ray.origin));
        (e_min, e_max) = (e_min.min(end), e_max.max(end));
        length += ray.tmax;
    }
    let diagonal = (o_max - o_min).length().max((e_max - e_min).length());
    // False for NaN and infinite spreads or lengths.
    diagonal <= spread * length / rays.len() as f32
}

/// The fewest primitives for which shadow packets are traced: in smaller trees a single ray's
/// traversal is too short for a packet to save anything (the 38-triangle Cornell box measured
/// 3-6% slower with packets, the 4k-triangle textured_mesh faster).
const MIN_PRIMITIVES: usize = 1024;

impl Accel {
    /// Whether [`Accel::occluded_batch`] is worth calling for a batch of `count` shadow rays:
    /// packets on this CPU and layout, a tree large enough ([`MIN_PRIMITIVES`]), and rays
    /// enough for two packets (groups split by octant, and a wavefront stage's later bounces,
    /// with few rays, are rarely coherent). Otherwise [`Accel::occluded`] ray by ray costs less.
    pub fn shadow_packets_pay(&self, count: usize) -> bool {
        let width = self.packet_width();
        width > 0
            && count >= 2 * width
            && self.primitive_count >= MIN_PRIMITIVES
            && min_lanes(width) <= width
    }

    /// [`Accel::occluded`] of every ray of `rays`, into `occluded`, bit-identical; traced as
    /// packets where the CPU and the node layout allow ([`Accel::packet_width`] rays each).
    pub fn occluded_batch(&self, rays: &[Ray], occluded: &mut [bool]) {
        let width = self.packet_width();
        self.occluded_batch_with(rays, occluded, width, min_lanes(width), spread());
    }

    /// [`Accel::occluded_batch`] with packets of `width` rays (0: none), groups of fewer than
    /// `min_lanes` rays traced one by one, and packets only of rays within `spread`
    /// ([`coherent`]).
    pub(crate) fn occluded_batch_with(
        &self,
        rays: &[Ray],
        occluded: &mut [bool],
        width: usize,
        min_lanes: usize,
        spread: f32,
    ) {
        assert_eq!(rays.len(), occluded.len(), "one answer per ray");
        // No packets where the tree does not take them (no wide layout, a tree too deep for
        // the fixed stack, an empty scene), whatever `width` asks for.
        if width == 0
            || self.packet_width() == 0
            || self.root == super::traversal::EMPTY
            || rays.len() < min_lanes
        {
            for (ray, occluded) in rays.iter().zip(occluded) {
                *occluded = self.occluded(ray);
            }
            return;
        }
        for (rays, occluded) in rays
            .chunks(SHADOW_BATCH)
            .zip(occluded.chunks_mut(SHADOW_BATCH))
        {
            self.occluded_run(rays, occluded, (width, min_lanes, spread));
        }
    }

    /// One run of at most [`SHADOW_BATCH`] rays: a counting sort by group key, then each group
    /// in packets, those rays that are not [`coherent`] enough one by one.
    #[cfg(target_arch = "x86_64")]
    fn occluded_run(
        &self,
        rays: &[Ray],
        occluded: &mut [bool],
        (width, min_lanes, spread): (usize, usize, f32),
    ) {
        use super::x86_64::shadow_packet::{group_key, ShadowBatch, ShadowPacket};
        use std::cell::RefCell;
        use std::mem::MaybeUninit;
        thread_local! {
            static BATCH: RefCell<Box<ShadowBatch>> = RefCell::new(ShadowBatch::new());
        }
        let mut keys = [0u8; SHADOW_BATCH];
        let mut starts = [0u16; KEYS + 1];
        for (key, ray) in keys.iter_mut().zip(rays) {
            *key = group_key(ray) as u8;
            starts[*key as usize + 1] += 1;
        }
        for k in 0..KEYS {
            starts[k + 1] += starts[k];
        }
        BATCH.with_borrow_mut(|batch| {
            let mut next = starts;
            let mut order = [0u16; SHADOW_BATCH];
            let mut sorted = [const { MaybeUninit::<Ray>::uninit() }; SHADOW_BATCH];
            for (i, (&key, ray)) in keys.iter().zip(rays).enumerate() {
                let at = next[key as usize] as usize;
                next[key as usize] += 1;
                order[at] = i as u16;
                sorted[at].write(*ray);
            }
            // SAFETY: every entry below rays.len() was written (the groups' ranges cover them).
            let sorted =
                unsafe { std::slice::from_raw_parts(sorted.as_ptr().cast::<Ray>(), rays.len()) };
            for key in 0..KEYS {
                let (first, end) = (starts[key] as usize, starts[key + 1] as usize);
                let mut at = first;
                while at < end {
                    let count = (end - at).min(width);
                    if count < min_lanes || !coherent(&sorted[at..at + count], spread) {
                        let single = if count < min_lanes { end } else { at + count };
                        for (&i, ray) in order[at..single].iter().zip(&sorted[at..single]) {
                            occluded[i as usize] = self.occluded(ray);
                        }
                        at = single;
                        continue;
                    }
                    // The constants only of the rays packed (the others' set-up is the single-ray
                    // traversal's).
                    for (k, ray) in sorted[at..at + count].iter().enumerate() {
                        batch.set(at + k, ray);
                    }
                    let packet = ShadowPacket::new(batch, at, &sorted[at..at + count], key);
                    let blocked = self.occluded_packet(&packet, width);
                    for (lane, &i) in order[at..at + count].iter().enumerate() {
                        occluded[i as usize] = blocked & (1 << lane) != 0;
                    }
                    at += count;
                }
            }
        });
    }

    /// The lanes of `packet` that something blocks; it holds at most `width` rays (8, or 16
    /// with AVX-512).
    #[cfg(target_arch = "x86_64")]
    fn occluded_packet(
        &self,
        packet: &super::x86_64::shadow_packet::ShadowPacket,
        width: usize,
    ) -> u32 {
        use super::x86_64::shadow_packet::*;
        use super::Layout;
        // SAFETY: a packet width is non-zero only for wide layouts (which exist only on CPUs
        // with their instruction sets, AVX-512 for sixteen-wide nodes) whose tree fits the
        // fixed stack and is not empty (`Accel::packet_width`); sixteen lanes are asked for only
        // on CPUs with AVX-512 (checked here), and the packet holds at most `width` rays.
        unsafe {
            match (&self.layout, width) {
                (Layout::Eight(nodes), 8) => occluded8_8(nodes, &self.leaves, self.root, packet),
                (Layout::Sixteen(nodes), 8) => occluded8_16(nodes, &self.leaves, self.root, packet),
                (Layout::Eight(nodes), 16) if super::Simd::detect() == super::Simd::Avx512 => {
                    occluded16_8(nodes, &self.leaves, self.root, packet)
                }
                (Layout::Sixteen(nodes), 16) => {
                    occluded16_16(nodes, &self.leaves, self.root, packet)
                }
                _ => packet
                    .rays()
                    .iter()
                    .enumerate()
                    .fold(0, |m, (k, ray)| m | (self.occluded(ray) as u32) << k),
            }
        }
    }

    /// No packets on this target: one by one.
    #[cfg(not(target_arch = "x86_64"))]
    fn occluded_run(&self, rays: &[Ray], occluded: &mut [bool], _rule: (usize, usize, f32)) {
        for (ray, occluded) in rays.iter().zip(occluded) {
            *occluded = self.occluded(ray);
        }
    }
}
