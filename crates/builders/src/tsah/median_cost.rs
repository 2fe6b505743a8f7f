//! A deliberately poor cost-only temporary for the paper's builder: object-median splits on
//! the axis of largest centroid extent, down to leaves of at most `max_leaf` primitives, costed
//! bottom-up by Eq. 1 without allocating a node. It exists to test the paper's claim that only
//! SAH-built temporaries help (the `study` command's "temporary quality" factor).

use sahara_geom::Aabb;
use sahara_metrics::CostModel;

use crate::cost_only::SubtreeCost;

/// The cost of a median-split tree over `boxes` (reordered in place). Deterministic: the
/// same boxes in the same order give the same cost. `boxes` must not be empty.
pub(crate) fn median_cost(boxes: &mut [Aabb], cost: &CostModel, max_leaf: usize) -> SubtreeCost {
    let mut bounds = Aabb::EMPTY;
    let mut cbounds = Aabb::EMPTY;
    for b in boxes.iter() {
        bounds.grow_aabb(b);
        cbounds.grow(b.centroid());
    }
    let area = bounds.half_area() as f64;
    let n = boxes.len();
    if n <= max_leaf.max(1) {
        return SubtreeCost {
            cost: cost.leaf_cost(n),
            area,
        };
    }
    let ext = cbounds.extent();
    let axis = if ext.x >= ext.y && ext.x >= ext.z {
        0
    } else if ext.y >= ext.z {
        1
    } else {
        2
    };
    let mid = n / 2;
    boxes.select_nth_unstable_by(mid, |a, b| {
        a.centroid()[axis].total_cmp(&b.centroid()[axis])
    });
    let (lo, hi) = boxes.split_at_mut(mid);
    let l = median_cost(lo, cost, max_leaf);
    let r = median_cost(hi, cost, max_leaf);
    SubtreeCost {
        cost: cost.inner_cost(area, l.area, l.cost, r.area, r.cost),
        area,
    }
}
