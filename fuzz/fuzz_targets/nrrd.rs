//! Arbitrary bytes as an NRRD label map or 3D Slicer segmentation: `nrrd::read_volume`, then
//! `input::read` (checks in src/readers.rs).
#![no_main]

libfuzzer_sys::fuzz_target!(init: dynaslice_fuzz::init("nrrd"), |data: &[u8]| dynaslice_fuzz::readers::nrrd(data));
