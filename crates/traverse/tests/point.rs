//! Closest-point queries: on every tree (object and spatial splits, binary, 4- and 8-wide)
//! the answer equals the brute-force twin bit for bit, on random soups, meshes with shared
//! edges, degenerate and duplicate triangles, points inside, outside and exactly on the
//! geometry, limits that cut the search off, bad query points and empty scenes; the same for
//! user primitives (spheres, with spatial splits through a clipping callback).

#[path = "../examples/spheres.rs"]
#[allow(dead_code)]
mod spheres;

use sahara_builders::{registry, BuildInput, CostModel};
use sahara_bvh::Bvh;
use sahara_fixtures::meshes::{mesh_like, sphere};
use sahara_fixtures::rays::point_in;
use sahara_fixtures::soups::{degenerate_mix, mixed_soup, named_degenerates};
use sahara_geom::{rng::Pcg32, Aabb, Triangle, Vec3A};
use sahara_traverse::{brute, point, Bvh4, Bvh8, NoStats, PointHit, WorkCounters};

/// A result as bits, for exact comparisons.
type Bits = Option<(u32, [u32; 3], u64, u32, u32)>;

fn bits(h: &Option<PointHit>) -> Bits {
    h.map(|h| {
        (
            h.prim,
            h.point.to_array().map(f32::to_bits),
            h.distance_squared.to_bits(),
            h.u.to_bits(),
            h.v.to_bits(),
        )
    })
}

/// Object splits (two builders) and spatial splits.
const BUILDERS: [&str; 3] = ["binned", "sweep", "sbvh"];

fn build(name: &str, tris: &[Triangle]) -> Bvh {
    let input = BuildInput::new(tris, CostModel::default()).unwrap();
    let bvh = registry::by_name(name).unwrap().build(&input).unwrap();
    bvh.validate(tris).unwrap();
    bvh
}

/// Query points for a scene: random points in and around its bounds, every vertex, edge
/// midpoints, centroids and random points on triangles (exactly on or rounded onto the
/// geometry), and points just off the vertices.
fn points(tris: &[Triangle], n: usize, seed: u64) -> Vec<Vec3A> {
    let mut rng = Pcg32::new(seed, 21);
    let mut out = Vec::new();
    if tris.is_empty() {
        return vec![Vec3A::ZERO, Vec3A::ONE];
    }
    let mut b = Aabb::EMPTY;
    tris.iter().for_each(|t| b.grow_aabb(&t.bounds()));
    let c = b.centroid();
    let grown = Aabb::new(c + (b.min - c) * 1.5 - 0.1, c + (b.max - c) * 1.5 + 0.1);
    for i in 0..n {
        let t = &tris[rng.below(tris.len() as u32) as usize];
        let p = match i % 6 {
            0 | 1 => point_in(&grown, &mut rng),
            2 => t.v[rng.below(3) as usize],
            3 => t.point(0.5, 0.0 + 0.5 * (rng.below(2) as f32)),
            4 => {
                let (u, v) = (rng.next_f32(), rng.next_f32());
                if u + v <= 1.0 {
                    t.point(u, v)
                } else {
                    t.point(1.0 - u, 1.0 - v)
                }
            }
            _ => t.v[0] + (t.cross().normalize_or_zero() * (rng.next_f32() - 0.5) * 0.01),
        };
        out.push(p);
    }
    out
}

/// Limits: unbounded, a few sizes relative to the scene, and zero.
fn limits(tris: &[Triangle]) -> [f32; 4] {
    let mut b = Aabb::EMPTY;
    tris.iter().for_each(|t| b.grow_aabb(&t.bounds()));
    let size = if b.is_empty() {
        1.0
    } else {
        b.extent().max_element()
    };
    [f32::INFINITY, size * 0.01, size * 0.1, 0.0]
}

/// Every tree and layout over `tris` against brute force on `n` points and every limit;
/// returns how many queries found a point.
fn check_scene(label: &str, tris: &[Triangle], n: usize, seed: u64) -> usize {
    let pts = points(tris, n, seed);
    let lims = limits(tris);
    let expected: Vec<Vec<Bits>> = lims
        .iter()
        .map(|&m| {
            pts.iter()
                .map(|&p| bits(&brute::closest_point(tris, p, m)))
                .collect()
        })
        .collect();
    for name in BUILDERS {
        let bvh = build(name, tris);
        let w4 = Bvh4::from_bvh(&bvh, tris);
        let w8 = Bvh8::from_bvh(&bvh, tris);
        for (&m, want) in lims.iter().zip(&expected) {
            for (&p, want) in pts.iter().zip(want) {
                let got = point::closest_point(&bvh, tris, p, m, &mut NoStats);
                assert_eq!(bits(&got), *want, "{label} {name} bvh2 {p} {m}");
                let got = w4.closest_point(p, m, &mut NoStats);
                assert_eq!(bits(&got), *want, "{label} {name} bvh4 {p} {m}");
                let got = w8.closest_point(p, m, &mut NoStats);
                assert_eq!(bits(&got), *want, "{label} {name} bvh8 {p} {m}");
            }
        }
    }
    expected.iter().flatten().filter(|h| h.is_some()).count()
}

#[test]
fn random_soups_equal_brute_force() {
    let tris = mixed_soup(3_000, 7);
    let found = check_scene("mixed_soup", &tris, 1_500, 1);
    assert!(found > 1_500 * 2, "{found}");
}

/// A height field (shared edges and vertices everywhere: ties between neighbours) inside a
/// few big triangles, and a closed sphere (points inside and outside).
#[test]
fn meshes_with_shared_edges_equal_brute_force() {
    check_scene("mesh_like", &mesh_like(30, 3), 1_500, 2);
    check_scene("sphere", &sphere(16, 24), 1_000, 3);
}

/// Degenerate triangles (never the answer) and exact duplicates (the lowest index wins).
#[test]
fn degenerate_and_duplicate_triangles() {
    let tris = degenerate_mix(mixed_soup(400, 9), 20, Vec3A::X * 0.3, Vec3A::Y * 0.2, 12);
    check_scene("degenerate_mix", &tris, 1_000, 4);
    for (name, tris) in named_degenerates() {
        check_scene(name, &tris, 200, 5);
    }
    // A point on a duplicated triangle: the first copy.
    let dup = tris[5];
    let first = tris.iter().position(|t| *t == dup).unwrap() as u32;
    let hit = brute::closest_point(&tris, dup.centroid(), f32::INFINITY).unwrap();
    assert_eq!(hit.prim, first);
    // Only degenerate triangles: nothing.
    let flat = [Triangle::new(Vec3A::ZERO, Vec3A::X, Vec3A::X * 2.0)];
    assert_eq!(
        brute::closest_point(&flat, Vec3A::ZERO, f32::INFINITY),
        None
    );
}

#[test]
fn exact_ties_go_to_the_lowest_index() {
    // Four triangles around the origin sharing the vertex at the origin, each queried at
    // that vertex, in every order of indices: the lowest index wins on every tree.
    let quad = |o: Vec3A| {
        [
            Triangle::new(o, o + Vec3A::X, o + Vec3A::Y),
            Triangle::new(o, o - Vec3A::X, o + Vec3A::Y),
            Triangle::new(o, o - Vec3A::X, o - Vec3A::Y),
            Triangle::new(o, o + Vec3A::X, o - Vec3A::Y),
        ]
    };
    let mut tris = Vec::new();
    for i in 0..64 {
        tris.extend(quad(Vec3A::new((i % 8) as f32, (i / 8) as f32, 0.0)));
    }
    for name in BUILDERS {
        let bvh = build(name, &tris);
        let w8 = Bvh8::from_bvh(&bvh, &tris);
        for i in 0..64 {
            let p = Vec3A::new((i % 8) as f32, (i / 8) as f32, 0.0);
            let want = brute::closest_point(&tris, p, f32::INFINITY).unwrap();
            assert_eq!(want.distance_squared, 0.0);
            // The vertex is shared by the neighbouring quads' triangles too.
            assert!(want.prim <= 4 * i as u32, "{want:?}");
            let got = w8.closest_point(p, f32::INFINITY, &mut NoStats);
            assert_eq!(bits(&got), bits(&Some(want)), "{name} {p}");
            let got = point::closest_point(&bvh, &tris, p, 0.0, &mut NoStats);
            assert_eq!(bits(&got), bits(&Some(want)), "{name} {p}");
        }
    }
}

/// Tiny and huge coordinates, and small triangles far from the origin (the box pad is
/// relative to the largest coordinate): still brute force bit for bit.
#[test]
fn extreme_scales_equal_brute_force() {
    let base = mixed_soup(800, 13);
    let moved = |scale: f32, offset: Vec3A| -> Vec<Triangle> {
        base.iter()
            .map(|t| {
                Triangle::new(
                    t.v[0] * scale + offset,
                    t.v[1] * scale + offset,
                    t.v[2] * scale + offset,
                )
            })
            .collect()
    };
    check_scene("tiny", &moved(1e-30, Vec3A::ZERO), 600, 6);
    check_scene("huge", &moved(1e30, Vec3A::ZERO), 600, 7);
    check_scene("far", &moved(1e-3, Vec3A::new(3e5, -2e5, 1e5)), 600, 8);
}

/// A leaf box that misses its triangle by one ulp, as a spatial split's clipped box rounded
/// to `f32` can: the box pad keeps that leaf, so the lower index still wins the tie at
/// distance zero (without the pad the leaf is pruned and triangle 1 is returned).
#[test]
fn the_box_pad_covers_clipped_boxes_off_by_an_ulp() {
    use sahara_bvh::Node;
    let tris = [
        Triangle::new(
            Vec3A::new(0.0, 1000.0, 0.0),
            Vec3A::new(2000.0, 1000.0, 0.0),
            Vec3A::new(0.0, 3000.0, 0.0),
        ),
        Triangle::new(
            Vec3A::new(0.0, 1000.0, 0.0),
            Vec3A::new(2000.0, 1000.0, 0.0),
            Vec3A::new(0.0, -1000.0, 0.0),
        ),
    ];
    // On the shared edge: both triangles at distance 0.
    let p = Vec3A::new(1000.0, 1000.0, 0.0);
    let mut clipped = tris[0].bounds();
    clipped.min.y = 1000.0f32.next_up();
    let root = tris[0].bounds().union(&tris[1].bounds());
    let bvh = Bvh {
        nodes: vec![
            Node::inner(&root, 2),
            Node::leaf(&tris[1].bounds(), 0, 1),
            Node::leaf(&clipped, 1, 1),
        ],
        prim_indices: vec![1, 0],
        spatial_splits: true,
        ref_cuts: None,
    };
    let want = brute::closest_point(&tris, p, f32::INFINITY);
    assert_eq!(want.map(|h| (h.prim, h.distance_squared)), Some((0, 0.0)));
    for m in [f32::INFINITY, 0.0] {
        let got = point::closest_point(&bvh, &tris, p, m, &mut NoStats);
        assert_eq!(bits(&got), bits(&want), "{m}");
    }
}

#[test]
fn max_distance_cuts_off() {
    let tris = [Triangle::new(Vec3A::ZERO, Vec3A::X, Vec3A::Y)];
    let bvh = build("sweep", &tris);
    let w8 = Bvh8::from_bvh(&bvh, &tris);
    let p = Vec3A::new(0.25, 0.25, 2.0);
    for (m, found) in [
        (2.0, true),
        (f32::INFINITY, true),
        (1.999_999_9, false),
        (0.0, false),
    ] {
        assert_eq!(w8.closest_point(p, m, &mut NoStats).is_some(), found, "{m}");
        assert_eq!(brute::closest_point(&tris, p, m).is_some(), found, "{m}");
    }
}

#[test]
fn bad_query_points_and_limits_return_none() {
    let tris = mixed_soup(200, 3);
    let bvh = build("binned", &tris);
    let w8 = Bvh8::from_bvh(&bvh, &tris);
    let bad_points = [
        Vec3A::new(f32::NAN, 0.0, 0.0),
        Vec3A::new(0.0, f32::INFINITY, 0.0),
        Vec3A::new(0.0, 0.0, f32::NEG_INFINITY),
        Vec3A::NAN,
    ];
    for p in bad_points {
        assert_eq!(w8.closest_point(p, f32::INFINITY, &mut NoStats), None);
        assert_eq!(
            point::closest_point(&bvh, &tris, p, 1.0, &mut NoStats),
            None
        );
        assert_eq!(brute::closest_point(&tris, p, f32::INFINITY), None);
    }
    for m in [-1.0, -f32::MIN_POSITIVE, f32::NAN, f32::NEG_INFINITY] {
        assert_eq!(w8.closest_point(Vec3A::ZERO, m, &mut NoStats), None, "{m}");
        assert_eq!(brute::closest_point(&tris, Vec3A::ZERO, m), None, "{m}");
    }
    // Huge but finite points still work, and far away points find something.
    let far = Vec3A::splat(f32::MAX);
    let want = brute::closest_point(&tris, far, f32::INFINITY);
    assert!(want.is_some());
    assert_eq!(
        bits(&w8.closest_point(far, f32::INFINITY, &mut NoStats)),
        bits(&want)
    );
}

#[test]
fn empty_scenes_find_nothing() {
    let tris: Vec<Triangle> = Vec::new();
    let bvh = Bvh::empty();
    let w8 = Bvh8::from_bvh(&bvh, &tris);
    assert_eq!(
        point::closest_point(&bvh, &tris, Vec3A::ZERO, f32::INFINITY, &mut NoStats),
        None
    );
    assert_eq!(
        w8.closest_point(Vec3A::ZERO, f32::INFINITY, &mut NoStats),
        None
    );
    assert_eq!(
        brute::closest_point(&tris, Vec3A::ZERO, f32::INFINITY),
        None
    );
    let built = build("sweep", &tris);
    assert_eq!(
        Bvh8::from_bvh(&built, &tris).closest_point(Vec3A::ONE, 1.0, &mut NoStats),
        None
    );
}

/// Pruning works: far fewer triangles are tested than a scan does.
#[test]
fn the_tree_prunes() {
    let tris = mixed_soup(5_000, 11);
    let bvh = build("sweep", &tris);
    let w8 = Bvh8::from_bvh(&bvh, &tris);
    let mut work = WorkCounters::default();
    let pts = points(&tris, 600, 8);
    for &p in &pts {
        w8.closest_point(p, f32::INFINITY, &mut work);
    }
    let per_query = work.triangles as f64 / pts.len() as f64;
    assert!(per_query < 500.0, "{per_query} triangles per query");
}

/// The closest point of a sphere's surface, in `f64` (a point at the centre takes `+x`).
fn sphere_point(s: &spheres::Sphere, p: Vec3A) -> Option<(Vec3A, f64)> {
    let (c, pd) = (s.c.as_dvec3(), p.as_dvec3());
    let d = pd - c;
    let len = d.length();
    let dir = if len > 0.0 { d / len } else { glam::DVec3::X };
    let q = c + dir * s.r as f64;
    let gap = len - s.r as f64;
    Some((q.as_vec3a(), gap * gap))
}

#[test]
fn user_primitives_equal_brute_force() {
    let spheres = spheres::spheres(1_500, 4);
    let boxes: Vec<Aabb> = spheres.iter().map(spheres::Sphere::bounds).collect();
    // Skip every seventh sphere: the callback's own filter.
    let closest = |prim: u32, p: Vec3A| {
        if prim % 7 == 3 {
            return None;
        }
        sphere_point(&spheres[prim as usize], p)
    };
    let mut rng = Pcg32::new(5, 1);
    let bounds = Aabb::new(Vec3A::splat(-12.0), Vec3A::splat(12.0));
    let mut pts: Vec<Vec3A> = (0..1_500).map(|_| point_in(&bounds, &mut rng)).collect();
    // Centres and points on the surfaces.
    pts.extend(spheres.iter().take(300).map(|s| s.c));
    pts.extend(spheres.iter().take(300).map(|s| s.c + Vec3A::X * s.r));
    let splitter = spheres::SphereSplitter(&spheres);
    for (name, split) in [("binned", false), ("sbvh", true)] {
        let mut input = BuildInput::from_boxes(&boxes, CostModel::default()).unwrap();
        if split {
            input = input.with_splitter(&splitter);
        }
        let bvh = registry::by_name(name).unwrap().build(&input).unwrap();
        let w8 = Bvh8::from_boxes(&bvh, &boxes);
        for m in [f32::INFINITY, 0.3] {
            for &p in &pts {
                let want = bits(&brute::closest_point_custom(&boxes, p, m, closest));
                let got = point::closest_point_custom(&bvh, &boxes, p, m, closest, &mut NoStats);
                assert_eq!(bits(&got), want, "{name} bvh2 {p} {m}");
                let got = w8.closest_point_custom(&boxes, p, m, closest, &mut NoStats);
                assert_eq!(bits(&got), want, "{name} bvh8 {p} {m}");
            }
        }
        // A tree over boxes holds no triangles.
        assert_eq!(
            w8.closest_point(Vec3A::ZERO, f32::INFINITY, &mut NoStats),
            None
        );
    }
}

/// A callback that lies (distances below its box's, NaN, points anywhere) still equals the
/// brute force with the same callback.
#[test]
fn a_lying_callback_still_equals_brute_force() {
    let spheres = spheres::spheres(800, 6);
    let boxes: Vec<Aabb> = spheres.iter().map(spheres::Sphere::bounds).collect();
    let closest = |prim: u32, p: Vec3A| match prim % 5 {
        0 => Some((Vec3A::ZERO, 0.0)),
        1 => Some((p, f64::NAN)),
        2 => Some((p, -1.0)),
        _ => sphere_point(&spheres[prim as usize], p),
    };
    let input = BuildInput::from_boxes(&boxes, CostModel::default()).unwrap();
    let bvh = registry::by_name("sweep").unwrap().build(&input).unwrap();
    let w8 = Bvh8::from_boxes(&bvh, &boxes);
    let mut rng = Pcg32::new(9, 1);
    let bounds = Aabb::new(Vec3A::splat(-12.0), Vec3A::splat(12.0));
    for _ in 0..1_000 {
        let p = point_in(&bounds, &mut rng);
        let want = bits(&brute::closest_point_custom(
            &boxes,
            p,
            f32::INFINITY,
            closest,
        ));
        let got = w8.closest_point_custom(&boxes, p, f32::INFINITY, closest, &mut NoStats);
        assert_eq!(bits(&got), want, "{p}");
        let got =
            point::closest_point_custom(&bvh, &boxes, p, f32::INFINITY, closest, &mut NoStats);
        assert_eq!(bits(&got), want, "{p}");
    }
}
