//! Arbitrary bytes as a NIfTI-1 label volume (plain or gzip): `nifti::read_volume`, then
//! `input::read` (checks in src/readers.rs).
#![no_main]

libfuzzer_sys::fuzz_target!(init: dynaslice_fuzz::init("nifti"), |data: &[u8]| dynaslice_fuzz::readers::nifti(data));
