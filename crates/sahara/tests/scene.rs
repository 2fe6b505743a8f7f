//! Scenes of many geometries: every query equals the brute-force twin bit for bit (ids,
//! distances, barycentrics, normals) with masks, filters, user primitives and empty
//! geometries; bad input is a typed error; foreign ids are refused.

use sahara::sahara_builders::split::spatial::SplitPrimitive;
use sahara::{
    Aabb, Accel, Error, GeometryId, Intersection, Quality, Ray, Scene, SceneBuilder, SceneError,
    SceneHit, Triangle, Vec3A, ALL_MASK,
};
use sahara_fixtures::{
    rays::segments_in,
    soups::{box_soup, mixed_soup},
};
use sahara_geom::rng::Pcg32;
use std::panic::AssertUnwindSafe;

mod common;

use common::{scene_bits as bits, segments_and_rays_from_above};

/// Three meshes (one shifted copy of part of another, so hits tie across geometries), two
/// empty geometries, masks 1, 2, 4, 1|2.
fn add_meshes(b: &mut SceneBuilder) -> Vec<GeometryId> {
    let a = mixed_soup(700, 3);
    let c = mixed_soup(500, 8);
    let mut ids = vec![b.add_triangles(&[])];
    ids.push(b.add_triangles(&a));
    ids.push(b.add_triangles(&c));
    // Exact duplicates of `a`'s first triangles: equal distances, the lower geometry wins.
    ids.push(b.add_triangles(&a[..60]));
    let positions: Vec<[f32; 3]> = c[..200]
        .iter()
        .flat_map(|t| t.v.map(|p| p.to_array()))
        .collect();
    let indices: Vec<[u32; 3]> = (0..200u32).map(|i| [3 * i + 2, 3 * i + 1, 3 * i]).collect();
    ids.push(b.add_indexed(&positions, &indices).unwrap());
    ids.push(b.add_triangles(&[]));
    for (i, &id) in ids.iter().enumerate() {
        b.set_mask(id, [1, 2, 4, 1 | 2, 2 | 4, 4][i]).unwrap();
    }
    ids
}

fn rays(n: usize, seed: u64) -> Vec<Ray> {
    let mut rays = segments_and_rays_from_above(n, seed, 1.2);
    // Invalid rays miss.
    rays.push(Ray::new(Vec3A::splat(f32::NAN), Vec3A::Z, 0.0, 1.0));
    rays.push(Ray::new(Vec3A::ZERO, Vec3A::ZERO, 0.0, 1.0));
    rays
}

const MASKS: [u32; 6] = [ALL_MASK, 1, 2, 4, 0, 8];

/// Checks every query of `scene` against the brute-force twin for every mask, with and without
/// `filter`; returns (hits without filter, answers the filter changed).
fn check(
    scene: &Scene,
    rays: &[Ray],
    filter: &(dyn Fn(&SceneHit) -> bool + Sync),
    what: &str,
) -> (usize, usize) {
    let (mut hits, mut changed) = (0, 0);
    for mask in MASKS {
        let closest = scene.closest_hits(rays, mask);
        let any = scene.any_hits(rays, mask);
        let closest_f = scene.closest_hits_filtered(rays, mask, filter);
        let any_f = scene.any_hits_filtered(rays, mask, filter);
        for (i, ray) in rays.iter().enumerate() {
            let want = scene.brute_closest_hit(ray, mask, None);
            let got = scene.closest_hit(ray, mask);
            assert_eq!(bits(got), bits(want), "{what} mask {mask:#x} ray {i}");
            assert_eq!(
                bits(closest[i]),
                bits(want),
                "{what} batch mask {mask:#x} ray {i}"
            );
            assert_eq!(
                scene.any_hit(ray, mask),
                want.is_some(),
                "{what} any mask {mask:#x} ray {i}"
            );
            assert_eq!(
                any[i],
                want.is_some(),
                "{what} batch any mask {mask:#x} ray {i}"
            );
            let want_f = scene.brute_closest_hit(ray, mask, Some(&mut |h: &SceneHit| filter(h)));
            let got_f = scene.closest_hit_filtered(ray, mask, filter);
            assert_eq!(
                bits(got_f),
                bits(want_f),
                "{what} filtered mask {mask:#x} ray {i}"
            );
            assert_eq!(
                bits(closest_f[i]),
                bits(want_f),
                "{what} batch filtered {mask:#x} ray {i}"
            );
            let want_any_f = scene.brute_any_hit(ray, mask, Some(&mut |h: &SceneHit| filter(h)));
            assert_eq!(
                want_any_f,
                want_f.is_some(),
                "{what} brute twins disagree, ray {i}"
            );
            assert_eq!(
                scene.any_hit_filtered(ray, mask, filter),
                want_any_f,
                "{what} any filtered {mask:#x} ray {i}"
            );
            assert_eq!(
                any_f[i], want_any_f,
                "{what} batch any filtered {mask:#x} ray {i}"
            );
            if let Some(h) = got_f {
                assert!(filter(&h), "{what}: a rejected hit was returned");
            }
            if let Some(h) = got {
                assert_ne!(
                    scene.mask(h.geometry).unwrap() & mask,
                    0,
                    "{what}: a masked geometry was hit"
                );
            }
            if mask & 7 == 0 {
                assert!(
                    got.is_none() && got_f.is_none(),
                    "{what}: mask {mask:#x} excludes everything"
                );
            }
            hits += got.is_some() as usize;
            changed += (bits(got) != bits(got_f)) as usize;
        }
    }
    (hits, changed)
}

/// Rejects every other triangle (by global parity of geometry and primitive).
fn every_other(h: &SceneHit) -> bool {
    (h.geometry.index() + h.primitive).is_multiple_of(2)
}

#[test]
fn triangle_scenes_equal_brute_force_with_masks_and_filters() {
    let rays = rays(700, 11);
    for q in Quality::ALL {
        let mut b = SceneBuilder::new();
        add_meshes(&mut b);
        let scene = b.build(q).unwrap();
        assert_eq!(scene.len(), 700 + 500 + 60 + 200);
        let (hits, changed) = check(&scene, &rays, &every_other, &format!("{q}"));
        // Masks and the filter matter, and the rays hit.
        assert!(hits > rays.len(), "{q}: {hits} hits");
        assert!(
            changed > rays.len() / 4,
            "{q}: the filter changed {changed} answers"
        );
    }
}

#[test]
fn the_fast_path_equals_one_accel_over_all_triangles() {
    let mut b = SceneBuilder::new();
    let ids = add_meshes(&mut b);
    let mut scene = b.build(Quality::Medium).unwrap();
    for &id in &ids {
        scene.set_mask(id, ALL_MASK).unwrap();
    }
    let all: Vec<Triangle> = ids
        .iter()
        .flat_map(|&id| scene.triangles(id).unwrap().to_vec())
        .collect();
    let accel = Accel::build(&all, Quality::Medium).unwrap();
    let firsts: Vec<u32> = ids
        .iter()
        .scan(0, |n, &id| {
            let f = *n;
            *n += scene.geometry_len(id).unwrap() as u32;
            Some(f)
        })
        .collect();
    for ray in rays(700, 12) {
        let got = scene.closest_hit(&ray, 1);
        let want = accel.closest_hit(&ray);
        assert_eq!(
            got.map(|h| firsts[h.geometry.index() as usize] + h.primitive),
            want.map(|h| h.prim)
        );
        assert_eq!(got.map(|h| (h.t, h.u, h.v)), want.map(|h| (h.t, h.u, h.v)));
        if let Some(h) = got {
            assert_eq!(h.normal, all[want.unwrap().prim as usize].cross());
        }
    }
}

#[test]
fn masks_set_after_the_build_equal_masks_set_before() {
    let rays = rays(300, 13);
    let mut before = SceneBuilder::new();
    add_meshes(&mut before);
    let before = before.build(Quality::Fast).unwrap();
    let mut after = SceneBuilder::new();
    let ids = add_meshes(&mut after);
    for &id in &ids {
        after.set_mask(id, ALL_MASK).unwrap();
    }
    let mut after = after.build(Quality::Fast).unwrap();
    for (&id, b) in ids.iter().zip(before.geometries()) {
        after.set_mask(id, before.mask(b).unwrap()).unwrap();
    }
    for mask in MASKS {
        for ray in &rays {
            assert_eq!(
                bits(after.closest_hit(ray, mask)),
                bits(before.closest_hit(ray, mask))
            );
        }
    }
}

/// A sphere: centre and radius.
#[derive(Clone, Copy)]
struct Sphere {
    c: Vec3A,
    r: f32,
}

impl Sphere {
    fn bounds(&self) -> Aabb {
        Aabb::new(self.c - self.r, self.c + self.r)
    }

    /// The entry point, or the exit point when the entry lies before `tmin`.
    fn intersect(&self, ray: &Ray, tmin: f32, tmax: f32) -> Option<Intersection> {
        let oc = ray.origin - self.c;
        let a = ray.direction().dot(ray.direction());
        let b = oc.dot(ray.direction());
        let k = oc.dot(oc) - self.r * self.r;
        let disc = b * b - a * k;
        if disc.is_nan() || disc < 0.0 {
            return None;
        }
        let s = disc.sqrt();
        let near = (-b - s) / a;
        let t = if near >= tmin { near } else { (-b + s) / a };
        let n = ray.at(t) - self.c;
        (t >= tmin && t <= tmax).then_some(Intersection {
            t,
            u: n.x,
            v: n.y,
            normal: n,
        })
    }
}

/// Clips the sphere's box by the plane and, for a cap, by the cap's radius (rounded up).
struct SphereSplitter(Vec<Sphere>);

impl SplitPrimitive for SphereSplitter {
    fn split(&self, prim: u32, axis: usize, pos: f32, bounds: &Aabb) -> (Aabb, Aabb) {
        let s = self.0[prim as usize];
        let part = |below: bool| {
            let mut b = s.bounds();
            let d = pos - s.c[axis];
            if below {
                b.max[axis] = b.max[axis].min(pos);
            } else {
                b.min[axis] = b.min[axis].max(pos);
            }
            if (below && d < 0.0) || (!below && d > 0.0) {
                let rho = ((s.r * s.r - d * d).max(0.0)).sqrt() * (1.0 + 1e-5);
                for a in (0..3).filter(|&a| a != axis) {
                    b.min[a] = b.min[a].max(s.c[a] - rho);
                    b.max[a] = b.max[a].min(s.c[a] + rho);
                }
            }
            let b = b.intersection(bounds);
            if b.is_empty() {
                Aabb::EMPTY
            } else {
                b
            }
        };
        (part(true), part(false))
    }
}

fn spheres(n: usize, seed: u64) -> Vec<Sphere> {
    let mut rng = Pcg32::new(seed, 1);
    (0..n)
        .map(|_| Sphere {
            c: Vec3A::new(
                rng.range_f32(-1.0, 1.0),
                rng.range_f32(-1.0, 1.0),
                rng.range_f32(-1.0, 1.0),
            ),
            r: rng.range_f32(0.01, 0.15),
        })
        .collect()
}

fn add_spheres(b: &mut SceneBuilder, spheres: Vec<Sphere>, split: bool) -> GeometryId {
    let boxes: Vec<Aabb> = spheres.iter().map(Sphere::bounds).collect();
    let s = spheres.clone();
    let intersect =
        move |ray: &Ray, p: u32, tmin: f32, tmax: f32| s[p as usize].intersect(ray, tmin, tmax);
    if split {
        b.add_primitives_with_splitter(&boxes, intersect, SphereSplitter(spheres))
    } else {
        b.add_primitives(&boxes, intersect)
    }
}

#[test]
fn spheres_mixed_with_triangles_equal_brute_force() {
    let rays = rays(600, 14);
    for q in Quality::ALL {
        let mut b = SceneBuilder::new();
        let meshes = add_meshes(&mut b);
        let split = add_spheres(&mut b, spheres(300, 1), true);
        let unsplit = add_spheres(&mut b, spheres(200, 2), false);
        let empty = b.add_primitives(&[], |_: &Ray, _, _, _| -> Option<Intersection> {
            unreachable!()
        });
        b.set_mask(split, 1).unwrap();
        b.set_mask(unsplit, 4).unwrap();
        let scene = b.build(q).unwrap();
        assert_eq!(scene.geometry_len(empty), Some(0));
        assert_eq!(scene.triangles(split), None);
        assert!(scene.triangles(meshes[1]).is_some());
        let (hits, changed) = check(&scene, &rays, &every_other, &format!("spheres {q}"));
        assert!(hits > rays.len(), "{q}: {hits} hits");
        assert!(
            changed > rays.len() / 4,
            "{q}: the filter changed {changed} answers"
        );
        // Spheres are hit, and at their distance.
        let sphere_hits = rays
            .iter()
            .filter_map(|r| scene.closest_hit(r, 1 | 4))
            .filter(|h| h.geometry == split || h.geometry == unsplit)
            .count();
        assert!(
            sphere_hits > rays.len() / 10,
            "{q}: {sphere_hits} sphere hits"
        );
    }
}

#[test]
fn a_scene_of_spheres_only() {
    let rays = rays(400, 15);
    for q in [Quality::Fast, Quality::High] {
        let mut b = SceneBuilder::new();
        let id = add_spheres(&mut b, spheres(400, 3), q == Quality::High);
        b.set_mask(id, 2 | 4).unwrap();
        let scene = b.build(q).unwrap();
        let keep = |h: &SceneHit| !h.primitive.is_multiple_of(3);
        let (hits, _) = check(&scene, &rays, &keep, "spheres only");
        assert!(hits > 0);
    }
}

#[test]
fn bad_input_is_a_typed_error() {
    let good = Triangle::new(Vec3A::ZERO, Vec3A::X, Vec3A::Y);
    let mut bad = good;
    bad.v[2].y = f32::INFINITY;
    let mut b = SceneBuilder::new();
    b.add_triangles(&[good]);
    b.add_primitives(&[Aabb::new(Vec3A::ZERO, Vec3A::ONE)], |_: &Ray, _, _, _| {
        None
    });
    b.add_triangles(&[good, good, bad]);
    assert!(matches!(
        b.build(Quality::Fast),
        Err(Error::Scene(SceneError::NonFinite {
            geometry: 2,
            primitive: 2
        }))
    ));
    for broken in [
        Aabb::new(Vec3A::ZERO, Vec3A::new(1.0, f32::NAN, 1.0)),
        Aabb::new(Vec3A::ONE, Vec3A::ZERO),
        Aabb::new(Vec3A::splat(f32::NEG_INFINITY), Vec3A::ZERO),
    ] {
        let mut b = SceneBuilder::new();
        b.add_triangles(&[good]);
        b.add_primitives(
            &[Aabb::new(Vec3A::ZERO, Vec3A::ONE), broken],
            |_: &Ray, _, _, _| None,
        );
        assert!(matches!(
            b.build(Quality::High),
            Err(Error::Scene(SceneError::InvalidBox {
                geometry: 1,
                primitive: 1
            }))
        ));
    }
    let mut b = SceneBuilder::new();
    assert!(matches!(
        b.add_indexed(&[[0.0f32; 3]; 2], &[[0, 1, 2]]),
        Err(Error::IndexOutOfRange {
            triangle: 0,
            index: 2,
            vertices: 2
        })
    ));
    // Nothing was added.
    assert_eq!(b.add_triangles(&[]).index(), 0);
}

#[test]
fn ids_of_another_scene_are_refused() {
    let tri = Triangle::new(Vec3A::ZERO, Vec3A::X, Vec3A::Y);
    let mut b1 = SceneBuilder::new();
    let own = b1.add_triangles(&[tri]);
    let mut b2 = SceneBuilder::new();
    b2.add_triangles(&[tri]);
    let foreign = b2.add_triangles(&[tri]);
    assert!(
        matches!(b1.set_mask(foreign, 0), Err(Error::Scene(SceneError::UnknownGeometry(id))) if id == foreign)
    );
    let mut scene = b1.build(Quality::Fast).unwrap();
    let other = b2.build(Quality::Fast).unwrap();
    // `own` has index 0, which `other` also has: still refused.
    assert_eq!(other.mask(own), None);
    assert_eq!(scene.mask(foreign), None);
    assert_eq!(scene.geometry_len(foreign), None);
    assert_eq!(scene.triangles(foreign), None);
    assert!(matches!(
        scene.set_mask(foreign, 0),
        Err(Error::Scene(SceneError::UnknownGeometry(_)))
    ));
    scene.set_mask(own, 0).unwrap();
    let ray = Ray::new(Vec3A::new(0.2, 0.2, 1.0), -Vec3A::Z, 0.0, 2.0);
    assert_eq!(scene.closest_hit(&ray, ALL_MASK), None);
    assert_eq!(
        other
            .closest_hit(&ray, ALL_MASK)
            .map(|h| h.geometry.index()),
        Some(0)
    );
}

#[test]
fn a_panicking_filter_propagates_and_the_scene_stays_usable() {
    let mut b = SceneBuilder::new();
    b.add_triangles(&mixed_soup(200, 4));
    add_spheres(&mut b, spheres(50, 5), false);
    let scene = b.build(Quality::Medium).unwrap();
    let rays = rays(100, 16);
    let ray = *rays
        .iter()
        .find(|r| scene.closest_hit(r, ALL_MASK).is_some())
        .unwrap();
    let panicked = std::panic::catch_unwind(AssertUnwindSafe(|| {
        scene.closest_hit_filtered(&ray, ALL_MASK, |_| panic!("alpha texture missing"))
    }));
    assert!(panicked.is_err());
    let panicked = std::panic::catch_unwind(AssertUnwindSafe(|| {
        scene.any_hits_filtered(&rays, ALL_MASK, |_| panic!("in a batch"))
    }));
    assert!(panicked.is_err());
    assert_eq!(
        bits(scene.closest_hit(&ray, ALL_MASK)),
        bits(scene.brute_closest_hit(&ray, ALL_MASK, None))
    );
}

#[test]
fn a_callback_that_lies_is_clamped_to_its_box_like_brute_force() {
    // Distances pushed up to 0.5 beyond the sphere (outside its box for most rays): the hit
    // rule clamps them onto the box's span, in the traversal as in the brute-force twin.
    let lie = |p: u32| 0.25 * (p % 3) as f32;
    let boxes: Vec<Aabb> = spheres(300, 6).iter().map(Sphere::bounds).collect();
    let rays = rays(500, 17);
    for q in [Quality::Fast, Quality::High] {
        let mut b = SceneBuilder::new();
        b.add_triangles(&mixed_soup(300, 9));
        let balls = spheres(300, 6);
        let id = b.add_primitives(&boxes, move |ray: &Ray, p: u32, tmin: f32, _tmax: f32| {
            let mut hit = balls[p as usize].intersect(ray, tmin, f32::INFINITY)?;
            hit.t += lie(p);
            Some(hit)
        });
        let scene = b.build(q).unwrap();
        let balls = spheres(300, 6);
        let mut clamped = 0;
        for ray in &rays {
            let got = scene.closest_hit(ray, ALL_MASK);
            assert_eq!(
                bits(got),
                bits(scene.brute_closest_hit(ray, ALL_MASK, None)),
                "{q}"
            );
            assert_eq!(scene.any_hit(ray, ALL_MASK), got.is_some(), "{q}");
            if let Some(h) = got.filter(|h| h.geometry == id) {
                let p = h.primitive;
                let told = balls[p as usize]
                    .intersect(ray, ray.tmin, f32::INFINITY)
                    .unwrap()
                    .t
                    + lie(p);
                clamped += (h.t < told) as usize;
            }
        }
        assert!(clamped > 10, "{q}: only {clamped} clamped hits");
    }
}

/// Timings for `docs/facade.md` (one thread, interleaved, best of 5):
/// `cargo test -p sahara --test scene -- --ignored --nocapture scene_query_timings`.
#[test]
#[ignore]
fn scene_query_timings() {
    use std::time::Instant;
    // 200,000 triangles, mostly small, some large, in [-10, 10]^3, as eight meshes.
    let meshes: Vec<Vec<Triangle>> = (0..8).map(|s| box_soup(25_000, 100 + s)).collect();
    let all: Vec<Triangle> = meshes.concat();
    let accel = Accel::build(&all, Quality::Medium).unwrap();
    let build = |user: bool| {
        let mut b = SceneBuilder::new();
        let ids: Vec<GeometryId> = meshes.iter().map(|m| b.add_triangles(m)).collect();
        b.set_mask(ids[7], 2).unwrap();
        if user {
            b.add_primitives(&[], |_: &Ray, _, _, _| None);
        }
        b.build(Quality::Medium).unwrap()
    };
    let (tris, mixed) = (build(false), build(true));
    // The SIMD path runs on the same tree as the `Accel`.
    assert!(accel.bvh().nodes == tris.bvh().nodes);
    assert_eq!(accel.bvh().prim_indices, tris.bvh().prim_indices);
    let bounds = Aabb::new(Vec3A::splat(-12.0), Vec3A::splat(12.0));
    let rays = segments_in(&bounds, 100_000, &mut Pcg32::new(18, 5));
    let time = |f: &dyn Fn(&Ray) -> bool| {
        let t = Instant::now();
        let hits = rays.iter().filter(|r| f(r)).count();
        (t.elapsed().as_secs_f64() * 1e9 / rays.len() as f64, hits)
    };
    type Query<'a> = Box<dyn Fn(&Ray) -> bool + 'a>;
    let cases: Vec<(&str, Query)> = vec![
        (
            "Accel::closest_hit",
            Box::new(|r| accel.closest_hit(r).is_some()),
        ),
        (
            "Scene::closest_hit, all masks pass (SIMD path)",
            Box::new(|r| tris.closest_hit(r, ALL_MASK).is_some()),
        ),
        (
            "Scene::closest_hit, mask excludes 1 of 8 meshes",
            Box::new(|r| tris.closest_hit(r, 1).is_some()),
        ),
        (
            "Scene::closest_hit_filtered, filter keeps all",
            Box::new(|r| tris.closest_hit_filtered(r, ALL_MASK, |_| true).is_some()),
        ),
        (
            "Scene::closest_hit, with a user geometry (custom path)",
            Box::new(|r| mixed.closest_hit(r, ALL_MASK).is_some()),
        ),
        ("Accel::any_hit", Box::new(|r| accel.any_hit(r))),
        (
            "Scene::any_hit, all masks pass",
            Box::new(|r| tris.any_hit(r, ALL_MASK)),
        ),
        (
            "Scene::any_hit, mask excludes 1 of 8",
            Box::new(|r| tris.any_hit(r, 1)),
        ),
        (
            "Scene::any_hit, with a user geometry",
            Box::new(|r| mixed.any_hit(r, ALL_MASK)),
        ),
    ];
    let mut best = vec![(f64::INFINITY, 0); cases.len()];
    for _ in 0..5 {
        for (i, (_, f)) in cases.iter().enumerate() {
            let (ns, hits) = time(f.as_ref());
            best[i] = (best[i].0.min(ns), hits);
        }
    }
    for ((name, _), (ns, hits)) in cases.iter().zip(best) {
        println!("{name:58} {ns:8.1} ns/ray  ({hits} hits)");
    }
}
