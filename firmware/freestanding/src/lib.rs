//! The DynaSlice core as a freestanding static library: `#![no_std]`, `panic = "abort"`, no
//! allocator and no libc, with the three models written by `modelgen` embedded in the image.
//!
//! `main.c` (built with `gcc -ffreestanding -nostdlib -static`, its own `_start`) calls
//! [`dynaslice_fw_transcript`] and compares the words with the host reference. This proves that
//! the core links into an environment with nothing but a C compiler's freestanding subset, and
//! that it computes there exactly what the std build computes on the host.
#![no_std]

#[path = "../../common/transcript.rs"]
mod transcript;

/// Bytes at a 64-byte aligned address: the weight section starts 64-byte aligned within the
/// file, so with this wrapper `Model::from_bytes` reads the weights in place from the image.
#[repr(C, align(64))]
struct Aligned<T: ?Sized>(T);

static MODEL_F32: &Aligned<[u8]> = &Aligned(*include_bytes!("../../generated/model_f32.dsm"));
static MODEL_F16: &Aligned<[u8]> = &Aligned(*include_bytes!("../../generated/model_f16.dsm"));
static MODEL_MOTION: &Aligned<[u8]> = &Aligned(*include_bytes!("../../generated/model_motion.dsm"));

/// Evaluates the embedded models at the common query points and writes the transcript words to
/// `out[..cap]`. Returns the number of words, or a negative code: −(1 + i) when model i was
/// refused or a query on it failed, −100 when `cap` is too small.
///
/// # Safety
/// `out` must be valid for writes of `cap` words.
#[no_mangle]
pub unsafe extern "C" fn dynaslice_fw_transcript(out: *mut u32, cap: usize) -> i32 {
    if out.is_null() {
        return -100;
    }
    // SAFETY: the caller guarantees `out` is valid for `cap` writes.
    let out = unsafe { core::slice::from_raw_parts_mut(out, cap) };
    match transcript::transcript(&[&MODEL_F32.0, &MODEL_F16.0, &MODEL_MOTION.0], out) {
        Ok(n) => n as i32,
        Err(transcript::TranscriptError::Model(i, _)) => -1 - i as i32,
        Err(transcript::TranscriptError::OutputTooShort) => -100,
    }
}

extern "C" {
    /// Provided by the C program: reports the panic and exits with status 101.
    fn dynaslice_fw_panic() -> !;
}

/// The core promises never to panic; should a panic path be reached anyway, the C side turns it
/// into a distinct exit status instead of a hang, so the link test fails loudly.
#[panic_handler]
fn panic(_: &core::panic::PanicInfo) -> ! {
    // SAFETY: a plain C function that never returns.
    unsafe { dynaslice_fw_panic() }
}
