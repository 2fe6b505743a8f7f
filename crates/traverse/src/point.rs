//! Closest-point queries: the point of the geometry nearest to a query point `p` within
//! `max_distance`, on the binary [`Bvh`] ([`closest_point`], [`closest_point_custom`]) and the
//! wide trees ([`WideBvh::closest_point`], [`WideBvh::closest_point_custom`]), with their
//! brute-force twins in [`crate::brute`].
//!
//! # The answer
//!
//! Every primitive's candidate is a pure function of the primitive and `p`:
//!
//! * **triangles**: [`closest_point_on_triangle`] (Ericson's region method, in `f64` from the
//!   `f32` inputs). Degenerate triangles ([`is_degenerate`]: collinear or coincident vertices)
//!   are skipped, as ray queries never hit them (the wide layouts do not even store their
//!   vertices);
//! * **user primitives**: a callback `closest(prim, p) -> Option<(point, distance_squared)>`
//!   (`None` skips the primitive). The distance is raised to at least the squared distance
//!   from `p` to the primitive's **box** (the one given at build time), as a ray hit on a user
//!   primitive is clamped into its box's span (see [`crate::custom`]); a NaN distance skips the
//!   primitive.
//!
//! The answer is the candidate with the least squared distance (an `f64`,
//! [`PointHit::distance_squared`]) among those with `distance_squared <= max_distance²`;
//! **ties at exactly the same squared distance go to the lowest primitive index**, as for ray
//! hits. So the result does not depend on the tree, its layout or the order leaves are
//! visited in: every query equals its brute-force twin ([`crate::brute::closest_point`],
//! [`crate::brute::closest_point_custom`]) bit for bit.
//!
//! **Bad input**: a query point with a NaN or infinite coordinate, or a `max_distance` that is
//! negative or NaN, returns `None` (no panic). `max_distance = +∞` means no limit;
//! `max_distance = 0` finds only candidates at distance exactly zero.
//!
//! # Traversal and why it is exact
//!
//! Depth first with a stack, nearest box first: at an inner node every child whose box is
//! within the best squared distance so far (`lower <= best`, not `<`, so that a box holding a
//! tie with a lower index is still visited) is kept, the nearest is entered and the others
//! are pushed with their distances, re-checked when popped. Initially "best" is
//! `max_distance²`.
//!
//! The box distance is a **lower bound**: per axis, the gap between `p` and the box (in
//! `f64`) is reduced by a pad of `2^-16` of the largest coordinate magnitude of `p` and of the
//! tree's bounds before squaring. Without it, a rounded candidate distance could fall below
//! the computed distance of a box that holds its primitive: a candidate is computed with
//! rounding (about `2^-50` of the coordinates' magnitude in `f64`), and with spatial splits a
//! leaf's box is the clipped part of its triangles, whose clipped vertices are rounded to
//! `f32` (half an ulp of the coordinates). The pad exceeds both by orders of magnitude, so the
//! box of the leaf that holds a primitive's exact closest point is never pruned while that
//! primitive could win or tie; it costs almost nothing (a box is entered `2^-16` of the
//! scene's size earlier). For user primitives the raised distance is at least the exact box
//! distance, so their boxes (and every box containing them) are never pruned before them;
//! with spatial splits over user primitives the returned point must lie on the primitive and
//! the split callback must be conservative (as for ray queries).
//!
//! ```
//! use sahara_bvh::{Bvh, Node};
//! use sahara_geom::{Triangle, Vec3A};
//! use sahara_traverse::{brute, point, Bvh8, NoStats};
//!
//! let tris = [Triangle::new(Vec3A::ZERO, Vec3A::X, Vec3A::Y)];
//! let bvh = Bvh { nodes: vec![Node::leaf(&tris[0].bounds(), 0, 1)], prim_indices: vec![0], spatial_splits: false, ref_cuts: None };
//! let p = Vec3A::new(0.25, 0.25, 3.0);
//! let hit = point::closest_point(&bvh, &tris, p, f32::INFINITY, &mut NoStats).unwrap();
//! assert_eq!((hit.prim, hit.distance()), (0, 3.0));
//! assert_eq!(hit.point, Vec3A::new(0.25, 0.25, 0.0));
//! assert_eq!(Some(hit), brute::closest_point(&tris, p, f32::INFINITY));
//! let wide = Bvh8::from_bvh(&bvh, &tris);
//! assert_eq!(Some(hit), wide.closest_point(p, 10.0, &mut NoStats));
//! // Beyond max_distance, NaN points and negative distances: nothing.
//! assert_eq!(wide.closest_point(p, 2.5, &mut NoStats), None);
//! assert_eq!(wide.closest_point(Vec3A::NAN, 10.0, &mut NoStats), None);
//! assert_eq!(wide.closest_point(p, -1.0, &mut NoStats), None);
//! ```

use crate::wide::{decode_leaf, LEAF_BIT, NO_ROOT};
use crate::{TraversalStats, WideBvh};
use sahara_bvh::Bvh;
use sahara_geom::closest::closest_point_on_triangle;
use sahara_geom::intersect::is_degenerate;
use sahara_geom::{Aabb, Triangle, Vec3A};

/// The closest point found by a closest-point query.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct PointHit {
    /// Index of the primitive (triangle or user primitive).
    pub prim: u32,
    /// The closest point (rounded to `f32`). For triangles, `(1 - u - v) v0 + u v1 + v v2`;
    /// for user primitives, the callback's point.
    pub point: Vec3A,
    /// The squared distance from the query point, in `f64`: what the queries minimise (for
    /// triangles, from the closest point before its rounding to `f32`).
    pub distance_squared: f64,
    /// Barycentric weight of vertex 1 (triangles; `0` for user primitives).
    pub u: f32,
    /// Barycentric weight of vertex 2 (triangles; `0` for user primitives).
    pub v: f32,
}

impl PointHit {
    /// The distance, `sqrt(distance_squared)` rounded to `f32`.
    #[inline]
    pub fn distance(&self) -> f32 {
        self.distance_squared.sqrt() as f32
    }
}

/// A validated query: the point in `f64`, the squared distance limit and the box pad.
pub(crate) struct Query {
    pub(crate) p: Vec3A,
    pd: [f64; 3],
    max_d2: f64,
    pad: f64,
}

impl Query {
    /// `None` for a non-finite point or a negative or NaN `max_distance`. `bounds` are the
    /// bounds of everything the tree holds (empty is fine): they set the box pad.
    pub(crate) fn new(p: Vec3A, max_distance: f32, bounds: &Aabb) -> Option<Query> {
        if !p.is_finite() || max_distance.is_nan() || max_distance < 0.0 {
            return None;
        }
        let mut scale = p.abs().max_element() as f64;
        if bounds.min.is_finite() && bounds.max.is_finite() {
            scale = scale
                .max(bounds.min.abs().max_element() as f64)
                .max(bounds.max.abs().max_element() as f64);
        }
        let m = max_distance as f64;
        Some(Query {
            p,
            pd: [p.x as f64, p.y as f64, p.z as f64],
            max_d2: m * m,
            pad: scale * (1.0 / 65536.0) + f32::MIN_POSITIVE as f64,
        })
    }

    /// The padded lower bound of the squared distance from `p` to the box `[min, max]`.
    #[inline(always)]
    fn lower(&self, min: [f32; 3], max: [f32; 3]) -> f64 {
        let mut s = 0.0;
        for a in 0..3 {
            let g = (min[a] as f64 - self.pd[a]).max(self.pd[a] - max[a] as f64) - self.pad;
            if g > 0.0 {
                s += g * g;
            }
        }
        s
    }

    /// The padded lower bound for an [`Aabb`].
    #[inline]
    fn lower_aabb(&self, b: &Aabb) -> f64 {
        self.lower(b.min.to_array(), b.max.to_array())
    }

    /// The exact (unpadded) squared distance from `p` to a primitive's box, the least
    /// distance a user primitive can report.
    #[inline]
    fn box_floor(&self, b: &Aabb) -> f64 {
        let mut s = 0.0;
        for a in 0..3 {
            let g = (b.min[a] as f64 - self.pd[a]).max(self.pd[a] - b.max[a] as f64);
            if g > 0.0 {
                s += g * g;
            }
        }
        s
    }
}

/// The best candidate so far and the bound boxes are pruned against.
pub(crate) struct Best {
    pub(crate) hit: Option<PointHit>,
    /// The best squared distance (`max_distance²` before the first candidate).
    bound: f64,
    /// The best primitive (`u32::MAX` before the first candidate).
    prim: u32,
}

impl Best {
    pub(crate) fn new(q: &Query) -> Best {
        Best {
            hit: None,
            bound: q.max_d2,
            prim: u32::MAX,
        }
    }

    /// True when a candidate at `d2` on `prim` replaces the best: nearer, or as near on a
    /// lower index (NaN never does).
    #[inline(always)]
    fn improves(&self, d2: f64, prim: u32) -> bool {
        d2 < self.bound || (d2 == self.bound && prim < self.prim)
    }

    #[inline(always)]
    fn set(&mut self, hit: PointHit) {
        self.bound = hit.distance_squared;
        self.prim = hit.prim;
        self.hit = Some(hit);
    }

    /// Offers triangle `prim` (degenerate triangles are the caller's to skip).
    #[inline(always)]
    pub(crate) fn offer_triangle(&mut self, q: &Query, tri: &Triangle, prim: u32) {
        let c = closest_point_on_triangle(tri, q.p);
        if self.improves(c.distance_squared, prim) {
            self.set(PointHit {
                prim,
                point: c.point.as_vec3a(),
                distance_squared: c.distance_squared,
                u: c.u as f32,
                v: c.v as f32,
            });
        }
    }

    /// Offers user primitive `prim` with box `b`: the callback is asked only when the box is
    /// within the bound (else its raised distance could not win).
    #[inline(always)]
    pub(crate) fn offer_custom<F>(&mut self, q: &Query, b: &Aabb, prim: u32, closest: &mut F)
    where
        F: FnMut(u32, Vec3A) -> Option<(Vec3A, f64)>,
    {
        let floor = q.box_floor(b);
        if !self.improves(floor, prim) {
            return;
        }
        let Some((point, d2)) = closest(prim, q.p) else {
            return;
        };
        if d2.is_nan() {
            return;
        }
        let d2 = d2.max(floor);
        if self.improves(d2, prim) {
            self.set(PointHit {
                prim,
                point,
                distance_squared: d2,
                u: 0.0,
                v: 0.0,
            });
        }
    }
}

/// A stack entry: a node and the lower bound of its box's squared distance.
#[derive(Clone, Copy)]
struct Entry {
    node: u32,
    lower: f64,
}

/// The closest point on the triangles of a binary tree to `p`, within `max_distance` (see
/// the [module documentation](self)). Equal to [`crate::brute::closest_point`] bit for bit.
///
/// # Panics
///
/// If a leaf references a triangle outside `tris`.
pub fn closest_point<S: TraversalStats>(
    bvh: &Bvh,
    tris: &[Triangle],
    p: Vec3A,
    max_distance: f32,
    stats: &mut S,
) -> Option<PointHit> {
    let q = Query::new(p, max_distance, &bvh.bounds())?;
    let mut best = Best::new(&q);
    binary(bvh, &q, &mut best, stats, |best, prims, stats| {
        stats.triangles(prims.len() as u32);
        for &prim in prims {
            let tri = &tris[prim as usize];
            if !is_degenerate(tri) {
                best.offer_triangle(&q, tri, prim);
            }
        }
    });
    best.hit
}

/// The closest point on user primitives of a binary tree built over `boxes`, with
/// `closest(prim, p) -> Option<(point, distance_squared)>` (see the
/// [module documentation](self)). Equal to [`crate::brute::closest_point_custom`] bit for bit.
///
/// # Panics
///
/// If a leaf references a primitive outside `boxes`.
pub fn closest_point_custom<F, S>(
    bvh: &Bvh,
    boxes: &[Aabb],
    p: Vec3A,
    max_distance: f32,
    mut closest: F,
    stats: &mut S,
) -> Option<PointHit>
where
    F: FnMut(u32, Vec3A) -> Option<(Vec3A, f64)>,
    S: TraversalStats,
{
    let q = Query::new(p, max_distance, &bvh.bounds())?;
    let mut best = Best::new(&q);
    binary(bvh, &q, &mut best, stats, |best, prims, stats| {
        stats.triangles(prims.len() as u32);
        for &prim in prims {
            best.offer_custom(&q, &boxes[prim as usize], prim, &mut closest);
        }
    });
    best.hit
}

/// The traversal of a binary tree, nearest child first; `leaf` gets each leaf's references.
fn binary<S, L>(bvh: &Bvh, q: &Query, best: &mut Best, stats: &mut S, mut leaf: L)
where
    S: TraversalStats,
    L: FnMut(&mut Best, &[u32], &mut S),
{
    let nodes = &bvh.nodes;
    if nodes.is_empty() || q.lower_aabb(&nodes[0].bounds()) > best.bound {
        return;
    }
    let mut stack: Vec<Entry> = Vec::new();
    let mut cur = 0usize;
    loop {
        let node = &nodes[cur];
        if node.is_leaf() {
            stats.leaf();
            leaf(best, bvh.leaf_prims(node), stats);
        } else {
            stats.inner();
            let (l, r) = bvh.children(cur);
            let dl = q.lower(nodes[l].min, nodes[l].max);
            let dr = q.lower(nodes[r].min, nodes[r].max);
            let (near, dn, far, df) = if dr < dl {
                (r, dr, l, dl)
            } else {
                (l, dl, r, dr)
            };
            if dn <= best.bound {
                if df <= best.bound {
                    stack.push(Entry {
                        node: far as u32,
                        lower: df,
                    });
                }
                cur = near;
                continue;
            }
        }
        match pop(&mut stack, best) {
            Some(n) => cur = n as usize,
            None => return,
        }
    }
}

/// Pops entries until one is within the bound.
#[inline(always)]
fn pop(stack: &mut Vec<Entry>, best: &Best) -> Option<u32> {
    while let Some(e) = stack.pop() {
        if e.lower <= best.bound {
            return Some(e.node);
        }
    }
    None
}

impl<const W: usize> WideBvh<W> {
    /// The closest point on the tree's triangles to `p`, within `max_distance` (see
    /// [`crate::point`]). Equal to [`crate::brute::closest_point`] over the triangles the tree
    /// was built from, bit for bit. A tree over boxes ([`WideBvh::from_boxes`]) holds no
    /// triangles: `None`.
    pub fn closest_point<S: TraversalStats>(
        &self,
        p: Vec3A,
        max_distance: f32,
        stats: &mut S,
    ) -> Option<PointHit> {
        let q = Query::new(p, max_distance, &self.root_bounds)?;
        let mut best = Best::new(&q);
        self.point_traverse(&q, &mut best, stats, |best, leaf, stats| {
            let (first, n) = decode_leaf(leaf);
            for packet in &self.packets[first..first + n] {
                stats.triangles(packet.len());
                for lane in 0..4 {
                    let prim = packet.prims[lane];
                    // Padding lanes and degenerate triangles hold NaN vertices.
                    if prim != u32::MAX && !packet.v[0][0][lane].is_nan() {
                        best.offer_triangle(&q, &packet.triangle(lane), prim);
                    }
                }
            }
        });
        best.hit
    }

    /// The closest point on user primitives (a tree from [`WideBvh::from_boxes`] over
    /// `boxes`), with `closest(prim, p) -> Option<(point, distance_squared)>` (see
    /// [`crate::point`]). Equal to [`crate::brute::closest_point_custom`] bit for bit.
    ///
    /// # Panics
    ///
    /// If a leaf references a primitive outside `boxes`.
    pub fn closest_point_custom<F, S>(
        &self,
        boxes: &[Aabb],
        p: Vec3A,
        max_distance: f32,
        mut closest: F,
        stats: &mut S,
    ) -> Option<PointHit>
    where
        F: FnMut(u32, Vec3A) -> Option<(Vec3A, f64)>,
        S: TraversalStats,
    {
        let q = Query::new(p, max_distance, &self.root_bounds)?;
        let mut best = Best::new(&q);
        self.point_traverse(&q, &mut best, stats, |best, leaf, stats| {
            let (first, n) = decode_leaf(leaf);
            for packet in &self.packets[first..first + n] {
                stats.triangles(packet.len());
                for &prim in packet.prims.iter().filter(|&&q| q != u32::MAX) {
                    best.offer_custom(&q, &boxes[prim as usize], prim, &mut closest);
                }
            }
        });
        best.hit
    }

    /// The traversal of a wide tree, nearest child first; `leaf` gets each leaf reference.
    fn point_traverse<S, L>(&self, q: &Query, best: &mut Best, stats: &mut S, mut leaf: L)
    where
        S: TraversalStats,
        L: FnMut(&mut Best, u32, &mut S),
    {
        if self.root == NO_ROOT || q.lower_aabb(&self.root_bounds) > best.bound {
            return;
        }
        let mut stack: Vec<Entry> = Vec::with_capacity(4 * W);
        let mut cur = self.root;
        loop {
            if cur & LEAF_BIT != 0 {
                stats.leaf();
                leaf(best, cur, stats);
            } else {
                stats.inner();
                let node = &self.nodes[cur as usize];
                let b = &node.bounds;
                // The lower bounds of all slots (unused ones are empty boxes: `+∞`).
                let mut d = [0.0f64; W];
                for a in 0..3 {
                    let (lo, hi) = (&b[2 * a], &b[2 * a + 1]);
                    for (s, ds) in d.iter_mut().enumerate() {
                        let g = (lo[s] as f64 - q.pd[a]).max(q.pd[a] - hi[s] as f64) - q.pad;
                        if g > 0.0 {
                            *ds += g * g;
                        }
                    }
                }
                // The used slots within the bound, sorted by distance (ties: slot order).
                let mut keep = [Entry {
                    node: 0,
                    lower: 0.0,
                }; W];
                let mut n = 0;
                for (s, &ds) in d.iter().enumerate() {
                    if node.valid & (1 << s) != 0 && ds <= best.bound {
                        let e = Entry {
                            node: node.children[s],
                            lower: ds,
                        };
                        let mut i = n;
                        while i > 0 && keep[i - 1].lower > e.lower {
                            keep[i] = keep[i - 1];
                            i -= 1;
                        }
                        keep[i] = e;
                        n += 1;
                    }
                }
                if n > 0 {
                    stack.extend(keep[1..n].iter().rev());
                    cur = keep[0].node;
                    continue;
                }
            }
            match pop(&mut stack, best) {
                Some(n) => cur = n,
                None => return,
            }
        }
    }
}
