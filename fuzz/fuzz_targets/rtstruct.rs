//! Arbitrary bytes as a DICOM RT Structure Set: `rtstruct::read`, both absence modes (checks in
//! src/readers.rs).
#![no_main]

libfuzzer_sys::fuzz_target!(init: dynaslice_fuzz::init("rtstruct"), |data: &[u8]| dynaslice_fuzz::readers::rtstruct(data));
