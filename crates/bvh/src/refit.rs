//! Refitting: new node bounds for moved primitives, the tree's topology kept.

use crate::{replay_cuts, Bvh, RefCuts, ValidationError};
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
    /// * With spatial splits a leaf's bounds were the clipped part of its primitives; boxes
    ///   alone cannot be clipped again, so this uses the primitives' whole boxes: the tree
    ///   stays correct (every leaf contains its primitives) but becomes looser. Trees over
    ///   triangles keep their clipped boxes with [`Bvh::refit_triangles`].
    ///
    /// The primitives are the same ones as at build time (index `i` is primitive `i`); only
    /// their geometry moved. On error the tree is left unchanged.
    pub fn refit(&mut self, boxes: &[Aabb]) -> Result<(), RefitError> {
        self.check_refs(boxes.len(), |p| boxes[p as usize])?;
        self.refit_leaves(|_, p| boxes[p as usize]);
        Ok(())
    }

    /// [`Bvh::refit`] for a tree over triangles: each reference's box is its triangle's
    /// bounds, or, for a tree with cut records ([`Bvh::ref_cuts`], which the spatial-split
    /// builders fill), the triangle clipped again by the reference's cuts
    /// ([`crate::RefCuts::replay`]):
    ///
    /// * with unmoved triangles every box is the builder's, bit for bit, so refitting is the
    ///   identity for every builder's tree, spatial splits included (an inner node's box also
    ///   takes the boxes its split cut, as the builders bound a node by its references before
    ///   splitting them: [`crate::Cut::depth`]);
    /// * with moved triangles each reference's box holds the part of its triangle inside the
    ///   reference's split region, and those regions cover space, so traversal still finds
    ///   every hit. A reference whose triangle left its region gets [`Aabb::EMPTY`] (no ray
    ///   reaches it; a leaf or a whole subtree may become empty, which [`Bvh::validate`]
    ///   accepts for trees with cut records).
    ///
    /// A spatial-split tree without cut records (loaded from a version-1 file, or built over
    /// other primitives) uses the whole triangle bounds, as [`Bvh::refit`] does.
    ///
    /// ```
    /// use sahara_bvh::Bvh;
    /// use sahara_geom::{Triangle, Vec3A};
    /// # use sahara_bvh::{Cut, Keep, Node, RefCuts};
    /// // Two references to one long triangle, cut at x = 2 (as a spatial split does).
    /// let tri = Triangle::new(Vec3A::ZERO, Vec3A::new(4.0, 0.0, 0.0), Vec3A::new(4.0, 1.0, 0.0));
    /// let mut cuts = RefCuts::new();
    /// cuts.push(&[Cut { pos: 2.0, axis: 0, keep: Keep::Below, depth: 0 }]);
    /// cuts.push(&[Cut { pos: 2.0, axis: 0, keep: Keep::Above, depth: 0 }]);
    /// let (l, r) = (cuts.replay(0, &tri), cuts.replay(1, &tri));
    /// // The root is bounded by the reference before the cut, as the builders do.
    /// let mut bvh = Bvh {
    ///     nodes: vec![Node::inner(&tri.bounds(), 2), Node::leaf(&l, 0, 1), Node::leaf(&r, 1, 1)],
    ///     prim_indices: vec![0, 0],
    ///     spatial_splits: true,
    ///     ref_cuts: Some(cuts),
    /// };
    /// let built = bvh.clone();
    /// bvh.refit_triangles(&[tri]).unwrap();
    /// assert_eq!(bvh, built); // unmoved: the same boxes, bit for bit
    /// let moved = Triangle::new(Vec3A::Y, Vec3A::new(4.0, 1.0, 0.0), Vec3A::new(4.0, 2.0, 0.0));
    /// bvh.refit_triangles(&[moved]).unwrap();
    /// assert!(bvh.nodes[1].bounds().max.x <= 2.0); // still clipped at the plane
    /// bvh.validate(&[moved]).unwrap();
    /// ```
    pub fn refit_triangles(&mut self, triangles: &[Triangle]) -> Result<(), RefitError> {
        // A NaN coordinate can hide in a triangle's bounds (`min`/`max` skip NaN): check the
        // vertices.
        self.validate_structure()?;
        for &p in &self.prim_indices {
            if triangles.get(p as usize).is_some_and(|t| !t.is_finite()) {
                return Err(RefitError::InvalidBox { prim: p });
            }
        }
        self.check_refs(triangles.len(), |p| triangles[p as usize].bounds())?;
        match self.ref_cuts.take() {
            Some(cuts) => {
                self.refit_cut(&cuts, triangles);
                self.ref_cuts = Some(cuts);
            }
            None => self.refit_leaves(|_, p| triangles[p as usize].bounds()),
        }
        Ok(())
    }

    /// The refit of a tree with cut records: the leaves get their references' replayed boxes,
    /// and the node at depth `d` on a reference's path the boxes its cuts at depth `d` were
    /// applied to; then every inner node is the union of its children and of those boxes.
    fn refit_cut(&mut self, cuts: &RefCuts, triangles: &[Triangle]) {
        let n = self.nodes.len();
        let mut extra = vec![Aabb::EMPTY; n];
        let mut path: Vec<usize> = Vec::new();
        let mut stack = vec![(0usize, 0usize)];
        while let Some((i, depth)) = stack.pop() {
            path.truncate(depth);
            path.push(i);
            let node = self.nodes[i];
            if !node.is_leaf() {
                let (l, r) = self.children(i);
                stack.push((r, depth + 1));
                stack.push((l, depth + 1));
                continue;
            }
            let mut b = Aabb::EMPTY;
            let first = node.index as usize;
            for (k, &p) in self.leaf_prims(&node).iter().enumerate() {
                let tri = &triangles[p as usize];
                b.grow_aabb(&replay_cuts(cuts.get(first + k), tri, |c, before| {
                    if let Some(&a) = path
                        .get(c.depth as usize)
                        .filter(|_| c.depth < depth as u32)
                    {
                        extra[a].grow_aabb(before);
                    }
                }));
            }
            self.nodes[i].min = b.min.to_array();
            self.nodes[i].max = b.max.to_array();
        }
        for i in (0..n).rev() {
            if self.nodes[i].is_leaf() {
                continue;
            }
            let (l, r) = self.children(i);
            let b = self.nodes[l]
                .bounds()
                .union(&self.nodes[r].bounds())
                .union(&extra[i]);
            self.nodes[i].min = b.min.to_array();
            self.nodes[i].max = b.max.to_array();
        }
    }

    /// Checks the structure, that every reference is below `len` and that its whole box is
    /// finite and not inverted.
    fn check_refs(&self, len: usize, bounds: impl Fn(u32) -> Aabb) -> Result<(), RefitError> {
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
        Ok(())
    }

    /// The bottom-up pass: `ref_box(slot, prim)` is the box of the reference at `slot` of
    /// `prim_indices`.
    fn refit_leaves(&mut self, ref_box: impl Fn(usize, u32) -> Aabb) {
        // Children come after their parent in depth-first order: a reverse sweep sees every
        // child before its parent.
        for i in (0..self.nodes.len()).rev() {
            let node = self.nodes[i];
            let b = if node.is_leaf() {
                let mut b = Aabb::EMPTY;
                let first = node.index as usize;
                for (k, &p) in self.leaf_prims(&node).iter().enumerate() {
                    b.grow_aabb(&ref_box(first + k, p));
                }
                b
            } else {
                let (l, r) = self.children(i);
                self.nodes[l].bounds().union(&self.nodes[r].bounds())
            };
            self.nodes[i].min = b.min.to_array();
            self.nodes[i].max = b.max.to_array();
        }
    }
}
