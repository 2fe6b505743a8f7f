//! Ray-distribution-weighted metrics: SAH and EPO re-weighted by the rays a ray type really
//! casts, the basis of our reading of the improved primary-ray predictor of Wodniok & Goesele
//! (see `docs/metrics.md`).
//!
//! SAH weights each node by `A(n) / A(root)`, the probability that a ray from infinity with a
//! uniform direction that hits the root also hits the node. Primary rays are nothing like that:
//! they all start at the eye and fill the camera's frustum. Here a node is weighted by a
//! function `w(box)` instead, typically the fraction of the camera's rays that hit the box
//! ([`CameraGrid::box_weight`]):
//!
//! ```text
//! weighted SAH = (c_t Σ_inner w(n) + c_i Σ_leaf |n| w(n)) / w(root)
//! ```
//!
//! which is exactly [`crate::sah()`] for `w = half area`. The EPO-like term for primary rays is
//! the [`crate::endpoint_overlap`] of the points the camera actually sees
//! ([`primary_ray_metrics`]).
//!
//! Everything here is deterministic: integer counts or sums in a fixed order.

use crate::{endpoint_overlap, epo::CHUNK, CostModel, Endpoint};
use rayon::prelude::*;
use sahara_bvh::Bvh;
use sahara_geom::{
    intersect::{cull_distance, intersect_aabb, intersect_triangle, lower_distance},
    Aabb, Ray, Triangle, Vec3A,
};
use serde::{Deserialize, Serialize};
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

/// A closest hit: distance along the ray and the triangle hit, with its barycentrics.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Hit {
    /// Distance along the ray (in units of its direction).
    pub t: f32,
    /// Index of the triangle.
    pub triangle: u32,
    /// Barycentric `u` (weight of vertex 1).
    pub u: f32,
    /// Barycentric `v` (weight of vertex 2).
    pub v: f32,
}

impl Hit {
    /// The hit as an [`Endpoint`] (the point is computed from the barycentrics, so it lies on
    /// the triangle up to rounding).
    pub fn endpoint(&self, tris: &[Triangle]) -> Endpoint {
        Endpoint {
            point: tris[self.triangle as usize].point(self.u, self.v),
            triangle: self.triangle,
        }
    }
}

/// The closest hit of every ray through `bvh` (a plain stack traversal with the watertight
/// triangle test and the robust slab test; ties at equal distance go to the lowest triangle
/// index, as in the kernels). Metrics use it to find where the rays of a coarse camera grid
/// end; the result does not depend on the tree. Invalid rays miss.
pub fn closest_hits(bvh: &Bvh, tris: &[Triangle], rays: &[Ray]) -> Vec<Option<Hit>> {
    rays.par_iter()
        .map_init(
            || Vec::with_capacity(64),
            |stack, r| {
                if bvh.nodes.is_empty() || !r.is_valid() {
                    return None;
                }
                let w = r.watertight();
                let mut best: Option<Hit> = None;
                let mut tmax = r.tmax;
                stack.clear();
                stack.push(0usize);
                while let Some(i) = stack.pop() {
                    let node = &bvh.nodes[i];
                    let (lo, hi) = (lower_distance(r.tmin), cull_distance(tmax));
                    if intersect_aabb(r.origin, r.inv_direction(), lo, hi, &node.bounds()).is_none()
                    {
                        continue;
                    }
                    if node.is_leaf() {
                        for &p in bvh.leaf_prims(node) {
                            // The ray's own interval (the reported distance is clamped into
                            // it), then the kernels' order: nearer, or as near with a lower index.
                            let Some(h) = intersect_triangle(&w, &tris[p as usize], r.tmin, r.tmax)
                            else {
                                continue;
                            };
                            if h.t < tmax || (h.t == tmax && best.is_none_or(|b| p < b.triangle)) {
                                tmax = h.t;
                                best = Some(Hit {
                                    t: h.t,
                                    triangle: p,
                                    u: h.u,
                                    v: h.v,
                                });
                            }
                        }
                    } else {
                        let (l, rr) = bvh.children(i);
                        stack.push(rr);
                        stack.push(l);
                    }
                }
                best
            },
        )
        .collect()
}

/// A pinhole camera sampled on a coarse grid of pixel centres: the primary-ray distribution
/// that the camera-weighted metrics integrate over.
///
/// Pixel `(x, y)` (`y = 0` at the top) shoots from `eye` along
/// `forward + sx · tan(fov_y / 2) · aspect · right + sy · tan(fov_y / 2) · up'` with
/// `sx = 2 (x + 0.5) / width - 1` and `sy = 1 - 2 (y + 0.5) / height`, where `right` and
/// `up'` complete `forward = normalize(target - eye)` to an orthonormal frame.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct CameraGrid {
    /// The eye.
    pub eye: [f32; 3],
    /// Unit viewing direction.
    pub forward: [f32; 3],
    /// Unit right vector.
    pub right: [f32; 3],
    /// Unit up vector (orthogonal to `forward` and `right`).
    pub up: [f32; 3],
    /// `tan(fov_y / 2)`.
    pub tan_half_fov_y: f32,
    /// Width / height of the image.
    pub aspect: f32,
    /// Grid columns.
    pub width: u32,
    /// Grid rows.
    pub height: u32,
}

impl CameraGrid {
    /// A camera at `eye` looking at `target`, with vertical field of view `fov_y_degrees`,
    /// image aspect ratio `aspect` (width / height), sampled on `width × height` rays.
    ///
    /// A degenerate `up` (parallel to the view direction) is replaced by another axis.
    ///
    /// # Panics
    /// When `eye == target` or the grid is empty.
    pub fn new(
        eye: Vec3A,
        target: Vec3A,
        up: Vec3A,
        fov_y_degrees: f32,
        aspect: f32,
        width: u32,
        height: u32,
    ) -> Self {
        assert!(width > 0 && height > 0, "empty camera grid");
        let forward = (target - eye).normalize_or_zero();
        assert!(forward != Vec3A::ZERO, "camera eye equals target");
        let mut right = forward.cross(up).normalize_or_zero();
        if right == Vec3A::ZERO {
            let alt = if forward.x.abs() < 0.9 {
                Vec3A::X
            } else {
                Vec3A::Y
            };
            right = forward.cross(alt).normalize();
        }
        let up = right.cross(forward);
        Self {
            eye: eye.to_array(),
            forward: forward.to_array(),
            right: right.to_array(),
            up: up.to_array(),
            tan_half_fov_y: (fov_y_degrees.to_radians() * 0.5).tan(),
            aspect,
            width,
            height,
        }
    }

    /// A grid of `grid` rows and `max(1, round(grid · aspect))` columns.
    pub fn with_rows(
        eye: Vec3A,
        target: Vec3A,
        up: Vec3A,
        fov_y_degrees: f32,
        aspect: f32,
        grid: u32,
    ) -> Self {
        let w = ((grid as f32 * aspect).round() as u32).max(1);
        Self::new(eye, target, up, fov_y_degrees, aspect, w, grid)
    }

    /// Number of rays of the grid.
    pub fn len(&self) -> usize {
        self.width as usize * self.height as usize
    }

    /// Always false (a grid has at least one ray).
    pub fn is_empty(&self) -> bool {
        self.len() == 0
    }

    /// The ray of pixel `(x, y)`: unit direction, `t` in `[0, ∞)`.
    pub fn ray(&self, x: u32, y: u32) -> Ray {
        let sx = 2.0 * (x as f32 + 0.5) / self.width as f32 - 1.0;
        let sy = 1.0 - 2.0 * (y as f32 + 0.5) / self.height as f32;
        let d = Vec3A::from_array(self.forward)
            + Vec3A::from_array(self.right) * (sx * self.tan_half_fov_y * self.aspect)
            + Vec3A::from_array(self.up) * (sy * self.tan_half_fov_y);
        Ray::new(
            Vec3A::from_array(self.eye),
            d.normalize(),
            0.0,
            f32::INFINITY,
        )
    }

    /// Every ray of the grid, row by row from the top.
    pub fn rays(&self) -> Vec<Ray> {
        (0..self.height)
            .flat_map(|y| (0..self.width).map(move |x| (x, y)))
            .map(|(x, y)| self.ray(x, y))
            .collect()
    }

    /// The fraction of the grid's rays that hit `b` (ignoring occlusion): the probability that
    /// a primary ray reaches a node with this box.
    ///
    /// Exact for the grid's rays (each candidate is slab-tested); the candidates are the
    /// pixels inside the screen rectangle of the box's projected corners (plus a pixel of
    /// margin) when the box lies in front of the eye, every pixel otherwise, and all of them
    /// without a test when the eye is inside the box.
    pub fn box_weight(&self, b: &Aabb) -> f64 {
        if b.is_empty() {
            return 0.0;
        }
        let eye = Vec3A::from_array(self.eye);
        if b.contains_point(eye) {
            return 1.0;
        }
        let (f, r, u) = (
            Vec3A::from_array(self.forward),
            Vec3A::from_array(self.right),
            Vec3A::from_array(self.up),
        );
        let (w, h) = (self.width as f32, self.height as f32);
        let mut rect = Some((
            f32::INFINITY,
            f32::INFINITY,
            f32::NEG_INFINITY,
            f32::NEG_INFINITY,
        ));
        for k in 0..8 {
            let c = Vec3A::new(
                if k & 1 == 0 { b.min.x } else { b.max.x },
                if k & 2 == 0 { b.min.y } else { b.max.y },
                if k & 4 == 0 { b.min.z } else { b.max.z },
            );
            let d = c - eye;
            let z = d.dot(f);
            if z.is_nan() || z <= 1e-6 * d.length() {
                rect = None;
                break;
            }
            let sx = d.dot(r) / (z * self.tan_half_fov_y * self.aspect);
            let sy = d.dot(u) / (z * self.tan_half_fov_y);
            // Pixel coordinates whose centres are at integer + 0.5.
            let px = (sx + 1.0) * 0.5 * w - 0.5;
            let py = (1.0 - sy) * 0.5 * h - 0.5;
            if let Some(rc) = rect.as_mut() {
                rc.0 = rc.0.min(px);
                rc.1 = rc.1.min(py);
                rc.2 = rc.2.max(px);
                rc.3 = rc.3.max(py);
            }
        }
        let (x0, y0, x1, y1) = match rect {
            Some((ax, ay, bx, by)) => {
                if !(ax.is_finite() && ay.is_finite() && bx.is_finite() && by.is_finite()) {
                    (0, 0, self.width as i64 - 1, self.height as i64 - 1)
                } else {
                    (
                        ((ax.floor() as i64) - 1).max(0),
                        ((ay.floor() as i64) - 1).max(0),
                        ((bx.ceil() as i64) + 1).min(self.width as i64 - 1),
                        ((by.ceil() as i64) + 1).min(self.height as i64 - 1),
                    )
                }
            }
            None => (0, 0, self.width as i64 - 1, self.height as i64 - 1),
        };
        let mut hits = 0u64;
        for y in y0..=y1 {
            for x in x0..=x1 {
                let ray = self.ray(x as u32, y as u32);
                if intersect_aabb(ray.origin, ray.inv_direction(), 0.0, f32::INFINITY, b).is_some()
                {
                    hits += 1;
                }
            }
        }
        hits as f64 / self.len() as f64
    }
}

/// The weight function of a camera: `w(box)` = fraction of a grid of `grid` rows
/// (`round(grid · aspect)` columns) of primary rays that hit the box
/// ([`CameraGrid::box_weight`]). `fov_y_degrees` is the vertical field of view in degrees,
/// `aspect` the image's width / height. Feed it to [`weighted_sah`] for the "frustum SAH".
pub fn camera_box_weight(
    eye: Vec3A,
    target: Vec3A,
    up: Vec3A,
    fov_y_degrees: f32,
    aspect: f32,
    grid: u32,
) -> impl Fn(&Aabb) -> f64 + Send + Sync {
    let cam = CameraGrid::with_rows(eye, target, up, fov_y_degrees, aspect, grid);
    move |b: &Aabb| cam.box_weight(b)
}

/// The metrics of our improved primary-ray predictor for one tree and one camera (see
/// `docs/metrics.md`).
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct PrimaryRayMetrics {
    /// [`weighted_sah`] with the camera's box weights: every node weighted by the fraction of
    /// primary rays hitting its box, ignoring occlusion.
    pub frustum_sah: f64,
    /// [`weighted_sah_from_node_weights`] with [`segment_node_weights`] of the grid's rays cut
    /// at their closest hit: nodes hidden behind visible surfaces no longer count.
    pub occluded_sah: f64,
    /// [`endpoint_overlap`] of the points the grid's rays hit: EPO with the surface weighted
    /// by what the camera sees instead of by area.
    pub visible_epo: f64,
    /// Number of grid rays.
    pub rays: usize,
    /// Number of grid rays that hit the scene.
    pub hits: usize,
}

/// Computes the [`PrimaryRayMetrics`] of `bvh` for the rays of `camera`.
///
/// The improved predictor is `(1 - α) frustum_sah + α visible_epo`, fitted with
/// [`crate::SahEpoPredictor::fit`] exactly like the SAH-EPO predictor.
pub fn primary_ray_metrics(
    bvh: &Bvh,
    tris: &[Triangle],
    cost: &CostModel,
    camera: &CameraGrid,
) -> PrimaryRayMetrics {
    let mut rays = camera.rays();
    let hits = closest_hits(bvh, tris, &rays);
    let endpoints: Vec<Endpoint> = hits.iter().flatten().map(|h| h.endpoint(tris)).collect();
    for (r, h) in rays.iter_mut().zip(&hits) {
        if let Some(h) = h {
            r.tmax = h.t;
        }
    }
    PrimaryRayMetrics {
        frustum_sah: weighted_sah(bvh, cost, |b| camera.box_weight(b)),
        occluded_sah: weighted_sah_from_node_weights(bvh, cost, &segment_node_weights(bvh, &rays)),
        visible_epo: endpoint_overlap(bvh, tris, cost, &endpoints),
        rays: rays.len(),
        hits: endpoints.len(),
    }
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
