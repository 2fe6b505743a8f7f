use crate::intersect::WatertightRay;
use glam::Vec3A;

/// A ray `origin + t * direction` for `t` in `[tmin, tmax]`.
///
/// The reciprocal of the direction is computed at construction and whenever the direction is
/// changed ([`Ray::set_direction`]); components of the direction that are `±0` give `±inf`,
/// which the slab test handles.
///
/// The direction and its reciprocal are private, so they cannot disagree: a ray reused with a
/// new direction gets its reciprocal recomputed, never a stale one (a stale reciprocal made
/// the box tests and the watertight test answer for the old direction). The origin and the
/// interval are public fields, because nothing is derived from them before a query: a
/// renderer may write `ray.origin`, `ray.tmin` and `ray.tmax` freely (`docs/facade.md`).
///
/// ```
/// use sahara_geom::{Ray, Vec3A};
/// let mut ray = Ray::new(Vec3A::ZERO, Vec3A::X, 0.0, f32::INFINITY);
/// ray.set_direction(Vec3A::new(0.0, -2.0, 0.0));
/// assert_eq!(ray.direction(), Vec3A::new(0.0, -2.0, 0.0));
/// assert_eq!(ray.inv_direction(), Vec3A::new(f32::INFINITY, -0.5, f32::INFINITY));
/// ray.tmax = 10.0; // the interval and the origin are plain fields
/// ```
///
/// Writing the direction or its reciprocal directly does not compile:
///
/// ```compile_fail,E0616
/// let mut ray = sahara_geom::Ray::new(sahara_geom::Vec3A::ZERO, sahara_geom::Vec3A::X, 0.0, 1.0);
/// ray.direction = -sahara_geom::Vec3A::X;
/// ```
///
/// ```compile_fail,E0616
/// let mut ray = sahara_geom::Ray::new(sahara_geom::Vec3A::ZERO, sahara_geom::Vec3A::X, 0.0, 1.0);
/// ray.inv_direction = -sahara_geom::Vec3A::X;
/// ```
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Ray {
    /// Origin.
    pub origin: Vec3A,
    /// Direction (need not be normalised; `t` is measured in units of it).
    direction: Vec3A,
    /// Start of the valid interval.
    pub tmin: f32,
    /// End of the valid interval.
    pub tmax: f32,
    /// `direction.recip()`, kept equal to it by every constructor and setter: the box tests
    /// and the watertight triangle test's constants ([`Ray::watertight`]) both use it.
    inv_direction: Vec3A,
}

impl Ray {
    /// A ray with its reciprocal direction precomputed.
    #[inline]
    pub fn new(origin: Vec3A, direction: Vec3A, tmin: f32, tmax: f32) -> Self {
        Self {
            origin,
            direction,
            tmin,
            tmax,
            inv_direction: direction.recip(),
        }
    }

    /// The direction (not normalised; `t` is measured in units of it).
    #[inline]
    pub fn direction(&self) -> Vec3A {
        self.direction
    }

    /// `1 / direction`, component-wise (always equal to `self.direction().recip()`).
    #[inline]
    pub fn inv_direction(&self) -> Vec3A {
        self.inv_direction
    }

    /// Sets the direction and recomputes its reciprocal.
    #[inline]
    pub fn set_direction(&mut self, direction: Vec3A) {
        self.direction = direction;
        self.inv_direction = direction.recip();
    }

    /// The same ray with another direction (its reciprocal recomputed).
    #[inline]
    pub fn with_direction(mut self, direction: Vec3A) -> Self {
        self.set_direction(direction);
        self
    }

    /// The point at parameter `t`.
    #[inline]
    pub fn at(&self, t: f32) -> Vec3A {
        self.origin + self.direction * t
    }

    /// True when the ray can hit anything: finite origin and direction, a direction with at
    /// least one normal (not zero, not subnormal) component, and a non-empty `[tmin, tmax]`
    /// with `tmin` not NaN and `tmax` not NaN.
    ///
    /// Every traversal kernel of the workspace treats an invalid ray as a miss (documented
    /// handling of NaN, Inf and zero-direction rays). `tmax = +inf` is valid.
    ///
    /// A direction whose components are all zero or subnormal (below `f32::MIN_POSITIVE`,
    /// about 1.2e-38, in magnitude) is invalid: every reciprocal component is infinite, so the
    /// slab test cannot bound the ray's interval, and any hit would lie at a distance near or
    /// beyond `f32::MAX`. (Without this rule such rays visit most of the tree in subnormal
    /// arithmetic, hundreds of times slower than ordinary rays, to find nothing.) A subnormal
    /// component next to a normal one is valid and acts like a zero component in box tests.
    #[inline]
    pub fn is_valid(&self) -> bool {
        self.origin.is_finite()
            && self.direction.is_finite()
            && self.direction.abs().max_element() >= f32::MIN_POSITIVE
            && !self.tmin.is_nan()
            && !self.tmax.is_nan()
            && self.tmin <= self.tmax
            && self.tmax >= 0.0
    }

    /// Precomputes the per-ray data of the watertight triangle test.
    #[inline]
    pub fn watertight(&self) -> WatertightRay {
        WatertightRay::with_inverse(self.origin, self.direction, self.inv_direction)
    }
}
