//! The closest point of a triangle to a point: the region method of Ericson ("Real-Time
//! Collision Detection", 2005, §5.1.5), evaluated in `f64`.
//!
//! The `f32` vertices and query point are widened to `f64` (exactly) and every step runs in
//! `f64`, so the returned point lies on the triangle up to a rounding of about `2^-50` of the
//! coordinates' magnitude and its squared distance neither overflows nor underflows for any
//! finite `f32` input. The routine is a pure function of its inputs, so every caller that uses
//! it (a BVH query and its brute-force twin) gets the same bits.
//!
//! The point is always on the closed triangle: when rounding makes the region tests disagree
//! with each other (nearly degenerate triangles) and the face case yields barycentrics outside
//! the triangle, the nearest of the three edges' closest points is taken instead.
//!
//! ```
//! use sahara_geom::{closest::closest_point_on_triangle, Triangle, Vec3A};
//!
//! let tri = Triangle::new(Vec3A::ZERO, Vec3A::X, Vec3A::Y);
//! let c = closest_point_on_triangle(&tri, Vec3A::new(0.25, 0.25, 2.0));
//! assert_eq!(c.point.to_array(), [0.25, 0.25, 0.0]);
//! assert_eq!(c.distance_squared, 4.0);
//! assert_eq!((c.u, c.v), (0.25, 0.25));
//! // Beyond vertex 1: the vertex itself.
//! let c = closest_point_on_triangle(&tri, Vec3A::new(3.0, -1.0, 0.0));
//! assert_eq!((c.u, c.v, c.distance_squared), (1.0, 0.0, 5.0));
//! ```

use crate::Triangle;
use glam::DVec3;
use glam::Vec3A;

/// The closest point of a triangle to a query point, in `f64`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct TrianglePoint {
    /// The closest point, `(1 - u - v) v0 + u v1 + v v2`.
    pub point: DVec3,
    /// Barycentric weight of vertex 1 (in `[0, 1]`).
    pub u: f64,
    /// Barycentric weight of vertex 2 (in `[0, 1]`, `u + v <= 1`).
    pub v: f64,
    /// Squared distance from the query point to [`TrianglePoint::point`].
    pub distance_squared: f64,
}

/// The closest point of `tri` to `p` (see the [module documentation](self)). Degenerate
/// triangles (a segment or a point) give the closest point of the segment or the point. For
/// non-finite inputs the result is unspecified (possibly NaN) but never a panic.
#[inline]
pub fn closest_point_on_triangle(tri: &Triangle, p: Vec3A) -> TrianglePoint {
    let a = tri.v[0].as_dvec3();
    let b = tri.v[1].as_dvec3();
    let c = tri.v[2].as_dvec3();
    let p = p.as_dvec3();
    let (u, v) = barycentrics(a, b, c, p);
    let point = a + (b - a) * u + (c - a) * v;
    TrianglePoint {
        point,
        u,
        v,
        distance_squared: (p - point).length_squared(),
    }
}

/// Ericson's region tests: the barycentric weights `(u, v)` of vertices 1 and 2 at the
/// closest point.
#[inline]
fn barycentrics(a: DVec3, b: DVec3, c: DVec3, p: DVec3) -> (f64, f64) {
    let ab = b - a;
    let ac = c - a;
    let ap = p - a;
    let d1 = ab.dot(ap);
    let d2 = ac.dot(ap);
    if d1 <= 0.0 && d2 <= 0.0 {
        return (0.0, 0.0);
    }
    let bp = p - b;
    let d3 = ab.dot(bp);
    let d4 = ac.dot(bp);
    if d3 >= 0.0 && d4 <= d3 {
        return (1.0, 0.0);
    }
    let vc = d1 * d4 - d3 * d2;
    if vc <= 0.0 && d1 >= 0.0 && d3 <= 0.0 {
        return (ratio(d1, d1 - d3), 0.0);
    }
    let cp = p - c;
    let d5 = ab.dot(cp);
    let d6 = ac.dot(cp);
    if d6 >= 0.0 && d5 <= d6 {
        return (0.0, 1.0);
    }
    let vb = d5 * d2 - d1 * d6;
    if vb <= 0.0 && d2 >= 0.0 && d6 <= 0.0 {
        return (0.0, ratio(d2, d2 - d6));
    }
    let va = d3 * d6 - d5 * d4;
    if va <= 0.0 && d4 - d3 >= 0.0 && d5 - d6 >= 0.0 {
        let w = ratio(d4 - d3, (d4 - d3) + (d5 - d6));
        return (1.0 - w, w);
    }
    let sum = va + vb + vc;
    let (v, w) = (vb / sum, vc / sum);
    // In exact arithmetic `va, vb, vc >= 0` here; rounding can break it for nearly degenerate
    // triangles, and a degenerate one gives `0 / 0`.
    if v >= 0.0 && w >= 0.0 && v + w <= 1.0 {
        (v, w)
    } else {
        nearest_edge(a, b, c, p)
    }
}

/// `num / den` clamped into `[0, 1]` (`0` when it is NaN: `0 / 0`).
#[inline]
fn ratio(num: f64, den: f64) -> f64 {
    let r = num / den;
    if r >= 0.0 {
        r.min(1.0)
    } else {
        0.0
    }
}

/// The nearest of the three edges' closest points, as barycentric weights of vertices 1 and 2
/// (ties: the first edge of `ab`, `ac`, `bc`).
fn nearest_edge(a: DVec3, b: DVec3, c: DVec3, p: DVec3) -> (f64, f64) {
    let on = |s: DVec3, e: DVec3| ratio((p - s).dot(e - s), (e - s).length_squared());
    let t_ab = on(a, b);
    let t_ac = on(a, c);
    let t_bc = on(b, c);
    let candidates = [(t_ab, 0.0), (0.0, t_ac), (1.0 - t_bc, t_bc)];
    let mut best = candidates[0];
    let mut best_d = f64::INFINITY;
    for (u, v) in candidates {
        let d = (p - (a + (b - a) * u + (c - a) * v)).length_squared();
        if d < best_d {
            best = (u, v);
            best_d = d;
        }
    }
    best
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::rng::Pcg32;

    fn tri() -> Triangle {
        Triangle::new(
            Vec3A::ZERO,
            Vec3A::new(2.0, 0.0, 0.0),
            Vec3A::new(0.0, 2.0, 0.0),
        )
    }

    #[test]
    fn every_region() {
        let t = tri();
        let cases = [
            // (query, expected point, u, v)
            (Vec3A::new(-1.0, -1.0, 1.0), [0.0, 0.0, 0.0], 0.0, 0.0),
            (Vec3A::new(3.0, -1.0, 0.0), [2.0, 0.0, 0.0], 1.0, 0.0),
            (Vec3A::new(-1.0, 3.0, 0.0), [0.0, 2.0, 0.0], 0.0, 1.0),
            (Vec3A::new(1.0, -1.0, 0.0), [1.0, 0.0, 0.0], 0.5, 0.0),
            (Vec3A::new(-1.0, 1.0, 0.0), [0.0, 1.0, 0.0], 0.0, 0.5),
            (Vec3A::new(2.0, 2.0, 0.0), [1.0, 1.0, 0.0], 0.5, 0.5),
            (Vec3A::new(0.5, 0.5, -3.0), [0.5, 0.5, 0.0], 0.25, 0.25),
        ];
        for (q, point, u, v) in cases {
            let c = closest_point_on_triangle(&t, q);
            assert_eq!(c.point.to_array(), point.map(f64::from), "{q}");
            assert_eq!((c.u, c.v), (u, v), "{q}");
            let d = q.as_dvec3() - c.point;
            assert_eq!(c.distance_squared, d.length_squared());
        }
    }

    #[test]
    fn degenerate_triangles_give_their_segment_or_point() {
        let seg = Triangle::new(Vec3A::ZERO, Vec3A::X, Vec3A::X * 2.0);
        let c = closest_point_on_triangle(&seg, Vec3A::new(1.5, 1.0, 0.0));
        assert_eq!(c.point.to_array(), [1.5, 0.0, 0.0]);
        assert_eq!(c.distance_squared, 1.0);
        let dot = Triangle::new(Vec3A::ONE, Vec3A::ONE, Vec3A::ONE);
        let c = closest_point_on_triangle(&dot, Vec3A::new(1.0, 1.0, 3.0));
        assert_eq!(c.point.to_array(), [1.0, 1.0, 1.0]);
        assert_eq!(c.distance_squared, 4.0);
    }

    /// Against a dense sampling of the triangle: never farther than the best sample (up to
    /// rounding), always on the triangle.
    #[test]
    fn no_sample_is_closer() {
        let mut r = Pcg32::new(3, 9);
        let mut pt = || {
            Vec3A::new(
                r.next_f32() * 4.0 - 2.0,
                r.next_f32() * 4.0 - 2.0,
                r.next_f32() * 4.0 - 2.0,
            )
        };
        for _ in 0..300 {
            let t = Triangle::new(pt(), pt(), pt());
            let q = pt();
            let c = closest_point_on_triangle(&t, q);
            assert!(c.u >= 0.0 && c.v >= 0.0 && c.u + c.v <= 1.0);
            let n = 40;
            for i in 0..=n {
                for j in 0..=n - i {
                    let s = t.point(i as f32 / n as f32, j as f32 / n as f32).as_dvec3();
                    let d = (q.as_dvec3() - s).length_squared();
                    assert!(
                        c.distance_squared <= d + 1e-9,
                        "{} > {d}",
                        c.distance_squared
                    );
                }
            }
        }
    }

    #[test]
    fn non_finite_inputs_do_not_panic() {
        let t = tri();
        let _ = closest_point_on_triangle(&t, Vec3A::splat(f32::NAN));
        let _ = closest_point_on_triangle(&t, Vec3A::splat(f32::INFINITY));
        let bad = Triangle::new(Vec3A::splat(f32::NAN), Vec3A::X, Vec3A::Y);
        let _ = closest_point_on_triangle(&bad, Vec3A::ONE);
    }
}
