//! Spatial splits (Stich, Friedrich & Dietrich 2009): a plane cuts the references that
//! straddle it, and both sides keep the part on their side.
//!
//! * [`spatial_search`]: per axis, equal-width bins over the node's box; each reference is cut
//!   into the bins it spans ([`Clipper::bin`]) and counted as entering its first bin and
//!   leaving its last; a sweep over the bins rates every plane with the duplicated
//!   references;
//! * [`estimated_spatial_search`]: the cheap estimate the spatial temporary-subtree builder's
//!   temporaries use: references binned by their boxes only (no cutting), then the best planes
//!   re-rated with the straddling primitives cut at the plane;
//! * [`apply_spatial`]: cuts the straddling references exactly ([`Clipper::split`]), with
//!   reference unsplitting.
//!
//! Primitives are cut by a [`Clipper`]: triangles are clipped exactly, other primitives by a
//! user's [`SplitPrimitive`].
//!
//! This file is the search (the binning and the plane sweep); `clip.rs` cuts primitives,
//! `apply.rs` applies a split, `estimate.rs` is the estimate, and on x86-64 `simd.rs` bins
//! triangles eight or sixteen slabs at a time with AVX2 or AVX-512, bit for bit the scalar
//! binning.

use rayon::prelude::*;
use sahara_geom::{Aabb, Axis, Vec3A};
use sahara_metrics::CostModel;

use super::object::Ref;
use super::{half_area, offer, ranks_before, BinMap, Suffix, PAR_AXES_THRESHOLD};

mod apply;
mod clip;
mod estimate;
#[cfg(target_arch = "x86_64")]
mod simd;

pub use apply::{apply_spatial, child_budgets, share_budget, CutLog, NO_CUT};
pub use clip::{clip_halves, plane_pieces, Clipper, SlabClipper, SplitPrimitive};
pub use estimate::{estimated_spatial_search, EstimateScratch};

/// A rated spatial split.
#[derive(Clone, Copy, Debug)]
pub struct SpatialCand {
    /// The axis.
    pub axis: Axis,
    /// References entirely in bins `< plane` go left, entirely in bins `>= plane` go right.
    pub plane: usize,
    /// The bins.
    pub map: BinMap,
    /// The plane's coordinate.
    pub pos: f32,
    /// `A_l n_l + A_r n_r` (with duplicated references).
    pub score: f64,
    /// Eq. 2 with duplicated references.
    pub cost: f64,
    /// References on the left (straddling ones on both sides).
    pub n_left: usize,
    /// References on the right.
    pub n_right: usize,
}

impl SpatialCand {
    /// The candidate order: score (as Eq. 2), then axis, then plane.
    #[inline]
    pub fn better(&self, other: &SpatialCand) -> bool {
        ranks_before(
            self.score,
            || (0, self.axis, self.plane),
            other.score,
            || (0, other.axis, other.plane),
        )
    }
}

/// The `k` best spatial splits of a node (box `bounds`, half area `area`) with `bins` bins per
/// axis whose duplication fits in `budget`.
#[allow(clippy::too_many_arguments)]
pub fn spatial_search(
    clipper: &Clipper,
    refs: &[Ref],
    bounds: &Aabb,
    area: f64,
    k: usize,
    budget: usize,
    bins: usize,
    cost: &CostModel,
) -> Vec<SpatialCand> {
    let f = |axis, out: &mut Vec<SpatialCand>| {
        spatial_axis(
            clipper, refs, bounds, axis, area, k, budget, bins, cost, out,
        )
    };
    let mut cands = Vec::with_capacity(k);
    if refs.len() >= PAR_AXES_THRESHOLD {
        let per_axis: Vec<Vec<SpatialCand>> = (0..3)
            .into_par_iter()
            .map(|axis| {
                let mut out = Vec::with_capacity(k);
                f(axis, &mut out);
                out
            })
            .collect();
        for c in per_axis.into_iter().flatten() {
            offer(&mut cands, k, c, SpatialCand::better);
        }
    } else {
        // One list for the three axes (the `k` best of all planes whatever the order in
        // which they are offered: the candidate order is total), without a list per axis.
        for axis in 0..3 {
            f(axis, &mut cands);
        }
    }
    cands
}

#[derive(Clone, Copy)]
struct SpatialBin {
    bounds: Aabb,
    enter: u32,
    exit: u32,
}

#[allow(clippy::too_many_arguments)]
fn spatial_axis(
    clipper: &Clipper,
    refs: &[Ref],
    bounds: &Aabb,
    axis: Axis,
    area: f64,
    k: usize,
    budget: usize,
    nb: usize,
    cost: &CostModel,
    out: &mut Vec<SpatialCand>,
) {
    if let Some(map) = BinMap::new(bounds.min[axis], bounds.max[axis], nb) {
        binned_axis(clipper, refs, axis, map, area, k, budget, cost, out);
    }
}

/// The best spatial split of a node found coarse to fine: per axis, `coarse` equal-width bins
/// over the node's box, then, around each of that axis's two best coarse planes,
/// `2 × ceil(fine / coarse)` bins over the two coarse bins beside it (the resolution of `fine`
/// bins over the box, where the best plane is likely to be); the best of all those planes
/// over the three axes. Bins
/// references like [`spatial_search`] with `fine` bins at a fraction of the cost where
/// references span many bins. `None` when no plane fits `budget`.
#[allow(clippy::too_many_arguments)]
pub fn refined_spatial_search(
    clipper: &Clipper,
    refs: &[Ref],
    bounds: &Aabb,
    area: f64,
    budget: usize,
    coarse: usize,
    fine: usize,
    cost: &CostModel,
) -> Option<SpatialCand> {
    let f = |axis| {
        refined_axis(
            clipper, refs, bounds, axis, area, budget, coarse, fine, cost,
        )
    };
    let per_axis: Vec<Option<SpatialCand>> = if refs.len() >= PAR_AXES_THRESHOLD {
        (0..3).into_par_iter().map(f).collect()
    } else {
        (0..3).map(f).collect()
    };
    let mut best: Option<SpatialCand> = None;
    for c in per_axis.into_iter().flatten() {
        if best.as_ref().is_none_or(|b| c.better(b)) {
            best = Some(c);
        }
    }
    best
}

/// How many of an axis's best coarse planes [`refined_spatial_search`] refines.
const REFINED_PLANES: usize = 2;

#[allow(clippy::too_many_arguments)]
fn refined_axis(
    clipper: &Clipper,
    refs: &[Ref],
    bounds: &Aabb,
    axis: Axis,
    area: f64,
    budget: usize,
    coarse: usize,
    fine: usize,
    cost: &CostModel,
) -> Option<SpatialCand> {
    let map = BinMap::new(bounds.min[axis], bounds.max[axis], coarse)?;
    let mut coarse_cands = Vec::with_capacity(REFINED_PLANES);
    binned_axis(
        clipper,
        refs,
        axis,
        map,
        area,
        REFINED_PLANES,
        budget,
        cost,
        &mut coarse_cands,
    );
    let mut best = *coarse_cands.first()?;
    let sub = fine.div_ceil(coarse.max(1));
    if sub < 2 {
        return Some(best);
    }
    for c in &coarse_cands {
        let (lo, hi) = (map.plane(c.plane - 1), map.plane(c.plane + 1));
        let Some(fmap) = BinMap::new(lo, hi, 2 * sub) else {
            continue;
        };
        let mut fine_best = Vec::with_capacity(1);
        binned_axis(
            clipper,
            refs,
            axis,
            fmap,
            area,
            1,
            budget,
            cost,
            &mut fine_best,
        );
        if let Some(f) = fine_best.first() {
            if f.better(&best) {
                best = *f;
            }
        }
    }
    Some(best)
}

/// Offers the spatial splits on one axis with the bins of `map` to `out`, the `k` best so far
/// (of this axis or of others), which keeps the `k` best.
#[allow(clippy::too_many_arguments)]
fn binned_axis(
    clipper: &Clipper,
    refs: &[Ref],
    axis: Axis,
    map: BinMap,
    area: f64,
    k: usize,
    budget: usize,
    cost: &CostModel,
    out: &mut Vec<SpatialCand>,
) {
    let nb = map.bins;
    SCRATCH.with_borrow_mut(|sc| {
        let SpatialScratch {
            bins,
            planes,
            #[cfg(not(target_arch = "x86_64"))]
            right,
            #[cfg(target_arch = "x86_64")]
            soa,
            #[cfg(target_arch = "x86_64")]
            suffix_areas,
            #[cfg(target_arch = "x86_64")]
            suffix_counts,
        } = sc;
        bins.clear();
        bins.resize(nb, SpatialBin::EMPTY);
        // Plane positions once per node and axis (exactly `map.plane(i)`): a division each.
        planes.clear();
        planes.extend((0..=nb).map(|i| map.plane(i)));
        #[cfg(target_arch = "x86_64")]
        planes.resize(nb + 1 + simd::PLANE_PADDING, f32::INFINITY);
        #[cfg(target_arch = "x86_64")]
        match (clipper, crate::simd::active()) {
            (Clipper::Triangles(tris), level) if level != crate::simd::BuildSimd::Baseline => {
                let job = simd::AxisJob {
                    tris,
                    refs,
                    axis,
                    map: &map,
                    planes,
                };
                simd::fill(level, job, bins, soa)
            }
            _ => fill_scalar(clipper, refs, axis, &map, planes, bins),
        }
        #[cfg(not(target_arch = "x86_64"))]
        fill_scalar(clipper, refs, axis, &map, planes, bins);
        let plane = PlaneRating {
            n: refs.len(),
            axis,
            map,
            area,
            k,
            budget,
            cost,
        };
        #[cfg(target_arch = "x86_64")]
        {
            plane.rate_batched(bins, suffix_areas, suffix_counts, out)
        }
        #[cfg(not(target_arch = "x86_64"))]
        {
            right.clear();
            right.resize(nb, (0.0f32, 0u32));
            rate_spatial_planes(bins, right, &plane, out)
        }
    })
}

/// What rating the planes of one axis's spatial bins needs besides the bins.
#[derive(Clone, Copy)]
struct PlaneRating<'c> {
    /// References of the node.
    n: usize,
    axis: Axis,
    map: BinMap,
    /// Half area of the node's box.
    area: f64,
    /// How many candidates to keep.
    k: usize,
    budget: usize,
    cost: &'c CostModel,
}

impl PlaneRating<'_> {
    /// Offers plane `i` (left: `nl` references, half area `la`; right: `nr`, `ra`; score
    /// `A_l n_l + A_r n_r`) to the `k` best, with the filters and the order of
    /// [`rate_spatial_planes`].
    #[inline(always)]
    #[allow(clippy::too_many_arguments)]
    fn offer(
        &self,
        cands: &mut Vec<SpatialCand>,
        i: usize,
        la: f64,
        nl: usize,
        ra: f64,
        nr: usize,
        score: f64,
    ) {
        if nl == 0 || nr == 0 || (nl + nr).saturating_sub(self.n) > self.budget {
            return;
        }
        let k = self.k;
        if cands.len() == k && score > cands[k - 1].score {
            return;
        }
        let cand = SpatialCand {
            axis: self.axis,
            plane: i,
            map: self.map,
            pos: self.map.plane(i),
            score,
            cost: self.cost.split_cost(self.area, la, nl, ra, nr),
            n_left: nl,
            n_right: nr,
        };
        offer(cands, k, cand, SpatialCand::better);
    }

    /// [`rate_spatial_planes`] with the half areas of four consecutive sides computed side by
    /// side (SSE2, each lane with the operations of `Aabb::half_area`) and the scores of four
    /// planes compared with the `k`-th best at once: a block whose four scores are all above it
    /// is skipped (its planes would each be rejected, as the `k`-th best only improves). The
    /// others are offered one by one, in order. The same candidates, bit for bit
    /// (`batched_plane_rating_equals_the_scalar_rating`). `scratch` holds the suffix areas.
    #[cfg(target_arch = "x86_64")]
    fn rate_batched(
        &self,
        bins: &[SpatialBin],
        areas: &mut Vec<f32>,
        counts: &mut Vec<u32>,
        cands: &mut Vec<SpatialCand>,
    ) {
        use super::sweep::batched::{extent, half_areas4};
        use std::arch::x86_64::*;
        let nb = bins.len();
        // The suffix areas `areas[i]` and counts `counts[i]` of bins `i..` for `i` in `1..nb`.
        areas.clear();
        areas.resize(nb, 0.0);
        counts.clear();
        counts.resize(nb, 0);
        let mut acc = Aabb::EMPTY;
        let mut rc = 0u32;
        let mut j = nb;
        // SAFETY (intrinsics): SSE2 is part of x86-64; the loads and stores are in bounds as
        // noted.
        unsafe {
            while j >= 5 {
                let mut e = [_mm_setzero_ps(); 4];
                for q in (0..4).rev() {
                    let b = &bins[j - 4 + q];
                    acc.grow_aabb(&b.bounds);
                    rc += b.exit;
                    counts[j - 4 + q] = rc;
                    e[q] = extent(&acc);
                }
                // In bounds: `j <= nb`.
                _mm_storeu_ps(areas.as_mut_ptr().add(j - 4), half_areas4(e));
                j -= 4;
            }
            for i in (1..j).rev() {
                acc.grow_aabb(&bins[i].bounds);
                rc += bins[i].exit;
                counts[i] = rc;
                areas[i] = acc.half_area();
            }
            let mut lb = Aabb::EMPTY;
            let mut lc = 0u32;
            let mut i = 1;
            while i + 4 <= nb {
                let mut e = [_mm_setzero_ps(); 4];
                let mut nl = [0u32; 4];
                for q in 0..4 {
                    let b = &bins[i - 1 + q];
                    lb.grow_aabb(&b.bounds);
                    lc += b.enter;
                    nl[q] = lc;
                    e[q] = extent(&lb);
                }
                let la4 = half_areas4(e);
                // In bounds: `i + 4 <= nb`.
                let ra4 = _mm_loadu_ps(areas.as_ptr().add(i));
                let la = [_mm_cvtps_pd(la4), _mm_cvtps_pd(_mm_movehl_ps(la4, la4))];
                let ra = [_mm_cvtps_pd(ra4), _mm_cvtps_pd(_mm_movehl_ps(ra4, ra4))];
                let f = |x: u32| x as f64;
                let nlv = [
                    _mm_set_pd(f(nl[1]), f(nl[0])),
                    _mm_set_pd(f(nl[3]), f(nl[2])),
                ];
                let nr = &counts[i..i + 4];
                let nrv = [
                    _mm_set_pd(f(nr[1]), f(nr[0])),
                    _mm_set_pd(f(nr[3]), f(nr[2])),
                ];
                let score = [0, 1]
                    .map(|h| _mm_add_pd(_mm_mul_pd(la[h], nlv[h]), _mm_mul_pd(ra[h], nrv[h])));
                if cands.len() == self.k {
                    let worst = _mm_set1_pd(cands[self.k - 1].score);
                    let above = _mm_movemask_pd(_mm_cmpgt_pd(score[0], worst))
                        | _mm_movemask_pd(_mm_cmpgt_pd(score[1], worst)) << 2;
                    if above == 0b1111 {
                        i += 4;
                        continue;
                    }
                }
                let mut lf = [0.0f64; 4];
                let mut rf = [0.0f64; 4];
                let mut sf = [0.0f64; 4];
                for h in 0..2 {
                    _mm_storeu_pd(lf.as_mut_ptr().add(2 * h), la[h]);
                    _mm_storeu_pd(rf.as_mut_ptr().add(2 * h), ra[h]);
                    _mm_storeu_pd(sf.as_mut_ptr().add(2 * h), score[h]);
                }
                for q in 0..4 {
                    let (nl, nr) = (nl[q] as usize, nr[q] as usize);
                    self.offer(cands, i + q, lf[q], nl, rf[q], nr, sf[q]);
                }
                i += 4;
            }
            while i < nb {
                let b = &bins[i - 1];
                lb.grow_aabb(&b.bounds);
                lc += b.enter;
                let (la, ra) = (half_area(&lb), areas[i] as f64);
                let (nl, nr) = (lc as usize, counts[i] as usize);
                let score = la * nl as f64 + ra * nr as f64;
                self.offer(cands, i, la, nl, ra, nr, score);
                i += 1;
            }
        }
    }
}

/// Reusable buffers of one spatial-binning axis (one set per thread: the binning of an axis
/// never calls into rayon, so it is never re-entered on the same thread).
#[derive(Default)]
struct SpatialScratch {
    bins: Vec<SpatialBin>,
    planes: Vec<f32>,
    /// The suffix areas and counts of the plane-by-plane rating.
    #[cfg(not(target_arch = "x86_64"))]
    right: Vec<(f32, u32)>,
    /// The SIMD backends' bins.
    #[cfg(target_arch = "x86_64")]
    soa: simd::SoaScratch,
    /// The suffix areas and counts of the batched plane rating.
    #[cfg(target_arch = "x86_64")]
    suffix_areas: Vec<f32>,
    #[cfg(target_arch = "x86_64")]
    suffix_counts: Vec<u32>,
}

thread_local! {
    static SCRATCH: std::cell::RefCell<SpatialScratch> = Default::default();
}

impl SpatialBin {
    const EMPTY: SpatialBin = SpatialBin {
        bounds: Aabb::EMPTY,
        enter: 0,
        exit: 0,
    };
}

/// Bins every reference on one axis: counts it as entering its first bin and leaving its last,
/// and grows each bin it spans by the box of its part there. References inside one bin grow
/// it by their box; triangles spanning several are clipped plane by plane
/// ([`SlabClipper::bin_into`]); other primitives go through [`Clipper::bin`].
///
/// The baseline path of every CPU. On x86-64 CPUs with AVX2 or AVX-512, triangles go through
/// `simd::fill` instead, which fills the same bins bit for bit eight or sixteen slabs at a
/// time ([`crate::simd`]).
fn fill_scalar(
    clipper: &Clipper,
    refs: &[Ref],
    axis: Axis,
    map: &BinMap,
    planes: &[f32],
    bins: &mut [SpatialBin],
) {
    for r in refs {
        let (first, last) = count_span(map, r, axis, bins);
        if first == last {
            bins[first].bounds.grow_aabb(&r.bounds);
            continue;
        }
        match clipper {
            Clipper::Triangles(t) => {
                let c = SlabClipper::new(&t[r.prim as usize], axis, &r.bounds);
                c.bin_into(planes, first, last, bins);
            }
            Clipper::Custom(_) => {
                clipper.bin(r.prim, axis, &r.bounds, map, first..=last, |b, piece| {
                    bins[b].bounds.grow_aabb(piece)
                })
            }
        }
    }
}

/// The first and last bins of a reference's box on `axis`, counted as the bins it enters and
/// leaves.
#[inline(always)]
fn count_span(map: &BinMap, r: &Ref, axis: Axis, bins: &mut [SpatialBin]) -> (usize, usize) {
    let first = map.bin(r.bounds.min[axis]);
    let last = map.bin(r.bounds.max[axis]);
    bins[first].enter += 1;
    bins[last].exit += 1;
    (first, last)
}

impl SlabClipper<'_> {
    /// [`bin`](Self::bin) into `bins` directly, with the plane positions read from `planes`
    /// (`planes[i] == map.plane(i)`) and without branches on the pieces: the same boxes, bit
    /// for bit (an empty piece becomes [`Aabb::EMPTY`], which leaves a bin unchanged).
    #[inline]
    fn bin_into(&self, planes: &[f32], first: usize, last: usize, bins: &mut [SpatialBin]) {
        let a = self.axis;
        let v = &self.v;
        let (v0a, v1a, v2a) = (v[0][a], v[1][a], v[2][a]);
        let mask = self.axis_mask();
        let empty = Aabb::EMPTY;
        // `crossing`, computed on both branches and selected (the same values).
        let crossing = |pos: f32| -> Aabb {
            let t0 = pos - v0a;
            let long = v[0] + self.dir[0] * t0;
            let s0 = v[0] + self.dir[1] * t0;
            let s1 = v[1] + self.dir[2] * (pos - v1a);
            let short = Vec3A::select(glam::BVec3A::splat(pos < v1a), s0, s1);
            let inside = glam::BVec3A::splat(pos > v0a && pos < v2a);
            Aabb::new(
                Vec3A::select(inside, long.min(short), empty.min),
                Vec3A::select(inside, long.max(short), empty.max),
            )
        };
        let piece_in = |lower_pos: f32, lower: &Aabb, upper_pos: f32, upper: &Aabb| -> Aabb {
            let piece = self.piece(mask, lower_pos, lower, upper_pos, upper);
            let keep = glam::BVec3A::splat(!piece.is_empty());
            Aabb::new(
                Vec3A::select(keep, piece.min, empty.min),
                Vec3A::select(keep, piece.max, empty.max),
            )
        };
        let mut lower_pos = f32::NEG_INFINITY;
        let mut lower = Aabb::EMPTY;
        for (b, &upper_pos) in (first..last).zip(&planes[first + 1..=last]) {
            let upper = crossing(upper_pos);
            let piece = piece_in(lower_pos, &lower, upper_pos, &upper);
            bins[b].bounds.grow_aabb(&piece);
            lower_pos = upper_pos;
            lower = upper;
        }
        let piece = piece_in(lower_pos, &lower, f32::INFINITY, &empty);
        bins[last].bounds.grow_aabb(&piece);
    }
}

/// The sweep over the filled bins of one axis: the `k` best planes. (On x86-64 the builders
/// use its batched twin, `PlaneRating::rate_batched`; this is the reference it is tested
/// against.)
#[cfg_attr(target_arch = "x86_64", allow(dead_code))]
fn rate_spatial_planes(
    bins: &[SpatialBin],
    right: &mut [(f32, u32)],
    rating: &PlaneRating,
    cands: &mut Vec<SpatialCand>,
) {
    let (n, budget) = (rating.n, rating.budget);
    let nb = bins.len();
    let side = |i: usize| {
        (
            &bins[i].bounds,
            &bins[i].bounds,
            bins[i].enter,
            bins[i].exit,
        )
    };
    sweep_spatial_planes(nb, side, right, n, budget, |i, lb, nl, ra: &f32, nr| {
        let (la, ra) = (half_area(lb), ra.area());
        rating.offer(cands, i, la, nl, ra, nr, la * nl as f64 + ra * nr as f64);
    });
}

/// The plane sweep of a spatial binning of `nb` bins: `bin(i)` gives the box that bin `i`
/// adds to a left side, the box it adds to a right side, and how many references enter and
/// leave in it. The suffix goes right to left into `right`, then `visit(plane, left, n_left,
/// right, n_right)` runs left to right for every plane with references on both sides whose
/// duplication (`n_left + n_right - n`) fits `budget`.
#[inline]
#[allow(clippy::needless_range_loop)]
pub(super) fn sweep_spatial_planes<'b, S: Suffix>(
    nb: usize,
    bin: impl Fn(usize) -> (&'b Aabb, &'b Aabb, u32, u32),
    right: &mut [(S, u32)],
    n: usize,
    budget: usize,
    mut visit: impl FnMut(usize, &Aabb, usize, &S, usize),
) {
    let mut acc = Aabb::EMPTY;
    let mut rc = 0u32;
    for i in (1..nb).rev() {
        let (_, r, _, exit) = bin(i);
        acc.grow_aabb(r);
        rc += exit;
        right[i] = (S::of(&acc), rc);
    }
    let mut lb = Aabb::EMPTY;
    let mut lc = 0u32;
    for i in 1..nb {
        let (l, _, enter, _) = bin(i - 1);
        lb.grow_aabb(l);
        lc += enter;
        let (r, rc) = &right[i];
        let (nl, nr) = (lc as usize, *rc as usize);
        if nl == 0 || nr == 0 || (nl + nr).saturating_sub(n) > budget {
            continue;
        }
        visit(i, &lb, nl, r, nr);
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use sahara_geom::Triangle;

    /// A small deterministic generator (no dependency on a RNG crate in unit tests).
    pub(super) fn lcg(state: &mut u64) -> f32 {
        *state = state
            .wrapping_mul(6364136223846793005)
            .wrapping_add(1442695040888963407);
        ((*state >> 40) as f32 / (1u64 << 24) as f32) * 4.0 - 2.0
    }

    #[test]
    fn branchless_slab_binning_matches_the_reference_clipper() {
        let mut s = 7u64;
        let mut checked = 0;
        for i in 0..2000 {
            let mut p = || Vec3A::new(lcg(&mut s), lcg(&mut s), lcg(&mut s));
            let mut tri = Triangle::new(p(), p(), p());
            if i % 7 == 0 {
                // A vertex on a plane and an edge parallel to the axis.
                tri.v[1].x = tri.v[0].x;
            }
            let full = tri.bounds();
            // Also a reference box that cuts the triangle (as after a spatial split).
            let cut = Aabb::new(full.min + (full.max - full.min) * 0.2, full.max);
            for bounds in [full, cut] {
                for axis in 0..3 {
                    let Some(map) = BinMap::new(-2.0, 2.0, 32) else {
                        unreachable!()
                    };
                    let planes: Vec<f32> = (0..=32).map(|i| map.plane(i)).collect();
                    let (first, last) = (map.bin(bounds.min[axis]), map.bin(bounds.max[axis]));
                    if first == last {
                        continue;
                    }
                    let c = SlabClipper::new(&tri, axis, &bounds);
                    let mut want = vec![SpatialBin::EMPTY; 32];
                    c.bin(&map, first, last, |b, piece| {
                        want[b].bounds.grow_aabb(piece)
                    });
                    let mut got = vec![SpatialBin::EMPTY; 32];
                    c.bin_into(&planes, first, last, &mut got);
                    for (w, g) in want.iter().zip(&got) {
                        let bits = |b: &Aabb| (b.min.to_array(), b.max.to_array()).map_bits();
                        assert_eq!(bits(&w.bounds), bits(&g.bounds), "{tri:?} axis {axis}");
                    }
                    checked += 1;
                }
            }
        }
        assert!(checked > 1000);
    }

    /// The batched plane rating keeps exactly the candidates (planes, scores, costs, counts, in
    /// order) of the plane-by-plane rating: random bins with empty stretches, coarse
    /// coordinates (tied scores), tight budgets, every `k` from 1 to 4, and bin counts that
    /// leave every remainder of the blocks of four.
    #[cfg(target_arch = "x86_64")]
    #[test]
    fn batched_plane_rating_equals_the_scalar_rating() {
        let mut s = 3u64;
        let cost = CostModel::default();
        let (mut areas, mut counts) = (Vec::new(), Vec::new());
        let mut skipped = 0;
        for case in 0..4000 {
            let nb = [2usize, 3, 4, 5, 6, 7, 8, 9, 16, 33, 128][case % 11];
            let map = BinMap::new(-2.0, 2.0, nb).unwrap();
            let mut bins = vec![SpatialBin::EMPTY; nb];
            let mut n = 0;
            for _ in 0..(case % 40 + 1) {
                // A reference spanning bins `first..=last`, its pieces random boxes.
                let mut b = || ((lcg(&mut s) + 2.0) / 4.0 * nb as f32) as usize % nb;
                let (a, c) = (b(), b());
                let (first, last) = (a.min(c), a.max(c));
                bins[first].enter += 1;
                bins[last].exit += 1;
                n += 1;
                for bin in &mut bins[first..=last] {
                    let mut q = || (lcg(&mut s) * 2.0).round() * 0.5;
                    let (p, r) = (Vec3A::new(q(), q(), q()), Vec3A::new(q(), q(), q()));
                    bin.bounds.grow_aabb(&Aabb::new(p.min(r), p.max(r)));
                }
            }
            let area = half_area(&Aabb::new(Vec3A::splat(-2.0), Vec3A::splat(2.0)));
            let budget = [0usize, 1, 3, usize::MAX][(case / 11) % 4];
            for k in 1..=4 {
                let rating = PlaneRating {
                    n,
                    axis: 1,
                    map,
                    area,
                    k,
                    budget,
                    cost: &cost,
                };
                let mut right = vec![(0.0f32, 0u32); nb];
                // Both lists start with a candidate of another axis (the lists are shared by
                // the three axes), in half of the cases.
                let other = SpatialCand {
                    axis: 0,
                    plane: 1,
                    map,
                    pos: map.plane(1),
                    score: [2.0, 40.0][case % 2],
                    cost: 1.0,
                    n_left: 1,
                    n_right: 1,
                };
                let start = if case % 4 < 2 {
                    vec![other]
                } else {
                    Vec::new()
                };
                let mut want = start.clone();
                rate_spatial_planes(&bins, &mut right, &rating, &mut want);
                let mut got = start;
                rating.rate_batched(&bins, &mut areas, &mut counts, &mut got);
                let key = |c: &SpatialCand| {
                    let bits = (c.score.to_bits(), c.cost.to_bits(), c.pos.to_bits());
                    (c.axis, c.plane, bits, c.n_left, c.n_right)
                };
                let g: Vec<_> = got.iter().map(key).collect();
                let w: Vec<_> = want.iter().map(key).collect();
                assert_eq!(g, w, "case {case} k {k}");
                skipped += (nb > 8 && want.len() == k) as usize;
            }
        }
        assert!(skipped > 1000, "{skipped}");
    }

    trait MapBits {
        fn map_bits(self) -> [u32; 6];
    }

    impl MapBits for ([f32; 3], [f32; 3]) {
        fn map_bits(self) -> [u32; 6] {
            let (a, b) = self;
            [a[0], a[1], a[2], b[0], b[1], b[2]].map(f32::to_bits)
        }
    }
}
