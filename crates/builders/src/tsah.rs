//! The builders of Wodniok & Goesele (2017, "Construction of bounding volume hierarchies with
//! SAH cost approximation on temporary subtrees"; first published at Graphics Interface 2016 as
//! "Recursive SAH-based bounding volume hierarchy construction").
//!
//! A greedy SAH builder rates a split by Eq. 2, as if both children stayed leaves. The paper's
//! builder rates each candidate partition `(L, R)` of a node `P` instead by building temporary
//! SAH trees `T_L` and `T_R` over both sides and evaluating their real recursive cost (Eq. 1):
//!
//! ```text
//! cost(L, R) = c_t + A(L)/A(P) c(T_L) + A(R)/A(P) c(T_R)
//! ```
//!
//! It takes the cheapest candidate (the node becomes a leaf when `n c_i` is not above that
//! cost and it has at most [`TsahConfig::max_leaf_size`] primitives), throws the temporaries
//! away and recurses with the same rule. Temporaries only need their cost: they are computed
//! by the cost-only builds [`crate::rules::greedy::sweep_cost`] (or a cost-only binned build) and
//! allocate no nodes. The candidates of a node are rated in parallel on rayon and the cheapest
//! is found with the same deterministic tie-break as the sweep builder, so the tree does not
//! depend on the number of threads.
//!
//! With [`Candidates::TopK`] (rate only the `k` best candidates by Eq. 2) each node costs
//! `O(k n log n)` and the whole build `O(k N log² N)`, the subquadratic complexity the paper
//! establishes. See `docs/builders-tsah.md` for the presets and the measurements behind the
//! defaults.
//!
//! ```
//! use sahara_builders::tsah::{TsahBuilder, TsahConfig};
//! use sahara_builders::sweep::SweepBuilder;
//! use sahara_builders::{BuildInput, Builder};
//! use sahara_geom::{Triangle, Vec3A};
//! use sahara_metrics::{sah, CostModel};
//!
//! let tris: Vec<Triangle> = (0..500)
//!     .map(|i| {
//!         let o = Vec3A::new((i % 23) as f32, (i / 23) as f32 * 0.3, (i % 7) as f32);
//!         Triangle::new(o, o + Vec3A::X * 0.9, o + Vec3A::Z * 0.4)
//!     })
//!     .collect();
//! let input = BuildInput::new(&tris, CostModel::default()).unwrap();
//! let tsah_tree = TsahBuilder::new(TsahConfig::TOP_K).build(&input).unwrap();
//! tsah_tree.validate(&tris).unwrap();
//! // With the greedy-best split among the candidates and sweep temporaries, the SAH cost is
//! // never above that of the sweep builder's tree.
//! let sweep_tree = SweepBuilder::default().build(&input).unwrap();
//! assert!(sah(&tsah_tree, &input.cost) <= sah(&sweep_tree, &input.cost) * (1.0 + 1e-9));
//! ```

mod binned_cost;
mod median_cost;

use sahara_bvh::Bvh;

use crate::cost_only::{RootSplit, SubtreeCost, TopLevels};
use crate::rules::greedy::{sweep_cost_memo, SweepScratch};
pub use crate::rules::rated::Candidates;
use crate::rules::rated::{self, LocalNode, RatedParams, Rater};
use crate::split::binned::boxes::BoxScratch;
use crate::split::orders::{split_orders_padded, Marks};
use crate::split::sweep::SplitCandidate;
use crate::{BuildError, BuildInput, Configured, Strategy};
use binned_cost::binned_cost;

/// How the temporary subtrees that rate a candidate are built.
#[derive(Clone, Copy, Debug, PartialEq, Eq, serde::Serialize, serde::Deserialize)]
pub enum Temporary {
    /// Full-sweep SAH, exactly the tree [`crate::sweep::SweepBuilder`] would build (same
    /// `max_leaf_size`), via the cost-only [`crate::rules::greedy::sweep_cost`].
    Sweep,
    /// Binned SAH with this many bins per axis (at least 2), by a cost-only binned build
    /// over the node's centroid bounds (Wald 2007).
    Binned {
        /// Bins per axis.
        bins: usize,
    },
    /// A deliberately poor temporary: object-median splits on the axis of largest centroid
    /// extent down to leaves of at most `max_leaf_size` (a study setting, testing the
    /// paper's claim that only SAH-built temporaries help).
    Median,
}

/// Configuration of the temporary-subtree SAH builder.
#[derive(Clone, Copy, Debug, PartialEq, Eq, serde::Serialize, serde::Deserialize)]
pub struct TsahConfig {
    /// Which candidate splits are rated with temporaries.
    pub candidates: Candidates,
    /// How the temporaries are built.
    pub temporary: Temporary,
    /// Nodes with at most this many primitives are built by the plain greedy rule (Eq. 2,
    /// i.e. the sweep builder); 0 applies the paper's rule everywhere. Small nodes gain little
    /// from temporaries and cost most of the calls.
    pub greedy_below: usize,
    /// Always rate the greedy-best split (the sweep builder's choice) too, even when the
    /// candidate selection would not include it. With [`Temporary::Sweep`] this makes the
    /// tree's SAH cost never exceed the sweep builder's.
    pub always_include_greedy_best: bool,
    /// Largest leaf (at least 1), also used by the temporaries. Default 8.
    pub max_leaf_size: usize,
}

impl Default for TsahConfig {
    fn default() -> Self {
        Self::TOP_K
    }
}

impl TsahConfig {
    /// Every sweep candidate rated with sweep temporaries: `O(n² log n)` per node, small
    /// inputs only (registered as `tsah-exhaustive`).
    pub const EXHAUSTIVE: TsahConfig = TsahConfig {
        candidates: Candidates::Exhaustive,
        temporary: Temporary::Sweep,
        greedy_below: 0,
        always_include_greedy_best: true,
        max_leaf_size: 8,
    };
    /// The default `O(N log² N)` builder (registered as `tsah-topk`): on each axis the 2 best
    /// candidates by Eq. 2 (6 in all, the greedy-best among them) rated with sweep
    /// temporaries; nodes of at most 8 primitives greedy.
    pub const TOP_K: TsahConfig = TsahConfig {
        candidates: Candidates::TopK {
            k: 2,
            per_axis: true,
        },
        temporary: Temporary::Sweep,
        greedy_below: 8,
        always_include_greedy_best: true,
        max_leaf_size: 8,
    };
    /// The fastest preset (registered as `tsah-binned`): the centroid-midpoint plane of each
    /// axis (2 bins per axis) plus the greedy-best split, rated with 16-bin binned
    /// temporaries; nodes of at most 32 primitives greedy.
    pub const BINNED: TsahConfig = TsahConfig {
        candidates: Candidates::Binned { bins_per_axis: 2 },
        temporary: Temporary::Binned { bins: 16 },
        greedy_below: 32,
        always_include_greedy_best: true,
        max_leaf_size: 8,
    };
}

impl Strategy for TsahConfig {
    const NAME: &'static str = "tsah";

    fn check(&self) -> Result<(), BuildError> {
        let bad = |m: &str| Err(BuildError::InvalidConfig(format!("tsah: {m}")));
        if self.max_leaf_size == 0 {
            return bad("max_leaf_size must be at least 1");
        }
        match self.candidates {
            Candidates::TopK { k: 0, .. } | Candidates::ExhaustiveBelow { k: 0, .. } => {
                return bad("top-k needs k >= 1")
            }
            Candidates::Binned { bins_per_axis } if bins_per_axis < 2 => {
                return bad("binned candidates need at least 2 bins per axis")
            }
            _ => {}
        }
        if let Temporary::Binned { bins } = self.temporary {
            if bins < 2 {
                return bad("binned temporaries need at least 2 bins");
            }
        }
        Ok(())
    }

    fn describe(&self) -> String {
        let cands = match self.candidates {
            Candidates::Exhaustive => "all sweep candidates".to_string(),
            Candidates::TopK { k, per_axis } => {
                format!(
                    "top-{k}{} by Eq. 2",
                    if per_axis { " per axis" } else { "" }
                )
            }
            Candidates::Binned { bins_per_axis } => format!("{bins_per_axis} bins per axis"),
            Candidates::ExhaustiveBelow { up_to, k } => {
                format!("all sweep candidates up to {up_to} prims, top-{k} per axis above")
            }
        };
        let temps = match self.temporary {
            Temporary::Sweep => "sweep".to_string(),
            Temporary::Binned { bins } => format!("binned ({bins} bins)"),
            Temporary::Median => "median-split".to_string(),
        };
        format!(
            "temporary-subtree SAH (Wodniok & Goesele): {cands}{}, {temps} temporaries, greedy at <= {} prims, max leaf {}",
            if self.always_include_greedy_best { " + greedy best" } else { "" },
            self.greedy_below,
            self.max_leaf_size
        )
    }

    fn build_tree(&self, input: &BuildInput) -> Result<Bvh, BuildError> {
        let params = RatedParams {
            candidates: self.candidates,
            include_greedy: self.always_include_greedy_best,
            greedy_below: self.greedy_below,
            max_leaf_size: self.max_leaf_size,
        };
        let rater = TemporaryRater {
            cost: input.cost,
            max_leaf: self.max_leaf_size,
            temporary: self.temporary,
        };
        rated::build(input, &params, &rater)
    }
}

/// The temporary-subtree SAH builder of Wodniok & Goesele (named `"tsah"` by
/// [`Configured::new`]).
pub type TsahBuilder = Configured<TsahConfig>;

/// Nodes at least this large rate the two sides of a candidate on two rayon tasks.
const JOIN_SIDES: usize = 4096;

/// Rates candidates with temporary subtrees.
struct TemporaryRater {
    pub cost: sahara_metrics::CostModel,
    pub max_leaf: usize,
    pub temporary: Temporary,
}

/// Reusable buffers of [`TemporaryRater`].
#[derive(Default)]
struct TempScratch {
    marks: Marks,
    left: [Vec<u32>; 3],
    right: [Vec<u32>; 3],
    sweep: SweepScratch,
    binned: BoxScratch,
    boxes: Vec<sahara_geom::Aabb>,
}

impl Rater for TemporaryRater {
    type Scratch = TempScratch;

    fn rate(&self, node: &LocalNode, c: &SplitCandidate, sc: &mut TempScratch) -> f64 {
        self.rate_hinted(node, c, sc).0
    }

    fn rate_hinted(
        &self,
        node: &LocalNode,
        c: &SplitCandidate,
        sc: &mut TempScratch,
    ) -> (f64, [TopLevels; 2]) {
        if self.temporary == Temporary::Sweep {
            let ((l, lh), (r, rh)) = sweep_sides(node, c, &self.cost, self.max_leaf, sc);
            let rating = self
                .cost
                .inner_cost(node.area, l.area, l.cost, r.area, r.cost);
            return (rating, [lh, rh]);
        }
        (self.rate_other(node, c, sc), [TopLevels::NONE; 2])
    }

    fn rate_from_hint(&self, node: &LocalNode, hint: &RootSplit) -> Option<f64> {
        // `rate_hinted` of the node's greedy candidate: its sides' sweep temporaries are the
        // hint's two subtrees.
        (self.temporary == Temporary::Sweep).then(|| {
            let (l, r) = (&hint.left, &hint.right);
            self.cost
                .inner_cost(node.area, l.area, l.cost, r.area, r.cost)
        })
    }
}

impl TemporaryRater {
    /// The rating with median or binned temporaries.
    fn rate_other(&self, node: &LocalNode, c: &SplitCandidate, sc: &mut TempScratch) -> f64 {
        let (l, r) = match self.temporary {
            Temporary::Sweep => unreachable!("sweep temporaries are rated by `rate_hinted`"),
            Temporary::Median => {
                let (lo, hi) = node.orders[c.axis].split_at(c.pos);
                let mut side = |ids: &[u32]| {
                    sc.boxes.clear();
                    sc.boxes
                        .extend(ids.iter().map(|&i| node.bounds[i as usize]));
                    median_cost::median_cost(&mut sc.boxes, &self.cost, self.max_leaf)
                };
                (side(lo), side(hi))
            }
            Temporary::Binned { bins } => {
                let order = &node.orders[c.axis];
                let side =
                    |ids: &[u32], boxes: &mut Vec<sahara_geom::Aabb>, bs: &mut BoxScratch| {
                        boxes.clear();
                        boxes.extend(ids.iter().map(|&i| node.bounds[i as usize]));
                        binned_cost(boxes, bins, &self.cost, self.max_leaf, bs)
                    };
                let (lo, hi) = order.split_at(c.pos);
                if node.len() >= JOIN_SIDES {
                    rayon::join(
                        || side(lo, &mut sc.boxes, &mut sc.binned),
                        || side(hi, &mut Vec::new(), &mut BoxScratch::default()),
                    )
                } else {
                    (
                        side(lo, &mut sc.boxes, &mut sc.binned),
                        side(hi, &mut sc.boxes, &mut sc.binned),
                    )
                }
            }
        };
        self.cost
            .inner_cost(node.area, l.area, l.cost, r.area, r.cost)
    }
}

/// The costs of sweep temporaries over both sides of a candidate of a local node.
fn sweep_sides(
    node: &LocalNode,
    c: &SplitCandidate,
    cost: &sahara_metrics::CostModel,
    max_leaf: usize,
    sc: &mut TempScratch,
) -> ((SubtreeCost, TopLevels), (SubtreeCost, TopLevels)) {
    let n = node.len();
    let TempScratch {
        marks,
        left,
        right,
        sweep: sweep_scratch,
        ..
    } = sc;
    marks.reserve_ids(n);
    // One spare id at the end of each side's buffers (`split_orders_padded`).
    for (l, r) in left.iter_mut().zip(right.iter_mut()) {
        l.resize(c.pos + 1, 0);
        r.resize(n - c.pos + 1, 0);
    }
    {
        let [l0, l1, l2] = &mut *left;
        let [r0, r1, r2] = &mut *right;
        split_orders_padded(
            node.orders(),
            c.axis,
            c.pos,
            marks,
            [l0, l1, l2],
            [r0, r1, r2],
        );
    }
    let marks = &*marks;
    let side = |o: &mut [Vec<u32>; 3], s: &mut SweepScratch| {
        let [a, b, c] = o;
        let len = a.len() - 1;
        let (a, b, c) = (&mut a[..len], &mut b[..len], &mut c[..len]);
        sweep_cost_memo(
            &node.bounds,
            [a, b, c],
            marks,
            cost,
            max_leaf,
            s,
            Some(node.memo_view()),
        )
    };
    if n >= JOIN_SIDES {
        rayon::join(
            || side(left, sweep_scratch),
            || side(right, &mut SweepScratch::new()),
        )
    } else {
        (side(left, sweep_scratch), side(right, sweep_scratch))
    }
}
