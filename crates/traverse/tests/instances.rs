//! Instances: the two-level traversal equals the two-level brute-force reference bit for bit
//! and the flattened mesh within the stated tolerance (the instance example, run small), and
//! bad input gets typed errors.

#[path = "../examples/instances.rs"]
#[allow(dead_code)]
mod instances;

use glam::{Affine3A, Vec3};
use sahara_bvh::Bvh;
use sahara_geom::{Aabb, Ray, Vec3A};
use sahara_traverse::instance::{Instance, InstanceError, InstanceSet};
use sahara_traverse::{Bvh8, NoStats};

#[test]
fn instances_example_equals_both_references() {
    let r = instances::run(4, 48);
    assert!(r.hits > r.rays / 4, "{} hits of {}", r.hits, r.rays);
    assert_eq!(r.flat_mismatches, 0, "{r:?}");
    // Grazing rays are rare: at most 1% of the rays.
    assert!(r.grazing * 100 <= r.rays, "{r:?}");
    assert!(r.max_rel_dt <= instances::TOLERANCE);
    println!("{r:?}");
}

fn one_leaf(boxes: &[Aabb]) -> Bvh {
    let b = boxes.iter().fold(Aabb::EMPTY, |b, x| b.union(x));
    Bvh {
        nodes: vec![sahara_bvh::Node::leaf(&b, 0, boxes.len() as u32)],
        prim_indices: (0..boxes.len() as u32).collect(),
        spatial_splits: false,
        ref_cuts: None,
    }
}

#[test]
fn bad_instances_are_typed_errors() {
    let blas = || vec![Bvh8::from_bvh(&Bvh::empty(), &[])];
    let id = Affine3A::IDENTITY;
    let e = InstanceSet::new(
        blas(),
        vec![Instance {
            blas: 1,
            transform: id,
        }],
        one_leaf,
    )
    .unwrap_err();
    assert_eq!(
        e,
        InstanceError::UnknownBlas {
            instance: 0,
            blas: 1,
            count: 1
        }
    );
    for bad in [
        Affine3A::from_scale(Vec3::ZERO),
        Affine3A::from_translation(Vec3::new(f32::NAN, 0.0, 0.0)),
    ] {
        let e = InstanceSet::new(
            blas(),
            vec![
                Instance {
                    blas: 0,
                    transform: id,
                },
                Instance {
                    blas: 0,
                    transform: bad,
                },
            ],
            one_leaf,
        )
        .unwrap_err();
        assert_eq!(e, InstanceError::BadTransform { instance: 1 });
    }
    // A top-level tree that forgets an instance.
    let e = InstanceSet::new(
        blas(),
        vec![
            Instance {
                blas: 0,
                transform: id
            };
            2
        ],
        |b: &[Aabb]| one_leaf(&b[..1]),
    )
    .unwrap_err();
    assert_eq!(e, InstanceError::TopLevelCoverage(2));
    // Instances of an empty tree are never hit; no instance at all is fine too.
    let set = InstanceSet::new(
        blas(),
        vec![Instance {
            blas: 0,
            transform: id,
        }],
        one_leaf,
    )
    .unwrap();
    let ray = Ray::new(Vec3A::new(0.0, 0.0, -1.0), Vec3A::Z, 0.0, f32::INFINITY);
    assert!(set.closest_hit(&ray, &mut NoStats).is_none());
    assert!(!set.any_hit(&ray, &mut NoStats));
    let set = InstanceSet::new(blas(), vec![], |_: &[Aabb]| Bvh::empty()).unwrap();
    assert!(set.closest_hit(&ray, &mut NoStats).is_none());
}

/// Moves (`set_transforms`) and masks: a moved set equals the set built from the moved
/// instances, masked queries equal the masked brute force, and a broken top level or a bad
/// update changes nothing.
#[test]
fn moved_and_masked_sets_equal_brute_force() {
    use sahara_builders::{registry, BuildInput};
    use sahara_fixtures::rays::segments_in;
    use sahara_fixtures::soups::mixed_soup;
    use sahara_geom::rng::Pcg32;
    use sahara_traverse::brute;
    use std::sync::Arc;

    let tris = mixed_soup(200, 2);
    let builder = registry::by_name("binned").expect("the binned builder");
    let cost = sahara_metrics::CostModel::default();
    let blas_tree = builder
        .build(&BuildInput::new(&tris, cost).unwrap())
        .unwrap();
    let blas = Arc::new(Bvh8::from_bvh(&blas_tree, &tris));
    let top = |b: &[Aabb]| {
        builder
            .build(&BuildInput::from_boxes(b, cost).unwrap())
            .unwrap()
    };
    let mut rng = Pcg32::new(5, 5);
    let random = |rng: &mut Pcg32| {
        Affine3A::from_scale_rotation_translation(
            Vec3::new(rng.range_f32(0.5, 1.5), 1.0, rng.range_f32(-1.5, -0.5)),
            glam::Quat::from_rotation_y(rng.range_f32(0.0, 6.0)),
            Vec3::new(rng.range_f32(0.0, 8.0), rng.range_f32(0.0, 8.0), 0.0),
        )
    };
    let instances: Vec<Instance> = (0..10)
        .map(|_| Instance {
            blas: 0,
            transform: random(&mut rng),
        })
        .collect();
    let mut set = InstanceSet::new(vec![blas.clone()], instances, top).unwrap();
    for round in 0..5u32 {
        let updates: Vec<(usize, Affine3A)> = (0..3)
            .map(|_| (rng.below(10) as usize, random(&mut rng)))
            .collect();
        set.set_transforms(&updates, top).unwrap();
        let fresh = InstanceSet::new(vec![blas.clone()], set.instances().to_vec(), top).unwrap();
        assert_eq!(fresh.world_boxes(), set.world_boxes());
        assert_eq!(
            fresh.top_level().fingerprint(),
            set.top_level().fingerprint()
        );
        for i in 0..10 {
            set.set_mask(i, 1 << ((i as u32 + round) % 3)).unwrap();
        }
        let world = set
            .world_boxes()
            .iter()
            .fold(Aabb::EMPTY, |b, x| b.union(x));
        let rays = segments_in(&world, 300, &mut rng);
        let mut hits = 0;
        for mask in [u32::MAX, 0b001, 0b110, 0b1000] {
            for (k, r) in rays.iter().enumerate() {
                let want =
                    set.brute_closest_hit_masked(r, mask, |_, o| brute::closest_hit(&tris, o));
                assert_eq!(
                    set.closest_hit_masked(r, mask, &mut NoStats),
                    want,
                    "round {round} mask {mask} ray {k}"
                );
                let want_any = set.brute_any_hit_masked(r, mask, |_, o| brute::any_hit(&tris, o));
                assert_eq!(
                    set.any_hit_masked(r, mask, &mut NoStats),
                    want_any,
                    "round {round} mask {mask} ray {k}"
                );
                if mask == 0b1000 {
                    assert!(want.is_none() && !want_any);
                }
                hits += usize::from(want.is_some());
            }
        }
        assert!(hits > 0, "round {round}");
    }
    assert_eq!(Arc::strong_count(&blas), 2);
    // A broken top level and bad updates change nothing.
    let before = (set.world_boxes().to_vec(), set.top_level().fingerprint());
    let e = set.set_transforms(&[(0, Affine3A::IDENTITY)], |b: &[Aabb]| one_leaf(&b[..1]));
    assert_eq!(e, Err(InstanceError::TopLevelCoverage(10)));
    let e = set.set_transforms(&[(10, Affine3A::IDENTITY)], top);
    assert_eq!(
        e,
        Err(InstanceError::UnknownInstance {
            instance: 10,
            count: 10
        })
    );
    assert_eq!(
        set.set_mask(10, 0),
        Err(InstanceError::UnknownInstance {
            instance: 10,
            count: 10
        })
    );
    assert_eq!(
        (set.world_boxes().to_vec(), set.top_level().fingerprint()),
        before
    );
}
