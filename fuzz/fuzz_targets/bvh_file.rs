//! Fuzz target `bvh_file`: BVH file loader (sahara_bvh::Bvh::load), then validation and traversal of what loads.
//!
//! The check is `sahara_hardcases::fuzzing::check_bvh_file`, which the CI test
//! `crates/hardcases/tests/files.rs` also replays on a deterministic corpus; it returns an
//! error (turned into a panic here, so libFuzzer records the input) when the code under test
//! panics or breaks a promise. Run with `cargo fuzz run bvh_file` (nightly).
#![no_main]

use libfuzzer_sys::fuzz_target;

fuzz_target!(|data: &[u8]| {
    if let Err(e) = sahara_hardcases::fuzzing::check_bvh_file(data) {
        panic!("bvh_file: {e}");
    }
});
