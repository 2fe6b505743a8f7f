//! `cargo xtask sanitize`: the test suites of the crates with unsafe code under AddressSanitizer
//! (and ThreadSanitizer with `--thread`), on nightly with the standard library rebuilt
//! instrumented (`-Zbuild-std`). The suites compare every backend the CPU runs (AVX-512
//! included, which Miri cannot run) with brute force, so one run per sanitizer covers them all.
//! docs/robustness.md records what ran where.

use anyhow::{ensure, Context};
use std::process::Command;

/// Options of `cargo xtask sanitize`.
#[derive(clap::Args)]
pub struct Args {
    /// Which sanitizers: `address`, `thread` or both (comma-separated).
    #[arg(long, default_value = "address")]
    sanitizers: String,
    /// Only the packages whose name contains this text.
    #[arg(long)]
    only: Option<String>,
    /// Extra arguments for the test binaries (e.g. a test name filter).
    #[arg(last = true)]
    test_args: Vec<String>,
}

/// The packages whose test suites run under the sanitizers: the ones with unsafe code and the
/// façade that calls it.
pub const SANITIZED_PACKAGES: &[&str] =
    &["sahara-traverse", "sahara-builders", "sahara-bvh", "sahara"];

pub fn run(args: Args) -> anyhow::Result<()> {
    let target = host_target()?;
    let mut failed = Vec::new();
    for sanitizer in args.sanitizers.split(',').map(str::trim) {
        ensure!(
            ["address", "thread"].contains(&sanitizer),
            "unknown sanitizer `{sanitizer}` (address or thread)"
        );
        for package in SANITIZED_PACKAGES {
            if let Some(only) = &args.only {
                if !package.contains(only.as_str()) {
                    continue;
                }
            }
            eprintln!("== {sanitizer} sanitizer: {package}");
            let t0 = std::time::Instant::now();
            let mut cmd = Command::new("cargo");
            cmd.args([
                "+nightly",
                "test",
                "-Zbuild-std",
                "--target",
                &target,
                "-p",
                package,
                "--lib",
                "--tests",
            ])
            .env(
                "RUSTFLAGS",
                format!("-Zsanitizer={sanitizer} -Cforce-frame-pointers=yes"),
            )
            .env("RUSTDOCFLAGS", format!("-Zsanitizer={sanitizer}"))
            // One directory per sanitizer: the instrumented standard library is rebuilt once.
            .env("CARGO_TARGET_DIR", format!("target/sanitize-{sanitizer}"))
            // Leaks are not what this looks for (rayon's global pool lives to exit).
            .env(
                "ASAN_OPTIONS",
                "detect_leaks=0:detect_stack_use_after_return=1:abort_on_error=1",
            )
            .env("TSAN_OPTIONS", "halt_on_error=1");
            if !args.test_args.is_empty() {
                cmd.arg("--").args(&args.test_args);
            }
            let status = cmd.status().context("running cargo +nightly test")?;
            eprintln!(
                "== {sanitizer}: {package}: {} in {:.0} s",
                if status.success() { "ok" } else { "FAILED" },
                t0.elapsed().as_secs_f64()
            );
            if !status.success() {
                failed.push(format!("{package} ({sanitizer})"));
            }
        }
    }
    ensure!(
        failed.is_empty(),
        "sanitizer runs failed: {}",
        failed.join(", ")
    );
    Ok(())
}

/// The host's target triple (the sanitizers need an explicit `--target`).
fn host_target() -> anyhow::Result<String> {
    let out = Command::new("rustc")
        .args(["+nightly", "-vV"])
        .output()
        .context("running `rustc +nightly -vV` (is the nightly toolchain installed?)")?;
    ensure!(out.status.success(), "`rustc +nightly -vV` failed");
    String::from_utf8_lossy(&out.stdout)
        .lines()
        .find_map(|l| l.strip_prefix("host: ").map(str::to_string))
        .context("no host line in `rustc -vV`")
}
