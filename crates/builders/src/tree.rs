//! A pointer-based intermediate tree that builders may produce (serially or in parallel with
//! `rayon::join`) and then flatten into the depth-first [`Bvh`] layout.

use sahara_bvh::{Bvh, Node};
use sahara_geom::Aabb;

/// A node of the intermediate tree.
#[derive(Clone, Debug)]
pub enum TempNode {
    /// A leaf with its primitive references.
    Leaf {
        /// Bounds of the leaf.
        bounds: Aabb,
        /// Primitive indices.
        prims: Vec<u32>,
    },
    /// An inner node.
    Inner {
        /// Bounds of the node.
        bounds: Aabb,
        /// The two children.
        children: Box<[TempNode; 2]>,
    },
}

impl TempNode {
    /// Bounds of the node.
    pub fn bounds(&self) -> &Aabb {
        match self {
            TempNode::Leaf { bounds, .. } | TempNode::Inner { bounds, .. } => bounds,
        }
    }

    /// An inner node over two children; its bounds are their union.
    pub fn inner(left: TempNode, right: TempNode) -> TempNode {
        TempNode::Inner {
            bounds: left.bounds().union(right.bounds()),
            children: Box::new([left, right]),
        }
    }

    /// Flattens the tree into the depth-first [`Bvh`] layout (iteratively, so deep trees do
    /// not overflow the stack). Leaves' references are stored in depth-first order.
    pub fn flatten(self, spatial_splits: bool) -> Bvh {
        let mut bvh = Bvh {
            spatial_splits,
            ..Bvh::default()
        };
        // (node, index of the parent whose right-child field must be patched)
        let mut stack: Vec<(TempNode, Option<usize>)> = vec![(self, None)];
        while let Some((node, patch)) = stack.pop() {
            let idx = bvh.nodes.len();
            if let Some(p) = patch {
                bvh.nodes[p].index = idx as u32;
            }
            match node {
                TempNode::Leaf { bounds, prims } => {
                    bvh.nodes.push(Node::leaf(
                        &bounds,
                        bvh.prim_indices.len() as u32,
                        prims.len() as u32,
                    ));
                    bvh.prim_indices.extend_from_slice(&prims);
                }
                TempNode::Inner { bounds, children } => {
                    bvh.nodes.push(Node::inner(&bounds, 0));
                    let [l, r] = *children;
                    stack.push((r, Some(idx)));
                    stack.push((l, None));
                }
            }
        }
        bvh
    }
}
