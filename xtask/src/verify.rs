//! `cargo xtask verify`: the heavy equality suites and the checks the default test suite
//! ignores, run with `SAHARA_VERIFY_ALL=1`.

/// Runs the equality suites with `SAHARA_VERIFY_ALL=1`: `tree_hashes` of sahara-builders
/// (every registered builder's tree on every shared scene file against its recorded
/// fingerprint), `builders` of sahara-traverse (every
/// builder on every scene against brute force) and `layouts_shared_scenes` of sahara-trace
/// (every layout and backend against the scalar reference, ray by ray, at 1024×768); then the
/// heavy checks that are `#[ignore]`d in the default test suite because they take seconds to
/// minutes each: `sweep` of sahara-builders (the sweep tree of a 1M-triangle soup against its
/// cost-only twin), `procedural` of sahara-scene (every generator at up to 10^6 triangles) and
/// `shared_scenes` of sahara-scene (every shared scene's triangle count and checksum).
pub fn run() -> anyhow::Result<()> {
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
    /// Every suite `verify` runs exists, so a renamed test file cannot drop out of it silently.
    #[test]
    fn verify_suites_exist() {
        crate::util::assert_suites_exist(super::VERIFY_SUITES);
    }
}
