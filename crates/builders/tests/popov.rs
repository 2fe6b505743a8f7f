//! The look-ahead SAH builders (after Popov et al.) and the hybrid with temporary subtrees.

mod common;
mod tsah_support;

use common::assert_rejected;
use sahara_builders::popov::{Frontier, PopovBuilder, PopovConfig};
use sahara_builders::sweep::{SweepBuilder, SweepConfig};
use sahara_builders::tsah::{Candidates, Temporary, TsahBuilder, TsahConfig};
use sahara_builders::{registry, BuildInput, Builder};
use sahara_fixtures::meshes::mesh_like;
use sahara_fixtures::soups::{box_soup, clustered_boxes};
use sahara_geom::Triangle;
use sahara_metrics::{sah, CostModel};
use tsah_support::*;

fn inputs() -> Vec<(String, Vec<Triangle>)> {
    with_degenerates(vec![
        ("soup", box_soup(2000, 1)),
        ("clustered", clustered_boxes(2000, 2)),
        ("mesh", mesh_like(25, 3)),
    ])
}

#[test]
fn presets_valid_deterministic_bounded() {
    for name in ["popov-d2", "popov-d3", "hybrid"] {
        let b = registry::by_name(name).expect(name);
        assert_eq!(b.name(), name);
        for (what, tris) in inputs() {
            check_builder(b.as_ref(), &tris, 8, &what);
        }
    }
    let b = PopovBuilder::new(PopovConfig {
        depth: 3,
        k: 2,
        per_axis: true,
        frontier: Frontier::Temporary,
        greedy_below: 0,
        max_leaf_size: 3,
    });
    for (what, tris) in inputs() {
        check_builder(&b, &tris, 3, &what);
    }
}

/// Depth 1 with leaf frontier is the greedy sweep builder, bit for bit.
#[test]
fn depth_one_is_sweep() {
    for (what, tris) in inputs() {
        for max_leaf in [1, 8] {
            let p = PopovBuilder::new(PopovConfig {
                depth: 1,
                k: 3,
                per_axis: false,
                frontier: Frontier::Leaf,
                greedy_below: 0,
                max_leaf_size: max_leaf,
            });
            let s = SweepBuilder::new(SweepConfig::DEFAULT.with_max_leaf_size(max_leaf));
            assert_eq!(build_in(&p, &tris, 2), build_in(&s, &tris, 1), "{what}");
        }
    }
}

/// Depth 1 with temporary frontier is the top-k temporary-subtree builder, bit for bit.
#[test]
fn hybrid_depth_one_is_tsah_top_k() {
    for (what, tris) in inputs() {
        for (k, per_axis, greedy_below) in [(1, false, 0), (4, false, 16), (2, true, 8)] {
            let p = PopovBuilder::new(PopovConfig {
                depth: 1,
                k,
                per_axis,
                frontier: Frontier::Temporary,
                greedy_below,
                max_leaf_size: 8,
            });
            let t = TsahBuilder::new(TsahConfig {
                candidates: Candidates::TopK { k, per_axis },
                temporary: Temporary::Sweep,
                greedy_below,
                always_include_greedy_best: true,
                max_leaf_size: 8,
            });
            assert_eq!(build_in(&p, &tris, 2), build_in(&t, &tris, 1), "{what}");
        }
    }
}

/// The hybrid applied at every node (no greedy nodes) never has a higher SAH than the sweep
/// builder: every look-ahead value is at most the cost of the sweep tree it could roll out.
#[test]
fn hybrid_everywhere_sah_never_above_sweep() {
    for cost in [CostModel::AILA, CostModel::UNIT] {
        for (what, tris) in inputs() {
            let input = BuildInput::new(&tris, cost).unwrap();
            let s = sah(&SweepBuilder::default().build(&input).unwrap(), &cost);
            let config = PopovConfig {
                greedy_below: 0,
                ..PopovConfig::HYBRID
            };
            let h = sah(&PopovBuilder::new(config).build(&input).unwrap(), &cost);
            assert!(h <= s * (1.0 + 1e-9), "{what}: hybrid {h} > sweep {s}");
        }
    }
}

#[test]
fn rejects_bad_configs() {
    assert_rejected(
        &box_soup(10, 1),
        [
            PopovConfig {
                depth: 0,
                ..PopovConfig::D2
            },
            PopovConfig {
                k: 0,
                ..PopovConfig::D2
            },
            PopovConfig {
                max_leaf_size: 0,
                ..PopovConfig::D2
            },
        ],
        PopovBuilder::new,
    );
}
