//! Arbitrary bytes as a label table: `LabelTable::parse`, and an accepted table's round trip
//! through `to_text` (checks in src/readers.rs).
#![no_main]

libfuzzer_sys::fuzz_target!(init: dynaslice_fuzz::init("label_table"), |data: &[u8]| dynaslice_fuzz::readers::label_table(data));
