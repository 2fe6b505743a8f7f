//! Binned SAH construction (Wald 2007, "On fast construction of SAH-based bounding volume
//! hierarchies").
//!
//! At every node the centroids of the node's triangles are bounded, and `K` equal-width bins
//! are laid over those *centroid* bounds on each of the three axes (binning over the node's own
//! box would put whole clusters of small triangles into one bin). Each bin records how many
//! triangles it holds and the union of their boxes; a right-to-left sweep over the bins stores
//! the suffix areas and counts, a left-to-right sweep evaluates the greedy cost of Eq. 2 at
//! each of the `K - 1` planes. A node becomes a leaf when it has at most
//! [`BinnedConfig::max_leaf_size`] triangles and no plane is cheaper than the leaf; a larger
//! node is always split, by the best plane or, where no plane separates anything (all
//! centroids coincide), by an object median split.
//!
//! The plane search and the partitions are [`crate::split::binned`]'s ([`plane`] and
//! [`partition`]); the builder is the rule that puts them together on the top-down driver.
//!
//! [`plane`]: crate::split::binned::plane
//! [`partition`]: crate::split::binned::partition
//!
//! ```
//! use sahara_builders::binned::{BinnedBuilder, BinnedConfig};
//! use sahara_builders::{BuildInput, Builder};
//! use sahara_geom::{Triangle, Vec3A};
//! use sahara_metrics::CostModel;
//!
//! let tris: Vec<Triangle> = (0..200)
//!     .map(|i| {
//!         let o = Vec3A::new((i % 13) as f32, (i / 13) as f32, (i % 5) as f32);
//!         Triangle::new(o, o + Vec3A::X * 0.5, o + Vec3A::Y * 0.5)
//!     })
//!     .collect();
//! let input = BuildInput::new(&tris, CostModel::default()).unwrap();
//! let bvh = BinnedBuilder::new(BinnedConfig::default()).build(&input).unwrap();
//! bvh.validate(&tris).unwrap();
//! ```

use crate::rules::binned::{BinTask, BinnedRule};
use crate::split::binned::refs::ref_bounds;
pub use crate::split::binned::{FillBackend, PrimRef};
use crate::topdown;
use crate::{BuildError, BuildInput, Bvh, Configured, Strategy};

/// Configuration of the binned SAH builder.
#[derive(Clone, Copy, Debug, PartialEq, Eq, serde::Serialize, serde::Deserialize)]
pub struct BinnedConfig {
    /// Number of equal-width bins per axis, `K` (at least 2). Default 32.
    pub bins: usize,
    /// Largest leaf (at least 1): nodes with more triangles are always split. Default 8.
    pub max_leaf_size: usize,
    /// Nodes at this depth or deeper are split at the object median only (when they must be
    /// split at all). This bounds the depth of trees over adversarial inputs, where the best
    /// plane may peel off a few triangles per level, to `fallback_depth + log2(n)`; it never
    /// triggers on ordinary scenes. Default 96.
    pub fallback_depth: usize,
}

impl Default for BinnedConfig {
    fn default() -> Self {
        Self::DEFAULT
    }
}

impl BinnedConfig {
    /// 32 bins, leaves of at most 8 triangles: the usual quality/speed trade-off.
    pub const DEFAULT: BinnedConfig = BinnedConfig {
        bins: 32,
        max_leaf_size: 8,
        fallback_depth: 96,
    };
    /// 8 bins: the fastest preset, a little worse SAH.
    pub const FAST: BinnedConfig = BinnedConfig {
        bins: 8,
        ..Self::DEFAULT
    };
    /// 128 bins: close to a full sweep in quality.
    pub const FINE: BinnedConfig = BinnedConfig {
        bins: 128,
        ..Self::DEFAULT
    };

    /// The default configuration with `bins` bins per axis.
    pub const fn with_bins(bins: usize) -> BinnedConfig {
        BinnedConfig {
            bins,
            ..Self::DEFAULT
        }
    }
}

impl Strategy for BinnedConfig {
    const NAME: &'static str = "binned";

    fn check(&self) -> Result<(), BuildError> {
        if self.bins < 2 {
            return Err(BuildError::InvalidConfig(format!(
                "binned: bins must be at least 2 (got {})",
                self.bins
            )));
        }
        if self.max_leaf_size < 1 {
            return Err(BuildError::InvalidConfig(
                "binned: max_leaf_size must be at least 1".into(),
            ));
        }
        Ok(())
    }

    fn describe(&self) -> String {
        format!(
            "binned SAH (Wald 2007): {} centroid bins per axis, leaves <= {}",
            self.bins, self.max_leaf_size
        )
    }

    fn build_tree(&self, input: &BuildInput) -> Result<Bvh, BuildError> {
        Ok(build_tree(input, self, FillBackend::Simd))
    }
}

/// The tree of [`BinnedBuilder`] with `config`, its bins filled by `backend`. Both backends
/// give the bit-identical tree on every CPU (the crate's tests compare them); this entry point
/// exists so that they can be compared.
///
/// # Errors
///
/// As [`Builder::build`](crate::Builder::build): an invalid configuration or too many
/// primitives.
pub fn build_with_backend(
    input: &BuildInput,
    config: &BinnedConfig,
    backend: FillBackend,
) -> Result<Bvh, BuildError> {
    config.check()?;
    if input.is_empty() {
        return Ok(Bvh::empty());
    }
    if input.len() > (u32::MAX / 2) as usize {
        return Err(BuildError::TooManyPrimitives(input.len()));
    }
    Ok(build_tree(input, config, backend))
}

fn build_tree(input: &BuildInput, config: &BinnedConfig, backend: FillBackend) -> Bvh {
    let rule = BinnedRule::new(
        input,
        config.bins,
        config.max_leaf_size,
        config.fallback_depth,
        backend,
    );
    let mut refs = rule.refs_of((0..input.len() as u32).collect::<Vec<_>>().as_slice());
    let nb = ref_bounds(&refs);
    let root = BinTask {
        refs: &mut refs,
        nb,
        depth: 0,
    };
    topdown::build(&rule, root, false)
}

/// The binned SAH builder (Wald 2007). Parallel on rayon; the tree does not depend on the
/// number of threads.
pub type BinnedBuilder = Configured<BinnedConfig>;
