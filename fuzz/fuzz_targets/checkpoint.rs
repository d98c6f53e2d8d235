//! A mode byte and arbitrary bytes as a training checkpoint: `Checkpoint::load` (the mode and
//! the checks in src/readers.rs).
#![no_main]

libfuzzer_sys::fuzz_target!(init: dynaslice_fuzz::init("checkpoint"), |data: &[u8]| dynaslice_fuzz::readers::checkpoint(data));
