//! Helpers shared by the binned, SBVH and spatial temporary-subtree builders: a growable
//! fragment of the depth-first node layout (so that subtrees built on other threads can be
//! appended deterministically), equal-width bin mappings and sortable float keys.

use sahara_bvh::{Bvh, Node};
use sahara_geom::Aabb;

/// Nodes with at least this many primitives (or references) build their two children with
/// `rayon::join`. Below it, recursion is serial: the join overhead would dominate.
pub(crate) const PAR_SPLIT_THRESHOLD: usize = 2048;

/// Nodes with at least this many primitives also bin, bound and sweep in parallel.
pub(crate) const PAR_NODE_THRESHOLD: usize = 32 * 1024;

/// Chunk size of parallel reductions over primitives. Fixed, so that chunking never depends
/// on the number of threads (the reductions used are exact anyway: integer sums and min/max).
pub(crate) const PAR_CHUNK: usize = 8 * 1024;

/// Half the surface area of a box in `f64` (the SAH only ever uses ratios of areas).
#[inline]
pub(crate) fn half_area(b: &Aabb) -> f64 {
    b.half_area() as f64
}

/// A piece of the depth-first [`Bvh`] layout. Inner nodes' right-child indices and leaves'
/// first-reference indices are relative to the start of the fragment's own arrays; appending
/// a fragment to another shifts them. A subtree built on another thread is therefore built
/// into its own fragment and appended afterwards, which gives the same arrays as a serial
/// build.
#[derive(Clone, Debug, Default)]
pub(crate) struct Fragment {
    pub nodes: Vec<Node>,
    pub prims: Vec<u32>,
}

impl Fragment {
    /// Appends a leaf over `prims`.
    pub fn push_leaf(&mut self, bounds: &Aabb, prims: impl IntoIterator<Item = u32>) {
        let first = self.prims.len();
        self.prims.extend(prims);
        let count = self.prims.len() - first;
        debug_assert!(count > 0);
        self.nodes
            .push(Node::leaf(bounds, first as u32, count as u32));
    }

    /// Appends an inner node whose right child is not known yet; returns its index.
    pub fn push_inner(&mut self, bounds: &Aabb) -> usize {
        self.nodes.push(Node::inner(bounds, 0));
        self.nodes.len() - 1
    }

    /// Makes the next node to be appended the right child of inner node `inner`.
    pub fn set_right_here(&mut self, inner: usize) {
        self.nodes[inner].index = self.nodes.len() as u32;
    }

    /// Appends another fragment, shifting its indices.
    pub fn append(&mut self, other: Fragment) {
        let node_off = self.nodes.len() as u32;
        let prim_off = self.prims.len() as u32;
        self.nodes.extend(other.nodes.into_iter().map(|mut n| {
            if n.is_leaf() {
                n.index += prim_off;
            } else {
                n.index += node_off;
            }
            n
        }));
        self.prims.extend_from_slice(&other.prims);
    }

    /// The finished tree.
    pub fn into_bvh(self, spatial_splits: bool) -> Bvh {
        Bvh {
            nodes: self.nodes,
            prim_indices: self.prims,
            spatial_splits,
        }
    }
}

/// Equal-width bins over `[min, min + extent]` on one axis.
#[derive(Clone, Copy, Debug, PartialEq)]
pub(crate) struct BinMap {
    pub min: f32,
    pub scale: f32,
    pub bins: usize,
}

impl BinMap {
    /// The mapping of `bins` bins over `[min, max]`, or `None` when the interval is empty,
    /// flat or so thin that its bin scale is not a finite number.
    pub fn new(min: f32, max: f32, bins: usize) -> Option<Self> {
        let extent = max - min;
        // NaN-safe: a NaN extent or scale fails these tests.
        let scale = bins as f32 / extent;
        if extent > 0.0 && scale.is_finite() && scale > 0.0 {
            Some(Self { min, scale, bins })
        } else {
            None
        }
    }

    /// The bin of coordinate `x` (clamped to `0..bins`; monotone in `x`).
    #[inline]
    pub fn bin(&self, x: f32) -> usize {
        // `as usize` saturates (negative and NaN give 0).
        (((x - self.min) * self.scale) as usize).min(self.bins - 1)
    }

    /// The position of plane `i` (the boundary between bins `i - 1` and `i`).
    #[inline]
    pub fn plane(&self, i: usize) -> f32 {
        self.min + i as f32 / self.scale
    }
}

/// An unsigned key with the same order as `x` (for finite floats; `-0.0 < +0.0`).
#[inline]
pub(crate) fn float_key(x: f32) -> u32 {
    let b = x.to_bits();
    if b & 0x8000_0000 != 0 {
        !b
    } else {
        b | 0x8000_0000
    }
}

/// The balance measure used to break exact cost ties: smaller is more balanced.
#[inline]
pub(crate) fn imbalance(n_left: usize, n_right: usize) -> u128 {
    let (l, r) = (n_left as u128, n_right as u128);
    l * l + r * r
}

/// Splits what is left of a duplication budget between two children in proportion to their
/// reference counts (deterministic, whatever the order in which subtrees are built).
#[inline]
pub(crate) fn share_budget(budget: usize, n_left: usize, n_right: usize) -> (usize, usize) {
    let total = (n_left + n_right) as u128;
    if total == 0 {
        return (budget / 2, budget - budget / 2);
    }
    let left = (budget as u128 * n_left as u128 / total) as usize;
    (left, budget - left)
}

/// Keeps the `k` best items of a stream, sorted best first, by a strict "better than" order.
pub(crate) fn offer<T>(list: &mut Vec<T>, k: usize, item: T, better: impl Fn(&T, &T) -> bool) {
    if k == 0 {
        return;
    }
    if list.len() == k {
        if !better(&item, &list[k - 1]) {
            return;
        }
        list.pop();
    }
    let pos = list
        .iter()
        .position(|x| better(&item, x))
        .unwrap_or(list.len());
    list.insert(pos, item);
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn float_keys_are_ordered() {
        let xs = [-3.5f32, -1.0, -0.0, 0.0, 1e-30, 2.0, 1e30];
        for w in xs.windows(2) {
            assert!(float_key(w[0]) < float_key(w[1]), "{w:?}");
        }
    }

    #[test]
    fn bins_are_monotone_and_clamped() {
        let m = BinMap::new(-1.0, 3.0, 8).unwrap();
        assert_eq!(m.bin(-1.0), 0);
        assert_eq!(m.bin(3.0), 7);
        assert_eq!(m.bin(-5.0), 0);
        assert_eq!(m.bin(1e9), 7);
        assert_eq!(m.plane(4), 1.0);
        assert!(BinMap::new(1.0, 1.0, 8).is_none());
    }

    #[test]
    fn top_k() {
        let mut v = Vec::new();
        for x in [5, 3, 9, 1, 4, 1] {
            offer(&mut v, 3, x, |a, b| a < b);
        }
        assert_eq!(v, vec![1, 1, 3]);
    }

    #[test]
    fn budget_shares_add_up() {
        assert_eq!(share_budget(10, 1, 4), (2, 8));
        assert_eq!(share_budget(7, 0, 0), (3, 4));
    }
}
