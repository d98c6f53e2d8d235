//! DynaSlice on a Cortex-M4F: an example firmware and a measurement rig (docs/firmware.md).
//!
//! Runs on QEMU's `mps2-an386` board (`cargo run --release`, see .cargo/config.toml) and prints,
//! over semihosting:
//! - `T 0x…` lines: the transcript of `firmware/common/transcript.rs` for the two embedded models,
//!   which scripts/ci-nostd.sh compares with the host's std-build reference word for word;
//! - `stack NAME BYTES` lines: the deepest stack each API call reached, measured by painting;
//! - `batch` and `done` lines; then it exits through semihosting with status 0, or 1 on any
//!   failure, panic or hard fault (so a hang or a crash can never pass for success).
//!
//! With `--features baseline` the same image is built without any DynaSlice code or data, to
//! measure the core's flash footprint by difference.
#![no_std]
#![no_main]

use cortex_m_rt::{entry, exception, ExceptionFrame};
use cortex_m_semihosting::{debug, hprintln};

#[cfg(not(feature = "baseline"))]
#[path = "../../common/transcript.rs"]
mod transcript;

#[entry]
fn main() -> ! {
    #[cfg(not(feature = "baseline"))]
    let ok = rig::run();
    #[cfg(feature = "baseline")]
    let ok = {
        // The same semihosting and integer formatting as the full image, so that the size
        // difference is the core's (plus the rig's own few hundred bytes).
        hprintln!("baseline {:#010x}", cortex_m::register::msp::read());
        true
    };
    hprintln!("done");
    debug::exit(if ok {
        debug::EXIT_SUCCESS
    } else {
        debug::EXIT_FAILURE
    });
    // Only reached when a debugger resumes after the exit request.
    loop {
        cortex_m::asm::wfi();
    }
}

#[cfg(not(feature = "baseline"))]
mod rig {
    use super::transcript;
    use core::ptr::{addr_of, addr_of_mut};
    use cortex_m_semihosting::hprintln;
    use dynaslice_core::format::MAX_CLASSES;
    use dynaslice_core::{Model, Scratch};

    /// Bytes at a 64-byte aligned address, so `Model::from_bytes` reads the weights in place
    /// from flash (the weight section is 64-byte aligned within the file).
    #[repr(C, align(64))]
    struct Aligned<T: ?Sized>(T);

    static MODEL_F32: &Aligned<[u8]> = &Aligned(*include_bytes!("../../generated/model_f32.dsm"));
    static MODEL_F16: &Aligned<[u8]> = &Aligned(*include_bytes!("../../generated/model_f16.dsm"));
    static MODEL_MOTION: &Aligned<[u8]> =
        &Aligned(*include_bytes!("../../generated/model_motion.dsm"));

    /// Number of classes of the embedded models (checked at run time).
    const K: usize = 3;
    const WORDS: usize = 3 * transcript::words_per_model(K);

    /// The batch functions' working memory (≈ 330 KiB): far too big for a stack, so it lives in
    /// .bss, as the core's documentation recommends for firmware.
    static mut SCRATCH: Scratch = Scratch::new();
    static mut WORDS_OUT: [u32; WORDS] = [0; WORDS];

    /// Pattern painted below the stack pointer before a measured call.
    const PAINT: u32 = 0x5EED_C0DE;
    /// How far below the stack pointer the painting reaches (the measurement's ceiling).
    const WINDOW: usize = 256 * 1024;
    /// Left unpainted right below the measuring function's own stack pointer, for its own use
    /// while it paints (it is a leaf loop; 256 bytes is ample).
    const MARGIN: usize = 256;

    extern "C" {
        /// End of .bss/.uninit, from cortex-m-rt's link.x: the stack must never be painted
        /// below it.
        static __sheap: u32;
    }

    /// The deepest stack `f` reaches below this function's stack pointer, in bytes: paints the
    /// region below with [`PAINT`], runs `f`, and finds the lowest word that changed. Includes
    /// the few bytes of the `dyn FnMut` call itself; a word that happens to be written with the
    /// paint value would be missed, which is why the pattern is not 0 or a small float.
    #[inline(never)]
    fn stack_used(f: &mut dyn FnMut()) -> usize {
        let sp = cortex_m::register::msp::read() as usize;
        // Taking the address of an extern static reads nothing, so needs no `unsafe`.
        let heap_start = addr_of!(__sheap) as usize;
        let bottom = sp.saturating_sub(WINDOW).max(heap_start) & !3;
        let top = (sp - MARGIN) & !3;
        let mut p = bottom;
        while p < top {
            // SAFETY: [bottom, top) lies between the end of .bss and the live part of the stack
            // (below this function's frame, minus a margin), memory nothing else uses now.
            unsafe { core::ptr::write_volatile(p as *mut u32, PAINT) };
            p += 4;
        }
        f();
        let mut lowest = top;
        let mut p = bottom;
        while p < top {
            // SAFETY: as above; `f` has returned, so this is unused stack again.
            if unsafe { core::ptr::read_volatile(p as *const u32) } != PAINT {
                lowest = p;
                break;
            }
            p += 4;
        }
        sp - lowest
    }

    /// Runs everything; false when any check failed (each failure is printed).
    pub fn run() -> bool {
        // SAFETY: single-threaded firmware without interrupt handlers touching these, and each
        // `&mut` is taken exactly once, here.
        let (scratch, words) =
            unsafe { (&mut *addr_of_mut!(SCRATCH), &mut *addr_of_mut!(WORDS_OUT)) };
        let models: [&[u8]; 3] = [&MODEL_F32.0, &MODEL_F16.0, &MODEL_MOTION.0];

        // 1. The transcript, for the host to compare bit for bit.
        let mut result = Ok(0);
        let transcript_stack = stack_used(&mut || {
            result = transcript::transcript(&models, words);
        });
        match result {
            Ok(n) if n == WORDS => {
                for w in words.iter() {
                    hprintln!("T {:#010x}", w);
                }
            }
            Ok(n) => {
                hprintln!("FAIL transcript: {} words, expected {}", n, WORDS);
                return false;
            }
            Err(transcript::TranscriptError::Model(i, e)) => {
                hprintln!("FAIL transcript: model {}: {}", i, e);
                return false;
            }
            Err(transcript::TranscriptError::OutputTooShort) => {
                hprintln!("FAIL transcript: output too short");
                return false;
            }
        }

        // 2. Stack of each API call on its own.
        let model = match Model::from_bytes(models[0]) {
            Ok(m) if m.num_classes() == K => m,
            _ => {
                hprintln!("FAIL: the embedded f32 model");
                return false;
            }
        };
        let (x, t) = transcript::QUERIES[0];
        let mut f = [0.0f32; MAX_CLASSES];
        let mut grad = [[0.0f32; 3]; MAX_CLASSES];
        let mut dfdt = [0.0f32; MAX_CLASSES];
        let mut failed = false;
        let mut check = |what: &str, r: Result<(), dynaslice_core::Error>| {
            if let Err(e) = r {
                hprintln!("FAIL {}: {}", what, e);
                failed = true;
            }
        };
        let mut loaded = Ok(());
        let s = stack_used(&mut || loaded = Model::from_bytes(models[1]).map(|_| ()));
        check("from_bytes", loaded);
        hprintln!("stack from_bytes {}", s);
        let mut r = Ok(());
        let s = stack_used(&mut || r = model.eval(x, t, &mut f[..K]));
        check("eval", r);
        hprintln!("stack eval {}", s);
        let s = stack_used(&mut || r = model.eval_grad(x, t, &mut f[..K], &mut grad[..K]));
        check("eval_grad", r);
        hprintln!("stack eval_grad {}", s);
        let s = stack_used(&mut || {
            r = model.eval_jacobian(x, t, &mut f[..K], &mut grad[..K], &mut dfdt[..K])
        });
        check("eval_jacobian", r);
        hprintln!("stack eval_jacobian {}", s);
        let mut label = 0;
        let s = stack_used(&mut || label = model.label(x, t));
        hprintln!("stack label {}", s);
        let Ok(moving) = Model::from_bytes(models[2]) else {
            hprintln!("FAIL: the embedded motion model");
            return false;
        };
        let s = stack_used(&mut || {
            r = moving.eval_jacobian(x, t, &mut f[..K], &mut grad[..K], &mut dfdt[..K])
        });
        check("eval_jacobian (motion model)", r);
        hprintln!("stack eval_jacobian (motion model) {}", s);
        let n = transcript::QUERIES.len();
        let mut xyz = [[0.0f32; 3]; transcript::QUERIES.len()];
        let mut ts = [0.0f32; transcript::QUERIES.len()];
        for (i, &(x, t)) in transcript::QUERIES.iter().enumerate() {
            xyz[i] = x;
            ts[i] = t;
        }
        let mut batch = [0.0f32; transcript::QUERIES.len() * K];
        let s = stack_used(&mut || r = model.eval_batch(scratch, &xyz, &ts, &mut batch));
        check("eval_batch", r);
        hprintln!("stack eval_batch {}", s);
        hprintln!("stack transcript {}", transcript_stack);
        if failed {
            return false;
        }

        // 3. The batch path (portable kernels here) must give the single-point values bit for
        //    bit: both sum every product in the same order.
        let mut mismatches = 0;
        for i in 0..n {
            let mut single = [0.0f32; K];
            if model.eval(xyz[i], ts[i], &mut single).is_err() {
                mismatches += K;
                continue;
            }
            for k in 0..K {
                if single[k].to_bits() != batch[i * K + k].to_bits() {
                    mismatches += 1;
                }
            }
        }
        hprintln!(
            "batch {} points x {} classes, {} differ from single-point evaluation",
            n,
            K,
            mismatches
        );
        hprintln!(
            "label {} macs_per_point {} params {}",
            label,
            model.layout().macs_per_point(),
            model.layout().param_count()
        );
        mismatches == 0
    }
}

/// Reports where a panic happened, but not its message: formatting a message can pull in the
/// float formatting machinery (≈ 20 KiB of flash), which would distort the size measurement.
#[panic_handler]
fn panic(info: &core::panic::PanicInfo) -> ! {
    match info.location() {
        Some(l) => hprintln!("PANIC at {}:{}", l.file(), l.line()),
        None => hprintln!("PANIC"),
    }
    debug::exit(debug::EXIT_FAILURE);
    loop {
        cortex_m::asm::wfi();
    }
}

#[exception]
unsafe fn HardFault(frame: &ExceptionFrame) -> ! {
    hprintln!("HARD FAULT at pc {:#010x}", frame.pc());
    debug::exit(debug::EXIT_FAILURE);
    loop {
        cortex_m::asm::wfi();
    }
}
