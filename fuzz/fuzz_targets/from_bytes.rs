//! Arbitrary bytes straight into `Model::from_bytes` (checks in src/lib.rs).
#![no_main]

libfuzzer_sys::fuzz_target!(init: dynaslice_fuzz::init("from_bytes"), |data: &[u8]| dynaslice_fuzz::check(data));
