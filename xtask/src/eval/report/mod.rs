//! Writes `results.json`, `results.csv`, `report.md` and a self-contained `report.html`
//! (tables, inline SVG plots, PNG images embedded as data URLs) from one [`Results`].
//!
//! The report is a list of [`Block`]s, rendered once as Markdown and once as HTML (`doc.rs`).
//! Each section is one function appending its blocks to a [`Doc`] (`sections.rs`); [`report`]
//! calls them in order. `csv.rs` writes `results.csv`.

mod csv;
mod doc;
mod sections;

use super::plot::{esc, fmt_num, Plot, Point};
use super::{Results, TraceRow, REFERENCE, SPATIAL_REFERENCE};
use crate::interval::{self, Interval};
use crate::util::geomean;
use anyhow::Result;
use base64::Engine;
use csv::csv;
use doc::{Block, Doc};
use sections::*;
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
                            precision: "exact".into(),
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
        super::super::rounds::relate(a);
        super::super::rounds::relate(b);
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
