//! Look-ahead SAH construction, after the generic algorithm of Popov, Georgiev, Dimov &
//! Slusallek (2009, "Object partitioning considered harmful: space subdivision for BVHs"), of
//! which greedy builders are the depth-one case, and its hybrid with the temporary subtrees of
//! Wodniok & Goesele (2017), who compare against both.
//!
//! **Our reading** (the source paper's body is not available to us; see
//! `docs/builders-tsah.md`): a candidate split of a node is rated by optimising its children
//! `depth - 1` further levels ahead. Each look-ahead node `S` is worth
//!
//! ```text
//! LA(S, 0) = |S| c_i                    (frontier: Eq. 2 style)   -- or c(T_S), see below
//! LA(S, d) = min( |S| c_i  if |S| <= max leaf,
//!                 min over the k best splits (L, R) of S by Eq. 2 of
//!                     c_t + A(L)/A(S) LA(L, d - 1) + A(R)/A(S) LA(R, d - 1) )
//! ```
//!
//! and the rating of a split `(L, R)` of the node being built is
//! `c_t + A(L)/A(P) LA(L, depth - 1) + A(R)/A(P) LA(R, depth - 1)`. With `depth = 1` this is
//! Eq. 2: the greedy sweep builder. The candidates of the node itself are also the `k` best by
//! Eq. 2 (overall, or on each axis with [`PopovConfig::per_axis`]). A single primitive is always
//! a leaf.
//!
//! The **hybrid** ([`Frontier::Temporary`]) costs the frontier nodes with temporary sweep SAH
//! subtrees, `LA(S, 0) = c(T_S)` (the cost-only [`crate::rules::greedy::sweep_cost`]), instead of as
//! leaves; with `depth = 1` it is exactly the top-k temporary-subtree builder.
//!
//! ```
//! use sahara_builders::popov::{PopovBuilder, PopovConfig};
//! use sahara_builders::{BuildInput, Builder};
//! use sahara_geom::{Triangle, Vec3A};
//! use sahara_metrics::CostModel;
//!
//! let tris: Vec<Triangle> = (0..300)
//!     .map(|i| {
//!         let o = Vec3A::new((i % 19) as f32, (i / 19) as f32, 0.0);
//!         Triangle::new(o, o + Vec3A::X, o + Vec3A::Y)
//!     })
//!     .collect();
//! let input = BuildInput::new(&tris, CostModel::default()).unwrap();
//! for config in [PopovConfig::D2, PopovConfig::HYBRID] {
//!     PopovBuilder::new(config).build(&input).unwrap().validate(&tris).unwrap();
//! }
//! ```

use sahara_bvh::Bvh;
use sahara_geom::Aabb;
use sahara_metrics::CostModel;

use crate::cost_only::MemoView;
use crate::rules::greedy::{sweep_cost_memo, SweepScratch};
use crate::rules::rated::{self, offer_top_k, Candidates, LocalNode, RatedParams, Rater};
use crate::split::orders::{split_orders, Marks};
use crate::split::sweep::{sweep_axis, SplitCandidate};
use crate::{BuildError, BuildInput, Configured, Strategy};

/// How the frontier nodes of the look-ahead are costed.
#[derive(Clone, Copy, Debug, PartialEq, Eq, serde::Serialize, serde::Deserialize)]
pub enum Frontier {
    /// As leaves, `|S| c_i` (the look-ahead SAH of Popov et al., in our reading).
    Leaf,
    /// By the cost of a temporary sweep SAH subtree over them (the hybrid with Wodniok &
    /// Goesele's temporaries).
    Temporary,
}

/// Configuration of the look-ahead builders.
#[derive(Clone, Copy, Debug, PartialEq, Eq, serde::Serialize, serde::Deserialize)]
pub struct PopovConfig {
    /// Look-ahead depth `d` (at least 1): a split is rated by optimising its children `d - 1`
    /// levels further. `d = 1` is the greedy builder (or, with [`Frontier::Temporary`], the
    /// top-k temporary-subtree builder).
    pub depth: usize,
    /// Number of candidates (the best by Eq. 2) tried at every node and every look-ahead
    /// level, at least 1; per axis with `per_axis`.
    pub k: usize,
    /// Take the `k` best candidates of each axis (`3k` in all) instead of the `k` best overall.
    pub per_axis: bool,
    /// How frontier nodes are costed.
    pub frontier: Frontier,
    /// Nodes with at most this many primitives are built by the plain greedy rule (0: never).
    pub greedy_below: usize,
    /// Largest leaf (at least 1), also in the look-ahead and the temporaries. Default 8.
    pub max_leaf_size: usize,
}

impl Default for PopovConfig {
    fn default() -> Self {
        Self::D2
    }
}

impl PopovConfig {
    /// Two levels (the split and its children's best splits), 8 candidates per level, frontier
    /// costed as leaves (registered as `popov-d2`).
    pub const D2: PopovConfig = PopovConfig {
        depth: 2,
        k: 8,
        per_axis: false,
        frontier: Frontier::Leaf,
        greedy_below: 16,
        max_leaf_size: 8,
    };
    /// Three levels, 4 candidates per level (registered as `popov-d3`).
    pub const D3: PopovConfig = PopovConfig {
        depth: 3,
        k: 4,
        per_axis: false,
        frontier: Frontier::Leaf,
        greedy_below: 16,
        max_leaf_size: 8,
    };
    /// The hybrid (registered as `hybrid`): two levels, the best candidate of each axis per
    /// level, frontier costed with temporary sweep subtrees; nodes of at most 8 primitives
    /// greedy.
    pub const HYBRID: PopovConfig = PopovConfig {
        depth: 2,
        k: 1,
        per_axis: true,
        frontier: Frontier::Temporary,
        greedy_below: 8,
        max_leaf_size: 8,
    };
}

impl Strategy for PopovConfig {
    const NAME: &'static str = "popov";

    fn check(&self) -> Result<(), BuildError> {
        if self.depth == 0 || self.k == 0 || self.max_leaf_size == 0 {
            return Err(BuildError::InvalidConfig(
                "popov: depth, k and max_leaf_size must be at least 1".into(),
            ));
        }
        Ok(())
    }

    fn describe(&self) -> String {
        format!(
            "look-ahead SAH (after Popov et al.), depth {}, top-{} per level, frontier {}, greedy at <= {} prims, max leaf {}",
            self.depth,
            self.k,
            match self.frontier {
                Frontier::Leaf => "as leaves",
                Frontier::Temporary => "by temporary sweep subtrees (hybrid)",
            },
            self.greedy_below,
            self.max_leaf_size
        )
    }

    fn build_tree(&self, input: &BuildInput) -> Result<Bvh, BuildError> {
        let c = self;
        let params = RatedParams {
            candidates: Candidates::TopK {
                k: c.k,
                per_axis: c.per_axis,
            },
            include_greedy: true,
            greedy_below: c.greedy_below,
            max_leaf_size: c.max_leaf_size,
        };
        let rater = LookAhead {
            cost: input.cost,
            depth: c.depth,
            k: c.k,
            per_axis: c.per_axis,
            frontier: c.frontier,
            max_leaf: c.max_leaf_size,
        };
        rated::build(input, &params, &rater)
    }
}

/// The look-ahead SAH builder and its hybrid (named `"popov"` by [`Configured::new`]).
pub type PopovBuilder = Configured<PopovConfig>;

struct LookAhead {
    cost: CostModel,
    depth: usize,
    k: usize,
    per_axis: bool,
    frontier: Frontier,
    max_leaf: usize,
}

impl Rater for LookAhead {
    type Scratch = ();

    fn rate(&self, node: &LocalNode, c: &SplitCandidate, _: &mut ()) -> f64 {
        if self.depth <= 1 && self.frontier == Frontier::Leaf {
            return c.cost;
        }
        let marks = Marks::new(node.len());
        let (mut l, mut r) = split(node.orders(), c, &marks);
        let memo = node.memo_view();
        let cl = self.look_ahead(&node.bounds, &mut l, self.depth - 1, &marks, memo);
        let cr = self.look_ahead(&node.bounds, &mut r, self.depth - 1, &marks, memo);
        self.cost
            .inner_cost(node.area, c.left_area, cl, c.right_area, cr)
    }
}

impl LookAhead {
    /// `LA(S, depth)` of the set whose sorted orders are given (permuted by the hybrid's
    /// temporaries, which share their subtrees through `memo`: the frontiers of neighbouring
    /// candidates, and of a node and its children, overlap).
    fn look_ahead(
        &self,
        bounds: &[Aabb],
        orders: &mut [Vec<u32>; 3],
        depth: usize,
        marks: &Marks,
        memo: MemoView,
    ) -> f64 {
        let n = orders[0].len();
        if n == 1 {
            return self.cost.leaf_cost(1);
        }
        if depth == 0 {
            return match self.frontier {
                Frontier::Leaf => self.cost.leaf_cost(n),
                Frontier::Temporary => {
                    let [a, b, c] = orders;
                    sweep_cost_memo(
                        bounds,
                        [a, b, c],
                        marks,
                        &self.cost,
                        self.max_leaf,
                        &mut SweepScratch::new(),
                        Some(memo),
                    )
                    .0
                    .cost
                }
            };
        }
        let mut areas = vec![0.0f32; n];
        let mut lists: [Vec<SplitCandidate>; 3] = Default::default();
        let mut node = Aabb::EMPTY;
        for (axis, order) in orders.iter().enumerate() {
            let list = &mut lists[if self.per_axis { axis } else { 0 }];
            node = sweep_axis(bounds, order, axis, &mut areas, &self.cost, |c| {
                offer_top_k(list, self.k, c, n)
            });
        }
        let top: Vec<SplitCandidate> = lists.into_iter().flatten().collect();
        let area = node.half_area() as f64;
        let mut best = if n <= self.max_leaf {
            self.cost.leaf_cost(n)
        } else {
            f64::INFINITY
        };
        let leaf_frontier = depth == 1 && self.frontier == Frontier::Leaf;
        for c in &top {
            let rating = if leaf_frontier {
                c.cost
            } else {
                let (mut l, mut r) = split([&orders[0], &orders[1], &orders[2]], c, marks);
                let cl = self.look_ahead(bounds, &mut l, depth - 1, marks, memo);
                let cr = self.look_ahead(bounds, &mut r, depth - 1, marks, memo);
                self.cost
                    .inner_cost(area, c.left_area, cl, c.right_area, cr)
            };
            if rating < best {
                best = rating;
            }
        }
        best
    }
}

/// The sorted orders of both sides of a candidate, in new vectors.
fn split(orders: [&[u32]; 3], c: &SplitCandidate, marks: &Marks) -> ([Vec<u32>; 3], [Vec<u32>; 3]) {
    let n = orders[0].len();
    let mut left: [Vec<u32>; 3] = std::array::from_fn(|_| vec![0; c.pos]);
    let mut right: [Vec<u32>; 3] = std::array::from_fn(|_| vec![0; n - c.pos]);
    {
        let [l0, l1, l2] = &mut left;
        let [r0, r1, r2] = &mut right;
        split_orders(orders, c.axis, c.pos, marks, [l0, l1, l2], [r0, r1, r2]);
    }
    (left, right)
}
