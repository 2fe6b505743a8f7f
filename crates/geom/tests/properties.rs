//! Property tests of clipping, splitting and the watertight triangle test.

use approx::assert_relative_eq;
use proptest::prelude::*;
use sahara_geom::{
    clip::{clip_triangle, clipped_area, split_triangle_bounds},
    intersect::{
        cull_distance, intersect_aabb, intersect_ray_triangle, lower_distance, WatertightRay,
    },
    Aabb, Ray, Triangle, Vec3A,
};

fn v3() -> impl Strategy<Value = Vec3A> {
    (-10.0f32..10.0, -10.0f32..10.0, -10.0f32..10.0).prop_map(|(x, y, z)| Vec3A::new(x, y, z))
}

fn tri() -> impl Strategy<Value = Triangle> {
    (v3(), v3(), v3()).prop_map(|(a, b, c)| Triangle::new(a, b, c))
}

fn aabb() -> impl Strategy<Value = Aabb> {
    (v3(), v3()).prop_map(|(a, b)| Aabb::new(a.min(b), a.max(b)))
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(2000))]

    #[test]
    fn clipped_area_never_exceeds_the_triangle(t in tri(), b in aabb()) {
        let a = clipped_area(&t, &b);
        prop_assert!(a >= 0.0);
        prop_assert!(a <= t.area() * (1.0 + 1e-5) + 1e-9, "{} > {}", a, t.area());
        // The clipped polygon lies in the box (up to rounding of the interpolated points).
        let pb = clip_triangle(&t, &b).bounds();
        if !pb.is_empty() {
            let pad = 1e-4 * (1.0 + b.extent().max_element());
            prop_assert!(Aabb::new(b.min - pad, b.max + pad).contains_aabb(&pb));
        }
    }

    #[test]
    fn clipping_to_an_enclosing_box_keeps_the_whole_triangle(t in tri(), grow in 0.0f32..5.0) {
        let b = t.bounds();
        let b = Aabb::new(b.min - grow, b.max + grow);
        let p = clip_triangle(&t, &b);
        prop_assert_eq!(p.vertices().len(), 3);
        assert_relative_eq!(p.area(), t.area(), max_relative = 1e-12);
        prop_assert_eq!(p.bounds(), t.bounds());
    }

    #[test]
    fn split_halves_cover_the_original_bounds(t in tri(), axis in 0usize..3, f in 0.0f32..1.0) {
        let b = t.bounds();
        let pos = b.min[axis] + f * (b.max[axis] - b.min[axis]);
        let (l, r) = split_triangle_bounds(&t, axis, pos, &b);
        // Each half stays inside the original bounds and on its side of the plane...
        prop_assert!(b.contains_aabb(&l) && b.contains_aabb(&r));
        if !l.is_empty() { prop_assert!(l.max[axis] <= pos); }
        if !r.is_empty() { prop_assert!(r.min[axis] >= pos); }
        // ... and together they cover it.
        prop_assert_eq!(l.union(&r), b);
    }

    #[test]
    fn split_halves_contain_the_clipped_parts(t in tri(), axis in 0usize..3, f in 0.05f32..0.95) {
        let b = t.bounds();
        let pos = b.min[axis] + f * (b.max[axis] - b.min[axis]);
        let (l, r) = split_triangle_bounds(&t, axis, pos, &b);
        let mut below = b;
        below.max[axis] = pos;
        let mut above = b;
        above.min[axis] = pos;
        let pad = 1e-4 * (1.0 + b.extent().max_element());
        for (half, part) in [(l, below), (r, above)] {
            let clipped = clip_triangle(&t, &part).bounds();
            if !clipped.is_empty() {
                prop_assert!(Aabb::new(half.min - pad, half.max + pad).contains_aabb(&clipped));
            }
        }
    }

    /// The invariant BVH traversal rests on: every box containing a triangle passes the slab
    /// test over `[lower_distance(tmin), cull_distance(t)]` for every hit `t` the triangle
    /// test reports, whatever the triangle (including slivers, flat and near-degenerate ones,
    /// made by snapping coordinates to one plane or line) and the ray.
    #[test]
    fn boxes_around_a_hit_triangle_are_never_culled(
        t in tri(),
        flatten in 0usize..5,
        o in v3(),
        target in (0.0f32..1.0, 0.0f32..1.0),
        tmin in prop_oneof![Just(0.0f32), -1.0f32..1.0],
        end_on_hit in any::<bool>(),
        grow in (0.0f32..1.0, 0.0f32..1.0, 0.0f32..1.0),
    ) {
        let mut t = t;
        let v0 = t.v[0];
        match flatten {
            // Axis-aligned triangle: a flat box.
            1 => for v in &mut t.v { v.x = v0.x; },
            // Two coordinates shared: a segment along z (zero area).
            2 => for v in &mut t.v { v.x = v0.x; v.y = v0.y; },
            // A sliver: the third vertex next to the first edge's midpoint.
            3 => t.v[2] = (t.v[0] + t.v[1]) * 0.5 + Vec3A::splat(1e-6),
            _ => {}
        }
        let (a, b) = target;
        let p = t.v[0] + (t.v[1] - t.v[0]) * a * (1.0 - b) + (t.v[2] - t.v[0]) * b * (1.0 - a);
        let d = p - o;
        let tmax = if end_on_hit { 1.0 } else { f32::INFINITY };
        let ray = Ray::new(o, d, tmin, tmax);
        if let Some(h) = intersect_ray_triangle(&ray, &t) {
            prop_assert!(h.t.is_finite());
            let tb = t.bounds();
            let g = Vec3A::new(grow.0, grow.1, grow.2);
            for bx in [tb, Aabb::new(tb.min - g, tb.max), Aabb::new(tb.min, tb.max + g)] {
                prop_assert!(
                    intersect_aabb(o, ray.inv_direction(), lower_distance(tmin), cull_distance(h.t), &bx)
                        .is_some(),
                    "hit at t = {} culled by {:?}", h.t, bx
                );
            }
        }
    }

    /// The far distances of the slab test are conservative: where the ray's line (its `f32`
    /// origin and direction, in `f64`) leaves the box at `t_exit`, the test admits the interval
    /// that starts at `t_exit` rounded down. Only the `1 ± 2γ(3)` scales folded into the far
    /// factors ([`sahara_geom::intersect::far_factors`]) make up for the four roundings.
    #[test]
    fn slab_far_distances_are_never_rounded_below_the_exit(
        b in aabb(),
        o in v3(),
        at in (0.0f32..=1.0, 0.0f32..=1.0, 0.0f32..=1.0),
        scale in prop_oneof![Just(1.0f32), 1e-3f32..1e3, -1e3f32..-1e-3],
    ) {
        // Aimed at a point of the box (so the line crosses it, up to rounding), or away from
        // it: then the box lies behind the origin, `t_exit < 0`, and the test runs with
        // `tmin < 0`, where negative far distances must be rounded up.
        let p = (b.min + (b.max - b.min) * Vec3A::new(at.0, at.1, at.2)).clamp(b.min, b.max);
        let d = (p - o) * scale;
        let (o64, d64) = (o.to_array().map(f64::from), d.to_array().map(f64::from));
        let (mut t_enter, mut t_exit) = (f64::NEG_INFINITY, f64::INFINITY);
        for a in 0..3 {
            if d64[a] == 0.0 {
                prop_assume!(o64[a] > b.min[a] as f64 && o64[a] < b.max[a] as f64);
                continue;
            }
            let t0 = (b.min[a] as f64 - o64[a]) / d64[a];
            let t1 = (b.max[a] as f64 - o64[a]) / d64[a];
            t_enter = t_enter.max(t0.min(t1));
            t_exit = t_exit.min(t0.max(t1));
        }
        prop_assume!(t_exit >= t_enter && t_exit.abs() < 1e30);
        let mut tmin = t_exit as f32;
        if tmin as f64 > t_exit {
            // One step down (towards -inf).
            tmin = match tmin {
                x if x > 0.0 => f32::from_bits(x.to_bits() - 1),
                x if x < 0.0 => f32::from_bits(x.to_bits() + 1),
                _ => -f32::from_bits(1),
            };
        }
        let ray = Ray::new(o, d, tmin, f32::INFINITY);
        prop_assert!(
            intersect_aabb(o, ray.inv_direction(), tmin, f32::INFINITY, &b).is_some(),
            "{ray:?} leaves {b:?} at {t_exit} but is rejected from {tmin}"
        );
    }

    /// The division-free watertight constants follow their definition: `kz` is the first axis
    /// of largest magnitude, `(kx, ky)` the next two (swapped for a negative `direction[kz]`),
    /// and the shear uses the reciprocal of `direction[kz]`; `new` and `with_inverse` agree.
    #[test]
    fn watertight_constants_follow_the_definition(
        d in (-3i32..=3, -3i32..=3, -3i32..=3, 0.1f32..10.0),
    ) {
        let dir = Vec3A::new(d.0 as f32, d.1 as f32, d.2 as f32 * d.3);
        let w = WatertightRay::new(Vec3A::ZERO, dir);
        let a = dir.abs();
        let kz = if a.x >= a.y && a.x >= a.z { 0 } else if a.y >= a.z { 1 } else { 2 };
        let (mut kx, mut ky) = ((kz + 1) % 3, (kz + 2) % 3);
        if dir[kz] < 0.0 {
            std::mem::swap(&mut kx, &mut ky);
        }
        prop_assert_eq!(w.axes(), (kx, ky, kz));
        let inv = dir.recip();
        let shear = Vec3A::new(dir[kx] * inv[kz], dir[ky] * inv[kz], inv[kz]);
        prop_assert_eq!(w.shear().to_array().map(f32::to_bits), shear.to_array().map(f32::to_bits));
        let r = Ray::new(Vec3A::ONE, dir, 0.0, 1.0).watertight();
        prop_assert_eq!(r.axes(), (kx, ky, kz));
        prop_assert_eq!(r.shear().to_array().map(f32::to_bits), shear.to_array().map(f32::to_bits));
    }
}

/// A closed icosphere with shared vertices (subdivided `levels` times).
fn icosphere(levels: u32) -> Vec<Triangle> {
    let t = (1.0 + 5f32.sqrt()) / 2.0;
    let mut v: Vec<Vec3A> = [
        (-1.0, t, 0.0),
        (1.0, t, 0.0),
        (-1.0, -t, 0.0),
        (1.0, -t, 0.0),
        (0.0, -1.0, t),
        (0.0, 1.0, t),
        (0.0, -1.0, -t),
        (0.0, 1.0, -t),
        (t, 0.0, -1.0),
        (t, 0.0, 1.0),
        (-t, 0.0, -1.0),
        (-t, 0.0, 1.0),
    ]
    .iter()
    .map(|&(x, y, z)| Vec3A::new(x, y, z).normalize())
    .collect();
    let mut f: Vec<[usize; 3]> = vec![
        [0, 11, 5],
        [0, 5, 1],
        [0, 1, 7],
        [0, 7, 10],
        [0, 10, 11],
        [1, 5, 9],
        [5, 11, 4],
        [11, 10, 2],
        [10, 7, 6],
        [7, 1, 8],
        [3, 9, 4],
        [3, 4, 2],
        [3, 2, 6],
        [3, 6, 8],
        [3, 8, 9],
        [4, 9, 5],
        [2, 4, 11],
        [6, 2, 10],
        [8, 6, 7],
        [9, 8, 1],
    ];
    for _ in 0..levels {
        let mut mid = std::collections::HashMap::new();
        let mut m = |a: usize, b: usize, v: &mut Vec<Vec3A>| {
            *mid.entry((a.min(b), a.max(b))).or_insert_with(|| {
                v.push(((v[a] + v[b]) * 0.5).normalize());
                v.len() - 1
            })
        };
        f = f
            .iter()
            .flat_map(|&[a, b, c]| {
                let (ab, bc, ca) = (m(a, b, &mut v), m(b, c, &mut v), m(c, a, &mut v));
                [[a, ab, ca], [b, bc, ab], [c, ca, bc], [ab, bc, ca]]
            })
            .collect();
    }
    f.iter()
        .map(|&[a, b, c]| Triangle::new(v[a], v[b], v[c]))
        .collect()
}

/// Rays from inside a closed sphere aimed exactly at its vertices and at points on its
/// edges: the watertight test never lets one through. Through a shared edge or vertex
/// several triangles may report the hit (at the same distance); closest-hit kernels keep
/// exactly one of them, the lowest index.
#[test]
fn rays_through_shared_edges_and_vertices_never_miss() {
    let tris = icosphere(3);
    let origins = [
        Vec3A::ZERO,
        Vec3A::new(0.1, -0.2, 0.05),
        Vec3A::new(-0.3, 0.3, 0.2),
    ];
    let mut targets = Vec::new();
    for t in &tris {
        for i in 0..3 {
            let (a, b) = (t.v[i], t.v[(i + 1) % 3]);
            targets.push(a);
            for k in 1..4 {
                targets.push(a + (b - a) * (k as f32 * 0.25));
            }
        }
    }
    let mut shared = 0usize;
    for o in origins {
        for &p in &targets {
            let ray = Ray::new(o, p - o, 0.0, f32::INFINITY);
            let hits: Vec<(usize, f32)> = tris
                .iter()
                .enumerate()
                .filter_map(|(i, t)| intersect_ray_triangle(&ray, t).map(|h| (i, h.t)))
                .collect();
            assert!(!hits.is_empty(), "ray from {o:?} to {p:?} slipped through");
            if hits.len() > 1 {
                shared += 1;
            }
            // All reported hits are at (numerically) the same point of the surface.
            let t0 = hits[0].1;
            for &(_, t) in &hits {
                assert!((t - t0).abs() <= 1e-4 * t0.abs().max(1.0));
            }
        }
    }
    assert!(shared > 0, "the test should exercise shared edges");
}
