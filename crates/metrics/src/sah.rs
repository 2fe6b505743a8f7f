use crate::CostModel;
use sahara_bvh::Bvh;

/// The SAH cost of a tree, `c(root)` of Eq. 1:
/// `(c_t Σ_inner A(n) + c_i Σ_leaf |n| A(n)) / A(root)`. Zero for an empty tree.
///
/// When the root has zero area (all primitives on one point or line), every node is weighted
/// as if it were hit whenever the root is (the limit of the area ratios), so the cost is the
/// number of inner nodes times `c_t` plus the references times `c_i`.
pub fn sah(bvh: &Bvh, cost: &CostModel) -> f64 {
    if bvh.nodes.is_empty() {
        return 0.0;
    }
    sah_of_subtree(bvh, 0, cost)
}

/// Half the surface area of a node's box: `Aabb::half_area` (the value every builder rates
/// splits with, so that cost-only builds match this function to the last bit), recomputed in
/// `f64` when the `f32` product overflows (extents above about 1.8e19), which would otherwise
/// make the SAH of scenes with coordinates near 1e30 NaN.
fn half_area(n: &sahara_bvh::Node) -> f64 {
    let a = n.bounds().half_area();
    if a.is_finite() {
        return a as f64;
    }
    let e: [f64; 3] = std::array::from_fn(|k| (n.max[k] as f64 - n.min[k] as f64).max(0.0));
    e[0] * e[1] + e[1] * e[2] + e[2] * e[0]
}

/// The SAH cost `c(n)` of the subtree rooted at node `root`, relative to that node's area.
pub fn sah_of_subtree(bvh: &Bvh, root: usize, cost: &CostModel) -> f64 {
    let root_area = half_area(&bvh.nodes[root]);
    let mut inner = 0.0f64;
    let mut leaf = 0.0f64;
    let mut stack = vec![root];
    while let Some(i) = stack.pop() {
        let n = &bvh.nodes[i];
        let a = if root_area > 0.0 { half_area(n) } else { 1.0 };
        if n.is_leaf() {
            leaf += a * n.count as f64;
        } else {
            inner += a;
            let (l, r) = bvh.children(i);
            stack.push(r);
            stack.push(l);
        }
    }
    let norm = if root_area > 0.0 { root_area } else { 1.0 };
    (cost.traversal as f64 * inner + cost.intersection as f64 * leaf) / norm
}

#[cfg(test)]
mod tests {
    use super::*;
    use approx::assert_relative_eq;
    use sahara_bvh::Node;
    use sahara_geom::{Aabb, Vec3A};

    #[test]
    fn matches_recursive_definition() {
        let root = Aabb::new(Vec3A::ZERO, Vec3A::new(2.0, 1.0, 1.0));
        let l = Aabb::new(Vec3A::ZERO, Vec3A::new(1.0, 1.0, 1.0));
        let r = Aabb::new(Vec3A::new(1.5, 0.0, 0.0), Vec3A::new(2.0, 1.0, 1.0));
        let bvh = Bvh {
            nodes: vec![
                Node::inner(&root, 2),
                Node::leaf(&l, 0, 2),
                Node::leaf(&r, 2, 3),
            ],
            prim_indices: vec![0, 1, 2, 3, 4],
            spatial_splits: false,
            ref_cuts: None,
        };
        let c = CostModel::default();
        let (ap, al, ar) = (
            root.half_area() as f64,
            l.half_area() as f64,
            r.half_area() as f64,
        );
        let expect = c.inner_cost(ap, al, c.leaf_cost(2), ar, c.leaf_cost(3));
        assert_relative_eq!(sah(&bvh, &c), expect, epsilon = 1e-9);
        assert_eq!(sah(&Bvh::empty(), &c), 0.0);
    }

    #[test]
    fn finite_for_huge_coordinates() {
        let root = Aabb::new(Vec3A::splat(-1e30), Vec3A::splat(1e30));
        let l = Aabb::new(Vec3A::splat(-1e30), Vec3A::ZERO);
        let r = Aabb::new(Vec3A::ZERO, Vec3A::splat(1e30));
        let bvh = Bvh {
            nodes: vec![
                Node::inner(&root, 2),
                Node::leaf(&l, 0, 1),
                Node::leaf(&r, 1, 1),
            ],
            prim_indices: vec![0, 1],
            spatial_splits: false,
            ref_cuts: None,
        };
        let c = sah(&bvh, &CostModel::default());
        assert!(c.is_finite(), "{c}");
        assert_relative_eq!(c, 1.2 + 0.25 + 0.25, max_relative = 1e-6);
    }
}
