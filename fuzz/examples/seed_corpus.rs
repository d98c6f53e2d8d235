//! Writes valid inputs as seeds for every fuzz target:
//! `cargo run --manifest-path fuzz/Cargo.toml --example seed_corpus -- fuzz/corpus`
//! creates `fuzz/corpus/TARGET/` for each target (the directories `cargo fuzz run TARGET`
//! reads by default), after checking that the target's reader accepts every seed.
//!
//! The seeds are those of `dynaslice_fuzz::fixtures` (see there what they vary). Each target
//! also writes its own seeds when run with `DYNASLICE_FUZZ_SEEDS=DIR`, which is how
//! `scripts/ci-fuzz.sh` gets them without building this example.

use dynaslice_fuzz::{fixtures, readers, TARGETS};
use std::path::PathBuf;

fn main() -> Result<(), fixtures::Error> {
    let root = PathBuf::from(std::env::args().nth(1).unwrap_or_else(|| "corpus".into()));
    let written = TARGETS.iter().try_for_each(|target| {
        let dir = root.join(target);
        let n = readers::write_seeds(target, &dir)?;
        println!("wrote {n} seeds to {}", dir.display());
        Ok(())
    });
    std::fs::remove_dir_all(readers::scratch_dir())?;
    written
}
