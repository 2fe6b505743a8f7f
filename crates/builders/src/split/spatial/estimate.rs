//! The estimated spatial split of the spatial temporary-subtree builder's temporaries:
//! references binned by their boxes only (no cutting), then the best planes re-rated with the
//! straddling primitives cut at the plane ([`estimated_spatial_search`]).

use rayon::prelude::*;
use sahara_geom::{Aabb, Axis, Vec3A};
use sahara_metrics::CostModel;

use super::clip::Clipper;
use super::{sweep_spatial_planes, SpatialCand};
use crate::split::object::Ref;
use crate::split::{half_area, offer, ranks_before, BinMap, PAR_AXES_THRESHOLD};

/// A spatial split rated with the references' boxes (no cutting).
#[derive(Clone, Copy)]
struct Rough {
    score: f64,
    axis: Axis,
    plane: usize,
    map: BinMap,
    n_left: usize,
    n_right: usize,
}

impl Rough {
    /// The candidate order: score, then axis, then plane.
    fn better(&self, other: &Rough) -> bool {
        ranks_before(
            self.score,
            || (0, self.axis, self.plane),
            other.score,
            || (0, other.axis, other.plane),
        )
    }
}

#[derive(Clone, Copy)]
struct BoxBin {
    /// Union of the boxes of the references whose first bin is this one.
    by_first: Aabb,
    /// Union of the boxes of the references whose last bin is this one.
    by_last: Aabb,
    /// References whose first bin is this one.
    enter: u32,
    /// References whose last bin is this one.
    exit: u32,
}

/// Reusable buffers of [`estimated_spatial_search`].
#[derive(Default)]
pub struct EstimateScratch {
    bins: Vec<BoxBin>,
    right: Vec<(Aabb, u32)>,
}

/// The estimated best spatial split of a node with `bins` bins per axis whose duplication
/// fits `budget`: the references are counted as [`super::spatial_search`] counts them, each side of
/// a plane is bounded by the boxes of the references reaching it, cut at the plane; the
/// `refine` best planes over the three axes are then re-rated with the straddling primitives
/// cut by [`Clipper::estimate`], and the best of those is returned.
#[allow(clippy::too_many_arguments)]
pub fn estimated_spatial_search(
    clipper: &Clipper,
    refs: &[Ref],
    bounds: &Aabb,
    area: f64,
    budget: usize,
    bins: usize,
    refine: usize,
    cost: &CostModel,
    scratch: &mut EstimateScratch,
) -> Option<SpatialCand> {
    let per_axis: Vec<Vec<Rough>> = if refs.len() >= PAR_AXES_THRESHOLD {
        (0..3)
            .into_par_iter()
            .map(|axis| {
                let sc = &mut EstimateScratch::default();
                rough_axis(refs, bounds, axis, budget, bins, refine, sc)
            })
            .collect()
    } else {
        (0..3)
            .map(|axis| rough_axis(refs, bounds, axis, budget, bins, refine, scratch))
            .collect()
    };
    let mut rough: Vec<Rough> = Vec::with_capacity(refine);
    for r in per_axis.into_iter().flatten() {
        offer(&mut rough, refine, r, Rough::better);
    }
    let mut best: Option<SpatialCand> = None;
    for r in &rough {
        let cand = refine_plane(clipper, refs, r, area, cost);
        if best.as_ref().is_none_or(|b| cand.better(b)) {
            best = Some(cand);
        }
    }
    best
}

/// The `keep` best planes of one axis by the box estimate.
fn rough_axis(
    refs: &[Ref],
    bounds: &Aabb,
    axis: Axis,
    budget: usize,
    nb: usize,
    keep: usize,
    sc: &mut EstimateScratch,
) -> Vec<Rough> {
    let Some(map) = BinMap::new(bounds.min[axis], bounds.max[axis], nb) else {
        return Vec::new();
    };
    let empty = BoxBin {
        by_first: Aabb::EMPTY,
        by_last: Aabb::EMPTY,
        enter: 0,
        exit: 0,
    };
    let bins = &mut sc.bins;
    bins.clear();
    bins.resize(nb, empty);
    for r in refs {
        let first = map.bin(r.bounds.min[axis]);
        let last = map.bin(r.bounds.max[axis]);
        bins[first].enter += 1;
        bins[first].by_first.grow_aabb(&r.bounds);
        bins[last].exit += 1;
        bins[last].by_last.grow_aabb(&r.bounds);
    }
    // Lane masks instead of writes to one lane (those go through memory and stall).
    let mask = Vec3A::new(0.0, 1.0, 2.0).cmpeq(Vec3A::splat(axis as f32));
    let right = &mut sc.right;
    right.clear();
    right.resize(nb, (Aabb::EMPTY, 0));
    let mut rough: Vec<Rough> = Vec::with_capacity(keep);
    let side = |i: usize| {
        let b = &bins[i];
        (&b.by_first, &b.by_last, b.enter, b.exit)
    };
    sweep_spatial_planes(
        nb,
        side,
        right,
        refs.len(),
        budget,
        |i, lb, nl, rb: &Aabb, nr| {
            let pos = Vec3A::splat(map.plane(i));
            let l = Aabb::new(lb.min, Vec3A::select(mask, lb.max.min(pos), lb.max));
            let r = Aabb::new(Vec3A::select(mask, rb.min.max(pos), rb.min), rb.max);
            let score = half_area(&l) * nl as f64 + half_area(&r) * nr as f64;
            if rough.len() == keep && score >= rough[keep - 1].score {
                return;
            }
            let cand = Rough {
                score,
                axis,
                plane: i,
                map,
                n_left: nl,
                n_right: nr,
            };
            offer(&mut rough, keep, cand, Rough::better);
        },
    );
    rough
}

/// Rates a plane found by the box estimate with the straddling primitives cut at it.
fn refine_plane(
    clipper: &Clipper,
    refs: &[Ref],
    r: &Rough,
    area: f64,
    cost: &CostModel,
) -> SpatialCand {
    let (axis, plane, map) = (r.axis, r.plane, r.map);
    let pos = map.plane(plane);
    let mut lb = Aabb::EMPTY;
    let mut rb = Aabb::EMPTY;
    for rf in refs {
        if map.bin(rf.bounds.max[axis]) < plane {
            lb.grow_aabb(&rf.bounds);
        } else if map.bin(rf.bounds.min[axis]) >= plane {
            rb.grow_aabb(&rf.bounds);
        } else {
            let (pl, pr) = clipper.estimate(rf.prim, axis, pos, &rf.bounds);
            lb.grow_aabb(&pl);
            rb.grow_aabb(&pr);
        }
    }
    let (la, ra) = (half_area(&lb), half_area(&rb));
    let (nl, nr) = (r.n_left, r.n_right);
    SpatialCand {
        axis,
        plane,
        map,
        pos,
        score: la * nl as f64 + ra * nr as f64,
        cost: cost.split_cost(area, la, nl, ra, nr),
        n_left: nl,
        n_right: nr,
    }
}
