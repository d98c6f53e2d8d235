//! Evaluation of DynaSlice 4D multi-class neural signed distance functions.
//!
//! A DynaSlice model is one SIREN f_θ: R³ × [t₀, t₁] → R^K with one signed-distance channel per
//! anatomical structure (paper Eq. 1, 9), or a motion model: that network g (one shape per
//! structure) read through a second SIREN u, the motion, f(x, t) = g(x_n + u(x_n, t_n), t_n)
//! ([`Model::motion`], [`Model::displacement`]). This crate reads the model file format
//! ([`format`], versions 1 and 2, documented byte by byte in `docs/model-format.md`), and
//! evaluates f, ∇ₓf, ∂f/∂t and the Eq. 11 argmin labels at world coordinates and world times
//! ([`Model`]) for both kinds.
//!
//! It is written for scanner firmware as much as for desktop viewers:
//! - `#![no_std]`, no heap: every buffer is a caller's slice, a fixed-size stack array, or a
//!   [`Scratch`] the caller places wherever it likes (a `static`, a `Box`, the stack).
//! - No panics on any input: [`Model::from_bytes`] validates every byte it relies on and returns a
//!   typed [`Error`]; evaluation checks buffer lengths and returns [`Error::BufferLength`].
//! - Bounded work per query: the cost of one point is fixed by the validated layer widths
//!   ([`Layout::macs_per_point`]), which are bounded by [`format::MAX_WIDTH`] and friends.
//!
//! With the `std` feature, batch evaluation picks AVX2 or AVX-512 kernels at run time
//! ([`cpu::Level`]), and models can be written ([`format::ModelWriter`]) and held in aligned
//! owned storage ([`ModelBytes`]), validated once ([`OwnedModel`]).
//!
//! ```
//! # #[cfg(feature = "std")] {
//! use dynaslice_core::{format::ModelWriter, Model};
//! let bytes = ModelWriter::random_siren(&[32, 32], 2, 7).to_bytes();
//! let model = Model::from_bytes(&bytes).unwrap();
//! let mut f = [0.0f32; 2];
//! model.eval([0.1, 0.2, 0.3], 0.5, &mut f).unwrap();
//! let label = model.label([0.1, 0.2, 0.3], 0.5);
//! assert!(label <= 2);
//! # }
//! ```
#![no_std]
#![forbid(unsafe_op_in_unsafe_fn)]
#![warn(missing_docs)]

#[cfg(feature = "std")]
extern crate std;

mod class_record;
pub mod cpu;
mod crc32;
pub mod domain;
mod error;
mod eval;
pub mod format;
mod kernel;
mod label;
mod layout;
mod model;
#[cfg(feature = "std")]
mod model_bytes;
pub mod sine;

pub use class_record::ClassInfo;
pub use crc32::crc32;
pub use domain::Domain;
pub use error::Error;
pub use eval::Scratch;
pub use label::{argmin_label, UNDEFINED_LABEL};
pub use layout::Layout;
pub use model::{Model, Siren, Weights};
#[cfg(feature = "std")]
pub use model_bytes::{ModelBytes, OwnedModel};

/// Name of the batch kernels this CPU gets ("avx512", "avx2" or "portable").
pub fn kernel_name() -> &'static str {
    kernel::best().name
}
