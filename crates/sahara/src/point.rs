//! Closest-point queries on an [`Accel`]: the point of the triangles nearest to a query
//! point (signed distance fields, collision, snapping), one at a time or in batches.

use crate::{Accel, Vec3A};

/// The closest point of an [`Accel`]'s triangles to a query point
/// ([`Accel::closest_point`]).
///
/// `prim`, `point`, `distance_squared`, `u` and `v` are those of the kernel's
/// [`sahara_traverse::PointHit`]; `distance` and `normal` are derived from them.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct PointHit {
    /// Index of the triangle (its position in [`Accel::triangles`]).
    pub prim: u32,
    /// The closest point, `(1 - u - v) v0 + u v1 + v v2` (computed in `f64`, rounded to
    /// `f32`).
    pub point: Vec3A,
    /// The distance from the query point, `sqrt(distance_squared)` rounded to `f32`.
    pub distance: f32,
    /// The squared distance from the query point in `f64`, what the query minimises.
    pub distance_squared: f64,
    /// Barycentric weight of vertex 1.
    pub u: f32,
    /// Barycentric weight of vertex 2.
    pub v: f32,
    /// The triangle's unit geometric normal, `(v1 - v0) × (v2 - v0)` normalised (winding
    /// order; the triangle may face either way).
    pub normal: Vec3A,
}

impl Accel {
    /// The point of the triangles nearest to `p` within `max_distance` (inclusive; `+∞` for
    /// no limit), or `None`.
    ///
    /// Exact in the sense of the ray queries: the answer is the one of a brute-force scan of
    /// every triangle with the same closest-point routine
    /// ([`sahara_traverse::brute::closest_point`]), bit for bit; **at exactly the same
    /// distance the lowest triangle index wins**. Degenerate triangles (collinear vertices),
    /// which rays never hit, are never the answer. A query point with a NaN or infinite
    /// coordinate, or a negative or NaN `max_distance`, gives `None`. See
    /// `sahara_traverse::point` for the traversal (nearest box first) and why its pruning
    /// never drops the answer.
    ///
    /// ```
    /// use sahara::{Accel, Quality, Triangle, Vec3A};
    ///
    /// // A unit square in the plane z = 0, as two triangles.
    /// let tris = [
    ///     Triangle::new(Vec3A::ZERO, Vec3A::X, Vec3A::Y),
    ///     Triangle::new(Vec3A::X, Vec3A::new(1.0, 1.0, 0.0), Vec3A::Y),
    /// ];
    /// let accel = Accel::build(&tris, Quality::Medium)?;
    /// let hit = accel.closest_point(Vec3A::new(0.8, 0.9, 2.0), f32::INFINITY).unwrap();
    /// assert_eq!((hit.prim, hit.distance), (1, 2.0));
    /// assert_eq!(hit.point, Vec3A::new(0.8, 0.9, 0.0));
    /// assert_eq!(hit.normal, Vec3A::Z);
    /// // On the shared diagonal both triangles are at distance 0: the lower index wins.
    /// assert_eq!(accel.closest_point(Vec3A::new(0.5, 0.5, 0.0), 0.0).unwrap().prim, 0);
    /// // Farther than max_distance, or a NaN point: nothing.
    /// assert_eq!(accel.closest_point(Vec3A::new(0.5, 0.5, 3.0), 1.0), None);
    /// assert_eq!(accel.closest_point(Vec3A::NAN, 1.0), None);
    /// # Ok::<(), sahara::Error>(())
    /// ```
    pub fn closest_point(&self, p: Vec3A, max_distance: f32) -> Option<PointHit> {
        let hit = self
            .wide()
            .closest_point(p, max_distance, &mut sahara_traverse::NoStats)?;
        Some(PointHit {
            prim: hit.prim,
            point: hit.point,
            distance: hit.distance(),
            distance_squared: hit.distance_squared,
            u: hit.u,
            v: hit.v,
            normal: self.triangles()[hit.prim as usize].normal(),
        })
    }

    /// [`Accel::closest_point`] of every point, in parallel on the current rayon pool, in the
    /// order of `points` (the same answers whatever the thread count).
    ///
    /// ```
    /// use sahara::{Accel, Quality, Triangle, Vec3A};
    ///
    /// let tris = [Triangle::new(Vec3A::ZERO, Vec3A::X, Vec3A::Y)];
    /// let accel = Accel::build(&tris, Quality::Fast)?;
    /// let points = [Vec3A::new(0.1, 0.1, 1.0), Vec3A::new(0.1, 0.1, 5.0), Vec3A::NAN];
    /// let hits = accel.closest_points(&points, 2.0);
    /// assert_eq!(hits[0].map(|h| h.distance), Some(1.0));
    /// assert_eq!((hits[1], hits[2]), (None, None));
    /// # Ok::<(), sahara::Error>(())
    /// ```
    pub fn closest_points(&self, points: &[Vec3A], max_distance: f32) -> Vec<Option<PointHit>> {
        crate::batch(points, |&p| self.closest_point(p, max_distance))
    }
}
