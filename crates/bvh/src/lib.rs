//! The binary bounding volume hierarchy shared by every crate of sahara.
//!
//! A [`Bvh`] is an array of 32-byte [`Node`]s in depth-first order plus an array of primitive
//! references (`prim_indices`). An inner node's left child is the node right after it; its
//! right child is at `node.index`. A leaf holds `count >= 1` consecutive references starting at
//! `prim_indices[node.index]`. Builders produce it, metrics read it, traversal kernels collapse
//! it into wider layouts; none of them needs to know who made it.
//!
//! [`Bvh::validate`] checks every structural and geometric invariant with typed errors, and
//! [`Bvh::save`] / [`Bvh::load`] store it in a versioned, checksummed file format.
//!
//! ```
//! use sahara_bvh::{Bvh, Node};
//! use sahara_geom::{Triangle, Vec3A};
//!
//! let tris = [
//!     Triangle::new(Vec3A::ZERO, Vec3A::X, Vec3A::Y),
//!     Triangle::new(Vec3A::Z, Vec3A::Z + Vec3A::X, Vec3A::Z + Vec3A::Y),
//! ];
//! let (a, b) = (tris[0].bounds(), tris[1].bounds());
//! let bvh = Bvh {
//!     nodes: vec![Node::inner(&a.union(&b), 2), Node::leaf(&a, 0, 1), Node::leaf(&b, 1, 1)],
//!     prim_indices: vec![0, 1],
//!     spatial_splits: false,
//!     ref_cuts: None,
//! };
//! bvh.validate(&tris).unwrap();
//! let stats = bvh.stats();
//! assert_eq!((stats.leaves, stats.depth), (2, 2));
//!
//! let mut file = Vec::new();
//! bvh.save(&mut file).unwrap();
//! assert_eq!(Bvh::load(&mut file.as_slice()).unwrap(), bvh);
//! ```
#![warn(missing_docs)]

mod cuts;
mod io;
mod node;
mod refit;
mod stats;
mod validate;

pub use cuts::{replay_cuts, Cut, Keep, RefCuts};
pub use io::{LoadError, FILE_MAGIC, FILE_VERSION};
pub use node::Node;
pub use refit::RefitError;
pub use stats::BvhStats;
pub use validate::ValidationError;

/// A binary BVH over triangles (or any primitives indexed `0..n`).
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Bvh {
    /// Nodes in depth-first order; `nodes[0]` is the root. Empty for an empty scene.
    pub nodes: Vec<Node>,
    /// Primitive references: leaves point at ranges of this array, which holds primitive
    /// indices.
    pub prim_indices: Vec<u32>,
    /// True when a primitive may be referenced by several leaves (spatial splits); leaf
    /// bounds may then cut through a primitive's bounds.
    pub spatial_splits: bool,
    /// Where spatial splits cut each reference (one entry per `prim_indices` slot), recorded
    /// by the spatial-split builders so that [`Bvh::refit_triangles`] clips moved triangles
    /// as the builder did ([`RefCuts`]). `None` for trees without spatial splits, for trees
    /// of other primitives and for trees loaded from version-1 files: a refit then uses the
    /// primitives' whole boxes. Not part of [`Bvh::fingerprint`].
    pub ref_cuts: Option<RefCuts>,
}

impl Bvh {
    /// The empty tree (no nodes): what every builder returns for an empty scene.
    pub fn empty() -> Self {
        Self::default()
    }

    /// True when the tree has no node.
    pub fn is_empty(&self) -> bool {
        self.nodes.is_empty()
    }

    /// Bounds of the root (empty for an empty tree).
    pub fn bounds(&self) -> sahara_geom::Aabb {
        self.nodes
            .first()
            .map_or(sahara_geom::Aabb::EMPTY, |n| n.bounds())
    }

    /// The children `(left, right)` of inner node `i`.
    #[inline]
    pub fn children(&self, i: usize) -> (usize, usize) {
        (i + 1, self.nodes[i].index as usize)
    }

    /// The references of leaf `node`.
    #[inline]
    pub fn leaf_prims(&self, node: &Node) -> &[u32] {
        let first = node.index as usize;
        &self.prim_indices[first..first + node.count as usize]
    }

    /// A 64-bit fingerprint of the whole tree (FNV-1a over the nodes' bytes, the references
    /// and the spatial-split flag): equal trees give equal fingerprints, and any change of a
    /// bound's bit, an index or a reference changes it with overwhelming probability. The
    /// builders' regression test records one per builder and scene, so that a refactoring that
    /// changes a tree by a single bit is caught.
    pub fn fingerprint(&self) -> u64 {
        const PRIME: u64 = 0x0000_0100_0000_01b3;
        let mut h: u64 = 0xcbf2_9ce4_8422_2325;
        let mut eat = |bytes: &[u8]| {
            for &b in bytes {
                h = (h ^ b as u64).wrapping_mul(PRIME);
            }
        };
        eat(&(self.nodes.len() as u64).to_le_bytes());
        eat(bytemuck::cast_slice(&self.nodes));
        eat(&(self.prim_indices.len() as u64).to_le_bytes());
        eat(bytemuck::cast_slice(&self.prim_indices));
        eat(&[self.spatial_splits as u8]);
        h
    }
}

/// The README's examples, compiled and run as doctests.
#[cfg(doctest)]
#[doc = include_str!("../README.md")]
struct ReadmeDoctests;
