//! Tests of the temporary-subtree SAH builder with spatial splits.

use sahara_builders::sbvh::{SbvhBuilder, SbvhConfig};
use sahara_builders::tsah_spatial::{TemporarySearch, TsahSpatialBuilder, TsahSpatialConfig};
use sahara_builders::{BuildInput, Builder, Bvh};
use sahara_fixtures::soups::{clustered_centroid, flat_scene, sized_soup};
use sahara_geom::{Triangle, Vec3A};
use sahara_metrics::{sah, CostModel};

mod common;
mod spatial_support;
use common::*;
use spatial_support::*;

/// A smaller grid than the other spatial tests': 25 × 25 crossed by 50 diagonals one way.
fn small_needs_spatial() -> Vec<Triangle> {
    grid_crossed_by_diagonals(25, 4.0, 50, false)
}

/// A small threshold, so that small test inputs exercise the rating.
fn small() -> TsahSpatialConfig {
    TsahSpatialConfig {
        min_size: 24,
        ..TsahSpatialConfig::DEFAULT
    }
}

/// [`small`] with exact SBVH temporaries: the configuration with the SAH guarantee.
fn exact() -> TsahSpatialConfig {
    TsahSpatialConfig {
        min_size: 24,
        ..TsahSpatialConfig::EXACT
    }
}

/// The plain top-k candidates (no separation) with exact temporaries.
fn exact_top_k() -> TsahSpatialConfig {
    TsahSpatialConfig {
        object_separation: 0.0,
        spatial_separation: 0,
        ..exact()
    }
}

fn configs() -> Vec<TsahSpatialConfig> {
    vec![
        small(),
        exact(),
        TsahSpatialConfig {
            min_size: 24,
            ..TsahSpatialConfig::FAST
        },
        TsahSpatialConfig {
            temporary: SbvhConfig::FAST,
            temporary_search: TemporarySearch::Estimated {
                bins_per_ref: 3,
                min_bins: 2,
                refine: 1,
            },
            object_separation: 1.0,
            spatial_separation: 1000,
            ..small()
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
    let builder = TsahSpatialBuilder::new(config);
    let max_leaf_size = config.sbvh.max_leaf_size;
    let bvh = build_valid(&builder, tris, CostModel::default(), max_leaf_size, None);
    assert!(bvh.prim_indices.len() <= tris.len() + config.sbvh.budget_for(tris.len()));
    bvh
}

#[test]
fn random_soups_validate() {
    build_random_soups(1500, &configs(), build_with);
}

#[test]
fn clustered_degenerate_and_flat_inputs() {
    for config in configs() {
        build_with(&clustered_centroid(600), config);
        build_with(&degenerate_mix(200, 100, 40), config);
        build_with(&flat_scene(1000, 9.0), config);
        let p = Vec3A::new(1.0, -2.0, 3.0);
        build_with(&vec![Triangle::new(p, p, p); 300], config);
        build_with(&[Triangle::new(p, p + Vec3A::X, p + Vec3A::Y)], config);
        assert_eq!(build_with(&[], config), Bvh::empty());
    }
}

#[test]
fn sah_never_above_sbvh() {
    for tris in [
        small_needs_spatial(),
        sized_soup(1500, 21, 10.0),
        clustered_centroid(800),
        degenerate_mix(200, 100, 40),
    ] {
        for cost in [CostModel::AILA, CostModel::UNIT] {
            let input = BuildInput::new(&tris, cost).unwrap();
            let reference = sah(
                &SbvhBuilder::new(SbvhConfig::DEFAULT).build(&input).unwrap(),
                &cost,
            );
            for config in [exact(), exact_top_k()] {
                let bvh = TsahSpatialBuilder::new(config).build(&input).unwrap();
                bvh.validate(&tris).unwrap();
                let ours = sah(&bvh, &cost);
                assert!(
                    ours <= reference * (1.0 + 1e-9),
                    "tsah-sbvh {ours} vs sbvh {reference} with {config:?}"
                );
            }
        }
    }
}

#[test]
fn improves_on_sbvh_somewhere() {
    let tris = sized_soup(1500, 31, 10.0);
    let input = BuildInput::new(&tris, CostModel::default()).unwrap();
    let reference = sah(&SbvhBuilder::default().build(&input).unwrap(), &input.cost);
    for config in [small(), exact()] {
        let ours = sah(
            &TsahSpatialBuilder::new(config).build(&input).unwrap(),
            &input.cost,
        );
        assert!(ours < reference, "tsah-sbvh {ours} vs sbvh {reference}");
    }
}

#[test]
fn no_duplication_without_budget() {
    let mut tris = sized_soup(1000, 61, 10.0);
    tris.extend(small_needs_spatial());
    for base in [small(), exact()] {
        let no_budget = SbvhConfig {
            duplication_budget: 0.0,
            ..SbvhConfig::DEFAULT
        };
        let config = TsahSpatialConfig {
            sbvh: no_budget,
            temporary: no_budget,
            ..base
        };
        let bvh = build_with(&tris, config);
        assert_eq!(bvh.prim_indices.len(), tris.len());
    }
}

#[test]
fn huge_min_size_is_plain_sbvh() {
    let tris = sized_soup(800, 41, 10.0);
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
    let mut tris = sized_soup(2500, 51, 6.0);
    tris.extend(small_needs_spatial());
    let input = BuildInput::new(&tris, CostModel::default()).unwrap();
    for config in [
        TsahSpatialConfig::DEFAULT,
        TsahSpatialConfig {
            min_size: 256,
            ..TsahSpatialConfig::EXACT
        },
    ] {
        assert_same_tree_whatever_the_threads(|| {
            TsahSpatialBuilder::new(config).build(&input).unwrap()
        });
    }
}

#[test]
fn invalid_config_is_rejected() {
    let bad = [
        TsahSpatialConfig {
            object_candidates: 0,
            ..TsahSpatialConfig::DEFAULT
        },
        TsahSpatialConfig {
            object_separation: f32::NAN,
            ..TsahSpatialConfig::DEFAULT
        },
        TsahSpatialConfig {
            object_separation: 1.5,
            ..TsahSpatialConfig::DEFAULT
        },
        TsahSpatialConfig {
            temporary_search: TemporarySearch::Estimated {
                bins_per_ref: 1,
                min_bins: 1,
                refine: 2,
            },
            ..TsahSpatialConfig::DEFAULT
        },
        TsahSpatialConfig {
            temporary_search: TemporarySearch::Estimated {
                bins_per_ref: 1,
                min_bins: 4,
                refine: 0,
            },
            ..TsahSpatialConfig::DEFAULT
        },
    ];
    assert_rejected(&sized_soup(10, 1, 1.0), bad, TsahSpatialBuilder::new);
}

#[test]
fn registry_entry() {
    let e = entry("tsah-sbvh");
    assert!(e.spatial);
    assert!(!e.small_inputs_only);
    assert_eq!(e.max_practical_triangles, None);
    let b = (e.make)();
    assert_eq!(b.name(), "tsah-sbvh");
    let tris = small_needs_spatial();
    let input = BuildInput::new(&tris, CostModel::default()).unwrap();
    b.build(&input).unwrap().validate(&tris).unwrap();
}

#[test]
fn registry_entry_exact() {
    let e = entry("tsah-sbvh-exact");
    assert!(e.spatial);
    assert!(!e.small_inputs_only);
    assert_eq!(e.max_practical_triangles, Some(150_000));
    let b = (e.make)();
    assert_eq!(b.name(), "tsah-sbvh-exact");
    // The registered builder is the exact preset: its SAH is never above sbvh's, and on a
    // soup that needs spatial splits it is strictly below (the exact temporaries see splits
    // that sbvh's greedy rule misses).
    let mut tris = sized_soup(1200, 47, 10.0);
    tris.extend(small_needs_spatial());
    let input = BuildInput::new(&tris, CostModel::default()).unwrap();
    let bvh = b.build(&input).unwrap();
    bvh.validate(&tris).unwrap();
    let ours = sah(&bvh, &input.cost);
    let reference = sah(&SbvhBuilder::default().build(&input).unwrap(), &input.cost);
    let direct = sah(
        &TsahSpatialBuilder::new(TsahSpatialConfig::EXACT)
            .build(&input)
            .unwrap(),
        &input.cost,
    );
    assert_eq!(ours, direct, "the entry must build the EXACT preset");
    assert!(
        ours < reference,
        "tsah-sbvh-exact {ours} vs sbvh {reference}"
    );
}
