//! The SBVH rule (Stich, Friedrich & Dietrich 2009), shared by the `sbvh` builder and the
//! spatial temporary-subtree builder (`tsah_spatial`), which rates its candidates with
//! temporaries built by the same rule (or by its decision with cheaper searches): its
//! configuration ([`SbvhConfig`]), a node's task (references, depth,
//! duplication budget), the decision at one node and the rule.

use sahara_bvh::RefCuts;
use sahara_geom::Aabb;
use sahara_metrics::CostModel;

use crate::split::half_area;
use crate::split::object::{
    apply_object, bin_objects, median_split, refs_bounds, sweep_objects, ObjectCand, ObjectScratch,
    ObjectSearch, Ref,
};
use crate::split::spatial::{
    apply_spatial, child_budgets, refined_spatial_search, spatial_search, Clipper, CutLog,
    SpatialCand,
};
use crate::topdown::{Rule, Step};
use crate::{BuildError, BuildInput};

/// How SBVH finds object splits.
#[derive(Clone, Copy, Debug, PartialEq, Eq, serde::Serialize, serde::Deserialize)]
pub enum ObjectSplitMethod {
    /// Full sweep: at every node the references are sorted by centroid on each axis and all
    /// `n - 1` positions are rated (Stich et al.'s original). `O(n log n)` per node.
    Sweep,
    /// Equal-width bins over the reference centroids (as in the `binned` builder); falls back to
    /// the sweep where no plane separates the centroids. `O(n)` per node.
    Binned {
        /// Bins per axis (at least 2).
        bins: usize,
    },
}

/// Configuration of the SBVH builder.
#[derive(Clone, Copy, Debug, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct SbvhConfig {
    /// Equal-width bins per axis for the spatial split search. Default 128. Values below 2
    /// disable spatial splits (the builder then is a plain sweep SAH builder).
    pub spatial_bins: usize,
    /// When at least 2 and below `spatial_bins`, the best spatial split is searched coarse
    /// to fine ([`crate::split::spatial::refined_spatial_search`]): this many bins per axis
    /// first, then bins of the resolution of `spatial_bins` around each axis's two best
    /// coarse planes. About 2-2.5x faster builds for a SAH within about ±0.5% of the full
    /// search (sometimes lower, sometimes higher: see `docs/builders-classic.md`). `0` (the
    /// default) bins all `spatial_bins` at once (Stich et al.'s search).
    #[serde(default)]
    pub coarse_spatial_bins: usize,
    /// Spatial splits are searched only where the two sides of the best object split overlap
    /// by more than `alpha` times the surface area of the root. Default `1e-5`.
    pub alpha: f32,
    /// Spatial splits are searched only where that overlap is also at least this fraction of
    /// the sum of the two sides' areas (the gate of Embree's spatial-split builder, which uses
    /// 0.2): a test relative to the node rather than to the root, so that the many small nodes
    /// whose sides barely touch are not binned. Default `0` (Stich et al.'s test alone).
    #[serde(default)]
    pub overlap_ratio: f32,
    /// No spatial split is searched at this depth or deeper. Default 48.
    pub max_spatial_depth: usize,
    /// Extra references allowed, relative to the number of triangles: `1.0` allows up to
    /// twice as many references as triangles. Default `1.0`.
    pub duplication_budget: f32,
    /// Largest leaf (at least 1): nodes with more references are always split. Default 8.
    pub max_leaf_size: usize,
    /// How object splits are found. Default [`ObjectSplitMethod::Sweep`].
    pub object_split: ObjectSplitMethod,
    /// Reference unsplitting when a spatial split is applied. Default `true`.
    pub unsplitting: bool,
    /// Nodes at this depth or deeper are split at the object median only (when they must be
    /// split), bounding the depth on adversarial input. Default 96.
    pub fallback_depth: usize,
}

impl Default for SbvhConfig {
    fn default() -> Self {
        Self::DEFAULT
    }
}

impl SbvhConfig {
    /// Stich et al.'s parameters: 128 spatial bins, `alpha = 1e-5`, full sweep object splits,
    /// spatial splits down to depth 48, up to 2× references, leaves of at most 8.
    pub const DEFAULT: SbvhConfig = SbvhConfig {
        spatial_bins: 128,
        coarse_spatial_bins: 0,
        alpha: 1e-5,
        overlap_ratio: 0.0,
        max_spatial_depth: 48,
        duplication_budget: 1.0,
        max_leaf_size: 8,
        object_split: ObjectSplitMethod::Sweep,
        unsplitting: true,
        fallback_depth: 96,
    };
    /// The default with the spatial splits searched coarse to fine: 16 bins per axis, refined
    /// to the resolution of 128 around each axis's two best coarse planes (registered as
    /// `sbvh-refined`).
    pub const REFINED: SbvhConfig = SbvhConfig {
        coarse_spatial_bins: 16,
        ..Self::DEFAULT
    };
    /// A faster preset: object splits by 32 centroid bins, 32 spatial bins.
    pub const FAST: SbvhConfig = SbvhConfig {
        spatial_bins: 32,
        object_split: ObjectSplitMethod::Binned { bins: 32 },
        ..Self::DEFAULT
    };

    /// [`SbvhConfig::FAST`] with the overlap gate of Embree's spatial-split builder
    /// (`overlap_ratio` 0.2), registered as `sbvh-fast`: about 2-3x faster builds than the
    /// default for a SAH 0.5-4% higher on the shared scenes (`docs/builders-classic.md`,
    /// "Faster SBVH").
    pub const FAST_GATED: SbvhConfig = SbvhConfig {
        overlap_ratio: 0.2,
        ..Self::FAST
    };

    /// The number of extra references allowed for `n` triangles.
    pub fn budget_for(&self, n: usize) -> usize {
        let b = self.duplication_budget as f64 * n as f64;
        if b >= usize::MAX as f64 {
            usize::MAX
        } else {
            b as usize
        }
    }

    /// Checks the ranges of the fields ([`BuildError::InvalidConfig`] names the field); the
    /// `sbvh` builder's [`Strategy::check`](crate::Strategy::check).
    pub fn check(&self) -> Result<(), BuildError> {
        let bad = |m: &str| Err(BuildError::InvalidConfig(format!("sbvh: {m}")));
        if self.max_leaf_size < 1 {
            return bad("max_leaf_size must be at least 1");
        }
        if !(self.alpha.is_finite() && self.alpha >= 0.0) {
            return bad("alpha must be finite and non-negative");
        }
        if !(self.overlap_ratio.is_finite() && self.overlap_ratio >= 0.0) {
            return bad("overlap_ratio must be finite and non-negative");
        }
        if !(self.duplication_budget.is_finite() && self.duplication_budget >= 0.0) {
            return bad("duplication_budget must be finite and non-negative");
        }
        if let ObjectSplitMethod::Binned { bins } = self.object_split {
            if bins < 2 {
                return bad("object split bins must be at least 2");
            }
        }
        Ok(())
    }

    /// A one-line description, for listings and reports; the `sbvh` builder's
    /// [`Strategy::describe`](crate::Strategy::describe).
    pub fn describe(&self) -> String {
        let c = self;
        let object = match c.object_split {
            ObjectSplitMethod::Sweep => "full-sweep object splits".to_string(),
            ObjectSplitMethod::Binned { bins } => format!("{bins}-bin object splits"),
        };
        let spatial = if c.coarse_spatial_bins >= 2 && c.coarse_spatial_bins < c.spatial_bins {
            format!(
                "{} coarse spatial bins refined to {}",
                c.coarse_spatial_bins, c.spatial_bins
            )
        } else {
            format!("{} spatial bins", c.spatial_bins)
        };
        format!(
            "SBVH (Stich et al. 2009): {object}, {spatial}, alpha {:e}{}, spatial depth < {}, \
             budget {}x extra refs, unsplitting {}, leaves <= {}",
            c.alpha,
            if c.overlap_ratio > 0.0 {
                format!(", overlap >= {} of the sides' areas", c.overlap_ratio)
            } else {
                String::new()
            },
            c.max_spatial_depth,
            c.duplication_budget,
            if c.unsplitting { "on" } else { "off" },
            c.max_leaf_size
        )
    }
}

/// The references of all primitives (or of a subset) with their full boxes.
pub(crate) fn initial_refs(input: &BuildInput, prims: Option<&[u32]>) -> Vec<Ref> {
    let b = input.bounds();
    match prims {
        Some(p) => p
            .iter()
            .map(|&prim| Ref::new(b[prim as usize], prim))
            .collect(),
        None => b
            .iter()
            .enumerate()
            .map(|(i, &bounds)| Ref::new(bounds, i as u32))
            .collect(),
    }
}

/// Everything a node decision needs besides the node's references.
#[derive(Clone, Copy, Debug)]
pub(crate) struct Ctx<'a> {
    /// How primitives are cut (`None`: no spatial splits).
    pub clipper: Option<Clipper<'a>>,
    pub cost: CostModel,
    pub cfg: SbvhConfig,
    /// Half area of the root (of the whole build, also for temporary subtrees).
    pub root_area: f64,
    /// Where applied spatial splits record their cuts (the tree's build; `None` for
    /// temporaries and cost-only builds, whose trees are dropped).
    pub log: Option<&'a CutLog>,
}

impl<'a> Ctx<'a> {
    pub fn new(input: &'a BuildInput, cfg: SbvhConfig, root_refs: &[Ref]) -> Self {
        Self {
            clipper: input.clipper(),
            cost: input.cost,
            cfg,
            root_area: half_area(&refs_bounds(root_refs)),
            log: None,
        }
    }

    /// The same context with another configuration, recording no cuts.
    pub fn with_config(&self, cfg: SbvhConfig) -> Self {
        Self {
            cfg,
            log: None,
            ..*self
        }
    }

    /// The same context recording the cuts of the spatial splits it applies into `log`.
    pub fn logging(&self, log: &'a CutLog) -> Self {
        Self {
            log: Some(log),
            ..*self
        }
    }

    /// The same context recording no cuts.
    pub fn unlogged(&self) -> Self {
        Self { log: None, ..*self }
    }

    /// The `k` best object splits of a node with at least two references (never empty), by
    /// the configured method.
    pub fn object_search(
        &self,
        refs: &[Ref],
        area: f64,
        k: usize,
        scratch: &mut ObjectScratch,
    ) -> ObjectSearch {
        debug_assert!(refs.len() >= 2 && k >= 1);
        if let ObjectSplitMethod::Binned { bins } = self.cfg.object_split {
            let cands = bin_objects(refs, area, k, bins, &self.cost, scratch);
            if !cands.is_empty() {
                return ObjectSearch {
                    orders: Default::default(),
                    cands,
                };
            }
        }
        sweep_objects(refs, area, k, &self.cost, scratch)
    }

    /// The `k` best spatial splits of a node whose duplication fits in `budget`. The best one
    /// alone (`k == 1`) is searched coarse to fine when the configuration asks for it
    /// ([`SbvhConfig::coarse_spatial_bins`]).
    pub fn spatial_search(
        &self,
        refs: &[Ref],
        bounds: &Aabb,
        area: f64,
        k: usize,
        budget: usize,
    ) -> Vec<SpatialCand> {
        let Some(c) = &self.clipper else {
            return Vec::new();
        };
        let (fine, coarse) = (self.cfg.spatial_bins, self.cfg.coarse_spatial_bins);
        if k == 1 && coarse >= 2 && coarse < fine {
            return refined_spatial_search(c, refs, bounds, area, budget, coarse, fine, &self.cost)
                .into_iter()
                .collect();
        }
        spatial_search(c, refs, bounds, area, k, budget, fine, &self.cost)
    }

    /// The two sides of a spatial split at a node at `depth` (see [`apply_spatial`]).
    pub fn apply_spatial(
        &self,
        refs: &[Ref],
        cand: &SpatialCand,
        depth: usize,
    ) -> Option<(Vec<Ref>, Vec<Ref>)> {
        let clipper = self.clipper.as_ref()?;
        let log = self.log.map(|l| (l, depth));
        apply_spatial(clipper, refs, cand, self.cfg.unsplitting, log)
    }
}

/// True when the SBVH rule searches spatial splits at this node, given its best object split:
/// its sides overlap by more than `alpha` times the root's area (Stich et al.) and, when
/// [`SbvhConfig::overlap_ratio`] is set, by at least that fraction of the sides' own areas
/// (Embree's gate; the areas are `f64`, so no finite box overflows them).
pub(crate) fn spatial_allowed(
    ctx: &Ctx,
    best_object: &ObjectCand,
    depth: usize,
    budget: usize,
) -> bool {
    if ctx.clipper.is_none()
        || ctx.cfg.spatial_bins < 2
        || depth >= ctx.cfg.max_spatial_depth
        || budget == 0
    {
        return false;
    }
    let overlap = best_object.overlap();
    let ratio = ctx.cfg.overlap_ratio as f64;
    overlap > ctx.cfg.alpha as f64 * ctx.root_area
        && (ratio <= 0.0
            || overlap >= ratio * (half_area(&best_object.left) + half_area(&best_object.right)))
}

/// What the SBVH rule does with a node.
pub(crate) enum Decision {
    Leaf,
    Split(Vec<Ref>, Vec<Ref>),
}

/// The SBVH rule: the cheapest of leaf, best object split and best spatial split.
pub(crate) fn decide(
    ctx: &Ctx,
    refs: &[Ref],
    bounds: &Aabb,
    area: f64,
    depth: usize,
    budget: usize,
    scratch: &mut ObjectScratch,
) -> Decision {
    decide_with(
        ctx,
        refs,
        bounds,
        area,
        depth,
        budget,
        |refs, area| ctx.object_search(refs, area, 1, scratch),
        |refs, bounds, area, budget| {
            ctx.spatial_search(refs, bounds, area, 1, budget)
                .first()
                .copied()
        },
    )
}

/// The SBVH rule with the given searches (`object(refs, area)`: the best object split first
/// in its candidates; `spatial(refs, bounds, area, budget)`: the best spatial split, if any),
/// which lets cost-only temporaries use cheaper searches under the same rule (see
/// `tsah_spatial`). `ctx` gives the configuration, the cost model and the clipping.
#[allow(clippy::too_many_arguments)]
pub(crate) fn decide_with(
    ctx: &Ctx,
    refs: &[Ref],
    bounds: &Aabb,
    area: f64,
    depth: usize,
    budget: usize,
    object: impl FnOnce(&[Ref], f64) -> ObjectSearch,
    spatial: impl FnOnce(&[Ref], &Aabb, f64, usize) -> Option<SpatialCand>,
) -> Decision {
    let n = refs.len();
    if n == 1 {
        return Decision::Leaf;
    }
    let can_leaf = n <= ctx.cfg.max_leaf_size;
    if depth >= ctx.cfg.fallback_depth {
        if can_leaf {
            return Decision::Leaf;
        }
        let (l, r) = median_split(refs);
        return Decision::Split(l, r);
    }
    let search = object(refs, area);
    let best_object = search.cands[0];
    let spatial = if spatial_allowed(ctx, &best_object, depth, budget) {
        spatial(refs, bounds, area, budget).filter(|s| s.cost < best_object.cost)
    } else {
        None
    };
    let best = spatial.map_or(best_object.cost, |s| s.cost);
    if can_leaf && ctx.cost.leaf_cost(n) <= best {
        return Decision::Leaf;
    }
    if let Some(s) = spatial {
        if let Some((l, r)) = ctx.apply_spatial(refs, &s, depth) {
            return Decision::Split(l, r);
        }
    }
    let (l, r) = apply_object(refs, &search, &best_object);
    Decision::Split(l, r)
}

/// A node of a spatial-split build: its references, depth and duplication budget.
pub(crate) struct SbvhTask {
    pub refs: Vec<Ref>,
    pub depth: usize,
    pub budget: usize,
}

impl SbvhTask {
    /// The children's tasks after a split (with the budget left shared between them).
    pub fn children(&self, left: Vec<Ref>, right: Vec<Ref>) -> (SbvhTask, SbvhTask) {
        let (bl, br) = child_budgets(self.refs.len(), left.len(), right.len(), self.budget);
        let depth = self.depth + 1;
        (
            SbvhTask {
                refs: left,
                depth,
                budget: bl,
            },
            SbvhTask {
                refs: right,
                depth,
                budget: br,
            },
        )
    }

    /// The driver's step for a decision over this node (of box `bounds`).
    pub fn step(self, bounds: Aabb, decision: Decision) -> Step<SbvhTask> {
        match decision {
            Decision::Leaf => Step::Leaf { bounds, task: self },
            Decision::Split(l, r) => {
                let (left, right) = self.children(l, r);
                Step::Split {
                    bounds,
                    left,
                    right,
                }
            }
        }
    }
}

/// The SBVH rule as a [`Rule`].
pub(crate) struct SbvhRule<'a>(pub Ctx<'a>);

impl Rule for SbvhRule<'_> {
    type Task = SbvhTask;
    type Scratch = ObjectScratch;

    fn size(&self, t: &SbvhTask) -> usize {
        t.refs.len()
    }

    fn split(&self, t: SbvhTask, scratch: &mut ObjectScratch) -> Step<SbvhTask> {
        let bounds = refs_bounds(&t.refs);
        let area = half_area(&bounds);
        let d = decide(&self.0, &t.refs, &bounds, area, t.depth, t.budget, scratch);
        t.step(bounds, d)
    }

    fn leaf_refs(&self, t: &SbvhTask, out: &mut Vec<u32>) {
        out.extend(t.refs.iter().map(|r| r.prim));
    }

    fn leaf_cuts(&self, t: &SbvhTask, out: &mut Vec<u32>) {
        leaf_cuts(&self.0, t, out)
    }

    fn ref_cuts(&self, heads: &[u32]) -> Option<RefCuts> {
        ref_cuts(&self.0, heads)
    }

    fn parallel_threshold(&self) -> usize {
        2048
    }
}

/// [`Rule::leaf_cuts`] of the rules over SBVH tasks: the references' last cuts, when `ctx`
/// records them.
pub(crate) fn leaf_cuts(ctx: &Ctx, t: &SbvhTask, out: &mut Vec<u32>) {
    if ctx.log.is_some() {
        out.extend(t.refs.iter().map(|r| r.cut));
    }
}

/// [`Rule::ref_cuts`] of the rules over SBVH tasks.
pub(crate) fn ref_cuts(ctx: &Ctx, heads: &[u32]) -> Option<RefCuts> {
    ctx.log.map(|log| log.resolve(heads))
}
