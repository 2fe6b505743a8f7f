//! Binned splits of plain boxes (no ids): the cheapest plane by Eq. 2 over `k` equal-width
//! centroid bins per axis ([`best_box_plane`]) and the in-place partition of the boxes by it
//! ([`partition_boxes`]). The cost-only binned temporaries of the paper's builder work on
//! private copies of a node's boxes with these, reading memory sequentially.

use sahara_geom::{Aabb, Vec3A};
use sahara_metrics::CostModel;

use super::{fill, sides, sweep_planes, Bin};
use crate::split::{imbalance, ranks_before, BinMap, Suffix};

/// Reusable buffers of [`best_box_plane`].
#[derive(Debug, Default)]
pub struct BoxScratch {
    bins: Vec<Bin>,
    right: Vec<(f32, u32)>,
}

/// A plane of [`best_box_plane`].
#[derive(Clone, Copy, Debug)]
pub struct BoxPlane {
    /// Its Eq. 2 cost.
    pub cost: f64,
    /// How unbalanced its sides are ([`imbalance`]).
    pub imbalance: usize,
    /// The axis.
    pub axis: usize,
    /// Boxes in bins `< plane` go left.
    pub plane: usize,
    /// Bounds of the left side.
    pub left: Aabb,
}

impl BoxPlane {
    /// Lower cost, then more balanced, then lower axis, then lower plane.
    #[inline]
    fn better_than(&self, o: &BoxPlane) -> bool {
        ranks_before(
            self.cost,
            || (self.imbalance, self.axis, self.plane),
            o.cost,
            || (o.imbalance, o.axis, o.plane),
        )
    }
}

/// Bins the boxes `seg` (of a node of half area `area`) on every axis with a map, `k` bins per
/// axis, and returns the plane of least Eq. 2 cost (ties: see [`ranks_before`]) and the bounds
/// of that plane's right side (`None` when no plane separates anything). The bins keep no
/// centroid bounds: [`partition_boxes`] computes the sides'.
pub fn best_box_plane(
    seg: &[Aabb],
    maps: &[Option<BinMap>; 3],
    k: usize,
    area: f64,
    cost: &CostModel,
    s: &mut BoxScratch,
) -> Option<(BoxPlane, Aabb)> {
    s.bins.resize(3 * k, Bin::EMPTY);
    s.right.resize(k, (0.0, 0));
    fill::<false>(&mut s.bins, k, maps, seg.iter().map(|b| (b, b.centroid())));
    let mut best: Option<BoxPlane> = None;
    for (a, map) in maps.iter().enumerate() {
        if map.is_none() {
            continue;
        }
        let bins = &s.bins[a * k..(a + 1) * k];
        sweep_planes(bins, &mut s.right, |j, left, nl, right: &f32, nr| {
            let c = cost.split_cost(area, left.half_area() as f64, nl, right.area(), nr);
            let cand = BoxPlane {
                cost: c,
                imbalance: imbalance(nl, nr),
                axis: a,
                plane: j,
                left: *left,
            };
            if best.as_ref().is_none_or(|b| cand.better_than(b)) {
                best = Some(cand);
            }
        });
    }
    // The right box of the winner (only its area was kept during the sweep).
    best.map(|b| {
        let bins = &s.bins[b.axis * k..(b.axis + 1) * k];
        (b, sides(bins, b.plane).1.bounds)
    })
}

/// Bounds and centroid bounds of some boxes.
pub fn box_bounds(prims: &[Aabb]) -> (Aabb, Aabb) {
    let mut b = Aabb::EMPTY;
    let mut c = Aabb::EMPTY;
    for p in prims {
        b.grow_aabb(p);
        c.grow(p.centroid());
    }
    (b, c)
}

/// In-place partition of boxes by a predicate on their centroids (a two-pointer scheme);
/// returns the number of boxes on the left and the centroid bounds of both sides.
pub fn partition_boxes(seg: &mut [Aabb], left: impl Fn(Vec3A) -> bool) -> (usize, Aabb, Aabb) {
    let mut lc = Aabb::EMPTY;
    let mut rc = Aabb::EMPTY;
    let mut i = 0;
    let mut j = seg.len();
    while i < j {
        let c = seg[i].centroid();
        if left(c) {
            lc.grow(c);
            i += 1;
        } else {
            rc.grow(c);
            j -= 1;
            seg.swap(i, j);
        }
    }
    (i, lc, rc)
}
