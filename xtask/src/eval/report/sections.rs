//! The report's sections, in the order [`report`](super::report) calls them.

use super::*;

/// The title and one line on the run: when, where, how long, which matrix.
pub(super) fn title(d: &mut Doc, c: &Ctx) {
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
                crate::eval::MIN_ROUNDS.min(s.passes),
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
pub(super) fn summary(d: &mut Doc, c: &Ctx) {
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
pub(super) const MARK: &str = "≈";

/// A speed ratio with its interval, marked with [`MARK`] when the interval contains 1:
/// `≈1.012 [0.981–1.043]`.
pub(super) fn speed_cell(i: Interval) -> String {
    format!(
        "{}{:.3} [{:.3}–{:.3}]",
        if i.contains_one() { MARK } else { "" },
        i.estimate,
        i.low,
        i.high
    )
}

/// `builder`'s build time relative to sweep: geometric mean over scenes.
pub(super) fn build_factor(c: &Ctx, builder: &str) -> Option<f64> {
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
pub(super) fn claims(d: &mut Doc, c: &Ctx) {
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
pub(super) fn run_notes(d: &mut Doc, c: &Ctx) {
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
                crate::eval::MIN_ROUNDS.min(s.passes),
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
pub(super) fn sweep_tables(d: &mut Doc, c: &Ctx) {
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
pub(super) fn sbvh_table(d: &mut Doc, c: &Ctx) {
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
pub(super) fn scene_tables(d: &mut Doc, c: &Ctx) {
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
pub(super) fn speed_against_error(d: &mut Doc, c: &Ctx) {
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
pub(super) fn predictors(d: &mut Doc, c: &Ctx) {
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
pub(super) fn scaling(d: &mut Doc, c: &Ctx) {
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
pub(super) fn heat_maps(d: &mut Doc, c: &Ctx) {
    d.h(
        2,
        "Scenes: render, work heat maps and difference against sweep (primary rays)",
    );
    d.p(format!(
        "Heat maps show inner nodes + leaves + triangles visited per pixel (bvh2 layout: the binary tree). All heat maps of a scene share one colour scale (viridis, dark = little work), topping out at the largest of the trees' {:.0}th percentiles of per-pixel work, so the same colour means the same work in every image of the scene. \
         Difference maps show a tree's per-pixel work minus the sweep tree's on a diverging scale: **blue where the tree saves work**, red where it costs more, white where they agree; the scale's ends are the largest of the trees' {:.0}th percentiles of the absolute difference.",
        crate::eval::HEAT_PERCENTILE,
        crate::eval::HEAT_PERCENTILE
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
