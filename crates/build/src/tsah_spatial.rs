//! The temporary-subtree SAH builder with spatial splits (Wodniok & Goesele 2017, the variant
//! "with spatial splits"; see `ALGORITHMS.md` §3 item 4 and `docs/builders-classic.md`).
//!
//! At every node with at least [`TsahSpatialConfig::min_size`] references the builder collects
//! candidate splits with the SBVH machinery of [`crate::sbvh`]:
//!
//! * the [`TsahSpatialConfig::object_candidates`] best object splits by Eq. 2 (over all axes);
//! * where the SBVH rule would search spatial splits at this node (overlap above `alpha`,
//!   depth and duplication budget left), the [`TsahSpatialConfig::spatial_candidates`] best
//!   spatial splits by Eq. 2 with duplicated references that fit the budget;
//!
//! applies each candidate (clipping, unsplitting) to get the two sides `L` and `R`, and rates
//! it by the real recursive SAH cost of temporary SBVH trees built over each side:
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
//! Because the candidates always include the greedy SBVH choice (the best object split and
//! the best spatial split), the temporaries are built by exactly the SBVH builder with the
//! same limits, and leaves are made whenever cheaper, the tree's SAH is never above the SBVH
//! tree's with the same configuration (by induction over the nodes, up to rounding) when
//! [`TsahSpatialConfig::temporary`] equals [`TsahSpatialConfig::sbvh`].
//!
//! ```
//! use sahara_build::sbvh::{SbvhBuilder, SbvhConfig};
//! use sahara_build::tsah_spatial::{TsahSpatialBuilder, TsahSpatialConfig};
//! use sahara_build::{BuildInput, Builder};
//! use sahara_geom::{rng::Pcg32, Triangle, Vec3A};
//! use sahara_metrics::{sah, CostModel};
//!
//! let mut rng = Pcg32::new(1, 2);
//! let mut p = || Vec3A::new(rng.range_f32(0.0, 10.0), rng.range_f32(0.0, 10.0), rng.range_f32(0.0, 10.0));
//! let tris: Vec<Triangle> = (0..500).map(|_| Triangle::new(p(), p(), p())).collect();
//! let input = BuildInput::new(&tris, CostModel::default()).unwrap();
//! let config = TsahSpatialConfig { min_size: 64, ..TsahSpatialConfig::default() };
//! let bvh = TsahSpatialBuilder::new(config).build(&input).unwrap();
//! bvh.validate(&tris).unwrap();
//! let sbvh = SbvhBuilder::new(SbvhConfig::default()).build(&input).unwrap();
//! assert!(sah(&bvh, &input.cost) <= sah(&sbvh, &input.cost) * (1.0 + 1e-9));
//! ```

use crate::common::{half_area, Fragment};
use crate::registry::Entry;
use crate::sbvh::{
    self, apply_object, apply_spatial, child_budgets, emit_leaf, initial_refs, object_search,
    recurse_children, refs_bounds, spatial_allowed, spatial_search, ObjectCand, Ref, SbvhConfig,
    SpatialCand,
};
use crate::{BuildError, BuildInput, Builder, Bvh};
use rayon::prelude::*;

/// Configuration of the spatial temporary-subtree builder.
#[derive(Clone, Copy, Debug, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct TsahSpatialConfig {
    /// The SBVH rule: how candidates are searched (object split method, spatial bins,
    /// `alpha`, depth limit, duplication budget, leaf size) and how nodes below
    /// [`min_size`](Self::min_size) are split. Default [`SbvhConfig::DEFAULT`].
    pub sbvh: SbvhConfig,
    /// The configuration of the temporary SBVH builds that rate candidates. Default
    /// [`SbvhConfig::DEFAULT`] (the same as `sbvh`, which guarantees SAH no worse than SBVH).
    pub temporary: SbvhConfig,
    /// Object split candidates rated per node (the best by Eq. 2 over all axes; at least 1).
    /// Default 4.
    pub object_candidates: usize,
    /// Spatial split candidates rated per node where spatial splits are searched. Default 4.
    pub spatial_candidates: usize,
    /// Nodes with fewer references use the plain SBVH rule. Default 256.
    pub min_size: usize,
}

impl Default for TsahSpatialConfig {
    fn default() -> Self {
        Self::DEFAULT
    }
}

impl TsahSpatialConfig {
    /// 4 object + 4 spatial candidates, SBVH temporaries, the SBVH rule below 256 references.
    pub const DEFAULT: TsahSpatialConfig = TsahSpatialConfig {
        sbvh: SbvhConfig::DEFAULT,
        temporary: SbvhConfig::DEFAULT,
        object_candidates: 4,
        spatial_candidates: 4,
        min_size: 256,
    };
    /// Faster: 2 + 2 candidates, temporaries with [`SbvhConfig::FAST`], rating only nodes of
    /// 1024 references or more.
    pub const FAST: TsahSpatialConfig = TsahSpatialConfig {
        temporary: SbvhConfig::FAST,
        object_candidates: 2,
        spatial_candidates: 2,
        min_size: 1024,
        ..Self::DEFAULT
    };

    /// Checks the ranges of the fields.
    pub fn check(&self) -> Result<(), BuildError> {
        self.sbvh.check()?;
        self.temporary.check()?;
        if self.object_candidates < 1 {
            return Err(BuildError::InvalidConfig(
                "tsah-sbvh: object_candidates must be at least 1".into(),
            ));
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
        format!(
            "temporary-subtree SAH with spatial splits: {} object + {} spatial candidates per \
             node of >= {} refs, rated with cost-only temporaries [{}]; rule [{}]",
            c.object_candidates,
            c.spatial_candidates,
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
                  rated by cost-only SBVH temporaries",
        spatial: true,
        small_inputs_only: false,
        max_practical_triangles: Some(150_000),
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
    let search = object_search(g, &refs, area, ctx.cfg.object_candidates);
    let mut cands: Vec<Candidate> = search.cands.iter().map(|&c| Candidate::Object(c)).collect();
    if ctx.cfg.spatial_candidates > 0 && spatial_allowed(g, &search.cands[0], depth, budget) {
        let k = ctx.cfg.spatial_candidates;
        let spatial = spatial_search(g, &refs, &bounds, area, k, budget);
        cands.extend(spatial.into_iter().map(Candidate::Spatial));
    }
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
            let t = &ctx.temporary;
            let ((c_l, a_l), (c_r, a_r)) = rayon::join(
                || sbvh::build_rec(t, l, depth + 1, bl, None),
                || sbvh::build_rec(t, r, depth + 1, br, None),
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
