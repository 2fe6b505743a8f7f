use crate::Aabb;
use glam::Vec3A;

/// A triangle given by its three vertices.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Triangle {
    /// The vertices, in winding order.
    pub v: [Vec3A; 3],
}

impl Triangle {
    /// A triangle from three vertices.
    #[inline]
    pub fn new(a: Vec3A, b: Vec3A, c: Vec3A) -> Self {
        Self { v: [a, b, c] }
    }

    /// The bounding box of the three vertices.
    #[inline]
    pub fn bounds(&self) -> Aabb {
        Aabb::new(
            self.v[0].min(self.v[1]).min(self.v[2]),
            self.v[0].max(self.v[1]).max(self.v[2]),
        )
    }

    /// The mean of the three vertices.
    #[inline]
    pub fn centroid(&self) -> Vec3A {
        (self.v[0] + self.v[1] + self.v[2]) * (1.0 / 3.0)
    }

    /// The unnormalised geometric normal `(v1 - v0) × (v2 - v0)`.
    #[inline]
    pub fn cross(&self) -> Vec3A {
        (self.v[1] - self.v[0]).cross(self.v[2] - self.v[0])
    }

    /// The unit geometric normal (zero for degenerate triangles).
    #[inline]
    pub fn normal(&self) -> Vec3A {
        self.cross().normalize_or_zero()
    }

    /// Area, computed in `f64` so that thin triangles keep their digits.
    #[inline]
    pub fn area(&self) -> f64 {
        let a = self.v[0].as_dvec3();
        let b = self.v[1].as_dvec3();
        let c = self.v[2].as_dvec3();
        0.5 * (b - a).cross(c - a).length()
    }

    /// True when every coordinate is finite.
    #[inline]
    pub fn is_finite(&self) -> bool {
        self.v.iter().all(|p| p.is_finite())
    }

    /// The point with barycentric coordinates `(1 - u - v, u, v)`.
    #[inline]
    pub fn point(&self, u: f32, v: f32) -> Vec3A {
        self.v[0] * (1.0 - u - v) + self.v[1] * u + self.v[2] * v
    }
}
