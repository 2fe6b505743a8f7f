//! Geometry for the sahara BVH toolkit.
//!
//! The lowest crate of the workspace, with no dependency beyond `glam`:
//!
//! * [`Aabb`]: axis-aligned boxes on [`glam::Vec3A`] (grow, union, intersection, surface area);
//! * [`Ray`]: origin, direction, `[tmin, tmax]` interval and the direction's reciprocal, which
//!   its constructor and setters keep equal to it (the direction is private);
//! * [`Triangle`]: three vertices, with bounds, area, centroid and normal;
//! * [`Camera`]: the pinhole camera and its primary rays through pixel centres (the one
//!   primary-ray generator of the workspace, with one documented rule for degenerate cameras),
//!   the framing of a scene without a camera ([`UpAxis`]) and the command-line camera format;
//! * [`intersect::intersect_triangle`]: the watertight ray/triangle test of Woop, Benthin and
//!   Wald (2013);
//! * [`intersect::intersect_aabb`]: the robust slab test of Ize (2013);
//! * [`clip`]: clipping a triangle against a box (area and bounds of the clipped polygon) and
//!   splitting a triangle's bounds by an axis-aligned plane, as spatial splits and the EPO
//!   metric need;
//! * [`closest::closest_point_on_triangle`]: the closest point of a triangle to a point
//!   (Ericson's region method, in `f64`), for closest-point queries;
//! * [`rng::Pcg32`]: a small deterministic random generator, so that procedural scenes and ray
//!   sets are bit-identical on every machine and every version of the workspace.
//!
//! ```
//! use sahara_geom::{Ray, Triangle, Vec3A, intersect::intersect_triangle};
//!
//! let tri = Triangle::new(
//!     Vec3A::new(-1.0, -1.0, 5.0),
//!     Vec3A::new(1.0, -1.0, 5.0),
//!     Vec3A::new(0.0, 1.0, 5.0),
//! );
//! let ray = Ray::new(Vec3A::ZERO, Vec3A::Z, 0.0, f32::INFINITY);
//! let hit = intersect_triangle(&ray.watertight(), &tri, ray.tmin, ray.tmax).unwrap();
//! assert!((hit.t - 5.0).abs() < 1e-6);
//! assert!(tri.bounds().surface_area() > 0.0);
//! ```
#![warn(missing_docs)]

mod aabb;
pub mod camera;
pub mod clip;
pub mod closest;
pub mod intersect;
mod ray;
pub mod rng;
mod triangle;

pub use aabb::Aabb;
pub use camera::{Camera, CameraBasis, CameraFrame, CameraSpecError, UpAxis};
pub use glam::{Vec3, Vec3A};
pub use ray::Ray;
pub use triangle::Triangle;

/// An axis of 3D space: 0 = x, 1 = y, 2 = z.
pub type Axis = usize;

/// The README's examples, compiled and run as doctests.
#[cfg(doctest)]
#[doc = include_str!("../README.md")]
struct ReadmeDoctests;
