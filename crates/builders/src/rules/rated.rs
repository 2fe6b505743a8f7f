//! The rated rule, shared by the temporary-subtree builders ([`crate::tsah`]) and the
//! look-ahead builders ([`crate::popov`]): at every node, sweep the three sorted orders (Eq. 2
//! at every position), select candidate splits ([`Candidates`]), rate each with a rater
//! (in parallel for large nodes; the builders differ only in their raters), take the cheapest
//! (deterministic tie-break), decide leaf or split. Nodes at or below `greedy_below`
//! primitives are split by the plain sweep rule ([`Greedy`]).

use std::sync::atomic::{AtomicU32, Ordering};

use rayon::prelude::*;
use sahara_bvh::Bvh;
use sahara_geom::{Aabb, Vec3A};

use crate::cost_only::{MemoView, RootSplit, SubtreeMemo, TopLevels};
use crate::rules::greedy::{Greedy, Job, JobStorage, PARALLEL_THRESHOLD};
use crate::split::orders::Marks;
use crate::split::sweep::{sweep_axis, SplitCandidate};
use crate::split::{offer, BinMap};
use crate::topdown::{self, Rule, Step};
use crate::{BuildError, BuildInput};
use std::sync::Arc;

/// Which candidate splits of a node are rated with temporary subtrees.
#[derive(Clone, Copy, Debug, PartialEq, Eq, serde::Serialize, serde::Deserialize)]
pub enum Candidates {
    /// Every one of the `3 (n - 1)` sweep positions: `O(n² log n)` per node, a reference for
    /// small inputs and tests.
    Exhaustive,
    /// The `k` best sweep positions by Eq. 2 (same tie-break as the sweep builder), over all
    /// three axes together or, with `per_axis`, `k` on each axis (`3k` in all).
    TopK {
        /// Number of candidates (per axis with `per_axis`), at least 1.
        k: usize,
        /// Select `k` per axis instead of `k` overall.
        per_axis: bool,
    },
    /// The split positions of `bins_per_axis` equal-width bins over the node's centroid
    /// extent on each axis (at most `bins_per_axis - 1` planes per axis; planes that separate
    /// nothing, or the same primitives as the previous plane, are skipped).
    Binned {
        /// Number of bins per axis, at least 2.
        bins_per_axis: usize,
    },
    /// [`Candidates::Exhaustive`] at nodes of at most `up_to` primitives, the `k` best per
    /// axis by Eq. 2 above (a study setting: is the top-k selection what loses the gain?).
    ExhaustiveBelow {
        /// Largest node rated exhaustively.
        up_to: usize,
        /// Candidates per axis at larger nodes, at least 1.
        k: usize,
    },
}

/// Rates a candidate split of a node (smaller is better). Implementations are called in
/// parallel for the candidates of a node and must be deterministic.
pub(crate) trait Rater: Sync {
    /// Buffers a rating may reuse.
    type Scratch: Default + Send;
    /// The rating of `cand` (a split of `node`'s sorted orders).
    fn rate(&self, node: &LocalNode, cand: &SplitCandidate, scratch: &mut Self::Scratch) -> f64;

    /// [`rate`](Self::rate), and for each side of `cand` a hint for that side's own rating
    /// when it becomes a node: the top levels of the side's temporary subtree (if the rater
    /// builds one). By default no hints.
    fn rate_hinted(
        &self,
        node: &LocalNode,
        cand: &SplitCandidate,
        scratch: &mut Self::Scratch,
    ) -> (f64, [TopLevels; 2]) {
        (self.rate(node, cand, scratch), [TopLevels::NONE; 2])
    }

    /// The rating of `node`'s greedy candidate (its best split by Eq. 2) from the hint its
    /// parent's rating left for it, bit for bit what [`rate`](Self::rate) would return, or
    /// `None` when the rater cannot tell. By default `None`.
    fn rate_from_hint(&self, _node: &LocalNode, _hint: &RootSplit) -> Option<f64> {
        None
    }
}

/// A node of the rated builder: its sorted orders and, where an ancestor's rating built a
/// temporary subtree over exactly this node, the top levels of that temporary (see
/// [`Rater::rate_hinted`]). The temporary's root is split by the same greedy rule as this
/// node's greedy candidate, over the same boxes in the same orders, so its children's costs
/// are that candidate's rating inputs: reusing them saves two temporaries per node. When
/// the greedy candidate wins, its children inherit the temporary's next levels.
pub(crate) struct Hinted<'a> {
    job: Job<'a>,
    hint: TopLevels,
    /// The memo of the parent's temporaries, which built subtrees over this node's
    /// primitives (see [`LocalNode::memo`]).
    memo: Option<Arc<SubtreeMemo>>,
}

impl<'a> From<Job<'a>> for Hinted<'a> {
    fn from(job: Job<'a>) -> Self {
        Self {
            job,
            hint: TopLevels::NONE,
            memo: None,
        }
    }
}

/// A candidate's rating and the hints for its sides ([`Rater::rate_hinted`]).
type Rating = (f64, [TopLevels; 2]);

/// Nodes at least this large rate their candidates in parallel; smaller ones rate them on the
/// current thread with the driver's scratch.
const PAR_RATE: usize = 1024;

/// How candidates are chosen and when to stop.
#[derive(Clone, Copy, Debug)]
pub(crate) struct RatedParams {
    pub candidates: Candidates,
    pub include_greedy: bool,
    pub greedy_below: usize,
    pub max_leaf_size: usize,
}

/// A node's primitives relabelled `0..n` (by their position in the node's x order), so that
/// raters work on small dense arrays: their boxes and the three sorted orders in local ids.
pub(crate) struct LocalNode {
    pub bounds: Vec<Aabb>,
    pub orders: [Vec<u32>; 3],
    /// Half area of the node's bounds.
    pub area: f64,
    /// The subtree costs of the temporaries built so far over this node's primitives (see
    /// [`SubtreeMemo`]): neighbouring candidates' sides differ by a few primitives, so their
    /// temporaries share most subtrees. The children read it too: the temporaries of their
    /// candidates share subtrees with those of this node's.
    pub memo: Arc<SubtreeMemo>,
    /// The parent's memo, read as well.
    pub parent_memo: Option<Arc<SubtreeMemo>>,
}

/// The smallest temporary subtree a node's [`SubtreeMemo`] keeps: at least [`MEMO_MIN`]
/// references and `1 / MEMO_FRACTION` of the node (the memo saves most where a reused
/// subtree is large; small entries would cost more to key and store than they save).
const MEMO_MIN: usize = 32;
const MEMO_FRACTION: usize = 1024;

impl LocalNode {
    /// The memos the temporaries over this node's primitives use.
    pub fn memo_view(&self) -> MemoView<'_> {
        MemoView {
            own: &self.memo,
            other: self.parent_memo.as_deref(),
        }
    }

    pub fn len(&self) -> usize {
        self.bounds.len()
    }

    pub fn orders(&self) -> [&[u32]; 3] {
        [&self.orders[0], &self.orders[1], &self.orders[2]]
    }
}

/// The rule: [`Greedy`] for small nodes, rated candidates above.
struct Rated<'a, R: Rater> {
    greedy: Greedy<'a>,
    centroids: &'a [Vec3A],
    params: RatedParams,
    rater: &'a R,
    /// Global id -> local id of the node being rated (nodes rated concurrently are disjoint).
    local_of: Vec<AtomicU32>,
}

/// Builds the tree over a non-empty input.
pub(crate) fn build<R: Rater>(
    input: &BuildInput,
    params: &RatedParams,
    rater: &R,
) -> Result<Bvh, BuildError> {
    let marks = Marks::new(input.len());
    let rule = Rated {
        greedy: Greedy {
            bounds: input.bounds(),
            cost: input.cost,
            max_leaf: params.max_leaf_size.max(1),
            marks: &marks,
            parallel_threshold: PARALLEL_THRESHOLD,
            memo: None,
        },
        centroids: input.centroids(),
        params: *params,
        rater,
        local_of: (0..input.len()).map(|_| AtomicU32::new(0)).collect(),
    };
    let mut storage = JobStorage::new(input.len(), input.centroids());
    Ok(topdown::build(&rule, storage.root().into(), false))
}

impl<'a, R: Rater> Rule for Rated<'a, R> {
    type Task = Hinted<'a>;
    type Scratch = R::Scratch;

    fn size(&self, t: &Hinted<'a>) -> usize {
        t.job.len()
    }

    fn split(&self, t: Hinted<'a>, scratch: &mut R::Scratch) -> Step<Hinted<'a>> {
        if t.job.len() <= self.params.greedy_below.max(1) {
            self.greedy.decide(t.job).map(Hinted::from)
        } else {
            self.node(t, scratch)
        }
    }

    fn leaf_refs(&self, t: &Hinted<'a>, out: &mut Vec<u32>) {
        out.extend_from_slice(t.job.orders[0]);
    }

    fn parallel_threshold(&self) -> usize {
        PAR_RATE
    }
}
/// Collects candidate splits during the sweep of a node.
enum Collector {
    All(Vec<SplitCandidate>),
    TopK {
        k: usize,
        lists: [Vec<SplitCandidate>; 3],
        per_axis: bool,
    },
    Positions {
        wanted: [Vec<usize>; 3],
        cursor: [usize; 3],
        out: Vec<SplitCandidate>,
    },
}

impl Collector {
    fn new(c: &Candidates, orders: [&[u32]; 3], centroids: &[Vec3A]) -> Self {
        match *c {
            Candidates::Exhaustive => Collector::All(Vec::new()),
            Candidates::ExhaustiveBelow { up_to, .. } if orders[0].len() <= up_to => {
                Collector::All(Vec::new())
            }
            Candidates::ExhaustiveBelow { k, .. } => Collector::TopK {
                k,
                lists: Default::default(),
                per_axis: true,
            },
            Candidates::TopK { k, per_axis } => Collector::TopK {
                k,
                lists: Default::default(),
                per_axis,
            },
            Candidates::Binned { bins_per_axis } => Collector::Positions {
                wanted: std::array::from_fn(|axis| {
                    bin_positions(orders[axis], centroids, axis, bins_per_axis)
                }),
                cursor: [0; 3],
                out: Vec::new(),
            },
        }
    }

    #[inline]
    fn offer(&mut self, c: SplitCandidate, n: usize) {
        match self {
            Collector::All(v) => v.push(c),
            Collector::TopK { k, lists, per_axis } => {
                let list = if *per_axis {
                    &mut lists[c.axis]
                } else {
                    &mut lists[0]
                };
                offer_top_k(list, *k, c, n);
            }
            Collector::Positions {
                wanted,
                cursor,
                out,
            } => {
                let w = &wanted[c.axis];
                let cur = &mut cursor[c.axis];
                if *cur < w.len() && w[*cur] == c.pos {
                    *cur += 1;
                    out.push(c);
                }
            }
        }
    }

    fn finish(self) -> Vec<SplitCandidate> {
        match self {
            Collector::All(v) | Collector::Positions { out: v, .. } => v,
            Collector::TopK { lists, .. } => lists.into_iter().flatten().collect(),
        }
    }
}

/// Keeps the `k` best candidates, best first.
#[inline]
pub(crate) fn offer_top_k(list: &mut Vec<SplitCandidate>, k: usize, c: SplitCandidate, n: usize) {
    offer(list, k, c, |a, b| a.better_than(b, n));
}

/// The split positions of `bins` equal-width bins over the centroid extent of a sorted order:
/// position `p` of plane `j` counts the primitives whose bin is below `j`. Distinct, within
/// `1..n`, increasing.
fn bin_positions(order: &[u32], centroids: &[Vec3A], axis: usize, bins: usize) -> Vec<usize> {
    let n = order.len();
    let lo = centroids[order[0] as usize][axis];
    let hi = centroids[order[n - 1] as usize][axis];
    let Some(map) = BinMap::new(lo, hi, bins) else {
        return Vec::new();
    };
    let mut out = Vec::with_capacity(bins);
    for j in 1..bins {
        let p = order.partition_point(|&id| map.bin(centroids[id as usize][axis]) < j);
        if p > 0 && p < n && out.last() != Some(&p) {
            out.push(p);
        }
    }
    out
}

impl<'a, R: Rater> Rated<'a, R> {
    /// One node of the paper's builder: candidates, ratings, leaf or split.
    fn node(&self, t: Hinted<'a>, scratch: &mut R::Scratch) -> Step<Hinted<'a>> {
        let Hinted { job, hint, memo } = t;
        let g = &self.greedy;
        let n = job.len();
        if n == 1 {
            let bounds = g.bounds[job.orders[0][0] as usize];
            return Step::Leaf {
                bounds,
                task: job.into(),
            };
        }
        let orders = [&*job.orders[0], &*job.orders[1], &*job.orders[2]];
        let mut collector = Collector::new(&self.params.candidates, orders, self.centroids);
        let mut greedy = SplitCandidate::fallback(n);
        let mut node_bounds = Aabb::EMPTY;
        for (axis, order) in orders.iter().enumerate() {
            node_bounds = sweep_axis(g.bounds, order, axis, job.areas, &g.cost, |c| {
                if c.better_than(&greedy, n) {
                    greedy = c;
                }
                collector.offer(c, n);
            });
        }
        let mut cands = collector.finish();
        if (self.params.include_greedy || cands.is_empty())
            && !cands
                .iter()
                .any(|c| c.axis == greedy.axis && c.pos == greedy.pos)
        {
            cands.push(greedy);
        }

        let must_split = n > g.max_leaf;
        let (best, hints, memo) = if must_split && cands.len() == 1 {
            // Nothing to compare: skip the ratings.
            (cands[0], [TopLevels::NONE; 2], memo)
        } else {
            let local = self.local_node(orders, &node_bounds, memo);
            // The greedy candidate's rating from an ancestor's temporary over this node (see
            // `Hinted`). Its root split is this node's greedy split only where Eq. 2 is
            // finite: the sweep's pruning of positions (`best_split`) equals the full
            // evaluation for a finite best, not where every cost overflows (denormal or huge
            // boxes, which the hard cases have). The sides' sizes and areas must match too.
            let hinted = hint
                .root_split()
                .filter(|h| {
                    greedy.cost.is_finite()
                        && h.left_len == greedy.pos
                        && h.left.area == greedy.left_area
                        && h.right.area == greedy.right_area
                })
                .and_then(|h| self.rater.rate_from_hint(&local, &h));
            let rate = |c: &SplitCandidate, sc: &mut R::Scratch| match hinted {
                Some(rating) if c.axis == greedy.axis && c.pos == greedy.pos => {
                    debug_assert_eq!(
                        rating.to_bits(),
                        self.rater.rate(&local, c, sc).to_bits(),
                        "a hinted rating differs from the rating"
                    );
                    // The candidate's sides are the temporary's children: their own top
                    // levels are the hint's next ones.
                    (rating, [hint.child(0), hint.child(1)])
                }
                _ => self.rater.rate_hinted(&local, c, sc),
            };
            let rated: Vec<Rating> = if n >= PAR_RATE {
                // The axes in parallel, the candidates of an axis one after the other: they
                // are neighbours, so the later ones find most of their subtrees in the
                // node's memo.
                let mut by_axis: [Vec<usize>; 3] = Default::default();
                for (i, c) in cands.iter().enumerate() {
                    by_axis[c.axis].push(i);
                }
                let per_axis: Vec<Vec<(usize, Rating)>> = by_axis
                    .par_iter()
                    .map_init(R::Scratch::default, |sc, ids| {
                        ids.iter().map(|&i| (i, rate(&cands[i], sc))).collect()
                    })
                    .collect();
                let mut rated = vec![(0.0, [TopLevels::NONE; 2]); cands.len()];
                for (i, r) in per_axis.into_iter().flatten() {
                    rated[i] = r;
                }
                rated
            } else {
                cands.iter().map(|c| rate(c, scratch)).collect()
            };
            let ratings: Vec<f64> = rated.iter().map(|r| r.0).collect();
            let mut best = 0;
            for i in 1..cands.len() {
                let a = SplitCandidate {
                    cost: ratings[i],
                    ..cands[i]
                };
                let b = SplitCandidate {
                    cost: ratings[best],
                    ..cands[best]
                };
                if a.better_than(&b, n) {
                    best = i;
                }
            }
            if !must_split && g.cost.leaf_cost(n) <= ratings[best] {
                return Step::Leaf {
                    bounds: node_bounds,
                    task: job.into(),
                };
            }
            (cands[best], rated[best].1, Some(local.memo))
        };
        let (left, right) = job.split(best.axis, best.pos, g.marks);
        // Only children that will rate candidates keep the memo alive: a small sibling waiting
        // on the stack (a chain of them on adversarial input) would hold it for nothing.
        let rated = |j: &Job| j.len() > self.params.greedy_below.max(1);
        let memo_of = |j: &Job| memo.clone().filter(|_| rated(j));
        Step::Split {
            bounds: node_bounds,
            left: Hinted {
                hint: hints[0],
                memo: memo_of(&left),
                job: left,
            },
            right: Hinted {
                hint: hints[1],
                memo: memo_of(&right),
                job: right,
            },
        }
    }

    fn local_node(
        &self,
        orders: [&[u32]; 3],
        node_bounds: &Aabb,
        parent_memo: Option<Arc<SubtreeMemo>>,
    ) -> LocalNode {
        let n = orders[0].len();
        for (j, &g) in orders[0].iter().enumerate() {
            self.local_of[g as usize].store(j as u32, Ordering::Relaxed);
        }
        let relabel = |o: &[u32]| -> Vec<u32> {
            o.iter()
                .map(|&g| self.local_of[g as usize].load(Ordering::Relaxed))
                .collect()
        };
        LocalNode {
            bounds: orders[0]
                .iter()
                .map(|&g| self.greedy.bounds[g as usize])
                .collect(),
            orders: [
                (0..n as u32).collect(),
                relabel(orders[1]),
                relabel(orders[2]),
            ],
            area: node_bounds.half_area() as f64,
            memo: Arc::new(SubtreeMemo::new(MEMO_MIN.max(n / MEMO_FRACTION), orders[0])),
            parent_memo,
        }
    }
}
