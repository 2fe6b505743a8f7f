//! The full sweep (MacDonald & Booth 1990): the primitives of a node sorted by centroid on
//! each axis, and every one of the `n - 1` positions of each order as a candidate.
//!
//! [`suffix_pass`] and [`prefix_pass`] are the one sweep: suffix bounds right to left, then
//! the left side grown left to right, each position handed to a visitor with both sides'
//! geometry. [`sweep_axis`] and [`best_split`] rate the positions by Eq. 2 as
//! [`SplitCandidate`]s (the greedy builders and the candidate selection of the paper's
//! builders); the SBVH object search rates them by area-count score through the same sweep.
//! The orders themselves, and how they stay sorted through a split, are
//! [`super::orders`]; on x86-64 the greedy search runs four positions at a time
//! (`batched.rs`), bit for bit its scalar twin.

use sahara_geom::Aabb;
use sahara_metrics::CostModel;

use super::{imbalance, ranks_before, Suffix, PAR_AXES_THRESHOLD};

#[cfg(target_arch = "x86_64")]
pub(in crate::split) mod batched;

/// A candidate split of a node whose primitives are sorted by centroid along `axis`: the first
/// `pos` primitives of that order go left, the others right.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SplitCandidate {
    /// The axis whose sorted order is split.
    pub axis: usize,
    /// Number of primitives on the left (`1..n`).
    pub pos: usize,
    /// Its greedy cost (Eq. 2), or whatever rating replaced it.
    pub cost: f64,
    /// Half the surface area of the left side's bounds.
    pub left_area: f64,
    /// Half the surface area of the right side's bounds.
    pub right_area: f64,
}

impl SplitCandidate {
    /// True when `self` beats `other` for a node of `n` primitives: lower cost, then (on an
    /// exact tie) the more balanced split, then the lower axis, then the lower position (see
    /// [`ranks_before`]).
    #[inline]
    pub fn better_than(&self, other: &SplitCandidate, n: usize) -> bool {
        ranks_before(
            self.cost,
            || (imbalance(self.pos, n - self.pos), self.axis, self.pos),
            other.cost,
            || (imbalance(other.pos, n - other.pos), other.axis, other.pos),
        )
    }

    /// The stand-in a sweep starts from: the median split of the x order with infinite cost.
    /// Any real candidate with a finite cost beats it; it is kept only when every cost is
    /// infinite or NaN (boxes whose area overflows), which still gives a valid tree.
    pub fn fallback(n: usize) -> SplitCandidate {
        SplitCandidate {
            axis: 0,
            pos: n / 2,
            cost: f64::INFINITY,
            left_area: f64::INFINITY,
            right_area: f64::INFINITY,
        }
    }
}

/// The first pass of a sweep over one sorted order of `n >= 1` items whose boxes are
/// `item(0..n)`: the suffix bounds right to left into `suffix[1..n]`. Returns the bounds of
/// all the items (the node's bounds).
#[inline]
pub fn suffix_pass<'b, S: Suffix>(
    n: usize,
    item: impl Fn(usize) -> &'b Aabb,
    suffix: &mut [S],
) -> Aabb {
    let suffix = &mut suffix[..n];
    let mut acc = Aabb::EMPTY;
    for j in (1..n).rev() {
        acc.grow_aabb(item(j));
        suffix[j] = S::of(&acc);
    }
    acc.grow_aabb(item(0));
    acc
}

/// The second pass of a sweep (after [`suffix_pass`]): the left side grown left to right,
/// calling `visit(pos, left, right)` for each position `pos` in `1..n`, with `left` the bounds
/// of items `0..pos` and `right` the suffix of items `pos..n`.
#[inline]
#[allow(clippy::needless_range_loop)]
pub fn prefix_pass<'b, S: Suffix>(
    n: usize,
    item: impl Fn(usize) -> &'b Aabb,
    suffix: &[S],
    mut visit: impl FnMut(usize, &Aabb, &S),
) {
    let suffix = &suffix[..n];
    let mut left = Aabb::EMPTY;
    for j in 1..n {
        left.grow_aabb(item(j - 1));
        visit(j, &left, &suffix[j]);
    }
}

/// Sweeps one sorted order of primitive ids by Eq. 2: each of the `n - 1` positions is handed
/// to `visit` as a [`SplitCandidate`] (`areas` is scratch of at least `n`). Returns the bounds
/// of all the primitives of the order. `n >= 1`.
#[inline]
pub fn sweep_axis<F: FnMut(SplitCandidate)>(
    bounds: &[Aabb],
    order: &[u32],
    axis: usize,
    areas: &mut [f32],
    cost: &CostModel,
    mut visit: F,
) -> Aabb {
    let n = order.len();
    let item = |j: usize| &bounds[order[j] as usize];
    let node = suffix_pass(n, item, areas);
    let parent_area = node.half_area() as f64;
    // Counts in floating point (exact): see `CostModel::split_cost_counts`.
    let total = n as f64;
    let mut n_left = 0.0;
    prefix_pass(n, item, areas, |j, left, right: &f32| {
        n_left += 1.0;
        let left_area = left.half_area() as f64;
        let right_area = right.area();
        visit(SplitCandidate {
            axis,
            pos: j,
            cost: cost.split_cost_counts(
                parent_area,
                left_area,
                n_left,
                right_area,
                total - n_left,
            ),
            left_area,
            right_area,
        });
    });
    node
}

/// The best candidate of one sorted order by Eq. 2, merged into `best` (the running best of
/// the node, `n` primitives), as [`sweep_axis`] with a visitor keeping the best would find it,
/// but without Eq. 2's division at most positions. Returns the bounds of the order.
///
/// Eq. 2 computed in floating point, `c(s) = t + s·c_i / A` with `s = A_l n_l + A_r n_r`, is
/// monotone non-decreasing in `s` (every rounding step is). So once a position with score `s0`
/// costs strictly more than the best so far, every later position with a score `s >= s0`
/// costs strictly more than the best too (which only falls), and loses to it whatever the
/// tie-break: it is skipped. `s0` carries over between the axes of a node. Nothing is
/// approximated, so where the best cost is finite the chosen split is bit for bit the one of
/// the full evaluation. Where Eq. 2 overflows to infinity at every position (boxes near the
/// float range's ends: the hard cases), "strictly more" no longer separates the positions and
/// the two may pick different splits of equal (infinite) cost; both trees are valid, and the
/// builders only ever use this search (`tsah`'s reuse of temporaries checks finiteness).
#[inline]
fn best_on_axis(
    bounds: &[Aabb],
    order: &[u32],
    axis: usize,
    areas: &mut [f32],
    cost: &CostModel,
    best: &mut SplitCandidate,
    s0: &mut f64,
) -> Aabb {
    #[cfg(target_arch = "x86_64")]
    {
        batched::best_on_axis(bounds, order, axis, areas, cost, best, s0)
    }
    #[cfg(not(target_arch = "x86_64"))]
    {
        best_on_axis_scalar(bounds, order, axis, areas, cost, best, s0)
    }
}

#[cfg_attr(target_arch = "x86_64", allow(dead_code))]
#[inline]
fn best_on_axis_scalar(
    bounds: &[Aabb],
    order: &[u32],
    axis: usize,
    areas: &mut [f32],
    cost: &CostModel,
    best: &mut SplitCandidate,
    s0: &mut f64,
) -> Aabb {
    let n = order.len();
    let item = |j: usize| &bounds[order[j] as usize];
    let node = suffix_pass(n, item, areas);
    let rater = PositionRater::new(axis, n, &node, cost);
    let mut n_left = 0.0;
    prefix_pass(n, item, areas, |j, left, right: &f32| {
        n_left += 1.0;
        rater.rate(j, n_left, left.half_area() as f64, right.area(), best, s0);
    });
    node
}

/// Rates the positions of one sweep by Eq. 2 with the pruning bound `s0` (see
/// [`best_on_axis`]); shared by the scalar and the batched sweep.
struct PositionRater<'c> {
    axis: usize,
    n: usize,
    total: f64,
    parent_area: f64,
    cost: &'c CostModel,
}

impl<'c> PositionRater<'c> {
    #[inline(always)]
    fn new(axis: usize, n: usize, node: &Aabb, cost: &'c CostModel) -> Self {
        Self {
            axis,
            n,
            total: n as f64,
            parent_area: node.half_area() as f64,
            cost,
        }
    }

    /// Position `j` (`n_left == j`, in `f64`), whose sides have these half areas.
    #[inline(always)]
    fn rate(
        &self,
        j: usize,
        n_left: f64,
        left_area: f64,
        right_area: f64,
        best: &mut SplitCandidate,
        s0: &mut f64,
    ) {
        let n_right = self.total - n_left;
        let score = left_area * n_left + right_area * n_right;
        if score >= *s0 {
            return;
        }
        let c = SplitCandidate {
            axis: self.axis,
            pos: j,
            cost: self.cost.split_cost_counts(
                self.parent_area,
                left_area,
                n_left,
                right_area,
                n_right,
            ),
            left_area,
            right_area,
        };
        if c.better_than(best, self.n) {
            *best = c;
        } else if c.cost > best.cost {
            *s0 = score;
        }
    }
}

/// [`best_split`] of a node of two primitives `p` and `q`: every axis's one candidate puts one
/// of them on each side, so its score is `A_p + A_q` on every axis (in either order: `f64`
/// addition commutes bit for bit, NaN included, and a one-box side's area is the box's own).
/// The three candidates cost the same, and the tie goes to axis 0 ([`ranks_before`]); axes 1
/// and 2 can change neither the best candidate nor, therefore, anything else. So only axis
/// 0 is swept. The node's bounds are grown in the order the last axis's sweep grows them
/// (which decides the sign of a zero bound), as [`best_split`] returns them.
#[inline]
fn best_split_of_two(
    bounds: &[Aabb],
    orders: [&[u32]; 3],
    areas: &mut [f32],
    cost: &CostModel,
) -> (Aabb, SplitCandidate) {
    let mut best = SplitCandidate::fallback(2);
    let mut s0 = f64::INFINITY;
    best_on_axis(bounds, orders[0], 0, areas, cost, &mut best, &mut s0);
    let mut node = Aabb::EMPTY;
    node.grow_aabb(&bounds[orders[2][1] as usize]);
    node.grow_aabb(&bounds[orders[2][0] as usize]);
    (node, best)
}

/// Nodes of at most this many primitives are searched by [`best_split_small`].
const SMALL_SWEEP: usize = 32;

/// [`best_split`] of a node of `3..=SMALL_SWEEP` primitives without a branch per position,
/// bit for bit its answer, or `None` where the shortcut's conditions fail (then the general
/// search runs).
///
/// The pruned search of [`best_on_axis`] returns the best of all positions under
/// [`SplitCandidate::better_than`] (a pruned position costs strictly more than the best), but
/// its branches on each position's score and cost mispredict at small nodes, where they are
/// most of the time. Here every position's score `s = A_l n_l + A_r n_r` is computed first,
/// with the operations of the general search, and only positions whose score is within a
/// factor `1 + 2^-16` of the smallest, `s_min`, are costed and compared. The others cost
/// strictly more than the position of `s_min`, so they cannot be the best.
///
/// Why. Eq. 2 is `c(s) = c_t + y(s)` with `y(s) = (s c_i) / A` rounded twice. Where
/// `y(s_min) >= 2^-30 c_t`, all of `c_t >= 0`, `c_i > 0`, `A > 0` and `s_min` are finite and
/// `y(s_min)` is far from the subnormals (at least `2^-900`), a score `s > s_min (1 + 2^-16)`
/// gives `y(s) - y(s_min) > 2^-17 y(s_min)`, which is more than two units in the last place
/// of `c_t + y(s_min) <= (2^30 + 1) y(s_min)`, so `c(s) > c(s_min)` after rounding. Where the
/// conditions fail (a score that is infinite or NaN, a flat node, `c_t` swamping the areas),
/// the function returns `None`.
#[inline]
fn best_split_small(
    bounds: &[Aabb],
    orders: [&[u32]; 3],
    cost: &CostModel,
) -> Option<(Aabb, SplitCandidate)> {
    let n = orders[0].len();
    debug_assert!((3..=SMALL_SWEEP).contains(&n));
    use std::mem::MaybeUninit;
    // Written for positions `1..n` of each axis before they are read (not zeroed: this runs
    // at every small node).
    let mut la = [[MaybeUninit::<f32>::uninit(); SMALL_SWEEP]; 3];
    let mut ra = [[MaybeUninit::<f32>::uninit(); SMALL_SWEEP]; 3];
    let mut score = [[MaybeUninit::<f64>::uninit(); SMALL_SWEEP]; 3];
    let mut parent = [0.0f64; 3];
    let mut node = Aabb::EMPTY;
    let total = n as f64;
    for axis in 0..3 {
        let order = orders[axis];
        let item = |j: usize| &bounds[order[j] as usize];
        // The suffix pass, as `suffix_pass` grows it (the last axis's box is the node's).
        let mut acc = Aabb::EMPTY;
        for j in (1..n).rev() {
            acc.grow_aabb(item(j));
            ra[axis][j].write(acc.half_area());
        }
        acc.grow_aabb(item(0));
        parent[axis] = acc.half_area() as f64;
        node = acc;
        let mut left = Aabb::EMPTY;
        for (j, slot) in la[axis].iter_mut().enumerate().take(n).skip(1) {
            left.grow_aabb(item(j - 1));
            slot.write(left.half_area());
        }
    }
    // `PositionRater::rate`'s scores, in a pass of their own: the smallest score and the
    // finiteness test are accumulated in four independent lanes, so no chain of dependent additions or minima runs through the positions. The
    // smallest of non-negative scores does not depend on the order it is taken in, and `NaN`
    // scores never win a `<` (they are caught by the finiteness test).
    let mut s_mins = [f64::INFINITY; 4];
    // `0` while every score is finite (`s · 0` is NaN for an infinite or NaN `s`).
    let mut not_finite = [0.0f64; 4];
    for axis in 0..3 {
        // Positions `j..j + 4` in lanes `0..4` (the inner loop is unrolled, so the lanes
        // stay in registers); the last block stops at `n`.
        for j in (1..n).step_by(4) {
            for k in 0..4 {
                let p = j + k;
                if p < n {
                    let n_left = p as f64;
                    // SAFETY: positions `1..n` of both arrays were written above.
                    let (l, r) = unsafe { (la[axis][p].assume_init(), ra[axis][p].assume_init()) };
                    let sc = l as f64 * n_left + r as f64 * (total - n_left);
                    score[axis][p].write(sc);
                    not_finite[k] += sc * 0.0;
                    s_mins[k] = if sc < s_mins[k] { sc } else { s_mins[k] };
                }
            }
        }
    }
    let s_min = s_mins
        .iter()
        .fold(f64::INFINITY, |m, &s| if s < m { s } else { m });
    let finite = not_finite.iter().sum::<f64>() == 0.0;
    let (ct, ci) = (cost.traversal as f64, cost.intersection as f64);
    let areas_ok = parent.iter().all(|&a| a > 0.0 && a.is_finite());
    if !(finite && areas_ok && ct >= 0.0 && ci > 0.0 && ct.is_finite() && ci.is_finite()) {
        return None;
    }
    let y_min = s_min * ci / parent[0];
    if !(y_min >= ct * f64::powi(2.0, -30) && y_min >= f64::powi(2.0, -900) && y_min.is_finite()) {
        return None;
    }
    let window = s_min * (1.0 + f64::powi(2.0, -16));
    let mut best = SplitCandidate::fallback(n);
    for axis in 0..3 {
        for j in 1..n {
            // SAFETY: positions `1..n` of every axis were written above.
            if unsafe { score[axis][j].assume_init() } <= window {
                let n_left = j as f64;
                // SAFETY: as above.
                let (l, r) = unsafe {
                    (
                        la[axis][j].assume_init() as f64,
                        ra[axis][j].assume_init() as f64,
                    )
                };
                let c = SplitCandidate {
                    axis,
                    pos: j,
                    cost: cost.split_cost_counts(parent[axis], l, n_left, r, total - n_left),
                    left_area: l,
                    right_area: r,
                };
                if c.better_than(&best, n) {
                    best = c;
                }
            }
        }
    }
    Some((node, best))
}

/// The node's bounds and its greedy-best split by Eq. 2 (see [`SplitCandidate::better_than`]);
/// for `n == 1` the split is a meaningless fallback.
#[inline]
pub fn best_split(
    bounds: &[Aabb],
    orders: [&[u32]; 3],
    areas: &mut [f32],
    cost: &CostModel,
) -> (Aabb, SplitCandidate) {
    let n = orders[0].len();
    if n == 2 {
        return best_split_of_two(bounds, orders, areas, cost);
    }
    if (3..=SMALL_SWEEP).contains(&n) {
        if let Some(r) = best_split_small(bounds, orders, cost) {
            return r;
        }
    }
    if n >= PAR_AXES_THRESHOLD && rayon::current_num_threads() > 1 {
        // The three axes at once, each with its own suffix buffer. The candidates are totally
        // ordered (`better_than`), so the best of the axes' bests is the sequential best; the
        // node's bounds are those of the last axis's sweep, as sequentially.
        let axis_best = |axis: usize, areas: &mut [f32]| {
            let mut best = SplitCandidate::fallback(n);
            let mut s0 = f64::INFINITY;
            let node = best_on_axis(bounds, orders[axis], axis, areas, cost, &mut best, &mut s0);
            (node, best)
        };
        let (mut a1, mut a2) = (vec![0.0f32; n], vec![0.0f32; n]);
        let ((_, b0), ((_, b1), (node, b2))) = rayon::join(
            || axis_best(0, areas),
            || rayon::join(|| axis_best(1, &mut a1), || axis_best(2, &mut a2)),
        );
        let mut best = SplitCandidate::fallback(n);
        for b in [b0, b1, b2] {
            if b.better_than(&best, n) {
                best = b;
            }
        }
        return (node, best);
    }
    let mut best = SplitCandidate::fallback(n);
    let mut node = Aabb::EMPTY;
    let mut s0 = f64::INFINITY;
    for (axis, order) in orders.iter().enumerate() {
        node = best_on_axis(bounds, order, axis, areas, cost, &mut best, &mut s0);
    }
    (node, best)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::split::orders::sorted_orders;
    use sahara_geom::rng::Pcg32;
    use sahara_geom::Vec3A;

    /// A candidate as bits (exact comparison, NaN included).
    fn cand_bits(c: &SplitCandidate) -> (usize, usize, u64, u64, u64) {
        (
            c.axis,
            c.pos,
            c.cost.to_bits(),
            c.left_area.to_bits(),
            c.right_area.to_bits(),
        )
    }

    /// A box as bits (the sign of a zero included).
    fn box_bits(b: &Aabb) -> [[u32; 3]; 2] {
        [b.min.to_array(), b.max.to_array()].map(|v| v.map(f32::to_bits))
    }

    /// A box on a coarse grid of `scale` (ties; `1e19`: overflowing areas; `3e38`: infinite
    /// extents and NaN areas).
    fn grid_box(rng: &mut Pcg32, steps: u32, scale: f32) -> Aabb {
        let mut q = || (rng.next_u32() % steps) as f32 * 0.5 * scale;
        let lo = Vec3A::new(q(), q(), q()) - scale;
        let size = Vec3A::new(q(), q(), q()) * 0.5;
        Aabb::new(lo, lo + size)
    }

    /// A node of two primitives: [`best_split`]'s shortcut (axis 0 only) returns bit for bit
    /// what sweeping all three axes returns, with the boxes in every relative order, equal,
    /// flat, and with infinite and NaN areas.
    #[test]
    fn two_primitive_shortcut_equals_the_three_axis_search() {
        let mut rng = Pcg32::new(23, 1);
        let cost = CostModel::default();
        for case in 0..4000 {
            let scale = match case % 4 {
                0 => 1e19f32,
                1 => 3e38,
                _ => 1.0,
            };
            // Every fourth case: coordinates from {-1, -0, +0, 1}, so that the two boxes' zero
            // bounds may differ in sign only (the order of the growth decides which is kept).
            let z = |rng: &mut Pcg32| [-1.0f32, -0.0, 0.0, 1.0][(rng.next_u32() % 4) as usize];
            let bounds: Vec<Aabb> = (0..2)
                .map(|_| {
                    if case % 4 == 3 {
                        let a = Vec3A::new(z(&mut rng), z(&mut rng), z(&mut rng));
                        let b = Vec3A::new(z(&mut rng), z(&mut rng), z(&mut rng));
                        return Aabb {
                            min: a.min(b),
                            max: a.max(b),
                        };
                    }
                    grid_box(&mut rng, 5, scale)
                })
                .collect();
            // Each axis's order independently (they need not agree with the centroids here:
            // the shortcut relies only on each order holding both ids).
            let ord = |rng: &mut Pcg32| {
                if rng.next_u32().is_multiple_of(2) {
                    [0u32, 1]
                } else {
                    [1, 0]
                }
            };
            let (o0, o1, o2) = (ord(&mut rng), ord(&mut rng), ord(&mut rng));
            let orders = [&o0[..], &o1[..], &o2[..]];
            let mut areas = vec![0.0f32; 2];
            let (node, best) = best_split(&bounds, orders, &mut areas, &cost);
            let mut full = SplitCandidate::fallback(2);
            let mut s0 = f64::INFINITY;
            let mut full_node = Aabb::EMPTY;
            for (axis, o) in orders.iter().enumerate() {
                full_node =
                    best_on_axis_scalar(&bounds, o, axis, &mut areas, &cost, &mut full, &mut s0);
            }
            assert_eq!(
                box_bits(&node),
                box_bits(&full_node),
                "case {case}: node bounds"
            );
            assert_eq!(cand_bits(&best), cand_bits(&full), "case {case}");
        }
    }

    /// The batched sweep (four positions at a time, x86-64) finds bit for bit the scalar
    /// sweep's candidate, pruning bound, suffix areas and node bounds: orders of every length
    /// (whole blocks and tails), ties, flat boxes, and boxes whose areas overflow to infinity
    /// or NaN (the hard cases), with the bound carried over between axes.
    #[test]
    fn batched_sweep_equals_the_scalar_sweep() {
        let mut rng = Pcg32::new(17, 5);
        for case in 0..600 {
            let n = 1 + case % 37 + (rng.next_u32() % 3) as usize * 40;
            let scale = match case % 5 {
                0 => 1e19f32, // products overflow: infinite areas
                1 => 3e38,    // extents overflow: infinite extents, NaN areas
                _ => 1.0,
            };
            let bounds: Vec<Aabb> = (0..n).map(|_| grid_box(&mut rng, 7, scale)).collect();
            let centroids: Vec<Vec3A> = bounds.iter().map(|b| b.centroid()).collect();
            let ids: Vec<u32> = (0..n as u32).collect();
            let orders = sorted_orders(&centroids, &ids);
            let cost = CostModel::default();
            let (mut a1, mut a2) = (vec![0.0f32; n], vec![0.0f32; n]);
            let (mut b1, mut b2) = (SplitCandidate::fallback(n), SplitCandidate::fallback(n));
            let (mut s1, mut s2) = (f64::INFINITY, f64::INFINITY);
            for (axis, o) in orders.iter().enumerate() {
                let n1 = best_on_axis(&bounds, o, axis, &mut a1, &cost, &mut b1, &mut s1);
                let n2 = best_on_axis_scalar(&bounds, o, axis, &mut a2, &cost, &mut b2, &mut s2);
                assert_eq!(
                    box_bits(&n1),
                    box_bits(&n2),
                    "case {case}, axis {axis}: node"
                );
                let ab = |a: &[f32]| a[1..].iter().map(|x| x.to_bits()).collect::<Vec<_>>();
                assert_eq!(ab(&a1), ab(&a2), "case {case}, axis {axis}: suffix areas");
                assert_eq!(
                    cand_bits(&b1),
                    cand_bits(&b2),
                    "case {case}, axis {axis}, n {n}"
                );
                assert_eq!(s1.to_bits(), s2.to_bits(), "case {case}: pruning bound");
            }
        }
    }

    /// The small-node search gives bit for bit the general search's candidate and node
    /// bounds: every size it takes, boxes on coarse grids (ties of areas and scores), flat
    /// boxes, clusters of tiny boxes far apart (the traversal cost swamps the areas), areas
    /// that overflow, and cost models with a large traversal cost. It must also apply to most
    /// ordinary nodes (else this tests nothing).
    #[test]
    fn small_node_search_equals_the_general_search() {
        let mut rng = Pcg32::new(41, 7);
        let (mut taken, mut ordinary) = (0, 0);
        for case in 0..6000 {
            let n = 3 + case % (SMALL_SWEEP - 2);
            let kind = (case / (SMALL_SWEEP - 2)) % 6;
            let bounds: Vec<Aabb> = (0..n)
                .map(|i| match kind {
                    // Tiny boxes near the origin and (rounded to) points 1e12 away.
                    4 => {
                        let b = grid_box(&mut rng, 5, 1e-20);
                        let off = Vec3A::splat(if i % 2 == 0 { 0.0 } else { 1e12 });
                        Aabb::new(b.min + off, b.max + off)
                    }
                    5 => grid_box(&mut rng, 7, 1e19),
                    _ => grid_box(&mut rng, 3 + kind as u32 * 2, 1.0),
                })
                .collect();
            let centroids: Vec<Vec3A> = bounds.iter().map(|b| b.centroid()).collect();
            let ids: Vec<u32> = (0..n as u32).collect();
            let o = sorted_orders(&centroids, &ids);
            let orders = [&o[0][..], &o[1][..], &o[2][..]];
            let cost = match case % 3 {
                0 => CostModel::default(),
                1 => CostModel {
                    traversal: 3.0,
                    intersection: 1.0,
                },
                // A traversal cost that swamps the areas' differences in rounding (cost
                // ties between different scores): the shortcut must step aside.
                _ => CostModel {
                    traversal: 1e15,
                    intersection: 1.0,
                },
            };
            let mut areas = vec![0.0f32; n];
            let mut general = SplitCandidate::fallback(n);
            let mut s0 = f64::INFINITY;
            let mut node = Aabb::EMPTY;
            for (axis, o) in orders.iter().enumerate() {
                node =
                    best_on_axis_scalar(&bounds, o, axis, &mut areas, &cost, &mut general, &mut s0);
            }
            if kind < 4 && case % 3 != 2 {
                ordinary += 1;
            }
            if let Some((small_node, small)) = best_split_small(&bounds, orders, &cost) {
                taken += usize::from(kind < 4 && case % 3 != 2);
                assert_eq!(box_bits(&small_node), box_bits(&node), "case {case}: node");
                assert_eq!(cand_bits(&small), cand_bits(&general), "case {case}, n {n}");
            }
            let (bs_node, bs) = best_split(&bounds, orders, &mut areas, &cost);
            assert_eq!(
                box_bits(&bs_node),
                box_bits(&node),
                "case {case}: best_split node"
            );
            assert_eq!(
                cand_bits(&bs),
                cand_bits(&general),
                "case {case}: best_split"
            );
        }
        assert!(
            taken * 10 > ordinary * 9,
            "the shortcut took {taken} of {ordinary} ordinary nodes"
        );
    }

    /// The pruned search of [`best_split`] picks exactly the candidate that rating every
    /// position (with [`sweep_axis`]) picks, on boxes with many exact ties.
    #[test]
    fn pruned_best_split_equals_the_full_evaluation() {
        let mut rng = Pcg32::new(3, 9);
        for case in 0..300 {
            // One node large enough for the three-axes-in-parallel path.
            let n = if case == 0 {
                PAR_AXES_THRESHOLD + 100
            } else {
                2 + (rng.next_u32() % 200) as usize
            };
            // Coordinates on a coarse grid (ties of areas and costs), some boxes flat.
            let q = |rng: &mut Pcg32| (rng.next_u32() % 6) as f32 * 0.5;
            let bounds: Vec<Aabb> = (0..n)
                .map(|_| {
                    let lo = Vec3A::new(q(&mut rng), q(&mut rng), q(&mut rng));
                    let size = Vec3A::new(q(&mut rng), q(&mut rng), q(&mut rng)) * 0.5;
                    Aabb::new(lo, lo + size)
                })
                .collect();
            let centroids: Vec<Vec3A> = bounds.iter().map(|b| b.centroid()).collect();
            let ids: Vec<u32> = (0..n as u32).collect();
            let orders = sorted_orders(&centroids, &ids);
            let cost = if case % 2 == 0 {
                CostModel::default()
            } else {
                CostModel {
                    traversal: 3.0,
                    intersection: 1.0,
                }
            };
            let mut areas = vec![0.0f32; n];
            let mut full = SplitCandidate::fallback(n);
            for (axis, order) in orders.iter().enumerate() {
                sweep_axis(&bounds, order, axis, &mut areas, &cost, |c| {
                    if c.better_than(&full, n) {
                        full = c;
                    }
                });
            }
            let (_, pruned) = best_split(
                &bounds,
                [&orders[0], &orders[1], &orders[2]],
                &mut areas,
                &cost,
            );
            assert_eq!(pruned, full, "case {case}, n = {n}");
        }
    }
}
