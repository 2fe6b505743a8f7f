//! Moving instances (issue 45, item 3): after random `set_transform` moves, with instance and
//! ray masks, every query equals the brute-force twin bit for bit; moves rebuild the top level
//! only (the meshes are the same `Arc`s, untouched); bad moves are typed errors that change
//! nothing; the world-space normal is the inverse-transpose one; save/load keeps moves and
//! masks.

use std::sync::Arc;

use sahara::sahara_traverse::instance::InstanceError;
use sahara::{Accel, Affine3A, Error, Instances, Quality, Ray, Triangle, Vec3, Vec3A, ALL_MASK};
use sahara_fixtures::meshes::mesh_like;
use sahara_fixtures::soups::mixed_soup;
use sahara_geom::rng::Pcg32;
use sahara_geom::Aabb;

mod common;

/// A random placement: rotation, non-uniform scale (a mirror one time in five), translation
/// in a 12-unit cube.
fn random_transform(rng: &mut Pcg32) -> Affine3A {
    let axis = Vec3::new(
        rng.range_f32(-1.0, 1.0),
        rng.range_f32(-1.0, 1.0),
        rng.range_f32(0.1, 1.0),
    )
    .normalize();
    let mut scale = Vec3::new(
        rng.range_f32(0.4, 1.6),
        rng.range_f32(0.4, 1.6),
        rng.range_f32(0.4, 1.6),
    );
    if rng.range_f32(0.0, 1.0) < 0.2 {
        scale.x = -scale.x;
    }
    let rotation = glam::Quat::from_axis_angle(axis, rng.range_f32(0.0, 6.3));
    let t = Vec3::new(
        rng.range_f32(0.0, 12.0),
        rng.range_f32(0.0, 12.0),
        rng.range_f32(0.0, 12.0),
    );
    Affine3A::from_scale_rotation_translation(scale, rotation, t)
}

/// `n` random placements ([`random_transform`]) of meshes 0 and 1 in turn.
fn alternating_placements(n: usize, rng: &mut Pcg32) -> Vec<(usize, Affine3A)> {
    (0..n).map(|i| (i % 2, random_transform(rng))).collect()
}

fn meshes() -> Vec<Arc<Accel>> {
    let small: Vec<Triangle> = mesh_like(10, 3)
        .iter()
        .map(|t| Triangle::new(t.v[0] * 0.03, t.v[1] * 0.03, t.v[2] * 0.03))
        .collect();
    vec![
        Arc::new(Accel::build(&mixed_soup(300, 5), Quality::Medium).unwrap()),
        // The mesh is about 100 units across: scaled to the soup's size (about 2.6).
        Arc::new(Accel::build(&small, Quality::High).unwrap()),
    ]
}

fn world(scene: &Instances) -> Aabb {
    scene
        .set()
        .world_boxes()
        .iter()
        .fold(Aabb::EMPTY, |b, w| b.union(w))
}

/// Segments and unbounded rays through `b`.
fn rays(b: &Aabb, n: usize, seed: u64) -> Vec<Ray> {
    common::segments_and_unbounded_rays(b, n, seed, 4)
}

/// Every query of `scene` under `mask` against the brute-force twins; returns the hit count.
fn check(scene: &Instances, rays: &[Ray], mask: u32, what: &str) -> usize {
    let got = scene.closest_hits(rays, mask);
    let got_any = scene.any_hits(rays, mask);
    let mut hits = 0;
    for (i, r) in rays.iter().enumerate() {
        let want = scene.brute_closest_hit(r, mask);
        assert_eq!(got[i], want, "{what}: mask {mask:#x}, ray {i}");
        // Bit for bit, the normal's sign of zero included.
        let bits =
            |h: Option<sahara::InstanceHit>| h.map(|h| h.normal.to_array().map(f32::to_bits));
        assert_eq!(bits(got[i]), bits(want), "{what}: normal of ray {i}");
        assert_eq!(
            got_any[i],
            scene.brute_any_hit(r, mask),
            "{what}: any-hit of ray {i}"
        );
        if let Some(h) = want {
            assert_ne!(
                scene.mask(h.instance as usize).unwrap() & mask,
                0,
                "{what}: masked instance hit"
            );
            hits += 1;
        }
    }
    hits
}

#[test]
fn moved_and_masked_instances_equal_brute_force_bit_for_bit() {
    let mut rng = Pcg32::new(45, 3);
    let placements = alternating_placements(16, &mut rng);
    for quality in [Quality::Fast, Quality::Medium] {
        let mut scene = Instances::build_shared(meshes(), &placements, quality).unwrap();
        let mut total = 0;
        for round in 0..6 {
            // One instance moved alone, then three moved together.
            let i = rng.below(16) as usize;
            scene.set_transform(i, random_transform(&mut rng)).unwrap();
            let batch: Vec<(usize, Affine3A)> = (0..3)
                .map(|_| (rng.below(16) as usize, random_transform(&mut rng)))
                .collect();
            scene.set_transforms(&batch).unwrap();
            // Masks: instance k gets bit k / 2 % 4 (both meshes share each bit), and every fifth
            // instance none.
            for k in 0..16 {
                let m = if (k + round) % 5 == 0 {
                    0
                } else {
                    1 << (k / 2 % 4)
                };
                scene.set_mask(k, m).unwrap();
            }
            let rays = rays(&world(&scene), 1_000, round as u64);
            let what = format!("{quality:?}, round {round}");
            total += check(&scene, &rays, ALL_MASK, &what);
            let some = check(&scene, &rays, 0b0101, &what);
            // Masks that exclude every instance: no hit at all.
            assert_eq!(check(&scene, &rays, 0b1_0000, &what), 0);
            assert_eq!(check(&scene, &rays, 0, &what), 0);
            assert!(some > 0, "{what}: the mask 0b0101 hit nothing");
            // The moved set is the set built from its placements: the same top-level tree.
            let fresh = Instances::build_shared(meshes(), scene.placements(), quality).unwrap();
            assert_eq!(
                fresh.set().top_level().fingerprint(),
                scene.set().top_level().fingerprint(),
                "{what}"
            );
            assert_eq!(
                fresh.set().world_boxes(),
                scene.set().world_boxes(),
                "{what}"
            );
        }
        assert!(total > 6 * 1_000 / 20, "{quality:?}: only {total} hits");
    }
}

#[test]
fn moving_an_instance_keeps_the_meshes() {
    let shared = meshes();
    let fingerprints: Vec<u64> = shared.iter().map(|m| m.wide().fingerprint()).collect();
    let placements = [
        (0, Affine3A::IDENTITY),
        (1, Affine3A::IDENTITY),
        (0, Affine3A::IDENTITY),
    ];
    let mut scene = Instances::build_shared(shared.clone(), &placements, Quality::Fast).unwrap();
    let top_before = scene.set().top_level().fingerprint();
    let mut rng = Pcg32::new(7, 1);
    for k in 0..10 {
        scene
            .set_transform(k % 3, random_transform(&mut rng))
            .unwrap();
    }
    assert_ne!(
        scene.set().top_level().fingerprint(),
        top_before,
        "the top level was not rebuilt"
    );
    for (m, s) in shared.iter().zip(scene.meshes()) {
        assert!(Arc::ptr_eq(m, s), "a mesh was replaced");
        // Ours and the scene's: no copy was made.
        assert_eq!(Arc::strong_count(m), 2);
    }
    let after: Vec<u64> = scene
        .meshes()
        .iter()
        .map(|m| m.wide().fingerprint())
        .collect();
    assert_eq!(after, fingerprints);
    // Cloning the set shares the meshes too.
    let copy = scene.clone();
    assert!(Arc::ptr_eq(&copy.meshes()[1], &shared[1]));
    assert_eq!(Arc::strong_count(&shared[1]), 3);
    // `build` from owned meshes still works, and wraps them.
    let owned = Instances::build(
        vec![(*shared[0]).clone()],
        &[(0, Affine3A::IDENTITY)],
        Quality::Fast,
    )
    .unwrap();
    assert_eq!(Arc::strong_count(&owned.meshes()[0]), 1);
}

#[test]
fn bad_moves_and_masks_are_typed_errors_that_change_nothing() {
    let mut rng = Pcg32::new(11, 2);
    let placements = alternating_placements(5, &mut rng);
    let mut scene = Instances::build_shared(meshes(), &placements, Quality::Medium).unwrap();
    scene.set_mask(2, 0b11).unwrap();
    let snapshot = |s: &Instances| {
        (
            s.placements().to_vec(),
            s.set().world_boxes().to_vec(),
            s.set().inverse_transforms().to_vec(),
            s.set().top_level().fingerprint(),
            (0..5).map(|i| s.mask(i)).collect::<Vec<_>>(),
        )
    };
    let before = snapshot(&scene);
    let good = random_transform(&mut rng);
    let nan = Affine3A::from_translation(Vec3::new(f32::NAN, 0.0, 0.0));
    let inf = Affine3A::from_scale(Vec3::new(f32::INFINITY, 1.0, 1.0));
    let singular = Affine3A::from_scale(Vec3::new(1.0, 0.0, 1.0));
    for (k, bad) in [nan, inf, singular].into_iter().enumerate() {
        let r = scene.set_transform(3, bad);
        assert!(
            matches!(
                r,
                Err(Error::Instance(InstanceError::BadTransform { instance: 3 }))
            ),
            "{k}: {r:?}"
        );
        // A good move batched with a bad one: nothing moves.
        let r = scene.set_transforms(&[(0, good), (4, bad)]);
        assert!(
            matches!(
                r,
                Err(Error::Instance(InstanceError::BadTransform { instance: 4 }))
            ),
            "{k}: {r:?}"
        );
        assert_eq!(snapshot(&scene), before, "{k}");
    }
    for i in [5, usize::MAX] {
        let r = scene.set_transform(i, good);
        assert!(
            matches!(r, Err(Error::Instance(InstanceError::UnknownInstance { instance, count: 5 })) if instance == i),
            "{r:?}"
        );
        let r = scene.set_transforms(&[(1, good), (i, good)]);
        assert!(
            matches!(
                r,
                Err(Error::Instance(InstanceError::UnknownInstance { .. }))
            ),
            "{r:?}"
        );
        let r = scene.set_mask(i, 0);
        assert!(
            matches!(
                r,
                Err(Error::Instance(InstanceError::UnknownInstance { .. }))
            ),
            "{r:?}"
        );
        assert_eq!(scene.mask(i), None);
    }
    assert_eq!(snapshot(&scene), before);
    // An empty batch moves nothing and succeeds.
    scene.set_transforms(&[]).unwrap();
    assert_eq!(snapshot(&scene), before);
}

#[test]
fn the_normal_is_the_inverse_transpose_of_the_object_normal() {
    let mut rng = Pcg32::new(3, 8);
    let placements = alternating_placements(8, &mut rng);
    let scene = Instances::build_shared(meshes(), &placements, Quality::Fast).unwrap();
    let rays = rays(&world(&scene), 2_000, 5);
    let mut checked = 0;
    for r in &rays {
        let Some(h) = scene.closest_hit(r, ALL_MASK) else {
            continue;
        };
        let (mesh, m) = scene.placements()[h.instance as usize];
        assert_eq!(mesh as u32, h.mesh);
        let tri = scene.meshes()[mesh].triangles()[h.prim as usize];
        let w: Vec<Vec3A> = tri.v.iter().map(|&p| m.transform_point3a(p)).collect();
        let world_cross = (w[1] - w[0]).cross(w[2] - w[0]);
        let det = m.matrix3.determinant();
        // (w1 - w0) × (w2 - w0) = det M · M⁻ᵀ n, up to rounding.
        let want = world_cross / det;
        let err = (h.normal - want).length();
        assert!(
            err <= 1e-3 * want.length().max(1e-12),
            "normal {:?} vs {want:?}",
            h.normal
        );
        // Perpendicular to the world-space triangle.
        for e in [w[1] - w[0], w[2] - w[0]] {
            assert!(h.normal.dot(e).abs() <= 1e-3 * h.normal.length() * e.length());
        }
        checked += 1;
    }
    assert!(checked > 100, "only {checked} hits");
}

#[test]
fn save_and_load_keep_moves_and_masks() {
    let mut rng = Pcg32::new(9, 9);
    let placements = alternating_placements(6, &mut rng);
    let mut scene = Instances::build_shared(meshes(), &placements, Quality::Fast).unwrap();
    scene.set_transform(2, random_transform(&mut rng)).unwrap();
    scene.set_mask(1, 0).unwrap();
    scene.set_mask(4, 0b100).unwrap();
    let mut bytes = Vec::new();
    scene.save(&mut bytes).unwrap();
    let back = Instances::load(&mut bytes.as_slice()).unwrap();
    assert_eq!(back.placements(), scene.placements());
    assert_eq!(back.set().masks(), scene.set().masks());
    assert_eq!(
        back.set().top_level().fingerprint(),
        scene.set().top_level().fingerprint()
    );
    let rays = rays(&world(&scene), 500, 1);
    for mask in [ALL_MASK, 0b100, 0b11] {
        assert_eq!(
            back.closest_hits(&rays, mask),
            scene.closest_hits(&rays, mask)
        );
        assert_eq!(back.any_hits(&rays, mask), scene.any_hits(&rays, mask));
    }
    // A version 1 file (no masks) still loads, every mask all ones.
    let n = scene.placements().len();
    let mut payload = bytes[56..bytes.len() - 4 * n].to_vec();
    let mut header = bytes[..56].to_vec();
    header[8..12].copy_from_slice(&1u32.to_le_bytes());
    header[40..48].copy_from_slice(&(payload.len() as u64).to_le_bytes());
    let mut h: u64 = 0xcbf2_9ce4_8422_2325;
    for &b in header[8..48].iter().chain(&payload) {
        h ^= b as u64;
        h = h.wrapping_mul(0x0100_0000_01b3);
    }
    header[48..56].copy_from_slice(&h.to_le_bytes());
    header.append(&mut payload);
    let v1 = Instances::load(&mut header.as_slice()).unwrap();
    assert_eq!(v1.placements(), scene.placements());
    assert!(v1.set().masks().iter().all(|&m| m == ALL_MASK));
    // A version 3 file is refused.
    let mut v3 = bytes.clone();
    v3[8..12].copy_from_slice(&3u32.to_le_bytes());
    assert!(matches!(
        Instances::load(&mut v3.as_slice()),
        Err(sahara::LoadError::UnsupportedVersion(3))
    ));
}
