//! The portable backend: the wide layouts traversed with scalar code (every target).

use super::kernel::{self, FixedStack, Kernel, PacketHits, RayData, VecStack, FIXED_STACK};
use super::{TriPacket, WideBvh, WideNode};
use crate::{Hit, TraversalStats};
use sahara_geom::intersect::{intersect_triangle, intersect_triangle_fast, TriangleHit};
use sahara_geom::{Ray, Vec3A};

/// Scalar box and triangle tests, lane by lane, with the watertight triangle test
/// ([`Precision::Exact`](crate::Precision::Exact)) when `FAST` is false and Möller–Trumbore
/// ([`Precision::Fast`](crate::Precision::Fast)) when it is true.
pub(crate) struct Scalar<const FAST: bool>;

/// The portable backend of [`Precision::Exact`](crate::Precision::Exact).
pub(crate) type Portable = Scalar<false>;

/// The triangle test of lane `l` of a packet over the ray's interval.
#[inline(always)]
fn lane_test<const FAST: bool>(p: &TriPacket, l: usize, rd: &RayData) -> Option<TriangleHit> {
    if FAST {
        intersect_triangle_fast(
            rd.w.origin(),
            Vec3A::from(rd.dir),
            rd.w.inv_direction(),
            &p.triangle(l),
            rd.tmin,
            rd.tmax,
        )
    } else {
        intersect_triangle(&rd.w, &p.triangle(l), rd.tmin, rd.tmax)
    }
}

impl<const W: usize, const FAST: bool> Kernel<W> for Scalar<FAST> {
    type Ray = ();

    #[inline(always)]
    unsafe fn prepare(_: &RayData) {}

    #[inline(always)]
    unsafe fn intersect_node<const NEG: bool>(
        node: &WideNode<W>,
        _: &(),
        rd: &RayData,
        tfar: f32,
        dist: &mut [f32; W],
    ) -> u32 {
        let mut mask = 0;
        for i in 0..W {
            let b = &node.bounds;
            let bx = [b[0][i], b[1][i], b[2][i], b[3][i], b[4][i], b[5][i]];
            if let Some(d) = rd.slab::<NEG>(bx, tfar) {
                dist[i] = d;
                mask |= 1 << i;
            }
        }
        mask
    }

    #[inline(always)]
    unsafe fn intersect_packet<const NEG: bool>(
        p: &TriPacket,
        _: &(),
        rd: &RayData,
        tfar: f32,
        out: &mut PacketHits,
    ) -> (u32, u32) {
        let mut mask = 0;
        for l in 0..4 {
            if p.prims[l] == u32::MAX {
                continue;
            }
            if let Some(h) = lane_test::<FAST>(p, l, rd) {
                if h.t <= tfar {
                    out.t[l] = h.t;
                    out.u[l] = h.u;
                    out.v[l] = h.v;
                    mask |= 1 << l;
                }
            }
        }
        (mask, 0)
    }

    #[inline(always)]
    unsafe fn occlude_packet<const NEG: bool>(p: &TriPacket, _: &(), rd: &RayData) -> (u32, u32) {
        let mut mask = 0;
        for l in 0..4 {
            if p.prims[l] != u32::MAX && lane_test::<FAST>(p, l, rd).is_some() {
                mask |= 1 << l;
            }
        }
        (mask, 0)
    }
}

pub(crate) fn closest_hit<const W: usize, S: TraversalStats, const FAST: bool>(
    bvh: &WideBvh<W>,
    ray: &Ray,
    stats: &mut S,
) -> Hit {
    // The portable kernel needs no CPU feature.
    slow_path!(kernel::closest_hit, Scalar<FAST>, bvh, ray, stats)
}

pub(crate) fn any_hit<const W: usize, S: TraversalStats, const FAST: bool>(
    bvh: &WideBvh<W>,
    ray: &Ray,
    stats: &mut S,
) -> bool {
    // The portable kernel needs no CPU feature.
    slow_path!(kernel::any_hit, Scalar<FAST>, bvh, ray, stats)
}
