//! The one top-down driver every builder runs on.
//!
//! A top-down builder is a rule that looks at one node and either makes it a leaf or splits it
//! into two children. That rule is all a builder writes: it implements [`TopDown`] (its
//! [`Task`](TopDown::Task) is whatever it needs to know about a node still to build: a segment
//! of sorted orders, a list of references, a depth, a budget...), and [`build`] does the rest:
//!
//! * **recursion** without a depth limit: subtrees are built with an explicit stack;
//! * **parallelism**: when a split leaves a child with more than
//!   [`TopDown::parallel_threshold`] references, the smaller child goes to another rayon
//!   worker and the current one continues with the larger, so the stack stays small whatever
//!   the shape of the tree;
//! * **node storage**: each worker writes its subtrees into its own fragment of the depth-first
//!   layout; the fragments are joined once at the end;
//! * **determinism**: the output layout is the depth-first order of the tree (left child right
//!   after its parent, leaves' references in the same order), whichever worker built which
//!   subtree, so the [`Bvh`] does not depend on the number of threads as long as the rule
//!   itself does not.
//!
//! [`cost`] runs the same rule without storing anything: it returns the SAH cost `c(T)`
//! (Eq. 1) of the tree the rule would build, bottom-up. The paper's builders rate candidate
//! splits with it (temporary subtrees).
//!
//! # Example: a median-split builder
//!
//! ```
//! use sahara_builders::topdown::{self, Step, TopDown};
//! use sahara_builders::BuildInput;
//! use sahara_geom::{Aabb, Triangle, Vec3A};
//! use sahara_metrics::CostModel;
//!
//! /// Splits every node of more than 4 primitives at the median of its longest axis.
//! struct Median<'a> {
//!     input: &'a BuildInput<'a>,
//! }
//!
//! impl<'a> TopDown for Median<'a> {
//!     type Task = &'a mut [u32];
//!     type Scratch = ();
//!
//!     fn size(&self, prims: &Self::Task) -> usize {
//!         prims.len()
//!     }
//!
//!     fn split(&self, prims: Self::Task, _: &mut ()) -> Step<Self::Task> {
//!         let bounds = prims.iter().fold(Aabb::EMPTY, |b, &p| b.union(&self.input.bounds()[p as usize]));
//!         if prims.len() <= 4 {
//!             return Step::Leaf { bounds, task: prims };
//!         }
//!         let axis = bounds.largest_axis();
//!         let c = self.input.centroids();
//!         prims.sort_unstable_by(|&a, &b| {
//!             c[a as usize][axis].total_cmp(&c[b as usize][axis]).then(a.cmp(&b))
//!         });
//!         let (left, right) = prims.split_at_mut(prims.len() / 2);
//!         Step::Split { bounds, left, right }
//!     }
//!
//!     fn leaf_refs(&self, prims: &Self::Task, out: &mut Vec<u32>) {
//!         out.extend_from_slice(prims);
//!     }
//! }
//!
//! let tris: Vec<Triangle> = (0..100)
//!     .map(|i| {
//!         let o = Vec3A::new(i as f32, 0.0, 0.0);
//!         Triangle::new(o, o + Vec3A::X, o + Vec3A::Y)
//!     })
//!     .collect();
//! let input = BuildInput::new(&tris, CostModel::default()).unwrap();
//! let mut prims: Vec<u32> = (0..100).collect();
//! let bvh = topdown::build(&Median { input: &input }, &mut prims[..], false);
//! bvh.validate(&tris).unwrap();
//! assert_eq!(bvh.stats().max_leaf, 4);
//! ```
//!
//! `examples/median_split.rs` is the same builder behind the [`Builder`](crate::Builder) trait
//! and registered with [`crate::registry::register`].

use std::sync::Mutex;

use sahara_bvh::{Bvh, Node};
use sahara_geom::Aabb;
use sahara_metrics::CostModel;

use crate::split::half_area;
use crate::split::sweep::SubtreeCost;

/// What [`TopDown::split`] decided for a node.
#[derive(Debug)]
pub enum Step<T> {
    /// The node is a leaf with these bounds; its references are those of `task`
    /// ([`TopDown::leaf_refs`]).
    Leaf {
        /// The leaf's bounds.
        bounds: Aabb,
        /// The node, for [`TopDown::leaf_refs`] and [`TopDown::size`].
        task: T,
    },
    /// The node is an inner node with these bounds and two children to build.
    Split {
        /// The node's bounds (the union of its children's).
        bounds: Aabb,
        /// The left child (stored first).
        left: T,
        /// The right child.
        right: T,
    },
}

impl<T> Step<T> {
    /// The same decision over other tasks (`f` applied to each task).
    pub fn map<U>(self, mut f: impl FnMut(T) -> U) -> Step<U> {
        match self {
            Step::Leaf { bounds, task } => Step::Leaf {
                bounds,
                task: f(task),
            },
            Step::Split {
                bounds,
                left,
                right,
            } => Step::Split {
                bounds,
                left: f(left),
                right: f(right),
            },
        }
    }
}

/// A top-down construction rule: what to do with one node. See the [module
/// documentation](self) for what the driver does with it.
///
/// The rule must be deterministic (its decision a function of the task alone) for the tree to
/// be; it may use rayon internally (to rate candidates in parallel, for example).
pub trait TopDown: Sync {
    /// A node still to be built.
    type Task: Send;
    /// Reusable buffers: the driver keeps one per worker loop and hands it to every
    /// [`split`](Self::split) of that loop.
    type Scratch: Default + Send;

    /// The number of references of the node (used to decide what runs in parallel, and as the
    /// leaf's reference count by [`cost`]).
    fn size(&self, task: &Self::Task) -> usize;

    /// Makes the node a leaf, or splits it.
    fn split(&self, task: Self::Task, scratch: &mut Self::Scratch) -> Step<Self::Task>;

    /// Appends the references (primitive indices) of a node that [`split`](Self::split) made a
    /// leaf.
    fn leaf_refs(&self, task: &Self::Task, out: &mut Vec<u32>);

    /// Children with more references than this are built by other rayon workers; smaller
    /// subtrees are built serially. It changes the speed, never the tree. Default 4096.
    fn parallel_threshold(&self) -> usize {
        4096
    }

    /// Cost-only builds ([`cost`], [`cost_with_top_levels`]): the memo of subtree costs this
    /// rule shares with other cost-only builds over the same primitives, and the key of a
    /// node in it (`None`: do not look the node up). A rule may only key nodes whose subtree
    /// is a function of the key's set of references (see [`SubtreeMemo`]). By default none.
    fn memo(&self, _task: &Self::Task) -> Option<(MemoView<'_>, MemoKey)> {
        None
    }

    /// [`memo`](Self::memo) of the two children of a split node, given the node's own (the
    /// driver asks only for the children of a node that [`memo`](Self::memo) keyed, so a rule
    /// must not key a child whose parent it would not key). A rule may derive the keys from
    /// the parent's, which is cheaper than hashing both children (see
    /// [`MemoKey::without`]). By default [`memo`](Self::memo) of each child.
    fn child_memo<'s>(
        &'s self,
        _parent: &(MemoView<'s>, MemoKey),
        left: &Self::Task,
        right: &Self::Task,
    ) -> [Option<(MemoView<'s>, MemoKey)>; 2] {
        [self.memo(left), self.memo(right)]
    }
}

/// The set of references of a node, as a key of a [`SubtreeMemo`]: the number of references
/// and two independent 64-bit sums of a hash of each reference's primitive (order-independent,
/// so equal sets have equal keys whatever their order; different sets collide with
/// probability about 2^-128 per pair).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub struct MemoKey {
    n: usize,
    a: u64,
    b: u64,
}

impl MemoKey {
    /// The key of this set without the subset keyed `part` (which must be a subset of it):
    /// the sums are of one hash per reference, so the difference is exactly the key the rest
    /// of the set would get. A split node's larger child is keyed this way from the node and
    /// the smaller child, which hashes only the smaller one.
    #[inline]
    pub fn without(&self, part: &MemoKey) -> MemoKey {
        debug_assert!(part.n <= self.n);
        MemoKey {
            n: self.n - part.n,
            a: self.a.wrapping_sub(part.a),
            b: self.b.wrapping_sub(part.b),
        }
    }
}

/// Hashes a [`MemoKey`] for the memo's table: its sums are already uniformly mixed, so the
/// table takes the first one and the count (a keyed hash such as the default SipHash would
/// cost more than the lookup saves).
#[derive(Default, Clone, Copy)]
struct KeyHasher(u64);

impl std::hash::Hasher for KeyHasher {
    #[inline]
    fn finish(&self) -> u64 {
        self.0
    }

    #[inline]
    fn write(&mut self, bytes: &[u8]) {
        for &b in bytes {
            self.0 = (self.0.rotate_left(8) ^ u64::from(b)).wrapping_mul(0x9e37_79b9_7f4a_7c15);
        }
    }

    #[inline]
    fn write_u64(&mut self, x: u64) {
        self.0 = self.0.rotate_left(29) ^ x;
    }

    #[inline]
    fn write_usize(&mut self, x: usize) {
        self.write_u64(x as u64);
    }
}

type KeyTable = std::collections::HashMap<MemoKey, Known, std::hash::BuildHasherDefault<KeyHasher>>;

/// Subtree costs that cost-only builds over subsets of the same primitives share: the cost of
/// a node's subtree is a function of its set of references for rules like the sweep (the same
/// set gives the same sorted orders, decisions and sums), so a build that meets a set another
/// build has costed takes its value instead of building the subtree again. The paper's
/// builders rate a node's neighbouring candidates, whose sides differ by a few primitives:
/// their temporaries share most subtrees, and so do a node's temporaries and its children's.
///
/// Builds may label primitives locally: a memo maps its builds' ids to global ones
/// ([`SubtreeMemo::new`]) and keys sets by the global ids, so that builds can also read the
/// entries of another memo, whose builds labelled the primitives otherwise ([`MemoView`]).
///
/// Only nodes of at least [`SubtreeMemo::min_size`] references are stored and looked up. The
/// values are those the build would compute, bit for bit, so the memo changes the speed,
/// never a cost (but for a collision of [`MemoKey`]s). Thread-safe; which build stores a value
/// first depends on the threads' timing, not the value.
#[derive(Debug)]
pub struct SubtreeMemo {
    min_size: usize,
    /// The two hashes of each local id's global id (the terms of [`MemoKey`]'s sums).
    hashes: Vec<[u64; 2]>,
    known: Mutex<KeyTable>,
}

/// A memo entry: the subtree's cost, its root's left size (`0` for a leaf) and, when it was
/// costed within the top levels of a build, the subtree's own top levels.
#[derive(Clone, Debug)]
struct Known {
    cost: SubtreeCost,
    left_len: usize,
    top: Option<Box<TopLevels>>,
}

impl SubtreeMemo {
    /// An empty memo for nodes of at least `min_size` references (at least 2), whose builds
    /// label primitive `global[i]` as `i`.
    pub fn new(min_size: usize, global: &[u32]) -> Self {
        // splitmix64's finaliser, of two different inputs per primitive.
        #[inline(always)]
        fn mix(mut z: u64) -> u64 {
            z = (z ^ (z >> 30)).wrapping_mul(0xbf58_476d_1ce4_e5b9);
            z = (z ^ (z >> 27)).wrapping_mul(0x94d0_49bb_1331_11eb);
            z ^ (z >> 31)
        }
        let hashes = global
            .iter()
            .map(|&g| {
                let x = u64::from(g).wrapping_mul(0x9e37_79b9_7f4a_7c15);
                [mix(x), mix(x ^ 0x5851_f42d_4c95_7f2d)]
            })
            .collect();
        Self {
            min_size: min_size.max(2),
            hashes,
            known: Mutex::new(Default::default()),
        }
    }

    /// The smallest node stored.
    #[inline]
    pub fn min_size(&self) -> usize {
        self.min_size
    }

    /// The key of the set of local `ids` (in any order).
    #[inline]
    pub fn key(&self, ids: &[u32]) -> MemoKey {
        let (mut a, mut b) = (0u64, 0u64);
        for &id in ids {
            let [x, y] = self.hashes[id as usize];
            a = a.wrapping_add(x);
            b = b.wrapping_add(y);
        }
        MemoKey { n: ids.len(), a, b }
    }

    /// Number of subtrees stored.
    pub fn len(&self) -> usize {
        self.known.lock().expect("memo").len()
    }

    /// True when nothing is stored.
    pub fn is_empty(&self) -> bool {
        self.len() == 0
    }

    fn get(&self, k: &MemoKey) -> Option<Known> {
        self.known.lock().expect("memo").get(k).cloned()
    }

    fn put(&self, k: MemoKey, v: Known) {
        let mut m = self.known.lock().expect("memo");
        let e = m.entry(k).or_insert_with(|| v.clone());
        // Top levels are worth keeping when the first entry had none.
        if e.top.is_none() {
            e.top = v.top;
        }
    }
}

/// What a cost-only build reads and writes: its own [`SubtreeMemo`] (its ids' labels, and where
/// it stores), and another memo over the same primitives it reads as well (the parent node's,
/// in the paper's builders).
#[derive(Clone, Copy, Debug)]
pub struct MemoView<'a> {
    /// Keys, lookups and stores.
    pub own: &'a SubtreeMemo,
    /// Lookups only.
    pub other: Option<&'a SubtreeMemo>,
}

impl MemoView<'_> {
    fn get(&self, k: &MemoKey) -> Option<Known> {
        self.own
            .get(k)
            .or_else(|| self.other.and_then(|o| o.get(k)))
    }

    fn put(&self, k: MemoKey, v: Known) {
        self.own.put(k, v)
    }
}

/// Marks a fragment node that stands for another fragment (its `index` is the fragment's slot).
const PLACEHOLDER: u32 = u32::MAX;
/// No node to patch.
const NONE: usize = usize::MAX;

/// A piece of the depth-first layout. Either a subtree built serially (indices relative to the
/// fragment's own arrays) or, for a split handed to other workers, an inner node followed by
/// two placeholders.
#[derive(Default)]
struct Fragment {
    nodes: Vec<Node>,
    prims: Vec<u32>,
}

struct Shared<'h, H> {
    hook: &'h H,
    slots: Mutex<Vec<Option<Fragment>>>,
}

impl<H> Shared<'_, H> {
    fn reserve(&self) -> u32 {
        let mut s = self.slots.lock().expect("slots");
        s.push(None);
        (s.len() - 1) as u32
    }

    fn store(&self, slot: u32, f: Fragment) {
        self.slots.lock().expect("slots")[slot as usize] = Some(f);
    }
}

/// Builds the tree of the rule `hook` over the root task. `spatial_splits` is recorded in the
/// [`Bvh`] (true when a primitive may be referenced by several leaves).
pub fn build<H: TopDown>(hook: &H, root: H::Task, spatial_splits: bool) -> Bvh {
    let threshold = hook.parallel_threshold().max(1);
    if hook.size(&root) <= threshold {
        let mut f = Fragment::default();
        serial(hook, root, &mut f, &mut H::Scratch::default());
        return Bvh {
            nodes: f.nodes,
            prim_indices: f.prims,
            spatial_splits,
        };
    }
    let shared = Shared {
        hook,
        slots: Mutex::new(vec![None]),
    };
    rayon::scope(|s| run(s, &shared, root, 0));
    let frags: Vec<Fragment> = shared
        .slots
        .into_inner()
        .expect("slots")
        .into_iter()
        .map(|f| f.expect("every fragment is built"))
        .collect();
    stitch(frags, spatial_splits)
}

/// Builds the subtree of `task` into fragment `slot` (and the fragments it spawns).
fn run<'s, H: TopDown>(
    scope: &rayon::Scope<'s>,
    shared: &'s Shared<'s, H>,
    mut task: H::Task,
    mut slot: u32,
) where
    H::Task: 's,
{
    let hook = shared.hook;
    let threshold = hook.parallel_threshold().max(1);
    let mut scratch = H::Scratch::default();
    loop {
        let mut frag = Fragment::default();
        if hook.size(&task) <= threshold {
            serial(hook, task, &mut frag, &mut scratch);
            shared.store(slot, frag);
            return;
        }
        match hook.split(task, &mut scratch) {
            Step::Leaf { bounds, task } => {
                push_leaf(hook, &mut frag, &bounds, &task);
                shared.store(slot, frag);
                return;
            }
            Step::Split {
                bounds,
                left,
                right,
            } => {
                let (ls, rs) = (shared.reserve(), shared.reserve());
                frag.nodes.push(Node::inner(&bounds, 2));
                frag.nodes.push(placeholder(ls));
                frag.nodes.push(placeholder(rs));
                shared.store(slot, frag);
                let (small, small_slot, large, large_slot) =
                    if hook.size(&left) <= hook.size(&right) {
                        (left, ls, right, rs)
                    } else {
                        (right, rs, left, ls)
                    };
                if hook.size(&small) > threshold {
                    scope.spawn(move |s| run(s, shared, small, small_slot));
                } else {
                    let mut f = Fragment::default();
                    serial(hook, small, &mut f, &mut scratch);
                    shared.store(small_slot, f);
                }
                task = large;
                slot = large_slot;
            }
        }
    }
}

fn placeholder(slot: u32) -> Node {
    Node {
        index: slot,
        count: PLACEHOLDER,
        ..Node::default()
    }
}

fn push_leaf<H: TopDown>(hook: &H, frag: &mut Fragment, bounds: &Aabb, task: &H::Task) {
    let first = frag.prims.len();
    hook.leaf_refs(task, &mut frag.prims);
    let count = frag.prims.len() - first;
    debug_assert!(count > 0, "a leaf without references");
    frag.nodes
        .push(Node::leaf(bounds, first as u32, count as u32));
}

/// Builds a subtree on the current thread into `frag` (an explicit stack: no depth limit).
fn serial<H: TopDown>(hook: &H, task: H::Task, frag: &mut Fragment, scratch: &mut H::Scratch) {
    // (task, index of the inner node whose right child it is)
    let mut stack = vec![(task, NONE)];
    while let Some((task, patch)) = stack.pop() {
        if patch != NONE {
            frag.nodes[patch].index = frag.nodes.len() as u32;
        }
        match hook.split(task, scratch) {
            Step::Leaf { bounds, task } => push_leaf(hook, frag, &bounds, &task),
            Step::Split {
                bounds,
                left,
                right,
            } => {
                let me = frag.nodes.len();
                frag.nodes.push(Node::inner(&bounds, 0));
                stack.push((right, me));
                stack.push((left, NONE));
            }
        }
    }
}

/// Joins the fragments into one depth-first layout, starting from fragment 0.
fn stitch(frags: Vec<Fragment>, spatial_splits: bool) -> Bvh {
    let n_nodes = frags
        .iter()
        .map(|f| f.nodes.iter().filter(|n| n.count != PLACEHOLDER).count())
        .sum();
    let n_prims = frags.iter().map(|f| f.prims.len()).sum();
    let mut nodes: Vec<Node> = Vec::with_capacity(n_nodes);
    let mut prims: Vec<u32> = Vec::with_capacity(n_prims);
    enum Item {
        Emit(u32),
        Right(usize, u32),
    }
    let mut stack = vec![Item::Emit(0)];
    while let Some(item) = stack.pop() {
        let slot = match item {
            Item::Emit(slot) => slot,
            Item::Right(parent, slot) => {
                nodes[parent].index = nodes.len() as u32;
                slot
            }
        };
        let f = &frags[slot as usize];
        if f.nodes.len() == 3 && f.nodes[1].count == PLACEHOLDER {
            // A split handed to other workers: the inner node, then both children.
            let me = nodes.len();
            nodes.push(f.nodes[0]);
            stack.push(Item::Right(me, f.nodes[2].index));
            stack.push(Item::Emit(f.nodes[1].index));
            continue;
        }
        let node_off = nodes.len() as u32;
        let prim_off = prims.len() as u32;
        nodes.extend(f.nodes.iter().map(|n| {
            let mut n = *n;
            n.index += if n.is_leaf() { prim_off } else { node_off };
            n
        }));
        prims.extend_from_slice(&f.prims);
    }
    Bvh {
        nodes,
        prim_indices: prims,
        spatial_splits,
    }
}

/// The SAH cost `c(T)` (Eq. 1, relative to the root's bounds) of the tree the rule `hook`
/// would build over `task`, and the half area of its root, computed bottom-up on the current
/// thread without storing a node. A leaf of `n` references costs `n c_i`, an inner node
/// combines its children by their areas (`CostModel::inner_cost`).
///
/// Temporary subtrees are costed by the million, most of them small: the first
/// [`COST_RECURSION`] levels recurse on the call stack (no allocation), deeper subtrees
/// continue on an explicit stack, so no input can overflow the thread's stack.
pub fn cost<H: TopDown>(
    hook: &H,
    task: H::Task,
    cost: &CostModel,
    scratch: &mut H::Scratch,
) -> SubtreeCost {
    let memo = hook.memo(&task);
    cost_rec(hook, task, memo, cost, scratch, 0)
}

/// Levels of a subtree whose node costs [`cost_with_top_levels`] records.
pub const TOP_LEVELS: usize = 4;
const TOP_NODES: usize = (1 << TOP_LEVELS) - 1;

/// The costs of the nodes in the top [`TOP_LEVELS`] levels of a subtree that [`cost`]
/// computed on the way (heap order: node `i`'s children are `2i + 1` and `2i + 2`), with the
/// size of each split node's left child: enough to know, without building them again, what
/// the subtrees of the root's children, grandchildren... cost.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct TopLevels {
    /// `(c(T), size of the left child)` of each node (`0` for a leaf), `None` below the tree.
    nodes: [Option<(SubtreeCost, usize)>; TOP_NODES],
}

/// The split of a subtree's root: the size of its left child and the costs of both children.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct RootSplit {
    /// References of the left child ([`TopDown::size`]).
    pub left_len: usize,
    /// `c(T)` of the left child's subtree.
    pub left: SubtreeCost,
    /// `c(T)` of the right child's subtree.
    pub right: SubtreeCost,
}

impl TopLevels {
    /// Nothing recorded.
    pub const NONE: TopLevels = TopLevels {
        nodes: [None; TOP_NODES],
    };

    /// The root's split, when the root was split.
    pub fn root_split(&self) -> Option<RootSplit> {
        let (_, left_len) = self.nodes[0]?;
        if left_len == 0 {
            return None;
        }
        Some(RootSplit {
            left_len,
            left: self.nodes[1]?.0,
            right: self.nodes[2]?.0,
        })
    }

    /// The levels recorded of the subtree of the node of heap index `index` (at `depth`), as
    /// that subtree's own top levels (`TOP_LEVELS - depth` of them).
    fn extract(&self, index: usize, depth: usize) -> TopLevels {
        let mut out = TopLevels::NONE;
        let offset = index + 1 - (1 << depth);
        for level in 0..TOP_LEVELS - depth {
            let width = 1 << level;
            let first = (1 << (depth + level)) - 1 + offset * width;
            out.nodes[width - 1..2 * width - 1].copy_from_slice(&self.nodes[first..first + width]);
        }
        out
    }

    /// Writes a subtree's own top levels (see [`TopLevels::extract`]) as the levels of the node
    /// of heap index `index` (at `depth`).
    fn implant(&mut self, sub: &TopLevels, index: usize, depth: usize) {
        let offset = index + 1 - (1 << depth);
        for level in 0..TOP_LEVELS - depth {
            let width = 1 << level;
            let first = (1 << (depth + level)) - 1 + offset * width;
            self.nodes[first..first + width].copy_from_slice(&sub.nodes[width - 1..2 * width - 1]);
        }
    }

    /// The levels of the root's left (`side` 0) or right (`side` 1) child's subtree (one level
    /// fewer).
    pub fn child(&self, side: usize) -> TopLevels {
        let mut out = TopLevels::NONE;
        for level in 0..TOP_LEVELS - 1 {
            let width = 1 << level;
            for k in 0..width {
                out.nodes[width - 1 + k] = self.nodes[(2 * width - 1) + side * width + k];
            }
        }
        out
    }
}

/// [`cost`], and the costs of the nodes of the top [`TOP_LEVELS`] levels of the tree the rule
/// builds: the very values [`cost`] combines (the same calls in the same order), so a caller
/// can reuse them where it would cost the same subtrees again.
pub fn cost_with_top_levels<H: TopDown>(
    hook: &H,
    task: H::Task,
    cost: &CostModel,
    scratch: &mut H::Scratch,
) -> (SubtreeCost, TopLevels) {
    let mut top = TopLevels::NONE;
    let memo = hook.memo(&task);
    let c = cost_top(hook, task, memo, cost, scratch, 0, 0, &mut top);
    (c, top)
}

/// The memo of a node's children ([`TopDown::child_memo`]), given the node's.
#[inline]
fn child_memo<'h, H: TopDown>(
    hook: &'h H,
    memo: &Option<(MemoView<'h>, MemoKey)>,
    left: &H::Task,
    right: &H::Task,
) -> [Option<(MemoView<'h>, MemoKey)>; 2] {
    match memo {
        Some(m) => hook.child_memo(m, left, right),
        None => [None, None],
    }
}

/// [`cost_rec`] recording the node of heap index `index` at `depth` (and its subtree's top
/// levels) in `top`. `memo` is [`TopDown::memo`] of the task.
#[allow(clippy::too_many_arguments)]
fn cost_top<'h, H: TopDown>(
    hook: &'h H,
    task: H::Task,
    memo: Option<(MemoView<'h>, MemoKey)>,
    cost: &CostModel,
    scratch: &mut H::Scratch,
    depth: usize,
    index: usize,
    top: &mut TopLevels,
) -> SubtreeCost {
    if depth >= TOP_LEVELS {
        return cost_rec(hook, task, memo, cost, scratch, depth);
    }
    if let Some(k) = memo.and_then(|(m, key)| m.get(&key)) {
        match k.top {
            Some(sub) => top.implant(&sub, index, depth),
            None => top.nodes[index] = Some((k.cost, k.left_len)),
        }
        return k.cost;
    }
    let (v, left_len) = match hook.split(task, scratch) {
        Step::Leaf { bounds, task } => (leaf_value(hook, &bounds, &task, cost), 0),
        Step::Split {
            bounds,
            left,
            right,
        } => {
            let left_len = hook.size(&left);
            let [ml, mr] = child_memo(hook, &memo, &left, &right);
            let l = cost_top(hook, left, ml, cost, scratch, depth + 1, 2 * index + 1, top);
            let r = cost_top(
                hook,
                right,
                mr,
                cost,
                scratch,
                depth + 1,
                2 * index + 2,
                top,
            );
            (inner_value(cost, half_area(&bounds), &l, &r), left_len)
        }
    };
    top.nodes[index] = Some((v, left_len));
    if let Some((m, key)) = memo {
        let sub = top.extract(index, depth);
        m.put(
            key,
            Known {
                cost: v,
                left_len,
                top: Some(Box::new(sub)),
            },
        );
    }
    v
}

/// Levels of [`cost`] that recurse on the call stack.
pub const COST_RECURSION: usize = 48;

/// `memo` is [`TopDown::memo`] of the task.
fn cost_rec<'h, H: TopDown>(
    hook: &'h H,
    task: H::Task,
    memo: Option<(MemoView<'h>, MemoKey)>,
    cost: &CostModel,
    scratch: &mut H::Scratch,
    depth: usize,
) -> SubtreeCost {
    if depth >= COST_RECURSION {
        return cost_iterative(hook, task, cost, scratch);
    }
    if let Some(k) = memo.and_then(|(m, key)| m.get(&key)) {
        return k.cost;
    }
    let (v, left_len) = match hook.split(task, scratch) {
        Step::Leaf { bounds, task } => (leaf_value(hook, &bounds, &task, cost), 0),
        Step::Split {
            bounds,
            left,
            right,
        } => {
            let left_len = hook.size(&left);
            let [ml, mr] = child_memo(hook, &memo, &left, &right);
            let l = cost_rec(hook, left, ml, cost, scratch, depth + 1);
            let r = cost_rec(hook, right, mr, cost, scratch, depth + 1);
            (inner_value(cost, half_area(&bounds), &l, &r), left_len)
        }
    };
    if let Some((m, key)) = memo {
        m.put(
            key,
            Known {
                cost: v,
                left_len,
                top: None,
            },
        );
    }
    v
}

/// The cost of a leaf: `n c_i`.
#[inline]
fn leaf_value<H: TopDown>(
    hook: &H,
    bounds: &Aabb,
    task: &H::Task,
    cost: &CostModel,
) -> SubtreeCost {
    SubtreeCost {
        cost: cost.leaf_cost(hook.size(task)),
        area: half_area(bounds),
    }
}

/// The cost of an inner node of half area `area` over its children's.
#[inline]
fn inner_value(cost: &CostModel, area: f64, l: &SubtreeCost, r: &SubtreeCost) -> SubtreeCost {
    SubtreeCost {
        cost: cost.inner_cost(area, l.area, l.cost, r.area, r.cost),
        area,
    }
}

/// [`cost`] on an explicit stack.
fn cost_iterative<H: TopDown>(
    hook: &H,
    task: H::Task,
    cost: &CostModel,
    scratch: &mut H::Scratch,
) -> SubtreeCost {
    enum Item<T> {
        Visit(T),
        Combine(f64),
    }
    let mut stack = vec![Item::Visit(task)];
    let mut values: Vec<SubtreeCost> = Vec::new();
    while let Some(item) = stack.pop() {
        match item {
            Item::Visit(task) => match hook.split(task, scratch) {
                Step::Leaf { bounds, task } => values.push(leaf_value(hook, &bounds, &task, cost)),
                Step::Split {
                    bounds,
                    left,
                    right,
                } => {
                    stack.push(Item::Combine(half_area(&bounds)));
                    stack.push(Item::Visit(right));
                    stack.push(Item::Visit(left));
                }
            },
            Item::Combine(area) => {
                let r = values.pop().expect("right cost");
                let l = values.pop().expect("left cost");
                values.push(inner_value(cost, area, &l, &r));
            }
        }
    }
    values.pop().expect("root cost")
}

#[cfg(test)]
mod tests {
    use super::*;
    use sahara_geom::Vec3A;

    /// Halves a row of unit boxes (odd rows leave the extra box right), down to single boxes.
    struct Halve;

    impl TopDown for Halve {
        type Task = (u32, u32);
        type Scratch = ();

        fn size(&self, t: &(u32, u32)) -> usize {
            (t.1 - t.0) as usize
        }

        fn split(&self, t: (u32, u32), _: &mut ()) -> Step<(u32, u32)> {
            let bounds = Aabb::new(
                Vec3A::new(t.0 as f32, 0.0, 0.0),
                Vec3A::new(t.1 as f32, 1.0 + t.0 as f32 * 0.01, 1.0),
            );
            if t.1 - t.0 == 1 {
                Step::Leaf { bounds, task: t }
            } else {
                let mid = t.0 + (t.1 - t.0) / 2;
                Step::Split {
                    bounds,
                    left: (t.0, mid),
                    right: (mid, t.1),
                }
            }
        }

        fn leaf_refs(&self, t: &(u32, u32), out: &mut Vec<u32>) {
            out.extend(t.0..t.1);
        }
    }

    /// The top levels hold, bit for bit, what [`cost`] computes for each subtree, and
    /// `child` descends to a child's own top levels.
    #[test]
    fn top_levels_are_the_subtrees_costs() {
        let cost = CostModel::default();
        for n in [1u32, 2, 3, 7, 8, 13, 40] {
            let (c, top) = cost_with_top_levels(&Halve, (0, n), &cost, &mut ());
            assert_eq!(
                c.cost.to_bits(),
                cost_fn(&Halve, (0, n)).cost.to_bits(),
                "n = {n}"
            );
            // Walk two levels down the left and right children and compare with fresh costs.
            let mut stack = vec![((0u32, n), top, 0usize)];
            while let Some(((a, b), t, level)) = stack.pop() {
                let fresh = cost_fn(&Halve, (a, b));
                let (rec, left_len) = t.nodes[0].expect("recorded");
                assert_eq!(rec.cost.to_bits(), fresh.cost.to_bits(), "({a}, {b})");
                assert_eq!(rec.area.to_bits(), fresh.area.to_bits(), "({a}, {b})");
                if b - a == 1 {
                    assert_eq!(left_len, 0);
                    assert!(t.root_split().is_none());
                    continue;
                }
                let mid = a + (b - a) / 2;
                assert_eq!(left_len, (mid - a) as usize);
                let rs = t.root_split().expect("split root");
                assert_eq!(
                    rs.left.cost.to_bits(),
                    cost_fn(&Halve, (a, mid)).cost.to_bits()
                );
                assert_eq!(
                    rs.right.cost.to_bits(),
                    cost_fn(&Halve, (mid, b)).cost.to_bits()
                );
                if level + 2 < TOP_LEVELS {
                    stack.push(((a, mid), t.child(0), level + 1));
                    stack.push(((mid, b), t.child(1), level + 1));
                }
            }
        }

        fn cost_fn(h: &Halve, t: (u32, u32)) -> SubtreeCost {
            super::cost(h, t, &CostModel::default(), &mut ())
        }
    }

    /// Peels one unit box off the end of a row per level: a chain as deep as the row is long.
    struct Peel;

    impl TopDown for Peel {
        type Task = (u32, u32);
        type Scratch = ();

        fn size(&self, t: &(u32, u32)) -> usize {
            (t.1 - t.0) as usize
        }

        fn split(&self, t: (u32, u32), _: &mut ()) -> Step<(u32, u32)> {
            let bounds = Aabb::new(
                Vec3A::new(t.0 as f32, 0.0, 0.0),
                Vec3A::new(t.1 as f32, 1.0, 1.0),
            );
            if t.1 - t.0 == 1 {
                Step::Leaf { bounds, task: t }
            } else {
                Step::Split {
                    bounds,
                    left: (t.0, t.1 - 1),
                    right: (t.1 - 1, t.1),
                }
            }
        }

        fn leaf_refs(&self, t: &(u32, u32), out: &mut Vec<u32>) {
            out.extend(t.0..t.1);
        }

        fn parallel_threshold(&self) -> usize {
            16
        }
    }

    #[test]
    fn deep_chains_cost_the_same_recursively_and_iteratively() {
        let c = CostModel::default();
        for n in [1, 2, COST_RECURSION as u32, 5_000] {
            let a = cost(&Peel, (0, n), &c, &mut ());
            let b = cost_iterative(&Peel, (0, n), &c, &mut ());
            assert_eq!(a, b, "{n}");
        }
    }

    #[test]
    fn parallel_and_serial_builds_are_identical() {
        // A chain deep enough to spawn at many levels and to stitch many fragments.
        let n = 3_000;
        let bvh = build(&Peel, (0, n), false);
        bvh.validate_structure().unwrap();
        let mut f = Fragment::default();
        serial(&Peel, (0, n), &mut f, &mut ());
        assert_eq!(bvh.nodes, f.nodes);
        assert_eq!(bvh.prim_indices, f.prims);
        let one = rayon::ThreadPoolBuilder::new()
            .num_threads(1)
            .build()
            .unwrap();
        assert_eq!(one.install(|| build(&Peel, (0, n), false)), bvh);
    }
}
