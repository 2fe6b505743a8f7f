//! Cost-only builds: the SAH cost `c(T)` (Eq. 1) of the tree a [`Rule`] would build, computed
//! bottom-up on the current thread without storing a node. The paper's builders rate candidate
//! splits with the cost of temporary subtrees built this way (`docs/builders-tsah.md`), and
//! the spatial temporary-subtree builder rates its candidates with SBVH-like ones.
//!
//! * [`cost`]: `c(T)` and the half area of the root, for any rule;
//! * [`cost_with_top_levels`]: the same computation, also recording the costs of the nodes of
//!   the top [`TOP_LEVELS`] levels ([`TopLevels`]), for a rule that shares subtree costs with
//!   other cost-only builds through a [`SubtreeMemo`] ([`Memoised`]).
//!
//! Both run one recursion: a leaf of `n` references costs `n c_i`, an inner node combines its
//! children by their areas (`CostModel::inner_cost`). Temporary subtrees are costed by the
//! million, most of them small: the first [`COST_RECURSION`] levels recurse on the call stack
//! (no allocation), deeper subtrees continue on an explicit stack, so no input can overflow
//! the thread's stack.

mod levels;
mod memo;

pub use levels::{RootSplit, SubtreeCost, TopLevels, TOP_LEVELS};
pub use memo::{MemoKey, MemoView, Memoised, SubtreeMemo};

use sahara_geom::Aabb;
use sahara_metrics::CostModel;

use crate::split::half_area;
use crate::topdown::{Rule, Step};
use memo::Known;

/// The SAH cost `c(T)` (Eq. 1, relative to the root's bounds) of the tree `rule` would build
/// over `task`, and the half area of its root (see the [module documentation](self)).
pub fn cost<R: Rule>(
    rule: &R,
    task: R::Task,
    cost: &CostModel,
    scratch: &mut R::Scratch,
) -> SubtreeCost {
    node(&Unmemoised(rule), task, None, cost, scratch, 0, None)
}

/// [`cost`], and the costs of the nodes of the top [`TOP_LEVELS`] levels of the tree the rule
/// builds: the very values [`cost`] combines (the same calls in the same order), so a caller
/// can reuse them where it would cost the same subtrees again. Subtrees the rule keys
/// ([`Memoised::memo`]) are looked up in its memo before they are built, and stored after.
pub fn cost_with_top_levels<R: Memoised>(
    rule: &R,
    task: R::Task,
    cost: &CostModel,
    scratch: &mut R::Scratch,
) -> (SubtreeCost, TopLevels) {
    let mut top = TopLevels::NONE;
    let memo = rule.memo(&task);
    let c = node(rule, task, memo, cost, scratch, 0, Some((&mut top, 0)));
    (c, top)
}

/// Levels of a cost-only build that recurse on the call stack.
pub const COST_RECURSION: usize = 48;

/// A rule without a memo, for [`cost`].
struct Unmemoised<'r, R>(&'r R);

impl<R: Rule> Rule for Unmemoised<'_, R> {
    type Task = R::Task;
    type Scratch = R::Scratch;

    #[inline]
    fn size(&self, task: &R::Task) -> usize {
        self.0.size(task)
    }

    #[inline]
    fn split(&self, task: R::Task, scratch: &mut R::Scratch) -> Step<R::Task> {
        self.0.split(task, scratch)
    }

    fn leaf_refs(&self, task: &R::Task, out: &mut Vec<u32>) {
        self.0.leaf_refs(task, out)
    }
}

impl<R: Rule> Memoised for Unmemoised<'_, R> {
    #[inline]
    fn memo(&self, _: &R::Task) -> Option<(MemoView<'_>, MemoKey)> {
        None
    }
}

/// The memo of a node's children ([`Memoised::child_memo`]), given the node's.
#[inline]
fn child_memo<'r, R: Memoised>(
    rule: &'r R,
    memo: &Option<(MemoView<'r>, MemoKey)>,
    left: &R::Task,
    right: &R::Task,
) -> [Option<(MemoView<'r>, MemoKey)>; 2] {
    match memo {
        Some(m) => rule.child_memo(m, left, right),
        None => [None, None],
    }
}

/// The cost of the subtree of `task` at `depth`. `memo` is [`Memoised::memo`] of the task;
/// `top`, within the top levels of a [`cost_with_top_levels`] build, is where the node (of
/// heap index `index`) and its subtree's top levels are recorded.
#[allow(clippy::too_many_arguments)]
fn node<'r, R: Memoised>(
    rule: &'r R,
    task: R::Task,
    memo: Option<(MemoView<'r>, MemoKey)>,
    cost: &CostModel,
    scratch: &mut R::Scratch,
    depth: usize,
    top: Option<(&mut TopLevels, usize)>,
) -> SubtreeCost {
    if depth >= COST_RECURSION {
        return iterative(rule, task, cost, scratch);
    }
    if let Some(k) = memo.and_then(|(m, key)| m.get(&key)) {
        if let Some((top, index)) = top {
            match k.top {
                Some(sub) => top.implant(&sub, index, depth),
                None => top.nodes[index] = Some((k.cost, k.left_len)),
            }
        }
        return k.cost;
    }
    let mut top = top;
    let (v, left_len) = match rule.split(task, scratch) {
        Step::Leaf { bounds, task } => (leaf_value(rule, &bounds, &task, cost), 0),
        Step::Split {
            bounds,
            left,
            right,
        } => {
            let left_len = rule.size(&left);
            let [ml, mr] = child_memo(rule, &memo, &left, &right);
            let d = depth + 1;
            let (l, r) = match &mut top {
                Some((top, index)) if d < TOP_LEVELS => {
                    let (i, top) = (*index, &mut **top);
                    let l = node(rule, left, ml, cost, scratch, d, Some((top, 2 * i + 1)));
                    let r = node(rule, right, mr, cost, scratch, d, Some((top, 2 * i + 2)));
                    (l, r)
                }
                _ => (
                    node(rule, left, ml, cost, scratch, d, None),
                    node(rule, right, mr, cost, scratch, d, None),
                ),
            };
            (inner_value(cost, half_area(&bounds), &l, &r), left_len)
        }
    };
    // The node's own top levels, recorded in the build's (and kept with its memo entry).
    let sub = top.map(|(top, index)| {
        top.nodes[index] = Some((v, left_len));
        (top, index)
    });
    if let Some((m, key)) = memo {
        let top = sub.map(|(top, index)| Box::new(top.extract(index, depth)));
        m.put(
            key,
            Known {
                cost: v,
                left_len,
                top,
            },
        );
    }
    v
}

/// The cost of a leaf: `n c_i`.
#[inline]
fn leaf_value<R: Rule>(rule: &R, bounds: &Aabb, task: &R::Task, cost: &CostModel) -> SubtreeCost {
    SubtreeCost {
        cost: cost.leaf_cost(rule.size(task)),
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

/// [`cost`] on an explicit stack (no memo: the nodes this deep are small).
fn iterative<R: Rule>(
    rule: &R,
    task: R::Task,
    cost: &CostModel,
    scratch: &mut R::Scratch,
) -> SubtreeCost {
    enum Item<T> {
        Visit(T),
        Combine(f64),
    }
    let mut stack = vec![Item::Visit(task)];
    let mut values: Vec<SubtreeCost> = Vec::new();
    while let Some(item) = stack.pop() {
        match item {
            Item::Visit(task) => match rule.split(task, scratch) {
                Step::Leaf { bounds, task } => values.push(leaf_value(rule, &bounds, &task, cost)),
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
    use crate::topdown::tests::{Halve, Peel};

    impl Memoised for Halve {
        fn memo(&self, _: &(u32, u32)) -> Option<(MemoView<'_>, MemoKey)> {
            None
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

    #[test]
    fn deep_chains_cost_the_same_recursively_and_iteratively() {
        let c = CostModel::default();
        for n in [1, 2, COST_RECURSION as u32, 5_000] {
            let a = cost(&Peel, (0, n), &c, &mut ());
            let b = iterative(&Peel, (0, n), &c, &mut ());
            assert_eq!(a, b, "{n}");
        }
    }
}
