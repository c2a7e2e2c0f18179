//! Shadow packets ([`Accel::occluded_batch`]) against single-ray any-hit queries: the same
//! boolean for every ray, on every node layout and packet width the CPU has.

use super::*;
use crate::ray::Ray;
use glam::Vec3A;

/// A scene built to make the single-ray tests' edge cases common: a grid of triangles whose
/// shared vertices and edges rays pass exactly through (edge functions exactly zero: the
/// double-precision fallback), an axis-aligned floor (flat boxes), a random triangle cloud,
/// spheres, a disk and a cylinder (leaves tested ray by ray).
fn adversarial_scene(rnd: &mut impl FnMut() -> f32) -> Vec<PrimGeom> {
    let mut geoms = Vec::new();
    // A 12 × 12 grid at z = 1 of unit squares, two triangles each, sharing edges and vertices.
    for i in 0..12 {
        for j in 0..12 {
            let p =
                |di: i32, dj: i32| Vec3A::new((i + di) as f32 - 6.0, (j + dj) as f32 - 6.0, 1.0);
            geoms.push(PrimGeom::Triangle {
                p0: p(0, 0),
                p1: p(1, 0),
                p2: p(1, 1),
            });
            geoms.push(PrimGeom::Triangle {
                p0: p(0, 0),
                p1: p(1, 1),
                p2: p(0, 1),
            });
        }
    }
    // An axis-aligned floor at y = -3.
    geoms.push(PrimGeom::Triangle {
        p0: Vec3A::new(-8.0, -3.0, -8.0),
        p1: Vec3A::new(8.0, -3.0, -8.0),
        p2: Vec3A::new(8.0, -3.0, 8.0),
    });
    geoms.push(PrimGeom::Triangle {
        p0: Vec3A::new(-8.0, -3.0, -8.0),
        p1: Vec3A::new(8.0, -3.0, 8.0),
        p2: Vec3A::new(-8.0, -3.0, 8.0),
    });
    for i in 0..500 {
        let c = Vec3A::new(rnd() * 5.0, rnd() * 5.0, rnd() * 3.0 - 2.0);
        if i % 9 == 0 {
            geoms.push(PrimGeom::Sphere {
                center: c,
                radius: 0.1 + 0.2 * rnd().abs(),
            });
        } else {
            let p1 = c + Vec3A::new(rnd(), rnd(), rnd()) * 0.4;
            let p2 = c + Vec3A::new(rnd(), rnd(), rnd()) * 0.4;
            geoms.push(PrimGeom::Triangle { p0: c, p1, p2 });
        }
    }
    use crate::shapes::{cylinder::Cylinder, disk::Disk};
    use glam::{Mat4, Vec3};
    geoms.push(
        Disk::new(Mat4::from_translation(Vec3::new(2.0, 2.0, -1.0)))
            .unwrap()
            .prim_geom(),
    );
    geoms.push(
        Cylinder::new(
            Vec3::ZERO,
            Vec3::Z,
            0.5,
            Mat4::from_translation(Vec3::new(-2.0, 1.0, -2.0)),
        )
        .unwrap()
        .prim_geom(),
    );
    geoms
}

/// Shadow rays of every kind: from random points and from points on the surfaces (hits of
/// earlier rays) towards a point light and area-light points, through grid vertices and edge
/// midpoints, with `tmax` exactly at a hit and one ulp either side, and non-finite ones.
fn adversarial_rays(accel: &Accel, rnd: &mut impl FnMut() -> f32) -> Vec<Ray> {
    let mut rays = Vec::new();
    let light = Vec3A::new(0.3, 0.7, 6.0);
    let toward = |origin: Vec3A, target: Vec3A| {
        let d = target - origin;
        let len = d.length();
        Ray {
            origin,
            dir: d / len,
            tmax: len * (1.0 - 1e-4),
        }
    };
    for _ in 0..3000 {
        let origin = Vec3A::new(rnd() * 6.0, rnd() * 6.0, rnd() * 3.0 - 2.0);
        // To the point light, to points of a 2 × 2 area light, through a grid vertex (z = 1).
        rays.push(toward(origin, light));
        rays.push(toward(origin, light + Vec3A::new(rnd(), rnd(), 0.0)));
        let vertex = Vec3A::new((rnd() * 5.0).round(), (rnd() * 5.0).round(), 1.0);
        let mut through = toward(origin, vertex);
        through.tmax = f32::INFINITY;
        rays.push(through);
        let midpoint = vertex + Vec3A::new(0.5, 0.0, 0.0);
        rays.push(Ray {
            tmax: 20.0,
            ..toward(origin, midpoint)
        });
        // Straight down a vertex and along an edge: exact zeros in the edge functions.
        rays.push(Ray {
            origin: Vec3A::new(vertex.x, vertex.y, 4.0),
            dir: -Vec3A::Z,
            tmax: 3.0 + rnd().abs(),
        });
        // From a surface point (a hit), towards the light: the origin on a triangle.
        let probe = toward(origin, Vec3A::new(rnd() * 4.0, rnd() * 4.0, rnd() * 3.0));
        if let Some(hit) = accel.intersect(&Ray {
            tmax: f32::INFINITY,
            ..probe
        }) {
            let p = probe.origin + probe.dir * hit.t;
            rays.push(toward(p, light));
            rays.push(toward(p, light + Vec3A::new(rnd(), rnd(), 0.0)));
            // tmax at the hit's distance exactly, and an ulp either side.
            for tmax in [
                hit.t,
                f32::from_bits(hit.t.to_bits() + 1),
                f32::from_bits(hit.t.to_bits() - 1),
            ] {
                rays.push(Ray { tmax, ..probe });
            }
        }
    }
    let bad = [f32::NAN, f32::INFINITY, f32::NEG_INFINITY, 0.0, -0.0, 1e-30];
    for &x in &bad {
        for (origin, dir, tmax) in [
            (Vec3A::ZERO, Vec3A::splat(x), 10.0),
            (Vec3A::splat(x), Vec3A::Z, 10.0),
            (
                Vec3A::new(x, 1.0, 2.0),
                Vec3A::new(0.0, x, 1.0),
                f32::INFINITY,
            ),
            (Vec3A::new(0.5, 0.5, -1.0), Vec3A::new(0.0, 0.0, 1.0), x),
            (Vec3A::new(0.5, 0.5, -1.0), Vec3A::new(x, 0.0, 1.0), 5.0),
        ] {
            rays.push(Ray { origin, dir, tmax });
        }
    }
    rays
}

/// Every packet width and node layout this CPU has (layout width, packet width).
fn packet_configs() -> Vec<(BvhWidth, usize)> {
    match Simd::detect() {
        Simd::Portable => vec![],
        Simd::Avx2 => vec![(BvhWidth::Eight, 8)],
        Simd::Avx512 => vec![
            (BvhWidth::Eight, 8),
            (BvhWidth::Eight, 16),
            (BvhWidth::Sixteen, 8),
            (BvhWidth::Sixteen, 16),
        ],
    }
}

/// Shadow packets answer, ray by ray, exactly what `Accel::occluded` answers: on random and
/// adversarial rays (shared edges and vertices, tmax exactly at a hit, origins on surfaces,
/// NaN and infinite components), in full and partial packets, for 8 and 16 lanes through 8- and
/// 16-wide nodes.
#[test]
fn shadow_packets_answer_as_single_rays() {
    let mut rng = torrey_testkit::Rng::new(2121);
    let mut rnd = || rng.range(-1.0, 1.0);
    let geoms = adversarial_scene(&mut rnd);
    for (layout, width) in packet_configs() {
        let accel = Accel::build(&geoms, layout);
        assert!(accel.packet_width() > 0);
        let rays = adversarial_rays(&accel, &mut rnd);
        let single: Vec<bool> = rays.iter().map(|r| accel.occluded(r)).collect();
        let blocked = single.iter().filter(|&&b| b).count();
        assert!(
            blocked > rays.len() / 5 && blocked < rays.len() * 4 / 5,
            "{blocked} of {} blocked: the test needs both answers often",
            rays.len()
        );
        // Every ray in a packet (min 1), packets of at least half, only coherent packets, and
        // the batch in random order too (other packet mates).
        for (min_lanes, spread) in [(1, f32::INFINITY), (width / 2, f32::INFINITY), (1, 0.25)] {
            let mut out = vec![false; rays.len()];
            accel.occluded_batch_with(&rays, &mut out, width, min_lanes, spread);
            for (i, (&a, &b)) in out.iter().zip(&single).enumerate() {
                assert_eq!(
                    a, b,
                    "ray {i} {:?}: packet {a}, single {b} ({layout:?}, {width} lanes)",
                    rays[i]
                );
            }
        }
        let mut shuffled = rays.clone();
        for i in (1..shuffled.len()).rev() {
            let j = ((rnd() * 0.5 + 0.5) * i as f32) as usize % (i + 1);
            shuffled.swap(i, j);
        }
        let mut out = vec![false; shuffled.len()];
        accel.occluded_batch_with(&shuffled, &mut out, width, 1, f32::INFINITY);
        for (ray, &a) in shuffled.iter().zip(&out) {
            assert_eq!(
                a,
                accel.occluded(ray),
                "{ray:?} ({layout:?}, {width} lanes)"
            );
        }
    }
}

/// The batch entry point on any CPU (portable: one by one), empty scenes and empty batches.
#[test]
fn occluded_batch_handles_any_batch() {
    let mut rng = torrey_testkit::Rng::new(5);
    let mut rnd = || rng.range(-1.0, 1.0);
    let geoms = adversarial_scene(&mut rnd);
    let accel = Accel::build(&geoms, BvhWidth::Auto);
    let rays = adversarial_rays(&accel, &mut rnd);
    let mut out = vec![false; rays.len()];
    accel.occluded_batch(&rays, &mut out);
    for (ray, &a) in rays.iter().zip(&out) {
        assert_eq!(a, accel.occluded(ray));
    }
    accel.occluded_batch(&[], &mut []);
    let empty = Accel::build(&[], BvhWidth::Auto);
    let mut out = vec![true; rays.len()];
    empty.occluded_batch(&rays, &mut out);
    assert!(out.iter().all(|&b| !b));
}
