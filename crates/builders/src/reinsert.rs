//! Reinsertion: a post-pass that lowers the SAH cost of any binary [`Bvh`] by moving subtrees
//! (after Bittner, Hapala & Havran 2013, "Fast insertion-based optimization of bounding volume
//! hierarchies", and Meister & Bittner 2018, "Parallel reinsertion for bounding volume
//! hierarchy optimization").
//!
//! # The move
//!
//! A move takes a node `N` (a leaf or an inner node, with its whole subtree) out of the tree:
//! its parent `P` disappears and `N`'s sibling `S` takes `P`'s place. It then puts `N` back
//! next to a node `X`: a new inner node (the old `P`, reused) gets the children `X` and `N` and
//! takes `X`'s place. Only the inner nodes on the two paths to the root change their boxes, so
//! the change of the SAH numerator `c_t Σ_inner A + c_i Σ_leaf |n| A` is
//!
//! * removal: `−A(P) − Σ_{a ⊃ P} (A(a) − A'(a))`, where `A'` is the area of the ancestor's box
//!   without `N`;
//! * insertion: `A(X ∪ N) + Σ_{a ⊃ X} (A(a ∪ N) − A(a))`, with the ancestors' boxes of the tree
//!   without `N`,
//!
//! all times `c_t` (leaves never change: their references and boxes stay as the input builder
//! made them). The search for `X` runs on the tree *without* `N` and starts where `N` was:
//! it searches the subtree of the sibling `S`, then climbs, searching at each ancestor of `P`
//! the subtree off the path (depth first, pruned by the bound "gain left above this subtree
//! minus `A(N)`", which no target inside can beat) and trying the ancestor itself; see
//! `Tree::best_move` and `docs/builders-frontier.md`. The gain it reports is the exact change
//! of a move applied alone.
//!
//! # Candidates and batches
//!
//! Meister & Bittner select the candidates by a node cost; here it is the node's weight, its
//! surface area for the SAH (the area-weighted cost of a node is what a move can save: large
//! nodes high in the tree first). Iteration `i` ranks the nodes by weight (ties by index),
//! takes the top `batch_fraction / (1 + decay · i)` of them ([`ReinsertConfig::batch_fraction`],
//! [`ReinsertConfig::decay`]: rounds over a shrinking fraction, as in Meister & Bittner's
//! schedule), searches every candidate's best move in parallel (read-only, each a function of
//! the tree alone), then accepts the moves in order of gain (ties by node index) as long as
//! they are conflict free: a move locks `N`, `S`, `X`, the parents of `P` and `X`, and the
//! paths from `N` and from `X` up to their lowest common ancestor; a move that touches a
//! locked node waits for a later iteration. Disjoint locks keep the tree acyclic (a node can
//! only be moved into a subtree whose root is on another move's path, which that move would
//! have locked) and make the moves' pointer updates independent, so the accepted moves are
//! applied one after the other in a fixed order and the boxes are refitted once.
//!
//! Moves applied together interact through their common ancestors' boxes, so a batch could in
//! principle cost more than it saves: the batch is then undone and retried with its better
//! half (down to the single best move, whose gain is exact). The SAH therefore never rises,
//! and as a last guard the result is replaced by the input if its SAH (as
//! [`sahara_metrics::sah`] computes it) is not lower or equal.
//!
//! The optimisation stops after [`ReinsertConfig::max_iterations`] iterations, or after an
//! iteration whose relative gain fell below [`ReinsertConfig::min_gain`] times its batch's
//! share of the first batch. Everything is a function of the tree: the result is the same for
//! any number of rayon threads.
//!
//! # Other objectives
//!
//! Nothing in the search is specific to surface area: [`optimize_for`] lowers
//! `Σ_inner w(box)` for any [`NodeWeight`] `w`, such as the fraction of a representative ray
//! set's segments that meet a box (the ray-weighted SAH of `docs/metrics.md`). The weight is
//! computed outside this crate (builders never see rays): `cargo xtask reinsert-rays` builds
//! it from a training ray set with `sahara_metrics::SegmentSet`.
//!
//! # Use
//!
//! [`optimize`] post-processes any tree; [`Reinsert`] wraps any builder's configuration
//! (a [`Strategy`]) so that its trees are reinserted, and [`ReinsertAfter`] does the same for
//! any `Box<dyn Builder>` (a builder of your own).
//!
//! ```
//! use sahara_builders::reinsert::{optimize, ReinsertConfig};
//! use sahara_builders::{registry, BuildInput};
//! use sahara_geom::{Triangle, Vec3A};
//! use sahara_metrics::{sah, CostModel};
//!
//! let tris: Vec<Triangle> = (0..500)
//!     .map(|i| {
//!         let o = Vec3A::new((i % 23) as f32, (i / 23) as f32 * 0.7, (i % 5) as f32);
//!         Triangle::new(o, o + Vec3A::X * 0.9, o + Vec3A::Y * 0.5)
//!     })
//!     .collect();
//! let input = BuildInput::new(&tris, CostModel::default()).unwrap();
//! let bvh = registry::by_name("binned-8").unwrap().build(&input).unwrap();
//! let better = optimize(&bvh, &input.cost, &ReinsertConfig::default()).unwrap();
//! better.validate(&tris).unwrap();
//! assert!(sah(&better, &input.cost) <= sah(&bvh, &input.cost));
//! ```

use rayon::prelude::*;
use sahara_bvh::Node;
use sahara_geom::Aabb;
use sahara_metrics::CostModel;

use crate::{BuildError, BuildInput, Builder, Bvh, Strategy};

/// The knobs of the reinsertion optimiser. The defaults ([`ReinsertConfig::THOROUGH`]) were
/// chosen from measurements on the shared and procedural scenes (see
/// `docs/builders-frontier.md`); [`ReinsertConfig::LIGHT`] is the cheaper budget that
/// `ploc+reinsert` uses.
#[derive(Clone, Copy, Debug, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct ReinsertConfig {
    /// Candidates of the first iteration, as a fraction of the nodes (in `(0, 1]`; at least
    /// 64 candidates are taken): the nodes of largest weight (surface area for the SAH).
    pub batch_fraction: f64,
    /// Iteration `i` (from 0) takes `batch_fraction / (1 + decay · i)` of the nodes (at least
    /// 0): the rounds run over a shrinking top of the ranking, as in Meister & Bittner 2018.
    pub decay: f64,
    /// At most this many iterations (batches); 0 returns the input's topology (refitted).
    pub max_iterations: usize,
    /// Stop after an iteration that lowered the objective by less than this fraction of it
    /// (at least 0), scaled by the iteration's share of the first batch: with shrinking
    /// batches the threshold shrinks with them.
    pub min_gain: f64,
    /// At most this many nodes are visited by one candidate's search (0: no limit, the exact
    /// branch and bound). A limited search returns the best position among those it visited.
    pub max_search_nodes: usize,
}

impl Default for ReinsertConfig {
    fn default() -> Self {
        Self::THOROUGH
    }
}

impl ReinsertConfig {
    /// The default: the budget chosen for the `+reinsert` presets of the top-down builders.
    pub const THOROUGH: ReinsertConfig = ReinsertConfig {
        batch_fraction: 0.3,
        decay: 0.0,
        max_iterations: 100,
        min_gain: 0.0001,
        max_search_nodes: 0,
    };
    /// A lighter budget (a tenth of the candidates per iteration, ten iterations), for
    /// `ploc+reinsert`: chosen so that PLOC plus this pass stays within three times the sweep
    /// builder's time on every shared scene (`docs/builders-frontier.md`).
    pub const LIGHT: ReinsertConfig = ReinsertConfig {
        batch_fraction: 0.03,
        decay: 0.0,
        max_iterations: 10,
        min_gain: 0.0005,
        max_search_nodes: 0,
    };

    fn check(&self) -> Result<(), BuildError> {
        let frac = |v: f64| v.is_finite() && v > 0.0 && v <= 1.0;
        if !frac(self.batch_fraction) {
            return Err(BuildError::InvalidConfig(
                "reinsert: batch_fraction must be in (0, 1]".into(),
            ));
        }
        if !(self.decay.is_finite() && self.decay >= 0.0) {
            return Err(BuildError::InvalidConfig(
                "reinsert: decay must be finite and at least 0".into(),
            ));
        }
        if !(self.min_gain.is_finite() && self.min_gain >= 0.0) {
            return Err(BuildError::InvalidConfig(
                "reinsert: min_gain must be finite and at least 0".into(),
            ));
        }
        Ok(())
    }

    fn describe(&self) -> String {
        format!(
            "reinsertion (batch {:.3}, decay {:.1}, ≤ {} iterations, stop below {:.4}, \
             search limit {})",
            self.batch_fraction,
            self.decay,
            self.max_iterations,
            self.min_gain,
            self.max_search_nodes
        )
    }

    /// The candidates of iteration `it` for a tree of `n` nodes.
    fn batch(&self, it: usize, n: usize) -> usize {
        let f = self.batch_fraction / (1.0 + self.decay * it as f64);
        ((n as f64 * f).ceil() as usize).max(64).min(n)
    }
}

/// Why [`optimize`] refused its input.
#[derive(Clone, Debug, PartialEq, thiserror::Error)]
pub enum ReinsertError {
    /// The configuration is out of range (the message names the field).
    #[error(transparent)]
    Config(#[from] BuildError),
    /// The tree is not a well-formed depth-first binary tree (a child index out of range or
    /// not after its parent, a node reached twice or never, a leaf range out of bounds).
    #[error("malformed tree at node {node}")]
    MalformedTree {
        /// The first offending node.
        node: usize,
    },
}

/// What one run of the optimiser did.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct ReinsertStats {
    /// Iterations (batches) run.
    pub iterations: usize,
    /// Candidates searched (over all iterations).
    pub searches: usize,
    /// Moves applied.
    pub moves: usize,
    /// SAH of the input (after refitting its inner boxes); for [`optimize_for`], the
    /// objective `Σ_inner w(box)` of the input.
    pub sah_before: f64,
    /// SAH of the result; for [`optimize_for`], its objective.
    pub sah_after: f64,
}

/// The weight of a node's box in the objective that reinsertion lowers:
/// `Σ_inner w(box(n))` (leaves never change). The SAH is [`SurfaceArea`]; any other weight
/// (for instance the fraction of a ray set's segments that meet the box, computed outside
/// the builders: builders never see rays) makes reinsertion lower that objective instead.
///
/// `weight` must be non-negative and should be monotone (a box inside another weighs no
/// more): the search's pruning bound relies on it. A weight that is not monotone still never
/// raises the objective (every batch is checked), the search is only no longer exact.
pub trait NodeWeight: Sync {
    /// The weight of a box.
    fn weight(&self, b: &Aabb) -> f64;
}

/// The SAH's weight: half the surface area (in `f64`, as [`sahara_metrics::sah`] weighs
/// nodes).
#[derive(Clone, Copy, Debug, Default)]
pub struct SurfaceArea;

impl NodeWeight for SurfaceArea {
    #[inline]
    fn weight(&self, b: &Aabb) -> f64 {
        area(b)
    }
}

impl<F: Fn(&Aabb) -> f64 + Sync> NodeWeight for F {
    #[inline]
    fn weight(&self, b: &Aabb) -> f64 {
        self(b)
    }
}

/// Reinserts subtrees of `bvh` to lower its SAH under `cost` (see the module documentation).
/// The result has the same leaves (boxes and references), passes `Bvh::validate` whenever the
/// input does, and its SAH is at most the input's.
pub fn optimize(
    bvh: &Bvh,
    cost: &CostModel,
    config: &ReinsertConfig,
) -> Result<Bvh, ReinsertError> {
    optimize_with_stats(bvh, cost, config).map(|(b, _)| b)
}

/// [`optimize`], also returning what it did.
pub fn optimize_with_stats(
    bvh: &Bvh,
    cost: &CostModel,
    config: &ReinsertConfig,
) -> Result<(Bvh, ReinsertStats), ReinsertError> {
    reinsert(bvh, &SurfaceArea, config, |b| sahara_metrics::sah(b, cost))
}

/// Reinsertion that lowers `Σ_inner weight(box(n))` instead of the SAH (see [`NodeWeight`];
/// with [`SurfaceArea`] it makes the same moves as [`optimize`]). The result has the same
/// leaves, and its objective (as the stats report it, summed over the inner nodes in
/// depth-first order) is at most the input's: otherwise the input is returned.
pub fn optimize_for<W: NodeWeight>(
    bvh: &Bvh,
    weight: &W,
    config: &ReinsertConfig,
) -> Result<(Bvh, ReinsertStats), ReinsertError> {
    reinsert(bvh, weight, config, |b| objective(b, weight))
}

/// The one reinsertion driver: moves chosen by `weight`, the result kept only when `measure`
/// (the SAH, or the weight's objective) is not higher than the input's, which the stats
/// report before and after.
fn reinsert<W: NodeWeight>(
    bvh: &Bvh,
    weight: &W,
    config: &ReinsertConfig,
    measure: impl Fn(&Bvh) -> f64,
) -> Result<(Bvh, ReinsertStats), ReinsertError> {
    config.check()?;
    if bvh.nodes.is_empty() {
        return Ok((bvh.clone(), ReinsertStats::default()));
    }
    // The structure is checked before anything walks the tree.
    let mut tree = Tree::from_bvh(bvh, weight)?;
    let before = measure(bvh);
    let unchanged = |stats: ReinsertStats| {
        (
            bvh.clone(),
            ReinsertStats {
                sah_before: before,
                sah_after: before,
                moves: 0,
                ..stats
            },
        )
    };
    if bvh.nodes.len() < 5 {
        // Fewer than three leaves: no move changes anything.
        return Ok(unchanged(ReinsertStats::default()));
    }
    let mut stats = tree.run(config, weight);
    let out = tree.to_bvh(bvh);
    let after = measure(&out);
    // `after <= before` unless float noise in the sums says otherwise: keep the input then.
    // (Written negated so that a NaN measure also keeps the input.)
    #[allow(clippy::neg_cmp_op_on_partial_ord)]
    let worse = !(after <= before);
    if worse {
        return Ok(unchanged(stats));
    }
    stats.sah_before = before;
    stats.sah_after = after;
    Ok((out, stats))
}

/// The objective of [`optimize_for`]: `Σ_inner weight(box(n))` over `bvh`'s inner nodes, in
/// depth-first order.
pub fn objective<W: NodeWeight>(bvh: &Bvh, weight: &W) -> f64 {
    let w: Vec<f64> = bvh
        .nodes
        .par_iter()
        .map(|n| {
            if n.is_leaf() {
                0.0
            } else {
                weight.weight(&n.bounds())
            }
        })
        .collect();
    w.iter().sum()
}

const NONE: u32 = u32::MAX;

/// Half the surface area in `f64`, as `sahara_metrics::sah` weighs nodes (recomputed in `f64`
/// when the `f32` product overflows).
#[inline]
fn area(b: &Aabb) -> f64 {
    let a = b.half_area();
    if a.is_finite() {
        return a as f64;
    }
    let e = b.extent();
    let (x, y, z) = (e.x as f64, e.y as f64, e.z as f64);
    x * y + y * z + z * x
}

/// A best move found for a candidate: put `node` next to `target`, lowering the objective
/// by `gain`.
#[derive(Clone, Copy, Debug)]
struct Move {
    node: u32,
    target: u32,
    gain: f64,
}

/// The tree with parent pointers, in which moves are pointer updates, and the weight of
/// every node's box.
#[derive(Clone)]
struct Tree {
    boxes: Vec<Aabb>,
    weights: Vec<f64>,
    parent: Vec<u32>,
    /// Children of inner nodes (`NONE` for leaves).
    left: Vec<u32>,
    right: Vec<u32>,
    root: u32,
}

/// The best target of a search so far.
struct Found {
    gain: f64,
    target: u32,
    visits: usize,
}

impl Tree {
    fn from_bvh<W: NodeWeight>(bvh: &Bvh, w: &W) -> Result<Self, ReinsertError> {
        let n = bvh.nodes.len();
        let mut t = Tree {
            boxes: bvh.nodes.iter().map(Node::bounds).collect(),
            weights: vec![0.0; n],
            parent: vec![NONE; n],
            left: vec![NONE; n],
            right: vec![NONE; n],
            root: 0,
        };
        for (i, node) in bvh.nodes.iter().enumerate() {
            if node.is_leaf() {
                let end = node.index as usize + node.count as usize;
                if end > bvh.prim_indices.len() {
                    return Err(ReinsertError::MalformedTree { node: i });
                }
                continue;
            }
            let (l, r) = (i + 1, node.index as usize);
            if l >= n || r >= n || r <= l {
                return Err(ReinsertError::MalformedTree { node: i });
            }
            for c in [l, r] {
                if t.parent[c] != NONE {
                    return Err(ReinsertError::MalformedTree { node: c });
                }
                t.parent[c] = i as u32;
            }
            t.left[i] = l as u32;
            t.right[i] = r as u32;
        }
        if let Some(i) = (1..n).find(|&i| t.parent[i] == NONE) {
            return Err(ReinsertError::MalformedTree { node: i });
        }
        // Every node but the root has one parent that comes before it: a tree.
        let order = t.preorder();
        t.refit(&order);
        t.weights = t.boxes.par_iter().map(|b| w.weight(b)).collect();
        Ok(t)
    }

    fn is_leaf(&self, i: u32) -> bool {
        self.left[i as usize] == NONE
    }

    fn preorder(&self) -> Vec<u32> {
        let mut order = Vec::with_capacity(self.boxes.len());
        let mut stack = vec![self.root];
        while let Some(i) = stack.pop() {
            order.push(i);
            if !self.is_leaf(i) {
                stack.push(self.right[i as usize]);
                stack.push(self.left[i as usize]);
            }
        }
        order
    }

    /// Recomputes the inner boxes bottom-up (leaves keep theirs); returns the inner nodes
    /// whose box changed.
    fn refit(&mut self, order: &[u32]) -> Vec<u32> {
        let mut changed = Vec::new();
        for &i in order.iter().rev() {
            let iu = i as usize;
            if self.left[iu] != NONE {
                let b =
                    self.boxes[self.left[iu] as usize].union(&self.boxes[self.right[iu] as usize]);
                if b != self.boxes[iu] {
                    self.boxes[iu] = b;
                    changed.push(i);
                }
            }
        }
        changed
    }

    /// Refits and updates the weights of the boxes that changed.
    fn refit_weighted<W: NodeWeight>(&mut self, order: &[u32], w: &W) {
        let changed = self.refit(order);
        let new: Vec<f64> = changed
            .par_iter()
            .map(|&i| w.weight(&self.boxes[i as usize]))
            .collect();
        for (i, v) in changed.into_iter().zip(new) {
            self.weights[i as usize] = v;
        }
    }

    /// Σ of the inner nodes' weights, in preorder.
    fn inner_weight(&self, order: &[u32]) -> f64 {
        order
            .iter()
            .filter(|&&i| !self.is_leaf(i))
            .map(|&i| self.weights[i as usize])
            .sum()
    }

    fn sibling(&self, n: u32) -> u32 {
        let p = self.parent[n as usize] as usize;
        if self.left[p] == n {
            self.right[p]
        } else {
            self.left[p]
        }
    }

    fn replace_child(&mut self, p: u32, old: u32, new: u32) {
        let p = p as usize;
        if self.left[p] == old {
            self.left[p] = new;
        } else {
            debug_assert_eq!(self.right[p], old);
            self.right[p] = new;
        }
    }

    /// The best move of `n` in the current tree (if any lowers the cost by more than `eps`).
    ///
    /// The search starts where `N` is and climbs: with `A_1, A_2, …` the ancestors of `P`
    /// and `A'` their boxes without `N`, a target `X` in the subtree of `O_k` (the child of
    /// `A_k` off the path; `O_0 = S`) gains `D_k − w(X ∪ N) − Σ (w(a ∪ N) − w(a))` over its
    /// ancestors `a` inside that subtree, where `D_k = w(P) + Σ_{j<k} (w(A_j) − w(A'_j))`
    /// (the ancestors from `A_k` up contain `N` again, so their terms cancel), and the
    /// ancestor `A'_k` itself gains `D_{k+1} − w(A_k)`. Each subtree is searched depth first,
    /// pruned when `D_k` minus the induced cost minus `w(N)` cannot beat the best gain so far,
    /// and the climb stops once no `D` left (at most the whole removal gain) can.
    fn best_move<W: NodeWeight>(
        &self,
        n: u32,
        eps: f64,
        limit: usize,
        w: &W,
        scratch: &mut Scratch,
    ) -> Option<Move> {
        let p = self.parent[n as usize];
        if p == NONE {
            return None;
        }
        let s = self.sibling(n);
        let bn = self.boxes[n as usize];
        let an = self.weights[n as usize];
        // The ancestors of P with the weights of their boxes without N, bottom-up.
        let path = &mut scratch.path;
        path.clear();
        let mut removal = self.weights[p as usize];
        let mut child = p;
        let mut b = self.boxes[s as usize];
        let mut a = self.parent[p as usize];
        while a != NONE {
            let other = if self.left[a as usize] == child {
                self.right[a as usize]
            } else {
                self.left[a as usize]
            };
            b = b.union(&self.boxes[other as usize]);
            let wb = if b == self.boxes[a as usize] {
                self.weights[a as usize]
            } else {
                w.weight(&b)
            };
            removal += self.weights[a as usize] - wb;
            path.push((a, other, wb));
            child = a;
            a = self.parent[a as usize];
        }
        let mut found = Found {
            gain: eps,
            target: NONE,
            visits: 0,
        };
        let stack = &mut scratch.stack;
        let mut d = self.weights[p as usize];
        self.search_subtree(s, d, &bn, an, limit, w, stack, &mut found);
        for &(anc, other, wb) in path.iter() {
            if found.gain >= removal - an || found.visits >= limit {
                break;
            }
            self.search_subtree(other, d, &bn, an, limit, w, stack, &mut found);
            d += self.weights[anc as usize] - wb;
            // The ancestor without N as the target: N joins it under a new parent.
            let gain = d - self.weights[anc as usize];
            if gain > found.gain {
                found.gain = gain;
                found.target = anc;
            }
        }
        let best = found.gain;
        let best_x = found.target;
        (best_x != NONE).then_some(Move {
            node: n,
            target: best_x,
            gain: best,
        })
    }
    /// Depth-first search of the subtree of `sub` for targets that gain more than
    /// `found.gain`, the targets gaining `d − induced − w(X ∪ N)` (see [`Tree::best_move`]).
    #[allow(clippy::too_many_arguments)]
    #[inline]
    fn search_subtree<W: NodeWeight>(
        &self,
        sub: u32,
        d: f64,
        bn: &Aabb,
        an: f64,
        limit: usize,
        w: &W,
        stack: &mut Vec<(u32, f64)>,
        found: &mut Found,
    ) {
        if d - an <= found.gain {
            return;
        }
        stack.clear();
        stack.push((sub, 0.0f64));
        while let Some((x, induced)) = stack.pop() {
            if d - induced - an <= found.gain {
                continue;
            }
            if found.visits >= limit {
                return;
            }
            found.visits += 1;
            let (bx, wx) = (self.boxes[x as usize], self.weights[x as usize]);
            let ub = bx.union(bn);
            let u = if ub == bx { wx } else { w.weight(&ub) };
            let gain = d - induced - u;
            if gain > found.gain {
                found.gain = gain;
                found.target = x;
            }
            if self.is_leaf(x) {
                continue;
            }
            let below = induced + u - wx;
            if d - below - an > found.gain {
                stack.push((self.right[x as usize], below));
                stack.push((self.left[x as usize], below));
            }
        }
    }

    /// Locks the nodes a move touches (see the module documentation); false (and nothing
    /// locked) when one of them is locked already.
    fn lock(
        &self,
        m: &Move,
        depth: &[u32],
        locks: &mut [u32],
        stamp: u32,
        nodes: &mut Vec<u32>,
    ) -> bool {
        nodes.clear();
        let (n, x) = (m.node, m.target);
        let p = self.parent[n as usize];
        nodes.extend([n, x, p, self.sibling(n)]);
        for v in [self.parent[p as usize], self.parent[x as usize]] {
            if v != NONE {
                nodes.push(v);
            }
        }
        let (mut a, mut b) = (n, x);
        while a != b {
            if depth[a as usize] >= depth[b as usize] {
                a = self.parent[a as usize];
                nodes.push(a);
            } else {
                b = self.parent[b as usize];
                nodes.push(b);
            }
        }
        if nodes.iter().any(|&v| locks[v as usize] == stamp) {
            return false;
        }
        for &v in nodes.iter() {
            locks[v as usize] = stamp;
        }
        true
    }

    /// Applies a move (pointers only; the boxes are refitted afterwards).
    fn apply(&mut self, m: &Move) {
        let (n, x) = (m.node, m.target);
        let p = self.parent[n as usize];
        let s = self.sibling(n);
        let g = self.parent[p as usize];
        if g == NONE {
            self.root = s;
        } else {
            self.replace_child(g, p, s);
        }
        self.parent[s as usize] = g;
        let y = self.parent[x as usize];
        self.left[p as usize] = x;
        self.right[p as usize] = n;
        self.parent[x as usize] = p;
        self.parent[n as usize] = p;
        self.parent[p as usize] = y;
        if y == NONE {
            self.root = p;
        } else {
            self.replace_child(y, x, p);
        }
    }

    fn run<W: NodeWeight>(&mut self, config: &ReinsertConfig, w: &W) -> ReinsertStats {
        let n = self.boxes.len();
        let mut order = self.preorder();
        let mut cost = self.inner_weight(&order);
        let eps = 1e-10 * self.weights[self.root as usize];
        let mut stats = ReinsertStats::default();
        let mut locks = vec![0u32; n];
        let mut depth = vec![0u32; n];
        let mut lock_nodes = Vec::new();
        let mut ranked: Vec<(f64, u32)> = Vec::with_capacity(n);
        let limit = if config.max_search_nodes == 0 {
            usize::MAX
        } else {
            config.max_search_nodes
        };
        let first = config.batch(0, n);
        let trace = std::env::var_os("SAHARA_REINSERT_TRACE").is_some();
        for it in 0..config.max_iterations {
            let t0 = std::time::Instant::now();
            let batch = config.batch(it, n);
            stats.iterations += 1;
            // Candidates: the top of the weight ranking (largest first, ties by index).
            ranked.clear();
            ranked.extend(
                order
                    .iter()
                    .filter(|&&i| i != self.root)
                    .map(|&i| (self.weights[i as usize], i)),
            );
            let cmp = |a: &(f64, u32), b: &(f64, u32)| b.0.total_cmp(&a.0).then(a.1.cmp(&b.1));
            let hi = batch.min(ranked.len());
            if hi < ranked.len() {
                ranked.select_nth_unstable_by(hi, cmp);
            }
            ranked[..hi].sort_unstable_by(cmp);
            stats.searches += hi;
            let tree = &*self;
            let mut moves: Vec<Move> = ranked[..hi]
                .par_iter()
                .map_init(Scratch::default, |s, &(_, c)| {
                    tree.best_move(c, eps, limit, w, s)
                })
                .flatten()
                .collect();
            let t_search = t0.elapsed().as_secs_f64();
            let start = cost;
            let (found, mut took, mut applied) = (moves.len(), 0usize, 0usize);
            if !moves.is_empty() {
                moves.sort_unstable_by(|a, b| b.gain.total_cmp(&a.gain).then(a.node.cmp(&b.node)));
                for &i in &order {
                    let p = self.parent[i as usize];
                    depth[i as usize] = if p == NONE { 0 } else { depth[p as usize] + 1 };
                }
                let stamp = it as u32 + 1;
                let accepted: Vec<Move> = moves
                    .into_iter()
                    .filter(|m| self.lock(m, &depth, &mut locks, stamp, &mut lock_nodes))
                    .collect();
                // Apply; undo and halve while the batch costs more than it saves.
                let mut k = accepted.len();
                took = k;
                let saved = self.clone();
                loop {
                    for m in &accepted[..k] {
                        self.apply(m);
                    }
                    let new_order = self.preorder();
                    self.refit_weighted(&new_order, w);
                    let new_cost = self.inner_weight(&new_order);
                    if new_cost <= cost {
                        order = new_order;
                        cost = new_cost;
                        stats.moves += k;
                        applied = k;
                        break;
                    }
                    *self = saved.clone();
                    if k == 1 {
                        break;
                    }
                    k /= 2;
                }
            }
            let gain = (start - cost) / start.max(f64::MIN_POSITIVE);
            if trace {
                eprintln!(
                    "reinsert it {it}: {hi} candidates, {found} found, {took} conflict-free, {applied} applied, gain {:.5}%, search {:.3} s, total {:.3} s",
                    100.0 * gain,
                    t_search,
                    t0.elapsed().as_secs_f64()
                );
            }
            // Stop when the iteration gained less than its share of the threshold.
            if gain < config.min_gain * batch as f64 / first as f64 {
                break;
            }
        }
        stats
    }

    /// The tree in depth-first layout; leaves keep the input's boxes and references.
    fn to_bvh(&self, input: &Bvh) -> Bvh {
        let mut nodes = Vec::with_capacity(input.nodes.len());
        let mut prims = Vec::with_capacity(input.prim_indices.len());
        // The cut records follow their references.
        let mut cuts = input.ref_cuts.as_ref().map(|_| sahara_bvh::RefCuts::new());
        let mut stack = vec![(self.root, NONE)];
        while let Some((v, patch)) = stack.pop() {
            let idx = nodes.len() as u32;
            if patch != NONE {
                let pn: &mut Node = &mut nodes[patch as usize];
                pn.index = idx;
            }
            if self.is_leaf(v) {
                let leaf = &input.nodes[v as usize];
                nodes.push(Node::leaf(&leaf.bounds(), prims.len() as u32, leaf.count));
                prims.extend_from_slice(input.leaf_prims(leaf));
                if let (Some(out), Some(from)) = (&mut cuts, &input.ref_cuts) {
                    let first = leaf.index as usize;
                    for slot in first..first + leaf.count as usize {
                        out.push(from.get(slot));
                    }
                }
            } else {
                nodes.push(Node::inner(&self.boxes[v as usize], 0));
                stack.push((self.right[v as usize], idx));
                stack.push((self.left[v as usize], NONE));
            }
        }
        Bvh {
            nodes,
            prim_indices: prims,
            spatial_splits: input.spatial_splits,
            // Reinsertion recomputed the inner boxes as unions of their children.
            ref_cuts: cuts.map(sahara_bvh::RefCuts::without_depths),
        }
    }
}

/// Per-worker buffers of the search.
#[derive(Default)]
struct Scratch {
    /// The ancestors of P: (ancestor, its child off the path, weight of its box without N).
    path: Vec<(u32, u32, f64)>,
    stack: Vec<(u32, f64)>,
}

/// A builder's configuration followed by reinsertion: `Configured<Reinsert<C>>` is a
/// [`Builder`] whose trees are `C`'s trees passed through [`optimize`].
#[derive(Clone, Debug, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct Reinsert<C> {
    /// The builder whose trees are optimised.
    pub base: C,
    /// The reinsertion budget.
    pub config: ReinsertConfig,
}

impl<C: Default> Default for Reinsert<C> {
    fn default() -> Self {
        Self {
            base: C::default(),
            config: ReinsertConfig::default(),
        }
    }
}

impl<C: Strategy> Strategy for Reinsert<C> {
    /// The generic name; the registered presets are named `BASE+reinsert`.
    const NAME: &'static str = "reinsert";

    fn check(&self) -> Result<(), BuildError> {
        self.base.check()?;
        self.config.check()
    }

    fn describe(&self) -> String {
        format!("{}, then {}", self.base.describe(), self.config.describe())
    }

    fn build_tree(&self, input: &BuildInput) -> Result<Bvh, BuildError> {
        let bvh = self.base.build_tree(input)?;
        optimize(&bvh, &input.cost, &self.config).map_err(into_build_error)
    }
}

fn into_build_error(e: ReinsertError) -> BuildError {
    match e {
        ReinsertError::Config(e) => e,
        other => BuildError::InvalidConfig(format!("reinsert: the base builder made a {other}")),
    }
}

/// Any [`Builder`] followed by reinsertion (for builders that are not a [`Strategy`] of this
/// crate, such as a user's builder from the registry).
pub struct ReinsertAfter {
    /// The builder whose trees are optimised.
    pub inner: Box<dyn Builder>,
    /// The reinsertion budget.
    pub config: ReinsertConfig,
    name: String,
}

impl ReinsertAfter {
    /// `inner` followed by reinsertion with `config`, named `INNER+reinsert`.
    pub fn new(inner: Box<dyn Builder>, config: ReinsertConfig) -> Self {
        let name = format!("{}+reinsert", inner.name());
        Self {
            inner,
            config,
            name,
        }
    }
}

impl Builder for ReinsertAfter {
    fn name(&self) -> &str {
        &self.name
    }

    fn describe(&self) -> String {
        format!("{}, then {}", self.inner.describe(), self.config.describe())
    }

    fn build(&self, input: &BuildInput) -> Result<Bvh, BuildError> {
        self.config.check()?;
        let bvh = self.inner.build(input)?;
        optimize(&bvh, &input.cost, &self.config).map_err(into_build_error)
    }
}
