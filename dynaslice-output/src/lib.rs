//! Output files as users' tools expect them, the same from the command line and from Python:
//!
//! - [`Plan`] checks every output of a run before any work starts (the right extension, never
//!   an input, never the same file twice, never an existing file unless forced) and claims
//!   each for the run, so two runs on one output cannot mix;
//! - [`write_via`] and [`write_atomically`] write each file under a unique temporary name and
//!   rename it into place when complete, with the mode a plain `File::create` gives
//!   ([`atomic`]);
//! - [`OutputSet`] writes an output of several files all or nothing ([`set`]);
//! - [`cleanup`] lists what a run made only for its duration, for a signal handler to remove.

#![warn(missing_docs)]

pub mod atomic;
pub mod cleanup;
pub mod folder;
pub mod plan;
pub mod set;

pub use atomic::{
    claim, create_temporary, lock_path, persist, remove_stale_temporaries, write_atomically,
    write_via, Claim,
};
pub use folder::{prepare_owned_folder, OwnedFolder};
pub use plan::{Kind, Plan};
pub use set::OutputSet;
