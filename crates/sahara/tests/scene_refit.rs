//! `Scene::refit`: moving a geometry's triangles refits the scene's tree; refitting to unmoved
//! triangles is the identity, every answer after large random motion equals the brute-force
//! twin bit for bit, and bad refits are typed errors that change nothing.

use sahara::{
    Aabb, Error, GeometryId, Intersection, Quality, Ray, Scene, SceneBuilder, SceneError, SceneHit,
    Triangle, Vec3A, ALL_MASK,
};
use sahara_fixtures::soups::{exploded, mixed_soup};
use sahara_geom::rng::Pcg32;

mod common;

use common::{scene_bits as bits, segments_and_rays_from_above};

/// Three meshes with masks 1, 2 and 1|2, and an empty one.
fn meshes(b: &mut SceneBuilder) -> Vec<(GeometryId, Vec<Triangle>)> {
    let soups = [
        mixed_soup(500, 3),
        mixed_soup(400, 8),
        Vec::new(),
        mixed_soup(300, 5),
    ];
    soups
        .into_iter()
        .zip([1, 2, 4, 1 | 2])
        .map(|(tris, mask)| {
            let id = b.add_triangles(&tris);
            b.set_mask(id, mask).unwrap();
            (id, tris)
        })
        .collect()
}

/// A unit-radius-ish sphere per box, centred in it.
fn add_spheres(b: &mut SceneBuilder, n: usize, seed: u64) -> GeometryId {
    let mut rng = Pcg32::new(seed, 2);
    let spheres: Vec<(Vec3A, f32)> = (0..n)
        .map(|_| {
            let c = Vec3A::new(
                rng.range_f32(-1.0, 1.0),
                rng.range_f32(-1.0, 1.0),
                rng.range_f32(-1.0, 1.0),
            );
            (c, rng.range_f32(0.02, 0.12))
        })
        .collect();
    let boxes: Vec<Aabb> = spheres
        .iter()
        .map(|&(c, r)| Aabb::new(c - Vec3A::splat(r), c + Vec3A::splat(r)))
        .collect();
    b.add_primitives(&boxes, move |ray: &Ray, p, tmin, tmax| {
        let (c, r) = spheres[p as usize];
        let (o, d) = (ray.origin - c, ray.direction());
        let (a, h, k) = (d.dot(d), o.dot(d), o.dot(o) - r * r);
        let disc = h * h - a * k;
        let t = (-h - disc.max(0.0).sqrt()) / a;
        (disc >= 0.0 && t >= tmin && t <= tmax).then(|| Intersection {
            t,
            u: 0.0,
            v: 0.0,
            normal: o + d * t,
        })
    })
}

/// Every query against the brute-force twin, with masks and a filter.
fn check(scene: &Scene, rays: &[Ray], what: &str) -> usize {
    let keep = |h: &SceneHit| !(h.primitive + h.geometry.index()).is_multiple_of(3);
    let mut hits = 0;
    for mask in [ALL_MASK, 1, 2] {
        let closest = scene.closest_hits(rays, mask);
        let any = scene.any_hits(rays, mask);
        for (i, ray) in rays.iter().enumerate() {
            let want = scene.brute_closest_hit(ray, mask, None);
            assert_eq!(bits(closest[i]), bits(want), "{what} mask {mask} ray {i}");
            assert_eq!(any[i], want.is_some(), "{what} any mask {mask} ray {i}");
            let want_f = scene.brute_closest_hit(ray, mask, Some(&mut { keep }));
            let got_f = scene.closest_hit_filtered(ray, mask, keep);
            assert_eq!(bits(got_f), bits(want_f), "{what} filtered {mask} ray {i}");
            assert_eq!(
                scene.any_hit_filtered(ray, mask, keep),
                want_f.is_some(),
                "{what} any filtered {mask} ray {i}"
            );
            hits += want.is_some() as usize;
        }
    }
    hits
}

#[test]
fn refitting_unmoved_triangles_is_the_identity() {
    for q in Quality::ALL {
        let mut b = SceneBuilder::new();
        let geos = meshes(&mut b);
        let mut scene = b.build(q).unwrap();
        let (bvh, wide) = (scene.bvh().clone(), scene.wide().clone());
        let moves: Vec<(GeometryId, &[Triangle])> =
            geos.iter().map(|(id, t)| (*id, &t[..])).collect();
        scene.refit_many(&moves).unwrap();
        assert_eq!(scene.bvh(), &bvh, "{q}");
        assert!(scene.wide() == &wide, "{q}: the layout changed");
    }
    // With user primitives, for the levels without spatial splits.
    for q in [Quality::Fast, Quality::Medium] {
        let mut b = SceneBuilder::new();
        let geos = meshes(&mut b);
        add_spheres(&mut b, 80, 4);
        let mut scene = b.build(q).unwrap();
        let (bvh, wide) = (scene.bvh().clone(), scene.wide().clone());
        scene.refit(geos[1].0, &geos[1].1).unwrap();
        assert_eq!(scene.bvh(), &bvh, "{q} mixed");
        assert!(scene.wide() == &wide, "{q} mixed: the layout changed");
    }
}

#[test]
fn refit_scenes_equal_brute_force_after_large_random_motion() {
    let rays = segments_and_rays_from_above(400, 21, 1.5);
    for q in Quality::ALL {
        for with_spheres in [false, true] {
            let mut b = SceneBuilder::new();
            let geos = meshes(&mut b);
            let balls = with_spheres.then(|| add_spheres(&mut b, 60, 9));
            let mut scene = b.build(q).unwrap();
            let what = format!("{q} spheres {with_spheres}");
            assert!(check(&scene, &rays, &what) > 0);
            for frame in 1..=3u64 {
                // Large motion of one mesh, small of another, one left alone.
                let far = exploded(&geos[0].1, 0.4 * frame as f32, frame);
                let near = exploded(&geos[3].1, 0.02, frame + 10);
                if frame == 2 {
                    scene.refit(geos[0].0, &far).unwrap();
                    scene.refit(geos[3].0, &near).unwrap();
                } else {
                    scene
                        .refit_many(&[(geos[0].0, &far), (geos[3].0, &near)])
                        .unwrap();
                }
                assert_eq!(scene.triangles(geos[0].0), Some(&far[..]));
                assert_eq!(scene.triangles(geos[1].0), Some(&geos[1].1[..]));
                if let Some(balls) = balls {
                    assert_eq!(scene.geometry_len(balls), Some(60));
                }
                let hits = check(&scene, &rays, &format!("{what} frame {frame}"));
                assert!(hits > rays.len() / 4, "{what} frame {frame}: {hits} hits");
            }
        }
    }
}

/// The argument of `Scene::refit_many`.
type Moves<'a> = Vec<(GeometryId, &'a [Triangle])>;

#[test]
fn bad_refits_are_typed_errors_and_change_nothing() {
    let mut b = SceneBuilder::new();
    let geos = meshes(&mut b);
    let balls = add_spheres(&mut b, 10, 3);
    let mut scene = b.build(Quality::Medium).unwrap();
    let foreign = SceneBuilder::new().add_triangles(&[]);
    let bvh = scene.bvh().clone();
    let (id, tris) = (&geos[0].0, &geos[0].1);
    let moved = exploded(tris, 0.3, 1);
    let mut nan = moved.clone();
    nan[7].v[2].y = f32::NAN;
    let cases: [(Moves, SceneError); 5] = [
        (vec![(foreign, &[])], SceneError::UnknownGeometry(foreign)),
        (vec![(balls, &[])], SceneError::NotTriangles(balls)),
        (
            vec![(*id, &moved[1..])],
            SceneError::RefitCount {
                geometry: 0,
                expected: tris.len(),
                given: tris.len() - 1,
            },
        ),
        (
            vec![(*id, &nan)],
            SceneError::NonFinite {
                geometry: 0,
                primitive: 7,
            },
        ),
        // A good move before a bad one: neither happens.
        (
            vec![(*id, &moved), (geos[1].0, &moved)],
            SceneError::RefitCount {
                geometry: 1,
                expected: geos[1].1.len(),
                given: moved.len(),
            },
        ),
    ];
    for (moves, want) in cases {
        match scene.refit_many(&moves) {
            Err(Error::Scene(e)) => assert_eq!(e, want),
            other => panic!("expected {want:?}, got {other:?}"),
        }
        assert_eq!(scene.bvh(), &bvh);
        assert_eq!(scene.triangles(*id), Some(&tris[..]));
    }
    assert!(matches!(
        scene.refit(foreign, &[]),
        Err(Error::Scene(SceneError::UnknownGeometry(_)))
    ));
}
