//! Tests of the acceleration structure against brute force, for every node layout.

use super::*;
use crate::ray::Ray;
use crate::shapes::cylinder::intersect_cylinder;
use crate::shapes::disk::intersect_disk;
use crate::shapes::{sphere::intersect_sphere, triangle::intersect_triangle};
use glam::Vec3A;

fn intersect_one(g: &PrimGeom, ray: &Ray, tmax: f32) -> Option<f32> {
    match *g {
        PrimGeom::Triangle { p0, p1, p2 } => intersect_triangle(ray, p0, p1, p2, tmax).map(|h| h.t),
        PrimGeom::Sphere { center, radius } => intersect_sphere(ray, center, radius, 0.0, tmax),
        PrimGeom::Disk { to_object } => intersect_disk(ray, &to_object, tmax),
        PrimGeom::Cylinder { to_object } => intersect_cylinder(ray, &to_object, tmax),
        PrimGeom::SdfVoxel { .. } => unreachable!("these tests build no sdfgrid voxels"),
    }
}

/// A brute-force reference: every primitive tested.
fn brute(geoms: &[PrimGeom], ray: &Ray) -> Option<(f32, u32)> {
    let mut best: Option<(f32, u32)> = None;
    for (i, g) in geoms.iter().enumerate() {
        let tmax = best.map_or(ray.tmax, |b| b.0);
        if let Some(t) = intersect_one(g, ray, tmax) {
            best = Some((t, i as u32));
        }
    }
    best
}

#[test]
fn bvh_agrees_with_brute_force() {
    // A deterministic cloud of small triangles and spheres.
    let mut rng = torrey_testkit::Rng::new(12345);
    let mut rnd = || rng.range(-1.0, 1.0);
    let mut geoms = Vec::new();
    for i in 0..400 {
        let c = Vec3A::new(rnd(), rnd(), rnd()) * 5.0;
        if i % 5 == 0 {
            geoms.push(PrimGeom::Sphere {
                center: c,
                radius: 0.2 + 0.1 * rnd(),
            });
        } else {
            let p1 = c + Vec3A::new(rnd(), rnd(), rnd()) * 0.5;
            let p2 = c + Vec3A::new(rnd(), rnd(), rnd()) * 0.5;
            geoms.push(PrimGeom::Triangle { p0: c, p1, p2 });
        }
    }
    // Widths the CPU lacks fall back to narrower ones (and are tested where it has them).
    for width in [BvhWidth::Four, BvhWidth::Eight, BvhWidth::Sixteen] {
        let accel = Accel::build(&geoms, width);
        check_against_brute_force(&accel, &geoms, &mut rnd);
    }
}

/// Analytic primitives keep `PrimGeom` as small as a triangle (the build holds one per
/// primitive).
#[test]
fn prim_geom_stays_triangle_sized() {
    assert_eq!(std::mem::size_of::<PrimGeom>(), 64);
}

/// Disks and cylinders (randomly placed, rotated and non-uniformly scaled) among triangles
/// and spheres: the BVH finds what brute force finds.
#[test]
fn bvh_with_disks_and_cylinders_agrees_with_brute_force() {
    use crate::shapes::{cylinder::Cylinder, disk::Disk};
    use glam::{Mat4, Quat, Vec3};
    let mut rng = torrey_testkit::Rng::new(4242);
    let mut rnd = || rng.range(-1.0, 1.0);
    let mut geoms = Vec::new();
    for i in 0..300 {
        let c = Vec3A::new(rnd(), rnd(), rnd()) * 5.0;
        let to_world = Mat4::from_scale_rotation_translation(
            Vec3::new(0.2 + 0.2 * rnd().abs(), 0.2 + 0.2 * rnd().abs(), 0.3),
            Quat::from_euler(glam::EulerRot::XYZ, rnd() * 3.0, rnd() * 3.0, rnd() * 3.0),
            c.into(),
        );
        match i % 4 {
            0 => geoms.push(Disk::new(to_world).unwrap().prim_geom()),
            1 => geoms.push(
                Cylinder::new(Vec3::ZERO, Vec3::new(0.0, 0.3, 1.0), 0.8, to_world)
                    .unwrap()
                    .prim_geom(),
            ),
            2 => geoms.push(PrimGeom::Sphere {
                center: c,
                radius: 0.2,
            }),
            _ => {
                let p1 = c + Vec3A::new(rnd(), rnd(), rnd()) * 0.5;
                let p2 = c + Vec3A::new(rnd(), rnd(), rnd()) * 0.5;
                geoms.push(PrimGeom::Triangle { p0: c, p1, p2 });
            }
        }
    }
    assert!(geoms.iter().all(PrimGeom::is_finite));
    for width in [BvhWidth::Four, BvhWidth::Eight, BvhWidth::Sixteen] {
        let accel = Accel::build(&geoms, width);
        check_against_brute_force(&accel, &geoms, &mut rnd);
    }
}

/// 4000 random rays: closest hits as brute force finds them, any-hit queries consistent.
fn check_against_brute_force(accel: &Accel, geoms: &[PrimGeom], rnd: &mut impl FnMut() -> f32) {
    let mut hits = 0;
    for _ in 0..4000 {
        let o = Vec3A::new(rnd(), rnd(), rnd()) * 8.0;
        let d = Vec3A::new(rnd(), rnd(), rnd()).normalize();
        let ray = Ray {
            origin: o,
            dir: d,
            tmax: f32::INFINITY,
        };
        let a = accel.intersect(&ray).map(|h| (h.t, h.prim));
        let b = brute(geoms, &ray);
        match (a, b) {
            (None, None) => {}
            (Some(a), Some(b)) => {
                hits += 1;
                assert!((a.0 - b.0).abs() < 1e-4, "{a:?} vs {b:?}");
                assert_eq!(a.1, b.1);
                let shadow = Ray {
                    tmax: b.0 * 1.001,
                    ..ray
                };
                // Nothing lies closer than the closest hit.
                let clear = Ray {
                    tmax: b.0 * 0.999,
                    ..ray
                };
                assert!(accel.occluded(&shadow));
                assert!(!accel.occluded(&clear));
            }
            other => panic!("bvh and brute force disagree: {other:?}"),
        }
    }
    assert!(hits > 50, "test rays should hit often, got {hits}");
}

/// Packets of eight rays from one origin find, lane by lane, exactly the hits single rays
/// find: same distance, primitive and barycentrics, bit for bit. The scene mixes a random
/// triangle cloud, spheres (leaves the packet tests ray by ray) and a grid, into whose shared
/// vertices some lanes point straight down, so that edge functions are exactly zero and the
/// lane takes the single-ray test's double-precision fallback. There several triangles meet at
/// the same distance, and only the distance is compared. Directions in different octants are
/// not packed.
#[test]
fn packets_find_the_hits_of_single_rays() {
    if Simd::detect() == Simd::Portable {
        return; // packets need eight-wide nodes
    }
    let mut rng = torrey_testkit::Rng::new(777);
    let mut rnd = || rng.range(-1.0, 1.0);
    let mut geoms = Vec::new();
    for i in 0..600 {
        let c = Vec3A::new(rnd() * 4.0, rnd() * 4.0, rnd() * 2.0 - 1.5);
        if i % 7 == 0 {
            geoms.push(PrimGeom::Sphere {
                center: c,
                radius: 0.15 + 0.05 * rnd(),
            });
        } else {
            let p1 = c + Vec3A::new(rnd(), rnd(), rnd()) * 0.4;
            let p2 = c + Vec3A::new(rnd(), rnd(), rnd()) * 0.4;
            geoms.push(PrimGeom::Triangle { p0: c, p1, p2 });
        }
    }
    // A 10 x 10 grid of unit squares at z = -4, two triangles each.
    let grid = |x: i32, y: i32| Vec3A::new(x as f32, y as f32, -4.0);
    for x in -5..5 {
        for y in -5..5 {
            let (a, b, c, d) = (
                grid(x, y),
                grid(x + 1, y),
                grid(x + 1, y + 1),
                grid(x, y + 1),
            );
            geoms.push(PrimGeom::Triangle {
                p0: a,
                p1: b,
                p2: c,
            });
            geoms.push(PrimGeom::Triangle {
                p0: a,
                p1: c,
                p2: d,
            });
        }
    }
    for width in [BvhWidth::Eight, BvhWidth::Sixteen] {
        let accel = Accel::build(&geoms, width);
        let preferred = if Simd::detect() == Simd::Avx512 {
            16
        } else {
            8
        };
        if std::env::var("TORREY_PACKET").is_err() {
            assert_eq!(accel.packet_width(), preferred);
        }
        check_packets::<8>(&accel, &mut rnd);
        if Simd::detect() == Simd::Avx512 {
            check_packets::<16>(&accel, &mut rnd);
        } else {
            let dirs = [Vec3A::new(0.0, 0.0, -1.0); 16];
            assert!(!accel.intersect_packet(Vec3A::ZERO, &dirs, &mut [None; 16]));
        }
    }
}

/// The checks of [`packets_find_the_hits_of_single_rays`] on one layout, with packets of
/// `PACKET` rays.
fn check_packets<const PACKET: usize>(accel: &Accel, rnd: &mut impl FnMut() -> f32) {
    let (mut packed, mut hits, mut vertex_hits) = (0, 0, 0);
    for case in 0..3000 {
        // Integer x and y, so that straight-down lanes meet grid vertices exactly.
        let origin = Vec3A::new((rnd() * 3.0).round(), (rnd() * 3.0).round(), 4.0 + rnd());
        let centre = Vec3A::new(rnd() * 0.3, rnd() * 0.3, -1.0).normalize();
        let spread = if case % 2 == 0 { 0.002 } else { 0.05 };
        let dirs: [Vec3A; PACKET] = std::array::from_fn(|k| {
            if case % 3 == 0 && k < 2 {
                -Vec3A::Z
            } else {
                (centre + Vec3A::new(rnd(), rnd(), rnd()) * spread).normalize()
            }
        });
        let mut packet = [None; PACKET];
        if !accel.intersect_packet(origin, &dirs, &mut packet) {
            continue;
        }
        packed += 1;
        for (k, (&dir, got)) in dirs.iter().zip(packet).enumerate() {
            let ray = Ray {
                origin,
                dir,
                tmax: f32::INFINITY,
            };
            let want = accel.intersect(&ray);
            let straight_down = dir == -Vec3A::Z;
            match (got, want) {
                (None, None) => {}
                (Some(g), Some(w)) if straight_down => {
                    vertex_hits += 1;
                    assert_eq!(g.t.to_bits(), w.t.to_bits(), "case {case} lane {k}");
                }
                (Some(g), Some(w)) => {
                    hits += 1;
                    let bits =
                        |h: ClosestHit| (h.t.to_bits(), h.prim, h.b1.to_bits(), h.b2.to_bits());
                    assert_eq!(bits(g), bits(w), "case {case} lane {k}: {g:?} vs {w:?}");
                }
                other => {
                    panic!("case {case} lane {k}: packet and single ray disagree: {other:?}")
                }
            }
        }
    }
    assert!(
        packed > 1500 && hits > 5000 && vertex_hits > 300,
        "{packed} {hits} {vertex_hits}"
    );

    // Two octants: not packed.
    let mut dirs = [Vec3A::new(0.1, 0.1, -1.0).normalize(); PACKET];
    dirs[3] = Vec3A::new(-0.1, 0.1, -1.0).normalize();
    assert!(!accel.intersect_packet(Vec3A::new(0.0, 0.0, 5.0), &dirs, &mut [None; PACKET]));
}

#[test]
fn empty_scene_misses() {
    for width in [BvhWidth::Four, BvhWidth::Eight, BvhWidth::Sixteen] {
        let accel = Accel::build(&[], width);
        let ray = Ray {
            origin: Vec3A::ZERO,
            dir: Vec3A::Z,
            tmax: f32::INFINITY,
        };
        assert!(accel.intersect(&ray).is_none());
        assert!(!accel.occluded(&ray));
    }
}

/// Eight-wide nodes are built when asked for on a CPU with AVX2 and FMA, sixteen-wide ones on a
/// CPU with AVX-512 (so that the tests above cover them on such machines), narrower otherwise.
#[test]
fn width_follows_the_request() {
    let geoms: Vec<PrimGeom> = (0..64)
        .map(|i| {
            let c = Vec3A::new(i as f32, 0.0, 0.0);
            PrimGeom::Triangle {
                p0: c,
                p1: c + Vec3A::X * 0.5,
                p2: c + Vec3A::Y * 0.5,
            }
        })
        .collect();
    assert_eq!(Accel::build(&geoms, BvhWidth::Four).bvh_width(), 4);
    let simd = Simd::detect();
    let eight = Accel::build(&geoms, BvhWidth::Eight).bvh_width();
    assert_eq!(eight, if simd == Simd::Portable { 4 } else { 8 });
    let sixteen = Accel::build(&geoms, BvhWidth::Sixteen).bvh_width();
    let widest = match simd {
        Simd::Portable => 4,
        Simd::Avx2 => 8,
        Simd::Avx512 => 16,
    };
    assert_eq!(sixteen, widest);
    assert_eq!(
        Accel::build(&geoms, BvhWidth::Auto).bvh_width(),
        simd.auto_width(geoms.len())
    );
}

/// The default width: eight with AVX2, and with AVX-512 sixteen from 10k primitives (deep trees
/// walked by incoherent rays), eight below; four without either.
#[test]
fn the_default_width_follows_the_instruction_set_and_the_scene_size() {
    assert_eq!(Simd::Portable.auto_width(1 << 20), 4);
    assert_eq!(Simd::Avx2.auto_width(1 << 20), 8);
    assert_eq!(Simd::Avx512.auto_width(9_999), 8);
    assert_eq!(Simd::Avx512.auto_width(10_000), 16);
}

/// Rays with NaN or infinite components pass every box test (the SIMD minimum and maximum
/// return their non-NaN operand), so a traversal visits every lane of every node, unused ones
/// included. They must find nothing and read nothing out of bounds, whatever the layout: unused
/// lanes point at the empty leaf. (Before, they held a sentinel that decoded as a leaf of 15
/// blocks far past the end: the SIGSEGV of a degenerate camera.)
#[test]
fn non_finite_rays_are_safe_in_every_layout() {
    let mut geoms = Vec::new();
    // A few hundred triangles, and nodes with unused lanes: 6 and 7 children per group.
    for i in 0..301 {
        let c = Vec3A::new((i % 17) as f32, (i / 17) as f32, (i % 5) as f32);
        geoms.push(PrimGeom::Triangle {
            p0: c,
            p1: c + Vec3A::X * 0.5,
            p2: c + Vec3A::Y * 0.5,
        });
    }
    geoms.push(PrimGeom::Sphere {
        center: Vec3A::new(3.0, 3.0, 9.0),
        radius: 0.5,
    });
    let bad = [f32::NAN, f32::INFINITY, f32::NEG_INFINITY, 1e-30, 0.0];
    for width in [BvhWidth::Four, BvhWidth::Eight, BvhWidth::Sixteen] {
        let accel = Accel::build(&geoms, width);
        for &x in &bad {
            for (origin, dir) in [
                (Vec3A::ZERO, Vec3A::splat(x)),
                (Vec3A::splat(x), Vec3A::Z),
                (Vec3A::new(x, 1.0, 2.0), Vec3A::new(0.0, x, 1.0)),
            ] {
                let ray = Ray {
                    origin,
                    dir,
                    tmax: f32::INFINITY,
                };
                if let Some(hit) = accel.intersect(&ray) {
                    assert!((hit.prim as usize) < geoms.len());
                }
                accel.occluded(&ray);
                let widths = if accel.packet_width() > 0 {
                    vec![8, accel.packet_width()]
                } else {
                    vec![]
                };
                for lanes in widths {
                    let dirs = vec![dir; lanes];
                    let mut hits = vec![None; lanes];
                    accel.intersect_packet(origin, &dirs, &mut hits);
                    for hit in hits.into_iter().flatten() {
                        assert!((hit.prim as usize) < geoms.len());
                    }
                }
            }
        }
    }
}

/// Primitives the builder cannot order are recognised: non-finite coordinates, and finite ones
/// whose box extent or area overflows (found by the fuzzer: a rectangle scaled by 3.4e38).
#[test]
fn primitives_with_overflowing_bounds_are_not_finite() {
    let tri = |p0: Vec3A, p1: Vec3A, p2: Vec3A| PrimGeom::Triangle { p0, p1, p2 };
    assert!(tri(Vec3A::ZERO, Vec3A::X, Vec3A::Y).is_finite());
    assert!(!tri(Vec3A::ZERO, Vec3A::X, Vec3A::splat(f32::NAN)).is_finite());
    let big = 3.4e38;
    assert!(!tri(Vec3A::splat(-big), Vec3A::splat(big), Vec3A::X).is_finite());
    assert!(!tri(
        Vec3A::new(-big, 0.0, 0.0),
        Vec3A::new(0.0, 1e30, 0.0),
        Vec3A::new(0.0, 0.0, 1e30)
    )
    .is_finite());
    assert!(!PrimGeom::Sphere {
        center: Vec3A::ZERO,
        radius: f32::INFINITY
    }
    .is_finite());
    assert!(!PrimGeom::Sphere {
        center: Vec3A::splat(3e38),
        radius: 1e38
    }
    .is_finite());
}
