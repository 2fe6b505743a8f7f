//! The SSE2 backend: 4-wide box tests (the 4-wide nodes and the packet tests of every x86
//! backend).

use super::kernel::{Kernel, RayData};
use super::{PacketHits, SseRay, TriPacket, WideNode};
use std::arch::x86_64::*;

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
