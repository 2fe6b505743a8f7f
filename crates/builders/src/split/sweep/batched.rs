//! [`super::best_on_axis`] four positions at a time (SSE2, part of x86-64): the boxes are still grown
//! one by one, but the half areas of four consecutive boxes are computed side by side (their
//! extents transposed into lanes) and Eq. 2's scores of four positions are compared with the
//! pruning bound `s0` at once; the positions that survive are then rated one by one, in order,
//! exactly as [`super::best_on_axis_scalar`] rates them. Every lane performs the scalar code's `f32`
//! and `f64` operations in the same order (no FMA), so areas, scores, costs and the chosen
//! candidate are bit for bit the scalar ones (tested against it).

use super::{CostModel, PositionRater, SplitCandidate};
use sahara_geom::{Aabb, Vec3A};
use std::arch::x86_64::*;

/// How many positions ahead the sweeps prefetch the boxes they will read.
const PREFETCH: usize = 48;

/// Asks for the cache line of `b`.
#[inline(always)]
fn prefetch(b: &Aabb) {
    // SAFETY: a prefetch never faults; SSE is part of x86-64.
    unsafe { _mm_prefetch::<_MM_HINT_T0>((b as *const Aabb).cast()) }
}

/// The extent of `b` as `Aabb::half_area` computes it (`Aabb::extent`).
#[inline(always)]
pub(in crate::split) fn extent(b: &Aabb) -> __m128 {
    b.extent().into()
}

/// `x·y + y·z + z·x` of four extents (one per lane), with the operations and order of
/// `Aabb::half_area`.
#[inline(always)]
pub(in crate::split) fn half_areas4(e: [__m128; 4]) -> __m128 {
    // SAFETY: SSE2 is part of x86-64.
    unsafe {
        let t0 = _mm_unpacklo_ps(e[0], e[1]); // x0 x1 y0 y1
        let t1 = _mm_unpacklo_ps(e[2], e[3]); // x2 x3 y2 y3
        let t2 = _mm_unpackhi_ps(e[0], e[1]); // z0 z1 . .
        let t3 = _mm_unpackhi_ps(e[2], e[3]); // z2 z3 . .
        let x = _mm_movelh_ps(t0, t1);
        let y = _mm_movehl_ps(t1, t0);
        let z = _mm_movelh_ps(t2, t3);
        _mm_add_ps(
            _mm_add_ps(_mm_mul_ps(x, y), _mm_mul_ps(y, z)),
            _mm_mul_ps(z, x),
        )
    }
}

/// The suffix half areas right to left into `areas[1..n]` (as `suffix_pass` with `f32`
/// suffixes); returns the bounds of all `n >= 1` items.
#[inline(always)]
fn suffix_areas<'b>(n: usize, item: impl Fn(usize) -> &'b Aabb, areas: &mut [f32]) -> Aabb {
    let areas = &mut areas[..n];
    let mut acc = Aabb::EMPTY;
    let mut j = n;
    // Blocks of positions `j - 4 .. j`, all at least 1.
    while j >= 5 {
        if j >= 4 + PREFETCH {
            for k in 0..4 {
                prefetch(item(j - 4 - PREFETCH + k));
            }
        }
        let mut e = [Vec3A::ZERO.into(); 4];
        for k in (0..4).rev() {
            acc.grow_aabb(item(j - 4 + k));
            e[k] = extent(&acc);
        }
        // SAFETY: `j - 4 + 4 <= n`, so the four floats are in bounds.
        unsafe { _mm_storeu_ps(areas.as_mut_ptr().add(j - 4), half_areas4(e)) };
        j -= 4;
    }
    for i in (1..j).rev() {
        acc.grow_aabb(item(i));
        areas[i] = acc.half_area();
    }
    acc.grow_aabb(item(0));
    acc
}

#[inline]
pub(super) fn best_on_axis(
    bounds: &[Aabb],
    order: &[u32],
    axis: usize,
    areas: &mut [f32],
    cost: &CostModel,
    best: &mut SplitCandidate,
    s0: &mut f64,
) -> Aabb {
    let n = order.len();
    assert!(n >= 1, "a sweep needs at least one primitive");
    // SAFETY: every caller passes `j < n = order.len()`; the id itself stays checked.
    let item = |j: usize| &bounds[*unsafe { order.get_unchecked(j) } as usize];
    let node = suffix_areas(n, item, areas);
    let rater = PositionRater::new(axis, n, &node, cost);
    let total = n as f64;
    let areas = &areas[..n];
    // `n_left` is `j` exactly, as the scalar sweep's running count.
    let rate = |j: usize, left_area: f64, right_area: f64, best: &mut _, s0: &mut _| {
        rater.rate(j, j as f64, left_area, right_area, best, s0)
    };
    let mut left = Aabb::EMPTY;
    let mut j = 1;
    // Blocks of positions `j .. j + 4`, all below `n`.
    while j + 4 <= n {
        if j + 3 + PREFETCH + 4 <= n {
            for k in 0..4 {
                prefetch(item(j - 1 + PREFETCH + k));
            }
        }
        let mut e = [Vec3A::ZERO.into(); 4];
        for (k, ek) in e.iter_mut().enumerate() {
            left.grow_aabb(item(j - 1 + k));
            *ek = extent(&left);
        }
        let la = half_areas4(e);
        // SAFETY: SSE2 is part of x86-64; `areas[j..j + 4]` is in bounds.
        let (la, ra, score) = unsafe {
            let ra = _mm_loadu_ps(areas.as_ptr().add(j));
            let la = [_mm_cvtps_pd(la), _mm_cvtps_pd(_mm_movehl_ps(la, la))];
            let ra = [_mm_cvtps_pd(ra), _mm_cvtps_pd(_mm_movehl_ps(ra, ra))];
            let jf = j as f64;
            let nl = [_mm_set_pd(jf + 1.0, jf), _mm_set_pd(jf + 3.0, jf + 2.0)];
            let tot = _mm_set1_pd(total);
            let score = [0, 1].map(|h| {
                let nr = _mm_sub_pd(tot, nl[h]);
                _mm_add_pd(_mm_mul_pd(la[h], nl[h]), _mm_mul_pd(ra[h], nr))
            });
            (la, ra, score)
        };
        // SAFETY: as above.
        let pruned = unsafe {
            let b = _mm_set1_pd(*s0);
            (_mm_movemask_pd(_mm_cmpge_pd(score[0], b))
                | _mm_movemask_pd(_mm_cmpge_pd(score[1], b)) << 2) as u32
        };
        if pruned != 0b1111 {
            // Lanes whose score is already `>= s0` stay pruned: `s0` only falls.
            let mut lf = [0.0f64; 4];
            let mut rf = [0.0f64; 4];
            // SAFETY: the arrays hold four doubles.
            unsafe {
                _mm_storeu_pd(lf.as_mut_ptr(), la[0]);
                _mm_storeu_pd(lf.as_mut_ptr().add(2), la[1]);
                _mm_storeu_pd(rf.as_mut_ptr(), ra[0]);
                _mm_storeu_pd(rf.as_mut_ptr().add(2), ra[1]);
            }
            for k in 0..4 {
                if pruned & (1 << k) == 0 {
                    rate(j + k, lf[k], rf[k], best, s0);
                }
            }
        }
        j += 4;
    }
    while j < n {
        left.grow_aabb(item(j - 1));
        rate(j, left.half_area() as f64, areas[j] as f64, best, s0);
        j += 1;
    }
    node
}
