//! Tables of outcomes: case × builder and case × kernel, and the list of failures.

use crate::Outcome;

/// Counts of outcomes.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct Summary {
    /// Checks that held.
    pub passed: usize,
    /// Checks that failed, not explained by [`crate::KNOWN_BUGS`].
    pub failed: usize,
    /// Failures explained by [`crate::KNOWN_BUGS`].
    pub known_bugs: usize,
    /// Checks not run.
    pub skipped: usize,
}

/// Counts the outcomes.
pub fn summarize(outcomes: &[Outcome]) -> Summary {
    let mut s = Summary::default();
    for o in outcomes {
        if o.skipped {
            s.skipped += 1;
        } else if o.passed {
            s.passed += 1;
        } else if o.known_bug.is_some() {
            s.known_bugs += 1;
        } else {
            s.failed += 1;
        }
    }
    s
}

fn unique<'a>(it: impl Iterator<Item = &'a str>) -> Vec<&'a str> {
    let mut v: Vec<&str> = Vec::new();
    for s in it {
        if !v.contains(&s) {
            v.push(s);
        }
    }
    v
}

fn render(header: &[String], rows: &[Vec<String>]) -> String {
    let cols = header.len();
    let mut width = vec![0usize; cols];
    for r in std::iter::once(header).chain(rows.iter().map(|r| r.as_slice())) {
        for (i, c) in r.iter().enumerate() {
            width[i] = width[i].max(c.chars().count());
        }
    }
    let line = |r: &[String]| {
        let mut s = String::new();
        for (i, c) in r.iter().enumerate() {
            if i > 0 {
                s.push_str("  ");
            }
            s.push_str(c);
            if i + 1 < cols {
                s.push_str(&" ".repeat(width[i] - c.chars().count()));
            }
        }
        s.trim_end().to_string()
    };
    let mut out = line(header);
    out.push('\n');
    out.push_str(&"-".repeat(width.iter().sum::<usize>() + 2 * (cols - 1)));
    out.push('\n');
    for r in rows {
        out.push_str(&line(r));
        out.push('\n');
    }
    out
}

/// A short word for what went wrong in a builder-level outcome.
fn failure_word(o: &Outcome) -> &'static str {
    let d = o.detail.as_str();
    if d.starts_with("timeout") {
        "timeout"
    } else if d.contains("panic") {
        "panic"
    } else if d.contains("invalid tree") {
        "invalid"
    } else if d.contains("not deterministic") {
        "nondet"
    } else if d.contains("SAH cost") {
        "sah"
    } else if d.contains("error") {
        "error"
    } else {
        "FAIL"
    }
}

fn cell(outs: &[&Outcome]) -> String {
    if outs.is_empty() {
        return "-".to_string();
    }
    if outs.iter().all(|o| o.skipped) {
        return "skip".to_string();
    }
    let failed: Vec<&&Outcome> = outs.iter().filter(|o| !o.passed).collect();
    if failed.is_empty() {
        let typed = outs
            .iter()
            .any(|o| o.kernel.is_none() && o.detail.starts_with("ok: typed error"));
        return if typed { "ok(err)" } else { "ok" }.to_string();
    }
    let mut parts: Vec<String> = Vec::new();
    let mut bugs = unique(failed.iter().filter_map(|o| o.known_bug.as_deref()));
    let regressions: Vec<&&Outcome> = failed
        .iter()
        .filter(|o| o.known_bug.is_none())
        .copied()
        .collect();
    if let Some(b) = regressions.iter().find(|o| o.kernel.is_none()) {
        parts.push(failure_word(b).to_string());
    }
    let k = regressions.iter().filter(|o| o.kernel.is_some()).count();
    if k > 0 {
        let misses = regressions
            .iter()
            .any(|o| o.kernel.is_some() && o.detail.contains("watertightness"));
        parts.push(format!("{k}k{}", if misses { "-leak" } else { "" }));
    }
    if !bugs.is_empty() {
        bugs.sort_unstable();
        parts.push(format!("BUG:{}", bugs.join(",")));
    }
    if regressions.is_empty() {
        parts.join(" ")
    } else {
        format!("FAIL:{}", parts.join(" "))
    }
}

/// Case × builder: `ok`, `ok(err)` (a typed build error, accepted for bad geometry), `skip`,
/// `BUG:id` (a known bug), or `FAIL:` followed by what failed (`panic`, `timeout`, `invalid`,
/// `nondet`, `sah`, `error`, and `Nk` for N kernels that differ from brute force, `-leak`
/// when rays from inside a closed mesh missed). The `input` and `brute` columns are the
/// checks of the input and of the brute-force reference.
pub fn builder_table(outcomes: &[Outcome]) -> String {
    let cases = unique(outcomes.iter().map(|o| o.case.as_str()));
    let builders = unique(outcomes.iter().filter_map(|o| o.builder.as_deref()));
    let mut header = vec!["case".to_string(), "input".to_string(), "brute".to_string()];
    header.extend(builders.iter().map(|b| b.to_string()));
    let rows: Vec<Vec<String>> = cases
        .iter()
        .map(|&c| {
            let of_case: Vec<&Outcome> = outcomes.iter().filter(|o| o.case == c).collect();
            let mut row = vec![c.to_string()];
            for s in ["input", "brute"] {
                let v: Vec<&Outcome> = of_case.iter().filter(|o| o.subject == s).copied().collect();
                row.push(cell(&v));
            }
            for b in &builders {
                let v: Vec<&Outcome> = of_case
                    .iter()
                    .filter(|o| o.builder.as_deref() == Some(b))
                    .copied()
                    .collect();
                row.push(cell(&v));
            }
            row
        })
        .collect();
    render(&header, &rows)
}

/// Case × kernel, over every builder: `ok`, `-` (no tree to trace), `BUG:id`, or
/// `FAIL:N` with the number of builders whose tree the kernel traced differently from brute
/// force (or leaked).
pub fn kernel_table(outcomes: &[Outcome]) -> String {
    let cases = unique(outcomes.iter().map(|o| o.case.as_str()));
    let kernels = unique(outcomes.iter().filter_map(|o| o.kernel.as_deref()));
    let mut header = vec!["case".to_string()];
    header.extend(kernels.iter().map(|k| k.to_string()));
    let rows: Vec<Vec<String>> = cases
        .iter()
        .map(|&c| {
            let mut row = vec![c.to_string()];
            for k in &kernels {
                let v: Vec<&Outcome> = outcomes
                    .iter()
                    .filter(|o| o.case == c && o.kernel.as_deref() == Some(k))
                    .collect();
                let text = if v.is_empty() {
                    "-".to_string()
                } else {
                    let bad: Vec<&&Outcome> = v.iter().filter(|o| !o.passed).collect();
                    let regress = bad.iter().filter(|o| o.known_bug.is_none()).count();
                    let bugs = unique(bad.iter().filter_map(|o| o.known_bug.as_deref()));
                    match (regress, bugs.is_empty()) {
                        (0, true) => "ok".to_string(),
                        (0, false) => format!("BUG:{}", bugs.join(",")),
                        (n, _) => format!("FAIL:{n}"),
                    }
                };
                row.push(text);
            }
            row
        })
        .collect();
    render(&header, &rows)
}

/// Every failed outcome with its detail, one per line (known bugs marked).
pub fn failures(outcomes: &[Outcome]) -> String {
    let mut s = String::new();
    for o in outcomes.iter().filter(|o| !o.passed) {
        let tag = o
            .known_bug
            .as_ref()
            .map(|b| format!("[known bug {b}] "))
            .unwrap_or_default();
        s.push_str(&format!("{tag}{} / {}: {}\n", o.case, o.subject, o.detail));
    }
    s
}
