//! The ray-weighted metrics of primary rays: SAH and EPO re-weighted by the rays a camera
//! really casts, our reading of the improved primary-ray predictor of Wodniok & Goesele (see
//! `docs/metrics.md`). They trace rays, so they live here, above `sahara-traverse`: their
//! closest hits are the reference kernel's ([`Bvh2Tracer`]), and their rays the camera's
//! ([`CameraFrame`]). The weights themselves, and the weighted SAH of any weight function,
//! are `sahara-metrics`' ([`weighted_sah`], [`segment_node_weights`]).
//!
//! A node is weighted by the fraction of the camera's rays that hit its box ([`box_weight`]):
//!
//! ```text
//! frustum SAH = (c_t Σ_inner w(n) + c_i Σ_leaf |n| w(n)) / w(root)
//! ```
//!
//! and the EPO-like term is the [`endpoint_overlap`] of the points the camera actually sees
//! ([`primary_ray_metrics`]). Everything here is deterministic: integer counts or sums in a
//! fixed order.
//!
//! ```
//! use sahara_bvh::{Bvh, Node};
//! use sahara_geom::{Camera, Triangle, Vec3A};
//! use sahara_metrics::CostModel;
//! use sahara_trace::weighted::{grid_frame, primary_ray_metrics};
//!
//! let tris = [Triangle::new(Vec3A::new(-1.0, -1.0, 0.0), Vec3A::new(1.0, -1.0, 0.0), Vec3A::new(0.0, 1.0, 0.0))];
//! let bvh = Bvh { nodes: vec![Node::leaf(&tris[0].bounds(), 0, 1)], prim_indices: vec![0], spatial_splits: false, ref_cuts: None };
//! let camera = Camera::new(Vec3A::new(0.0, 0.0, 3.0), Vec3A::ZERO, Vec3A::Y, 60.0);
//! let m = primary_ray_metrics(&bvh, &tris, &CostModel::AILA, &grid_frame(&camera, 4.0 / 3.0, 24));
//! assert_eq!(m.rays, 32 * 24);
//! assert!(m.hits > 0 && m.frustum_sah > 0.0);
//! ```

use crate::{trace_closest, Bvh2Tracer};
use sahara_bvh::Bvh;
use sahara_geom::{
    intersect::intersect_aabb, Aabb, Camera, CameraBasis, CameraFrame, Triangle, Vec3A,
};
use sahara_metrics::{
    endpoint_overlap, segment_node_weights, weighted_sah, weighted_sah_from_node_weights,
    CostModel, Endpoint,
};
use sahara_traverse::Hit;
use serde::{Deserialize, Serialize};

/// The frame of a coarse grid of `rows` rows and `max(1, round(rows · aspect))` columns over
/// an image of aspect ratio `aspect` (width / height): the primary-ray distribution the
/// camera-weighted metrics integrate over ([`Camera::frame_with_aspect`]).
pub fn grid_frame(camera: &Camera, aspect: f32, rows: u32) -> CameraFrame {
    let columns = ((rows as f32 * aspect).round() as u32).max(1);
    camera.frame_with_aspect(columns, rows, aspect)
}

/// The fraction of the frame's rays that hit `b` (ignoring occlusion): the probability that a
/// primary ray reaches a node with this box.
///
/// Exact for the frame's rays (each candidate is slab-tested); the candidates are the pixels
/// inside the screen rectangle of the box's projected corners (plus a pixel of margin) when
/// the box lies in front of the eye, every pixel otherwise, and all of them without a test
/// when the eye is inside the box. 0 for an empty box.
pub fn box_weight(frame: &CameraFrame, b: &Aabb) -> f64 {
    if b.is_empty() {
        return 0.0;
    }
    let eye = frame.eye();
    if b.contains_point(eye) {
        return 1.0;
    }
    let CameraBasis {
        forward: f,
        right: r,
        up: u,
    } = frame.basis();
    let (tan, aspect) = (frame.tan_half_fov_y(), frame.aspect());
    let (width, height) = (frame.width() as i64, frame.height() as i64);
    let (w, h) = (width as f32, height as f32);
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
        let sx = d.dot(r) / (z * tan * aspect);
        let sy = d.dot(u) / (z * tan);
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
        Some((ax, ay, bx, by))
            if ax.is_finite() && ay.is_finite() && bx.is_finite() && by.is_finite() =>
        {
            (
                ((ax.floor() as i64) - 1).max(0),
                ((ay.floor() as i64) - 1).max(0),
                ((bx.ceil() as i64) + 1).min(width - 1),
                ((by.ceil() as i64) + 1).min(height - 1),
            )
        }
        _ => (0, 0, width - 1, height - 1),
    };
    let mut hits = 0u64;
    for y in y0..=y1 {
        for x in x0..=x1 {
            let ray = frame.ray(x as u32, y as u32);
            if intersect_aabb(ray.origin, ray.inv_direction(), 0.0, f32::INFINITY, b).is_some() {
                hits += 1;
            }
        }
    }
    hits as f64 / frame.len() as f64
}

/// The weight function of a camera: `w(box)` = [`box_weight`] over the [`grid_frame`] of
/// `rows` rows at aspect ratio `aspect` (the image's width / height). Feed it to
/// [`weighted_sah`] for the "frustum SAH".
pub fn camera_box_weight(
    camera: &Camera,
    aspect: f32,
    rows: u32,
) -> impl Fn(&Aabb) -> f64 + Send + Sync {
    let frame = grid_frame(camera, aspect, rows);
    move |b: &Aabb| box_weight(&frame, b)
}

/// The hit as an [`Endpoint`] of the metrics (the point is computed from the barycentrics,
/// so it lies on the triangle up to rounding); `None` for a miss.
///
/// # Panics
///
/// When the hit's triangle is not in `tris`.
pub fn hit_endpoint(tris: &[Triangle], hit: &Hit) -> Option<Endpoint> {
    hit.is_hit().then(|| Endpoint {
        point: tris[hit.prim as usize].point(hit.u, hit.v),
        triangle: hit.prim,
    })
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

/// Computes the [`PrimaryRayMetrics`] of `bvh` for the rays of `frame` (typically a
/// [`grid_frame`]), their closest hits found by the reference kernel ([`Bvh2Tracer`]).
///
/// The improved predictor is `(1 - α) frustum_sah + α visible_epo`, fitted with
/// `sahara_metrics::SahEpoPredictor::fit` exactly like the SAH-EPO predictor.
///
/// # Panics
///
/// When the tree references a triangle outside `tris`.
pub fn primary_ray_metrics(
    bvh: &Bvh,
    tris: &[Triangle],
    cost: &CostModel,
    frame: &CameraFrame,
) -> PrimaryRayMetrics {
    let mut rays = frame.rays();
    let hits = trace_closest(&Bvh2Tracer::new(bvh, tris), &rays);
    let endpoints: Vec<Endpoint> = hits.iter().filter_map(|h| hit_endpoint(tris, h)).collect();
    for (r, h) in rays.iter_mut().zip(&hits) {
        if h.is_hit() {
            r.tmax = h.t;
        }
    }
    PrimaryRayMetrics {
        frustum_sah: weighted_sah(bvh, cost, |b| box_weight(frame, b)),
        occluded_sah: weighted_sah_from_node_weights(bvh, cost, &segment_node_weights(bvh, &rays)),
        visible_epo: endpoint_overlap(bvh, tris, cost, &endpoints),
        rays: rays.len(),
        hits: endpoints.len(),
    }
}
