//! The façade: every quality level answers like brute force, builds are deterministic, bad
//! input is a typed error, and saved structures load back identical or fail with a typed
//! error, never a panic.

use sahara::{
    Accel, AccelHit, BuildOptions, CostModel, Error, LoadError, Quality, Ray, Triangle, Vec3A,
};
use sahara_fixtures::soups::mixed_soup;
use sahara_geom::rng::Pcg32;
use sahara_traverse::brute;

mod common;

use common::segments_and_rays_from_above;

fn scene() -> Vec<Triangle> {
    let mut tris = mixed_soup(1500, 3);
    // A few duplicates and a degenerate triangle: built like any other, ties by index.
    tris.extend_from_within(..20);
    tris.push(Triangle::new(Vec3A::ZERO, Vec3A::ZERO, Vec3A::X));
    tris
}

/// Segments in the soup's cube and infinite rays from outside towards the soup.
fn rays(n: usize) -> Vec<Ray> {
    segments_and_rays_from_above(n, 11, 1.2)
}

/// The brute-force twin of `Accel::closest_hit`, written out here: the kernel's brute-force
/// hit (every triangle, the watertight test) and the normal `(v1 - v0) × (v2 - v0)` of the
/// triangle it names.
fn brute_twin(tris: &[Triangle], ray: &Ray) -> Option<AccelHit> {
    let h = brute::closest_hit(tris, ray);
    h.is_hit().then(|| {
        let [v0, v1, v2] = tris[h.prim as usize].v;
        AccelHit {
            prim: h.prim,
            t: h.t,
            u: h.u,
            v: h.v,
            normal: (v1 - v0).cross(v2 - v0),
        }
    })
}

/// A hit's bits (NaN-safe equality, signed zeros told apart).
fn bits(h: Option<AccelHit>) -> Option<(u32, u32, u32, u32, [u32; 3])> {
    h.map(|h| {
        let n = h.normal.to_array().map(f32::to_bits);
        (h.prim, h.t.to_bits(), h.u.to_bits(), h.v.to_bits(), n)
    })
}

#[test]
fn the_hit_normal_is_the_unnormalised_cross_product_of_the_hit_triangle() {
    // Both windings, seen from both sides, at every level: the normal follows the winding,
    // not the ray, and its length is twice the area.
    let (a, b, c) = (
        Vec3A::new(0.0, 0.0, 2.0),
        Vec3A::new(3.0, 0.0, 2.0),
        Vec3A::new(0.0, 3.0, 2.0),
    );
    let tris = [
        Triangle::new(a, b, c),
        Triangle::new(
            a + Vec3A::X * 10.0,
            c + Vec3A::X * 10.0,
            b + Vec3A::X * 10.0,
        ),
    ];
    for q in Quality::ALL {
        let accel = Accel::build(&tris, q).unwrap();
        for (x, want) in [
            (0.5, Vec3A::new(0.0, 0.0, 9.0)),
            (10.5, Vec3A::new(0.0, 0.0, -9.0)),
        ] {
            for dz in [1.0, -1.0] {
                let o = Vec3A::new(x, 0.5, 2.0 - 3.0 * dz);
                let hit = accel
                    .closest_hit(&Ray::new(o, Vec3A::Z * dz, 0.0, 9.0))
                    .unwrap();
                assert_eq!((hit.t, hit.normal), (3.0, want), "{q} x {x} dz {dz}");
            }
        }
    }
}

#[test]
fn every_quality_level_is_a_registered_builder() {
    let names = sahara_builders::registry::names();
    for q in Quality::ALL {
        assert!(names.contains(&q.builder_name()), "{q}");
    }
    assert_eq!(Quality::default(), Quality::Medium);
}

#[test]
fn every_quality_answers_like_brute_force() {
    let tris = scene();
    let rays = rays(1500);
    for q in Quality::ALL {
        let accel = Accel::build(&tris, q).unwrap();
        assert_eq!(accel.quality(), q);
        assert_eq!(accel.len(), tris.len());
        let closest = accel.closest_hits(&rays);
        let any = accel.any_hits(&rays);
        let mut hits = 0;
        for (i, ray) in rays.iter().enumerate() {
            let want = brute::closest_hit(&tris, ray);
            let got = accel.closest_hit(ray);
            assert_eq!(bits(got), bits(brute_twin(&tris, ray)), "{q} ray {i}");
            assert_eq!(got, accel.brute_closest_hit(ray), "{q} ray {i}");
            assert_eq!(closest[i], got, "{q} batch ray {i}");
            assert_eq!(accel.any_hit(ray), want.is_hit(), "{q} any ray {i}");
            assert_eq!(any[i], want.is_hit(), "{q} batch any ray {i}");
            hits += want.is_hit() as usize;
        }
        assert!(hits > rays.len() / 4 && hits < rays.len(), "{hits}");
    }
}

#[test]
fn builds_are_the_same_on_any_thread_count() {
    let tris = scene();
    for q in [Quality::Fast, Quality::High] {
        let one = Accel::build(&tris, BuildOptions::new(q).with_threads(1)).unwrap();
        let two = Accel::build(&tris, BuildOptions::new(q).with_threads(2)).unwrap();
        assert_eq!(one.bvh(), two.bvh(), "{q}");
        // The level's tree is the registered builder's tree.
        let input = sahara_builders::BuildInput::new(&tris, CostModel::default()).unwrap();
        let direct = sahara_builders::registry::by_name(q.builder_name())
            .unwrap()
            .build(&input)
            .unwrap();
        assert_eq!(one.bvh(), &direct, "{q}");
    }
}

#[test]
fn bad_input_is_a_typed_error() {
    let mut tris = scene();
    tris[7].v[1].y = f32::NAN;
    assert!(matches!(
        Accel::build(&tris, Quality::Fast),
        Err(Error::Build(sahara::BuildError::NonFinite { triangle: 7 }))
    ));
    let bad_cost = BuildOptions::new(Quality::Fast).with_cost(CostModel {
        traversal: 1.0,
        intersection: f32::INFINITY,
    });
    assert!(matches!(
        Accel::build(&scene(), bad_cost),
        Err(Error::Build(sahara::BuildError::InvalidCostModel))
    ));
    let positions = [Vec3A::ZERO, Vec3A::X, Vec3A::Y];
    assert!(matches!(
        Accel::build_indexed(&positions, &[[0, 1, 2], [2, 1, 9]], Quality::Fast),
        Err(Error::IndexOutOfRange {
            triangle: 1,
            index: 9,
            vertices: 3
        })
    ));
    // Nothing to build: every ray misses; invalid rays miss.
    let empty = Accel::build(&[], Quality::Best).unwrap();
    assert!(empty.is_empty());
    let ray = Ray::new(Vec3A::ZERO, Vec3A::Z, 0.0, f32::INFINITY);
    assert_eq!(empty.closest_hit(&ray), None);
    assert!(!empty.any_hit(&ray));
    let accel = Accel::build(&scene(), Quality::Fast).unwrap();
    let nan = Ray::new(Vec3A::new(0.0, f32::NAN, 0.0), Vec3A::Z, 0.0, f32::INFINITY);
    assert_eq!(accel.closest_hit(&nan), None);
    assert!(!accel.any_hit(&nan));
}

#[test]
fn saved_structures_load_back_identical() {
    let tris = scene();
    let rays = rays(300);
    for q in [Quality::Medium, Quality::High] {
        let options = BuildOptions::new(q).with_cost(CostModel::UNIT);
        let accel = Accel::build(&tris, options).unwrap();
        let mut file = Vec::new();
        accel.save(&mut file).unwrap();
        let back = Accel::load(&mut file.as_slice()).unwrap();
        assert_eq!(back.bvh(), accel.bvh());
        assert_eq!(back.triangles(), accel.triangles());
        assert_eq!((back.quality(), back.cost()), (q, CostModel::UNIT));
        assert_eq!(back.wide().nodes(), accel.wide().nodes());
        assert_eq!(back.closest_hits(&rays), accel.closest_hits(&rays));
    }
    let empty = Accel::build(&[], Quality::Fast).unwrap();
    let mut file = Vec::new();
    empty.save(&mut file).unwrap();
    assert!(Accel::load(&mut file.as_slice()).unwrap().is_empty());
}

#[test]
fn saved_structures_round_trip_through_a_file() {
    let accel = Accel::build(&scene(), Quality::Fast).unwrap();
    let path = std::env::temp_dir().join(format!("sahara-facade-{}.accel", std::process::id()));
    accel.save_to_path(&path).unwrap();
    let back = Accel::load_from_path(&path);
    std::fs::remove_file(&path).unwrap();
    assert_eq!(back.unwrap().bvh(), accel.bvh());
    assert!(matches!(
        Accel::load_from_path(&path),
        Err(LoadError::Io(_))
    ));
}

/// The saved file of the structure over the scene's first 40 triangles.
fn saved_small(quality: Quality) -> Vec<u8> {
    let tris: Vec<Triangle> = scene().into_iter().take(40).collect();
    let mut file = Vec::new();
    Accel::build(&tris, quality)
        .unwrap()
        .save(&mut file)
        .unwrap();
    file
}

#[test]
fn broken_files_are_typed_errors() {
    let file = saved_small(Quality::High);
    let load = |bytes: &[u8]| Accel::load(&mut &bytes[..]);

    // Every truncation.
    for len in 0..file.len() {
        match load(&file[..len]) {
            Err(LoadError::Truncated { expected, actual }) => {
                assert_eq!(actual, len as u64, "length {len}");
                assert!(expected > actual, "length {len}");
            }
            other => panic!("length {len}: {other:?}"),
        }
    }
    // Trailing bytes.
    let mut long = file.clone();
    long.extend_from_slice(&[0; 5]);
    assert!(matches!(load(&long), Err(LoadError::TrailingData(5))));
    // Every single-bit flip is caught (the header's fields by their own checks, the payload
    // by the checksum), and none panics.
    for i in 0..file.len() {
        for bit in [0, 3, 7] {
            let mut bad = file.clone();
            bad[i] ^= 1 << bit;
            let err = load(&bad).expect_err(&format!("byte {i} bit {bit}"));
            if i < 8 {
                assert!(matches!(err, LoadError::BadMagic), "byte {i}: {err:?}");
            } else if (8..12).contains(&i) {
                assert!(matches!(err, LoadError::UnsupportedVersion(_)), "{err:?}");
            } else if i >= 48 || (12..24).contains(&i) || (40..48).contains(&i) {
                assert!(matches!(err, LoadError::Checksum), "byte {i}: {err:?}");
            } else {
                // A size field: the data present no longer matches it.
                assert!(
                    matches!(
                        err,
                        LoadError::Truncated { .. } | LoadError::TrailingData(_)
                    ),
                    "byte {i}: {err:?}"
                );
            }
        }
    }
    assert!(matches!(
        load(b"SAHARBVH is another format, this is not an accel"),
        Err(LoadError::BadMagic)
    ));
}

/// A file whose checksum is right but whose content is wrong (as a buggy or hostile writer
/// makes): each inconsistency is a typed error.
#[test]
fn consistent_checksums_over_bad_content_are_typed_errors() {
    let file = saved_small(Quality::Medium);
    let reseal = |mut bytes: Vec<u8>| {
        common::reseal(&mut bytes, 40);
        Accel::load(&mut bytes.as_slice())
    };
    let mut q = file.clone();
    q[12] = 9;
    assert!(matches!(reseal(q), Err(LoadError::UnknownQuality(9))));
    let mut cost = file.clone();
    cost[20..24].copy_from_slice(&(-1.0f32).to_le_bytes());
    assert!(matches!(reseal(cost), Err(LoadError::InvalidCostModel)));
    let mut nan = file.clone();
    nan[48 + 36 * 3 + 4..48 + 36 * 3 + 8].copy_from_slice(&f32::NAN.to_le_bytes());
    assert!(matches!(reseal(nan), Err(LoadError::NonFinite(3))));
    // Move a vertex far away: the tree no longer bounds the triangle.
    let mut moved = file.clone();
    moved[48..52].copy_from_slice(&1000.0f32.to_le_bytes());
    assert!(matches!(reseal(moved), Err(LoadError::InvalidTree(_))));
    // Corrupt the embedded tree file (behind its own checksum).
    let mut tree = file.clone();
    let last = tree.len() - 1;
    tree[last] ^= 1;
    assert!(matches!(reseal(tree), Err(LoadError::Tree(_))));
}

/// A renderer reuses its ray structs: turning a ray round with `set_direction` must answer for
/// the new direction. (With a public `direction` field and the reciprocal computed once in
/// `Ray::new`, a ray turned away from the triangle still hit it at t = 5: the box tests and the
/// watertight test read the stale reciprocal.) Each reused ray is checked against a fresh one
/// and against brute force, on every quality level.
#[test]
fn a_reused_ray_answers_for_its_new_direction() {
    let wall = [Triangle::new(
        Vec3A::new(-1.0, -1.0, 5.0),
        Vec3A::new(3.0, -1.0, 5.0),
        Vec3A::new(-1.0, 3.0, 5.0),
    )];
    let tris = scene();
    for q in Quality::ALL {
        let accel = Accel::build(&wall, q).unwrap();
        let mut ray = Ray::new(Vec3A::ZERO, Vec3A::Z, 0.0, f32::INFINITY);
        assert_eq!(accel.closest_hit(&ray).map(|h| h.t), Some(5.0), "{q}");
        ray.set_direction(-Vec3A::Z);
        assert_eq!(
            accel.closest_hit(&ray),
            None,
            "{q}: the turned ray points away"
        );
        assert!(!accel.any_hit(&ray), "{q}");

        // Random turns of one ray struct over the soup, each equal to a fresh ray's answer.
        let accel = Accel::build(&tris, q).unwrap();
        let mut reused = Ray::new(Vec3A::new(0.1, -0.2, 3.0), -Vec3A::Z, 0.0, f32::INFINITY);
        let mut rng = Pcg32::new(7, 3);
        for _ in 0..500 {
            let d = Vec3A::new(
                rng.range_f32(-1.0, 1.0),
                rng.range_f32(-1.0, 1.0),
                rng.range_f32(-1.0, 1.0),
            );
            reused.set_direction(d);
            let fresh = Ray::new(reused.origin, d, 0.0, f32::INFINITY);
            assert_eq!(reused, fresh);
            let want = brute_twin(&tris, &fresh);
            assert_eq!(bits(accel.closest_hit(&reused)), bits(want));
        }
    }
}
