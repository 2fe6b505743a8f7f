//! `cargo xtask eval`: the paper's evaluation matrix (scenes × builders × ray types ×
//! layouts), written as a dated report folder under `target/eval/`.
//!
//! For each scene every builder builds its tree (timed, with SAH and EPO); the ray sets are
//! generated once per scene (they do not depend on the tree: hits are deterministic) and each
//! tree is traced with each layout (timed after a warm-up, the passes of every layout and tree
//! interleaved, and counted). Results are reported
//! relative to the full-sweep SAH tree (and to SBVH for spatial-split builders), in measured
//! speed and in work per ray; the SAH-EPO predictors are fitted to the measurements.

mod plot;
mod predict;
mod report;

use crate::bvh_cmd::{build_and_measure, BuildReport};
use crate::trace_cmd::{self, TraceReport};
use crate::util;
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
    /// Layouts to trace.
    #[arg(long, value_delimiter = ',')]
    pub layouts: Vec<String>,
    /// Output folder (default: target/eval/<date>).
    #[arg(long)]
    pub out: Option<PathBuf>,
    /// Rayon threads for building and tracing (default: all cores).
    #[arg(long)]
    pub threads: Option<usize>,
    /// Image width (default 1024, quick 320).
    #[arg(long)]
    pub width: Option<u32>,
    /// Image height (default 768, quick 240).
    #[arg(long)]
    pub height: Option<u32>,
    /// Timed trace passes (default 5, quick 3).
    #[arg(long)]
    pub passes: Option<usize>,
    /// Timed builds per builder (default 5, quick 3; builds slower than 5 s run once).
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
    pub scenes: Vec<String>,
    pub builders: Vec<String>,
    pub rays: Vec<String>,
    pub layouts: Vec<String>,
    pub width: u32,
    pub height: u32,
    pub passes: usize,
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
    /// The camera of the primary rays (`eye=… target=… up=… fov=…`).
    pub camera: String,
    /// Where it comes from (`generator`, `cameras.tsv`, `command line`, `placed (…)`, …).
    pub camera_source: String,
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
    pub scaling: Vec<crate::scaling::Series>,
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

/// The quick matrix keeps one preset of each strategy.
const QUICK_BUILDERS: &[&str] = &[
    "sweep",
    "sbvh",
    "binned",
    "tsah-topk",
    "tsah-binned",
    "popov-d2",
    "hybrid",
];

fn default_builders(quick: bool) -> Vec<String> {
    sahara_builders::registry::entries()
        .into_iter()
        .filter(|e| !e.small_inputs_only)
        .filter(|e| !quick || QUICK_BUILDERS.contains(&e.name))
        .map(|e| e.name.to_string())
        .collect()
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
    fn settings(&self) -> Settings {
        let q = self.quick;
        let mut builders = if self.builders.is_empty() {
            default_builders(q)
        } else {
            self.builders.clone()
        };
        // The references every comparison needs come first.
        for r in [SPATIAL_REFERENCE, REFERENCE] {
            if !builders.iter().any(|b| b == r) {
                builders.insert(0, r.to_string());
            }
        }
        builders.sort_by_key(|b| (b != REFERENCE, b != SPATIAL_REFERENCE));
        Settings {
            quick: q,
            scenes: if self.scenes.is_empty() {
                default_scenes(q)
            } else {
                self.scenes.clone()
            },
            builders,
            rays: self.rays.clone(),
            layouts: if self.layouts.is_empty() {
                trace_cmd::layouts().iter().map(|s| s.to_string()).collect()
            } else {
                self.layouts.clone()
            },
            width: self.width.unwrap_or(if q { 320 } else { 1024 }),
            height: self.height.unwrap_or(if q { 240 } else { 768 }),
            passes: self.passes.unwrap_or(if q { 3 } else { 5 }),
            build_runs: self.build_runs.unwrap_or(if q { 3 } else { 5 }),
            threads: util::thread_count(self.threads),
            seed: self.seed,
            cost_model: sahara_metrics::CostModel::default(),
        }
    }
}

fn out_dir(a: &Args) -> PathBuf {
    if let Some(o) = &a.out {
        return o.clone();
    }
    let root = sahara_scene::workspace_root().unwrap_or_else(|| PathBuf::from("."));
    let stamp = chrono_like_stamp();
    root.join("target").join("eval").join(stamp)
}

/// `YYYY-MM-DDTHH-MM-SS` in UTC, from the system clock (no date crate needed).
fn chrono_like_stamp() -> String {
    let secs = std::time::SystemTime::now()
        .duration_since(std::time::UNIX_EPOCH)
        .map(|d| d.as_secs())
        .unwrap_or(0);
    let days = secs / 86_400;
    let rem = secs % 86_400;
    let (y, m, d) = civil_from_days(days as i64);
    format!(
        "{y:04}-{m:02}-{d:02}T{:02}-{:02}-{:02}",
        rem / 3600,
        (rem / 60) % 60,
        rem % 60
    )
}

/// Days since 1970-01-01 to a civil date (Howard Hinnant's algorithm).
fn civil_from_days(z: i64) -> (i64, u32, u32) {
    let z = z + 719_468;
    let era = z.div_euclid(146_097);
    let doe = z.rem_euclid(146_097);
    let yoe = (doe - doe / 1460 + doe / 36_524 - doe / 146_096) / 365;
    let y = yoe + era * 400;
    let doy = doe - (365 * yoe + yoe / 4 - yoe / 100);
    let mp = (5 * doy + 2) / 153;
    let d = (doy - (153 * mp + 2) / 5 + 1) as u32;
    let m = if mp < 10 { mp + 3 } else { mp - 9 } as u32;
    (if m <= 2 { y + 1 } else { y }, m, d)
}

pub fn run(a: Args) -> Result<()> {
    let t0 = std::time::Instant::now();
    let s = a.settings();
    let out = out_dir(&a);
    std::fs::create_dir_all(out.join("images"))
        .with_context(|| format!("creating {}", out.display()))?;
    std::fs::create_dir_all(out.join("plots"))?;
    let kinds: Vec<RayKind> = s
        .rays
        .iter()
        .map(|r| r.parse::<RayKind>().map_err(|e| anyhow::anyhow!("{e}")))
        .collect::<Result<_>>()?;
    for l in &s.layouts {
        anyhow::ensure!(
            trace_cmd::layouts().contains(&l.as_str()),
            "unknown layout '{l}'"
        );
    }
    for b in &s.builders {
        util::builder(b)?;
    }

    let steps = (s.scenes.len() * s.builders.len() * (1 + kinds.len() * s.layouts.len())) as u64;
    let bar = ProgressBar::new(steps);
    bar.set_style(
        ProgressStyle::with_template("{elapsed_precise} [{bar:30}] {pos}/{len} {msg}")
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
            let runs = adaptive_runs(&scene.triangles, b, s.build_runs, a.threads)?;
            let (rep, bvh) =
                build_and_measure(&scene.name, &scene.triangles, b, a.threads, runs, true)?;
            bvh.validate(&scene.triangles)
                .with_context(|| format!("{b} on {}", scene.name))?;
            builds.push(rep);
            trees.push((b.clone(), bvh));
            bar.inc(1);
        }
        // Ray sets from the reference tree: identical for every tree (deterministic hits).
        let reference = &trees[0].1;
        let ref_tracer = sahara_trace::Bvh2Tracer::new(reference, &scene.triangles);
        let camera = trace_cmd::trace_camera(&scene.camera);
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
            camera: scene.camera.to_string(),
            camera_source: scene.camera_source.clone(),
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
        // Every tracer of the scene: one per layout and tree.
        let tracers: Vec<Vec<Box<dyn sahara_trace::Tracer + '_>>> = s
            .layouts
            .iter()
            .map(|layout| {
                trees
                    .iter()
                    .map(|(_, bvh)| trace_cmd::make_tracer(layout, bvh, &scene.triangles))
                    .collect::<Result<_>>()
            })
            .collect::<Result<_>>()?;
        // Embree ignores the builders' trees (every tracer of that layout traces the same
        // Embree scene): it is traced once, and its figures fill every builder's row.
        let timed_trees = |layout: &str| if layout == "embree" { 1 } else { trees.len() };
        // Timings per ray set, layout and tree. The passes of every layout and tree are
        // interleaved (one warm-up round, then `passes` timed rounds), so that the drift of a
        // shared machine hits every engine alike and their ratios come from the same rounds.
        let mut timings: Vec<Vec<Vec<sahara_trace::Timing>>> = Vec::new();
        for set in &sets {
            status(&bar, format!("{} / trace {}", scene.name, set.kind.name()));
            let engines: Vec<&dyn sahara_trace::Tracer> = s
                .layouts
                .iter()
                .zip(&tracers)
                .flat_map(|(layout, ts)| ts[..timed_trees(layout)].iter().map(|t| t.as_ref()))
                .collect();
            let mut flat =
                util::with_threads(a.threads, || interleaved_timings(&engines, set, s.passes))?
                    .into_iter();
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
                    let timing = timings[si][li][if shared { 0 } else { ti }];
                    let counted = match &shared_counts {
                        Some(c) => c.clone(),
                        None => util::with_threads(a.threads, || {
                            sahara_trace::trace_set_counted(tracer.as_ref(), set)
                        })?,
                    };
                    if shared && shared_counts.is_none() {
                        shared_counts = Some(counted.clone());
                    }
                    let rep = trace_cmd::report(
                        &scene.name,
                        scene.triangles.len(),
                        b,
                        layout,
                        set,
                        a.threads,
                        timing,
                        &counted,
                    );
                    if layout == "bvh2" && set.kind == RayKind::Primary {
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
                    });
                    bar.inc(1);
                }
            }
        }
        drop(tracers);
        write_heat_maps(&out, &scene.name, &heat, &mut info)?;
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
        let sizes: Vec<usize> = if s.quick {
            vec![1_000, 4_000, 16_000]
        } else {
            vec![1_000, 10_000, 100_000, 1_000_000]
        };
        eprintln!("scaling: build time against N on procedural 'soup' ({sizes:?})");
        crate::scaling::measure(
            &s.builders,
            sahara_scene::Procedural::Soup,
            &sizes,
            if s.quick { 1 } else { 3 },
            if s.quick { 5.0 } else { 300.0 },
            a.threads,
            a.builders.is_empty(),
            |b, n, t| eprintln!("  {b:<16} N = {n:>9}: {t:.3} s"),
        )?
    };

    let results = Results {
        meta: Meta {
            date: chrono_like_stamp(),
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
            "[{:>4}/{}] {msg}",
            bar.position(),
            bar.length().unwrap_or(0)
        );
    }
    bar.set_message(msg);
}

/// Times every tracer on `set`: one untimed warm-up round, then `passes` rounds, each round
/// tracing the whole set once with every tracer in turn.
fn interleaved_timings(
    tracers: &[&dyn sahara_trace::Tracer],
    set: &RaySet,
    passes: usize,
) -> Vec<sahara_trace::Timing> {
    let mut samples = vec![Vec::with_capacity(passes); tracers.len()];
    for round in 0..=passes.max(1) {
        for (i, t) in tracers.iter().enumerate() {
            let t0 = std::time::Instant::now();
            std::hint::black_box(sahara_trace::trace_set(*t, set));
            if round > 0 {
                samples[i].push(t0.elapsed().as_secs_f64());
            }
        }
    }
    samples
        .iter()
        .map(|s| sahara_trace::Timing::from_samples(s))
        .collect()
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

/// Builds slower than 5 s are timed once (the report says how many runs each has).
fn adaptive_runs(
    tris: &[sahara_geom::Triangle],
    builder: &str,
    runs: usize,
    threads: Option<usize>,
) -> Result<usize> {
    if tris.len() < 50_000 {
        return Ok(runs);
    }
    let b = util::builder(builder)?;
    let input = sahara_builders::BuildInput::new(tris, sahara_builders::CostModel::default())?;
    let (t, r) = util::with_threads(threads, || util::time_runs(1, || b.build(&input)))?;
    r?;
    Ok(if t[0] > 5.0 { 1 } else { runs })
}

/// Fills the relative columns of one scene's rows.
fn relate(rows: &mut [TraceRow]) {
    let find = |rows: &[TraceRow], b: &str, r: &TraceRow| {
        rows.iter()
            .find(|x| {
                x.report.builder == b
                    && x.report.layout == r.report.layout
                    && x.report.ray_kind == r.report.ray_kind
            })
            .map(|x| (x.report.mrays_s.median, x.work_cost))
    };
    let snapshot: Vec<TraceRow> = rows.to_vec();
    for r in rows.iter_mut() {
        if let Some((speed, work)) = find(&snapshot, REFERENCE, r) {
            r.speed_vs_sweep = Some(r.report.mrays_s.median / speed);
            r.work_vs_sweep = Some(work / r.work_cost);
        }
        if let Some((speed, work)) = find(&snapshot, SPATIAL_REFERENCE, r) {
            r.speed_vs_sbvh = Some(r.report.mrays_s.median / speed);
            r.work_vs_sbvh = Some(work / r.work_cost);
        }
    }
}

fn simd_backend() -> String {
    sahara_traverse::simd_backend().to_string()
}

pub fn file_stem(name: &str) -> String {
    name.chars()
        .map(|c| {
            if c.is_ascii_alphanumeric() || c == '-' || c == '_' {
                c
            } else {
                '_'
            }
        })
        .collect()
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
