//! The greedy full-sweep rule (MacDonald & Booth 1990): at every node, the cheapest of the
//! `3 (n - 1)` sweep candidates by Eq. 2 ([`crate::split::sweep::best_split`]), or a leaf when
//! the node holds at most `max_leaf` primitives and no split is cheaper than it. It is the
//! `sweep` builder's rule, the rule of the paper's builders at small nodes, and, costed
//! without storing a node, their temporary subtrees:
//!
//! * [`Greedy`], a [`Rule`] over [`Job`]s (a node's segment of the three sorted orders, which
//!   [`JobStorage`] holds for a whole build);
//! * [`sweep_cost`] (and [`sweep_cost_with_top_levels`], [`sweep_cost_memo`]): the SAH cost
//!   `c(T)` (Eq. 1, relative to the subset's own bounds) of exactly the tree the `sweep`
//!   builder would make over a subset of the primitives, computed bottom-up without allocating
//!   a node ([`cost_only::cost_with_top_levels`] with the same rule). The orders of a subset
//!   come from [`crate::split::orders`].
//!
//! ```
//! use sahara_builders::rules::greedy::{sweep_cost, SweepScratch};
//! use sahara_builders::split::orders::{sorted_orders, Marks};
//! use sahara_builders::sweep::{SweepBuilder, SweepConfig};
//! use sahara_builders::{BuildInput, Builder};
//! use sahara_geom::{Triangle, Vec3A};
//! use sahara_metrics::{sah, CostModel};
//!
//! let tris: Vec<Triangle> = (0..300)
//!     .map(|i| {
//!         let o = Vec3A::new((i % 17) as f32, (i / 17) as f32, (i % 3) as f32);
//!         Triangle::new(o, o + Vec3A::X * 0.7, o + Vec3A::Y * 0.4)
//!     })
//!     .collect();
//! let input = BuildInput::new(&tris, CostModel::default()).unwrap();
//! let bvh = SweepBuilder::default().build(&input).unwrap();
//!
//! // The cost of the same tree, without building it.
//! let all: Vec<u32> = (0..tris.len() as u32).collect();
//! let [mut x, mut y, mut z] = sorted_orders(input.centroids(), &all);
//! let marks = Marks::new(tris.len());
//! let c = sweep_cost(
//!     input.bounds(),
//!     [&mut x, &mut y, &mut z],
//!     &marks,
//!     &input.cost,
//!     SweepConfig::DEFAULT.max_leaf_size,
//!     &mut SweepScratch::new(),
//! );
//! assert!((c.cost - sah(&bvh, &input.cost)).abs() <= 1e-9 * c.cost);
//! ```

use sahara_geom::Aabb;
use sahara_metrics::CostModel;

use crate::cost_only::{self, MemoKey, MemoView, Memoised, SubtreeCost, TopLevels};
use crate::split::orders::{partition_in_place, sorted_orders, Marks};
use crate::split::sweep::{best_split, SplitCandidate};
use crate::topdown::{Rule, Step};

/// The parallel threshold of the `sweep` builder's default configuration (see
/// [`Rule::parallel_threshold`]). 64 under Miri (see `split/mod.rs`).
pub const PARALLEL_THRESHOLD: usize = if cfg!(miri) { 64 } else { 4096 };

/// A node of a build over presorted orders: its segment of the three orders (which end up as
/// the leaves' references) and of the scratch arrays.
pub struct Job<'a> {
    /// The node's primitive ids sorted by centroid along x, y and z.
    pub orders: [&'a mut [u32]; 3],
    /// Partition scratch (as long as the orders).
    pub tmp: &'a mut [u32],
    /// Sweep scratch (as long as the orders).
    pub areas: &'a mut [f32],
}

impl<'a> Job<'a> {
    /// Number of primitives.
    #[inline]
    pub fn len(&self) -> usize {
        self.tmp.len()
    }

    /// True when the node has no primitive.
    pub fn is_empty(&self) -> bool {
        self.tmp.is_empty()
    }

    /// The three orders, read-only.
    #[inline]
    pub fn orders(&self) -> [&[u32]; 3] {
        [&*self.orders[0], &*self.orders[1], &*self.orders[2]]
    }

    /// Partitions the orders by `(axis, pos)` (stable: both sides stay sorted) and returns the
    /// children's jobs.
    pub fn split(mut self, axis: usize, pos: usize, marks: &Marks) -> (Job<'a>, Job<'a>) {
        debug_assert!(pos > 0 && pos < self.len());
        partition_in_place(&mut self.orders, axis, pos, marks, self.tmp);
        let [o0, o1, o2] = self.orders;
        let (l0, r0) = o0.split_at_mut(pos);
        let (l1, r1) = o1.split_at_mut(pos);
        let (l2, r2) = o2.split_at_mut(pos);
        let (lt, rt) = self.tmp.split_at_mut(pos);
        let (la, ra) = self.areas.split_at_mut(pos);
        (
            Job {
                orders: [l0, l1, l2],
                tmp: lt,
                areas: la,
            },
            Job {
                orders: [r0, r1, r2],
                tmp: rt,
                areas: ra,
            },
        )
    }
}

/// The arrays behind the [`Job`]s of a whole build: the three sorted orders and scratch.
pub struct JobStorage {
    orders: [Vec<u32>; 3],
    tmp: Vec<u32>,
    areas: Vec<f32>,
}

impl JobStorage {
    /// The orders of primitives `0..n` (see [`sorted_orders`]).
    pub fn new(n: usize, centroids: &[sahara_geom::Vec3A]) -> Self {
        let ids: Vec<u32> = (0..n as u32).collect();
        Self {
            orders: sorted_orders(centroids, &ids),
            tmp: vec![0; n],
            areas: vec![0.0; n],
        }
    }

    /// The job of the root.
    pub fn root(&mut self) -> Job<'_> {
        let [o0, o1, o2] = &mut self.orders;
        Job {
            orders: [o0, o1, o2],
            tmp: &mut self.tmp,
            areas: &mut self.areas,
        }
    }
}

/// The greedy full-sweep rule: the cheapest of the `3 (n - 1)` sweep candidates by Eq. 2, or a
/// leaf when the node holds at most `max_leaf` primitives and no split is cheaper than it.
pub struct Greedy<'a> {
    /// Bounds of every primitive, by id.
    pub bounds: &'a [Aabb],
    /// The SAH constants.
    pub cost: CostModel,
    /// Largest leaf (at least 1).
    pub max_leaf: usize,
    /// A clear flag per primitive id (for the partitions).
    pub marks: &'a Marks,
    /// See [`Rule::parallel_threshold`].
    pub parallel_threshold: usize,
    /// Cost-only builds: subtree costs shared with other cost-only builds over the same
    /// primitives (see [`cost_only::SubtreeMemo`]).
    pub memo: Option<MemoView<'a>>,
}

impl<'a> Greedy<'a> {
    /// The rule's decision for a node (a free function of the job, so that other rules can
    /// fall back to it).
    #[inline]
    pub fn decide(&self, job: Job<'a>) -> Step<Job<'a>> {
        let n = job.len();
        if n == 1 {
            let bounds = self.bounds[job.orders[0][0] as usize];
            return Step::Leaf { bounds, task: job };
        }
        let orders = [&*job.orders[0], &*job.orders[1], &*job.orders[2]];
        let (node, best) = best_split(self.bounds, orders, &mut *job.areas, &self.cost);
        if is_leaf(n, &best, &self.cost, self.max_leaf) {
            Step::Leaf {
                bounds: node,
                task: job,
            }
        } else {
            let (left, right) = job.split(best.axis, best.pos, self.marks);
            Step::Split {
                bounds: node,
                left,
                right,
            }
        }
    }
}

impl<'a> Rule for Greedy<'a> {
    type Task = Job<'a>;
    type Scratch = ();

    #[inline]
    fn size(&self, job: &Job<'a>) -> usize {
        job.len()
    }

    #[inline]
    fn split(&self, job: Job<'a>, _: &mut ()) -> Step<Job<'a>> {
        self.decide(job)
    }

    fn leaf_refs(&self, job: &Job<'a>, out: &mut Vec<u32>) {
        out.extend_from_slice(job.orders[0]);
    }

    fn parallel_threshold(&self) -> usize {
        self.parallel_threshold
    }
}

impl<'a> Memoised for Greedy<'a> {
    #[inline]
    fn memo(&self, job: &Job<'a>) -> Option<(MemoView<'_>, MemoKey)> {
        // A sweep subtree is a function of its set: any subset's orders are the global sorted
        // orders restricted to it.
        let m = self.memo?;
        (job.len() >= m.own.min_size()).then(|| (m, m.own.key(job.orders[0])))
    }

    #[inline]
    fn child_memo<'s>(
        &'s self,
        parent: &(MemoView<'s>, MemoKey),
        left: &Job<'a>,
        right: &Job<'a>,
    ) -> [Option<(MemoView<'s>, MemoKey)>; 2] {
        // Only the smaller child is hashed; the larger one's key is the rest of the parent's.
        let (m, key) = *parent;
        let min = m.own.min_size();
        let left_smaller = left.len() <= right.len();
        let (small, big) = if left_smaller {
            (left, right)
        } else {
            (right, left)
        };
        if big.len() < min {
            return [None, None];
        }
        let small_key = m.own.key(small.orders[0]);
        let big_key = key.without(&small_key);
        let small_memo = (small.len() >= min).then_some((m, small_key));
        let big_memo = Some((m, big_key));
        if left_smaller {
            [small_memo, big_memo]
        } else {
            [big_memo, small_memo]
        }
    }
}

/// The leaf rule of the greedy builder: at most `max_leaf_size` primitives and no split
/// cheaper than the leaf.
#[inline]
pub fn is_leaf(n: usize, best: &SplitCandidate, cost: &CostModel, max_leaf: usize) -> bool {
    n <= 1 || (n <= max_leaf && best.cost >= cost.leaf_cost(n))
}

/// Reusable buffers of [`sweep_cost`] (they grow to the largest subset seen).
#[derive(Debug, Default)]
pub struct SweepScratch {
    tmp: Vec<u32>,
    areas: Vec<f32>,
}

impl SweepScratch {
    /// Empty buffers.
    pub fn new() -> Self {
        Self::default()
    }
}

/// The SAH cost `c(T)` (Eq. 1, relative to the subset's bounds) of the tree the `sweep` builder
/// with this `max_leaf_size` would build over the subset whose three sorted orders are given
/// (see [`sorted_orders`] and [`crate::split::orders::split_orders`]), computed bottom-up during the recursion:
/// no node is allocated, and the only memory used is `scratch` (reused between calls) and the
/// orders themselves, which are permuted in place (each stays a permutation of the subset).
///
/// `bounds[id]` is the box of primitive `id`; `marks` must cover every id with its flag clear
/// (flags are clear again on return, and calls on disjoint subsets may share one `Marks`
/// concurrently). Returns zero cost and area for an empty subset.
///
/// The decisions (split costs, tie-breaks, leaf rule) are exactly those of the `sweep` builder, so
/// the result equals `sahara_metrics::sah` of the real tree up to rounding of the summation.
pub fn sweep_cost(
    bounds: &[Aabb],
    orders: [&mut [u32]; 3],
    marks: &Marks,
    cost: &CostModel,
    max_leaf_size: usize,
    scratch: &mut SweepScratch,
) -> SubtreeCost {
    sweep_cost_with_top_levels(bounds, orders, marks, cost, max_leaf_size, scratch).0
}

/// [`sweep_cost`], and the costs of the top levels of the tree (see
/// [`cost_only::cost_with_top_levels`]): a node's split there is its subset's greedy split by
/// Eq. 2, so its children's costs are the costs of the temporaries of that split's sides.
pub fn sweep_cost_with_top_levels(
    bounds: &[Aabb],
    orders: [&mut [u32]; 3],
    marks: &Marks,
    cost: &CostModel,
    max_leaf_size: usize,
    scratch: &mut SweepScratch,
) -> (SubtreeCost, TopLevels) {
    sweep_cost_memo(bounds, orders, marks, cost, max_leaf_size, scratch, None)
}

/// [`sweep_cost_with_top_levels`] with the subtree costs of other cost-only sweep builds over
/// the same `bounds`, `cost` and `max_leaf_size` ([`cost_only::SubtreeMemo`]): subtrees over a
/// set of primitives found in `memo` are not built again, and the subtrees this build costs are
/// added to it. The same values as without the memo (but for a key collision, about 2^-128).
pub fn sweep_cost_memo(
    bounds: &[Aabb],
    orders: [&mut [u32]; 3],
    marks: &Marks,
    cost: &CostModel,
    max_leaf_size: usize,
    scratch: &mut SweepScratch,
    memo: Option<MemoView<'_>>,
) -> (SubtreeCost, TopLevels) {
    let n = orders[0].len();
    assert!(orders[1].len() == n && orders[2].len() == n);
    if n == 0 {
        return (SubtreeCost::ZERO, TopLevels::NONE);
    }
    if scratch.tmp.len() < n {
        scratch.tmp.resize(n, 0);
        scratch.areas.resize(n, 0.0);
    }
    let rule = Greedy {
        bounds,
        cost: *cost,
        max_leaf: max_leaf_size.max(1),
        marks,
        parallel_threshold: usize::MAX,
        memo,
    };
    let job = Job {
        orders,
        tmp: &mut scratch.tmp[..n],
        areas: &mut scratch.areas[..n],
    };
    cost_only::cost_with_top_levels(&rule, job, cost, &mut ())
}

#[cfg(test)]
mod memo_tests {
    use super::*;
    use crate::cost_only::SubtreeMemo;
    use sahara_geom::rng::Pcg32;
    use sahara_geom::Vec3A;

    /// The cost-only sweep build over the primitives `set` of `all` (labelled `0..` in the
    /// order of `set`, as the paper's builders relabel a node), with `memo` or without.
    fn cost_of(all: &[Aabb], set: &[u32], memo: Option<MemoView>) -> (SubtreeCost, TopLevels) {
        let bounds: Vec<Aabb> = set.iter().map(|&g| all[g as usize]).collect();
        let cents: Vec<Vec3A> = bounds.iter().map(Aabb::centroid).collect();
        let ids: Vec<u32> = (0..set.len() as u32).collect();
        let [mut x, mut y, mut z] = sorted_orders(&cents, &ids);
        sweep_cost_memo(
            &bounds,
            [&mut x, &mut y, &mut z],
            &Marks::new(set.len()),
            &CostModel::default(),
            8,
            &mut SweepScratch::new(),
            memo,
        )
    }

    fn bits(c: &(SubtreeCost, TopLevels)) -> String {
        format!("{:?} {:?}", (c.0.cost.to_bits(), c.0.area.to_bits()), c.1)
    }

    /// Neighbouring sets (two prefixes of the x order that differ by one primitive) and a
    /// relabelled set: the memoised builds give the fresh builds' costs and top levels bit for
    /// bit, the neighbour reuses the first build's subtrees, and a memo labelled otherwise
    /// finds them by their global ids.
    #[test]
    fn memoised_costs_equal_fresh_costs_and_are_reused() {
        let mut r = Pcg32::new(7, 3);
        let all: Vec<Aabb> = (0..3000)
            .map(|_| {
                let o = Vec3A::new(r.next_f32(), r.next_f32(), r.next_f32()) * 100.0;
                Aabb::new(o, o + Vec3A::new(r.next_f32(), r.next_f32(), r.next_f32()))
            })
            .collect();
        let cents: Vec<Vec3A> = all.iter().map(Aabb::centroid).collect();
        let every: Vec<u32> = (0..all.len() as u32).collect();
        let [xs, _, zs] = sorted_orders(&cents, &every);
        let big = &xs[..1501];
        let small = &xs[..1500];
        let in_z =
            |set: &[u32]| -> Vec<u32> { zs.iter().copied().filter(|g| set.contains(g)).collect() };
        // The build over `labels` (a set in some order) with a memo of its own that reads
        // `other`: equal to the fresh build over `set`; returns the memo.
        let check = |labels: &[u32], set: &[u32], other: Option<&SubtreeMemo>| {
            let own = SubtreeMemo::new(16, labels);
            let view = MemoView { own: &own, other };
            let memoised = cost_of(&all, labels, Some(view));
            assert_eq!(bits(&memoised), bits(&cost_of(&all, set, None)));
            own
        };

        let parent = check(big, big, None);
        let stored = parent.len();
        assert!(stored > 20, "{stored} subtrees stored");
        // The neighbour, labelled as the first set and in z order: it finds the first build's
        // subtrees by their primitives, not by its labels.
        for labels in [small.to_vec(), in_z(small)] {
            let own = check(&labels, small, Some(&parent));
            assert!(
                own.len() * 3 < stored,
                "the neighbour stored {} subtrees of its own (the first build {stored})",
                own.len()
            );
        }
        // The first set labelled in z order: its whole tree is found at the root.
        let own = check(&in_z(big), big, Some(&parent));
        assert_eq!(own.len(), 0, "the relabelled build missed the memo");
    }

    /// The children's keys the rule derives from their parent's (the smaller child hashed,
    /// the larger one the rest) are the keys of the children's own sets, and a child below
    /// the memo's smallest size is not keyed.
    #[test]
    fn derived_child_keys_are_the_childrens_keys() {
        let mut r = Pcg32::new(5, 9);
        for case in 0..60 {
            let n = 20 + (r.next_u32() % 400) as usize;
            let bounds: Vec<Aabb> = (0..n)
                .map(|_| {
                    let o = Vec3A::new(r.next_f32(), r.next_f32(), r.next_f32()) * 10.0;
                    Aabb::new(o, o + Vec3A::splat(0.1))
                })
                .collect();
            let cents: Vec<Vec3A> = bounds.iter().map(Aabb::centroid).collect();
            let global: Vec<u32> = (0..n as u32).map(|i| i * 7 + 3).collect();
            let memo = SubtreeMemo::new(16, &global);
            let marks = Marks::new(n);
            let rule = Greedy {
                bounds: &bounds,
                cost: CostModel::default(),
                max_leaf: 8,
                marks: &marks,
                parallel_threshold: usize::MAX,
                memo: Some(MemoView {
                    own: &memo,
                    other: None,
                }),
            };
            let mut storage = JobStorage::new(n, &cents);
            let job = storage.root();
            let parent = rule.memo(&job).expect("the root is keyed");
            let axis = case % 3;
            let pos = 1 + (r.next_u32() as usize) % (n - 1);
            let (left, right) = job.split(axis, pos, &marks);
            let derived = rule.child_memo(&parent, &left, &right);
            for (child, got) in [(&left, derived[0]), (&right, derived[1])] {
                let want = rule.memo(child).map(|m| m.1);
                assert_eq!(
                    got.map(|m| m.1),
                    want,
                    "case {case}: n {n}, split {axis}/{pos}"
                );
            }
        }
    }
}
