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
mod common;
mod input;
pub mod popov;
pub mod registry;
pub mod sbvh;
pub mod sweep;
pub mod tree;
pub mod tsah;
pub mod tsah_spatial;

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

/// The README's examples, compiled and run as doctests.
#[cfg(doctest)]
#[doc = include_str!("../README.md")]
struct ReadmeDoctests;
