//! Brute force: every triangle tested, for checking the kernels.

use crate::{Hit, Precision};
use sahara_geom::intersect::{intersect_triangle, intersect_triangle_fast, TriangleHit};
use sahara_geom::{Ray, Triangle};

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
