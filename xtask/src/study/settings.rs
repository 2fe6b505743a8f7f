//! The study's settings as data: one row of [`SETTINGS`] per setting of a factor, in report
//! order, with the runs it belongs to (quick, full or both), its cost model, reference,
//! camera, whether it is heavy, and the builder it makes ([`Make`]).

use anyhow::{bail, Result};
use sahara_builders::popov::{PopovBuilder, PopovConfig};
use sahara_builders::sbvh::{SbvhBuilder, SbvhConfig};
use sahara_builders::sweep::{SweepBuilder, SweepConfig};
use sahara_builders::tsah::{Candidates, Temporary, TsahBuilder, TsahConfig};
use sahara_builders::tsah_spatial::{TsahSpatialBuilder, TsahSpatialConfig};
use sahara_builders::{Builder, CostModel};

/// The factors, in report order.
pub const FACTORS: &[&str] = &[
    "cost",
    "leaf",
    "breadth",
    "where",
    "temporary",
    "camera",
    "reinsert",
    "combined",
];

/// The camera a setting's rays come from.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum CameraKind {
    /// The catalog's camera (inside the scene for interiors such as sponza).
    Catalog,
    /// An orbit camera outside the scene's bounds, looking at its centre.
    Outside,
}

impl CameraKind {
    /// The name of the CSV's `camera` column.
    pub fn name(self) -> &'static str {
        match self {
            CameraKind::Catalog => "catalog",
            CameraKind::Outside => "outside",
        }
    }
}

/// The reference a setting is compared with.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Reference {
    /// The full-sweep tree with this leaf size (and the setting's cost model).
    Sweep { max_leaf: usize },
    /// SBVH with its default configuration.
    Sbvh,
}

/// The sweep tree of the registered presets (leaves of at most 8), the usual reference.
const SWEEP: Reference = Reference::Sweep { max_leaf: 8 };

impl Reference {
    /// The name of the CSV's `reference` column.
    pub fn name(self) -> String {
        match self {
            Reference::Sweep { max_leaf: 8 } => "sweep".into(),
            Reference::Sweep { max_leaf } => format!("sweep(leaf {})", leaf_label(max_leaf)),
            Reference::Sbvh => "sbvh".into(),
        }
    }

    /// The reference's builder.
    pub fn builder(self) -> Box<dyn Builder> {
        match self {
            Reference::Sweep { max_leaf } => Box::new(SweepBuilder::named(
                "sweep",
                SweepConfig {
                    max_leaf_size: max_leaf,
                    ..SweepConfig::DEFAULT
                },
            )),
            Reference::Sbvh => Box::new(SbvhBuilder::named("sbvh", SbvhConfig::DEFAULT)),
        }
    }
}

/// The leaf size standing for "unbounded": leaves are then decided by the SAH alone.
const UNBOUNDED: usize = 1 << 20;

fn leaf_label(l: usize) -> String {
    if l >= UNBOUNDED {
        "∞".into()
    } else {
        l.to_string()
    }
}

/// The builder a setting makes.
#[derive(Clone, Copy, Debug)]
pub enum Make {
    /// The temporary-subtree builder with this configuration.
    Tsah(TsahConfig),
    /// `tsah-topk` applied only to nodes above `N / 2^d` primitives (≈ the top `d` levels of
    /// a scene of `N` triangles).
    TsahTopLevels(u32),
    /// The look-ahead builder with this configuration.
    Popov(PopovConfig),
    /// The spatial-split temporary-subtree builder with this configuration.
    TsahSpatial(TsahSpatialConfig),
    /// A registered preset, so that the rows are the trees `cargo xtask eval` builds.
    Registered(&'static str),
}

impl Make {
    /// The builder for a scene of `n` triangles.
    pub fn builder(self, n: usize) -> Box<dyn Builder> {
        match self {
            Make::Tsah(c) => Box::new(TsahBuilder::named("tsah", c)),
            Make::TsahTopLevels(d) => Make::Tsah(TsahConfig {
                greedy_below: n >> d,
                ..TsahConfig::TOP_K
            })
            .builder(n),
            Make::Popov(c) => Box::new(PopovBuilder::named("popov", c)),
            Make::TsahSpatial(c) => Box::new(TsahSpatialBuilder::named("tsah-sbvh", c)),
            Make::Registered(name) => {
                sahara_builders::registry::by_name(name).expect("checked by settings()")
            }
        }
    }
}

/// Which studies a setting belongs to.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Runs {
    Both,
    /// `--quick` only (a smaller level standing for a full-study one).
    Quick,
    /// The full study only.
    Full,
}

/// One setting of one factor.
#[derive(Clone, Copy, Debug)]
pub struct Setting {
    pub factor: &'static str,
    /// The builder family (a preset name, or the preset the setting modifies).
    pub builder: &'static str,
    /// The factor's level, as shown in the table.
    pub level: &'static str,
    pub runs: Runs,
    pub cost: CostModel,
    pub reference: Reference,
    pub camera: CameraKind,
    /// Skipped on scenes above `--heavy-limit` triangles.
    pub heavy: bool,
    pub make: Make,
}

/// A setting of `factor`: `builder` at `level`, in both studies, under the default cost model,
/// against the sweep tree, from the catalog camera, not heavy.
const fn s(
    factor: &'static str,
    builder: &'static str,
    level: &'static str,
    make: Make,
) -> Setting {
    Setting {
        factor,
        builder,
        level,
        runs: Runs::Both,
        cost: CostModel::AILA,
        reference: SWEEP,
        camera: CameraKind::Catalog,
        heavy: false,
        make,
    }
}

impl Setting {
    const fn cost(self, traversal: f32, intersection: f32) -> Setting {
        Setting {
            cost: CostModel {
                traversal,
                intersection,
            },
            ..self
        }
    }
    const fn against(self, reference: Reference) -> Setting {
        Setting { reference, ..self }
    }
    const fn camera(self, camera: CameraKind) -> Setting {
        Setting { camera, ..self }
    }
    const fn heavy(self) -> Setting {
        Setting {
            heavy: true,
            ..self
        }
    }
    const fn quick_only(self) -> Setting {
        Setting {
            runs: Runs::Quick,
            ..self
        }
    }
    const fn full_only(self) -> Setting {
        Setting {
            runs: Runs::Full,
            ..self
        }
    }
}

const TOP_K: Make = Make::Tsah(TsahConfig::TOP_K);
const HYBRID: Make = Make::Popov(PopovConfig::HYBRID);

/// `tsah-topk` with leaves of at most `l`, greedy below `g` primitives.
const fn leaf(l: usize, g: usize) -> Make {
    Make::Tsah(TsahConfig {
        max_leaf_size: l,
        greedy_below: g,
        ..TsahConfig::TOP_K
    })
}

/// `tsah-topk` with other candidates (and greedy below `g` primitives).
const fn candidates(c: Candidates, g: usize) -> Make {
    Make::Tsah(TsahConfig {
        candidates: c,
        greedy_below: g,
        ..TsahConfig::TOP_K
    })
}

const fn top_k(k: usize) -> Make {
    candidates(Candidates::TopK { k, per_axis: true }, 8)
}

const fn planes(bins_per_axis: usize) -> Make {
    candidates(Candidates::Binned { bins_per_axis }, 8)
}

const fn exhaustive_below(up_to: usize) -> Make {
    candidates(Candidates::ExhaustiveBelow { up_to, k: 2 }, 0)
}

/// `tsah-topk` applied to nodes above `g` primitives.
const fn greedy_below(g: usize) -> Make {
    Make::Tsah(TsahConfig {
        greedy_below: g,
        ..TsahConfig::TOP_K
    })
}

/// `tsah-topk` with other temporaries.
const fn temporary(t: Temporary) -> Make {
    Make::Tsah(TsahConfig {
        temporary: t,
        ..TsahConfig::TOP_K
    })
}

const fn sweep(max_leaf: usize) -> Reference {
    Reference::Sweep { max_leaf }
}

use CameraKind::{Catalog, Outside};
use Reference::Sbvh;

/// Every setting of every factor, in report order.
#[rustfmt::skip]
pub const SETTINGS: &[Setting] = &[
    // The cost constants: the builders and the metric under the same four ratios.
    s("cost", "tsah-topk", "c_t/c_i = 1/1", TOP_K).cost(1.0, 1.0),
    s("cost", "hybrid", "c_t/c_i = 1/1", HYBRID).cost(1.0, 1.0),
    s("cost", "tsah-topk", "c_t/c_i = 1.2/1", TOP_K).cost(1.2, 1.0),
    s("cost", "hybrid", "c_t/c_i = 1.2/1", HYBRID).cost(1.2, 1.0),
    s("cost", "tsah-topk", "c_t/c_i = 3/1", TOP_K).cost(3.0, 1.0),
    s("cost", "hybrid", "c_t/c_i = 3/1", HYBRID).cost(3.0, 1.0),
    s("cost", "tsah-topk", "c_t/c_i = 1/3", TOP_K).cost(1.0, 3.0),
    s("cost", "hybrid", "c_t/c_i = 1/3", HYBRID).cost(1.0, 3.0),
    // The leaf policy, against the sweep tree of the same leaf size. "Rule everywhere": the
    // temporary-subtree leaf rule decides every node, small ones too, against its
    // temporaries' real cost.
    s("leaf", "tsah-topk", "max leaf 1, greedy ≤ 1", leaf(1, 1)).against(sweep(1)),
    s("leaf", "tsah-topk", "max leaf 4, greedy ≤ 4", leaf(4, 4)).against(sweep(4)),
    s("leaf", "tsah-topk", "max leaf 4, rule everywhere", leaf(4, 0)).against(sweep(4)),
    s("leaf", "tsah-topk", "max leaf 8, greedy ≤ 8", leaf(8, 8)).against(sweep(8)),
    s("leaf", "tsah-topk", "max leaf 8, rule everywhere", leaf(8, 0)).against(sweep(8)),
    s("leaf", "tsah-topk", "max leaf ∞, greedy ≤ 8", leaf(UNBOUNDED, 8)).against(sweep(UNBOUNDED)),
    s("leaf", "tsah-topk", "max leaf ∞, rule everywhere", leaf(UNBOUNDED, 0)).against(sweep(UNBOUNDED)).heavy(),
    // The candidate breadth: top-k by Eq. 2, binned planes, every candidate of small nodes.
    s("breadth", "tsah-topk", "top-1 per axis", top_k(1)),
    s("breadth", "tsah-topk", "top-2 per axis", top_k(2)),
    s("breadth", "tsah-topk", "top-4 per axis", top_k(4)),
    s("breadth", "tsah-topk", "top-8 per axis", top_k(8)).heavy().full_only(),
    s("breadth", "tsah-topk", "4 binned planes per axis", planes(4)),
    s("breadth", "tsah-topk", "16 binned planes per axis", planes(16)),
    s("breadth", "tsah-topk", "64 binned planes per axis", planes(64)).heavy().full_only(),
    s("breadth", "tsah-topk", "exhaustive ≤ 32 prims, top-2 above", exhaustive_below(32)).heavy().quick_only(),
    s("breadth", "tsah-topk", "exhaustive ≤ 256 prims, top-2 above", exhaustive_below(256)).heavy().full_only(),
    // Where the rule applies: above a node size, or in the top levels only.
    s("where", "tsah-topk", "nodes above 0 prims", greedy_below(0)),
    s("where", "tsah-topk", "nodes above 8 prims", greedy_below(8)),
    s("where", "tsah-topk", "nodes above 64 prims", greedy_below(64)).full_only(),
    s("where", "tsah-topk", "nodes above 512 prims", greedy_below(512)),
    s("where", "tsah-topk", "nodes above 4096 prims", greedy_below(4096)).full_only(),
    s("where", "tsah-topk", "≈ top 1 levels (nodes above N/2^1)", Make::TsahTopLevels(1)).full_only(),
    s("where", "tsah-topk", "≈ top 3 levels (nodes above N/2^3)", Make::TsahTopLevels(3)),
    s("where", "tsah-topk", "≈ top 6 levels (nodes above N/2^6)", Make::TsahTopLevels(6)).full_only(),
    // The temporaries' quality, and the spatial-split variant against SBVH.
    s("temporary", "tsah-topk", "sweep", temporary(Temporary::Sweep)),
    s("temporary", "tsah-topk", "binned 8", temporary(Temporary::Binned { bins: 8 })),
    s("temporary", "tsah-topk", "binned 16", temporary(Temporary::Binned { bins: 16 })).full_only(),
    s("temporary", "tsah-topk", "binned 32", temporary(Temporary::Binned { bins: 32 })),
    s("temporary", "tsah-topk", "median split (poor)", temporary(Temporary::Median)),
    s("temporary", "tsah-sbvh", "SBVH (estimated)", Make::TsahSpatial(TsahSpatialConfig::DEFAULT)).against(Sbvh),
    s("temporary", "tsah-sbvh", "SBVH (exact)", Make::TsahSpatial(TsahSpatialConfig::EXACT)).against(Sbvh).heavy().full_only(),
    // The camera: the same trees from the catalog camera and from outside.
    s("camera", "tsah-topk", "catalog camera", TOP_K).camera(Catalog),
    s("camera", "tsah-binned", "catalog camera", Make::Tsah(TsahConfig::BINNED)).camera(Catalog),
    s("camera", "popov-d2", "catalog camera", Make::Popov(PopovConfig::D2)).camera(Catalog),
    s("camera", "hybrid", "catalog camera", HYBRID).camera(Catalog),
    s("camera", "tsah-topk", "outside camera", TOP_K).camera(Outside),
    s("camera", "tsah-binned", "outside camera", Make::Tsah(TsahConfig::BINNED)).camera(Outside),
    s("camera", "popov-d2", "outside camera", Make::Popov(PopovConfig::D2)).camera(Outside),
    s("camera", "hybrid", "outside camera", HYBRID).camera(Outside),
    // The paper's builders against the post-pass optimisers of issue 16, each against the
    // reference its builder starts from: the registered presets.
    s("reinsert", "tsah-topk", "temporary subtrees, no reinsertion", Make::Registered("tsah-topk")),
    s("reinsert", "sweep+reinsert", "reinsertion after sweep", Make::Registered("sweep+reinsert")),
    s("reinsert", "ploc+reinsert", "PLOC, then the light reinsertion", Make::Registered("ploc+reinsert")),
    s("reinsert", "tsah-topk+reinsert", "reinsertion after tsah-topk", Make::Registered("tsah-topk+reinsert")).full_only(),
    s("reinsert", "ploc", "PLOC, no reinsertion", Make::Registered("ploc")).full_only(),
    s("reinsert", "tsah-sbvh", "spatial temporaries, no reinsertion", Make::Registered("tsah-sbvh")).against(Sbvh).full_only(),
    s("reinsert", "sbvh+reinsert", "reinsertion after sbvh", Make::Registered("sbvh+reinsert")).against(Sbvh).full_only(),
    // Candidate presets combining the levels the single factors favour (wider candidate
    // sets, binned temporaries), next to the registered presets they would have to beat:
    // the evidence for registering one (issue 15, item 3).
    s("combined", "tsah-topk", "4 binned planes per axis, binned-8 temporaries", Make::Tsah(TsahConfig {
        candidates: Candidates::Binned { bins_per_axis: 4 },
        temporary: Temporary::Binned { bins: 8 },
        ..TsahConfig::TOP_K
    })),
    s("combined", "tsah-topk", "top-2 per axis, binned-8 temporaries", temporary(Temporary::Binned { bins: 8 })),
    s("combined", "tsah-topk", "4 binned planes per axis, sweep temporaries", planes(4)),
    s("combined", "tsah-topk", "registered preset", TOP_K),
    s("combined", "hybrid", "registered preset", HYBRID),
];

/// The settings of `factor` in the quick or the full study; an error for an unknown factor,
/// or when a setting needs a preset the registry does not have.
pub fn settings(factor: &str, quick: bool) -> Result<Vec<Setting>> {
    if !FACTORS.contains(&factor) {
        bail!("unknown factor '{factor}' (known: {})", FACTORS.join(", "));
    }
    let wanted = if quick { Runs::Quick } else { Runs::Full };
    let v: Vec<Setting> = SETTINGS
        .iter()
        .filter(|s| s.factor == factor && (s.runs == Runs::Both || s.runs == wanted))
        .copied()
        .collect();
    for s in &v {
        if let Make::Registered(name) = s.make {
            if sahara_builders::registry::by_name(name).is_none() {
                bail!("the {factor} factor needs the registered preset '{name}'");
            }
        }
    }
    Ok(v)
}
