//! The AVX2 backend: 8-wide box tests and descent in 256-bit registers.

use super::kernel::{descend_ordered, Kernel, RayData, Stack};
use super::Sse;
use super::{PacketHits, SseRay, TriPacket, WideNode};
use std::arch::x86_64::*;

/// The 8-wide slab test of an 8-wide node (`W == 8`) against `[box_tmin, tfar]`, exactly as
/// [`RayData::slab`]: writes the entry distances to `dist` and returns `(near, far)`, whose
/// lane-wise `near <= far` is the hit mask.
///
/// # Safety
/// AVX2 and FMA must be present; `W == 8`.
#[inline]
#[target_feature(enable = "avx2,fma")]
pub(super) unsafe fn slabs8<const W: usize, const NEG: bool>(
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
pub(super) unsafe fn descend8<const W: usize, St: Stack>(
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
