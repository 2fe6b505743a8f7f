//! Writes the seed files of the cargo-fuzz corpus (`sahara_hardcases::corpus::seeds`) into
//! `fuzz/corpus/<target>/`: `cargo run --release -p sahara-hardcases --example
//! write_fuzz_seeds` from the repository's root. The CI replay
//! (`tests/files.rs`, `fuzz_seed_files_pass_their_checks`) runs every file found there.

fn main() -> std::io::Result<()> {
    let root = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("../../fuzz/corpus");
    let mut n = 0;
    for (target, name, data) in sahara_hardcases::corpus::seeds() {
        let dir = root.join(target.name());
        std::fs::create_dir_all(&dir)?;
        std::fs::write(dir.join(name), data)?;
        n += 1;
    }
    println!("{n} seed files written under {}", root.display());
    Ok(())
}
