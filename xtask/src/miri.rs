//! `cargo xtask miri`: the unsafe code under Miri (issue 46; docs/robustness.md lists what runs,
//! every `cfg(miri)` difference and what covers the paths Miri cannot run).
//!
//! Each suite runs twice: once at the target's baseline (SSE2, so the portable and SSE2
//! kernels), once built with `-C target-feature=+avx2,+fma` (Miri then reports AVX2 and FMA as
//! present, so runtime dispatch takes the AVX2 kernels and the AVX2 spatial binning). Miri
//! cannot run AVX-512 intrinsics nor `madvise`; `cargo xtask sanitize` covers AVX-512 on a
//! machine that has it, the ordinary test suite covers `madvise`.

use anyhow::{ensure, Context};
use std::process::Command;

/// Options of `cargo xtask miri`.
#[derive(clap::Args)]
pub struct Args {
    /// Only the baseline build (skip the AVX2+FMA pass).
    #[arg(long)]
    baseline_only: bool,
    /// Run only the suites whose test file contains this text (e.g. `traverse`).
    #[arg(long)]
    only: Option<String>,
}

/// The suites Miri runs: `(package, test file)`. Each is written for Miri: small inputs, with
/// the parallel and huge-page thresholds lowered under `cfg(miri)` so they are still taken.
pub const MIRI_SUITES: &[(&str, &str)] =
    &[("sahara-traverse", "miri"), ("sahara-builders", "miri")];

/// Miri's flags. Tree Borrows, not Stacked Borrows: rayon's crossbeam-epoch is known not to
/// pass Stacked Borrows (crossbeam-rs/crossbeam#545, #878) and runs its own Miri CI under Tree
/// Borrows (crossbeam-rs/crossbeam#996); under Stacked Borrows the first parallel test stops in
/// `crossbeam_epoch::internal::Local::element_of`, before any sahara code is judged.
/// Permissive provenance for the same crate's integer-to-pointer casts (a warning otherwise);
/// isolation off because the suites read the environment and rayon the clock; leaks ignored
/// because rayon's global pool keeps its threads until the process exits (Miri otherwise
/// fails a passing run with "the main thread terminated without waiting for all remaining
/// threads").
const MIRIFLAGS: &str = "-Zmiri-tree-borrows -Zmiri-permissive-provenance \
                         -Zmiri-disable-isolation -Zmiri-ignore-leaks";

/// The two builds every suite runs under: a name and the extra `RUSTFLAGS`.
const BUILDS: &[(&str, &str)] = &[
    ("baseline (SSE2)", ""),
    ("AVX2+FMA", "-C target-feature=+avx2,+fma"),
];

pub fn run(args: Args) -> anyhow::Result<()> {
    let version = Command::new("cargo")
        .args(["+nightly", "miri", "--version"])
        .output()
        .context("running `cargo +nightly miri --version`")?;
    ensure!(
        version.status.success(),
        "Miri is not installed: `rustup toolchain install nightly --component miri rust-src`"
    );
    let mut failed = Vec::new();
    let builds = if args.baseline_only {
        &BUILDS[..1]
    } else {
        BUILDS
    };
    for (build, flags) in builds {
        for (package, test) in MIRI_SUITES {
            if let Some(only) = &args.only {
                if !package.contains(only.as_str()) && !test.contains(only.as_str()) {
                    continue;
                }
            }
            eprintln!("== miri: {package} --test {test}, {build}");
            let t0 = std::time::Instant::now();
            // Miri keeps its own target directory per RUSTFLAGS, so the two builds do not
            // rebuild each other's dependencies.
            let status = Command::new("cargo")
                .args(["+nightly", "miri", "test", "-p", package, "--test", test])
                .env("RUSTFLAGS", flags)
                .env("MIRIFLAGS", MIRIFLAGS)
                .env(
                    "CARGO_TARGET_DIR",
                    format!(
                        "target/miri-{}",
                        if flags.is_empty() { "base" } else { "avx2" }
                    ),
                )
                .status()
                .context("running cargo miri")?;
            if !crate::util::report_status(status, t0, &format!("{package} --test {test}, {build}"))
            {
                failed.push(format!("{package} --test {test} ({build})"));
            }
        }
    }
    ensure!(failed.is_empty(), "Miri failed: {}", failed.join(", "));
    Ok(())
}

#[cfg(test)]
mod tests {
    /// Every suite `miri` runs exists, so a renamed test file cannot drop out of it silently.
    #[test]
    fn miri_suites_exist() {
        crate::util::assert_suites_exist(super::MIRI_SUITES);
    }
}
