//! Deterministic ray sets: primary, diffuse and ambient-occlusion rays.

use crate::{batch::trace_closest, Camera, Tracer};
use rayon::prelude::*;
use sahara_geom::{rng::Pcg32, Aabb, Ray, Triangle, Vec3A};
use sahara_traverse::Hit;
use serde::{Deserialize, Serialize};
use std::fmt;
use std::str::FromStr;

/// The three kinds of ray set of the evaluation (`docs/evaluation.md`, "The matrix").
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum RayKind {
    /// One ray per pixel from a pinhole camera; traced for the closest hit.
    Primary,
    /// One cosine-weighted bounce from each primary hit; traced for the closest hit.
    Diffuse,
    /// Short cosine-weighted rays from each primary hit; traced for any hit (occlusion).
    #[serde(rename = "ao")]
    AmbientOcclusion,
}

impl RayKind {
    /// Every kind, in the order of the evaluation's tables.
    pub const ALL: [RayKind; 3] = [
        RayKind::Primary,
        RayKind::Diffuse,
        RayKind::AmbientOcclusion,
    ];

    /// The name used on the command line and in reports: `primary`, `diffuse`, `ao`.
    pub fn name(self) -> &'static str {
        match self {
            RayKind::Primary => "primary",
            RayKind::Diffuse => "diffuse",
            RayKind::AmbientOcclusion => "ao",
        }
    }

    /// True when rays of this kind are traced with an any-hit (occlusion) query; false when
    /// they are traced for the closest hit.
    pub fn uses_any_hit(self) -> bool {
        self == RayKind::AmbientOcclusion
    }

    /// The PCG stream of the kind in [`ray_rng`]: 0, 1, 2.
    fn stream(self) -> u64 {
        match self {
            RayKind::Primary => 0,
            RayKind::Diffuse => 1,
            RayKind::AmbientOcclusion => 2,
        }
    }
}

impl fmt::Display for RayKind {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(self.name())
    }
}

/// The error of parsing a [`RayKind`] from a string.
#[derive(Clone, Debug, PartialEq, Eq, thiserror::Error)]
#[error("unknown ray kind {0:?} (expected primary, diffuse or ao)")]
pub struct ParseRayKindError(pub String);

impl FromStr for RayKind {
    type Err = ParseRayKindError;

    /// Parses `primary`, `diffuse`, `ao` (also `ambient-occlusion` and
    /// `ambient_occlusion`), ignoring ASCII case.
    fn from_str(s: &str) -> Result<Self, Self::Err> {
        match s.to_ascii_lowercase().as_str() {
            "primary" => Ok(RayKind::Primary),
            "diffuse" => Ok(RayKind::Diffuse),
            "ao" | "ambient-occlusion" | "ambient_occlusion" => Ok(RayKind::AmbientOcclusion),
            _ => Err(ParseRayKindError(s.to_string())),
        }
    }
}

/// Ambient-occlusion rays end at this fraction of the scene's bounding-box diagonal.
pub const AO_DISTANCE_FRACTION: f32 = 0.1;

/// The relative size of the origin offset of secondary rays (see [`offset_epsilon`]).
pub const OFFSET_SCALE: f32 = 1e-4;

/// The distance by which a secondary ray's origin is pushed off the surface along the normal:
///
/// `OFFSET_SCALE * max(1e-3 * scene_diagonal, max(|p.x|, |p.y|, |p.z|))`
///
/// with `OFFSET_SCALE = 1e-4`. The `|p|` term is about a thousand times the rounding error of
/// a point computed from `f32` vertices of magnitude `|p|` (`2^-24 |p|` per operation), so the
/// new ray cannot start behind its own surface; the scene term (`1e-7` of the diagonal) keeps
/// the offset meaningful near the origin. A non-finite or negative diagonal counts as 0.
#[inline]
pub fn offset_epsilon(p: Vec3A, scene_diagonal: f32) -> f32 {
    let diag = if scene_diagonal.is_finite() {
        scene_diagonal.max(0.0)
    } else {
        0.0
    };
    OFFSET_SCALE * (1e-3 * diag).max(p.abs().max_element())
}

/// SplitMix64 finaliser: a bijective 64-bit mix.
#[inline]
fn splitmix64(mut z: u64) -> u64 {
    z = z.wrapping_add(0x9E37_79B9_7F4A_7C15);
    z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
    z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
    z ^ (z >> 31)
}

/// The random generator of the ray spawned at `pixel` for a set of `kind` generated from
/// `seed`: `Pcg32::new(splitmix64(seed ^ splitmix64(pixel)), stream)` with stream 0, 1, 2 for
/// primary, diffuse and AO.
///
/// Each ray owns its generator, so a ray set is bit-identical whatever the number of threads
/// and whichever subset of pixels is generated. Diffuse and AO sets of the same seed use
/// different streams, hence different directions.
pub fn ray_rng(seed: u64, pixel: u32, kind: RayKind) -> Pcg32 {
    Pcg32::new(
        splitmix64(seed ^ splitmix64(u64::from(pixel))),
        kind.stream(),
    )
}

/// A cosine-weighted direction in the hemisphere around the unit vector `normal`, from two
/// uniform numbers in `[0, 1)` (Malley's method on the orthonormal basis of Duff et al. 2017).
///
/// The result has unit length and `dot(result, normal) >= 2^-12` (up to rounding) since
/// `r2 < 1`, so it never grazes the surface.
#[inline]
pub fn cosine_hemisphere(normal: Vec3A, r1: f32, r2: f32) -> Vec3A {
    let n = normal;
    let sign = 1.0f32.copysign(n.z);
    let a = -1.0 / (sign + n.z);
    let b = n.x * n.y * a;
    let tangent = Vec3A::new(1.0 + sign * n.x * n.x * a, sign * b, -sign * n.x);
    let bitangent = Vec3A::new(b, sign + n.y * n.y * a, -n.y);
    let phi = std::f32::consts::TAU * r1;
    let r = r2.sqrt();
    let z = (1.0 - r2).max(0.0).sqrt();
    let (s, c) = phi.sin_cos();
    (tangent * (r * c) + bitangent * (r * s) + n * z).normalize()
}

/// The bounding box of the finite triangles of a scene (empty for none).
pub fn scene_bounds(tris: &[Triangle]) -> Aabb {
    tris.iter()
        .filter(|t| t.is_finite())
        .fold(Aabb::EMPTY, |mut b, t| {
            b.grow_aabb(&t.bounds());
            b
        })
}

/// The length of the diagonal of `bounds` (0 for an empty box).
fn diagonal(bounds: &Aabb) -> f32 {
    if bounds.is_empty() {
        0.0
    } else {
        bounds.extent().length()
    }
}

/// A set of rays generated for an image, with the pixel each ray belongs to.
///
/// Built by [`RaySet::primary`], [`RaySet::diffuse`], [`RaySet::ambient_occlusion`] (or
/// [`RaySet::generate`] by kind), [`RaySet::spawn`] from already traced hits, or
/// [`RaySet::from_rays`] for rays read from a file. Everything is deterministic: the same
/// inputs give bit-identical sets on any number of threads.
#[derive(Clone, Debug, PartialEq)]
pub struct RaySet {
    /// The rays.
    pub rays: Vec<Ray>,
    /// What they are, which decides the query: closest hit, or any hit for
    /// [`RayKind::AmbientOcclusion`] ([`RayKind::uses_any_hit`]).
    pub kind: RayKind,
    /// Width of the image the rays belong to.
    pub width: u32,
    /// Height of the image the rays belong to.
    pub height: u32,
    /// The pixel index (`py * width + px`) of each ray, parallel to `rays`, ascending. Primary
    /// sets hold every pixel; secondary sets only the pixels whose primary ray hit.
    pub pixel: Vec<u32>,
}

impl RaySet {
    /// One primary ray per pixel ([`Camera::primary_ray`]), in pixel order.
    ///
    /// # Panics
    ///
    /// When `width * height` does not fit in a `u32` pixel index.
    pub fn primary(camera: &Camera, width: u32, height: u32) -> Self {
        let n = u32::try_from(u64::from(width) * u64::from(height))
            .expect("image too large: width * height must fit in u32");
        let frame = camera.frame(width, height);
        let mut rays = Vec::new();
        (0..n)
            .into_par_iter()
            .with_min_len(1024)
            .map(|i| frame.ray(i % width, i / width))
            .collect_into_vec(&mut rays);
        Self {
            rays,
            kind: RayKind::Primary,
            width,
            height,
            pixel: (0..n).collect(),
        }
    }

    /// Diffuse rays: the primary rays are traced (closest hit, `tracer`), and each hit spawns
    /// one cosine-weighted ray as described in [`RaySet::spawn`]; `tmin = 0`, `tmax = +inf`.
    /// `tris` are the scene's triangles (for normals and the scene's size).
    pub fn diffuse<T: Tracer + ?Sized>(
        camera: &Camera,
        width: u32,
        height: u32,
        tracer: &T,
        tris: &[Triangle],
        seed: u64,
    ) -> Self {
        Self::generate(RayKind::Diffuse, camera, width, height, tracer, tris, seed)
    }

    /// Ambient-occlusion rays: like [`RaySet::diffuse`] but with
    /// `tmax = AO_DISTANCE_FRACTION * scene diagonal`, traced for any hit.
    pub fn ambient_occlusion<T: Tracer + ?Sized>(
        camera: &Camera,
        width: u32,
        height: u32,
        tracer: &T,
        tris: &[Triangle],
        seed: u64,
    ) -> Self {
        Self::generate(
            RayKind::AmbientOcclusion,
            camera,
            width,
            height,
            tracer,
            tris,
            seed,
        )
    }

    /// The set of `kind` for a camera and image size. Primary sets ignore `tracer`, `tris` and
    /// `seed`.
    pub fn generate<T: Tracer + ?Sized>(
        kind: RayKind,
        camera: &Camera,
        width: u32,
        height: u32,
        tracer: &T,
        tris: &[Triangle],
        seed: u64,
    ) -> Self {
        let primary = Self::primary(camera, width, height);
        if kind == RayKind::Primary {
            return primary;
        }
        let hits = trace_closest(tracer, &primary.rays);
        Self::spawn(&primary, &hits, kind, tris, seed)
    }

    /// Secondary rays of `kind` from the closest hits `hits` of the rays of `base` (parallel
    /// to `base.rays`), which keeps the pixels of `base`. For each hit, in order:
    ///
    /// * `p = tri.point(u, v)`, the hit point from its barycentrics;
    /// * `n` = the unit geometric normal of the triangle, flipped to face the incoming ray
    ///   (`dot(n, ray.direction()) <= 0`); if the triangle is too small for a normal, `-direction`;
    /// * origin `p + n * offset_epsilon(p, diagonal)` ([`offset_epsilon`]), where `diagonal`
    ///   is that of [`scene_bounds`]`(tris)`;
    /// * direction: [`cosine_hemisphere`]`(n, r1, r2)` with `r1`, `r2` the first two
    ///   `next_f32` of [`ray_rng`]`(seed, pixel, kind)`;
    /// * `tmin = 0`; `tmax = +inf` for diffuse rays, `AO_DISTANCE_FRACTION * diagonal` for AO.
    ///
    /// Misses, and hits whose `prim` is not an index of `tris`, spawn nothing. With
    /// `kind = Primary` the result is a copy of `base`.
    ///
    /// # Panics
    ///
    /// When `hits.len() != base.rays.len()`.
    pub fn spawn(base: &RaySet, hits: &[Hit], kind: RayKind, tris: &[Triangle], seed: u64) -> Self {
        assert_eq!(
            hits.len(),
            base.rays.len(),
            "RaySet::spawn: one hit per ray of the base set"
        );
        if kind == RayKind::Primary {
            return base.clone();
        }
        let diag = diagonal(&scene_bounds(tris));
        let tmax = match kind {
            RayKind::AmbientOcclusion => AO_DISTANCE_FRACTION * diag,
            _ => f32::INFINITY,
        };
        let spawned: Vec<Option<(u32, Ray)>> = base
            .rays
            .par_iter()
            .zip(hits.par_iter())
            .zip(base.pixel.par_iter())
            .with_min_len(256)
            .map(|((ray, hit), &pixel)| {
                if !hit.is_hit() {
                    return None;
                }
                let tri = tris.get(hit.prim as usize)?;
                let p = tri.point(hit.u, hit.v);
                let mut n = tri.normal();
                if n == Vec3A::ZERO || !n.is_finite() {
                    n = -ray.direction().normalize_or_zero();
                } else if n.dot(ray.direction()) > 0.0 {
                    n = -n;
                }
                let origin = p + n * offset_epsilon(p, diag);
                let mut rng = ray_rng(seed, pixel, kind);
                let (r1, r2) = (rng.next_f32(), rng.next_f32());
                let dir = cosine_hemisphere(n, r1, r2);
                Some((pixel, Ray::new(origin, dir, 0.0, tmax)))
            })
            .collect();
        let (pixel, rays) = spawned.into_iter().flatten().unzip();
        Self {
            rays,
            kind,
            width: base.width,
            height: base.height,
            pixel,
        }
    }

    /// A set of arbitrary rays (for example read from a ray file): pixel `i` for ray `i`, in
    /// an image of `rays.len() × 1` pixels.
    pub fn from_rays(kind: RayKind, rays: Vec<Ray>) -> Self {
        let n = u32::try_from(rays.len()).unwrap_or(u32::MAX);
        Self {
            pixel: (0..n).collect(),
            kind,
            width: n,
            height: 1,
            rays,
        }
    }

    /// Number of rays.
    pub fn len(&self) -> usize {
        self.rays.len()
    }

    /// True when the set holds no ray.
    pub fn is_empty(&self) -> bool {
        self.rays.is_empty()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn kind_names_round_trip() {
        for k in RayKind::ALL {
            assert_eq!(k.name().parse::<RayKind>().unwrap(), k);
            assert_eq!(k.to_string(), k.name());
        }
        assert!("bounce".parse::<RayKind>().is_err());
    }

    #[test]
    fn cosine_directions_are_unit_and_above_the_surface() {
        let mut rng = Pcg32::new(1, 2);
        for i in 0..2000 {
            let n = cosine_hemisphere(Vec3A::Z, rng.next_f32(), 0.5).normalize();
            let n = if i % 2 == 0 { n } else { -n };
            let d = cosine_hemisphere(n, rng.next_f32(), rng.next_f32());
            assert!((d.length() - 1.0).abs() < 1e-5);
            assert!(d.dot(n) > 0.0, "{n:?} {d:?}");
        }
        // Extreme normals, including the sign switch of the basis.
        for n in [Vec3A::Z, -Vec3A::Z, Vec3A::X, -Vec3A::Y] {
            let d = cosine_hemisphere(n, 0.999_999_9, 0.999_999_9);
            assert!(d.dot(n) > 0.0);
        }
    }

    #[test]
    fn mean_cosine_is_two_thirds() {
        // E[cos θ] = 2/3 for a cosine-weighted hemisphere.
        let mut rng = Pcg32::new(5, 0);
        let n = Vec3A::new(1.0, 2.0, -3.0).normalize();
        let m = 20_000;
        let s: f32 = (0..m)
            .map(|_| cosine_hemisphere(n, rng.next_f32(), rng.next_f32()).dot(n))
            .sum();
        assert!((s / m as f32 - 2.0 / 3.0).abs() < 0.01);
    }

    #[test]
    fn offset_scales_with_magnitude_and_scene() {
        assert!((offset_epsilon(Vec3A::new(0.0, -1000.0, 1.0), 1.0) - 0.1).abs() < 1e-7);
        assert!((offset_epsilon(Vec3A::ZERO, 100.0) - 1e-5).abs() < 1e-12);
        assert_eq!(offset_epsilon(Vec3A::ZERO, f32::NAN), 0.0);
    }
}
