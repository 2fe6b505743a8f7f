//! SSE2 and AVX2 backends (x86-64).
//!
//! The box tests reproduce [`RayData::slab`] lane by lane: `_mm_max_ps(a, b)` and
//! `_mm_min_ps(a, b)` return `b` when either operand is NaN, so the running near / far
//! distance (never NaN) is always the second operand and a NaN slab distance is ignored.
//! The triangle test reproduces `sahara_geom::intersect::intersect_triangle` with the same
//! operations in the same order (Rust never contracts a multiply and an add into an FMA), and
//! reports lanes with an edge function exactly zero for the exact scalar fallback.

use super::kernel::{
    self, FixedStack, Kernel, PacketHits, RayData, VecStack, FIXED_STACK, ROBUST_NEG_FAR_SCALE,
};
use super::{TriPacket, WideBvh, WideNode};
use crate::{Hit, TraversalStats};
use sahara_geom::intersect::ROBUST_FAR_SCALE;
use sahara_geom::Ray;
use std::arch::x86_64::*;

/// The ray's constants for the 4-wide box and triangle tests.
#[derive(Clone, Copy)]
pub(crate) struct SseRay {
    origin: [__m128; 3],
    inv: [__m128; 3],
    box_tmin: __m128,
    tmin: __m128,
    tmax: __m128,
    /// Offsets (in floats, rows times `W`) of the near and far planes of each axis.
    near_off: [usize; 3],
    far_off: [usize; 3],
    /// Watertight test: origin and shear permuted to `(kx, ky, kz)`, and the offsets of the
    /// permuted axes in a packet's vertex rows.
    w_origin: [__m128; 3],
    w_shear: [__m128; 3],
    w_axis: [usize; 3],
}

#[inline(always)]
unsafe fn sse_ray<const W: usize>(rd: &RayData) -> SseRay {
    // SAFETY (whole function): SSE2 is part of x86-64.
    unsafe {
        let w = &rd.w;
        let (kx, ky, kz) = (w.kx, w.ky, w.kz);
        let o = rd.origin;
        SseRay {
            origin: [_mm_set1_ps(o[0]), _mm_set1_ps(o[1]), _mm_set1_ps(o[2])],
            inv: [
                _mm_set1_ps(rd.inv[0]),
                _mm_set1_ps(rd.inv[1]),
                _mm_set1_ps(rd.inv[2]),
            ],
            box_tmin: _mm_set1_ps(rd.box_tmin),
            tmin: _mm_set1_ps(rd.tmin),
            tmax: _mm_set1_ps(rd.tmax),
            near_off: rd.near_row.map(|r| r * W),
            far_off: rd.far_row.map(|r| r * W),
            w_origin: [
                _mm_set1_ps(w.origin[kx]),
                _mm_set1_ps(w.origin[ky]),
                _mm_set1_ps(w.origin[kz]),
            ],
            w_shear: [
                _mm_set1_ps(w.shear.x),
                _mm_set1_ps(w.shear.y),
                _mm_set1_ps(w.shear.z),
            ],
            w_axis: [kx, ky, kz],
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
        let scale = _mm_set1_ps(ROBUST_FAR_SCALE);
        let mut near = r.box_tmin;
        let mut far = tfar;
        for a in 0..3 {
            let pn = _mm_load_ps(base.add(r.near_off[a]));
            let pf = _mm_load_ps(base.add(r.far_off[a]));
            let tn = _mm_mul_ps(_mm_sub_ps(pn, r.origin[a]), r.inv[a]);
            let tf0 = _mm_mul_ps(_mm_sub_ps(pf, r.origin[a]), r.inv[a]);
            let mut tf = _mm_mul_ps(tf0, scale);
            if NEG {
                tf = _mm_max_ps(tf, _mm_mul_ps(tf0, _mm_set1_ps(ROBUST_NEG_FAR_SCALE)));
            }
            near = _mm_max_ps(tn, near);
            far = _mm_min_ps(tf, far);
        }
        _mm_storeu_ps(dist.add(off), near);
        _mm_movemask_ps(_mm_cmple_ps(near, far)) as u32
    }
}

/// The shared part of the 4-wide watertight test: `(u, v, w, t_scaled, det, ok, zero)`.
#[inline(always)]
unsafe fn tri4(p: &TriPacket, r: &SseRay) -> [__m128; 7] {
    // SAFETY (whole function): the packet is 16-byte aligned and its vertex rows hold 4
    // floats each; the axes are in 0..3.
    unsafe {
        let base = p.v.as_ptr().cast::<f32>();
        let [kx, ky, kz] = r.w_axis;
        let [ox, oy, oz] = r.w_origin;
        let [sx, sy, sz] = r.w_shear;
        // Vertex k, relative to the origin, sheared: (x, y, z·sz) as in the reference.
        let vert = |k: usize| {
            let row = base.add(k * 12);
            let dx = _mm_sub_ps(_mm_load_ps(row.add(kx * 4)), ox);
            let dy = _mm_sub_ps(_mm_load_ps(row.add(ky * 4)), oy);
            let dz = _mm_sub_ps(_mm_load_ps(row.add(kz * 4)), oz);
            (
                _mm_sub_ps(dx, _mm_mul_ps(sx, dz)),
                _mm_sub_ps(dy, _mm_mul_ps(sy, dz)),
                _mm_mul_ps(sz, dz),
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
        let neg = _mm_or_ps(
            _mm_or_ps(_mm_cmplt_ps(u, zero), _mm_cmplt_ps(v, zero)),
            _mm_cmplt_ps(w, zero),
        );
        let pos = _mm_or_ps(
            _mm_or_ps(_mm_cmpgt_ps(u, zero), _mm_cmpgt_ps(v, zero)),
            _mm_cmpgt_ps(w, zero),
        );
        let det = _mm_add_ps(_mm_add_ps(u, v), w);
        // det != 0 and not NaN, and the edge functions do not have mixed signs.
        let ok = _mm_andnot_ps(
            _mm_and_ps(neg, pos),
            _mm_and_ps(_mm_cmpneq_ps(det, zero), _mm_cmpord_ps(det, det)),
        );
        let t_scaled = _mm_add_ps(
            _mm_add_ps(_mm_mul_ps(u, az), _mm_mul_ps(v, bz)),
            _mm_mul_ps(w, cz),
        );
        [u, v, w, t_scaled, det, ok, is_zero]
    }
}

/// Distance checks of the watertight test; returns `(ok, t, 1 / det)`.
#[inline(always)]
unsafe fn tri4_range(r: &SseRay, t_scaled: __m128, det: __m128, ok: __m128) -> [__m128; 3] {
    // SAFETY (whole function): SSE2 is part of x86-64.
    unsafe {
        // ts = t_scaled * sign(det), ad = |det| (the reference multiplies by ±1.0, which only
        // flips the sign bit).
        let sign = _mm_and_ps(det, _mm_set1_ps(-0.0));
        let ts = _mm_xor_ps(t_scaled, sign);
        let ad = _mm_xor_ps(det, sign);
        let in_range = _mm_and_ps(
            _mm_cmpge_ps(ts, _mm_mul_ps(r.tmin, ad)),
            _mm_cmple_ps(ts, _mm_mul_ps(r.tmax, ad)),
        );
        let inv = _mm_div_ps(_mm_set1_ps(1.0), det);
        let t = _mm_mul_ps(t_scaled, inv);
        let t_ok = _mm_and_ps(_mm_cmpge_ps(t, r.tmin), _mm_cmple_ps(t, r.tmax));
        [_mm_and_ps(_mm_and_ps(ok, in_range), t_ok), t, inv]
    }
}

#[inline(always)]
unsafe fn packet_closest(p: &TriPacket, r: &SseRay, tfar: f32, out: &mut PacketHits) -> (u32, u32) {
    // SAFETY (whole function): SSE2 is part of x86-64; `out`'s arrays hold 4 floats.
    unsafe {
        let [_, v, w, t_scaled, det, ok, is_zero] = tri4(p, r);
        let pre = _mm_movemask_ps(ok) as u32;
        let fallback = _mm_movemask_ps(is_zero) as u32;
        if pre & !fallback == 0 {
            return (0, fallback);
        }
        let [ok, t, inv] = tri4_range(r, t_scaled, det, ok);
        let ok = _mm_and_ps(ok, _mm_cmple_ps(t, _mm_set1_ps(tfar)));
        let hits = _mm_movemask_ps(_mm_andnot_ps(is_zero, ok)) as u32;
        if hits != 0 {
            _mm_storeu_ps(out.t.as_mut_ptr(), t);
            _mm_storeu_ps(out.u.as_mut_ptr(), _mm_mul_ps(v, inv));
            _mm_storeu_ps(out.v.as_mut_ptr(), _mm_mul_ps(w, inv));
        }
        (hits, fallback)
    }
}

#[inline(always)]
unsafe fn packet_occluded(p: &TriPacket, r: &SseRay, t_out: &mut [f32; 4]) -> (u32, u32) {
    // SAFETY (whole function): SSE2 is part of x86-64; `t_out` holds 4 floats.
    unsafe {
        let [_, _, _, t_scaled, det, ok, is_zero] = tri4(p, r);
        let fallback = _mm_movemask_ps(is_zero) as u32;
        if _mm_movemask_ps(ok) as u32 & !fallback == 0 {
            return (0, fallback);
        }
        let [ok, t, _] = tri4_range(r, t_scaled, det, ok);
        let hits = _mm_movemask_ps(_mm_andnot_ps(is_zero, ok)) as u32;
        if hits != 0 {
            _mm_storeu_ps(t_out.as_mut_ptr(), t);
        }
        (hits, fallback)
    }
}

/// The SSE2 backend: 4 lanes at a time.
pub(crate) struct Sse;

impl<const W: usize> Kernel<W> for Sse {
    type Ray = SseRay;
    const ACCEPTS_HITS: bool = false;

    #[inline(always)]
    unsafe fn prepare(rd: &RayData) -> SseRay {
        // SAFETY: SSE2 is part of x86-64.
        unsafe { sse_ray::<W>(rd) }
    }

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

    #[inline(always)]
    unsafe fn intersect_packet(
        p: &TriPacket,
        r: &SseRay,
        _: &RayData,
        tfar: f32,
        out: &mut PacketHits,
    ) -> (u32, u32) {
        // SAFETY: SSE2 is part of x86-64.
        unsafe { packet_closest(p, r, tfar, out) }
    }

    #[inline(always)]
    unsafe fn occlude_packet(
        p: &TriPacket,
        r: &SseRay,
        _: &RayData,
        t: &mut [f32; 4],
    ) -> (u32, u32) {
        // SAFETY: SSE2 is part of x86-64.
        unsafe { packet_occluded(p, r, t) }
    }
}

/// The AVX2 backend: 8-wide box tests in 256-bit registers (4-wide nodes and triangle
/// packets use the SSE code, compiled with VEX encoding).
pub(crate) struct Avx2;

impl<const W: usize> Kernel<W> for Avx2 {
    type Ray = SseRay;
    const ACCEPTS_HITS: bool = false;

    #[inline(always)]
    unsafe fn prepare(rd: &RayData) -> SseRay {
        // SAFETY: SSE2 is part of x86-64. (The 256-bit constants are broadcast in
        // `intersect_node`, which is inlined into the traversal loop, so they are hoisted out of
        // it; building them here would need a `target_feature` function that is not inlined.)
        unsafe { sse_ray::<W>(rd) }
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
        if W != 8 {
            // SAFETY: as for `Sse`.
            return unsafe { <Sse as Kernel<W>>::intersect_node::<NEG>(node, r, rd, tfar, dist) };
        }
        // SAFETY: `W == 8`: rows hold 8 floats, 32-byte aligned (the node is 64-byte aligned
        // and rows are 32 bytes); `dist` holds 8 floats.
        unsafe {
            let base = node.bounds.as_ptr().cast::<f32>();
            let scale = _mm256_set1_ps(ROBUST_FAR_SCALE);
            let mut near = _mm256_set1_ps(rd.box_tmin);
            let mut far = _mm256_set1_ps(tfar);
            for a in 0..3 {
                let o = _mm256_set1_ps(rd.origin[a]);
                let inv = _mm256_set1_ps(rd.inv[a]);
                let pn = _mm256_load_ps(base.add(r.near_off[a]));
                let pf = _mm256_load_ps(base.add(r.far_off[a]));
                let tn = _mm256_mul_ps(_mm256_sub_ps(pn, o), inv);
                let tf0 = _mm256_mul_ps(_mm256_sub_ps(pf, o), inv);
                let mut tf = _mm256_mul_ps(tf0, scale);
                if NEG {
                    tf =
                        _mm256_max_ps(tf, _mm256_mul_ps(tf0, _mm256_set1_ps(ROBUST_NEG_FAR_SCALE)));
                }
                near = _mm256_max_ps(tn, near);
                far = _mm256_min_ps(tf, far);
            }
            _mm256_storeu_ps(dist.as_mut_ptr(), near);
            _mm256_movemask_ps(_mm256_cmp_ps::<_CMP_LE_OQ>(near, far)) as u32
        }
    }

    #[inline]
    #[target_feature(enable = "avx2,fma")]
    unsafe fn intersect_packet(
        p: &TriPacket,
        r: &SseRay,
        _: &RayData,
        tfar: f32,
        out: &mut PacketHits,
    ) -> (u32, u32) {
        // SAFETY: SSE2 is part of x86-64.
        unsafe { packet_closest(p, r, tfar, out) }
    }

    #[inline]
    #[target_feature(enable = "avx2,fma")]
    unsafe fn occlude_packet(
        p: &TriPacket,
        r: &SseRay,
        _: &RayData,
        t: &mut [f32; 4],
    ) -> (u32, u32) {
        // SAFETY: SSE2 is part of x86-64.
        unsafe { packet_occluded(p, r, t) }
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
