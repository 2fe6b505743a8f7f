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
//! made them). The search for `X` is the branch and bound of Bittner et al. 2013, run on the
//! tree *without* `N` (the ancestors of `P` use their boxes `A'`, `S` stands where `P` was): a
//! priority queue ordered by the induced cost `Σ_{a ⊃ X} (A(a ∪ N) − A(a))`, pruned when the
//! induced cost plus `A(N)` (the least the new node can cost) cannot beat the best position so
//! far. The gain it reports is therefore the exact change of a move applied alone.
//!
//! # Candidates and batches
//!
//! Meister & Bittner select the candidates by a node cost; here it is the node's surface area
//! (the area-weighted cost of a node is what a move can save: large nodes high in the tree
//! first). Every iteration sorts the nodes by area (ties by index), takes a window of
//! [`ReinsertConfig::batch_fraction`] of them, searches every candidate's best move in parallel
//! (read-only, each a function of the tree alone), then accepts the moves in order of gain
//! (ties by node index) as long as they are conflict free: a move locks `N`, `S`, `X`, the
//! parents of `P` and `X`, and the paths from `N` and from `X` up to their lowest common
//! ancestor; a move that touches a locked node waits for a later iteration. Disjoint locks keep
//! the tree acyclic (a node can only be moved into a subtree whose root is on another move's
//! path, which that move would have locked) and make the moves' pointer updates independent,
//! so the accepted moves are applied one after the other in a fixed order and the boxes are
//! refitted once. The windows walk down the area ranking, over the
//! [`ReinsertConfig::pool_fraction`] largest nodes, and start again at the top.
//!
//! Moves applied together interact through their common ancestors' boxes, so a batch could in
//! principle cost more than it saves: the batch is then undone and retried with its better
//! half (down to the single best move, whose gain is exact). The SAH therefore never rises,
//! and as a last guard the result is replaced by the input if its SAH (as
//! [`sahara_metrics::sah`] computes it) is not lower or equal.
//!
//! The optimisation stops after [`ReinsertConfig::max_iterations`] iterations, or when a full
//! round through the pool lowered the SAH by less than [`ReinsertConfig::min_round_gain`]
//! (relative). Everything is a function of the tree: the result is the same for any number of
//! rayon threads.
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

use std::cmp::Ordering;
use std::collections::BinaryHeap;

use rayon::prelude::*;
use sahara_bvh::Node;
use sahara_geom::Aabb;
use sahara_metrics::CostModel;

use crate::registry::Entry;
use crate::{BuildError, BuildInput, Builder, Bvh, Configured, Strategy};

/// The knobs of the reinsertion optimiser. The defaults ([`ReinsertConfig::THOROUGH`]) were
/// chosen from measurements on the shared and procedural scenes (see
/// `docs/builders-frontier.md`); [`ReinsertConfig::LIGHT`] is the cheaper budget that
/// `ploc+reinsert` uses.
#[derive(Clone, Copy, Debug, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct ReinsertConfig {
    /// Fraction of the nodes that are candidates in one iteration (in `(0, 1]`; at least 64
    /// candidates are taken). Larger batches need fewer iterations but conflict more.
    pub batch_fraction: f64,
    /// Fraction of the nodes, the largest by area, that the candidate windows walk through
    /// (in `(0, 1]`). The small nodes deep in the tree rarely find a better place.
    pub pool_fraction: f64,
    /// At most this many iterations (batches); 0 returns the input's topology (refitted).
    pub max_iterations: usize,
    /// Stop when a full round of windows through the pool lowered the SAH by less than this
    /// fraction of the SAH at the round's start (at least 0).
    pub min_round_gain: f64,
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
        batch_fraction: 0.02,
        pool_fraction: 0.2,
        max_iterations: 100,
        min_round_gain: 0.002,
        max_search_nodes: 0,
    };
    /// A lighter budget (fewer iterations), for `ploc+reinsert`.
    pub const LIGHT: ReinsertConfig = ReinsertConfig {
        batch_fraction: 0.02,
        pool_fraction: 0.1,
        max_iterations: 20,
        min_round_gain: 0.005,
        max_search_nodes: 0,
    };

    fn check(&self) -> Result<(), BuildError> {
        let frac = |v: f64| v.is_finite() && v > 0.0 && v <= 1.0;
        if !frac(self.batch_fraction) {
            return Err(BuildError::InvalidConfig(
                "reinsert: batch_fraction must be in (0, 1]".into(),
            ));
        }
        if !frac(self.pool_fraction) {
            return Err(BuildError::InvalidConfig(
                "reinsert: pool_fraction must be in (0, 1]".into(),
            ));
        }
        if !(self.min_round_gain.is_finite() && self.min_round_gain >= 0.0) {
            return Err(BuildError::InvalidConfig(
                "reinsert: min_round_gain must be finite and at least 0".into(),
            ));
        }
        Ok(())
    }

    fn describe(&self) -> String {
        format!(
            "reinsertion (batch {:.3}, pool {:.2}, ≤ {} iterations, stop below {:.4} per round, \
             search limit {})",
            self.batch_fraction,
            self.pool_fraction,
            self.max_iterations,
            self.min_round_gain,
            self.max_search_nodes
        )
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
    /// Moves applied.
    pub moves: usize,
    /// SAH of the input (after refitting its inner boxes).
    pub sah_before: f64,
    /// SAH of the result.
    pub sah_after: f64,
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
    config.check()?;
    if bvh.nodes.is_empty() {
        return Ok((bvh.clone(), ReinsertStats::default()));
    }
    // The structure is checked before anything walks the tree.
    let mut tree = Tree::from_bvh(bvh)?;
    let before = sahara_metrics::sah(bvh, cost);
    if bvh.nodes.len() < 5 {
        // Fewer than three leaves: no move changes anything.
        let stats = ReinsertStats {
            sah_before: before,
            sah_after: before,
            ..Default::default()
        };
        return Ok((bvh.clone(), stats));
    }
    let mut stats = tree.run(config);
    let out = tree.to_bvh(bvh);
    let after = sahara_metrics::sah(&out, cost);
    // `after <= before` unless float noise in the sums says otherwise: keep the input then.
    // (Written negated so that a NaN SAH also keeps the input.)
    #[allow(clippy::neg_cmp_op_on_partial_ord)]
    let worse = !(after <= before);
    if worse {
        stats.sah_after = before;
        stats.moves = 0;
        return Ok((
            bvh.clone(),
            ReinsertStats {
                sah_before: before,
                ..stats
            },
        ));
    }
    stats.sah_before = before;
    stats.sah_after = after;
    Ok((out, stats))
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

/// A best move found for a candidate: put `node` next to `target`, lowering the inner-area sum
/// by `gain`.
#[derive(Clone, Copy, Debug)]
struct Move {
    node: u32,
    target: u32,
    gain: f64,
}

/// The tree with parent pointers, in which moves are pointer updates.
#[derive(Clone)]
struct Tree {
    boxes: Vec<Aabb>,
    parent: Vec<u32>,
    /// Children of inner nodes (`NONE` for leaves).
    left: Vec<u32>,
    right: Vec<u32>,
    root: u32,
}

/// A search queue entry: a node of the tree without the candidate, its induced cost, and its
/// place on the path from the root to the candidate's grandparent (`NONE` off the path).
#[derive(Clone, Copy)]
struct QItem {
    induced: f64,
    node: u32,
    path: u32,
}

impl PartialEq for QItem {
    fn eq(&self, o: &Self) -> bool {
        self.cmp(o) == Ordering::Equal
    }
}
impl Eq for QItem {}
impl PartialOrd for QItem {
    fn partial_cmp(&self, o: &Self) -> Option<Ordering> {
        Some(self.cmp(o))
    }
}
impl Ord for QItem {
    /// Reversed (the heap pops the smallest induced cost first), ties by node index.
    fn cmp(&self, o: &Self) -> Ordering {
        o.induced
            .total_cmp(&self.induced)
            .then_with(|| o.node.cmp(&self.node))
    }
}

impl Tree {
    fn from_bvh(bvh: &Bvh) -> Result<Self, ReinsertError> {
        let n = bvh.nodes.len();
        let mut t = Tree {
            boxes: bvh.nodes.iter().map(Node::bounds).collect(),
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
        t.refit(&t.preorder());
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

    /// Recomputes the inner boxes bottom-up (leaves keep theirs).
    fn refit(&mut self, order: &[u32]) {
        for &i in order.iter().rev() {
            let i = i as usize;
            if self.left[i] != NONE {
                self.boxes[i] =
                    self.boxes[self.left[i] as usize].union(&self.boxes[self.right[i] as usize]);
            }
        }
    }

    /// Σ of the inner nodes' areas, in preorder.
    fn inner_area(&self, order: &[u32]) -> f64 {
        order
            .iter()
            .filter(|&&i| !self.is_leaf(i))
            .map(|&i| area(&self.boxes[i as usize]))
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

    /// The best move of `n` in the current tree (if any lowers the cost).
    fn best_move(&self, n: u32, eps: f64, limit: usize, scratch: &mut Scratch) -> Option<Move> {
        let p = self.parent[n as usize];
        if p == NONE {
            return None;
        }
        let s = self.sibling(n);
        let bn = self.boxes[n as usize];
        let an = area(&bn);
        // The ancestors of P with their boxes without N, bottom-up, then reversed.
        let path = &mut scratch.path;
        path.clear();
        let mut removal = area(&self.boxes[p as usize]);
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
            removal += area(&self.boxes[a as usize]) - area(&b);
            path.push((a, b));
            child = a;
            a = self.parent[a as usize];
        }
        path.reverse();
        // Branch and bound over the tree without N.
        let heap = &mut scratch.heap;
        heap.clear();
        heap.push(if path.is_empty() {
            QItem {
                induced: 0.0,
                node: s,
                path: NONE,
            }
        } else {
            QItem {
                induced: 0.0,
                node: path[0].0,
                path: 0,
            }
        });
        let mut best = removal - eps;
        let mut best_x = NONE;
        let mut visits = 0usize;
        while let Some(QItem {
            induced,
            node: x,
            path: k,
        }) = heap.pop()
        {
            if induced + an >= best || visits == limit {
                break;
            }
            visits += 1;
            let bx = if k == NONE {
                self.boxes[x as usize]
            } else {
                path[k as usize].1
            };
            let u = area(&bx.union(&bn));
            if induced + u < best {
                best = induced + u;
                best_x = x;
            }
            if self.is_leaf(x) {
                continue;
            }
            let below = induced + u - area(&bx);
            if below + an >= best {
                continue;
            }
            let (l, r) = (self.left[x as usize], self.right[x as usize]);
            if k == NONE {
                heap.push(QItem {
                    induced: below,
                    node: l,
                    path: NONE,
                });
                heap.push(QItem {
                    induced: below,
                    node: r,
                    path: NONE,
                });
                continue;
            }
            // On the path: one child is the next path node (or P, which S replaces).
            let next = if (k as usize) + 1 < path.len() {
                path[k as usize + 1].0
            } else {
                p
            };
            let other = if l == next { r } else { l };
            heap.push(QItem {
                induced: below,
                node: other,
                path: NONE,
            });
            heap.push(if next == p {
                QItem {
                    induced: below,
                    node: s,
                    path: NONE,
                }
            } else {
                QItem {
                    induced: below,
                    node: next,
                    path: k + 1,
                }
            });
        }
        (best_x != NONE).then_some(Move {
            node: n,
            target: best_x,
            gain: removal - best,
        })
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

    fn run(&mut self, config: &ReinsertConfig) -> ReinsertStats {
        let n = self.boxes.len();
        let batch = ((n as f64 * config.batch_fraction).ceil() as usize)
            .max(64)
            .min(n);
        let pool = ((n as f64 * config.pool_fraction).ceil() as usize)
            .max(batch)
            .min(n);
        let windows = pool.div_ceil(batch);
        let mut order = self.preorder();
        let mut cost = self.inner_area(&order);
        let eps = 1e-10 * area(&self.boxes[self.root as usize]);
        let mut stats = ReinsertStats::default();
        let mut locks = vec![0u32; n];
        let mut depth = vec![0u32; n];
        let mut lock_nodes = Vec::new();
        let mut round_start = cost;
        let mut ranked: Vec<(f64, u32)> = Vec::with_capacity(n);
        let limit = if config.max_search_nodes == 0 {
            usize::MAX
        } else {
            config.max_search_nodes
        };
        for it in 0..config.max_iterations {
            let window = it % windows;
            if window == 0 && it > 0 {
                if round_start - cost < config.min_round_gain * round_start {
                    break;
                }
                round_start = cost;
            }
            stats.iterations += 1;
            // Candidates: the window of the area ranking (largest first, ties by index).
            ranked.clear();
            ranked.extend(
                order
                    .iter()
                    .filter(|&&i| i != self.root)
                    .map(|&i| (area(&self.boxes[i as usize]), i)),
            );
            let cmp = |a: &(f64, u32), b: &(f64, u32)| b.0.total_cmp(&a.0).then(a.1.cmp(&b.1));
            let hi = ((window + 1) * batch).min(ranked.len());
            let lo = (window * batch).min(hi);
            if hi < ranked.len() {
                ranked.select_nth_unstable_by(hi, cmp);
            }
            ranked[..hi].sort_unstable_by(cmp);
            let tree = &*self;
            let mut moves: Vec<Move> = ranked[lo..hi]
                .par_iter()
                .map_init(Scratch::default, |s, &(_, c)| {
                    tree.best_move(c, eps, limit, s)
                })
                .flatten()
                .collect();
            if moves.is_empty() {
                continue;
            }
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
            let saved = self.clone();
            loop {
                for m in &accepted[..k] {
                    self.apply(m);
                }
                let new_order = self.preorder();
                self.refit(&new_order);
                let new_cost = self.inner_area(&new_order);
                if new_cost <= cost {
                    order = new_order;
                    cost = new_cost;
                    stats.moves += k;
                    break;
                }
                *self = saved.clone();
                if k == 1 {
                    break;
                }
                k /= 2;
            }
        }
        stats
    }

    /// The tree in depth-first layout; leaves keep the input's boxes and references.
    fn to_bvh(&self, input: &Bvh) -> Bvh {
        let mut nodes = Vec::with_capacity(input.nodes.len());
        let mut prims = Vec::with_capacity(input.prim_indices.len());
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
        }
    }
}

/// Per-worker buffers of the search.
#[derive(Default)]
struct Scratch {
    path: Vec<(u32, Aabb)>,
    heap: BinaryHeap<QItem>,
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

/// Registry entries of this module: the top-down builders followed by the thorough
/// reinsertion.
pub fn registry_entries() -> Vec<Entry> {
    use crate::sbvh::SbvhConfig;
    use crate::sweep::SweepConfig;
    use crate::tsah::TsahConfig;
    vec![
        Entry {
            name: "sweep+reinsert",
            summary: "full-sweep SAH, then reinsertion (Meister & Bittner 2018)",
            spatial: false,
            small_inputs_only: false,
            max_practical_triangles: None,
            make: || {
                Box::new(Configured::named(
                    "sweep+reinsert",
                    Reinsert {
                        base: SweepConfig::DEFAULT,
                        config: ReinsertConfig::THOROUGH,
                    },
                ))
            },
        },
        Entry {
            name: "sbvh+reinsert",
            summary: "SBVH, then reinsertion (Meister & Bittner 2018)",
            spatial: true,
            small_inputs_only: false,
            max_practical_triangles: None,
            make: || {
                Box::new(Configured::named(
                    "sbvh+reinsert",
                    Reinsert {
                        base: SbvhConfig::DEFAULT,
                        config: ReinsertConfig::THOROUGH,
                    },
                ))
            },
        },
        Entry {
            name: "tsah-topk+reinsert",
            summary: "temporary-subtree SAH (top-k), then reinsertion (Meister & Bittner 2018)",
            spatial: false,
            small_inputs_only: false,
            max_practical_triangles: None,
            make: || {
                Box::new(Configured::named(
                    "tsah-topk+reinsert",
                    Reinsert {
                        base: TsahConfig::TOP_K,
                        config: ReinsertConfig::THOROUGH,
                    },
                ))
            },
        },
    ]
}
