//! Shadow rays traced together: [`Accel::occluded_batch`] groups a batch's rays by octant and
//! largest axis and traces each group as any-hit packets of eight (AVX2) or sixteen (AVX-512)
//! ([`super::x86_64::shadow_packet`]), every ray getting exactly the answer of
//! [`Accel::occluded`].

use super::traversal::reciprocal;
use super::triangle4::Ray4;
use super::Accel;
use crate::ray::Ray;
use glam::Vec3A;
use std::sync::OnceLock;

/// The most rays one call groups at once; longer batches are cut into runs of this many.
pub const SHADOW_BATCH: usize = 256;

/// Group keys: 8 octants × 3 largest axes.
const KEYS: usize = 24;

/// The group of a ray: its octant (the bound rows its box tests read) and the largest axis of
/// its direction (the watertight test's permutation), computed as the single-ray set-up does.
#[inline]
pub(crate) fn group_key(ray: &Ray) -> usize {
    let inv = reciprocal(ray);
    let octant = inv.cmplt(Vec3A::ZERO).bitmask() as usize & 7;
    let kz = Ray4::for_ray(ray, inv).lane_constants().0[2];
    octant * 3 + kz
}

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

impl Accel {
    /// [`Accel::occluded`] of every ray of `rays`, into `occluded`, bit-identical; traced as
    /// packets where the CPU and the node layout allow ([`Accel::packet_width`] rays each).
    pub fn occluded_batch(&self, rays: &[Ray], occluded: &mut [bool]) {
        let width = self.packet_width();
        self.occluded_batch_with(rays, occluded, width, min_lanes(width));
    }

    /// [`Accel::occluded_batch`] with packets of `width` rays (0: none), groups of fewer than
    /// `min_lanes` rays traced one by one.
    pub(crate) fn occluded_batch_with(
        &self,
        rays: &[Ray],
        occluded: &mut [bool],
        width: usize,
        min_lanes: usize,
    ) {
        assert_eq!(rays.len(), occluded.len(), "one answer per ray");
        if width == 0 || self.root == super::traversal::EMPTY || rays.len() < min_lanes {
            for (ray, occluded) in rays.iter().zip(occluded) {
                *occluded = self.occluded(ray);
            }
            return;
        }
        for (rays, occluded) in rays
            .chunks(SHADOW_BATCH)
            .zip(occluded.chunks_mut(SHADOW_BATCH))
        {
            self.occluded_run(rays, occluded, width, min_lanes);
        }
    }

    /// One run of at most [`SHADOW_BATCH`] rays: a counting sort by [`group_key`], then each
    /// group in packets.
    fn occluded_run(&self, rays: &[Ray], occluded: &mut [bool], width: usize, min_lanes: usize) {
        let mut keys = [0u8; SHADOW_BATCH];
        let mut starts = [0u16; KEYS + 1];
        for (key, ray) in keys.iter_mut().zip(rays) {
            *key = group_key(ray) as u8;
            starts[*key as usize + 1] += 1;
        }
        for k in 0..KEYS {
            starts[k + 1] += starts[k];
        }
        let mut next = starts;
        let mut order = [0u16; SHADOW_BATCH];
        for (i, &key) in keys[..rays.len()].iter().enumerate() {
            order[next[key as usize] as usize] = i as u16;
            next[key as usize] += 1;
        }
        for k in 0..KEYS {
            let group = &order[starts[k] as usize..starts[k + 1] as usize];
            for members in group.chunks(width) {
                if members.len() < min_lanes {
                    for &i in members {
                        occluded[i as usize] = self.occluded(&rays[i as usize]);
                    }
                    continue;
                }
                let blocked = self.occluded_packet(members, rays, width);
                for (lane, &i) in members.iter().enumerate() {
                    occluded[i as usize] = blocked & (1 << lane) != 0;
                }
            }
        }
    }

    /// The lanes (bit i: ray `members[i]` of `rays`) that something blocks; the members share
    /// their group key and are at most `width` (8, or 16 with AVX-512).
    #[cfg(target_arch = "x86_64")]
    fn occluded_packet(&self, members: &[u16], rays: &[Ray], width: usize) -> u32 {
        use super::x86_64::shadow_packet::*;
        use super::Layout;
        let packet = ShadowPacket::new(members.iter().map(|&i| rays[i as usize]));
        // SAFETY: a packet width is non-zero only for wide layouts (which exist only on CPUs
        // with their instruction sets, AVX-512 for sixteen-wide nodes) whose tree fits the
        // fixed stack and is not empty (`Accel::packet_width`); sixteen lanes are asked for only
        // on CPUs with AVX-512 (checked here), and the packet holds at most `width` rays.
        unsafe {
            match (&self.layout, width) {
                (Layout::Eight(nodes), 8) => occluded8_8(nodes, &self.leaves, self.root, &packet),
                (Layout::Sixteen(nodes), 8) => {
                    occluded8_16(nodes, &self.leaves, self.root, &packet)
                }
                (Layout::Eight(nodes), 16) if super::Simd::detect() == super::Simd::Avx512 => {
                    occluded16_8(nodes, &self.leaves, self.root, &packet)
                }
                (Layout::Sixteen(nodes), 16) => {
                    occluded16_16(nodes, &self.leaves, self.root, &packet)
                }
                _ => packet
                    .rays()
                    .iter()
                    .enumerate()
                    .fold(0, |m, (k, ray)| m | (self.occluded(ray) as u32) << k),
            }
        }
    }

    #[cfg(not(target_arch = "x86_64"))]
    fn occluded_packet(&self, members: &[u16], rays: &[Ray], _width: usize) -> u32 {
        members.iter().enumerate().fold(0, |m, (k, &i)| {
            m | (self.occluded(&rays[i as usize]) as u32) << k
        })
    }
}
