//! Refitting: new node bounds for moved primitives, the tree's topology kept.

use crate::{Bvh, ValidationError};
use sahara_geom::{Aabb, Triangle};

/// Why [`Bvh::refit`] refused to refit a tree.
#[derive(Clone, Debug, PartialEq, thiserror::Error)]
pub enum RefitError {
    /// The tree's structure is broken (see [`Bvh::validate_structure`]).
    #[error("the tree's structure is invalid: {0}")]
    Structure(#[from] ValidationError),
    /// A leaf references primitive `prim`, but only `len` primitives were given.
    #[error("a leaf references primitive {prim}, but only {len} primitives were given")]
    MissingPrimitive {
        /// The referenced primitive.
        prim: u32,
        /// How many primitives were given.
        len: usize,
    },
    /// Primitive `prim`'s new box (or triangle) is NaN, infinite or inverted.
    #[error("primitive {prim} has a non-finite or inverted box")]
    InvalidBox {
        /// The primitive.
        prim: u32,
    },
}

impl Bvh {
    /// Recomputes every node's bounds from the primitives' new boxes, bottom-up, keeping the
    /// topology (nodes, child indices, references) unchanged: a leaf's bounds become the union
    /// of its primitives' boxes, an inner node's the union of its children's.
    ///
    /// * For a tree whose node bounds are exactly these unions (every builder's tree without
    ///   spatial splits, over the same boxes), refitting with unchanged boxes is the identity,
    ///   bit for bit: the union of boxes is exact in floating point and does not depend on
    ///   the order.
    /// * With spatial splits (`spatial_splits`), a leaf's bounds were the clipped part of its
    ///   primitives; refit uses the primitives' whole boxes instead, so the tree stays correct
    ///   (every leaf contains its primitives) but becomes looser, and refitting is not the
    ///   identity. Rebuild such trees when their quality matters.
    ///
    /// The primitives are the same ones as at build time (index `i` is primitive `i`); only
    /// their geometry moved. On error the tree is left unchanged.
    pub fn refit(&mut self, boxes: &[Aabb]) -> Result<(), RefitError> {
        self.refit_with(boxes.len(), |p| boxes[p as usize])
    }

    /// [`Bvh::refit`] for a tree over triangles: each primitive's box is its triangle's
    /// bounds.
    pub fn refit_triangles(&mut self, triangles: &[Triangle]) -> Result<(), RefitError> {
        // A NaN coordinate can hide in a triangle's bounds (`min`/`max` skip NaN): check the
        // vertices.
        self.validate_structure()?;
        for &p in &self.prim_indices {
            if triangles.get(p as usize).is_some_and(|t| !t.is_finite()) {
                return Err(RefitError::InvalidBox { prim: p });
            }
        }
        self.refit_with(triangles.len(), |p| triangles[p as usize].bounds())
    }

    fn refit_with(&mut self, len: usize, bounds: impl Fn(u32) -> Aabb) -> Result<(), RefitError> {
        self.validate_structure()?;
        for &p in &self.prim_indices {
            if p as usize >= len {
                return Err(RefitError::MissingPrimitive { prim: p, len });
            }
            let b = bounds(p);
            if !(b.min.is_finite() && b.max.is_finite()) || b.min.cmpgt(b.max).any() {
                return Err(RefitError::InvalidBox { prim: p });
            }
        }
        // Children come after their parent in depth-first order: a reverse sweep sees every
        // child before its parent.
        for i in (0..self.nodes.len()).rev() {
            let node = self.nodes[i];
            let b = if node.is_leaf() {
                let mut b = Aabb::EMPTY;
                for &p in self.leaf_prims(&node) {
                    b.grow_aabb(&bounds(p));
                }
                b
            } else {
                let (l, r) = self.children(i);
                self.nodes[l].bounds().union(&self.nodes[r].bounds())
            };
            self.nodes[i].min = b.min.to_array();
            self.nodes[i].max = b.max.to_array();
        }
        Ok(())
    }
}
