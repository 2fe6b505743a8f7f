//! Traversal over any primitive: a user intersection callback instead of the triangle test,
//! and an any-hit filter callback (alpha-tested leaves) for triangles.
//!
//! The tree is built from the primitives' boxes (`BuildInput::from_boxes` in
//! `sahara-builders`, with a split callback for spatial splits); traversal is given the same
//! boxes and a callback `intersect(ray, prim, tmin, tmax) -> Option<(t, data)>`. This module
//! holds the binary-tree kernels and the brute-force references; the wide trees have the same
//! queries ([`crate::WideBvh::closest_hit_custom`], built by [`crate::WideBvh::from_boxes`]).
//!
//! # The hit rule for user primitives
//!
//! The kernels cull a box with the slab test over `[lower_distance(tmin),
//! cull_distance(min(best t, tmax))]`, as for triangles. What keeps "no box holding a hit at or
//! before the best one is culled" true for any callback is the rule every candidate passes
//! ([`accept_primitive_hit`], the counterpart of
//! [`accept_hit`](sahara_geom::intersect::accept_hit) for triangles):
//!
//! * `[n, f]` is the ray's computed span through the primitive's **box** (the one given at build
//!   time, [`primitive_span`]);
//! * the callback's `t` must lie in the ray's `[tmin, tmax]` (finite);
//! * it is clamped into the span, `t_c = min(max(t, n), f)`, and `t_c` must lie in `[tmin,
//!   tmax]`: `t_c` is the reported distance.
//!
//! So a reported hit lies in its box's span, its box passes the culling slab test, and so does
//! every box containing it (the slab distances are monotonic in the box): every kernel returns
//! the brute-force result ([`brute_closest_hit`]) **bit for bit, whatever the callback
//! computes**, provided the callback is a pure function of its arguments and
//!
//! * **the primitive lies inside its box**: otherwise the callback's exact hits outside the box
//!   are clamped onto the box's span (the answer stays deterministic and equal to brute force,
//!   but it is not the primitive's distance any more); for a primitive inside its box the exact
//!   hit lies in the span, so clamping only moves a rounded `t` towards it;
//! * **the answer does not depend on the interval** except for being reported or not: the
//!   callback returns the `t` it would return for the ray's whole interval when that `t` lies in
//!   the `[tmin, tmax]` it is given, and a miss (or that same `t`) otherwise. The kernels pass
//!   `tmax` = the current best distance when that cannot drop a better hit (a `t` beyond it
//!   would be clamped to at least `min(t, f) >` best: see [`callback_tmax`]), else the ray's
//!   `tmax`, so callbacks can stop early (an instance's bottom-level traversal culls with it);
//! * **ties**: at exactly the same reported distance the lowest primitive index wins, as for
//!   triangles.
//!
//! Primitives whose span misses `[tmin, tmax]`, or starts beyond the current best hit, are not
//! even given to the callback (they could not pass the rule).
//!
//! With spatial splits (a split callback at build time) the primitive's box is still its whole
//! box; leaves only hold clipped parts of it, and the callback must only be conservative (each
//! part's box contains the primitive's part in that half), as for triangles.
//!
//! # Filters
//!
//! The filtered triangle queries ([`closest_hit_filtered`], [`any_hit_filtered`]) run the
//! built-in watertight test, then ask `filter(&hit)` whether to keep the candidate (an alpha
//! texture lookup at `u`, `v`, say). The filter is called only for candidates that would change
//! the answer (nearer than the best kept hit, or an equal distance on a lower index), in an
//! order that depends on the tree: it must be a pure function of the hit. Then the result is
//! the brute-force result with the same filter, bit for bit. For user primitives the
//! intersection callback is its own filter (return a miss to reject).
//!
//! ```
//! use sahara_bvh::{Bvh, Node};
//! use sahara_geom::{Aabb, Ray, Vec3A};
//! use sahara_traverse::{custom, NoStats};
//!
//! // One sphere of radius 1 at z = 3, as a user primitive.
//! let (c, r) = (Vec3A::new(0.0, 0.0, 3.0), 1.0f32);
//! let boxes = [Aabb::new(c - r, c + r)];
//! let bvh = Bvh { nodes: vec![Node::leaf(&boxes[0], 0, 1)], prim_indices: vec![0], spatial_splits: false, ref_cuts: None };
//! let sphere = |ray: &Ray, _prim: u32, tmin: f32, tmax: f32| {
//!     let oc = ray.origin - c;
//!     let (a, b, k) = (ray.direction().dot(ray.direction()), oc.dot(ray.direction()), oc.dot(oc) - r * r);
//!     let disc = b * b - a * k;
//!     let t = (-b - disc.max(0.0).sqrt()) / a;
//!     (disc >= 0.0 && t >= tmin && t <= tmax).then_some((t, ()))
//! };
//! let ray = Ray::new(Vec3A::ZERO, Vec3A::Z, 0.0, f32::INFINITY);
//! let hit = custom::closest_hit(&bvh, &boxes, &ray, sphere, &mut NoStats).unwrap();
//! assert_eq!(hit.t, 2.0);
//! assert_eq!(Some(hit), custom::brute_closest_hit(&boxes, &ray, sphere));
//! ```

use crate::{scalar, Hit, TraversalStats};
use sahara_bvh::Bvh;
use sahara_geom::intersect::{clamp_to_span, intersect_triangle, slab_span, WatertightRay};
use sahara_geom::{Aabb, Ray, Triangle};

/// A hit on a user primitive: the reported distance, the primitive and the callback's data.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct PrimHit<D> {
    /// Ray parameter of the hit (the callback's `t` clamped by [`accept_primitive_hit`]).
    pub t: f32,
    /// Index of the primitive hit.
    pub prim: u32,
    /// What the callback returned with the distance (surface coordinates, a normal, ...).
    pub data: D,
}

/// The primitives of a tree that holds triangles and user primitives together
/// ([`crate::WideBvh::from_mixed`], [`crate::WideBvh::closest_hit_mixed`]): every primitive's
/// box (for a triangle, exactly its bounds), and for each primitive the index of its triangle
/// in `triangles`, or `u32::MAX` for a user primitive (traced by the intersection callback).
///
/// ```
/// use sahara_builders::{registry, BuildInput, CostModel};
/// use sahara_geom::{Aabb, Ray, Triangle, Vec3A};
/// use sahara_traverse::{custom::MixedPrims, Bvh8, NoStats};
///
/// // Primitive 0: a triangle at z = 2; primitive 1: a user box at z = 1 that reports its
/// // entry distance.
/// let tri = Triangle::new(Vec3A::new(-1.0, -1.0, 2.0), Vec3A::new(1.0, -1.0, 2.0), Vec3A::new(0.0, 1.0, 2.0));
/// let boxes = [tri.bounds(), Aabb::new(Vec3A::new(-0.5, -0.5, 1.0), Vec3A::new(0.5, 0.5, 1.5))];
/// let prims = MixedPrims { boxes: &boxes, triangles: &[tri], triangle_of: &[0, u32::MAX] };
/// assert_eq!((prims.triangle(0), prims.triangle(1)), (Some(0), None));
/// let input = BuildInput::from_boxes(&boxes, CostModel::default()).unwrap();
/// let bvh = registry::by_name("binned").unwrap().build(&input).unwrap();
/// let wide = Bvh8::from_mixed(&bvh, prims);
/// let ray = Ray::new(Vec3A::ZERO, Vec3A::Z, 0.0, f32::INFINITY);
/// let entry = |_: &Ray, _: u32, _: f32, _: f32| Some((1.0, "box"));
/// let hit = wide.closest_hit_mixed(prims, &ray, |_| Some("triangle"), entry, &mut NoStats);
/// assert_eq!(hit.map(|h| (h.t, h.data)), Some((1.0, "box")));
/// // A ray that starts past the box hits the triangle (the box's distance fails the hit
/// // rule), unless `accept` rejects it.
/// let past = Ray::new(Vec3A::new(0.0, 0.0, 1.75), Vec3A::Z, 0.0, f32::INFINITY);
/// let hit = wide.closest_hit_mixed(prims, &past, |_| Some("triangle"), entry, &mut NoStats);
/// assert_eq!(hit.map(|h| (h.t, h.data)), Some((0.25, "triangle")));
/// assert!(wide.closest_hit_mixed(prims, &past, |_| None, entry, &mut NoStats).is_none());
/// ```
#[derive(Clone, Copy, Debug)]
pub struct MixedPrims<'a> {
    /// The box of every primitive (a triangle's must be its [`Triangle::bounds`]).
    pub boxes: &'a [Aabb],
    /// The triangles.
    pub triangles: &'a [Triangle],
    /// Per primitive, its triangle's index in `triangles`, or `u32::MAX` for a user primitive
    /// (as long as `boxes`).
    pub triangle_of: &'a [u32],
}

impl MixedPrims<'_> {
    /// The index in `triangles` of primitive `prim`'s triangle, or `None` for a user primitive.
    #[inline]
    pub fn triangle(&self, prim: u32) -> Option<u32> {
        let i = self.triangle_of[prim as usize];
        (i != u32::MAX).then_some(i)
    }
}

/// The ray's computed entry and exit `(n, f)` through a primitive's box: [`slab_span`] with
/// the far-plane rounding of the ray (`tmin < 0` rays also widen negative far distances).
#[inline]
pub fn primitive_span(ray: &Ray, bounds: &Aabb) -> (f32, f32) {
    slab_span(ray.origin, ray.inv_direction(), ray.tmin < 0.0, bounds)
}

/// The hit rule of user primitives (see the [module documentation](self)): the callback's
/// distance `t` must lie in `[ray.tmin, ray.tmax]`; it is clamped into the primitive's box span
/// `span = (n, f)` ([`primitive_span`]), and the clamped distance, which is returned, must lie
/// in `[ray.tmin, ray.tmax]` too. NaN and infinite distances, and empty spans, are misses.
#[inline]
pub fn accept_primitive_hit(ray: &Ray, span: (f32, f32), t: f32) -> Option<f32> {
    let (n, f) = span;
    if !(t >= ray.tmin && t <= ray.tmax && t.is_finite() && n <= f) {
        return None;
    }
    let tc = clamp_to_span(t, n, f);
    (tc >= ray.tmin && tc <= ray.tmax && tc.is_finite()).then_some(tc)
}

/// The `tmax` a closest-hit kernel passes to the callback for a primitive whose box span ends
/// at `f`, when the best hit so far is at `best_t` (`+∞` before the first hit): `best_t` (at
/// most the ray's `tmax`) when `f > best_t`, since a callback distance beyond `best_t` is then
/// clamped to `min(t, f) > best_t` and could not win; the ray's `tmax` otherwise (every
/// distance clamps to at most `f <= best_t`).
#[inline]
pub fn callback_tmax(ray: &Ray, f: f32, best_t: f32) -> f32 {
    if f > best_t {
        best_t.min(ray.tmax)
    } else {
        ray.tmax
    }
}

/// The user primitives of a query: their boxes and the intersection callback.
pub(crate) struct UserPrims<'a, F> {
    pub(crate) boxes: &'a [Aabb],
    pub(crate) intersect: F,
}

impl<F> UserPrims<'_, F> {
    /// The candidate `prim` under the hit rule, given the best distance so far (`+∞` for none).
    #[inline]
    pub(crate) fn closest<D>(&mut self, ray: &Ray, prim: u32, best_t: f32) -> Option<(f32, D)>
    where
        F: FnMut(&Ray, u32, f32, f32) -> Option<(f32, D)>,
    {
        let span = primitive_span(ray, &self.boxes[prim as usize]);
        let (n, f) = span;
        // Cannot pass the rule (`t_c` lies in the span and the interval) or beat the best hit.
        if !(n <= f && n <= ray.tmax && f >= ray.tmin && n <= best_t) {
            return None;
        }
        let tmax = callback_tmax(ray, f, best_t);
        let (t, d) = (self.intersect)(ray, prim, ray.tmin, tmax)?;
        accept_primitive_hit(ray, span, t).map(|t| (t, d))
    }

    /// Any-hit: true when `prim` has a hit under the hit rule.
    #[inline]
    pub(crate) fn any<D>(&mut self, ray: &Ray, prim: u32) -> bool
    where
        F: FnMut(&Ray, u32, f32, f32) -> Option<(f32, D)>,
    {
        self.closest(ray, prim, f32::INFINITY).is_some()
    }
}

/// Keeps `(t, prim, data)` when it beats `best`: nearer, or equally near on a lower index.
#[inline]
pub(crate) fn offer<D>(best: &mut Option<PrimHit<D>>, t: f32, prim: u32, data: D) {
    let better = match best {
        None => true,
        Some(b) => t < b.t || (t == b.t && prim < b.prim),
    };
    if better {
        *best = Some(PrimHit { t, prim, data });
    }
}

/// Closest hit on user primitives over the binary tree built from `boxes`: `intersect(ray,
/// prim, tmin, tmax)` returns the primitive's distance and data, or `None` (see the
/// [module documentation](self) for what it must guarantee). Invalid rays miss.
///
/// # Panics
///
/// If the tree references a primitive outside `boxes` (it was built over other primitives).
pub fn closest_hit<D, F, S>(
    bvh: &Bvh,
    boxes: &[Aabb],
    ray: &Ray,
    intersect: F,
    stats: &mut S,
) -> Option<PrimHit<D>>
where
    F: FnMut(&Ray, u32, f32, f32) -> Option<(f32, D)>,
    S: TraversalStats,
{
    let mut prims = UserPrims { boxes, intersect };
    scalar::closest_walk(bvh, ray, stats, |p, best| prims.closest(ray, p, best))
}

/// Any hit on user primitives over the binary tree: true when some primitive has a hit under
/// the hit rule (exactly when [`closest_hit`] finds one). Invalid rays miss.
///
/// # Panics
///
/// As [`closest_hit`].
pub fn any_hit<D, F, S>(bvh: &Bvh, boxes: &[Aabb], ray: &Ray, intersect: F, stats: &mut S) -> bool
where
    F: FnMut(&Ray, u32, f32, f32) -> Option<(f32, D)>,
    S: TraversalStats,
{
    let mut prims = UserPrims { boxes, intersect };
    scalar::any_walk(bvh, ray, stats, |p| prims.any(ray, p))
}

/// The brute-force reference of [`closest_hit`]: every primitive, in index order, under the
/// same hit rule.
pub fn brute_closest_hit<D, F>(boxes: &[Aabb], ray: &Ray, intersect: F) -> Option<PrimHit<D>>
where
    F: FnMut(&Ray, u32, f32, f32) -> Option<(f32, D)>,
{
    if !ray.is_valid() {
        return None;
    }
    let mut prims = UserPrims { boxes, intersect };
    let mut best = None;
    for p in 0..boxes.len() as u32 {
        let bt = best.as_ref().map_or(f32::INFINITY, |h: &PrimHit<D>| h.t);
        if let Some((t, d)) = prims.closest(ray, p, bt) {
            offer(&mut best, t, p, d);
        }
    }
    best
}

/// The brute-force reference of [`any_hit`].
pub fn brute_any_hit<D, F>(boxes: &[Aabb], ray: &Ray, intersect: F) -> bool
where
    F: FnMut(&Ray, u32, f32, f32) -> Option<(f32, D)>,
{
    if !ray.is_valid() {
        return false;
    }
    let mut prims = UserPrims { boxes, intersect };
    (0..boxes.len() as u32).any(|p| prims.any(ray, p))
}

/// The watertight test of triangle `prim` as a [`Hit`].
#[inline]
pub(crate) fn triangle_hit(w: &WatertightRay, tri: &Triangle, ray: &Ray, prim: u32) -> Option<Hit> {
    intersect_triangle(w, tri, ray.tmin, ray.tmax).map(|h| Hit {
        t: h.t,
        prim,
        u: h.u,
        v: h.v,
    })
}

/// Closest hit on triangles with an any-hit filter: the hits of the built-in watertight test
/// that `filter` keeps (see [Filters](self#filters)). Invalid rays miss; a miss is
/// [`Hit::MISS`].
///
/// # Panics
///
/// If the tree references a triangle outside `tris`.
pub fn closest_hit_filtered<G, S>(
    bvh: &Bvh,
    tris: &[Triangle],
    ray: &Ray,
    mut filter: G,
    stats: &mut S,
) -> Hit
where
    G: FnMut(&Hit) -> bool,
    S: TraversalStats,
{
    let w = ray.watertight();
    let mut best = Hit::MISS;
    let found = scalar::closest_walk(bvh, ray, stats, |p, _| {
        let h = triangle_hit(&w, &tris[p as usize], ray, p)?;
        // Only candidates that would change the answer reach the filter.
        (best.is_improved_by(h.t, p) && filter(&h)).then(|| {
            best = h;
            (h.t, h)
        })
    });
    found.map_or(Hit::MISS, |h| h.data)
}

/// Any hit on triangles with an any-hit filter: true when some hit of the watertight test in
/// `[tmin, tmax]` is kept by `filter` (a shadow ray through alpha-tested leaves).
///
/// # Panics
///
/// As [`closest_hit_filtered`].
pub fn any_hit_filtered<G, S>(
    bvh: &Bvh,
    tris: &[Triangle],
    ray: &Ray,
    mut filter: G,
    stats: &mut S,
) -> bool
where
    G: FnMut(&Hit) -> bool,
    S: TraversalStats,
{
    let w = ray.watertight();
    scalar::any_walk(bvh, ray, stats, |p| {
        triangle_hit(&w, &tris[p as usize], ray, p).is_some_and(|h| filter(&h))
    })
}

/// The brute-force reference of [`closest_hit_filtered`].
pub fn brute_closest_hit_filtered<G: FnMut(&Hit) -> bool>(
    tris: &[Triangle],
    ray: &Ray,
    mut filter: G,
) -> Hit {
    let mut best = Hit::MISS;
    if !ray.is_valid() {
        return best;
    }
    let w = ray.watertight();
    for (i, tri) in tris.iter().enumerate() {
        if let Some(h) = triangle_hit(&w, tri, ray, i as u32) {
            if best.is_improved_by(h.t, h.prim) && filter(&h) {
                best = h;
            }
        }
    }
    best
}

/// The brute-force reference of [`any_hit_filtered`].
pub fn brute_any_hit_filtered<G: FnMut(&Hit) -> bool>(
    tris: &[Triangle],
    ray: &Ray,
    mut filter: G,
) -> bool {
    if !ray.is_valid() {
        return false;
    }
    let w = ray.watertight();
    tris.iter()
        .enumerate()
        .any(|(i, tri)| triangle_hit(&w, tri, ray, i as u32).is_some_and(|h| filter(&h)))
}
