//! Ray traversal of sahara BVHs.
//!
//! * [`scalar`]: closest-hit and any-hit traversal of the binary [`Bvh`] (near child first,
//!   robust slab test, watertight triangles): the reference every faster kernel is checked
//!   against;
//! * [`brute`]: a brute-force tracer that tests every triangle, for tests;
//! * [`custom`]: any primitive (a user intersection callback over a tree built from boxes)
//!   and any-hit filters on triangles (alpha-tested leaves), with their brute-force references;
//! * [`instance`]: two-level scenes, a top-level tree over instances (a bottom-level tree and
//!   an affine transform each);
//! * [`point`]: closest-point queries (the nearest point of the triangles or of user
//!   primitives to a point, within a distance) on the binary and the wide trees, nearest box
//!   first, equal to their brute-force twins bit for bit;
//! * [`wide`]: 4- and 8-wide BVHs collapsed from the binary tree, with SSE2 / AVX2 kernels
//!   (and a portable fallback) that return exactly the reference's hits.
//!
//! **Traversal never knows the builder**: kernels see only a [`Bvh`] and the triangles.
//!
//! Hits are deterministic: among triangles hit at exactly the same distance, the lowest
//! primitive index wins, in every kernel. So two kernels agree ray by ray even on shared edges.
//!
//! ```
//! use sahara_bvh::{Bvh, Node};
//! use sahara_geom::{Ray, Triangle, Vec3A};
//! use sahara_traverse::{brute, scalar, NoStats};
//!
//! let tris = [Triangle::new(Vec3A::new(-1.0, -1.0, 2.0), Vec3A::new(1.0, -1.0, 2.0), Vec3A::new(0.0, 1.0, 2.0))];
//! let bvh = Bvh { nodes: vec![Node::leaf(&tris[0].bounds(), 0, 1)], prim_indices: vec![0], spatial_splits: false, ref_cuts: None };
//! let ray = Ray::new(Vec3A::ZERO, Vec3A::Z, 0.0, f32::INFINITY);
//! let hit = scalar::closest_hit(&bvh, &tris, &ray, &mut NoStats);
//! assert_eq!(hit, brute::closest_hit(&tris, &ray));
//! assert_eq!(hit.prim, 0);
//! assert!(scalar::any_hit(&bvh, &tris, &ray, &mut NoStats));
//! ```
#![warn(missing_docs)]

pub mod brute;
pub mod custom;
pub mod instance;
pub mod point;
mod precision;
pub mod scalar;
mod stats;
pub mod wide;

pub use point::PointHit;
pub use precision::{ParsePrecisionError, Precision};
pub use sahara_bvh::Bvh;
pub use stats::{HitLocation, NoStats, TraversalStats, WorkCounters};
pub use wide::{simd_backend, Backend, Bvh4, Bvh8, WideBvh, WideNode};

/// The result of a closest-hit query: distance, primitive and barycentrics (`u` weights
/// vertex 1, `v` vertex 2). A miss has `t = +inf` and `prim = u32::MAX`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Hit {
    /// Ray parameter of the hit (`+inf` for a miss).
    pub t: f32,
    /// Index of the triangle hit (`u32::MAX` for a miss).
    pub prim: u32,
    /// Barycentric weight of vertex 1.
    pub u: f32,
    /// Barycentric weight of vertex 2.
    pub v: f32,
}

impl Hit {
    /// No hit.
    pub const MISS: Hit = Hit {
        t: f32::INFINITY,
        prim: u32::MAX,
        u: 0.0,
        v: 0.0,
    };

    /// True when something was hit.
    #[inline]
    pub fn is_hit(&self) -> bool {
        self.prim != u32::MAX
    }

    /// True when a hit at `t` on `prim` should replace this one: nearer, or at exactly the
    /// same distance on a lower primitive index (the deterministic tie-break every kernel
    /// uses).
    #[inline]
    pub fn is_improved_by(&self, t: f32, prim: u32) -> bool {
        t < self.t || (t == self.t && prim < self.prim)
    }
}

/// A small stack of node indices that lives on the call stack and spills to the heap only for
/// unusually deep trees.
pub(crate) struct NodeStack {
    inline: [u32; 64],
    len: usize,
    spill: Vec<u32>,
}

impl NodeStack {
    #[inline]
    pub(crate) fn new() -> Self {
        Self {
            inline: [0; 64],
            len: 0,
            spill: Vec::new(),
        }
    }

    #[inline]
    pub(crate) fn push(&mut self, v: u32) {
        if self.len < 64 {
            self.inline[self.len] = v;
            self.len += 1;
        } else {
            self.spill.push(v);
        }
    }

    #[inline]
    pub(crate) fn pop(&mut self) -> Option<u32> {
        if let Some(v) = self.spill.pop() {
            return Some(v);
        }
        if self.len == 0 {
            return None;
        }
        self.len -= 1;
        Some(self.inline[self.len])
    }
}
