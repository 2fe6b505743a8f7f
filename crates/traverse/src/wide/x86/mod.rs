//! SSE2, AVX2 and AVX-512 backends (x86-64), one file per backend (`sse2.rs`, `avx2.rs`,
//! `avx512.rs`) and one per triangle test (`watertight.rs` for [`Precision::Exact`],
//! `moller.rs` for [`Precision::Fast`]), on the ray constants and entry points of this file.
//!
//! [`Precision::Exact`]: crate::Precision::Exact
//! [`Precision::Fast`]: crate::Precision::Fast
//!
//! The box tests reproduce [`RayData::slab`] lane by lane: `_mm_max_ps(a, b)` and
//! `_mm_min_ps(a, b)` return `b` when either operand is NaN, so the running near / far
//! distance (never NaN) is always the second operand and a NaN slab distance is ignored.
//! The triangle test reproduces `sahara_geom::intersect::intersect_triangle` with the same
//! operations in the same order (Rust never contracts a multiply and an add into an FMA), and
//! reports lanes with an edge function exactly zero for the exact scalar fallback.

use super::kernel::{self, FixedStack, PacketHits, RayData, VecStack, FIXED_STACK};
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
        }
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
            unsafe { super::sse_ray::<W, { $splat }>(rd) }
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
            unsafe { super::packet_closest::<NEG>(p, r, tfar, out) }
        }

        #[inline(always)]
        unsafe fn occlude_packet<const NEG: bool>(
            p: &TriPacket,
            r: &SseRay,
            _: &RayData,
        ) -> (u32, u32) {
            // SAFETY: SSE2 is part of x86-64.
            unsafe { super::packet_occluded::<NEG>(p, r) }
        }
    };
}

mod avx2;
mod avx512;
mod moller;
mod sse2;
mod watertight;

pub(crate) use avx2::Avx2;
pub(crate) use avx512::Avx512;
pub(crate) use sse2::Sse;
use watertight::{packet_closest, packet_occluded};

/// A backend `K` with the Möller–Trumbore packet tests of [`Precision::Fast`]
/// (`moller.rs`) in place of the watertight ones: the same box tests, descent and loops.
///
/// [`Precision::Fast`]: crate::Precision::Fast
pub(crate) struct Fast<K>(std::marker::PhantomData<K>);

/// The ray of [`Fast`]: the backend's ray and the direction (which only the Möller–Trumbore
/// test needs, so the exact kernels do not broadcast it).
#[derive(Clone, Copy)]
pub(crate) struct FastRay {
    base: SseRay,
    dir: [__m128; 3],
}

impl<const W: usize, K: kernel::Kernel<W, Ray = SseRay>> kernel::Kernel<W> for Fast<K> {
    type Ray = FastRay;

    const NESTED_LOOPS: bool = K::NESTED_LOOPS;

    #[inline(always)]
    unsafe fn prepare(rd: &RayData) -> FastRay {
        // SAFETY: forwarded from the caller; SSE2 is part of x86-64.
        unsafe {
            FastRay {
                base: K::prepare(rd),
                dir: rd.dir.map(|x| _mm_set1_ps(x)),
            }
        }
    }

    #[inline(always)]
    unsafe fn intersect_node<const NEG: bool>(
        node: &WideNode<W>,
        r: &FastRay,
        rd: &RayData,
        tfar: f32,
        dist: &mut [f32; W],
    ) -> u32 {
        // SAFETY: forwarded from the caller.
        unsafe { K::intersect_node::<NEG>(node, &r.base, rd, tfar, dist) }
    }

    #[inline(always)]
    unsafe fn descend<St: kernel::Stack>(
        node: &WideNode<W>,
        mask: u32,
        dist: &[f32; W],
        rd: &RayData,
        stack: &mut St,
    ) -> Option<u32> {
        // SAFETY: forwarded from the caller.
        unsafe { K::descend(node, mask, dist, rd, stack) }
    }

    #[inline(always)]
    unsafe fn intersect_packet<const NEG: bool>(
        p: &TriPacket,
        r: &FastRay,
        _: &RayData,
        tfar: f32,
        out: &mut PacketHits,
    ) -> (u32, u32) {
        // SAFETY: SSE2 is part of x86-64.
        unsafe { moller::packet_closest::<NEG>(p, &r.base, &r.dir, tfar, out) }
    }

    #[inline(always)]
    unsafe fn occlude_packet<const NEG: bool>(
        p: &TriPacket,
        r: &FastRay,
        _: &RayData,
    ) -> (u32, u32) {
        // SAFETY: SSE2 is part of x86-64.
        unsafe { moller::packet_occluded::<NEG>(p, &r.base, &r.dir) }
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
            slow_path!(kernel::closest_hit, $kernel, bvh, ray, stats)
        }

        #[inline(never)]
        $($feat)*
        unsafe fn $any_slow<const W: usize, S: TraversalStats>(
            bvh: &WideBvh<W>,
            ray: &Ray,
            stats: &mut S,
        ) -> bool {
            slow_path!(kernel::any_hit, $kernel, bvh, ray, stats)
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
entry_points!(
    Fast<Sse>,
    [],
    closest_hit_sse2_fast,
    any_hit_sse2_fast,
    closest_sse2_fast_slow,
    any_sse2_fast_slow
);
entry_points!(
    Fast<Avx2>,
    [#[target_feature(enable = "avx2,fma")]],
    closest_hit_avx2_fast,
    any_hit_avx2_fast,
    closest_avx2_fast_slow,
    any_avx2_fast_slow
);
entry_points!(
    Fast<Avx512>,
    [#[target_feature(enable = "avx2,fma,avx512f,avx512vl")]],
    closest_hit_avx512_fast,
    any_hit_avx512_fast,
    closest_avx512_fast_slow,
    any_avx512_fast_slow
);
