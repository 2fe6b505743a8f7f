//! Tracing for the sahara BVH toolkit: what turns a tree into measured speed, work per ray
//! and pictures.
//!
//! * [`Camera`]: the workspace's one pinhole camera (`sahara_geom::Camera`, re-exported) and
//!   its primary rays through pixel centres;
//! * [`RaySet`]: deterministic ray sets of a [`RayKind`] — primary rays, one cosine-weighted
//!   diffuse bounce from each primary hit, short ambient-occlusion rays — each ray seeded by
//!   `(seed, pixel)` ([`ray_rng`]) so a set is bit-identical on any number of threads;
//! * [`Tracer`]: closest-hit and any-hit queries, with and without work counters; one
//!   implementation per BVH layout ([`Bvh2Tracer`] for the binary tree, [`BruteTracer`] for
//!   checks, [`WideTracer`] for the 4- and 8-wide SIMD kernels with a chosen backend,
//!   [`parse_backend`] for a `--backend` name checked against the CPU), so new layouts plug
//!   into everything below;
//! * batch tracing on rayon ([`trace_closest`], [`trace_any`], [`trace_set`] and their
//!   `_counted` variants with per-ray [`WorkCounters`]), results in the order of the rays;
//!   [`checksum`] and [`hit_count`] to compare tracers;
//! * [`measure`]: median/min/max wall-clock time of repeated passes after a warm-up, and
//!   Mrays/s ([`Timing::mrays_per_s`]);
//! * images ([`shade`], [`heat_map`] of work per pixel) written as PNG
//!   ([`RgbImage::write_png`]);
//! * [`weighted`]: the ray-weighted metrics of primary rays (frustum SAH, occluded SAH,
//!   visible EPO), the camera's rays traced by the reference kernel;
//! * ray files and hit files ([`read_rays`], [`write_rays`], [`read_hits`], [`write_hits`]),
//!   with typed errors ([`TraceError`]) naming the file.
//!
//! ```
//! use sahara_bvh::{Bvh, Node};
//! use sahara_geom::{Triangle, Vec3A};
//! use sahara_trace::*;
//!
//! // A quad at z = 0 seen from z = 3 (a one-leaf tree is a valid BVH).
//! let tris = [
//!     Triangle::new(Vec3A::new(-1.0, -1.0, 0.0), Vec3A::new(1.0, -1.0, 0.0), Vec3A::new(1.0, 1.0, 0.0)),
//!     Triangle::new(Vec3A::new(-1.0, -1.0, 0.0), Vec3A::new(1.0, 1.0, 0.0), Vec3A::new(-1.0, 1.0, 0.0)),
//! ];
//! let bounds = tris[0].bounds().union(&tris[1].bounds());
//! let bvh = Bvh { nodes: vec![Node::leaf(&bounds, 0, 2)], prim_indices: vec![0, 1], spatial_splits: false, ref_cuts: None };
//! let tracer = Bvh2Tracer::new(&bvh, &tris);
//!
//! let camera = Camera::new(Vec3A::new(0.0, 0.0, 3.0), Vec3A::ZERO, Vec3A::Y, 60.0);
//! let primary = RaySet::primary(&camera, 32, 24);
//! let hits = trace_closest(&tracer, &primary.rays);
//! assert_eq!(hits.len(), 32 * 24);
//! assert!(hit_count(&hits) > 0);
//!
//! // Counting gives the same hits, plus the work of each ray.
//! let counted = trace_closest_counted(&tracer, &primary.rays);
//! assert_eq!(checksum(&counted.results), checksum(&hits));
//! assert!(counted.per_ray().triangles > 0.0);
//!
//! // Ambient occlusion from each primary hit: nothing above a lone quad occludes.
//! let ao = RaySet::ambient_occlusion(&camera, 32, 24, &tracer, &tris, 7);
//! assert_eq!(ao.len(), hit_count(&hits));
//! assert_eq!(trace_set(&tracer, &ao).hit_count(), 0);
//!
//! // A heat map of the work per pixel, and the time of a batch.
//! let heat = heat_map(32, 24, &primary.pixel, &counted.work, 99.0);
//! assert!(heat.scale_max >= 1.0);
//! let t = measure(3, 1, || trace_closest(&tracer, &primary.rays));
//! assert!(t.mrays_per_s(primary.len()).median > 0.0);
//! ```
#![warn(missing_docs)]

mod batch;
mod error;
mod files;
mod placement;
mod rays;
mod render;
mod timing;
mod tracer;
pub mod weighted;

pub use batch::{
    checksum, checksum_occlusion, hit_count, occluded_count, trace_any, trace_any_counted,
    trace_any_into, trace_closest, trace_closest_counted, trace_closest_into, trace_set,
    trace_set_counted, work_total, CountedTrace, TraceResults, WorkPerRay,
};
pub use error::TraceError;
pub use files::{
    decode_hits, decode_rays, encode_hits, encode_rays, read_hits, read_rays, write_hits,
    write_rays, HIT_RECORD_BYTES, RAY_RECORD_BYTES,
};
pub use placement::{place_camera, Placement, PlacementKind};
pub use rays::{
    cosine_hemisphere, offset_epsilon, ray_rng, scene_bounds, ParseRayKindError, RayKind, RaySet,
    AO_DISTANCE_FRACTION, OFFSET_SCALE,
};
pub use render::{
    colour_ramp, heat_map, shade, HeatMap, PixelWork, RgbImage, Shading, MISS_COLOUR,
};
pub use sahara_geom::{Camera, CameraFrame};
pub use sahara_traverse::{Backend, Hit, WorkCounters};
pub use timing::{measure, mrays_per_s, Throughput, Timing};
pub use tracer::{
    parse_backend, require_backend, BackendError, BruteTracer, Bvh2Tracer, Tracer, WideTracer,
};

/// The README's examples, compiled and run as doctests.
#[cfg(doctest)]
#[doc = include_str!("../README.md")]
struct ReadmeDoctests;
