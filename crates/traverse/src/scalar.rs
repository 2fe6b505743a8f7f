//! The scalar reference traversal of the binary BVH.

use crate::{Hit, NodeStack, TraversalStats};
use sahara_bvh::Bvh;
use sahara_geom::{
    intersect::{cull_distance, intersect_aabb, intersect_triangle, lower_distance},
    Ray, Triangle,
};

/// Closest hit: depth-first, nearer child first, children culled against the current hit.
/// Invalid rays ([`Ray::is_valid`]) miss.
///
/// Boxes are tested against `[lower_distance(tmin), cull_distance(min(best t, tmax))]`, the
/// interval for which [`sahara_geom::intersect::accept_hit`] guarantees that every box
/// containing a hit triangle passes: the result is the brute-force result ([`crate::brute`]).
pub fn closest_hit<S: TraversalStats>(
    bvh: &Bvh,
    tris: &[Triangle],
    ray: &Ray,
    stats: &mut S,
) -> Hit {
    let mut best = Hit::MISS;
    if bvh.nodes.is_empty() || !ray.is_valid() {
        return best;
    }
    let (o, inv) = (ray.origin, ray.inv_direction());
    let box_tmin = lower_distance(ray.tmin);
    let w = ray.watertight();
    let nodes = &bvh.nodes;
    if intersect_aabb(
        o,
        inv,
        box_tmin,
        cull_distance(ray.tmax),
        &nodes[0].bounds(),
    )
    .is_none()
    {
        return best;
    }
    let mut stack = NodeStack::new();
    let mut cur = 0usize;
    loop {
        let node = &nodes[cur];
        if node.is_leaf() {
            stats.leaf();
            stats.triangles(node.count);
            for &p in bvh.leaf_prims(node) {
                // The ray's own interval, not the current hit: the test's pre-check of the
                // distance (before the division) is not monotonic in `tmax` near ties, so a
                // tighter bound could drop a triangle at exactly the current distance.
                if let Some(h) = intersect_triangle(&w, &tris[p as usize], ray.tmin, ray.tmax) {
                    if best.is_improved_by(h.t, p) {
                        best = Hit {
                            t: h.t,
                            prim: p,
                            u: h.u,
                            v: h.v,
                        };
                    }
                }
            }
        } else {
            stats.inner();
            let (l, r) = (cur + 1, node.index as usize);
            let tmax = cull_distance(best.t.min(ray.tmax));
            let hl = intersect_aabb(o, inv, box_tmin, tmax, &nodes[l].bounds());
            let hr = intersect_aabb(o, inv, box_tmin, tmax, &nodes[r].bounds());
            match (hl, hr) {
                (Some(tl), Some(tr)) => {
                    let (near, far) = if tr < tl { (r, l) } else { (l, r) };
                    stack.push(far as u32);
                    cur = near;
                    continue;
                }
                (Some(_), None) => {
                    cur = l;
                    continue;
                }
                (None, Some(_)) => {
                    cur = r;
                    continue;
                }
                (None, None) => {}
            }
        }
        // Pop the next node that can still hold a nearer hit.
        loop {
            match stack.pop() {
                None => return best,
                Some(n) => {
                    let n = n as usize;
                    let tmax = cull_distance(best.t.min(ray.tmax));
                    if intersect_aabb(o, inv, box_tmin, tmax, &nodes[n].bounds()).is_some() {
                        cur = n;
                        break;
                    }
                }
            }
        }
    }
}

/// Any hit (occlusion): true as soon as one triangle is hit in `[tmin, tmax]`.
pub fn any_hit<S: TraversalStats>(bvh: &Bvh, tris: &[Triangle], ray: &Ray, stats: &mut S) -> bool {
    if bvh.nodes.is_empty() || !ray.is_valid() {
        return false;
    }
    let (o, inv) = (ray.origin, ray.inv_direction());
    let (box_tmin, box_tmax) = (lower_distance(ray.tmin), cull_distance(ray.tmax));
    let w = ray.watertight();
    let mut stack = NodeStack::new();
    stack.push(0);
    while let Some(i) = stack.pop() {
        let node = &bvh.nodes[i as usize];
        if intersect_aabb(o, inv, box_tmin, box_tmax, &node.bounds()).is_none() {
            continue;
        }
        if node.is_leaf() {
            stats.leaf();
            for &p in bvh.leaf_prims(node) {
                stats.triangles(1);
                if intersect_triangle(&w, &tris[p as usize], ray.tmin, ray.tmax).is_some() {
                    return true;
                }
            }
        } else {
            stats.inner();
            stack.push(node.index);
            stack.push(i + 1);
        }
    }
    false
}
