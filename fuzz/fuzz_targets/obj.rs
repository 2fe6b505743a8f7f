//! Fuzz target `obj`: OBJ loader (sahara_scene::parse_obj).
//!
//! The check is `sahara_hardcases::fuzzing::check_obj`, which the CI test
//! `crates/hardcases/tests/files.rs` also replays on a deterministic corpus; it returns an
//! error (turned into a panic here, so libFuzzer records the input) when the code under test
//! panics or breaks a promise. Run with `cargo fuzz run obj` (nightly).
#![no_main]

use libfuzzer_sys::fuzz_target;

fuzz_target!(|data: &[u8]| {
    if let Err(e) = sahara_hardcases::fuzzing::check_obj(data) {
        panic!("obj: {e}");
    }
});
