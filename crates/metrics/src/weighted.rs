//! Ray-distribution-weighted metrics: SAH re-weighted by the rays a ray type really casts, the
//! basis of our reading of the improved primary-ray predictor of Wodniok & Goesele (see
//! `docs/metrics.md`).
//!
//! SAH weights each node by `A(n) / A(root)`, the probability that a ray from infinity with a
//! uniform direction that hits the root also hits the node. Primary rays are nothing like that:
//! they all start at the eye and fill the camera's frustum. Here a node is weighted by a
//! function `w(box)` instead, for example the fraction of a ray set's segments that meet the
//! box ([`segment_node_weights`], [`SegmentSet`]):
//!
//! ```text
//! weighted SAH = (c_t Σ_inner w(n) + c_i Σ_leaf |n| w(n)) / w(root)
//! ```
//!
//! which is exactly [`crate::sah()`] for `w = half area`. The metrics that shoot a camera's
//! rays and need their closest hits (the camera's box weights, the frustum and occluded SAH,
//! the visible EPO) live above the traversal kernels, in `sahara_trace::weighted`: nothing here
//! finds a hit.
//!
//! Everything here is deterministic: integer counts or sums in a fixed order.

use crate::{epo::CHUNK, CostModel};
use rayon::prelude::*;
use sahara_bvh::Bvh;
use sahara_geom::{intersect::intersect_aabb, Aabb, Ray, Vec3A};
use std::sync::atomic::{AtomicU32, Ordering};

/// `w(box(n))` for every node, evaluated in parallel.
pub fn node_weights(bvh: &Bvh, weight: impl Fn(&Aabb) -> f64 + Sync) -> Vec<f64> {
    bvh.nodes.par_iter().map(|n| weight(&n.bounds())).collect()
}

/// The SAH with surface-area ratios replaced by `w(box(n)) / w(box(root))`:
/// `(c_t Σ_inner w(n) + c_i Σ_leaf |n| w(n)) / w(root)`.
///
/// `weight(&b)` must be non-negative; with `|b| b.half_area() as f64` this is [`crate::sah()`]
/// (for a root of non-zero area). Returns 0 for an empty tree or when `w(root) <= 0` (the
/// weighted ray type never reaches the scene).
pub fn weighted_sah(bvh: &Bvh, cost: &CostModel, weight: impl Fn(&Aabb) -> f64 + Sync) -> f64 {
    weighted_sah_from_node_weights(bvh, cost, &node_weights(bvh, weight))
}

/// [`weighted_sah`] from precomputed per-node weights (`node_weights[i]` for `bvh.nodes[i]`),
/// such as [`node_weights`] or [`segment_node_weights`].
///
/// # Panics
/// When `node_weights.len() != bvh.nodes.len()`.
pub fn weighted_sah_from_node_weights(bvh: &Bvh, cost: &CostModel, node_weights: &[f64]) -> f64 {
    assert_eq!(node_weights.len(), bvh.nodes.len(), "one weight per node");
    if bvh.nodes.is_empty() || node_weights[0].is_nan() || node_weights[0] <= 0.0 {
        return 0.0;
    }
    let (ct, ci) = (cost.traversal as f64, cost.intersection as f64);
    let mut sum = 0.0f64;
    for (n, &w) in bvh.nodes.iter().zip(node_weights) {
        sum += if n.is_leaf() {
            ci * n.count as f64 * w
        } else {
            ct * w
        };
    }
    sum / node_weights[0]
}

/// For every node, the fraction of `rays` whose interval `[tmin, tmax]` meets the node's box
/// (robust slab test), found by walking the tree with each ray (children lie inside their
/// parent, so a ray missing a node misses its subtree). Invalid rays ([`Ray::is_valid`]) count
/// as misses. All zeros when `rays` is empty.
///
/// With `tmax` set to each ray's closest-hit distance this is the occlusion-aware visit
/// probability: a node whose box the ray reaches before its hit must be tested by any
/// closest-hit traversal.
pub fn segment_node_weights(bvh: &Bvh, rays: &[Ray]) -> Vec<f64> {
    let counts: Vec<AtomicU32> = (0..bvh.nodes.len()).map(|_| AtomicU32::new(0)).collect();
    if bvh.nodes.is_empty() || rays.is_empty() {
        return vec![0.0; bvh.nodes.len()];
    }
    rays.par_chunks(CHUNK / 8).for_each(|chunk| {
        let mut stack = Vec::with_capacity(64);
        for r in chunk.iter().filter(|r| r.is_valid()) {
            stack.clear();
            stack.push(0usize);
            while let Some(i) = stack.pop() {
                let node = &bvh.nodes[i];
                if intersect_aabb(r.origin, r.inv_direction(), r.tmin, r.tmax, &node.bounds())
                    .is_none()
                {
                    continue;
                }
                counts[i].fetch_add(1, Ordering::Relaxed);
                if !node.is_leaf() {
                    let (l, rr) = bvh.children(i);
                    stack.push(rr);
                    stack.push(l);
                }
            }
        }
    });
    let n = rays.len() as f64;
    counts
        .into_iter()
        .map(|c| c.into_inner() as f64 / n)
        .collect()
}

/// Rays per cluster of a [`SegmentSet`].
const SEGMENT_CLUSTER: usize = 32;

/// A fixed set of ray segments (each ray's `[tmin, tmax]`, clipped to a scene box) that counts,
/// for **any** box, how many of them meet it: the visit count of [`segment_node_weights`]
/// for boxes that are not (yet) nodes of a tree, such as the candidate boxes of an
/// optimiser. With `tmax` cut at each ray's closest hit, `count(b) / len()` is the
/// occlusion-aware probability that a closest-hit traversal tests a node with box `b`, the
/// weight of the ray-weighted SAH (`docs/metrics.md`).
///
/// The count is monotone in the box (a box inside another meets no more segments), as
/// branch-and-bound searches over it need: it is a plain slab test (`f32::min`/`max`, which
/// ignore the NaN of a zero direction component on a slab's plane) on segments sorted into
/// clusters of 32 along a Morton curve of their midpoints, a cluster skipped when its
/// segments' bounding box misses the box. Deterministic: integer counts.
#[derive(Clone, Debug, Default)]
pub struct SegmentSet {
    /// Per cluster: the bounds of its segments and its first segment (the next cluster's
    /// first, or `len`, ends it).
    clusters: Vec<(Aabb, u32)>,
    origin: [Vec<f32>; 3],
    inv: [Vec<f32>; 3],
    t0: Vec<f32>,
    t1: Vec<f32>,
}

impl SegmentSet {
    /// The segments of the valid `rays` ([`Ray::is_valid`]) that meet `bounds`, clipped to it
    /// (rays missing `bounds` are dropped: they meet no box inside it).
    pub fn new(rays: &[Ray], bounds: &Aabb) -> Self {
        let mut segs: Vec<(u64, Ray, f32, f32, Aabb)> = rays
            .iter()
            .filter(|r| r.is_valid())
            .filter_map(|r| {
                let tmin = r.tmin.max(0.0);
                let t = slab(r.origin, r.inv_direction(), tmin, r.tmax, bounds)?;
                let (a, b) = (r.at(t.0), r.at(t.1));
                let seg = Aabb::new(a.min(b), a.max(b));
                Some((0, *r, t.0, t.1, seg))
            })
            .collect();
        let ext = bounds.extent().max(Vec3A::splat(f32::MIN_POSITIVE));
        for s in &mut segs {
            let c = ((s.4.centroid() - bounds.min) / ext).clamp(Vec3A::ZERO, Vec3A::ONE);
            s.0 = morton3((c * 1023.0).as_uvec3().to_array());
        }
        // Stable: equal codes keep the rays' order.
        segs.sort_by_key(|s| s.0);
        let pad = 1e-5 * ext.max_element();
        let mut out = SegmentSet::default();
        for (k, chunk) in segs.chunks(SEGMENT_CLUSTER).enumerate() {
            let b = chunk.iter().fold(Aabb::EMPTY, |b, s| b.union(&s.4));
            let b = Aabb::new(b.min - Vec3A::splat(pad), b.max + Vec3A::splat(pad));
            out.clusters.push((b, (k * SEGMENT_CLUSTER) as u32));
            for (_, r, t0, t1, _) in chunk {
                for a in 0..3 {
                    out.origin[a].push(r.origin[a]);
                    out.inv[a].push(r.inv_direction()[a]);
                }
                out.t0.push(*t0);
                out.t1.push(*t1);
            }
        }
        out
    }

    /// Number of segments kept.
    pub fn len(&self) -> usize {
        self.t0.len()
    }

    /// True when no segment was kept.
    pub fn is_empty(&self) -> bool {
        self.t0.is_empty()
    }

    /// How many segments meet `b` (0 for an empty box).
    pub fn count(&self, b: &Aabb) -> u32 {
        if b.is_empty() {
            return 0;
        }
        let mut n = 0u32;
        for (k, (cb, first)) in self.clusters.iter().enumerate() {
            if !cb.overlaps(b) {
                continue;
            }
            let end = self
                .clusters
                .get(k + 1)
                .map_or(self.t0.len(), |c| c.1 as usize);
            n += self.count_range(*first as usize..end, b);
        }
        n
    }

    /// `count(b) / len()` (0 when empty).
    pub fn fraction(&self, b: &Aabb) -> f64 {
        if self.is_empty() {
            0.0
        } else {
            self.count(b) as f64 / self.len() as f64
        }
    }

    #[inline]
    fn count_range(&self, r: std::ops::Range<usize>, b: &Aabb) -> u32 {
        let (lo, hi) = (b.min.to_array(), b.max.to_array());
        let [ox, oy, oz] = &self.origin;
        let [ix, iy, iz] = &self.inv;
        let (ox, oy, oz) = (&ox[r.clone()], &oy[r.clone()], &oz[r.clone()]);
        let (ix, iy, iz) = (&ix[r.clone()], &iy[r.clone()], &iz[r.clone()]);
        let (t0, t1) = (&self.t0[r.clone()], &self.t1[r]);
        let mut n = 0u32;
        for i in 0..t0.len() {
            let (ax, bx) = ((lo[0] - ox[i]) * ix[i], (hi[0] - ox[i]) * ix[i]);
            let (ay, by) = ((lo[1] - oy[i]) * iy[i], (hi[1] - oy[i]) * iy[i]);
            let (az, bz) = ((lo[2] - oz[i]) * iz[i], (hi[2] - oz[i]) * iz[i]);
            let near = t0[i].max(ax.min(bx)).max(ay.min(by)).max(az.min(bz));
            let far = t1[i].min(ax.max(bx)).min(ay.max(by)).min(az.max(bz));
            n += (near <= far) as u32;
        }
        n
    }
}

/// The part `[near, far]` of `[tmin, tmax]` inside `b` (plain slab test), if any.
fn slab(o: Vec3A, inv: Vec3A, tmin: f32, tmax: f32, b: &Aabb) -> Option<(f32, f32)> {
    let a = (b.min - o) * inv;
    let c = (b.max - o) * inv;
    let (lo, hi) = (a.min(c), a.max(c));
    let near = tmin.max(lo.x).max(lo.y).max(lo.z);
    let far = tmax.min(hi.x).min(hi.y).min(hi.z);
    (near <= far && far.is_finite()).then_some((near, far))
}

/// Interleaves three 10-bit coordinates into a 30-bit Morton code.
fn morton3(c: [u32; 3]) -> u64 {
    let spread = |v: u32| {
        let mut x = (v & 0x3ff) as u64;
        x = (x | (x << 16)) & 0x0300_00ff;
        x = (x | (x << 8)) & 0x0300_f00f;
        x = (x | (x << 4)) & 0x030c_30c3;
        x = (x | (x << 2)) & 0x0924_9249;
        x
    };
    spread(c[0]) | (spread(c[1]) << 1) | (spread(c[2]) << 2)
}
