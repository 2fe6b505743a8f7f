//! Fuzz target `scene_bytes`: bytes as up to 15 triangles and 64 rays: every builder and every kernel against brute force.
//!
//! The check is `sahara_hardcases::fuzzing::check_scene_bytes`, which the CI test
//! `crates/hardcases/tests/files.rs` also replays on a deterministic corpus; it returns an
//! error (turned into a panic here, so libFuzzer records the input) when the code under test
//! panics or breaks a promise. Run with `cargo fuzz run scene_bytes` (nightly).
#![no_main]

use libfuzzer_sys::fuzz_target;

fuzz_target!(|data: &[u8]| {
    if let Err(e) = sahara_hardcases::fuzzing::check_scene_bytes(data) {
        panic!("scene_bytes: {e}");
    }
});
