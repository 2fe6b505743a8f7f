//! Fuzz target `gltf`: glTF and GLB loader (sahara_scene::parse_gltf, embedded buffers only).
//!
//! The check is `sahara_hardcases::fuzzing::check_gltf`, which the CI test
//! `crates/hardcases/tests/files.rs` also replays on a deterministic corpus; it returns an
//! error (turned into a panic here, so libFuzzer records the input) when the code under test
//! panics or breaks a promise. Run with `cargo fuzz run gltf` (nightly).
#![no_main]

use libfuzzer_sys::fuzz_target;

fuzz_target!(|data: &[u8]| {
    if let Err(e) = sahara_hardcases::fuzzing::check_gltf(data) {
        panic!("gltf: {e}");
    }
});
