//! `cargo xtask eval`: the paper's evaluation matrix (scenes × builders × ray types ×
//! layouts), written as a dated report folder under `target/eval/`.
//!
//! For each scene every builder builds its tree (timed, with SAH and EPO); the ray sets are
//! generated once per scene (they do not depend on the tree: hits are deterministic) and each
//! tree is traced with each layout (timed after a warm-up, the passes of every layout and tree
//! interleaved, and counted). Results are reported
//! relative to the full-sweep SAH tree (and to SBVH for spatial-split builders), in measured
//! speed and in work per ray; the SAH-EPO predictors are fitted to the measurements.

//!
//! The steps of [`run`], one function each: the settings from the flags and the matrix
//! (`matrix.rs`), then per scene [`Run::build_trees`], [`Run::ray_sets`], [`Run::trace`]
//! (timed rounds, `rounds.rs`; counted passes and rows; images, `images.rs`), then the
//! predictors (`predict.rs`), the scaling section and the report (`report.rs`, `plot.rs`).

#[cfg(test)]
mod browser_test;
mod images;
mod matrix;
mod plot;
mod predict;
mod report;
mod results;
mod rounds;
pub mod saved_study;

use crate::engine::{self, Engine, TraceReport};
use crate::tree::{self, BuildReport};
use crate::util::{self, LoadedScene};
use anyhow::{Context, Result};
use indicatif::{ProgressBar, ProgressStyle};
use matrix::Matrix;
use sahara_bvh::Bvh;
use sahara_trace::{Bvh2Tracer, RayKind, RaySet, Tracer};
use std::path::{Path, PathBuf};
use std::time::Instant;

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

const REFERENCE: &str = "sweep";
const SPATIAL_REFERENCE: &str = "sbvh";

pub use images::HEAT_PERCENTILE;
pub use matrix::headline_layout;
pub use results::{Meta, Results, SceneInfo, Settings, TraceRow};
pub use rounds::MIN_ROUNDS;

/// Runs the evaluation: measures every scene, fits the predictors, measures scaling and
/// writes the report folder.
pub fn run(a: Args) -> Result<()> {
    let t0 = Instant::now();
    let s = a.settings();
    let out = util::out_dir(a.out.as_deref(), "target/eval", &util::utc_stamp());
    std::fs::create_dir_all(out.join("images"))
        .with_context(|| format!("creating {}", out.display()))?;
    std::fs::create_dir_all(out.join("plots"))?;
    let kinds = check(&s)?;
    let run = Run {
        bar: progress_bar(s.scenes.len() * s.builders.len() * (1 + kinds.len() * s.layouts.len())),
        a: &a,
        s: &s,
        kinds,
        out: &out,
    };
    let catalog = sahara_scene::Catalog::discover();
    let mut m = Measured::default();
    for scene_name in &s.scenes {
        run.scene(&catalog, scene_name, &mut m)?;
    }
    run.bar.finish_with_message("traced");

    let (predictors, predicted_points) = predict::evaluate(&m.trees, &m.builds, &m.traces, &s)?;
    let scaling = if a.no_scaling {
        Vec::new()
    } else {
        scaling(&a, &s)?
    };
    let results = Results {
        meta: Meta {
            date: util::utc_stamp(),
            commit: util::git_commit(),
            cpu: util::cpu_name(),
            simd: sahara_traverse::simd_backend().to_string(),
            settings: s,
            seconds: t0.elapsed().as_secs_f64(),
        },
        scenes: m.scenes,
        skipped: m.skipped,
        builds: m.builds,
        traces: m.traces,
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

/// Checks the run's ray types, layouts and builders before anything is measured; the ray
/// kinds.
fn check(s: &Settings) -> Result<Vec<RayKind>> {
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
    Ok(kinds)
}

/// A progress bar of `steps` steps (one per build and per trace row).
fn progress_bar(steps: usize) -> ProgressBar {
    let bar = ProgressBar::new(steps as u64);
    bar.set_style(
        ProgressStyle::with_template(
            "{elapsed_precise} [{bar:30}] {pos}/{len} ETA {eta_precise} {msg}",
        )
        .unwrap_or_else(|_| ProgressStyle::default_bar())
        .progress_chars("=> "),
    );
    bar
}

/// What the scenes of a run have measured so far.
#[derive(Default)]
struct Measured {
    scenes: Vec<SceneInfo>,
    /// Builders left out on scenes where they are impractical.
    skipped: Vec<String>,
    builds: Vec<BuildReport>,
    traces: Vec<TraceRow>,
    /// Every scene's trees and ray samples, for the predictors.
    trees: Vec<predict::SceneTrees>,
}

/// A run's flags, settings, ray kinds, output folder and progress, shared by its steps.
struct Run<'a> {
    a: &'a Args,
    s: &'a Settings,
    kinds: Vec<RayKind>,
    out: &'a Path,
    bar: ProgressBar,
}

impl Run<'_> {
    /// Progress steps of one builder on one scene: its build and its trace rows.
    fn steps_per_builder(&self) -> u64 {
        (1 + self.kinds.len() * self.s.layouts.len()) as u64
    }

    /// Measures one scene (skipped with a message when it does not load): builds its trees,
    /// generates its ray sets, traces every tree with every layout, relates the rows to the
    /// references.
    fn scene(
        &self,
        catalog: &sahara_scene::Catalog,
        scene_name: &str,
        m: &mut Measured,
    ) -> Result<()> {
        status(&self.bar, format!("loading {scene_name}"));
        let scene = match util::load_scene_with(catalog, scene_name, self.a.camera.as_ref()) {
            Ok(sc) => sc,
            Err(e) => {
                eprintln!("skipping scene {scene_name}: {e:#}");
                self.bar
                    .inc(self.s.builders.len() as u64 * self.steps_per_builder());
                return Ok(());
            }
        };
        let trees = self.build_trees(&scene, m)?;
        // Ray sets from the reference tree: identical for every tree (deterministic hits).
        let ref_tracer = Bvh2Tracer::new(&trees[0].1, &scene.triangles);
        let sets = self.ray_sets(&scene, &ref_tracer)?;
        let mut info = SceneInfo::new(&scene);
        let samples = predictor_samples(&sets, &ref_tracer);
        let first_row = m.traces.len();
        self.trace(&scene, &trees, &sets, &mut info, &mut m.traces)?;
        rounds::relate(&mut m.traces[first_row..]);
        m.trees.push(predict::SceneTrees {
            scene,
            trees,
            samples,
        });
        m.scenes.push(info);
        Ok(())
    }

    /// Builds and validates every builder's tree of the scene (the reference first), skipping
    /// the builders impractical at its size that the user did not name.
    fn build_trees(&self, scene: &LoadedScene, m: &mut Measured) -> Result<Vec<(String, Bvh)>> {
        let mut trees = Vec::new();
        for b in &self.s.builders {
            if matrix::impractical(b, scene.triangles.len(), !self.a.builders.is_empty()) {
                m.skipped.push(format!(
                    "{b} on {} ({} triangles; name it with --builders to run it)",
                    scene.name,
                    scene.triangles.len()
                ));
                self.bar.inc(self.steps_per_builder());
                continue;
            }
            status(&self.bar, format!("{} / build {b}", scene.name));
            let (rep, bvh) = build_adaptive(
                &scene.name,
                &scene.triangles,
                b,
                self.s.build_runs,
                self.a.threads,
            )?;
            bvh.validate(&scene.triangles)
                .with_context(|| format!("{b} on {}", scene.name))?;
            m.builds.push(rep);
            trees.push((b.clone(), bvh));
            self.bar.inc(1);
        }
        Ok(trees)
    }

    /// The run's ray sets of the scene, one per ray kind, generated with `reference`.
    fn ray_sets(&self, scene: &LoadedScene, reference: &dyn Tracer) -> Result<Vec<RaySet>> {
        let camera = scene.camera;
        util::with_threads(self.a.threads, || {
            self.kinds
                .iter()
                .map(|&k| {
                    RaySet::generate(
                        k,
                        &camera,
                        self.s.width,
                        self.s.height,
                        reference,
                        &scene.triangles,
                        self.s.seed,
                    )
                })
                .collect()
        })
    }

    /// Traces every tree of the scene with every layout: the timed rounds
    /// ([`Run::time_rounds`]), then one counted pass per tree, layout and ray set, each a
    /// row of `traces`; the primary-ray work of the bvh2 rows goes to the images.
    fn trace(
        &self,
        scene: &LoadedScene,
        trees: &[(String, Bvh)],
        sets: &[RaySet],
        info: &mut SceneInfo,
        traces: &mut Vec<TraceRow>,
    ) -> Result<()> {
        let backend = self.a.backend();
        // Every tracer of the scene: one per layout and tree.
        let tracers: Vec<Vec<Box<dyn Tracer + '_>>> = self
            .s
            .layouts
            .iter()
            .map(|layout| {
                trees
                    .iter()
                    .map(|(_, bvh)| layout.tracer(bvh, &scene.triangles, backend))
                    .collect::<Result<_>>()
            })
            .collect::<Result<_>>()?;
        let timings = self.time_rounds(&scene.name, trees.len(), &tracers, sets, info)?;
        // Per-pixel primary-ray work of each tree, for heat maps on one colour scale.
        let mut heat: Vec<(String, sahara_trace::PixelWork)> = Vec::new();
        // The same work as raw per-pixel sums, for the difference maps against sweep.
        let mut pixel_work: Vec<(String, Vec<Option<u64>>)> = Vec::new();
        for (li, layout) in self.s.layouts.iter().enumerate() {
            for (si, set) in sets.iter().enumerate() {
                status(
                    &self.bar,
                    format!("{} / count {layout} {}", scene.name, set.kind.name()),
                );
                let shared = timed_trees(*layout, trees.len()) == 1 && trees.len() > 1;
                let mut shared_counts: Option<
                    sahara_trace::CountedTrace<sahara_trace::TraceResults>,
                > = None;
                for (ti, ((b, _), tracer)) in trees.iter().zip(&tracers[li]).enumerate() {
                    let rounds = &timings[si][li][if shared { 0 } else { ti }];
                    let timing = sahara_trace::Timing::from_samples(rounds);
                    let counted = match &shared_counts {
                        Some(c) => c.clone(),
                        None => util::with_threads(self.a.threads, || {
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
                        &layout.backend_name(backend),
                        sahara_traverse::Precision::Exact,
                        set,
                        self.a.threads,
                        timing,
                        &counted,
                    );
                    if *layout == Engine::Bvh2 && set.kind == RayKind::Primary {
                        images::write_render(self.out, scene, set, &counted, info)?;
                        heat.push((
                            b.clone(),
                            sahara_trace::PixelWork::new(
                                set.width,
                                set.height,
                                &set.pixel,
                                &counted.work,
                            ),
                        ));
                        pixel_work.push((b.clone(), images::per_pixel_work(set, &counted.work)));
                    }
                    traces.push(TraceRow::new(rep, rounds.clone(), self.s.cost_model));
                    self.bar.inc(1);
                }
            }
        }
        drop(tracers);
        images::write_heat_maps(self.out, &scene.name, &heat, info)?;
        images::write_diff_maps(
            self.out,
            &scene.name,
            self.s.width,
            self.s.height,
            &pixel_work,
            info,
        )?;
        Ok(())
    }

    /// The timed rounds per ray set, layout and tree (`[set][layout][tree]`, one tree for a
    /// foreign engine). The passes of every layout and tree are interleaved (one warm-up
    /// round, then `passes` timed rounds), so that the drift of a shared machine hits every
    /// engine alike and their ratios come from the same rounds. Records the rounds taken in
    /// `info`.
    fn time_rounds(
        &self,
        scene: &str,
        trees: usize,
        tracers: &[Vec<Box<dyn Tracer + '_>>],
        sets: &[RaySet],
        info: &mut SceneInfo,
    ) -> Result<Vec<Vec<Vec<Vec<f64>>>>> {
        let mut timings = Vec::new();
        for set in sets {
            status(&self.bar, format!("{scene} / trace {}", set.kind.name()));
            let engines: Vec<&dyn Tracer> = self
                .s
                .layouts
                .iter()
                .zip(tracers)
                .flat_map(|(layout, ts)| {
                    ts[..timed_trees(*layout, trees)].iter().map(|t| t.as_ref())
                })
                .collect();
            let samples = util::with_threads(self.a.threads, || {
                rounds::interleaved_timings(&engines, set, self.s.passes, self.s.round_budget)
            })?;
            info.rounds.push((
                set.kind.name().to_string(),
                samples.first().map_or(0, Vec::len),
            ));
            let mut flat = samples.into_iter();
            timings.push(
                self.s
                    .layouts
                    .iter()
                    .map(|layout| flat.by_ref().take(timed_trees(*layout, trees)).collect())
                    .collect(),
            );
        }
        Ok(timings)
    }
}

/// How many of a layout's `trees` tracers are timed: foreign engines (Embree, tinybvh, obvhs)
/// ignore the builders' trees (every tracer of such a layout traces the same tree of the
/// engine's own), so each is traced once and its figures fill every builder's row.
fn timed_trees(layout: Engine, trees: usize) -> usize {
    if layout.is_foreign() {
        1
    } else {
        trees
    }
}

/// Per ray set: a sample of its rays cut at the reference's closest hits, for the
/// ray-weighted predictor.
fn predictor_samples(
    sets: &[RaySet],
    reference: &dyn Tracer,
) -> Vec<(String, Vec<sahara_geom::Ray>)> {
    sets.iter()
        .map(|set| {
            let hits = (!set.kind.uses_any_hit())
                .then(|| sahara_trace::trace_closest(reference, &set.rays));
            (
                set.kind.name().to_string(),
                predict::ray_sample(&set.rays, hits.as_deref()),
            )
        })
        .collect()
}

/// The build-time-against-N section: the run's builders on procedural `soup` at the matrix's
/// sizes.
fn scaling(a: &Args, s: &Settings) -> Result<Vec<tree::Series>> {
    let m = Matrix::of(s.quick, s.full);
    let sizes = m.scaling_sizes;
    eprintln!("scaling: build time against N on procedural 'soup' ({sizes:?})");
    tree::measure_scaling(
        &s.builders,
        sahara_scene::Procedural::Soup,
        sizes,
        m.scaling_runs,
        m.scaling_max_seconds,
        a.threads,
        a.builders.is_empty(),
        |b, n, t| eprintln!("  {b:<16} N = {n:>9}: {t:.3} s"),
    )
}

impl SceneInfo {
    /// A scene's entry before its images and rounds are known.
    fn new(scene: &LoadedScene) -> SceneInfo {
        SceneInfo {
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
        }
    }
}

impl TraceRow {
    /// The row of a measurement, its work in the cost model's units, before [`rounds::relate`]
    /// fills the relative columns.
    fn new(
        report: TraceReport,
        round_seconds: Vec<f64>,
        cm: sahara_metrics::CostModel,
    ) -> TraceRow {
        TraceRow {
            work_cost: cm.traversal as f64 * report.inner_per_ray
                + cm.intersection as f64 * report.triangles_per_ray,
            report,
            speed_vs_sweep: None,
            work_vs_sweep: None,
            speed_vs_sbvh: None,
            work_vs_sbvh: None,
            round_seconds,
            speed_vs_sweep_ci: None,
            speed_vs_sbvh_ci: None,
        }
    }
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
    let (mut rep, bvh, _, _) = tree::build_and_measure(scene, tris, builder, threads, 1, false)?;
    if runs > 1 && rep.build_ms.median < SLOW_BUILD_MS {
        let (rep, bvh, _, _) = tree::build_and_measure(scene, tris, builder, threads, runs, true)?;
        return Ok((rep, bvh));
    }
    rep.epo = Some(util::with_threads(threads, || {
        sahara_metrics::epo(&bvh, tris, &sahara_metrics::CostModel::default())
    })?);
    Ok((rep, bvh))
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
