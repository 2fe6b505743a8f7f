//! `cargo xtask`: the project's tasks (see README.md and the command-line contract in
//! `docs/command-line.md`).

mod alloc_count;
mod build_bench;
mod bvh_cmd;
#[cfg(feature = "embree")]
mod embree;
#[cfg(feature = "embree")]
mod embree_tree;
mod eval;
mod hardcases;
mod measure;
#[cfg(feature = "obvhs")]
mod obvhs;
mod oracle_cmd;
mod package_cmd;
mod peers;
mod reinsert_rays;
mod scaling;
mod scenes_cmd;
mod study;
#[cfg(test)]
mod tidy;
#[cfg(feature = "tinybvh")]
mod tinybvh;
mod trace_cmd;
mod util;

use clap::{Parser, Subcommand};

/// Counts heap bytes for the build-memory figures (`alloc_count`).
#[global_allocator]
static ALLOC: alloc_count::Counting = alloc_count::Counting;

#[derive(Parser)]
#[command(name = "cargo xtask", about = "sahara project tasks")]
struct Cli {
    #[command(subcommand)]
    cmd: Cmd,
}

#[derive(Subcommand)]
enum Cmd {
    /// List every scene found: name, triangles, bounds, source.
    Scenes(scenes_cmd::Args),
    /// List builder names and their configurations.
    Builders,
    /// Build a BVH and report build time and tree statistics.
    Bvh(bvh_cmd::Args),
    /// Time builders (and Embree's builder, with the `embree` feature) alternating in one
    /// window: medians, spreads and ratios (docs/embree.md).
    BuildBench(build_bench::Args),
    /// Trace a ray set and report speed and work per ray.
    Trace(trace_cmd::Args),
    /// Run the evaluation matrix and write the report.
    Eval(eval::Args),
    /// Measure build time against N and fit the exponent.
    Scaling(scaling::Args),
    /// The numerical-stability suite: every builder and kernel on hard cases (fast subset by
    /// default, `--full` for everything), printed as a table.
    Hardcases(hardcases::Args),
    /// The reference kernels judged by the exact oracle on every scene file and on
    /// floor-and-wall levels at 1 to 10^4 units (primary, diffuse and AO rays, 10^5 of each).
    Oracle(oracle_cmd::Args),
    /// Every builder's tree on every scene file against its recorded fingerprint; every
    /// builder on every scene: validate, and traversal against brute force ray by ray;
    /// then every wide layout and backend against the scalar reference on primary, diffuse and
    /// AO rays at 1024×768 (the heavy versions of the test suite's checks), and the heavy
    /// checks the default suite ignores (takes minutes).
    Verify,
    /// The sensitivity study of the temporary-subtree builders (issue 15): one factor at a
    /// time against the sweep tree built under the same settings (`--quick`: ≤ 5 minutes).
    Study(study::Args),
    /// The measurement harnesses whose figures the documents quote: builders against sweep
    /// (`presets`, `knobs`, `dragon`, `configs`, `popov-configs`), `sbvh`, `tsah-spatial`, the
    /// single-thread kernel benchmarks (`wide-bench`, `kernels`) and the exact oracle's speed
    /// (`oracle`).
    Measure(measure::Args),
    /// Reinsertion driven by the ray-weighted cost of a training ray set, against sweep and
    /// sweep+reinsert, measured on other rays (docs/builders-frontier.md, "Beyond SAH").
    ReinsertRays(reinsert_rays::Args),
    /// `cargo package` with verification of every publishable crate together (takes minutes;
    /// not part of the test suite).
    Package(package_cmd::Args),
}

fn main() {
    let cli = Cli::parse();
    let result = match cli.cmd {
        Cmd::Scenes(a) => scenes_cmd::run(a),
        Cmd::Builders => bvh_cmd::list_builders(),
        Cmd::Bvh(a) => bvh_cmd::run(a),
        Cmd::BuildBench(a) => build_bench::run(a),
        Cmd::Trace(a) => trace_cmd::run(a),
        Cmd::Eval(a) => eval::run(a),
        Cmd::Scaling(a) => scaling::run(a),
        Cmd::Verify => verify(),
        Cmd::Hardcases(a) => hardcases::run(a),
        Cmd::Oracle(a) => oracle_cmd::run(a),
        Cmd::Study(a) => study::run(a),
        Cmd::Measure(a) => measure::run(a),
        Cmd::ReinsertRays(a) => reinsert_rays::run(a),
        Cmd::Package(a) => package_cmd::run(a),
    };
    if let Err(e) = result {
        eprintln!("error: {e:#}");
        std::process::exit(1);
    }
}

/// Runs the equality suites with `SAHARA_VERIFY_ALL=1`: `tree_hashes` of sahara-builders
/// (every registered builder's tree on every shared scene file against its recorded
/// fingerprint), `builders` of sahara-traverse (every
/// builder on every scene against brute force) and `layouts_shared_scenes` of sahara-trace
/// (every layout and backend against the scalar reference, ray by ray, at 1024×768); then the
/// heavy checks that are `#[ignore]`d in the default test suite because they take seconds to
/// minutes each: `sweep` of sahara-builders (the sweep tree of a 1M-triangle soup against its
/// cost-only twin), `procedural` of sahara-scene (every generator at up to 10^6 triangles) and
/// `shared_scenes` of sahara-scene (every shared scene's triangle count and checksum).
fn verify() -> anyhow::Result<()> {
    let cargo = std::env::var("CARGO").unwrap_or_else(|_| "cargo".into());
    let mut failed = Vec::new();
    for (package, test) in VERIFY_SUITES {
        let status = std::process::Command::new(&cargo)
            .args([
                "test",
                "--release",
                "-p",
                package,
                "--test",
                test,
                "--",
                "--nocapture",
                "--test-threads=1",
                "--include-ignored",
            ])
            .env("SAHARA_VERIFY_ALL", "1")
            .status()?;
        if !status.success() {
            failed.push(format!("{package} --test {test}"));
        }
    }
    anyhow::ensure!(
        failed.is_empty(),
        "verification failed: {}",
        failed.join(", ")
    );
    Ok(())
}

/// The test suites `verify` runs, each with its ignored (heavy) tests included.
const VERIFY_SUITES: &[(&str, &str)] = &[
    ("sahara-builders", "tree_hashes"),
    ("sahara-traverse", "builders"),
    ("sahara-trace", "layouts_shared_scenes"),
    ("sahara-builders", "sweep"),
    ("sahara-scene", "procedural"),
    ("sahara-scene", "shared_scenes"),
];

#[cfg(test)]
mod tests {
    use super::VERIFY_SUITES;

    /// Every suite `verify` runs exists, so a renamed test file cannot drop out of it silently.
    #[test]
    fn verify_suites_exist() {
        let root = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("..");
        for (package, test) in VERIFY_SUITES {
            let dir = package.strip_prefix("sahara-").expect("a sahara-* package");
            let file = root
                .join("crates")
                .join(dir)
                .join("tests")
                .join(format!("{test}.rs"));
            assert!(
                file.is_file(),
                "{package} --test {test}: no {}",
                file.display()
            );
        }
    }
}
