//! Regression test of issue 13: valid hits on large axis-aligned (flat-box) triangles.
//!
//! The triangle test's distance carries a rounding error that grows with the triangle's
//! extent along the ray's dominant axis, while the slab interval of a box of zero extent on
//! one axis is a single distance. The old acceptance rule asked the computed distance (widened
//! by 2^-16) to reach the triangle's own slab interval, and rejected these hits; every layout
//! and backend agreed with the (equally wrong) brute force. Exact rational Möller–Trumbore on
//! these `f32` inputs puts every ray below well inside its triangle.

use sahara_builders::{registry, BuildInput, CostModel};
use sahara_geom::{Ray, Triangle, Vec3A};
use sahara_traverse::{brute, scalar, Backend, Bvh4, Bvh8, NoStats};

fn scene() -> Vec<Triangle> {
    let v = |x: f32, y: f32, z: f32| Vec3A::new(x, y, z);
    vec![
        Triangle::new(
            v(1291.0, 498.0, 608.0),
            v(960.0, 512.0, 608.0),
            v(896.0, 512.0, 608.0),
        ),
        Triangle::new(
            v(1291.0, 498.0, 608.0),
            v(704.0, 512.0, 608.0),
            v(704.0, 480.0, 608.0),
        ),
        Triangle::new(
            v(2556.0, 2552.0, 320.0),
            v(-2656.0, 2552.0, 1536.0),
            v(2556.0, 2552.0, 1536.0),
        ),
    ]
}

/// `(ray, expected triangle, exact t)`: the exact t is the rational Möller–Trumbore distance on
/// the `f32` inputs, rounded.
fn rays() -> Vec<(Ray, u32, f32)> {
    let ray = |o: [f32; 3], tmin: f32, d: [f32; 3], tmax: f32| {
        Ray::new(Vec3A::from_array(o), Vec3A::from_array(d), tmin, tmax)
    };
    vec![
        (
            ray(
                [1_088.749_4, 503.719_7, 607.478_94],
                0.0,
                [0.929_888_7, 0.355_295_18, 0.095_249_17],
                f32::INFINITY,
            ),
            0,
            5.470_463_8,
        ),
        (
            ray(
                [1_088.749_4, 498.322_3, 607.478_9],
                0.0,
                [0.770_610_5, 0.394_149_57, 0.500_804_9],
                f32::INFINITY,
            ),
            1,
            1.040_561_2,
        ),
        (
            ray(
                [-267.110_17, 2_551.986_8, 1_535.250_6],
                0.0,
                [-0.743_540_4, 0.228_775_88, -0.628_338_4],
                749.405_94,
            ),
            2,
            0.057_626_675,
        ),
    ]
}

fn check(what: &str, got_prim: u32, got_t: f32, want_prim: u32, want_t: f32) {
    assert_eq!(got_prim, want_prim, "{what}: wrong triangle (t {got_t})");
    let rel = ((got_t - want_t) / want_t).abs();
    assert!(
        rel < 1e-4,
        "{what}: t {got_t} is {rel:e} away from the exact {want_t}"
    );
}

#[test]
fn the_f32_inputs_are_the_reported_ones() {
    // The literals above are the shortest decimals of the reported f32 values.
    let r = &rays()[0].0;
    assert_eq!(r.origin.x as f64, 1088.7493896484375);
    assert_eq!(r.direction().z as f64, 0.09524916857481003);
    assert_eq!(rays()[2].0.tmax as f64, 749.4059448242188);
}

#[test]
fn every_kernel_hits_the_flat_triangles() {
    let tris = scene();
    for (i, (ray, prim, t)) in rays().into_iter().enumerate() {
        let b = brute::closest_hit(&tris, &ray);
        check(&format!("ray {i} brute force"), b.prim, b.t, prim, t);
        assert!(brute::any_hit(&tris, &ray), "ray {i}: brute-force any hit");
        for e in registry::entries() {
            let input = BuildInput::new(&tris, CostModel::default()).unwrap();
            let bvh = (e.make)().build(&input).unwrap();
            let name = e.name;
            let s = scalar::closest_hit(&bvh, &tris, &ray, &mut NoStats);
            check(&format!("ray {i} {name} scalar"), s.prim, s.t, prim, t);
            assert!(scalar::any_hit(&bvh, &tris, &ray, &mut NoStats));
            let b4 = Bvh4::from_bvh(&bvh, &tris);
            let b8 = Bvh8::from_bvh(&bvh, &tris);
            for backend in Backend::ALL.into_iter().filter(|b| b.is_available()) {
                let h = b4.closest_hit_with(backend, &ray, &mut NoStats);
                check(
                    &format!("ray {i} {name} bvh4 {backend}"),
                    h.prim,
                    h.t,
                    prim,
                    t,
                );
                assert!(b4.any_hit_with(backend, &ray, &mut NoStats));
                let h = b8.closest_hit_with(backend, &ray, &mut NoStats);
                check(
                    &format!("ray {i} {name} bvh8 {backend}"),
                    h.prim,
                    h.t,
                    prim,
                    t,
                );
                assert!(b8.any_hit_with(backend, &ray, &mut NoStats));
            }
        }
    }
}

#[test]
fn moved_to_the_origin_it_still_hits() {
    // The issue noted that the same triangle moved near the origin still missed.
    let off = Vec3A::new(1088.0, 503.0, 608.0);
    let tris: Vec<Triangle> = scene()
        .iter()
        .map(|t| Triangle::new(t.v[0] - off, t.v[1] - off, t.v[2] - off))
        .collect();
    let (ray, _, _) = rays()[0];
    let ray = Ray::new(ray.origin - off, ray.direction(), ray.tmin, ray.tmax);
    let h = brute::closest_hit(&tris, &ray);
    assert_eq!(h.prim, 0, "moved triangle 0 must still be hit: {h:?}");
}
