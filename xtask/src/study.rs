//! `cargo xtask study`: the sensitivity study of issue 15. Why do the temporary-subtree
//! builders of Wodniok & Goesele save a few percent of work per ray against full-sweep SAH on
//! our scenes where the paper reports up to 37%?
//!
//! One factor varies at a time (cost constants, leaf policy, candidate breadth, where the rule
//! applies, temporary quality, camera; every row also carries the bvh8 kernel's work), and
//! every setting is compared with the reference tree built **under the same settings** (the
//! sweep tree with the same cost model and leaf size; SBVH for the spatial variant). Work per
//! ray, `c_t · inner nodes + c_i · triangles` with the setting's own cost model, is counted
//! exactly and is the primary, noise-free column; SAH, EPO and build time come with every row;
//! `--speed` adds measured speed ratios (median of per-round ratios of interleaved rounds, with
//! 95% bootstrap intervals; an undecided cell is rerun with more rounds, see [`needs_more_rounds`]).
//!
//! Results go to a folder (default `docs/results/<date>-study/`, quick runs
//! `docs/results/<date>-study-quick/`): `study.csv`, one row per scene and setting, and
//! `README.md`, rendered from the CSV alone by [`render_markdown`] (the eval report can call it
//! on the latest saved CSV instead of rerunning the study; `--render <csv>` re-renders).

use crate::engine::Engine;
use crate::interval::{median_interval, Interval};
use crate::util::geomean;
use anyhow::{bail, Context, Result};
use sahara_builders::popov::{PopovBuilder, PopovConfig};
use sahara_builders::sbvh::{SbvhBuilder, SbvhConfig};
use sahara_builders::sweep::{SweepBuilder, SweepConfig};
use sahara_builders::tsah::{Candidates, Temporary, TsahBuilder, TsahConfig};
use sahara_builders::tsah_spatial::{TsahSpatialBuilder, TsahSpatialConfig};
use sahara_builders::{BuildInput, Builder, CostModel};
use sahara_geom::Vec3A;
use sahara_trace::{Backend, RayKind, RaySet, Tracer};
use std::collections::hash_map::Entry;
use std::collections::HashMap;
use std::fmt::Write as _;
use std::path::PathBuf;
use std::time::Instant;

use crate::util;

/// Command-line arguments of `cargo xtask study`.
#[derive(clap::Args, Clone)]
pub struct Args {
    /// Small study: procedural scenes at small sizes, a few levels of each factor (≤ 5 min).
    #[arg(long)]
    pub quick: bool,
    /// Scenes (catalog names or `procedural:size`; default: every shared scene file plus
    /// hairball, city and teapot_stadium; quick: the procedural ones at 20k/10k triangles).
    #[arg(long, value_delimiter = ',')]
    pub scenes: Vec<String>,
    /// Factors to run (default all): cost, leaf, breadth, where, temporary, camera, reinsert,
    /// combined.
    #[arg(long, value_delimiter = ',')]
    pub factors: Vec<String>,
    /// Measure speed (bvh2 and bvh8) against the reference in interleaved rounds. The full
    /// study does by default; `--quick` only with this flag.
    #[arg(long)]
    pub speed: bool,
    /// Skip the speed measurement (work per ray, SAH, EPO and build time only).
    #[arg(long, conflicts_with = "speed")]
    pub no_speed: bool,
    /// Timed rounds per speed cell (default 5, quick 3).
    #[arg(long)]
    pub rounds: Option<usize>,
    /// Output folder (default docs/results/<date>-study[-quick]).
    #[arg(long)]
    pub out: Option<PathBuf>,
    /// Rayon threads (default: all cores).
    #[arg(long)]
    pub threads: Option<usize>,
    /// Image width of the ray sets (default 384, quick 192).
    #[arg(long)]
    pub width: Option<u32>,
    /// Image height (default 288, quick 144).
    #[arg(long)]
    pub height: Option<u32>,
    /// Seed of the secondary rays.
    #[arg(long, default_value_t = 1)]
    pub seed: u64,
    /// Skip settings whose builder is slow on scenes above this many triangles (exhaustive
    /// candidates, exact SBVH temporaries, k = 8). Default 150000.
    #[arg(long, default_value_t = 150_000)]
    pub heavy_limit: usize,
    /// Only re-render the markdown of an existing study.csv (written next to it).
    #[arg(long)]
    pub render: Option<PathBuf>,
}

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
enum CameraKind {
    /// The catalog's camera (inside the scene for interiors such as sponza).
    Catalog,
    /// An orbit camera outside the scene's bounds, looking at its centre.
    Outside,
}

impl CameraKind {
    fn name(self) -> &'static str {
        match self {
            CameraKind::Catalog => "catalog",
            CameraKind::Outside => "outside",
        }
    }
}

/// The reference a setting is compared with.
#[derive(Clone, Copy, Debug)]
enum Reference {
    /// The full-sweep tree with this leaf size (and the setting's cost model).
    Sweep { max_leaf: usize },
    /// SBVH with its default configuration.
    Sbvh,
}

impl Reference {
    fn name(self) -> String {
        match self {
            Reference::Sweep { max_leaf: 8 } => "sweep".into(),
            Reference::Sweep { max_leaf } => format!("sweep(leaf {})", leaf_label(max_leaf)),
            Reference::Sbvh => "sbvh".into(),
        }
    }

    fn builder(self) -> Box<dyn Builder> {
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

/// A named preset and the function that makes it.
type Preset = (&'static str, fn() -> Box<dyn Builder>);

fn leaf_label(l: usize) -> String {
    if l >= UNBOUNDED {
        "∞".into()
    } else {
        l.to_string()
    }
}

/// One setting of one factor.
struct Setting {
    factor: &'static str,
    /// The builder family (a preset name, or the preset the setting modifies).
    builder: &'static str,
    /// The factor's level, as shown in the table.
    level: String,
    cost: CostModel,
    reference: Reference,
    camera: CameraKind,
    /// Skip on scenes above `heavy_limit` triangles.
    heavy: bool,
    make: Box<dyn Fn(usize) -> Box<dyn Builder>>,
}

fn cm(t: f32, i: f32) -> CostModel {
    CostModel {
        traversal: t,
        intersection: i,
    }
}

fn tsah(c: TsahConfig) -> Box<dyn Builder> {
    Box::new(TsahBuilder::named("tsah", c))
}

fn popov(c: PopovConfig) -> Box<dyn Builder> {
    Box::new(PopovBuilder::named("popov", c))
}

/// The settings of `factor`.
fn settings(factor: &str, quick: bool) -> Result<Vec<Setting>> {
    let def = CostModel::default();
    let base = |factor: &'static str, builder: &'static str, level: String| Setting {
        factor,
        builder,
        level,
        cost: def,
        reference: Reference::Sweep { max_leaf: 8 },
        camera: CameraKind::Catalog,
        heavy: false,
        make: Box::new(|_| tsah(TsahConfig::TOP_K)),
    };
    let mut v = Vec::new();
    match factor {
        "cost" => {
            // The same four ratios in the quick and the full study.
            let models: &[(f32, f32)] = &[(1.0, 1.0), (1.2, 1.0), (3.0, 1.0), (1.0, 3.0)];
            for &(t, i) in models {
                let level = format!("c_t/c_i = {t}/{i}");
                v.push(Setting {
                    cost: cm(t, i),
                    ..base("cost", "tsah-topk", level.clone())
                });
                v.push(Setting {
                    cost: cm(t, i),
                    make: Box::new(|_| popov(PopovConfig::HYBRID)),
                    ..base("cost", "hybrid", level)
                });
            }
        }
        "leaf" => {
            let leaves: &[usize] = &[1, 4, 8, UNBOUNDED];
            for &l in leaves {
                v.push(Setting {
                    reference: Reference::Sweep { max_leaf: l },
                    make: Box::new(move |_| {
                        tsah(TsahConfig {
                            max_leaf_size: l,
                            greedy_below: l.min(8),
                            ..TsahConfig::TOP_K
                        })
                    }),
                    ..base(
                        "leaf",
                        "tsah-topk",
                        format!("max leaf {}, greedy ≤ {}", leaf_label(l), l.min(8)),
                    )
                });
                if l > 1 {
                    // The temporary-subtree leaf rule active: every node, small ones too, is
                    // decided against its temporaries' real cost.
                    v.push(Setting {
                        reference: Reference::Sweep { max_leaf: l },
                        heavy: l >= UNBOUNDED,
                        make: Box::new(move |_| {
                            tsah(TsahConfig {
                                max_leaf_size: l,
                                greedy_below: 0,
                                ..TsahConfig::TOP_K
                            })
                        }),
                        ..base(
                            "leaf",
                            "tsah-topk",
                            format!("max leaf {}, rule everywhere", leaf_label(l)),
                        )
                    });
                }
            }
        }
        "breadth" => {
            let ks: &[usize] = if quick { &[1, 2, 4] } else { &[1, 2, 4, 8] };
            for &k in ks {
                v.push(Setting {
                    heavy: k >= 8,
                    make: Box::new(move |_| {
                        tsah(TsahConfig {
                            candidates: Candidates::TopK { k, per_axis: true },
                            ..TsahConfig::TOP_K
                        })
                    }),
                    ..base("breadth", "tsah-topk", format!("top-{k} per axis"))
                });
            }
            let planes: &[usize] = if quick { &[4, 16] } else { &[4, 16, 64] };
            for &b in planes {
                v.push(Setting {
                    heavy: b >= 64,
                    make: Box::new(move |_| {
                        tsah(TsahConfig {
                            candidates: Candidates::Binned { bins_per_axis: b },
                            ..TsahConfig::TOP_K
                        })
                    }),
                    ..base(
                        "breadth",
                        "tsah-topk",
                        format!("{b} binned planes per axis"),
                    )
                });
            }
            let up_to = if quick { 32 } else { 256 };
            v.push(Setting {
                heavy: true,
                make: Box::new(move |_| {
                    tsah(TsahConfig {
                        candidates: Candidates::ExhaustiveBelow { up_to, k: 2 },
                        greedy_below: 0,
                        ..TsahConfig::TOP_K
                    })
                }),
                ..base(
                    "breadth",
                    "tsah-topk",
                    format!("exhaustive ≤ {up_to} prims, top-2 above"),
                )
            });
        }
        "where" => {
            let below: &[usize] = if quick {
                &[0, 8, 512]
            } else {
                &[0, 8, 64, 512, 4096]
            };
            for &g in below {
                v.push(Setting {
                    make: Box::new(move |_| {
                        tsah(TsahConfig {
                            greedy_below: g,
                            ..TsahConfig::TOP_K
                        })
                    }),
                    ..base("where", "tsah-topk", format!("nodes above {g} prims"))
                });
            }
            let depths: &[u32] = if quick { &[3] } else { &[1, 3, 6] };
            for &d in depths {
                v.push(Setting {
                    make: Box::new(move |n| {
                        tsah(TsahConfig {
                            greedy_below: n >> d,
                            ..TsahConfig::TOP_K
                        })
                    }),
                    ..base(
                        "where",
                        "tsah-topk",
                        format!("≈ top {d} levels (nodes above N/2^{d})"),
                    )
                });
            }
        }
        "temporary" => {
            let mut temps: Vec<(String, Temporary)> = vec![("sweep".into(), Temporary::Sweep)];
            let bins: &[usize] = if quick { &[8, 32] } else { &[8, 16, 32] };
            for &b in bins {
                temps.push((format!("binned {b}"), Temporary::Binned { bins: b }));
            }
            temps.push(("median split (poor)".into(), Temporary::Median));
            for (name, t) in temps {
                v.push(Setting {
                    make: Box::new(move |_| {
                        tsah(TsahConfig {
                            temporary: t,
                            ..TsahConfig::TOP_K
                        })
                    }),
                    ..base("temporary", "tsah-topk", name)
                });
            }
            v.push(Setting {
                reference: Reference::Sbvh,
                make: Box::new(|_| {
                    Box::new(TsahSpatialBuilder::named(
                        "tsah-sbvh",
                        TsahSpatialConfig::DEFAULT,
                    ))
                }),
                ..base("temporary", "tsah-sbvh", "SBVH (estimated)".into())
            });
            if !quick {
                v.push(Setting {
                    reference: Reference::Sbvh,
                    heavy: true,
                    make: Box::new(|_| {
                        Box::new(TsahSpatialBuilder::named(
                            "tsah-sbvh",
                            TsahSpatialConfig::EXACT,
                        ))
                    }),
                    ..base("temporary", "tsah-sbvh", "SBVH (exact)".into())
                });
            }
        }
        "camera" => {
            for camera in [CameraKind::Catalog, CameraKind::Outside] {
                let presets: [Preset; 4] = [
                    ("tsah-topk", || tsah(TsahConfig::TOP_K)),
                    ("tsah-binned", || tsah(TsahConfig::BINNED)),
                    ("popov-d2", || popov(PopovConfig::D2)),
                    ("hybrid", || popov(PopovConfig::HYBRID)),
                ];
                for (name, f) in presets {
                    v.push(Setting {
                        camera,
                        make: Box::new(move |_| f()),
                        ..base("camera", name, format!("{} camera", camera.name()))
                    });
                }
            }
        }
        "reinsert" => {
            // The paper's builders against the post-pass optimisers of issue 16, each against
            // the reference its builder starts from: the registered presets, so that the rows
            // are the trees `cargo xtask eval` and `cargo xtask bvh` build.
            let sweep = Reference::Sweep { max_leaf: 8 };
            let mut presets: Vec<(&'static str, Reference, &'static str)> = vec![
                ("tsah-topk", sweep, "temporary subtrees, no reinsertion"),
                ("sweep+reinsert", sweep, "reinsertion after sweep"),
                ("ploc+reinsert", sweep, "PLOC, then the light reinsertion"),
            ];
            if !quick {
                presets.extend([
                    ("tsah-topk+reinsert", sweep, "reinsertion after tsah-topk"),
                    ("ploc", sweep, "PLOC, no reinsertion"),
                    (
                        "tsah-sbvh",
                        Reference::Sbvh,
                        "spatial temporaries, no reinsertion",
                    ),
                    ("sbvh+reinsert", Reference::Sbvh, "reinsertion after sbvh"),
                ]);
            }
            for (name, reference, level) in presets {
                if sahara_builders::registry::by_name(name).is_none() {
                    bail!("the reinsert factor needs the registered preset '{name}'");
                }
                v.push(Setting {
                    reference,
                    make: Box::new(move |_| {
                        sahara_builders::registry::by_name(name).expect("checked above")
                    }),
                    ..base("reinsert", name, level.into())
                });
            }
        }
        "combined" => {
            // Candidate presets that combine the levels the single factors favour (wider
            // candidate sets, binned temporaries), next to the registered presets they would
            // have to beat: the evidence for registering one (issue 15, item 3).
            let combos: [(&'static str, TsahConfig); 3] = [
                (
                    "4 binned planes per axis, binned-8 temporaries",
                    TsahConfig {
                        candidates: Candidates::Binned { bins_per_axis: 4 },
                        temporary: Temporary::Binned { bins: 8 },
                        ..TsahConfig::TOP_K
                    },
                ),
                (
                    "top-2 per axis, binned-8 temporaries",
                    TsahConfig {
                        temporary: Temporary::Binned { bins: 8 },
                        ..TsahConfig::TOP_K
                    },
                ),
                (
                    "4 binned planes per axis, sweep temporaries",
                    TsahConfig {
                        candidates: Candidates::Binned { bins_per_axis: 4 },
                        ..TsahConfig::TOP_K
                    },
                ),
            ];
            for (name, c) in combos {
                v.push(Setting {
                    make: Box::new(move |_| tsah(c)),
                    ..base("combined", "tsah-topk", name.into())
                });
            }
            let presets: [Preset; 2] = [
                ("tsah-topk", || tsah(TsahConfig::TOP_K)),
                ("hybrid", || popov(PopovConfig::HYBRID)),
            ];
            for (name, f) in presets {
                v.push(Setting {
                    make: Box::new(move |_| f()),
                    ..base("combined", name, "registered preset".into())
                });
            }
        }
        other => bail!("unknown factor '{other}' (known: {})", FACTORS.join(", ")),
    }
    Ok(v)
}

fn default_scenes(quick: bool) -> Vec<String> {
    if quick {
        return ["teapot_stadium:20000", "city:20000", "hairball:2000"]
            .map(String::from)
            .to_vec();
    }
    let catalog = sahara_scene::Catalog::discover();
    let mut v: Vec<String> = catalog
        .distinct_files()
        .into_iter()
        .map(|e| e.name.clone())
        .collect();
    // Smallest first, so that a run cut short has covered the most scenes.
    v.sort_by_key(|n| {
        catalog
            .distinct_files()
            .into_iter()
            .find(|e| &e.name == n)
            .and_then(|e| e.triangles)
            .unwrap_or(0)
    });
    v.extend(["teapot_stadium", "city", "hairball"].map(String::from));
    v
}

/// The CSV columns, in order.
const COLUMNS: &[&str] = &[
    "scene",
    "triangles",
    "factor",
    "builder",
    "level",
    "reference",
    "c_t",
    "c_i",
    "camera",
    "camera_inside",
    "build_s",
    "ref_build_s",
    "sah",
    "ref_sah",
    "epo",
    "ref_epo",
    "work_bvh2_primary",
    "ref_work_bvh2_primary",
    "work_bvh2_diffuse",
    "ref_work_bvh2_diffuse",
    "work_bvh2_ao",
    "ref_work_bvh2_ao",
    "work_bvh8_primary",
    "ref_work_bvh8_primary",
    "work_bvh8_diffuse",
    "ref_work_bvh8_diffuse",
    "work_bvh8_ao",
    "ref_work_bvh8_ao",
    "speed_bvh2_primary",
    "speed_bvh2_diffuse",
    "speed_bvh2_ao",
    "speed_bvh8_primary",
    "speed_bvh8_diffuse",
    "speed_bvh8_ao",
    "speed_bvh2_primary_low",
    "speed_bvh2_primary_high",
    "speed_bvh2_diffuse_low",
    "speed_bvh2_diffuse_high",
    "speed_bvh2_ao_low",
    "speed_bvh2_ao_high",
    "speed_bvh8_primary_low",
    "speed_bvh8_primary_high",
    "speed_bvh8_diffuse_low",
    "speed_bvh8_diffuse_high",
    "speed_bvh8_ao_low",
    "speed_bvh8_ao_high",
    "speed_rounds",
];

const KINDS: [RayKind; 3] = [
    RayKind::Primary,
    RayKind::Diffuse,
    RayKind::AmbientOcclusion,
];
const LAYOUTS: [Engine; 2] = [Engine::Bvh2, Engine::Bvh8];

/// A built tree with its measurements.
struct Tree {
    bvh: sahara_bvh::Bvh,
    build_s: f64,
    sah: f64,
    epo: f64,
}

fn build(
    b: &dyn Builder,
    tris: &[sahara_geom::Triangle],
    cost: CostModel,
    threads: Option<usize>,
) -> Result<Tree> {
    let input = BuildInput::new(tris, cost)?;
    let t0 = Instant::now();
    let bvh = util::with_threads(threads, || b.build(&input))??;
    let build_s = t0.elapsed().as_secs_f64();
    bvh.validate(tris)
        .with_context(|| format!("{} tree invalid", b.name()))?;
    let sah = sahara_metrics::sah(&bvh, &cost);
    let epo = util::with_threads(threads, || sahara_metrics::epo(&bvh, tris, &cost))?;
    Ok(Tree {
        bvh,
        build_s,
        sah,
        epo,
    })
}

/// Work per ray, `c_t inner + c_i triangles`, of each (layout, ray kind).
fn work(
    tree: &Tree,
    tris: &[sahara_geom::Triangle],
    sets: &[RaySet],
    cost: CostModel,
    threads: Option<usize>,
) -> Result<Vec<f64>> {
    let mut out = Vec::new();
    for layout in LAYOUTS {
        let tracer = layout.tracer(&tree.bvh, tris, Backend::best())?;
        for set in sets {
            let c = util::with_threads(threads, || {
                sahara_trace::trace_set_counted(tracer.as_ref(), set)
            })?;
            let w = c.per_ray();
            out.push(cost.traversal as f64 * w.inner + cost.intersection as f64 * w.triangles);
        }
    }
    Ok(out)
}

/// The most timed rounds one speed cell may take while its interval is still undecided.
pub const MAX_SPEED_ROUNDS: usize = 60;

/// A speed cell is settled when its 95% interval excludes 1, or is narrower than this (as a
/// fraction of the estimate), or when [`MAX_SPEED_ROUNDS`] were spent.
pub const SETTLED_WIDTH: f64 = 0.02;

/// Whether a speed cell needs more rounds: its interval contains 1, is at least
/// [`SETTLED_WIDTH`] wide, and fewer than [`MAX_SPEED_ROUNDS`] rounds were taken.
pub fn needs_more_rounds(iv: &Interval, rounds: usize) -> bool {
    iv.contains_one()
        && (iv.high - iv.low) >= SETTLED_WIDTH * iv.estimate
        && rounds < MAX_SPEED_ROUNDS
}

/// One speed cell: the median of per-round ratios with its 95% interval, and the rounds taken.
#[derive(Clone, Copy, Debug)]
struct SpeedCell {
    interval: Interval,
    rounds: usize,
}

impl SpeedCell {
    /// The cell of a tree identical to its reference: exactly 1, no rounds timed.
    const IDENTICAL: SpeedCell = SpeedCell {
        interval: Interval {
            estimate: 1.0,
            low: 1.0,
            high: 1.0,
        },
        rounds: 0,
    };
}

/// Speed of `tree` against `reference` per (layout, ray kind): the median of the per-round
/// ratios reference time / tree time (> 1 is faster) of interleaved rounds, with its
/// bootstrap interval. Each cell starts with `rounds` rounds and takes `rounds` more while
/// [`needs_more_rounds`] says it is undecided (the rerun rule of `docs/study.md`).
fn speed(
    tree: &Tree,
    reference: &Tree,
    tris: &[sahara_geom::Triangle],
    sets: &[RaySet],
    rounds: usize,
    threads: Option<usize>,
) -> Result<Vec<SpeedCell>> {
    let mut out = Vec::new();
    for layout in LAYOUTS {
        let a = layout.tracer(&tree.bvh, tris, Backend::best())?;
        let r = layout.tracer(&reference.bvh, tris, Backend::best())?;
        for set in sets {
            let cell = util::with_threads(threads, || {
                let time = |t: &dyn Tracer| {
                    let t0 = Instant::now();
                    std::hint::black_box(sahara_trace::trace_set(t, set));
                    t0.elapsed().as_secs_f64()
                };
                time(a.as_ref());
                time(r.as_ref());
                let mut v: Vec<f64> = Vec::new();
                loop {
                    for _ in 0..rounds.max(1) {
                        // Alternate the order so neither tree always runs second.
                        let ratio = if v.len().is_multiple_of(2) {
                            let ta = time(a.as_ref());
                            time(r.as_ref()) / ta
                        } else {
                            let tr = time(r.as_ref());
                            tr / time(a.as_ref())
                        };
                        v.push(ratio);
                    }
                    let iv = median_interval(&v).unwrap_or(Interval {
                        estimate: f64::NAN,
                        low: f64::NAN,
                        high: f64::NAN,
                    });
                    if !needs_more_rounds(&iv, v.len()) {
                        return SpeedCell {
                            interval: iv,
                            rounds: v.len(),
                        };
                    }
                }
            })?;
            out.push(cell);
        }
    }
    Ok(out)
}

/// An orbit camera outside the scene's bounds, from above and to the side of the catalog
/// camera's view direction, framing the whole scene.
fn outside_camera(
    tris: &[sahara_geom::Triangle],
    c: &sahara_scene::Camera,
) -> sahara_trace::Camera {
    let mut b = sahara_geom::Aabb::EMPTY;
    for t in tris {
        b.grow_aabb(&t.bounds());
    }
    let centre = b.centroid();
    let diag = b.extent().length().max(1e-6);
    let up = c.up.normalize_or_zero();
    let up = if up == Vec3A::ZERO { Vec3A::Y } else { up };
    let mut view = (c.target - c.eye).normalize_or_zero();
    view -= up * view.dot(up);
    let side = if view.length() < 1e-3 {
        up.any_orthonormal_vector()
    } else {
        -view.normalize()
    };
    let dir = (side * 0.8 + up * 0.6).normalize();
    let eye = centre + dir * diag * 1.05;
    sahara_trace::Camera::new(eye, centre, up, 55.0)
}

fn inside(tris: &[sahara_geom::Triangle], p: Vec3A) -> bool {
    let mut b = sahara_geom::Aabb::EMPTY;
    for t in tris {
        b.grow_aabb(&t.bounds());
    }
    b.contains_point(p)
}

fn csv_field(s: &str) -> String {
    s.replace([',', '\n'], ";")
}

fn fmt_opt(x: Option<f64>) -> String {
    x.map(|v| format!("{v:.6}")).unwrap_or_default()
}

/// Runs the study.
pub fn run(a: Args) -> Result<()> {
    if let Some(csv) = &a.render {
        let text =
            std::fs::read_to_string(csv).with_context(|| format!("reading {}", csv.display()))?;
        let md = render_markdown(&text)?;
        let out = csv.with_file_name("README.md");
        std::fs::write(&out, md)?;
        println!("rendered {}", out.display());
        return Ok(());
    }
    let t0 = Instant::now();
    let q = a.quick;
    let (width, height) = (
        a.width.unwrap_or(if q { 192 } else { 384 }),
        a.height.unwrap_or(if q { 144 } else { 288 }),
    );
    let rounds = a.rounds.unwrap_or(if q { 3 } else { 5 });
    let measure_speed = if q { a.speed } else { !a.no_speed };
    let factors: Vec<String> = if a.factors.is_empty() {
        FACTORS.iter().map(|s| s.to_string()).collect()
    } else {
        a.factors.clone()
    };
    let mut plan = Vec::new();
    for f in &factors {
        plan.extend(settings(f, q)?);
    }
    let scenes = if a.scenes.is_empty() {
        default_scenes(q)
    } else {
        a.scenes.clone()
    };
    let suffix = if a.quick { "-study-quick" } else { "-study" };
    let out = util::out_dir(
        a.out.as_deref(),
        "docs/results",
        &format!("{}{suffix}", util::utc_date()),
    );
    std::fs::create_dir_all(&out).with_context(|| format!("creating {}", out.display()))?;
    let csv_path = out.join("study.csv");
    let mut csv = COLUMNS.join(",") + "\n";
    std::fs::write(&csv_path, &csv)?;
    let catalog = sahara_scene::Catalog::discover();
    for scene_name in &scenes {
        let scene = match util::load_scene_from(&catalog, scene_name) {
            Ok(s) => s,
            Err(e) => {
                eprintln!("skipping scene {scene_name}: {e:#}");
                continue;
            }
        };
        let tris = &scene.triangles;
        let n = tris.len();
        eprintln!(
            "[{:>6.0} s] {} ({n} triangles)",
            t0.elapsed().as_secs_f64(),
            scene.name
        );
        // Reference trees by (reference, cost), candidate trees by (description, cost),
        // ray sets by camera, reference work by (reference, cost, camera).
        let mut refs: HashMap<String, Tree> = HashMap::new();
        let mut cands: HashMap<String, (Tree, String)> = HashMap::new();
        let mut sets: HashMap<CameraKind, (Vec<RaySet>, bool)> = HashMap::new();
        let mut ref_work: HashMap<String, Vec<f64>> = HashMap::new();
        // Speed cells by (candidate, reference, camera): a tree shared by several rows
        // (tsah-topk appears in most factors) is timed once.
        let mut speeds: HashMap<String, Vec<SpeedCell>> = HashMap::new();
        for s in &plan {
            if s.heavy && n > a.heavy_limit {
                eprintln!(
                    "  skip {} / {} / {} (heavy above {} triangles)",
                    s.factor, s.builder, s.level, a.heavy_limit
                );
                continue;
            }
            let cost_key = format!("{}/{}", s.cost.traversal, s.cost.intersection);
            let rkey = format!("{} {cost_key}", s.reference.name());
            if let Entry::Vacant(slot) = refs.entry(rkey.clone()) {
                slot.insert(build(
                    s.reference.builder().as_ref(),
                    tris,
                    s.cost,
                    a.threads,
                )?);
            }
            if let Entry::Vacant(slot) = sets.entry(s.camera) {
                let reference = &refs[&rkey];
                let tracer = sahara_trace::Bvh2Tracer::new(&reference.bvh, tris);
                let camera = match s.camera {
                    CameraKind::Catalog => crate::engine::trace_camera(&scene.camera),
                    CameraKind::Outside => outside_camera(tris, &scene.camera),
                };
                let eye_inside = inside(tris, camera.eye);
                let v = util::with_threads(a.threads, || {
                    KINDS
                        .iter()
                        .map(|&k| {
                            RaySet::generate(k, &camera, width, height, &tracer, tris, a.seed)
                        })
                        .collect::<Vec<_>>()
                })?;
                slot.insert((v, eye_inside));
            }
            let builder = (s.make)(n);
            let ckey = format!("{} {cost_key}", builder.describe());
            let t_build = Instant::now();
            if let Entry::Vacant(slot) = cands.entry(ckey.clone()) {
                let t = build(builder.as_ref(), tris, s.cost, a.threads)?;
                slot.insert((t, builder.describe()));
            }
            let (set, eye_inside) = &sets[&s.camera];
            let reference = &refs[&rkey];
            let wkey = format!("{rkey} {}", s.camera.name());
            if let Entry::Vacant(slot) = ref_work.entry(wkey.clone()) {
                slot.insert(work(reference, tris, set, s.cost, a.threads)?);
            }
            let (tree, _) = &cands[&ckey];
            let w = work(tree, tris, set, s.cost, a.threads)?;
            let rw = &ref_work[&wkey];
            let sp = if measure_speed {
                let skey = format!("{ckey} | {wkey}");
                if let Entry::Vacant(slot) = speeds.entry(skey.clone()) {
                    slot.insert(if tree.bvh == reference.bvh {
                        // The same tree: the ratio is 1 by definition, nothing to time.
                        vec![SpeedCell::IDENTICAL; LAYOUTS.len() * set.len()]
                    } else {
                        speed(tree, reference, tris, set, rounds, a.threads)?
                    });
                }
                Some(speeds[&skey].clone())
            } else {
                None
            };
            let mut row = vec![
                csv_field(&scene.name),
                n.to_string(),
                s.factor.to_string(),
                s.builder.to_string(),
                csv_field(&s.level),
                csv_field(&s.reference.name()),
                s.cost.traversal.to_string(),
                s.cost.intersection.to_string(),
                s.camera.name().to_string(),
                eye_inside.to_string(),
                format!("{:.4}", tree.build_s),
                format!("{:.4}", reference.build_s),
                format!("{:.6}", tree.sah),
                format!("{:.6}", reference.sah),
                format!("{:.6}", tree.epo),
                format!("{:.6}", reference.epo),
            ];
            for i in 0..6 {
                row.push(format!("{:.6}", w[i]));
                row.push(format!("{:.6}", rw[i]));
            }
            for i in 0..6 {
                row.push(fmt_opt(sp.as_ref().map(|v| v[i].interval.estimate)));
            }
            for i in 0..6 {
                row.push(fmt_opt(sp.as_ref().map(|v| v[i].interval.low)));
                row.push(fmt_opt(sp.as_ref().map(|v| v[i].interval.high)));
            }
            row.push(
                sp.as_ref()
                    .map(|v| v.iter().map(|c| c.rounds).max().unwrap_or(0).to_string())
                    .unwrap_or_default(),
            );
            let line = row.join(",") + "\n";
            csv.push_str(&line);
            std::fs::write(&csv_path, &csv)?;
            eprintln!(
                "  {:>9} {:<11} {:<44} SAH {:.3}  primary {:.3} diffuse {:.3} ao {:.3} (bvh8 {:.3})  {:.1} s",
                s.factor,
                s.builder,
                s.level,
                reference.sah / tree.sah,
                rw[0] / w[0],
                rw[1] / w[1],
                rw[2] / w[2],
                rw[3] / w[3],
                t_build.elapsed().as_secs_f64()
            );
        }
    }
    let mut md = render_markdown(&csv)?;
    let _ = write!(
        md,
        "\n---\n\nRun: `cargo xtask study{}` at commit `{}` on {} ({} threads), rays {width}×{height} per \
         camera, seed {}, {:.0} s in all.\n",
        if q { " --quick" } else { "" },
        util::git_commit(),
        util::cpu_name(),
        util::thread_count(a.threads),
        a.seed,
        t0.elapsed().as_secs_f64()
    );
    std::fs::write(out.join("README.md"), md)?;
    println!(
        "study written to {} ({:.0} s)",
        out.display(),
        t0.elapsed().as_secs_f64()
    );
    Ok(())
}

/// One parsed CSV row.
struct Row<'a> {
    f: HashMap<&'a str, &'a str>,
}

impl Row<'_> {
    fn s(&self, k: &str) -> &str {
        self.f.get(k).copied().unwrap_or("")
    }
    fn x(&self, k: &str) -> Option<f64> {
        self.f
            .get(k)
            .and_then(|v| v.parse::<f64>().ok())
            .filter(|v| v.is_finite())
    }
    /// Reference over this (> 1: this tree is better), for a metric and its `ref_` column.
    fn gain(&self, k: &str) -> Option<f64> {
        let (a, r) = (self.x(k)?, self.x(&format!("ref_{k}"))?);
        (a > 0.0 && r > 0.0).then(|| r / a)
    }
}

/// Renders a study CSV (as written by `cargo xtask study`) as markdown: one table per factor,
/// rows = settings, columns = geometric means over the scenes of the setting's gain against
/// its reference (reference / builder: > 1 is better, for SAH, EPO and work per ray) and the
/// build-time factor; then each setting's best scene for primary rays; then per-scene tables.
/// The eval report can call this on the latest saved `study.csv`.
pub fn render_markdown(csv: &str) -> Result<String> {
    let mut lines = csv.lines();
    let header: Vec<&str> = lines
        .next()
        .context("empty study CSV")?
        .split(',')
        .collect();
    let rows: Vec<Row> = lines
        .filter(|l| !l.trim().is_empty())
        .map(|l| Row {
            f: header.iter().copied().zip(l.split(',')).collect(),
        })
        .collect();
    let mut md = String::new();
    let scenes: Vec<&str> = {
        let mut v: Vec<&str> = Vec::new();
        for r in &rows {
            if !v.contains(&r.s("scene")) {
                v.push(r.s("scene"));
            }
        }
        v
    };
    let _ = writeln!(
        md,
        "# Sensitivity study: temporary-subtree SAH against its reference\n"
    );
    let _ = writeln!(
        md,
        "Scenes ({}): {}.\n\nEvery cell is a geometric mean over the scenes of **reference ÷ \
         builder** (> 1: the builder's tree is better: lower SAH, lower EPO, less work per \
         ray), the reference being built under the same settings (same cost model, same leaf \
         size; SBVH for tsah-sbvh). Work per ray is `c_t · inner nodes + c_i · triangles` \
         with the setting's own cost constants, counted exactly (bvh8: 8-wide nodes and \
         triangles of the collapsed tree). `build ×` is the builder's build time over the \
         reference's (one run each; noisy on a shared machine). `best primary` is the \
         setting's largest primary-ray gain over the scenes. Speed columns (median of \
         per-round time ratios; 1 exactly where the tree equals its reference) are absent \
         when the study ran without timing (`--no-speed`, or `--quick` without `--speed`).\n",
        scenes.len(),
        scenes.join(", ")
    );
    let has_speed = rows.iter().any(|r| r.x("speed_bvh2_primary").is_some());
    let mut factors: Vec<&str> = Vec::new();
    for r in &rows {
        if !factors.contains(&r.s("factor")) {
            factors.push(r.s("factor"));
        }
    }
    let gain_cols: &[(&str, &str)] = &[
        ("SAH", "sah"),
        ("EPO", "epo"),
        ("bvh2 primary", "work_bvh2_primary"),
        ("bvh2 diffuse", "work_bvh2_diffuse"),
        ("bvh2 AO", "work_bvh2_ao"),
        ("bvh8 primary", "work_bvh8_primary"),
        ("bvh8 diffuse", "work_bvh8_diffuse"),
        ("bvh8 AO", "work_bvh8_ao"),
    ];
    let speed_cols: &[(&str, &str)] = &[
        ("speed bvh2 primary", "speed_bvh2_primary"),
        ("speed bvh2 diffuse", "speed_bvh2_diffuse"),
        ("speed bvh8 primary", "speed_bvh8_primary"),
        ("speed bvh8 diffuse", "speed_bvh8_diffuse"),
    ];
    main_table(&mut md, &rows, &factors, has_speed);
    for factor in &factors {
        let _ = writeln!(md, "## Factor: {factor}\n");
        let mut head = "| builder | setting | reference | scenes |".to_string();
        let mut rule = "| --- | --- | --- | ---: |".to_string();
        for (h, _) in gain_cols {
            head += &format!(" {h} |");
            rule += " ---: |";
        }
        head += " build × | best primary (scene) |";
        rule += " ---: | --- |";
        if has_speed {
            for (h, _) in speed_cols {
                head += &format!(" {h} |");
                rule += " ---: |";
            }
        }
        let _ = writeln!(md, "{head}\n{rule}");
        let mut keys: Vec<(&str, &str, &str)> = Vec::new();
        for r in rows.iter().filter(|r| r.s("factor") == *factor) {
            let k = (r.s("builder"), r.s("level"), r.s("reference"));
            if !keys.contains(&k) {
                keys.push(k);
            }
        }
        for k in keys {
            let sel: Vec<&Row> = rows
                .iter()
                .filter(|r| {
                    r.s("factor") == *factor
                        && (r.s("builder"), r.s("level"), r.s("reference")) == k
                })
                .collect();
            let mut line = format!("| {} | {} | {} | {} |", k.0, k.1, k.2, sel.len());
            for (_, c) in gain_cols {
                let v: Vec<f64> = sel.iter().filter_map(|r| r.gain(c)).collect();
                line += &format!(" {} |", fmt_cell(geomean(&v)));
            }
            let bt: Vec<f64> = sel
                .iter()
                .filter_map(|r| r.gain("build_s").map(|g| 1.0 / g))
                .collect();
            let best = sel
                .iter()
                .filter_map(|r| r.gain("work_bvh2_primary").map(|g| (g, r.s("scene"))))
                .max_by(|a, b| a.0.total_cmp(&b.0));
            line += &format!(
                " {} | {} |",
                fmt_cell(geomean(&bt)),
                best.map(|(g, s)| format!("{g:.3} ({s})"))
                    .unwrap_or_default()
            );
            if has_speed {
                for (_, c) in speed_cols {
                    let v: Vec<f64> = sel.iter().filter_map(|r| r.x(c)).collect();
                    line += &format!(" {} |", fmt_cell(geomean(&v)));
                }
            }
            let _ = writeln!(md, "{line}");
        }
        let _ = writeln!(md);
    }
    let _ = writeln!(md, "## Per scene\n");
    let _ = writeln!(
        md,
        "Each setting's gains on each scene (reference ÷ builder; SAH, then bvh2 work for \
         primary / diffuse / AO, then bvh8 primary).\n"
    );
    let has_intervals = rows.iter().any(|r| r.x("speed_bvh8_primary_low").is_some());
    let speed_head = if has_intervals {
        " bvh8 speed primary / diffuse / AO [95%] (rounds) |"
    } else {
        ""
    };
    let _ = writeln!(
        md,
        "| scene | triangles | factor | builder | setting | camera (inside) | SAH | primary | diffuse | AO | bvh8 primary |{speed_head}\n| --- | ---: | --- | --- | --- | --- | ---: | ---: | ---: | ---: | ---: |{}",
        if has_intervals { " --- |" } else { "" }
    );
    for r in &rows {
        let speed = if has_intervals {
            let cells: Vec<String> = ["primary", "diffuse", "ao"]
                .iter()
                .map(|k| speed_cell(r, &format!("speed_bvh8_{k}")))
                .collect();
            format!(" {} ({}) |", cells.join(" / "), r.s("speed_rounds"))
        } else {
            String::new()
        };
        let _ = writeln!(
            md,
            "| {} | {} | {} | {} | {} | {} ({}) | {} | {} | {} | {} | {} |{speed}",
            r.s("scene"),
            r.s("triangles"),
            r.s("factor"),
            r.s("builder"),
            r.s("level"),
            r.s("camera"),
            r.s("camera_inside"),
            fmt_cell(r.gain("sah")),
            fmt_cell(r.gain("work_bvh2_primary")),
            fmt_cell(r.gain("work_bvh2_diffuse")),
            fmt_cell(r.gain("work_bvh2_ao")),
            fmt_cell(r.gain("work_bvh8_primary")),
        );
    }
    Ok(md)
}

/// The geometric mean over `sel` of the gain in column `c`.
fn mean_gain(sel: &[&Row], c: &str) -> Option<f64> {
    geomean(&sel.iter().filter_map(|r| r.gain(c)).collect::<Vec<_>>())
}

/// The geometric mean over `sel` of the raw value in column `c` (speed ratios).
fn mean_x(sel: &[&Row], c: &str) -> Option<f64> {
    geomean(&sel.iter().filter_map(|r| r.x(c)).collect::<Vec<_>>())
}

/// The study's main table, one row per factor: the level with the largest geometric-mean
/// bvh2 primary work gain among the levels that ran on every scene of the factor, its other
/// figures, and the range of that gain over the factor's levels (how much the knob moves it).
/// Then the largest single-scene gains of the whole study, with their measured speed.
fn main_table(md: &mut String, rows: &[Row], factors: &[&str], has_speed: bool) {
    let _ = writeln!(
        md,
        "## Main table\n\nPer factor, the level with the largest bvh2 primary-ray work gain \
         (geometric mean over the scenes the factor's levels all ran on), and the range of \
         that gain over the factor's levels.\n"
    );
    let mut head = "| factor | best level (builder) | scenes | SAH | bvh2 primary | bvh2 diffuse | \
                    bvh2 AO | bvh8 primary | bvh8 diffuse | bvh8 AO | build × | range over levels |"
        .to_string();
    let mut rule =
        "| --- | --- | ---: | ---: | ---: | ---: | ---: | ---: | ---: | ---: | ---: | --- |"
            .to_string();
    if has_speed {
        head += " speed bvh2 primary | speed bvh8 primary | speed bvh8 diffuse |";
        rule += " ---: | ---: | ---: |";
    }
    let _ = writeln!(md, "{head}\n{rule}");
    for factor in factors {
        let in_factor: Vec<&Row> = rows.iter().filter(|r| r.s("factor") == *factor).collect();
        let mut keys: Vec<(&str, &str, &str)> = Vec::new();
        for r in &in_factor {
            let k = (r.s("builder"), r.s("level"), r.s("reference"));
            if !keys.contains(&k) {
                keys.push(k);
            }
        }
        let of = |k: &(&str, &str, &str)| -> Vec<&Row> {
            in_factor
                .iter()
                .copied()
                .filter(|r| (r.s("builder"), r.s("level"), r.s("reference")) == *k)
                .collect()
        };
        let full = keys.iter().map(|k| of(k).len()).max().unwrap_or(0);
        let rated: Vec<((&str, &str, &str), f64)> = keys
            .iter()
            .filter(|k| of(k).len() == full)
            .filter_map(|k| mean_gain(&of(k), "work_bvh2_primary").map(|g| (*k, g)))
            .collect();
        let Some((best, _)) = rated.iter().copied().max_by(|a, b| a.1.total_cmp(&b.1)) else {
            continue;
        };
        let lo = rated.iter().map(|r| r.1).fold(f64::INFINITY, f64::min);
        let hi = rated.iter().map(|r| r.1).fold(f64::NEG_INFINITY, f64::max);
        let sel = of(&best);
        let mut line = format!("| {factor} | {} ({}) | {} |", best.1, best.0, sel.len());
        for c in [
            "sah",
            "work_bvh2_primary",
            "work_bvh2_diffuse",
            "work_bvh2_ao",
            "work_bvh8_primary",
            "work_bvh8_diffuse",
            "work_bvh8_ao",
        ] {
            line += &format!(" {} |", fmt_cell(mean_gain(&sel, c)));
        }
        let bt: Vec<f64> = sel
            .iter()
            .filter_map(|r| r.gain("build_s").map(|g| 1.0 / g))
            .collect();
        line += &format!(" {} | {lo:.3}–{hi:.3} |", fmt_cell(geomean(&bt)));
        if has_speed {
            for c in [
                "speed_bvh2_primary",
                "speed_bvh8_primary",
                "speed_bvh8_diffuse",
            ] {
                line += &format!(" {} |", fmt_cell(mean_x(&sel, c)));
            }
        }
        let _ = writeln!(md, "{line}");
    }
    let _ = writeln!(
        md,
        "\n### Largest single-scene gains\n\nThe ten (scene, setting) rows with the largest \
         bvh2 primary-ray work gain{}.\n",
        if has_speed {
            ", with their measured bvh2 and bvh8 primary speed (median ratio [95% interval])"
        } else {
            ""
        }
    );
    let mut top: Vec<&Row> = rows
        .iter()
        .filter(|r| r.gain("work_bvh2_primary").is_some())
        .collect();
    top.sort_by(|a, b| {
        b.gain("work_bvh2_primary")
            .unwrap_or(0.0)
            .total_cmp(&a.gain("work_bvh2_primary").unwrap_or(0.0))
    });
    // One row per (scene, builder, level): the same tree appears in several factors.
    let mut seen: Vec<(&str, &str, &str, &str)> = Vec::new();
    let _ = writeln!(
        md,
        "| scene | factor | builder | setting | camera | SAH | bvh2 primary | bvh2 diffuse | bvh8 primary |{}\n| --- | --- | --- | --- | --- | ---: | ---: | ---: | ---: |{}",
        if has_speed { " speed bvh2 primary | speed bvh8 primary |" } else { "" },
        if has_speed { " --- | --- |" } else { "" }
    );
    for r in top {
        let k = (r.s("scene"), r.s("builder"), r.s("level"), r.s("camera"));
        if seen.contains(&k) {
            continue;
        }
        seen.push(k);
        let mut line = format!(
            "| {} | {} | {} | {} | {} | {} | {} | {} | {} |",
            r.s("scene"),
            r.s("factor"),
            r.s("builder"),
            r.s("level"),
            r.s("camera"),
            fmt_cell(r.gain("sah")),
            fmt_cell(r.gain("work_bvh2_primary")),
            fmt_cell(r.gain("work_bvh2_diffuse")),
            fmt_cell(r.gain("work_bvh8_primary")),
        );
        if has_speed {
            line += &format!(
                " {} | {} |",
                speed_cell(r, "speed_bvh2_primary"),
                speed_cell(r, "speed_bvh8_primary")
            );
        }
        let _ = writeln!(md, "{line}");
        if seen.len() == 10 {
            break;
        }
    }
    let _ = writeln!(md);
}

/// A speed cell with its interval, `≈` marking an interval that contains 1 (a tie).
fn speed_cell(r: &Row, c: &str) -> String {
    match (r.x(c), r.x(&format!("{c}_low")), r.x(&format!("{c}_high"))) {
        (Some(e), Some(lo), Some(hi)) => {
            let tie = if lo <= 1.0 && 1.0 <= hi { "≈" } else { "" };
            format!("{tie}{e:.3} [{lo:.3}–{hi:.3}]")
        }
        (e, _, _) => fmt_cell(e),
    }
}

fn fmt_cell(x: Option<f64>) -> String {
    x.map(|v| format!("{v:.3}")).unwrap_or_else(|| "–".into())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn renders_a_small_csv() {
        let mut csv = COLUMNS.join(",") + "\n";
        let mut row: Vec<String> = vec![
            "s".into(),
            "10".into(),
            "cost".into(),
            "tsah-topk".into(),
            "c_t/c_i = 1/1".into(),
            "sweep".into(),
            "1".into(),
            "1".into(),
            "catalog".into(),
            "false".into(),
        ];
        row.extend(["2", "1", "9", "10", "4", "5"].map(String::from));
        for _ in 0..6 {
            row.push("8".into());
            row.push("10".into());
        }
        row.extend(std::iter::repeat_n(String::new(), 6 + 12 + 1));
        csv += &(row.join(",") + "\n");
        let md = render_markdown(&csv).unwrap();
        assert!(md.contains("## Factor: cost"), "{md}");
        // SAH gain 10/9, work gain 10/8, build 2×.
        assert!(md.contains("| 1.111 | 1.250 | 1.250 |"), "{md}");
        assert!(md.contains("| 2.000 | 1.250 (s) |"), "{md}");
    }

    #[test]
    fn speed_intervals_render_with_ties_marked() {
        let mut csv = COLUMNS.join(",") + "\n";
        let mut row: Vec<String> = ["s", "10", "cost", "tsah-topk", "x", "sweep", "1", "1"]
            .map(String::from)
            .to_vec();
        row.extend(["catalog", "false", "2", "1", "9", "10", "4", "5"].map(String::from));
        for _ in 0..6 {
            row.push("8".into());
            row.push("10".into());
        }
        row.extend(["1.1", "1.0", "1.0", "1.05", "0.99", "1.2"].map(String::from));
        row.extend(std::iter::repeat_n("0.5".to_string(), 6));
        row.extend(["1.04", "1.06", "0.98", "1.03", "1.1", "1.3"].map(String::from));
        row.push("15".into());
        assert_eq!(row.len(), COLUMNS.len());
        csv += &(row.join(",") + "\n");
        let md = render_markdown(&csv).unwrap();
        assert!(
            md.contains(
                "| 1.050 [1.040–1.060] / ≈0.990 [0.980–1.030] / 1.200 [1.100–1.300] (15) |"
            ),
            "{md}"
        );
    }

    #[test]
    fn undecided_speed_cells_get_more_rounds() {
        let iv = |estimate, low, high| Interval {
            estimate,
            low,
            high,
        };
        // Contains 1 and is wide: rerun.
        assert!(needs_more_rounds(&iv(1.01, 0.97, 1.05), 5));
        // Excludes 1: settled.
        assert!(!needs_more_rounds(&iv(1.04, 1.01, 1.07), 5));
        // Contains 1 but narrower than 2%: a tie, settled.
        assert!(!needs_more_rounds(&iv(1.0, 0.995, 1.01), 5));
        // Out of rounds: settled whatever the interval.
        assert!(!needs_more_rounds(&iv(1.01, 0.9, 1.1), MAX_SPEED_ROUNDS));
    }

    #[test]
    fn every_factor_has_settings() {
        for f in FACTORS {
            assert!(!settings(f, true).unwrap().is_empty());
            assert!(!settings(f, false).unwrap().is_empty());
        }
        assert!(settings("nope", true).is_err());
    }
}
