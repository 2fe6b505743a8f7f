//! `cargo xtask hardcases [--full]`: every hard case of `sahara-hardcases` against every
//! registered builder and every traversal kernel, a table case × builder/kernel, the list of
//! failures, and the bad-ray batch timing (ratios to a valid batch, measured, not asserted).

use std::path::PathBuf;
use std::time::{Duration, Instant};

use anyhow::Context;
use sahara_hardcases::{
    cases, kernels, report, run_case_with, timing, Level, Options, Outcome, KNOWN_BUGS,
};

/// Options of `cargo xtask hardcases`.
#[derive(clap::Args)]
pub struct Args {
    /// Run every case (meshes up to 10^6 triangles, more rays, more than 2^24 triangles);
    /// without it, the fast subset that CI runs.
    #[arg(long)]
    pub full: bool,
    /// Only cases whose name contains one of these strings (comma-separated).
    #[arg(long, value_delimiter = ',')]
    pub cases: Vec<String>,
    /// Only these builders (comma-separated registry names; default: every builder).
    #[arg(long, value_delimiter = ',')]
    pub builders: Vec<String>,
    /// Seconds one builder may take on one case (build, rebuilds, validation, every kernel)
    /// before it is reported as a timeout [default: 120, or 1800 with --full].
    #[arg(long)]
    pub timeout: Option<u64>,
    /// Skip the determinism rebuilds (1 and 2 threads, repeated run).
    #[arg(long)]
    pub no_determinism: bool,
    /// Skip the bad-ray batch timing.
    #[arg(long)]
    pub no_timing: bool,
    /// Rays per batch in the bad-ray timing.
    #[arg(long, default_value_t = 20_000)]
    pub timing_rays: usize,
    /// Builder of the tree the bad-ray timing traces.
    #[arg(long, default_value = "sweep")]
    pub timing_builder: String,
    /// Also write every outcome and timing as JSON to this file.
    #[arg(long)]
    pub json: Option<PathBuf>,
    /// No progress lines on stderr.
    #[arg(long)]
    pub quiet: bool,
}

/// Runs the suite and prints the tables; fails when a check failed (known bugs listed in
/// `sahara_hardcases::KNOWN_BUGS` are reported but do not fail the run).
pub fn run(a: Args) -> anyhow::Result<()> {
    let level = if a.full { Level::Full } else { Level::Fast };
    let start = Instant::now();
    let mut builders = sahara_builders::registry::entries();
    if !a.builders.is_empty() {
        for b in &a.builders {
            anyhow::ensure!(
                builders.iter().any(|e| e.name == b),
                "unknown builder {b:?} (known: {})",
                sahara_builders::registry::names().join(", ")
            );
        }
        builders.retain(|e| a.builders.iter().any(|b| b == e.name));
    }
    let kernels = kernels();
    let slow_builders = if a.full {
        calibrate(&builders, a.quiet)?
    } else {
        Vec::new()
    };
    let opts = Options {
        timeout: Duration::from_secs(a.timeout.unwrap_or(if a.full { 1800 } else { 120 })),
        determinism: !a.no_determinism,
        verbose: !a.quiet,
        slow_builders,
        large_input: 10_000,
        // The exhaustive builder needs minutes for 2000 clustered triangles.
        small_input_limit: 1000,
    };
    println!(
        "hard cases ({:?}): {} builders, kernels {}, {} rayon threads",
        level,
        builders.len(),
        kernels
            .iter()
            .map(|k| k.name())
            .collect::<Vec<_>>()
            .join(" "),
        rayon::current_num_threads()
    );
    let t = Instant::now();
    let mut all = cases(level);
    if !a.cases.is_empty() {
        all.retain(|c| a.cases.iter().any(|s| c.name.contains(s.as_str())));
    }
    anyhow::ensure!(!all.is_empty(), "no case matches {:?}", a.cases);
    if !a.quiet {
        eprintln!(
            "generated {} cases in {:.1} s",
            all.len(),
            t.elapsed().as_secs_f64()
        );
    }

    let mut outcomes: Vec<Outcome> = Vec::new();
    let mut case_rows = Vec::new();
    while !all.is_empty() {
        // Free each case's scene once it has run (the 2^24-triangle one is large).
        let case = all.remove(0);
        let t = Instant::now();
        let out = run_case_with(&case, &builders, &kernels, &opts);
        let secs = t.elapsed().as_secs_f64();
        let bad = out.iter().filter(|o| o.is_regression()).count();
        case_rows.push(format!(
            "{:<48} {:>10} {:>7} {:>8.1} s  {}",
            case.name,
            case.triangle_count(),
            case.rays.len(),
            secs,
            if bad == 0 {
                "ok".to_string()
            } else {
                format!("{bad} failed")
            }
        ));
        outcomes.extend(out);
    }

    println!();
    println!(
        "{:<48} {:>10} {:>7} {:>10}",
        "case", "triangles", "rays", "time"
    );
    for r in &case_rows {
        println!("{r}");
    }
    println!();
    println!("== case × builder (each cell: the build checks and every kernel on its tree)");
    print!("{}", report::builder_table(&outcomes));
    println!();
    println!("== case × kernel (over every builder)");
    print!("{}", report::kernel_table(&outcomes));

    let timings = if a.no_timing {
        Vec::new()
    } else {
        let t = Instant::now();
        let tm = timing::bad_ray_timing(&kernels, &a.timing_builder, a.timing_rays, 5);
        println!();
        println!(
            "== bad-ray batches: time relative to a valid batch ({} rays, closest hit, one thread, best of 5, `{}` tree of sphere_in_box; measured in {:.1} s; the issue's bound is 2x)",
            a.timing_rays,
            a.timing_builder,
            t.elapsed().as_secs_f64()
        );
        print!("{}", timing::timing_table(&tm));
        tm
    };

    let fails = report::failures(&outcomes);
    if !fails.is_empty() {
        println!();
        println!("== failures");
        print!("{fails}");
    }
    let s = report::summarize(&outcomes);
    if s.known_bugs > 0 || !timings.is_empty() {
        println!();
        println!("== known bugs (routed to their crates)");
        for b in KNOWN_BUGS {
            println!("{}: {}", b.id, b.description);
        }
    }
    println!();
    println!(
        "{} passed, {} failed, {} known bugs, {} skipped in {:.1} s",
        s.passed,
        s.failed,
        s.known_bugs,
        s.skipped,
        start.elapsed().as_secs_f64()
    );
    if let Some(path) = &a.json {
        let json = serde_json::json!({
            "level": level,
            "outcomes": outcomes,
            "timing": timings,
        });
        std::fs::write(path, serde_json::to_string_pretty(&json)?)
            .with_context(|| format!("writing {}", path.display()))?;
    }
    anyhow::ensure!(s.failed == 0, "{} hard-case checks failed", s.failed);
    Ok(())
}

/// Builds `soup` with 20 000 triangles with each builder (not `small_inputs_only`); those that
/// take more than a second are skipped on inputs above 10 000 triangles in `--full` runs
/// (they would take hours on the million-triangle meshes; the fast level covers them).
fn calibrate(
    builders: &[sahara_builders::registry::Entry],
    quiet: bool,
) -> anyhow::Result<Vec<String>> {
    let tris = sahara_scene::soup(20_000, 1).triangles();
    let input = sahara_builders::BuildInput::new(&tris, sahara_builders::CostModel::default())?;
    let mut slow = Vec::new();
    for e in builders.iter().filter(|e| !e.small_inputs_only) {
        let t = Instant::now();
        let _ = sahara_hardcases::catch_quiet(|| (e.make)().build(&input));
        let secs = t.elapsed().as_secs_f64();
        if !quiet {
            eprintln!(
                "calibration: {:<16} {secs:>7.2} s for 20 000 triangles",
                e.name
            );
        }
        if secs > 1.0 {
            slow.push(e.name.to_string());
        }
    }
    if !slow.is_empty() {
        println!(
            "slow builders (over 1 s for 20 000 triangles), skipped above 10 000 triangles: {}",
            slow.join(", ")
        );
    }
    Ok(slow)
}
