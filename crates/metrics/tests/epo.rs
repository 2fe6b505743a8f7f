//! The efficient EPO against a brute-force O(nodes × triangles) reference.

mod common;

use common::{brute_epo, build, close, Split};
use proptest::prelude::*;
use sahara_bvh::{Bvh, Node};
use sahara_fixtures::meshes::{height_field, sphere};
use sahara_fixtures::soups::unit_cube_soup;
use sahara_geom::{clip::clipped_bounds, Aabb, Triangle, Vec3A};
use sahara_metrics::{
    endpoint_overlap, epo, epo_breakdown, epo_with_node_weights, sample_surface_endpoints,
    total_area, CostModel,
};

fn check(bvh: &Bvh, tris: &[Triangle], what: &str) {
    for cost in [CostModel::AILA, CostModel::UNIT] {
        let fast = epo_breakdown(bvh, tris, &cost);
        let (inner, leaf) = brute_epo(bvh, tris, &cost, None);
        assert!(
            close(fast.inner, inner, 1e-9),
            "{what}: inner {} vs brute {inner}",
            fast.inner
        );
        assert!(
            close(fast.leaf, leaf, 1e-9),
            "{what}: leaf {} vs brute {leaf}",
            fast.leaf
        );
        assert!(
            close(epo(bvh, tris, &cost), inner + leaf, 1e-9),
            "{what}: total"
        );
    }
}

#[test]
fn random_soups_match_brute_force() {
    for (seed, n, size) in [(1, 50, 0.3), (2, 200, 0.2), (3, 300, 0.6), (4, 120, 0.05)] {
        let tris = unit_cube_soup(n, size, seed);
        for (leaf, split) in [
            (1, Split::Median),
            (4, Split::Median),
            (3, Split::Random(seed)),
        ] {
            let bvh = build(&tris, leaf, split);
            bvh.validate(&tris).unwrap();
            check(
                &bvh,
                &tris,
                &format!("soup {seed} {n} leaf {leaf} {split:?}"),
            );
        }
    }
}

#[test]
fn procedural_scenes_match_brute_force() {
    let scenes = [("grid", height_field(14)), ("sphere", sphere(10, 16))];
    for (name, tris) in &scenes {
        for (leaf, split) in [
            (1, Split::Median),
            (4, Split::Median),
            (2, Split::Random(9)),
        ] {
            let bvh = build(tris, leaf, split);
            bvh.validate(tris).unwrap();
            check(&bvh, tris, &format!("{name} leaf {leaf} {split:?}"));
        }
    }
}

/// A hand-made spatial-split tree: the long triangle 0 is referenced by leaves 2 and 4, which
/// are not siblings, and passes through the box of leaf 3, which does not reference it.
fn spatial_tree(reference_in_middle: bool) -> (Bvh, Vec<Triangle>) {
    let tris = vec![
        Triangle::new(
            Vec3A::ZERO,
            Vec3A::new(3.0, 0.0, 0.2),
            Vec3A::new(3.0, 0.3, -0.1),
        ),
        Triangle::new(
            Vec3A::new(0.1, 0.5, 0.0),
            Vec3A::new(0.9, 0.5, 0.1),
            Vec3A::new(0.5, 0.9, 0.0),
        ),
        Triangle::new(
            Vec3A::new(1.1, 0.0, 0.1),
            Vec3A::new(1.9, 0.2, -0.1),
            Vec3A::new(1.5, 0.8, 0.0),
        ),
        Triangle::new(
            Vec3A::new(2.1, 0.1, 0.0),
            Vec3A::new(2.9, 0.6, 0.2),
            Vec3A::new(2.4, 0.7, -0.2),
        ),
    ];
    let slab =
        |x0: f32, x1: f32| Aabb::new(Vec3A::new(x0, -10.0, -10.0), Vec3A::new(x1, 10.0, 10.0));
    let part = |x0, x1| clipped_bounds(&tris[0], &slab(x0, x1));
    let l1 = part(0.0, 1.0).union(&tris[1].bounds());
    let mut l2 = tris[2].bounds();
    if reference_in_middle {
        l2 = l2.union(&part(1.0, 2.0));
    }
    let l3 = part(2.0, 3.0).union(&tris[3].bounds());
    let a = l1.union(&l2);
    let root = a.union(&l3);
    let mut prims = vec![0, 1, 2];
    if reference_in_middle {
        prims.push(0);
    }
    let l3_first = prims.len() as u32;
    prims.extend([0, 3]);
    let bvh = Bvh {
        nodes: vec![
            Node::inner(&root, 4),
            Node::inner(&a, 3),
            Node::leaf(&l1, 0, 2),
            Node::leaf(&l2, 2, if reference_in_middle { 2 } else { 1 }),
            Node::leaf(&l3, l3_first, 2),
        ],
        prim_indices: prims,
        spatial_splits: true,
        ref_cuts: None,
    };
    (bvh, tris)
}

#[test]
fn spatial_split_tree_matches_brute_force() {
    for middle in [false, true] {
        let (bvh, tris) = spatial_tree(middle);
        bvh.validate(&tris).unwrap();
        check(&bvh, &tris, &format!("spatial, middle reference {middle}"));
    }
    // Triangle 0 crosses leaf 3's box without being referenced there: foreign surface that
    // only the spatial-split-aware membership gets right.
    let (without, tris) = spatial_tree(false);
    let crossing = sahara_geom::clip::clipped_area(&tris[0], &without.nodes[3].bounds());
    assert!(crossing > 0.0);
    let c = CostModel::UNIT;
    let e = epo_breakdown(&without, &tris, &c);
    let (_, leaf) = common::brute_epo(&without, &tris, &c, None);
    assert!(close(e.leaf, leaf, 1e-9) && e.leaf >= crossing / total_area(&tris));
}

#[test]
fn empty_and_trivial_trees() {
    let c = CostModel::default();
    assert_eq!(epo(&Bvh::empty(), &[], &c), 0.0);
    let tris = unit_cube_soup(5, 0.3, 5);
    let one_leaf = build(&tris, 8, Split::Median);
    assert_eq!(one_leaf.nodes.len(), 1);
    assert_eq!(
        epo(&one_leaf, &tris, &c),
        0.0,
        "a single leaf holds every triangle"
    );
}

#[test]
fn deterministic_across_thread_counts() {
    let tris = unit_cube_soup(6000, 0.08, 11);
    let bvh = build(&tris, 4, Split::Median);
    let c = CostModel::default();
    let run = |threads| {
        rayon::ThreadPoolBuilder::new()
            .num_threads(threads)
            .build()
            .unwrap()
            .install(|| (epo(&bvh, &tris, &c), total_area(&tris)))
    };
    let one = run(1);
    assert_eq!(one, run(2));
    assert_eq!(one, run(3));
}

#[test]
fn node_weights_scale_each_term() {
    let tris = sphere(8, 12);
    let bvh = build(&tris, 2, Split::Median);
    let c = CostModel::AILA;
    let ones = vec![1.0; bvh.nodes.len()];
    assert!(close(
        epo_with_node_weights(&bvh, &tris, &c, &ones).total(),
        epo(&bvh, &tris, &c),
        1e-12
    ));
    let w: Vec<f64> = (0..bvh.nodes.len()).map(|i| 2.0 + (i % 5) as f64).collect();
    let fast = epo_with_node_weights(&bvh, &tris, &c, &w);
    let (inner, leaf) = brute_epo(&bvh, &tris, &c, Some(&w));
    assert!(close(fast.inner, inner, 1e-9) && close(fast.leaf, leaf, 1e-9));
}

#[test]
fn uniform_endpoints_estimate_epo() {
    let tris = unit_cube_soup(400, 0.25, 21);
    let bvh = build(&tris, 2, Split::Median);
    let c = CostModel::AILA;
    let exact = epo(&bvh, &tris, &c);
    let samples = sample_surface_endpoints(&tris, 200_000, 3);
    assert_eq!(samples.len(), 200_000);
    let est = endpoint_overlap(&bvh, &tris, &c, &samples);
    assert!(
        close(est, exact, 0.03),
        "Monte Carlo {est} vs exact {exact}"
    );
    // Spatial split tree too.
    let (sbvh, stris) = spatial_tree(false);
    let exact = epo(&sbvh, &stris, &c);
    let est = endpoint_overlap(
        &sbvh,
        &stris,
        &c,
        &sample_surface_endpoints(&stris, 200_000, 4),
    );
    assert!(
        close(est, exact, 0.03),
        "spatial: Monte Carlo {est} vs exact {exact}"
    );
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(24))]
    #[test]
    fn prop_matches_brute_force(seed in 0u64..1_000_000, n in 1usize..60, size in 0.01f32..0.8, leaf in 1usize..4, random in any::<bool>()) {
        let tris = unit_cube_soup(n, size, seed);
        let split = if random { Split::Random(seed) } else { Split::Median };
        let bvh = build(&tris, leaf, split);
        let c = CostModel::AILA;
        let fast = epo_breakdown(&bvh, &tris, &c);
        let (inner, leaf_b) = brute_epo(&bvh, &tris, &c, None);
        prop_assert!(close(fast.inner, inner, 1e-9), "inner {} vs {}", fast.inner, inner);
        prop_assert!(close(fast.leaf, leaf_b, 1e-9), "leaf {} vs {}", fast.leaf, leaf_b);
    }
}
