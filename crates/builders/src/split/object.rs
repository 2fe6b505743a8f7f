//! Object splits of a list of references (the unit of spatial-split builders: a primitive and
//! the box of the part of it the reference stands for): the full sweep over the references
//! sorted per axis, or equal-width bins over their centroids, each keeping the `k` best
//! candidates by area-count score; the application of a candidate; the median split.
//!
//! Used by SBVH ([`crate::sbvh`]), the spatial temporary-subtree builder and its temporaries
//! ([`crate::tsah_spatial`]).

use rayon::prelude::*;
use sahara_geom::{Aabb, Axis};
use sahara_metrics::CostModel;

use super::binned::{self, Bin};
use super::sweep::{prefix_pass, suffix_pass};
use super::{
    half_area, imbalance, offer, ranks_before, sort_by_key, BinMap, PAR_AXES_THRESHOLD, PAR_CHUNK,
    PAR_NODE_THRESHOLD,
};

/// A primitive reference: the primitive and the box of the part of it this reference covers.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Ref {
    /// The part's bounds.
    pub bounds: Aabb,
    /// The primitive's index.
    pub prim: u32,
    /// The last cut applied to the reference, an entry of the build's
    /// [`CutLog`](crate::split::spatial::CutLog), or [`NO_CUT`](crate::split::spatial::NO_CUT)
    /// (never cut, or cuts not recorded).
    pub cut: u32,
}

impl Ref {
    /// A reference never cut.
    #[inline]
    pub fn new(bounds: Aabb, prim: u32) -> Self {
        Ref {
            bounds,
            prim,
            cut: crate::split::spatial::NO_CUT,
        }
    }

    /// The centroid of the reference's box on `axis`.
    #[inline]
    pub fn centroid(&self, axis: Axis) -> f32 {
        (self.bounds.min[axis] + self.bounds.max[axis]) * 0.5
    }
}

/// Union of the reference boxes (in parallel chunks for large lists; exact).
pub fn refs_bounds(refs: &[Ref]) -> Aabb {
    let fold = |refs: &[Ref]| refs.iter().fold(Aabb::EMPTY, |b, r| b.union(&r.bounds));
    if refs.len() >= PAR_NODE_THRESHOLD {
        refs.par_chunks(PAR_CHUNK)
            .map(fold)
            .reduce(|| Aabb::EMPTY, |a, b| a.union(&b))
    } else {
        fold(refs)
    }
}

/// How an object split candidate partitions the references.
#[derive(Clone, Copy, Debug)]
pub enum ObjectPartition {
    /// The first `count` references of the order sorted along `axis` go left.
    Sorted {
        /// The sorted axis.
        axis: Axis,
        /// References going left.
        count: usize,
    },
    /// References whose centroid falls in a bin below `plane` go left.
    Binned {
        /// The binned axis.
        axis: Axis,
        /// The first bin of the right side.
        plane: usize,
        /// The bins.
        map: BinMap,
    },
}

/// A rated object split.
#[derive(Clone, Copy, Debug)]
pub struct ObjectCand {
    /// How it partitions.
    pub part: ObjectPartition,
    /// `A_l n_l + A_r n_r`: orders the candidates of one node as Eq. 2 does.
    pub score: f64,
    /// Eq. 2.
    pub cost: f64,
    /// Bounds of the left side.
    pub left: Aabb,
    /// Bounds of the right side.
    pub right: Aabb,
    /// References going left.
    pub n_left: usize,
    /// References going right.
    pub n_right: usize,
}

impl ObjectCand {
    /// The axis it splits.
    pub fn axis(&self) -> Axis {
        self.key().0
    }

    fn key(&self) -> (usize, usize) {
        match self.part {
            ObjectPartition::Sorted { axis, count } => (axis, count),
            ObjectPartition::Binned { axis, plane, .. } => (axis, plane),
        }
    }

    /// The candidate order: score (as Eq. 2), then balance, then axis, then position.
    #[inline]
    pub fn better(&self, other: &ObjectCand) -> bool {
        let (a, p) = self.key();
        let (b, q) = other.key();
        ranks_before(
            self.score,
            || (imbalance(self.n_left, self.n_right), a, p),
            other.score,
            || (imbalance(other.n_left, other.n_right), b, q),
        )
    }

    /// Surface area of the overlap of the two sides (zero when they are disjoint).
    pub fn overlap(&self) -> f64 {
        let i = self.left.intersection(&self.right);
        if i.is_empty() {
            0.0
        } else {
            half_area(&i)
        }
    }
}

/// The result of an object split search: the best candidates (best first) and, for the
/// sweep, the sorted orders they refer to (positions in the reference list; only the orders
/// of axes that hold a candidate are kept).
pub struct ObjectSearch {
    /// The orders of the sweep (empty for axes without a candidate).
    pub orders: [Vec<u32>; 3],
    /// The best candidates, best first.
    pub cands: Vec<ObjectCand>,
}

/// Reusable buffers of the object searches.
#[derive(Default)]
pub struct ObjectScratch {
    keys: Vec<u64>,
    suffix: Vec<Aabb>,
    bins: Vec<Bin>,
    right: Vec<(Aabb, u32)>,
}

/// The `k` best object splits of a node of at least two references by the full sweep (never
/// empty). Large nodes sweep their three axes in parallel.
pub fn sweep_objects(
    refs: &[Ref],
    area: f64,
    k: usize,
    cost: &CostModel,
    scratch: &mut ObjectScratch,
) -> ObjectSearch {
    debug_assert!(refs.len() >= 2 && k >= 1);
    let mut cands = Vec::with_capacity(k);
    let mut orders: [Vec<u32>; 3] = Default::default();
    if refs.len() >= PAR_AXES_THRESHOLD {
        let per_axis: Vec<(Vec<u32>, Vec<ObjectCand>)> = (0..3)
            .into_par_iter()
            .map(|axis| {
                let mut list = Vec::with_capacity(k);
                let order = sweep_axis(
                    refs,
                    axis,
                    area,
                    k,
                    cost,
                    &mut ObjectScratch::default(),
                    &mut list,
                );
                (order, list)
            })
            .collect();
        for (axis, (order, list)) in per_axis.into_iter().enumerate() {
            for cand in list {
                offer(&mut cands, k, cand, ObjectCand::better);
            }
            orders[axis] = order;
        }
    } else {
        for (axis, order) in orders.iter_mut().enumerate() {
            *order = sweep_axis(refs, axis, area, k, cost, scratch, &mut cands);
        }
    }
    for (axis, order) in orders.iter_mut().enumerate() {
        if !cands.iter().any(|c| c.axis() == axis) {
            *order = Vec::new();
        }
    }
    ObjectSearch { orders, cands }
}

/// Sweeps one axis, offering its candidates to `cands`; returns the order when the list holds
/// a candidate of this axis afterwards (else an empty order).
fn sweep_axis(
    refs: &[Ref],
    axis: Axis,
    area: f64,
    k: usize,
    cost: &CostModel,
    sc: &mut ObjectScratch,
    cands: &mut Vec<ObjectCand>,
) -> Vec<u32> {
    let n = refs.len();
    // Ties in the centroid go to the earlier reference: the key is unique and total.
    sort_by_key(&mut sc.keys, n, |i| (refs[i].centroid(axis), i as u32));
    let keys = &sc.keys;
    let item = |j: usize| &refs[keys[j] as u32 as usize].bounds;
    sc.suffix.resize(n, Aabb::EMPTY);
    suffix_pass(n, item, &mut sc.suffix);
    prefix_pass(n, item, &sc.suffix, |i, left, right: &Aabb| {
        let (al, ar) = (half_area(left), half_area(right));
        let score = al * i as f64 + ar * (n - i) as f64;
        if cands.len() == k && score > cands[k - 1].score {
            return;
        }
        let cand = ObjectCand {
            part: ObjectPartition::Sorted { axis, count: i },
            score,
            cost: cost.split_cost(area, al, i, ar, n - i),
            left: *left,
            right: *right,
            n_left: i,
            n_right: n - i,
        };
        offer(cands, k, cand, ObjectCand::better);
    });
    if cands.iter().any(|c| c.axis() == axis) {
        keys.iter().map(|&k| k as u32).collect()
    } else {
        Vec::new()
    }
}

/// The `k` best object splits by `bins` equal-width bins over the reference centroids (empty
/// when no plane separates the centroids).
pub fn bin_objects(
    refs: &[Ref],
    area: f64,
    k: usize,
    bins: usize,
    cost: &CostModel,
    scratch: &mut ObjectScratch,
) -> Vec<ObjectCand> {
    let mut cb = Aabb::EMPTY;
    for r in refs {
        cb.grow(r.bounds.centroid());
    }
    let maps = binned::maps(&cb, bins);
    let mut cands: Vec<ObjectCand> = Vec::with_capacity(k);
    if maps.iter().all(Option::is_none) {
        return cands;
    }
    let ObjectScratch { bins: b, right, .. } = scratch;
    b.resize(3 * bins, Bin::EMPTY);
    right.resize(bins, (Aabb::EMPTY, 0));
    binned::fill::<false>(
        b,
        bins,
        &maps,
        refs.iter().map(|r| (&r.bounds, r.bounds.centroid())),
    );
    for (axis, map) in maps.iter().enumerate() {
        let Some(map) = *map else { continue };
        let axis_bins = &b[axis * bins..(axis + 1) * bins];
        binned::sweep_planes(axis_bins, right, |plane, lb, nl, rb: &Aabb, nr| {
            let (al, ar) = (half_area(lb), half_area(rb));
            let score = al * nl as f64 + ar * nr as f64;
            if cands.len() == k && score > cands[k - 1].score {
                return;
            }
            let cand = ObjectCand {
                part: ObjectPartition::Binned { axis, plane, map },
                score,
                cost: cost.split_cost(area, al, nl, ar, nr),
                left: *lb,
                right: *rb,
                n_left: nl,
                n_right: nr,
            };
            offer(&mut cands, k, cand, ObjectCand::better);
        });
    }
    cands
}

/// The two sides of an object split, each in a deterministic order.
pub fn apply_object(
    refs: &[Ref],
    search: &ObjectSearch,
    cand: &ObjectCand,
) -> (Vec<Ref>, Vec<Ref>) {
    match cand.part {
        ObjectPartition::Sorted { axis, count } => {
            let order = &search.orders[axis];
            let left = order[..count].iter().map(|&i| refs[i as usize]).collect();
            let right = order[count..].iter().map(|&i| refs[i as usize]).collect();
            (left, right)
        }
        ObjectPartition::Binned { axis, plane, map } => {
            let mut left = Vec::with_capacity(cand.n_left);
            let mut right = Vec::with_capacity(cand.n_right);
            for r in refs {
                if map.bin(r.centroid(axis)) < plane {
                    left.push(*r);
                } else {
                    right.push(*r);
                }
            }
            (left, right)
        }
    }
}

/// The object median split on the largest axis of the centroid bounds (by centroid, then
/// position).
pub fn median_split(refs: &[Ref]) -> (Vec<Ref>, Vec<Ref>) {
    let mut cb = Aabb::EMPTY;
    for r in refs {
        cb.grow(r.bounds.centroid());
    }
    let axis = cb.largest_axis();
    let mut keys = Vec::new();
    sort_by_key(&mut keys, refs.len(), |i| {
        (refs[i].centroid(axis), i as u32)
    });
    let mid = refs.len() / 2;
    let left = keys[..mid]
        .iter()
        .map(|&k| refs[k as u32 as usize])
        .collect();
    let right = keys[mid..]
        .iter()
        .map(|&k| refs[k as u32 as usize])
        .collect();
    (left, right)
}
