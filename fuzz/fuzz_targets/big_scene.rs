//! Fuzz target `big_scene`: a few bytes expanded into a scene of up to 150 000 triangles (a generator, a size past the parallel and huge-page thresholds, a builder, a seed, a scale) plus adversarial edits and rays: the builder, every kernel at both precisions against brute force, the exact oracle, refit, instances and a mutated saved file.
//!
//! The check is `sahara_hardcases::expand::check_big_scene`, which the CI test
//! `crates/hardcases/tests/files.rs` also replays on the saved corpus; it returns an error
//! (turned into a panic here, so libFuzzer records the input) when the code under test panics
//! or breaks a promise. Run with `cargo xtask fuzz big_scene` or `cargo fuzz run big_scene`
//! (nightly).
#![no_main]

use libfuzzer_sys::fuzz_target;

fuzz_target!(|data: &[u8]| {
    if let Err(e) = sahara_hardcases::expand::check_big_scene(data) {
        panic!("big_scene: {e}");
    }
});
