//! Ray/triangle and ray/box intersection tests.
//!
//! * [`intersect_triangle`]: the watertight test of Woop, Benthin and Wald, "Watertight
//!   Ray/Triangle Intersection" (JCGT 2013). A ray through a shared edge or vertex of a closed
//!   mesh hits at least one of the triangles sharing it; edge functions that evaluate to exactly
//!   zero in `f32` are recomputed in `f64`.
//! * [`intersect_aabb`]: the slab test with the conservative rounding of Ize, "Robust BVH Ray
//!   Traversal" (JCGT 2013): far distances are scaled up by `1 + 2γ(3)` so that rounding never
//!   culls a box the ray really enters.

use crate::{Aabb, Ray, Triangle};
use glam::Vec3A;

/// `γ(n) = n ε / (1 - n ε)` with `ε = 2^-24`, the rounding bound of Pharr et al.
pub const fn gamma(n: i32) -> f32 {
    let e = f32::EPSILON * 0.5;
    (n as f32 * e) / (1.0 - n as f32 * e)
}

/// The factor that makes a positive far slab distance conservative (Ize 2013): `1 + 2γ(3)`.
pub const ROBUST_FAR_SCALE: f32 = 1.0 + 2.0 * gamma(3);

/// The factor that makes a *negative* far slab distance conservative: `1 - 2γ(3)` (only rays
/// with `tmin < 0` can use boxes behind their origin).
pub const ROBUST_NEG_FAR_SCALE: f32 = 1.0 - 2.0 * gamma(3);

/// The reciprocal direction scaled for the far planes of the slab test, for positive and for
/// negative far distances: `(inv_direction · ROBUST_FAR_SCALE, inv_direction ·
/// ROBUST_NEG_FAR_SCALE)`. The scale is folded into the per-ray factor rather than applied to
/// every far distance (one multiplication per plane instead of two); [`intersect_aabb`]
/// computes these, and SIMD kernels that precompute them per ray get the same bits.
#[inline]
pub fn far_factors(inv_direction: Vec3A) -> (Vec3A, Vec3A) {
    (
        inv_direction * ROBUST_FAR_SCALE,
        inv_direction * ROBUST_NEG_FAR_SCALE,
    )
}

/// Per-ray constants of the watertight triangle test.
#[derive(Clone, Copy, Debug)]
pub struct WatertightRay {
    /// Ray origin.
    pub origin: Vec3A,
    /// `1 / direction`, component-wise (for the bounds check of [`accept_hit`]).
    pub inv_direction: Vec3A,
    /// Index of the direction's largest component (the one mapped to z).
    pub kz: usize,
    /// The two other axes, swapped when `direction[kz] < 0` to keep the winding.
    pub kx: usize,
    /// See `kx`.
    pub ky: usize,
    /// Shear constants: `dir[kx] · (1 / dir[kz])`, `dir[ky] · (1 / dir[kz])`, `1 / dir[kz]`.
    pub shear: Vec3A,
}

impl WatertightRay {
    /// Precomputes the axis permutation and the shear for a ray.
    #[inline]
    pub fn new(origin: Vec3A, direction: Vec3A) -> Self {
        Self::with_inverse(origin, direction, direction.recip())
    }

    /// [`WatertightRay::new`] for a ray whose reciprocal direction is known
    /// (`inv_direction` must be `direction.recip()`, as [`Ray::inv_direction`] is): no
    /// division, and no branch on the direction (the dominant axis of an incoherent ray is
    /// unpredictable).
    #[inline]
    pub fn with_inverse(origin: Vec3A, direction: Vec3A, inv_direction: Vec3A) -> Self {
        let a = direction.abs();
        // kz: the first axis of largest magnitude (z when a component is NaN).
        let x_max = (a.x >= a.y) & (a.x >= a.z);
        let kz = (!x_max as usize) * (2 - (a.y >= a.z) as usize);
        let d = direction.to_array();
        // (kx, ky) = (kz + 1, kz + 2) mod 3, swapped when direction[kz] < 0 (keeps the
        // winding, so the sign of the edge functions does not depend on the ray).
        let k1 = (kz + 1) % 3;
        let k2 = (kz + 2) % 3;
        let swap = 0usize.wrapping_sub((d[kz] < 0.0) as usize);
        let kx = k1 ^ ((k1 ^ k2) & swap);
        let ky = k1 ^ k2 ^ kx;
        let inv_z = inv_direction.to_array()[kz];
        Self {
            origin,
            inv_direction,
            kz,
            kx,
            ky,
            shear: Vec3A::new(d[kx] * inv_z, d[ky] * inv_z, inv_z),
        }
    }
}

/// A ray/triangle hit: distance and barycentrics, with the hit point at
/// `(1 - u - v) v0 + u v1 + v v2` (Embree's convention).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct TriangleHit {
    /// Ray parameter of the hit.
    pub t: f32,
    /// Barycentric weight of `v1`.
    pub u: f32,
    /// Barycentric weight of `v2`.
    pub v: f32,
}

/// Watertight ray/triangle test. Returns the hit when it lies in `[tmin, tmax]`.
///
/// Both faces are hit (no culling). Degenerate triangles (zero determinant, or three
/// collinear vertices: see [`accept_hit`]) never hit. The result is a miss or a hit at a
/// finite distance, never a NaN or infinite one, whatever the ray (zero, NaN, infinite or
/// subnormal directions) and the triangle.
///
/// In `f32`, rounding can make the sheared 2-D test accept a ray that passes beside a
/// zero-area triangle, or (for triangles whose extent dwarfs their distance from the origin,
/// near `f32::MAX`) return a distance far from the triangle's plane. Such answers fail
/// [`accept_hit`] and are misses.
#[inline]
pub fn intersect_triangle(
    r: &WatertightRay,
    tri: &Triangle,
    tmin: f32,
    tmax: f32,
) -> Option<TriangleHit> {
    let (kx, ky, kz) = (r.kx, r.ky, r.kz);
    let a = tri.v[0] - r.origin;
    let b = tri.v[1] - r.origin;
    let c = tri.v[2] - r.origin;
    let (sx, sy, sz) = (r.shear.x, r.shear.y, r.shear.z);
    let ax = a[kx] - sx * a[kz];
    let ay = a[ky] - sy * a[kz];
    let bx = b[kx] - sx * b[kz];
    let by = b[ky] - sy * b[kz];
    let cx = c[kx] - sx * c[kz];
    let cy = c[ky] - sy * c[kz];

    let mut u = cx * by - cy * bx;
    let mut v = ax * cy - ay * cx;
    let mut w = bx * ay - by * ax;
    if u == 0.0 || v == 0.0 || w == 0.0 {
        let (ax, ay, bx, by, cx, cy) = (
            ax as f64, ay as f64, bx as f64, by as f64, cx as f64, cy as f64,
        );
        u = (cx * by - cy * bx) as f32;
        v = (ax * cy - ay * cx) as f32;
        w = (bx * ay - by * ax) as f32;
    }
    if (u < 0.0 || v < 0.0 || w < 0.0) && (u > 0.0 || v > 0.0 || w > 0.0) {
        return None;
    }
    let det = u + v + w;
    if det == 0.0 || det.is_nan() {
        return None;
    }
    let az = sz * a[kz];
    let bz = sz * b[kz];
    let cz = sz * c[kz];
    let t_scaled = u * az + v * bz + w * cz;
    // Compare before dividing: t = t_scaled / det must lie in [tmin, tmax].
    let sign = det.signum();
    let ts = t_scaled * sign;
    let ad = det * sign;
    if !(ts >= tmin * ad && ts <= tmax * ad) {
        return None;
    }
    let inv = 1.0 / det;
    let t = t_scaled * inv;
    if !(t >= tmin && t <= tmax && accept_hit(r, tri, tmin, t)) {
        return None;
    }
    Some(TriangleHit {
        t,
        u: v * inv,
        v: w * inv,
    })
}

/// The final check of every hit the watertight test computes (the wide kernels apply it to
/// their SIMD hits too): true when
///
/// * `t` is finite (a valid ray whose true hit distance overflows `f32` misses);
/// * the triangle is not degenerate ([`is_degenerate`]);
/// * the slab test [`intersect_aabb`] of the triangle's own bounding box admits the interval
///   `[lower_distance(tmin), cull_distance(t)]`.
///
/// The last condition is what makes BVH traversal agree with brute force on every hit: the
/// slab test's computed distances are monotonic in the box (a larger box never has a later
/// computed entry or an earlier computed exit), so every box containing the triangle passes
/// the same test for any interval containing that one, and the kernels cull with exactly
/// `[lower_distance(tmin), cull_distance(best t)]`. For ordinary triangles it never rejects a
/// hit (the widening by 2^-16 of the distance dwarfs the rounding of both tests); it rejects
/// the rounding artefacts of the `f32` test on degenerate and extreme triangles.
#[inline]
pub fn accept_hit(r: &WatertightRay, tri: &Triangle, tmin: f32, t: f32) -> bool {
    if !t.is_finite() || is_degenerate(tri) {
        return false;
    }
    intersect_aabb(
        r.origin,
        r.inv_direction,
        lower_distance(tmin),
        cull_distance(t),
        &tri.bounds(),
    )
    .is_some()
}

/// True when the triangle's three vertices are collinear (or coincide): the cross product of
/// its edges, computed in `f64` from the `f32` vertices (so it neither overflows nor underflows,
/// unlike `f32` for coordinates near 1e±30), is exactly zero. Such triangles are never hit.
#[inline]
pub fn is_degenerate(tri: &Triangle) -> bool {
    let d = |a: Vec3A, b: Vec3A| {
        [
            b.x as f64 - a.x as f64,
            b.y as f64 - a.y as f64,
            b.z as f64 - a.z as f64,
        ]
    };
    let e1 = d(tri.v[0], tri.v[1]);
    let e2 = d(tri.v[0], tri.v[2]);
    let c = [
        e1[1] * e2[2] - e1[2] * e2[1],
        e1[2] * e2[0] - e1[0] * e2[2],
        e1[0] * e2[1] - e1[1] * e2[0],
    ];
    c == [0.0; 3]
}

/// Convenience wrapper: precomputes the ray constants and tests one triangle.
#[inline]
pub fn intersect_ray_triangle(ray: &Ray, tri: &Triangle) -> Option<TriangleHit> {
    intersect_triangle(&ray.watertight(), tri, ray.tmin, ray.tmax)
}

/// Robust slab test (Ize 2013). Returns the entry distance when the ray's `[tmin, tmax]`
/// overlaps the box, using `inv_direction` for the reciprocal direction.
///
/// Per axis, the near distance is `(near plane - origin) · inv_direction` and the far distance
/// `(far plane - origin) · (inv_direction · ROBUST_FAR_SCALE)` ([`far_factors`]): three
/// roundings of at most 2^-24 each plus the one of the factor are outweighed by the
/// `1 + 2γ(3)` scale, so a ray that really enters the box is never rejected by rounding. For
/// `tmin < 0` (boxes behind the origin matter) a negative far distance must be made larger
/// instead, so the far distance is the larger of that and `(far plane - origin) ·
/// (inv_direction · ROBUST_NEG_FAR_SCALE)`; for `tmin >= 0` a negative far distance fails
/// either way. The near and far planes of each axis are chosen by the sign of the reciprocal
/// direction, so a zero direction component with the origin exactly on a slab plane
/// (`0 · ∞ = NaN`) leaves that slab unconstrained on both the minimum and the maximum plane,
/// which keeps the test conservative. The computed distances are monotonic in the box (a
/// larger box never enters later or leaves earlier), which [`accept_hit`] relies on.
#[inline]
pub fn intersect_aabb(
    origin: Vec3A,
    inv_direction: Vec3A,
    tmin: f32,
    tmax: f32,
    aabb: &Aabb,
) -> Option<f32> {
    let negative = inv_direction.cmplt(Vec3A::ZERO);
    let lo = Vec3A::select(negative, aabb.max, aabb.min);
    let hi = Vec3A::select(negative, aabb.min, aabb.max);
    let tnear = (lo - origin) * inv_direction;
    let (far_pos, far_neg) = far_factors(inv_direction);
    let d = hi - origin;
    let mut tfar = d * far_pos;
    if tmin < 0.0 {
        // `maxps(tfar, other)`: the second operand when either is NaN.
        let other = d * far_neg;
        tfar = Vec3A::select(tfar.cmpgt(other), tfar, other);
    }
    // f32::max / f32::min return the non-NaN operand: a NaN slab distance is ignored.
    let near = tmin.max(tnear.x).max(tnear.y).max(tnear.z);
    let far = tmax.min(tfar.x).min(tfar.y).min(tfar.z);
    if near <= far {
        Some(near)
    } else {
        None
    }
}

/// The distance up to which boxes and triangles must still be tested once a hit at `t` is
/// known: `t` widened by a relative `2^-16`, so that a hit at exactly the same distance (a tie,
/// which the lowest triangle index wins) or one rounding step nearer is never culled by the
/// rounded comparisons of the box and triangle tests.
#[inline]
pub fn cull_distance(t: f32) -> f32 {
    t + t.abs() * (1.0 / 65536.0)
}

/// The counterpart of [`cull_distance`] for the start of the interval: `t` lowered by 2^-16 of
/// its magnitude. Box tests use `[lower_distance(tmin), cull_distance(tmax or best t)]`, so that
/// a triangle hit at exactly `tmin` or `tmax` (a shadow ray ending on a surface) is never lost to
/// the rounding of a box entry or exit distance.
#[inline]
pub fn lower_distance(t: f32) -> f32 {
    t - t.abs() * (1.0 / 65536.0)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn tri() -> Triangle {
        Triangle::new(
            Vec3A::new(0.0, 0.0, 1.0),
            Vec3A::new(1.0, 0.0, 1.0),
            Vec3A::new(0.0, 1.0, 1.0),
        )
    }

    #[test]
    fn hits_and_barycentrics() {
        let r = Ray::new(Vec3A::new(0.25, 0.25, 0.0), Vec3A::Z, 0.0, 10.0);
        let h = intersect_ray_triangle(&r, &tri()).unwrap();
        assert!((h.t - 1.0).abs() < 1e-6);
        assert!((h.u - 0.25).abs() < 1e-6 && (h.v - 0.25).abs() < 1e-6);
        let p = tri().point(h.u, h.v);
        assert!((p - r.at(h.t)).length() < 1e-6);
    }

    #[test]
    fn respects_interval_and_both_faces() {
        let r = Ray::new(Vec3A::new(0.25, 0.25, 2.0), -Vec3A::Z, 0.0, 0.5);
        assert!(intersect_ray_triangle(&r, &tri()).is_none());
        let r = Ray::new(Vec3A::new(0.25, 0.25, 2.0), -Vec3A::Z, 0.0, 1.5);
        assert!(intersect_ray_triangle(&r, &tri()).is_some());
        let r = Ray::new(Vec3A::new(0.25, 0.25, 2.0), -Vec3A::Z, 1.5, 5.0);
        assert!(intersect_ray_triangle(&r, &tri()).is_none());
    }

    #[test]
    fn degenerate_triangle_never_hits() {
        let d = Triangle::new(Vec3A::ZERO, Vec3A::X, Vec3A::X * 2.0);
        let r = Ray::new(Vec3A::new(0.5, 0.0, -1.0), Vec3A::Z, 0.0, 10.0);
        assert!(intersect_ray_triangle(&r, &d).is_none());
    }

    #[test]
    fn bad_rays_do_not_produce_nan() {
        for dir in [
            Vec3A::ZERO,
            Vec3A::new(f32::NAN, 0.0, 1.0),
            Vec3A::new(f32::INFINITY, 0.0, 1.0),
            Vec3A::new(1e-40, 1e-41, 1e-40),
        ] {
            let r = Ray::new(Vec3A::new(0.25, 0.25, 0.0), dir, 0.0, f32::INFINITY);
            if let Some(h) = intersect_ray_triangle(&r, &tri()) {
                assert!(h.t.is_finite());
            }
        }
    }

    #[test]
    fn slab_test() {
        let b = Aabb::new(Vec3A::splat(-1.0), Vec3A::splat(1.0));
        let r = Ray::new(Vec3A::new(0.0, 0.0, -5.0), Vec3A::Z, 0.0, 100.0);
        let t = intersect_aabb(r.origin, r.inv_direction, r.tmin, r.tmax, &b).unwrap();
        assert!((t - 4.0).abs() < 1e-6);
        let r = Ray::new(Vec3A::new(2.0, 0.0, -5.0), Vec3A::Z, 0.0, 100.0);
        assert!(intersect_aabb(r.origin, r.inv_direction, r.tmin, r.tmax, &b).is_none());
        // Axis-parallel ray lying exactly in a face plane: conservative hit.
        let r = Ray::new(Vec3A::new(1.0, 0.0, -5.0), Vec3A::Z, 0.0, 100.0);
        assert!(intersect_aabb(r.origin, r.inv_direction, r.tmin, r.tmax, &b).is_some());
        // ... and in the minimum plane too (0 * inf = NaN must be ignored on both sides).
        let r = Ray::new(Vec3A::new(-1.0, 0.0, -5.0), Vec3A::Z, 0.0, 100.0);
        assert!(intersect_aabb(r.origin, r.inv_direction, r.tmin, r.tmax, &b).is_some());
        let r = Ray::new(
            Vec3A::new(0.0, -1.0, -5.0),
            Vec3A::new(-0.0, 0.0, 1.0),
            0.0,
            100.0,
        );
        assert!(intersect_aabb(r.origin, r.inv_direction, r.tmin, r.tmax, &b).is_some());
        // A flat box behind the origin is found by a ray with tmin < 0.
        let flat_z = Aabb::new(Vec3A::new(-1.0, -1.0, -3.0), Vec3A::new(1.0, 1.0, -3.0));
        let r = Ray::new(
            Vec3A::new(0.1, 0.2, 0.0),
            Vec3A::new(0.0, 0.0, 1.0),
            -10.0,
            10.0,
        );
        assert!(intersect_aabb(r.origin, r.inv_direction, r.tmin, r.tmax, &flat_z).is_some());
        // Flat box (zero thickness) is still hit.
        let flat = Aabb::new(Vec3A::new(-1.0, -1.0, 0.0), Vec3A::new(1.0, 1.0, 0.0));
        let r = Ray::new(
            Vec3A::new(0.3, 0.2, -5.0),
            Vec3A::new(0.0, 0.0, 1.0),
            0.0,
            100.0,
        );
        assert!(intersect_aabb(r.origin, r.inv_direction, r.tmin, r.tmax, &flat).is_some());
    }
}
