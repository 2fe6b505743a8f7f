//! Ray sets of the hard cases.

use std::collections::HashSet;

use sahara_geom::{rng::Pcg32, Aabb, Ray, Triangle, Vec3A};
use sahara_scene::Mesh;

/// A uniformly distributed unit vector.
pub(crate) fn unit(rng: &mut Pcg32) -> Vec3A {
    let z = rng.range_f32(-1.0, 1.0);
    let phi = rng.range_f32(0.0, std::f32::consts::TAU);
    let r = (1.0 - z * z).max(0.0).sqrt();
    Vec3A::new(r * phi.cos(), r * phi.sin(), z)
}

/// A point uniformly distributed on a triangle (two uniform numbers, folded into the lower half
/// of the unit square).
pub(crate) fn on_triangle(rng: &mut Pcg32, tri: &Triangle) -> Vec3A {
    let (mut u, mut v) = (rng.next_f32(), rng.next_f32());
    if u + v > 1.0 {
        (u, v) = (1.0 - u, 1.0 - v);
    }
    tri.point(u, v)
}

/// A point uniformly distributed in the ball of radius `radius` around `center`.
pub(crate) fn in_ball(rng: &mut Pcg32, center: Vec3A, radius: f32) -> Vec3A {
    center + unit(rng) * (radius * rng.next_f32().cbrt())
}

/// `n` rays from random points within `radius` of `center`, in random directions.
pub(crate) fn inside_random(rng: &mut Pcg32, center: Vec3A, radius: f32, n: usize) -> Vec<Ray> {
    (0..n)
        .map(|_| Ray::new(in_ball(rng, center, radius), unit(rng), 0.0, f32::INFINITY))
        .collect()
}

/// Rays from `center` along the 6 axes, the 12 face diagonals and the 8 space diagonals
/// (exact directions with zero components: for boxes they go exactly through face centres,
/// edges and corners).
pub(crate) fn axis_and_diagonal(center: Vec3A) -> Vec<Ray> {
    let mut v = Vec::new();
    for x in [-1.0f32, 0.0, 1.0] {
        for y in [-1.0f32, 0.0, 1.0] {
            for z in [-1.0f32, 0.0, 1.0] {
                if x != 0.0 || y != 0.0 || z != 0.0 {
                    v.push(Ray::new(center, Vec3A::new(x, y, z), 0.0, f32::INFINITY));
                }
            }
        }
    }
    v
}

/// Points exactly on the mesh's vertices, on its edges' midpoints and at a third of each edge
/// (rounded to `f32`: as close to the edge as a ray can aim). At most `max` of them, sampled
/// deterministically.
pub(crate) fn edge_and_vertex_targets(mesh: &Mesh, max: usize, rng: &mut Pcg32) -> Vec<Vec3A> {
    let mut edges: HashSet<(u32, u32)> = HashSet::new();
    let mut list = Vec::new();
    for t in &mesh.indices {
        for k in 0..3 {
            let (a, b) = (t[k], t[(k + 1) % 3]);
            if edges.insert((a.min(b), a.max(b))) {
                list.push((a.min(b), a.max(b)));
            }
        }
    }
    let mut targets = Vec::new();
    let budget_vertices = max / 3;
    let nv = mesh.positions.len();
    let step = (nv / budget_vertices.max(1)).max(1);
    for i in (0..nv).step_by(step).take(budget_vertices) {
        targets.push(mesh.positions[i]);
    }
    let ne = list.len();
    let remaining = max.saturating_sub(targets.len());
    let per_edge = remaining / 2;
    for _ in 0..per_edge.min(ne) {
        let (a, b) = list[rng.below(ne as u32) as usize];
        let (pa, pb) = (mesh.positions[a as usize], mesh.positions[b as usize]);
        targets.push((pa + pb) * 0.5);
        targets.push(pa + (pb - pa) * (1.0 / 3.0));
    }
    targets
}

/// Rays from `origins` (cycled) to each target: direction `target - origin`.
pub(crate) fn aimed(origins: &[Vec3A], targets: &[Vec3A]) -> Vec<Ray> {
    targets
        .iter()
        .enumerate()
        .filter_map(|(i, &t)| {
            let o = origins[i % origins.len()];
            let d = t - o;
            (d != Vec3A::ZERO).then(|| Ray::new(o, d, 0.0, f32::INFINITY))
        })
        .collect()
}

/// Probe rays for an arbitrary scene: rays from outside the bounds aimed at random triangle
/// vertices and interior points (with an open and with an exact `tmax = 1` end), rays between
/// random points of the bounds, and axis-parallel rays through the bounds' centre.
pub(crate) fn probe(tris: &[Triangle], n: usize, rng: &mut Pcg32) -> Vec<Ray> {
    let mut rays = Vec::with_capacity(n + 32);
    if tris.is_empty() {
        // Anything: nothing may be hit.
        for _ in 0..n.min(64) {
            rays.push(Ray::new(Vec3A::ZERO, unit(rng), 0.0, f32::INFINITY));
        }
        return rays;
    }
    let mut b = Aabb::EMPTY;
    for t in tris {
        b.grow_aabb(&t.bounds());
    }
    let center = b.centroid();
    let extent = b.extent().max_element();
    // Far enough out to start outside, and not lost in the rounding of `center`.
    let reach = (2.0 * extent)
        .max(center.abs().max_element() * 1e-3)
        .max(1e-30);
    let reach = if reach.is_finite() { reach } else { f32::MAX };
    for i in 0..n {
        let tri = &tris[rng.below(tris.len() as u32) as usize];
        let target = match i % 4 {
            0 => tri.v[rng.below(3) as usize],
            1 | 2 => on_triangle(rng, tri),
            _ => Vec3A::new(
                rng.range_f32(b.min.x, b.max.x),
                rng.range_f32(b.min.y, b.max.y),
                rng.range_f32(b.min.z, b.max.z),
            ),
        };
        let origin = if i % 5 == 4 {
            Vec3A::new(
                rng.range_f32(b.min.x, b.max.x),
                rng.range_f32(b.min.y, b.max.y),
                rng.range_f32(b.min.z, b.max.z),
            )
        } else {
            let o = center + unit(rng) * reach;
            if o.is_finite() {
                o
            } else {
                center
            }
        };
        let d = target - origin;
        if d == Vec3A::ZERO || !d.is_finite() {
            continue;
        }
        let tmax = if i % 3 == 0 { 1.0 } else { f32::INFINITY };
        rays.push(Ray::new(origin, d, 0.0, tmax));
    }
    // Axis-parallel rays through the centre, starting outside: zero direction components
    // and origins on the slab planes of flat boxes.
    for axis in 0..3 {
        for s in [-1.0f32, 1.0] {
            let mut d = Vec3A::ZERO;
            d[axis] = s;
            let o = center - d * reach;
            if o.is_finite() {
                rays.push(Ray::new(o, d, 0.0, f32::INFINITY));
            }
        }
    }
    rays
}

/// Makes a ray bad in one way.
pub(crate) type Corruption = fn(Ray) -> Ray;

/// The corruptions applied to each base ray of the bad-ray cases, with their names.
pub(crate) fn corruptions() -> Vec<(&'static str, Corruption)> {
    vec![
        ("origin.x=NaN", |r| {
            Ray::new(
                Vec3A::new(f32::NAN, r.origin.y, r.origin.z),
                r.direction(),
                r.tmin,
                r.tmax,
            )
        }),
        ("origin.y=+inf", |r| {
            Ray::new(
                Vec3A::new(r.origin.x, f32::INFINITY, r.origin.z),
                r.direction(),
                r.tmin,
                r.tmax,
            )
        }),
        ("origin.z=-inf", |r| {
            Ray::new(
                Vec3A::new(r.origin.x, r.origin.y, f32::NEG_INFINITY),
                r.direction(),
                r.tmin,
                r.tmax,
            )
        }),
        ("origin=NaN", |r| {
            Ray::new(Vec3A::NAN, r.direction(), r.tmin, r.tmax)
        }),
        ("direction.x=NaN", |r| {
            Ray::new(
                r.origin,
                Vec3A::new(f32::NAN, r.direction().y, r.direction().z),
                r.tmin,
                r.tmax,
            )
        }),
        ("direction.y=+inf", |r| {
            Ray::new(
                r.origin,
                Vec3A::new(r.direction().x, f32::INFINITY, r.direction().z),
                r.tmin,
                r.tmax,
            )
        }),
        ("direction.z=-inf", |r| {
            Ray::new(
                r.origin,
                Vec3A::new(r.direction().x, r.direction().y, f32::NEG_INFINITY),
                r.tmin,
                r.tmax,
            )
        }),
        ("direction=NaN", |r| {
            Ray::new(r.origin, Vec3A::NAN, r.tmin, r.tmax)
        }),
        ("direction=0", |r| {
            Ray::new(r.origin, Vec3A::ZERO, r.tmin, r.tmax)
        }),
        ("direction=-0", |r| {
            Ray::new(r.origin, Vec3A::splat(-0.0), r.tmin, r.tmax)
        }),
        ("tmin=NaN", |r| {
            Ray::new(r.origin, r.direction(), f32::NAN, r.tmax)
        }),
        ("tmax=NaN", |r| {
            Ray::new(r.origin, r.direction(), r.tmin, f32::NAN)
        }),
        ("tmin=+inf", |r| {
            Ray::new(r.origin, r.direction(), f32::INFINITY, f32::INFINITY)
        }),
        ("tmin=-inf", |r| {
            Ray::new(r.origin, r.direction(), f32::NEG_INFINITY, r.tmax)
        }),
        ("tmax=-inf", |r| {
            Ray::new(r.origin, r.direction(), r.tmin, f32::NEG_INFINITY)
        }),
        ("tmax=-1", |r| {
            Ray::new(r.origin, r.direction(), r.tmin, -1.0)
        }),
        ("tmin>tmax", |r| Ray::new(r.origin, r.direction(), 5.0, 1.0)),
        ("tmin=tmax=1", |r| {
            Ray::new(r.origin, r.direction(), 1.0, 1.0)
        }),
        ("tmin=tmax=0", |r| {
            Ray::new(r.origin, r.direction(), 0.0, 0.0)
        }),
        ("tmin=-1e30", |r| {
            Ray::new(r.origin, r.direction(), -1e30, r.tmax)
        }),
        ("tmax=f32::MAX", |r| {
            Ray::new(r.origin, r.direction(), r.tmin, f32::MAX)
        }),
        ("tmax=MIN_POSITIVE", |r| {
            Ray::new(r.origin, r.direction(), r.tmin, f32::MIN_POSITIVE)
        }),
        ("direction*1e-40 (denormal)", |r| {
            Ray::new(r.origin, r.direction() * 1e-40, r.tmin, r.tmax)
        }),
        ("direction=(1e-45,1e-45,1e-45)", |r| {
            Ray::new(r.origin, Vec3A::splat(1e-45), r.tmin, r.tmax)
        }),
        ("direction.x denormal", |r| {
            Ray::new(
                r.origin,
                Vec3A::new(1e-40, r.direction().y, r.direction().z),
                r.tmin,
                r.tmax,
            )
        }),
        ("direction*1e-30 (tiny)", |r| {
            Ray::new(r.origin, r.direction() * 1e-30, r.tmin, r.tmax)
        }),
        ("direction*1e30 (huge)", |r| {
            Ray::new(r.origin, r.direction() * 1e30, r.tmin, r.tmax)
        }),
        ("direction.y=-0", |r| {
            Ray::new(
                r.origin,
                Vec3A::new(r.direction().x, -0.0, r.direction().z),
                r.tmin,
                r.tmax,
            )
        }),
        ("direction=(-0,-0,1)", |r| {
            Ray::new(r.origin, Vec3A::new(-0.0, -0.0, 1.0), r.tmin, r.tmax)
        }),
        ("direction=(0,0,-1)", |r| {
            Ray::new(r.origin, Vec3A::new(0.0, 0.0, -1.0), r.tmin, r.tmax)
        }),
        ("origin*1e30 (huge, finite)", |r| {
            Ray::new(r.origin * 1e30, r.direction(), r.tmin, r.tmax)
        }),
        ("origin=f32::MAX", |r| {
            Ray::new(Vec3A::splat(f32::MAX), -r.direction(), r.tmin, r.tmax)
        }),
        ("direction=f32::MAX", |r| {
            Ray::new(
                r.origin,
                Vec3A::new(f32::MAX, -f32::MAX, f32::MAX),
                r.tmin,
                r.tmax,
            )
        }),
    ]
}
