//! User primitives and any-hit filters: every tree layout and backend equals brute force with
//! the same callback, bit for bit (the sphere example, run small; triangles with a filter that
//! rejects half of them; a callback that lies about its distances; triangles and spheres in
//! one tree).

#[allow(unused_imports)]
mod wide_common;

#[path = "../examples/spheres.rs"]
#[allow(dead_code)]
mod spheres;

use sahara_builders::{registry, BuildInput, CostModel};
use sahara_bvh::Bvh;
use sahara_fixtures::soups::mixed_soup;
use sahara_geom::{Aabb, Ray, Triangle, Vec3A};
use sahara_traverse::{custom, Bvh4, Bvh8, Hit, NoStats, WideBvh};
use wide_common::{backends, bits, segment_rays};

fn build(name: &str, input: &BuildInput) -> Bvh {
    registry::by_name(name).unwrap().build(input).unwrap()
}

/// Rays through a soup's bounds: random segments, unbounded rays and rays with `tmin < 0`.
fn rays(bounds: &Aabb, n: usize, seed: u64) -> Vec<Ray> {
    segment_rays(bounds, n, seed, |i, o, e| match i % 3 {
        0 => Ray::new(o, e - o, 0.0, 1.0),
        1 => Ray::new(o, e - o, 0.0, f32::INFINITY),
        _ => Ray::new(o, e - o, -0.5, 0.5),
    })
}

#[test]
fn spheres_example_equals_brute_force() {
    let r = spheres::run(1_500, 1_500);
    assert!(r.hits > r.rays / 10, "{} hits of {}", r.hits, r.rays);
    let (_, refs, _) = &r.builders[1];
    // The split callback was used: spatial splits duplicated references.
    assert!(
        *refs > 1_500,
        "sbvh made no spatial split ({refs} references)"
    );
}

/// A filter that keeps half of the triangles, and half of the area of the others (an alpha
/// mask in barycentric coordinates): a pure function of the hit.
fn alpha(h: &Hit) -> bool {
    h.prim.is_multiple_of(2) || h.u > 0.5
}

fn check_filtered<const W: usize>(wide: &WideBvh<W>, bvh: &Bvh, tris: &[Triangle], rays: &[Ray]) {
    for ray in rays {
        let want = custom::brute_closest_hit_filtered(tris, ray, alpha);
        let want_any = custom::brute_any_hit_filtered(tris, ray, alpha);
        assert_eq!(want_any, want.is_hit());
        let got = custom::closest_hit_filtered(bvh, tris, ray, alpha, &mut NoStats);
        assert_eq!(bits(&got), bits(&want), "binary {ray:?}");
        assert_eq!(
            custom::any_hit_filtered(bvh, tris, ray, alpha, &mut NoStats),
            want_any
        );
        for b in backends() {
            let got = wide.closest_hit_filtered_with(b, ray, alpha, &mut NoStats);
            assert_eq!(bits(&got), bits(&want), "bvh{W} {b} {ray:?}");
            assert_eq!(
                wide.any_hit_filtered_with(b, ray, alpha, &mut NoStats),
                want_any,
                "bvh{W} {b} any {ray:?}"
            );
        }
    }
}

#[test]
fn filtered_triangles_equal_brute_force_with_the_same_filter() {
    let tris = mixed_soup(3_000, 21);
    let bounds = tris.iter().fold(Aabb::EMPTY, |b, t| b.union(&t.bounds()));
    let rays = rays(&bounds, 1_500, 3);
    let input = BuildInput::new(&tris, CostModel::default()).unwrap();
    let mut rejected = 0;
    for name in ["binned", "sbvh"] {
        let bvh = build(name, &input);
        check_filtered(&Bvh8::from_bvh(&bvh, &tris), &bvh, &tris, &rays);
        check_filtered(&Bvh4::from_bvh(&bvh, &tris), &bvh, &tris, &rays);
    }
    // The filter matters: it changes many answers.
    for ray in &rays {
        let plain = sahara_traverse::brute::closest_hit(&tris, ray);
        let filtered = custom::brute_closest_hit_filtered(&tris, ray, alpha);
        rejected += (plain.prim != filtered.prim) as usize;
    }
    assert!(
        rejected > rays.len() / 10,
        "only {rejected} answers changed"
    );
}

/// Triangles as user primitives whose callback adds a constant to the exact distance (its hits
/// lie outside the triangles' boxes): the hit rule clamps them into the boxes' spans, and the
/// result still equals brute force with the same callback, on every layout.
#[test]
fn a_callback_that_lies_still_equals_brute_force() {
    let tris = mixed_soup(2_000, 8);
    let boxes: Vec<Aabb> = tris.iter().map(Triangle::bounds).collect();
    let bounds = boxes.iter().fold(Aabb::EMPTY, |b, x| b.union(x));
    let rays = rays(&bounds, 1_500, 9);
    let lie = |ray: &Ray, p: u32, tmin: f32, tmax: f32| {
        let h = sahara_geom::intersect::intersect_ray_triangle(
            &Ray::new(ray.origin, ray.direction(), ray.tmin, ray.tmax),
            &tris[p as usize],
        )?;
        let t = h.t + 0.25 * (p % 3) as f32;
        (t >= tmin && t <= tmax).then_some((t, p))
    };
    let input = BuildInput::from_boxes(&boxes, CostModel::default()).unwrap();
    let mut clamped = 0;
    for name in ["sweep", "binned"] {
        let bvh = build(name, &input);
        let w8 = Bvh8::from_boxes(&bvh, &boxes);
        let w4 = Bvh4::from_boxes(&bvh, &boxes);
        for ray in &rays {
            let want = custom::brute_closest_hit(&boxes, ray, lie);
            let key = |h: Option<custom::PrimHit<u32>>| h.map(|h| (h.t.to_bits(), h.prim));
            assert_eq!(
                key(custom::closest_hit(&bvh, &boxes, ray, lie, &mut NoStats)),
                key(want)
            );
            for b in backends() {
                assert_eq!(
                    key(w8.closest_hit_custom_with(b, &boxes, ray, lie, &mut NoStats)),
                    key(want),
                    "{name} bvh8 {b} {ray:?}"
                );
                assert_eq!(
                    key(w4.closest_hit_custom_with(b, &boxes, ray, lie, &mut NoStats)),
                    key(want)
                );
                assert_eq!(
                    w8.any_hit_custom_with(b, &boxes, ray, lie, &mut NoStats),
                    want.is_some()
                );
            }
            if let Some(h) = want {
                let span = custom::primitive_span(ray, &boxes[h.prim as usize]);
                clamped += (h.t == span.1 && h.prim % 3 != 0) as usize;
            }
        }
    }
    assert!(clamped > 0, "no distance was clamped");
}

#[test]
fn the_hit_rule() {
    let ray = Ray::new(Vec3A::ZERO, Vec3A::Z, 1.0, 10.0);
    let b = Aabb::new(Vec3A::new(-1.0, -1.0, 4.0), Vec3A::new(1.0, 1.0, 6.0));
    let span = custom::primitive_span(&ray, &b);
    assert_eq!(custom::accept_primitive_hit(&ray, span, 5.0), Some(5.0));
    // Clamped into the box span.
    assert_eq!(custom::accept_primitive_hit(&ray, span, 3.0), Some(span.0));
    assert_eq!(custom::accept_primitive_hit(&ray, span, 7.0), Some(span.1));
    // Outside the ray's interval, NaN, infinite: misses.
    for t in [0.5, 11.0, f32::NAN, f32::INFINITY] {
        assert_eq!(custom::accept_primitive_hit(&ray, span, t), None);
    }
    // A box beyond tmax: nothing is accepted.
    let far = Aabb::new(Vec3A::new(-1.0, -1.0, 20.0), Vec3A::ONE * 21.0);
    let span = custom::primitive_span(&ray, &far);
    assert_eq!(custom::accept_primitive_hit(&ray, span, 9.0), None);
    // The callback's tmax: the best hit unless the box ends before it.
    assert_eq!(custom::callback_tmax(&ray, 6.0, 5.0), 5.0);
    assert_eq!(custom::callback_tmax(&ray, 4.0, 5.0), 10.0);
    assert_eq!(custom::callback_tmax(&ray, 6.0, f32::INFINITY), 10.0);
}

#[test]
fn empty_trees_and_invalid_rays_miss() {
    let bvh = Bvh::empty();
    let boxes: [Aabb; 0] = [];
    let never = |_: &Ray, _: u32, _: f32, _: f32| -> Option<(f32, ())> { unreachable!() };
    let ray = Ray::new(Vec3A::ZERO, Vec3A::Z, 0.0, 1.0);
    assert!(custom::closest_hit(&bvh, &boxes, &ray, never, &mut NoStats).is_none());
    let w = Bvh8::from_boxes(&bvh, &boxes);
    assert!(w
        .closest_hit_custom(&boxes, &ray, never, &mut NoStats)
        .is_none());
    assert!(!w.any_hit_custom(&boxes, &ray, never, &mut NoStats));
    let s = spheres::spheres(10, 3);
    let boxes: Vec<Aabb> = s.iter().map(|s| s.bounds()).collect();
    let input = BuildInput::from_boxes(&boxes, CostModel::default()).unwrap();
    let bvh = build("binned", &input);
    let w = Bvh8::from_boxes(&bvh, &boxes);
    for bad in [
        Ray::new(Vec3A::ZERO, Vec3A::ZERO, 0.0, 1.0),
        Ray::new(Vec3A::splat(f32::NAN), Vec3A::Z, 0.0, 1.0),
        Ray::new(Vec3A::ZERO, Vec3A::Z, 2.0, 1.0),
    ] {
        assert!(custom::closest_hit(&bvh, &boxes, &bad, never, &mut NoStats).is_none());
        assert!(!custom::any_hit(&bvh, &boxes, &bad, never, &mut NoStats));
        assert!(w
            .closest_hit_custom(&boxes, &bad, never, &mut NoStats)
            .is_none());
        // A tree over boxes holds no triangles: the filtered triangle queries miss.
        assert!(!w
            .closest_hit_filtered(&ray, |_| true, &mut NoStats)
            .is_hit());
    }
}

/// Triangles and spheres in one tree ([`WideBvh::from_mixed`]): the packet test with a filter
/// on the triangles, the sphere callback on the others, equal to a loop over all primitives
/// in index order on every layout and backend.
#[test]
fn triangles_and_spheres_in_one_tree_equal_brute_force() {
    use sahara_geom::intersect::intersect_triangle;
    // Primitive p: a sphere when p % 3 == 1, else the next triangle.
    let balls = spheres::spheres(600, 4);
    let tris: Vec<Triangle> = mixed_soup(1_200, 22)
        .iter()
        .map(|t| Triangle::new(t.v[0] * 10.0, t.v[1] * 10.0, t.v[2] * 10.0))
        .collect();
    let (mut boxes, mut triangle_of, mut sphere_of) = (vec![], vec![], vec![]);
    let (mut t, mut s) = (0u32, 0usize);
    while (t as usize) < tris.len() || s < balls.len() {
        let p = boxes.len();
        if (p % 3 == 1 && s < balls.len()) || t as usize == tris.len() {
            boxes.push(balls[s].bounds());
            triangle_of.push(u32::MAX);
            sphere_of.push(s);
            s += 1;
        } else {
            boxes.push(tris[t as usize].bounds());
            triangle_of.push(t);
            sphere_of.push(usize::MAX);
            t += 1;
        }
    }
    let prims = custom::MixedPrims {
        boxes: &boxes,
        triangles: &tris,
        triangle_of: &triangle_of,
    };
    let sphere = |ray: &Ray, p: u32, tmin: f32, tmax: f32| {
        let (t, n) = balls[sphere_of[p as usize]].intersect(ray, tmin, tmax)?;
        Some((
            t,
            Hit {
                t,
                prim: p,
                u: n.x,
                v: n.y,
            },
        ))
    };
    // Keeps even primitives and the u > 0.5 half of the odd triangles.
    let accept = |h: &Hit| alpha(h).then_some(*h);
    let brute = |ray: &Ray| {
        let mut best: Option<custom::PrimHit<Hit>> = None;
        if !ray.is_valid() {
            return best;
        }
        let w = ray.watertight();
        for p in 0..boxes.len() as u32 {
            let bt = best.as_ref().map_or(f32::INFINITY, |b| b.t);
            let hit = match prims.triangle(p) {
                Some(i) => intersect_triangle(&w, &tris[i as usize], ray.tmin, ray.tmax)
                    .map(|h| Hit {
                        t: h.t,
                        prim: p,
                        u: h.u,
                        v: h.v,
                    })
                    .filter(|h| h.t < bt)
                    .and_then(|h| accept(&h)),
                None => sphere(ray, p, ray.tmin, ray.tmax).and_then(|(t, d)| {
                    let span = custom::primitive_span(ray, &boxes[p as usize]);
                    let t = custom::accept_primitive_hit(ray, span, t)?;
                    (t < bt).then_some(Hit { t, ..d })
                }),
            };
            if let Some(h) = hit {
                best = Some(custom::PrimHit {
                    t: h.t,
                    prim: p,
                    data: h,
                });
            }
        }
        best
    };
    let key = |h: &Option<custom::PrimHit<Hit>>| h.map(|h| (h.t.to_bits(), h.prim, bits(&h.data)));
    let bounds = boxes.iter().fold(Aabb::EMPTY, |b, x| b.union(x));
    let rays = rays(&bounds, 1_500, 9);
    let input = BuildInput::from_boxes(&boxes, CostModel::default()).unwrap();
    let (mut tri_hits, mut sphere_hits) = (0, 0);
    for name in ["binned", "sweep"] {
        let bvh = build(name, &input);
        let (w8, w4) = (Bvh8::from_mixed(&bvh, prims), Bvh4::from_mixed(&bvh, prims));
        for ray in &rays {
            let want = brute(ray);
            match want.map(|h| prims.triangle(h.prim)) {
                Some(Some(_)) => tri_hits += 1,
                Some(None) => sphere_hits += 1,
                None => {}
            }
            for b in backends() {
                let got = w8.closest_hit_mixed_with(b, prims, ray, accept, sphere, &mut NoStats);
                assert_eq!(key(&got), key(&want), "{name} bvh8 {b} {ray:?}");
                let got = w4.closest_hit_mixed_with(b, prims, ray, accept, sphere, &mut NoStats);
                assert_eq!(key(&got), key(&want), "{name} bvh4 {b} {ray:?}");
                let any = w8.any_hit_mixed_with(b, prims, ray, accept, sphere, &mut NoStats);
                assert_eq!(any, want.is_some(), "{name} bvh8 {b} any {ray:?}");
            }
        }
    }
    assert!(
        tri_hits > 100 && sphere_hits > 100,
        "{tri_hits} triangle and {sphere_hits} sphere hits"
    );
}
