//! Full-sweep SAH construction (MacDonald & Booth 1990, "Heuristics for ray tracing using
//! space subdivision").
//!
//! The primitive indices are sorted by centroid once per axis. At every node a right-to-left
//! sweep over each of the three orders stores the suffix areas, and a left-to-right sweep
//! evaluates the greedy cost of Eq. 2 of Wodniok & Goesele (both children assumed to stay
//! leaves) at each of the `n - 1` positions. The cheapest of the `3 (n - 1)` candidates wins;
//! exact cost ties go to the more balanced split (smaller `i² + (n - i)²`), then to the lower
//! axis, then to the lower position, so the result never depends on evaluation order. The two
//! orders that were not split are kept sorted by a stable partition with a flag array, so the
//! whole build is `O(N log N)` for balanced trees.
//!
//! A node becomes a leaf when it holds at most [`SweepConfig::max_leaf_size`] primitives and no
//! split is cheaper than the leaf cost `n c_i`; a larger node is always split, by the cheapest
//! candidate (where all centroids coincide the sorted order still splits by position, and the
//! balance tie-break makes that a median split).
//!
//! # The cost-only build
//!
//! Besides [`SweepBuilder`], the module exposes the pieces the temporary-subtree builders of
//! Wodniok & Goesele need: [`sweep_cost`] returns the SAH cost `c(T)` (Eq. 1, relative to the
//! subset's own bounds) of exactly the tree the builder would make over a subset of the
//! primitives, computed bottom-up without allocating a node; [`split_orders`] derives the
//! sorted orders of both sides of a candidate split from the sorted orders of a node, and
//! [`sorted_orders`] produces the orders of any subset.
//!
//! ```
//! use sahara_builders::sweep::{sorted_orders, sweep_cost, Marks, SweepBuilder, SweepConfig, SweepScratch};
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
//! bvh.validate(&tris).unwrap();
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

use std::cmp::Ordering as CmpOrdering;
use std::sync::atomic::{AtomicBool, Ordering};

use rayon::prelude::*;
use sahara_bvh::{Bvh, Node};
use sahara_geom::{Aabb, Vec3A};
use sahara_metrics::CostModel;

use crate::registry::Entry;
use crate::{BuildError, BuildInput, Builder};

/// Configuration of the full-sweep SAH builder.
#[derive(Clone, Copy, Debug, PartialEq, Eq, serde::Serialize, serde::Deserialize)]
pub struct SweepConfig {
    /// Largest leaf (at least 1): a node with more primitives is always split. Smaller nodes
    /// become leaves when no split is cheaper than the leaf (Eq. 2 against `n c_i`).
    /// Default 8.
    pub max_leaf_size: usize,
    /// Subtrees with more primitives than this are handed to other rayon workers; smaller
    /// ones are built serially. It changes only the speed, never the tree. Default 4096.
    pub parallel_threshold: usize,
}

impl Default for SweepConfig {
    fn default() -> Self {
        Self::DEFAULT
    }
}

impl SweepConfig {
    /// Leaves of at most 8 primitives: the reference builder the paper compares against.
    pub const DEFAULT: SweepConfig = SweepConfig {
        max_leaf_size: 8,
        parallel_threshold: 4096,
    };
    /// Leaves of at most 4 primitives, matching the leaf width of the SIMD traversal kernels.
    pub const SMALL_LEAVES: SweepConfig = SweepConfig {
        max_leaf_size: 4,
        ..Self::DEFAULT
    };

    /// This configuration with another maximum leaf size.
    #[must_use]
    pub const fn with_max_leaf_size(mut self, max_leaf_size: usize) -> Self {
        self.max_leaf_size = max_leaf_size;
        self
    }

    /// Checks the ranges of the fields.
    pub fn validate(&self) -> Result<(), BuildError> {
        if self.max_leaf_size == 0 {
            return Err(BuildError::InvalidConfig(
                "sweep: max_leaf_size must be at least 1".into(),
            ));
        }
        Ok(())
    }
}

/// The full-sweep SAH builder, registered as `"sweep"`.
#[derive(Clone, Debug, Default)]
pub struct SweepBuilder {
    /// Its configuration.
    pub config: SweepConfig,
}

impl SweepBuilder {
    /// A builder with the given configuration.
    pub fn new(config: SweepConfig) -> Self {
        Self { config }
    }
}

impl Builder for SweepBuilder {
    fn name(&self) -> &str {
        "sweep"
    }

    fn describe(&self) -> String {
        format!(
            "full-sweep SAH (MacDonald & Booth), max leaf {}",
            self.config.max_leaf_size
        )
    }

    fn build(&self, input: &BuildInput) -> Result<Bvh, BuildError> {
        self.config.validate()?;
        if input.is_empty() {
            return Ok(Bvh::empty());
        }
        check_size(input)?;
        let ctx = BuildCtx::new(
            input,
            self.config.max_leaf_size,
            self.config.parallel_threshold,
        );
        let mut storage = Storage::new(input.centroids());
        {
            let job = storage.root_job();
            rayon::scope(|s| drive(s, job, &ctx));
        }
        Ok(storage.finish())
    }
}

/// Registry entries of this module.
pub fn registry_entries() -> Vec<Entry> {
    vec![Entry {
        name: "sweep",
        summary: "full-sweep SAH (MacDonald & Booth 1990), the reference greedy builder",
        spatial: false,
        small_inputs_only: false,
        max_practical_triangles: None,
        make: || Box::new(SweepBuilder::default()),
    }]
}

// ---------------------------------------------------------------------------------------------
// Public building blocks of the cost-only build.

/// One flag per primitive id, shareable between threads that work on disjoint sets of ids
/// (relaxed atomics, which cost nothing on common hardware).
///
/// [`split_orders`] and [`sweep_cost`] set flags while they partition and clear them again
/// before returning, so a `Marks` with every flag clear can be reused for any number of calls,
/// and concurrent calls on disjoint id sets may share one.
pub struct Marks {
    flags: Vec<AtomicBool>,
}

impl Marks {
    /// `len` clear flags, for ids `0..len`.
    pub fn new(len: usize) -> Self {
        Self {
            flags: (0..len).map(|_| AtomicBool::new(false)).collect(),
        }
    }

    /// Makes room for ids `0..len` (new flags are clear; never shrinks).
    pub fn reserve_ids(&mut self, len: usize) {
        if self.flags.len() < len {
            self.flags.resize_with(len, || AtomicBool::new(false));
        }
    }

    /// Number of flags.
    pub fn len(&self) -> usize {
        self.flags.len()
    }

    /// True when there is no flag.
    pub fn is_empty(&self) -> bool {
        self.flags.is_empty()
    }

    /// Sets flag `id` to `value`.
    #[inline]
    pub fn set(&self, id: u32, value: bool) {
        self.flags[id as usize].store(value, Ordering::Relaxed);
    }

    /// Flag `id`.
    #[inline]
    pub fn get(&self, id: u32) -> bool {
        self.flags[id as usize].load(Ordering::Relaxed)
    }
}

impl Default for Marks {
    /// No flags (see [`Marks::reserve_ids`]).
    fn default() -> Self {
        Self::new(0)
    }
}

impl std::fmt::Debug for Marks {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("Marks").field("len", &self.len()).finish()
    }
}

/// A candidate split of a node whose primitives are sorted by centroid along `axis`: the first
/// `pos` primitives of that order go left, the others right.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SplitCandidate {
    /// The axis whose sorted order is split.
    pub axis: usize,
    /// Number of primitives on the left (`1..n`).
    pub pos: usize,
    /// Its greedy cost (Eq. 2).
    pub cost: f64,
    /// Half the surface area of the left side's bounds.
    pub left_area: f64,
    /// Half the surface area of the right side's bounds.
    pub right_area: f64,
}

impl SplitCandidate {
    /// True when `self` beats `other` for a node of `n` primitives: lower cost, then (on an
    /// exact tie) the more balanced split (smaller `|2 pos - n|`, equivalent to smaller
    /// `pos² + (n - pos)²`), then the lower axis, then the lower position. A total order on
    /// the candidates of a node, so choices never depend on evaluation order.
    #[inline]
    pub fn better_than(&self, other: &SplitCandidate, n: usize) -> bool {
        // Fast paths, equivalent to `total_cmp` for these operands (it differs from `<` only
        // on NaN and on -0.0 == +0.0, which fall through).
        if self.cost < other.cost {
            return true;
        }
        if self.cost > other.cost {
            return false;
        }
        match self.cost.total_cmp(&other.cost) {
            CmpOrdering::Less => true,
            CmpOrdering::Greater => false,
            CmpOrdering::Equal => {
                (imbalance(self.pos, n), self.axis, self.pos)
                    < (imbalance(other.pos, n), other.axis, other.pos)
            }
        }
    }

    /// The stand-in a sweep starts from: the median split of the x order with infinite cost.
    /// Any real candidate with a finite cost beats it; it is kept only when every cost is
    /// infinite or NaN (boxes whose area overflows), which still gives a valid tree.
    pub(crate) fn fallback(n: usize) -> SplitCandidate {
        SplitCandidate {
            axis: 0,
            pos: n / 2,
            cost: f64::INFINITY,
            left_area: f64::INFINITY,
            right_area: f64::INFINITY,
        }
    }
}

#[inline]
fn imbalance(pos: usize, n: usize) -> usize {
    (2 * pos).abs_diff(n)
}

/// The SAH cost of a (temporary) subtree and the half area of its root's bounds.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SubtreeCost {
    /// `c(T)` of Eq. 1, relative to the subtree root's own bounds (the expected cost of a ray
    /// that hits the root's box).
    pub cost: f64,
    /// Half the surface area of the root's bounds (as `f64`).
    pub area: f64,
}

/// The three sorted orders of a subset of primitives: `ids` sorted by centroid along x, y and
/// z, each by the total order of `f32::total_cmp` with ties broken by the primitive id. These
/// are the orders [`sweep_cost`] and the builders work on. Runs the three sorts in parallel.
pub fn sorted_orders(centroids: &[Vec3A], ids: &[u32]) -> [Vec<u32>; 3] {
    let sort_axis = |axis: usize| {
        let mut keyed: Vec<u64> = ids
            .iter()
            .map(|&i| ((float_key(centroids[i as usize][axis]) as u64) << 32) | i as u64)
            .collect();
        if keyed.len() > 1 << 14 {
            keyed.par_sort_unstable();
        } else {
            keyed.sort_unstable();
        }
        keyed.into_iter().map(|k| k as u32).collect::<Vec<u32>>()
    };
    let (x, (y, z)) = rayon::join(
        || sort_axis(0),
        || rayon::join(|| sort_axis(1), || sort_axis(2)),
    );
    [x, y, z]
}

/// An unsigned key ordered like `f32::total_cmp`.
#[inline]
fn float_key(x: f32) -> u32 {
    let b = x.to_bits();
    if b & 0x8000_0000 != 0 {
        !b
    } else {
        b | 0x8000_0000
    }
}

/// Splits the sorted orders of a node by a candidate: the first `pos` ids of `orders[axis]` go
/// left, the rest right; `left[a]` and `right[a]` receive the ids of each side in the order of
/// `orders[a]` (a stable partition, so they stay sorted). `left` slices must hold `pos` ids and
/// `right` slices `n - pos`. `marks` must cover every id and have the ids' flags clear; they
/// are clear again on return.
///
/// # Panics
/// If the slice lengths do not match, or `pos` is not in `1..n`.
pub fn split_orders(
    orders: [&[u32]; 3],
    axis: usize,
    pos: usize,
    marks: &Marks,
    left: [&mut [u32]; 3],
    right: [&mut [u32]; 3],
) {
    let n = orders[axis].len();
    assert!(pos > 0 && pos < n, "split position {pos} outside 1..{n}");
    for &id in &orders[axis][..pos] {
        marks.set(id, true);
    }
    for ((order, l), r) in orders.iter().zip(left).zip(right) {
        assert_eq!(order.len(), n);
        assert_eq!(l.len(), pos);
        assert_eq!(r.len(), n - pos);
        let (mut li, mut ri) = (0, 0);
        for &id in order.iter() {
            if marks.get(id) {
                l[li] = id;
                li += 1;
            } else {
                r[ri] = id;
                ri += 1;
            }
        }
        assert_eq!(li, pos, "orders do not hold the same ids");
    }
    for &id in &orders[axis][..pos] {
        marks.set(id, false);
    }
}

/// Reusable buffers of [`sweep_cost`] (they grow to the largest subset seen).
#[derive(Debug, Default)]
pub struct SweepScratch {
    tmp: Vec<u32>,
    areas: Vec<f32>,
    tasks: Vec<Task>,
    values: Vec<SubtreeCost>,
}

impl SweepScratch {
    /// Empty buffers.
    pub fn new() -> Self {
        Self::default()
    }
}

#[derive(Clone, Copy, Debug)]
enum Task {
    /// Decide the node over positions `start..end` of the orders.
    Visit(usize, usize),
    /// Combine the two costs on top of the value stack into their parent's (of that area).
    Combine(f64),
}

/// The SAH cost `c(T)` (Eq. 1, relative to the subset's bounds) of the tree [`SweepBuilder`]
/// with this `max_leaf_size` would build over the subset whose three sorted orders are given
/// (see [`sorted_orders`] and [`split_orders`]), computed bottom-up during the recursion:
/// no node is allocated, and the only memory used is `scratch` (reused between calls) and the
/// orders themselves, which are permuted in place (each stays a permutation of the subset).
///
/// `bounds[id]` is the box of primitive `id`; `marks` must cover every id with its flag clear
/// (flags are clear again on return, and calls on disjoint subsets may share one `Marks`
/// concurrently). Returns zero cost and area for an empty subset.
///
/// The decisions (split costs, tie-breaks, leaf rule) are exactly those of [`SweepBuilder`], so
/// the result equals `sahara_metrics::sah` of the real tree up to rounding of the summation.
pub fn sweep_cost(
    bounds: &[Aabb],
    orders: [&mut [u32]; 3],
    marks: &Marks,
    cost: &CostModel,
    max_leaf_size: usize,
    scratch: &mut SweepScratch,
) -> SubtreeCost {
    let n = orders[0].len();
    assert!(orders[1].len() == n && orders[2].len() == n);
    let max_leaf_size = max_leaf_size.max(1);
    if n == 0 {
        return SubtreeCost {
            cost: 0.0,
            area: 0.0,
        };
    }
    let SweepScratch {
        tmp,
        areas,
        tasks,
        values,
    } = scratch;
    if tmp.len() < n {
        tmp.resize(n, 0);
        areas.resize(n, 0.0);
    }
    tasks.clear();
    values.clear();
    let [o0, o1, o2] = orders;
    tasks.push(Task::Visit(0, n));
    while let Some(task) = tasks.pop() {
        match task {
            Task::Visit(s, e) => {
                let m = e - s;
                if m == 1 {
                    values.push(SubtreeCost {
                        cost: cost.leaf_cost(1),
                        area: bounds[o0[s] as usize].half_area() as f64,
                    });
                    continue;
                }
                let mut seg = [&mut o0[s..e], &mut o1[s..e], &mut o2[s..e]];
                let (node, best) = best_split(
                    bounds,
                    [&*seg[0], &*seg[1], &*seg[2]],
                    &mut areas[..m],
                    cost,
                );
                let area = node.half_area() as f64;
                if is_leaf(m, &best, cost, max_leaf_size) {
                    values.push(SubtreeCost {
                        cost: cost.leaf_cost(m),
                        area,
                    });
                    continue;
                }
                partition_in_place(&mut seg, best.axis, best.pos, marks, &mut tmp[..m]);
                tasks.push(Task::Combine(area));
                tasks.push(Task::Visit(s + best.pos, e));
                tasks.push(Task::Visit(s, s + best.pos));
            }
            Task::Combine(area) => {
                let r = values.pop().expect("right cost");
                let l = values.pop().expect("left cost");
                values.push(SubtreeCost {
                    cost: cost.inner_cost(area, l.area, l.cost, r.area, r.cost),
                    area,
                });
            }
        }
    }
    debug_assert_eq!(values.len(), 1);
    values.pop().expect("root cost")
}

// ---------------------------------------------------------------------------------------------
// Crate-internal machinery shared with the temporary-subtree and look-ahead builders.

/// Sweeps one sorted order: suffix areas right to left into `areas`, then Eq. 2 at each of the
/// `n - 1` positions left to right, handing each candidate to `visit`. Returns the bounds of
/// all the primitives of the order. `n >= 1`.
#[inline]
pub(crate) fn sweep_axis<F: FnMut(SplitCandidate)>(
    bounds: &[Aabb],
    order: &[u32],
    axis: usize,
    areas: &mut [f32],
    cost: &CostModel,
    mut visit: F,
) -> Aabb {
    let n = order.len();
    let areas = &mut areas[..n];
    let mut acc = Aabb::EMPTY;
    for j in (1..n).rev() {
        acc.grow_aabb(&bounds[order[j] as usize]);
        areas[j] = acc.half_area();
    }
    acc.grow_aabb(&bounds[order[0] as usize]);
    let parent_area = acc.half_area() as f64;
    let mut left = Aabb::EMPTY;
    for j in 1..n {
        left.grow_aabb(&bounds[order[j - 1] as usize]);
        let left_area = left.half_area() as f64;
        let right_area = areas[j] as f64;
        visit(SplitCandidate {
            axis,
            pos: j,
            cost: cost.split_cost(parent_area, left_area, j, right_area, n - j),
            left_area,
            right_area,
        });
    }
    acc
}

/// The node's bounds and its greedy-best split (see [`SplitCandidate::better_than`]); for
/// `n == 1` the split is a meaningless fallback.
#[inline]
pub(crate) fn best_split(
    bounds: &[Aabb],
    orders: [&[u32]; 3],
    areas: &mut [f32],
    cost: &CostModel,
) -> (Aabb, SplitCandidate) {
    let n = orders[0].len();
    let mut best = SplitCandidate::fallback(n);
    let mut node = Aabb::EMPTY;
    for (axis, order) in orders.iter().enumerate() {
        node = sweep_axis(bounds, order, axis, areas, cost, |c| {
            if c.better_than(&best, n) {
                best = c;
            }
        });
    }
    (node, best)
}

/// The leaf rule of the greedy builder: at most `max_leaf_size` primitives and no split
/// cheaper than the leaf.
#[inline]
pub(crate) fn is_leaf(n: usize, best: &SplitCandidate, cost: &CostModel, max_leaf: usize) -> bool {
    n <= 1 || (n <= max_leaf && best.cost >= cost.leaf_cost(n))
}

/// Stable partition of the node's orders by a split: the first `pos` ids of `orders[axis]`
/// stay in front on every axis, in their order. `tmp.len() >= n`.
pub(crate) fn partition_in_place(
    orders: &mut [&mut [u32]; 3],
    axis: usize,
    pos: usize,
    marks: &Marks,
    tmp: &mut [u32],
) {
    for &id in orders[axis][..pos].iter() {
        marks.set(id, true);
    }
    for (b, order) in orders.iter_mut().enumerate() {
        if b == axis {
            continue;
        }
        let (mut l, mut r) = (0, 0);
        for j in 0..order.len() {
            let id = order[j];
            if marks.get(id) {
                order[l] = id;
                l += 1;
            } else {
                tmp[r] = id;
                r += 1;
            }
        }
        debug_assert_eq!(l, pos);
        order[pos..].copy_from_slice(&tmp[..r]);
    }
    for &id in orders[axis][..pos].iter() {
        marks.set(id, false);
    }
}

/// What every top-down builder over presorted orders shares: the input, the cost model, the
/// leaf limit and a flag per primitive.
pub(crate) struct BuildCtx<'a> {
    pub bounds: &'a [Aabb],
    pub centroids: &'a [Vec3A],
    pub cost: CostModel,
    pub max_leaf: usize,
    pub marks: Marks,
    pub parallel_threshold: usize,
}

impl<'a> BuildCtx<'a> {
    pub fn new(input: &'a BuildInput, max_leaf: usize, parallel_threshold: usize) -> Self {
        Self {
            bounds: input.bounds(),
            centroids: input.centroids(),
            cost: input.cost,
            max_leaf: max_leaf.max(1),
            marks: Marks::new(input.len()),
            parallel_threshold: parallel_threshold.max(1),
        }
    }
}

/// Node slots (`2N - 1`) are addressed by `u32`: rejects inputs too large for that.
pub(crate) fn check_size(input: &BuildInput) -> Result<(), BuildError> {
    if input.len() > (u32::MAX / 2) as usize {
        return Err(BuildError::TooManyPrimitives(input.len()));
    }
    Ok(())
}

/// Marks a node slot that no node uses (removed by [`Storage::finish`]).
const HOLE: u32 = u32::MAX;

/// The arrays of a build: the three orders (which end up as the leaves' references), scratch,
/// and `2N - 1` node slots. A subtree over `n` primitives owns `2n - 1` consecutive slots: its
/// root, then its left subtree's, then its right subtree's, so disjoint subtrees can be built on
/// any thread and the slots are in depth-first order; slots a subtree does not need (its leaves
/// hold several primitives) are holes that [`Storage::finish`] squeezes out.
pub(crate) struct Storage {
    orders: [Vec<u32>; 3],
    tmp: Vec<u32>,
    areas: Vec<f32>,
    nodes: Vec<Node>,
}

impl Storage {
    pub fn new(centroids: &[Vec3A]) -> Self {
        let n = centroids.len();
        let ids: Vec<u32> = (0..n as u32).collect();
        let hole = Node {
            count: HOLE,
            ..Node::default()
        };
        Self {
            orders: sorted_orders(centroids, &ids),
            tmp: vec![0; n],
            areas: vec![0.0; n],
            nodes: vec![hole; 2 * n - 1],
        }
    }

    pub fn root_job(&mut self) -> Job<'_> {
        let [o0, o1, o2] = &mut self.orders;
        Job {
            orders: [o0, o1, o2],
            tmp: &mut self.tmp,
            areas: &mut self.areas,
            nodes: &mut self.nodes,
            first: 0,
            slot: 0,
        }
    }

    pub fn finish(self) -> Bvh {
        let mut map = vec![0u32; self.nodes.len()];
        let mut k = 0u32;
        for (m, node) in map.iter_mut().zip(&self.nodes) {
            *m = k;
            if node.count != HOLE {
                k += 1;
            }
        }
        let nodes = self
            .nodes
            .iter()
            .filter(|n| n.count != HOLE)
            .map(|n| {
                let mut n = *n;
                if !n.is_leaf() {
                    n.index = map[n.index as usize];
                }
                n
            })
            .collect();
        let [refs, _, _] = self.orders;
        Bvh {
            nodes,
            prim_indices: refs,
            spatial_splits: false,
        }
    }
}

/// A node to build: its segment of the three orders (and of the scratch arrays), its node
/// slots, the position of its segment in the orders (= its first reference) and the index of
/// its first slot.
pub(crate) struct Job<'a> {
    pub orders: [&'a mut [u32]; 3],
    pub tmp: &'a mut [u32],
    pub areas: &'a mut [f32],
    pub nodes: &'a mut [Node],
    pub first: usize,
    pub slot: usize,
}

impl<'a> Job<'a> {
    #[inline]
    pub fn len(&self) -> usize {
        self.tmp.len()
    }

    /// Writes the node as a leaf over its whole segment.
    pub fn make_leaf(self, bounds: &Aabb) {
        let n = self.len() as u32;
        self.nodes[0] = Node::leaf(bounds, self.first as u32, n);
    }

    /// Writes the node as an inner node split by `(axis, pos)`, partitions the orders, and
    /// returns the children's jobs.
    pub fn split(
        mut self,
        axis: usize,
        pos: usize,
        bounds: &Aabb,
        marks: &Marks,
    ) -> (Job<'a>, Job<'a>) {
        debug_assert!(pos > 0 && pos < self.len());
        partition_in_place(&mut self.orders, axis, pos, marks, self.tmp);
        self.nodes[0] = Node::inner(bounds, (self.slot + 2 * pos) as u32);
        let [o0, o1, o2] = self.orders;
        let (l0, r0) = o0.split_at_mut(pos);
        let (l1, r1) = o1.split_at_mut(pos);
        let (l2, r2) = o2.split_at_mut(pos);
        let (lt, rt) = self.tmp.split_at_mut(pos);
        let (la, ra) = self.areas.split_at_mut(pos);
        let (ln, rn) = self.nodes[1..].split_at_mut(2 * pos - 1);
        (
            Job {
                orders: [l0, l1, l2],
                tmp: lt,
                areas: la,
                nodes: ln,
                first: self.first,
                slot: self.slot + 1,
            },
            Job {
                orders: [r0, r1, r2],
                tmp: rt,
                areas: ra,
                nodes: rn,
                first: self.first + pos,
                slot: self.slot + 2 * pos,
            },
        )
    }
}

/// One greedy node: leaf, or the children to build.
pub(crate) fn sweep_node<'a>(job: Job<'a>, ctx: &BuildCtx) -> Option<(Job<'a>, Job<'a>)> {
    let n = job.len();
    if n == 1 {
        let b = ctx.bounds[job.orders[0][0] as usize];
        job.make_leaf(&b);
        return None;
    }
    let (node, best) = best_split(
        ctx.bounds,
        [&*job.orders[0], &*job.orders[1], &*job.orders[2]],
        &mut *job.areas,
        &ctx.cost,
    );
    if is_leaf(n, &best, &ctx.cost, ctx.max_leaf) {
        job.make_leaf(&node);
        None
    } else {
        Some(job.split(best.axis, best.pos, &node, &ctx.marks))
    }
}

/// Builds a subtree on the current thread (an explicit stack: no recursion depth limit).
pub(crate) fn build_serial(job: Job<'_>, ctx: &BuildCtx) {
    let mut stack = vec![job];
    while let Some(job) = stack.pop() {
        if let Some((l, r)) = sweep_node(job, ctx) {
            stack.push(r);
            stack.push(l);
        }
    }
}

/// Builds a subtree in parallel: the smaller child of a split goes to another worker when it
/// is large (else it is built right away), and the loop continues with the larger one, so the
/// stack depth stays logarithmic whatever the shape of the tree.
pub(crate) fn drive<'s>(scope: &rayon::Scope<'s>, mut job: Job<'s>, ctx: &'s BuildCtx<'s>) {
    loop {
        if job.len() <= ctx.parallel_threshold {
            build_serial(job, ctx);
            return;
        }
        let Some((l, r)) = sweep_node(job, ctx) else {
            return;
        };
        let (small, large) = if l.len() <= r.len() { (l, r) } else { (r, l) };
        if small.len() > ctx.parallel_threshold {
            scope.spawn(move |s| drive(s, small, ctx));
        } else {
            build_serial(small, ctx);
        }
        job = large;
    }
}
