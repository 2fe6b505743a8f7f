//! The 4-wide Möller–Trumbore test of [`Precision::Fast`]: lane by lane, the operations of
//! [`intersect_triangle_fast`] in the same order (Rust never contracts a multiply and an add
//! into an FMA), so each lane's answer is the reference's bit for bit.
//!
//! The edge tests need no division: `u` and `v`, their signs flipped by the determinant's, are
//! compared with 0 and `|det|`; a packet with no lane passing returns before the divide. The
//! distance of the passing lanes goes through the watertight test's [`accept4`] (the hit rule
//! of every triangle test, [`accept_hit_at`]), which is what makes the traversal agree with a
//! brute-force scan. A degenerate triangle's lane holds NaN vertices, so its determinant is NaN
//! and it never passes (the reference rejects it in [`accept_hit_at`]).
//!
//! [`Precision::Fast`]: crate::Precision::Fast
//! [`intersect_triangle_fast`]: sahara_geom::intersect::intersect_triangle_fast
//! [`accept_hit_at`]: sahara_geom::intersect::accept_hit_at

use super::kernel::PacketHits;
use super::watertight::accept4;
use super::{SseRay, TriPacket};
use std::arch::x86_64::*;

/// What the edge tests leave for the distance: the unscaled barycentrics, the determinant, the
/// vectors of the distance's dot product and the mask of lanes that passed.
struct Edges {
    u: __m128,
    v: __m128,
    det: __m128,
    e2: [__m128; 3],
    q: [__m128; 3],
    pass: __m128,
}

/// `(a.y b.z - a.z b.y, a.z b.x - a.x b.z, a.x b.y - a.y b.x)`.
#[inline(always)]
unsafe fn cross(a: [__m128; 3], b: [__m128; 3]) -> [__m128; 3] {
    // SAFETY (whole function): SSE2 is part of x86-64.
    unsafe {
        [
            _mm_sub_ps(_mm_mul_ps(a[1], b[2]), _mm_mul_ps(a[2], b[1])),
            _mm_sub_ps(_mm_mul_ps(a[2], b[0]), _mm_mul_ps(a[0], b[2])),
            _mm_sub_ps(_mm_mul_ps(a[0], b[1]), _mm_mul_ps(a[1], b[0])),
        ]
    }
}

/// `(a.x b.x + a.y b.y) + a.z b.z`.
#[inline(always)]
unsafe fn dot(a: [__m128; 3], b: [__m128; 3]) -> __m128 {
    // SAFETY (whole function): SSE2 is part of x86-64.
    unsafe {
        _mm_add_ps(
            _mm_add_ps(_mm_mul_ps(a[0], b[0]), _mm_mul_ps(a[1], b[1])),
            _mm_mul_ps(a[2], b[2]),
        )
    }
}

/// The edge tests of the 4 lanes (`d`: the direction, broadcast).
#[inline(always)]
unsafe fn edges(p: &TriPacket, r: &SseRay, d: &[__m128; 3]) -> Edges {
    // SAFETY (whole function): the packet is 16-byte aligned and its vertex rows hold 4
    // floats each.
    unsafe {
        let base = p.v.as_ptr().cast::<f32>();
        let ld = |k: usize, a: usize| _mm_load_ps(base.add(k * 12 + a * 4));
        let v0 = [ld(0, 0), ld(0, 1), ld(0, 2)];
        let e1 = [0, 1, 2].map(|a| _mm_sub_ps(ld(1, a), v0[a]));
        let e2 = [0, 1, 2].map(|a| _mm_sub_ps(ld(2, a), v0[a]));
        let d = *d;
        let pv = cross(d, e2);
        let det = dot(e1, pv);
        let s = [0, 1, 2].map(|a| _mm_sub_ps(r.origin[a], v0[a]));
        let u = dot(s, pv);
        let q = cross(s, e1);
        let v = dot(d, q);
        let sign_bit = _mm_set1_ps(-0.0);
        let sign = _mm_and_ps(det, sign_bit);
        let adet = _mm_andnot_ps(sign_bit, det);
        let us = _mm_xor_ps(u, sign);
        let vs = _mm_xor_ps(v, sign);
        let zero = _mm_setzero_ps();
        let pass = _mm_and_ps(
            _mm_and_ps(_mm_cmpgt_ps(adet, zero), _mm_cmpge_ps(us, zero)),
            _mm_and_ps(
                _mm_cmpge_ps(vs, zero),
                _mm_cmple_ps(_mm_add_ps(us, vs), adet),
            ),
        );
        Edges {
            u,
            v,
            det,
            e2,
            q,
            pass,
        }
    }
}

/// Closest-hit packet test against `[tmin, min(tmax, tfar)]`: `(hit mask, 0)` (no lane needs
/// a scalar fallback), with `t`, `u`, `v` written to `out` when a lane hits.
#[inline(always)]
pub(super) unsafe fn packet_closest<const NEG: bool>(
    p: &TriPacket,
    r: &SseRay,
    d: &[__m128; 3],
    tfar: f32,
    out: &mut PacketHits,
) -> (u32, u32) {
    // SAFETY (whole function): SSE2 is part of x86-64; `out`'s arrays hold 4 floats.
    unsafe {
        let e = edges(p, r, d);
        if _mm_movemask_ps(e.pass) == 0 {
            return (0, 0);
        }
        let inv = _mm_div_ps(_mm_set1_ps(1.0), e.det);
        let hi = _mm_min_ps(r.t_hi, _mm_set1_ps(tfar));
        let (accepted, t) = accept4::<NEG>(p, r, _mm_mul_ps(dot(e.e2, e.q), inv), hi);
        let hits = _mm_movemask_ps(_mm_and_ps(e.pass, accepted)) as u32;
        if hits != 0 {
            _mm_storeu_ps(out.t.as_mut_ptr(), t);
            _mm_storeu_ps(out.u.as_mut_ptr(), _mm_mul_ps(e.u, inv));
            _mm_storeu_ps(out.v.as_mut_ptr(), _mm_mul_ps(e.v, inv));
        }
        (hits, 0)
    }
}

/// Any-hit packet test against `[tmin, tmax]`: `(hit mask, 0)`.
#[inline(always)]
pub(super) unsafe fn packet_occluded<const NEG: bool>(
    p: &TriPacket,
    r: &SseRay,
    d: &[__m128; 3],
) -> (u32, u32) {
    // SAFETY (whole function): SSE2 is part of x86-64.
    unsafe {
        let e = edges(p, r, d);
        if _mm_movemask_ps(e.pass) == 0 {
            return (0, 0);
        }
        let inv = _mm_div_ps(_mm_set1_ps(1.0), e.det);
        let (accepted, _) = accept4::<NEG>(p, r, _mm_mul_ps(dot(e.e2, e.q), inv), r.t_hi);
        (_mm_movemask_ps(_mm_and_ps(e.pass, accepted)) as u32, 0)
    }
}
