//! BVH builders behind one trait.
//!
//! Three names, three roles:
//!
//! * [`Builder`] is what callers use: an object (the [`registry`] hands out
//!   `Box<dyn Builder>`) with a name, a description and [`Builder::build`];
//! * [`Strategy`] is what a builder's configuration implements to become one: its default
//!   registry name, the checks of its fields, its description and
//!   [`build_tree`](Strategy::build_tree), the build proper over a non-empty input;
//! * [`Configured<C>`](Configured) is the one adapter from the second to the first: a
//!   configuration and a registry name; it checks the configuration and handles empty and
//!   oversized inputs before calling `build_tree`. Every builder of this crate is a
//!   `Configured<ItsConfig>` (for example [`sweep::SweepBuilder`] is
//!   `Configured<SweepConfig>`).
//!
//! The modules are layered, each importing only the ones before it: [`split`] (the split
//! search: candidate splits and partitions), [`topdown`] (the one driver: a [`topdown::Rule`]
//! decides leaf or split for one node, the driver builds the tree), [`cost_only`] (the same
//! rules costed without storing a node: temporary subtrees), [`rules`] (the rules several
//! builders share), the builders, one module each, which never import one another
//! ([`binned`], [`cluster_binned`], [`sweep`], [`sbvh`], [`spatial_binned`], [`tsah`], [`tsah_spatial`], [`popov`], [`ploc`],
//! [`reinsert`]), and the [`registry`], the table of presets that the xtask, the benches and
//! the tests enumerate. `docs/ARCHITECTURE.md` says what adding a builder takes.
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
pub mod cluster_binned;
pub mod cost_only;
mod input;
pub mod ploc;
pub mod popov;
pub mod registry;
pub mod reinsert;
pub mod rules;
pub mod sbvh;
pub mod simd;
pub mod spatial_binned;
pub mod split;
pub mod sweep;
pub mod topdown;
pub mod tsah;
pub mod tsah_spatial;

use std::borrow::Cow;

pub use input::{BuildError, BuildInput};
pub use sahara_bvh::Bvh;
pub use sahara_metrics::CostModel;

/// A BVH builder, as callers use it (see the [crate documentation](crate) for how it relates
/// to [`Strategy`] and [`Configured`]).
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

/// What a builder's configuration implements: what [`Configured`] needs to be a [`Builder`].
/// Every builder of this crate is a `Configured<ItsConfig>`.
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

/// A [`Builder`] made of a configuration (a [`Strategy`]) and a registry name: the one way a
/// configuration becomes a builder.
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
