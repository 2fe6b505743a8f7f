//! `cargo xtask`: the project's tasks (see README.md and the command-line contract in
//! `docs/command-line.md`).

// The commands, one module each, named after the command (`reinsert-rays`: `reinsert_rays`).
// None uses another (`tidy::no_command_module_uses_another`).
mod build_bench;
mod builders;
mod bvh;
mod eval;
mod hardcases;
mod measure;
mod miri;
mod oracle;
mod package;
mod reinsert_rays;
mod sanitize;
mod scaling;
mod scenes;
mod study;
mod trace;
mod verify;

// What the commands share; none of these is a command, nor uses one.
mod alloc_count;
mod engine;
mod interval;
mod tree;
mod util;

#[cfg(test)]
mod tidy;

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
    Scenes(scenes::Args),
    /// List builder names and their configurations.
    Builders,
    /// Build a BVH and report build time and tree statistics.
    Bvh(bvh::Args),
    /// Time builders (and Embree's builder, with the `embree` feature) alternating in one
    /// window: medians, spreads and ratios (docs/embree.md).
    BuildBench(build_bench::Args),
    /// Trace a ray set and report speed and work per ray.
    Trace(trace::Args),
    /// Run the evaluation matrix and write the report.
    Eval(eval::Args),
    /// Measure build time against N and fit the exponent.
    Scaling(scaling::Args),
    /// The numerical-stability suite: every builder and kernel on hard cases (fast subset by
    /// default, `--full` for everything), printed as a table.
    Hardcases(hardcases::Args),
    /// The reference kernels judged by the exact oracle on every scene file and on
    /// floor-and-wall levels at 1 to 10^4 units (primary, diffuse and AO rays, 10^5 of each).
    Oracle(oracle::Args),
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
    /// The unsafe code under Miri: the Miri suites of sahara-traverse and sahara-builders, at
    /// the baseline ISA and built with AVX2+FMA (nightly with the miri component).
    Miri(miri::Args),
    /// The test suites of the crates with unsafe code under AddressSanitizer (`--sanitizers
    /// address,thread` adds ThreadSanitizer), nightly with `-Zbuild-std`.
    Sanitize(sanitize::Args),
    /// `cargo package` with verification of every publishable crate together (takes minutes;
    /// not part of the test suite).
    Package(package::Args),
}

fn main() {
    let cli = Cli::parse();
    let result = match cli.cmd {
        Cmd::Scenes(a) => scenes::run(a),
        Cmd::Builders => builders::run(),
        Cmd::Bvh(a) => bvh::run(a),
        Cmd::BuildBench(a) => build_bench::run(a),
        Cmd::Trace(a) => trace::run(a),
        Cmd::Eval(a) => eval::run(a),
        Cmd::Scaling(a) => scaling::run(a),
        Cmd::Verify => verify::run(),
        Cmd::Hardcases(a) => hardcases::run(a),
        Cmd::Oracle(a) => oracle::run(a),
        Cmd::Study(a) => study::run(a),
        Cmd::Measure(a) => measure::run(a),
        Cmd::ReinsertRays(a) => reinsert_rays::run(a),
        Cmd::Miri(a) => miri::run(a),
        Cmd::Sanitize(a) => sanitize::run(a),
        Cmd::Package(a) => package::run(a),
    };
    if let Err(e) = result {
        eprintln!("error: {e:#}");
        std::process::exit(1);
    }
}
