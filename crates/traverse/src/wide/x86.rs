//! SSE2, AVX2 and AVX-512 backends (x86-64).
//!
//! The box tests reproduce [`RayData::slab`] lane by lane: `_mm_max_ps(a, b)` and
//! `_mm_min_ps(a, b)` return `b` when either operand is NaN, so the running near / far
//! distance (never NaN) is always the second operand and a NaN slab distance is ignored.
//! The triangle test reproduces `sahara_geom::intersect::intersect_triangle` with the same
//! operations in the same order (Rust never contracts a multiply and an add into an FMA), and
//! reports lanes with an edge function exactly zero for the exact scalar fallback.

use super::kernel::{
    self, descend_ordered, FixedStack, Kernel, PacketHits, RayData, Stack, VecStack, FIXED_STACK,
};
use super::{TriPacket, WideBvh, WideNode};
use crate::{Hit, TraversalStats};
use sahara_geom::Ray;
use std::arch::x86_64::*;

/// The ray's constants for the 4-wide box and triangle tests.
#[derive(Clone, Copy)]
pub(crate) struct SseRay {
    origin: [__m128; 3],
    inv: [__m128; 3],
    /// The reciprocal direction scaled for far planes (positive and negative distances).
    inv_far: [__m128; 3],
    inv_far_neg: [__m128; 3],
    /// `max(tmin, -f32::MAX)` and `min(tmax, f32::MAX)`: the range check of [`accept4`] with
    /// its finiteness check folded in.
    t_lo: __m128,
    t_hi: __m128,
    box_tmin: __m128,
    /// Offsets (in floats, rows times `W`) of the near and far planes of each axis.
    near_off: [usize; 3],
    far_off: [usize; 3],
    /// Watertight test: origin and shear permuted to `(kx, ky, kz)`, and the offsets of the
    /// permuted axes in a packet's vertex rows.
    w_origin: [__m128; 3],
    w_shear: [__m128; 3],
    w_axis: [usize; 3],
    /// The far-plane factors of the dominant axis (`inv_far[kz]`, `inv_far_neg[kz]`), for
    /// [`dominant_slab4`].
    w_far: __m128,
    w_far_neg: __m128,
    /// The direction, for the benchmark-only Möller–Trumbore test ([`inexact`]).
    #[cfg(feature = "inexact-bench")]
    dir: [__m128; 3],
}

/// The three components of `v`, each broadcast to the four lanes (one shuffle each; with SSE2
/// a broadcast from memory takes a load and a shuffle).
#[inline(always)]
unsafe fn splat3(v: sahara_geom::Vec3A) -> [__m128; 3] {
    // SAFETY (whole function): SSE2 is part of x86-64.
    unsafe {
        let v: __m128 = v.into();
        [
            _mm_shuffle_ps::<0x00>(v, v),
            _mm_shuffle_ps::<0x55>(v, v),
            _mm_shuffle_ps::<0xaa>(v, v),
        ]
    }
}

/// The ray's constants. `SPLAT`: broadcast the origin, the reciprocal direction and the shear
/// from vector registers, one shuffle each (cheaper for SSE2, where a broadcast from memory is a
/// load and a shuffle); else from memory (one `vbroadcastss` with AVX, measured cheaper there).
#[inline(always)]
unsafe fn sse_ray<const W: usize, const SPLAT: bool>(rd: &RayData) -> SseRay {
    // SAFETY (whole function): SSE2 is part of x86-64.
    unsafe {
        let w = &rd.w;
        let (kx, ky, kz) = w.axes();
        // Indexing arrays, not `Vec3A` (whose `Index` is a branch per component: the dominant
        // axis of incoherent rays is unpredictable).
        let wo = w.origin().to_array();
        // `w.origin` and `w.inv_direction` are the ray's origin and reciprocal direction (also
        // before `RayData::finish`), and `far_factors` gives `rd.inv_far` / `rd.inv_far_neg`
        // bit for bit (the same multiplications).
        let (far_pos, far_neg) = sahara_geom::intersect::far_factors(w.inv_direction());
        let from_memory = |x: [f32; 3]| x.map(|c| _mm_set1_ps(c));
        SseRay {
            origin: if SPLAT {
                splat3(w.origin())
            } else {
                from_memory(rd.origin)
            },
            inv: if SPLAT {
                splat3(w.inv_direction())
            } else {
                from_memory(rd.inv)
            },
            inv_far: if SPLAT {
                splat3(far_pos)
            } else {
                from_memory(rd.inv_far)
            },
            inv_far_neg: if SPLAT {
                splat3(far_neg)
            } else {
                from_memory(rd.inv_far_neg)
            },
            t_lo: _mm_set1_ps(rd.tmin.max(-f32::MAX)),
            t_hi: _mm_set1_ps(rd.tmax.min(f32::MAX)),
            box_tmin: _mm_set1_ps(rd.box_tmin),
            near_off: rd.near_row.map(|r| r * W),
            far_off: rd.far_row.map(|r| r * W),
            w_origin: [
                _mm_set1_ps(wo[kx]),
                _mm_set1_ps(wo[ky]),
                _mm_set1_ps(wo[kz]),
            ],
            w_shear: if SPLAT {
                splat3(w.shear())
            } else {
                from_memory(w.shear().to_array())
            },
            w_axis: [kx, ky, kz],
            w_far: _mm_set1_ps(rd.inv_far[kz]),
            w_far_neg: _mm_set1_ps(rd.inv_far_neg[kz]),
            #[cfg(feature = "inexact-bench")]
            dir: rd.dir.map(|x| _mm_set1_ps(x)),
        }
    }
}

/// 4-wide slab test of lanes `off..off + 4` of a node; returns the hit mask of those lanes.
#[inline(always)]
unsafe fn node4<const W: usize, const NEG: bool>(
    node: &WideNode<W>,
    r: &SseRay,
    tfar: __m128,
    off: usize,
    dist: *mut f32,
) -> u32 {
    // SAFETY (whole function): rows hold `W` floats, `off + 4 <= W`, the node is 64-byte
    // aligned and `W` is a multiple of 4, so every load is in bounds and 16-byte aligned;
    // `dist` holds `W` floats.
    unsafe {
        let base = node.bounds.as_ptr().cast::<f32>().add(off);
        let mut near = r.box_tmin;
        let mut far = tfar;
        for a in 0..3 {
            let pn = _mm_load_ps(base.add(r.near_off[a]));
            let pf = _mm_load_ps(base.add(r.far_off[a]));
            let tn = _mm_mul_ps(_mm_sub_ps(pn, r.origin[a]), r.inv[a]);
            let d = _mm_sub_ps(pf, r.origin[a]);
            let mut tf = _mm_mul_ps(d, r.inv_far[a]);
            if NEG {
                tf = _mm_max_ps(tf, _mm_mul_ps(d, r.inv_far_neg[a]));
            }
            near = _mm_max_ps(tn, near);
            far = _mm_min_ps(tf, far);
        }
        _mm_storeu_ps(dist.add(off), near);
        _mm_movemask_ps(_mm_cmple_ps(near, far)) as u32
    }
}

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
unsafe fn accept4<const NEG: bool>(
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
unsafe fn packet_closest<const NEG: bool>(
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
unsafe fn packet_occluded<const NEG: bool>(p: &TriPacket, r: &SseRay) -> (u32, u32) {
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

/// The members every x86 backend shares: the ray's constants in SSE registers and the 4-wide
/// packet tests. They are not `target_feature` functions, so they are always inlined into the
/// backend's entry points, which compile them with their own features (VEX encoding under AVX2,
/// EVEX and 32 registers under AVX-512). The 256-bit constants of the 8-wide box test are
/// broadcast in `intersect_node`, which is inlined into the traversal loop, so they are
/// hoisted out of it (building them in `prepare` would need a `target_feature` function that
/// is not inlined).
macro_rules! sse_ray_and_packets {
    ($splat:expr) => {
        type Ray = SseRay;

        #[inline(always)]
        unsafe fn prepare(rd: &RayData) -> SseRay {
            // SAFETY: SSE2 is part of x86-64.
            unsafe { sse_ray::<W, { $splat }>(rd) }
        }

        #[inline(always)]
        unsafe fn intersect_packet<const NEG: bool>(
            p: &TriPacket,
            r: &SseRay,
            _: &RayData,
            tfar: f32,
            out: &mut PacketHits,
        ) -> (u32, u32) {
            // SAFETY: SSE2 is part of x86-64.
            unsafe { packet_closest::<NEG>(p, r, tfar, out) }
        }

        #[inline(always)]
        unsafe fn occlude_packet<const NEG: bool>(
            p: &TriPacket,
            r: &SseRay,
            _: &RayData,
        ) -> (u32, u32) {
            // SAFETY: SSE2 is part of x86-64.
            unsafe { packet_occluded::<NEG>(p, r) }
        }
    };
}

/// The SSE2 backend: 4 lanes at a time.
pub(crate) struct Sse;

impl<const W: usize> Kernel<W> for Sse {
    sse_ray_and_packets!(true);

    #[inline(always)]
    unsafe fn intersect_node<const NEG: bool>(
        node: &WideNode<W>,
        r: &SseRay,
        _: &RayData,
        tfar: f32,
        dist: &mut [f32; W],
    ) -> u32 {
        // SAFETY: `W` is a multiple of 4 (checked when the tree is built).
        unsafe {
            let tf = _mm_set1_ps(tfar);
            let mut mask = 0;
            let mut off = 0;
            while off < W {
                mask |= node4::<W, NEG>(node, r, tf, off, dist.as_mut_ptr()) << off;
                off += 4;
            }
            mask
        }
    }
}

/// The 8-wide slab test of an 8-wide node (`W == 8`) against `[box_tmin, tfar]`, exactly as
/// [`RayData::slab`]: writes the entry distances to `dist` and returns `(near, far)`, whose
/// lane-wise `near <= far` is the hit mask.
///
/// # Safety
/// AVX2 and FMA must be present; `W == 8`.
#[inline]
#[target_feature(enable = "avx2,fma")]
unsafe fn slabs8<const W: usize, const NEG: bool>(
    node: &WideNode<W>,
    r: &SseRay,
    rd: &RayData,
    tfar: f32,
    dist: &mut [f32; W],
) -> (__m256, __m256) {
    debug_assert_eq!(W, 8);
    // SAFETY: `W == 8`: rows hold 8 floats, 32-byte aligned (the node is 64-byte aligned and
    // rows are 32 bytes); `dist` holds 8 floats.
    unsafe {
        let base = node.bounds.as_ptr().cast::<f32>();
        let mut near = _mm256_set1_ps(rd.box_tmin);
        let mut far = _mm256_set1_ps(tfar);
        for a in 0..3 {
            let o = _mm256_set1_ps(rd.origin[a]);
            let pn = _mm256_load_ps(base.add(r.near_off[a]));
            let pf = _mm256_load_ps(base.add(r.far_off[a]));
            let tn = _mm256_mul_ps(_mm256_sub_ps(pn, o), _mm256_set1_ps(rd.inv[a]));
            let d = _mm256_sub_ps(pf, o);
            let mut tf = _mm256_mul_ps(d, _mm256_set1_ps(rd.inv_far[a]));
            if NEG {
                tf = _mm256_max_ps(tf, _mm256_mul_ps(d, _mm256_set1_ps(rd.inv_far_neg[a])));
            }
            near = _mm256_max_ps(tn, near);
            far = _mm256_min_ps(tf, far);
        }
        _mm256_storeu_ps(dist.as_mut_ptr(), near);
        (near, far)
    }
}

/// For every 8-bit mask, the positions of its set bits in increasing order, 3 bits each
/// (lowest first): the lane permutation that packs the set lanes at the bottom; the number of
/// set bits in bits 24..28 (AVX2 does not imply `popcnt`).
static COMPACT8: [u32; 256] = {
    let mut t = [0u32; 256];
    let mut m = 0;
    while m < 256 {
        let (mut p, mut k, mut b) = (0u32, 0u32, 0u32);
        while b < 8 {
            if (m >> b) & 1 != 0 {
                p |= b << (3 * k);
                k += 1;
            }
            b += 1;
        }
        t[m] = p | k << 24;
        m += 1;
    }
    t
};

/// [`descend_ordered`] of an 8-wide node in AVX2 registers: the node's order for the ray's
/// octant becomes a lane permutation (far first), the hit lanes are packed at the bottom with
/// [`COMPACT8`], and the children with their entry distances are written to the stack as two
/// 256-bit stores; the nearest (the last hit lane) is returned instead of pushed.
///
/// # Safety
/// AVX2 must be present; `W == 8`.
#[inline]
#[target_feature(enable = "avx2,fma")]
unsafe fn descend8<const W: usize, St: Stack>(
    node: &WideNode<W>,
    mask: u32,
    dist: &[f32; W],
    rd: &RayData,
    stack: &mut St,
) -> Option<u32> {
    debug_assert_eq!(W, 8);
    debug_assert_eq!(mask & !node.valid, 0, "an unused slot's empty box was hit");
    if mask == 0 {
        return None;
    }
    if mask & (mask - 1) == 0 {
        return Some(node.children[mask.trailing_zeros() as usize & (W - 1)]);
    }
    // SAFETY: `W == 8`: `children` and `dist` hold 8 lanes; `spare(8)` makes room for the two
    // stores; `Entry` is `repr(C)` (`child`, `dist`).
    unsafe {
        let lanes = _mm256_setr_epi32(0, 1, 2, 3, 4, 5, 6, 7);
        let three = _mm256_set1_epi32(3);
        let seven = _mm256_set1_epi32(7);
        // Lane i: the slot at stored position `i ^ order_xor` (far to near). `order_xor` is 0
        // or 7; masked so that the compiler knows every shift is below 32 (else the variable
        // shift gets a select for out-of-range counts).
        let shift = _mm256_mullo_epi32(
            _mm256_xor_si256(lanes, _mm256_set1_epi32((rd.order_xor & 7) as i32)),
            three,
        );
        let p = node.order_bits(rd.order_q) as i32;
        let idx = _mm256_and_si256(_mm256_srlv_epi32(_mm256_set1_epi32(p), shift), seven);
        // The hit bit of each lane's slot, in the sign bit.
        let hit = _mm256_slli_epi32::<31>(_mm256_srlv_epi32(_mm256_set1_epi32(mask as i32), idx));
        let m = _mm256_movemask_ps(_mm256_castsi256_ps(hit)) as u32;
        let packed = COMPACT8[m as usize & 255];
        let n = (packed >> 24) as usize;
        let packed = packed as i32;
        let pick = _mm256_and_si256(
            _mm256_srlv_epi32(_mm256_set1_epi32(packed), _mm256_mullo_epi32(lanes, three)),
            seven,
        );
        let fin = _mm256_permutevar8x32_epi32(idx, pick);
        let c = _mm256_permutevar8x32_epi32(_mm256_loadu_si256(node.children.as_ptr().cast()), fin);
        let d = _mm256_castps_si256(_mm256_permutevar8x32_ps(
            _mm256_loadu_ps(dist.as_ptr()),
            fin,
        ));
        let lo = _mm256_unpacklo_epi32(c, d);
        let hi = _mm256_unpackhi_epi32(c, d);
        let out = stack.spare(8).cast::<__m256i>();
        _mm256_storeu_si256(out, _mm256_permute2x128_si256::<0x20>(lo, hi));
        _mm256_storeu_si256(out.add(1), _mm256_permute2x128_si256::<0x31>(lo, hi));
        stack.grow(n - 1);
        let near = _mm256_permutevar8x32_epi32(c, _mm256_set1_epi32(n as i32 - 1));
        Some(_mm256_cvtsi256_si32(near) as u32)
    }
}

/// The AVX2 backend: 8-wide box tests in 256-bit registers (4-wide nodes and triangle
/// packets use the SSE code, compiled with VEX encoding).
pub(crate) struct Avx2;

impl<const W: usize> Kernel<W> for Avx2 {
    sse_ray_and_packets!(false);

    const NESTED_LOOPS: bool = true;

    #[inline]
    #[target_feature(enable = "avx2,fma")]
    unsafe fn intersect_node<const NEG: bool>(
        node: &WideNode<W>,
        r: &SseRay,
        rd: &RayData,
        tfar: f32,
        dist: &mut [f32; W],
    ) -> u32 {
        if W != 8 {
            // SAFETY: as for `Sse`.
            return unsafe { <Sse as Kernel<W>>::intersect_node::<NEG>(node, r, rd, tfar, dist) };
        }
        // SAFETY: `W == 8`; the caller guarantees AVX2 and FMA.
        unsafe {
            let (near, far) = slabs8::<W, NEG>(node, r, rd, tfar, dist);
            _mm256_movemask_ps(_mm256_cmp_ps::<_CMP_LE_OQ>(near, far)) as u32
        }
    }
    #[inline]
    #[target_feature(enable = "avx2,fma")]
    unsafe fn descend<St: Stack>(
        node: &WideNode<W>,
        mask: u32,
        dist: &[f32; W],
        rd: &RayData,
        stack: &mut St,
    ) -> Option<u32> {
        if W != 8 {
            return descend_ordered(node, mask, dist, rd, stack);
        }
        // SAFETY: `W == 8`; the caller guarantees the features.
        unsafe { descend8(node, mask, dist, rd, stack) }
    }
}

/// The AVX-512 backend: the AVX2 kernels compiled with AVX-512F and AVX-512VL as well. The
/// vectors stay 256 bits wide (no frequency penalty); the 8-wide box test's mask comes from a
/// mask register, and the entry points, into which everything is inlined, have 32 vector
/// registers (the ray's constants no longer spill). +2–3% over [`Avx2`] on Zen 4.
pub(crate) struct Avx512;

impl<const W: usize> Kernel<W> for Avx512 {
    sse_ray_and_packets!(false);

    const NESTED_LOOPS: bool = true;

    #[inline]
    #[target_feature(enable = "avx2,fma,avx512f,avx512vl")]
    unsafe fn intersect_node<const NEG: bool>(
        node: &WideNode<W>,
        r: &SseRay,
        rd: &RayData,
        tfar: f32,
        dist: &mut [f32; W],
    ) -> u32 {
        if W != 8 {
            // SAFETY: as for `Sse`.
            return unsafe { <Sse as Kernel<W>>::intersect_node::<NEG>(node, r, rd, tfar, dist) };
        }
        // SAFETY: `W == 8`; the caller guarantees the features.
        unsafe {
            let (near, far) = slabs8::<W, NEG>(node, r, rd, tfar, dist);
            u32::from(_mm256_cmp_ps_mask::<_CMP_LE_OQ>(near, far))
        }
    }
    #[inline]
    #[target_feature(enable = "avx2,fma,avx512f,avx512vl")]
    unsafe fn descend<St: Stack>(
        node: &WideNode<W>,
        mask: u32,
        dist: &[f32; W],
        rd: &RayData,
        stack: &mut St,
    ) -> Option<u32> {
        if W != 8 {
            return descend_ordered(node, mask, dist, rd, stack);
        }
        // SAFETY: `W == 8`; the caller guarantees the features.
        unsafe { descend8(node, mask, dist, rd, stack) }
    }
}

/// Generates the entry points of a backend: a fast path (inline stack, `tmin >= 0`) and an
/// out-of-line path for deep trees and rays with `tmin < 0`. The entry points are `unsafe`:
/// the caller guarantees the backend's CPU features.
macro_rules! entry_points {
    ($kernel:ty, [$($feat:tt)*], $closest:ident, $any:ident, $closest_slow:ident, $any_slow:ident) => {
        $($feat)*
        pub(crate) unsafe fn $closest<const W: usize, S: TraversalStats>(
            bvh: &WideBvh<W>,
            ray: &Ray,
            stats: &mut S,
        ) -> Hit {
            if bvh.max_stack > FIXED_STACK || ray.tmin < 0.0 {
                // SAFETY: the caller guarantees the CPU features.
                #[allow(unused_unsafe)]
                return unsafe { $closest_slow(bvh, ray, stats) };
            }
            // SAFETY: the caller guarantees the CPU features; the stack bound fits.
            #[allow(unused_unsafe)]
            unsafe {
                kernel::closest_hit::<$kernel, W, S, _, false>(bvh, ray, stats, &mut FixedStack::new(&mut FixedStack::buffer()))
            }
        }

        $($feat)*
        pub(crate) unsafe fn $any<const W: usize, S: TraversalStats>(
            bvh: &WideBvh<W>,
            ray: &Ray,
            stats: &mut S,
        ) -> bool {
            if bvh.max_stack > FIXED_STACK || ray.tmin < 0.0 {
                // SAFETY: the caller guarantees the CPU features.
                #[allow(unused_unsafe)]
                return unsafe { $any_slow(bvh, ray, stats) };
            }
            // SAFETY: the caller guarantees the CPU features; the stack bound fits.
            #[allow(unused_unsafe)]
            unsafe {
                kernel::any_hit::<$kernel, W, S, _, false>(bvh, ray, stats, &mut FixedStack::new(&mut FixedStack::buffer()))
            }
        }

        #[inline(never)]
        $($feat)*
        unsafe fn $closest_slow<const W: usize, S: TraversalStats>(
            bvh: &WideBvh<W>,
            ray: &Ray,
            stats: &mut S,
        ) -> Hit {
            let neg = ray.tmin < 0.0;
            // SAFETY: the caller guarantees the CPU features; `FixedStack` only when the
            // bound fits.
            #[allow(unused_unsafe)]
            unsafe {
                if bvh.max_stack <= FIXED_STACK {
                    let mut buf = FixedStack::buffer();
                    let st = &mut FixedStack::new(&mut buf);
                    return if neg {
                        kernel::closest_hit::<$kernel, W, S, _, true>(bvh, ray, stats, st)
                    } else {
                        kernel::closest_hit::<$kernel, W, S, _, false>(bvh, ray, stats, st)
                    };
                }
                let st = &mut VecStack(Vec::with_capacity(bvh.max_stack));
                if neg {
                    kernel::closest_hit::<$kernel, W, S, _, true>(bvh, ray, stats, st)
                } else {
                    kernel::closest_hit::<$kernel, W, S, _, false>(bvh, ray, stats, st)
                }
            }
        }

        #[inline(never)]
        $($feat)*
        unsafe fn $any_slow<const W: usize, S: TraversalStats>(
            bvh: &WideBvh<W>,
            ray: &Ray,
            stats: &mut S,
        ) -> bool {
            let neg = ray.tmin < 0.0;
            // SAFETY: as above.
            #[allow(unused_unsafe)]
            unsafe {
                if bvh.max_stack <= FIXED_STACK {
                    let mut buf = FixedStack::buffer();
                    let st = &mut FixedStack::new(&mut buf);
                    return if neg {
                        kernel::any_hit::<$kernel, W, S, _, true>(bvh, ray, stats, st)
                    } else {
                        kernel::any_hit::<$kernel, W, S, _, false>(bvh, ray, stats, st)
                    };
                }
                let st = &mut VecStack(Vec::with_capacity(bvh.max_stack));
                if neg {
                    kernel::any_hit::<$kernel, W, S, _, true>(bvh, ray, stats, st)
                } else {
                    kernel::any_hit::<$kernel, W, S, _, false>(bvh, ray, stats, st)
                }
            }
        }
    };
}

// SSE2 is part of x86-64: the SSE2 entry points are always safe to call there.
entry_points!(
    Sse,
    [],
    closest_hit_sse2,
    any_hit_sse2,
    closest_sse2_slow,
    any_sse2_slow
);
entry_points!(
    Avx2,
    [#[target_feature(enable = "avx2,fma")]],
    closest_hit_avx2,
    any_hit_avx2,
    closest_avx2_slow,
    any_avx2_slow
);
entry_points!(
    Avx512,
    [#[target_feature(enable = "avx2,fma,avx512f,avx512vl")]],
    closest_hit_avx512,
    any_hit_avx512,
    closest_avx512_slow,
    any_avx512_slow
);

/// Benchmark only (cargo feature `inexact-bench`, off by default, never a [`Backend`]): the
/// AVX2 kernels with the exact watertight triangle test replaced by a plain 4-wide
/// Möller–Trumbore test (no shear, no `f64` fallback, no `accept_hit` bounds clamp). Its
/// answers are *not* the reference's; it exists to price exactness.
///
/// [`Backend`]: super::Backend
#[cfg(feature = "inexact-bench")]
pub(crate) mod inexact {
    use super::*;

    pub(crate) struct Avx2Mt;

    /// Möller–Trumbore on the 4 lanes of a packet against `[lo, hi]`: `(mask, t, u, v)`.
    #[inline(always)]
    unsafe fn mt4(
        p: &TriPacket,
        r: &SseRay,
        lo: __m128,
        hi: __m128,
    ) -> (u32, __m128, __m128, __m128) {
        // SAFETY (whole function): the packet is 16-byte aligned, rows hold 4 floats.
        unsafe {
            let base = p.v.as_ptr().cast::<f32>();
            let ld = |k: usize, a: usize| _mm_load_ps(base.add(k * 12 + a * 4));
            let v0 = [ld(0, 0), ld(0, 1), ld(0, 2)];
            let e1 = [0, 1, 2].map(|a| _mm_sub_ps(ld(1, a), v0[a]));
            let e2 = [0, 1, 2].map(|a| _mm_sub_ps(ld(2, a), v0[a]));
            let d = r.dir;
            let cross = |a: [__m128; 3], b: [__m128; 3]| {
                [
                    _mm_sub_ps(_mm_mul_ps(a[1], b[2]), _mm_mul_ps(a[2], b[1])),
                    _mm_sub_ps(_mm_mul_ps(a[2], b[0]), _mm_mul_ps(a[0], b[2])),
                    _mm_sub_ps(_mm_mul_ps(a[0], b[1]), _mm_mul_ps(a[1], b[0])),
                ]
            };
            let dot = |a: [__m128; 3], b: [__m128; 3]| {
                _mm_add_ps(
                    _mm_add_ps(_mm_mul_ps(a[0], b[0]), _mm_mul_ps(a[1], b[1])),
                    _mm_mul_ps(a[2], b[2]),
                )
            };
            let pv = cross(d, e2);
            let det = dot(e1, pv);
            let inv = _mm_div_ps(_mm_set1_ps(1.0), det);
            let sv = [0, 1, 2].map(|a| _mm_sub_ps(r.origin[a], v0[a]));
            let u = _mm_mul_ps(dot(sv, pv), inv);
            let qv = cross(sv, e1);
            let v = _mm_mul_ps(dot(d, qv), inv);
            let t = _mm_mul_ps(dot(e2, qv), inv);
            let zero = _mm_setzero_ps();
            let ok = _mm_and_ps(
                _mm_and_ps(_mm_cmpge_ps(u, zero), _mm_cmpge_ps(v, zero)),
                _mm_and_ps(
                    _mm_cmple_ps(_mm_add_ps(u, v), _mm_set1_ps(1.0)),
                    _mm_and_ps(_mm_cmpge_ps(t, lo), _mm_cmple_ps(t, hi)),
                ),
            );
            let ok = _mm_and_ps(ok, _mm_cmpneq_ps(det, zero));
            (_mm_movemask_ps(ok) as u32, t, u, v)
        }
    }

    impl<const W: usize> Kernel<W> for Avx2Mt {
        type Ray = SseRay;

        #[inline(always)]
        unsafe fn prepare(rd: &RayData) -> SseRay {
            // SAFETY: SSE2 is part of x86-64.
            unsafe { sse_ray::<W, false>(rd) }
        }

        #[inline]
        #[target_feature(enable = "avx2,fma")]
        unsafe fn intersect_node<const NEG: bool>(
            node: &WideNode<W>,
            r: &SseRay,
            rd: &RayData,
            tfar: f32,
            dist: &mut [f32; W],
        ) -> u32 {
            // SAFETY: the caller guarantees AVX2 and FMA.
            unsafe { <Avx2 as Kernel<W>>::intersect_node::<NEG>(node, r, rd, tfar, dist) }
        }

        #[inline(always)]
        unsafe fn intersect_packet<const NEG: bool>(
            p: &TriPacket,
            r: &SseRay,
            _: &RayData,
            tfar: f32,
            out: &mut PacketHits,
        ) -> (u32, u32) {
            // SAFETY: SSE2 is part of x86-64; `out`'s arrays hold 4 floats.
            unsafe {
                let hi = _mm_min_ps(r.t_hi, _mm_set1_ps(tfar));
                let (m, t, u, v) = mt4(p, r, r.t_lo, hi);
                if m != 0 {
                    _mm_storeu_ps(out.t.as_mut_ptr(), t);
                    _mm_storeu_ps(out.u.as_mut_ptr(), u);
                    _mm_storeu_ps(out.v.as_mut_ptr(), v);
                }
                (m, 0)
            }
        }

        #[inline(always)]
        unsafe fn occlude_packet<const NEG: bool>(
            p: &TriPacket,
            r: &SseRay,
            _: &RayData,
        ) -> (u32, u32) {
            // SAFETY: SSE2 is part of x86-64.
            unsafe { (mt4(p, r, r.t_lo, r.t_hi).0, 0) }
        }
    }

    entry_points!(
        Avx2Mt,
        [#[target_feature(enable = "avx2,fma")]],
        closest_hit_avx2_mt,
        any_hit_avx2_mt,
        closest_avx2_mt_slow,
        any_avx2_mt_slow
    );
}
