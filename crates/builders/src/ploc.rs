//! PLOC: parallel locally-ordered clustering (Meister & Bittner 2018, "Parallel
//! locally-ordered clustering for bounding volume hierarchy construction").
//!
//! A bottom-up builder:
//!
//! 1. **Morton order.** Each primitive's centroid (the centre of its box) is quantised to 21
//!    bits per axis over the centroids' bounds (an axis of zero extent gets 0) and the bits
//!    are interleaved into a 63-bit Morton code (x in the lowest bit of each triple). The
//!    primitives are sorted by `(code, index)`: the keys are unique, so the parallel sort is
//!    deterministic.
//! 2. **Clusters.** Every primitive starts as a cluster of one. In each iteration every
//!    cluster `i` looks for its nearest neighbour among the clusters `i - r ..= i + r` of the
//!    current Morton-ordered list (`r` = [`PlocConfig::radius`]), the distance being the area of
//!    the merged box. Ties are broken by a total order on *pairs* (area, then `|i - j|`, then
//!    whether `min(i, j)` is odd, then `min(i, j)`), so the cheapest pair of the iteration is
//!    always mutual (every iteration merges at least one pair) and runs of identical boxes
//!    pair up as `(0, 1), (2, 3), …` instead of one pair per iteration.
//! 3. **Merge and compaction.** Mutual nearest neighbours `i < j` merge into a new inner node
//!    that takes position `i`; position `j` disappears; the list keeps its order. The
//!    neighbour search runs in parallel (rayon) over chunks of the list, each pair's area
//!    computed once for both of its clusters; merging and compaction are a linear pass.
//!
//! The clustering makes a binary tree with one primitive per leaf. **Leaves** are then made by
//! SAH cost, bottom-up: a subtree of at most [`PlocConfig::max_leaf_size`] primitives becomes
//! one leaf when `n c_i A` is at most the cost of keeping it (`c_t A` plus its children's
//! costs), as the top-down builders decide their leaves. The output is written in depth-first
//! order, each leaf's references in Morton order.
//!
//! Everything is a function of the input: the tree is the same for any number of threads.
//! Spatial splits are not made (`spatial_splits` is false).

use rayon::prelude::*;
use sahara_bvh::Node;
use sahara_geom::{Aabb, Vec3A};

use crate::{BuildError, BuildInput, Bvh, Configured, Strategy};

/// Configuration of the PLOC builder.
#[derive(Clone, Copy, Debug, PartialEq, Eq, serde::Serialize, serde::Deserialize)]
pub struct PlocConfig {
    /// Search radius `r` of the nearest-neighbour search (1 to [`MAX_RADIUS`]): each cluster compares
    /// itself with the `r` clusters before and after it in Morton order. Default 16 (Meister &
    /// Bittner's recommendation, confirmed by measurements, see `docs/builders-frontier.md`).
    pub radius: usize,
    /// Largest leaf (at least 1) made when collapsing subtrees by SAH cost. Default 8, as the
    /// sweep builder.
    pub max_leaf_size: usize,
}

impl Default for PlocConfig {
    fn default() -> Self {
        Self::DEFAULT
    }
}

impl PlocConfig {
    /// Radius 16, leaves of at most 8 primitives.
    pub const DEFAULT: PlocConfig = PlocConfig {
        radius: 16,
        max_leaf_size: 8,
    };
}

impl Strategy for PlocConfig {
    const NAME: &'static str = "ploc";

    fn check(&self) -> Result<(), BuildError> {
        if self.radius == 0 || self.radius > MAX_RADIUS {
            return Err(BuildError::InvalidConfig(format!(
                "ploc: radius must be in 1..={MAX_RADIUS}"
            )));
        }
        if self.max_leaf_size == 0 {
            return Err(BuildError::InvalidConfig(
                "ploc: max_leaf_size must be at least 1".into(),
            ));
        }
        Ok(())
    }

    fn describe(&self) -> String {
        format!(
            "PLOC (Meister & Bittner 2018), radius {}, SAH leaves of at most {}",
            self.radius, self.max_leaf_size
        )
    }

    fn build_tree(&self, input: &BuildInput) -> Result<Bvh, BuildError> {
        Ok(build(input, self))
    }
}

/// The PLOC builder, registered as `"ploc"`.
pub type PlocBuilder = Configured<PlocConfig>;

/// Spreads the low 21 bits of `v` to every third bit.
fn spread(v: u64) -> u64 {
    let mut x = v & 0x1f_ffff;
    x = (x | (x << 32)) & 0x001f_0000_0000_ffff;
    x = (x | (x << 16)) & 0x001f_0000_ff00_00ff;
    x = (x | (x << 8)) & 0x100f_00f0_0f00_f00f;
    x = (x | (x << 4)) & 0x10c3_0c30_c30c_30c3;
    x = (x | (x << 2)) & 0x1249_2492_4924_9249;
    x
}

/// The 63-bit Morton code of `p` within `bounds`.
fn morton(p: Vec3A, lo: Vec3A, scale: Vec3A) -> u64 {
    const MAX: f32 = ((1u32 << 21) - 1) as f32;
    let q = ((p - lo) * scale).clamp(Vec3A::ZERO, Vec3A::splat(MAX));
    spread(q.x as u64) | (spread(q.y as u64) << 1) | (spread(q.z as u64) << 2)
}

/// The primitives in Morton order of their centroids.
fn morton_order(centroids: &[Vec3A]) -> Vec<u32> {
    let cb = Aabb::from_points(centroids.iter().copied());
    let ext = cb.extent();
    const MAX: f32 = ((1u32 << 21) - 1) as f32;
    let inv = |e: f32| {
        let s = MAX / e;
        if e > 0.0 && s.is_finite() {
            s
        } else {
            0.0
        }
    };
    let scale = Vec3A::new(inv(ext.x), inv(ext.y), inv(ext.z));
    let mut keys: Vec<(u64, u32)> = centroids
        .par_iter()
        .enumerate()
        .map(|(i, &c)| (morton(c, cb.min, scale), i as u32))
        .collect();
    keys.par_sort_unstable();
    keys.into_iter().map(|(_, i)| i).collect()
}

fn build(input: &BuildInput, config: &PlocConfig) -> Bvh {
    let n = input.len();
    let bounds = input.bounds();
    let order = morton_order(input.centroids());
    // Nodes 0..n are the primitives; inner nodes are appended as they are made, so a node's
    // children always have smaller ids.
    let total = 2 * n - 1;
    let mut boxes: Vec<Aabb> = Vec::with_capacity(total);
    boxes.extend_from_slice(bounds);
    let mut children: Vec<[u32; 2]> = Vec::with_capacity(n.saturating_sub(1));
    let mut clusters: Vec<u32> = order;
    let mut cboxes: Vec<Aabb> = clusters.iter().map(|&p| bounds[p as usize]).collect();
    let r = config.radius;
    let mut next_clusters = Vec::with_capacity(n);
    let mut next_boxes = Vec::with_capacity(n);
    while clusters.len() > 1 {
        let m = clusters.len();
        let nn = nearest_neighbours(&cboxes, r);
        next_clusters.clear();
        next_boxes.clear();
        for i in 0..m {
            let j = nn[i];
            if nn[j] == i {
                if i < j {
                    let b = cboxes[i].union(&cboxes[j]);
                    let id = boxes.len() as u32;
                    boxes.push(b);
                    children.push([clusters[i], clusters[j]]);
                    next_clusters.push(id);
                    next_boxes.push(b);
                }
            } else {
                next_clusters.push(clusters[i]);
                next_boxes.push(cboxes[i]);
            }
        }
        std::mem::swap(&mut clusters, &mut next_clusters);
        std::mem::swap(&mut cboxes, &mut next_boxes);
    }
    let root = clusters[0] as usize;
    collapse(input, &boxes, &children, root, config.max_leaf_size)
}

/// Clusters per task of the neighbour search: the areas of a chunk's pairs stay in cache.
const CHUNK: usize = 2048;

/// The largest search radius: a candidate's offset must fit the packed key of the
/// neighbour search (20 bits).
pub const MAX_RADIUS: usize = 1 << 20;

/// An `f32` as a `u32` whose unsigned order is `f32::total_cmp`'s.
#[inline]
fn ordered_bits(a: f32) -> u32 {
    let b = a.to_bits();
    if b >> 31 == 1 {
        !b
    } else {
        b | 0x8000_0000
    }
}

/// The pair `{i, i - d}` (`below`) or `{i, i + d}` as seen from cluster `i`, packed into a
/// `u64` whose order among `i`'s candidates is the order of the pair order (module docs, step 2): the area first
/// (as `total_cmp`), then `d = hi - lo`, then the parity of the lower index, then the lower
/// index itself, which among two pairs of `i` with the same `d` is the smaller for the pair
/// below `i`. The candidate is decoded back by [`candidate_of`].
#[inline]
fn candidate_key(area_bits: u32, i: usize, d: usize, below: bool) -> u64 {
    let lo = if below { i - d } else { i };
    ((area_bits as u64) << 32) | ((d as u64) << 2) | (((lo & 1) as u64) << 1) | (!below as u64)
}

/// The neighbour of cluster `i` that a [`candidate_key`] stands for.
#[inline]
fn candidate_of(key: u64, i: usize) -> usize {
    let d = ((key as u32) >> 2) as usize;
    if key & 1 == 0 {
        i - d
    } else {
        i + d
    }
}

/// The nearest neighbour of every cluster of the list among the `r` on each side, by the
/// pair order of the pair order (module docs, step 2). Each pair's merged area is computed once, from the lower
/// index's side (`cboxes[i].union(&cboxes[j])`, `i < j`), and read by both clusters: half the
/// box unions of a search from each side; the comparisons are of packed integer keys
/// ([`candidate_key`]). The pair order is total on distinct pairs, so the order in which
/// candidates are visited does not matter and the result is a function of the list alone,
/// whatever the thread count.
fn nearest_neighbours(cboxes: &[Aabb], r: usize) -> Vec<usize> {
    debug_assert!((1..=MAX_RADIUS).contains(&r));
    let m = cboxes.len();
    let chunks: Vec<Vec<usize>> = (0..m.div_ceil(CHUNK))
        .into_par_iter()
        .map(|c| {
            let c0 = c * CHUNK;
            let c1 = (c0 + CHUNK).min(m);
            // areas[(i - s0) * r + d - 1]: the ordered bits of the area of the pair
            // (i, i + d), for i in s0..c1 and d in 1..=r.
            let s0 = c0.saturating_sub(r);
            let mut areas = vec![u32::MAX; (c1 - s0) * r];
            for i in s0..c1 {
                let b = cboxes[i];
                let row = &mut areas[(i - s0) * r..(i - s0 + 1) * r];
                for (d, a) in (1..=r).zip(row.iter_mut()) {
                    let Some(other) = cboxes.get(i + d) else {
                        break;
                    };
                    *a = ordered_bits(b.union(other).half_area());
                }
            }
            (c0..c1)
                .map(|i| {
                    let mut best = u64::MAX;
                    for d in 1..=r.min(i) {
                        let a = areas[(i - d - s0) * r + d - 1];
                        best = best.min(candidate_key(a, i, d, true));
                    }
                    let row = &areas[(i - s0) * r..(i - s0) * r + r.min(m - 1 - i)];
                    for (d, &a) in (1..).zip(row) {
                        best = best.min(candidate_key(a, i, d, false));
                    }
                    candidate_of(best, i)
                })
                .collect()
        })
        .collect();
    chunks.concat()
}

/// Area in `f64` (recomputed in `f64` when the `f32` product overflows).
fn area(b: &Aabb) -> f64 {
    let a = b.half_area();
    if a.is_finite() {
        return a as f64;
    }
    let e = b.extent();
    let (x, y, z) = (e.x as f64, e.y as f64, e.z as f64);
    x * y + y * z + z * x
}

/// Makes leaves by SAH cost and writes the depth-first layout.
fn collapse(
    input: &BuildInput,
    boxes: &[Aabb],
    children: &[[u32; 2]],
    root: usize,
    max_leaf: usize,
) -> Bvh {
    let n = input.len();
    let (ct, ci) = (input.cost.traversal as f64, input.cost.intersection as f64);
    let total = boxes.len();
    let mut count = vec![1usize; total];
    let mut cost = vec![0.0f64; total];
    let mut leaf = vec![true; total];
    for v in 0..n {
        cost[v] = ci * area(&boxes[v]);
    }
    for (k, &[l, r]) in children.iter().enumerate() {
        let v = n + k;
        let (l, r) = (l as usize, r as usize);
        count[v] = count[l] + count[r];
        let a = area(&boxes[v]);
        let split = ct * a + cost[l] + cost[r];
        let as_leaf = ci * count[v] as f64 * a;
        if count[v] <= max_leaf && as_leaf <= split {
            cost[v] = as_leaf;
        } else {
            cost[v] = split;
            leaf[v] = false;
        }
    }
    let mut nodes = Vec::with_capacity(total);
    let mut prims: Vec<u32> = Vec::with_capacity(n);
    let mut stack = vec![(root as u32, u32::MAX)];
    let mut gather = Vec::new();
    while let Some((v, patch)) = stack.pop() {
        let idx = nodes.len() as u32;
        if patch != u32::MAX {
            let pn: &mut Node = &mut nodes[patch as usize];
            pn.index = idx;
        }
        let vu = v as usize;
        if leaf[vu] {
            let first = prims.len() as u32;
            gather.clear();
            gather.push(v);
            while let Some(w) = gather.pop() {
                let w = w as usize;
                if w < n {
                    prims.push(w as u32);
                } else {
                    let [l, r] = children[w - n];
                    gather.push(r);
                    gather.push(l);
                }
            }
            nodes.push(Node::leaf(&boxes[vu], first, count[vu] as u32));
        } else {
            let [l, r] = children[vu - n];
            nodes.push(Node::inner(&boxes[vu], 0));
            stack.push((r, idx));
            stack.push((l, u32::MAX));
        }
    }
    Bvh {
        nodes,
        prim_indices: prims,
        spatial_splits: false,
        ref_cuts: None,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The pair order of the neighbour search: a function of the unordered pair `{i, j}`.
    #[inline]
    fn pair_key(area: f32, i: usize, j: usize) -> (f32, usize, usize, usize) {
        let (lo, hi) = if i < j { (i, j) } else { (j, i) };
        (area, hi - lo, lo & 1, lo)
    }

    #[inline]
    fn less(a: (f32, usize, usize, usize), b: (f32, usize, usize, usize)) -> bool {
        match a.0.total_cmp(&b.0) {
            std::cmp::Ordering::Less => true,
            std::cmp::Ordering::Greater => false,
            std::cmp::Ordering::Equal => (a.1, a.2, a.3) < (b.1, b.2, b.3),
        }
    }

    /// The search of the first version: every cluster unions its box with each of its `2r`
    /// neighbours' boxes itself.
    fn nearest_naive(cboxes: &[Aabb], r: usize) -> Vec<usize> {
        let m = cboxes.len();
        (0..m)
            .map(|i| {
                let mut best = (f32::INFINITY, usize::MAX, 0, 0);
                let mut best_j = usize::MAX;
                for j in i.saturating_sub(r)..(i + r + 1).min(m) {
                    if j == i {
                        continue;
                    }
                    let k = pair_key(cboxes[i].union(&cboxes[j]).half_area(), i, j);
                    if best_j == usize::MAX || less(k, best) {
                        best = k;
                        best_j = j;
                    }
                }
                best_j
            })
            .collect()
    }

    #[test]
    fn chunked_search_equals_the_search_from_both_sides() {
        // Pseudo-random boxes, with runs of equal boxes (ties) and lists that cross chunk
        // boundaries, for radii below and above the list lengths.
        let mut x = 0x9e37_79b9_u32;
        let mut rnd = move || {
            x ^= x << 13;
            x ^= x >> 17;
            x ^= x << 5;
            (x % 1000) as f32 / 10.0
        };
        for (m, r) in [
            (2, 1),
            (5, 16),
            (CHUNK + 7, 16),
            (3 * CHUNK + 1, 4),
            (5000, 1),
        ] {
            let boxes: Vec<Aabb> = (0..m)
                .map(|i| {
                    if i % 7 < 3 {
                        Aabb::new(Vec3A::splat(1.0), Vec3A::splat(2.0))
                    } else if i % 11 == 5 {
                        // Points: pairs of zero area.
                        Aabb::new(Vec3A::ZERO, Vec3A::ZERO)
                    } else {
                        let p = Vec3A::new(rnd(), rnd(), rnd());
                        Aabb::new(p, p + Vec3A::new(rnd(), rnd(), rnd()))
                    }
                })
                .collect();
            assert_eq!(
                nearest_neighbours(&boxes, r),
                nearest_naive(&boxes, r),
                "m {m}, r {r}"
            );
        }
    }

    #[test]
    fn morton_interleaves() {
        assert_eq!(spread(1), 1);
        assert_eq!(spread(0b11), 0b1001);
        assert_eq!(spread(0x1f_ffff).count_ones(), 21);
        let lo = Vec3A::ZERO;
        let s = Vec3A::splat(1.0);
        assert_eq!(morton(Vec3A::new(1.0, 0.0, 0.0), lo, s), 1);
        assert_eq!(morton(Vec3A::new(0.0, 1.0, 0.0), lo, s), 2);
        assert_eq!(morton(Vec3A::new(0.0, 0.0, 1.0), lo, s), 4);
    }
}
