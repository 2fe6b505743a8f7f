//! SBVH: SAH construction with spatial splits (Stich, Friedrich and Dietrich 2009, "Spatial
//! splits in bounding volume hierarchies").
//!
//! The builder works on *references*: a triangle index with a box that bounds the part of the
//! triangle the reference stands for (at first the triangle's own box). At every node it finds
//!
//! * the best **object split** by Eq. 2 over the reference centroids: a full sweep over the
//!   references sorted per axis (the original algorithm; [`ObjectSplitMethod::Binned`] bins
//!   the centroids instead);
//! * when the two sides of that object split overlap by more than `alpha` times the area of
//!   the root (and, with [`SbvhConfig::overlap_ratio`], by at least that fraction of the two
//!   sides' own areas, as Embree's builder asks), the best **spatial split**: per axis, equal-width bins over the node's box; each
//!   reference is clipped against the planes it straddles (the real triangle is clipped, and
//!   the pieces intersected with the reference's box) and counted as entering its first bin and
//!   leaving its last one; a sweep over the bins gives Eq. 2 with the duplicated references;
//!
//! and applies the cheapest of leaf, object split and spatial split. When a spatial split is
//! applied, every straddling reference is cut exactly at the plane (its pieces' boxes are the
//! bounds of the triangle clipped to each half of its box) unless *reference unsplitting*
//! finds it cheaper to send the whole reference to one side.
//!
//! Duplication is bounded by a budget of extra references (relative to the number of
//! triangles), shared out between the two children of every split in proportion to their
//! reference counts, so the tree does not depend on the order in which parallel subtrees are
//! built. Node bounds are the union of the node's reference boxes, so every node contains its
//! children exactly, and every leaf box touches each triangle it references.
//!
//! ```
//! use sahara_builders::sbvh::{SbvhBuilder, SbvhConfig};
//! use sahara_builders::{BuildInput, Builder};
//! use sahara_geom::{Triangle, Vec3A};
//! use sahara_metrics::CostModel;
//!
//! // Long thin diagonal triangles: object splits cannot separate them, spatial splits can.
//! let tris: Vec<Triangle> = (0..64)
//!     .map(|i| {
//!         let o = Vec3A::new(0.0, i as f32 * 0.1, 0.0);
//!         Triangle::new(o, o + Vec3A::new(50.0, 50.0, 0.0), o + Vec3A::new(50.0, 50.05, 0.1))
//!     })
//!     .collect();
//! let input = BuildInput::new(&tris, CostModel::default()).unwrap();
//! let bvh = SbvhBuilder::new(SbvhConfig::default()).build(&input).unwrap();
//! bvh.validate(&tris).unwrap();
//! assert!(bvh.spatial_splits);
//! assert!(bvh.prim_indices.len() > tris.len()); // some triangles were split
//! ```

mod rule;

pub(crate) use rule::{
    decide, decide_with, initial_refs, spatial_allowed, Ctx, Decision, SbvhRule, SbvhTask,
};

use crate::cost_only;
use crate::topdown;
use crate::{BuildError, BuildInput, Bvh, Configured, Strategy};

/// How SBVH finds object splits.
#[derive(Clone, Copy, Debug, PartialEq, Eq, serde::Serialize, serde::Deserialize)]
pub enum ObjectSplitMethod {
    /// Full sweep: at every node the references are sorted by centroid on each axis and all
    /// `n - 1` positions are rated (Stich et al.'s original). `O(n log n)` per node.
    Sweep,
    /// Equal-width bins over the reference centroids (as in [`crate::binned`]); falls back to
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
}

impl Strategy for SbvhConfig {
    const NAME: &'static str = "sbvh";

    fn check(&self) -> Result<(), BuildError> {
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

    fn describe(&self) -> String {
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

    fn build_tree(&self, input: &BuildInput) -> Result<Bvh, BuildError> {
        let refs = initial_refs(input, None);
        let ctx = Ctx::new(input, *self, &refs);
        let root = SbvhTask {
            refs,
            depth: 0,
            budget: self.budget_for(input.len()),
        };
        Ok(topdown::build(&SbvhRule(ctx), root, true))
    }
}

/// The SBVH builder. Parallel on rayon; the tree does not depend on the number of threads.
pub type SbvhBuilder = Configured<SbvhConfig>;

/// The SAH cost `c(T)` (Eq. 1, relative to the area of the subset's bounds) of the tree that
/// [`SbvhBuilder`] with `config` would build over the triangles `prims`, computed bottom-up
/// without allocating tree nodes (references are still clipped and duplicated while the
/// cost is computed, then dropped). The duplication budget is relative to `prims.len()` and
/// the `alpha` threshold to the area of the subset's bounds. An empty subset costs `0`.
///
/// # Panics
///
/// If a primitive index is out of range or the configuration is invalid.
pub fn sbvh_cost_only(input: &BuildInput, prims: &[u32], config: &SbvhConfig) -> f64 {
    config.check().expect("invalid SBVH configuration");
    if prims.is_empty() {
        return 0.0;
    }
    let refs = initial_refs(input, Some(prims));
    let ctx = Ctx::new(input, *config, &refs);
    let root = SbvhTask {
        refs,
        depth: 0,
        budget: config.budget_for(prims.len()),
    };
    cost_only::cost(&SbvhRule(ctx), root, &input.cost, &mut Default::default()).cost
}
