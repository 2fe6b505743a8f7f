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
///
/// The fields are private and derived together from one origin and direction
/// ([`WatertightRay::new`], [`Ray::watertight`]), so they cannot disagree with each other.
#[derive(Clone, Copy, Debug)]
pub struct WatertightRay {
    origin: Vec3A,
    inv_direction: Vec3A,
    kz: usize,
    kx: usize,
    ky: usize,
    shear: Vec3A,
}

impl WatertightRay {
    /// Ray origin.
    #[inline]
    pub fn origin(&self) -> Vec3A {
        self.origin
    }

    /// `1 / direction`, component-wise (for the bounds check of [`accept_hit`]).
    #[inline]
    pub fn inv_direction(&self) -> Vec3A {
        self.inv_direction
    }

    /// The axis permutation `(kx, ky, kz)`: `kz` is the index of the direction's largest
    /// component (the one mapped to z), `kx` and `ky` the two others, swapped when
    /// `direction[kz] < 0` to keep the winding.
    #[inline]
    pub fn axes(&self) -> (usize, usize, usize) {
        (self.kx, self.ky, self.kz)
    }

    /// Shear constants: `dir[kx] · (1 / dir[kz])`, `dir[ky] · (1 / dir[kz])`, `1 / dir[kz]`.
    #[inline]
    pub fn shear(&self) -> Vec3A {
        self.shear
    }

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

/// Watertight ray/triangle test. Returns the hit when it lies in `[tmin, tmax]`, its distance
/// decided and reported by [`accept_hit`].
///
/// Both faces are hit (no culling). Degenerate triangles (zero determinant, or three
/// collinear vertices: see [`accept_hit`]) never hit. The result is a miss or a hit at a
/// finite distance, never a NaN or infinite one, whatever the ray (zero, NaN, infinite or
/// subnormal directions) and the triangle.
///
/// In `f32`, the distance's rounding error grows with the triangle's extent along the ray's
/// dominant axis (a weighted sum of vertex distances cancels), and for triangles whose extent
/// dwarfs their distance from the origin (near `f32::MAX`) the distance can land far from the
/// triangle's plane. [`accept_hit`] clamps the distance into the ray's span through the
/// triangle's own box (which holds the exact hit), and a ray whose span misses the interval
/// misses.
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
    // An exact early out (it never changes the answer, only spares work): `az`, `bz`, `cz` are
    // computed like the near distances of the dominant axis's slab, so the span entry of
    // `accept_hit` is at least their minimum, and its exit at most the largest far distance of
    // that axis. A triangle wholly beyond `tmax` or behind `tmin` fails the range check anyway.
    let far = |d: f32| {
        let f = d * (r.inv_direction[kz] * ROBUST_FAR_SCALE);
        if tmin < 0.0 {
            let g = d * (r.inv_direction[kz] * ROBUST_NEG_FAR_SCALE);
            if f > g {
                f
            } else {
                g
            }
        } else {
            f
        }
    };
    let zfar = far(a[kz]).max(far(b[kz])).max(far(c[kz]));
    if !(az.min(bz).min(cz) <= tmax && zfar >= tmin) {
        return None;
    }
    let t_scaled = u * az + v * bz + w * cz;
    let inv = 1.0 / det;
    let t = accept_hit(r, tri, tmin, tmax, t_scaled * inv)?;
    Some(TriangleHit {
        t,
        u: v * inv,
        v: w * inv,
    })
}

/// The final step of every hit the watertight test computes (the wide kernels apply it to
/// their SIMD hits too, lane by lane with the same operations): decides whether the distance
/// `t` computed by the test is a hit in `[tmin, tmax]`, and returns the distance to report.
///
/// With `[n, f]` = [`slab_span`] of the triangle's own bounding box (the computed entry and exit
/// of the ray, whatever its interval):
///
/// * the triangle must not be degenerate ([`is_degenerate`]) and the span not empty (`n <= f`);
/// * the distance is clamped into the span, `t_c = min(max(t, n), f)`: the exact hit lies
///   inside the triangle's box, and the span contains the exact entry and exit up to one
///   rounding of the entry, so clamping only ever moves `t` towards the exact distance;
/// * `t_c` must be finite and lie in `[tmin, tmax]`; it is the reported distance.
///
/// Why clamp: the test's distance is a weighted sum of the vertices' distances along the
/// dominant axis, so its absolute rounding error grows with the triangle's extent along that
/// axis, not with `t`. For a triangle whose box has zero extent on one axis (a floor, a wall)
/// the span is a single distance, and no relative widening of `t` reaches it reliably: the old
/// rule (the span had to meet `[lower_distance(tmin), cull_distance(t)]`) dropped such hits.
///
/// What makes BVH traversal agree with brute force: the reported `t` lies in `[n, f]` and in
/// `[tmin, tmax]`, so the triangle's box passes the slab test over `[lower_distance(tmin),
/// cull_distance(t)]` and, the computed slab distances being monotonic in the box, so does
/// every box containing the triangle, for every interval containing that one. Kernels cull with
/// `[lower_distance(tmin), cull_distance(min(best t, tmax))]`, so no box holding a hit at or
/// before the best one is ever culled. `docs/robustness.md` gives the whole argument.
#[inline]
pub fn accept_hit(r: &WatertightRay, tri: &Triangle, tmin: f32, tmax: f32, t: f32) -> Option<f32> {
    accept_hit_at(r.origin, r.inv_direction, tri, tmin, tmax, t)
}

/// [`accept_hit`] for a ray given by its origin and reciprocal direction (the rule of every
/// triangle test of the workspace, the watertight one and [`intersect_triangle_fast`]).
#[inline]
pub fn accept_hit_at(
    origin: Vec3A,
    inv_direction: Vec3A,
    tri: &Triangle,
    tmin: f32,
    tmax: f32,
    t: f32,
) -> Option<f32> {
    if is_degenerate(tri) {
        return None;
    }
    let (n, f) = slab_span(origin, inv_direction, tmin < 0.0, &tri.bounds());
    let tc = clamp_to_span(t, n, f);
    (n <= f && tc >= tmin && tc <= tmax && tc.is_finite()).then_some(tc)
}

/// `min(max(t, lo), hi)` with the operand order of the SIMD kernels' selects (`t` stays when a
/// comparison is false, so a NaN `t` stays NaN).
#[inline(always)]
pub fn clamp_to_span(t: f32, lo: f32, hi: f32) -> f32 {
    let t = if t < lo { lo } else { t };
    if t > hi {
        hi
    } else {
        t
    }
}

/// The computed entry and exit distances `(n, f)` of the line `origin + t · direction` through
/// a box, with the operations of [`intersect_aabb`] but without the ray's interval: `n` is the
/// largest near-plane distance, `f` the smallest far-plane distance (scaled as in
/// [`far_factors`]; `neg_far` for rays with `tmin < 0`, as in [`intersect_aabb`]). A NaN slab
/// distance (zero direction component with the origin on a slab plane) is ignored, as the SIMD
/// `maxps`/`minps` running maximum and minimum ignore it: `n` starts at `-∞`, `f` at `+∞`.
/// [`intersect_aabb`] over `[tmin, tmax]` passes exactly when `max(tmin, n) <= min(tmax, f)`.
///
/// The operations are those of the SIMD kernels lane by lane (the near plane chosen by the sign
/// of the reciprocal direction, `(plane - origin) · inv`), so the distances agree to the bit,
/// signs of zeros included: a hit clamped to `n` or `f` reports that value.
#[inline]
pub fn slab_span(origin: Vec3A, inv_direction: Vec3A, neg_far: bool, aabb: &Aabb) -> (f32, f32) {
    let negative = inv_direction.cmplt(Vec3A::ZERO);
    let lo = Vec3A::select(negative, aabb.max, aabb.min);
    let hi = Vec3A::select(negative, aabb.min, aabb.max);
    let tnear = ((lo - origin) * inv_direction).to_array();
    let (far_pos, far_neg) = far_factors(inv_direction);
    let d = hi - origin;
    let tf_pos = (d * far_pos).to_array();
    let tf_neg = (d * far_neg).to_array();
    let (mut n, mut f) = (f32::NEG_INFINITY, f32::INFINITY);
    for a in 0..3 {
        let mut tf = tf_pos[a];
        if neg_far {
            // `maxps(tf, tf_neg)`: the second operand unless the first is larger.
            tf = if tf > tf_neg[a] { tf } else { tf_neg[a] };
        }
        // `maxps(tn, n)` / `minps(tf, f)`: the running value when the slab distance is NaN.
        n = if tnear[a] > n { tnear[a] } else { n };
        f = if tf < f { tf } else { f };
    }
    (n, f)
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

/// Möller–Trumbore ray/triangle test with the division deferred: the reference of the `Fast`
/// precision level of the traversal kernels (`sahara_traverse::Precision::Fast`), whose SIMD
/// lanes perform these operations in this order, so that they agree with it bit for bit.
///
/// With `e1 = v1 - v0`, `e2 = v2 - v0`, `p = d × e2`, `det = e1 · p`, `s = o - v0`,
/// `q = s × e1`: the edge tests compare `u = s · p` and `v = d · q`, their signs flipped by the
/// sign of `det`, against 0 and `|det|` (no division: a triangle that fails them costs no
/// divide), and only a triangle that passes divides: `t = (e2 · q) · (1 / det)`. Every cross
/// product is `(a.y b.z - a.z b.y, a.z b.x - a.x b.z, a.x b.y - a.y b.x)` and every dot product
/// `(a.x b.x + a.y b.y) + a.z b.z`, in `f32`. The distance then goes through the same
/// [`accept_hit_at`] rule as the watertight test (clamped into the ray's span through the
/// triangle's box, checked against `[tmin, tmax]`), which is what lets a BVH traversal agree
/// with a brute-force scan of this test.
///
/// It is *not* watertight: a ray through a shared edge or vertex may miss both triangles, and
/// hits near edges may go to the neighbour. `docs/precision.md` measures how often on real
/// scenes. `inv_direction` must be `direction.recip()` (as [`Ray::inv_direction`] is).
#[inline]
pub fn intersect_triangle_fast(
    origin: Vec3A,
    direction: Vec3A,
    inv_direction: Vec3A,
    tri: &Triangle,
    tmin: f32,
    tmax: f32,
) -> Option<TriangleHit> {
    let [v0, v1, v2] = tri.v.map(|p| p.to_array());
    let [ox, oy, oz] = origin.to_array();
    let d = direction.to_array();
    let e1 = [v1[0] - v0[0], v1[1] - v0[1], v1[2] - v0[2]];
    let e2 = [v2[0] - v0[0], v2[1] - v0[1], v2[2] - v0[2]];
    let cross = |a: [f32; 3], b: [f32; 3]| {
        [
            a[1] * b[2] - a[2] * b[1],
            a[2] * b[0] - a[0] * b[2],
            a[0] * b[1] - a[1] * b[0],
        ]
    };
    let dot = |a: [f32; 3], b: [f32; 3]| a[0] * b[0] + a[1] * b[1] + a[2] * b[2];
    let p = cross(d, e2);
    let det = dot(e1, p);
    let s = [ox - v0[0], oy - v0[1], oz - v0[2]];
    let u = dot(s, p);
    let q = cross(s, e1);
    let v = dot(d, q);
    // The signs of `u` and `v` flipped by the sign of `det` (its sign bit), compared with 0
    // and `|det|`; NaN anywhere fails a comparison.
    let sign = det.to_bits() & 0x8000_0000;
    let flip = |x: f32| f32::from_bits(x.to_bits() ^ sign);
    let (us, vs, adet) = (flip(u), flip(v), det.abs());
    if !(adet > 0.0 && us >= 0.0 && vs >= 0.0 && us + vs <= adet) {
        return None;
    }
    let inv = 1.0 / det;
    let t = accept_hit_at(origin, inv_direction, tri, tmin, tmax, dot(e2, q) * inv)?;
    Some(TriangleHit {
        t,
        u: u * inv,
        v: v * inv,
    })
}

/// [`intersect_triangle_fast`] of one ray over its own interval.
#[inline]
pub fn intersect_ray_triangle_fast(ray: &Ray, tri: &Triangle) -> Option<TriangleHit> {
    intersect_triangle_fast(
        ray.origin,
        ray.direction(),
        ray.inv_direction(),
        tri,
        ray.tmin,
        ray.tmax,
    )
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
        let t = intersect_aabb(r.origin, r.inv_direction(), r.tmin, r.tmax, &b).unwrap();
        assert!((t - 4.0).abs() < 1e-6);
        let r = Ray::new(Vec3A::new(2.0, 0.0, -5.0), Vec3A::Z, 0.0, 100.0);
        assert!(intersect_aabb(r.origin, r.inv_direction(), r.tmin, r.tmax, &b).is_none());
        // Axis-parallel ray lying exactly in a face plane: conservative hit.
        let r = Ray::new(Vec3A::new(1.0, 0.0, -5.0), Vec3A::Z, 0.0, 100.0);
        assert!(intersect_aabb(r.origin, r.inv_direction(), r.tmin, r.tmax, &b).is_some());
        // ... and in the minimum plane too (0 * inf = NaN must be ignored on both sides).
        let r = Ray::new(Vec3A::new(-1.0, 0.0, -5.0), Vec3A::Z, 0.0, 100.0);
        assert!(intersect_aabb(r.origin, r.inv_direction(), r.tmin, r.tmax, &b).is_some());
        let r = Ray::new(
            Vec3A::new(0.0, -1.0, -5.0),
            Vec3A::new(-0.0, 0.0, 1.0),
            0.0,
            100.0,
        );
        assert!(intersect_aabb(r.origin, r.inv_direction(), r.tmin, r.tmax, &b).is_some());
        // A flat box behind the origin is found by a ray with tmin < 0.
        let flat_z = Aabb::new(Vec3A::new(-1.0, -1.0, -3.0), Vec3A::new(1.0, 1.0, -3.0));
        let r = Ray::new(
            Vec3A::new(0.1, 0.2, 0.0),
            Vec3A::new(0.0, 0.0, 1.0),
            -10.0,
            10.0,
        );
        assert!(intersect_aabb(r.origin, r.inv_direction(), r.tmin, r.tmax, &flat_z).is_some());
        // Flat box (zero thickness) is still hit.
        let flat = Aabb::new(Vec3A::new(-1.0, -1.0, 0.0), Vec3A::new(1.0, 1.0, 0.0));
        let r = Ray::new(
            Vec3A::new(0.3, 0.2, -5.0),
            Vec3A::new(0.0, 0.0, 1.0),
            0.0,
            100.0,
        );
        assert!(intersect_aabb(r.origin, r.inv_direction(), r.tmin, r.tmax, &flat).is_some());
    }
}
