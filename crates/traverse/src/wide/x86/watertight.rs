//! The 4-wide watertight triangle test of every x86 backend (bit for bit
//! `sahara_geom::intersect::intersect_triangle`, lane by lane).

use super::kernel::PacketHits;
use super::{SseRay, TriPacket};
use std::arch::x86_64::*;

/// The edge functions of the 4-wide watertight test (the part every packet needs).
struct Edges {
    u: __m128,
    v: __m128,
    w: __m128,
    /// The edge functions are all positive or all negative, with the proviso that `minps`
    /// and `maxps` may hide a NaN among them: see [`Edges::det`] for why those lanes still
    /// never hit.
    strict: __m128,
    /// An edge function is exactly zero: the lane needs the exact scalar test.
    is_zero: __m128,
    /// The vertices' coordinates along the ray's dominant axis, relative to the origin (not
    /// yet scaled by the shear), for [`t_scaled`].
    dz: [__m128; 3],
}

/// The edge functions of the 4-wide watertight test, with the operations of the reference.
#[inline(always)]
unsafe fn tri4(p: &TriPacket, r: &SseRay) -> Edges {
    // SAFETY (whole function): the packet is 16-byte aligned and its vertex rows hold 4
    // floats each; the axes are in 0..3.
    unsafe {
        let base = p.v.as_ptr().cast::<f32>();
        let [kx, ky, kz] = r.w_axis;
        let [ox, oy, oz] = r.w_origin;
        let [sx, sy, _] = r.w_shear;
        // Vertex k, relative to the origin, sheared: (x, y) as in the reference, and the
        // unscaled z.
        let vert = |k: usize| {
            let row = base.add(k * 12);
            let dx = _mm_sub_ps(_mm_load_ps(row.add(kx * 4)), ox);
            let dy = _mm_sub_ps(_mm_load_ps(row.add(ky * 4)), oy);
            let dz = _mm_sub_ps(_mm_load_ps(row.add(kz * 4)), oz);
            (
                _mm_sub_ps(dx, _mm_mul_ps(sx, dz)),
                _mm_sub_ps(dy, _mm_mul_ps(sy, dz)),
                dz,
            )
        };
        let (ax, ay, az) = vert(0);
        let (bx, by, bz) = vert(1);
        let (cx, cy, cz) = vert(2);
        let u = _mm_sub_ps(_mm_mul_ps(cx, by), _mm_mul_ps(cy, bx));
        let v = _mm_sub_ps(_mm_mul_ps(ax, cy), _mm_mul_ps(ay, cx));
        let w = _mm_sub_ps(_mm_mul_ps(bx, ay), _mm_mul_ps(by, ax));
        let zero = _mm_setzero_ps();
        let is_zero = _mm_or_ps(
            _mm_or_ps(_mm_cmpeq_ps(u, zero), _mm_cmpeq_ps(v, zero)),
            _mm_cmpeq_ps(w, zero),
        );
        // All of one strict sign. A zero edge function fails both comparisons whatever a NaN
        // beside it hides (`minps`/`maxps` return their second operand when either is NaN, so
        // the minimum is a zero, a negative value or NaN, and the maximum a zero, a positive
        // value or NaN).
        let strict = _mm_or_ps(
            _mm_cmpgt_ps(_mm_min_ps(u, _mm_min_ps(v, w)), zero),
            _mm_cmplt_ps(_mm_max_ps(u, _mm_max_ps(v, w)), zero),
        );
        Edges {
            u,
            v,
            w,
            strict,
            is_zero,
            dz: [az, bz, cz],
        }
    }
}

impl Edges {
    /// The reference's determinant `u + v + w`. Of the lanes of `strict`, those where the
    /// reference's sign test passes (no exact zero, no mixed signs, a determinant neither zero
    /// nor NaN) are the lanes whose determinant is not NaN:
    ///
    /// * a NaN edge function makes the sum NaN, so an ordered determinant means none is NaN,
    ///   and then `strict` is exact: all three are non-zero and of one sign;
    /// * a sum of non-zero values of one sign is not zero (rounding never takes it below its
    ///   largest term), and not NaN (no `∞ - ∞`).
    ///
    /// A NaN determinant needs no mask of its own: it makes the distance NaN, which
    /// [`accept4`] rejects. Computed only for packets with a `strict` lane (most have none).
    #[inline(always)]
    unsafe fn det(&self) -> __m128 {
        // SAFETY: SSE2 is part of x86-64.
        unsafe { _mm_add_ps(_mm_add_ps(self.u, self.v), self.w) }
    }
}

/// The vertices' distances along the ray's dominant axis, `z_i = sz · dz_i` (the reference's
/// `az`, `bz`, `cz`), and the mask of lanes that can pass [`accept4`]'s range check with a
/// distance at most `hi`: the smallest `z_i` is at most `hi` and the largest far distance of the
/// dominant axis, `max_i dz_i · inv_far[kz]` (and `inv_far_neg[kz]` for `NEG`), at least
/// `t_lo = max(tmin, -f32::MAX)` (the bound of [`accept4`]'s range check: a lane whose far bound
/// is below it fails that check, or is `-∞`, which is not finite).
///
/// This is exact, not a heuristic: `z_i` is computed with the operations of the triangle box's
/// near distance on that axis, which is therefore `min_i z_i` (rounding is monotonic), and the
/// span's entry `n` is at least that; likewise its exit `f` is at most the far bound. The
/// reported distance lies in `[n, f]`, so a lane failing this test would fail the range check
/// (or the closest-hit `t <= tfar`) anyway. It spares the span for lanes whose triangle lies
/// wholly behind the origin or beyond the current hit.
#[inline(always)]
unsafe fn dominant_slab4<const NEG: bool>(
    e: &Edges,
    r: &SseRay,
    hi: __m128,
) -> (__m128, [__m128; 3]) {
    // SAFETY (whole function): SSE2 is part of x86-64.
    unsafe {
        let sz = r.w_shear[2];
        let z = e.dz.map(|d| _mm_mul_ps(sz, d));
        let zmin = _mm_min_ps(z[0], _mm_min_ps(z[1], z[2]));
        let far = |d: __m128| {
            let f = _mm_mul_ps(d, r.w_far);
            if NEG {
                _mm_max_ps(f, _mm_mul_ps(d, r.w_far_neg))
            } else {
                f
            }
        };
        let [d0, d1, d2] = e.dz;
        let zfar = _mm_max_ps(far(d0), _mm_max_ps(far(d1), far(d2)));
        let ok = _mm_and_ps(_mm_cmple_ps(zmin, hi), _mm_cmpge_ps(zfar, r.t_lo));
        (ok, z)
    }
}

/// The scaled hit distance `u·az + v·bz + w·cz` of the reference.
#[inline(always)]
unsafe fn t_scaled(e: &Edges, z: [__m128; 3]) -> __m128 {
    // SAFETY (whole function): SSE2 is part of x86-64.
    unsafe {
        let [az, bz, cz] = z;
        _mm_add_ps(
            _mm_add_ps(_mm_mul_ps(e.u, az), _mm_mul_ps(e.v, bz)),
            _mm_mul_ps(e.w, cz),
        )
    }
}

/// [`accept_hit`] of the 4 lanes of a packet whose watertight test computed the distance `t`
/// (degenerate triangles are stored as NaN lanes, which never pass the edge tests, so the
/// degeneracy check is not repeated; a NaN distance, from a NaN determinant, fails the range
/// check below, as `maxps` returns it and `minps` then returns it too): the [`slab_span`] `[n, f]` of each lane's triangle
/// bounds, with the operations of the reference, `t` clamped into
/// it (`minps(f, maxps(n, t))` is exactly [`clamp_to_span`]), and the range check against
/// `[tmin, min(tmax, hi)]` with finiteness. Returns `(accepted mask, reported t)`. `NEG` as in
/// the box tests.
///
/// [`accept_hit`]: sahara_geom::intersect::accept_hit
/// [`slab_span`]: sahara_geom::intersect::slab_span
/// [`clamp_to_span`]: sahara_geom::intersect::clamp_to_span
#[inline(always)]
pub(super) unsafe fn accept4<const NEG: bool>(
    p: &TriPacket,
    r: &SseRay,
    t: __m128,
    hi: __m128,
) -> (__m128, __m128) {
    // SAFETY (whole function): the packet is 16-byte aligned and its vertex rows hold 4
    // floats each.
    unsafe {
        let base = p.v.as_ptr().cast::<f32>();
        let mut near = _mm_set1_ps(f32::NEG_INFINITY);
        let mut far = _mm_set1_ps(f32::INFINITY);
        for a in 0..3 {
            let v0 = _mm_load_ps(base.add(a * 4));
            let v1 = _mm_load_ps(base.add(12 + a * 4));
            let v2 = _mm_load_ps(base.add(24 + a * 4));
            let lo = _mm_min_ps(v0, _mm_min_ps(v1, v2));
            let hi = _mm_max_ps(v0, _mm_max_ps(v1, v2));
            // The near plane is the maximum where the reciprocal direction is negative.
            let neg = _mm_cmplt_ps(r.inv[a], _mm_setzero_ps());
            let pn = _mm_or_ps(_mm_and_ps(neg, hi), _mm_andnot_ps(neg, lo));
            let pf = _mm_or_ps(_mm_and_ps(neg, lo), _mm_andnot_ps(neg, hi));
            let tn = _mm_mul_ps(_mm_sub_ps(pn, r.origin[a]), r.inv[a]);
            let d = _mm_sub_ps(pf, r.origin[a]);
            let mut tf = _mm_mul_ps(d, r.inv_far[a]);
            if NEG {
                tf = _mm_max_ps(tf, _mm_mul_ps(d, r.inv_far_neg[a]));
            }
            near = _mm_max_ps(tn, near);
            far = _mm_min_ps(tf, far);
        }
        let tc = _mm_min_ps(far, _mm_max_ps(near, t));
        let ok = _mm_and_ps(
            _mm_cmple_ps(near, far),
            _mm_and_ps(_mm_cmpge_ps(tc, r.t_lo), _mm_cmple_ps(tc, hi)),
        );
        (ok, tc)
    }
}

#[inline(always)]
pub(super) unsafe fn packet_closest<const NEG: bool>(
    p: &TriPacket,
    r: &SseRay,
    tfar: f32,
    out: &mut PacketHits,
) -> (u32, u32) {
    // SAFETY (whole function): SSE2 is part of x86-64; `out`'s arrays hold 4 floats.
    unsafe {
        let e = tri4(p, r);
        let fallback = _mm_movemask_ps(e.is_zero) as u32;
        if _mm_movemask_ps(e.strict) == 0 {
            return (0, fallback);
        }
        let det = e.det();
        let tfar = _mm_set1_ps(tfar);
        let (reach, z) = dominant_slab4::<NEG>(&e, r, tfar);
        let ok = _mm_and_ps(e.strict, reach);
        if _mm_movemask_ps(ok) == 0 {
            return (0, fallback);
        }
        let inv = _mm_div_ps(_mm_set1_ps(1.0), det);
        let hi = _mm_min_ps(r.t_hi, tfar);
        let (accepted, t) = accept4::<NEG>(p, r, _mm_mul_ps(t_scaled(&e, z), inv), hi);
        let ok = _mm_and_ps(ok, accepted);
        let hits = _mm_movemask_ps(ok) as u32;
        if hits != 0 {
            _mm_storeu_ps(out.t.as_mut_ptr(), t);
            _mm_storeu_ps(out.u.as_mut_ptr(), _mm_mul_ps(e.v, inv));
            _mm_storeu_ps(out.v.as_mut_ptr(), _mm_mul_ps(e.w, inv));
        }
        (hits, fallback)
    }
}

#[inline(always)]
pub(super) unsafe fn packet_occluded<const NEG: bool>(p: &TriPacket, r: &SseRay) -> (u32, u32) {
    // SAFETY (whole function): SSE2 is part of x86-64.
    unsafe {
        let e = tri4(p, r);
        let fallback = _mm_movemask_ps(e.is_zero) as u32;
        if _mm_movemask_ps(e.strict) == 0 {
            return (0, fallback);
        }
        let det = e.det();
        let (reach, z) = dominant_slab4::<NEG>(&e, r, r.t_hi);
        let ok = _mm_and_ps(e.strict, reach);
        if _mm_movemask_ps(ok) == 0 {
            return (0, fallback);
        }
        let inv = _mm_div_ps(_mm_set1_ps(1.0), det);
        let (accepted, _) = accept4::<NEG>(p, r, _mm_mul_ps(t_scaled(&e, z), inv), r.t_hi);
        let hits = _mm_movemask_ps(_mm_and_ps(ok, accepted)) as u32;
        (hits, fallback)
    }
}
