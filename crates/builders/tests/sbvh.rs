//! Tests of the SBVH builder (spatial splits).

use sahara_builders::binned::{BinnedBuilder, BinnedConfig};
use sahara_builders::sbvh::{sbvh_cost_only, ObjectSplitMethod, SbvhBuilder, SbvhConfig};
use sahara_builders::{BuildInput, Builder, Bvh};
use sahara_fixtures::soups::{clustered_centroid, flat_scene, rand_point, sized_soup};
use sahara_geom::rng::Pcg32;
use sahara_geom::{Triangle, Vec3A};
use sahara_metrics::{sah, CostModel};

mod common;
mod spatial_support;
use common::*;
use spatial_support::*;

fn build_with(tris: &[Triangle], config: SbvhConfig, cost: CostModel) -> Bvh {
    let builder = SbvhBuilder::new(config);
    let bvh = build_valid(&builder, tris, cost, config.max_leaf_size, Some(true));
    let budget = config.budget_for(tris.len());
    assert!(bvh.prim_indices.len() <= tris.len() + budget);
    bvh
}

fn build(tris: &[Triangle], config: SbvhConfig) -> Bvh {
    build_with(tris, config, CostModel::default())
}

fn configs() -> Vec<SbvhConfig> {
    vec![
        SbvhConfig::DEFAULT,
        SbvhConfig::FAST,
        SbvhConfig::REFINED,
        SbvhConfig {
            coarse_spatial_bins: 2,
            spatial_bins: 5,
            max_leaf_size: 1,
            ..SbvhConfig::DEFAULT
        },
        SbvhConfig {
            unsplitting: false,
            ..SbvhConfig::DEFAULT
        },
        SbvhConfig {
            alpha: 0.0,
            max_leaf_size: 1,
            ..SbvhConfig::DEFAULT
        },
        SbvhConfig {
            spatial_bins: 0,
            ..SbvhConfig::DEFAULT
        },
        SbvhConfig::FAST_GATED,
    ]
}

#[test]
fn random_soups_validate() {
    build_random_soups(3000, &configs(), build);
}

#[test]
fn spatial_splits_happen_and_duplicate() {
    let tris = needs_spatial();
    let bvh = build(&tris, SbvhConfig::DEFAULT);
    assert!(bvh.prim_indices.len() > tris.len());
    // Without spatial bins there is no duplication.
    let plain = build(
        &tris,
        SbvhConfig {
            spatial_bins: 0,
            ..SbvhConfig::DEFAULT
        },
    );
    assert_eq!(plain.prim_indices.len(), tris.len());
}

#[test]
fn sah_below_binned_where_spatial_splits_help() {
    let tris = needs_spatial();
    for cost in [CostModel::AILA, CostModel::UNIT] {
        let input = BuildInput::new(&tris, cost).unwrap();
        let binned = sah(
            &BinnedBuilder::new(BinnedConfig::DEFAULT)
                .build(&input)
                .unwrap(),
            &cost,
        );
        let sbvh = sah(&build_with(&tris, SbvhConfig::DEFAULT, cost), &cost);
        assert!(sbvh < 0.8 * binned, "sbvh {sbvh} vs binned {binned}");
        // The coarse-to-fine search finds planes as good as the full one here.
        let refined = sah(&build_with(&tris, SbvhConfig::REFINED, cost), &cost);
        assert!(refined <= 1.01 * sbvh, "refined {refined} vs sbvh {sbvh}");
    }
}

#[test]
fn zero_budget_means_no_duplication() {
    let tris = needs_spatial();
    let bvh = build(
        &tris,
        SbvhConfig {
            duplication_budget: 0.0,
            ..SbvhConfig::DEFAULT
        },
    );
    assert_eq!(bvh.prim_indices.len(), tris.len());
    let small = SbvhConfig {
        duplication_budget: 0.05,
        ..SbvhConfig::DEFAULT
    };
    build(&tris, small);
}

#[test]
fn clustered_centroids_respect_max_leaf() {
    for config in configs() {
        build(&clustered_centroid(3000), config);
    }
}

#[test]
fn degenerate_inputs() {
    for config in configs() {
        build_degenerate_inputs(|tris| build(tris, config));
    }
    assert_empty_input_builds_empty_tree(&SbvhBuilder::default());
}

#[test]
fn flat_scene_validates() {
    for config in configs() {
        build(&flat_scene(2000, 9.0), config);
    }
}

#[test]
fn huge_and_tiny_triangles_mixed() {
    // A wide range of sizes, as in real scenes: big walls and tiny details.
    let mut tris = sized_soup(2000, 61, 0.05);
    let mut rng = Pcg32::new(3, 3);
    for _ in 0..200 {
        tris.push(Triangle::new(
            rand_point(&mut rng, -1000.0, 1000.0),
            rand_point(&mut rng, -1000.0, 1000.0),
            rand_point(&mut rng, -1000.0, 1000.0),
        ));
    }
    for config in configs() {
        build(&tris, config);
    }
}

/// The overlap gate (`overlap_ratio`) searches spatial splits at fewer nodes: on a scene where
/// spatial splits happen, every ratio gives a valid tree, a ratio of 0 is the ungated builder
/// bit for bit, 0.2 duplicates strictly fewer references than no gate, and a ratio no overlap
/// can reach (an overlap is at most either side's area, so at most half their sum) leaves no
/// spatial split at all.
#[test]
fn overlap_gate_searches_spatial_splits_at_fewer_nodes() {
    let mut tris = needs_spatial();
    tris.extend(sized_soup(3000, 91, 8.0));
    let refs = |ratio: f32| {
        let bvh = build(
            &tris,
            SbvhConfig {
                overlap_ratio: ratio,
                ..SbvhConfig::FAST
            },
        );
        (bvh.fingerprint(), bvh.prim_indices.len())
    };
    let (ungated_fp, ungated) = refs(0.0);
    let fast = build(&tris, SbvhConfig::FAST);
    assert_eq!(
        ungated_fp,
        fast.fingerprint(),
        "ratio 0 must not change the tree"
    );
    let (_, gated) = refs(SbvhConfig::FAST_GATED.overlap_ratio);
    let (_, closed) = refs(0.6);
    assert!(ungated > tris.len(), "the scene must have spatial splits");
    assert!(
        gated < ungated,
        "the gate must cut duplication: {gated} refs gated, {ungated} ungated"
    );
    assert!(gated > tris.len(), "0.2 still lets the diagonals be split");
    assert_eq!(
        closed,
        tris.len(),
        "no overlap reaches 0.6 of the sides' areas"
    );
}

#[test]
fn invalid_config_is_rejected() {
    assert_rejected(
        &sized_soup(10, 1, 1.0),
        [
            SbvhConfig {
                max_leaf_size: 0,
                ..SbvhConfig::DEFAULT
            },
            SbvhConfig {
                alpha: f32::NAN,
                ..SbvhConfig::DEFAULT
            },
            SbvhConfig {
                duplication_budget: -1.0,
                ..SbvhConfig::DEFAULT
            },
            SbvhConfig {
                overlap_ratio: f32::NAN,
                ..SbvhConfig::DEFAULT
            },
            SbvhConfig {
                overlap_ratio: -0.5,
                ..SbvhConfig::DEFAULT
            },
            SbvhConfig {
                overlap_ratio: f32::INFINITY,
                ..SbvhConfig::DEFAULT
            },
            SbvhConfig {
                object_split: ObjectSplitMethod::Binned { bins: 1 },
                ..SbvhConfig::DEFAULT
            },
        ],
        SbvhBuilder::new,
    );
}

#[test]
fn cost_only_equals_sah_of_tree() {
    for (tris, config) in [
        (needs_spatial(), SbvhConfig::DEFAULT),
        (sized_soup(5000, 71, 10.0), SbvhConfig::DEFAULT),
        (sized_soup(3000, 72, 10.0), SbvhConfig::FAST),
        (degenerate_mix(300, 200, 50), SbvhConfig::DEFAULT),
    ] {
        let input = BuildInput::new(&tris, CostModel::default()).unwrap();
        let bvh = SbvhBuilder::new(config).build(&input).unwrap();
        let prims: Vec<u32> = (0..tris.len() as u32).collect();
        let c = sbvh_cost_only(&input, &prims, &config);
        let s = sah(&bvh, &input.cost);
        assert!((c - s).abs() <= 1e-9 * s, "cost-only {c} vs sah {s}");
    }
}

#[test]
fn deterministic_across_thread_counts() {
    assert_deterministic_on_a_large_spatial_input(&SbvhBuilder::default());
}

#[test]
fn registry_entry() {
    registered_spatial_tree("sbvh");
}

/// Triangles that are flat (or one unit in the last place thick) along an axis, far from the
/// origin, crossing each other: clipped pieces' boxes must still touch their triangles.
fn near_flat(n: usize, seed: u64) -> Vec<Triangle> {
    let mut rng = Pcg32::new(seed, 17);
    let base = 11.58724f32;
    let ulp = f32::from_bits(base.to_bits() + 1) - base;
    (0..n)
        .map(|i| {
            let axis = i % 3;
            let mut p = || {
                let mut v = rand_point(&mut rng, 0.0, 20.0);
                v[axis] = base + ulp * rng.below(2) as f32;
                v + Vec3A::splat(1000.0 * (axis as f32))
            };
            Triangle::new(p(), p(), p())
        })
        .collect()
}

/// Long slivers one unit in the last place thick along x, among many tiny triangles, so that
/// spatial splits cut the slivers into short pieces (as happens in Sponza).
fn slivers(seed: u64) -> Vec<Triangle> {
    let mut rng = Pcg32::new(seed, 23);
    let mut tris = Vec::new();
    for base in [11.58724f32, 7.300001, 101.7] {
        let ulp = f32::from_bits(base.to_bits() + 1) - base;
        for k in 0..10 {
            let d = k as f32 * 0.05;
            tris.push(Triangle::new(
                Vec3A::new(base, 14.783308 - d, 0.081487 + d),
                Vec3A::new(base, 14.803308 - d, 0.101488 + d),
                Vec3A::new(base + ulp, 11.76331 - d, 3.181487 + d),
            ));
        }
        for _ in 0..1500 {
            let c = Vec3A::new(
                base + rng.range_f32(-0.01, 0.01),
                rng.range_f32(11.0, 15.0),
                rng.range_f32(0.0, 3.5),
            );
            let s = 0.01;
            tris.push(Triangle::new(
                c,
                c + Vec3A::new(0.0, s, 0.0),
                c + Vec3A::new(s, 0.0, s),
            ));
        }
    }
    tris
}

#[test]
fn near_flat_triangles_validate() {
    for seed in 0..2 {
        let tris = slivers(seed);
        for config in configs() {
            build(&tris, config);
        }
        let tris = near_flat(1500, seed);
        build(&tris, SbvhConfig::DEFAULT);
    }
}
