//! Brute-force references shared by the metric tests (their scenes and their simple test
//! builder, `split_tree`, are `sahara_fixtures`').
#![allow(dead_code)]

use sahara_bvh::Bvh;
pub use sahara_fixtures::trees::{split_tree as build, Split};
use sahara_geom::{clip::clipped_area, Triangle};
use sahara_metrics::CostModel;
use std::collections::BTreeSet;

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
