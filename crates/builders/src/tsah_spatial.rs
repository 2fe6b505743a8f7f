//! The temporary-subtree SAH builder with spatial splits (Wodniok & Goesele 2017, the variant
//! "with spatial splits"; see `ALGORITHMS.md` §3 item 4 and `docs/builders-classic.md`).
//!
//! At every node with at least [`TsahSpatialConfig::min_size`] references the builder collects
//! candidate splits with the SBVH machinery of [`crate::sbvh`]:
//!
//! * up to [`TsahSpatialConfig::object_candidates`] object splits: the best by Eq. 2 over all
//!   axes, then the next best that are not within
//!   [`object_separation`](TsahSpatialConfig::object_separation) of one already taken (same
//!   axis, left counts closer than that fraction of the node's references), from the
//!   `4 × object_candidates` best;
//! * where the SBVH rule would search spatial splits at this node (overlap above `alpha`,
//!   depth and duplication budget left), up to [`TsahSpatialConfig::spatial_candidates`]
//!   spatial splits: the best by Eq. 2 with duplicated references that fits the budget, then
//!   the next best whose planes are at least
//!   [`spatial_separation`](TsahSpatialConfig::spatial_separation) bins away from those taken
//!   on the same axis, from the `4 × spatial_candidates` best;
//!
//! applies each candidate (clipping, unsplitting) to get the two sides `L` and `R`, and rates
//! it by the real recursive SAH cost of temporary SBVH-like trees built over each side:
//!
//! ```text
//! cost(L, R) = c_t + A(L)/A(P) c(T_L) + A(R)/A(P) c(T_R)
//! ```
//!
//! The temporaries are built cost-only (no node is allocated; their clipped and duplicated
//! references are dropped after rating). The cheapest candidate is applied (a leaf when the
//! node is small enough and `|n| c_i` is not above it) and its children are built with the
//! same rule. Smaller nodes use the plain SBVH rule.
//!
//! # Temporaries
//!
//! [`TsahSpatialConfig::temporary_search`] says how the temporaries search spatial splits:
//!
//! * [`TemporarySearch::Exact`]: a temporary is exactly the tree [`SbvhBuilder`] builds with
//!   [`TsahSpatialConfig::temporary`]. SBVH's spatial search clips every reference into every
//!   bin it spans; in small nodes most references span most of the 128 bins, so this costs
//!   about `128 × 3` clipping steps per reference per level and dominates the build.
//! * [`TemporarySearch::Estimated`] (the default): the temporaries use SBVH's object sweep,
//!   leaf rule, `alpha`, depth and budget rules and apply splits exactly as SBVH does
//!   (clipping, unsplitting), but they find spatial splits by a cheaper estimate: a node of
//!   `n` references uses `min(temporary.spatial_bins, max(min_bins, bins_per_ref × n))`
//!   bins, the references are binned by their boxes (no clipping: `O(n + bins)` per axis),
//!   and only the `refine` best planes over the three axes are re-rated with the straddling
//!   triangles clipped at the plane. The rule that builds the final tree (candidates and
//!   small nodes) is always SBVH's exact search.
//!
//! # SAH guarantee
//!
//! The candidates always include the greedy SBVH choice (the best object split and the best
//! spatial split). When the temporaries are built by exactly the SBVH builder with the same
//! limits ([`TemporarySearch::Exact`] and [`TsahSpatialConfig::temporary`] equal to
//! [`TsahSpatialConfig::sbvh`], as in [`TsahSpatialConfig::EXACT`]) each rating of the greedy
//! choice is exactly the cost SBVH's subtree would have, and leaves are made whenever
//! cheaper, so the tree's SAH is never above the SBVH tree's with the same configuration (by
//! induction over the nodes, up to rounding).
//!
//! The default preset, [`TsahSpatialConfig::DEFAULT`], gives this guarantee up for speed:
//! its temporaries are estimates of SBVH subtrees, not SBVH subtrees, so a rating can rank a
//! candidate above SBVH's choice whose real subtree turns out costlier. (On the ten shared
//! scenes its SAH is below SBVH's everywhere; see `docs/builders-classic.md`.)
//!
//! ```
//! use sahara_builders::sbvh::{SbvhBuilder, SbvhConfig};
//! use sahara_builders::tsah_spatial::{TsahSpatialBuilder, TsahSpatialConfig};
//! use sahara_builders::{BuildInput, Builder};
//! use sahara_geom::{rng::Pcg32, Triangle, Vec3A};
//! use sahara_metrics::{sah, CostModel};
//!
//! let mut rng = Pcg32::new(1, 2);
//! let mut p = || Vec3A::new(rng.range_f32(0.0, 10.0), rng.range_f32(0.0, 10.0), rng.range_f32(0.0, 10.0));
//! let tris: Vec<Triangle> = (0..500).map(|_| Triangle::new(p(), p(), p())).collect();
//! let input = BuildInput::new(&tris, CostModel::default()).unwrap();
//! let sbvh = SbvhBuilder::new(SbvhConfig::default()).build(&input).unwrap();
//! // The default: estimated temporaries.
//! let bvh = TsahSpatialBuilder::new(TsahSpatialConfig::DEFAULT).build(&input).unwrap();
//! bvh.validate(&tris).unwrap();
//! // Exact SBVH temporaries: never above SBVH's SAH.
//! let exact = TsahSpatialBuilder::new(TsahSpatialConfig::EXACT).build(&input).unwrap();
//! exact.validate(&tris).unwrap();
//! assert!(sah(&exact, &input.cost) <= sah(&sbvh, &input.cost) * (1.0 + 1e-9));
//! ```
//!
//! [`SbvhBuilder`]: crate::sbvh::SbvhBuilder

use crate::common::{float_key, half_area, offer, BinMap, Fragment};
use crate::registry::Entry;
use crate::sbvh::{
    self, apply_object, apply_spatial, child_budgets, emit_leaf, initial_refs, object_search,
    recurse_children, refs_bounds, spatial_allowed, spatial_search, Decision, ObjectCand,
    ObjectPartition, ObjectSearch, ObjectSplitMethod, Ref, SbvhConfig, SpatialCand,
};
use crate::{BuildError, BuildInput, Builder, Bvh};
use rayon::prelude::*;
use sahara_geom::{Aabb, Axis, Triangle, Vec3A};
use std::cell::RefCell;

/// How the temporary builds that rate the candidates search spatial splits (see the
/// [module documentation](self#temporaries)).
#[derive(Clone, Copy, Debug, PartialEq, Eq, serde::Serialize, serde::Deserialize)]
pub enum TemporarySearch {
    /// Exactly as [`SbvhBuilder`](crate::sbvh::SbvhBuilder) with
    /// [`TsahSpatialConfig::temporary`]: temporaries are SBVH trees (cost only). Needed for
    /// the SAH guarantee; several times slower.
    Exact,
    /// Spatial splits estimated from the references' boxes, then the best planes re-rated
    /// with clipping. Everything else as SBVH.
    Estimated {
        /// Spatial bins per reference of a temporary node (at least 1): a node of `n`
        /// references uses `min(temporary.spatial_bins, max(min_bins, bins_per_ref × n))`
        /// bins. Default 1.
        bins_per_ref: usize,
        /// The fewest spatial bins of a temporary node (at least 2). Default 4.
        min_bins: usize,
        /// Planes (the best by the box estimate over the three axes) re-rated with the
        /// straddling triangles clipped; the best of them is the node's spatial split (at
        /// least 1). Default 2.
        refine: usize,
    },
}

impl TemporarySearch {
    /// The default estimate: one bin per reference (4 to 128), 2 planes re-rated.
    pub const ESTIMATED: TemporarySearch = TemporarySearch::Estimated {
        bins_per_ref: 1,
        min_bins: 4,
        refine: 2,
    };
}

/// Configuration of the spatial temporary-subtree builder.
#[derive(Clone, Copy, Debug, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct TsahSpatialConfig {
    /// The SBVH rule: how candidates are searched (object split method, spatial bins,
    /// `alpha`, depth limit, duplication budget, leaf size) and how nodes below
    /// [`min_size`](Self::min_size) are split. Default [`SbvhConfig::DEFAULT`].
    pub sbvh: SbvhConfig,
    /// The configuration of the temporary SBVH builds that rate candidates. Default
    /// [`SbvhConfig::DEFAULT`] (the same as `sbvh`, which with
    /// [`TemporarySearch::Exact`] guarantees SAH no worse than SBVH).
    pub temporary: SbvhConfig,
    /// How the temporaries search spatial splits. Default [`TemporarySearch::ESTIMATED`].
    pub temporary_search: TemporarySearch,
    /// Object split candidates rated per node (at least 1). Default 4.
    pub object_candidates: usize,
    /// Spatial split candidates rated per node where spatial splits are searched. Default 4.
    pub spatial_candidates: usize,
    /// Object candidates after the best are skipped when another candidate on the same axis
    /// has a left count closer than this fraction of the node's references (0 to 1; 0 takes
    /// the plain top-k by Eq. 2). Default 0.05.
    pub object_separation: f32,
    /// Spatial candidates after the best are skipped when another candidate on the same axis
    /// has a plane fewer than this many bins away (0 or 1 takes the plain top-k by Eq. 2).
    /// Default 4.
    pub spatial_separation: usize,
    /// Nodes with fewer references use the plain SBVH rule. Default 64.
    pub min_size: usize,
}

impl Default for TsahSpatialConfig {
    fn default() -> Self {
        Self::DEFAULT
    }
}

/// Candidates are chosen among this many times the requested number of best splits.
const CANDIDATE_POOL: usize = 4;

impl TsahSpatialConfig {
    /// 4 object + 4 spatial candidates spread apart, estimated SBVH temporaries, the SBVH rule
    /// below 64 references. No SAH guarantee (see the module documentation).
    pub const DEFAULT: TsahSpatialConfig = TsahSpatialConfig {
        sbvh: SbvhConfig::DEFAULT,
        temporary: SbvhConfig::DEFAULT,
        temporary_search: TemporarySearch::ESTIMATED,
        object_candidates: 4,
        spatial_candidates: 4,
        object_separation: 0.05,
        spatial_separation: 4,
        min_size: 64,
    };
    /// [`DEFAULT`](Self::DEFAULT) with exact SBVH temporaries: SAH never above SBVH's, 4–8×
    /// the time of `DEFAULT`.
    pub const EXACT: TsahSpatialConfig = TsahSpatialConfig {
        temporary_search: TemporarySearch::Exact,
        ..Self::DEFAULT
    };
    /// Faster: 2 + 2 candidates, rating only nodes of 256 references or more.
    pub const FAST: TsahSpatialConfig = TsahSpatialConfig {
        object_candidates: 2,
        spatial_candidates: 2,
        min_size: 256,
        ..Self::DEFAULT
    };

    /// Checks the ranges of the fields.
    pub fn check(&self) -> Result<(), BuildError> {
        self.sbvh.check()?;
        self.temporary.check()?;
        let bad = |m: &str| Err(BuildError::InvalidConfig(format!("tsah-sbvh: {m}")));
        if self.object_candidates < 1 {
            return bad("object_candidates must be at least 1");
        }
        if !(0.0..=1.0).contains(&self.object_separation) {
            return bad("object_separation must be between 0 and 1");
        }
        if let TemporarySearch::Estimated {
            bins_per_ref,
            min_bins,
            refine,
        } = self.temporary_search
        {
            if bins_per_ref < 1 || min_bins < 2 || refine < 1 {
                return bad(
                    "estimated temporaries need bins_per_ref >= 1, min_bins >= 2, refine >= 1",
                );
            }
        }
        Ok(())
    }
}

/// The temporary-subtree SAH builder with spatial splits. Parallel on rayon (nodes, candidates
/// and temporary builds); the tree does not depend on the number of threads.
#[derive(Clone, Debug)]
pub struct TsahSpatialBuilder {
    /// The configuration.
    pub config: TsahSpatialConfig,
    name: &'static str,
}

impl TsahSpatialBuilder {
    /// A builder with `config`, named `"tsah-sbvh"`.
    pub fn new(config: TsahSpatialConfig) -> Self {
        Self::named("tsah-sbvh", config)
    }

    /// A builder with `config` and a registry name of your choice.
    pub fn named(name: &'static str, config: TsahSpatialConfig) -> Self {
        Self { config, name }
    }
}

impl Default for TsahSpatialBuilder {
    fn default() -> Self {
        Self::new(TsahSpatialConfig::default())
    }
}

impl Builder for TsahSpatialBuilder {
    fn name(&self) -> &str {
        self.name
    }

    fn describe(&self) -> String {
        let c = &self.config;
        let search = match c.temporary_search {
            TemporarySearch::Exact => "exact spatial search".to_string(),
            TemporarySearch::Estimated {
                bins_per_ref,
                min_bins,
                refine,
            } => format!(
                "estimated spatial search ({bins_per_ref} bins/ref, >= {min_bins} bins, \
                 {refine} planes clipped)"
            ),
        };
        format!(
            "temporary-subtree SAH with spatial splits: {} object (separation {}) + {} spatial \
             (separation {} bins) candidates per node of >= {} refs, rated with cost-only \
             temporaries [{}; {search}]; rule [{}]",
            c.object_candidates,
            c.object_separation,
            c.spatial_candidates,
            c.spatial_separation,
            c.min_size,
            sbvh::describe_config(&c.temporary),
            sbvh::describe_config(&c.sbvh),
        )
    }

    fn build(&self, input: &BuildInput) -> Result<Bvh, BuildError> {
        self.config.check()?;
        if input.is_empty() {
            return Ok(Bvh::empty());
        }
        let refs = initial_refs(input, None);
        let greedy = sbvh::Ctx::new(input, self.config.sbvh, &refs);
        let ctx = Ctx {
            greedy,
            temporary: greedy.with_config(self.config.temporary),
            cfg: self.config,
        };
        let budget = self.config.sbvh.budget_for(input.len());
        let mut out = Fragment::default();
        build_rec(&ctx, refs, 0, budget, Some(&mut out));
        Ok(out.into_bvh(true))
    }
}

/// Registry entries of this module: `tsah-sbvh`.
pub fn registry_entries() -> Vec<Entry> {
    vec![Entry {
        name: "tsah-sbvh",
        summary: "temporary-subtree SAH with spatial splits: 4 object + 4 spatial candidates \
                  rated by cost-only SBVH-like temporaries (estimated spatial search)",
        spatial: true,
        small_inputs_only: false,
        max_practical_triangles: None,
        make: || Box::new(TsahSpatialBuilder::new(TsahSpatialConfig::DEFAULT)),
    }]
}

struct Ctx<'a> {
    /// The SBVH rule (candidates, small nodes).
    greedy: sbvh::Ctx<'a>,
    /// The temporaries' configuration.
    temporary: sbvh::Ctx<'a>,
    cfg: TsahSpatialConfig,
}

#[derive(Clone, Copy)]
enum Candidate {
    Object(ObjectCand),
    Spatial(SpatialCand),
}

/// Builds the subtree over `refs`; returns its cost `c(n)` and half area.
fn build_rec(
    ctx: &Ctx,
    refs: Vec<Ref>,
    depth: usize,
    budget: usize,
    out: Option<&mut Fragment>,
) -> (f64, f64) {
    let n = refs.len();
    let g = &ctx.greedy;
    if n < ctx.cfg.min_size.max(2) || depth >= g.cfg.fallback_depth {
        return sbvh::build_rec(g, refs, depth, budget, out);
    }
    let bounds = refs_bounds(&refs);
    let area = half_area(&bounds);
    let (search, cands) = candidates(ctx, &refs, &bounds, area, depth, budget);
    let apply = |c: &Candidate| match c {
        Candidate::Object(o) => Some(apply_object(&refs, &search, o)),
        Candidate::Spatial(s) => apply_spatial(g, &refs, s),
    };
    // Rate every candidate with cost-only temporaries over both sides.
    let ratings: Vec<Option<f64>> = cands
        .par_iter()
        .map(|c| {
            let (l, r) = apply(c)?;
            let (bl, br) = child_budgets(n, l.len(), r.len(), budget);
            let ((c_l, a_l), (c_r, a_r)) = rayon::join(
                || temporary(ctx, l, depth + 1, bl),
                || temporary(ctx, r, depth + 1, br),
            );
            Some(g.cost.inner_cost(area, a_l, c_l, a_r, c_r))
        })
        .collect();
    let mut best: Option<(usize, f64)> = None;
    for (i, r) in ratings.iter().enumerate() {
        if let Some(r) = *r {
            if best.is_none_or(|(_, b)| r < b) {
                best = Some((i, r));
            }
        }
    }
    // The best object split always applies, so there is a best candidate.
    let (best, best_cost) = best.expect("object splits always apply");
    if n <= g.cfg.max_leaf_size && g.cost.leaf_cost(n) <= best_cost {
        emit_leaf(out, &bounds, &refs);
        return (g.cost.leaf_cost(n), area);
    }
    let (left, right) = apply(&cands[best]).expect("rated candidates apply");
    drop(refs);
    let ((c_l, a_l), (c_r, a_r)) = recurse_children(
        n,
        &bounds,
        left,
        right,
        depth,
        budget,
        out,
        &|refs, d, b, out| build_rec(ctx, refs, d, b, out),
    );
    (g.cost.inner_cost(area, a_l, c_l, a_r, c_r), area)
}

/// The candidates of a node (object splits first, each kind best first) and the object
/// search they refer to.
fn candidates(
    ctx: &Ctx,
    refs: &[Ref],
    bounds: &Aabb,
    area: f64,
    depth: usize,
    budget: usize,
) -> (ObjectSearch, Vec<Candidate>) {
    let g = &ctx.greedy;
    let n = refs.len();
    let cfg = &ctx.cfg;
    let k = cfg.object_candidates;
    let search = object_search(g, refs, area, k * CANDIDATE_POOL);
    let min_gap = cfg.object_separation as f64 * n as f64;
    let mut objects: Vec<ObjectCand> = Vec::with_capacity(k);
    for c in &search.cands {
        if objects.len() == k {
            break;
        }
        let close = objects.iter().any(|o| {
            object_axis(o) == object_axis(c) && (o.n_left.abs_diff(c.n_left) as f64) < min_gap
        });
        if !close {
            objects.push(*c);
        }
    }
    let mut cands: Vec<Candidate> = objects.into_iter().map(Candidate::Object).collect();
    let k = cfg.spatial_candidates;
    if k > 0 && spatial_allowed(g, &search.cands[0], depth, budget) {
        let pool = spatial_search(g, refs, bounds, area, k * CANDIDATE_POOL, budget);
        let mut spatial: Vec<SpatialCand> = Vec::with_capacity(k);
        for c in pool {
            if spatial.len() == k {
                break;
            }
            let close = spatial
                .iter()
                .any(|s| s.axis == c.axis && s.plane.abs_diff(c.plane) < cfg.spatial_separation);
            if !close {
                spatial.push(c);
            }
        }
        cands.extend(spatial.into_iter().map(Candidate::Spatial));
    }
    (search, cands)
}

fn object_axis(c: &ObjectCand) -> Axis {
    match c.part {
        ObjectPartition::Sorted { axis, .. } | ObjectPartition::Binned { axis, .. } => axis,
    }
}

/// The cost `c(T)` and half area of the temporary tree over `refs`.
fn temporary(ctx: &Ctx, refs: Vec<Ref>, depth: usize, budget: usize) -> (f64, f64) {
    match ctx.cfg.temporary_search {
        TemporarySearch::Exact => sbvh::build_rec(&ctx.temporary, refs, depth, budget, None),
        TemporarySearch::Estimated { .. } => estimated_rec(ctx, refs, depth, budget),
    }
}

// ---------------------------------------------------------------------------------------------
// Estimated temporaries.

/// Nodes with at least this many references search their three axes in parallel.
const PAR_AXES_THRESHOLD: usize = 8 * 1024;

/// The cost-only SBVH-like temporary with the estimated spatial search.
fn estimated_rec(ctx: &Ctx, refs: Vec<Ref>, depth: usize, budget: usize) -> (f64, f64) {
    let n = refs.len();
    let bounds = refs_bounds(&refs);
    let area = half_area(&bounds);
    let t = &ctx.temporary;
    match estimated_decide(ctx, &refs, &bounds, area, depth, budget) {
        Decision::Leaf => (t.cost.leaf_cost(n), area),
        Decision::Split(l, r) => {
            drop(refs);
            let ((c_l, a_l), (c_r, a_r)) =
                recurse_children(n, &bounds, l, r, depth, budget, None, &|refs, d, b, _| {
                    estimated_rec(ctx, refs, d, b)
                });
            (t.cost.inner_cost(area, a_l, c_l, a_r, c_r), area)
        }
    }
}

/// SBVH's rule ([`sbvh::decide_with`]) with the sweep object search in scratch buffers and
/// the estimated spatial search, over at most `bins_per_ref` spatial bins per reference.
fn estimated_decide(
    ctx: &Ctx,
    refs: &[Ref],
    bounds: &Aabb,
    area: f64,
    depth: usize,
    budget: usize,
) -> Decision {
    let TemporarySearch::Estimated {
        bins_per_ref,
        min_bins,
        refine,
    } = ctx.cfg.temporary_search
    else {
        unreachable!("estimated temporaries only")
    };
    let mut cfg = ctx.temporary.cfg;
    cfg.spatial_bins = cfg
        .spatial_bins
        .min(refs.len().saturating_mul(bins_per_ref).max(min_bins));
    let t = &ctx.temporary.with_config(cfg);
    sbvh::decide_with(
        t,
        refs,
        bounds,
        area,
        depth,
        budget,
        |refs, area| sweep_object_search(t, refs, area),
        |refs, bounds, area, budget| {
            estimated_spatial_search(t, refs, bounds, area, budget, refine)
        },
    )
}

/// Scratch buffers of the temporaries' searches, one set per thread (the searches call no
/// rayon operation while they hold them).
#[derive(Default)]
struct Scratch {
    keys: Vec<u64>,
    suffix: Vec<Aabb>,
    bins: Vec<BoxBin>,
    right: Vec<(Aabb, u32)>,
}

thread_local! {
    static SCRATCH: RefCell<Scratch> = RefCell::default();
}

/// The best object split, the same as [`object_search`] with `k = 1` finds, in scratch
/// buffers instead of fresh allocations.
fn sweep_object_search(t: &sbvh::Ctx, refs: &[Ref], area: f64) -> ObjectSearch {
    if t.cfg.object_split != ObjectSplitMethod::Sweep || refs.len() >= PAR_AXES_THRESHOLD {
        return object_search(t, refs, area, 1);
    }
    let n = refs.len();
    SCRATCH.with_borrow_mut(|sc| {
        let mut best: Option<ObjectCand> = None;
        let mut orders: [Vec<u32>; 3] = Default::default();
        for axis in 0..3 {
            // The same keys as SBVH's sweep: ties in the centroid go to the earlier reference.
            sc.keys.clear();
            sc.keys.extend(refs.iter().enumerate().map(|(i, r)| {
                let c = (r.bounds.min[axis] + r.bounds.max[axis]) * 0.5;
                ((float_key(c) as u64) << 32) | i as u64
            }));
            sc.keys.sort_unstable();
            let keys = &sc.keys;
            sc.suffix.clear();
            sc.suffix.resize(n, Aabb::EMPTY);
            let mut acc = Aabb::EMPTY;
            for i in (1..n).rev() {
                acc.grow_aabb(&refs[keys[i] as u32 as usize].bounds);
                sc.suffix[i] = acc;
            }
            let mut left = Aabb::EMPTY;
            let mut improved = false;
            for i in 1..n {
                left.grow_aabb(&refs[keys[i - 1] as u32 as usize].bounds);
                let (al, ar) = (half_area(&left), half_area(&sc.suffix[i]));
                let score = al * i as f64 + ar * (n - i) as f64;
                if best.as_ref().is_some_and(|b| score > b.score) {
                    continue;
                }
                let cand = ObjectCand {
                    part: ObjectPartition::Sorted { axis, count: i },
                    score,
                    cost: t.cost.split_cost(area, al, i, ar, n - i),
                    left,
                    right: sc.suffix[i],
                    n_left: i,
                    n_right: n - i,
                };
                if best.as_ref().is_none_or(|b| cand.better(b)) {
                    best = Some(cand);
                    improved = true;
                }
            }
            if improved {
                // Only the best candidate's order is needed.
                orders = Default::default();
                orders[axis] = keys.iter().map(|&k| k as u32).collect();
            }
        }
        ObjectSearch {
            orders,
            cands: vec![best.expect("two or more references have an object split")],
        }
    })
}

/// A spatial split rated with the references' boxes (no clipping).
#[derive(Clone, Copy)]
struct Rough {
    score: f64,
    axis: Axis,
    plane: usize,
    map: BinMap,
    n_left: usize,
    n_right: usize,
}

impl Rough {
    /// The candidate order: score, then axis, then plane.
    fn better(&self, other: &Rough) -> bool {
        self.score
            .total_cmp(&other.score)
            .then((self.axis, self.plane).cmp(&(other.axis, other.plane)))
            .is_lt()
    }
}

#[derive(Clone, Copy)]
struct BoxBin {
    /// Union of the boxes of the references whose first bin is this one.
    by_first: Aabb,
    /// Union of the boxes of the references whose last bin is this one.
    by_last: Aabb,
    /// References whose first bin is this one.
    enter: u32,
    /// References whose last bin is this one.
    exit: u32,
}

/// The estimated best spatial split of a temporary node (whose duplication fits `budget`).
fn estimated_spatial_search(
    t: &sbvh::Ctx,
    refs: &[Ref],
    bounds: &Aabb,
    area: f64,
    budget: usize,
    refine: usize,
) -> Option<SpatialCand> {
    let f = |axis| rough_axis(t, refs, bounds, axis, budget, refine);
    let per_axis: Vec<Vec<Rough>> = if refs.len() >= PAR_AXES_THRESHOLD {
        (0..3).into_par_iter().map(f).collect()
    } else {
        (0..3).map(f).collect()
    };
    let mut rough: Vec<Rough> = Vec::with_capacity(refine);
    for r in per_axis.into_iter().flatten() {
        offer(&mut rough, refine, r, Rough::better);
    }
    let mut best: Option<SpatialCand> = None;
    for r in &rough {
        let cand = refine_plane(t, refs, r, area);
        if best.as_ref().is_none_or(|b| cand.better(b)) {
            best = Some(cand);
        }
    }
    best
}

/// The `keep` best planes of one axis by the box estimate: the references are counted as
/// SBVH counts them (entering their first bin, leaving their last), and each side of a plane
/// is bounded by the boxes of the references reaching it, cut at the plane.
fn rough_axis(
    t: &sbvh::Ctx,
    refs: &[Ref],
    bounds: &Aabb,
    axis: Axis,
    budget: usize,
    keep: usize,
) -> Vec<Rough> {
    let nb = t.cfg.spatial_bins;
    let Some(map) = BinMap::new(bounds.min[axis], bounds.max[axis], nb) else {
        return Vec::new();
    };
    SCRATCH.with_borrow_mut(|sc| {
        let empty = BoxBin {
            by_first: Aabb::EMPTY,
            by_last: Aabb::EMPTY,
            enter: 0,
            exit: 0,
        };
        let bins = &mut sc.bins;
        bins.clear();
        bins.resize(nb, empty);
        for r in refs {
            let first = map.bin(r.bounds.min[axis]);
            let last = map.bin(r.bounds.max[axis]);
            bins[first].enter += 1;
            bins[first].by_first.grow_aabb(&r.bounds);
            bins[last].exit += 1;
            bins[last].by_last.grow_aabb(&r.bounds);
        }
        let n = refs.len();
        // Lane masks instead of writes to one lane (those go through memory and stall).
        let mask = Vec3A::new(0.0, 1.0, 2.0).cmpeq(Vec3A::splat(axis as f32));
        let right = &mut sc.right;
        right.clear();
        right.resize(nb, (Aabb::EMPTY, 0));
        let mut acc = Aabb::EMPTY;
        let mut rc = 0u32;
        for i in (1..nb).rev() {
            acc.grow_aabb(&bins[i].by_last);
            rc += bins[i].exit;
            right[i] = (acc, rc);
        }
        let mut rough: Vec<Rough> = Vec::with_capacity(keep);
        let mut lb = Aabb::EMPTY;
        let mut lc = 0u32;
        for i in 1..nb {
            lb.grow_aabb(&bins[i - 1].by_first);
            lc += bins[i - 1].enter;
            let (rb, rc) = right[i];
            let (nl, nr) = (lc as usize, rc as usize);
            if nl == 0 || nr == 0 || (nl + nr).saturating_sub(n) > budget {
                continue;
            }
            let pos = Vec3A::splat(map.plane(i));
            let l = Aabb::new(lb.min, Vec3A::select(mask, lb.max.min(pos), lb.max));
            let r = Aabb::new(Vec3A::select(mask, rb.min.max(pos), rb.min), rb.max);
            let score = half_area(&l) * nl as f64 + half_area(&r) * nr as f64;
            if rough.len() == keep && score >= rough[keep - 1].score {
                continue;
            }
            let cand = Rough {
                score,
                axis,
                plane: i,
                map,
                n_left: nl,
                n_right: nr,
            };
            offer(&mut rough, keep, cand, Rough::better);
        }
        rough
    })
}

/// Rates a plane found by the box estimate with the straddling triangles clipped at it.
fn refine_plane(t: &sbvh::Ctx, refs: &[Ref], r: &Rough, area: f64) -> SpatialCand {
    let (axis, plane, map) = (r.axis, r.plane, r.map);
    let pos = map.plane(plane);
    let mut lb = Aabb::EMPTY;
    let mut rb = Aabb::EMPTY;
    for rf in refs {
        if map.bin(rf.bounds.max[axis]) < plane {
            lb.grow_aabb(&rf.bounds);
        } else if map.bin(rf.bounds.min[axis]) >= plane {
            rb.grow_aabb(&rf.bounds);
        } else {
            let (pl, pr) = plane_pieces(&t.tris[rf.prim as usize], axis, pos, &rf.bounds);
            lb.grow_aabb(&pl);
            rb.grow_aabb(&pr);
        }
    }
    let (la, ra) = (half_area(&lb), half_area(&rb));
    let (nl, nr) = (r.n_left, r.n_right);
    SpatialCand {
        axis,
        plane,
        map,
        pos,
        score: la * nl as f64 + ra * nr as f64,
        cost: t.cost.split_cost(area, la, nl, ra, nr),
        n_left: nl,
        n_right: nr,
    }
}

/// Bounds of the parts of `tri` on each side of the plane `x[axis] = pos` (its vertices on
/// that side and the points where its edges cross the plane), intersected with the
/// reference's box `b` and the half space, as SBVH's binning bounds a piece.
#[inline]
fn plane_pieces(tri: &Triangle, axis: Axis, pos: f32, b: &Aabb) -> (Aabb, Aabb) {
    let mut l = Aabb::EMPTY;
    let mut r = Aabb::EMPTY;
    for k in 0..3 {
        let p = tri.v[k];
        let q = tri.v[(k + 1) % 3];
        let (pa, qa) = (p[axis], q[axis]);
        if pa <= pos {
            l.grow(p);
        }
        if pa >= pos {
            r.grow(p);
        }
        if (pa < pos && qa > pos) || (pa > pos && qa < pos) {
            let x = p + (q - p) * ((pos - pa) / (qa - pa));
            l.grow(x);
            r.grow(x);
        }
    }
    let mut lb = *b;
    lb.max[axis] = lb.max[axis].min(pos);
    let mut rb = *b;
    rb.min[axis] = rb.min[axis].max(pos);
    (l.intersection(&lb), r.intersection(&rb))
}
