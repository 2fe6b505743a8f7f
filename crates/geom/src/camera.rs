//! The pinhole camera, its primary rays, and the framing of a scene that has no camera of its
//! own: the one camera of the workspace (scenes store it, the tracer and the ray-weighted
//! metrics shoot its rays).
//!
//! Image conventions: pixel `(px, py)` has `px` in `0..width` from left to right and `py` in
//! `0..height` from **top** to bottom; its index is `py * width + px`. Rays go through pixel
//! centres `(px + 0.5, py + 0.5)`, so an image of odd size has a centre pixel whose ray points
//! exactly at `target`. The horizontal field of view follows from the aspect ratio (square
//! pixels: `width / height`, unless given by [`Camera::frame_with_aspect`]).
//!
//! **The degenerate-camera rule** (one rule for every primary ray of the workspace,
//! [`Camera::basis`]): the view direction is `normalize(target - eye)`, or `-z` when `eye ==
//! target` (or the difference is not finite); the right vector is `normalize(forward × up)`,
//! or, when `up` is zero, not finite or parallel to the view, `normalize(forward × y)`, then
//! `normalize(forward × z)`; the image's up vector is `right × forward`. So a degenerate
//! camera never panics and gives valid rays.

use crate::{Aabb, Ray, Triangle};
use glam::Vec3A;

/// A pinhole camera: where it is, what it looks at, which way is up, and its vertical field
/// of view. Primary rays: [`Camera::primary_ray`], [`Camera::primary_rays`] and
/// [`Camera::frame`] (see the [module documentation](self) for the image conventions and the
/// degenerate-camera rule).
///
/// ```
/// use sahara_geom::{Camera, Vec3A};
///
/// let cam = Camera::new(Vec3A::new(0.0, 0.0, 5.0), Vec3A::ZERO, Vec3A::Y, 45.0);
/// let centre = cam.primary_ray(1, 1, 3, 3);
/// assert_eq!(centre.direction(), -Vec3A::Z);
/// assert_eq!(cam.primary_rays(4, 3).len(), 12);
/// ```
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Camera {
    /// Position of the eye (the origin of every primary ray).
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
    /// Detects the up axis of a scene from its triangles: y unless z is clearly up.
    ///
    /// Floors, ceilings, roofs and terrain face along the up axis, while walls split their
    /// area between the two horizontal axes; so the axis along which the most triangle area
    /// faces is up. Each triangle adds its area times `|n_y|` to the y score and times `|n_z|`
    /// to the z score (`n` its unit normal); z wins when its score is more than 1.25 times
    /// the y score (ties and near-ties keep y, the convention of OBJ and glTF; an object
    /// whose normals point everywhere, a scanned statue, scores about equally on every axis).
    /// Degenerate and non-finite triangles add nothing; an empty scene is y up.
    pub fn detect(triangles: &[Triangle]) -> UpAxis {
        let (mut y, mut z) = (0f64, 0f64);
        for t in triangles {
            // |cross| is twice the area; |cross_y| = 2 · area · |n_y|.
            let c = (t.v[1] - t.v[0]).cross(t.v[2] - t.v[0]);
            if c.is_finite() {
                y += f64::from(c.y.abs());
                z += f64::from(c.z.abs());
            }
        }
        if z > 1.25 * y {
            UpAxis::Z
        } else {
            UpAxis::Y
        }
    }

    /// The up vector.
    pub fn vector(self) -> Vec3A {
        match self {
            UpAxis::Y => Vec3A::Y,
            UpAxis::Z => Vec3A::Z,
        }
    }
}

/// A camera's orthonormal frame under the degenerate-camera rule ([`Camera::basis`]).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct CameraBasis {
    /// Unit view direction.
    pub forward: Vec3A,
    /// Unit right vector, orthogonal to `forward`.
    pub right: Vec3A,
    /// Unit up vector of the image, `right × forward`.
    pub up: Vec3A,
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

    /// The unit viewing direction, from `eye` to `target` (zero when they are equal; the
    /// primary rays then look along `-z`, see [`Camera::basis`]).
    pub fn direction(&self) -> Vec3A {
        (self.target - self.eye).normalize_or_zero()
    }

    /// The camera's orthonormal frame under the degenerate-camera rule of the
    /// [module documentation](self): `forward` is `normalize(target - eye)`, or `-z`; `right`
    /// is `normalize(forward × up)`, or `normalize(forward × y)`, or `normalize(forward × z)`;
    /// `up` is `right × forward`.
    pub fn basis(&self) -> CameraBasis {
        let mut forward = (self.target - self.eye).normalize_or_zero();
        if forward == Vec3A::ZERO || !forward.is_finite() {
            forward = Vec3A::NEG_Z;
        }
        let mut right = forward.cross(self.up).normalize_or_zero();
        if right == Vec3A::ZERO || !right.is_finite() {
            // `up` is zero, not finite or parallel to the view: fall back to y, then z.
            right = forward.cross(Vec3A::Y).normalize_or_zero();
            if right == Vec3A::ZERO {
                right = forward.cross(Vec3A::Z).normalize_or_zero();
            }
        }
        CameraBasis {
            forward,
            right,
            up: right.cross(forward),
        }
    }

    /// The frame of a `width × height` image with square pixels (aspect `width / height`;
    /// sizes of 0 count as 1): the part of the primary rays that does not depend on the
    /// pixel, computed once per image.
    pub fn frame(&self, width: u32, height: u32) -> CameraFrame {
        let (w, h) = (width.max(1) as f32, height.max(1) as f32);
        let tan_half = (self.fov_y_degrees.to_radians() * 0.5).tan();
        self.frame_scaled(width, height, tan_half * w / h, tan_half, w / h)
    }

    /// The frame of a `width × height` grid of rays over an image of aspect ratio `aspect`
    /// (width / height), which need not be `width / height`: a coarse sampling of a camera's
    /// image, such as the ray-weighted metrics' grid (sizes of 0 count as 1).
    pub fn frame_with_aspect(&self, width: u32, height: u32, aspect: f32) -> CameraFrame {
        let tan_half = (self.fov_y_degrees.to_radians() * 0.5).tan();
        self.frame_scaled(width, height, tan_half * aspect, tan_half, aspect)
    }

    fn frame_scaled(
        &self,
        width: u32,
        height: u32,
        right_scale: f32,
        up_scale: f32,
        aspect: f32,
    ) -> CameraFrame {
        let basis = self.basis();
        let (w, h) = (width.max(1), height.max(1));
        CameraFrame {
            eye: self.eye,
            basis,
            right: basis.right * right_scale,
            up: basis.up * up_scale,
            tan_half_fov_y: up_scale,
            aspect,
            width: w,
            height: h,
            inv_width: 1.0 / w as f32,
            inv_height: 1.0 / h as f32,
        }
    }

    /// The primary ray through the centre of pixel `(px, py)` of a `width × height` image:
    /// origin `eye`, unit-length direction, `tmin = 0`, `tmax = +inf`.
    ///
    /// Deterministic: the same inputs give bit-identical rays, equal to those of
    /// [`Camera::primary_rays`] and [`CameraFrame::ray`]. Degenerate cameras do not panic
    /// (the rule of [`Camera::basis`]). Pixels outside the image give rays outside the
    /// frustum, computed by the same formula.
    pub fn primary_ray(&self, px: u32, py: u32, width: u32, height: u32) -> Ray {
        self.frame(width, height).ray(px, py)
    }

    /// Every primary ray of a `width × height` image, row by row from the top
    /// ([`Camera::primary_ray`] of each pixel in index order).
    pub fn primary_rays(&self, width: u32, height: u32) -> Vec<Ray> {
        self.frame(width, height).rays()
    }
}

/// A camera's frame scaled for an image: the primary rays of its pixels
/// ([`Camera::frame`], [`Camera::frame_with_aspect`]).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct CameraFrame {
    eye: Vec3A,
    basis: CameraBasis,
    /// Right vector scaled by `tan(fov/2) * aspect`.
    right: Vec3A,
    /// Up vector scaled by `tan(fov/2)`.
    up: Vec3A,
    tan_half_fov_y: f32,
    aspect: f32,
    width: u32,
    height: u32,
    inv_width: f32,
    inv_height: f32,
}

impl CameraFrame {
    /// The primary ray through the centre of pixel `(px, py)`: origin the eye, direction
    /// `normalize(forward + sx · right' + sy · up')` with `sx = 2 (px + 0.5) / width - 1`,
    /// `sy = 1 - 2 (py + 0.5) / height`, `right'` and `up'` the basis scaled by
    /// `tan(fov_y / 2) · aspect` and `tan(fov_y / 2)`; `[0, +inf)`.
    #[inline]
    pub fn ray(&self, px: u32, py: u32) -> Ray {
        let sx = (px as f32 + 0.5) * self.inv_width * 2.0 - 1.0;
        let sy = 1.0 - (py as f32 + 0.5) * self.inv_height * 2.0;
        let dir = (self.basis.forward + self.right * sx + self.up * sy).normalize_or_zero();
        Ray::new(self.eye, dir, 0.0, f32::INFINITY)
    }

    /// Every ray of the frame, row by row from the top.
    pub fn rays(&self) -> Vec<Ray> {
        let mut rays = Vec::with_capacity(self.len());
        for py in 0..self.height {
            for px in 0..self.width {
                rays.push(self.ray(px, py));
            }
        }
        rays
    }

    /// The eye.
    pub fn eye(&self) -> Vec3A {
        self.eye
    }

    /// The orthonormal frame ([`Camera::basis`]).
    pub fn basis(&self) -> CameraBasis {
        self.basis
    }

    /// `tan(fov_y / 2)`.
    pub fn tan_half_fov_y(&self) -> f32 {
        self.tan_half_fov_y
    }

    /// The image's width / height.
    pub fn aspect(&self) -> f32 {
        self.aspect
    }

    /// Pixels per row (at least 1).
    pub fn width(&self) -> u32 {
        self.width
    }

    /// Rows (at least 1).
    pub fn height(&self) -> u32 {
        self.height
    }

    /// Number of pixels, `width · height`.
    pub fn len(&self) -> usize {
        self.width as usize * self.height as usize
    }

    /// Always false: a frame has at least one pixel.
    pub fn is_empty(&self) -> bool {
        self.len() == 0
    }
}

/// Why a camera written on the command line (`eye=x,y,z target=x,y,z up=x,y,z fov=deg`)
/// could not be read.
#[derive(Clone, Debug, PartialEq)]
#[non_exhaustive]
pub enum CameraSpecError {
    /// A word that is not `key=value`, or whose key is not `eye`, `target`, `up` or `fov`.
    UnknownField(String),
    /// A field given twice.
    Duplicate(&'static str),
    /// `eye` or `target` is missing.
    Missing(&'static str),
    /// A vector that is not three finite numbers `x,y,z`.
    InvalidVector {
        /// The field.
        field: &'static str,
        /// What was written.
        value: String,
    },
    /// A field of view that is not a number strictly between 0 and 180 degrees.
    InvalidFov(String),
    /// `eye` equals `target`, or `up` is zero or parallel to the view direction.
    Degenerate(&'static str),
}

impl std::fmt::Display for CameraSpecError {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            CameraSpecError::UnknownField(w) => write!(
                f,
                "camera: unknown field `{w}` (expected eye=x,y,z target=x,y,z up=x,y,z fov=degrees)"
            ),
            CameraSpecError::Duplicate(k) => write!(f, "camera: `{k}` is given twice"),
            CameraSpecError::Missing(k) => write!(
                f,
                "camera: `{k}` is missing (eye and target are required; up defaults to 0,1,0, fov to 60)"
            ),
            CameraSpecError::InvalidVector { field, value } => write!(
                f,
                "camera: `{field}` must be three finite numbers x,y,z, got `{value}`"
            ),
            CameraSpecError::InvalidFov(v) => write!(
                f,
                "camera: `fov` must be a number of degrees strictly between 0 and 180, got `{v}`"
            ),
            CameraSpecError::Degenerate(why) => write!(f, "camera: {why}"),
        }
    }
}

impl std::error::Error for CameraSpecError {}

impl std::str::FromStr for Camera {
    type Err = CameraSpecError;

    /// Reads `eye=x,y,z target=x,y,z [up=x,y,z] [fov=degrees]` (fields in any order,
    /// separated by blanks or semicolons; `up` defaults to `0,1,0`, `fov` to 60), the format
    /// [`Camera`]'s `Display` writes. Rejects unknown and repeated fields, vectors that are
    /// not three finite numbers, a field of view outside (0, 180), `eye == target` and an
    /// `up` that is zero or parallel to the view direction.
    fn from_str(s: &str) -> Result<Camera, CameraSpecError> {
        let (mut eye, mut target, mut up, mut fov) = (None, None, None, None);
        for word in s
            .split(|c: char| c.is_whitespace() || c == ';')
            .filter(|w| !w.is_empty())
        {
            let (key, value) = word
                .split_once('=')
                .ok_or_else(|| CameraSpecError::UnknownField(word.to_string()))?;
            let (field, slot): (&'static str, &mut Option<Vec3A>) = match key {
                "eye" => ("eye", &mut eye),
                "target" => ("target", &mut target),
                "up" => ("up", &mut up),
                "fov" | "fov_y_degrees" => {
                    if fov.is_some() {
                        return Err(CameraSpecError::Duplicate("fov"));
                    }
                    let f = value
                        .parse::<f32>()
                        .ok()
                        .filter(|f| *f > 0.0 && *f < 180.0)
                        .ok_or_else(|| CameraSpecError::InvalidFov(value.to_string()))?;
                    fov = Some(f);
                    continue;
                }
                _ => return Err(CameraSpecError::UnknownField(word.to_string())),
            };
            if slot.is_some() {
                return Err(CameraSpecError::Duplicate(field));
            }
            let v: Vec<f32> = value
                .split(',')
                .map(|x| x.trim().parse::<f32>())
                .collect::<Result<_, _>>()
                .unwrap_or_default();
            if v.len() != 3 || v.iter().any(|x| !x.is_finite()) {
                return Err(CameraSpecError::InvalidVector {
                    field,
                    value: value.to_string(),
                });
            }
            *slot = Some(Vec3A::new(v[0], v[1], v[2]));
        }
        let eye = eye.ok_or(CameraSpecError::Missing("eye"))?;
        let target = target.ok_or(CameraSpecError::Missing("target"))?;
        let up = up.unwrap_or(Vec3A::Y);
        let view = target - eye;
        if view == Vec3A::ZERO || !view.is_finite() {
            return Err(CameraSpecError::Degenerate(
                "eye and target are the same point",
            ));
        }
        if view.cross(up).length_squared() <= f32::MIN_POSITIVE {
            return Err(CameraSpecError::Degenerate(
                "up is zero or parallel to the view direction",
            ));
        }
        Ok(Camera::new(eye, target, up, fov.unwrap_or(60.0)))
    }
}

impl std::fmt::Display for Camera {
    /// `eye=x,y,z target=x,y,z up=x,y,z fov=deg`, with the shortest decimals that read back
    /// bit for bit ([`Camera`]'s `FromStr`).
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        let v = |v: Vec3A| format!("{},{},{}", v.x, v.y, v.z);
        write!(
            f,
            "eye={} target={} up={} fov={}",
            v(self.eye),
            v(self.target),
            v(self.up),
            self.fov_y_degrees
        )
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

    #[test]
    fn spec_round_trips_and_errors_are_typed() {
        let c: Camera = "eye=1,2,3 target=0,0.5,0 up=0,0,1 fov=50".parse().unwrap();
        assert_eq!(
            c,
            Camera::new(
                Vec3A::new(1.0, 2.0, 3.0),
                Vec3A::new(0.0, 0.5, 0.0),
                Vec3A::Z,
                50.0
            )
        );
        let odd = Camera::new(
            Vec3A::new(0.1, -1e-7, 3.3),
            Vec3A::new(1.0 / 3.0, 2.0, 0.0),
            Vec3A::Y,
            47.5,
        );
        assert_eq!(odd.to_string().parse::<Camera>().unwrap(), odd);
        let d: Camera = "target=0,0,0;eye=0,0,5".parse().unwrap();
        assert_eq!((d.up, d.fov_y_degrees), (Vec3A::Y, 60.0));
        let err = |s: &str| s.parse::<Camera>().unwrap_err();
        assert_eq!(err("eye=0,0,5"), CameraSpecError::Missing("target"));
        assert!(matches!(
            err("eye=0,0 target=0,0,0"),
            CameraSpecError::InvalidVector { field: "eye", .. }
        ));
        assert!(matches!(
            err("eye=0,0,nan target=0,0,0"),
            CameraSpecError::InvalidVector { .. }
        ));
        assert!(matches!(
            err("eye=0,0,1 target=0,0,0 fov=180"),
            CameraSpecError::InvalidFov(_)
        ));
        assert!(matches!(
            err("eye=0,0,1 target=0,0,0 zoom=2"),
            CameraSpecError::UnknownField(_)
        ));
        assert!(matches!(
            err("eye=0,0,1 eye=0,0,2"),
            CameraSpecError::Duplicate("eye")
        ));
        assert!(matches!(
            err("eye=1,1,1 target=1,1,1"),
            CameraSpecError::Degenerate(_)
        ));
        assert!(matches!(
            err("eye=0,0,0 target=0,5,0"),
            CameraSpecError::Degenerate(_)
        ));
    }

    #[test]
    fn up_axis_follows_the_area_facing_each_axis() {
        // A floor of 10 × 10 with 2-high walls: y up; the same turned so y goes to z: z up.
        let quad = |a: Vec3A, b: Vec3A, c: Vec3A| vec![Triangle::new(a, b, c)];
        let mut tris = Vec::new();
        tris.extend(quad(
            Vec3A::ZERO,
            Vec3A::new(10.0, 0.0, 0.0),
            Vec3A::new(0.0, 0.0, 10.0),
        ));
        tris.extend(quad(
            Vec3A::ZERO,
            Vec3A::new(10.0, 0.0, 0.0),
            Vec3A::new(0.0, 2.0, 0.0),
        ));
        tris.extend(quad(
            Vec3A::ZERO,
            Vec3A::new(0.0, 0.0, 10.0),
            Vec3A::new(0.0, 2.0, 0.0),
        ));
        assert_eq!(UpAxis::detect(&tris), UpAxis::Y);
        let turned: Vec<Triangle> = tris
            .iter()
            .map(|t| Triangle {
                v: t.v.map(|p| Vec3A::new(p.x, -p.z, p.y)),
            })
            .collect();
        assert_eq!(UpAxis::detect(&turned), UpAxis::Z);
        assert_eq!(UpAxis::detect(&[]), UpAxis::Y);
    }

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

    #[test]
    fn degenerate_cameras_follow_the_one_rule() {
        // Looking along `up`: forward × y is zero, so right = forward × z.
        let along_up = Camera::new(Vec3A::ZERO, Vec3A::new(0.0, 2.0, 0.0), Vec3A::Y, 45.0);
        let b = along_up.basis();
        assert_eq!((b.forward, b.right, b.up), (Vec3A::Y, Vec3A::X, Vec3A::Z));
        // A zero `up`: forward × y.
        let no_up = Camera::new(Vec3A::ZERO, Vec3A::new(0.0, 0.0, -3.0), Vec3A::ZERO, 45.0);
        let b = no_up.basis();
        assert_eq!(
            (b.forward, b.right, b.up),
            (Vec3A::NEG_Z, Vec3A::X, Vec3A::Y)
        );
        // eye == target: the view is -z.
        let same = Camera::new(Vec3A::ONE, Vec3A::ONE, Vec3A::Y, 45.0);
        let b = same.basis();
        assert_eq!(
            (b.forward, b.right, b.up),
            (Vec3A::NEG_Z, Vec3A::X, Vec3A::Y)
        );
        // Every primary ray of a degenerate camera is valid, with a unit direction, and the
        // frame, the image and the single ray agree bit for bit.
        for cam in [along_up, no_up, same] {
            let rays = cam.primary_rays(5, 3);
            for (i, r) in rays.iter().enumerate() {
                assert!(r.is_valid(), "{cam:?} -> {r:?}");
                assert!((r.direction().length() - 1.0).abs() < 1e-6);
                assert_eq!(*r, cam.primary_ray(i as u32 % 5, i as u32 / 5, 5, 3));
            }
            assert_eq!(cam.primary_ray(2, 1, 5, 3).direction(), cam.basis().forward);
        }
    }

    #[test]
    fn a_frame_with_the_image_aspect_gives_the_image_rays_up_to_rounding() {
        let cam = Camera::new(Vec3A::new(0.3, 0.4, 3.0), Vec3A::splat(0.5), Vec3A::Y, 50.0);
        let (a, b) = (cam.frame(24, 16), cam.frame_with_aspect(24, 16, 1.5));
        assert_eq!((b.width(), b.height(), b.len()), (24, 16, 384));
        for (x, y) in a.rays().iter().zip(b.rays()) {
            assert!((x.direction() - y.direction()).length() < 1e-6);
        }
    }
}
