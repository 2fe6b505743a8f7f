//! Tests of the Morton-cluster binned builder (`cluster-binned`).

use sahara_builders::cluster_binned::{ClusterBinnedBuilder, ClusterBinnedConfig};
use sahara_builders::{BuildInput, Builder, Bvh};
use sahara_fixtures::soups::{self, sized_soup};
use sahara_geom::{Triangle, Vec3A};
use sahara_metrics::CostModel;

mod common;
mod spatial_support;
use common::assert_rejected;
use spatial_support::{assert_same_tree_whatever_the_threads, build_valid};

fn build(tris: &[Triangle], config: ClusterBinnedConfig) -> Bvh {
    let (builder, max_leaf) = (ClusterBinnedBuilder::new(config), config.max_leaf_size);
    build_valid(&builder, tris, CostModel::default(), max_leaf, Some(false))
}

#[test]
fn soups_degenerate_and_coincident_inputs_validate() {
    let one = Triangle::new(Vec3A::ZERO, Vec3A::X, Vec3A::Y);
    let inputs = [
        sized_soup(1, 1, 5.0),
        sized_soup(2, 2, 5.0),
        sized_soup(100, 3, 5.0),
        sized_soup(5000, 4, 5.0),
        soups::degenerate_mix(sized_soup(300, 11, 5.0), 200, Vec3A::X, Vec3A::Y, 50),
        // One Morton code for all: the clusters are runs of equal codes.
        vec![one; 1000],
    ];
    for tris in &inputs {
        for config in [
            ClusterBinnedConfig::DEFAULT,
            ClusterBinnedConfig {
                cluster_size: 1,
                always_leaf: 0,
                ..ClusterBinnedConfig::DEFAULT
            },
            ClusterBinnedConfig {
                cluster_size: 100,
                bins: 2,
                max_leaf_size: 4,
                always_leaf: 4,
            },
        ] {
            build(tris, config);
        }
    }
}

#[test]
fn the_tree_does_not_depend_on_the_thread_count() {
    // Large enough for the parallel sort, the parallel top and several workers.
    let tris = sized_soup(40_000, 7, 5.0);
    let input = BuildInput::new(&tris, CostModel::default()).unwrap();
    assert_same_tree_whatever_the_threads(|| {
        ClusterBinnedBuilder::default().build(&input).unwrap()
    });
}

#[test]
fn invalid_configurations_are_rejected() {
    assert_rejected(
        &sized_soup(10, 1, 5.0),
        [
            ClusterBinnedConfig {
                bins: 1,
                ..ClusterBinnedConfig::DEFAULT
            },
            ClusterBinnedConfig {
                cluster_size: 0,
                ..ClusterBinnedConfig::DEFAULT
            },
            ClusterBinnedConfig {
                max_leaf_size: 0,
                always_leaf: 0,
                ..ClusterBinnedConfig::DEFAULT
            },
            ClusterBinnedConfig {
                always_leaf: 9,
                ..ClusterBinnedConfig::DEFAULT
            },
        ],
        ClusterBinnedBuilder::new,
    );
}
