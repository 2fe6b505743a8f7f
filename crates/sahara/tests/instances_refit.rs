//! The façade's instances and refit: every answer equals brute force (the two-level
//! reference of `sahara_traverse::instance` for instances, a loop over the moved triangles
//! for refit), bad input is a typed error that leaves the structure unchanged.

use sahara::sahara_traverse::brute;
use sahara::{Accel, Affine3A, Error, Instances, Quality, Ray, Triangle, Vec3, Vec3A, ALL_MASK};
use sahara_fixtures::meshes::mesh_like;
use sahara_fixtures::soups::{exploded, mixed_soup};
use sahara_geom::rng::Pcg32;
use sahara_geom::Aabb;

mod common;

fn bounds(points: impl IntoIterator<Item = Vec3A>) -> Aabb {
    points.into_iter().fold(Aabb::EMPTY, |b, p| b.grown(p))
}

/// Segments and unbounded rays through `b`.
fn rays(b: &Aabb, n: usize, seed: u64) -> Vec<Ray> {
    common::segments_and_unbounded_rays(b, n, seed, 9)
}

#[test]
fn instances_equal_the_two_level_brute_force() {
    let meshes = vec![
        Accel::build(&mixed_soup(600, 3), Quality::Medium).unwrap(),
        Accel::build(&mesh_like(12, 4), Quality::High).unwrap(),
    ];
    // 24 placements: rotations, non-uniform scales and translations over a 6 × 4 grid.
    let placements: Vec<(usize, Affine3A)> = (0..24)
        .map(|i| {
            let t = Vec3::new(2.5 * (i % 6) as f32, 0.3 * i as f32, 2.5 * (i / 6) as f32);
            let m = Affine3A::from_scale_rotation_translation(
                Vec3::new(1.0, 0.5 + 0.1 * (i % 4) as f32, 1.3),
                glam::Quat::from_rotation_y(0.4 * i as f32),
                t,
            );
            (i % 2, m)
        })
        .collect();
    for quality in [Quality::Fast, Quality::Medium] {
        let scene = Instances::build(meshes.clone(), &placements, quality).unwrap();
        let world = bounds(
            scene
                .set()
                .world_boxes()
                .iter()
                .flat_map(|b| [b.min, b.max]),
        );
        let rays = rays(&world, 3_000, 11);
        let got = scene.closest_hits(&rays, ALL_MASK);
        let got_any = scene.any_hits(&rays, ALL_MASK);
        let mut hits = 0;
        for (i, r) in rays.iter().enumerate() {
            let want = scene.set().brute_closest_hit(r, |blas, o| {
                brute::closest_hit(meshes[blas as usize].triangles(), o)
            });
            let g = got[i].map(|h| (h.t, h.instance, h.prim, h.u, h.v));
            assert_eq!(
                g,
                want.map(|h| (h.t, h.instance, h.prim, h.u, h.v)),
                "{quality:?}: ray {i}"
            );
            assert_eq!(
                got[i],
                scene.brute_closest_hit(r, ALL_MASK),
                "{quality:?}: ray {i}"
            );
            let want_any = scene.set().brute_any_hit(r, |blas, o| {
                brute::any_hit(meshes[blas as usize].triangles(), o)
            });
            assert_eq!(got_any[i], want_any, "{quality:?}: any-hit of ray {i}");
            hits += usize::from(want.is_some());
        }
        assert!(hits > rays.len() / 10, "{quality:?}: only {hits} hits");
    }
}

#[test]
fn bad_placements_are_typed_errors() {
    let mesh = Accel::build(&mixed_soup(50, 1), Quality::Fast).unwrap();
    let missing = Instances::build(
        vec![mesh.clone()],
        &[(1, Affine3A::IDENTITY)],
        Quality::Fast,
    );
    assert!(matches!(missing, Err(Error::Instance(_))), "{missing:?}");
    let singular = Affine3A::from_scale(Vec3::new(1.0, 0.0, 1.0));
    let r = Instances::build(vec![mesh.clone()], &[(0, singular)], Quality::Fast);
    assert!(matches!(r, Err(Error::Instance(_))), "{r:?}");
    let nan = Affine3A::from_translation(Vec3::new(f32::NAN, 0.0, 0.0));
    let r = Instances::build(vec![mesh], &[(0, nan)], Quality::Fast);
    assert!(matches!(r, Err(Error::Instance(_))), "{r:?}");
    // No placement: every ray misses.
    let empty = Instances::build(Vec::new(), &[], Quality::Fast).unwrap();
    let ray = Ray::new(Vec3A::ZERO, Vec3A::Z, 0.0, f32::INFINITY);
    assert_eq!(empty.closest_hit(&ray, ALL_MASK), None);
    assert!(!empty.any_hit(&ray, ALL_MASK));
}

/// Every vertex moved by a smooth field plus jitter (triangles stay triangles).
fn moved(tris: &[Triangle], amount: f32, seed: u64) -> Vec<Triangle> {
    let mut rng = Pcg32::new(seed, 2);
    let mut f = |p: Vec3A| {
        let j = Vec3A::new(rng.range_f32(-1.0, 1.0), rng.range_f32(-1.0, 1.0), 0.0);
        p + amount * (Vec3A::new(p.y.sin(), p.z.cos(), p.x.sin()) + 0.2 * j)
    };
    tris.iter()
        .map(|t| Triangle::new(f(t.v[0]), f(t.v[1]), f(t.v[2])))
        .collect()
}

#[test]
fn refit_equals_brute_force_on_the_moved_triangles() {
    let tris = mixed_soup(1_500, 8);
    let size = bounds(tris.iter().flat_map(|t| t.v)).extent().max_element();
    for quality in [Quality::Fast, Quality::Medium, Quality::High, Quality::Best] {
        let mut accel = Accel::build(&tris, quality).unwrap();
        // Refitting to the same triangles changes nothing, bit for bit, at every level: the
        // spatial-split trees (High, Best) clip their references again by the recorded cuts.
        let (bvh0, wide0) = (accel.bvh().fingerprint(), accel.wide().fingerprint());
        let spatial = accel.bvh().spatial_splits;
        assert_eq!(spatial, accel.bvh().ref_cuts.is_some(), "{quality:?}");
        accel.refit(&tris).unwrap();
        assert_eq!(accel.bvh().fingerprint(), bvh0, "{quality:?}");
        assert_eq!(accel.wide().fingerprint(), wide0, "{quality:?}");
        // Also after a save and a load (the cut records are saved).
        let mut file = Vec::new();
        accel.save(&mut file).unwrap();
        let mut loaded = Accel::load(&mut file.as_slice()).unwrap();
        loaded.refit(&tris).unwrap();
        assert_eq!(loaded.wide().fingerprint(), wide0, "{quality:?} loaded");
        for frame in 1..=4 {
            let now = if frame <= 2 {
                moved(&tris, 0.05 * frame as f32, frame)
            } else {
                // Large random motion: up to a fifth and a half of the scene per axis.
                exploded(&tris, [0.2, 0.5][frame as usize - 3] * size, frame)
            };
            accel.refit(&now).unwrap();
            accel.bvh().validate(&now).unwrap();
            assert_eq!(accel.triangles(), &now[..]);
            let rays = rays(&bounds(now.iter().flat_map(|t| t.v)), 2_000, frame);
            let got = accel.closest_hits(&rays);
            let got_any = accel.any_hits(&rays);
            for (i, r) in rays.iter().enumerate() {
                let want = brute::closest_hit(&now, r);
                // Bit for bit: the hit's distance, triangle and barycentrics.
                let got_bits =
                    got[i].map(|h| (h.t.to_bits(), h.prim, h.u.to_bits(), h.v.to_bits()));
                let want_bits = want.is_hit().then(|| {
                    (
                        want.t.to_bits(),
                        want.prim,
                        want.u.to_bits(),
                        want.v.to_bits(),
                    )
                });
                assert_eq!(got_bits, want_bits, "{quality:?} frame {frame} ray {i}");
                // The normal is the moved triangle's.
                if let Some(h) = got[i] {
                    assert_eq!(
                        h.normal,
                        now[h.prim as usize].cross(),
                        "{quality:?} normal {i}"
                    );
                }
                assert_eq!(
                    got_any[i],
                    brute::any_hit(&now, r),
                    "{quality:?} any, ray {i}"
                );
            }
        }
    }
}

#[test]
fn bad_refits_leave_the_structure_unchanged() {
    let tris = mixed_soup(200, 5);
    let mut accel = Accel::build(&tris, Quality::Medium).unwrap();
    let (bvh0, wide0) = (accel.bvh().fingerprint(), accel.wide().fingerprint());
    let r = accel.refit(&tris[..199]);
    assert!(
        matches!(
            r,
            Err(Error::RefitCount {
                expected: 200,
                given: 199
            })
        ),
        "{r:?}"
    );
    let mut bad = tris.clone();
    bad[17].v[1].y = f32::NAN;
    let r = accel.refit(&bad);
    assert!(matches!(r, Err(Error::Refit(_))), "{r:?}");
    bad[17].v[1].y = f32::INFINITY;
    assert!(accel.refit(&bad).is_err());
    assert_eq!(accel.bvh().fingerprint(), bvh0);
    assert_eq!(accel.wide().fingerprint(), wide0);
    assert_eq!(accel.triangles(), &tris[..]);
}

#[test]
fn instance_sets_save_and_load() {
    let meshes = vec![
        Accel::build(&mixed_soup(60, 21), Quality::Medium).unwrap(),
        Accel::build(&mesh_like(4, 2), Quality::High).unwrap(),
    ];
    let placements: Vec<(usize, Affine3A)> = (0..9)
        .map(|i| {
            let m = Affine3A::from_rotation_translation(
                glam::Quat::from_rotation_z(0.7 * i as f32),
                Vec3::new(3.0 * (i % 3) as f32, 3.0 * (i / 3) as f32, 0.5),
            );
            (i % 2, m)
        })
        .collect();
    let scene = Instances::build(meshes, &placements, Quality::Fast).unwrap();
    let mut bytes = Vec::new();
    scene.save(&mut bytes).unwrap();
    let back = Instances::load(&mut bytes.as_slice()).unwrap();
    assert_eq!(back.placements(), scene.placements());
    assert_eq!(back.options(), scene.options());
    assert_eq!(
        back.set().top_level().fingerprint(),
        scene.set().top_level().fingerprint()
    );
    for (a, b) in back.meshes().iter().zip(scene.meshes()) {
        assert_eq!(a.wide().fingerprint(), b.wide().fingerprint());
    }
    let world = bounds(
        scene
            .set()
            .world_boxes()
            .iter()
            .flat_map(|b| [b.min, b.max]),
    );
    let rays = rays(&world, 500, 3);
    assert_eq!(
        back.closest_hits(&rays, ALL_MASK),
        scene.closest_hits(&rays, ALL_MASK)
    );
    // Every truncation and every flip of one of three bits per byte is a typed error.
    for n in 0..bytes.len() {
        assert!(
            Instances::load(&mut &bytes[..n]).is_err(),
            "truncated at {n}"
        );
    }
    for i in 0..bytes.len() {
        for bit in [0, 3, 7] {
            let mut b = bytes.clone();
            b[i] ^= 1 << bit;
            assert!(
                Instances::load(&mut b.as_slice()).is_err(),
                "byte {i} bit {bit}"
            );
        }
    }
    let mut padded = bytes.clone();
    padded.push(0);
    assert!(matches!(
        Instances::load(&mut padded.as_slice()),
        Err(sahara::LoadError::TrailingData(1))
    ));
    // An Accel file is not an instance set.
    let mut accel = Vec::new();
    scene.meshes()[0].save(&mut accel).unwrap();
    assert!(matches!(
        Instances::load(&mut accel.as_slice()),
        Err(sahara::LoadError::BadMagic)
    ));
}
