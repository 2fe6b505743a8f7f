//! Writes `results.json`, `results.csv`, `report.md` and a self-contained `report.html`
//! (tables, inline SVG plots, PNG images embedded as data URLs) from one [`Results`].
//!
//! The report is a list of [`Block`]s, rendered once as Markdown and once as HTML. Each section
//! is one function appending its blocks to a [`Doc`]; [`report`] calls them in order.

use super::plot::{esc, fmt_num, Plot, Point};
use super::{Results, TraceRow, REFERENCE, SPATIAL_REFERENCE};
use crate::interval::{self, Interval};
use anyhow::Result;
use base64::Engine;
use std::collections::BTreeMap;
use std::fmt::Write as _;
use std::path::Path;

/// Writes every output file of the run into `dir` (which has a `plots/` folder, and the
/// `images/` the scenes name).
pub fn write_all(dir: &Path, r: &Results) -> Result<()> {
    std::fs::write(dir.join("results.json"), serde_json::to_string_pretty(r)?)?;
    std::fs::write(dir.join("results.csv"), csv(r))?;
    let d = report(&Ctx::new(r));
    for b in &d.blocks {
        if let Block::Svg { path, svg, .. } = b {
            std::fs::write(dir.join(path), svg)?;
        }
    }
    std::fs::write(dir.join("report.md"), d.markdown())?;
    std::fs::write(dir.join("report.html"), d.html(dir))?;
    Ok(())
}

/// The report: its sections in order, the answer first (summary, the speed-against-error
/// plot, the images per scene), the tables after.
fn report(c: &Ctx) -> Doc {
    let mut d = Doc::default();
    title(&mut d, c);
    summary(&mut d, c);
    claims(&mut d, c);
    speed_against_error(&mut d, c);
    heat_maps(&mut d, c);
    d.h(2, "Tables");
    sweep_tables(&mut d, c);
    sbvh_table(&mut d, c);
    scene_tables(&mut d, c);
    predictors(&mut d, c);
    scaling(&mut d, c);
    run_notes(&mut d, c);
    d
}

// ---------------------------------------------------------------------------------------
// Sections.

/// The title and one line on the run: when, where, how long, which matrix.
fn title(d: &mut Doc, c: &Ctx) {
    let (r, s) = (c.r, &c.r.meta.settings);
    d.h(1, "sahara evaluation");
    d.p(format!(
        "Run {} at commit `{}` on **{}** ({} threads, backend: {}, the best of this CPU: {}), {:.0} s in all: {} scenes, {} builders, {}×{} pixels, {} interleaved rounds{}.{}",
        r.meta.date,
        r.meta.commit,
        r.meta.cpu,
        s.threads,
        s.backend,
        r.meta.simd,
        r.meta.seconds,
        r.scenes.len(),
        s.builders.len(),
        s.width,
        s.height,
        s.passes,
        if s.round_budget > 0.0 {
            format!(
                " (fewer, at least {}, where they would take over {:.0} s per scene and ray type)",
                super::MIN_ROUNDS.min(s.passes),
                s.round_budget
            )
        } else {
            String::new()
        },
        if s.quick {
            " This is the **--quick** matrix."
        } else if s.full {
            " This is the **--full** matrix."
        } else {
            ""
        }
    ));
}

/// The answer: per ray type, the builder with the least work per ray (geometric mean over
/// scenes, headline layout), its work and speed against sweep and SBVH with 95% intervals,
/// and its build time relative to sweep; then the predictors' errors in one line.
fn summary(d: &mut Doc, c: &Ctx) {
    d.h(2, "Summary");
    d.p(format!(
        "Per ray type, the builder whose trees take the least work per ray ({} layout, geometric mean over scenes). \
         Work > 1: less work than the reference (noise-free). Speed > 1: faster, with its 95% interval; \
         {MARK} marks a speed whose interval contains 1 (not told apart from the reference). \
         Build: build time relative to sweep.",
        c.layout0
    ));
    let mut rows = Vec::new();
    for kind in &c.kinds {
        let best = c
            .builders
            .iter()
            .filter_map(|&b| {
                let w = c.mean_ratio(b, kind, |t| t.work_vs_sweep)?;
                Some((b, w))
            })
            .max_by(|a, b| a.1.total_cmp(&b.1));
        let Some((b, _)) = best else { continue };
        rows.push(vec![
            kind.to_string(),
            format!("**{b}**"),
            ratio(c.mean_ratio(b, kind, |t| t.work_vs_sweep)),
            or_none(c.mean_speed(b, kind, REFERENCE), speed_cell),
            ratio(c.mean_ratio(b, kind, |t| t.work_vs_sbvh)),
            or_none(c.mean_speed(b, kind, SPATIAL_REFERENCE), speed_cell),
            or_none(build_factor(c, b), |f| format!("{f:.1}×")),
        ]);
    }
    d.table(
        [
            "rays",
            "best builder",
            "work vs sweep",
            "speed vs sweep [95%]",
            "work vs sbvh",
            "speed vs sbvh [95%]",
            "build vs sweep",
        ],
        rows,
    );
    let line: Vec<String> = distinct(
        c.r.predictors
            .iter()
            .filter(|p| p.target.starts_with("time"))
            .map(|p| p.predictor.as_str()),
    )
    .into_iter()
    .map(|name| {
        let errs: Vec<String> =
            c.r.predictors
                .iter()
                .filter(|p| p.predictor == name && p.target.starts_with("time"))
                .map(|p| {
                    format!(
                        "{} {}",
                        p.ray_kind,
                        or_none(
                            p.report.as_ref().map(|x| x.mean_relative_error),
                            |e| format!("{:.1}%", 100.0 * e)
                        )
                    )
                })
                .collect();
        format!("{name}: {}", errs.join(", "))
    })
    .collect();
    if !line.is_empty() {
        d.p(format!(
            "Predictors' mean error against measured trace time: {}.",
            line.join("; ")
        ));
    }
}

/// What a speed ratio's cell shows when its interval contains 1.
const MARK: &str = "≈";

/// A speed ratio with its interval, marked with [`MARK`] when the interval contains 1:
/// `≈1.012 [0.981–1.043]`.
fn speed_cell(i: Interval) -> String {
    format!(
        "{}{:.3} [{:.3}–{:.3}]",
        if i.contains_one() { MARK } else { "" },
        i.estimate,
        i.low,
        i.high
    )
}

/// `builder`'s build time relative to sweep: geometric mean over scenes.
fn build_factor(c: &Ctx, builder: &str) -> Option<f64> {
    let v: Vec<f64> =
        c.r.scenes
            .iter()
            .filter_map(|sc| {
                let t = |b: &str| {
                    c.r.builds
                        .iter()
                        .find(|x| x.scene == sc.name && x.builder == b)
                        .map(|x| x.build_ms.median)
                };
                Some(t(builder)? / t(REFERENCE)?)
            })
            .collect();
    geomean(&v)
}

/// The paper's claims against our best figures, from the study's saved run (`docs/study.md`
/// and the newest study folder under `docs/results/`): read, not recomputed.
fn claims(d: &mut Doc, c: &Ctx) {
    let Some(st) = &c.r.study else {
        return;
    };
    d.h(2, "The paper's claims (from the study's saved run)");
    d.p(format!(
        "Our reading of the paper's claims against our best measured figures, as written in \
         `docs/study.md`{}. These are not recomputed by this run: `cargo xtask study` measures \
         them (hours for the full study).",
        st.run
            .as_ref()
            .map(|r| format!(" from the study run saved in `{r}`"))
            .unwrap_or_default()
    ));
    d.text_table(st.head.clone(), st.rows.clone());
    if let Some((head, rows)) = &st.main {
        d.h(3, "The study's main table");
        d.p(
            "Per factor of the saved run, the level with the largest bvh2 primary-ray work gain \
             against its reference (geometric mean over the scenes, reference ÷ builder: > 1 is \
             better) and the range of that gain over the factor's levels, as the run's README \
             renders it.",
        );
        d.text_table(head.clone(), rows.clone());
    }
}

/// The protocol: cost model, image size, rounds and runs, seed; what the ratios and their
/// intervals mean; the builders left out as impractical.
fn run_notes(d: &mut Doc, c: &Ctx) {
    let (r, s) = (c.r, &c.r.meta.settings);
    d.h(2, "How these numbers were taken");
    d.p(format!(
        "Cost model c_t = {}, c_i = {}. Images {}×{}; every tree and layout of a scene traces each ray set once per round, \
         in turn, for {} timed rounds after one warm-up round{}; Mrays/s are the median with min–max. \
         Each build is the median of up to {} runs (builds over 1 s run once). Secondary-ray seed {}.",
        s.cost_model.traversal,
        s.cost_model.intersection,
        s.width,
        s.height,
        s.passes,
        if s.round_budget > 0.0 {
            format!(
                " (fewer, but at least {}, when the warm-up round shows that {} rounds would take over {:.0} s: \
                 the scene's section then says how many)",
                super::MIN_ROUNDS.min(s.passes),
                s.passes,
                s.round_budget
            )
        } else {
            String::new()
        },
        s.build_runs,
        s.seed,
    ));
    d.p(format!(
        "A speed ratio is the median over rounds of the per-round ratio of trace times (reference / this tree, taken in the same round), \
         > 1 meaning faster than the reference; its 95% interval is a percentile bootstrap of that median ({} resamples, fixed seed), \
         and averages over scenes are geometric means of the scenes' medians with a bootstrap that resamples each scene's rounds. \
         {MARK} marks ratios whose interval contains 1. Work ratios compare the work per ray in SAH units \
         (c_t · inner nodes visited + c_i · triangles tested), which machine noise cannot touch: > 1 means less work than the reference.",
        interval::RESAMPLES
    ));
    if !r.skipped.is_empty() {
        d.p(format!(
            "Left out as impractical at this size (minutes per build on two cores): {}.",
            r.skipped.join("; ")
        ));
    }
}

/// The headline: per ray type, speed (work) of every builder relative to the sweep tree on
/// each scene, first layout, with the geometric mean over scenes.
fn sweep_tables(d: &mut Doc, c: &Ctx) {
    d.h(
        2,
        format!(
            "Trace performance relative to full-sweep SAH ({})",
            c.layout0
        ),
    );
    for kind in &c.kinds {
        d.h(3, format!("{kind} rays: speed (work) relative to sweep"));
        let mut rows = Vec::new();
        for sc in &c.r.scenes {
            let mut row = vec![sc.name.clone()];
            for &b in &c.builders {
                row.push(match c.trace(&sc.name, b, kind) {
                    Some(t) => speed_work(t.speed_vs_sweep, t.speed_vs_sweep_ci, t.work_vs_sweep),
                    None => NONE.into(),
                });
            }
            rows.push(row);
        }
        let mut mean = vec!["**geometric mean**".to_string()];
        for b in &c.builders {
            let speed = c.mean_speed(b, kind, REFERENCE);
            mean.push(speed_work(
                speed.map(|i| i.estimate),
                speed,
                c.mean_ratio(b, kind, |t| t.work_vs_sweep),
            ));
        }
        rows.push(mean);
        d.table(column_heads("scene", &c.builders), rows);
    }
}

/// The spatial-split builders' speed (work) relative to SBVH, per scene and ray type, first
/// layout (only with more than one spatial-split builder).
fn sbvh_table(d: &mut Doc, c: &Ctx) {
    let spatial: Vec<&str> = c
        .builders
        .iter()
        .copied()
        .filter(|b| {
            sahara_builders::registry::entries()
                .iter()
                .any(|e| e.name == *b && e.spatial)
        })
        .collect();
    if spatial.len() <= 1 {
        return;
    }
    d.h(
        2,
        format!("Spatial-split builders relative to SBVH ({})", c.layout0),
    );
    let mut rows = Vec::new();
    for sc in &c.r.scenes {
        for kind in &c.kinds {
            let mut row = vec![format!("{} / {kind}", sc.name)];
            for b in &spatial {
                row.push(c.trace(&sc.name, b, kind).map_or(NONE.into(), |t| {
                    speed_work(t.speed_vs_sbvh, t.speed_vs_sbvh_ci, t.work_vs_sbvh)
                }));
            }
            rows.push(row);
        }
    }
    d.table(column_heads("scene / rays", &spatial), rows);
}

/// Per scene: every tree's build time, SAH, EPO and shape, then every trace (builder, layout,
/// ray type) with its speed, work per ray and comparisons.
fn scene_tables(d: &mut Doc, c: &Ctx) {
    d.h(2, "Trees: build time, SAH and EPO");
    for sc in &c.r.scenes {
        d.h(3, format!("{} ({} triangles)", sc.name, sc.triangles));
        let builds = c.r.builds.iter().filter(|b| b.scene == sc.name);
        d.table(
            [
                "builder",
                "build ms median [min–max]",
                "SAH",
                "EPO",
                "nodes",
                "references",
                "max leaf",
                "depth",
            ],
            builds
                .map(|b| {
                    vec![
                        b.builder.clone(),
                        spread(b.build_ms.median, b.build_ms.min, b.build_ms.max, fmt_num),
                        format!("{:.3}", b.sah),
                        or_none(b.epo, |e| format!("{e:.3}")),
                        b.nodes.to_string(),
                        b.references.to_string(),
                        b.max_leaf.to_string(),
                        b.depth.to_string(),
                    ]
                })
                .collect(),
        );
        let traces = c.r.traces.iter().filter(|t| t.report.scene == sc.name);
        d.table(
            [
                "builder / layout / rays",
                "Mrays/s median [min–max]",
                "speed vs sweep [95%]",
                "inner/ray",
                "leaves/ray",
                "tris/ray",
                "work vs sweep",
                "LCV",
                "hits",
            ],
            traces
                .map(|t| {
                    let x = &t.report;
                    let f2 = |v: f64| format!("{v:.2}");
                    vec![
                        format!("{} / {} / {}", x.builder, x.layout, x.ray_kind),
                        spread(x.mrays_s.median, x.mrays_s.min, x.mrays_s.max, f2),
                        speed_or_interval(t.speed_vs_sweep, t.speed_vs_sweep_ci),
                        f2(x.inner_per_ray),
                        f2(x.leaves_per_ray),
                        f2(x.triangles_per_ray),
                        ratio(t.work_vs_sweep),
                        f2(x.lcv),
                        x.hits.to_string(),
                    ]
                })
                .collect(),
        );
    }
}

/// The speed-against-error plot: each builder's build time against its trace time, both
/// relative to sweep, with the Pareto front.
fn speed_against_error(d: &mut Doc, c: &Ctx) {
    d.h(2, "Build time against trace cost (speed against error)");
    d.p("Each point is a builder: x = build time relative to sweep (geometric mean over scenes), \
         y = trace time relative to sweep (geometric mean over scenes and ray types, headline layout). \
         The dashed line joins the Pareto front: no other builder is both faster to build and faster to trace.");
    let plot = Plot {
        title: "Build time against trace time (relative to sweep)".into(),
        x_label: "build time / sweep".into(),
        y_label: "trace time / sweep".into(),
        log_x: true,
        pareto: true,
        labels: true,
        points: c.builders.iter().filter_map(|b| cost_point(c, b)).collect(),
        ..Default::default()
    };
    d.svg("plots/speed-vs-error.svg", "speed against error", plot);
}

/// The trace-cost predictors: their fitted α and forecasting errors per ray type, and one
/// predicted-against-measured plot per ray type (when the run evaluated predictors).
fn predictors(d: &mut Doc, c: &Ctx) {
    if c.r.predictors.is_empty() {
        return;
    }
    d.h(2, "Trace-cost predictors");
    d.p("Per ray type, each predictor forecasts the trace cost of every tree normalised to the sweep tree of its scene. \
         α is fitted by least squares on relative errors over all builders and scenes of this run (clamped to [0, 1]). \
         Errors are over the non-reference trees; ρ is Spearman's rank correlation (pooled, and the mean of the per-scene values).");
    let f3 = |v: f64| format!("{v:.3}");
    let percent = |v: f64| format!("{:.1}%", 100.0 * v);
    d.table(
        [
            "rays",
            "predictor",
            "measured",
            "α",
            "mean error",
            "max error",
            "ρ pooled",
            "ρ per scene",
            "note",
        ],
        c.r.predictors
            .iter()
            .map(|p| {
                let score = p.report.as_ref();
                vec![
                    p.ray_kind.clone(),
                    p.predictor.clone(),
                    p.target.clone(),
                    or_none(p.alpha, f3),
                    or_none(score.map(|x| x.mean_relative_error), percent),
                    or_none(score.map(|x| x.max_relative_error), percent),
                    or_none(score.and_then(|x| x.spearman), f3),
                    or_none(score.and_then(|x| x.mean_scene_spearman), f3),
                    p.note.clone(),
                ]
            })
            .collect(),
    );
    let mut by_kind: BTreeMap<&str, Vec<Point>> = BTreeMap::new();
    for p in &c.r.predicted_points {
        by_kind.entry(p.ray_kind.as_str()).or_default().push(Point {
            x: p.predicted,
            y: p.measured,
            label: format!("{} {}", p.scene, p.builder),
            series: p.predictor.clone(),
        });
    }
    for (kind, points) in by_kind {
        let plot = Plot {
            title: format!("{kind} rays: predicted against measured time (relative to sweep)"),
            x_label: "predicted".into(),
            y_label: "measured".into(),
            diagonal: true,
            points,
            ..Default::default()
        };
        d.svg(
            format!("plots/predicted-{kind}.svg"),
            format!("predicted against measured, {kind}"),
            plot,
        );
    }
}

/// Build time against N on growing procedural soups: a table with the fitted exponents and a
/// log–log plot (when the run measured it).
fn scaling(d: &mut Doc, c: &Ctx) {
    let series = &c.r.scaling;
    if series.is_empty() {
        return;
    }
    d.h(2, "Build time against N (complexity)");
    d.p("Procedural triangle soups of growing size; the exponent b of time ≈ a·N^b is fitted by least squares on log–log \
         (over all sizes, and over N ≥ 10^4). N log N shows as b slightly above 1, N log² N a little higher, N² as 2.");
    let sizes = distinct(series.iter().flat_map(|s| s.points.iter().map(|p| p.0)));
    let mut head = vec!["builder".to_string()];
    head.extend(sizes.iter().map(|n| format!("N={n} (ms)")));
    head.extend(["b (all)".into(), "b (N≥1e4)".into()]);
    let f2 = |e: f64| format!("{e:.2}");
    let mut rows = Vec::new();
    let mut points = Vec::new();
    for sr in series {
        let ms = |n: &usize| {
            sr.points
                .iter()
                .find(|p| p.0 == *n)
                .map(|p| p.1.median * 1e3)
        };
        let mut row = vec![sr.builder.clone()];
        row.extend(sizes.iter().map(|n| or_none(ms(n), fmt_num)));
        row.push(or_none(sr.exponent, f2));
        row.push(or_none(sr.exponent_large, f2));
        rows.push(row);
        points.extend(sr.points.iter().map(|p| Point {
            x: p.0 as f64,
            y: p.1.median * 1e3,
            label: sr.builder.clone(),
            series: sr.builder.clone(),
        }));
    }
    d.table(head, rows);
    let plot = Plot {
        title: "Build time against N".into(),
        x_label: "triangles".into(),
        y_label: "build ms".into(),
        log_x: true,
        log_y: true,
        lines: true,
        points,
        ..Default::default()
    };
    d.svg("plots/scaling.svg", "build time against N", plot);
}

/// Per scene, a grid: its render and every tree's heat map of primary-ray work side by side
/// (the scene's shared colour scale), then each tree's difference map against sweep.
fn heat_maps(d: &mut Doc, c: &Ctx) {
    d.h(
        2,
        "Scenes: render, work heat maps and difference against sweep (primary rays)",
    );
    d.p(format!(
        "Heat maps show inner nodes + leaves + triangles visited per pixel (bvh2 layout: the binary tree). All heat maps of a scene share one colour scale (viridis, dark = little work), topping out at the largest of the trees' {:.0}th percentiles of per-pixel work, so the same colour means the same work in every image of the scene. \
         Difference maps show a tree's per-pixel work minus the sweep tree's on a diverging scale: **blue where the tree saves work**, red where it costs more, white where they agree; the scale's ends are the largest of the trees' {:.0}th percentiles of the absolute difference.",
        super::HEAT_PERCENTILE,
        super::HEAT_PERCENTILE
    ));
    for sc in &c.r.scenes {
        d.h(3, sc.name.clone());
        d.p(format!("Camera ({}): `{}`.", sc.camera_source, sc.camera));
        let cut: Vec<String> = sc
            .rounds
            .iter()
            .filter(|(_, n)| *n < c.r.meta.settings.passes)
            .map(|(kind, n)| format!("{kind} {n}"))
            .collect();
        if !cut.is_empty() {
            d.p(format!(
                "Timed rounds cut by the round budget (slow rounds): {}.",
                cut.join(", ")
            ));
        }
        d.p(format!(
            "Top of the heat maps' colour scale: {:.0} work units per pixel; difference maps: ±{:.0}.",
            sc.heat_scale, sc.diff_scale
        ));
        let render = sc
            .render
            .iter()
            .map(|p| (p.clone(), format!("{} render", sc.name)));
        let heat = sc
            .heat_maps
            .iter()
            .map(|(b, p)| (p.clone(), format!("{b} heat map")));
        d.gallery(render.chain(heat).collect());
        if !sc.diff_maps.is_empty() {
            d.gallery(
                sc.diff_maps
                    .iter()
                    .map(|(b, p)| (p.clone(), format!("{b} − sweep")))
                    .collect(),
            );
        }
    }
}

// ---------------------------------------------------------------------------------------
// What the sections share.

/// What every section reads: the results, and what is chosen from them once.
struct Ctx<'a> {
    r: &'a Results,
    /// The layout of the summary tables and plots: `bvh8` when traced, else the first.
    layout0: String,
    /// The builders, in the order of the settings.
    builders: Vec<&'a str>,
    /// The ray types, in the order they were traced.
    kinds: Vec<&'a str>,
}

impl<'a> Ctx<'a> {
    fn new(r: &'a Results) -> Self {
        let s = &r.meta.settings;
        Ctx {
            r,
            layout0: super::headline_layout(&s.layouts).to_string(),
            builders: s.builders.iter().map(String::as_str).collect(),
            kinds: distinct(r.traces.iter().map(|t| t.report.ray_kind.as_str())),
        }
    }

    /// The trace of `builder`'s tree on `scene` with `kind` rays, in the headline layout.
    fn trace(&self, scene: &str, builder: &str, kind: &str) -> Option<&'a TraceRow> {
        self.r.traces.iter().find(|t| {
            t.report.scene == scene
                && t.report.builder == builder
                && t.report.layout == self.layout0
                && t.report.ray_kind == kind
        })
    }

    /// The geometric mean over scenes of `f` of `builder`'s `kind` traces (headline layout).
    fn mean_ratio(
        &self,
        builder: &str,
        kind: &str,
        f: impl Fn(&TraceRow) -> Option<f64>,
    ) -> Option<f64> {
        let v: Vec<f64> = self
            .r
            .scenes
            .iter()
            .filter_map(|sc| f(self.trace(&sc.name, builder, kind)?))
            .collect();
        geomean(&v)
    }

    /// `builder`'s speed relative to `reference` on `kind` rays over all scenes (headline
    /// layout): geometric mean of the scenes' median per-round ratios, with its stratified
    /// bootstrap interval.
    fn mean_speed(&self, builder: &str, kind: &str, reference: &str) -> Option<Interval> {
        let groups: Vec<Vec<f64>> = self
            .r
            .scenes
            .iter()
            .filter_map(|sc| {
                let this = self.trace(&sc.name, builder, kind)?;
                let rf = self.trace(&sc.name, reference, kind)?;
                Some(interval::round_ratios(
                    &rf.round_seconds,
                    &this.round_seconds,
                ))
            })
            .collect();
        interval::geomean_of_medians_interval(&groups)
    }
}

/// `builder`'s point on the speed-against-error plot: its build time relative to sweep
/// (geometric mean over scenes) against its trace time relative to sweep (over scenes and ray
/// types, first layout); `None` when either is unknown.
fn cost_point(c: &Ctx, builder: &str) -> Option<Point> {
    let mut build = Vec::new();
    let mut trace = Vec::new();
    for sc in &c.r.scenes {
        let time = |b: &str| {
            c.r.builds
                .iter()
                .find(|x| x.scene == sc.name && x.builder == b)
                .map(|x| x.build_ms.median)
        };
        if let (Some(t), Some(rf)) = (time(builder), time(REFERENCE)) {
            if rf > 0.0 {
                build.push(t / rf);
            }
        }
        trace.extend(
            c.r.traces
                .iter()
                .filter(|t| {
                    t.report.scene == sc.name
                        && t.report.builder == builder
                        && t.report.layout == c.layout0
                })
                .filter_map(|t| t.speed_vs_sweep.map(|sp| 1.0 / sp)),
        );
    }
    Some(Point {
        x: geomean(&build)?,
        y: geomean(&trace)?,
        label: builder.to_string(),
        series: builder.to_string(),
    })
}

/// The items of `it` without repeats, in order of first appearance.
fn distinct<T: PartialEq>(it: impl IntoIterator<Item = T>) -> Vec<T> {
    let mut v = Vec::new();
    for x in it {
        if !v.contains(&x) {
            v.push(x);
        }
    }
    v
}

/// Geometric mean (ignores non-positive values).
fn geomean(v: &[f64]) -> Option<f64> {
    let v: Vec<f64> = v
        .iter()
        .copied()
        .filter(|x| *x > 0.0 && x.is_finite())
        .collect();
    if v.is_empty() {
        return None;
    }
    Some((v.iter().map(|x| x.ln()).sum::<f64>() / v.len() as f64).exp())
}

/// What a table cell shows for a missing value.
const NONE: &str = "–";

/// `x` formatted by `f`, or [`NONE`].
fn or_none<T>(x: Option<T>, f: impl FnOnce(T) -> String) -> String {
    x.map_or_else(|| NONE.into(), f)
}

/// A ratio to three decimals.
fn ratio(x: Option<f64>) -> String {
    or_none(x, |v| format!("{v:.3}"))
}

/// A speed ratio (with its interval when known) and its work ratio in parentheses:
/// `1.020 [1.010–1.031] (0.980)`.
fn speed_work(speed: Option<f64>, ci: Option<Interval>, work: Option<f64>) -> String {
    format!("{} ({})", speed_or_interval(speed, ci), ratio(work))
}

/// The speed ratio's cell: with its interval when known ([`speed_cell`]), else the ratio.
fn speed_or_interval(speed: Option<f64>, ci: Option<Interval>) -> String {
    ci.map_or_else(|| ratio(speed), speed_cell)
}

/// A median with its range: `12.00 [9.60–13.20]`.
fn spread(median: f64, min: f64, max: f64, f: impl Fn(f64) -> String) -> String {
    format!("{} [{}–{}]", f(median), f(min), f(max))
}

/// A table head: `first`, then one column per name.
fn column_heads(first: &str, names: &[&str]) -> Vec<String> {
    std::iter::once(first)
        .chain(names.iter().copied())
        .map(String::from)
        .collect()
}

// ---------------------------------------------------------------------------------------
// The document and its two renderings.

/// A piece of the report, rendered both as Markdown and as HTML.
enum Block {
    Heading(u8, String),
    /// A paragraph; `**bold**` and `` `code` `` are marked up in HTML.
    Para(String),
    /// Head and rows; the first column is left-aligned, the others right-aligned.
    Table(Vec<String>, Vec<Vec<String>>),
    /// Head and rows of prose, every column left-aligned.
    TextTable(Vec<String>, Vec<Vec<String>>),
    /// An SVG plot: file name (relative to the report), alt text, document.
    Svg {
        path: String,
        alt: String,
        svg: String,
    },
    /// A row of images (file name relative to the report, caption).
    Gallery(Vec<(String, String)>),
}

#[derive(Default)]
struct Doc {
    blocks: Vec<Block>,
}

impl Doc {
    fn h(&mut self, level: u8, s: impl Into<String>) {
        self.blocks.push(Block::Heading(level, s.into()));
    }

    fn p(&mut self, s: impl Into<String>) {
        self.blocks.push(Block::Para(s.into()));
    }

    fn table<S: Into<String>>(
        &mut self,
        head: impl IntoIterator<Item = S>,
        rows: Vec<Vec<String>>,
    ) {
        let head = head.into_iter().map(Into::into).collect();
        self.blocks.push(Block::Table(head, rows));
    }

    fn text_table(&mut self, head: Vec<String>, rows: Vec<Vec<String>>) {
        self.blocks.push(Block::TextTable(head, rows));
    }

    /// `plot`, saved as `path` (written by [`write_all`]) and drawn inline in HTML.
    fn svg(&mut self, path: impl Into<String>, alt: impl Into<String>, plot: Plot) {
        self.blocks.push(Block::Svg {
            path: path.into(),
            alt: alt.into(),
            svg: plot.svg(),
        });
    }

    fn gallery(&mut self, items: Vec<(String, String)>) {
        self.blocks.push(Block::Gallery(items));
    }

    fn markdown(&self) -> String {
        let mut s = String::new();
        for b in &self.blocks {
            b.markdown(&mut s);
        }
        s
    }

    /// The HTML page; images are read from `dir` and embedded.
    fn html(&self, dir: &Path) -> String {
        let mut s = String::from(HTML_HEAD);
        for b in &self.blocks {
            b.html(&mut s, dir);
        }
        s.push_str("</body></html>\n");
        s
    }
}

/// The HTML page up to its first block.
const HTML_HEAD: &str = r#"<!DOCTYPE html><html lang="en"><head><meta charset="utf-8"><title>sahara evaluation</title>
<style>
body{font-family:system-ui,sans-serif;max-width:1200px;margin:2em auto;padding:0 1em;color:#222}
table{border-collapse:collapse;margin:1em 0;font-size:13px}
th,td{border:1px solid #ccc;padding:3px 8px;text-align:right}
th:first-child,td:first-child{text-align:left}
table.text th,table.text td{text-align:left;vertical-align:top}
th{background:#f3f3f3}
img{max-width:100%;image-rendering:pixelated;border:1px solid #ddd}
.gallery{display:flex;flex-wrap:wrap;gap:10px}
.gallery figure{margin:0;width:230px}
figcaption{font-size:12px;text-align:center}
code{background:#f5f5f5;padding:1px 3px}
</style></head><body>
"#;

impl Block {
    /// Appends the block as Markdown.
    fn markdown(&self, s: &mut String) {
        match self {
            Block::Heading(l, t) => {
                let _ = writeln!(s, "{} {t}\n", "#".repeat(*l as usize));
            }
            Block::Para(t) => {
                let _ = writeln!(s, "{t}\n");
            }
            Block::Table(head, rows) | Block::TextTable(head, rows) => {
                let text = matches!(self, Block::TextTable(..));
                let _ = writeln!(s, "| {} |", head.join(" | "));
                let rule: Vec<&str> = (0..head.len())
                    .map(|i| if i == 0 || text { "---" } else { "---:" })
                    .collect();
                let _ = writeln!(s, "|{}|", rule.join("|"));
                for r in rows {
                    let _ = writeln!(s, "| {} |", r.join(" | "));
                }
                s.push('\n');
            }
            Block::Svg { path, alt, .. } => {
                let _ = writeln!(s, "![{alt}]({path})\n");
            }
            Block::Gallery(items) => {
                for (path, cap) in items {
                    let _ = write!(s, "![{cap}]({path}) ");
                }
                s.push_str("\n\n");
                let caps: Vec<&str> = items.iter().map(|(_, c)| c.as_str()).collect();
                let _ = writeln!(s, "*{}*\n", caps.join(" · "));
            }
        }
    }

    /// Appends the block as HTML (images read from `dir`).
    fn html(&self, s: &mut String, dir: &Path) {
        match self {
            Block::Heading(l, t) => {
                let _ = writeln!(s, "<h{l}>{}</h{l}>", esc(t));
            }
            Block::Para(t) => {
                let _ = writeln!(s, "<p>{}</p>", inline_md(&esc(t)));
            }
            Block::Table(head, rows) | Block::TextTable(head, rows) => {
                s.push_str(if matches!(self, Block::TextTable(..)) {
                    "<table class=\"text\"><thead><tr>"
                } else {
                    "<table><thead><tr>"
                });
                for h in head {
                    let _ = write!(s, "<th>{}</th>", esc(h));
                }
                s.push_str("</tr></thead><tbody>\n");
                for r in rows {
                    s.push_str("<tr>");
                    for c in r {
                        let _ = write!(s, "<td>{}</td>", inline_md(&esc(c)));
                    }
                    s.push_str("</tr>\n");
                }
                s.push_str("</tbody></table>\n");
            }
            Block::Svg { svg, .. } => {
                let _ = writeln!(s, "<div class=\"plot\">{svg}</div>");
            }
            Block::Gallery(items) => {
                s.push_str("<div class=\"gallery\">");
                for (path, cap) in items {
                    let _ = write!(
                        s,
                        "<figure>{}<figcaption>{}</figcaption></figure>",
                        embedded_image(dir, path, cap),
                        esc(cap)
                    );
                }
                s.push_str("</div>\n");
            }
        }
    }
}

/// The PNG at `dir/path` as an `<img>` with a data URL (a note when it cannot be read).
fn embedded_image(dir: &Path, path: &str, alt: &str) -> String {
    match std::fs::read(dir.join(path)) {
        Ok(bytes) => format!(
            r#"<img alt="{}" src="data:image/png;base64,{}">"#,
            esc(alt),
            base64::engine::general_purpose::STANDARD.encode(bytes)
        ),
        Err(_) => format!("<em>missing image {}</em>", esc(path)),
    }
}

/// `**bold**` and `` `code` `` in already escaped text.
fn inline_md(t: &str) -> String {
    let mut out = String::new();
    let mut bold = false;
    let mut code = false;
    let mut chars = t.chars().peekable();
    while let Some(c) = chars.next() {
        if c == '*' && chars.peek() == Some(&'*') {
            chars.next();
            out.push_str(if bold { "</b>" } else { "<b>" });
            bold = !bold;
        } else if c == '`' {
            out.push_str(if code { "</code>" } else { "<code>" });
            code = !code;
        } else {
            out.push(c);
        }
    }
    out
}

// ---------------------------------------------------------------------------------------
// results.csv.

/// One row per build and per trace: the build columns are empty in trace rows and the other
/// way round; a missing value is an empty field.
fn csv(r: &Results) -> String {
    let mut s = String::from(
        "kind,scene,triangles,builder,layout,rays,ray_count,threads,build_ms_median,build_ms_min,build_ms_max,sah,epo,nodes,leaves,references,max_leaf,depth,mrays_median,mrays_min,mrays_max,inner_per_ray,leaves_per_ray,triangles_per_ray,work_cost,lcv,hits,checksum,speed_vs_sweep,work_vs_sweep,speed_vs_sbvh,work_vs_sbvh,backend\n",
    );
    let o = |x: Option<f64>| x.map_or(String::new(), |v| format!("{v}"));
    for b in &r.builds {
        let _ = writeln!(
            s,
            "build,{},{},{},,,,{},{},{},{},{},{},{},{},{},{},{},,,,,,,,,,,,,,,",
            b.scene,
            b.triangles,
            b.builder,
            b.threads,
            b.build_ms.median,
            b.build_ms.min,
            b.build_ms.max,
            b.sah,
            o(b.epo),
            b.nodes,
            b.leaves,
            b.references,
            b.max_leaf,
            b.depth
        );
    }
    for t in &r.traces {
        let x = &t.report;
        let _ = writeln!(
            s,
            "trace,{},{},{},{},{},{},{},,,,,,,,,,,{},{},{},{},{},{},{},{},{},{},{},{},{},{},{}",
            x.scene,
            x.triangles,
            x.builder,
            x.layout,
            x.ray_kind,
            x.rays,
            x.threads,
            x.mrays_s.median,
            x.mrays_s.min,
            x.mrays_s.max,
            x.inner_per_ray,
            x.leaves_per_ray,
            x.triangles_per_ray,
            t.work_cost,
            x.lcv,
            x.hits,
            x.checksum,
            o(t.speed_vs_sweep),
            o(t.work_vs_sweep),
            o(t.speed_vs_sbvh),
            o(t.work_vs_sbvh),
            x.backend
        );
    }
    s
}

#[cfg(test)]
mod tests {
    //! Golden test: [`write_all`] on a small fixed [`Results`] must give, byte for byte, the
    //! `report.md`, `report.html` and `results.csv` recorded under `xtask/tests/data/report/`.
    //! A change to the report on purpose re-records them (`SAHARA_RECORD_REPORT=1 cargo test -p
    //! xtask golden_report`) in the same commit, and the diff of the recorded files shows it.

    use super::*;
    use crate::engine::TraceReport;
    use crate::eval::predict::{PredictedPoint, PredictorRow};
    use crate::eval::{Meta, SceneInfo, Settings};
    use crate::tree::BuildReport;
    use crate::tree::Series;
    use crate::util::file_stem;
    use crate::util::Spread;
    use sahara_metrics::{CostModel, ForecastReport};
    use sahara_trace::{Throughput, Timing, WorkPerRay};
    use std::path::PathBuf;

    const BUILDERS: [&str; 4] = ["sweep", "sbvh", "binned", "tsah-sbvh"];
    const KINDS: [&str; 2] = ["primary", "ao"];
    const LAYOUTS: [&str; 2] = ["bvh2", "bvh8"];

    fn timed(median: f64) -> Spread {
        Spread {
            median,
            min: 0.9 * median,
            max: 1.25 * median,
        }
    }

    /// Two scenes (one with characters that need escaping), four builders (two spatial), two
    /// ray types and two layouts; with holes where the report prints "–": a builder without
    /// traces, a scene without a sweep trace, predictors without scores, a scaling series
    /// without a point, and one heat map whose image is missing.
    fn results() -> Results {
        let settings = Settings {
            quick: true,
            full: false,
            scenes: vec!["cube".into(), "a<b> & c".into()],
            builders: BUILDERS.map(String::from).to_vec(),
            rays: KINDS.map(String::from).to_vec(),
            layouts: LAYOUTS.map(|l| l.parse().unwrap()).to_vec(),
            backend: "sse2".into(),
            width: 32,
            height: 24,
            passes: 3,
            round_budget: 20.0,
            build_runs: 3,
            threads: 2,
            seed: 1,
            cost_model: CostModel::default(),
        };
        let scenes: Vec<SceneInfo> = [("cube", 12usize), ("a<b> & c", 3000)]
            .iter()
            .enumerate()
            .map(|(i, &(name, triangles))| SceneInfo {
                name: name.into(),
                triangles,
                render: (i == 0).then(|| "images/cube-render.png".to_string()),
                heat_maps: BUILDERS
                    .iter()
                    .take(2)
                    .map(|b| {
                        (
                            b.to_string(),
                            format!("images/{}-{b}-heat.png", file_stem(name)),
                        )
                    })
                    .collect(),
                heat_scale: 40.0 + 7.5 * i as f64,
                diff_maps: if i == 0 {
                    vec![("sbvh".to_string(), "images/cube-sbvh-diff.png".to_string())]
                } else {
                    Vec::new()
                },
                diff_scale: 12.0 + i as f64,
                camera: "eye=0,0,5 target=0,0,0 up=0,1,0 fov=60".into(),
                camera_source: "generator".into(),
                rounds: vec![("primary".to_string(), if i == 0 { 2 } else { 3 })],
            })
            .collect();
        let mut builds = Vec::new();
        let mut traces: Vec<TraceRow> = Vec::new();
        for (si, sc) in scenes.iter().enumerate() {
            for (bi, b) in BUILDERS.iter().enumerate() {
                let f = 1.0 + 0.125 * bi as f64 + 0.5 * si as f64;
                builds.push(BuildReport {
                    scene: sc.name.clone(),
                    triangles: sc.triangles,
                    builder: b.to_string(),
                    config: String::new(),
                    threads: 2,
                    build_ms: timed(0.75 * f * f * (1 + 99 * si) as f64),
                    sah: 10.0 / f,
                    epo: (bi != 2).then_some(2.5 / f),
                    nodes: 2 * sc.triangles / (bi + 1) - 1,
                    leaves: sc.triangles / (bi + 1),
                    references: sc.triangles + bi * si * 17,
                    max_leaf: 4 + bi,
                    depth: 6 + bi + 3 * si,
                });
                if *b == "binned" && si == 1 {
                    continue; // a builder without traces on this scene
                }
                for (li, layout) in LAYOUTS.iter().enumerate() {
                    for (ki, kind) in KINDS.iter().enumerate() {
                        if *b == "sweep" && si == 1 && ki == 1 {
                            continue; // no reference: the ratios are None
                        }
                        let g = f * (1.0 + 0.25 * li as f64) * (1.0 + 0.5 * ki as f64);
                        let m = 12.0 / g;
                        let rep = TraceReport {
                            scene: sc.name.clone(),
                            triangles: sc.triangles,
                            builder: b.to_string(),
                            layout: layout.to_string(),
                            backend: if *layout == "bvh2" { "scalar" } else { "sse2" }.into(),
                            ray_kind: kind.to_string(),
                            rays: 768,
                            threads: 2,
                            mrays_s: Throughput {
                                median: m,
                                min: 0.8 * m,
                                max: 1.1 * m,
                            },
                            trace_ms: Timing {
                                median: 0.064 * g,
                                min: 0.058 * g,
                                max: 0.08 * g,
                                passes: 3,
                            },
                            work: WorkPerRay {
                                inner: 8.0 * g,
                                leaves: 2.0 * g,
                                triangles: 5.0 * g,
                            },
                            inner_per_ray: 8.0 * g,
                            leaves_per_ray: 2.0 * g,
                            triangles_per_ray: 5.0 * g,
                            lcv: 1.5 * g,
                            hits: 700 - 100 * ki,
                            checksum: format!("{:016x}", 0x5eed + 31 * traces.len()),
                        };
                        // Seven rounds; the tsah-sbvh rows swing about the sweep ones (their
                        // interval contains 1), the others differ steadily.
                        let wobble = |k: usize| match *b {
                            "tsah-sbvh" => 0.85 + 0.05 * ((k * 3) % 7) as f64,
                            _ => 1.0 + 0.01 * ((k * 5 + bi) % 7) as f64,
                        };
                        traces.push(TraceRow {
                            work_cost: 8.0 * g + 5.0 * g * (1.0 + 0.0625 * bi as f64),
                            report: rep,
                            speed_vs_sweep: None,
                            work_vs_sweep: None,
                            speed_vs_sbvh: None,
                            work_vs_sbvh: None,
                            round_seconds: (0..7).map(|k| 0.064 * g * wobble(k)).collect(),
                            speed_vs_sweep_ci: None,
                            speed_vs_sbvh_ci: None,
                        });
                    }
                }
            }
        }
        let split = traces
            .iter()
            .position(|t| t.report.scene != scenes[0].name)
            .unwrap();
        let (a, b) = traces.split_at_mut(split);
        super::super::relate(a);
        super::super::relate(b);
        let forecast = |e: f64, rho: Option<f64>| ForecastReport {
            alpha: 0.5,
            samples: 6,
            mean_relative_error: e,
            max_relative_error: 2.5 * e,
            spearman: rho,
            mean_scene_spearman: rho.map(|r| r - 0.1),
        };
        let predictors = vec![
            PredictorRow {
                ray_kind: "primary".into(),
                predictor: "SAH-EPO".into(),
                target: "time".into(),
                alpha: Some(0.4375),
                report: Some(forecast(0.0625, Some(0.875))),
                note: "fitted".into(),
            },
            PredictorRow {
                ray_kind: "ao".into(),
                predictor: "SAH".into(),
                target: "work".into(),
                alpha: None,
                report: Some(forecast(0.125, None)),
                note: "`alpha` fixed at **0**".into(),
            },
            PredictorRow {
                ray_kind: "ao".into(),
                predictor: "ray-weighted".into(),
                target: "time".into(),
                alpha: None,
                report: None,
                note: "no samples <here>".into(),
            },
        ];
        let mut predicted_points = Vec::new();
        for (ki, kind) in KINDS.iter().enumerate() {
            for (bi, b) in BUILDERS.iter().enumerate().skip(1) {
                for p in ["SAH", "SAH-EPO"] {
                    let x = 1.0 + 0.125 * bi as f64 + 0.0625 * ki as f64;
                    predicted_points.push(PredictedPoint {
                        ray_kind: kind.to_string(),
                        predictor: p.into(),
                        scene: "cube".into(),
                        builder: b.to_string(),
                        predicted: x,
                        measured: if p == "SAH" {
                            1.5 * x - 0.5
                        } else {
                            x + 0.03125
                        },
                    });
                }
            }
        }
        let scaling = vec![
            Series {
                builder: "sweep".into(),
                points: vec![(1000, timed(0.002)), (4000, timed(0.009))],
                exponent: Some(1.085),
                exponent_large: None,
            },
            Series {
                builder: "binned".into(),
                points: vec![(1000, timed(0.0005))],
                exponent: None,
                exponent_large: None,
            },
        ];
        Results {
            meta: Meta {
                date: "2024-01-02T03-04-05".into(),
                commit: "0123abc".into(),
                cpu: "Test CPU <2 cores>".into(),
                simd: "sse2".into(),
                settings,
                seconds: 61.5,
            },
            scenes,
            skipped: vec![
                "tsah-exhaustive on cube (12 triangles; name it with --builders to run it)".into(),
            ],
            builds,
            traces,
            predictors,
            predicted_points,
            scaling,
            study: Some(crate::eval::saved_study::SavedStudy {
                run: Some("docs/results/2024-01-01-study".into()),
                head: vec!["claim".into(), "our figure".into()],
                rows: vec![vec![
                    "37% faster <primary>".into(),
                    "**1.26** (`sponza`)".into(),
                ]],
                main: Some((
                    vec!["factor".into(), "bvh2 primary".into()],
                    vec![vec!["cost".into(), "1.036".into()]],
                )),
            }),
        }
    }

    fn golden_dir() -> PathBuf {
        PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("tests/data/report")
    }

    /// The line number and both lines at the first difference (`None`: equal).
    fn first_difference(want: &str, got: &str) -> Option<(usize, String, String)> {
        if want == got {
            return None;
        }
        let (mut w, mut g) = (want.split('\n'), got.split('\n'));
        for n in 1.. {
            match (w.next(), g.next()) {
                (Some(a), Some(b)) if a == b => continue,
                (a, b) => {
                    let show = |l: Option<&str>| {
                        l.map_or("<end of file>".to_string(), |l| {
                            l.chars().take(400).collect()
                        })
                    };
                    return Some((n, show(a), show(b)));
                }
            }
        }
        unreachable!()
    }

    #[test]
    fn golden_report() {
        let dir = std::env::temp_dir().join(format!("sahara-golden-report-{}", std::process::id()));
        let _ = std::fs::remove_dir_all(&dir);
        std::fs::create_dir_all(dir.join("plots")).unwrap();
        std::fs::create_dir_all(dir.join("images")).unwrap();
        // Stand-ins for PNGs (the HTML embeds the bytes as they are); the second heat map of
        // the second scene stays missing.
        std::fs::write(dir.join("images/cube-render.png"), b"render").unwrap();
        std::fs::write(dir.join("images/cube-sweep-heat.png"), b"heat\x00sweep").unwrap();
        std::fs::write(dir.join("images/cube-sbvh-heat.png"), b"heat\xffsbvh").unwrap();
        std::fs::write(dir.join("images/cube-sbvh-diff.png"), b"diff").unwrap();
        std::fs::write(dir.join("images/a_b____c-sweep-heat.png"), b"h").unwrap();
        write_all(&dir, &results()).unwrap();
        let html = std::fs::read_to_string(dir.join("report.html")).unwrap();
        for plot in [
            "speed-vs-error",
            "predicted-primary",
            "predicted-ao",
            "scaling",
        ] {
            let svg = std::fs::read_to_string(dir.join(format!("plots/{plot}.svg")))
                .unwrap_or_else(|e| panic!("plots/{plot}.svg: {e}"));
            assert!(
                html.contains(&svg),
                "plots/{plot}.svg is not the plot in the HTML"
            );
        }
        let record = std::env::var_os("SAHARA_RECORD_REPORT").is_some_and(|v| v != "0");
        let golden = golden_dir();
        let mut failures = Vec::new();
        for file in ["report.md", "report.html", "results.csv"] {
            let got = std::fs::read_to_string(dir.join(file)).unwrap();
            if record {
                std::fs::create_dir_all(&golden).unwrap();
                std::fs::write(golden.join(file), &got).unwrap();
                continue;
            }
            let want = std::fs::read_to_string(golden.join(file)).unwrap_or_default();
            if let Some((line, w, g)) = first_difference(&want, &got) {
                failures.push(format!(
                    "{file} differs from tests/data/report/{file} at line {line}:\n  want: {w}\n  got:  {g}"
                ));
            }
        }
        let _ = std::fs::remove_dir_all(&dir);
        assert!(
            failures.is_empty(),
            "{}\n(re-record with SAHARA_RECORD_REPORT=1 if the change is meant)",
            failures.join("\n")
        );
    }
}
