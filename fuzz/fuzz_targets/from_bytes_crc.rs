//! Arbitrary bytes with a correct CRC trailer, so mutations of valid seeds reach every check
//! behind the CRC and, when they stay valid, evaluation (checks in src/lib.rs).
#![no_main]

libfuzzer_sys::fuzz_target!(init: dynaslice_fuzz::init("from_bytes_crc"), |data: &[u8]| {
    let mut bytes = data.to_vec();
    dynaslice_fuzz::fix_crc(&mut bytes);
    dynaslice_fuzz::check(&bytes);
});
