//! Tests of the in-place binned spatial-split builder (`spatial-binned`).

use sahara_builders::binned::{BinnedBuilder, BinnedConfig};
use sahara_builders::spatial_binned::{SpatialBinnedBuilder, SpatialBinnedConfig};
use sahara_builders::{BuildInput, Builder, Bvh};
use sahara_fixtures::soups::{clustered_centroid, flat_scene, sized_soup};
use sahara_geom::Triangle;
use sahara_metrics::{sah, CostModel};

mod common;
mod spatial_support;
use common::*;
use spatial_support::*;

/// Builds, validates, and checks the leaf size and the replication budget.
fn build_with(tris: &[Triangle], config: SpatialBinnedConfig, cost: CostModel) -> Bvh {
    let builder = SpatialBinnedBuilder::new(config);
    let bvh = build_valid(&builder, tris, cost, config.max_leaf_size, Some(true));
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
    build_random_soups(3000, &configs(), build);
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
        build_degenerate_inputs(|tris| build(tris, config));
        build(&flat_scene(2000, 9.0), config);
    }
    assert_empty_input_builds_empty_tree(&SpatialBinnedBuilder::default());
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
    assert_rejected(
        &needs_spatial(),
        [
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
        ],
        SpatialBinnedBuilder::new,
    );
}

#[test]
fn deterministic_across_thread_counts() {
    assert_deterministic_on_a_large_spatial_input(&SpatialBinnedBuilder::default());
}

#[test]
fn registry_entry() {
    let (tris, bvh) = registered_spatial_tree("spatial-binned");
    assert!(bvh.prim_indices.len() > tris.len());
}
