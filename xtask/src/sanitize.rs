//! `cargo xtask sanitize`: the test suites of the crates with unsafe code under AddressSanitizer
//! (and ThreadSanitizer with `--sanitizers address,thread`), on nightly with the standard
//! library rebuilt instrumented (`-Zbuild-std`). The suites compare every backend the CPU runs
//! (AVX-512 included, which Miri cannot run) with brute force, so one run per sanitizer covers
//! them all.
//! docs/robustness.md records what ran where.

use anyhow::{ensure, Context};
use std::process::Command;

/// Options of `cargo xtask sanitize`.
#[derive(clap::Args)]
pub struct Args {
    /// Which sanitizers: `address`, `thread` or both (comma-separated).
    #[arg(long, default_value = "address")]
    sanitizers: String,
    /// Only this package (`--only sahara` is the façade alone), or, when no package has this
    /// exact name, the packages whose name contains the text (`--only traverse`).
    #[arg(long)]
    only: Option<String>,
    /// The short form CI runs: AddressSanitizer over the unit tests of `sahara-traverse` and
    /// `sahara-builders` and their Miri suites, with the machine's one (stable) toolchain
    /// (`RUSTC_BOOTSTRAP=1` admits `-Zsanitizer`) and the standard library as shipped, not
    /// rebuilt instrumented: what CI machines, which cannot fetch a nightly, can run.
    #[arg(long, conflicts_with_all = ["sanitizers", "only"])]
    short: bool,
    /// Extra arguments for the test binaries (e.g. a test name filter).
    #[arg(last = true)]
    test_args: Vec<String>,
}

/// ASan's options: leaks are not what this looks for (rayon's global pool lives to exit).
const ASAN_OPTIONS: &str = "detect_leaks=0:detect_stack_use_after_return=1:abort_on_error=1";

/// `--short`: one cargo invocation, so the instrumented dependencies are built once.
fn run_short(args: &Args) -> anyhow::Result<()> {
    let target = host_target(None)?;
    eprintln!(
        "== address sanitizer (short form, stable toolchain): sahara-traverse, sahara-builders"
    );
    let mut cmd = cargo_test(None, &target, "address", "target/sanitize-short");
    cmd.args([
        "--locked",
        "--profile",
        "test",
        "-p",
        "sahara-traverse",
        "-p",
        "sahara-builders",
        "--lib",
        "--test",
        "miri",
    ])
    .env("RUSTC_BOOTSTRAP", "1");
    let ok = run_tests(
        &mut cmd,
        &args.test_args,
        "running cargo test",
        "address sanitizer (short form)",
    )?;
    ensure!(ok, "the short AddressSanitizer run failed");
    Ok(())
}

/// `cargo [toolchain] test --target target` with the RUSTFLAGS of `sanitizer`, its own target
/// directory `target_dir` and [`ASAN_OPTIONS`].
fn cargo_test(toolchain: Option<&str>, target: &str, sanitizer: &str, target_dir: &str) -> Command {
    let mut cmd = Command::new("cargo");
    cmd.args(toolchain)
        .args(["test", "--target", target])
        .env(
            "RUSTFLAGS",
            format!("-Zsanitizer={sanitizer} -Cforce-frame-pointers=yes"),
        )
        .env("CARGO_TARGET_DIR", target_dir)
        .env("ASAN_OPTIONS", ASAN_OPTIONS);
    cmd
}

/// Runs `cmd` with `test_args` passed to the test binaries, and reports its time and status
/// as `what` (`running` is the context of a failure to start it); true when it passed.
fn run_tests(
    cmd: &mut Command,
    test_args: &[String],
    running: &'static str,
    what: &str,
) -> anyhow::Result<bool> {
    let t0 = std::time::Instant::now();
    if !test_args.is_empty() {
        cmd.arg("--").args(test_args);
    }
    let status = cmd.status().context(running)?;
    Ok(crate::util::report_status(status, t0, what))
}

/// The packages whose test suites run under the sanitizers: the ones with unsafe code and the
/// façade that calls it.
pub const SANITIZED_PACKAGES: &[&str] =
    &["sahara-traverse", "sahara-builders", "sahara-bvh", "sahara"];

/// The packages `--only` selects: the one named exactly so, else those whose name contains it
/// (every crate's name contains `sahara`, so a plain substring match would take them all).
fn selected(only: Option<&str>) -> anyhow::Result<Vec<&'static str>> {
    let Some(only) = only else {
        return Ok(SANITIZED_PACKAGES.to_vec());
    };
    if let Some(exact) = SANITIZED_PACKAGES.iter().find(|p| **p == only) {
        return Ok(vec![*exact]);
    }
    let some: Vec<_> = SANITIZED_PACKAGES
        .iter()
        .copied()
        .filter(|p| p.contains(only))
        .collect();
    ensure!(
        !some.is_empty(),
        "--only {only}: no package of {SANITIZED_PACKAGES:?} matches"
    );
    Ok(some)
}

pub fn run(args: Args) -> anyhow::Result<()> {
    if args.short {
        return run_short(&args);
    }
    let packages = selected(args.only.as_deref())?;
    let target = host_target(Some("+nightly"))?;
    let mut failed = Vec::new();
    for sanitizer in args.sanitizers.split(',').map(str::trim) {
        ensure!(
            ["address", "thread"].contains(&sanitizer),
            "unknown sanitizer `{sanitizer}` (address or thread)"
        );
        for &package in &packages {
            eprintln!("== {sanitizer} sanitizer: {package}");
            // One directory per sanitizer: the instrumented standard library is rebuilt once.
            let dir = format!("target/sanitize-{sanitizer}");
            let mut cmd = cargo_test(Some("+nightly"), &target, sanitizer, &dir);
            cmd.args(["-Zbuild-std", "-p", package, "--lib", "--tests"])
                .env("RUSTDOCFLAGS", format!("-Zsanitizer={sanitizer}"))
                .env("TSAN_OPTIONS", "halt_on_error=1");
            let what = format!("{sanitizer}: {package}");
            if !run_tests(
                &mut cmd,
                &args.test_args,
                "running cargo +nightly test",
                &what,
            )? {
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

/// The host's target triple of `toolchain` (`None`: the default one); the sanitizers need an
/// explicit `--target`.
fn host_target(toolchain: Option<&str>) -> anyhow::Result<String> {
    let mut cmd = Command::new("rustc");
    cmd.args(toolchain).arg("-vV");
    let out = cmd.output().with_context(|| {
        format!(
            "running `rustc {} -vV` (is the toolchain installed?)",
            toolchain.unwrap_or("")
        )
    })?;
    ensure!(out.status.success(), "`rustc -vV` failed");
    String::from_utf8_lossy(&out.stdout)
        .lines()
        .find_map(|l| l.strip_prefix("host: ").map(str::to_string))
        .context("no host line in `rustc -vV`")
}

#[cfg(test)]
mod tests {
    use super::{cargo_test, selected, ASAN_OPTIONS};

    #[test]
    fn cargo_test_sets_the_sanitizer_flags() {
        let cmd = cargo_test(
            Some("+nightly"),
            "x86_64-unknown-linux-gnu",
            "thread",
            "t/s",
        );
        let args: Vec<&str> = cmd.get_args().map(|a| a.to_str().unwrap()).collect();
        assert_eq!(
            args,
            ["+nightly", "test", "--target", "x86_64-unknown-linux-gnu"]
        );
        let env = |key: &str| {
            cmd.get_envs()
                .find(|(k, _)| *k == key)
                .and_then(|(_, v)| v?.to_str())
        };
        assert_eq!(
            env("RUSTFLAGS"),
            Some("-Zsanitizer=thread -Cforce-frame-pointers=yes")
        );
        assert_eq!(env("CARGO_TARGET_DIR"), Some("t/s"));
        assert_eq!(env("ASAN_OPTIONS"), Some(ASAN_OPTIONS));
        let stable = cargo_test(None, "x", "address", "d");
        assert_eq!(stable.get_args().count(), 3);
    }

    #[test]
    fn only_takes_an_exact_name_before_a_part_of_one() {
        assert_eq!(selected(Some("sahara")).unwrap(), ["sahara"]);
        assert_eq!(
            selected(Some("sahara-builders")).unwrap(),
            ["sahara-builders"]
        );
        assert_eq!(selected(Some("traverse")).unwrap(), ["sahara-traverse"]);
        assert_eq!(selected(None).unwrap().len(), 4);
        assert!(selected(Some("geom")).is_err());
    }
}
