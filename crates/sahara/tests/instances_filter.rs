//! Any-hit filters on instances: `Instances::closest_hit_filtered`, `any_hit_filtered` and
//! their batch forms equal the brute-force twins bit for bit (ids, t, u, v, world normal) with
//! masks, at every level, after moves; a panicking filter propagates and leaves the set usable.

use std::panic::AssertUnwindSafe;
use std::sync::Arc;

use sahara::{Accel, Affine3A, InstanceHit, Instances, Quality, Ray, Vec3, Vec3A, ALL_MASK};
use sahara_fixtures::rays::segments_in;
use sahara_fixtures::soups::mixed_soup;
use sahara_geom::rng::Pcg32;
use sahara_geom::Aabb;

type Bits = (u32, u32, u32, u32, u32, u32, [u32; 3]);

fn bits(h: Option<InstanceHit>) -> Option<Bits> {
    h.map(|h| {
        (
            h.instance,
            h.mesh,
            h.prim,
            h.t.to_bits(),
            h.u.to_bits(),
            h.v.to_bits(),
            h.normal.to_array().map(f32::to_bits),
        )
    })
}

fn transform(rng: &mut Pcg32) -> Affine3A {
    let axis = Vec3::new(
        rng.range_f32(-1.0, 1.0),
        rng.range_f32(-1.0, 1.0),
        rng.range_f32(0.1, 1.0),
    )
    .normalize();
    let mut scale = Vec3::splat(rng.range_f32(0.6, 1.4));
    if rng.range_f32(0.0, 1.0) < 0.25 {
        scale.y = -scale.y;
    }
    let t = Vec3::new(
        rng.range_f32(0.0, 6.0),
        rng.range_f32(0.0, 6.0),
        rng.range_f32(0.0, 6.0),
    );
    Affine3A::from_scale_rotation_translation(
        scale,
        glam::Quat::from_axis_angle(axis, rng.range_f32(0.0, 6.3)),
        t,
    )
}

fn rays(n: usize, seed: u64) -> Vec<Ray> {
    let mut rng = Pcg32::new(seed, 3);
    let mut rays = segments_in(
        &Aabb::new(Vec3A::splat(-1.5), Vec3A::splat(7.5)),
        n,
        &mut rng,
    );
    rays.push(Ray::new(Vec3A::splat(f32::NAN), Vec3A::Z, 0.0, 1.0));
    rays
}

/// Alpha test: drops a third of the triangles by instance and index, and the part of each
/// kept triangle where u > 0.7.
fn alpha(h: &InstanceHit) -> bool {
    !(h.instance + h.prim).is_multiple_of(3) && h.u <= 0.7
}

/// Every filtered query against the twins, for several masks; returns (hits, answers the
/// filter changed).
fn check(set: &Instances, rays: &[Ray], what: &str) -> (usize, usize) {
    let (mut hits, mut changed) = (0, 0);
    for mask in [ALL_MASK, 1, 2, 0] {
        let closest = set.closest_hits_filtered(rays, mask, alpha);
        let any = set.any_hits_filtered(rays, mask, alpha);
        for (i, ray) in rays.iter().enumerate() {
            let want = set.brute_closest_hit_filtered(ray, mask, Some(&mut alpha));
            let got = set.closest_hit_filtered(ray, mask, alpha);
            assert_eq!(bits(got), bits(want), "{what} mask {mask} ray {i}");
            assert_eq!(
                bits(closest[i]),
                bits(want),
                "{what} batch mask {mask} ray {i}"
            );
            if let Some(h) = got {
                assert!(alpha(&h), "{what}: a rejected hit was returned");
                assert_ne!(set.mask(h.instance as usize).unwrap() & mask, 0);
            }
            let want_any = set.brute_any_hit_filtered(ray, mask, Some(&mut alpha));
            assert_eq!(
                want_any,
                want.is_some(),
                "{what}: the twins disagree, ray {i}"
            );
            assert_eq!(
                set.any_hit_filtered(ray, mask, alpha),
                want_any,
                "{what} any {i}"
            );
            assert_eq!(any[i], want_any, "{what} batch any {mask} ray {i}");
            // Without a filter the twins are the unfiltered queries'.
            let plain = set.closest_hit(ray, mask);
            assert_eq!(
                bits(plain),
                bits(set.brute_closest_hit_filtered(ray, mask, None))
            );
            assert_eq!(
                bits(plain),
                bits(set.closest_hit_filtered(ray, mask, |_| true))
            );
            assert_eq!(
                set.any_hit(ray, mask),
                set.brute_any_hit_filtered(ray, mask, None)
            );
            if mask == 0 {
                assert!(got.is_none() && !want_any);
            }
            hits += plain.is_some() as usize;
            changed += (bits(plain) != bits(got)) as usize;
        }
    }
    (hits, changed)
}

#[test]
fn filtered_instance_queries_equal_brute_force() {
    let rays = rays(500, 31);
    for q in Quality::ALL {
        let meshes = vec![
            Arc::new(Accel::build(&mixed_soup(250, 5), q).unwrap()),
            Arc::new(Accel::build(&mixed_soup(150, 6), q).unwrap()),
        ];
        let mut rng = Pcg32::new(7, 7);
        let placements: Vec<(usize, Affine3A)> =
            (0..12).map(|i| (i % 2, transform(&mut rng))).collect();
        let mut set = Instances::build_shared(meshes, &placements, q).unwrap();
        for i in 0..12 {
            set.set_mask(i, [1, 2, 1 | 2][i % 3]).unwrap();
        }
        let (hits, changed) = check(&set, &rays, &format!("{q}"));
        assert!(
            hits > rays.len() / 2 && changed > 0,
            "{q}: {hits} hits, {changed} changed"
        );
        // After moves (a rebuilt top level).
        let moves: Vec<(usize, Affine3A)> = (0..12)
            .step_by(3)
            .map(|i| (i, transform(&mut rng)))
            .collect();
        set.set_transforms(&moves).unwrap();
        check(&set, &rays, &format!("{q} moved"));
    }
}

#[test]
fn a_panicking_instance_filter_propagates_and_the_set_stays_usable() {
    let mesh = Accel::build(&mixed_soup(200, 4), Quality::Medium).unwrap();
    let mut rng = Pcg32::new(3, 3);
    let placements: Vec<(usize, Affine3A)> = (0..6).map(|_| (0, transform(&mut rng))).collect();
    let set = Instances::build(vec![mesh], &placements, Quality::Medium).unwrap();
    let rays = rays(200, 5);
    let ray = *rays
        .iter()
        .find(|r| set.closest_hit(r, ALL_MASK).is_some())
        .unwrap();
    let panicked = std::panic::catch_unwind(AssertUnwindSafe(|| {
        set.closest_hit_filtered(&ray, ALL_MASK, |_| panic!("alpha texture missing"))
    }));
    assert!(panicked.is_err());
    let panicked = std::panic::catch_unwind(AssertUnwindSafe(|| {
        set.any_hits_filtered(&rays, ALL_MASK, |_| panic!("in a batch"))
    }));
    assert!(panicked.is_err());
    // A filter that is never called (mask 0) cannot panic.
    assert!(!set.any_hit_filtered(&ray, 0, |_| panic!("never called")));
    assert_eq!(
        bits(set.closest_hit(&ray, ALL_MASK)),
        bits(set.brute_closest_hit(&ray, ALL_MASK))
    );
    check(&set, &rays, "after the panics");
}
