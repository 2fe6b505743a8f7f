//! Clipping triangles against boxes and planes.
//!
//! Spatial splits (SBVH) need the bounds of the part of a triangle on each side of a plane;
//! the EPO metric needs the area of the part of a triangle inside a node's box. Both clip the
//! actual triangle, not its bounding box.

use crate::{Aabb, Axis, Triangle};
use glam::Vec3A;

/// Largest number of vertices a triangle clipped by the six planes of a box can have.
pub const MAX_CLIPPED_VERTICES: usize = 9;

/// A convex polygon of at most [`MAX_CLIPPED_VERTICES`] vertices (the result of clipping).
#[derive(Clone, Copy, Debug)]
pub struct ClippedPolygon {
    vertices: [Vec3A; MAX_CLIPPED_VERTICES],
    len: usize,
}

impl ClippedPolygon {
    fn from_triangle(t: &Triangle) -> Self {
        let mut vertices = [Vec3A::ZERO; MAX_CLIPPED_VERTICES];
        vertices[..3].copy_from_slice(&t.v);
        Self { vertices, len: 3 }
    }

    /// The polygon's vertices (empty when nothing of the triangle is inside).
    pub fn vertices(&self) -> &[Vec3A] {
        &self.vertices[..self.len]
    }

    /// True when nothing is left.
    pub fn is_empty(&self) -> bool {
        self.len == 0
    }

    /// Area of the polygon (a fan from its first vertex, summed in `f64`).
    pub fn area(&self) -> f64 {
        if self.len < 3 {
            return 0.0;
        }
        let p0 = self.vertices[0].as_dvec3();
        let mut sum = glam::DVec3::ZERO;
        for i in 1..self.len - 1 {
            let a = self.vertices[i].as_dvec3() - p0;
            let b = self.vertices[i + 1].as_dvec3() - p0;
            sum += a.cross(b);
        }
        0.5 * sum.length()
    }

    /// Bounds of the polygon (empty when nothing is left).
    pub fn bounds(&self) -> Aabb {
        Aabb::from_points(self.vertices().iter().copied())
    }

    /// Keeps the part with `sign * (p[axis] - pos) <= 0`; `sign = 1` keeps the lower side.
    fn clip_plane(&mut self, axis: Axis, pos: f32, keep_below: bool) {
        if self.len == 0 {
            return;
        }
        let inside = |p: Vec3A| {
            if keep_below {
                p[axis] <= pos
            } else {
                p[axis] >= pos
            }
        };
        let mut out = [Vec3A::ZERO; MAX_CLIPPED_VERTICES];
        let mut n = 0;
        for i in 0..self.len {
            let a = self.vertices[i];
            let b = self.vertices[(i + 1) % self.len];
            let (ia, ib) = (inside(a), inside(b));
            if ia && n < MAX_CLIPPED_VERTICES {
                out[n] = a;
                n += 1;
            }
            if ia != ib {
                let p = plane_point(a, b, axis, pos);
                if n < MAX_CLIPPED_VERTICES {
                    out[n] = p;
                    n += 1;
                }
            }
        }
        self.vertices = out;
        self.len = n;
    }
}

/// The point where segment `a`–`b` crosses the plane `p[axis] = pos` (the plane coordinate is
/// set exactly, the others interpolated in `f64`).
#[inline]
fn plane_point(a: Vec3A, b: Vec3A, axis: Axis, pos: f32) -> Vec3A {
    let (da, db) = (a[axis] as f64, b[axis] as f64);
    let t = ((pos as f64 - da) / (db - da)).clamp(0.0, 1.0);
    let p = a.as_dvec3() + (b.as_dvec3() - a.as_dvec3()) * t;
    let mut p = p.as_vec3a();
    p[axis] = pos;
    p
}

/// Clips a triangle to a box (Sutherland–Hodgman against the six planes).
pub fn clip_triangle(tri: &Triangle, aabb: &Aabb) -> ClippedPolygon {
    let mut poly = ClippedPolygon::from_triangle(tri);
    if aabb.is_empty() {
        poly.len = 0;
        return poly;
    }
    if aabb.contains_aabb(&tri.bounds()) {
        return poly;
    }
    for axis in 0..3 {
        poly.clip_plane(axis, aabb.min[axis], false);
        poly.clip_plane(axis, aabb.max[axis], true);
    }
    poly
}

/// Area of the part of `tri` inside `aabb`.
pub fn clipped_area(tri: &Triangle, aabb: &Aabb) -> f64 {
    if aabb.contains_aabb(&tri.bounds()) {
        return tri.area();
    }
    clip_triangle(tri, aabb).area()
}

/// Bounds of the part of `tri` inside `aabb` (empty when they do not meet).
pub fn clipped_bounds(tri: &Triangle, aabb: &Aabb) -> Aabb {
    clip_triangle(tri, aabb).bounds().intersection(aabb)
}

/// Bounds of the parts of `tri` inside the two halves of `cur` cut at `pos` on `axis`: how
/// the spatial-split builders cut a triangle reference (`cur` is the reference's box), and how
/// refitting replays those cuts on moved triangles (`sahara_bvh::RefCuts`).
///
/// The triangle is clipped to each half box, so a non-empty half touches the triangle. The
/// clipped polygon's vertices are rounded to `f32`, which may move them off the triangle by
/// half a unit in the last place: on a triangle that is almost flat along an axis this is
/// enough for the rounded box to miss the real triangle. Each piece's box is therefore grown
/// by about two units in the last place and then intersected with its half box again, so that
/// it stays inside the reference's box and on its side of the plane.
pub fn clip_halves(tri: &Triangle, axis: Axis, pos: f32, cur: &Aabb) -> (Aabb, Aabb) {
    let mut lbox = *cur;
    lbox.max[axis] = lbox.max[axis].min(pos);
    let mut rbox = *cur;
    rbox.min[axis] = rbox.min[axis].max(pos);
    let piece = |half: &Aabb| {
        let b = clipped_bounds(tri, half);
        if b.is_empty() {
            return b;
        }
        let slack = |v: Vec3A| v.abs() * (2.0 * f32::EPSILON) + Vec3A::splat(f32::MIN_POSITIVE);
        Aabb::new(b.min - slack(b.min), b.max + slack(b.max)).intersection(half)
    };
    (piece(&lbox), piece(&rbox))
}

/// Splits a triangle reference by the plane `p[axis] = pos`, as spatial splits do.
///
/// `current` is the reference's current box (a sub-box of the triangle's bounds after earlier
/// splits). Returns the bounds of the triangle's parts below and above the plane, each
/// intersected with `current`. The union of the two halves covers `current` ∩ triangle; a half
/// is empty when the triangle does not reach that side.
pub fn split_triangle_bounds(tri: &Triangle, axis: Axis, pos: f32, current: &Aabb) -> (Aabb, Aabb) {
    let mut left = Aabb::EMPTY;
    let mut right = Aabb::EMPTY;
    for i in 0..3 {
        let a = tri.v[i];
        let b = tri.v[(i + 1) % 3];
        if a[axis] <= pos {
            left.grow(a);
        }
        if a[axis] >= pos {
            right.grow(a);
        }
        if (a[axis] < pos && b[axis] > pos) || (a[axis] > pos && b[axis] < pos) {
            let p = plane_point(a, b, axis, pos);
            left.grow(p);
            right.grow(p);
        }
    }
    // Cap by the current box and by the plane itself.
    let mut l = left.intersection(current);
    let mut r = right.intersection(current);
    if !l.is_empty() {
        l.max[axis] = l.max[axis].min(pos);
    }
    if !r.is_empty() {
        r.min[axis] = r.min[axis].max(pos);
    }
    (l, r)
}

#[cfg(test)]
mod tests {
    use super::*;
    use approx::assert_relative_eq;

    #[test]
    fn clip_to_half_space() {
        let t = Triangle::new(
            Vec3A::ZERO,
            Vec3A::new(2.0, 0.0, 0.0),
            Vec3A::new(0.0, 2.0, 0.0),
        );
        let b = Aabb::new(Vec3A::splat(-1.0), Vec3A::new(1.0, 1.0, 1.0));
        let p = clip_triangle(&t, &b);
        // Unit square minus the corner triangle above x + y = 2 (none inside): area 1.
        assert_relative_eq!(p.area(), 1.0, epsilon = 1e-6);
        let bb = p.bounds();
        assert_relative_eq!(bb.max.x, 1.0);
        assert_relative_eq!(bb.max.y, 1.0);
    }

    #[test]
    fn disjoint_gives_nothing() {
        let t = Triangle::new(Vec3A::ZERO, Vec3A::X, Vec3A::Y);
        let b = Aabb::new(Vec3A::splat(5.0), Vec3A::splat(6.0));
        assert!(clip_triangle(&t, &b).is_empty());
        assert_eq!(clipped_area(&t, &b), 0.0);
        assert!(clipped_bounds(&t, &b).is_empty());
    }

    #[test]
    fn split_halves() {
        let t = Triangle::new(
            Vec3A::ZERO,
            Vec3A::new(2.0, 0.0, 0.0),
            Vec3A::new(0.0, 2.0, 0.0),
        );
        let (l, r) = split_triangle_bounds(&t, 0, 1.0, &t.bounds());
        assert_eq!(l, Aabb::new(Vec3A::ZERO, Vec3A::new(1.0, 2.0, 0.0)));
        assert_eq!(
            r,
            Aabb::new(Vec3A::new(1.0, 0.0, 0.0), Vec3A::new(2.0, 1.0, 0.0))
        );
    }
}
