//! The top level of a two-level BVH: a binary BVH over the world bounds of the scene's instances,
//! each placing one shape group whose primitives are stored once, under an [`Accel`] of their own
//! (the bottom level, any primitives, built in the group's space). A ray that reaches an
//! instance's box is carried into the group's space ([`Instance::local_ray`]) and traced through
//! the group's `Accel`; t is the same along both rays, so hits in different instances compare
//! directly.
//!
//! Scenes without instances have no top level: their one-level path is untouched. Instances
//! are few next to primitives (thousands, not millions), so the top level is a plain binary
//! tree traversed one ray at a time.

use super::traversal::{reciprocal, EXIT_WIDENING};
use super::{Accel, ClosestHit, PrimGeom};
use crate::ray::Ray;
use crate::shapes::instance::Instance;
use glam::{Mat4, Vec3A};
use obvhs::{aabb::Aabb, bvh2::Bvh2, BvhBuildParams};
use std::time::Duration;

/// A shape group's bottom level: its primitives' BVH and where its primitives start in the
/// scene's primitive records (a hit's primitive index is `first_prim` + its index in the group).
pub struct GroupAccel {
    pub accel: Accel,
    pub first_prim: u32,
    /// The group's bounds in its own space.
    bounds: Aabb,
}

impl GroupAccel {
    /// The BVH over `geoms` (in the group's space), whose records start at `first_prim`; None
    /// for a group without primitives (nothing of it can be hit).
    pub fn build(geoms: &[PrimGeom], first_prim: u32, width: super::BvhWidth) -> Option<Self> {
        Self::build_with(geoms, &[], first_prim, super::AccelOptions::best(width))
    }

    /// [`GroupAccel::build`] with the table of the `sdfgrid` voxels among `geoms`
    /// ([`Accel::build_with`]).
    pub fn build_with(
        geoms: &[PrimGeom],
        sdf_voxels: &[crate::shapes::sdfgrid::SdfVoxel],
        first_prim: u32,
        options: super::AccelOptions,
    ) -> Option<Self> {
        let bounds = geoms
            .iter()
            .map(PrimGeom::aabb)
            .reduce(|a, b| a.union(&b))?;
        Some(Self {
            accel: Accel::build_with(geoms, sdf_voxels, options),
            first_prim,
            bounds,
        })
    }
}

/// A node of the top-level tree: an inner node's children are `first` and `first + 1`; a
/// leaf's instances are `order[first..first + count]`.
#[derive(Clone, Copy, Debug)]
struct Node {
    min: Vec3A,
    max: Vec3A,
    first: u32,
    /// 0 for an inner node.
    count: u32,
}

/// The instances of a scene and the top-level BVH over them.
pub struct Instances {
    nodes: Vec<Node>,
    order: Vec<u32>,
    instances: Vec<Instance>,
    groups: Vec<GroupAccel>,
    /// Entries a traversal stack needs: the tree's depth plus one.
    stack_needed: usize,
}

/// Stack entries kept on the machine stack; deeper trees use a heap stack.
const STACK: usize = 64;

impl Instances {
    /// The top level over `placements` (to_world, group index into `groups`); placements of
    /// groups without geometry (`None`) are left out. None when nothing is left.
    pub fn build(groups: Vec<Option<GroupAccel>>, placements: &[(Mat4, usize)]) -> Option<Self> {
        let mut instances = Vec::new();
        let mut aabbs = Vec::new();
        // Groups are renumbered to the ones with geometry.
        let mut index = vec![u32::MAX; groups.len()];
        let mut kept = Vec::new();
        for (g, group) in groups.into_iter().enumerate() {
            if let Some(group) = group {
                index[g] = kept.len() as u32;
                kept.push(group);
            }
        }
        for &(to_world, g) in placements {
            let Some(&k) = index.get(g).filter(|&&k| k != u32::MAX) else {
                continue;
            };
            let instance = Instance::new(to_world, k);
            let b = kept[k as usize].bounds;
            let corners = (0..8).map(|c| {
                let pick = |bit: usize, lo: f32, hi: f32| if c >> bit & 1 == 0 { lo } else { hi };
                instance.to_world.transform_point3a(Vec3A::new(
                    pick(0, b.min.x, b.max.x),
                    pick(1, b.min.y, b.max.y),
                    pick(2, b.min.z, b.max.z),
                ))
            });
            let mut world = Aabb::empty();
            for p in corners {
                world.extend(p);
            }
            instances.push(instance);
            aabbs.push(world);
        }
        if instances.is_empty() {
            return None;
        }
        let mut params = BvhBuildParams::medium_build();
        params.max_prims_per_leaf = 1;
        let bvh2 = obvhs::bvh2::builder::build_bvh2(&aabbs, params, &mut Duration::default());
        let nodes: Vec<Node> = bvh2
            .nodes
            .iter()
            .map(|n| Node {
                min: n.aabb().min,
                max: n.aabb().max,
                first: n.first_index,
                count: n.prim_count,
            })
            .collect();
        Some(Self {
            stack_needed: depth(&bvh2) + 1,
            nodes,
            order: bvh2.primitive_indices.clone(),
            instances,
            groups: kept,
        })
    }

    /// How many instances the scene places.
    pub fn len(&self) -> usize {
        self.instances.len()
    }

    pub fn is_empty(&self) -> bool {
        self.instances.is_empty()
    }

    /// Instance `i`, as a hit reports it.
    #[inline(always)]
    pub fn instance(&self, i: u32) -> &Instance {
        &self.instances[i as usize]
    }

    /// Primitives stored in the groups' BVHs, each once however many instances place it.
    pub fn stored_primitive_count(&self) -> usize {
        self.groups.iter().map(|g| g.accel.primitive_count()).sum()
    }

    /// Primitives the instances place in the world (what copying the groups would store).
    pub fn placed_primitive_count(&self) -> usize {
        self.instances
            .iter()
            .map(|i| self.groups[i.group as usize].accel.primitive_count())
            .sum()
    }

    /// The closest hit in (0, ray.tmax) among the instances, and the instance hit; the hit's
    /// primitive index is the scene's (the group's first primitive added).
    #[inline(never)]
    pub fn intersect(&self, ray: &Ray) -> Option<(ClosestHit, u32)> {
        if self.stack_needed > STACK {
            return self.intersect_with(ray, &mut vec![(0, 0.0); self.stack_needed]);
        }
        self.intersect_with(ray, &mut [(0, 0.0); STACK])
    }

    /// True when some instance blocks the ray within (0, ray.tmax).
    #[inline(never)]
    pub fn occluded(&self, ray: &Ray) -> bool {
        if self.stack_needed > STACK {
            return self.occluded_with(ray, &mut vec![(0, 0.0); self.stack_needed]);
        }
        self.occluded_with(ray, &mut [(0, 0.0); STACK])
    }

    /// Entry distance of `node`'s box along the ray, if the ray enters it before `tmax`.
    #[inline(always)]
    fn enter(node: &Node, origin: Vec3A, inv: Vec3A, tmax: f32) -> Option<f32> {
        let t0 = (node.min - origin) * inv;
        let t1 = (node.max - origin) * inv;
        let near = t0.min(t1).max_element().max(0.0);
        let far = t0.max(t1).min_element() * EXIT_WIDENING;
        (near <= far && near < tmax).then_some(near)
    }

    fn intersect_with(&self, ray: &Ray, stack: &mut [(u32, f32)]) -> Option<(ClosestHit, u32)> {
        let inv = reciprocal(ray);
        let mut tmax = ray.tmax;
        let mut best = None;
        let mut top = 0;
        Self::enter(&self.nodes[0], ray.origin, inv, tmax)?;
        let mut current = 0u32;
        loop {
            let node = self.nodes[current as usize];
            if node.count > 0 {
                for &i in &self.order[node.first as usize..(node.first + node.count) as usize] {
                    let instance = &self.instances[i as usize];
                    let group = &self.groups[instance.group as usize];
                    let local = Ray {
                        tmax,
                        ..instance.local_ray(ray)
                    };
                    if let Some(hit) = group.accel.intersect(&local) {
                        tmax = hit.t;
                        best = Some((
                            ClosestHit {
                                prim: group.first_prim + hit.prim,
                                ..hit
                            },
                            i,
                        ));
                    }
                }
            } else {
                let (a, b) = (node.first, node.first + 1);
                let ta = Self::enter(&self.nodes[a as usize], ray.origin, inv, tmax);
                let tb = Self::enter(&self.nodes[b as usize], ray.origin, inv, tmax);
                match (ta, tb) {
                    (Some(ta), Some(tb)) => {
                        let (near, far, t_far) = if tb < ta { (b, a, ta) } else { (a, b, tb) };
                        stack[top] = (far, t_far);
                        top += 1;
                        current = near;
                        continue;
                    }
                    (Some(_), None) => {
                        current = a;
                        continue;
                    }
                    (None, Some(_)) => {
                        current = b;
                        continue;
                    }
                    (None, None) => {}
                }
            }
            // The nearest pending node that can still hold a closer hit.
            loop {
                if top == 0 {
                    return best;
                }
                top -= 1;
                let (node, near) = stack[top];
                if near < tmax {
                    current = node;
                    break;
                }
            }
        }
    }

    fn occluded_with(&self, ray: &Ray, stack: &mut [(u32, f32)]) -> bool {
        let inv = reciprocal(ray);
        let mut top = 0;
        stack[top] = (0, 0.0);
        top += 1;
        while top > 0 {
            top -= 1;
            let node = self.nodes[stack[top].0 as usize];
            if Self::enter(&node, ray.origin, inv, ray.tmax).is_none() {
                continue;
            }
            if node.count > 0 {
                for &i in &self.order[node.first as usize..(node.first + node.count) as usize] {
                    let instance = &self.instances[i as usize];
                    let group = &self.groups[instance.group as usize];
                    if group.accel.occluded(&instance.local_ray(ray)) {
                        return true;
                    }
                }
            } else {
                stack[top] = (node.first, 0.0);
                stack[top + 1] = (node.first + 1, 0.0);
                top += 2;
            }
        }
        false
    }
}

/// Levels below the root of `bvh2` (0 for a root leaf); iterative, as a degenerate tree may be
/// as deep as it has instances.
fn depth(bvh2: &Bvh2) -> usize {
    let mut deepest = 0;
    let mut pending = vec![(0usize, 0usize)];
    while let Some((index, level)) = pending.pop() {
        let node = &bvh2.nodes[index];
        deepest = deepest.max(level);
        if !node.is_leaf() {
            let first = node.first_index as usize;
            pending.extend([(first, level + 1), (first + 1, level + 1)]);
        }
    }
    deepest
}

#[cfg(test)]
mod tests {
    use crate::ray::Ray;
    use crate::scene::RenderScene;
    use glam::{Vec2, Vec3A};
    use std::path::Path;
    use torrey_parser as desc;
    use torrey_testkit::Rng;

    fn parse(xml: &str, dir: &Path) -> desc::Scene {
        desc::parse_scene_str(xml, &dir.join("test.xml"), &[]).unwrap()
    }

    /// The scene as the parser used to read it: every instance's shapes copied into the world.
    fn flattened(scene: &desc::Scene) -> desc::Scene {
        let mut flat = scene.clone();
        for i in &scene.instances {
            for s in &scene.shape_groups[i.group].shapes {
                flat.shapes.push(desc::Shape {
                    to_world: i.to_world * s.to_world,
                    ..s.clone()
                });
            }
        }
        flat.instances.clear();
        flat.shape_groups.clear();
        flat
    }

    /// A group of a smooth mesh with uvs, a sphere and a flipped rectangle, textured (so that
    /// uv and dp/du are computed), placed five times rotated, scaled (uniformly: the copied
    /// sphere needs it) and moved, beside a world shape.
    const GROUP_SCENE: &str = r#"<scene version="3.0.0">
        <texture type="checkerboard" id="checks"/>
        <shape type="rectangle"><transform name="to_world"><scale value="9"/><rotate x="1" angle="-90"/><translate y="-1.5"/></transform>
            <bsdf type="diffuse"><ref name="reflectance" id="checks"/></bsdf></shape>
        <shape type="shapegroup" id="g">
            <shape type="obj"><string name="filename" value="scenes/meshes/torus.obj"/>
                <transform name="to_world"><scale value="0.6"/><rotate x="1" angle="30"/><translate x="0.5"/></transform>
                <bsdf type="diffuse"><ref name="reflectance" id="checks"/></bsdf></shape>
            <shape type="sphere"><point name="center" x="-0.6" y="0.2" z="0.1"/><float name="radius" value="0.45"/>
                <transform name="to_world"><rotate z="1" angle="40"/></transform>
                <bsdf type="diffuse"><ref name="reflectance" id="checks"/></bsdf></shape>
            <shape type="rectangle"><boolean name="flip_normals" value="true"/>
                <transform name="to_world"><scale value="0.4"/><translate y="0.9"/></transform>
                <bsdf type="diffuse"><ref name="reflectance" id="checks"/></bsdf></shape>
        </shape>
        <shape type="instance"><ref id="g"/></shape>
        <shape type="instance"><ref id="g"/><transform name="to_world"><rotate y="1" angle="70"/><scale value="1.3"/><translate x="2.5" z="-1"/></transform></shape>
        <shape type="instance"><ref id="g"/><transform name="to_world"><rotate x="1" angle="-35"/><scale value="0.7"/><translate x="-2.2" y="0.5" z="0.8"/></transform></shape>
        <shape type="instance"><ref id="g"/><transform name="to_world"><rotate x="1" y="1" z="1" angle="120"/><translate y="2" z="-2"/></transform></shape>
        <shape type="instance"><ref id="g"/><transform name="to_world"><scale value="2"/><translate x="1" y="-0.5" z="2.5"/></transform></shape>
    </scene>"#;

    fn close(a: Vec3A, b: Vec3A, tol: f32) -> bool {
        (a - b).length() <= tol
    }

    /// Instances traced through the two-level BVH find the surfaces the copied shapes give:
    /// same hits and misses, t, position, normals, uv, dp/du, dp/dv and material, and the same
    /// shadow-ray answers, for rays in every direction from inside and around the scene.
    #[test]
    fn instances_hit_what_copies_hit() {
        let root = Path::new(env!("CARGO_MANIFEST_DIR")).join("../..");
        let desc = parse(GROUP_SCENE, &root);
        let instanced = RenderScene::build(&desc, 8, 8).unwrap();
        let copied = RenderScene::build(&flattened(&desc), 8, 8).unwrap();
        assert_eq!(instanced.instance_count(), 5);
        assert_eq!(copied.instance_count(), 0);
        let group_triangles = instanced.triangle_count() - 2; // the world's rectangle
        assert_eq!(copied.triangle_count(), 2 + 5 * group_triangles);
        assert_eq!(
            instanced.packet_width(),
            0,
            "scenes with instances trace rays one by one"
        );

        let mut rng = Rng::new(7);
        let (mut hits, mut differ, mut shadow_differ) = (0, 0, 0);
        let n = 4000;
        for _ in 0..n {
            let origin = Vec3A::new(
                rng.range(-4.0, 4.0),
                rng.range(-1.0, 3.5),
                rng.range(-4.0, 4.0),
            );
            let dir = Vec3A::new(
                rng.range(-1.0, 1.0),
                rng.range(-1.0, 1.0),
                rng.range(-1.0, 1.0),
            )
            .normalize_or(Vec3A::X);
            let ray = Ray {
                origin,
                dir,
                tmax: f32::INFINITY,
            };
            let (a, b) = (instanced.intersect(&ray), copied.intersect(&ray));
            match (a, b) {
                (Some(a), Some(b)) => {
                    hits += 1;
                    let tol = 2e-4 * (1.0 + b.t);
                    let same_surface = (a.t - b.t).abs() <= tol
                        && instanced.shapes[a.shape as usize].material
                            == copied.shapes[b.shape as usize].material;
                    if !same_surface {
                        differ += 1;
                        continue;
                    }
                    assert!(close(a.p, b.p, tol), "{} vs {}", a.p, b.p);
                    assert!(close(a.ng, b.ng, 2e-3), "ng {} vs {}", a.ng, b.ng);
                    assert!(close(a.ns, b.ns, 2e-3), "ns {} vs {}", a.ns, b.ns);
                    assert!(
                        (a.uv - b.uv).abs().max_element() < 1e-3,
                        "uv {} vs {}",
                        a.uv,
                        b.uv
                    );
                    let scale = b.dpdu.length().max(b.dpdv.length());
                    assert!(
                        close(a.dpdu, b.dpdu, 2e-3 * scale),
                        "{} vs {}",
                        a.dpdu,
                        b.dpdu
                    );
                    assert!(
                        close(a.dpdv, b.dpdv, 2e-3 * scale),
                        "{} vs {}",
                        a.dpdv,
                        b.dpdv
                    );
                    assert_ne!(a.uv, Vec2::ZERO);
                }
                (None, None) => {}
                _ => differ += 1,
            }
            let tmax = rng.range(0.1, 6.0);
            if instanced.visible(origin, dir, tmax) != copied.visible(origin, dir, tmax) {
                shadow_differ += 1;
            }
        }
        // Only rays grazing a silhouette or a shared edge may differ (rounding in the two
        // spaces): a handful in thousands.
        println!("{hits} hits of {n} rays; {differ} differ, {shadow_differ} shadow rays differ");
        assert!(hits > n / 3, "{hits} hits");
        assert!(
            differ <= n / 500,
            "{differ} of {n} rays found different surfaces"
        );
        assert!(
            shadow_differ <= n / 500,
            "{shadow_differ} of {n} shadow rays differ"
        );
    }

    /// A non-uniformly scaled instance of a sphere is an ellipsoid: the hit lies on it and its
    /// normal is the ellipsoid's gradient (the inverse transpose at work).
    #[test]
    fn non_uniform_instances_are_ellipsoids() {
        let root = Path::new(env!("CARGO_MANIFEST_DIR")).join("../..");
        let desc = parse(
            r#"<scene version="3.0.0">
            <shape type="shapegroup" id="s"><shape type="sphere"/></shape>
            <shape type="instance"><ref id="s"/><transform name="to_world"><scale x="3" y="1" z="0.5"/></transform></shape>
        </scene>"#,
            &root,
        );
        let scene = RenderScene::build(&desc, 8, 8).unwrap();
        let mut rng = Rng::new(3);
        for _ in 0..500 {
            let target = Vec3A::new(
                rng.range(-2.0, 2.0),
                rng.range(-0.6, 0.6),
                rng.range(-0.3, 0.3),
            );
            let origin = Vec3A::new(rng.range(-1.0, 1.0), rng.range(-1.0, 1.0), 5.0);
            let dir = (target - origin).normalize();
            let ray = Ray {
                origin,
                dir,
                tmax: f32::INFINITY,
            };
            let Some(hit) = scene.intersect(&ray) else {
                continue;
            };
            let q = hit.p / Vec3A::new(3.0, 1.0, 0.5);
            assert!(
                (q.length() - 1.0).abs() < 1e-4,
                "{} is not on the ellipsoid",
                hit.p
            );
            assert!(close(hit.p, origin + hit.t * dir, 1e-4));
            let gradient = (hit.p / Vec3A::new(9.0, 1.0, 0.25)).normalize();
            assert!(close(hit.ng, gradient, 1e-3), "{} vs {gradient}", hit.ng);
            assert!(!scene.visible(origin, dir, hit.t * 1.001));
            assert!(scene.visible(origin, dir, hit.t * 0.999));
        }
    }

    /// A thousand instances of a mesh of 10,368 triangles: the triangles are stored once (the
    /// scene's own counts say so), the world BVH holds nothing, and every instance is hit where
    /// it was placed.
    #[test]
    fn a_thousand_instances_store_their_mesh_once() {
        let dir = std::env::temp_dir().join(format!("torrey-instances-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        // A 72 x 72 grid of quads in [-0.4, 0.4]^2 at z = 0, facing +z.
        let n = 72;
        let mut obj = String::new();
        for j in 0..=n {
            for i in 0..=n {
                let (x, y) = (
                    i as f32 / n as f32 * 0.8 - 0.4,
                    j as f32 / n as f32 * 0.8 - 0.4,
                );
                obj += &format!("v {x} {y} 0\n");
            }
        }
        for j in 0..n {
            for i in 0..n {
                let v = |i: usize, j: usize| j * (n + 1) + i + 1;
                obj += &format!("f {} {} {}\n", v(i, j), v(i + 1, j), v(i + 1, j + 1));
                obj += &format!("f {} {} {}\n", v(i, j), v(i + 1, j + 1), v(i, j + 1));
            }
        }
        std::fs::write(dir.join("grid.obj"), obj).unwrap();
        let mut xml = String::from(
            r#"<scene version="3.0.0">
            <sensor type="perspective"><float name="fov" value="60"/>
                <transform name="to_world"><lookat origin="4.5, 4.5, 12" target="4.5, 4.5, 0" up="0, 1, 0"/></transform>
                <film type="hdrfilm"><integer name="width" value="24"/><integer name="height" value="24"/></film></sensor>
            <emitter type="constant"/>
            <shape type="shapegroup" id="grid"><shape type="obj"><string name="filename" value="grid.obj"/></shape></shape>"#,
        );
        let position =
            |k: usize| Vec3A::new((k % 10) as f32, (k / 10 % 10) as f32, -((k / 100) as f32));
        for k in 0..1000 {
            let p = position(k);
            xml += &format!(
                r#"<shape type="instance"><ref id="grid"/><transform name="to_world"><rotate z="1" angle="{}"/><translate x="{}" y="{}" z="{}"/></transform></shape>"#,
                k % 90,
                p.x,
                p.y,
                p.z
            );
        }
        xml += "</scene>";
        let desc = parse(&xml, &dir);
        std::fs::remove_dir_all(&dir).ok();
        let scene = RenderScene::build(&desc, 8, 8).unwrap();
        let triangles = 2 * n * n;
        assert_eq!(scene.triangle_count(), triangles);
        assert_eq!(scene.mesh.positions.len(), (n + 1) * (n + 1));
        assert_eq!(scene.prims.len(), triangles);
        assert_eq!(scene.accel().primitive_count(), 0);
        let instances = scene.instances().unwrap();
        assert_eq!(instances.len(), 1000);
        assert_eq!(instances.stored_primitive_count(), triangles);
        assert_eq!(instances.placed_primitive_count(), 1000 * triangles);
        // Each grid is hit at its own centre by a ray from the front; the layers behind stay
        // hidden, and a shadow ray through the whole stack is blocked.
        for k in 0..100 {
            let target = position(k);
            let ray = Ray {
                origin: target + Vec3A::new(0.05, 0.03, 2.0),
                dir: -Vec3A::Z,
                tmax: f32::INFINITY,
            };
            let hit = scene.intersect(&ray).expect("the front grid");
            assert!((hit.t - 2.0).abs() < 1e-5, "instance {k}: t = {}", hit.t);
            assert!(close(hit.ng, Vec3A::Z, 1e-5));
            assert!(!scene.visible(ray.origin, ray.dir, 20.0));
            assert!(scene.visible(ray.origin, ray.dir, 1.99));
        }
        // Between the grids' columns nothing is hit.
        let ray = Ray {
            origin: Vec3A::new(0.5, 0.5, 2.0),
            dir: -Vec3A::Z,
            tmax: f32::INFINITY,
        };
        assert!(scene.intersect(&ray).is_none());

        // It renders: grey grids (diffuse 0.5 under a white sky) in front of the white sky.
        let scene = RenderScene::build(&desc, 24, 24).unwrap();
        let settings = crate::render::RenderSettings {
            spp: 4,
            integrator: crate::integrator::Integrator::Path(crate::integrator::PathIntegrator {
                max_depth: 3,
                rr_depth: 5,
                hide_emitters: false,
            }),
            seed: 1,
            filter: desc::PixelFilter::Box,
            tile_size: 8,
            mipmapping: true,
            env_strategy: crate::integrator::EnvStrategy::default(),
            sampler: crate::sampler::SamplerKind::Sobol,
            packets: true,
            path_loop: crate::integrator::PathLoop::Auto,
            channels: Default::default(),
            noise_threshold: None,
            time_limit: None,
        };
        let out = crate::render::render(&scene, &settings, &|_, _| {});
        assert_eq!(out.nonfinite_samples, 0);
        let lum: Vec<f32> = out
            .image
            .pixels
            .iter()
            .map(|p| p.element_sum() / 3.0)
            .collect();
        let grids = lum.iter().filter(|&&l| l < 0.7).count();
        let sky = lum.iter().filter(|&&l| (l - 1.0).abs() < 1e-4).count();
        println!("{grids} grid pixels, {sky} sky pixels of {}", lum.len());
        assert!(
            grids > 100 && sky > 50,
            "{grids} grid pixels, {sky} sky pixels"
        );
    }
}
