//! The study's saved results in the eval report: the paper's claims table of `docs/study.md`
//! and the main table of the newest dated study run under `docs/results/` are read, never
//! recomputed (a full study takes hours; `cargo xtask study` is its own command).

use serde::Serialize;
use std::path::Path;

/// The claims table and where the study's numbers come from.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct SavedStudy {
    /// The study run the table quotes (a folder under `docs/results/`, newest full run, else
    /// the newest quick one), relative to the workspace.
    pub run: Option<String>,
    /// The claims table's head.
    pub head: Vec<String>,
    /// Its rows.
    pub rows: Vec<Vec<String>>,
    /// The saved run's main table (the section `## Main table` of its `README.md`, rendered
    /// by `study::render_markdown`): head and rows; `None` when the run has none.
    pub main: Option<(Vec<String>, Vec<Vec<String>>)>,
}

/// Reads the claims table from `<root>/docs/study.md` (the section `## Claims table`) and names
/// the newest study run in `<root>/docs/results/`; `None` when the file or the section is
/// missing (the report then leaves the section out).
pub fn load(root: &Path) -> Option<SavedStudy> {
    let text = std::fs::read_to_string(root.join("docs/study.md")).ok()?;
    let (head, rows) = claims_table(&text)?;
    let run = newest_run(&root.join("docs/results"));
    let main = run.as_ref().and_then(|r| {
        let readme = std::fs::read_to_string(root.join(r).join("README.md")).ok()?;
        table_after(&readme, "## Main table")
    });
    Some(SavedStudy {
        run,
        head,
        rows,
        main,
    })
}

/// The first markdown table after the heading `## Claims table`, before the next `## `.
pub fn claims_table(md: &str) -> Option<(Vec<String>, Vec<Vec<String>>)> {
    table_after(md, "## Claims table")
}

/// The first markdown table after the line `heading`, before the next `## ` heading; `None`
/// without one, or when a row's cell count differs from the head's.
pub fn table_after(md: &str, heading: &str) -> Option<(Vec<String>, Vec<Vec<String>>)> {
    let mut lines = md.lines().skip_while(|l| l.trim() != heading);
    lines.next()?;
    let table: Vec<&str> = lines
        .take_while(|l| !l.starts_with("## "))
        .skip_while(|l| !l.trim_start().starts_with('|'))
        .take_while(|l| l.trim_start().starts_with('|'))
        .collect();
    let cells = |l: &str| -> Vec<String> {
        let t = l.trim().trim_start_matches('|').trim_end_matches('|');
        t.split(" | ").map(|c| c.trim().to_string()).collect()
    };
    let (head, rest) = table.split_first()?;
    let head = cells(head);
    // The second line is the alignment rule.
    let rows: Vec<Vec<String>> = rest.iter().skip(1).map(|l| cells(l)).collect();
    (!rows.is_empty() && rows.iter().all(|r| r.len() == head.len())).then_some((head, rows))
}

/// The newest `<date>-study` folder with a `study.csv` (else the newest `<date>-study-quick`),
/// as `docs/results/<name>`.
fn newest_run(results: &Path) -> Option<String> {
    let mut names: Vec<String> = std::fs::read_dir(results)
        .ok()?
        .filter_map(|e| e.ok())
        .filter(|e| e.path().join("study.csv").is_file())
        .filter_map(|e| e.file_name().into_string().ok())
        .collect();
    names.sort();
    let pick = |suffix: &str| names.iter().rev().find(|n| n.ends_with(suffix)).cloned();
    pick("-study")
        .or_else(|| pick("-study-quick"))
        .map(|n| format!("docs/results/{n}"))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn reads_the_claims_table_section() {
        let md = "# Study\n\n## Claims table\n\nSome words.\n\n| claim | ours |\n| --- | --- |\n| 37% | 1.26 |\n| subquadratic | yes |\n\n## Next\n\n| x | y |\n| - | - |\n| 1 | 2 |\n";
        let (head, rows) = claims_table(md).unwrap();
        assert_eq!(head, ["claim", "ours"]);
        assert_eq!(rows, [["37%", "1.26"], ["subquadratic", "yes"]]);
        assert!(claims_table("# Study\n\n## Other\n\n| a |\n| - |\n| 1 |\n").is_none());
        // A later section's table is not the main table, and a ragged row rejects the table.
        let run = "# Run\n\n## Main table\n\nWords.\n\n| factor | gain |\n| --- | ---: |\n| cost | 1.04 |\n\n### Largest\n\n| x |\n| - |\n| 9 |\n";
        let (head, rows) = table_after(run, "## Main table").unwrap();
        assert_eq!(head, ["factor", "gain"]);
        assert_eq!(rows, [["cost", "1.04"]]);
        assert!(table_after(
            "## Main table\n\n| a | b |\n| - | - |\n| 1 |\n",
            "## Main table"
        )
        .is_none());
    }

    #[test]
    fn the_repository_has_a_claims_table_and_a_saved_run() {
        let root = Path::new(env!("CARGO_MANIFEST_DIR")).join("..");
        let s = load(&root).expect("docs/study.md has a claims table");
        assert!(s.rows.len() >= 5, "{s:?}");
        let run = s.run.expect("a saved study run under docs/results");
        assert!(root.join(&run).join("study.csv").is_file(), "{run}");
        // The saved run's main table: one row per factor the study varies.
        let (head, rows) = s.main.expect("the saved run's README has a main table");
        assert_eq!(head[0], "factor");
        for factor in ["cost", "leaf", "breadth", "where", "temporary", "camera"] {
            assert!(rows.iter().any(|r| r[0] == factor), "no {factor} row");
        }
    }
}
