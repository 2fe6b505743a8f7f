//! The five rays the fuzzers once reported as real hits missed (issue 46's
//! `OPEN_FINDINGS`, triaged 2026-12-07): each passes inside a triangle by the exact oracle,
//! away from its edges by more than the oracle's edge band (10^-4 barycentric), and the
//! `f32` watertight test misses it. In every case the hit lies within the test's own
//! barycentric rounding error ([`barycentric_resolution`]): a grazing ray (|cos| 1.3e-4 and
//! 2.5e-2 to the plane), an origin a thousand units away from a unit triangle, and a triangle
//! one ulp wide. These are limits of `f32`, not of the implementation (docs/robustness.md,
//! "Limits"); the check that judges fuzz inputs counts them apart, and this test keeps the
//! bound honest on both sides: it explains these four and does not explain ordinary hits.
//! The fifth is a distance, not a barycentric, beyond `f32`'s reach: a huge triangle hit
//! near the ray's origin ([`distance_resolution`]).

use sahara_geom::intersect::intersect_ray_triangle;
use sahara_geom::{Ray, Triangle, Vec3A};
use sahara_hardcases::expand::{barycentric_resolution, distance_resolution};
use sahara_hardcases::pinning::oracle_for;
use sahara_oracle::{OracleRay, EDGE_BAND};

fn v(x: f32, y: f32, z: f32) -> Vec3A {
    Vec3A::new(x, y, z)
}

fn ray(o: Vec3A, d: Vec3A) -> Ray {
    Ray::new(o, d, 0.0, f32::INFINITY)
}

/// (name, ray, triangle) as the replay printed them (`Debug` of `f32` round-trips).
fn findings() -> Vec<(&'static str, Ray, Triangle)> {
    vec![
        (
            "degenerate tsah-sbvh: a triangle one ulp wide",
            ray(
                v(1.4511476, -0.011779055, -1.2667648),
                v(-0.7816363, 0.41257536, 0.68489873),
            ),
            Triangle::new(
                v(0.6695111, 0.4007963, -0.581866),
                v(0.6695113, 0.4007963, -0.581866),
                v(0.6695111, 0.4007964, -0.581866),
            ),
        ),
        (
            "sphere tsah-topk+reinsert: a grazing ray",
            ray(
                v(0.34320435, 1.3082846, -1.1975231),
                v(-0.7817063, -0.51154447, 1.3386629),
            ),
            Triangle::new(
                v(-0.5257311, 0.8506508, 0.0),
                v(0.0, 0.5257311, 0.8506508),
                v(0.5257311, 0.8506508, 0.0),
            ),
        ),
        (
            "procedural binned: a grazing ray",
            ray(
                v(-1.3549051, 1.2164769, 0.69020253),
                v(1.5248969, -1.7676185, -0.28488356),
            ),
            Triangle::new(
                v(-0.42611408, -0.6997105, 0.35155642),
                v(0.75680137, -0.4048897, 0.45824313),
                v(0.16649418, -0.556582, 0.4039756),
            ),
        ),
        (
            "stacked sbvh-fast: an origin a thousand units away",
            ray(
                v(820.6378, 1013.733, 1394.7595),
                v(-820.6395, -1014.4561, -1394.3079),
            ),
            Triangle::new(
                v(-0.118210435, 0.028327227, 0.32595098),
                v(-0.001734376, -0.7231699, 0.45169997),
                v(0.33153355, -0.69298995, 0.753515),
            ),
        ),
    ]
}

fn exact_min_bary(tri: &Triangle, r: &Ray) -> Option<f64> {
    let oracle = oracle_for(&[*tri]);
    let or = OracleRay {
        origin: r.origin.to_array(),
        dir: r.direction().to_array(),
        tmin: r.tmin,
        tmax: r.tmax,
    };
    oracle
        .exact(0, &or)
        .filter(|h| h.is_strict())
        .map(|h| h.min_bary)
}

#[test]
fn the_triaged_misses_lie_within_the_f32_tests_rounding_error() {
    for (name, r, tri) in findings() {
        let min_bary = exact_min_bary(&tri, &r).expect("the oracle finds a strict hit");
        assert!(
            min_bary >= EDGE_BAND,
            "{name}: {min_bary} is inside the edge band"
        );
        assert!(
            intersect_ray_triangle(&r, &tri).is_none(),
            "{name}: the f32 test hits now"
        );
        let res = barycentric_resolution(&tri, &r);
        eprintln!("{name}: min_bary {min_bary:e} bound {res:e}");
        assert!(
            min_bary < res,
            "{name}: exact smallest barycentric {min_bary:e} is beyond the bound {res:e}"
        );
    }
}

/// The fifth finding (a free `big_scene` run, 2026-12-07,
/// `docs/results/2026-12-07-fuzz-coverage/finding-soup64-cluster-binned-missed.bin`): a
/// triangle about 5·10^8 wide hit at its centroid (barycentrics all 1/3) 3.19 units from the
/// ray's origin. The barycentrics are resolved; the distance is not: the test computes
/// `t · det` as a sum of terms near 10^25 that cancel to 10^18, and rounds it below `tmin`.
/// The miss lies within [`distance_resolution`].
#[test]
fn a_huge_triangle_near_the_origin_is_within_the_distance_resolution() {
    let p = |b: [u32; 3]| Vec3A::from_array(b.map(f32::from_bits));
    let tri = Triangle::new(
        p([1289984624, 3446100756, 1299945598]),
        p([3446430700, 1296640700, 1245563744]),
        p([1291132264, 1274102464, 3447623594]),
    );
    let r = ray(
        p([3202563486, 3210338262, 3195707982]),
        p([1053325836, 1064123884, 1064216826]),
    );
    let oracle = oracle_for(&[tri]);
    let or = OracleRay {
        origin: r.origin.to_array(),
        dir: r.direction().to_array(),
        tmin: r.tmin,
        tmax: r.tmax,
    };
    let h = oracle
        .exact(0, &or)
        .filter(|h| h.is_strict())
        .expect("a strict hit");
    assert!((h.t - 3.193).abs() < 1e-3, "t {}", h.t);
    assert!(h.min_bary > 0.33, "{}", h.min_bary);
    assert!(h.min_bary > barycentric_resolution(&tri, &r));
    assert!(
        intersect_ray_triangle(&r, &tri).is_none(),
        "the f32 test hits now"
    );
    let dt = distance_resolution(&tri, &r);
    assert!(h.t < dt, "t {} beyond the distance bound {dt:e}", h.t);
}

/// Ordinary hits are not excused: a ray along the normal, one at 60 degrees, and one from a
/// ten units away, each 10^-3 (barycentric) inside an edge of a unit triangle, have a
/// bound far below that, and the f32 test finds them.
#[test]
fn ordinary_hits_near_an_edge_are_beyond_the_bound() {
    let tri = Triangle::new(v(0.0, 0.0, 0.0), v(1.0, 0.0, 0.0), v(0.0, 1.0, 0.0));
    // A point 1.5e-3 (barycentric) inside the edge from v0 to v1.
    let p = tri.point(0.5, 0.0015);
    for (o, what) in [
        (p + v(0.0, 0.0, 1.0), "along the normal"),
        (p + v(0.0, 1.0, 1.732), "at 60 degrees"),
        (p + v(3.0, 4.0, 8.0), "from ten units"),
    ] {
        let r = ray(o, p - o);
        let res = barycentric_resolution(&tri, &r);
        assert!(res < 1e-4, "{what}: bound {res:e}");
        let min_bary = exact_min_bary(&tri, &r).expect("a strict hit");
        assert!(min_bary > 10.0 * res, "{what}: {min_bary:e} vs {res:e}");
        assert!(intersect_ray_triangle(&r, &tri).is_some(), "{what}: missed");
        let dt = distance_resolution(&tri, &r);
        assert!(dt < 1e-4, "{what}: distance bound {dt:e}");
    }
    // Degenerate input: no finite bound.
    let flat = Triangle::new(v(0.0, 0.0, 0.0), v(1.0, 0.0, 0.0), v(2.0, 0.0, 0.0));
    let r = ray(v(0.5, 1.0, 0.0), v(0.0, -1.0, 0.0));
    assert_eq!(barycentric_resolution(&flat, &r), f64::INFINITY);
}
