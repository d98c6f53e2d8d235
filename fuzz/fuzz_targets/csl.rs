//! Arbitrary bytes as a `.csl` cross-section file: `csl::parse` (checks in src/readers.rs).
#![no_main]

libfuzzer_sys::fuzz_target!(init: dynaslice_fuzz::init("csl"), |data: &[u8]| dynaslice_fuzz::readers::csl(data));
