//! The PLOC builder: valid, deterministic across thread counts, leaves bounded by the
//! configuration, hard cases, typed errors.

mod common;
mod tsah_support;

use common::{assert_empty_input_builds_empty_tree, assert_rejected};
use sahara_builders::ploc::{PlocBuilder, PlocConfig};
use sahara_builders::{registry, BuildError, BuildInput, Builder};
use sahara_fixtures::meshes::mesh_like;
use sahara_fixtures::soups::box_soup;
use sahara_geom::{Aabb, Triangle, Vec3A};
use sahara_metrics::{sah, CostModel};
use tsah_support::*;

#[test]
fn valid_deterministic_and_bounded_leaves() {
    for (radius, max_leaf) in [(16, 8), (1, 1), (4, 4)] {
        let b = PlocBuilder::new(PlocConfig {
            radius,
            max_leaf_size: max_leaf,
        });
        for (name, tris) in soups_mesh_and_degenerates() {
            check_builder(&b, &tris, max_leaf, &name);
        }
    }
}

#[test]
fn registered_and_close_to_sweep() {
    let b = registry::by_name("ploc").expect("ploc is registered");
    assert_eq!(b.name(), "ploc");
    let tris = mesh_like(60, 5);
    let t = check_builder(b.as_ref(), &tris, 8, "registry");
    let input = BuildInput::new(&tris, CostModel::default()).unwrap();
    let sweep = registry::by_name("sweep").unwrap().build(&input).unwrap();
    // PLOC's trees are a little worse than the full sweep's by SAH, not wildly.
    let (p, s) = (sah(&t, &input.cost), sah(&sweep, &input.cost));
    assert!(p < 1.3 * s, "ploc SAH {p} vs sweep {s}");
}

/// Identical boxes (every distance ties) still pair up in halves: the tree is balanced.
#[test]
fn identical_triangles_give_a_balanced_tree() {
    let t = Triangle::new(Vec3A::ZERO, Vec3A::X, Vec3A::Y);
    let tris = vec![t; 4096];
    let b = PlocBuilder::new(PlocConfig {
        radius: 16,
        max_leaf_size: 1,
    });
    let bvh = check_builder(&b, &tris, 1, "copies");
    assert!(bvh.stats().depth <= 14, "depth {}", bvh.stats().depth);
}

#[test]
fn typed_errors_and_edge_sizes() {
    let tris = box_soup(10, 1);
    assert_rejected(
        &tris,
        [
            PlocConfig {
                radius: 0,
                max_leaf_size: 8,
            },
            PlocConfig {
                radius: 16,
                max_leaf_size: 0,
            },
        ],
        PlocBuilder::new,
    );
    let b = PlocBuilder::default();
    assert_empty_input_builds_empty_tree(&b);
    for n in [1, 2, 3] {
        check_builder(&b, &tris[..n], 8, "tiny");
    }
    let nan = [Triangle::new(
        Vec3A::X,
        Vec3A::splat(f32::INFINITY),
        Vec3A::Y,
    )];
    assert!(matches!(
        BuildInput::new(&nan, CostModel::default()),
        Err(BuildError::NonFinite { triangle: 0 })
    ));
    // Boxes of any primitives; huge coordinates keep the Morton scale finite.
    let boxes: Vec<Aabb> = (0..100)
        .map(|i| {
            let c = Vec3A::splat(i as f32 * 1e36 - 5e37);
            Aabb::new(c, c + Vec3A::splat(1e35))
        })
        .collect();
    let input = BuildInput::from_boxes(&boxes, CostModel::default()).unwrap();
    let bvh = b.build(&input).unwrap();
    assert_eq!(bvh.prim_indices.len(), 100);
    assert!(sah(&bvh, &input.cost).is_finite());
}
