//! Simple builders and brute-force references shared by the metric tests (their scenes are
//! `sahara_fixtures`' generators).
#![allow(dead_code)]

use sahara_bvh::{Bvh, Node};
use sahara_geom::{clip::clipped_area, rng::Pcg32, Aabb, Triangle};
use sahara_metrics::CostModel;
use std::collections::BTreeSet;

/// How the test builder partitions a node.
#[derive(Clone, Copy, Debug)]
pub enum Split {
    /// Sort by centroid along the largest axis of the centroid bounds, split at the median.
    Median,
    /// Shuffle, split in the middle: spatially incoherent, lots of overlap.
    Random(u64),
}

/// A top-down builder producing the depth-first layout of [`Bvh`], leaves of at most
/// `max_leaf` triangles.
pub fn build(tris: &[Triangle], max_leaf: usize, split: Split) -> Bvh {
    let mut bvh = Bvh::empty();
    if tris.is_empty() {
        return bvh;
    }
    let mut idx: Vec<u32> = (0..tris.len() as u32).collect();
    let mut rng = Pcg32::new(
        match split {
            Split::Random(s) => s,
            _ => 0,
        },
        7,
    );
    rec(tris, &mut idx, max_leaf.max(1), split, &mut rng, &mut bvh);
    bvh
}

fn rec(
    tris: &[Triangle],
    idx: &mut [u32],
    max_leaf: usize,
    split: Split,
    rng: &mut Pcg32,
    bvh: &mut Bvh,
) -> usize {
    let bounds = idx
        .iter()
        .fold(Aabb::EMPTY, |b, &i| b.union(&tris[i as usize].bounds()));
    let me = bvh.nodes.len();
    bvh.nodes.push(Node::default());
    if idx.len() <= max_leaf {
        let first = bvh.prim_indices.len() as u32;
        bvh.prim_indices.extend_from_slice(idx);
        bvh.nodes[me] = Node::leaf(&bounds, first, idx.len() as u32);
        return me;
    }
    match split {
        Split::Median => {
            let cb = Aabb::from_points(idx.iter().map(|&i| tris[i as usize].centroid()));
            let axis = cb.largest_axis();
            idx.sort_by(|&a, &b| {
                tris[a as usize].centroid()[axis].total_cmp(&tris[b as usize].centroid()[axis])
            });
        }
        Split::Random(_) => {
            for i in (1..idx.len()).rev() {
                let j = rng.below(i as u32 + 1) as usize;
                idx.swap(i, j);
            }
        }
    }
    let mid = idx.len() / 2;
    let (l, r) = idx.split_at_mut(mid);
    rec(tris, l, max_leaf, split, rng, bvh);
    let right = rec(tris, r, max_leaf, split, rng, bvh);
    bvh.nodes[me] = Node::inner(&bounds, right as u32);
    me
}

/// The brute-force EPO: for every node, the explicit set `Q(n)` of triangles referenced in
/// its subtree, and the clipped area of every other triangle. O(nodes × triangles).
/// `weights` (one per node, relative to the root) default to 1.
pub fn brute_epo(
    bvh: &Bvh,
    tris: &[Triangle],
    cost: &CostModel,
    weights: Option<&[f64]>,
) -> (f64, f64) {
    if bvh.nodes.is_empty() {
        return (0.0, 0.0);
    }
    let total: f64 = tris.iter().map(|t| t.area()).sum();
    let (mut inner, mut leaf) = (0.0, 0.0);
    for (i, node) in bvh.nodes.iter().enumerate() {
        let q = subtree_set(bvh, i);
        let b = node.bounds();
        let w = weights.map_or(1.0, |w| w[i] / w[0]);
        let foreign: f64 = (0..tris.len() as u32)
            .filter(|t| !q.contains(t))
            .map(|t| clipped_area(&tris[t as usize], &b))
            .sum();
        if node.is_leaf() {
            leaf += w * cost.intersection as f64 * node.count as f64 * foreign;
        } else {
            inner += w * cost.traversal as f64 * foreign;
        }
    }
    (inner / total, leaf / total)
}

/// Every triangle referenced in the subtree of node `i` (explicit recursion).
pub fn subtree_set(bvh: &Bvh, i: usize) -> BTreeSet<u32> {
    let node = &bvh.nodes[i];
    if node.is_leaf() {
        return bvh.leaf_prims(node).iter().copied().collect();
    }
    let (l, r) = bvh.children(i);
    let mut s = subtree_set(bvh, l);
    s.extend(subtree_set(bvh, r));
    s
}

/// `|a - b| <= tol · max(|a|, |b|)` (or both below `tol` in absolute value).
pub fn close(a: f64, b: f64, tol: f64) -> bool {
    (a - b).abs() <= tol * a.abs().max(b.abs()).max(1e-300) || (a.abs() < tol && b.abs() < tol)
}
