//! Tests of the temporary-subtree SAH builder with spatial splits.

use sahara_build::sbvh::{SbvhBuilder, SbvhConfig};
use sahara_build::tsah_spatial::{TsahSpatialBuilder, TsahSpatialConfig};
use sahara_build::{registry, BuildInput, Builder, Bvh};
use sahara_geom::rng::Pcg32;
use sahara_geom::{Triangle, Vec3A};
use sahara_metrics::{sah, CostModel};

fn rand_point(rng: &mut Pcg32, lo: f32, hi: f32) -> Vec3A {
    Vec3A::new(
        rng.range_f32(lo, hi),
        rng.range_f32(lo, hi),
        rng.range_f32(lo, hi),
    )
}

fn soup(n: usize, seed: u64, size: f32) -> Vec<Triangle> {
    let mut rng = Pcg32::new(seed, 1);
    (0..n)
        .map(|_| {
            let c = rand_point(&mut rng, 0.0, 100.0);
            let s = rng.range_f32(0.01, size);
            Triangle::new(
                c + rand_point(&mut rng, -s, s),
                c + rand_point(&mut rng, -s, s),
                c + rand_point(&mut rng, -s, s),
            )
        })
        .collect()
}

fn clustered(n: usize) -> Vec<Triangle> {
    let mut rng = Pcg32::new(7, 3);
    let c = Vec3A::splat(50.0);
    (0..n)
        .map(|i| {
            let s = rng.range_f32(0.1, 50.0);
            let j = if i % 2 == 0 {
                Vec3A::ZERO
            } else {
                rand_point(&mut rng, -1e-4, 1e-4)
            };
            Triangle::new(
                c + j + Vec3A::new(-s, -s, 0.0),
                c + j + Vec3A::new(s, 0.0, -s),
                c + j + Vec3A::new(0.0, s, s),
            )
        })
        .collect()
}

fn degenerate_mix() -> Vec<Triangle> {
    let mut tris = soup(200, 11, 20.0);
    let p = Vec3A::new(3.0, 4.0, 5.0);
    for i in 0..100 {
        let o = Vec3A::splat(i as f32 * 0.1);
        tris.push(Triangle::new(o, o + Vec3A::X * 30.0, o + Vec3A::X * 60.0));
        tris.push(Triangle::new(o, o, o + Vec3A::new(20.0, 30.0, 40.0)));
        tris.push(Triangle::new(p, p, p));
    }
    let dup = tris[5];
    tris.extend(std::iter::repeat_n(dup, 40));
    tris
}

fn flat_scene(n: usize) -> Vec<Triangle> {
    let mut rng = Pcg32::new(5, 9);
    (0..n)
        .map(|_| {
            let c = Vec3A::new(rng.range_f32(0.0, 100.0), rng.range_f32(0.0, 100.0), 2.0);
            let a = Vec3A::new(rng.range_f32(-9.0, 9.0), rng.range_f32(-9.0, 9.0), 0.0);
            let b = Vec3A::new(rng.range_f32(-9.0, 9.0), rng.range_f32(-9.0, 9.0), 0.0);
            Triangle::new(c, c + a, c + b)
        })
        .collect()
}

/// A grid of small triangles crossed by long thin diagonal triangles.
fn needs_spatial() -> Vec<Triangle> {
    let mut tris = Vec::new();
    for i in 0..25 {
        for j in 0..25 {
            let o = Vec3A::new(i as f32 * 4.0, j as f32 * 4.0, (i + j) as f32 % 3.0);
            tris.push(Triangle::new(o, o + Vec3A::X * 0.5, o + Vec3A::Y * 0.5));
        }
    }
    for k in 0..50 {
        let t = 2.0 * k as f32;
        let a = Vec3A::new(0.0, t, 0.5);
        let b = Vec3A::new(100.0, 100.0 - t, 1.5);
        tris.push(Triangle::new(a, b, b + Vec3A::Z * 0.3));
    }
    tris
}

/// A small threshold, so that small test inputs exercise the rating.
fn small() -> TsahSpatialConfig {
    TsahSpatialConfig {
        min_size: 24,
        ..TsahSpatialConfig::DEFAULT
    }
}

fn configs() -> Vec<TsahSpatialConfig> {
    vec![
        small(),
        TsahSpatialConfig {
            min_size: 24,
            ..TsahSpatialConfig::FAST
        },
        TsahSpatialConfig {
            spatial_candidates: 0,
            object_candidates: 1,
            min_size: 2,
            ..TsahSpatialConfig::DEFAULT
        },
        TsahSpatialConfig {
            sbvh: SbvhConfig {
                max_leaf_size: 1,
                ..SbvhConfig::DEFAULT
            },
            min_size: 24,
            ..TsahSpatialConfig::DEFAULT
        },
    ]
}

fn build_with(tris: &[Triangle], config: TsahSpatialConfig) -> Bvh {
    let input = BuildInput::new(tris, CostModel::default()).unwrap();
    let bvh = TsahSpatialBuilder::new(config).build(&input).unwrap();
    bvh.validate(tris).unwrap();
    let max_leaf = bvh
        .nodes
        .iter()
        .filter(|n| n.is_leaf())
        .map(|n| n.count as usize)
        .max()
        .unwrap_or(0);
    assert!(max_leaf <= config.sbvh.max_leaf_size);
    assert!(bvh.prim_indices.len() <= tris.len() + config.sbvh.budget_for(tris.len()));
    bvh
}

fn bits(bvh: &Bvh) -> Vec<u32> {
    let mut v = Vec::new();
    for n in &bvh.nodes {
        v.extend(n.min.iter().chain(&n.max).map(|x| x.to_bits()));
        v.extend([n.index, n.count]);
    }
    v.extend(&bvh.prim_indices);
    v
}

#[test]
fn random_soups_validate() {
    for (n, seed) in [(1, 1), (2, 2), (9, 3), (100, 4), (1500, 5)] {
        for config in configs() {
            build_with(&soup(n, seed, 8.0), config);
        }
    }
}

#[test]
fn clustered_degenerate_and_flat_inputs() {
    for config in configs() {
        build_with(&clustered(600), config);
        build_with(&degenerate_mix(), config);
        build_with(&flat_scene(1000), config);
        let p = Vec3A::new(1.0, -2.0, 3.0);
        build_with(&vec![Triangle::new(p, p, p); 300], config);
        build_with(&[Triangle::new(p, p + Vec3A::X, p + Vec3A::Y)], config);
        assert_eq!(build_with(&[], config), Bvh::empty());
    }
}

#[test]
fn sah_never_above_sbvh() {
    for tris in [
        needs_spatial(),
        soup(1500, 21, 10.0),
        clustered(800),
        degenerate_mix(),
    ] {
        for cost in [CostModel::AILA, CostModel::UNIT] {
            let input = BuildInput::new(&tris, cost).unwrap();
            let reference = sah(
                &SbvhBuilder::new(SbvhConfig::DEFAULT).build(&input).unwrap(),
                &cost,
            );
            let bvh = TsahSpatialBuilder::new(small()).build(&input).unwrap();
            bvh.validate(&tris).unwrap();
            let ours = sah(&bvh, &cost);
            assert!(
                ours <= reference * (1.0 + 1e-9),
                "tsah-sbvh {ours} vs sbvh {reference}"
            );
        }
    }
}

#[test]
fn improves_on_sbvh_somewhere() {
    let tris = soup(1500, 31, 10.0);
    let input = BuildInput::new(&tris, CostModel::default()).unwrap();
    let reference = sah(&SbvhBuilder::default().build(&input).unwrap(), &input.cost);
    let ours = sah(
        &TsahSpatialBuilder::new(small()).build(&input).unwrap(),
        &input.cost,
    );
    assert!(ours < reference, "tsah-sbvh {ours} vs sbvh {reference}");
}

#[test]
fn huge_min_size_is_plain_sbvh() {
    let tris = soup(800, 41, 10.0);
    let input = BuildInput::new(&tris, CostModel::default()).unwrap();
    let config = TsahSpatialConfig {
        min_size: usize::MAX,
        ..TsahSpatialConfig::DEFAULT
    };
    let a = TsahSpatialBuilder::new(config).build(&input).unwrap();
    let b = SbvhBuilder::default().build(&input).unwrap();
    assert!(bits(&a) == bits(&b));
}

#[test]
fn deterministic_across_thread_counts() {
    let mut tris = soup(2500, 51, 6.0);
    tris.extend(needs_spatial());
    let input = BuildInput::new(&tris, CostModel::default()).unwrap();
    let config = TsahSpatialConfig {
        min_size: 256,
        ..TsahSpatialConfig::DEFAULT
    };
    let run = |threads: usize| {
        rayon::ThreadPoolBuilder::new()
            .num_threads(threads)
            .build()
            .unwrap()
            .install(|| bits(&TsahSpatialBuilder::new(config).build(&input).unwrap()))
    };
    assert!(run(1) == run(2), "trees differ between 1 and 2 threads");
}

#[test]
fn invalid_config_is_rejected() {
    let tris = soup(10, 1, 1.0);
    let input = BuildInput::new(&tris, CostModel::default()).unwrap();
    let bad = TsahSpatialConfig {
        object_candidates: 0,
        ..TsahSpatialConfig::DEFAULT
    };
    assert!(TsahSpatialBuilder::new(bad).build(&input).is_err());
}

#[test]
fn registry_entry() {
    let e = registry::entries()
        .into_iter()
        .find(|e| e.name == "tsah-sbvh")
        .unwrap();
    assert!(e.spatial);
    let b = (e.make)();
    assert_eq!(b.name(), "tsah-sbvh");
    let tris = needs_spatial();
    let input = BuildInput::new(&tris, CostModel::default()).unwrap();
    b.build(&input).unwrap().validate(&tris).unwrap();
}
