//! The end-point overlap metric (EPO) of Aila, Karras and Laine (2013), computed exactly, and
//! its generalisations to an arbitrary distribution of ray end points and to per-node weights.
//!
//! ```text
//! EPO = (1 / A(S)) Σ_n C_n Σ_{t ∈ S \ Q(n)} A(t ∩ box(n))
//! ```
//!
//! `S` is the scene's triangles, `A(S)` their total area, `Q(n)` the triangles referenced
//! anywhere in the subtree of `n` (with spatial splits a triangle referenced by any leaf under
//! `n` belongs to `Q(n)`), `C_n = c_t` for inner nodes and `c_i |n|` for leaves, and
//! `A(t ∩ box(n))` the area of the triangle clipped to the node's box.
//!
//! # Algorithm
//!
//! Triangle-centric, in parallel over triangles: each triangle `t` walks the tree itself from
//! the root, entering only nodes whose box overlaps `t`'s bounding box (children lie inside
//! their parent, so a node whose box misses `t` hides no contribution below it). At a visited
//! node `n`:
//!
//! * if `t ∈ Q(n)` nothing is added, but the walk descends (`t` may be foreign to a child);
//! * otherwise `C_n · A(t ∩ box(n))` is added. `t` is then foreign to every descendant too,
//!   so membership is not checked again below `n`, and when the clipped polygon is empty the
//!   whole subtree is skipped (the boxes below are inside `box(n)`).
//!
//! Membership `t ∈ Q(n)` is a range check: nodes are numbered in depth-first pre-order
//! (for the layout of [`Bvh`] this is the array index), so the subtree of `n` is the interval
//! `[pre(n), end(n))`; the leaves referencing each triangle are listed once (usually one leaf,
//! several with spatial splits), and `t ∈ Q(n)` iff one of them falls in that interval.
//!
//! Sums are deterministic: triangles are processed in fixed chunks of [`CHUNK`] whose partial
//! sums are added in chunk order, whatever the number of threads.

use crate::CostModel;
use rayon::prelude::*;
use sahara_bvh::Bvh;
use sahara_geom::{clip::clip_triangle, rng::Pcg32, Aabb, Triangle, Vec3A};

/// Number of triangles (or end points) per deterministic partial sum.
pub const CHUNK: usize = 2048;

/// The EPO of a tree split into the contributions of inner nodes and of leaves.
///
/// Both parts are already multiplied by their cost constants and divided by `A(S)`:
/// `inner = c_t Σ_inner A_foreign(n) / A(S)`, `leaf = c_i Σ_leaf |n| A_foreign(n) / A(S)`.
#[derive(Clone, Copy, Debug, Default, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct EpoBreakdown {
    /// Contribution of inner nodes (`C_n = c_t`).
    pub inner: f64,
    /// Contribution of leaves (`C_n = c_i |n|`).
    pub leaf: f64,
}

impl EpoBreakdown {
    /// `inner + leaf`: the EPO of the tree.
    pub fn total(&self) -> f64 {
        self.inner + self.leaf
    }
}

/// A point on a scene surface where a ray starts or ends, with the triangle it lies on.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Endpoint {
    /// The point.
    pub point: Vec3A,
    /// Index of the triangle the point lies on.
    pub triangle: u32,
}

/// The exact EPO of `bvh` over `tris` (see the [module documentation](mod@crate::epo)).
///
/// `tris` must be the triangles the tree was built over (every reference of the tree indexes
/// into it; a triangle no leaf references is foreign to every node). `A(S)` is the area of all
/// of `tris`. Returns 0 for an empty tree or a scene of zero area. The tree must be
/// structurally valid ([`Bvh::validate_structure`]) with children inside their parents.
///
/// # Panics
/// When a leaf references a triangle index `>= tris.len()`.
pub fn epo(bvh: &Bvh, tris: &[Triangle], cost: &CostModel) -> f64 {
    epo_breakdown(bvh, tris, cost).total()
}

/// The exact EPO split into inner-node and leaf contributions (same algorithm as [`epo`]).
///
/// # Panics
/// When a leaf references a triangle index `>= tris.len()`.
pub fn epo_breakdown(bvh: &Bvh, tris: &[Triangle], cost: &CostModel) -> EpoBreakdown {
    epo_impl(bvh, tris, cost, None)
}

/// EPO with each node's term scaled by a per-node weight relative to the root's:
/// `(1 / A(S)) Σ_n C_n (w_n / w_root) Σ_{t ∉ Q(n)} A(t ∩ box(n))`.
///
/// With all weights equal this is [`epo_breakdown`]; with `w_n` the probability that a ray
/// of some type reaches `box(n)` (for example `sahara_trace::weighted::box_weight`
/// evaluated by [`crate::weighted::node_weights`]) it discounts foreign surface in nodes that
/// ray type rarely enters. Returns zeros when `w_root <= 0`.
///
/// # Panics
/// When `node_weights.len() != bvh.nodes.len()` or a leaf references a triangle index
/// `>= tris.len()`.
pub fn epo_with_node_weights(
    bvh: &Bvh,
    tris: &[Triangle],
    cost: &CostModel,
    node_weights: &[f64],
) -> EpoBreakdown {
    assert_eq!(node_weights.len(), bvh.nodes.len(), "one weight per node");
    if bvh.nodes.is_empty() || node_weights[0].is_nan() || node_weights[0] <= 0.0 {
        return EpoBreakdown::default();
    }
    let e = epo_impl(bvh, tris, cost, Some(node_weights));
    EpoBreakdown {
        inner: e.inner / node_weights[0],
        leaf: e.leaf / node_weights[0],
    }
}

fn epo_impl(
    bvh: &Bvh,
    tris: &[Triangle],
    cost: &CostModel,
    weights: Option<&[f64]>,
) -> EpoBreakdown {
    if bvh.nodes.is_empty() || tris.is_empty() {
        return EpoBreakdown::default();
    }
    let total_area = total_area(tris);
    if total_area <= 0.0 {
        return EpoBreakdown::default();
    }
    let m = Membership::new(bvh, tris.len());
    let partials: Vec<(f64, f64)> = tris
        .par_chunks(CHUNK)
        .enumerate()
        .map(|(c, chunk)| {
            let mut stack = Vec::with_capacity(64);
            let (mut inner, mut leaf) = (0.0f64, 0.0f64);
            for (k, tri) in chunk.iter().enumerate() {
                let (i, l) = m.foreign_areas_of_triangle(
                    bvh,
                    (c * CHUNK + k) as u32,
                    tri,
                    weights,
                    &mut stack,
                );
                inner += i;
                leaf += l;
            }
            (inner, leaf)
        })
        .collect();
    let (mut inner, mut leaf) = (0.0f64, 0.0f64);
    for (i, l) in partials {
        inner += i;
        leaf += l;
    }
    EpoBreakdown {
        inner: cost.traversal as f64 * inner / total_area,
        leaf: cost.intersection as f64 * leaf / total_area,
    }
}

/// End-point overlap for an arbitrary distribution of ray end points: the mean over
/// `endpoints` of `Σ_n C_n [p ∈ box(n)] [t ∉ Q(n)]`, where `p` is the point and `t` its
/// triangle.
///
/// With end points distributed uniformly by area over the scene's surface this is an unbiased
/// estimate of [`epo`]; with the hit points of a ray type (for example the visible points of a
/// camera) it weights each node's foreign surface by how often that ray type really ends
/// there. `tris` is only used for its length (the triangle indices of the tree and of the end
/// points index into it). Returns 0 for an empty tree or no end points.
///
/// # Panics
/// When a leaf or an end point references a triangle index `>= tris.len()`.
pub fn endpoint_overlap(
    bvh: &Bvh,
    tris: &[Triangle],
    cost: &CostModel,
    endpoints: &[Endpoint],
) -> f64 {
    if bvh.nodes.is_empty() || endpoints.is_empty() {
        return 0.0;
    }
    let m = Membership::new(bvh, tris.len());
    let (ct, ci) = (cost.traversal as f64, cost.intersection as f64);
    let partials: Vec<f64> = endpoints
        .par_chunks(CHUNK)
        .map(|chunk| {
            let mut stack: Vec<(u32, bool)> = Vec::with_capacity(64);
            let mut sum = 0.0f64;
            for e in chunk {
                assert!(
                    (e.triangle as usize) < tris.len(),
                    "end point on triangle {} of {}",
                    e.triangle,
                    tris.len()
                );
                stack.clear();
                stack.push((0, true));
                while let Some((n, check)) = stack.pop() {
                    let node = &bvh.nodes[n as usize];
                    if !node.bounds().contains_point(e.point) {
                        continue;
                    }
                    let foreign = !check || !m.contains(n as usize, e.triangle);
                    if node.is_leaf() {
                        if foreign {
                            sum += ci * node.count as f64;
                        }
                    } else {
                        if foreign {
                            sum += ct;
                        }
                        let (l, r) = bvh.children(n as usize);
                        stack.push((r as u32, !foreign));
                        stack.push((l as u32, !foreign));
                    }
                }
            }
            sum
        })
        .collect();
    partials.iter().sum::<f64>() / endpoints.len() as f64
}

/// `count` points distributed uniformly by area over the surface of `tris` (deterministic for
/// a given `seed`). Feeding them to [`endpoint_overlap`] gives a Monte Carlo estimate of
/// [`epo`]. Empty when the scene has no area.
pub fn sample_surface_endpoints(tris: &[Triangle], count: usize, seed: u64) -> Vec<Endpoint> {
    let mut cdf = Vec::with_capacity(tris.len());
    let mut acc = 0.0f64;
    for t in tris {
        acc += t.area();
        cdf.push(acc);
    }
    if acc <= 0.0 {
        return Vec::new();
    }
    let mut rng = Pcg32::new(seed, 0x45_50_4f);
    (0..count)
        .map(|_| {
            // 48 random bits for the triangle choice, so that a million triangles are resolved.
            let r = ((rng.next_u32() as u64) << 16 | (rng.next_u32() >> 16) as u64) as f64
                / (1u64 << 48) as f64;
            let x = r * acc;
            let i = cdf.partition_point(|&c| c <= x).min(tris.len() - 1);
            let (mut u, mut v) = (rng.next_f32(), rng.next_f32());
            if u + v > 1.0 {
                (u, v) = (1.0 - u, 1.0 - v);
            }
            Endpoint {
                point: tris[i].point(u, v),
                triangle: i as u32,
            }
        })
        .collect()
}

/// Total area `A(S)` of the triangles, summed deterministically in `f64`.
pub fn total_area(tris: &[Triangle]) -> f64 {
    let partials: Vec<f64> = tris
        .par_chunks(CHUNK)
        .map(|c| c.iter().map(Triangle::area).sum::<f64>())
        .collect();
    partials.iter().sum()
}

/// Subtree intervals in pre-order and the leaves referencing each triangle.
pub(crate) struct Membership {
    /// Pre-order number of each node.
    pre: Vec<u32>,
    /// One past the pre-order number of the last node of each node's subtree.
    end: Vec<u32>,
    /// `refs[offsets[t]..offsets[t + 1]]`: pre-order numbers of the leaves referencing `t`.
    offsets: Vec<u32>,
    refs: Vec<u32>,
}

impl Membership {
    /// Builds the tables for a non-empty, structurally valid tree over `n_tris` triangles.
    pub(crate) fn new(bvh: &Bvh, n_tris: usize) -> Self {
        let n = bvh.nodes.len();
        let mut pre = vec![0u32; n];
        let mut order = Vec::with_capacity(n);
        let mut stack = vec![0usize];
        while let Some(i) = stack.pop() {
            pre[i] = order.len() as u32;
            order.push(i);
            if !bvh.nodes[i].is_leaf() {
                let (l, r) = bvh.children(i);
                stack.push(r);
                stack.push(l);
            }
        }
        let mut size = vec![1u32; n];
        for &i in order.iter().rev() {
            if !bvh.nodes[i].is_leaf() {
                let (l, r) = bvh.children(i);
                size[i] = 1 + size[l] + size[r];
            }
        }
        let end: Vec<u32> = (0..n).map(|i| pre[i] + size[i]).collect();

        let mut offsets = vec![0u32; n_tris + 1];
        for &i in &order {
            let node = &bvh.nodes[i];
            if node.is_leaf() {
                for &p in bvh.leaf_prims(node) {
                    assert!(
                        (p as usize) < n_tris,
                        "leaf {i} references triangle {p} of {n_tris}"
                    );
                    offsets[p as usize + 1] += 1;
                }
            }
        }
        for t in 0..n_tris {
            offsets[t + 1] += offsets[t];
        }
        let mut fill = offsets.clone();
        let mut refs = vec![0u32; offsets[n_tris] as usize];
        for &i in &order {
            let node = &bvh.nodes[i];
            if node.is_leaf() {
                for &p in bvh.leaf_prims(node) {
                    refs[fill[p as usize] as usize] = pre[i];
                    fill[p as usize] += 1;
                }
            }
        }
        Self {
            pre,
            end,
            offsets,
            refs,
        }
    }

    /// True when triangle `t` is referenced in the subtree of node `n`.
    #[inline]
    pub(crate) fn contains(&self, n: usize, t: u32) -> bool {
        let (lo, hi) = (self.pre[n], self.end[n]);
        let refs =
            &self.refs[self.offsets[t as usize] as usize..self.offsets[t as usize + 1] as usize];
        refs.iter().any(|&l| lo <= l && l < hi)
    }

    /// `(Σ_inner A(t ∩ box(n)), Σ_leaf |n| A(t ∩ box(n)))` over the nodes `n` to which `t` is
    /// foreign.
    fn foreign_areas_of_triangle(
        &self,
        bvh: &Bvh,
        t: u32,
        tri: &Triangle,
        weights: Option<&[f64]>,
        stack: &mut Vec<(u32, bool)>,
    ) -> (f64, f64) {
        let tb = tri.bounds();
        let (mut inner, mut leaf) = (0.0f64, 0.0f64);
        stack.clear();
        stack.push((0, true));
        while let Some((n, check)) = stack.pop() {
            let node = &bvh.nodes[n as usize];
            let b: Aabb = node.bounds();
            if !b.overlaps(&tb) {
                continue;
            }
            let foreign = !check || !self.contains(n as usize, t);
            if foreign {
                let poly = clip_triangle(tri, &b);
                if poly.is_empty() {
                    continue;
                }
                let mut a = poly.area();
                if let Some(w) = weights {
                    a *= w[n as usize];
                }
                if node.is_leaf() {
                    leaf += node.count as f64 * a;
                } else {
                    inner += a;
                }
            }
            if !node.is_leaf() {
                let (l, r) = bvh.children(n as usize);
                stack.push((r as u32, !foreign));
                stack.push((l as u32, !foreign));
            }
        }
        (inner, leaf)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use sahara_bvh::Node;

    #[test]
    fn two_overlapping_leaves() {
        // Two unit right triangles in the z = 0 plane; leaf boxes overlap in [0.5, 1] x [0, 1].
        let a = Triangle::new(Vec3A::ZERO, Vec3A::X, Vec3A::Y);
        let b = Triangle::new(
            Vec3A::new(0.5, 0.0, 0.0),
            Vec3A::new(1.5, 0.0, 0.0),
            Vec3A::new(0.5, 1.0, 0.0),
        );
        let (ba, bb) = (a.bounds(), b.bounds());
        let bvh = Bvh {
            nodes: vec![
                Node::inner(&ba.union(&bb), 2),
                Node::leaf(&ba, 0, 1),
                Node::leaf(&bb, 1, 1),
            ],
            prim_indices: vec![0, 1],
            spatial_splits: false,
            ref_cuts: None,
        };
        let tris = [a, b];
        // b ∩ box(a) = {0.5 <= x <= 1, y <= 1.5 - x}: 0.375; a ∩ box(b) = {0.5 <= x, y <= 1 - x}:
        // 0.125. Total area 1.
        let e = epo_breakdown(&bvh, &tris, &CostModel::UNIT);
        assert!((e.leaf - 0.5).abs() < 1e-7, "{e:?}");
        assert_eq!(e.inner, 0.0);
        let m = Membership::new(&bvh, 2);
        assert!(m.contains(0, 0) && m.contains(0, 1) && m.contains(1, 0) && !m.contains(1, 1));
    }
}
