use crate::Bvh;
use sahara_geom::{clip, Aabb, Triangle};

/// What [`Bvh::validate`] found wrong. Node and reference numbers are array indices.
#[derive(Clone, Debug, PartialEq, thiserror::Error)]
pub enum ValidationError {
    /// The cut records ([`Bvh::ref_cuts`]) do not have one entry per reference, or reference
    /// `reference` has an invalid cut (axis above 2, position not finite).
    #[error("the cut records are invalid at reference {reference}")]
    BadCuts {
        /// The first bad reference.
        reference: usize,
    },
    /// The scene has primitives but the tree has no node.
    #[error("the tree is empty but the scene has {0} primitives")]
    MissingRoot(usize),
    /// A node's bounds are NaN or infinite, or empty (with [`Bvh::ref_cuts`], a node may be
    /// exactly [`Aabb::EMPTY`]: a refit found every triangle under it outside its split
    /// regions).
    #[error("node {node} has non-finite or empty bounds")]
    BadBounds {
        /// The node.
        node: usize,
    },
    /// An inner node's child index points outside the node array or backwards (which would
    /// allow cycles: in depth-first order every child comes after its parent).
    #[error("node {node}: child index {child} is out of range or not after its parent")]
    ChildOutOfRange {
        /// The parent.
        node: usize,
        /// The offending child index.
        child: usize,
    },
    /// A node is reached twice, or never, from the root.
    #[error("node {node} is reached {times} times from the root (expected once)")]
    NodeReach {
        /// The node.
        node: usize,
        /// How often it was reached.
        times: usize,
    },
    /// A child's bounds stick out of its parent's.
    #[error("node {child}'s bounds are not inside its parent {parent}'s")]
    ChildNotContained {
        /// The parent.
        parent: usize,
        /// The child.
        child: usize,
    },
    /// A leaf's reference range leaves the reference array.
    #[error("leaf {node}: references {first}..{end} exceed the {len} references")]
    LeafRangeOutOfBounds {
        /// The leaf.
        node: usize,
        /// First reference.
        first: usize,
        /// One past the last reference.
        end: usize,
        /// Length of the reference array.
        len: usize,
    },
    /// A reference slot is used by several leaves, or by none.
    #[error("reference slot {slot} is used by {times} leaves (expected exactly one)")]
    SlotUse {
        /// The slot in `prim_indices`.
        slot: usize,
        /// How many leaves use it.
        times: usize,
    },
    /// A reference names a primitive that does not exist.
    #[error("leaf {node} references primitive {prim}, but there are only {count}")]
    PrimitiveOutOfRange {
        /// The leaf.
        node: usize,
        /// The primitive index.
        prim: usize,
        /// Number of primitives.
        count: usize,
    },
    /// A referenced triangle is not inside (or, with spatial splits, does not touch) its leaf.
    #[error("leaf {node}: triangle {prim} is not inside the leaf's bounds")]
    PrimitiveNotContained {
        /// The leaf.
        node: usize,
        /// The triangle.
        prim: usize,
    },
    /// A triangle is referenced by no leaf.
    #[error("triangle {prim} is not referenced by any leaf")]
    Unreferenced {
        /// The triangle.
        prim: usize,
    },
    /// A triangle is referenced several times in a tree without spatial splits.
    #[error("triangle {prim} is referenced {times} times in a tree without spatial splits")]
    Duplicated {
        /// The triangle.
        prim: usize,
        /// How often.
        times: usize,
    },
}

impl Bvh {
    /// Checks every invariant of the tree against the triangles it was built over:
    ///
    /// * structure: child indices in range and after their parent (so no cycles), every node
    ///   reached exactly once, every reference slot used by exactly one leaf, leaves non-empty
    ///   (inner nodes have two children by construction, so no inner node is empty);
    /// * geometry: finite non-empty bounds, children inside their parent, each referenced
    ///   triangle's bounds inside its leaf (with spatial splits: the triangle touches the leaf;
    ///   with cut records ([`Bvh::ref_cuts`]): the leaf holds the reference's replayed box
    ///   ([`crate::RefCuts::replay`]), which may be empty after a refit, and a node may then be
    ///   exactly [`Aabb::EMPTY`]);
    /// * coverage: every triangle referenced, exactly once unless `spatial_splits` is set.
    ///
    /// Never panics, whatever the arrays hold.
    pub fn validate(&self, triangles: &[Triangle]) -> Result<(), ValidationError> {
        self.validate_structure()?;
        let n_prims = triangles.len();
        if self.nodes.is_empty() {
            return if n_prims == 0 {
                Ok(())
            } else {
                Err(ValidationError::MissingRoot(n_prims))
            };
        }
        let mut uses = vec![0u32; n_prims];
        for (i, node) in self.nodes.iter().enumerate() {
            let b = node.bounds();
            let vacant = self.ref_cuts.is_some() && b == Aabb::EMPTY;
            if !vacant && (!b.is_finite() || b.is_empty()) {
                return Err(ValidationError::BadBounds { node: i });
            }
            if !node.is_leaf() {
                let (l, r) = self.children(i);
                for c in [l, r] {
                    if !b.contains_aabb(&self.nodes[c].bounds()) {
                        return Err(ValidationError::ChildNotContained {
                            parent: i,
                            child: c,
                        });
                    }
                }
                continue;
            }
            for (slot, &p) in self.leaf_prims(node).iter().enumerate() {
                let slot = node.index as usize + slot;
                let p = p as usize;
                let Some(tri) = triangles.get(p) else {
                    return Err(ValidationError::PrimitiveOutOfRange {
                        node: i,
                        prim: p,
                        count: n_prims,
                    });
                };
                uses[p] += 1;
                let inside = if let Some(cuts) = &self.ref_cuts {
                    b.contains_aabb(&cuts.replay(slot, tri))
                } else if self.spatial_splits {
                    touches(tri, &b)
                } else {
                    b.contains_aabb(&tri.bounds())
                };
                if !inside {
                    return Err(ValidationError::PrimitiveNotContained { node: i, prim: p });
                }
            }
        }
        for (p, &u) in uses.iter().enumerate() {
            if u == 0 {
                return Err(ValidationError::Unreferenced { prim: p });
            }
            if u > 1 && !self.spatial_splits {
                return Err(ValidationError::Duplicated {
                    prim: p,
                    times: u as usize,
                });
            }
        }
        Ok(())
    }

    /// Checks only the structure (indices, reachability, reference slots, the shape of the cut
    /// records); needs no
    /// geometry. [`Bvh::load`] runs it so that a loaded tree can be traversed safely.
    pub fn validate_structure(&self) -> Result<(), ValidationError> {
        let n = self.nodes.len();
        if n == 0 {
            if let Some(cuts) = &self.ref_cuts {
                cuts.check(self.prim_indices.len())?;
            }
            return if self.prim_indices.is_empty() {
                Ok(())
            } else {
                Err(ValidationError::SlotUse { slot: 0, times: 0 })
            };
        }
        let mut reached = vec![0u32; n];
        let mut slot_use = vec![0u32; self.prim_indices.len()];
        let mut stack = vec![0usize];
        while let Some(i) = stack.pop() {
            reached[i] += 1;
            if reached[i] > 1 {
                return Err(ValidationError::NodeReach { node: i, times: 2 });
            }
            let node = &self.nodes[i];
            if node.is_leaf() {
                let first = node.index as usize;
                let end = first + node.count as usize;
                if end > self.prim_indices.len() {
                    return Err(ValidationError::LeafRangeOutOfBounds {
                        node: i,
                        first,
                        end,
                        len: self.prim_indices.len(),
                    });
                }
                for s in &mut slot_use[first..end] {
                    *s += 1;
                }
            } else {
                let (l, r) = (i + 1, node.index as usize);
                for c in [l, r] {
                    if c >= n || c <= i {
                        return Err(ValidationError::ChildOutOfRange { node: i, child: c });
                    }
                }
                if r == l {
                    return Err(ValidationError::NodeReach { node: l, times: 2 });
                }
                stack.push(r);
                stack.push(l);
            }
        }
        if let Some(node) = reached.iter().position(|&r| r != 1) {
            return Err(ValidationError::NodeReach {
                node,
                times: reached[node] as usize,
            });
        }
        if let Some(slot) = slot_use.iter().position(|&u| u != 1) {
            return Err(ValidationError::SlotUse {
                slot,
                times: slot_use[slot] as usize,
            });
        }
        if let Some(cuts) = &self.ref_cuts {
            cuts.check(self.prim_indices.len())?;
        }
        Ok(())
    }
}

/// With spatial splits a leaf may hold only part of a triangle: the triangle must meet the
/// leaf's box. The box is widened by a relative epsilon because split planes are rounded.
fn touches(tri: &Triangle, b: &Aabb) -> bool {
    let pad = (b.extent().max_element() * 1e-5).max(f32::MIN_POSITIVE);
    let grown = Aabb::new(b.min - pad, b.max + pad);
    !clip::clip_triangle(tri, &grown).is_empty()
}
