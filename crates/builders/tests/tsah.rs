//! The temporary-subtree SAH builders (Wodniok & Goesele).

mod common;
mod tsah_support;

use common::assert_rejected;
use sahara_builders::sweep::{SweepBuilder, SweepConfig};
use sahara_builders::tsah::{Candidates, Temporary, TsahBuilder, TsahConfig};
use sahara_builders::{registry, BuildInput, Builder};
use sahara_fixtures::meshes::mesh_like;
use sahara_fixtures::soups::{box_soup, clustered_boxes, named_degenerates};
use sahara_geom::{Aabb, Triangle};
use sahara_metrics::{sah, CostModel};
use tsah_support::*;

fn presets() -> Vec<(&'static str, TsahConfig)> {
    vec![
        ("tsah-topk", TsahConfig::TOP_K),
        ("tsah-binned", TsahConfig::BINNED),
        ("tsah-exhaustive", TsahConfig::EXHAUSTIVE),
    ]
}

fn inputs(small: bool) -> Vec<(String, Vec<Triangle>)> {
    let (a, b) = if small { (150, 9) } else { (3000, 30) };
    with_degenerates(vec![
        ("soup", box_soup(a, 1)),
        ("clustered", clustered_boxes(a, 2)),
        ("mesh", mesh_like(b, 3)),
    ])
}

#[test]
fn presets_valid_deterministic_bounded() {
    for (name, config) in presets() {
        let small = config.candidates == Candidates::Exhaustive;
        let b = TsahBuilder::named(name, config);
        for (what, tris) in inputs(small) {
            check_builder(&b, &tris, config.max_leaf_size, &what);
        }
    }
}

#[test]
fn other_configurations_valid_deterministic_bounded() {
    let configs = [
        TsahConfig {
            candidates: Candidates::TopK {
                k: 3,
                per_axis: true,
            },
            greedy_below: 0,
            max_leaf_size: 2,
            ..TsahConfig::TOP_K
        },
        TsahConfig {
            candidates: Candidates::TopK {
                k: 2,
                per_axis: false,
            },
            temporary: Temporary::Binned { bins: 4 },
            always_include_greedy_best: false,
            greedy_below: 4,
            max_leaf_size: 1,
        },
        TsahConfig {
            candidates: Candidates::Binned { bins_per_axis: 16 },
            temporary: Temporary::Sweep,
            always_include_greedy_best: false,
            greedy_below: 0,
            max_leaf_size: 5,
        },
    ];
    for config in configs {
        let b = TsahBuilder::new(config);
        for (what, tris) in inputs(false) {
            check_builder(&b, &tris, config.max_leaf_size, &what);
        }
    }
}

#[test]
fn registered_presets() {
    let entries = registry::entries();
    for name in ["tsah-exhaustive", "tsah-topk", "tsah-binned"] {
        let e = entries.iter().find(|e| e.name == name).expect(name);
        assert_eq!(e.small_inputs_only, name == "tsah-exhaustive");
        assert!(!e.spatial);
        let b = (e.make)();
        assert_eq!(b.name(), name);
        assert!(!b.describe().is_empty());
        let tris = box_soup(120, 4);
        check_builder(b.as_ref(), &tris, 8, name);
    }
}

#[test]
fn rejects_bad_configs() {
    let bad = [
        TsahConfig {
            max_leaf_size: 0,
            ..TsahConfig::TOP_K
        },
        TsahConfig {
            candidates: Candidates::TopK {
                k: 0,
                per_axis: false,
            },
            ..TsahConfig::TOP_K
        },
        TsahConfig {
            candidates: Candidates::Binned { bins_per_axis: 1 },
            ..TsahConfig::TOP_K
        },
        TsahConfig {
            temporary: Temporary::Binned { bins: 1 },
            ..TsahConfig::TOP_K
        },
    ];
    assert_rejected(&box_soup(10, 1), bad, TsahBuilder::new);
}

/// With the greedy-best split always rated and sweep temporaries, the tree's SAH is never
/// above the sweep builder's (the induction in docs/builders-tsah.md, "SAH guarantee").
#[test]
fn sah_never_above_sweep() {
    let scenes: Vec<(&str, Vec<Triangle>)> = vec![
        ("soup", box_soup(2500, 41)),
        ("clustered", clustered_boxes(2500, 42)),
        ("mesh", mesh_like(32, 43)),
        (
            "degenerate",
            named_degenerates()
                .into_iter()
                .flat_map(|(_, t)| t)
                .collect(),
        ),
    ];
    let candidates = [
        Candidates::TopK {
            k: 1,
            per_axis: false,
        },
        Candidates::TopK {
            k: 4,
            per_axis: false,
        },
        Candidates::TopK {
            k: 2,
            per_axis: true,
        },
        Candidates::Binned { bins_per_axis: 4 },
        Candidates::Binned { bins_per_axis: 12 },
    ];
    for cost in [CostModel::AILA, CostModel::UNIT] {
        for (name, tris) in &scenes {
            let input = BuildInput::new(tris, cost).unwrap();
            for max_leaf in [1, 4, 8] {
                let sweep = SweepBuilder::new(SweepConfig::DEFAULT.with_max_leaf_size(max_leaf))
                    .build(&input)
                    .unwrap();
                let s = sah(&sweep, &cost);
                for cand in candidates {
                    for greedy_below in [0, 16] {
                        let config = TsahConfig {
                            candidates: cand,
                            temporary: Temporary::Sweep,
                            greedy_below,
                            always_include_greedy_best: true,
                            max_leaf_size: max_leaf,
                        };
                        let t = TsahBuilder::new(config).build(&input).unwrap();
                        let ts = sah(&t, &cost);
                        assert!(
                            ts <= s * (1.0 + 1e-9),
                            "{name}, {config:?}, {cost:?}: tsah {ts} > sweep {s}"
                        );
                    }
                }
            }
        }
    }
}

// --- An obviously correct reference for the exhaustive preset --------------------------------

struct Ref<'a> {
    input: &'a BuildInput<'a>,
    max_leaf: usize,
}

impl Ref<'_> {
    fn union(&self, s: &[u32]) -> Aabb {
        s.iter().fold(Aabb::EMPTY, |b, &i| {
            b.union(&self.input.bounds()[i as usize])
        })
    }

    fn sorted(&self, ids: &[u32], axis: usize) -> Vec<u32> {
        let c = self.input.centroids();
        let mut s = ids.to_vec();
        s.sort_by(|&a, &b| {
            c[a as usize][axis]
                .total_cmp(&c[b as usize][axis])
                .then(a.cmp(&b))
        });
        s
    }

    /// Picks the minimum of `(rating, |2i - n|, axis, i)` over every sweep candidate.
    fn best(&self, ids: &[u32], rate: impl Fn(&[u32], &[u32]) -> f64) -> (f64, Vec<u32>, usize) {
        let n = ids.len();
        let mut best: Option<(f64, usize, usize, usize, Vec<u32>)> = None;
        for axis in 0..3 {
            let s = self.sorted(ids, axis);
            for i in 1..n {
                let r = rate(&s[..i], &s[i..]);
                let key = ((2 * i).abs_diff(n), axis, i);
                let better = match &best {
                    None => true,
                    Some(b) => match r.total_cmp(&b.0) {
                        std::cmp::Ordering::Less => true,
                        std::cmp::Ordering::Greater => false,
                        std::cmp::Ordering::Equal => key < (b.1, b.2, b.3),
                    },
                };
                if better {
                    best = Some((r, key.0, key.1, key.2, s.clone()));
                }
            }
        }
        let (r, _, _, i, s) = best.unwrap();
        (r, s, i)
    }

    /// The cost of the greedy sweep tree over `ids` (naive: boxes from scratch).
    fn sweep_cost(&self, ids: &[u32]) -> f64 {
        let cost = self.input.cost;
        let n = ids.len();
        if n == 1 {
            return cost.leaf_cost(1);
        }
        let pa = self.union(ids).half_area() as f64;
        let (c, s, i) = self.best(ids, |l, r| {
            cost.split_cost(
                pa,
                self.union(l).half_area() as f64,
                l.len(),
                self.union(r).half_area() as f64,
                r.len(),
            )
        });
        if n <= self.max_leaf && c >= cost.leaf_cost(n) {
            return cost.leaf_cost(n);
        }
        let (l, r) = s.split_at(i);
        self.cost_over_sweep_trees(pa, l, r)
    }

    /// The cost of an inner node of half area `pa` whose children are the greedy sweep trees
    /// over `l` and `r`.
    fn cost_over_sweep_trees(&self, pa: f64, l: &[u32], r: &[u32]) -> f64 {
        self.input.cost.inner_cost(
            pa,
            self.union(l).half_area() as f64,
            self.sweep_cost(l),
            self.union(r).half_area() as f64,
            self.sweep_cost(r),
        )
    }

    /// One-step look-ahead with greedy rollout: every candidate rated by the sweep trees of
    /// both sides; appends the leaves in depth-first order.
    fn tsah(&self, ids: &[u32], out: &mut Vec<Vec<u32>>) {
        let cost = self.input.cost;
        let n = ids.len();
        if n == 1 {
            out.push(ids.to_vec());
            return;
        }
        let pa = self.union(ids).half_area() as f64;
        let (c, s, i) = self.best(ids, |l, r| self.cost_over_sweep_trees(pa, l, r));
        if n <= self.max_leaf && cost.leaf_cost(n) <= c {
            out.push(ids.to_vec());
            return;
        }
        self.tsah(&s[..i], out);
        self.tsah(&s[i..], out);
    }
}

#[test]
fn exhaustive_equals_brute_force_reference() {
    let mut cases: Vec<Vec<Triangle>> = (0..6).map(|s| box_soup(40, 100 + s)).collect();
    cases.push(clustered_boxes(40, 7));
    cases.push(mesh_like(4, 8));
    cases.push(
        named_degenerates()
            .into_iter()
            .flat_map(|(_, t)| t)
            .take(45)
            .collect(),
    );
    let mut differs = 0;
    for cost in [
        CostModel::AILA,
        CostModel {
            traversal: 0.5,
            intersection: 1.5,
        },
    ] {
        for tris in &cases {
            for max_leaf in [1, 4] {
                let input = BuildInput::new(tris, cost).unwrap();
                let reference = Ref {
                    input: &input,
                    max_leaf,
                };
                let ids: Vec<u32> = (0..tris.len() as u32).collect();
                let mut expect = Vec::new();
                reference.tsah(&ids, &mut expect);
                for l in &mut expect {
                    l.sort_unstable();
                }
                let config = TsahConfig {
                    max_leaf_size: max_leaf,
                    ..TsahConfig::EXHAUSTIVE
                };
                let bvh = TsahBuilder::new(config).build(&input).unwrap();
                bvh.validate(tris).unwrap();
                assert_eq!(shape(&bvh).1, expect, "leaf {max_leaf}, {cost:?}");
                // And the reference's naive sweep cost agrees with the sweep builder's tree.
                let sweep = SweepBuilder::new(SweepConfig::DEFAULT.with_max_leaf_size(max_leaf))
                    .build(&input)
                    .unwrap();
                let a = reference.sweep_cost(&ids);
                let b = sah(&sweep, &cost);
                assert!((a - b).abs() <= 1e-9 * a, "{a} vs {b}");
                if shape(&sweep) != shape(&bvh) {
                    differs += 1;
                }
            }
        }
    }
    // The comparison is not vacuous: most trees differ from the greedy ones.
    assert!(differs >= 10, "only {differs} trees differ from sweep");
    eprintln!(
        "{differs} of {} exhaustive trees differ from sweep",
        cases.len() * 4
    );
}

/// Inputs large enough that candidates are rated in parallel and both sides of a candidate
/// are built on two tasks: still the same tree with 1 and 2 threads.
#[test]
fn parallel_rating_paths_are_deterministic() {
    let tris = box_soup(9000, 61);
    for config in [TsahConfig::TOP_K, TsahConfig::BINNED] {
        check_builder(&TsahBuilder::new(config), &tris, 8, "soup-9000");
    }
}
