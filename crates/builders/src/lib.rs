//! BVH builders behind one trait.
//!
//! Every strategy is a module with a documented `Config` (with presets) and a type that
//! implements [`Builder`]. The [`registry`] maps names to builders, so the xtask, the benches
//! and the tests enumerate all of them: adding a builder is one module plus one registry line.
//!
//! **Builders never see rays**: their only input is a [`BuildInput`] (triangles and a cost
//! model), their only output a [`Bvh`].
//!
//! ```
//! use sahara_builders::{registry, BuildInput};
//! use sahara_geom::{Triangle, Vec3A};
//! use sahara_metrics::CostModel;
//!
//! let tris: Vec<Triangle> = (0..100)
//!     .map(|i| {
//!         let o = Vec3A::new(i as f32, (i % 7) as f32, 0.0);
//!         Triangle::new(o, o + Vec3A::X, o + Vec3A::Y)
//!     })
//!     .collect();
//! let input = BuildInput::new(&tris, CostModel::default()).unwrap();
//! for entry in registry::entries() {
//!     let bvh = (entry.make)().build(&input).unwrap();
//!     bvh.validate(&tris).unwrap();
//! }
//! ```
#![warn(missing_docs)]

pub mod binned;
pub mod cost_only;
mod input;
pub mod ploc;
pub mod popov;
pub mod registry;
pub mod reinsert;
pub mod rules;
pub mod sbvh;
pub mod simd;
pub mod split;
pub mod sweep;
pub mod topdown;
pub mod tsah;
pub mod tsah_spatial;

use std::borrow::Cow;

pub use input::{BuildError, BuildInput};
pub use sahara_bvh::Bvh;
pub use sahara_metrics::CostModel;

/// A BVH construction strategy.
///
/// Implementations must be deterministic: the same input gives the same tree whatever the
/// number of threads of the rayon pool they run in.
pub trait Builder: Send + Sync {
    /// The registry name (for example `"sweep"` or `"tsah-topk"`).
    fn name(&self) -> &str;
    /// A one-line description of the configuration, for listings and reports.
    fn describe(&self) -> String;
    /// Builds a tree over the input's primitives. An empty input gives [`Bvh::empty`].
    fn build(&self, input: &BuildInput) -> Result<Bvh, BuildError>;
}

/// A builder's configuration, and the strategy it configures: what [`Configured`] needs to
/// be a [`Builder`]. Every builder of this crate is a `Configured<ItsConfig>`.
pub trait Strategy: Clone + std::fmt::Debug + Send + Sync + 'static {
    /// The registry name of a builder made with [`Configured::new`].
    const NAME: &'static str;
    /// Checks the ranges of the fields ([`BuildError::InvalidConfig`] names the field).
    fn check(&self) -> Result<(), BuildError>;
    /// A one-line description, for listings and reports.
    fn describe(&self) -> String;
    /// Builds the tree over a non-empty input, once [`check`](Self::check) has passed.
    fn build_tree(&self, input: &BuildInput) -> Result<Bvh, BuildError>;
}

/// A [`Builder`] made of a configuration and a registry name.
#[derive(Clone, Debug)]
pub struct Configured<C> {
    /// The configuration.
    pub config: C,
    name: Cow<'static, str>,
}

impl<C: Strategy> Configured<C> {
    /// A builder with `config`, named [`Strategy::NAME`].
    pub fn new(config: C) -> Self {
        Self::named(C::NAME, config)
    }

    /// A builder with `config` and a registry name of your choice.
    pub fn named(name: impl Into<Cow<'static, str>>, config: C) -> Self {
        Self {
            config,
            name: name.into(),
        }
    }
}

impl<C: Strategy + Default> Default for Configured<C> {
    fn default() -> Self {
        Self::new(C::default())
    }
}

impl<C: Strategy> Builder for Configured<C> {
    fn name(&self) -> &str {
        &self.name
    }

    fn describe(&self) -> String {
        self.config.describe()
    }

    fn build(&self, input: &BuildInput) -> Result<Bvh, BuildError> {
        self.config.check()?;
        if input.is_empty() {
            return Ok(Bvh::empty());
        }
        // Up to 2N - 1 nodes are addressed by `u32`.
        if input.len() > (u32::MAX / 2) as usize {
            return Err(BuildError::TooManyPrimitives(input.len()));
        }
        self.config.build_tree(input)
    }
}

/// The README's examples, compiled and run as doctests.
#[cfg(doctest)]
#[doc = include_str!("../README.md")]
struct ReadmeDoctests;
