//! The binary BVH's build: obvhs 0.4's `build_bvh2` (PLOC, reinsertion, leaf collapse,
//! reinsertion), with PLOC's clustering and the reinsertion optimizer done here so that the
//! build always finishes in O(n log n), whatever the boxes (issue 34: polygons of a million
//! vertices, overlapping slivers).
//!
//! PLOC (Meister and Bittner 2018) sorts the primitives along a Morton curve and, pass after
//! pass, merges each node with its nearest neighbour within `SEARCH` places (smallest union
//! surface area) when the two choose each other. obvhs breaks ties towards the last candidate,
//! so where many boxes are equal (one triangle repeated, or a polygon's slivers nested in each
//! other) every node chooses the next one and only the last pair of such a run agrees: a pass
//! merged one pair, the build took n passes, O(n^2) (10,000 copies of one triangle: 43 s; a
//! random 30,000-gon: 20 s; 1,000,000 vertices: hours), and the tree was as deep as the run was
//! long, which made the reinsertion that follows quadratic too. Here a pass over more than
//! [`FORCE_MIN_NODES`] nodes that merges fewer than 1/[`FORCE_RATIO`] of them also merges the
//! nodes left unpaired with their unpaired neighbours on the curve; the node count then falls
//! by a constant fraction every pass, so there are O(log n) passes. Every other pass is obvhs's
//! to the bit (same Morton codes, sort, costs, ties and node layout), so ordinary scenes get
//! obvhs's tree exactly (`tests::same_tree_as_obvhs`).
//!
//! The reinsertion optimizer (Meister and Bittner 2018, obvhs's `ReinsertionOptimizer`) looks,
//! for each candidate node, for the place in the tree where moving it saves the most surface
//! area, a branch-and-bound search that prunes where no saving can beat the best found. Where
//! large boxes overlap (a random polygon's slivers all span it) nothing prunes: each search
//! visits most of the tree, O(n^2) (a random 30,000-gon took 20 s, 92% of it here). This
//! optimizer is obvhs's, step for step, but it is skipped where the clustered tree's boxes
//! overlap far more than any mesh's ([`overlap`], [`OVERLAP_LIMIT`]), and elsewhere it has a
//! budget on the nodes its searches visit in all: [`REINSERTION_VISITS_PER_CANDIDATE`] times
//! the candidates of the run; once spent, it stops (after applying the moves found so far),
//! leaving a valid, merely less optimized, tree (a cluster of slivers in an ordinary scene).
//! Ordinary scenes stay well within both and get obvhs's tree.

use obvhs::aabb::Aabb;
use obvhs::bvh2::leaf_collapser::collapse;
use obvhs::bvh2::node::Bvh2Node;
use obvhs::bvh2::reinsertion::{reinsert_node, Reinsertion};
use obvhs::bvh2::{Bvh2, DEFAULT_MAX_STACK_DEPTH};
use obvhs::ploc::morton::{morton_encode_u128_unorm, morton_encode_u64_unorm};
use obvhs::ploc::{PlocSearchDistance, SortPrecision};
use obvhs::BvhBuildParams;
use rayon::prelude::*;
use rdst::{RadixKey, RadixSort};

/// A pass that merges fewer than 1/FORCE_RATIO of its nodes makes too little progress.
const FORCE_RATIO: usize = 16;
/// Passes over this many nodes or fewer are never forced: at most this many such passes, each
/// over at most this many nodes. (Near the root PLOC merges few nodes a pass anyway: the
/// matpreview object's build has a pass merging 10 of 102, 1/10.)
const FORCE_MIN_NODES: usize = 64;

/// The most nodes the reinsertion searches of one optimizer run may visit, per candidate it
/// searches for: ordinary meshes take 50 to 150 (the scenes of scenes/ and
/// ../shared/scenes/mitsuba-real: at most 94), the budget several times that.
const REINSERTION_VISITS_PER_CANDIDATE: u64 = 512;

/// Reinsertion searches run in parallel in chunks of this many candidates.
const SEARCH_CHUNK: usize = 256;

/// PLOC passes over at least this many nodes search their neighbours in parallel (in pieces
/// of this many nodes).
const PARALLEL_NODES: usize = 4096;

/// obvhs's `bvh2::builder::build_bvh2` over boxes, with [`ploc`] for its clustering and
/// [`reinsert`] for its optimizer.
pub(super) fn build_bvh2(aabbs: &[Aabb], config: BvhBuildParams) -> Bvh2 {
    build_bvh2_stats(aabbs, config).0
}

/// [`build_bvh2`], and what its steps did.
pub(super) fn build_bvh2_stats(aabbs: &[Aabb], config: BvhBuildParams) -> (Bvh2, BuildStats) {
    let (mut bvh2, ploc) = ploc(
        aabbs,
        config.ploc_search_distance,
        config.sort_precision,
        config.search_depth_threshold,
    );
    let overlap = overlap(&bvh2);
    let optimize = overlap <= OVERLAP_LIMIT;
    let first = if optimize {
        reinsert(&mut bvh2, config.reinsertion_batch_ratio)
    } else {
        ReinsertionStats::default()
    };
    collapse(
        &mut bvh2,
        config.max_prims_per_leaf.clamp(1, 255),
        config.collapse_traversal_cost,
    );
    let second = if optimize {
        reinsert(
            &mut bvh2,
            config.reinsertion_batch_ratio
                * config.post_collapse_reinsertion_batch_ratio_multiplier,
        )
    } else {
        ReinsertionStats::default()
    };
    (
        bvh2,
        BuildStats {
            ploc,
            overlap,
            reinsertion: [first, second],
        },
    )
}

/// Above this [`overlap`], the tree's boxes overlap so much that reinsertion searches prune
/// nothing: they are skipped. Mesh scenes measure 0.3 to 2.4 (scenes/, the mitsuba-real
/// scenes); a random polygon's or a repeated triangle's slivers 270 to 1100.
const OVERLAP_LIMIT: f64 = 32.0;

/// The summed surface area of the inner nodes over the root's (the expected number of inner
/// nodes a ray crossing the root's box enters) per log2 of the primitive count: about 1 for a
/// mesh, about n / log2 n where every box spans the scene.
fn overlap(bvh: &Bvh2) -> f64 {
    let Some(root) = bvh.nodes.first() else {
        return 0.0;
    };
    let leaves = bvh.primitive_indices.len().max(2) as f64;
    let root_area = root.aabb().half_area() as f64;
    let inner: f64 = bvh
        .nodes
        .iter()
        .filter(|n| !n.is_leaf())
        .map(|n| n.aabb().half_area() as f64)
        .sum();
    if root_area > 0.0 {
        inner / root_area / leaves.log2()
    } else {
        // A point-like scene: every box is the root's.
        bvh.nodes.len() as f64 / leaves.log2()
    }
}

/// What a build did ([`build_bvh2_stats`]).
#[derive(Clone, Copy, Debug, Default)]
#[allow(dead_code, reason = "read by the tests, which count the build's work")]
pub(super) struct BuildStats {
    pub ploc: PlocStats,
    /// [`overlap`] of the clustered tree (reinsertion skipped above [`OVERLAP_LIMIT`]).
    pub overlap: f64,
    /// The two reinsertion runs.
    pub reinsertion: [ReinsertionStats; 2],
}

/// What a reinsertion run did: the nodes its searches visited, and whether it ran out of its
/// budget.
#[derive(Clone, Copy, Debug, Default)]
pub(super) struct ReinsertionStats {
    pub visits: u64,
    /// The candidates searched, and the budget of visits.
    pub candidates: u64,
    pub budget: u64,
    pub out_of_budget: bool,
}

/// A reinsertion candidate, as obvhs's (sorted by decreasing surface area).
#[derive(Clone, Copy)]
struct Candidate {
    node_id: u32,
    cost: f32,
}

impl RadixKey for Candidate {
    const LEVELS: usize = 4;
    #[inline]
    fn get_level(&self, level: usize) -> u8 {
        (-self.cost).get_level(level)
    }
}

/// obvhs's `ReinsertionOptimizer::run(bvh, batch_size_ratio, None)` (sequential), with a
/// budget on the nodes its searches visit (see the module documentation).
pub(super) fn reinsert(bvh: &mut Bvh2, batch_size_ratio: f32) -> ReinsertionStats {
    let mut stats = ReinsertionStats::default();
    if bvh.nodes.is_empty() || bvh.nodes[0].is_leaf() || batch_size_ratio <= 0.0 {
        return stats;
    }
    bvh.init_parents_if_uninit();
    let ratios: Vec<f32> = (1..32).step_by(2).map(|n| 1.0 / n as f32).collect();
    let node_counts: Vec<usize> = ratios
        .iter()
        .map(|ratio| {
            let batch_size =
                (((bvh.nodes.len() as f32 * batch_size_ratio) * ratio) as usize).max(1);
            bvh.nodes.len().min(batch_size + 1)
        })
        .collect();
    let budget =
        REINSERTION_VISITS_PER_CANDIDATE * node_counts.iter().map(|&n| n as u64 - 1).sum::<u64>();
    stats.budget = budget;
    let mut touched = vec![false; bvh.nodes.len()];
    let mut candidates: Vec<Candidate> = Vec::new();
    let mut reinsertions: Vec<Reinsertion> = Vec::new();
    bvh.children_are_ordered_after_parents = false;
    for node_count in node_counts {
        // Candidates: the first 2 node_count nodes, largest first.
        candidates.clear();
        candidates.extend(
            bvh.nodes
                .iter()
                .take(node_count * 2)
                .enumerate()
                .skip(1)
                .map(|(i, node)| Candidate {
                    cost: node.aabb().half_area(),
                    node_id: i as u32,
                }),
        );
        candidates.radix_sort_unstable();
        touched.fill(false);
        reinsertions.clear();
        // The searches only read the tree: a chunk of them runs in parallel, and their
        // results are taken in order as the sequential loop would take them (the budget
        // checked before each), so the tree is the same; past the budget at most one chunk's
        // searches are wasted.
        'search: for chunk in candidates[..node_count - 1].chunks(SEARCH_CHUNK) {
            let found: Vec<(Reinsertion, u64)> = chunk
                .par_iter()
                .map(|candidate| {
                    let mut visits = 0;
                    let r = find_reinsertion(bvh, candidate.node_id as usize, &mut visits);
                    (r, visits)
                })
                .collect();
            for (r, visits) in found {
                if stats.visits > budget {
                    stats.out_of_budget = true;
                    break 'search;
                }
                stats.candidates += 1;
                stats.visits += visits;
                if r.area_diff > 0.0 {
                    reinsertions.push(r);
                }
            }
        }
        reinsertions.sort_unstable_by(|a, b| b.area_diff.partial_cmp(&a.area_diff).unwrap());
        for r in &reinsertions {
            let (from, to) = (r.from as usize, r.to as usize);
            let conflicts = [
                to,
                from,
                Bvh2Node::get_sibling_id(from),
                bvh.parents[to] as usize,
                bvh.parents[from] as usize,
            ];
            if conflicts.iter().any(|&i| touched[i]) {
                continue;
            }
            for &c in &conflicts {
                touched[c] = true;
            }
            reinsert_node(bvh, from, to);
        }
        if stats.out_of_budget {
            break;
        }
    }
    stats
}

/// obvhs's `find_reinsertion`: where moving `node_id` saves the most surface area (none:
/// `area_diff` 0), counting the nodes it visits into `visits`.
fn find_reinsertion(bvh: &Bvh2, node_id: usize, visits: &mut u64) -> Reinsertion {
    let mut best = Reinsertion {
        from: node_id as u32,
        to: 0,
        area_diff: 0.0,
    };
    let node_area = bvh.nodes[node_id].aabb().half_area();
    let parent_id = bvh.parents[node_id] as usize;
    let mut area_diff = bvh.nodes[parent_id].aabb().half_area();
    let mut sibling_id = Bvh2Node::get_sibling_id(node_id);
    let mut pivot_bbox = *bvh.nodes[sibling_id].aabb();
    let mut pivot_id = parent_id;
    let aabb = *bvh.nodes[node_id].aabb();
    let mut stack: Vec<(f32, u32)> = Vec::new();
    loop {
        stack.push((area_diff, sibling_id as u32));
        while let Some((top_area_diff, top_sibling_id)) = stack.pop() {
            *visits += 1;
            if top_area_diff - node_area <= best.area_diff {
                continue;
            }
            let dst = &bvh.nodes[top_sibling_id as usize];
            let reinsert_area = top_area_diff - dst.aabb().union(&aabb).half_area();
            if reinsert_area > best.area_diff {
                best.to = top_sibling_id;
                best.area_diff = reinsert_area;
            }
            if !dst.is_leaf() {
                let child_area = reinsert_area + dst.aabb().half_area();
                stack.push((child_area, dst.first_index));
                stack.push((child_area, dst.first_index + 1));
            }
        }
        if pivot_id != parent_id {
            pivot_bbox = pivot_bbox.union(bvh.nodes[sibling_id].aabb());
            area_diff += bvh.nodes[pivot_id].aabb().half_area() - pivot_bbox.half_area();
        }
        if pivot_id == 0 {
            break;
        }
        sibling_id = Bvh2Node::get_sibling_id(pivot_id);
        pivot_id = bvh.parents[pivot_id] as usize;
    }
    if best.to == Bvh2Node::get_sibling_id32(best.from)
        || best.to == bvh.parents[best.from as usize]
    {
        best = Reinsertion::default();
    }
    best
}

/// What a PLOC build did: its passes, and those that were forced.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub(super) struct PlocStats {
    pub passes: usize,
    pub forced: usize,
}

/// obvhs's `PlocBuilder::build` (sequential), with forced merging in passes that merge too
/// little (see the module documentation).
pub(super) fn ploc(
    aabbs: &[Aabb],
    search: PlocSearchDistance,
    precision: SortPrecision,
    search_depth_threshold: usize,
) -> (Bvh2, PlocStats) {
    match search {
        PlocSearchDistance::Minimum => ploc_with::<1>(aabbs, precision, search_depth_threshold),
        PlocSearchDistance::VeryLow => ploc_with::<2>(aabbs, precision, search_depth_threshold),
        PlocSearchDistance::Low => ploc_with::<6>(aabbs, precision, search_depth_threshold),
        PlocSearchDistance::Medium => ploc_with::<14>(aabbs, precision, search_depth_threshold),
        PlocSearchDistance::High => ploc_with::<24>(aabbs, precision, search_depth_threshold),
        PlocSearchDistance::VeryHigh => ploc_with::<32>(aabbs, precision, search_depth_threshold),
    }
}

/// obvhs's Morton keys, laid out as its own (the unstable sort's order of equal keys must be
/// its order).
#[derive(Clone, Copy)]
#[repr(C)]
struct Morton128 {
    code: u128,
    index: u64,
    padding: u64,
}

#[derive(Clone, Copy)]
#[repr(C)]
struct Morton64 {
    code: u64,
    index: u64,
}

impl RadixKey for Morton128 {
    const LEVELS: usize = 16;
    #[inline(always)]
    fn get_level(&self, level: usize) -> u8 {
        self.code.get_level(level)
    }
}

impl RadixKey for Morton64 {
    const LEVELS: usize = 8;
    #[inline(always)]
    fn get_level(&self, level: usize) -> u8 {
        self.code.get_level(level)
    }
}

/// The nodes in obvhs's Morton order (its `sort_nodes_by_morton`, sequential).
fn morton_order(nodes: &[Bvh2Node], total: &Aabb, precision: SortPrecision) -> Vec<Bvh2Node> {
    let scale = 1.0 / total.diagonal().as_dvec3();
    let offset = -total.min.as_dvec3() * scale;
    let center = |n: &Bvh2Node| n.aabb().center().as_dvec3() * scale + offset;
    // obvhs sorts up to 250,000 keys with the standard library's unstable sort, more by radix.
    let radix = nodes.len() > 250_000;
    match precision {
        SortPrecision::U128 => {
            let mut keys: Vec<Morton128> = nodes
                .iter()
                .enumerate()
                .map(|(index, n)| Morton128 {
                    code: morton_encode_u128_unorm(center(n)),
                    index: index as u64,
                    padding: 0,
                })
                .collect();
            if radix {
                keys.radix_sort_unstable();
            } else {
                keys.sort_unstable_by_key(|m| m.code);
            }
            keys.iter().map(|m| nodes[m.index as usize]).collect()
        }
        SortPrecision::U64 => {
            let mut keys: Vec<Morton64> = nodes
                .iter()
                .enumerate()
                .map(|(index, n)| Morton64 {
                    code: morton_encode_u64_unorm(center(n)),
                    index: index as u64,
                })
                .collect();
            if radix {
                keys.radix_sort_unstable();
            } else {
                keys.sort_unstable_by_key(|m| m.code);
            }
            keys.iter().map(|m| nodes[m.index as usize]).collect()
        }
    }
}

fn ploc_with<const SEARCH: usize>(
    aabbs: &[Aabb],
    precision: SortPrecision,
    search_depth_threshold: usize,
) -> (Bvh2, PlocStats) {
    let prim_count = aabbs.len();
    let mut bvh = Bvh2::zeroed(prim_count);
    bvh.reset_for_reuse(prim_count, Some((0..prim_count as u32).collect()));
    let mut stats = PlocStats::default();
    if prim_count == 0 {
        return (bvh, stats);
    }
    let mut total = Aabb::empty();
    let leaves: Vec<Bvh2Node> = aabbs
        .iter()
        .enumerate()
        .map(|(i, aabb)| {
            total.extend(aabb.min);
            total.extend(aabb.max);
            Bvh2Node::new(*aabb, 1, i as u32)
        })
        .collect();
    let mut current = morton_order(&leaves, &total, precision);
    let mut next = vec![Bvh2Node::default(); prim_count];
    let mut merge = vec![0i8; prim_count];
    let mut insert_index = (2 * prim_count).saturating_sub(1);
    let cost = |a: &Bvh2Node, b: &Bvh2Node| a.aabb().union(b.aabb()).half_area();

    let mut depth = 0usize;
    let mut count = prim_count;
    while count > 1 {
        let nodes = &current[..count];
        let merge = &mut merge[..count];
        if SEARCH == 1 || depth < search_depth_threshold {
            // Each node towards the cheaper of its two neighbours (obvhs's first passes).
            let costs: Vec<f32> = (0..count - 1)
                .into_par_iter()
                .with_min_len(PARALLEL_NODES)
                .map(|i| cost(&nodes[i], &nodes[i + 1]))
                .collect();
            let mut last_cost = f32::INFINITY;
            for (m, &c) in merge.iter_mut().zip(&costs) {
                *m = if last_cost < c { -1 } else { 1 };
                last_cost = c;
            }
            merge[count - 1] = -1;
        } else {
            // The cheapest union within SEARCH places, ties to the last (obvhs's `<=`).
            merge
                .par_iter_mut()
                .enumerate()
                .with_min_len(PARALLEL_NODES)
                .for_each(|(index, best)| {
                    let mut best_node = index;
                    let mut best_cost = f32::INFINITY;
                    let begin = index - SEARCH.min(index);
                    let end = (index + SEARCH + 1).min(count);
                    for other in (begin..index).chain(index + 1..end) {
                        let c = cost(&nodes[other], &nodes[index]);
                        if c <= best_cost {
                            best_node = other;
                            best_cost = c;
                        }
                    }
                    *best = (best_node as i64 - index as i64) as i8;
                });
        }
        let mutual = |merge: &[i8], i: usize| {
            let best = (i as i64 + merge[i] as i64) as usize;
            best as i64 + merge[best] as i64 == i as i64
        };
        if count > FORCE_MIN_NODES {
            let merged = (0..count).filter(|&i| mutual(merge, i)).count();
            if merged * FORCE_RATIO < count {
                // Too little progress: the unpaired nodes pair up with their unpaired
                // neighbours on the curve.
                let paired: Vec<bool> = (0..count).map(|i| mutual(merge, i)).collect();
                let mut i = 0;
                while i + 1 < count {
                    if !paired[i] && !paired[i + 1] {
                        merge[i] = 1;
                        merge[i + 1] = -1;
                        i += 2;
                    } else {
                        i += 1;
                    }
                }
                stats.forced += 1;
            }
        }
        // obvhs's merge: mutual pairs become a parent placed for the next pass, their two
        // children stored from the end of the node array down.
        let mut next_count = 0;
        let mut index = 0;
        while index < count {
            let offset = merge[index] as i64;
            let best = (index as i64 + offset) as usize;
            if best as i64 + merge[best] as i64 != index as i64 {
                next[next_count] = nodes[index];
                next_count += 1;
                index += 1;
                continue;
            }
            if best > index {
                index += 1;
                continue;
            }
            let (left, right) = (nodes[index], nodes[best]);
            insert_index -= 2;
            bvh.nodes[insert_index] = left;
            bvh.nodes[insert_index + 1] = right;
            next[next_count] =
                Bvh2Node::new(left.aabb().union(right.aabb()), 0, insert_index as u32);
            next_count += 1;
            index += if SEARCH == 1 && offset == 1 { 2 } else { 1 };
        }
        std::mem::swap(&mut current, &mut next);
        count = next_count;
        depth += 1;
    }
    debug_assert_eq!(insert_index, 1);
    bvh.nodes[0] = current[0];
    bvh.max_depth = DEFAULT_MAX_STACK_DEPTH.max(depth + 1);
    bvh.children_are_ordered_after_parents = true;
    stats.passes = depth;
    (bvh, stats)
}

#[cfg(test)]
mod tests {
    use super::*;
    use glam::Vec3A;
    use torrey_testkit::Rng;

    fn triangle_box(p: [Vec3A; 3]) -> Aabb {
        Aabb {
            min: p[0].min(p[1]).min(p[2]),
            max: p[0].max(p[1]).max(p[2]),
        }
    }

    fn node_bits(bvh: &Bvh2) -> Vec<[u32; 8]> {
        bvh.nodes
            .iter()
            .map(|n| {
                let a = n.aabb();
                [
                    a.min.x.to_bits(),
                    a.min.y.to_bits(),
                    a.min.z.to_bits(),
                    a.max.x.to_bits(),
                    a.max.y.to_bits(),
                    a.max.z.to_bits(),
                    n.prim_count,
                    n.first_index,
                ]
            })
            .collect()
    }

    /// Small triangles scattered over a surface (a sphere of radius 1 and a plane), as meshes
    /// are, plus some larger ones.
    fn mesh_like(n: usize, seed: u64) -> Vec<Aabb> {
        let mut rng = Rng::new(seed);
        (0..n)
            .map(|i| {
                let size = if i % 97 == 0 { 0.2 } else { 0.01 };
                let c = if i % 3 == 0 {
                    Vec3A::new(rng.range(-2.0, 2.0), -1.0, rng.range(-2.0, 2.0))
                } else {
                    let v = Vec3A::new(
                        rng.range(-1.0, 1.0),
                        rng.range(-1.0, 1.0),
                        rng.range(-1.0, 1.0),
                    );
                    v.normalize_or(Vec3A::X)
                };
                let mut jitter = || {
                    Vec3A::new(
                        rng.range(-1.0, 1.0),
                        rng.range(-1.0, 1.0),
                        rng.range(-1.0, 1.0),
                    )
                };
                triangle_box([c, c + jitter() * size, c + jitter() * size])
            })
            .collect()
    }

    /// On mesh-like input the clustering is obvhs's, node for node and bit for bit, with the
    /// settings the renderer uses (the slowest build below 100,000 primitives, the medium one
    /// above), through both of obvhs's sorts (the radix sort above 250,000 keys); and no pass
    /// is forced.
    #[test]
    fn same_tree_as_obvhs() {
        let slow = BvhBuildParams::very_slow_build();
        let medium = BvhBuildParams::medium_build();
        for (n, params) in [
            (1, slow),
            (2, slow),
            (700, slow),
            (20_000, slow),
            (20_000, medium),
            (300_000, medium),
        ] {
            let aabbs = mesh_like(n, n as u64);
            let (ours, stats) = ploc(
                &aabbs,
                params.ploc_search_distance,
                params.sort_precision,
                params.search_depth_threshold,
            );
            let theirs = obvhs::ploc::PlocBuilder::new().build(
                params.ploc_search_distance,
                &aabbs,
                (0..n as u32).collect(),
                params.sort_precision,
                params.search_depth_threshold,
            );
            assert_eq!(stats.forced, 0, "{n}");
            assert_eq!(node_bits(&ours), node_bits(&theirs), "{n}");
            assert_eq!(ours.primitive_indices, theirs.primitive_indices, "{n}");
            assert_eq!(ours.max_depth, theirs.max_depth, "{n}");
            // The whole build (reinsertion, collapse, reinsertion) too, within its budget.
            let params = BvhBuildParams {
                max_prims_per_leaf: 4,
                ..params
            };
            let (ours, stats) = build_bvh2_stats(&aabbs, params);
            let theirs = obvhs::bvh2::builder::build_bvh2(
                &aabbs,
                params,
                &mut std::time::Duration::default(),
            );
            for r in stats.reinsertion {
                assert!(!r.out_of_budget, "{n}: {stats:?}");
                // Far from it: under a tenth.
                assert!(
                    r.visits <= r.budget / 2,
                    "{n}: {} visits per candidate",
                    r.visits / r.candidates.max(1)
                );
            }
            assert_eq!(node_bits(&ours), node_bits(&theirs), "{n}");
            assert_eq!(ours.primitive_indices, theirs.primitive_indices, "{n}");
        }
    }

    /// The scenes' own geometry (scenes/, and the mitsuba-real scenes of ../shared when it is
    /// there) gets obvhs's tree, node for node: no pass forced, no reinsertion skipped or out of
    /// budget.
    #[test]
    fn same_tree_as_obvhs_on_the_scenes() {
        use std::path::Path;
        let root = Path::new(env!("CARGO_MANIFEST_DIR")).join("../..");
        let mut files: Vec<_> = std::fs::read_dir(root.join("scenes"))
            .unwrap()
            .map(|e| e.unwrap().path())
            .filter(|p| p.extension().is_some_and(|e| e == "xml"))
            .collect();
        let real = root.join("../shared/scenes/mitsuba-real");
        if real.is_dir() {
            for f in [
                "stage-lights/bunny.xml",
                "matpreview-copper/docs/scenes/bsdf_roughconductor_copper.xml",
                "bunny-sss/docs/scenes/medium_homogeneous_sss.xml",
                "clover-banner/scene.xml",
            ] {
                files.push(real.join(f));
            }
        }
        files.sort();
        let mut checked = 0;
        for file in files {
            let Ok(desc) = torrey_parser::load_scene(&file, &[]) else {
                continue;
            };
            let Ok(scene) = crate::scene::RenderScene::build(&desc, 16, 16) else {
                continue;
            };
            let n = scene.accel().primitive_count() as u32;
            let aabbs: Vec<Aabb> = (0..n).map(|i| scene.prim_geom(i).aabb()).collect();
            let params = if aabbs.len() < super::super::build::LARGE_SCENE {
                BvhBuildParams::very_slow_build()
            } else {
                BvhBuildParams::medium_build()
            };
            let params = BvhBuildParams {
                max_prims_per_leaf: 4,
                collapse_traversal_cost: 3.0,
                ..params
            };
            let (ours, stats) = build_bvh2_stats(&aabbs, params);
            let theirs = obvhs::bvh2::builder::build_bvh2(
                &aabbs,
                params,
                &mut std::time::Duration::default(),
            );
            let what = file.display();
            assert_eq!(stats.ploc.forced, 0, "{what}: {stats:?}");
            assert!(stats.overlap <= OVERLAP_LIMIT / 8.0, "{what}: {stats:?}");
            for r in stats.reinsertion {
                assert!(r.visits <= r.budget / 4, "{what}: {stats:?}");
            }
            assert_eq!(node_bits(&ours), node_bits(&theirs), "{what}");
            assert_eq!(ours.primitive_indices, theirs.primitive_indices, "{what}");
            checked += 1;
        }
        assert!(checked >= 10, "{checked} scenes");
    }

    /// Inputs that made obvhs's build quadratic: one triangle repeated and a 4-vertex polygon's
    /// slivers (PLOC: about n passes, a tree n deep), a random polygon's slivers spanning it
    /// (reinsertion: searches that prune nothing), and such slivers packed into a corner of an
    /// ordinary scene. The work is counted, not timed: PLOC's passes (each O(n)) stay
    /// logarithmic in n, the reinsertion searches of the overlapping trees are skipped, and
    /// those of the scene with a corner of slivers stay within their budget. Every primitive
    /// ends in exactly one leaf.
    #[test]
    fn the_build_stays_n_log_n_on_overlapping_slivers() {
        let n = 20_000;
        let tri = [Vec3A::ZERO, Vec3A::X, Vec3A::Y];
        let quad = [Vec3A::ZERO, Vec3A::X, Vec3A::Y, Vec3A::new(1.0, 1.0, 0.5)];
        let mut rng = Rng::new(7);
        let random: Vec<Vec3A> = (0..n + 2)
            .map(|_| Vec3A::new(rng.f32(), rng.f32(), rng.f32()))
            .collect();
        // The zig-zag strip obj.rs cuts a polygon into.
        let strip = |points: &[Vec3A], scale: f32| -> Vec<Aabb> {
            let m = points.len();
            (0..m - 2)
                .map(|i| {
                    let (lo, hi) = (i / 2, m - 1 - i.div_ceil(2));
                    let third = if i % 2 == 0 { lo + 1 } else { hi + 1 };
                    triangle_box(
                        [points[lo], points[third.min(m - 1)], points[hi]].map(|p| p * scale),
                    )
                })
                .collect()
        };
        let mut corner = mesh_like(n, 3);
        corner.extend(strip(&random[..5000], 0.05));
        // (what, boxes, forced PLOC passes, reinsertion skipped)
        let cases: [(&str, Vec<Aabb>, bool, bool); 4] = [
            (
                "one triangle repeated",
                vec![triangle_box(tri); n],
                true,
                true,
            ),
            (
                "a polygon over 4 points",
                strip(&(0..n).map(|i| quad[i % 4]).collect::<Vec<_>>(), 1.0),
                true,
                true,
            ),
            ("a random polygon", strip(&random, 1.0), false, true),
            (
                "a mesh with a random polygon in a corner",
                corner,
                false,
                false,
            ),
        ];
        for (what, aabbs, forced, skipped) in cases {
            let count = aabbs.len();
            let params = BvhBuildParams {
                max_prims_per_leaf: 4,
                ..BvhBuildParams::very_slow_build()
            };
            let (bvh, stats) = build_bvh2_stats(&aabbs, params);
            assert_eq!(stats.ploc.forced > 0, forced, "{what}: {stats:?}");
            assert!(
                (stats.ploc.passes as f64) < 8.0 * (count as f64).log2() + FORCE_MIN_NODES as f64,
                "{what}: {} passes for {count} boxes",
                stats.ploc.passes
            );
            assert_eq!(stats.overlap > OVERLAP_LIMIT, skipped, "{what}: {stats:?}");
            for r in stats.reinsertion {
                if skipped {
                    assert_eq!(r.visits, 0, "{what}");
                }
                // The budget, overrun at most by the search that crossed it.
                assert!(r.visits <= r.budget + 4 * count as u64, "{what}: {r:?}");
            }
            let mut seen = vec![false; count];
            let mut stack = vec![0usize];
            while let Some(i) = stack.pop() {
                let node = &bvh.nodes[i];
                if node.is_leaf() {
                    let first = node.first_index as usize;
                    for &p in &bvh.primitive_indices[first..first + node.prim_count as usize] {
                        assert!(!seen[p as usize], "{what}");
                        seen[p as usize] = true;
                    }
                } else {
                    stack.extend([node.first_index as usize, node.first_index as usize + 1]);
                }
            }
            assert!(seen.iter().all(|&s| s), "{what}");
        }
    }
}
