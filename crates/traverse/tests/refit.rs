//! Refitting the binary tree and the wide layouts: unchanged primitives give the same tree bit
//! for bit, spatial-split trees included (their references are clipped again by the recorded
//! cuts); after the vertices move, the refitted trees validate and trace exactly as brute
//! force on every layout and backend, also after large motion that takes triangles out of
//! their references' split regions; spatial-split trees without cut records stay correct;
//! bad input is a typed error that leaves the tree unchanged.

#[allow(unused_imports)]
mod wide_common;

use sahara_builders::{registry, BuildInput, CostModel};
use sahara_bvh::{Bvh, RefitError};
use sahara_fixtures::meshes::mesh_like;
use sahara_fixtures::soups::{exploded, mixed_soup};
use sahara_geom::{rng::Pcg32, Aabb, Ray, Triangle, Vec3A};
use sahara_traverse::{brute, custom, scalar, Bvh4, Bvh8, NoStats, WideBvh};
use wide_common::{backends, bits, segment_rays};

fn build(name: &str, tris: &[Triangle]) -> Bvh {
    let input = BuildInput::new(tris, CostModel::default()).unwrap();
    registry::by_name(name).unwrap().build(&input).unwrap()
}

/// Every vertex moved by up to `amp` per axis (vertices shared between triangles move
/// together: the displacement is a function of the position).
fn jitter(tris: &[Triangle], amp: f32, seed: u64) -> Vec<Triangle> {
    let d = |p: Vec3A| {
        let h = |k: u32| {
            let x = (p.x.to_bits() ^ p.y.to_bits().rotate_left(11) ^ p.z.to_bits().rotate_left(22))
                .wrapping_mul(0x9e37_79b9)
                ^ (seed as u32).wrapping_add(k).wrapping_mul(0x85eb_ca6b);
            let mut r = Pcg32::new(x as u64, k as u64);
            r.range_f32(-amp, amp)
        };
        p + Vec3A::new(h(1), h(2), h(3))
    };
    tris.iter()
        .map(|t| Triangle::new(d(t.v[0]), d(t.v[1]), d(t.v[2])))
        .collect()
}

fn rays(bounds: &Aabb, n: usize, seed: u64) -> Vec<Ray> {
    segment_rays(bounds, n, seed, |i, o, e| {
        let tmax = if i % 2 == 0 { 1.0 } else { f32::INFINITY };
        Ray::new(o, e - o, 0.0, tmax)
    })
}

fn check_traces<const W: usize>(wide: &WideBvh<W>, bvh: &Bvh, tris: &[Triangle], rays: &[Ray]) {
    for ray in rays {
        let want = brute::closest_hit(tris, ray);
        assert_eq!(
            bits(&scalar::closest_hit(bvh, tris, ray, &mut NoStats)),
            bits(&want)
        );
        assert_eq!(scalar::any_hit(bvh, tris, ray, &mut NoStats), want.is_hit());
        for b in backends() {
            assert_eq!(
                bits(&wide.closest_hit_with(b, ray, &mut NoStats)),
                bits(&want),
                "bvh{W} {b} {ray:?}"
            );
            assert_eq!(wide.any_hit_with(b, ray, &mut NoStats), want.is_hit());
        }
    }
}

/// The 8- and 4-wide trees of `bvh` refitted to the unmoved `tris` are unchanged, bit for bit.
fn wide_refits_are_identities(bvh: &Bvh, tris: &[Triangle], name: &str) {
    let w8 = Bvh8::from_bvh(bvh, tris);
    let mut r8 = w8.clone();
    r8.refit_triangles(tris).unwrap();
    assert_eq!(r8.fingerprint(), w8.fingerprint(), "{name} bvh8");
    let w4 = Bvh4::from_bvh(bvh, tris);
    let mut r4 = w4.clone();
    r4.refit_triangles(tris).unwrap();
    assert_eq!(r4.fingerprint(), w4.fingerprint(), "{name} bvh4");
}

#[test]
fn refit_of_unchanged_triangles_is_the_identity() {
    let tris = mixed_soup(4_000, 3);
    for name in ["binned", "sweep", "tsah-binned"] {
        let bvh = build(name, &tris);
        let mut again = bvh.clone();
        again.refit_triangles(&tris).unwrap();
        assert_eq!(again.fingerprint(), bvh.fingerprint(), "{name}");
        let boxes: Vec<Aabb> = tris.iter().map(Triangle::bounds).collect();
        again.refit(&boxes).unwrap();
        assert_eq!(again.fingerprint(), bvh.fingerprint(), "{name}");
        wide_refits_are_identities(&bvh, &tris, name);
        // Boxes-only trees too.
        let b8 = Bvh8::from_boxes(&bvh, &boxes);
        let mut rb = b8.clone();
        rb.refit_boxes(&boxes).unwrap();
        assert_eq!(rb.fingerprint(), b8.fingerprint(), "{name} bvh8 over boxes");
    }
}

#[test]
fn refitted_trees_trace_like_brute_force_after_motion() {
    let tris = mesh_like(40, 4);
    let bounds = tris.iter().fold(Aabb::EMPTY, |b, t| b.union(&t.bounds()));
    for name in ["binned", "sbvh"] {
        let bvh = build(name, &tris);
        let (mut b2, mut w8, mut w4) = (
            bvh.clone(),
            Bvh8::from_bvh(&bvh, &tris),
            Bvh4::from_bvh(&bvh, &tris),
        );
        for (frame, amp) in [0.002f32, 0.02, 0.2].into_iter().enumerate() {
            let moved = jitter(&tris, amp, frame as u64);
            b2.refit_triangles(&moved).unwrap();
            b2.validate(&moved).unwrap();
            w8.refit_triangles(&moved).unwrap();
            w4.refit_triangles(&moved).unwrap();
            let rays = rays(&bounds, 600, frame as u64);
            check_traces(&w8, &b2, &moved, &rays);
            check_traces(&w4, &b2, &moved, &rays[..200]);
        }
    }
}

/// Every registered preset with spatial splits (clipped references).
fn spatial_builders() -> Vec<&'static str> {
    registry::entries()
        .into_iter()
        .filter(|e| e.spatial)
        .map(|e| e.name)
        .collect()
}

#[test]
fn refit_of_unchanged_triangles_keeps_every_spatial_builders_clipped_boxes() {
    let tris = mixed_soup(1_500, 4);
    let cost = CostModel::default();
    let names = spatial_builders();
    assert!(names.len() >= 5, "{names:?}");
    for name in names {
        let bvh = build(name, &tris);
        assert!(
            bvh.spatial_splits && bvh.prim_indices.len() > tris.len(),
            "{name}"
        );
        let cuts = bvh
            .ref_cuts
            .as_ref()
            .expect("spatial builders record their cuts");
        assert!(cuts.cut_count() > 0, "{name}");
        bvh.validate(&tris).unwrap();
        let mut again = bvh.clone();
        again.refit_triangles(&tris).unwrap();
        assert_eq!(again.fingerprint(), bvh.fingerprint(), "{name}");
        assert_eq!(
            sahara_metrics::sah(&again, &cost),
            sahara_metrics::sah(&bvh, &cost)
        );
        assert!(Bvh8::from_bvh(&bvh, &tris).cut_record_bytes() > 0);
        wide_refits_are_identities(&bvh, &tris, name);
    }
}

#[test]
fn spatial_split_trees_trace_like_brute_force_after_large_motion() {
    let tris = mixed_soup(1_500, 5);
    let bounds = tris.iter().fold(Aabb::EMPTY, |b, t| b.union(&t.bounds()));
    let size = bounds.extent().max_element();
    for name in spatial_builders() {
        let bvh = build(name, &tris);
        let (mut b2, mut w8, mut w4) = (
            bvh.clone(),
            Bvh8::from_bvh(&bvh, &tris),
            Bvh4::from_bvh(&bvh, &tris),
        );
        let mut vacant = 0;
        for frame in 0..3u64 {
            let amp = [0.01, 0.1, 0.3][frame as usize] * size;
            let moved = if frame == 1 {
                jitter(&tris, amp, frame)
            } else {
                exploded(&tris, amp, frame)
            };
            b2.refit_triangles(&moved).unwrap();
            b2.validate(&moved).unwrap();
            w8.refit_triangles(&moved).unwrap();
            w4.refit_triangles(&moved).unwrap();
            // References whose triangle left its split region: empty boxes.
            let cuts = b2.ref_cuts.as_ref().unwrap();
            let boxes: Vec<Aabb> = (0..cuts.len())
                .map(|i| cuts.replay(i, &moved[b2.prim_indices[i] as usize]))
                .collect();
            vacant += boxes.iter().filter(|b| b.is_empty()).count();
            // The split regions of a triangle's references cover space: each moved vertex
            // lies in one of its triangle's reference boxes.
            let mut covered = vec![[false; 3]; moved.len()];
            for (b, &p) in boxes.iter().zip(&b2.prim_indices) {
                for (k, v) in moved[p as usize].v.iter().enumerate() {
                    covered[p as usize][k] |= b.contains_aabb(&Aabb::new(*v, *v));
                }
            }
            assert!(covered.iter().all(|c| c.iter().all(|&x| x)), "{name}");
            let all = moved.iter().fold(Aabb::EMPTY, |b, t| b.union(&t.bounds()));
            let rays = rays(&all, 300, frame);
            check_traces(&w8, &b2, &moved, &rays);
            check_traces(&w4, &b2, &moved, &rays[..100]);
        }
        assert!(vacant > 0, "{name}: no reference left its region");
    }
}

#[test]
fn spatial_split_trees_without_cut_records_refit_looser_but_correct() {
    // As a tree loaded from a version-1 file: no cut records.
    let tris = mixed_soup(2_000, 4);
    let mut bvh = build("sbvh", &tris);
    bvh.ref_cuts = None;
    assert!(bvh.spatial_splits && bvh.prim_indices.len() > tris.len());
    let mut r = bvh.clone();
    r.refit_triangles(&tris).unwrap();
    r.validate(&tris).unwrap();
    let cost = CostModel::default();
    let (before, after) = (
        sahara_metrics::sah(&bvh, &cost),
        sahara_metrics::sah(&r, &cost),
    );
    assert!(
        after > before,
        "refit used whole triangle boxes: {after} > {before}"
    );
    // Every refitted leaf contains its triangles' whole bounds.
    for n in r.nodes.iter().filter(|n| n.is_leaf()) {
        for &p in r.leaf_prims(n) {
            assert!(n.bounds().contains_aabb(&tris[p as usize].bounds()));
        }
    }
    let bounds = bvh.bounds();
    let rays = rays(&bounds, 400, 1);
    let mut w = Bvh8::from_bvh(&bvh, &tris);
    assert_eq!(w.cut_record_bytes(), 0);
    w.refit_triangles(&tris).unwrap();
    check_traces(&w, &r, &tris, &rays);
}

#[test]
fn refit_user_primitive_boxes() {
    let mut rng = Pcg32::new(5, 5);
    let mut centres: Vec<Vec3A> = (0..2_000)
        .map(|_| {
            Vec3A::new(
                rng.range_f32(-5.0, 5.0),
                rng.range_f32(-5.0, 5.0),
                rng.range_f32(-5.0, 5.0),
            )
        })
        .collect();
    let r = 0.1f32;
    let boxes = |c: &[Vec3A]| {
        c.iter()
            .map(|&c| Aabb::new(c - r, c + r))
            .collect::<Vec<_>>()
    };
    let b0 = boxes(&centres);
    let input = BuildInput::from_boxes(&b0, CostModel::default()).unwrap();
    let mut bvh = registry::by_name("binned").unwrap().build(&input).unwrap();
    let mut wide = Bvh8::from_boxes(&bvh, &b0);
    for c in centres.iter_mut() {
        *c += Vec3A::new(rng.range_f32(-0.5, 0.5), 0.0, rng.range_f32(-0.5, 0.5));
    }
    let b1 = boxes(&centres);
    bvh.refit(&b1).unwrap();
    wide.refit_boxes(&b1).unwrap();
    // Cubes as user primitives: the entry distance of the box.
    let cube = |ray: &Ray, p: u32, tmin: f32, tmax: f32| {
        let t = sahara_geom::intersect::intersect_aabb(
            ray.origin,
            ray.inv_direction(),
            tmin,
            tmax,
            &b1[p as usize],
        )?;
        Some((t, ()))
    };
    let all = b1.iter().fold(Aabb::EMPTY, |a, b| a.union(b));
    for ray in rays(&all, 1_000, 8) {
        let want = custom::brute_closest_hit(&b1, &ray, cube).map(|h| (h.t.to_bits(), h.prim));
        let got = custom::closest_hit(&bvh, &b1, &ray, cube, &mut NoStats)
            .map(|h| (h.t.to_bits(), h.prim));
        assert_eq!(got, want);
        let got = wide
            .closest_hit_custom(&b1, &ray, cube, &mut NoStats)
            .map(|h| (h.t.to_bits(), h.prim));
        assert_eq!(got, want);
    }
}

#[test]
fn bad_refit_input_is_a_typed_error_and_changes_nothing() {
    let tris = mixed_soup(500, 1);
    let bvh = build("binned", &tris);
    let mut t = bvh.clone();
    let e = t.refit_triangles(&tris[..400]).unwrap_err();
    assert!(
        matches!(e, RefitError::MissingPrimitive { len: 400, .. }),
        "{e:?}"
    );
    let mut nan = tris.clone();
    nan[7].v[1].x = f32::NAN;
    assert_eq!(
        t.refit_triangles(&nan).unwrap_err(),
        RefitError::InvalidBox { prim: 7 }
    );
    assert_eq!(t.fingerprint(), bvh.fingerprint());
    let mut w = Bvh8::from_bvh(&bvh, &tris);
    let f = w.fingerprint();
    assert!(matches!(
        w.refit_triangles(&tris[..400]),
        Err(RefitError::MissingPrimitive { .. })
    ));
    assert_eq!(
        w.refit_triangles(&nan).unwrap_err(),
        RefitError::InvalidBox { prim: 7 }
    );
    assert_eq!(w.fingerprint(), f);
    // A broken tree.
    let mut broken = bvh.clone();
    broken.nodes[0].index = 10_000_000;
    assert!(matches!(
        broken.refit_triangles(&tris),
        Err(RefitError::Structure(_))
    ));
}
