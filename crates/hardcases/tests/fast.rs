//! The fast level of the hard-case suite, as CI runs it: every case of
//! `sahara_hardcases::cases(Level::Fast)` against every registered builder and every kernel.
//! A failure listed in `sahara_hardcases::KNOWN_BUGS` is printed but accepted (each has an
//! `#[ignore]`d minimal test in `tests/known_bugs.rs`); anything else fails the test with the
//! case, the subject and what went wrong. `cargo xtask hardcases` prints the same as a table.

use std::time::Duration;

use sahara_hardcases::{cases, kernels, report, run_case_with, Category, Level, Options};

/// In CI the exhaustive (`small_inputs_only`) builder runs on inputs of up to 700 triangles
/// only (the xtask uses 2000): it takes seconds per build above that.
fn options() -> Options {
    Options {
        timeout: Duration::from_secs(180),
        small_input_limit: 700,
        ..Options::default()
    }
}

fn run(categories: &[Category]) {
    let builders = sahara_builders::registry::entries();
    let kernels = kernels();
    let mut outcomes = Vec::new();
    let mut n = 0;
    for case in cases(Level::Fast)
        .into_iter()
        .filter(|c| categories.contains(&c.category))
    {
        n += 1;
        outcomes.extend(run_case_with(&case, &builders, &kernels, &options()));
    }
    assert!(n > 0, "no case in {categories:?}");
    let s = report::summarize(&outcomes);
    eprintln!(
        "{categories:?}: {n} cases, {} passed, {} failed, {} known bugs, {} skipped",
        s.passed, s.failed, s.known_bugs, s.skipped
    );
    let regressions: Vec<String> = outcomes
        .iter()
        .filter(|o| o.is_regression())
        .map(|o| format!("{} / {}: {}", o.case, o.subject, o.detail))
        .collect();
    assert!(
        regressions.is_empty(),
        "{} hard-case checks failed:\n{}\n\n{}",
        regressions.len(),
        regressions.join("\n"),
        report::builder_table(&outcomes)
    );
}

#[test]
fn watertightness() {
    run(&[Category::Watertight]);
}

#[test]
fn bad_rays() {
    run(&[Category::BadRays]);
}

#[test]
fn bad_geometry() {
    run(&[Category::BadGeometry, Category::NonFinite]);
}

/// Ordinary scenes: determinism on 1 and 2 threads and kernel equality.
#[test]
fn procedural_scenes() {
    run(&[Category::Procedural]);
}

/// Axis-aligned floors and walls at 1 to 10^4 units: kernel equality, and brute force pinned by
/// the exact oracle (issue 13: valid hits on flat-box triangles were dropped).
#[test]
fn flat_floors() {
    run(&[Category::FlatFloors]);
}

#[test]
fn every_kernel_is_listed() {
    let k = kernels();
    assert!(k.contains(&sahara_hardcases::Kernel::Bvh2));
    assert!(k.contains(&sahara_hardcases::Kernel::Bvh8(
        sahara_traverse::Backend::Portable
    )));
    assert!(k.contains(&sahara_hardcases::Kernel::Bvh4(
        sahara_traverse::Backend::Portable
    )));
}

#[test]
fn fast_cases_cover_every_category_but_huge() {
    let all = cases(Level::Fast);
    for c in [
        Category::Watertight,
        Category::BadRays,
        Category::BadGeometry,
        Category::NonFinite,
        Category::Procedural,
        Category::FlatFloors,
    ] {
        assert!(all.iter().any(|x| x.category == c), "{c:?}");
    }
    assert!(all.iter().all(|x| x.category != Category::Huge));
    let mut names: Vec<&str> = all.iter().map(|c| c.name.as_str()).collect();
    names.sort_unstable();
    names.dedup();
    assert_eq!(names.len(), all.len(), "case names are unique");
}
