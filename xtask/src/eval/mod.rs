//! `cargo xtask eval`: the paper's evaluation matrix (scenes × builders × ray types ×
//! layouts), written as a dated report folder under `target/eval/`.
//!
//! For each scene every builder builds its tree (timed, with SAH and EPO); the ray sets are
//! generated once per scene (they do not depend on the tree: hits are deterministic) and each
//! tree is traced with each layout (timed after a warm-up, the passes of every layout and tree
//! interleaved, and counted). Results are reported
//! relative to the full-sweep SAH tree (and to SBVH for spatial-split builders), in measured
//! speed and in work per ray; the SAH-EPO predictors are fitted to the measurements.

#[cfg(test)]
mod browser_test;
mod plot;
mod predict;
mod report;
pub mod saved_study;

use crate::engine::{self, Engine, TraceReport};
use crate::interval;
use crate::tree::{self, build_and_measure, BuildReport};
use crate::util::{self, file_stem};
use anyhow::{Context, Result};
use indicatif::{ProgressBar, ProgressStyle};
use sahara_trace::{RayKind, RaySet};
use serde::Serialize;
use std::path::{Path, PathBuf};

#[derive(clap::Args, Clone)]
pub struct Args {
    /// Small matrix on the built-in procedural scenes (about two minutes on two cores).
    #[arg(long)]
    pub quick: bool,
    /// The whole matrix: every registered builder, every layout, 1024×768 (over an hour).
    #[arg(long, conflicts_with = "quick")]
    pub full: bool,
    /// Scenes (catalog names or paths; default: see `--quick`).
    #[arg(long, value_delimiter = ',')]
    pub scenes: Vec<String>,
    /// The camera of every scene of the run: `eye=x,y,z target=x,y,z up=x,y,z fov=deg` (up
    /// and fov optional). Default: each scene's own; a scene given by path without one gets
    /// its row in a `cameras.tsv` beside it, else a placed camera (docs/cameras.md).
    #[arg(long, value_parser = crate::util::parse_camera)]
    pub camera: Option<sahara_scene::Camera>,
    /// Builders (default: every registered builder practical at the scene sizes).
    #[arg(long, value_delimiter = ',')]
    pub builders: Vec<String>,
    /// Ray types.
    #[arg(long, value_delimiter = ',', default_value = "primary,diffuse,ao")]
    pub rays: Vec<String>,
    /// Layouts to trace (and foreign engines, with their features: embree, tinybvh,
    /// tinybvh-hq, obvhs).
    #[arg(long, value_delimiter = ',')]
    pub layouts: Vec<Engine>,
    /// SIMD kernels of bvh4/bvh8: portable, sse2, avx2 or avx512 (default: the best this CPU
    /// runs; a backend the CPU lacks is an error). Embree gets the matching `isa=`.
    #[arg(long, value_parser = engine::parse_backend_arg)]
    pub backend: Option<sahara_trace::Backend>,
    /// Output folder (default: target/eval/<date>).
    #[arg(long)]
    pub out: Option<PathBuf>,
    /// Rayon threads for building and tracing (default: all cores).
    #[arg(long)]
    pub threads: Option<usize>,
    /// Image width (default 320, quick 256, full 1024).
    #[arg(long)]
    pub width: Option<u32>,
    /// Image height (default 240, quick 192, full 768).
    #[arg(long)]
    pub height: Option<u32>,
    /// Timed interleaved trace rounds (default 15, quick 11, full 11).
    #[arg(long)]
    pub passes: Option<usize>,
    /// Seconds of timed rounds per scene and ray type (default 20, full 0 = no budget): when
    /// the warm-up round shows that `--passes` rounds would take longer, fewer are traced, but
    /// never fewer than 5 (see docs/evaluation.md).
    #[arg(long)]
    pub round_budget: Option<f64>,
    /// Timed builds per builder (default 3, full 5; builds slower than 1 s run once).
    #[arg(long)]
    pub build_runs: Option<usize>,
    /// Seed of the secondary rays.
    #[arg(long, default_value_t = 1)]
    pub seed: u64,
    /// Skip the build-time-against-N section.
    #[arg(long)]
    pub no_scaling: bool,
}

/// Settings after defaults are applied.
#[derive(Clone, Debug, Serialize)]
pub struct Settings {
    pub quick: bool,
    pub full: bool,
    pub scenes: Vec<String>,
    pub builders: Vec<String>,
    pub rays: Vec<String>,
    pub layouts: Vec<Engine>,
    /// The backend of the bvh4/bvh8 kernels (`--backend`), also matched by Embree's ISA.
    pub backend: String,
    pub width: u32,
    pub height: u32,
    pub passes: usize,
    /// Seconds of timed rounds per scene and ray type (0: always `passes` rounds).
    pub round_budget: f64,
    pub build_runs: usize,
    pub threads: usize,
    pub seed: u64,
    pub cost_model: sahara_metrics::CostModel,
}

/// Facts about the run, written into every report.
#[derive(Clone, Debug, Serialize)]
pub struct Meta {
    pub date: String,
    pub commit: String,
    pub cpu: String,
    pub simd: String,
    pub settings: Settings,
    pub seconds: f64,
}

/// One scene's entry in the results.
#[derive(Clone, Debug, Serialize)]
pub struct SceneInfo {
    pub name: String,
    pub triangles: usize,
    pub render: Option<String>,
    pub heat_maps: Vec<(String, String)>,
    /// The work per pixel at the top of every heat map's colour scale (shared by the scene's
    /// trees).
    pub heat_scale: f64,
    /// Per builder other than sweep: the image of its per-pixel work minus the sweep tree's
    /// (blue: less work than sweep, red: more).
    pub diff_maps: Vec<(String, String)>,
    /// The work difference per pixel at either end of the difference maps' colour scale.
    pub diff_scale: f64,
    /// The camera of the primary rays (`eye=… target=… up=… fov=…`).
    pub camera: String,
    /// Where it comes from (`generator`, `cameras.tsv`, `command line`, `placed (…)`, …).
    pub camera_source: String,
    /// Timed rounds per ray type (`primary`, …), fewer than `passes` where the round budget
    /// cut them.
    pub rounds: Vec<(String, usize)>,
}

/// A trace measurement with its comparisons.
#[derive(Clone, Debug, Serialize)]
pub struct TraceRow {
    #[serde(flatten)]
    pub report: TraceReport,
    /// Trace cost per ray in SAH units, `c_t · inner + c_i · triangles`.
    pub work_cost: f64,
    /// Speed relative to the sweep tree on the same rays and layout (> 1 is faster).
    pub speed_vs_sweep: Option<f64>,
    /// Work relative to the sweep tree (sweep work / this work; > 1 is less work).
    pub work_vs_sweep: Option<f64>,
    /// Speed relative to SBVH (spatial-split builders).
    pub speed_vs_sbvh: Option<f64>,
    /// Work relative to SBVH.
    pub work_vs_sbvh: Option<f64>,
    /// The seconds of each timed round (the rounds of every tree of the scene are
    /// interleaved, so round `i` of two rows was taken in the same time window).
    pub round_seconds: Vec<f64>,
    /// The 95% interval of `speed_vs_sweep` (median of per-round ratios, bootstrapped).
    pub speed_vs_sweep_ci: Option<interval::Interval>,
    /// The 95% interval of `speed_vs_sbvh`.
    pub speed_vs_sbvh_ci: Option<interval::Interval>,
}

/// Everything the report is made from (`results.json`).
#[derive(Clone, Debug, Serialize)]
pub struct Results {
    pub meta: Meta,
    pub scenes: Vec<SceneInfo>,
    /// Builders left out on scenes where they are impractical.
    pub skipped: Vec<String>,
    pub builds: Vec<BuildReport>,
    pub traces: Vec<TraceRow>,
    pub predictors: Vec<predict::PredictorRow>,
    pub predicted_points: Vec<predict::PredictedPoint>,
    pub scaling: Vec<tree::Series>,
    /// The study's claims table and its saved run (read from `docs/`, not recomputed).
    pub study: Option<saved_study::SavedStudy>,
}

const REFERENCE: &str = "sweep";
const SPATIAL_REFERENCE: &str = "sbvh";

fn default_scenes(quick: bool) -> Vec<String> {
    if quick {
        return [
            "sphere_in_box:20000",
            "teapot_stadium:20000",
            "city:20000",
            "hairball:10000",
        ]
        .map(String::from)
        .to_vec();
    }
    let catalog = sahara_scene::Catalog::discover();
    // One file per model (the engine's GLB is its OBJ's model: traced once).
    let mut v: Vec<String> = catalog
        .distinct_files()
        .into_iter()
        .map(|e| e.name.clone())
        .collect();
    v.extend(["sphere_in_box", "teapot_stadium", "city", "hairball"].map(String::from));
    v
}

/// The default matrix's builders, in report order: the references, the paper's builders,
/// and the best presets of other work (reinsertion, PLOC). A name joins the run only when the
/// registry knows it ([`sahara_builders::registry::by_name`]), so presets still under way on
/// other branches appear by themselves once registered. Chosen to fit 20 minutes on two
/// cores with the shared scenes (timings in `docs/evaluation.md`).
pub const DEFAULT_BUILDERS: &[&str] = &[
    "sweep",
    "sbvh",
    "binned",
    "tsah-topk",
    "hybrid",
    "tsah-sbvh",
    "ploc",
    "sweep+reinsert",
    "sbvh+reinsert",
    "tsah-topk+reinsert",
    "ploc+reinsert",
];

/// The quick matrix keeps one preset of each strategy.
const QUICK_BUILDERS: &[&str] = &["sweep", "sbvh", "binned", "tsah-topk", "hybrid"];

/// The layouts of the default and quick matrices: the binary kernel (the paper's comparison)
/// and the 8-wide one (the headline: what users run); `--full` traces every layout.
const DEFAULT_LAYOUTS: &[Engine] = &[
    Engine::Bvh2,
    Engine::Bvh8,
    Engine::Embree,
    Engine::Tinybvh,
    Engine::TinybvhHq,
    Engine::Obvhs,
];

fn default_builders(quick: bool, full: bool) -> Vec<String> {
    if full {
        return tree::builders_for_large_inputs();
    }
    let list = if quick {
        QUICK_BUILDERS
    } else {
        DEFAULT_BUILDERS
    };
    list.iter()
        .filter(|n| sahara_builders::registry::by_name(n).is_some())
        .map(|n| n.to_string())
        .collect()
}

/// The layout whose speed the summary reports: `bvh8` when traced, else the first.
pub fn headline_layout(layouts: &[Engine]) -> Engine {
    layouts
        .iter()
        .find(|l| **l == Engine::Bvh8)
        .or(layouts.first())
        .copied()
        .unwrap_or(Engine::Bvh2)
}

/// True when `builder` splits triangles: the registry's `spatial` flag, or Embree's
/// spatial-split tree (`embree-high`, not a registry entry). An unknown name is not spatial
/// (it fails later, when it is built).
fn is_spatial(builder: &str) -> bool {
    builder == "embree-high"
        || sahara_builders::registry::entries()
            .iter()
            .any(|e| e.name == builder && e.spatial)
}

/// True when `builder` should be skipped on a scene of `triangles` (only for builders the
/// user did not name: a named builder always runs).
fn impractical(builder: &str, triangles: usize, named: bool) -> bool {
    !named
        && sahara_builders::registry::entries()
            .iter()
            .any(|e| e.name == builder && e.max_practical_triangles.is_some_and(|m| triangles > m))
}

impl Args {
    /// The backend of the run: `--backend`, else the best of this CPU.
    fn backend(&self) -> sahara_trace::Backend {
        self.backend.unwrap_or_else(sahara_trace::Backend::best)
    }

    fn settings(&self) -> Settings {
        let (q, full) = (self.quick, self.full);
        let mut builders = if self.builders.is_empty() {
            default_builders(q, full)
        } else {
            self.builders.clone()
        };
        // The references the run's comparisons need come first: `sweep` always, `sbvh` when a
        // spatial-split builder is in the run (only their "vs sbvh" figures use it).
        let needs_spatial = builders.iter().any(|b| is_spatial(b));
        for r in [SPATIAL_REFERENCE, REFERENCE] {
            let needed = r == REFERENCE || needs_spatial;
            if needed && !builders.iter().any(|b| b == r) {
                builders.insert(0, r.to_string());
            }
        }
        builders.sort_by_key(|b| (b != REFERENCE, b != SPATIAL_REFERENCE));
        Settings {
            quick: q,
            full,
            scenes: if self.scenes.is_empty() {
                default_scenes(q)
            } else {
                self.scenes.clone()
            },
            builders,
            rays: self.rays.clone(),
            layouts: if self.layouts.is_empty() {
                Engine::built()
                    .into_iter()
                    .filter(|l| full || DEFAULT_LAYOUTS.contains(l))
                    .collect()
            } else {
                self.layouts.clone()
            },
            backend: self.backend().name().to_string(),
            width: self.width.unwrap_or(pick(q, full, 256, 320, 1024)),
            height: self.height.unwrap_or(pick(q, full, 192, 240, 768)),
            passes: self.passes.unwrap_or(pick(q, full, 11, 15, 11)),
            round_budget: self.round_budget.unwrap_or(pick(q, full, 20.0, 20.0, 0.0)),
            build_runs: self.build_runs.unwrap_or(pick(q, full, 3, 3, 5)),
            threads: util::thread_count(self.threads),
            seed: self.seed,
            cost_model: sahara_metrics::CostModel::default(),
        }
    }
}

/// The quick, default or full value of a setting.
fn pick<T>(quick: bool, full: bool, q: T, default: T, f: T) -> T {
    if quick {
        q
    } else if full {
        f
    } else {
        default
    }
}

pub fn run(a: Args) -> Result<()> {
    let t0 = std::time::Instant::now();
    let s = a.settings();
    let out = util::out_dir(a.out.as_deref(), "target/eval", &util::utc_stamp());
    std::fs::create_dir_all(out.join("images"))
        .with_context(|| format!("creating {}", out.display()))?;
    std::fs::create_dir_all(out.join("plots"))?;
    let kinds: Vec<RayKind> = s
        .rays
        .iter()
        .map(|r| r.parse::<RayKind>().map_err(|e| anyhow::anyhow!("{e}")))
        .collect::<Result<_>>()?;
    for l in &s.layouts {
        anyhow::ensure!(l.is_built(), "unknown layout '{l}'");
    }
    for b in &s.builders {
        util::builder(b)?;
    }

    let steps = (s.scenes.len() * s.builders.len() * (1 + kinds.len() * s.layouts.len())) as u64;
    let bar = ProgressBar::new(steps);
    bar.set_style(
        ProgressStyle::with_template(
            "{elapsed_precise} [{bar:30}] {pos}/{len} ETA {eta_precise} {msg}",
        )
        .unwrap_or_else(|_| ProgressStyle::default_bar())
        .progress_chars("=> "),
    );

    let catalog = sahara_scene::Catalog::discover();
    let mut scenes = Vec::new();
    let mut builds = Vec::new();
    let mut traces: Vec<TraceRow> = Vec::new();
    let mut trees_for_predictors: Vec<predict::SceneTrees> = Vec::new();
    let mut skipped: Vec<String> = Vec::new();
    for scene_name in &s.scenes {
        status(&bar, format!("loading {scene_name}"));
        let scene = match util::load_scene_with(&catalog, scene_name, a.camera.as_ref()) {
            Ok(sc) => sc,
            Err(e) => {
                eprintln!("skipping scene {scene_name}: {e:#}");
                bar.inc((s.builders.len() * (1 + kinds.len() * s.layouts.len())) as u64);
                continue;
            }
        };
        let mut trees = Vec::new();
        for b in &s.builders {
            if impractical(b, scene.triangles.len(), !a.builders.is_empty()) {
                skipped.push(format!(
                    "{b} on {} ({} triangles; name it with --builders to run it)",
                    scene.name,
                    scene.triangles.len()
                ));
                bar.inc((1 + kinds.len() * s.layouts.len()) as u64);
                continue;
            }
            status(&bar, format!("{} / build {b}", scene.name));
            let (rep, bvh) =
                build_adaptive(&scene.name, &scene.triangles, b, s.build_runs, a.threads)?;
            bvh.validate(&scene.triangles)
                .with_context(|| format!("{b} on {}", scene.name))?;
            builds.push(rep);
            trees.push((b.clone(), bvh));
            bar.inc(1);
        }
        // Ray sets from the reference tree: identical for every tree (deterministic hits).
        let reference = &trees[0].1;
        let ref_tracer = sahara_trace::Bvh2Tracer::new(reference, &scene.triangles);
        let camera = engine::trace_camera(&scene.camera);
        let sets: Vec<RaySet> = util::with_threads(a.threads, || {
            kinds
                .iter()
                .map(|&k| {
                    RaySet::generate(
                        k,
                        &camera,
                        s.width,
                        s.height,
                        &ref_tracer,
                        &scene.triangles,
                        s.seed,
                    )
                })
                .collect()
        })?;
        let mut info = SceneInfo {
            name: scene.name.clone(),
            triangles: scene.triangles.len(),
            render: None,
            heat_maps: Vec::new(),
            heat_scale: 1.0,
            diff_maps: Vec::new(),
            diff_scale: 1.0,
            camera: scene.camera.to_string(),
            camera_source: scene.camera_source.clone(),
            rounds: Vec::new(),
        };
        let samples: Vec<(String, Vec<sahara_geom::Ray>)> = sets
            .iter()
            .map(|set| {
                let hits = (!set.kind.uses_any_hit())
                    .then(|| sahara_trace::trace_closest(&ref_tracer, &set.rays));
                (
                    set.kind.name().to_string(),
                    predict::ray_sample(&set.rays, hits.as_deref()),
                )
            })
            .collect();
        let first_row = traces.len();
        // Per-pixel primary-ray work of each tree, for heat maps on one colour scale.
        let mut heat: Vec<(String, sahara_trace::PixelWork)> = Vec::new();
        // The same work as raw per-pixel sums, for the difference maps against sweep.
        let mut pixel_work: Vec<(String, Vec<Option<u64>>)> = Vec::new();
        // Every tracer of the scene: one per layout and tree.
        let tracers: Vec<Vec<Box<dyn sahara_trace::Tracer + '_>>> = s
            .layouts
            .iter()
            .map(|layout| {
                trees
                    .iter()
                    .map(|(_, bvh)| layout.tracer(bvh, &scene.triangles, a.backend()))
                    .collect::<Result<_>>()
            })
            .collect::<Result<_>>()?;
        // Foreign engines (Embree, tinybvh, obvhs) ignore the builders' trees (every tracer of
        // such a layout traces the same tree of the engine's own): each is traced once, and
        // its figures fill every builder's row.
        let timed_trees = |layout: &Engine| {
            if layout.is_foreign() {
                1
            } else {
                trees.len()
            }
        };
        // Timings per ray set, layout and tree. The passes of every layout and tree are
        // interleaved (one warm-up round, then `passes` timed rounds), so that the drift of a
        // shared machine hits every engine alike and their ratios come from the same rounds.
        let mut timings: Vec<Vec<Vec<Vec<f64>>>> = Vec::new();
        for set in &sets {
            status(&bar, format!("{} / trace {}", scene.name, set.kind.name()));
            let engines: Vec<&dyn sahara_trace::Tracer> = s
                .layouts
                .iter()
                .zip(&tracers)
                .flat_map(|(layout, ts)| ts[..timed_trees(layout)].iter().map(|t| t.as_ref()))
                .collect();
            let samples = util::with_threads(a.threads, || {
                interleaved_timings(&engines, set, s.passes, s.round_budget)
            })?;
            info.rounds.push((
                set.kind.name().to_string(),
                samples.first().map_or(0, Vec::len),
            ));
            let mut flat = samples.into_iter();
            timings.push(
                s.layouts
                    .iter()
                    .map(|layout| flat.by_ref().take(timed_trees(layout)).collect())
                    .collect(),
            );
        }
        for (li, layout) in s.layouts.iter().enumerate() {
            for (si, set) in sets.iter().enumerate() {
                status(
                    &bar,
                    format!("{} / count {layout} {}", scene.name, set.kind.name()),
                );
                let shared = timed_trees(layout) == 1 && trees.len() > 1;
                let mut shared_counts: Option<
                    sahara_trace::CountedTrace<sahara_trace::TraceResults>,
                > = None;
                for (ti, ((b, _), tracer)) in trees.iter().zip(&tracers[li]).enumerate() {
                    let rounds = &timings[si][li][if shared { 0 } else { ti }];
                    let timing = sahara_trace::Timing::from_samples(rounds);
                    let counted = match &shared_counts {
                        Some(c) => c.clone(),
                        None => util::with_threads(a.threads, || {
                            sahara_trace::trace_set_counted(tracer.as_ref(), set)
                        })?,
                    };
                    if shared && shared_counts.is_none() {
                        shared_counts = Some(counted.clone());
                    }
                    let rep = engine::report(
                        &scene.name,
                        scene.triangles.len(),
                        b,
                        *layout,
                        &layout.backend_name(a.backend()),
                        set,
                        a.threads,
                        timing,
                        &counted,
                    );
                    if *layout == Engine::Bvh2 && set.kind == RayKind::Primary {
                        write_render(&out, &scene, set, &counted, &mut info)?;
                        heat.push((
                            b.clone(),
                            sahara_trace::PixelWork::new(
                                set.width,
                                set.height,
                                &set.pixel,
                                &counted.work,
                            ),
                        ));
                        pixel_work.push((b.clone(), per_pixel_work(set, &counted.work)));
                    }
                    let cm = s.cost_model;
                    traces.push(TraceRow {
                        work_cost: cm.traversal as f64 * rep.inner_per_ray
                            + cm.intersection as f64 * rep.triangles_per_ray,
                        report: rep,
                        speed_vs_sweep: None,
                        work_vs_sweep: None,
                        speed_vs_sbvh: None,
                        work_vs_sbvh: None,
                        round_seconds: rounds.clone(),
                        speed_vs_sweep_ci: None,
                        speed_vs_sbvh_ci: None,
                    });
                    bar.inc(1);
                }
            }
        }
        drop(tracers);
        write_heat_maps(&out, &scene.name, &heat, &mut info)?;
        write_diff_maps(&out, &scene.name, s.width, s.height, &pixel_work, &mut info)?;
        relate(&mut traces[first_row..]);
        trees_for_predictors.push(predict::SceneTrees {
            scene,
            trees,
            samples,
        });
        scenes.push(info);
    }
    bar.finish_with_message("traced");

    let (predictors, predicted_points) =
        predict::evaluate(&trees_for_predictors, &builds, &traces, &s)?;

    let scaling = if a.no_scaling {
        Vec::new()
    } else {
        let sizes: Vec<usize> = pick(
            s.quick,
            s.full,
            vec![1_000, 4_000, 16_000],
            vec![1_000, 10_000, 100_000],
            vec![1_000, 10_000, 100_000, 1_000_000],
        );
        eprintln!("scaling: build time against N on procedural 'soup' ({sizes:?})");
        tree::measure_scaling(
            &s.builders,
            sahara_scene::Procedural::Soup,
            &sizes,
            pick(s.quick, s.full, 1, 1, 3),
            pick(s.quick, s.full, 5.0, 5.0, 300.0),
            a.threads,
            a.builders.is_empty(),
            |b, n, t| eprintln!("  {b:<16} N = {n:>9}: {t:.3} s"),
        )?
    };

    let results = Results {
        meta: Meta {
            date: util::utc_stamp(),
            commit: util::git_commit(),
            cpu: util::cpu_name(),
            simd: simd_backend(),
            settings: s,
            seconds: t0.elapsed().as_secs_f64(),
        },
        scenes,
        skipped,
        builds,
        traces,
        predictors,
        predicted_points,
        scaling,
        study: saved_study::load(&Path::new(env!("CARGO_MANIFEST_DIR")).join("..")),
    };
    report::write_all(&out, &results)?;
    link_latest(&out)?;
    println!("report written to {}", out.join("report.md").display());
    println!("                  {}", out.join("report.html").display());
    Ok(())
}

/// Shows `msg` on the progress bar, or as a log line when stderr is not a terminal (the bar
/// is hidden there).
fn status(bar: &ProgressBar, msg: String) {
    if bar.is_hidden() {
        eprintln!(
            "[{:>4}/{} {:>5.0} s] {msg}",
            bar.position(),
            bar.length().unwrap_or(0),
            bar.elapsed().as_secs_f64()
        );
    }
    bar.set_message(msg);
}

/// The fewest timed rounds the round budget may leave (the bootstrap intervals need a few).
pub const MIN_ROUNDS: usize = 5;

/// How many timed rounds fit `budget` seconds when one round takes `round` seconds: `passes`
/// when they fit (or when the budget is 0, off), else as many as fit, but at least
/// [`MIN_ROUNDS`] (and never more than `passes`).
pub fn rounds_within(round: f64, budget: f64, passes: usize) -> usize {
    if budget <= 0.0 || round <= 0.0 || round * passes as f64 <= budget {
        return passes;
    }
    ((budget / round).floor() as usize).clamp(MIN_ROUNDS.min(passes), passes)
}

/// Times every tracer on `set`: one untimed warm-up round, then `passes` rounds (fewer when
/// they would exceed `budget` seconds, see [`rounds_within`]), each round tracing the whole set
/// once with every tracer in turn; the seconds of every round, per tracer.
fn interleaved_timings(
    tracers: &[&dyn sahara_trace::Tracer],
    set: &RaySet,
    passes: usize,
    budget: f64,
) -> Vec<Vec<f64>> {
    let warm_up = std::time::Instant::now();
    for t in tracers {
        std::hint::black_box(sahara_trace::trace_set(*t, set));
    }
    let rounds = rounds_within(warm_up.elapsed().as_secs_f64(), budget, passes.max(1));
    let mut samples = vec![Vec::with_capacity(rounds); tracers.len()];
    for _ in 0..rounds {
        for (i, t) in tracers.iter().enumerate() {
            let t0 = std::time::Instant::now();
            std::hint::black_box(sahara_trace::trace_set(*t, set));
            samples[i].push(t0.elapsed().as_secs_f64());
        }
    }
    samples
}

/// The percentile of per-pixel work that the heat maps' colour scale tops out at.
pub const HEAT_PERCENTILE: f64 = 99.0;

/// The scene's shaded render (once per scene, from the first tree's primary hits).
fn write_render(
    out: &Path,
    scene: &util::LoadedScene,
    set: &RaySet,
    counted: &sahara_trace::CountedTrace<sahara_trace::TraceResults>,
    info: &mut SceneInfo,
) -> Result<()> {
    if info.render.is_some() {
        return Ok(());
    }
    if let sahara_trace::TraceResults::Closest(hits) = &counted.results {
        let path = format!("images/{}-render.png", file_stem(&scene.name));
        sahara_trace::shade(
            set.width,
            set.height,
            &set.pixel,
            &set.rays,
            hits,
            &scene.triangles,
            sahara_trace::Shading::Grey,
        )
        .write_png(out.join(&path))?;
        info.render = Some(path);
    }
    Ok(())
}

/// Heat maps of primary-ray work, one per tree, all on one colour scale: the largest of the
/// trees' [`HEAT_PERCENTILE`]-th percentiles of per-pixel work, so that a colour means the same
/// work in every image of the scene (recorded in `info.heat_scale`).
fn write_heat_maps(
    out: &Path,
    scene: &str,
    heat: &[(String, sahara_trace::PixelWork)],
    info: &mut SceneInfo,
) -> Result<()> {
    let scale = heat
        .iter()
        .map(|(_, w)| w.percentile(HEAT_PERCENTILE))
        .fold(1.0, f64::max);
    for (builder, work) in heat {
        let path = format!("images/{}-{}-heat.png", file_stem(scene), builder);
        work.heat_map(scale, HEAT_PERCENTILE)
            .image
            .write_png(out.join(&path))?;
        info.heat_maps.push((builder.clone(), path));
    }
    info.heat_scale = scale;
    Ok(())
}

/// Builds slower than this are timed once (the report says how many runs each has).
const SLOW_BUILD_MS: f64 = 1000.0;

/// Builds `builder`'s tree and measures it: one timed build, and when it took under
/// [`SLOW_BUILD_MS`], `runs` timed builds (the median is reported); EPO of the tree.
fn build_adaptive(
    scene: &str,
    tris: &[sahara_geom::Triangle],
    builder: &str,
    runs: usize,
    threads: Option<usize>,
) -> Result<(BuildReport, sahara_bvh::Bvh)> {
    let (mut rep, bvh) = build_and_measure(scene, tris, builder, threads, 1, false)?;
    if runs > 1 && rep.build_ms.median < SLOW_BUILD_MS {
        return build_and_measure(scene, tris, builder, threads, runs, true);
    }
    rep.epo = Some(util::with_threads(threads, || {
        sahara_metrics::epo(&bvh, tris, &sahara_metrics::CostModel::default())
    })?);
    Ok((rep, bvh))
}

/// Per pixel of `set`'s image, the summed work of its rays (`None` for pixels without a
/// ray), as [`sahara_trace::PixelWork`] sums it.
fn per_pixel_work(set: &RaySet, work: &[sahara_trace::WorkCounters]) -> Vec<Option<u64>> {
    let mut v = vec![None; set.width as usize * set.height as usize];
    for (&p, w) in set.pixel.iter().zip(work) {
        if let Some(slot) = v.get_mut(p as usize) {
            *slot = Some(slot.unwrap_or(0) + sahara_trace::work_total(w));
        }
    }
    v
}

/// The diverging colour of `x` in `[-1, 1]` (clamped; NaN as 0): blue for negative (less
/// work than sweep), near-white at 0, red for positive (ColorBrewer RdBu ends).
pub fn diverging(x: f64) -> [u8; 3] {
    const BLUE: [f64; 3] = [33.0, 102.0, 172.0];
    const MID: [f64; 3] = [247.0, 247.0, 247.0];
    const RED: [f64; 3] = [178.0, 24.0, 43.0];
    let x = if x.is_nan() { 0.0 } else { x.clamp(-1.0, 1.0) };
    let (end, t) = if x < 0.0 { (BLUE, -x) } else { (RED, x) };
    std::array::from_fn(|c| (MID[c] + (end[c] - MID[c]) * t + 0.5) as u8)
}

/// One image per tree other than sweep: its per-pixel work minus the sweep tree's, coloured
/// by [`diverging`] on one symmetric scale for the scene (the largest of the trees'
/// [`HEAT_PERCENTILE`]-th percentiles of the absolute difference, at least 1). Pixels without
/// a ray are black.
fn write_diff_maps(
    out: &Path,
    scene: &str,
    width: u32,
    height: u32,
    work: &[(String, Vec<Option<u64>>)],
    info: &mut SceneInfo,
) -> Result<()> {
    let Some((_, reference)) = work.iter().find(|(b, _)| b == REFERENCE) else {
        return Ok(());
    };
    let diffs: Vec<(&String, Vec<Option<f64>>)> = work
        .iter()
        .filter(|(b, _)| b != REFERENCE)
        .map(|(b, w)| {
            let d = w
                .iter()
                .zip(reference)
                .map(|(x, r)| {
                    Some(x.unwrap_or(0) as f64 - r.unwrap_or(0) as f64)
                        .filter(|_| x.is_some() || r.is_some())
                })
                .collect();
            (b, d)
        })
        .collect();
    let scale = diffs
        .iter()
        .map(|(_, d)| {
            let mut a: Vec<f64> = d.iter().flatten().map(|x| x.abs()).collect();
            a.sort_by(f64::total_cmp);
            let rank = ((HEAT_PERCENTILE / 100.0) * a.len() as f64).ceil() as usize;
            a.get(rank.clamp(1, a.len().max(1)) - 1)
                .copied()
                .unwrap_or(0.0)
        })
        .fold(1.0, f64::max);
    for (builder, d) in diffs {
        let mut image = sahara_trace::RgbImage::new(width, height);
        for (i, v) in d.iter().enumerate() {
            if let Some(v) = v {
                image.set(i, diverging(v / scale));
            }
        }
        let path = format!(
            "images/{}-{}-diff.png",
            file_stem(scene),
            file_stem(builder)
        );
        image.write_png(out.join(&path))?;
        info.diff_maps.push((builder.clone(), path));
    }
    info.diff_scale = scale;
    Ok(())
}

/// Fills the relative columns of one scene's rows: work ratios, and speed ratios with their
/// intervals from the per-round ratios against the reference's rows of the same layout and
/// rays (the median of the throughput ratio when rounds are missing).
pub(crate) fn relate(rows: &mut [TraceRow]) {
    let find = |rows: &[TraceRow], b: &str, r: &TraceRow| {
        rows.iter()
            .find(|x| {
                x.report.builder == b
                    && x.report.layout == r.report.layout
                    && x.report.ray_kind == r.report.ray_kind
            })
            .map(|x| {
                (
                    x.report.mrays_s.median,
                    x.work_cost,
                    x.round_seconds.clone(),
                )
            })
    };
    let snapshot: Vec<TraceRow> = rows.to_vec();
    for r in rows.iter_mut() {
        let speed = |r: &TraceRow, (mrays, _, rounds): &(f64, f64, Vec<f64>)| {
            let ci = interval::median_interval(&interval::round_ratios(rounds, &r.round_seconds));
            let point = ci.map_or(r.report.mrays_s.median / mrays, |i| i.estimate);
            (Some(point), ci)
        };
        if let Some(reference) = find(&snapshot, REFERENCE, r) {
            (r.speed_vs_sweep, r.speed_vs_sweep_ci) = speed(r, &reference);
            r.work_vs_sweep = Some(reference.1 / r.work_cost);
        }
        if let Some(reference) = find(&snapshot, SPATIAL_REFERENCE, r) {
            (r.speed_vs_sbvh, r.speed_vs_sbvh_ci) = speed(r, &reference);
            r.work_vs_sbvh = Some(reference.1 / r.work_cost);
        }
    }
}

fn simd_backend() -> String {
    sahara_traverse::simd_backend().to_string()
}

/// Points `target/eval/latest` at the new folder (a symlink, or a copy where links fail).
fn link_latest(out: &Path) -> Result<()> {
    let Some(parent) = out.parent() else {
        return Ok(());
    };
    let latest = parent.join("latest");
    let _ = std::fs::remove_file(&latest);
    let _ = std::fs::remove_dir_all(&latest);
    #[cfg(unix)]
    {
        if let Some(name) = out.file_name() {
            if std::os::unix::fs::symlink(name, &latest).is_ok() {
                return Ok(());
            }
        }
    }
    copy_dir(out, &latest)
}

fn copy_dir(from: &Path, to: &Path) -> Result<()> {
    std::fs::create_dir_all(to)?;
    for e in std::fs::read_dir(from)? {
        let e = e?;
        let p = e.path();
        if p.is_dir() {
            copy_dir(&p, &to.join(e.file_name()))?;
        } else {
            std::fs::copy(&p, to.join(e.file_name()))?;
        }
    }
    Ok(())
}

#[cfg(test)]
mod reference_tests {
    use super::Args;
    use clap::Parser;

    #[derive(Parser)]
    struct Cli {
        #[command(flatten)]
        eval: Args,
    }

    fn builders(args: &[&str]) -> Vec<String> {
        let cli = Cli::parse_from(std::iter::once("eval").chain(args.iter().copied()));
        cli.eval.settings().builders
    }

    /// `sweep` joins every run first; `sbvh` only runs with a spatial-split builder to compare.
    #[test]
    fn the_spatial_reference_joins_only_runs_with_spatial_builders() {
        assert_eq!(builders(&["--builders", "binned"]), ["sweep", "binned"]);
        assert_eq!(
            builders(&["--builders", "ploc,tsah-topk"]),
            ["sweep", "ploc", "tsah-topk"]
        );
        assert_eq!(
            builders(&["--builders", "tsah-sbvh"]),
            ["sweep", "sbvh", "tsah-sbvh"]
        );
        assert_eq!(
            builders(&["--builders", "binned,sbvh+reinsert"]),
            ["sweep", "sbvh", "binned", "sbvh+reinsert"]
        );
        assert_eq!(builders(&["--builders", "sbvh,sweep"]), ["sweep", "sbvh"]);
        let default = builders(&[]);
        assert_eq!(&default[..2], ["sweep", "sbvh"], "{default:?}");
    }
}

#[cfg(test)]
mod round_budget_tests {
    use super::{rounds_within, MIN_ROUNDS};

    #[test]
    fn rounds_that_fit_the_budget_are_all_traced() {
        assert_eq!(rounds_within(1.0, 20.0, 15), 15);
        assert_eq!(rounds_within(1.0, 0.0, 15), 15, "a budget of 0 is off");
        assert_eq!(rounds_within(100.0, 0.0, 15), 15);
    }

    #[test]
    fn slow_rounds_are_cut_but_never_below_the_minimum() {
        assert_eq!(rounds_within(2.0, 20.0, 15), 10);
        assert_eq!(rounds_within(19.0, 20.0, 15), MIN_ROUNDS);
        assert_eq!(rounds_within(19.0, 20.0, 3), 3, "never more than asked for");
    }
}
