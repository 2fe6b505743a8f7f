//! A camera for a scene that has none: placed where its primary rays see what matters.
//!
//! Framing a scene's bounding box from outside ([`Camera::framing`](sahara_geom::Camera::framing)) shows
//! an object well, but shows a closed scene or a game level as its outer wall: the primary
//! rays then measure nothing a user cares about. [`place_camera`] looks for a better view
//! by tracing rays through the scene (it takes any [`Tracer`], so the caller chooses the
//! tree; this crate builds none, see `docs/cameras.md`):
//!
//! 1. **The outer hull**: the triangles seen from outside. Orthographic grids of 64 × 64
//!    rays come in from the 6 axis directions and the 8 box diagonals, aimed at the bounding
//!    sphere; every triangle one of them hits first is a hull triangle.
//! 2. **Inside**: eyes on a 5 × 5 × 5 lattice of the bounding box (cell centres), each
//!    looking in 8 directions around the up axis, 8.5° below the horizon, with a 60° field of
//!    view. Each of these 1000 views casts 8 × 8 rays; a ray is *good* when the first
//!    triangle it hits is not a hull triangle and faces the eye (its geometric normal, from
//!    the winding, points against the ray: so an eye inside a closed object, which sees
//!    that object's back faces, scores nothing). A view's score is its fraction of good rays
//!    plus a tenth of the mean distance of its good hits over the bounding-sphere radius
//!    (capped at 1), so that among equal views the one that sees farther wins. The best view
//!    (the first in lattice order on ties) is scored again on 32 × 32 rays; if at least a
//!    quarter of them are good, it is the camera ([`PlacementKind::Interior`]).
//! 3. **Outside** otherwise (an object, or a scene whose winding faces away from every
//!    eye): eyes on the bounding sphere's fitting distance, looking at its centre from 8
//!    directions around the up axis at 15° and 35° elevation, 45° field of view; the view
//!    whose 8 × 8 rays hit most (the first on ties, which is the front view from slightly
//!    above) is kept, then moved closer along its direction (to 0.85, 0.7, 0.55 and 0.4 of
//!    the distance, while the eye stays outside the bounding box) if that hits more: this
//!    is the camera ([`PlacementKind::Exterior`]), scored again on 32 × 32 rays.
//!
//! Everything is deterministic (fixed candidates, results in ray order), whatever the
//! thread count.

use sahara_geom::{Aabb, Ray, Triangle, Vec3A};
use sahara_traverse::Hit;

use crate::{trace_closest, Camera, Tracer};

/// Whether the placed camera is inside the scene or outside looking at it.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum PlacementKind {
    /// Inside the bounds, looking at geometry that is not the outer hull.
    Interior,
    /// Outside the bounds, looking at the scene's centre.
    Exterior,
}

/// A placed camera and how well it sees.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Placement {
    /// The camera.
    pub camera: Camera,
    /// Inside or outside.
    pub kind: PlacementKind,
    /// Of a 32 × 32 grid of its primary rays: for an interior camera the fraction whose first
    /// hit is a front-facing non-hull triangle, for an exterior camera the fraction that hits
    /// anything.
    pub score: f32,
    /// How many triangles the outer hull has.
    pub hull_triangles: usize,
}

/// Rays per side of the orthographic grids that find the outer hull.
const HULL_GRID: u32 = 64;
/// Eyes per axis of the interior lattice.
const LATTICE: u32 = 5;
/// View directions per eye (interior) or around the scene (exterior).
const AZIMUTHS: u32 = 8;
/// Rays per side of a candidate's scoring grid.
const SCORE_GRID: u32 = 8;
/// Rays per side of the final score.
const FINAL_GRID: u32 = 32;
/// The least final fraction of good rays for which the interior view is kept.
const INTERIOR_MIN: f32 = 0.25;
/// Field of view of interior cameras (degrees).
const FOV_INTERIOR: f32 = 60.0;
/// Field of view of exterior cameras (degrees).
const FOV_EXTERIOR: f32 = 45.0;

/// Places a camera for `tris` (traced through `tracer`, which must be built over `tris`)
/// with up direction `up` (e.g. `sahara_scene::UpAxis::detect`): see the module
/// documentation. An empty or non-finite scene gets a camera looking at the origin from
/// `+z` with score 0.
pub fn place_camera<T: Tracer + ?Sized>(tracer: &T, tris: &[Triangle], up: Vec3A) -> Placement {
    let bounds = tris.iter().fold(Aabb::EMPTY, |b, t| b.union(&t.bounds()));
    let up = up.normalize_or_zero();
    let up = if up == Vec3A::ZERO || !up.is_finite() {
        Vec3A::Y
    } else {
        up
    };
    if tris.is_empty() || !bounds.is_finite() || bounds.is_empty() {
        return Placement {
            camera: Camera::new(Vec3A::Z, Vec3A::ZERO, up, FOV_EXTERIOR),
            kind: PlacementKind::Exterior,
            score: 0.0,
            hull_triangles: 0,
        };
    }
    let centre = bounds.centroid();
    let radius = (bounds.extent().length() * 0.5).max(f32::MIN_POSITIVE);
    let hull = outer_hull(tracer, tris.len(), centre, radius);
    let hull_triangles = hull.iter().filter(|&&h| h).count();
    let (h1, h2) = horizontal_basis(up);

    // Inside.
    let mut views = Vec::new();
    let lo = bounds.min;
    let ext = bounds.extent();
    for k in 0..LATTICE {
        for j in 0..LATTICE {
            for i in 0..LATTICE {
                let f = |n: u32| (n as f32 + 0.5) / LATTICE as f32;
                let eye = lo + ext * Vec3A::new(f(i), f(j), f(k));
                for a in 0..AZIMUTHS {
                    let phi = a as f32 * std::f32::consts::TAU / AZIMUTHS as f32;
                    let dir = (h1 * phi.cos() + h2 * phi.sin() - up * 0.15).normalize();
                    views.push(Camera::new(eye, eye + dir * radius, up, FOV_INTERIOR));
                }
            }
        }
    }
    let scores = score_views(tracer, tris, &hull, &views, SCORE_GRID, radius, true);
    let best = argmax(&scores);
    let interior = views[best];
    let good = score_views(tracer, tris, &hull, &[interior], FINAL_GRID, radius, true)[0].1;
    if good >= INTERIOR_MIN {
        return Placement {
            camera: interior,
            kind: PlacementKind::Interior,
            score: good,
            hull_triangles,
        };
    }

    // Outside.
    let distance = radius / (FOV_EXTERIOR.to_radians() * 0.5).sin();
    let mut views = Vec::new();
    for elevation in [15f32, 35.0] {
        let (s, c) = elevation.to_radians().sin_cos();
        for a in 0..AZIMUTHS {
            let phi = a as f32 * std::f32::consts::TAU / AZIMUTHS as f32;
            let dir = (h1 * phi.cos() + h2 * phi.sin()) * c + up * s;
            views.push(Camera::new(
                centre + dir * distance,
                centre,
                up,
                FOV_EXTERIOR,
            ));
        }
    }
    let scores = score_views(tracer, tris, &hull, &views, SCORE_GRID, radius, false);
    let chosen = views[argmax(&scores)];
    // Closer along the chosen direction, while the eye stays outside the bounds: the
    // bounding sphere is larger than most objects' silhouettes.
    let closer: Vec<Camera> = [1.0f32, 0.85, 0.7, 0.55, 0.4]
        .into_iter()
        .map(|f| Camera {
            eye: centre + (chosen.eye - centre) * f,
            ..chosen
        })
        .filter(|c| c.eye == chosen.eye || !contains(&bounds, c.eye))
        .collect();
    let scores = score_views(tracer, tris, &hull, &closer, SCORE_GRID, radius, false);
    let exterior = closer[argmax(&scores)];
    let hit = score_views(tracer, tris, &hull, &[exterior], FINAL_GRID, radius, false)[0].1;
    Placement {
        camera: exterior,
        kind: PlacementKind::Exterior,
        score: hit,
        hull_triangles,
    }
}

/// Two unit vectors spanning the plane orthogonal to `up`; the first is the "front" of the
/// scene (`+z` for a y-up scene, `+y` for a z-up scene, as `Camera::framing` of
/// `sahara-scene`).
fn horizontal_basis(up: Vec3A) -> (Vec3A, Vec3A) {
    let a = up.abs();
    let front = if a.y >= a.x && a.y >= a.z {
        Vec3A::Z
    } else if a.z >= a.x {
        Vec3A::Y
    } else {
        Vec3A::Z
    };
    let h1 = (front - up * front.dot(up)).normalize();
    (h1, up.cross(h1).normalize())
}

/// Which triangles are hit first by rays coming in from outside the bounding sphere.
fn outer_hull<T: Tracer + ?Sized>(tracer: &T, n: usize, centre: Vec3A, radius: f32) -> Vec<bool> {
    let mut dirs = vec![
        Vec3A::X,
        Vec3A::NEG_X,
        Vec3A::Y,
        Vec3A::NEG_Y,
        Vec3A::Z,
        Vec3A::NEG_Z,
    ];
    for s in 0..8u32 {
        let sign = |b: u32| if s & b != 0 { -1.0 } else { 1.0 };
        dirs.push(Vec3A::new(sign(1), sign(2), sign(4)).normalize());
    }
    let mut rays = Vec::with_capacity(dirs.len() * (HULL_GRID * HULL_GRID) as usize);
    for d in dirs {
        let a = d.any_orthonormal_vector();
        let b = d.cross(a);
        let plane = centre - d * (2.0 * radius);
        for j in 0..HULL_GRID {
            for i in 0..HULL_GRID {
                let s = 2.0 * (i as f32 + 0.5) / HULL_GRID as f32 - 1.0;
                let t = 2.0 * (j as f32 + 0.5) / HULL_GRID as f32 - 1.0;
                rays.push(Ray::new(
                    plane + (a * s + b * t) * radius,
                    d,
                    0.0,
                    f32::INFINITY,
                ));
            }
        }
    }
    let mut hull = vec![false; n];
    for h in trace_closest(tracer, &rays) {
        if let Some(x) = hull.get_mut(h.prim as usize) {
            *x = true;
        }
    }
    hull
}

/// `(score, fraction)` of each view on a `grid × grid` image: `fraction` is the share of
/// good rays (interior: front-facing non-hull first hits; exterior: any hit), `score` adds a
/// tenth of the good hits' mean distance over `radius`, capped at 1 (interior only).
fn score_views<T: Tracer + ?Sized>(
    tracer: &T,
    tris: &[Triangle],
    hull: &[bool],
    views: &[Camera],
    grid: u32,
    radius: f32,
    interior: bool,
) -> Vec<(f32, f32)> {
    let per = (grid * grid) as usize;
    let mut rays = Vec::with_capacity(views.len() * per);
    for v in views {
        for py in 0..grid {
            for px in 0..grid {
                rays.push(v.primary_ray(px, py, grid, grid));
            }
        }
    }
    let hits = trace_closest(tracer, &rays);
    rays.chunks(per)
        .zip(hits.chunks(per))
        .map(|(rays, hits)| {
            let (mut good, mut dist) = (0usize, 0f64);
            for (r, h) in rays.iter().zip(hits) {
                if is_good(tris, hull, r, h, interior) {
                    good += 1;
                    dist += f64::from(h.t.min(radius * 4.0));
                }
            }
            let fraction = good as f32 / per as f32;
            let depth = if interior && good > 0 {
                ((dist / good as f64) as f32 / radius).min(1.0)
            } else {
                0.0
            };
            (fraction + 0.1 * depth, fraction)
        })
        .collect()
}

fn is_good(tris: &[Triangle], hull: &[bool], ray: &Ray, hit: &Hit, interior: bool) -> bool {
    let Some(t) = tris.get(hit.prim as usize) else {
        return false;
    };
    if !interior {
        return true;
    }
    let normal = (t.v[1] - t.v[0]).cross(t.v[2] - t.v[0]);
    !hull[hit.prim as usize] && normal.dot(ray.direction()) < 0.0
}

/// Whether `p` is in the closed box `b`.
fn contains(b: &Aabb, p: Vec3A) -> bool {
    p.cmpge(b.min).all() && p.cmple(b.max).all()
}

/// The index of the first greatest score.
fn argmax(scores: &[(f32, f32)]) -> usize {
    let mut best = 0;
    for (i, s) in scores.iter().enumerate() {
        if s.0 > scores[best].0 {
            best = i;
        }
    }
    best
}
