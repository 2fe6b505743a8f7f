//! Brute force: every triangle tested, for checking the kernels (ray queries and
//! closest-point queries).

use crate::point::{Best, PointHit, Query};
use crate::{Hit, Precision};
use sahara_geom::intersect::{
    intersect_triangle, intersect_triangle_fast, is_degenerate, TriangleHit,
};
use sahara_geom::{Aabb, Ray, Triangle, Vec3A};

/// The closest hit among all triangles (lowest index on exact ties), with the exact test.
pub fn closest_hit(tris: &[Triangle], ray: &Ray) -> Hit {
    closest_hit_at(tris, ray, Precision::Exact)
}

/// True when any triangle is hit in `[tmin, tmax]`, with the exact test.
pub fn any_hit(tris: &[Triangle], ray: &Ray) -> bool {
    any_hit_at(tris, ray, Precision::Exact)
}

/// The closest hit among all triangles with the triangle test of `precision` (lowest index on
/// exact ties): the twin every wide kernel of that precision is checked against.
pub fn closest_hit_at(tris: &[Triangle], ray: &Ray, precision: Precision) -> Hit {
    let mut best = Hit::MISS;
    if !ray.is_valid() {
        return best;
    }
    let test = tester(ray, precision);
    for (i, t) in tris.iter().enumerate() {
        if let Some(h) = test(t) {
            if best.is_improved_by(h.t, i as u32) {
                best = Hit {
                    t: h.t,
                    prim: i as u32,
                    u: h.u,
                    v: h.v,
                };
            }
        }
    }
    best
}

/// True when any triangle is hit in `[tmin, tmax]` with the triangle test of `precision`.
pub fn any_hit_at(tris: &[Triangle], ray: &Ray, precision: Precision) -> bool {
    if !ray.is_valid() {
        return false;
    }
    let test = tester(ray, precision);
    tris.iter().any(|t| test(t).is_some())
}

/// Brute force with an any-hit filter, the twin of the filtered queries: every triangle in
/// order with the exact test, `keep` asked for each candidate that would change the answer
/// (nearer than the best kept hit, so lowest index on exact ties); with `first`, the first
/// kept candidate is returned (an any-hit query).
pub fn closest_hit_filtered(
    tris: &[Triangle],
    ray: &Ray,
    keep: &mut dyn FnMut(&Hit) -> bool,
    first: bool,
) -> Hit {
    let mut best = Hit::MISS;
    if !ray.is_valid() {
        return best;
    }
    let test = tester(ray, Precision::Exact);
    for (p, tri) in tris.iter().enumerate() {
        let Some(h) = test(tri) else {
            continue;
        };
        let h = Hit {
            t: h.t,
            prim: p as u32,
            u: h.u,
            v: h.v,
        };
        if h.t < best.t && keep(&h) {
            best = h;
            if first {
                break;
            }
        }
    }
    best
}

/// The triangle test of `precision` for one ray over its interval.
fn tester(ray: &Ray, precision: Precision) -> impl Fn(&Triangle) -> Option<TriangleHit> + '_ {
    let w = ray.watertight();
    move |t: &Triangle| match precision {
        Precision::Exact => intersect_triangle(&w, t, ray.tmin, ray.tmax),
        Precision::Fast => intersect_triangle_fast(
            ray.origin,
            ray.direction(),
            ray.inv_direction(),
            t,
            ray.tmin,
            ray.tmax,
        ),
    }
}

/// The closest point on all triangles to `p` within `max_distance` (ties: lowest index;
/// degenerate triangles skipped; `None` for a non-finite `p` or a negative or NaN
/// `max_distance`): the twin every closest-point query over triangles is checked against
/// (see [`crate::point`]).
pub fn closest_point(tris: &[Triangle], p: Vec3A, max_distance: f32) -> Option<PointHit> {
    let q = Query::new(p, max_distance, &Aabb::EMPTY)?;
    let mut best = Best::new(&q);
    for (i, t) in tris.iter().enumerate() {
        if !is_degenerate(t) {
            best.offer_triangle(&q, t, i as u32);
        }
    }
    best.hit
}

/// The closest point on all user primitives (boxes `boxes`, callback `closest(prim, p) ->
/// Option<(point, distance_squared)>`) to `p` within `max_distance`: the twin of the
/// closest-point queries over user primitives (see [`crate::point`]).
pub fn closest_point_custom<F>(
    boxes: &[Aabb],
    p: Vec3A,
    max_distance: f32,
    mut closest: F,
) -> Option<PointHit>
where
    F: FnMut(u32, Vec3A) -> Option<(Vec3A, f64)>,
{
    let q = Query::new(p, max_distance, &Aabb::EMPTY)?;
    let mut best = Best::new(&q);
    for (i, b) in boxes.iter().enumerate() {
        best.offer_custom(&q, b, i as u32, &mut closest);
    }
    best.hit
}
