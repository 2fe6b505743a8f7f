//! Minimal tests for the bugs the hard-case suite found in crates it does not own. While a bug
//! is open, its test is `#[ignore]`d and it has an entry in `sahara_hardcases::KNOWN_BUGS`
//! (run them with `cargo test -p sahara-hardcases --test known_bugs -- --ignored`); once the
//! owner fixes it, the `#[ignore]` and the entry go and the test stays as a regression test.
//! All the bugs below are fixed; the names are the former `KNOWN_BUGS` ids.

use sahara_bvh::{Bvh, Node};
use sahara_geom::{intersect::intersect_ray_triangle, Ray, Triangle, Vec3A};
use sahara_metrics::CostModel;
use sahara_traverse::{brute, scalar, NoStats};

fn one_leaf(tris: &[Triangle]) -> Bvh {
    let mut b = tris[0].bounds();
    for t in tris {
        b.grow_aabb(&t.bounds());
    }
    Bvh {
        nodes: vec![Node::leaf(&b, 0, tris.len() as u32)],
        prim_indices: (0..tris.len() as u32).collect(),
        spatial_splits: false,
        ref_cuts: None,
    }
}

/// Formerly KNOWN_BUGS `false-hit`: a triangle whose three vertices lie on the x axis (zero area) is
/// hit, at a point 3e-4 away from it (outside its bounds).
#[test]
fn zero_area_triangle_is_never_hit() {
    let tri = Triangle::new(
        Vec3A::new(-0.11602485, 0.0, 0.0),
        Vec3A::new(-0.01602485, 0.0, 0.0),
        Vec3A::new(-0.066024855, 0.0, 0.0),
    );
    assert_eq!(tri.area(), 0.0);
    let ray = Ray::new(
        Vec3A::new(8.9440215e-1, -8.6559063e-1, -3.351251e-1),
        Vec3A::new(-9.7329e-1, 8.6559063e-1, 3.351251e-1),
        0.0,
        f32::INFINITY,
    );
    let hit = intersect_ray_triangle(&ray, &tri);
    if let Some(h) = hit {
        let p = ray.at(h.t);
        panic!(
            "zero-area triangle hit at t = {} (point {p:?}, inside its bounds: {})",
            h.t,
            tri.bounds().contains_point(p)
        );
    }
}

/// Formerly KNOWN_BUGS `slab-rounding`: a ray with `tmax = 1` ending on a triangle in the plane
/// x = 5; brute force hit it at t = 0.99999994 while the scalar kernel culled its flat leaf box
/// (entry distance 1.0000001 > tmax). The exact distance is 1.0000000628 (one ulp beyond
/// `tmax`): since the hit rule clamps the distance into the triangle's box span (issue 13), every
/// kernel reports the exact answer, a miss, and with a slightly longer ray a hit at 1.0000001.
#[test]
fn shadow_ray_ending_on_a_flat_leaf_hits_like_brute_force() {
    let tris = [Triangle::new(
        Vec3A::new(5.0, 0.15091252, 0.121218204),
        Vec3A::new(5.0, -0.55908823, -0.046049118),
        Vec3A::new(5.0, -0.5604497, 0.25197375),
    )];
    let bvh = one_leaf(&tris);
    for (tmax, hits) in [(1.0, false), (1.000_000_2, true)] {
        let ray = Ray::new(
            Vec3A::new(-1.3665824, 1.1384169, -6.4570484),
            Vec3A::new(6.366582, -1.2403353, 6.5327964),
            0.0,
            tmax,
        );
        let expect = brute::closest_hit(&tris, &ray);
        assert_eq!(
            expect.is_hit(),
            hits,
            "brute force, tmax {tmax}: {expect:?}"
        );
        assert!(!hits || (expect.t > 1.0 && expect.t <= tmax), "{expect:?}");
        assert_eq!(scalar::closest_hit(&bvh, &tris, &ray, &mut NoStats), expect);
        assert_eq!(scalar::any_hit(&bvh, &tris, &ray, &mut NoStats), hits);
    }
}

/// Formerly KNOWN_BUGS `inf-t`: a valid ray with a denormal direction hits at t = +inf.
#[test]
fn denormal_direction_gives_a_miss_or_a_finite_hit() {
    let tri = Triangle::new(
        Vec3A::new(-1.0, -1.0, 1.0),
        Vec3A::new(1.0, -1.0, 1.0),
        Vec3A::new(0.0, 1.0, 1.0),
    );
    // Documented handling: a direction with no normal component is an invalid ray (a miss).
    let ray = Ray::new(Vec3A::ZERO, Vec3A::new(0.0, 0.0, 1e-40), 0.0, f32::INFINITY);
    assert!(!ray.is_valid());
    assert!(!brute::closest_hit(&[tri], &ray).is_hit());
    // The triangle test itself (which does not check validity) never returns t = +inf.
    if let Some(h) = intersect_ray_triangle(&ray, &tri) {
        assert!(h.t.is_finite(), "hit at t = {}", h.t);
    }
    // A subnormal component next to a normal one is valid; hits stay finite.
    let ray = Ray::new(Vec3A::ZERO, Vec3A::new(1e-40, 0.0, 1.0), 0.0, f32::INFINITY);
    assert!(ray.is_valid());
    let h = brute::closest_hit(&[tri], &ray);
    assert!(h.is_hit() && h.t.is_finite(), "{h:?}");
}

/// Formerly KNOWN_BUGS `false-hit`: a triangle in the plane x = 2 reaching to z = ±f32::MAX is hit at
/// t = -0, i.e. at the ray origin (4, 3, -3), two units away from its plane.
#[test]
fn huge_triangle_is_not_hit_at_the_ray_origin() {
    let tri = Triangle::new(
        Vec3A::new(2.0, -1e-45, 0.0),
        Vec3A::new(2.0, 0.5, f32::MAX),
        Vec3A::new(2.0, -0.0, -f32::MAX),
    );
    let ray = Ray::new(
        Vec3A::new(4.0, 3.0, -3.0),
        Vec3A::new(-5.0, -2.5, -5e29),
        0.0,
        1.0,
    );
    if let Some(h) = intersect_ray_triangle(&ray, &tri) {
        let p = ray.at(h.t);
        assert!(
            (p.x - 2.0).abs() < 1e-3,
            "hit at t = {} at {p:?}, off the plane x = 2",
            h.t
        );
    }
}

/// Formerly KNOWN_BUGS `sah-overflow` (fixed: `sah` computes node areas in f64): the SAH
/// cost of a one-leaf tree over a triangle of size 1e30 is finite.
#[test]
fn sah_is_finite_for_huge_coordinates() {
    let tris = [Triangle::new(
        Vec3A::new(-1e30, -1e30, 0.0),
        Vec3A::new(1e30, -1e30, 1e30),
        Vec3A::new(0.0, 1e30, -1e30),
    )];
    let cost = sahara_metrics::sah(&one_leaf(&tris), &CostModel::default());
    assert!(cost.is_finite(), "SAH cost {cost}");
}

/// Formerly KNOWN_BUGS `denormal-slow`: a valid ray whose direction is denormal (every reciprocal
/// component overflows to infinity) hits at t = +inf (see `inf-t`), so no hit ever shortens
/// its interval: the scalar kernel visits 156 leaves and 312 triangles where the same ray
/// with a normal direction visits 1 leaf and 2 triangles, all in subnormal arithmetic.
/// (`cargo xtask hardcases` measures such batches at 200-370x the time of a valid batch;
/// this test asserts the work counts, which timing noise cannot touch.)
#[test]
fn denormal_direction_does_not_visit_the_whole_tree() {
    use sahara_builders::{registry, BuildInput};
    use sahara_traverse::WorkCounters;
    let scene = sahara_scene::Procedural::SphereInBox.scene(20_000, 1);
    let tris = scene.triangles();
    let input = BuildInput::new(&tris, CostModel::default()).unwrap();
    let bvh = registry::by_name("sweep").unwrap().build(&input).unwrap();
    let d = Vec3A::new(0.3, 0.5, 0.8);
    let work = |dir: Vec3A| {
        let ray = Ray::new(scene.camera.eye, dir, 0.0, f32::INFINITY);
        let mut w = WorkCounters::default();
        scalar::closest_hit(&bvh, &tris, &ray, &mut w);
        w
    };
    let normal = work(d);
    let denormal = work(d * 1e-40);
    assert!(
        denormal.triangles <= 4 * normal.triangles.max(16),
        "denormal direction: {denormal:?}; normal direction: {normal:?}"
    );
}
