//! The façade's closest-point queries: every quality level (spatial splits included) answers
//! like a brute-force scan bit for bit, the batch form equals one query at a time whatever the
//! thread count, and the answers stay exact after a refit and a save/load.

use sahara::{Accel, PointHit, Quality, Triangle, Vec3A};
use sahara_fixtures::{rays::point_in, soups::mixed_soup};
use sahara_geom::rng::Pcg32;
use sahara_traverse::brute;

fn scene() -> Vec<Triangle> {
    let mut tris = mixed_soup(1500, 5);
    // Duplicates and a degenerate triangle: ties by index, never the degenerate one.
    tris.extend_from_within(..20);
    tris.push(Triangle::new(Vec3A::ZERO, Vec3A::ZERO, Vec3A::X));
    tris
}

/// Random points around the soup, vertices and points on the triangles.
fn points(tris: &[Triangle], n: usize) -> Vec<Vec3A> {
    let mut rng = Pcg32::new(17, 2);
    let bounds = sahara::Aabb::new(Vec3A::splat(-14.0), Vec3A::splat(14.0));
    (0..n)
        .map(|i| {
            let t = &tris[rng.below(tris.len() as u32) as usize];
            match i % 3 {
                0 => point_in(&bounds, &mut rng),
                1 => t.v[rng.below(3) as usize],
                _ => t.point(0.25, 0.5),
            }
        })
        .collect()
}

type Bits = Option<(u32, [u32; 3], u64, u32, u32, [u32; 3])>;

fn bits(h: &Option<PointHit>) -> Bits {
    h.map(|h| {
        assert_eq!(h.distance, h.distance_squared.sqrt() as f32);
        (
            h.prim,
            h.point.to_array().map(f32::to_bits),
            h.distance_squared.to_bits(),
            h.u.to_bits(),
            h.v.to_bits(),
            h.normal.to_array().map(f32::to_bits),
        )
    })
}

/// The brute-force answer in the façade's record.
fn brute(tris: &[Triangle], p: Vec3A, max_distance: f32) -> Option<PointHit> {
    brute::closest_point(tris, p, max_distance).map(|h| PointHit {
        prim: h.prim,
        point: h.point,
        distance: h.distance(),
        distance_squared: h.distance_squared,
        u: h.u,
        v: h.v,
        normal: tris[h.prim as usize].normal(),
    })
}

fn check(accel: &Accel, pts: &[Vec3A], label: &str) {
    for m in [f32::INFINITY, 0.5] {
        let batch = accel.closest_points(pts, m);
        for (&p, got) in pts.iter().zip(&batch) {
            let want = bits(&brute(accel.triangles(), p, m));
            assert_eq!(bits(got), want, "{label} batch {p} {m}");
            assert_eq!(bits(&accel.closest_point(p, m)), want, "{label} {p} {m}");
        }
    }
}

#[test]
fn every_quality_level_equals_brute_force() {
    let tris = scene();
    let pts = points(&tris, 1_200);
    for q in Quality::ALL {
        let accel = Accel::build(&tris, q).unwrap();
        check(&accel, &pts, q.name());
    }
}

#[test]
fn batches_do_not_depend_on_the_thread_count() {
    let tris = scene();
    let accel = Accel::build(&tris, Quality::Medium).unwrap();
    let pts = points(&tris, 3_000);
    let run = |threads: usize| {
        rayon::ThreadPoolBuilder::new()
            .num_threads(threads)
            .build()
            .unwrap()
            .install(|| accel.closest_points(&pts, f32::INFINITY))
    };
    let one: Vec<Bits> = run(1).iter().map(bits).collect();
    let three: Vec<Bits> = run(3).iter().map(bits).collect();
    assert_eq!(one, three);
    assert!(one.iter().all(|h| h.is_some()));
}

#[test]
fn exact_after_refit_and_after_load() {
    let tris = scene();
    let pts = points(&tris, 600);
    let mut accel = Accel::build(&tris, Quality::High).unwrap();
    let moved: Vec<Triangle> = tris
        .iter()
        .enumerate()
        .map(|(i, t)| {
            let d = Vec3A::new((i % 7) as f32 * 0.3, 0.0, -((i % 3) as f32));
            Triangle::new(t.v[0] + d, t.v[1] + d, t.v[2] + d)
        })
        .collect();
    accel.refit(&moved).unwrap();
    check(&accel, &pts, "refit");
    let mut bytes = Vec::new();
    accel.save(&mut bytes).unwrap();
    let loaded = Accel::load(&mut bytes.as_slice()).unwrap();
    check(&loaded, &pts, "loaded");
}

#[test]
fn bad_input_and_empty_scenes_give_none() {
    let accel = Accel::build(&scene(), Quality::Fast).unwrap();
    for p in [Vec3A::NAN, Vec3A::new(0.0, f32::INFINITY, 0.0)] {
        assert_eq!(accel.closest_point(p, f32::INFINITY), None);
    }
    for m in [-1.0, f32::NAN] {
        assert_eq!(accel.closest_point(Vec3A::ZERO, m), None);
    }
    let empty = Accel::build(&[], Quality::Fast).unwrap();
    assert_eq!(empty.closest_point(Vec3A::ZERO, f32::INFINITY), None);
    assert_eq!(
        empty.closest_points(&[Vec3A::ONE; 100], 1.0),
        vec![None; 100]
    );
    assert!(accel.closest_points(&[], 1.0).is_empty());
}
