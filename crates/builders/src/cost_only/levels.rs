//! What a cost-only build returns: the cost of a subtree, and the costs of its top levels.

/// The SAH cost of a (temporary) subtree and the half area of its root's bounds.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SubtreeCost {
    /// `c(T)` of Eq. 1, relative to the subtree root's own bounds (the expected cost of a ray
    /// that hits the root's box).
    pub cost: f64,
    /// Half the surface area of the root's bounds (as `f64`).
    pub area: f64,
}

impl SubtreeCost {
    /// The cost of nothing.
    pub const ZERO: SubtreeCost = SubtreeCost {
        cost: 0.0,
        area: 0.0,
    };
}

/// Levels of a subtree whose node costs [`cost_with_top_levels`](super::cost_with_top_levels)
/// records.
pub const TOP_LEVELS: usize = 4;
const TOP_NODES: usize = (1 << TOP_LEVELS) - 1;

/// The costs of the nodes in the top [`TOP_LEVELS`] levels of a subtree that a cost-only build
/// computed on the way (heap order: node `i`'s children are `2i + 1` and `2i + 2`), with the
/// size of each split node's left child: enough to know, without building them again, what
/// the subtrees of the root's children, grandchildren... cost.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct TopLevels {
    /// `(c(T), size of the left child)` of each node (`0` for a leaf), `None` below the tree.
    pub(super) nodes: [Option<(SubtreeCost, usize)>; TOP_NODES],
}

/// The split of a subtree's root: the size of its left child and the costs of both children.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct RootSplit {
    /// References of the left child ([`Rule::size`](crate::topdown::Rule::size)).
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
    pub(super) fn extract(&self, index: usize, depth: usize) -> TopLevels {
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
    pub(super) fn implant(&mut self, sub: &TopLevels, index: usize, depth: usize) {
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
