//! The wide layouts (`Bvh4`, `Bvh8`) agree ray by ray with the scalar reference, with every
//! backend (the SIMD paths and the portable fallback), on random soups, a closed sphere in a
//! closed box, spatial-split trees and adversarial rays.

mod wide_common;

use sahara_bvh::Bvh;
use sahara_fixtures::soups::mixed_soup;
use sahara_geom::intersect::{intersect_ray_triangle, intersect_ray_triangle_fast, TriangleHit};
use sahara_geom::{rng::Pcg32, Aabb, Ray, Triangle, Vec3A};
use sahara_traverse::{
    brute, scalar, simd_backend, Backend, Bvh4, Bvh8, Hit, HitLocation, NoStats, Precision,
    WideBvh, WorkCounters,
};
use wide_common::*;

/// The closest hit of `wide` with backend `b`, after checking that the location it recorded
/// names the hit triangle: `tris[hit.prim]` bit for bit (`None` for a miss).
fn located_hit<const W: usize>(wide: &WideBvh<W>, b: Backend, tris: &[Triangle], ray: &Ray) -> Hit {
    let mut at = HitLocation::default();
    let hit = wide.closest_hit_with(b, ray, &mut at);
    let vertex_bits = |t: &Triangle| t.v.map(|p| p.to_array().map(f32::to_bits));
    let located = wide.located_triangle(&at).map(|t| vertex_bits(&t));
    let want = hit.is_hit().then(|| vertex_bits(&tris[hit.prim as usize]));
    assert_eq!(
        located, want,
        "bvh{W} {b}: the located triangle of {hit:?} for {ray:?}"
    );
    hit
}

/// Checks every ray against the reference with every backend of `wide`; returns the number
/// of closest hits found.
///
/// The scalar reference must return exactly the brute-force hit (t, prim, u, v bit for bit;
/// since the hit acceptance rule `accept_hit` and the widened box interval, there are no
/// corner cases left), and every wide kernel exactly the same; with `Precision::Fast`, every
/// wide kernel exactly the hit of the fast brute-force twin.
fn check_wide<const W: usize>(
    wide: &WideBvh<W>,
    bvh: &Bvh,
    tris: &[Triangle],
    rays: &[Ray],
    what: &str,
) -> usize {
    assert_eq!(wide.precision(), Precision::Exact);
    let fast = wide.clone().with_precision(Precision::Fast);
    let mut hits = 0;
    for (i, ray) in rays.iter().enumerate() {
        let want = brute::closest_hit(tris, ray);
        let want_any = brute::any_hit(tris, ray);
        let reference = scalar::closest_hit(bvh, tris, ray, &mut NoStats);
        assert_eq!(
            bits(&reference),
            bits(&want),
            "{what}: scalar closest hit of ray {i} {ray:?}: got {reference:?}, brute force {want:?}",
        );
        assert_eq!(
            scalar::any_hit(bvh, tris, ray, &mut NoStats),
            want_any,
            "{what}: scalar any hit of ray {i} {ray:?}",
        );
        hits += want.is_hit() as usize;
        // Every backend of `tree` answers as `want` and `want_any` (`precision` names the test).
        let backends_agree = |tree: &WideBvh<W>, want: Hit, want_any: bool, precision: &str| {
            for b in backends() {
                let got = located_hit(tree, b, tris, ray);
                assert_eq!(
                    bits(&got),
                    bits(&want),
                    "{what}: bvh{W} {b} {precision}closest hit of ray {i} {ray:?}: got {got:?}, want {want:?}",
                );
                let got_any = tree.any_hit_with(b, ray, &mut NoStats);
                assert_eq!(
                    got_any, want_any,
                    "{what}: bvh{W} {b} {precision}any hit of ray {i} {ray:?}: got {got_any}, want {want_any}",
                );
            }
        };
        backends_agree(wide, want, want_any, "");
        // The fast precision against its own twin.
        let want = brute::closest_hit_at(tris, ray, Precision::Fast);
        let want_any = brute::any_hit_at(tris, ray, Precision::Fast);
        backends_agree(&fast, want, want_any, "fast ");
    }
    hits
}

fn check_all(bvh: &Bvh, tris: &[Triangle], rays: &[Ray], what: &str) -> usize {
    let w4 = Bvh4::from_bvh(bvh, tris);
    let w8 = Bvh8::from_bvh(bvh, tris);
    check_structure(&w4, tris, bvh);
    check_structure(&w8, tris, bvh);
    let h4 = check_wide(&w4, bvh, tris, rays, what);
    let h8 = check_wide(&w8, bvh, tris, rays, what);
    assert_eq!(h4, h8);
    h4
}

/// Every triangle is referenced (exactly once without spatial splits) and the tree fits.
fn check_structure<const W: usize>(wide: &WideBvh<W>, tris: &[Triangle], bvh: &Bvh) {
    let refs = wide.reference_count();
    if bvh.spatial_splits {
        assert!(refs >= tris.len());
    } else {
        assert_eq!(refs, tris.len());
    }
    assert!(wide.packet_count() * 4 >= refs);
    for n in wide.nodes() {
        assert!((2..=W).contains(&n.child_count()) || wide.node_count() == 1);
        for s in 0..n.child_count() {
            let b = n.child_bounds(s);
            assert!(b.is_finite() && !b.is_empty());
        }
    }
    if !tris.is_empty() {
        assert_eq!(wide.bounds(), bvh.nodes[0].bounds());
    }
}

fn scene_box(tris: &[Triangle]) -> Aabb {
    tris.iter().fold(Aabb::EMPTY, |b, t| b.union(&t.bounds()))
}

#[test]
fn backend_names() {
    let best = Backend::best();
    assert!(best.is_available());
    assert_eq!(simd_backend(), best.name());
    assert!(Backend::Portable.is_available());
    #[cfg(target_arch = "x86_64")]
    assert!(Backend::Sse2.is_available());
    let tris = mixed_soup(50, 1);
    let w = Bvh8::from_bvh(&median_bvh(&tris, 2), &tris);
    assert_eq!(w.backend(), best);
    eprintln!("SIMD backend: {}", simd_backend());
}

#[test]
fn empty_and_single_leaf_trees() {
    let ray = Ray::new(Vec3A::new(0.0, 0.0, -5.0), Vec3A::Z, 0.0, f32::INFINITY);
    let empty = Bvh::empty();
    for b in Backend::ALL {
        assert_eq!(
            Bvh4::from_bvh(&empty, &[]).closest_hit_with(b, &ray, &mut NoStats),
            Hit::MISS
        );
        assert!(!Bvh8::from_bvh(&empty, &[]).any_hit_with(b, &ray, &mut NoStats));
    }
    // One leaf holding everything (more than 32 triangles: becomes a small subtree).
    for n in [1, 3, 4, 5, 33, 100, 300] {
        let tris = mixed_soup(n, n as u64);
        let bvh = median_bvh(&tris, usize::MAX);
        assert_eq!(bvh.nodes.len(), 1);
        let rays = random_rays(&scene_box(&tris), 300, 5);
        check_all(&bvh, &tris, &rays, &format!("single leaf of {n}"));
    }
}

#[test]
fn random_soups_agree() {
    for (n, seed) in [(300, 1), (3000, 2)] {
        let tris = mixed_soup(n, seed);
        let b = scene_box(&tris);
        let rays = random_rays(&b, 3000, seed);
        for leaf in [1, 2, 4, 7, 40] {
            let bvh = median_bvh(&tris, leaf);
            bvh.validate(&tris).unwrap();
            let hits = check_all(&bvh, &tris, &rays, &format!("soup {n}, median leaf {leaf}"));
            assert!(
                hits > rays.len() / 20,
                "too few hits to be a meaningful test: {hits}"
            );
        }
        let bvh = sah_bvh(&tris, 8);
        bvh.validate(&tris).unwrap();
        check_all(&bvh, &tris, &rays, &format!("soup {n}, sah"));
    }
}

#[test]
fn sphere_in_box_agrees_and_is_watertight() {
    let (tris, n_sphere) = sphere_in_box(24, 40, 1.0, 2.0, 6);
    let b = scene_box(&tris);
    for bvh in [
        median_bvh(&tris, 3),
        sah_bvh(&tris, 4),
        spatial_bvh(&tris, 4),
    ] {
        bvh.validate(&tris).unwrap();
        // From inside the sphere every ray hits the sphere: no leak through shared edges.
        let inside = rays_from_inside(1.0, 4000, 3);
        check_all(&bvh, &tris, &inside, "from inside the sphere");
        let w8 = Bvh8::from_bvh(&bvh, &tris);
        let w4 = Bvh4::from_bvh(&bvh, &tris);
        for ray in &inside {
            for b in backends() {
                let h = w8.closest_hit_with(b, ray, &mut NoStats);
                assert!(
                    h.is_hit() && (h.prim as usize) < n_sphere,
                    "{ray:?} leaked: {h:?}"
                );
                assert!(w4.any_hit_with(b, ray, &mut NoStats));
            }
        }
        // From inside the box every ray hits something.
        let mut r = Pcg32::new(9, 9);
        let between: Vec<Ray> = (0..2000)
            .map(|_| {
                let o = Vec3A::new(
                    r.range_f32(-1.9, 1.9),
                    r.range_f32(-1.9, 1.9),
                    r.range_f32(-1.9, 1.9),
                );
                Ray::new(o, unit_dir(&mut r), 0.0, f32::INFINITY)
            })
            .collect();
        check_all(&bvh, &tris, &between, "inside the box");
        for ray in &between {
            assert!(
                w8.closest_hit(ray, &mut NoStats).is_hit(),
                "{ray:?} leaked out of the box"
            );
        }
        check_all(
            &bvh,
            &tris,
            &random_rays(&b, 3000, 4),
            "sphere in box, random rays",
        );
        check_all(
            &bvh,
            &tris,
            &vertex_and_edge_rays(&tris, &b, 3000, 5),
            "sphere in box, vertex/edge rays",
        );
    }
}

#[test]
fn vertex_and_edge_rays_agree() {
    let tris = mixed_soup(500, 3);
    let b = scene_box(&tris);
    let rays = vertex_and_edge_rays(&tris, &b, 6000, 6);
    for bvh in [
        median_bvh(&tris, 1),
        median_bvh(&tris, 6),
        sah_bvh(&tris, 4),
    ] {
        check_all(&bvh, &tris, &rays, "soup, vertex/edge rays");
    }
}

#[test]
fn spatial_split_trees_agree() {
    let tris = mixed_soup(800, 4);
    let b = scene_box(&tris);
    let rays = random_rays(&b, 3000, 8);
    for leaf in [1, 3, 8] {
        let bvh = spatial_bvh(&tris, leaf);
        bvh.validate(&tris).unwrap();
        let dup = bvh.prim_indices.len() as f32 / tris.len() as f32;
        assert!(
            dup > 1.2,
            "the spatial builder should duplicate references ({dup})"
        );
        check_all(&bvh, &tris, &rays, &format!("spatial, leaf {leaf}"));
        check_all(
            &bvh,
            &tris,
            &vertex_and_edge_rays(&tris, &b, 2000, 9),
            "spatial, vertex/edge rays",
        );
    }
}

#[test]
fn adversarial_rays_agree() {
    let (sphere, _) = sphere_in_box(12, 16, 1.0, 2.0, 3);
    for tris in [mixed_soup(600, 5), sphere] {
        let b = scene_box(&tris);
        for bvh in [
            median_bvh(&tris, 2),
            sah_bvh(&tris, 4),
            spatial_bvh(&tris, 4),
        ] {
            let rays = adversarial_rays(&b, 10);
            check_all(&bvh, &tris, &rays, "adversarial rays");
            let w = Bvh8::from_bvh(&bvh, &tris);
            for ray in rays.iter().filter(|r| !r.is_valid()) {
                for be in Backend::ALL {
                    assert_eq!(w.closest_hit_with(be, ray, &mut NoStats), Hit::MISS);
                    assert!(!w.any_hit_with(be, ray, &mut NoStats));
                }
            }
        }
    }
}

#[test]
fn grazing_rays_agree() {
    let (sphere, _) = sphere_in_box(16, 24, 1.0, 2.0, 4);
    for tris in [mixed_soup(600, 6), sphere] {
        for bvh in [
            median_bvh(&tris, 2),
            sah_bvh(&tris, 4),
            spatial_bvh(&tris, 4),
        ] {
            let rays = grazing_rays(&bvh, 4000, 11);
            check_all(&bvh, &tris, &rays, "grazing rays");
        }
    }
}

#[test]
fn deep_trees_use_the_heap_stack() {
    // A comb of 700 triangles: depth 700, deeper than the inline stack.
    let tris = mixed_soup(700, 7);
    let bvh = comb_bvh(&tris);
    bvh.validate(&tris).unwrap();
    let rays = random_rays(&scene_box(&tris), 500, 12);
    check_all(&bvh, &tris, &rays, "comb");
}

#[test]
fn packet_test_is_bit_exact() {
    // One triangle per tree, so each wide result is one lane of the SIMD test against the
    // scalar function, including rays through vertices and edges (zero edge functions) and
    // degenerate triangles.
    let mut r = Pcg32::new(21, 1);
    let mut tris = mixed_soup(300, 8);
    tris.push(Triangle::new(Vec3A::ZERO, Vec3A::X, Vec3A::X * 2.0)); // degenerate
    tris.push(Triangle::new(Vec3A::ZERO, Vec3A::ZERO, Vec3A::ZERO));
    tris.push(Triangle::new(Vec3A::ZERO, Vec3A::X, Vec3A::Y));
    tris.push(Triangle::new(
        Vec3A::new(1e-20, 0.0, 0.0),
        Vec3A::new(0.0, 1e-20, 0.0),
        Vec3A::new(0.0, 0.0, 1e-20),
    ));
    // Edge functions whose two products both overflow (`∞ - ∞`: NaN) next to finite ones of
    // one sign: the SIMD sign test's `minps`/`maxps` hide the NaN, and the lane must still
    // miss because its determinant, and so its distance, is NaN.
    tris.push(Triangle::new(
        Vec3A::new(1.0, 1.0, 1.0),
        Vec3A::new(1e20, 5e19, 1.0),
        Vec3A::new(5e19, 1e20, 1.0),
    ));
    for tri in &tris {
        let one = [*tri];
        let bvh = median_bvh(&one, 1);
        let (w4, w8) = (Bvh4::from_bvh(&bvh, &one), Bvh8::from_bvh(&bvh, &one));
        // The one triangle's test result as the kernels' hit.
        let as_hit = |h: Option<TriangleHit>| {
            h.map_or(Hit::MISS, |h| Hit {
                t: h.t,
                prim: 0,
                u: h.u,
                v: h.v,
            })
        };
        for k in 0..40 {
            let target = match k % 4 {
                0 => tri.v[k % 3],
                1 => (tri.v[k % 3] + tri.v[(k + 1) % 3]) * 0.5,
                2 => tri.point(r.next_f32() * 0.5, r.next_f32() * 0.5),
                _ => tri.centroid() + unit_dir(&mut r) * 0.05,
            };
            let o = target + unit_dir(&mut r) * r.range_f32(0.01, 3.0);
            let ray = Ray::new(
                o,
                target - o,
                0.0,
                if k % 7 == 0 { 0.999 } else { f32::INFINITY },
            );
            let want = as_hit(intersect_ray_triangle(&ray, tri));
            for b in backends() {
                assert_eq!(
                    bits(&w4.closest_hit_with(b, &ray, &mut NoStats)),
                    bits(&want),
                    "{tri:?} {ray:?} {b}"
                );
                assert_eq!(
                    bits(&w8.closest_hit_with(b, &ray, &mut NoStats)),
                    bits(&want),
                    "{tri:?} {ray:?} {b}"
                );
                assert_eq!(w8.any_hit_with(b, &ray, &mut NoStats), want.is_hit());
            }
            // The Möller–Trumbore lanes against the scalar fast test.
            let want = as_hit(intersect_ray_triangle_fast(&ray, tri));
            let (f4, f8) = (
                w4.clone().with_precision(Precision::Fast),
                w8.clone().with_precision(Precision::Fast),
            );
            for b in backends() {
                for (w, got) in [
                    (4, f4.closest_hit_with(b, &ray, &mut NoStats)),
                    (8, f8.closest_hit_with(b, &ray, &mut NoStats)),
                ] {
                    assert_eq!(bits(&got), bits(&want), "fast bvh{w} {tri:?} {ray:?} {b}");
                }
                assert_eq!(f8.any_hit_with(b, &ray, &mut NoStats), want.is_hit());
            }
        }
    }
}

#[test]
fn original_indices_and_shared_leaves() {
    // Triangles stacked along z (same footprint): the nearest wins; duplicates at the same
    // distance report the lowest index, whatever the leaf layout.
    let base = Triangle::new(
        Vec3A::new(-1.0, -1.0, 0.0),
        Vec3A::new(1.0, -1.0, 0.0),
        Vec3A::new(0.0, 1.0, 0.0),
    );
    let mut tris = Vec::new();
    for i in 0..50 {
        let dz = Vec3A::new(0.0, 0.0, (49 - i / 2) as f32);
        tris.push(Triangle::new(
            base.v[0] + dz,
            base.v[1] + dz,
            base.v[2] + dz,
        ));
    }
    let ray = Ray::new(Vec3A::new(0.0, 0.0, -1.0), Vec3A::Z, 0.0, f32::INFINITY);
    for leaf in [1, 3, 50] {
        let bvh = median_bvh(&tris, leaf);
        let want = brute::closest_hit(&tris, &ray);
        assert_eq!(want.prim, 48);
        for b in backends() {
            assert_eq!(
                Bvh4::from_bvh(&bvh, &tris).closest_hit_with(b, &ray, &mut NoStats),
                want
            );
            assert_eq!(
                Bvh8::from_bvh(&bvh, &tris).closest_hit_with(b, &ray, &mut NoStats),
                want
            );
        }
    }
}

#[test]
fn stats_count_work() {
    let tris = mixed_soup(2000, 9);
    let bvh = sah_bvh(&tris, 4);
    let w8 = Bvh8::from_bvh(&bvh, &tris);
    let rays = random_rays(&scene_box(&tris), 500, 13);
    for b in backends() {
        let mut total = WorkCounters::default();
        for ray in &rays {
            let mut c = WorkCounters::default();
            let h = w8.closest_hit_with(b, ray, &mut c);
            if h.is_hit() {
                assert!(c.leaves >= 1 && c.triangles >= 1);
            }
            total += c;
        }
        assert!(total.inner > 0 && total.leaves > 0 && total.triangles >= total.leaves);
        let mut again = WorkCounters::default();
        for ray in &rays {
            w8.closest_hit_with(b, ray, &mut again);
        }
        assert_eq!(again, total, "counters are deterministic");
    }
}

/// `==` on layouts is bit-for-bit equality of the tree (padding lanes' NaN vertices included,
/// which `f32` equality would call unequal), whatever the precision of the queries.
#[test]
fn layouts_compare_bit_for_bit() {
    let tris = mixed_soup(500, 7);
    let bvh = sah_bvh(&tris, 8);
    let w8 = Bvh8::from_bvh(&bvh, &tris);
    let w4 = Bvh4::from_bvh(&bvh, &tris);
    // Padding lanes hold NaN: a field-wise `f32` comparison would fail here.
    assert_eq!(w8, Bvh8::from_bvh(&bvh, &tris));
    assert_eq!(w4, w4.clone());
    assert_eq!(w8, w8.clone().with_precision(Precision::Fast));
    // One vertex one ulp away is another tree.
    let mut moved = tris.clone();
    moved[0].v[0].x = f32::from_bits(moved[0].v[0].x.to_bits() + 1);
    assert_ne!(w8, Bvh8::from_bvh(&bvh, &moved));
    // Another tree over the same triangles.
    assert_ne!(w8, Bvh8::from_bvh(&median_bvh(&tris, 2), &tris));
    assert_eq!(
        Bvh8::from_bvh(&Bvh::empty(), &[]),
        Bvh8::from_bvh(&Bvh::empty(), &[])
    );
}
