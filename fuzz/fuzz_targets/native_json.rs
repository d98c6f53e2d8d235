//! Arbitrary bytes as a native JSON sequence: `native::from_json`, and an accepted document's
//! round trip (checks in src/readers.rs).
#![no_main]

libfuzzer_sys::fuzz_target!(init: dynaslice_fuzz::init("native_json"), |data: &[u8]| dynaslice_fuzz::readers::native_json(data));
