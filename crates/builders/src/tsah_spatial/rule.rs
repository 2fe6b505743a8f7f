//! The rule of the spatial temporary-subtree builder (candidates rated by temporaries) and
//! the rule of its estimated temporaries, both as [`Rule`]s over SBVH tasks.

use rayon::prelude::*;
use sahara_geom::Aabb;

use super::{TemporarySearch, TsahSpatialConfig};
use crate::cost_only;
use crate::rules::sbvh::{
    decide, decide_with, leaf_cuts, ref_cuts, spatial_allowed, Ctx, Decision, SbvhRule, SbvhTask,
};
use crate::split::half_area;
use crate::split::object::{
    apply_object, refs_bounds, ObjectCand, ObjectScratch, ObjectSearch, Ref,
};
use crate::split::spatial::{estimated_spatial_search, EstimateScratch, SpatialCand};
use crate::topdown::{Rule, Step};

/// Candidates are chosen among this many times the requested number of best splits.
pub(super) const CANDIDATE_POOL: usize = 4;

/// The builder's rule: rated candidates at nodes of at least `min_size` references, the SBVH
/// rule below.
pub(super) struct SpatialRated<'a> {
    /// The SBVH rule (candidates, small nodes).
    pub greedy: Ctx<'a>,
    /// The temporaries' configuration.
    pub temporary: Ctx<'a>,
    pub cfg: TsahSpatialConfig,
}

#[derive(Clone, Copy)]
enum Candidate {
    Object(ObjectCand),
    Spatial(SpatialCand),
}

impl Rule for SpatialRated<'_> {
    type Task = SbvhTask;
    type Scratch = ObjectScratch;

    fn size(&self, t: &SbvhTask) -> usize {
        t.refs.len()
    }

    fn split(&self, t: SbvhTask, scratch: &mut ObjectScratch) -> Step<SbvhTask> {
        let n = t.refs.len();
        let g = &self.greedy;
        let bounds = refs_bounds(&t.refs);
        let area = half_area(&bounds);
        if n < self.cfg.min_size.max(2) || t.depth >= g.cfg.fallback_depth {
            let d = decide(g, &t.refs, &bounds, area, t.depth, t.budget, scratch);
            return t.step(bounds, d);
        }
        let (search, cands) = self.candidates(&t.refs, &bounds, area, t.depth, t.budget, scratch);
        // The ratings apply candidates without recording cuts; the chosen one is applied
        // again with the log.
        let rating_ctx = g.unlogged();
        let apply = |ctx: &Ctx, c: &Candidate| match c {
            Candidate::Object(o) => Some(apply_object(&t.refs, &search, o)),
            Candidate::Spatial(s) => ctx.apply_spatial(&t.refs, s, t.depth),
        };
        // Rate every candidate with cost-only temporaries over both sides.
        let ratings: Vec<Option<f64>> = cands
            .par_iter()
            .map(|c| {
                let (l, r) = apply(&rating_ctx, c)?;
                let (tl, tr) = t.children(l, r);
                let (a, b) = rayon::join(|| self.temporary(tl), || self.temporary(tr));
                Some(g.cost.inner_cost(area, a.1, a.0, b.1, b.0))
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
            return t.step(bounds, Decision::Leaf);
        }
        let (left, right) = apply(g, &cands[best]).expect("rated candidates apply");
        t.step(bounds, Decision::Split(left, right))
    }

    fn leaf_refs(&self, t: &SbvhTask, out: &mut Vec<u32>) {
        out.extend(t.refs.iter().map(|r| r.prim));
    }

    fn leaf_cuts(&self, t: &SbvhTask, out: &mut Vec<u32>) {
        leaf_cuts(&self.greedy, t, out)
    }

    fn ref_cuts(&self, heads: &[u32]) -> Option<sahara_bvh::RefCuts> {
        ref_cuts(&self.greedy, heads)
    }

    fn parallel_threshold(&self) -> usize {
        2048
    }
}

impl SpatialRated<'_> {
    /// The candidates of a node (object splits first, each kind best first) and the object
    /// search they refer to.
    fn candidates(
        &self,
        refs: &[Ref],
        bounds: &Aabb,
        area: f64,
        depth: usize,
        budget: usize,
        scratch: &mut ObjectScratch,
    ) -> (ObjectSearch, Vec<Candidate>) {
        let g = &self.greedy;
        let n = refs.len();
        let cfg = &self.cfg;
        let k = cfg.object_candidates;
        let search = g.object_search(refs, area, k * CANDIDATE_POOL, scratch);
        let min_gap = cfg.object_separation as f64 * n as f64;
        let mut objects: Vec<ObjectCand> = Vec::with_capacity(k);
        for c in &search.cands {
            if objects.len() == k {
                break;
            }
            let close = objects
                .iter()
                .any(|o| o.axis() == c.axis() && (o.n_left.abs_diff(c.n_left) as f64) < min_gap);
            if !close {
                objects.push(*c);
            }
        }
        let mut cands: Vec<Candidate> = objects.into_iter().map(Candidate::Object).collect();
        let k = cfg.spatial_candidates;
        if k > 0 && spatial_allowed(g, &search.cands[0], depth, budget) {
            let pool = g.spatial_search(refs, bounds, area, k * CANDIDATE_POOL, budget);
            let mut spatial: Vec<SpatialCand> = Vec::with_capacity(k);
            for c in pool {
                if spatial.len() == k {
                    break;
                }
                let close = spatial.iter().any(|s| {
                    s.axis == c.axis && s.plane.abs_diff(c.plane) < cfg.spatial_separation
                });
                if !close {
                    spatial.push(c);
                }
            }
            cands.extend(spatial.into_iter().map(Candidate::Spatial));
        }
        (search, cands)
    }

    /// The cost `c(T)` and half area of the temporary tree over a task's references.
    fn temporary(&self, t: SbvhTask) -> (f64, f64) {
        let cost = &self.temporary.cost;
        let c = match self.cfg.temporary_search {
            TemporarySearch::Exact => {
                cost_only::cost(&SbvhRule(self.temporary), t, cost, &mut Default::default())
            }
            TemporarySearch::Estimated {
                bins_per_ref,
                min_bins,
                refine,
            } => {
                let rule = Estimated {
                    temporary: self.temporary,
                    bins_per_ref,
                    min_bins,
                    refine,
                };
                cost_only::cost(&rule, t, cost, &mut Default::default())
            }
        };
        (c.cost, c.area)
    }
}

/// The rule of the estimated temporaries: SBVH's rule ([`decide_with`]) with the estimated
/// spatial search over at most `bins_per_ref` spatial bins per reference.
struct Estimated<'a> {
    temporary: Ctx<'a>,
    bins_per_ref: usize,
    min_bins: usize,
    refine: usize,
}

impl Rule for Estimated<'_> {
    type Task = SbvhTask;
    type Scratch = (ObjectScratch, EstimateScratch);

    fn size(&self, t: &SbvhTask) -> usize {
        t.refs.len()
    }

    fn split(&self, t: SbvhTask, scratch: &mut Self::Scratch) -> Step<SbvhTask> {
        let bounds = refs_bounds(&t.refs);
        let area = half_area(&bounds);
        let mut cfg = self.temporary.cfg;
        cfg.spatial_bins = cfg.spatial_bins.min(
            t.refs
                .len()
                .saturating_mul(self.bins_per_ref)
                .max(self.min_bins),
        );
        let tc = &self.temporary.with_config(cfg);
        let (objects, estimate) = scratch;
        let refine = self.refine;
        let d = decide_with(
            tc,
            &t.refs,
            &bounds,
            area,
            t.depth,
            t.budget,
            |refs, area| tc.object_search(refs, area, 1, objects),
            |refs, bounds, area, budget| {
                let clipper = tc.clipper.as_ref()?;
                estimated_spatial_search(
                    clipper,
                    refs,
                    bounds,
                    area,
                    budget,
                    cfg.spatial_bins,
                    refine,
                    &tc.cost,
                    estimate,
                )
            },
        );
        t.step(bounds, d)
    }

    fn leaf_refs(&self, t: &SbvhTask, out: &mut Vec<u32>) {
        out.extend(t.refs.iter().map(|r| r.prim));
    }
}
