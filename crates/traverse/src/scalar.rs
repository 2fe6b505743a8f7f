//! The scalar reference traversal of the binary BVH: one closest-hit walk and one any-hit walk
//! of the binary tree ([`closest_hit`], [`any_hit`] on triangles; the same walks run the user
//! primitives and the filtered queries of [`crate::custom`]).

use crate::custom::{offer, PrimHit};
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
    let w = ray.watertight();
    // The ray's own interval, not the current hit: the test's pre-check of the distance
    // (before the division) is not monotonic in `tmax` near ties, so a tighter bound could
    // drop a triangle at exactly the current distance.
    closest_walk(bvh, ray, stats, |p, _| {
        intersect_triangle(&w, &tris[p as usize], ray.tmin, ray.tmax).map(|h| (h.t, (h.u, h.v)))
    })
    .map_or(Hit::MISS, |h| Hit {
        t: h.t,
        prim: h.prim,
        u: h.data.0,
        v: h.data.1,
    })
}

/// Any hit (occlusion): true as soon as one triangle is hit in `[tmin, tmax]`.
pub fn any_hit<S: TraversalStats>(bvh: &Bvh, tris: &[Triangle], ray: &Ray, stats: &mut S) -> bool {
    let w = ray.watertight();
    any_walk(bvh, ray, stats, |p| {
        intersect_triangle(&w, &tris[p as usize], ray.tmin, ray.tmax).is_some()
    })
}

/// The closest-hit walk of the binary tree, the one every binary-tree closest-hit query runs
/// ([`closest_hit`], the user-primitive and filtered queries of [`crate::custom`], and through
/// them the façade's and the tracer's): depth-first, nearer child first, children culled
/// against the current hit. Leaves are handled by `leaf(prim, best t)`, which returns an
/// accepted `(t, data)`; the best is kept by [`offer`]'s rule (nearer, or as near on a lower
/// index). Invalid rays miss.
pub(crate) fn closest_walk<D, S: TraversalStats>(
    bvh: &Bvh,
    ray: &Ray,
    stats: &mut S,
    mut leaf: impl FnMut(u32, f32) -> Option<(f32, D)>,
) -> Option<PrimHit<D>> {
    let mut best: Option<PrimHit<D>> = None;
    if bvh.nodes.is_empty() || !ray.is_valid() {
        return None;
    }
    let (o, inv) = (ray.origin, ray.inv_direction());
    let box_tmin = lower_distance(ray.tmin);
    let nodes = &bvh.nodes;
    let best_t = |b: &Option<PrimHit<D>>| b.as_ref().map_or(f32::INFINITY, |h| h.t);
    intersect_aabb(
        o,
        inv,
        box_tmin,
        cull_distance(ray.tmax),
        &nodes[0].bounds(),
    )?;
    let mut stack = NodeStack::new();
    let mut cur = 0usize;
    loop {
        let node = &nodes[cur];
        if node.is_leaf() {
            stats.leaf();
            stats.triangles(node.count);
            for &p in bvh.leaf_prims(node) {
                if let Some((t, d)) = leaf(p, best_t(&best)) {
                    offer(&mut best, t, p, d);
                }
            }
        } else {
            stats.inner();
            let (l, r) = (cur + 1, node.index as usize);
            let tmax = cull_distance(best_t(&best).min(ray.tmax));
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
        loop {
            match stack.pop() {
                None => return best,
                Some(n) => {
                    let n = n as usize;
                    let tmax = cull_distance(best_t(&best).min(ray.tmax));
                    if intersect_aabb(o, inv, box_tmin, tmax, &nodes[n].bounds()).is_some() {
                        cur = n;
                        break;
                    }
                }
            }
        }
    }
}

/// The any-hit walk of the binary tree, the one every binary-tree any-hit query runs
/// ([`any_hit`] and [`crate::custom`]'s): true as soon as `leaf(prim)` is. Invalid rays miss.
pub(crate) fn any_walk<S: TraversalStats>(
    bvh: &Bvh,
    ray: &Ray,
    stats: &mut S,
    mut leaf: impl FnMut(u32) -> bool,
) -> bool {
    if bvh.nodes.is_empty() || !ray.is_valid() {
        return false;
    }
    let (o, inv) = (ray.origin, ray.inv_direction());
    let (box_tmin, box_tmax) = (lower_distance(ray.tmin), cull_distance(ray.tmax));
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
                if leaf(p) {
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
