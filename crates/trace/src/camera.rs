//! The pinhole camera and its primary rays.

use sahara_geom::{Ray, Vec3A};

/// A pinhole camera: where it is, what it looks at, which way is up, and its vertical field
/// of view (the same four fields as `sahara_scene::Camera`, so the xtask converts field by
/// field).
///
/// Image conventions: pixel `(px, py)` has `px` in `0..width` from left to right and `py` in
/// `0..height` from **top** to bottom; its index is `py * width + px`. Rays go through pixel
/// centres `(px + 0.5, py + 0.5)`, so an image of odd size has a centre pixel whose ray points
/// exactly at `target`. The horizontal field of view follows from the aspect ratio
/// `width / height` (square pixels).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Camera {
    /// Position of the eye (the origin of every primary ray).
    pub eye: Vec3A,
    /// The point the camera looks at (the centre of the image).
    pub target: Vec3A,
    /// The up direction (need not be unit length nor orthogonal to the view direction).
    pub up: Vec3A,
    /// Vertical field of view in degrees.
    pub fov_y_degrees: f32,
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

    /// The primary ray through the centre of pixel `(px, py)` of a `width × height` image:
    /// origin `eye`, unit-length direction, `tmin = 0`, `tmax = +inf`.
    ///
    /// Deterministic: the same inputs give bit-identical rays, and [`crate::RaySet::primary`]
    /// produces exactly these rays. Degenerate cameras do not panic: when `up` is parallel to
    /// the view direction (or zero) another up axis is chosen, and when `eye == target` the view
    /// direction is `-z`. Pixels outside the image give rays outside the frustum, computed by
    /// the same formula.
    pub fn primary_ray(&self, px: u32, py: u32, width: u32, height: u32) -> Ray {
        CameraFrame::new(self, width, height).ray(px, py)
    }
}

/// The camera's orthonormal frame, scaled for an image size: the part of [`Camera::primary_ray`]
/// that does not depend on the pixel, computed once per image.
#[derive(Clone, Copy, Debug)]
pub(crate) struct CameraFrame {
    eye: Vec3A,
    forward: Vec3A,
    /// Right vector scaled by `tan(fov/2) * aspect`.
    right: Vec3A,
    /// Up vector scaled by `tan(fov/2)`.
    up: Vec3A,
    inv_width: f32,
    inv_height: f32,
}

impl CameraFrame {
    pub(crate) fn new(camera: &Camera, width: u32, height: u32) -> Self {
        let mut forward = (camera.target - camera.eye).normalize_or_zero();
        if forward == Vec3A::ZERO || !forward.is_finite() {
            forward = Vec3A::NEG_Z;
        }
        let mut right = forward.cross(camera.up).normalize_or_zero();
        if right == Vec3A::ZERO || !right.is_finite() {
            // `up` is zero, not finite or parallel to the view: fall back to y, then z.
            right = forward.cross(Vec3A::Y).normalize_or_zero();
            if right == Vec3A::ZERO {
                right = forward.cross(Vec3A::Z).normalize_or_zero();
            }
        }
        let up = right.cross(forward);
        let (w, h) = (width.max(1) as f32, height.max(1) as f32);
        let tan_half = (camera.fov_y_degrees.to_radians() * 0.5).tan();
        Self {
            eye: camera.eye,
            forward,
            right: right * (tan_half * w / h),
            up: up * tan_half,
            inv_width: 1.0 / w,
            inv_height: 1.0 / h,
        }
    }

    #[inline]
    pub(crate) fn ray(&self, px: u32, py: u32) -> Ray {
        let sx = (px as f32 + 0.5) * self.inv_width * 2.0 - 1.0;
        let sy = 1.0 - (py as f32 + 0.5) * self.inv_height * 2.0;
        let dir = (self.forward + self.right * sx + self.up * sy).normalize_or_zero();
        Ray::new(self.eye, dir, 0.0, f32::INFINITY)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn corners_span_the_field_of_view() {
        let cam = Camera::new(Vec3A::ZERO, Vec3A::NEG_Z, Vec3A::Y, 90.0);
        // Top-left pixel of a 2x2 image: up and left of the view direction.
        let r = cam.primary_ray(0, 0, 2, 2);
        assert!(r.direction().x < 0.0 && r.direction().y > 0.0 && r.direction().z < 0.0);
        let r = cam.primary_ray(1, 1, 2, 2);
        assert!(r.direction().x > 0.0 && r.direction().y < 0.0);
        // 90° vertical fov: the top edge of the image is at 45°.
        let top = cam.primary_ray(0, 0, 1, 1_000_000);
        assert!((top.direction().y / -top.direction().z - 1.0).abs() < 1e-3);
    }

    #[test]
    fn degenerate_cameras_give_finite_rays() {
        for cam in [
            Camera::new(Vec3A::ZERO, Vec3A::Y, Vec3A::Y, 45.0),
            Camera::new(Vec3A::ONE, Vec3A::ONE, Vec3A::ZERO, 45.0),
        ] {
            let r = cam.primary_ray(3, 4, 8, 8);
            assert!(r.is_valid(), "{cam:?} -> {r:?}");
            assert!((r.direction().length() - 1.0).abs() < 1e-6);
        }
    }
}
