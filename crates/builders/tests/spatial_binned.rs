//! Tests of the in-place binned spatial-split builder (`spatial-binned`).

use sahara_builders::binned::{BinnedBuilder, BinnedConfig};
use sahara_builders::spatial_binned::{SpatialBinnedBuilder, SpatialBinnedConfig};
use sahara_builders::{registry, BuildInput, Builder, Bvh};
use sahara_fixtures::soups::{clustered_centroid, flat_scene, sized_soup};
use sahara_geom::{Triangle, Vec3A};
use sahara_metrics::{sah, CostModel};

mod spatial_support;
use spatial_support::*;

/// Builds, validates, and checks the leaf size and the replication budget.
fn build_with(tris: &[Triangle], config: SpatialBinnedConfig, cost: CostModel) -> Bvh {
    let input = BuildInput::new(tris, cost).unwrap();
    let bvh = SpatialBinnedBuilder::new(config).build(&input).unwrap();
    bvh.validate(tris).unwrap();
    if !tris.is_empty() {
        assert!(bvh.spatial_splits);
    }
    assert!(max_leaf(&bvh) <= config.max_leaf_size);
    assert!(bvh.prim_indices.len() <= config.slots_for(tris.len()));
    bvh
}

fn build(tris: &[Triangle], config: SpatialBinnedConfig) -> Bvh {
    build_with(tris, config, CostModel::default())
}

fn configs() -> Vec<SpatialBinnedConfig> {
    let d = SpatialBinnedConfig::DEFAULT;
    vec![
        d,
        // Every reference cut into its bins (Stich et al.'s search).
        SpatialBinnedConfig {
            refine_planes: 0,
            ..d
        },
        SpatialBinnedConfig {
            refine_planes: 5,
            spatial_bins: 3,
            budget: 2.0,
            overlap_ratio: 0.0,
            alpha: 0.0,
            ..d
        },
        SpatialBinnedConfig {
            unsplitting: false,
            max_leaf_size: 1,
            ..d
        },
        SpatialBinnedConfig {
            object_bins: 2,
            max_leaf_size: 2,
            fallback_depth: 4,
            ..d
        },
    ]
}

#[test]
fn random_soups_validate() {
    for (n, seed) in [(1, 1), (2, 2), (9, 3), (100, 4), (3000, 5)] {
        for config in configs() {
            build(&sized_soup(n, seed, 8.0), config);
        }
    }
}

#[test]
fn spatial_splits_happen_duplicate_and_pay() {
    let tris = needs_spatial();
    for cost in [CostModel::AILA, CostModel::UNIT] {
        let input = BuildInput::new(&tris, cost).unwrap();
        let binned = BinnedBuilder::new(BinnedConfig::DEFAULT)
            .build(&input)
            .unwrap();
        for config in [
            SpatialBinnedConfig::DEFAULT,
            SpatialBinnedConfig {
                refine_planes: 0,
                ..SpatialBinnedConfig::DEFAULT
            },
        ] {
            let bvh = build_with(&tris, config, cost);
            assert!(bvh.prim_indices.len() > tris.len());
            let (s, b) = (sah(&bvh, &cost), sah(&binned, &cost));
            assert!(s < 0.85 * b, "spatial-binned {s} vs binned {b}");
        }
    }
}

/// Without spare slots (or without spatial bins) nothing is ever cut, and the builder is the
/// binned builder: the same searches, partitions and leaves give the same tree, bit for bit.
#[test]
fn without_budget_it_is_the_binned_builder() {
    for tris in [
        needs_spatial(),
        sized_soup(5000, 7, 4.0),
        clustered_centroid(3000),
    ] {
        let input = BuildInput::new(&tris, CostModel::default()).unwrap();
        let binned = BinnedBuilder::new(BinnedConfig::DEFAULT)
            .build(&input)
            .unwrap();
        for config in [
            SpatialBinnedConfig {
                budget: 0.0,
                ..SpatialBinnedConfig::DEFAULT
            },
            SpatialBinnedConfig {
                spatial_bins: 1,
                ..SpatialBinnedConfig::DEFAULT
            },
        ] {
            let bvh = SpatialBinnedBuilder::new(config).build(&input).unwrap();
            assert_eq!(bvh.prim_indices.len(), tris.len());
            assert_eq!(bits(&bvh), bits(&binned));
        }
    }
}

#[test]
fn a_small_budget_is_never_exceeded() {
    let tris = needs_spatial();
    for budget in [0.001, 0.01, 0.05] {
        let config = SpatialBinnedConfig {
            budget,
            overlap_ratio: 0.0,
            ..SpatialBinnedConfig::DEFAULT
        };
        let bvh = build(&tris, config);
        assert!(bvh.prim_indices.len() <= config.slots_for(tris.len()));
    }
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
        build(&degenerate_mix(300, 200, 50), config);
        let p = Vec3A::new(1.0, -2.0, 3.0);
        let bvh = build(&vec![Triangle::new(p, p, p); 500], config);
        assert!(bvh.stats().depth <= 12);
        build(&[Triangle::new(p, p + Vec3A::X, p + Vec3A::Y)], config);
        build(&[], config);
        let line: Vec<Triangle> = (0..300)
            .map(|i| {
                let o = Vec3A::splat(i as f32 * 0.3);
                Triangle::new(o, o + Vec3A::splat(40.0), o + Vec3A::splat(20.0))
            })
            .collect();
        build(&line, config);
        build(&flat_scene(2000, 9.0), config);
    }
    let input = BuildInput::new(&[], CostModel::default()).unwrap();
    assert_eq!(
        SpatialBinnedBuilder::default().build(&input).unwrap(),
        Bvh::empty()
    );
}

#[test]
fn huge_and_tiny_triangles_mixed() {
    let mut tris = sized_soup(2000, 11, 1e-4);
    tris.extend(sized_soup(50, 12, 1e6));
    tris.extend(needs_spatial());
    for config in configs() {
        build(&tris, config);
    }
}

#[test]
fn invalid_config_is_rejected() {
    let d = SpatialBinnedConfig::DEFAULT;
    let tris = needs_spatial();
    let input = BuildInput::new(&tris, CostModel::default()).unwrap();
    for bad in [
        SpatialBinnedConfig {
            object_bins: 1,
            ..d
        },
        SpatialBinnedConfig {
            max_leaf_size: 0,
            ..d
        },
        SpatialBinnedConfig {
            budget: f32::NAN,
            ..d
        },
        SpatialBinnedConfig { budget: -1.0, ..d },
        SpatialBinnedConfig {
            alpha: f32::INFINITY,
            ..d
        },
        SpatialBinnedConfig {
            overlap_ratio: -0.5,
            ..d
        },
    ] {
        assert!(SpatialBinnedBuilder::new(bad).build(&input).is_err());
    }
}

#[test]
fn deterministic_across_thread_counts() {
    let mut tris = sized_soup(30_000, 81, 6.0);
    tris.extend(needs_spatial());
    let input = BuildInput::new(&tris, CostModel::default()).unwrap();
    assert_same_tree_whatever_the_threads(|| {
        let bvh = SpatialBinnedBuilder::default().build(&input).unwrap();
        bvh.validate(&tris).unwrap();
        bvh
    });
}

#[test]
fn registry_entry() {
    let b = registry::by_name("spatial-binned").unwrap();
    assert_eq!(b.name(), "spatial-binned");
    let e = registry::entries()
        .into_iter()
        .find(|e| e.name == "spatial-binned")
        .unwrap();
    assert!(e.spatial);
    let tris = needs_spatial();
    let input = BuildInput::new(&tris, CostModel::default()).unwrap();
    let bvh = b.build(&input).unwrap();
    bvh.validate(&tris).unwrap();
    assert!(bvh.prim_indices.len() > tris.len());
}
