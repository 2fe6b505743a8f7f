//! Pinhole cameras, and the framing of a scene that has no camera of its own.
//!
//! The cameras of the named scenes are data, not code: the repository's `scenes/cameras.tsv`
//! (see [`named_cameras`](crate::named_cameras) and [`default_camera`](crate::default_camera)).

use sahara_geom::{Aabb, Ray, Vec3A};

/// A pinhole camera: where it is, what it looks at, which way is up, and its vertical field
/// of view. Image size and ray generation belong to the tracer (`sahara-trace`).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Camera {
    /// Position of the eye.
    pub eye: Vec3A,
    /// The point the camera looks at (the centre of the image).
    pub target: Vec3A,
    /// The up direction (need not be orthogonal to the view direction, nor unit length).
    pub up: Vec3A,
    /// Vertical field of view in degrees.
    pub fov_y_degrees: f32,
}

/// Which axis points up in a scene.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Hash)]
pub enum UpAxis {
    /// `+y` is up (the convention of OBJ and glTF, and of every scene but a few).
    #[default]
    Y,
    /// `+z` is up (GIS and CAD data, e.g. `san_francisco_osm`, whose camera in
    /// `scenes/cameras.tsv` has `up` = `0,0,1`).
    Z,
}

impl UpAxis {
    /// The up vector.
    pub fn vector(self) -> Vec3A {
        match self {
            UpAxis::Y => Vec3A::Y,
            UpAxis::Z => Vec3A::Z,
        }
    }
}

impl Camera {
    /// A camera from its four parameters.
    pub fn new(eye: Vec3A, target: Vec3A, up: Vec3A, fov_y_degrees: f32) -> Self {
        Self {
            eye,
            target,
            up,
            fov_y_degrees,
        }
    }

    /// A camera framing `bounds` from the front and slightly above, at 45° vertical field of
    /// view:
    ///
    /// * y up: `eye = c + normalize(0, 0.1, 1) · 1.2 · |diagonal|`;
    /// * z up: `eye = c + normalize(0, 1, 0.1) · 1.2 · |diagonal|`,
    ///
    /// where `c` is the centre of the box; the camera looks at `c`. An empty or degenerate
    /// box gives a camera at distance 1 from its centre (or from the origin).
    pub fn framing(bounds: &Aabb, up: UpAxis) -> Self {
        let (centre, diag) = if bounds.is_empty() || !bounds.is_finite() {
            (Vec3A::ZERO, 1.0)
        } else {
            let d = bounds.extent().length();
            (bounds.centroid(), if d > 0.0 { d } else { 1.0 })
        };
        let dir = match up {
            UpAxis::Y => Vec3A::new(0.0, 0.1, 1.0),
            UpAxis::Z => Vec3A::new(0.0, 1.0, 0.1),
        }
        .normalize();
        Self {
            eye: centre + dir * (1.2 * diag),
            target: centre,
            up: up.vector(),
            fov_y_degrees: 45.0,
        }
    }

    /// The unit viewing direction, from `eye` to `target`.
    pub fn direction(&self) -> Vec3A {
        (self.target - self.eye).normalize_or_zero()
    }

    /// An `n × n` grid of primary rays through pixel centres (square pixels over the vertical
    /// field of view, row 0 at the top), each `[0, ∞)`: the test suites' and the hard-case
    /// suite's camera rays. A camera looking along its up vector gets an arbitrary orthonormal
    /// right vector.
    pub fn grid_rays(&self, n: u32) -> Vec<Ray> {
        let f = (self.target - self.eye).normalize();
        let r = f.cross(self.up).normalize_or_zero();
        let r = if r == Vec3A::ZERO {
            f.any_orthonormal_vector()
        } else {
            r
        };
        let u = r.cross(f);
        let tan = (self.fov_y_degrees.to_radians() * 0.5).tan();
        let mut rays = Vec::with_capacity((n * n) as usize);
        for y in 0..n {
            for x in 0..n {
                let sx = (2.0 * (x as f32 + 0.5) / n as f32 - 1.0) * tan;
                let sy = (1.0 - 2.0 * (y as f32 + 0.5) / n as f32) * tan;
                rays.push(Ray::new(self.eye, f + r * sx + u * sy, 0.0, f32::INFINITY));
            }
        }
        rays
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn framing_looks_at_centre_from_front() {
        let b = Aabb::new(Vec3A::splat(-1.0), Vec3A::splat(1.0));
        let c = Camera::framing(&b, UpAxis::Y);
        assert_eq!(c.target, Vec3A::ZERO);
        let d = 2.0 * 3f32.sqrt() * 1.2;
        assert!((c.eye.length() - d).abs() < 1e-5);
        assert!(c.eye.z > 0.0 && c.eye.y > 0.0 && c.eye.x == 0.0);
        let z = Camera::framing(&b, UpAxis::Z);
        assert!(z.eye.y > 0.0 && z.eye.z > 0.0);
        assert_eq!(z.up, Vec3A::Z);
        assert!(Camera::framing(&Aabb::EMPTY, UpAxis::Y).eye.is_finite());
    }
}
