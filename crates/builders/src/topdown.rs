//! The one top-down driver every builder runs on.
//!
//! A top-down builder is a rule that looks at one node and either makes it a leaf or splits it
//! into two children. That rule is all a builder writes: it implements [`Rule`] (its
//! [`Task`](Rule::Task) is whatever it needs to know about a node still to build: a segment
//! of sorted orders, a list of references, a depth, a budget...), and [`build`] does the rest:
//!
//! * **recursion** without a depth limit: subtrees are built with an explicit stack;
//! * **parallelism**: when a split leaves a child with more than
//!   [`Rule::parallel_threshold`] references, the smaller child goes to another rayon
//!   worker and the current one continues with the larger, so the stack stays small whatever
//!   the shape of the tree;
//! * **node storage**: each worker writes its subtrees into its own fragment of the depth-first
//!   layout; the fragments are joined once at the end;
//! * **determinism**: the output layout is the depth-first order of the tree (left child right
//!   after its parent, leaves' references in the same order), whichever worker built which
//!   subtree, so the [`Bvh`] does not depend on the number of threads as long as the rule
//!   itself does not.
//!
//! [`crate::cost_only`] runs the same rule without storing anything: it returns the SAH cost
//! `c(T)` (Eq. 1) of the tree the rule would build, bottom-up. The paper's builders rate
//! candidate splits with it (temporary subtrees).
//!
//! # Example: a median-split builder
//!
//! ```
//! use sahara_builders::topdown::{self, Rule, Step};
//! use sahara_builders::BuildInput;
//! use sahara_geom::{Aabb, Triangle, Vec3A};
//! use sahara_metrics::CostModel;
//!
//! /// Splits every node of more than 4 primitives at the median of its longest axis.
//! struct Median<'a> {
//!     input: &'a BuildInput<'a>,
//! }
//!
//! impl<'a> Rule for Median<'a> {
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

use sahara_bvh::{Bvh, Node, RefCuts};
use sahara_geom::Aabb;

/// What [`Rule::split`] decided for a node.
#[derive(Debug)]
pub enum Step<T> {
    /// The node is a leaf with these bounds; its references are those of `task`
    /// ([`Rule::leaf_refs`]).
    Leaf {
        /// The leaf's bounds.
        bounds: Aabb,
        /// The node, for [`Rule::leaf_refs`] and [`Rule::size`].
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
pub trait Rule: Sync {
    /// A node still to be built.
    type Task: Send;
    /// Reusable buffers: the driver keeps one per worker loop and hands it to every
    /// [`split`](Self::split) of that loop.
    type Scratch: Default + Send;

    /// The number of references of the node (used to decide what runs in parallel, and as the
    /// leaf's reference count by the cost-only builds of [`crate::cost_only`]).
    fn size(&self, task: &Self::Task) -> usize;

    /// Makes the node a leaf, or splits it.
    fn split(&self, task: Self::Task, scratch: &mut Self::Scratch) -> Step<Self::Task>;

    /// Appends the references (primitive indices) of a node that [`split`](Self::split) made a
    /// leaf.
    fn leaf_refs(&self, task: &Self::Task, out: &mut Vec<u32>);

    /// For rules that cut references (spatial splits): appends one value per reference of the
    /// leaf, in the order of [`leaf_refs`](Self::leaf_refs), that [`ref_cuts`](Self::ref_cuts)
    /// turns into the tree's cut records (the SBVH rules append each reference's last entry
    /// in their [`CutLog`](crate::split::spatial::CutLog)). Default: nothing.
    fn leaf_cuts(&self, _task: &Self::Task, _out: &mut Vec<u32>) {}

    /// The tree's cut records ([`Bvh::ref_cuts`]) from the values [`leaf_cuts`](Self::leaf_cuts)
    /// appended for all references, in reference order. Default: `None` (no records).
    fn ref_cuts(&self, _heads: &[u32]) -> Option<RefCuts> {
        None
    }

    /// Children with more references than this are built by other rayon workers; smaller
    /// subtrees are built serially. It changes the speed, never the tree. Default 4096.
    fn parallel_threshold(&self) -> usize {
        4096
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
    /// [`Rule::leaf_cuts`] of the references (empty for rules that record none).
    heads: Vec<u32>,
}

struct Shared<'r, R> {
    rule: &'r R,
    slots: Mutex<Vec<Option<Fragment>>>,
}

impl<R> Shared<'_, R> {
    fn reserve(&self) -> u32 {
        let mut s = self.slots.lock().expect("slots");
        s.push(None);
        (s.len() - 1) as u32
    }

    fn store(&self, slot: u32, f: Fragment) {
        self.slots.lock().expect("slots")[slot as usize] = Some(f);
    }
}

/// Builds the tree of `rule` over the root task. `spatial_splits` is recorded in the
/// [`Bvh`] (true when a primitive may be referenced by several leaves).
pub fn build<R: Rule>(rule: &R, root: R::Task, spatial_splits: bool) -> Bvh {
    let threshold = rule.parallel_threshold().max(1);
    if rule.size(&root) <= threshold {
        let mut f = Fragment::default();
        serial(rule, root, &mut f, &mut R::Scratch::default());
        return Bvh {
            ref_cuts: cut_records(rule, &f.heads, f.prims.len()),
            nodes: f.nodes,
            prim_indices: f.prims,
            spatial_splits,
        };
    }
    let shared = Shared {
        rule,
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
    stitch(rule, frags, spatial_splits)
}

/// The rule's cut records for `refs` references, when it recorded one value per reference.
fn cut_records<R: Rule>(rule: &R, heads: &[u32], refs: usize) -> Option<RefCuts> {
    (heads.len() == refs)
        .then(|| rule.ref_cuts(heads))
        .flatten()
}

/// Builds the subtree of `task` into fragment `slot` (and the fragments it spawns).
fn run<'s, R: Rule>(
    scope: &rayon::Scope<'s>,
    shared: &'s Shared<'s, R>,
    mut task: R::Task,
    mut slot: u32,
) where
    R::Task: 's,
{
    let rule = shared.rule;
    let threshold = rule.parallel_threshold().max(1);
    let mut scratch = R::Scratch::default();
    loop {
        let mut frag = Fragment::default();
        if rule.size(&task) <= threshold {
            serial(rule, task, &mut frag, &mut scratch);
            shared.store(slot, frag);
            return;
        }
        match rule.split(task, &mut scratch) {
            Step::Leaf { bounds, task } => {
                push_leaf(rule, &mut frag, &bounds, &task);
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
                    if rule.size(&left) <= rule.size(&right) {
                        (left, ls, right, rs)
                    } else {
                        (right, rs, left, ls)
                    };
                if rule.size(&small) > threshold {
                    scope.spawn(move |s| run(s, shared, small, small_slot));
                } else {
                    let mut f = Fragment::default();
                    serial(rule, small, &mut f, &mut scratch);
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

fn push_leaf<R: Rule>(rule: &R, frag: &mut Fragment, bounds: &Aabb, task: &R::Task) {
    let first = frag.prims.len();
    rule.leaf_refs(task, &mut frag.prims);
    rule.leaf_cuts(task, &mut frag.heads);
    let count = frag.prims.len() - first;
    debug_assert!(count > 0, "a leaf without references");
    frag.nodes
        .push(Node::leaf(bounds, first as u32, count as u32));
}

/// Builds a subtree on the current thread into `frag` (an explicit stack: no depth limit).
fn serial<R: Rule>(rule: &R, task: R::Task, frag: &mut Fragment, scratch: &mut R::Scratch) {
    // (task, index of the inner node whose right child it is)
    let mut stack = vec![(task, NONE)];
    while let Some((task, patch)) = stack.pop() {
        if patch != NONE {
            frag.nodes[patch].index = frag.nodes.len() as u32;
        }
        match rule.split(task, scratch) {
            Step::Leaf { bounds, task } => push_leaf(rule, frag, &bounds, &task),
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
fn stitch<R: Rule>(rule: &R, frags: Vec<Fragment>, spatial_splits: bool) -> Bvh {
    let n_nodes = frags
        .iter()
        .map(|f| f.nodes.iter().filter(|n| n.count != PLACEHOLDER).count())
        .sum();
    let n_prims = frags.iter().map(|f| f.prims.len()).sum();
    let mut nodes: Vec<Node> = Vec::with_capacity(n_nodes);
    let mut prims: Vec<u32> = Vec::with_capacity(n_prims);
    let mut heads: Vec<u32> = Vec::new();
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
        heads.extend_from_slice(&f.heads);
    }
    Bvh {
        ref_cuts: cut_records(rule, &heads, prims.len()),
        nodes,
        prim_indices: prims,
        spatial_splits,
    }
}
/// Small rules over rows of unit boxes, for the tests of the driver and of the cost-only builds.
#[cfg(test)]
pub(crate) mod tests {
    use super::*;
    use sahara_geom::Vec3A;

    /// Halves a row of unit boxes (odd rows leave the extra box right), down to single boxes.
    pub(crate) struct Halve;

    impl Rule for Halve {
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

    /// Peels one unit box off the end of a row per level: a chain as deep as the row is long.
    pub(crate) struct Peel;

    impl Rule for Peel {
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
