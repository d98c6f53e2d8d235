//! Arbitrary bytes as a sequence manifest: `manifest::parse`, and `input::read` when it lists
//! only the sandbox's files (checks in src/readers.rs).
#![no_main]

libfuzzer_sys::fuzz_target!(init: dynaslice_fuzz::init("manifest"), |data: &[u8]| dynaslice_fuzz::readers::manifest(data));
