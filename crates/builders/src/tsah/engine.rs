//! The top-down driver shared by the temporary-subtree builders ([`crate::tsah`]) and the
//! look-ahead builders ([`crate::popov`]): at every node, sweep the three sorted orders
//! (Eq. 2 at every position), select candidate splits, rate each with a [`Rater`] in parallel,
//! take the cheapest (deterministic tie-break), decide leaf or split, recurse. Nodes at or below
//! `greedy_below` primitives are built by the plain sweep rule.

use std::sync::atomic::{AtomicU32, Ordering};
use std::sync::Mutex;

use rayon::prelude::*;
use sahara_bvh::Bvh;
use sahara_geom::{Aabb, Vec3A};

use crate::sweep::{self, BuildCtx, Job, SplitCandidate, Storage};
use crate::tsah::Candidates;
use crate::{BuildError, BuildInput};

/// Rates a candidate split of a node (smaller is better). Implementations are called in
/// parallel for the candidates of a node and must be deterministic.
pub(crate) trait Rater: Sync {
    /// Buffers a rating may reuse.
    type Scratch: Default + Send;
    /// The rating of `cand` (a split of `node`'s sorted orders).
    fn rate(&self, node: &LocalNode, cand: &SplitCandidate, scratch: &mut Self::Scratch) -> f64;
}

/// Nodes at least this large rate their candidates in parallel; smaller ones rate them on the
/// current thread with the thread's reusable scratch (raters must not call into rayon for
/// such nodes).
const PAR_RATE: usize = 1024;

/// How candidates are chosen and when to stop.
#[derive(Clone, Copy, Debug)]
pub(crate) struct EngineParams {
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
}

impl LocalNode {
    pub fn len(&self) -> usize {
        self.bounds.len()
    }

    pub fn orders(&self) -> [&[u32]; 3] {
        [&self.orders[0], &self.orders[1], &self.orders[2]]
    }
}

struct Env<'a, R: Rater> {
    ctx: BuildCtx<'a>,
    params: EngineParams,
    rater: &'a R,
    /// Global id -> local id of the node being rated (nodes rated concurrently are disjoint).
    local_of: Vec<AtomicU32>,
    /// One rating scratch per worker thread, for nodes rated serially.
    scratch: Vec<Mutex<R::Scratch>>,
}

/// Builds the tree.
pub(crate) fn build<R: Rater>(
    input: &BuildInput,
    params: &EngineParams,
    rater: &R,
) -> Result<Bvh, BuildError> {
    if input.is_empty() {
        return Ok(Bvh::empty());
    }
    sweep::check_size(input)?;
    let env = Env {
        ctx: BuildCtx::new(
            input,
            params.max_leaf_size,
            sweep::SweepConfig::DEFAULT.parallel_threshold,
        ),
        params: *params,
        rater,
        local_of: (0..input.len()).map(|_| AtomicU32::new(0)).collect(),
        scratch: (0..rayon::current_num_threads() + 1)
            .map(|_| Mutex::new(R::Scratch::default()))
            .collect(),
    };
    let mut storage = Storage::new(input.centroids());
    {
        let job = storage.root_job();
        rayon::scope(|s| drive(s, job, &env));
    }
    Ok(storage.finish())
}

fn drive<'s, R: Rater>(scope: &rayon::Scope<'s>, mut job: Job<'s>, env: &'s Env<'s, R>) {
    let greedy_below = env.params.greedy_below;
    loop {
        if job.len() <= greedy_below.max(1) {
            sweep::drive(scope, job, &env.ctx);
            return;
        }
        let Some((l, r)) = node(job, env) else {
            return;
        };
        let (small, large) = if l.len() <= r.len() { (l, r) } else { (r, l) };
        if small.len() <= greedy_below {
            sweep::drive(scope, small, &env.ctx);
        } else {
            scope.spawn(move |s| drive(s, small, env));
        }
        job = large;
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
    if list.len() == k {
        match list.last() {
            Some(worst) if c.better_than(worst, n) => {
                list.pop();
            }
            _ => return,
        }
    }
    let at = list
        .iter()
        .position(|x| c.better_than(x, n))
        .unwrap_or(list.len());
    list.insert(at, c);
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

/// Equal-width bins over `[min, max]` (`None` when the interval is flat or too thin for a
/// finite scale).
#[derive(Clone, Copy, Debug)]
pub(crate) struct BinMap {
    pub min: f32,
    pub scale: f32,
    bins: usize,
}

impl BinMap {
    pub fn new(min: f32, max: f32, bins: usize) -> Option<Self> {
        let extent = max - min;
        if extent.is_nan() || extent <= 0.0 || bins < 2 {
            return None;
        }
        let scale = bins as f32 / extent;
        if !scale.is_finite() || scale <= 0.0 {
            return None;
        }
        Some(Self { min, scale, bins })
    }

    /// Bin of `x`, monotone in `x`, clamped to `0..bins`.
    #[inline]
    pub fn bin(&self, x: f32) -> usize {
        (((x - self.min) * self.scale) as usize).min(self.bins - 1)
    }
}

/// One node of the paper's builder: candidates, parallel ratings, leaf or split.
fn node<'a, R: Rater>(job: Job<'a>, env: &Env<'_, R>) -> Option<(Job<'a>, Job<'a>)> {
    let ctx = &env.ctx;
    let n = job.len();
    if n == 1 {
        let b = ctx.bounds[job.orders[0][0] as usize];
        job.make_leaf(&b);
        return None;
    }
    let orders = [&*job.orders[0], &*job.orders[1], &*job.orders[2]];
    let mut collector = Collector::new(&env.params.candidates, orders, ctx.centroids);
    let mut greedy = SplitCandidate::fallback(n);
    let mut node_bounds = Aabb::EMPTY;
    for (axis, order) in orders.iter().enumerate() {
        node_bounds = sweep::sweep_axis(ctx.bounds, order, axis, job.areas, &ctx.cost, |c| {
            if c.better_than(&greedy, n) {
                greedy = c;
            }
            collector.offer(c, n);
        });
    }
    let mut cands = collector.finish();
    if (env.params.include_greedy || cands.is_empty())
        && !cands
            .iter()
            .any(|c| c.axis == greedy.axis && c.pos == greedy.pos)
    {
        cands.push(greedy);
    }

    let must_split = n > ctx.max_leaf;
    let best = if must_split && cands.len() == 1 {
        // Nothing to compare: skip the ratings.
        cands[0]
    } else {
        let local = local_node(env, orders, &node_bounds);
        let ratings: Vec<f64> = if n >= PAR_RATE {
            cands
                .par_iter()
                .map_init(R::Scratch::default, |sc, c| env.rater.rate(&local, c, sc))
                .collect()
        } else {
            let slot = rayon::current_thread_index()
                .map_or(env.scratch.len() - 1, |i| i.min(env.scratch.len() - 1));
            match env.scratch[slot].try_lock() {
                Ok(mut sc) => cands
                    .iter()
                    .map(|c| env.rater.rate(&local, c, &mut sc))
                    .collect(),
                Err(_) => {
                    let mut sc = R::Scratch::default();
                    cands
                        .iter()
                        .map(|c| env.rater.rate(&local, c, &mut sc))
                        .collect()
                }
            }
        };
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
        if !must_split && ctx.cost.leaf_cost(n) <= ratings[best] {
            job.make_leaf(&node_bounds);
            return None;
        }
        cands[best]
    };
    Some(job.split(best.axis, best.pos, &node_bounds, &ctx.marks))
}

fn local_node<R: Rater>(env: &Env<'_, R>, orders: [&[u32]; 3], node_bounds: &Aabb) -> LocalNode {
    let ctx = &env.ctx;
    let n = orders[0].len();
    for (j, &g) in orders[0].iter().enumerate() {
        env.local_of[g as usize].store(j as u32, Ordering::Relaxed);
    }
    let relabel = |o: &[u32]| -> Vec<u32> {
        o.iter()
            .map(|&g| env.local_of[g as usize].load(Ordering::Relaxed))
            .collect()
    };
    LocalNode {
        bounds: orders[0].iter().map(|&g| ctx.bounds[g as usize]).collect(),
        orders: [
            (0..n as u32).collect(),
            relabel(orders[1]),
            relabel(orders[2]),
        ],
        area: node_bounds.half_area() as f64,
    }
}
