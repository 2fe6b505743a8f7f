//! Full-sweep SAH construction (MacDonald & Booth 1990, "Heuristics for ray tracing using
//! space subdivision").
//!
//! The primitive indices are sorted by centroid once per axis. At every node a right-to-left
//! sweep over each of the three orders stores the suffix areas, and a left-to-right sweep
//! evaluates the greedy cost of Eq. 2 of Wodniok & Goesele (both children assumed to stay
//! leaves) at each of the `n - 1` positions. The cheapest of the `3 (n - 1)` candidates wins;
//! exact cost ties go to the more balanced split (smaller `i² + (n - i)²`), then to the lower
//! axis, then to the lower position, so the result never depends on evaluation order. The two
//! orders that were not split are kept sorted by a stable partition with a flag array, so the
//! whole build is `O(N log N)` for balanced trees.
//!
//! A node becomes a leaf when it holds at most [`SweepConfig::max_leaf_size`] primitives and no
//! split is cheaper than the leaf cost `n c_i`; a larger node is always split, by the cheapest
//! candidate (where all centroids coincide the sorted order still splits by position, and the
//! balance tie-break makes that a median split).
//!
//! The rule is [`Greedy`] ([`crate::rules::greedy`], shared with the paper's builders, which
//! use it at small nodes and, costed without storing a node, as their temporary subtrees);
//! the candidates come from [`crate::split::sweep`].
//!
//! ```
//! use sahara_builders::sweep::{SweepBuilder, SweepConfig};
//! use sahara_builders::{BuildInput, Builder};
//! use sahara_geom::{Triangle, Vec3A};
//! use sahara_metrics::CostModel;
//!
//! let tris: Vec<Triangle> = (0..300)
//!     .map(|i| {
//!         let o = Vec3A::new((i % 17) as f32, (i / 17) as f32, (i % 3) as f32);
//!         Triangle::new(o, o + Vec3A::X * 0.7, o + Vec3A::Y * 0.4)
//!     })
//!     .collect();
//! let input = BuildInput::new(&tris, CostModel::default()).unwrap();
//! let bvh = SweepBuilder::new(SweepConfig::SMALL_LEAVES).build(&input).unwrap();
//! bvh.validate(&tris).unwrap();
//! assert!(bvh.stats().max_leaf <= 4);
//! ```

use crate::rules::greedy::{Greedy, JobStorage, PARALLEL_THRESHOLD};
use crate::split::orders::Marks;
use crate::topdown;
use crate::{BuildError, BuildInput, Bvh, Configured, Strategy};

/// Configuration of the full-sweep SAH builder.
#[derive(Clone, Copy, Debug, PartialEq, Eq, serde::Serialize, serde::Deserialize)]
pub struct SweepConfig {
    /// Largest leaf (at least 1): a node with more primitives is always split. Smaller nodes
    /// become leaves when no split is cheaper than the leaf (Eq. 2 against `n c_i`).
    /// Default 8.
    pub max_leaf_size: usize,
    /// Subtrees with more primitives than this are handed to other rayon workers; smaller
    /// ones are built serially. It changes only the speed, never the tree. Default 4096.
    pub parallel_threshold: usize,
}

impl Default for SweepConfig {
    fn default() -> Self {
        Self::DEFAULT
    }
}

impl SweepConfig {
    /// Leaves of at most 8 primitives: the reference builder the paper compares against.
    pub const DEFAULT: SweepConfig = SweepConfig {
        max_leaf_size: 8,
        parallel_threshold: PARALLEL_THRESHOLD,
    };
    /// Leaves of at most 4 primitives, matching the leaf width of the SIMD traversal kernels.
    pub const SMALL_LEAVES: SweepConfig = SweepConfig {
        max_leaf_size: 4,
        ..Self::DEFAULT
    };

    /// This configuration with another maximum leaf size.
    #[must_use]
    pub const fn with_max_leaf_size(mut self, max_leaf_size: usize) -> Self {
        self.max_leaf_size = max_leaf_size;
        self
    }
}

impl Strategy for SweepConfig {
    const NAME: &'static str = "sweep";

    fn check(&self) -> Result<(), BuildError> {
        if self.max_leaf_size == 0 {
            return Err(BuildError::InvalidConfig(
                "sweep: max_leaf_size must be at least 1".into(),
            ));
        }
        Ok(())
    }

    fn describe(&self) -> String {
        format!(
            "full-sweep SAH (MacDonald & Booth), max leaf {}",
            self.max_leaf_size
        )
    }

    fn build_tree(&self, input: &BuildInput) -> Result<Bvh, BuildError> {
        let marks = Marks::new(input.len());
        let rule = Greedy {
            bounds: input.bounds(),
            cost: input.cost,
            max_leaf: self.max_leaf_size.max(1),
            marks: &marks,
            parallel_threshold: self.parallel_threshold,
            memo: None,
        };
        let mut storage = JobStorage::new(input.len(), input.centroids());
        Ok(topdown::build(&rule, storage.root(), false))
    }
}

/// The full-sweep SAH builder, registered as `"sweep"`.
pub type SweepBuilder = Configured<SweepConfig>;
