//! The study's markdown, rendered from its CSV alone: the main table, one table per factor and
//! one row per scene and setting (`README.md` of a study folder).

use crate::util::geomean;
use anyhow::{Context, Result};
use std::collections::HashMap;
use std::fmt::Write as _;

/// One parsed CSV row.
pub struct Row<'a> {
    f: HashMap<&'a str, &'a str>,
}

/// The rows of a study CSV (its first line names the columns).
pub fn parse(csv: &str) -> Result<Vec<Row<'_>>> {
    let mut lines = csv.lines();
    let header: Vec<&str> = lines
        .next()
        .context("empty study CSV")?
        .split(',')
        .collect();
    Ok(lines
        .filter(|l| !l.trim().is_empty())
        .map(|l| Row {
            f: header.iter().copied().zip(l.split(',')).collect(),
        })
        .collect())
}

impl Row<'_> {
    /// The text of column `k` (empty when absent).
    pub fn s(&self, k: &str) -> &str {
        self.f.get(k).copied().unwrap_or("")
    }
    /// The finite number of column `k`.
    pub fn x(&self, k: &str) -> Option<f64> {
        self.f
            .get(k)
            .and_then(|v| v.parse::<f64>().ok())
            .filter(|v| v.is_finite())
    }
    /// Reference over this (> 1: this tree is better), for a metric and its `ref_` column.
    pub fn gain(&self, k: &str) -> Option<f64> {
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
    let rows = parse(csv)?;
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
            "|{} {} ({}) |{}{speed}",
            text_cells(r, &["scene", "triangles", "factor", "builder", "level"]),
            r.s("camera"),
            r.s("camera_inside"),
            gain_cells(
                r,
                &[
                    "sah",
                    "work_bvh2_primary",
                    "work_bvh2_diffuse",
                    "work_bvh2_ao",
                    "work_bvh8_primary"
                ]
            ),
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
            "|{}{}",
            text_cells(r, &["scene", "factor", "builder", "level", "camera"]),
            gain_cells(
                r,
                &[
                    "sah",
                    "work_bvh2_primary",
                    "work_bvh2_diffuse",
                    "work_bvh8_primary"
                ]
            ),
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

/// The table cells ` text |` of a row's columns `cols`.
fn text_cells(r: &Row, cols: &[&str]) -> String {
    cols.iter().map(|c| format!(" {} |", r.s(c))).collect()
}

/// The table cells ` gain |` of a row's columns `cols` ([`Row::gain`], three decimals).
fn gain_cells(r: &Row, cols: &[&str]) -> String {
    cols.iter()
        .map(|c| format!(" {} |", fmt_cell(r.gain(c))))
        .collect()
}

/// A speed cell with its interval, `≈` marking an interval that contains 1 (a tie).
pub fn speed_cell(r: &Row, c: &str) -> String {
    match (r.x(c), r.x(&format!("{c}_low")), r.x(&format!("{c}_high"))) {
        (Some(e), Some(lo), Some(hi)) => {
            let tie = if lo <= 1.0 && 1.0 <= hi { "≈" } else { "" };
            format!("{tie}{e:.3} [{lo:.3}–{hi:.3}]")
        }
        (e, _, _) => fmt_cell(e),
    }
}

pub fn fmt_cell(x: Option<f64>) -> String {
    x.map(|v| format!("{v:.3}")).unwrap_or_else(|| "–".into())
}

#[cfg(test)]
mod tests {
    use super::super::COLUMNS;
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
}
