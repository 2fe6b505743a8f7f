//! Cutting primitives at a plane: the [`SplitPrimitive`] callback through which primitives
//! other than triangles are cut, the [`Clipper`] the builders hold (triangles clipped exactly,
//! or a user's [`SplitPrimitive`]), the clipping of a triangle reference into the slabs of a
//! spatial binning ([`SlabClipper`]) and the two cuts of a triangle at a plane: exact
//! ([`clip_halves`], for applied splits) and in `f32` ([`plane_pieces`], for estimates).

use std::ops::RangeInclusive;

use glam::BVec3A;
pub use sahara_geom::clip::clip_halves;
use sahara_geom::{Aabb, Axis, Triangle, Vec3A};

use crate::split::BinMap;

/// A primitive that spatial splits can cut: the callback of [`crate::BuildInput::with_splitter`].
pub trait SplitPrimitive: Sync {
    /// Bounds of the parts of primitive `prim` inside the two halves of `bounds` (the box of
    /// the reference being cut) below and above the plane `x[axis] = pos`. Each part must
    /// contain all of the primitive that lies in its half of `bounds`, and lie inside that
    /// half; a half the primitive does not reach is [`Aabb::EMPTY`].
    fn split(&self, prim: u32, axis: Axis, pos: f32, bounds: &Aabb) -> (Aabb, Aabb);

    /// Calls `f(bin, part)` for every bin of `bins` (`first..=last`, `first < last`) of `map`
    /// that the reference spans, with the bounds of the part of the primitive in that bin
    /// (used to rate spatial splits; an estimate is fine). The default cuts the reference at
    /// each plane in turn with [`split`](Self::split).
    fn bin(
        &self,
        prim: u32,
        axis: Axis,
        bounds: &Aabb,
        map: &BinMap,
        bins: RangeInclusive<usize>,
        f: &mut dyn FnMut(usize, &Aabb),
    ) {
        let (first, last) = (*bins.start(), *bins.end());
        let mut rest = *bounds;
        for b in first..last {
            let (l, r) = self.split(prim, axis, map.plane(b + 1), &rest);
            if !l.is_empty() {
                f(b, &l);
            }
            rest = r;
            if rest.is_empty() {
                return;
            }
        }
        f(last, &rest);
    }

    /// Bounds of the parts of the primitive on each side of the plane, for a rating (an
    /// estimate is fine). The default is [`split`](Self::split).
    fn estimate(&self, prim: u32, axis: Axis, pos: f32, bounds: &Aabb) -> (Aabb, Aabb) {
        self.split(prim, axis, pos, bounds)
    }
}

/// How the builders cut primitives: triangles (by exact clipping, dispatched statically) or a
/// user's [`SplitPrimitive`].
#[derive(Clone, Copy)]
pub enum Clipper<'a> {
    /// Triangles, clipped.
    Triangles(&'a [Triangle]),
    /// Another kind of primitive.
    Custom(&'a dyn SplitPrimitive),
}

impl std::fmt::Debug for Clipper<'_> {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            Clipper::Triangles(t) => write!(f, "Clipper::Triangles({})", t.len()),
            Clipper::Custom(_) => f.write_str("Clipper::Custom"),
        }
    }
}

impl Clipper<'_> {
    /// See [`SplitPrimitive::split`]. Triangles are clipped exactly ([`clip_halves`]).
    #[inline]
    pub fn split(&self, prim: u32, axis: Axis, pos: f32, bounds: &Aabb) -> (Aabb, Aabb) {
        match self {
            Clipper::Triangles(t) => clip_halves(&t[prim as usize], axis, pos, bounds),
            Clipper::Custom(c) => c.split(prim, axis, pos, bounds),
        }
    }

    /// See [`SplitPrimitive::bin`]. Triangles are clipped into the slabs ([`SlabClipper`]).
    #[inline]
    pub fn bin(
        &self,
        prim: u32,
        axis: Axis,
        bounds: &Aabb,
        map: &BinMap,
        bins: RangeInclusive<usize>,
        mut f: impl FnMut(usize, &Aabb),
    ) {
        match self {
            Clipper::Triangles(t) => SlabClipper::new(&t[prim as usize], axis, bounds).bin(
                map,
                *bins.start(),
                *bins.end(),
                f,
            ),
            Clipper::Custom(c) => c.bin(prim, axis, bounds, map, bins, &mut f),
        }
    }

    /// See [`SplitPrimitive::estimate`]. Triangles: [`plane_pieces`].
    #[inline]
    pub fn estimate(&self, prim: u32, axis: Axis, pos: f32, bounds: &Aabb) -> (Aabb, Aabb) {
        match self {
            Clipper::Triangles(t) => plane_pieces(&t[prim as usize], axis, pos, bounds),
            Clipper::Custom(c) => c.estimate(prim, axis, pos, bounds),
        }
    }
}

/// Clips a triangle reference into the consecutive slabs of a spatial binning.
///
/// Equivalent to cutting the reference with [`sahara_geom::clip::split_triangle_bounds`] at
/// every plane it straddles, from left to right, but each plane's crossing points (where the
/// triangle's edges pierce it) are computed once and shared by the two bins that plane
/// bounds, in `f32`. The box of a bin's piece is the bounds of the triangle's vertices inside
/// the slab and of the crossing points on its two planes, intersected with the reference's box
/// and the slab: the bounds of the real triangle clipped to the slab, up to rounding. Binning
/// only estimates costs; the split that is finally applied clips exactly ([`clip_halves`]).
pub struct SlabClipper<'a> {
    pub(super) axis: Axis,
    pub(super) bounds: &'a Aabb,
    /// The vertices sorted by their coordinate on `axis`.
    pub(super) v: [Vec3A; 3],
    /// Per unit of `axis`, the direction of the edges v0→v2, v0→v1 and v1→v2.
    pub(super) dir: [Vec3A; 3],
}

impl<'a> SlabClipper<'a> {
    /// The clipper of `tri`'s reference with box `bounds` along `axis`. Always inlined: the
    /// SIMD binning reads it right away, and a returned copy stalls on store forwarding.
    #[inline(always)]
    pub fn new(tri: &Triangle, axis: Axis, bounds: &'a Aabb) -> Self {
        let mut v = tri.v;
        if v[0][axis] > v[1][axis] {
            v.swap(0, 1);
        }
        if v[1][axis] > v[2][axis] {
            v.swap(1, 2);
        }
        if v[0][axis] > v[1][axis] {
            v.swap(0, 1);
        }
        let d = |p: Vec3A, q: Vec3A| {
            let da = q[axis] - p[axis];
            if da > 0.0 {
                (q - p) / da
            } else {
                Vec3A::ZERO
            }
        };
        let dir = [d(v[0], v[2]), d(v[0], v[1]), d(v[1], v[2])];
        Self {
            axis,
            bounds,
            v,
            dir,
        }
    }

    /// Bounds of the points where the triangle's edges cross the plane `x[axis] = pos`.
    #[inline]
    fn crossing(&self, pos: f32) -> Aabb {
        let a = self.axis;
        let v = &self.v;
        if !(pos > v[0][a] && pos < v[2][a]) {
            return Aabb::EMPTY;
        }
        // The points' coordinate on `axis` is `pos` up to rounding; the caller clamps it.
        let long = v[0] + self.dir[0] * (pos - v[0][a]);
        let short = if pos < v[1][a] {
            v[0] + self.dir[1] * (pos - v[0][a])
        } else {
            v[1] + self.dir[2] * (pos - v[1][a])
        };
        Aabb::new(long.min(short), long.max(short))
    }

    /// The lane mask of the clipper's axis (lane masks instead of writes to one lane: those go
    /// through memory and stall).
    #[inline(always)]
    pub(super) fn axis_mask(&self) -> BVec3A {
        Vec3A::new(0.0, 1.0, 2.0).cmpeq(Vec3A::splat(self.axis as f32))
    }

    /// The bounds of the piece of the triangle in the slab `lower_pos..=upper_pos` of the axis
    /// (`mask` is [`axis_mask`](Self::axis_mask)): the crossings `lower` and `upper` of its
    /// planes and the vertices between them, clamped to the reference's box and the slab
    /// (empty when the triangle misses the slab).
    #[inline(always)]
    pub(super) fn piece(
        &self,
        mask: BVec3A,
        lower_pos: f32,
        lower: &Aabb,
        upper_pos: f32,
        upper: &Aabb,
    ) -> Aabb {
        let a = self.axis;
        let mut piece = lower.union(upper);
        for p in &self.v {
            if p[a] >= lower_pos && p[a] <= upper_pos {
                piece.grow(*p);
            }
        }
        let slab = Aabb::new(
            Vec3A::select(mask, Vec3A::splat(lower_pos), self.bounds.min),
            Vec3A::select(mask, Vec3A::splat(upper_pos), self.bounds.max),
        );
        piece.intersection(self.bounds).intersection(&slab)
    }

    /// Calls `f(bin, piece_bounds)` for every bin `first..=last` the reference spans.
    #[inline]
    pub fn bin(&self, map: &BinMap, first: usize, last: usize, mut f: impl FnMut(usize, &Aabb)) {
        let mask = self.axis_mask();
        let mut lower_pos = f32::NEG_INFINITY;
        let mut lower = Aabb::EMPTY;
        for b in first..=last {
            let (upper_pos, upper) = if b == last {
                (f32::INFINITY, Aabb::EMPTY)
            } else {
                let p = map.plane(b + 1);
                (p, self.crossing(p))
            };
            let piece = self.piece(mask, lower_pos, &lower, upper_pos, &upper);
            if !piece.is_empty() {
                f(b, &piece);
            }
            lower_pos = upper_pos;
            lower = upper;
        }
    }
}

/// Bounds of the parts of `tri` on each side of the plane `x[axis] = pos` (its vertices on
/// that side and the points where its edges cross the plane), intersected with the
/// reference's box `b` and the half space, as the binning bounds a piece (in `f32`; an
/// estimate for ratings, see [`super::estimated_spatial_search`]).
#[inline]
pub fn plane_pieces(tri: &Triangle, axis: Axis, pos: f32, b: &Aabb) -> (Aabb, Aabb) {
    let mut l = Aabb::EMPTY;
    let mut r = Aabb::EMPTY;
    for k in 0..3 {
        let p = tri.v[k];
        let q = tri.v[(k + 1) % 3];
        let (pa, qa) = (p[axis], q[axis]);
        if pa <= pos {
            l.grow(p);
        }
        if pa >= pos {
            r.grow(p);
        }
        if (pa < pos && qa > pos) || (pa > pos && qa < pos) {
            let x = p + (q - p) * ((pos - pa) / (qa - pa));
            l.grow(x);
            r.grow(x);
        }
    }
    let mut lb = *b;
    lb.max[axis] = lb.max[axis].min(pos);
    let mut rb = *b;
    rb.min[axis] = rb.min[axis].max(pos);
    (l.intersection(&lb), r.intersection(&rb))
}
