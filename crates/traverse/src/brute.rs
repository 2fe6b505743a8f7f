//! Brute force: every triangle tested, for checking the kernels.

use crate::Hit;
use sahara_geom::{intersect::intersect_triangle, Ray, Triangle};

/// The closest hit among all triangles (lowest index on exact ties).
pub fn closest_hit(tris: &[Triangle], ray: &Ray) -> Hit {
    let mut best = Hit::MISS;
    if !ray.is_valid() {
        return best;
    }
    let w = ray.watertight();
    for (i, t) in tris.iter().enumerate() {
        if let Some(h) = intersect_triangle(&w, t, ray.tmin, ray.tmax) {
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

/// True when any triangle is hit in `[tmin, tmax]`.
pub fn any_hit(tris: &[Triangle], ray: &Ray) -> bool {
    if !ray.is_valid() {
        return false;
    }
    let w = ray.watertight();
    tris.iter()
        .any(|t| intersect_triangle(&w, t, ray.tmin, ray.tmax).is_some())
}
