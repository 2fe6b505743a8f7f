//! Every unsafe path of the traversal crate on inputs small enough for Miri (`cargo xtask miri`
//! runs this file under Miri, once with SSE2 and once with AVX2 and FMA enabled at compile
//! time; it also runs in the ordinary suite, in a fraction of a second).
//!
//! What it reaches: every wide kernel (portable, SSE2, AVX2 where the build enables it) at both
//! widths and both precisions, closest and any hit, with `tmin >= 0` and `tmin < 0` (the two
//! `NEG` instantiations), the inline stack and the heap stack (a comb deeper than the inline
//! stack), the serial and the parallel collapse (under Miri the parallel thresholds are lowered
//! so that small trees take them), huge-page arrays (under Miri the threshold is lowered too, and
//! `madvise` is skipped: Miri cannot call it), user primitives over boxes, filtered triangles and
//! instances. Every answer is compared with brute force, so a wrong read that Miri lets pass
//! still shows as a wrong answer.

#[allow(unused_imports)]
mod wide_common;

use glam::{Affine3A, Vec3};
use sahara_bvh::Bvh;
use sahara_fixtures::soups::mixed_soup;
use sahara_geom::{Aabb, Ray, Triangle, Vec3A};
use sahara_traverse::instance::{Instance, InstanceSet};
use sahara_traverse::{brute, custom, Bvh4, Bvh8, Hit, NoStats, Precision, WideBvh};
use wide_common::*;

fn scene_box(tris: &[Triangle]) -> Aabb {
    tris.iter().fold(Aabb::EMPTY, |b, t| b.union(&t.bounds()))
}

/// Rays with `tmin >= 0` and a few with `tmin < 0` (the other kernel instantiation).
fn rays(tris: &[Triangle], n: usize, seed: u64) -> Vec<Ray> {
    let mut v = random_rays(&scene_box(tris), n, seed);
    for r in v.iter_mut().step_by(3) {
        r.tmin = -0.25;
    }
    v
}

fn check<const W: usize>(wide: &WideBvh<W>, tris: &[Triangle], rays: &[Ray]) {
    for p in Precision::ALL {
        let wide = wide.clone().with_precision(p);
        for ray in rays {
            let want = brute::closest_hit_at(tris, ray, p);
            let want_any = brute::any_hit_at(tris, ray, p);
            for b in backends() {
                let got = wide.closest_hit_with(b, ray, &mut NoStats);
                assert_eq!(bits(&got), bits(&want), "bvh{W} {b} {p} {ray:?}");
                assert_eq!(wide.any_hit_with(b, ray, &mut NoStats), want_any);
            }
        }
    }
}

fn check_both(bvh: &Bvh, tris: &[Triangle], rays: &[Ray]) {
    check(&Bvh4::from_bvh(bvh, tris), tris, rays);
    check(&Bvh8::from_bvh(bvh, tris), tris, rays);
}

#[test]
fn miri_kernels_on_a_soup() {
    let mut tris = mixed_soup(48, 5);
    // A degenerate triangle (a NaN lane in its packet) and a duplicate (a tie).
    tris.push(Triangle::new(Vec3A::ZERO, Vec3A::X, Vec3A::X * 2.0));
    tris.push(tris[3]);
    check_both(&median_bvh(&tris, 3), &tris, &rays(&tris, 12, 1));
    check_both(&spatial_bvh(&tris, 2), &tris, &rays(&tris, 12, 2));
}

#[test]
fn miri_heap_stack_of_a_comb() {
    // Deeper than the inline stack (256 entries): the heap stack and the out-of-line entry
    // points.
    let tris = mixed_soup(300, 7);
    check(
        &Bvh8::from_bvh(&comb_bvh(&tris), &tris),
        &tris,
        &rays(&tris, 4, 3),
    );
}

#[test]
fn miri_collapse_serial_and_parallel() {
    // Under Miri the parallel thresholds of the collapse are 16 nodes and references, so this
    // tree is planned and written in parallel; outside Miri it is not (the bits must not tell).
    let tris = mixed_soup(200, 9);
    let bvh = median_bvh(&tris, 2);
    let a = Bvh8::from_bvh(&bvh, &tris);
    let b = rayon::ThreadPoolBuilder::new()
        .num_threads(1)
        .build()
        .unwrap()
        .install(|| Bvh8::from_bvh(&bvh, &tris));
    assert_eq!(a.fingerprint(), b.fingerprint());
    check(&a, &tris, &rays(&tris, 6, 4));
}

#[test]
fn miri_user_primitives_filters_and_instances() {
    let tris = mixed_soup(40, 11);
    let boxes: Vec<Aabb> = tris.iter().map(Triangle::bounds).collect();
    let bvh = median_bvh(&tris, 2);
    let wide = Bvh8::from_boxes(&bvh, &boxes);
    let tri_test = |ray: &Ray, prim: u32, tmin: f32, tmax: f32| {
        sahara_geom::intersect::intersect_triangle(
            &ray.watertight(),
            &tris[prim as usize],
            tmin,
            tmax,
        )
        .map(|h| (h.t, ()))
    };
    let keep = |h: &Hit| !h.prim.is_multiple_of(3);
    let tri_wide = Bvh8::from_bvh(&bvh, &tris);
    for ray in rays(&tris, 9, 5) {
        let want = custom::brute_closest_hit(&boxes, &ray, tri_test);
        assert_eq!(
            wide.closest_hit_custom(&boxes, &ray, tri_test, &mut NoStats),
            want
        );
        assert_eq!(
            wide.any_hit_custom(&boxes, &ray, tri_test, &mut NoStats),
            want.is_some()
        );
        let want = custom::brute_closest_hit_filtered(&tris, &ray, keep);
        assert_eq!(
            bits(&tri_wide.closest_hit_filtered(&ray, keep, &mut NoStats)),
            bits(&want)
        );
    }
    // Two instances of the soup, one shifted along z.
    let blas = Bvh8::from_bvh(&bvh, &tris);
    let instances = vec![
        Instance {
            blas: 0,
            transform: Affine3A::IDENTITY,
        },
        Instance {
            blas: 0,
            transform: Affine3A::from_translation(Vec3::new(0.0, 0.0, 3.0)),
        },
    ];
    let top = |b: &[Aabb]| Bvh {
        nodes: vec![
            sahara_bvh::Node::inner(&b[0].union(&b[1]), 2),
            sahara_bvh::Node::leaf(&b[0], 0, 1),
            sahara_bvh::Node::leaf(&b[1], 1, 1),
        ],
        prim_indices: vec![0, 1],
        spatial_splits: false,
        ref_cuts: None,
    };
    let set = InstanceSet::new(vec![blas], instances, top).unwrap();
    for ray in rays(&tris, 6, 6) {
        let got = set.closest_hit(&ray, &mut NoStats);
        assert_eq!(
            got,
            set.brute_closest_hit(&ray, |_, r| brute::closest_hit(&tris, r))
        );
        assert_eq!(
            set.any_hit(&ray, &mut NoStats),
            set.brute_any_hit(&ray, |_, r| brute::any_hit(&tris, r))
        );
    }
}
