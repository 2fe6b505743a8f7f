//! `cargo xtask package`: `cargo package` with verification for every publishable crate of
//! the workspace at once (the members without `publish = false`), so that siblings resolve
//! against each other's packaged archives (cargo 1.90 or later). Not part of the test
//! suite: it rebuilds every library crate from its archive (see `docs/facade.md`).

use std::process::Command;
use std::time::Instant;

use anyhow::{ensure, Context};

/// Options of `cargo xtask package`.
#[derive(clap::Args)]
pub struct Args {
    /// Package a work tree with uncommitted changes (while iterating; the real check runs on
    /// a committed tree).
    #[arg(long)]
    allow_dirty: bool,
    /// Only list the files of each package (`cargo package --list`), without building.
    #[arg(long)]
    list: bool,
}

/// The workspace members that may be published, in `cargo metadata` order.
pub fn publishable(cargo: &str) -> anyhow::Result<Vec<String>> {
    let out = Command::new(cargo)
        .args(["metadata", "--no-deps", "--format-version", "1"])
        .output()
        .context("running cargo metadata")?;
    ensure!(
        out.status.success(),
        "cargo metadata failed: {}",
        String::from_utf8_lossy(&out.stderr)
    );
    let meta: serde_json::Value = serde_json::from_slice(&out.stdout)?;
    let packages = meta["packages"]
        .as_array()
        .context("cargo metadata: no packages")?;
    Ok(packages
        .iter()
        // `publish = false` is `"publish": []`; publishable crates have `null`.
        .filter(|p| !p["publish"].as_array().is_some_and(|a| a.is_empty()))
        .filter_map(|p| p["name"].as_str().map(str::to_string))
        .collect())
}

/// Runs `cargo package -p …` over every publishable crate.
pub fn run(args: Args) -> anyhow::Result<()> {
    let cargo = std::env::var("CARGO").unwrap_or_else(|_| "cargo".into());
    let crates = publishable(&cargo)?;
    ensure!(!crates.is_empty(), "no publishable crate found");
    eprintln!("packaging {}", crates.join(", "));
    let mut cmd = Command::new(&cargo);
    cmd.arg("package");
    for c in &crates {
        cmd.args(["-p", c]);
    }
    if args.allow_dirty {
        cmd.arg("--allow-dirty");
    }
    if args.list {
        cmd.arg("--list");
    }
    let start = Instant::now();
    let status = cmd.status().context("running cargo package")?;
    ensure!(status.success(), "cargo package failed");
    eprintln!(
        "packaged {} crates in {:.0} s",
        crates.len(),
        start.elapsed().as_secs_f64()
    );
    Ok(())
}
