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
