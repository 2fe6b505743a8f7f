//! Pinhole cameras, and the framing of a scene that has no camera of its own.
//!
//! The cameras of the named scenes are data, not code: the repository's `scenes/cameras.tsv`
//! (see [`named_cameras`](crate::named_cameras) and [`default_camera`](crate::default_camera)).

use sahara_geom::{Aabb, Ray, Triangle, Vec3A};

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

/// Why a camera written on the command line (`eye=x,y,z target=x,y,z up=x,y,z fov=deg`)
/// could not be read.
#[derive(Clone, Debug, PartialEq, thiserror::Error)]
#[non_exhaustive]
pub enum CameraSpecError {
    /// A word that is not `key=value`, or whose key is not `eye`, `target`, `up` or `fov`.
    #[error("camera: unknown field `{0}` (expected eye=x,y,z target=x,y,z up=x,y,z fov=degrees)")]
    UnknownField(String),
    /// A field given twice.
    #[error("camera: `{0}` is given twice")]
    Duplicate(&'static str),
    /// `eye` or `target` is missing.
    #[error(
        "camera: `{0}` is missing (eye and target are required; up defaults to 0,1,0, fov to 60)"
    )]
    Missing(&'static str),
    /// A vector that is not three finite numbers `x,y,z`.
    #[error("camera: `{field}` must be three finite numbers x,y,z, got `{value}`")]
    InvalidVector {
        /// The field.
        field: &'static str,
        /// What was written.
        value: String,
    },
    /// A field of view that is not a number strictly between 0 and 180 degrees.
    #[error("camera: `fov` must be a number of degrees strictly between 0 and 180, got `{0}`")]
    InvalidFov(String),
    /// `eye` equals `target`, or `up` is zero or parallel to the view direction.
    #[error("camera: {0}")]
    Degenerate(&'static str),
}

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
}
