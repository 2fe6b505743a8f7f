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

pub use crate::rules::sbvh::{ObjectSplitMethod, SbvhConfig};

use crate::cost_only;
use crate::rules::sbvh::{initial_refs, Ctx, SbvhRule, SbvhTask};
use crate::split::spatial::CutLog;
use crate::topdown;
use crate::{BuildError, BuildInput, Bvh, Configured, Strategy};

/// The `sbvh` builder: the SBVH rule of [`crate::rules::sbvh`] on the top-down driver.
impl Strategy for SbvhConfig {
    const NAME: &'static str = "sbvh";

    fn check(&self) -> Result<(), BuildError> {
        SbvhConfig::check(self)
    }

    fn describe(&self) -> String {
        SbvhConfig::describe(self)
    }

    fn build_tree(&self, input: &BuildInput) -> Result<Bvh, BuildError> {
        let refs = initial_refs(input, None);
        let log = CutLog::default();
        let ctx = Ctx::new(input, *self, &refs).logging(&log);
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
