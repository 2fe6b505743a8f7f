//! The claims table: the paper's claims against the study's measured figures, rendered from
//! the study's CSV alone ([`render_claims`]; `claims.md` of a study folder). The table of
//! `docs/study.md`'s "Claims table" is this rendering of the saved full run, between two
//! marker comments naming the CSV, and a test checks that it still is.

use super::render::{fmt_cell, parse, speed_cell, Row};
use crate::tree::fit_exponent;
use crate::util::geomean;
use anyhow::Result;

/// One claim of the paper and how the study measures it.
struct Claim {
    /// The claim as we read it (from the paper's abstract and introduction).
    paper: &'static str,
    /// Our figure, from the study's rows.
    figure: fn(&[Row]) -> String,
    /// What the figure is taken over.
    conditions: &'static str,
}

/// The claims, in the table's order.
const CLAIMS: &[Claim] = &[
    Claim {
        paper: "up to **37% faster primary rays** than full-sweep SAH (no spatial splits)",
        figure: primary_rays,
        conditions: "the best row of the paper's builders (every factor but `reinsert`) \
                     against the sweep tree built under the same settings; registered presets: \
                     geometric mean over the scenes",
    },
    Claim {
        paper: "up to **32% faster diffuse rays**",
        figure: diffuse_rays,
        conditions: "the best row of the paper's builders (every factor but `reinsert`) \
                     against its reference (sweep, or SBVH for tsah-sbvh)",
    },
    Claim {
        paper: "**18% / 15%** faster than SBVH with spatial splits",
        figure: against_sbvh,
        conditions: "SBVH reference built with the same cost model; exact temporaries on the \
                     scenes below the heavy limit",
    },
    Claim {
        paper: "**subquadratic build**, O(N log² N)",
        figure: build_time,
        conditions: "tsah-topk as registered, one build per scene",
    },
    Claim {
        paper: "only **SAH-built temporaries** help",
        figure: temporaries,
        conditions: "tsah-topk with each temporary, every scene",
    },
    Claim {
        paper: "lower SAH, yet the greedy tree traces faster (the paper's motivation)",
        figure: lower_sah_more_work,
        conditions: "tsah-topk from the catalog camera and from outside, the same trees",
    },
    Claim {
        paper: "an improved **SAH-EPO predictor**, useful for primary rays",
        figure: |_| {
            "not a study factor: the evaluation's predictors section (`cargo xtask eval`) \
             forecasts work per ray with each predictor"
                .into()
        },
        conditions: "–",
    },
];

/// The claims table of a study CSV (as written by `cargo xtask study`): one row per claim,
/// every figure a gain reference ÷ builder (> 1: the builder's tree is better) or a speed
/// ratio with its 95% interval, computed from the CSV's rows.
pub fn render_claims(csv: &str) -> Result<String> {
    let rows = parse(csv)?;
    let mut md = String::from(
        "| claim of the paper | our best measured figure | conditions |\n| --- | --- | --- |\n",
    );
    for c in CLAIMS {
        md += &format!(
            "| {} | {} | {} |\n",
            c.paper,
            (c.figure)(&rows),
            c.conditions
        );
    }
    Ok(md)
}

/// `scene, builder level` of a row (and its reference when it is not the sweep tree).
fn label(r: &Row) -> String {
    let reference = r.s("reference");
    let against = if reference.starts_with("sweep") {
        String::new()
    } else {
        format!(" against {reference}")
    };
    format!(
        "{}, {} {}{against}",
        r.s("scene"),
        r.s("builder"),
        r.s("level")
    )
}

/// The row with the largest gain in column `c`.
fn best<'a, 'r>(rows: impl IntoIterator<Item = &'a Row<'r>>, c: &str) -> Option<&'a Row<'r>>
where
    'r: 'a,
{
    rows.into_iter()
        .filter_map(|r| r.gain(c).map(|g| (r, g)))
        .max_by(|a, b| a.1.total_cmp(&b.1))
        .map(|(r, _)| r)
}

/// The rows of a factor's setting: `builder` at `level`.
fn setting<'a, 'r>(
    rows: &'a [Row<'r>],
    factor: &str,
    builder: &str,
    level: &str,
) -> Vec<&'a Row<'r>> {
    rows.iter()
        .filter(|r| r.s("factor") == factor && r.s("builder") == builder && r.s("level") == level)
        .collect()
}

/// The geometric mean over `rows` of the gain in column `c`.
fn mean_gain(rows: &[&Row], c: &str) -> Option<f64> {
    geomean(&rows.iter().filter_map(|r| r.gain(c)).collect::<Vec<_>>())
}

/// The geometric mean over `rows` of the value of column `c` (speed ratios).
fn mean_x(rows: &[&Row], c: &str) -> Option<f64> {
    geomean(&rows.iter().filter_map(|r| r.x(c)).collect::<Vec<_>>())
}

/// `gain in c`, `speed [interval]` and the row's label, or `–`.
fn best_figure(r: Option<&Row>, work: &str, speed: &str) -> String {
    match r {
        Some(r) => format!(
            "**{}**, measured speed {} ({})",
            fmt_cell(r.gain(work)),
            speed_cell(r, speed),
            label(r)
        ),
        None => fmt_cell(None),
    }
}

/// The rows of the paper's builders: every factor but `reinsert` (whose post-pass optimisers
/// and PLOC are other work).
fn papers<'a, 'r>(rows: &'a [Row<'r>]) -> impl Iterator<Item = &'a Row<'r>> {
    rows.iter().filter(|r| r.s("factor") != "reinsert")
}

/// The registered presets `tsah-topk` and `hybrid` (factor `combined`).
fn presets<'a, 'r>(rows: &'a [Row<'r>]) -> [(&'static str, Vec<&'a Row<'r>>); 2] {
    ["tsah-topk", "hybrid"].map(|b| (b, setting(rows, "combined", b, "registered preset")))
}

fn primary_rays(rows: &[Row]) -> String {
    let sweep: Vec<&Row> = papers(rows)
        .filter(|r| r.s("reference").starts_with("sweep"))
        .collect();
    let presets = presets(rows);
    let means: Vec<String> = presets
        .iter()
        .map(|(b, sel)| {
            format!(
                "{b} {} (speed {}, {} scenes)",
                fmt_cell(mean_gain(sel, "work_bvh2_primary")),
                fmt_cell(mean_x(sel, "speed_bvh2_primary")),
                sel.len()
            )
        })
        .collect();
    let best_preset = best(
        presets.iter().flat_map(|(_, s)| s.iter().copied()),
        "work_bvh2_primary",
    );
    format!(
        "bvh2 work {}. bvh8 work {}. Registered presets, geomean: {}; best scene {}",
        best_figure(
            best(sweep.iter().copied(), "work_bvh2_primary"),
            "work_bvh2_primary",
            "speed_bvh2_primary"
        ),
        best_figure(
            best(sweep.iter().copied(), "work_bvh8_primary"),
            "work_bvh8_primary",
            "speed_bvh8_primary"
        ),
        means.join(", "),
        best_preset.map_or_else(
            || fmt_cell(None),
            |r| format!("{} ({})", fmt_cell(r.gain("work_bvh2_primary")), label(r))
        )
    )
}

fn diffuse_rays(rows: &[Row]) -> String {
    let means: Vec<String> = presets(rows)
        .iter()
        .map(|(b, sel)| format!("{b} {}", fmt_cell(mean_gain(sel, "work_bvh2_diffuse"))))
        .collect();
    format!(
        "bvh2 work {}. Registered presets, geomean: {}",
        best_figure(
            best(papers(rows), "work_bvh2_diffuse"),
            "work_bvh2_diffuse",
            "speed_bvh2_diffuse"
        ),
        means.join(", ")
    )
}

fn against_sbvh(rows: &[Row]) -> String {
    let levels: Vec<String> = ["SBVH (estimated)", "SBVH (exact)"]
        .iter()
        .map(|level| {
            let sel = setting(rows, "temporary", "tsah-sbvh", level);
            format!(
                "{level}: bvh2 work {} / {} (primary / diffuse), speed {}, {} scenes",
                fmt_cell(mean_gain(&sel, "work_bvh2_primary")),
                fmt_cell(mean_gain(&sel, "work_bvh2_diffuse")),
                fmt_cell(mean_x(&sel, "speed_bvh2_primary")),
                sel.len()
            )
        })
        .collect();
    let all: Vec<&Row> = rows
        .iter()
        .filter(|r| r.s("factor") == "temporary" && r.s("builder") == "tsah-sbvh")
        .collect();
    let top = best(all.iter().copied(), "work_bvh2_primary").map_or_else(
        || fmt_cell(None),
        |r| {
            format!(
                "{} / {} ({})",
                fmt_cell(r.gain("work_bvh2_primary")),
                fmt_cell(r.gain("work_bvh2_diffuse")),
                label(r)
            )
        },
    );
    format!("geomean {}; best scene {top}", levels.join("; "))
}

fn build_time(rows: &[Row]) -> String {
    let sel = setting(rows, "combined", "tsah-topk", "registered preset");
    let points = |c: &str| -> Vec<(f64, f64)> {
        sel.iter()
            .filter_map(|r| Some((r.x("triangles")?, r.x(c)?)))
            .collect()
    };
    let (own, sweep) = (points("build_s"), points("ref_build_s"));
    let ratios: Vec<f64> = sel
        .iter()
        .filter_map(|r| Some(r.x("build_s")? / r.x("ref_build_s")?))
        .filter(|x| x.is_finite())
        .collect();
    let (lo, hi) = ratios
        .iter()
        .fold((f64::INFINITY, f64::NEG_INFINITY), |(lo, hi), &x| {
            (lo.min(x), hi.max(x))
        });
    let mut by_size = own.clone();
    by_size.sort_by(|a, b| a.0.total_cmp(&b.0));
    let time = |p: Option<&(f64, f64)>| {
        p.map_or_else(
            || fmt_cell(None),
            |(n, t)| format!("{t:.2} s at {:.0}k triangles", n / 1e3),
        )
    };
    let exp = |e: Option<f64>| e.map_or_else(|| fmt_cell(None), |e| format!("{e:.2}"));
    format!(
        "fitted exponent of build time against triangles **{}** over {} scenes (sweep {}); \
         {}–{}× sweep's time; tsah-topk {} to {}",
        exp(fit_exponent(&own)),
        own.len(),
        exp(fit_exponent(&sweep)),
        if ratios.is_empty() {
            fmt_cell(None)
        } else {
            format!("{lo:.0}")
        },
        if ratios.is_empty() {
            fmt_cell(None)
        } else {
            format!("{hi:.0}")
        },
        time(by_size.first()),
        time(by_size.last())
    )
}

fn temporaries(rows: &[Row]) -> String {
    let median = setting(rows, "temporary", "tsah-topk", "median split (poor)");
    let worse = median
        .iter()
        .filter(|r| r.gain("work_bvh2_primary").is_some_and(|g| g < 1.0))
        .count();
    let levels: Vec<String> = ["sweep", "binned 8", "binned 16", "binned 32"]
        .iter()
        .map(|level| {
            let sel = setting(rows, "temporary", "tsah-topk", level);
            format!("{level} {}", fmt_cell(mean_gain(&sel, "work_bvh2_primary")))
        })
        .collect();
    format!(
        "median-split temporaries: geomean SAH {}, bvh2 work {} / {} / {} (primary / diffuse / \
         AO), measured speed {}; more primary work than the sweep tree on {worse} of {} scenes. \
         SAH temporaries, geomean primary work: {}",
        fmt_cell(mean_gain(&median, "sah")),
        fmt_cell(mean_gain(&median, "work_bvh2_primary")),
        fmt_cell(mean_gain(&median, "work_bvh2_diffuse")),
        fmt_cell(mean_gain(&median, "work_bvh2_ao")),
        fmt_cell(mean_x(&median, "speed_bvh2_primary")),
        median.len(),
        levels.join(", ")
    )
}

fn lower_sah_more_work(rows: &[Row]) -> String {
    let camera: Vec<&Row> = rows
        .iter()
        .filter(|r| r.s("factor") == "camera" && r.s("builder") == "tsah-topk")
        .collect();
    let contrary: Vec<&Row> = camera
        .iter()
        .copied()
        .filter(|r| {
            r.gain("sah").is_some_and(|g| g > 1.0)
                && r.gain("work_bvh2_primary").is_some_and(|g| g < 1.0)
        })
        .collect();
    let worst = contrary.iter().copied().min_by(|a, b| {
        let g = |r: &Row| r.gain("work_bvh2_primary").unwrap_or(f64::INFINITY);
        g(a).total_cmp(&g(b))
    });
    let means: Vec<String> = ["catalog", "outside"]
        .iter()
        .map(|c| {
            let sel: Vec<&Row> = camera
                .iter()
                .copied()
                .filter(|r| r.s("camera") == *c)
                .collect();
            format!(
                "{c} camera {}",
                fmt_cell(mean_gain(&sel, "work_bvh2_primary"))
            )
        })
        .collect();
    let worst = worst.map_or_else(
        || fmt_cell(None),
        |r| {
            format!(
                "{} from the {} camera: SAH {}, primary work **{}**, measured speed {}",
                r.s("scene"),
                r.s("camera"),
                fmt_cell(r.gain("sah")),
                fmt_cell(r.gain("work_bvh2_primary")),
                speed_cell(r, "speed_bvh2_primary")
            )
        },
    );
    format!(
        "{} of {} (scene, camera) rows of tsah-topk have a lower SAH and more primary-ray work \
         than the sweep tree; the most: {worst}. Geomean primary work: {}",
        contrary.len(),
        camera.len(),
        means.join(", ")
    )
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::path::Path;

    /// The marker lines around the rendered table in `docs/study.md`.
    const BEGIN: &str = "<!-- claims table: rendered by `cargo xtask study` from `";
    const END: &str = "<!-- end of claims table -->";

    #[test]
    fn the_claims_table_of_docs_study_md_is_the_saved_runs() {
        let root = Path::new(env!("CARGO_MANIFEST_DIR")).join("..");
        let doc = std::fs::read_to_string(root.join("docs/study.md")).unwrap();
        let begin = doc
            .lines()
            .position(|l| l.starts_with(BEGIN))
            .expect("docs/study.md: the claims table's opening marker");
        let end = doc
            .lines()
            .position(|l| l == END)
            .expect("docs/study.md: the claims table's closing marker");
        let marker = doc.lines().nth(begin).unwrap();
        let csv = marker[BEGIN.len()..].split('`').next().unwrap();
        let text = std::fs::read_to_string(root.join(csv))
            .unwrap_or_else(|e| panic!("docs/study.md names {csv}: {e}"));
        let table: String = doc
            .lines()
            .skip(begin + 1)
            .take(end - begin - 1)
            .map(|l| format!("{l}\n"))
            .collect();
        assert_eq!(
            table,
            render_claims(&text).unwrap(),
            "docs/study.md: the claims table differs from the rendering of {csv}; paste the \
             run's claims.md between the markers (or rerun `cargo xtask study --render {csv}`)"
        );
    }

    #[test]
    fn a_study_without_the_factors_renders_dashes() {
        let csv = super::super::COLUMNS.join(",") + "\n";
        let md = render_claims(&csv).unwrap();
        assert_eq!(md.lines().count(), 2 + CLAIMS.len());
        assert!(md.contains("bvh2 work –."), "{md}");
    }
}
