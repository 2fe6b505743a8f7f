//! The ray-weighted metrics of primary rays: camera box weights, the camera's closest hits
//! and the primary-ray metrics (moved from `sahara-metrics`, assertions kept).

use sahara_fixtures::meshes::{height_field, sphere};
use sahara_fixtures::soups::unit_cube_soup;
use sahara_fixtures::trees::{split_tree as build, Split};
use sahara_geom::{
    intersect::intersect_aabb, intersect::intersect_ray_triangle, rng::Pcg32, Aabb, Camera,
    CameraFrame, Vec3A,
};
use sahara_metrics::{
    node_weights, segment_node_weights, weighted_sah, weighted_sah_from_node_weights, CostModel,
};
use sahara_trace::weighted::{box_weight, camera_box_weight, hit_endpoint, primary_ray_metrics};
use sahara_trace::{trace_closest, Bvh2Tracer};

fn camera() -> Camera {
    Camera::new(
        Vec3A::new(0.3, 0.4, 3.0),
        Vec3A::new(0.5, 0.5, 0.5),
        Vec3A::Y,
        50.0,
    )
}

fn frame() -> CameraFrame {
    camera().frame_with_aspect(24, 16, 1.5)
}

#[test]
fn box_weight_counts_exactly_the_grid_rays_that_hit() {
    let cam = frame();
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
        assert_eq!(box_weight(&cam, b), brute, "{b:?}");
    }
    assert_eq!(box_weight(&cam, &boxes[0]), 1.0);
    assert_eq!(box_weight(&cam, &boxes[2]), 0.0);
    let f = camera_box_weight(&camera(), 1.5, 16);
    assert_eq!(f(&boxes[5]), box_weight(&cam, &boxes[5]));
}

#[test]
fn segment_weights_without_occlusion_equal_box_weights() {
    let tris = unit_cube_soup(500, 0.15, 9);
    let bvh = build(&tris, 2, Split::Median);
    let cam = frame();
    let seg = segment_node_weights(&bvh, &cam.rays());
    let boxw = node_weights(&bvh, |b| box_weight(&cam, b));
    assert_eq!(seg, boxw);
    let c = CostModel::AILA;
    assert_eq!(
        weighted_sah_from_node_weights(&bvh, &c, &seg),
        weighted_sah(&bvh, &c, |b| box_weight(&cam, b))
    );
}

#[test]
fn the_cameras_closest_hits_match_brute_force() {
    let tris = sphere(12, 20);
    let bvh = build(&tris, 3, Split::Median);
    let cam = Camera::new(Vec3A::new(0.2, 0.5, 4.0), Vec3A::ZERO, Vec3A::Y, 40.0);
    let rays = cam.frame_with_aspect(20, 20, 1.0).rays();
    let hits = trace_closest(&Bvh2Tracer::new(&bvh, &tris), &rays);
    let mut n_hits = 0;
    for (r, h) in rays.iter().zip(&hits) {
        let brute = tris
            .iter()
            .filter_map(|t| intersect_ray_triangle(r, t).map(|h| h.t))
            .fold(f32::INFINITY, f32::min);
        match hit_endpoint(&tris, h) {
            Some(e) => {
                n_hits += 1;
                assert_eq!(h.t, brute);
                assert!((e.point - r.at(h.t)).length() < 1e-4);
            }
            None => assert!(brute.is_infinite()),
        }
    }
    assert!(n_hits > 100 && n_hits < 400, "{n_hits}");
}

#[test]
fn primary_ray_metrics_are_consistent() {
    let scenes = [height_field(16), sphere(12, 20)];
    let cam = Camera::new(
        Vec3A::new(0.5, 1.5, 2.5),
        Vec3A::new(0.5, 0.0, 0.5),
        Vec3A::Y,
        45.0,
    )
    .frame_with_aspect(32, 32, 1.0);
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

#[test]
fn a_degenerate_camera_is_weighted_under_the_one_rule() {
    // eye == target once panicked here; the camera's rule now looks along -z.
    let tris = height_field(8);
    let bvh = build(&tris, 2, Split::Median);
    let eye = Vec3A::new(0.5, 0.5, 3.0);
    let cam = Camera::new(eye, eye, Vec3A::Y, 45.0).frame_with_aspect(8, 8, 1.0);
    let m = primary_ray_metrics(&bvh, &tris, &CostModel::AILA, &cam);
    assert_eq!(m.rays, 64);
    assert!(m.frustum_sah.is_finite());
}
