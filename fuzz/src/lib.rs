//! The checks of every fuzz target (see docs/robustness.md, "Fuzzing").
//!
//! The model-file targets (`from_bytes`, `from_bytes_crc`) use [`check`] and [`fix_crc`] below;
//! the reader targets use [`readers`], which feeds the input to one reader (through a scratch
//! file where the reader takes a path) and checks what an accepted input must satisfy.
//! [`fixtures`] builds the valid inputs the seeds and the manifest sandbox are made of.
//!
//! What the model-file targets check on every input (see docs/model-format.md, "Robustness"):
//!
//! 1. `Model::from_bytes` returns, without panicking or touching memory outside the input
//!    (AddressSanitizer, which `cargo fuzz` enables, turns any stray read into a crash).
//! 2. An accepted input is canonical: re-writing the model it decodes to gives back exactly the
//!    input bytes. The format leaves no byte free (offsets are implied, padding must be zero), so
//!    any accepted file that does not round-trip is a validation hole.
//! 3. Every query of an accepted model succeeds: single points (f, ∇f, ∂f/∂t, label) and every
//!    batch form, including empty batches and batches longer than one block. Values are not
//!    checked: a hostile but finite model may overflow to ±∞ and NaN, which is allowed.

#![warn(missing_docs)]

pub mod fixtures;
pub mod readers;

/// Every fuzz target, in the order `scripts/ci-fuzz.sh` runs them.
pub const TARGETS: [&str; 10] = [
    "from_bytes_crc",
    "from_bytes",
    "nifti",
    "nrrd",
    "rtstruct",
    "csl",
    "native_json",
    "manifest",
    "label_table",
    "checkpoint",
];

/// Each target's initialisation: when `DYNASLICE_FUZZ_SEEDS` names a folder, writes the
/// target's seeds there ([`readers::write_seeds`]) before libFuzzer reads its corpus, so a
/// run needs no separate seed build (`scripts/ci-fuzz.sh` passes the corpus folder). A seed
/// the reader refuses stops the run.
pub fn init(target: &str) {
    if target == "rtstruct" {
        allow_dicom_rs_panics();
    }
    if let Some(dir) = std::env::var_os("DYNASLICE_FUZZ_SEEDS") {
        match readers::write_seeds(target, std::path::Path::new(&dir)) {
            Ok(n) => eprintln!("{target}: {n} seeds written to {}", dir.to_string_lossy()),
            Err(e) => panic!("{target}: cannot write the seeds: {e}"),
        }
    }
}

/// dicom-rs asserts some structural invariants with panics, which `rtstruct::read` turns into
/// errors (`catch_unwind`); libFuzzer's panic hook would abort on them before the unwinding
/// reaches it. Panics raised inside the dicom-rs crates are therefore let through to be caught;
/// every other panic still aborts, as a crash.
fn allow_dicom_rs_panics() {
    let abort_hook = std::panic::take_hook();
    std::panic::set_hook(Box::new(move |info| {
        let in_dicom_rs = info
            .location()
            .is_some_and(|l| l.file().contains("/dicom-"));
        if !in_dicom_rs {
            abort_hook(info);
        }
    }));
}

use dynaslice_core::format::ModelWriter;
use dynaslice_core::{crc32, Model, ModelBytes, Scratch, UNDEFINED_LABEL};
use std::cell::RefCell;

thread_local! {
    /// One batch scratch (≈ 330 KiB) for the whole run rather than one per input: allocating
    /// and zeroing it each time would dominate the execution rate.
    static SCRATCH: RefCell<Box<Scratch>> = RefCell::new(Scratch::boxed());
}

/// Rewrites the last 4 bytes as the CRC-32 of the bytes before them.
pub fn fix_crc(bytes: &mut [u8]) {
    if let Some(body_len) = bytes.len().checked_sub(4) {
        let crc = crc32(&bytes[..body_len]);
        bytes[body_len..].copy_from_slice(&crc.to_le_bytes());
    }
}

/// Runs checks 1–3 on `bytes`, copied to aligned storage first: libFuzzer's buffers are heap
/// copies with no alignment promise, and `from_bytes` rightly refuses misaligned weights, which
/// would hide every deeper check behind `Error::Misaligned`.
pub fn check(bytes: &[u8]) {
    let aligned = ModelBytes::copy_from(bytes);
    let Ok(model) = aligned.model() else {
        return;
    };
    let rewritten = ModelWriter::from_model(&model).try_to_bytes();
    assert!(
        rewritten.as_deref() == Ok(bytes),
        "accepted a file that is not the canonical encoding of its model"
    );
    query_everything(&model);
}

fn query_everything(model: &Model) {
    let k = model.num_classes();
    let points = [
        ([0.0, 0.0, 0.0], 0.0),
        ([0.3, -0.7, 0.9], 0.25),
        ([-1.0, 1.0, -1.0], 1.0),
        ([1e30, -1e30, 0.0], -1e30),
        ([f32::NAN, 0.0, f32::INFINITY], 0.5),
    ];
    let (mut f, mut g, mut d) = (vec![0.0; k], vec![[0.0; 3]; k], vec![0.0; k]);
    for &(x, t) in &points {
        model.eval(x, t, &mut f).expect("eval");
        model.eval_grad(x, t, &mut f, &mut g).expect("eval_grad");
        model
            .eval_jacobian(x, t, &mut f, &mut g, &mut d)
            .expect("eval_jacobian");
        let label = model.label(x, t);
        assert!(label as usize <= k || label == UNDEFINED_LABEL);
        model.displacement(x, t).expect("displacement");
    }
    SCRATCH.with_borrow_mut(|scratch| {
        for n in [0, 1, 13] {
            let xyz: Vec<[f32; 3]> = (0..n).map(|i| points[i % points.len()].0).collect();
            let t: Vec<f32> = (0..n).map(|i| points[i % points.len()].1).collect();
            let (mut f, mut g, mut d) = (vec![0.0; n * k], vec![[0.0; 3]; n * k], vec![0.0; n * k]);
            let mut labels = vec![0u32; n];
            model
                .eval_batch(scratch, &xyz, &t, &mut f)
                .expect("eval_batch");
            model
                .eval_jacobian_batch(scratch, &xyz, &t, &mut f, &mut g, &mut d)
                .expect("eval_jacobian_batch");
            model
                .label_batch(scratch, &xyz, &t, &mut labels)
                .expect("label_batch");
            let mut u = vec![[0.0; 3]; n];
            model
                .displacement_batch(scratch, &xyz, &t, &mut u)
                .expect("displacement_batch");
            assert!(labels
                .iter()
                .all(|&l| l as usize <= k || l == UNDEFINED_LABEL));
        }
    });
}
