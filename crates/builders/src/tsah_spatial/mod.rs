//! The temporary-subtree SAH builder with spatial splits (Wodniok & Goesele 2017, the variant
//! "with spatial splits"; see docs/builders-classic.md, "Temporary-subtree SAH with spatial
//! splits").
//!
//! At every node with at least [`TsahSpatialConfig::min_size`] references the builder collects
//! candidate splits with the SBVH machinery of [`crate::rules::sbvh`]:
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

mod rule;

use crate::rules::sbvh::{initial_refs, Ctx as SbvhCtx, SbvhConfig, SbvhTask};
use crate::split::spatial::CutLog;
use crate::topdown;
use crate::{BuildError, BuildInput, Bvh, Configured, Strategy};
use rule::SpatialRated;

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
}

impl Strategy for TsahSpatialConfig {
    const NAME: &'static str = "tsah-sbvh";

    fn check(&self) -> Result<(), BuildError> {
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

    fn describe(&self) -> String {
        let c = self;
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
            c.temporary.describe(),
            c.sbvh.describe(),
        )
    }

    fn build_tree(&self, input: &BuildInput) -> Result<Bvh, BuildError> {
        let refs = initial_refs(input, None);
        let log = CutLog::default();
        let greedy = SbvhCtx::new(input, self.sbvh, &refs);
        let rule = SpatialRated {
            greedy: greedy.logging(&log),
            temporary: greedy.with_config(self.temporary),
            cfg: *self,
        };
        let root = SbvhTask {
            refs,
            depth: 0,
            budget: self.sbvh.budget_for(input.len()),
        };
        Ok(topdown::build(&rule, root, true))
    }
}

/// The temporary-subtree SAH builder with spatial splits. Parallel on rayon (nodes, candidates
/// and temporary builds); the tree does not depend on the number of threads.
pub type TsahSpatialBuilder = Configured<TsahSpatialConfig>;
