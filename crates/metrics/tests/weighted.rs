//! Ray-distribution-weighted metrics: weighted SAH and segment weights (the camera box weights,
//! the camera's closest hits and the primary-ray metrics are tested in `sahara-trace`'s
//! `tests/weighted.rs`, with the code they moved with).

mod common;

use common::{build, close, Split};
use sahara_fixtures::soups::unit_cube_soup;
use sahara_geom::{intersect::intersect_aabb, rng::Pcg32, Aabb, Vec3A};
use sahara_metrics::{sah, segment_node_weights, weighted_sah, CostModel};

#[test]
fn area_weights_give_the_sah() {
    let tris = unit_cube_soup(300, 0.2, 8);
    for split in [Split::Median, Split::Random(2)] {
        let bvh = build(&tris, 3, split);
        for c in [CostModel::AILA, CostModel::UNIT] {
            let w = weighted_sah(&bvh, &c, |b| b.half_area() as f64);
            assert!(close(w, sah(&bvh, &c), 1e-6), "{w} vs {}", sah(&bvh, &c));
        }
    }
    assert_eq!(
        weighted_sah(&sahara_bvh::Bvh::empty(), &CostModel::AILA, |_| 1.0),
        0.0
    );
}

/// Random segments: rays from random points in random directions, half of them cut short.
fn random_segments(n: usize, seed: u64) -> Vec<sahara_geom::Ray> {
    let mut rng = Pcg32::new(seed, 1);
    (0..n)
        .map(|i| {
            let mut v = || Vec3A::new(rng.next_f32(), rng.next_f32(), rng.next_f32());
            let o = v() * 1.6 - Vec3A::splat(0.3);
            let mut d = v() * 2.0 - Vec3A::ONE;
            if i % 7 == 0 {
                d.y = 0.0; // a zero component
            }
            let tmax = if i % 2 == 0 { f32::INFINITY } else { 0.4 };
            sahara_geom::Ray::new(o, d, 0.0, tmax)
        })
        .collect()
}

#[test]
fn segment_set_counts_like_the_slab_test_and_the_tree_walk() {
    let tris = unit_cube_soup(400, 0.15, 5);
    let bvh = build(&tris, 2, Split::Median);
    let rays = random_segments(700, 3);
    let root = bvh.nodes[0].bounds();
    let set = sahara_metrics::SegmentSet::new(&rays, &root);
    assert!(!set.is_empty() && set.len() <= rays.len());
    // Against the robust slab test of every ray (the tree walk's test): equal up to the rare
    // grazing ray where the plain and the robust tests differ.
    let walk = segment_node_weights(&bvh, &rays);
    let mut off = 0usize;
    for (n, w) in bvh.nodes.iter().zip(&walk) {
        let brute = rays
            .iter()
            .filter(|r| {
                intersect_aabb(r.origin, r.inv_direction(), r.tmin, r.tmax, &n.bounds()).is_some()
            })
            .count();
        assert_eq!((*w * rays.len() as f64).round() as usize, brute);
        off += brute.abs_diff(set.count(&n.bounds()) as usize);
    }
    assert!(off <= bvh.nodes.len() / 50, "{off} differing counts");
    // Monotone in the box, zero for the empty box and for a box outside every segment.
    let mut rng = Pcg32::new(9, 1);
    for _ in 0..200 {
        let p = Vec3A::new(rng.next_f32(), rng.next_f32(), rng.next_f32());
        let small = Aabb::new(p, p + Vec3A::splat(0.05 * rng.next_f32()));
        let big = small.union(&Aabb::new(p - Vec3A::splat(0.1), p));
        assert!(set.count(&small) <= set.count(&big));
    }
    assert_eq!(set.count(&Aabb::EMPTY), 0);
    let far = Aabb::new(Vec3A::splat(50.0), Vec3A::splat(51.0));
    assert_eq!(set.count(&far), 0);
    assert!((set.fraction(&root) - 1.0).abs() < 1e-12);
}
