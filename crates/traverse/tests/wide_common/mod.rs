//! Scenes, tiny builders and ray sets of the wide-BVH tests (random soups are
//! `sahara_fixtures::soups::mixed_soup`, the binned SAH tree `sahara_fixtures::trees::sah_bvh`),
//! and the backends and hit bits every layout test compares over (`custom.rs`, `miri.rs`,
//! `refit.rs`, `wide.rs`).
#![allow(dead_code)]

use sahara_bvh::{Bvh, Node};
use sahara_fixtures::rays::point_in;
use sahara_geom::{clip, rng::Pcg32, Aabb, Ray, Triangle, Vec3A};
use sahara_traverse::{Backend, Hit};

// ---------------------------------------------------------------------------------------------
// Backends and hits
// ---------------------------------------------------------------------------------------------

/// The SIMD backends this CPU runs (the portable fallback included).
pub fn backends() -> Vec<Backend> {
    Backend::ALL
        .into_iter()
        .filter(|b| b.is_available())
        .collect()
}

/// A hit as bits, for exact comparisons: distance, primitive, barycentrics.
pub fn bits(h: &Hit) -> (u32, u32, u32, u32) {
    (h.t.to_bits(), h.prim, h.u.to_bits(), h.v.to_bits())
}

// ---------------------------------------------------------------------------------------------
// Scenes
// ---------------------------------------------------------------------------------------------

/// A closed UV sphere (radius `radius`, centred at the origin; vertices shared exactly between
/// neighbouring triangles) inside a closed axis-aligned box `[-half, half]^3` whose faces are
/// split into `grid × grid` quads. Returns the triangles and the number belonging to the
/// sphere (they come first).
pub fn sphere_in_box(
    rings: usize,
    segments: usize,
    radius: f32,
    half: f32,
    grid: usize,
) -> (Vec<Triangle>, usize) {
    let mut tris = Vec::new();
    let vert = |i: usize, j: usize| -> Vec3A {
        if i == 0 {
            return Vec3A::new(0.0, radius, 0.0);
        }
        if i == rings {
            return Vec3A::new(0.0, -radius, 0.0);
        }
        let th = std::f32::consts::PI * i as f32 / rings as f32;
        let ph = 2.0 * std::f32::consts::PI * (j % segments) as f32 / segments as f32;
        Vec3A::new(
            radius * th.sin() * ph.cos(),
            radius * th.cos(),
            radius * th.sin() * ph.sin(),
        )
    };
    for i in 0..rings {
        for j in 0..segments {
            let (a, b, c, d) = (
                vert(i, j),
                vert(i, j + 1),
                vert(i + 1, j),
                vert(i + 1, j + 1),
            );
            if i != 0 {
                tris.push(Triangle::new(a, b, c));
            }
            if i + 1 != rings {
                tris.push(Triangle::new(b, d, c));
            }
        }
    }
    let n_sphere = tris.len();
    let coord = |k: usize| -half + 2.0 * half * k as f32 / grid as f32;
    for axis in 0..3 {
        for side in [-half, half] {
            let (u, v) = ((axis + 1) % 3, (axis + 2) % 3);
            let at = |i: usize, j: usize| {
                let mut p = Vec3A::ZERO;
                p[axis] = side;
                p[u] = coord(i);
                p[v] = coord(j);
                p
            };
            for i in 0..grid {
                for j in 0..grid {
                    let (a, b, c, d) = (at(i, j), at(i + 1, j), at(i, j + 1), at(i + 1, j + 1));
                    tris.push(Triangle::new(a, b, d));
                    tris.push(Triangle::new(a, d, c));
                }
            }
        }
    }
    (tris, n_sphere)
}

// ---------------------------------------------------------------------------------------------
// Builders
// ---------------------------------------------------------------------------------------------

fn bounds_of(tris: &[Triangle], prims: &[u32]) -> Aabb {
    prims
        .iter()
        .fold(Aabb::EMPTY, |b, &p| b.union(&tris[p as usize].bounds()))
}

/// Binned SAH (16 bins on the longest centroid axis, costs 1 and 1), leaves of at most
/// `max_leaf` triangles (in `sahara-fixtures`: `cargo xtask measure wide-bench` builds it too).
pub use sahara_fixtures::trees::sah_bvh;

/// Object-median split on the longest centroid axis, leaves of at most `leaf` triangles.
pub fn median_bvh(tris: &[Triangle], leaf: usize) -> Bvh {
    let mut prims: Vec<u32> = (0..tris.len() as u32).collect();
    let mut bvh = Bvh::empty();
    if !prims.is_empty() {
        median_rec(tris, &mut prims, leaf.max(1), &mut bvh);
    }
    bvh
}

fn median_rec(tris: &[Triangle], prims: &mut [u32], leaf: usize, bvh: &mut Bvh) -> u32 {
    let idx = bvh.nodes.len();
    let b = bounds_of(tris, prims);
    if prims.len() <= leaf {
        bvh.nodes.push(Node::leaf(
            &b,
            bvh.prim_indices.len() as u32,
            prims.len() as u32,
        ));
        bvh.prim_indices.extend_from_slice(prims);
        return idx as u32;
    }
    bvh.nodes.push(Node::inner(&b, 0));
    let cb = prims
        .iter()
        .fold(Aabb::EMPTY, |a, &p| a.grown(tris[p as usize].centroid()));
    let axis = cb.largest_axis();
    let mid = prims.len() / 2;
    prims.select_nth_unstable_by(mid, |&a, &b| {
        let (ca, cb) = (
            tris[a as usize].centroid()[axis],
            tris[b as usize].centroid()[axis],
        );
        ca.total_cmp(&cb).then(a.cmp(&b))
    });
    let (l, r) = prims.split_at_mut(mid);
    median_rec(tris, l, leaf, bvh);
    let right = median_rec(tris, r, leaf, bvh);
    bvh.nodes[idx].index = right;
    idx as u32
}

fn pad(b: Aabb) -> Aabb {
    let e = |v: Vec3A| v.abs() * 1e-6 + Vec3A::splat(1e-30);
    Aabb::new(b.min - e(b.min), b.max + e(b.max))
}

/// A spatial-split tree: every node is split at the spatial middle of its longest axis and
/// triangles straddling the plane are referenced on both sides, with their boxes clipped
/// (exactly, then padded outwards by a few ulps). Leaves hold at most `leaf` references.
pub fn spatial_bvh(tris: &[Triangle], leaf: usize) -> Bvh {
    let refs: Vec<(u32, Aabb)> = tris
        .iter()
        .enumerate()
        .map(|(i, t)| (i as u32, t.bounds()))
        .collect();
    let mut bvh = Bvh {
        spatial_splits: true,
        ref_cuts: None,
        ..Bvh::empty()
    };
    if !refs.is_empty() {
        spatial_rec(tris, refs, leaf.max(1), 0, &mut bvh);
    }
    bvh
}

fn spatial_rec(
    tris: &[Triangle],
    refs: Vec<(u32, Aabb)>,
    leaf: usize,
    depth: usize,
    bvh: &mut Bvh,
) -> Aabb {
    let idx = bvh.nodes.len();
    let b = refs.iter().fold(Aabb::EMPTY, |a, r| a.union(&r.1));
    let mut children = None;
    if refs.len() > leaf && depth < 24 {
        let axis = b.largest_axis();
        let mid = 0.5 * (b.min[axis] + b.max[axis]);
        let (mut lr, mut rr) = (b, b);
        lr.max[axis] = mid;
        rr.min[axis] = mid;
        let side = |region: &Aabb| -> Vec<(u32, Aabb)> {
            refs.iter()
                .filter_map(|&(p, rb)| {
                    let c = clip::clipped_bounds(&tris[p as usize], &rb.intersection(region));
                    (!c.is_empty()).then(|| (p, pad(c)))
                })
                .collect()
        };
        let (l, r) = (side(&lr), side(&rr));
        if !l.is_empty() && !r.is_empty() && (l.len() < refs.len() || r.len() < refs.len()) {
            children = Some((l, r));
        }
    }
    let Some((l, r)) = children else {
        bvh.nodes.push(Node::leaf(
            &b,
            bvh.prim_indices.len() as u32,
            refs.len() as u32,
        ));
        bvh.prim_indices.extend(refs.iter().map(|r| r.0));
        return b;
    };
    bvh.nodes.push(Node::inner(&b, 0));
    let lb = spatial_rec(tris, l, leaf, depth + 1, bvh);
    let right = bvh.nodes.len() as u32;
    let rb = spatial_rec(tris, r, leaf, depth + 1, bvh);
    let u = lb.union(&rb);
    bvh.nodes[idx] = Node::inner(&u, right);
    u
}

/// A degenerate "comb" tree: every inner node has a one-triangle leaf on the left and the rest
/// on the right (depth = number of triangles).
pub fn comb_bvh(tris: &[Triangle]) -> Bvh {
    let mut bvh = Bvh::empty();
    let n = tris.len();
    let all: Vec<u32> = (0..n as u32).collect();
    for i in 0..n {
        let b = bounds_of(tris, &all[i..]);
        if i + 1 == n {
            bvh.nodes.push(Node::leaf(&b, i as u32, 1));
        } else {
            let me = bvh.nodes.len();
            bvh.nodes.push(Node::inner(&b, (me + 2) as u32));
            bvh.nodes.push(Node::leaf(&tris[i].bounds(), i as u32, 1));
        }
    }
    bvh.prim_indices = all;
    bvh
}

// ---------------------------------------------------------------------------------------------
// Rays
// ---------------------------------------------------------------------------------------------

pub fn unit_dir(r: &mut Pcg32) -> Vec3A {
    loop {
        let d = Vec3A::new(
            r.range_f32(-1.0, 1.0),
            r.range_f32(-1.0, 1.0),
            r.range_f32(-1.0, 1.0),
        );
        let l = d.length_squared();
        if l > 1e-4 && l <= 1.0 {
            return d / l.sqrt();
        }
    }
}

/// `n` rays between two random points of `b` each (origin, then end point, drawn by
/// [`point_in`] from a generator seeded with `seed`): `make(i, origin, end)` makes ray `i`.
pub fn segment_rays(
    b: &Aabb,
    n: usize,
    seed: u64,
    make: impl Fn(usize, Vec3A, Vec3A) -> Ray,
) -> Vec<Ray> {
    let mut rng = Pcg32::new(seed, 5);
    let mut p = || point_in(b, &mut rng);
    (0..n)
        .map(|i| {
            let (o, e) = (p(), p());
            make(i, o, e)
        })
        .collect()
}

/// Random rays: origins in the scene box grown by half its size, random directions, with a mix
/// of `[tmin, tmax]` intervals.
pub fn random_rays(b: &Aabb, n: usize, seed: u64) -> Vec<Ray> {
    let mut r = Pcg32::new(seed, 11);
    let e = b.extent() * 0.5;
    let big = Aabb::new(b.min - e, b.max + e);
    (0..n)
        .map(|i| {
            let o = point_in(&big, &mut r);
            let d = unit_dir(&mut r);
            let (tmin, tmax) = match i % 8 {
                0 => (0.1 * r.next_f32(), r.range_f32(0.0, 3.0)),
                1 => (f32::NEG_INFINITY, f32::INFINITY),
                2 => (r.range_f32(0.0, 1.0), f32::INFINITY),
                _ => (0.0, f32::INFINITY),
            };
            Ray::new(o, d, tmin, tmax)
        })
        .collect()
}

/// Rays from random points inside a sphere of radius `radius` around the origin.
pub fn rays_from_inside(radius: f32, n: usize, seed: u64) -> Vec<Ray> {
    let mut r = Pcg32::new(seed, 13);
    (0..n)
        .map(|_| {
            let o = unit_dir(&mut r) * radius * r.next_f32().sqrt() * 0.99;
            Ray::new(o, unit_dir(&mut r), 0.0, f32::INFINITY)
        })
        .collect()
}

/// Rays aimed exactly at triangle vertices and at points on edges (midpoints and random
/// points), from random origins, with unnormalised directions `target - origin`.
pub fn vertex_and_edge_rays(tris: &[Triangle], b: &Aabb, n: usize, seed: u64) -> Vec<Ray> {
    let mut r = Pcg32::new(seed, 17);
    let e = b.extent();
    let big = Aabb::new(b.min - e, b.max + e);
    (0..n)
        .map(|i| {
            let t = &tris[r.below(tris.len() as u32) as usize];
            let k = r.below(3) as usize;
            let target = match i % 3 {
                0 => t.v[k],
                1 => (t.v[k] + t.v[(k + 1) % 3]) * 0.5,
                _ => {
                    let s = r.next_f32();
                    t.v[k] + (t.v[(k + 1) % 3] - t.v[k]) * s
                }
            };
            let o = point_in(&big, &mut r);
            let tmax = if i % 5 == 0 { 1.0 } else { f32::INFINITY };
            Ray::new(o, target - o, 0.0, tmax)
        })
        .collect()
}

/// Rays whose origin lies exactly on a plane of a node's box and whose direction is parallel
/// to that plane (component `+0.0` or `-0.0`), including axis-parallel rays along box edges.
pub fn grazing_rays(bvh: &Bvh, n: usize, seed: u64) -> Vec<Ray> {
    let mut r = Pcg32::new(seed, 19);
    (0..n)
        .map(|i| {
            let node = &bvh.nodes[r.below(bvh.nodes.len() as u32) as usize];
            let b = node.bounds();
            let axis = r.below(3) as usize;
            let mut o = point_in(&b, &mut r);
            o[axis] = if r.below(2) == 0 {
                b.min[axis]
            } else {
                b.max[axis]
            };
            let mut d = unit_dir(&mut r);
            d[axis] = if r.below(2) == 0 { 0.0 } else { -0.0 };
            if i % 3 == 0 {
                // Along an edge of the box: a second coordinate on a plane, axis-parallel.
                let a2 = (axis + 1 + r.below(2) as usize) % 3;
                o[a2] = if r.below(2) == 0 {
                    b.min[a2]
                } else {
                    b.max[a2]
                };
                d = Vec3A::ZERO;
                let a3 = 3 - axis - a2;
                d[a3] = if r.below(2) == 0 { 1.0 } else { -1.0 };
                if r.below(2) == 0 {
                    d[axis] = -0.0;
                }
                // Start outside the box along the free axis half of the time.
                if r.below(2) == 0 {
                    o[a3] = if d[a3] > 0.0 {
                        b.min[a3] - 1.0
                    } else {
                        b.max[a3] + 1.0
                    };
                }
            }
            Ray::new(o, d, 0.0, f32::INFINITY)
        })
        .collect()
}

/// Rays with NaN or infinite components, zero directions, empty or NaN intervals, denormal
/// directions, axis-parallel directions and unusual intervals.
pub fn adversarial_rays(b: &Aabb, seed: u64) -> Vec<Ray> {
    let mut r = Pcg32::new(seed, 23);
    let c = b.centroid();
    let outside = c - Vec3A::new(0.0, 0.0, 3.0 * b.extent().max_element().max(1.0));
    let specials = [
        f32::NAN,
        f32::INFINITY,
        f32::NEG_INFINITY,
        0.0,
        -0.0,
        1e-40,
        -1e-40,
        f32::MAX,
        f32::MIN_POSITIVE,
    ];
    let mut rays = Vec::new();
    for &s in &specials {
        for k in 0..3 {
            let mut o = outside;
            o[k] = s;
            rays.push(Ray::new(o, Vec3A::Z, 0.0, f32::INFINITY));
            let mut d = (c - outside).normalize();
            d[k] = s;
            rays.push(Ray::new(outside, d, 0.0, f32::INFINITY));
            rays.push(Ray::new(c, d, 0.0, f32::INFINITY));
        }
        rays.push(Ray::new(outside, Vec3A::Z, s, f32::INFINITY));
        rays.push(Ray::new(outside, Vec3A::Z, 0.0, s));
        rays.push(Ray::new(outside, Vec3A::Z, s, s));
        rays.push(Ray::new(outside, Vec3A::splat(s), 0.0, f32::INFINITY));
    }
    rays.push(Ray::new(c, Vec3A::ZERO, 0.0, f32::INFINITY));
    rays.push(Ray::new(c, Vec3A::Z, 1.0, 0.5)); // empty interval
    rays.push(Ray::new(c, Vec3A::Z, -5.0, -1.0)); // behind
    rays.push(Ray::new(c, Vec3A::Z, f32::NEG_INFINITY, f32::INFINITY));
    rays.push(Ray::new(c, Vec3A::Z, 0.0, 0.0));
    for axis in [
        Vec3A::X,
        Vec3A::Y,
        Vec3A::Z,
        -Vec3A::X,
        -Vec3A::Y,
        -Vec3A::Z,
    ] {
        for _ in 0..20 {
            let o = point_in(b, &mut r);
            rays.push(Ray::new(o, axis, 0.0, f32::INFINITY));
            rays.push(Ray::new(o - axis * 10.0, axis, 0.0, f32::INFINITY));
            rays.push(Ray::new(o, axis * 1e-30, 0.0, f32::INFINITY));
            rays.push(Ray::new(o, axis * 1e30, 0.0, f32::INFINITY));
        }
    }
    for _ in 0..50 {
        let o = point_in(b, &mut r);
        let d = unit_dir(&mut r) * 1e-39; // denormal direction
        rays.push(Ray::new(o, d, 0.0, f32::INFINITY));
    }
    rays
}
