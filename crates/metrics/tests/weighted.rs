//! Ray-distribution-weighted metrics: camera box weights, segment weights, closest hits and
//! the primary-ray metrics.

mod common;

use common::{build, close, Split};
use sahara_fixtures::meshes::{height_field, sphere};
use sahara_fixtures::soups::unit_cube_soup;
use sahara_geom::{
    intersect::intersect_aabb, intersect::intersect_ray_triangle, rng::Pcg32, Aabb, Vec3A,
};
use sahara_metrics::{
    camera_box_weight, closest_hits, node_weights, primary_ray_metrics, sah, segment_node_weights,
    weighted_sah, weighted_sah_from_node_weights, CameraGrid, CostModel,
};

fn camera() -> CameraGrid {
    CameraGrid::new(
        Vec3A::new(0.3, 0.4, 3.0),
        Vec3A::new(0.5, 0.5, 0.5),
        Vec3A::Y,
        50.0,
        1.5,
        24,
        16,
    )
}

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

#[test]
fn box_weight_counts_exactly_the_grid_rays_that_hit() {
    let cam = camera();
    let rays = cam.rays();
    assert_eq!(rays.len(), 24 * 16);
    let mut rng = Pcg32::new(5, 5);
    let mut boxes = vec![
        Aabb::new(Vec3A::splat(-100.0), Vec3A::splat(100.0)), // contains the eye
        Aabb::new(Vec3A::new(-5.0, -5.0, 2.9), Vec3A::new(5.0, 5.0, 3.1)), // straddles the eye plane
        Aabb::new(Vec3A::new(0.0, 0.0, 4.0), Vec3A::new(1.0, 1.0, 5.0)),   // behind the eye
        Aabb::EMPTY,
    ];
    for _ in 0..300 {
        let c = Vec3A::new(
            rng.range_f32(-2.0, 3.0),
            rng.range_f32(-2.0, 3.0),
            rng.range_f32(-3.0, 4.0),
        );
        let e =
            Vec3A::new(rng.next_f32(), rng.next_f32(), rng.next_f32()) * rng.range_f32(0.0, 1.5);
        boxes.push(Aabb::new(c - e, c + e));
    }
    for b in &boxes {
        let brute = rays
            .iter()
            .filter(|r| {
                !b.is_empty()
                    && intersect_aabb(r.origin, r.inv_direction(), 0.0, f32::INFINITY, b).is_some()
            })
            .count() as f64
            / rays.len() as f64;
        assert_eq!(cam.box_weight(b), brute, "{b:?}");
    }
    assert_eq!(cam.box_weight(&boxes[0]), 1.0);
    assert_eq!(cam.box_weight(&boxes[2]), 0.0);
    let f = camera_box_weight(
        Vec3A::new(0.3, 0.4, 3.0),
        Vec3A::new(0.5, 0.5, 0.5),
        Vec3A::Y,
        50.0,
        1.5,
        16,
    );
    assert_eq!(f(&boxes[5]), cam.box_weight(&boxes[5]));
}

#[test]
fn segment_weights_without_occlusion_equal_box_weights() {
    let tris = unit_cube_soup(500, 0.15, 9);
    let bvh = build(&tris, 2, Split::Median);
    let cam = camera();
    let seg = segment_node_weights(&bvh, &cam.rays());
    let boxw = node_weights(&bvh, |b| cam.box_weight(b));
    assert_eq!(seg, boxw);
    let c = CostModel::AILA;
    assert_eq!(
        weighted_sah_from_node_weights(&bvh, &c, &seg),
        weighted_sah(&bvh, &c, |b| cam.box_weight(b))
    );
}

#[test]
fn closest_hits_match_brute_force() {
    let tris = sphere(12, 20);
    let bvh = build(&tris, 3, Split::Median);
    let cam = CameraGrid::new(
        Vec3A::new(0.2, 0.5, 4.0),
        Vec3A::ZERO,
        Vec3A::Y,
        40.0,
        1.0,
        20,
        20,
    );
    let rays = cam.rays();
    let hits = closest_hits(&bvh, &tris, &rays);
    let mut n_hits = 0;
    for (r, h) in rays.iter().zip(&hits) {
        let brute = tris
            .iter()
            .filter_map(|t| intersect_ray_triangle(r, t).map(|h| h.t))
            .fold(f32::INFINITY, f32::min);
        match h {
            Some(h) => {
                n_hits += 1;
                assert_eq!(h.t, brute);
                let p = h.endpoint(&tris).point;
                assert!((p - r.at(h.t)).length() < 1e-4);
            }
            None => assert!(brute.is_infinite()),
        }
    }
    assert!(n_hits > 100 && n_hits < 400, "{n_hits}");
}

#[test]
fn primary_ray_metrics_are_consistent() {
    let scenes = [height_field(16), sphere(12, 20)];
    let cam = CameraGrid::new(
        Vec3A::new(0.5, 1.5, 2.5),
        Vec3A::new(0.5, 0.0, 0.5),
        Vec3A::Y,
        45.0,
        1.0,
        32,
        32,
    );
    for tris in &scenes {
        for split in [Split::Median, Split::Random(3)] {
            let bvh = build(tris, 2, split);
            let c = CostModel::AILA;
            let m = primary_ray_metrics(&bvh, tris, &c, &cam);
            assert_eq!(m.rays, 1024);
            assert!(m.hits > 0);
            assert!(m.frustum_sah > 0.0 && m.visible_epo >= 0.0);
            // Cutting rays at their hits can only remove node visits.
            assert!(m.occluded_sah <= m.frustum_sah + 1e-12, "{m:?}");
            // Deterministic.
            assert_eq!(m, primary_ray_metrics(&bvh, tris, &c, &cam));
        }
    }
    // A spatially incoherent tree overlaps a lot more.
    let tris = &scenes[0];
    let good = primary_ray_metrics(&build(tris, 2, Split::Median), tris, &CostModel::AILA, &cam);
    let bad = primary_ray_metrics(
        &build(tris, 2, Split::Random(3)),
        tris,
        &CostModel::AILA,
        &cam,
    );
    assert!(bad.visible_epo > good.visible_epo && bad.frustum_sah > good.frustum_sah);
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
