use bytemuck::{Pod, Zeroable};
use sahara_geom::{Aabb, Vec3A};

/// A 32-byte BVH node: bounds, then an index and a count.
///
/// * Inner node: `count == 0`; the left child is the next node, `index` is the right child.
/// * Leaf: `count >= 1` references starting at `prim_indices[index]`.
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq, Pod, Zeroable)]
pub struct Node {
    /// Lower corner of the bounds.
    pub min: [f32; 3],
    /// Right child (inner node) or first reference (leaf).
    pub index: u32,
    /// Upper corner of the bounds.
    pub max: [f32; 3],
    /// Number of references (0 for inner nodes).
    pub count: u32,
}

const _: () = assert!(std::mem::size_of::<Node>() == 32);

impl Node {
    /// An inner node whose right child is node `right`.
    #[inline]
    pub fn inner(bounds: &Aabb, right: u32) -> Self {
        Self {
            min: bounds.min.to_array(),
            index: right,
            max: bounds.max.to_array(),
            count: 0,
        }
    }

    /// A leaf with `count` references starting at `first`.
    #[inline]
    pub fn leaf(bounds: &Aabb, first: u32, count: u32) -> Self {
        Self {
            min: bounds.min.to_array(),
            index: first,
            max: bounds.max.to_array(),
            count,
        }
    }

    /// True for leaves.
    #[inline]
    pub fn is_leaf(&self) -> bool {
        self.count > 0
    }

    /// The node's bounds.
    #[inline]
    pub fn bounds(&self) -> Aabb {
        Aabb::new(Vec3A::from_array(self.min), Vec3A::from_array(self.max))
    }
}
