use glam::Vec3A;

/// An axis-aligned bounding box.
///
/// The empty box has `min = +inf` and `max = -inf` on every axis, so that growing it by any
/// point or box gives that point or box. An empty box has zero surface area.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Aabb {
    /// Lower corner.
    pub min: Vec3A,
    /// Upper corner.
    pub max: Vec3A,
}

impl Default for Aabb {
    fn default() -> Self {
        Self::EMPTY
    }
}

impl Aabb {
    /// The empty box (neutral element of [`Aabb::union`]).
    pub const EMPTY: Aabb = Aabb {
        min: Vec3A::splat(f32::INFINITY),
        max: Vec3A::splat(f32::NEG_INFINITY),
    };

    /// A box from its two corners.
    #[inline]
    pub fn new(min: Vec3A, max: Vec3A) -> Self {
        Self { min, max }
    }

    /// The smallest box containing every point of `points` (empty for no points).
    pub fn from_points<I: IntoIterator<Item = Vec3A>>(points: I) -> Self {
        points.into_iter().fold(Self::EMPTY, |b, p| b.grown(p))
    }

    /// True when the box contains no point (`min > max` on some axis).
    #[inline]
    pub fn is_empty(&self) -> bool {
        self.min.cmpgt(self.max).any()
    }

    /// True when both corners are finite numbers.
    #[inline]
    pub fn is_finite(&self) -> bool {
        self.min.is_finite() && self.max.is_finite()
    }

    /// Grows the box in place to contain `p`.
    #[inline]
    pub fn grow(&mut self, p: Vec3A) {
        self.min = self.min.min(p);
        self.max = self.max.max(p);
    }

    /// The box grown to contain `p`.
    #[inline]
    #[must_use]
    pub fn grown(mut self, p: Vec3A) -> Self {
        self.grow(p);
        self
    }

    /// Grows the box in place to contain `other`.
    #[inline]
    pub fn grow_aabb(&mut self, other: &Aabb) {
        self.min = self.min.min(other.min);
        self.max = self.max.max(other.max);
    }

    /// The smallest box containing both boxes.
    #[inline]
    #[must_use]
    pub fn union(&self, other: &Aabb) -> Aabb {
        Aabb {
            min: self.min.min(other.min),
            max: self.max.max(other.max),
        }
    }

    /// The intersection of both boxes (possibly empty: check [`Aabb::is_empty`]).
    #[inline]
    #[must_use]
    pub fn intersection(&self, other: &Aabb) -> Aabb {
        Aabb {
            min: self.min.max(other.min),
            max: self.max.min(other.max),
        }
    }

    /// `max - min`, clamped at zero for empty boxes.
    #[inline]
    pub fn extent(&self) -> Vec3A {
        (self.max - self.min).max(Vec3A::ZERO)
    }

    /// Total surface area of the box (`2 (xy + yz + zx)`), zero for empty boxes.
    #[inline]
    pub fn surface_area(&self) -> f32 {
        let e = self.extent();
        2.0 * (e.x * e.y + e.y * e.z + e.z * e.x)
    }

    /// Half the surface area, the quantity SAH ratios need (`xy + yz + zx`).
    #[inline]
    pub fn half_area(&self) -> f32 {
        let e = self.extent();
        e.x * e.y + e.y * e.z + e.z * e.x
    }

    /// The centre of the box.
    #[inline]
    pub fn centroid(&self) -> Vec3A {
        (self.min + self.max) * 0.5
    }

    /// The axis along which the box is longest (ties go to the lower axis).
    #[inline]
    pub fn largest_axis(&self) -> crate::Axis {
        let e = self.extent();
        if e.x >= e.y && e.x >= e.z {
            0
        } else if e.y >= e.z {
            1
        } else {
            2
        }
    }

    /// True when `p` lies inside the closed box.
    #[inline]
    pub fn contains_point(&self, p: Vec3A) -> bool {
        p.cmpge(self.min).all() && p.cmple(self.max).all()
    }

    /// True when `other` lies inside the closed box. An empty `other` is contained in every box.
    #[inline]
    pub fn contains_aabb(&self, other: &Aabb) -> bool {
        other.is_empty() || (other.min.cmpge(self.min).all() && other.max.cmple(self.max).all())
    }

    /// True when the closed boxes share at least one point.
    #[inline]
    pub fn overlaps(&self, other: &Aabb) -> bool {
        !self.intersection(other).is_empty()
    }

    /// Corner `min` and `max` as plain arrays.
    #[inline]
    pub fn to_arrays(&self) -> ([f32; 3], [f32; 3]) {
        (self.min.to_array(), self.max.to_array())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn empty_is_neutral() {
        let b = Aabb::new(Vec3A::new(-1.0, 0.0, 2.0), Vec3A::new(3.0, 4.0, 5.0));
        assert_eq!(Aabb::EMPTY.union(&b), b);
        assert!(Aabb::EMPTY.is_empty());
        assert_eq!(Aabb::EMPTY.surface_area(), 0.0);
        assert!(b.contains_aabb(&Aabb::EMPTY));
    }

    #[test]
    fn area_and_axis() {
        let b = Aabb::new(Vec3A::ZERO, Vec3A::new(1.0, 2.0, 3.0));
        assert_eq!(b.surface_area(), 22.0);
        assert_eq!(b.half_area(), 11.0);
        assert_eq!(b.largest_axis(), 2);
        assert_eq!(b.centroid(), Vec3A::new(0.5, 1.0, 1.5));
    }

    #[test]
    fn intersection_of_disjoint_boxes_is_empty() {
        let a = Aabb::new(Vec3A::ZERO, Vec3A::ONE);
        let b = Aabb::new(Vec3A::splat(2.0), Vec3A::splat(3.0));
        assert!(a.intersection(&b).is_empty());
        assert!(!a.overlaps(&b));
        let c = Aabb::new(Vec3A::splat(0.5), Vec3A::splat(3.0));
        assert_eq!(a.intersection(&c), Aabb::new(Vec3A::splat(0.5), Vec3A::ONE));
    }
}
