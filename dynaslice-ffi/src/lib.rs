//! C ABI for DynaSlice: load a trained 4D multi-class SDF (`.dsm`) and query it at any world
//! point and time from C, C++, Python (ctypes) or anything else that calls C.
//!
//! The header `include/dynaslice.h` is generated from this file by cbindgen
//! (`dynaslice-ffi/cbindgen.toml`); docs/c-api.md is the user guide. Conventions shared by every
//! entry point:
//!
//! - Functions returning `int` return `DS_OK` (0) or a negative `DS_E_*` code, and record a
//!   human-readable detail for `ds_last_error_message` on the calling thread.
//! - Every pointer is checked for NULL (and float/integer pointers for alignment) before use, and
//!   nothing is read or written outside the buffers the arguments describe. An output that
//!   overlaps another buffer of the same call is refused with `DS_E_INVALID_ARGUMENT`.
//! - Every call that takes a time refuses one outside the model's time range (NaN and ±∞
//!   included) with `DS_E_TIME_OUT_OF_RANGE`, writing nothing: the rule of every DynaSlice front
//!   end, the core's [`dynaslice_core::Domain::contains_time`], applied here and nowhere else.
//! - Every entry point runs inside [`std::panic::catch_unwind`], so a Rust panic (a bug) becomes
//!   `DS_E_INTERNAL` instead of unwinding into C, which would be undefined behaviour.
//! - A [`DsModel`] is immutable once loaded, so any number of threads may query one model at
//!   once. Batch calls run on the calling thread only: hosts (VTK's SMP tools, ParaView, Slicer)
//!   own their thread pools and split work across them themselves.

#![warn(missing_docs)]

use core::ffi::{c_char, c_int, CStr};
use dynaslice_core::{format, Error, Model, ModelBytes, OwnedModel, Scratch};
use std::cell::RefCell;
use std::ffi::CString;
use std::mem::{align_of, size_of};
use std::panic::{catch_unwind, AssertUnwindSafe};

/// Success.
pub const DS_OK: c_int = 0;
/// A pointer argument that must not be NULL was NULL.
pub const DS_E_NULL_POINTER: c_int = -1;
/// The model file could not be opened or read (missing, permissions, I/O error).
pub const DS_E_IO: c_int = -2;
/// The model is shorter than its header says (this includes an empty file).
pub const DS_E_TRUNCATED: c_int = -3;
/// The bytes are not a valid DynaSlice model (bad magic, inconsistent layout, bad values).
pub const DS_E_BAD_FORMAT: c_int = -4;
/// The model's CRC-32 does not match its contents: the file is corrupt.
pub const DS_E_CHECKSUM: c_int = -5;
/// A valid model this library cannot read (newer format version, big-endian host).
pub const DS_E_UNSUPPORTED: c_int = -6;
/// An output buffer is shorter than the answer (e.g. `sdf_len < K`).
pub const DS_E_BUFFER_TOO_SMALL: c_int = -7;
/// A class number outside `1..=K`.
pub const DS_E_NO_SUCH_CLASS: c_int = -8;
/// Any other invalid argument: a misaligned pointer, overlapping input and output buffers, or a
/// count whose buffer would exceed `PTRDIFF_MAX` bytes (`SIZE_MAX`, for one), on every call
/// that takes a count or length.
pub const DS_E_INVALID_ARGUMENT: c_int = -9;
/// A bug in the library (a caught Rust panic); the message says where.
pub const DS_E_INTERNAL: c_int = -10;
/// A time outside the model's time range (`ds_time_range`, to a rounding slack of 10⁻⁴ of the
/// range), or a NaN or infinite time. The network was fitted only inside the range and
/// extrapolates freely outside it, so such a time is refused, never answered: the same rule (the
/// core's `Domain::contains_time`) as `dynaslice query` and the Python package. Nothing is
/// written.
pub const DS_E_TIME_OUT_OF_RANGE: c_int = -11;

/// The label `ds_label` and `ds_label_batch` report for a NaN or infinite point, where no
/// class can be chosen.
pub const DS_LABEL_UNDEFINED: u32 = u32::MAX;
/// The largest number of classes K a model can have: an `sdf` array of this length fits any
/// model.
pub const DS_MAX_CLASSES: u32 = 64;
/// The longest class name in bytes, without the terminating NUL.
pub const DS_MAX_NAME_LEN: u32 = 56;

// The header needs literal values (cbindgen cannot see into the core); these keep them honest.
const _: () = {
    assert!(DS_LABEL_UNDEFINED == dynaslice_core::UNDEFINED_LABEL);
    assert!(DS_MAX_CLASSES as usize == format::MAX_CLASSES);
    assert!(DS_MAX_NAME_LEN as usize == format::MAX_NAME_LEN);
};

/// A loaded model, opaque: create it with `ds_model_open` or `ds_model_from_bytes`, free it with
/// `ds_model_free`. Immutable after loading: any number of threads may query one model at once.
//
// Inside: the model bytes (8-byte aligned) and a validated `Model` view into them, so queries
// never re-validate (`OwnedModel`, the one owned model type of every front end).
pub struct DsModel {
    owned: OwnedModel,
}

impl DsModel {
    /// Validates `bytes` and keeps them.
    fn new(bytes: ModelBytes) -> Result<DsModel, Failure> {
        OwnedModel::new(bytes)
            .map(|owned| DsModel { owned })
            .map_err(Failure::model)
    }

    /// The model, borrowed no longer than `self` (which owns its bytes).
    fn model(&self) -> &Model<'_> {
        self.owned.model()
    }
}

/// Why a call failed: the code returned to C and the detail kept for
/// `ds_last_error_message`.
#[derive(Debug)]
struct Failure {
    code: c_int,
    message: String,
}

impl Failure {
    fn new(code: c_int, message: impl Into<String>) -> Failure {
        Failure {
            code,
            message: message.into(),
        }
    }

    fn null(what: &str) -> Failure {
        Failure::new(DS_E_NULL_POINTER, format!("`{what}` is NULL"))
    }

    /// Maps a core error to its code; the core's message becomes the detail.
    fn model(e: Error) -> Failure {
        let code = match e {
            Error::Truncated { .. } => DS_E_TRUNCATED,
            Error::CrcMismatch { .. } => DS_E_CHECKSUM,
            Error::UnsupportedVersion(_) | Error::BigEndianHost => DS_E_UNSUPPORTED,
            Error::BufferLength { .. } => DS_E_BUFFER_TOO_SMALL,
            Error::NoSuchClass(_) => DS_E_NO_SUCH_CLASS,
            // The core's error enum is non-exhaustive: anything else, present or future, is a
            // malformed model.
            _ => DS_E_BAD_FORMAT,
        };
        Failure::new(code, e.to_string())
    }
}

thread_local! {
    /// Detail of the last failure on this thread, returned by `ds_last_error_message`.
    static LAST_ERROR: RefCell<CString> = RefCell::new(CString::default());
    /// Batch working memory (≈ 330 KiB), allocated on a thread's first batch call and freed when
    /// the thread exits, so concurrent batch calls from many threads never share it.
    static SCRATCH: RefCell<Option<Box<Scratch>>> = const { RefCell::new(None) };
}

fn set_last_error(message: &str) {
    // Interior NULs cannot come from our messages, but a path could hold one only if the caller
    // passed a non-C string; strip rather than fail.
    let text = CString::new(message.replace('\0', "")).unwrap_or_default();
    // During thread teardown the slot may be gone; the code is still returned.
    let _ = LAST_ERROR.try_with(|slot| *slot.borrow_mut() = text);
}

/// Runs an entry point's body: catches panics and records the failure detail.
fn guard(function: &str, body: impl FnOnce() -> Result<c_int, Failure>) -> c_int {
    match catch_unwind(AssertUnwindSafe(body)) {
        Ok(Ok(value)) => value,
        Ok(Err(failure)) => {
            set_last_error(&format!("{function}: {}", failure.message));
            failure.code
        }
        Err(payload) => {
            let what = payload
                .downcast_ref::<&str>()
                .copied()
                .or_else(|| payload.downcast_ref::<String>().map(String::as_str))
                .unwrap_or("unknown panic");
            set_last_error(&format!("{function}: internal error (panic: {what})"));
            DS_E_INTERNAL
        }
    }
}

/// The model behind a C pointer.
///
/// # Safety
/// `model` must be NULL or a live pointer from `ds_model_open` / `ds_model_from_bytes`.
unsafe fn model_ref<'a>(model: *const DsModel) -> Result<&'a DsModel, Failure> {
    // SAFETY: per this function's contract.
    unsafe { model.as_ref() }.ok_or_else(|| Failure::null("model"))
}

/// Checks a C array pointer for NULL and alignment and that `len` elements fit in `isize`.
fn check_array<T>(ptr: *const T, len: usize, what: &str) -> Result<(), Failure> {
    if ptr.is_null() {
        return Err(Failure::null(what));
    }
    if !(ptr as usize).is_multiple_of(align_of::<T>()) {
        return Err(Failure::new(
            DS_E_INVALID_ARGUMENT,
            format!("`{what}` is not aligned to {} bytes", align_of::<T>()),
        ));
    }
    if len
        .checked_mul(size_of::<T>())
        .is_none_or(|b| b > isize::MAX as usize)
    {
        return Err(Failure::new(
            DS_E_INVALID_ARGUMENT,
            format!("`{what}` holds {len} elements, more than any buffer can"),
        ));
    }
    Ok(())
}

/// A shared slice over a C array.
///
/// # Safety
/// `ptr` must point to `len` readable, initialised `T`s that nothing writes during the call.
unsafe fn input<'a, T>(ptr: *const T, len: usize, what: &str) -> Result<&'a [T], Failure> {
    check_array(ptr, len, what)?;
    // SAFETY: non-NULL, aligned, size checked above; readability per this function's contract.
    Ok(unsafe { core::slice::from_raw_parts(ptr, len) })
}

/// A mutable slice over a C array.
///
/// # Safety
/// `ptr` must point to `len` writable `T`s that the call may overwrite, and no other slice made
/// during the call may overlap it (checked by [`disjoint`] where the caller could alias).
unsafe fn output<'a, T>(ptr: *mut T, len: usize, what: &str) -> Result<&'a mut [T], Failure> {
    check_array(ptr, len, what)?;
    // SAFETY: as for `input`; exclusivity per this function's contract.
    Ok(unsafe { core::slice::from_raw_parts_mut(ptr, len) })
}

/// Fails when any two of the byte ranges (start pointer, element count, element size) overlap:
/// Rust must never hold a mutable slice aliasing another slice, so an output may not overlap any
/// other buffer of the call. Counts are already known not to overflow (see [`check_array`]).
fn disjoint(ranges: &[(&str, usize, usize)]) -> Result<(), Failure> {
    for (i, &(a, a_start, a_len)) in ranges.iter().enumerate() {
        for &(b, b_start, b_len) in &ranges[i + 1..] {
            if a_start < b_start + b_len && b_start < a_start + a_len {
                return Err(Failure::new(
                    DS_E_INVALID_ARGUMENT,
                    format!("`{a}` and `{b}` overlap"),
                ));
            }
        }
    }
    Ok(())
}

/// Byte range of a C array, for [`disjoint`].
fn span<T>(name: &str, ptr: *const T, len: usize) -> (&str, usize, usize) {
    (name, ptr as usize, len * size_of::<T>())
}

/// Reads a 3-float point (copied; the calls still refuse an output overlapping it, as documented).
///
/// # Safety
/// `xyz` must be NULL or point to 3 readable floats.
unsafe fn point(xyz: *const f32) -> Result<[f32; 3], Failure> {
    // SAFETY: per this function's contract.
    let p = unsafe { input(xyz, 3, "xyz") }?;
    Ok([p[0], p[1], p[2]])
}

/// The refusal of a time outside `model`'s range; `name` is how the caller called it (`t`,
/// `t[7]`), `more` says how many other times of the call are outside too.
fn time_refused(model: &Model, name: &str, t: f32, more: usize) -> Failure {
    let (t0, t1) = model.domain().time_range();
    let more = match more {
        0 => String::new(),
        1 => " (and 1 more time)".into(),
        n => format!(" (and {n} more times)"),
    };
    Failure::new(
        DS_E_TIME_OUT_OF_RANGE,
        format!("{name} = {t} is outside the model's time range [{t0}, {t1}]{more}"),
    )
}

/// Fails with `DS_E_TIME_OUT_OF_RANGE` unless `t` is in `model`'s time range by the core's rule
/// ([`dynaslice_core::Domain::contains_time`]), which every front end applies.
fn check_time(model: &Model, t: f32) -> Result<(), Failure> {
    if model.domain().contains_time(t) {
        Ok(())
    } else {
        Err(time_refused(model, "t", t, 0))
    }
}

/// [`check_time`] for every time of a batch; the refusal names the first time outside.
fn check_times(model: &Model, times: &[f32]) -> Result<(), Failure> {
    let domain = model.domain();
    let mut outside = times
        .iter()
        .enumerate()
        .filter(|&(_, &t)| !domain.contains_time(t));
    match outside.next() {
        None => Ok(()),
        Some((i, &t)) => Err(time_refused(model, &format!("t[{i}]"), t, outside.count())),
    }
}

/// Writes `text` snprintf-style: at most `len - 1` bytes, cut at a UTF-8 character boundary, then
/// a NUL. Returns the full length so a caller can retry with a bigger buffer.
///
/// # Safety
/// `buf` must be NULL (only with `len == 0`) or point to `len` writable bytes.
unsafe fn write_c_string(text: &str, buf: *mut c_char, len: usize) -> Result<c_int, Failure> {
    let full = c_int::try_from(text.len())
        .map_err(|_| Failure::new(DS_E_INVALID_ARGUMENT, "string longer than INT_MAX"))?;
    if len == 0 {
        // A pure size query: `buf` is not touched, and may be NULL.
        return Ok(full);
    }
    // SAFETY: per this function's contract.
    let out = unsafe { output(buf.cast::<u8>(), len, "buf") }?;
    let mut n = text.len().min(len - 1);
    while !text.is_char_boundary(n) {
        n -= 1;
    }
    out[..n].copy_from_slice(&text.as_bytes()[..n]);
    out[n] = 0;
    Ok(full)
}

/// Stores a new model in `*out`, or fails leaving `*out` NULL.
///
/// # Safety
/// `out` must be NULL or point to a writable `DsModel *`.
unsafe fn load(
    function: &str,
    out: *mut *mut DsModel,
    bytes: impl FnOnce() -> Result<DsModel, Failure>,
) -> c_int {
    guard(function, || {
        check_array(out, 1, "out")?;
        // SAFETY: checked non-NULL and aligned; writable per this function's contract.
        unsafe { out.write(core::ptr::null_mut()) };
        let model = Box::new(bytes()?);
        // SAFETY: as above.
        unsafe { out.write(Box::into_raw(model)) };
        Ok(DS_OK)
    })
}

/// Loads the model file at `path` into a new model stored in `*out`.
///
/// `path` is a NUL-terminated path (bytes as given on POSIX, UTF-8 elsewhere) of a regular file:
/// a FIFO, device or directory fails with `DS_E_IO` before it is opened (opening a FIFO would
/// block). Returns 0, or a negative `DS_E_*` code with `*out` set to NULL (when `out` itself is
/// not NULL). `DS_E_INVALID_ARGUMENT` when `out` overlaps the string `path`. Free the model with
/// `ds_model_free`.
///
/// # Safety
/// `path` must be NULL or a NUL-terminated string; `out` NULL or a writable `DsModel *`.
#[no_mangle]
pub unsafe extern "C" fn ds_model_open(path: *const c_char, out: *mut *mut DsModel) -> c_int {
    let read = || {
        if path.is_null() {
            return Err(Failure::null("path"));
        }
        // SAFETY: non-NULL, NUL-terminated per this function's contract.
        let c_path = unsafe { CStr::from_ptr(path) };
        // `*out` was set to NULL before this reads the path: an overlapping `out` has put a NUL
        // inside the string or at its start, so the span up to the NUL still meets it.
        disjoint(&[
            span("path", path, c_path.to_bytes_with_nul().len()),
            span("out", out, 1),
        ])?;
        #[cfg(unix)]
        let path = <std::ffi::OsStr as std::os::unix::ffi::OsStrExt>::from_bytes(c_path.to_bytes());
        #[cfg(not(unix))]
        let path = c_path
            .to_str()
            .map_err(|_| Failure::new(DS_E_INVALID_ARGUMENT, "`path` is not UTF-8"))?;
        let path = std::path::Path::new(path);
        // Regular files only, checked before the open (a FIFO would block it).
        let bytes = ModelBytes::read(path).map_err(|e| {
            let code = match e.kind() {
                std::io::ErrorKind::InvalidData => DS_E_BAD_FORMAT,
                _ => DS_E_IO,
            };
            Failure::new(code, format!("cannot read {}: {e}", path.display()))
        })?;
        DsModel::new(bytes)
    };
    // SAFETY: `out` is forwarded under this function's contract.
    unsafe { load("ds_model_open", out, read) }
}

/// Loads a model from `len` bytes at `bytes` (any alignment: they are copied, and the caller may
/// free them as soon as this returns) into a new model stored in `*out`.
///
/// Returns 0, or a negative `DS_E_*` code with `*out` set to NULL (when `out` is not NULL).
/// `DS_E_INVALID_ARGUMENT` when `out` overlaps the `len` bytes.
///
/// # Safety
/// `bytes` must be NULL or point to `len` readable bytes; `out` NULL or a writable `DsModel *`.
#[no_mangle]
pub unsafe extern "C" fn ds_model_from_bytes(
    bytes: *const u8,
    len: usize,
    out: *mut *mut DsModel,
) -> c_int {
    let copy = || {
        // SAFETY: per this function's contract.
        let bytes = unsafe { input(bytes, len, "bytes") }?;
        disjoint(&[span("bytes", bytes.as_ptr(), len), span("out", out, 1)])?;
        if bytes.len() as u64 > format::max_file_size() {
            return Err(Failure::new(
                DS_E_BAD_FORMAT,
                format!("{len} bytes is larger than any model"),
            ));
        }
        // Copied (any alignment) into owned aligned storage.
        DsModel::new(ModelBytes::copy_from(bytes))
    };
    // SAFETY: `out` is forwarded under this function's contract.
    unsafe { load("ds_model_from_bytes", out, copy) }
}

/// Frees a model. NULL is a no-op. The model must not be in use by another thread, and must not
/// be used or freed again afterwards.
///
/// # Safety
/// `model` must be NULL or a live pointer from `ds_model_open` / `ds_model_from_bytes`.
#[no_mangle]
pub unsafe extern "C" fn ds_model_free(model: *mut DsModel) {
    guard("ds_model_free", || {
        if !model.is_null() {
            // SAFETY: from `Box::into_raw` in `load`, freed once per this function's contract.
            drop(unsafe { Box::from_raw(model) });
        }
        Ok(DS_OK)
    });
}

/// K, the number of classes (output channels) of the model; 0 for NULL.
///
/// # Safety
/// `model` must be NULL or a live model.
#[no_mangle]
pub unsafe extern "C" fn ds_num_classes(model: *const DsModel) -> u32 {
    let k = guard("ds_num_classes", || {
        // SAFETY: per this function's contract.
        let model = unsafe { model_ref(model) }?;
        Ok(model.model().num_classes() as c_int)
    });
    // K is at most DS_MAX_CLASSES; failures (NULL, a caught panic) read as 0 classes.
    u32::try_from(k).unwrap_or(0)
}

/// Copies the name of class `k` (`1..=K`) into `buf` as UTF-8, NUL-terminated, snprintf-style:
/// at most `len - 1` bytes (cut at a character boundary) are written. Returns the full name
/// length in bytes (without the NUL), so a return value `>= len` means the name was cut; or a
/// negative `DS_E_*` code. With `len == 0`, `buf` may be NULL and only the length is returned.
///
/// # Safety
/// `model` must be NULL or a live model; `buf` NULL or `len` writable bytes.
#[no_mangle]
pub unsafe extern "C" fn ds_class_name(
    model: *const DsModel,
    k: u32,
    buf: *mut c_char,
    len: usize,
) -> c_int {
    guard("ds_class_name", || {
        // SAFETY: per this function's contract.
        let model = unsafe { model_ref(model) }?;
        let class = model.model().class(k).map_err(Failure::model)?;
        // SAFETY: per this function's contract.
        unsafe { write_c_string(class.name, buf, len) }
    })
}

/// Stores in `*label` the label value class `k` (`1..=K`) had in the source segmentation.
///
/// # Safety
/// `model` must be NULL or a live model; `label` NULL or a writable `int32_t`.
#[no_mangle]
pub unsafe extern "C" fn ds_class_label(model: *const DsModel, k: u32, label: *mut i32) -> c_int {
    guard("ds_class_label", || {
        // SAFETY: per this function's contract.
        let model = unsafe { model_ref(model) }?;
        let class = model.model().class(k).map_err(Failure::model)?;
        // SAFETY: per this function's contract.
        unsafe { output(label, 1, "label") }?[0] = class.label;
        Ok(DS_OK)
    })
}

/// Copies the model's free-form UTF-8 metadata (the trainer records its options here) into `buf`,
/// with the same conventions and return value as `ds_class_name`.
///
/// # Safety
/// `model` must be NULL or a live model; `buf` NULL or `len` writable bytes.
#[no_mangle]
pub unsafe extern "C" fn ds_metadata(model: *const DsModel, buf: *mut c_char, len: usize) -> c_int {
    guard("ds_metadata", || {
        // SAFETY: per this function's contract.
        let model = unsafe { model_ref(model) }?;
        // SAFETY: per this function's contract.
        unsafe { write_c_string(model.model().metadata(), buf, len) }
    })
}

/// Stores the time range the model was trained on, in world time units (usually seconds): the
/// times the evaluation calls answer. A time outside it (beyond a rounding slack of 10⁻⁴ of the
/// range), NaN or ±∞ is refused with `DS_E_TIME_OUT_OF_RANGE`; `ds_check_time` applies the same
/// test. A static model (trained on one timestep) has a nominal range of one time unit from that
/// timestep's time and the same answers at every time in it.
///
/// # Safety
/// `model` must be NULL or a live model; `t_min`, `t_max` NULL or writable floats.
#[no_mangle]
pub unsafe extern "C" fn ds_time_range(
    model: *const DsModel,
    t_min: *mut f32,
    t_max: *mut f32,
) -> c_int {
    guard("ds_time_range", || {
        // SAFETY: per this function's contract.
        let (lo, hi) = unsafe { model_ref(model) }?.model().domain().time_range();
        // SAFETY: per this function's contract.
        unsafe { write_range((t_min, "t_min"), (t_max, "t_max"), ([lo], [hi])) }
    })
}

/// Returns 0 when the evaluation calls answer `model` at time `t`, else
/// `DS_E_TIME_OUT_OF_RANGE` with a message naming the range (see `ds_time_range`): the exact test
/// every call that takes a time applies, for hosts that check a time once before many queries.
///
/// # Safety
/// `model` must be NULL or a live model.
#[no_mangle]
pub unsafe extern "C" fn ds_check_time(model: *const DsModel, t: f32) -> c_int {
    guard("ds_check_time", || {
        // SAFETY: per this function's contract.
        check_time(unsafe { model_ref(model) }?.model(), t)?;
        Ok(DS_OK)
    })
}

/// Stores the world bounding box the model was trained on, in world units (usually mm): 3 floats
/// each. Queries outside it are answered too (the network extrapolates).
///
/// # Safety
/// `model` must be NULL or a live model; `min_xyz`, `max_xyz` NULL or 3 writable floats each.
#[no_mangle]
pub unsafe extern "C" fn ds_bounds(
    model: *const DsModel,
    min_xyz: *mut f32,
    max_xyz: *mut f32,
) -> c_int {
    guard("ds_bounds", || {
        // SAFETY: per this function's contract.
        let range = unsafe { model_ref(model) }?.model().domain().bounds();
        // SAFETY: per this function's contract.
        unsafe { write_range((min_xyz, "min_xyz"), (max_xyz, "max_xyz"), range) }
    })
}

/// Stores the two ends of a range, `N` floats each, in two caller arrays that must not overlap.
///
/// # Safety
/// `lo` and `hi` must each be NULL or point to `N` writable floats.
unsafe fn write_range<const N: usize>(
    (lo, lo_name): (*mut f32, &str),
    (hi, hi_name): (*mut f32, &str),
    (min, max): ([f32; N], [f32; N]),
) -> Result<c_int, Failure> {
    // NULL before overlap: two NULL outputs are missing, not overlapping.
    check_array(lo, N, lo_name)?;
    check_array(hi, N, hi_name)?;
    disjoint(&[span(lo_name, lo, N), span(hi_name, hi, N)])?;
    // SAFETY: per this function's contract; disjoint checked above.
    let (a, b) = unsafe { (output(lo, N, lo_name)?, output(hi, N, hi_name)?) };
    a.copy_from_slice(&min);
    b.copy_from_slice(&max);
    Ok(DS_OK)
}

/// The model, the query point and K of a single-point query, failing unless an output of
/// `sdf_len` entries holds the model's K.
///
/// # Safety
/// `model` must be NULL or a live model; `xyz` NULL or 3 readable floats.
unsafe fn point_query<'a>(
    model: *const DsModel,
    xyz: *const f32,
    sdf_len: usize,
) -> Result<(&'a Model<'a>, [f32; 3], usize), Failure> {
    // SAFETY: per this function's contract.
    let (model, x) = unsafe { (model_ref(model)?.model(), point(xyz)?) };
    let k = model.num_classes();
    if sdf_len < k {
        return Err(Failure::new(
            DS_E_BUFFER_TOO_SMALL,
            format!("sdf_len is {sdf_len}, the model has {k} classes"),
        ));
    }
    Ok((model, x, k))
}

/// Evaluates the K signed distances f(x, t) at world point `xyz` (3 floats) and world time `t`
/// into `sdf[0..K]` (world units; negative inside class k). `sdf` holds `sdf_len >= K` floats;
/// entries past K are left untouched. `t` must lie in the model's time range (`ds_time_range`):
/// otherwise, NaN and ±∞ included, the call returns `DS_E_TIME_OUT_OF_RANGE` and writes nothing.
/// Every finite point gives finite distances, however far outside the model's bounds; a NaN or
/// infinite point gives NaN distances (and returns 0). `DS_E_INVALID_ARGUMENT` when `sdf`
/// overlaps `xyz`.
///
/// # Safety
/// `model` must be NULL or a live model; `xyz` NULL or 3 readable floats; `sdf` NULL or
/// `sdf_len` writable floats not overlapping `xyz`.
#[no_mangle]
pub unsafe extern "C" fn ds_eval(
    model: *const DsModel,
    xyz: *const f32,
    t: f32,
    sdf: *mut f32,
    sdf_len: usize,
) -> c_int {
    guard("ds_eval", || {
        // SAFETY: per this function's contract.
        let (model, x, k) = unsafe { point_query(model, xyz, sdf_len) }?;
        check_array(sdf, sdf_len, "sdf")?;
        disjoint(&[span("xyz", xyz, 3), span("sdf", sdf, sdf_len)])?;
        check_time(model, t)?;
        // SAFETY: per this function's contract; the only slice of this call (`x` is a copy).
        let f = unsafe { output(sdf, sdf_len, "sdf") }?;
        model.eval(x, t, &mut f[..k]).map_err(Failure::model)?;
        Ok(DS_OK)
    })
}

/// Like `ds_eval`, and also stores the exact spatial gradients (world units): `grad` holds
/// `3 * K` floats (K = `ds_num_classes`), and row k-1 (`grad[3(k-1)..3k]`) receives ∇ₓf^k for k
/// in 1..=K. Times, NaN and far points as in `ds_eval`.
///
/// # Safety
/// As `ds_eval`, and `grad` NULL or `3 * K` writable floats overlapping neither `xyz` nor `sdf`.
#[no_mangle]
pub unsafe extern "C" fn ds_eval_grad(
    model: *const DsModel,
    xyz: *const f32,
    t: f32,
    sdf: *mut f32,
    grad: *mut f32,
    sdf_len: usize,
) -> c_int {
    guard("ds_eval_grad", || {
        // SAFETY: per this function's contract.
        let (model, x, k) = unsafe { point_query(model, xyz, sdf_len) }?;
        check_array(sdf, sdf_len, "sdf")?;
        // `[f32; 3]` rows: K of them are the 3K floats (K ≤ format::MAX_CLASSES: no overflow).
        check_array(grad.cast::<[f32; 3]>(), k, "grad")?;
        disjoint(&[
            span("xyz", xyz, 3),
            span("sdf", sdf, sdf_len),
            span("grad", grad, 3 * k),
        ])?;
        check_time(model, t)?;
        // SAFETY: per this function's contract; disjoint checked above.
        let (f, g) = unsafe {
            (
                output(sdf, sdf_len, "sdf")?,
                output(grad.cast::<[f32; 3]>(), k, "grad")?,
            )
        };
        model
            .eval_grad(x, t, &mut f[..k], g)
            .map_err(Failure::model)?;
        Ok(DS_OK)
    })
}

/// Like `ds_eval_grad`, and also stores ∂f^k/∂t (world units per world time unit) in
/// `dfdt[k-1]`; `dfdt` holds `sdf_len` floats. With ∇ₓf this gives the surface's normal velocity
/// −(∂f/∂t)/‖∇ₓf‖. Times, NaN and far points as in `ds_eval`.
///
/// # Safety
/// As `ds_eval_grad`, and `dfdt` NULL or `sdf_len` writable floats overlapping no other buffer.
#[no_mangle]
pub unsafe extern "C" fn ds_eval_jacobian(
    model: *const DsModel,
    xyz: *const f32,
    t: f32,
    sdf: *mut f32,
    grad: *mut f32,
    dfdt: *mut f32,
    sdf_len: usize,
) -> c_int {
    guard("ds_eval_jacobian", || {
        // SAFETY: per this function's contract.
        let (model, x, k) = unsafe { point_query(model, xyz, sdf_len) }?;
        check_array(sdf, sdf_len, "sdf")?;
        // As in `ds_eval_grad`.
        check_array(grad.cast::<[f32; 3]>(), k, "grad")?;
        check_array(dfdt, sdf_len, "dfdt")?;
        disjoint(&[
            span("xyz", xyz, 3),
            span("sdf", sdf, sdf_len),
            span("grad", grad, 3 * k),
            span("dfdt", dfdt, sdf_len),
        ])?;
        check_time(model, t)?;
        // SAFETY: per this function's contract; disjoint checked above.
        let (f, g, d) = unsafe {
            (
                output(sdf, sdf_len, "sdf")?,
                output(grad.cast::<[f32; 3]>(), k, "grad")?,
                output(dfdt, sdf_len, "dfdt")?,
            )
        };
        model
            .eval_jacobian(x, t, &mut f[..k], g, &mut d[..k])
            .map_err(Failure::model)?;
        Ok(DS_OK)
    })
}

/// Stores the Eq. 11 label at (`xyz`, `t`) in `*label`: 0 for background, k when f^k is negative
/// and the smallest, `DS_LABEL_UNDEFINED` for a NaN or infinite point (which still returns 0).
/// A time outside the model's range is refused as in `ds_eval` (`*label` is not written).
///
/// # Safety
/// `model` must be NULL or a live model; `xyz` NULL or 3 readable floats; `label` NULL or a
/// writable `uint32_t` not overlapping `xyz`.
#[no_mangle]
pub unsafe extern "C" fn ds_label(
    model: *const DsModel,
    xyz: *const f32,
    t: f32,
    label: *mut u32,
) -> c_int {
    guard("ds_label", || {
        // SAFETY: per this function's contract.
        let (model, x) = unsafe { (model_ref(model)?.model(), point(xyz)?) };
        check_array(label, 1, "label")?;
        disjoint(&[span("xyz", xyz, 3), span("label", label, 1)])?;
        check_time(model, t)?;
        // SAFETY: per this function's contract; disjoint from `xyz` (checked above).
        unsafe { output(label, 1, "label") }?[0] = model.label(x, t);
        Ok(DS_OK)
    })
}

/// Stores in `out[0..3]` the displacement u at world point `xyz` and world time `t` of a motion
/// model (f(x, t) = g(x + u, t), g its shape network read in world coordinates): the offset, in
/// world units, that carries `xyz` at time `t` to its canonical (reference-shape) position.
/// A model without motion gives 0, 0, 0; a NaN or infinite point gives NaN (and returns 0).
/// Times as in `ds_eval`: outside the model's range, `DS_E_TIME_OUT_OF_RANGE` and nothing
/// written. `DS_E_INVALID_ARGUMENT` when `out` overlaps `xyz`.
///
/// # Safety
/// `model` must be NULL or a live model; `xyz` NULL or 3 readable floats; `out` NULL or 3
/// writable floats not overlapping `xyz`.
#[no_mangle]
pub unsafe extern "C" fn ds_displacement(
    model: *const DsModel,
    xyz: *const f32,
    t: f32,
    out: *mut f32,
) -> c_int {
    guard("ds_displacement", || {
        // SAFETY: per this function's contract.
        let (model, x) = unsafe { (model_ref(model)?.model(), point(xyz)?) };
        check_array(out, 3, "out")?;
        disjoint(&[span("xyz", xyz, 3), span("out", out, 3)])?;
        check_time(model, t)?;
        let u = model.displacement(x, t).map_err(Failure::model)?;
        // SAFETY: per this function's contract; disjoint from `xyz` (checked above).
        unsafe { output(out, 3, "out") }?.copy_from_slice(&u);
        Ok(DS_OK)
    })
}

/// The inputs of a batch call, checked: n points of 3 floats and n times.
///
/// # Safety
/// `xyz` must be NULL or `3n` readable floats; `t` NULL or `n` readable floats.
unsafe fn batch_inputs<'a>(
    n: usize,
    xyz: *const f32,
    t: *const f32,
) -> Result<(&'a [[f32; 3]], &'a [f32]), Failure> {
    // `[f32; 3]` has the size and alignment of 3 consecutive floats.
    // SAFETY: per this function's contract.
    let points = unsafe { input(xyz.cast::<[f32; 3]>(), n, "xyz") }?;
    // SAFETY: per this function's contract.
    let times = unsafe { input(t, n, "t") }?;
    Ok((points, times))
}

/// `n * K`, the entries of a batch's `sdf` (and of its `grad` rows), if it fits in `size_t`.
fn batch_len(model: &Model, n: usize) -> Result<usize, Failure> {
    n.checked_mul(model.num_classes())
        .ok_or_else(|| Failure::new(DS_E_INVALID_ARGUMENT, "n * K overflows"))
}

/// Fails when the outputs overlap each other or either input of a batch of `n` points; the
/// inputs may overlap each other (both are only read).
fn batch_disjoint(
    outputs: &[(&str, usize, usize)],
    n: usize,
    xyz: *const f32,
    t: *const f32,
) -> Result<(), Failure> {
    for input in [span("xyz", xyz, 3 * n), span("t", t, n)] {
        disjoint(&[outputs, &[input]].concat())?;
    }
    Ok(())
}

/// The one output array of a batch call: `len` elements, checked as by [`output`], disjoint
/// from the inputs.
///
/// # Safety
/// `ptr` must be NULL or point to `len` writable `T`s; `xyz` and `t` are the call's inputs.
unsafe fn batch_output<'a, T>(
    ptr: *mut T,
    len: usize,
    what: &str,
    n: usize,
    xyz: *const f32,
    t: *const f32,
) -> Result<&'a mut [T], Failure> {
    check_array(ptr, len, what)?;
    batch_disjoint(&[span(what, ptr, len)], n, xyz, t)?;
    // SAFETY: per this function's contract; disjoint from the inputs (checked above).
    unsafe { output(ptr, len, what) }
}

/// Runs `body` with this thread's batch scratch (allocated on the thread's first batch call).
fn with_scratch<R>(body: impl FnOnce(&mut Scratch) -> R) -> Result<R, Failure> {
    // Taken out of the slot for the call, so the slot is never borrowed across `body`.
    let taken = SCRATCH
        .try_with(|slot| slot.borrow_mut().take())
        .map_err(|_| Failure::new(DS_E_INTERNAL, "called during thread teardown"))?;
    let mut scratch = taken.unwrap_or_else(Scratch::boxed);
    let result = body(&mut scratch);
    let _ = SCRATCH.try_with(|slot| *slot.borrow_mut() = Some(scratch));
    Ok(result)
}

/// The K distances at each of `n` points: point i is `xyz[3i..3i+3]` at time `t[i]`, and its
/// answers go to `sdf[iK..(i+1)K]` (row-major, `n * K` floats). NaN or infinite points give NaN
/// rows. Every `t[i]` must lie in the model's time range (`ds_time_range`): when one does not
/// (NaN and ±∞ included), the call returns `DS_E_TIME_OUT_OF_RANGE` and writes nothing at all,
/// and the message names the first such i and how many more there are. Uses the SIMD batch
/// kernels (AVX-512/AVX2 when the CPU has them), so results may differ from `ds_eval` in the
/// last bits. Runs on the calling thread only; call it from several threads on disjoint ranges
/// to use more cores. `n == 0` is a no-op (pointers still checked).
///
/// # Safety
/// `model` must be NULL or a live model; `xyz` NULL or `3n` readable floats; `t` NULL or `n`
/// readable floats; `sdf` NULL or `n * K` writable floats overlapping neither input.
#[no_mangle]
pub unsafe extern "C" fn ds_eval_batch(
    model: *const DsModel,
    n: usize,
    xyz: *const f32,
    t: *const f32,
    sdf: *mut f32,
) -> c_int {
    guard("ds_eval_batch", || {
        // SAFETY: per this function's contract.
        let (model, (points, times)) =
            unsafe { (model_ref(model)?.model(), batch_inputs(n, xyz, t)?) };
        let len = batch_len(model, n)?;
        // SAFETY: per this function's contract.
        let f = unsafe { batch_output(sdf, len, "sdf", n, xyz, t) }?;
        check_times(model, times)?;
        with_scratch(|s| model.eval_batch(s, points, times, f))?.map_err(Failure::model)?;
        Ok(DS_OK)
    })
}

/// Like `ds_eval_batch`, and also stores ∇ₓf: `grad` holds `n * K * 3` floats, and
/// `grad[3(iK + k-1)..3(iK + k)]` receives ∇ₓf^k at point i. A time outside the model's range
/// is refused as in `ds_eval_batch`: neither `sdf` nor `grad` is written.
///
/// # Safety
/// As `ds_eval_batch`, and `grad` NULL or `3nK` writable floats overlapping no other buffer.
#[no_mangle]
pub unsafe extern "C" fn ds_eval_grad_batch(
    model: *const DsModel,
    n: usize,
    xyz: *const f32,
    t: *const f32,
    sdf: *mut f32,
    grad: *mut f32,
) -> c_int {
    guard("ds_eval_grad_batch", || {
        // SAFETY: per this function's contract.
        let (model, (points, times)) =
            unsafe { (model_ref(model)?.model(), batch_inputs(n, xyz, t)?) };
        let len = batch_len(model, n)?;
        check_array(sdf, len, "sdf")?;
        // `[f32; 3]` rows: the element-count check also bounds the float count 3·len.
        check_array(grad.cast::<[f32; 3]>(), len, "grad")?;
        let outputs = [span("sdf", sdf, len), span("grad", grad, 3 * len)];
        batch_disjoint(&outputs, n, xyz, t)?;
        check_times(model, times)?;
        // SAFETY: per this function's contract; disjoint from each other and the inputs.
        let (f, g) = unsafe {
            (
                output(sdf, len, "sdf")?,
                output(grad.cast::<[f32; 3]>(), len, "grad")?,
            )
        };
        with_scratch(|s| model.eval_grad_batch(s, points, times, f, g))?.map_err(Failure::model)?;
        Ok(DS_OK)
    })
}

/// The Eq. 11 label of each of `n` points into `labels[0..n]` (see `ds_label`), with the batch
/// kernels of `ds_eval_batch` (same threading and rounding notes, and the same refusal of a
/// time outside the model's range: nothing written).
///
/// # Safety
/// `model` must be NULL or a live model; `xyz` NULL or `3n` readable floats; `t` NULL or `n`
/// readable floats; `labels` NULL or `n` writable `uint32_t` overlapping neither input.
#[no_mangle]
pub unsafe extern "C" fn ds_label_batch(
    model: *const DsModel,
    n: usize,
    xyz: *const f32,
    t: *const f32,
    labels: *mut u32,
) -> c_int {
    guard("ds_label_batch", || {
        // SAFETY: per this function's contract.
        let (model, (points, times)) =
            unsafe { (model_ref(model)?.model(), batch_inputs(n, xyz, t)?) };
        // SAFETY: per this function's contract.
        let out = unsafe { batch_output(labels, n, "labels", n, xyz, t) }?;
        check_times(model, times)?;
        with_scratch(|s| model.label_batch(s, points, times, out))?.map_err(Failure::model)?;
        Ok(DS_OK)
    })
}

/// The displacement (see `ds_displacement`) at each of `n` points into `out[3i..3i+3]` (`3n`
/// floats), with the batch kernels of `ds_eval_batch` (same threading and rounding notes, and
/// the same refusal of a time outside the model's range: nothing written).
///
/// # Safety
/// `model` must be NULL or a live model; `xyz` NULL or `3n` readable floats; `t` NULL or `n`
/// readable floats; `out` NULL or `3n` writable floats overlapping neither input.
#[no_mangle]
pub unsafe extern "C" fn ds_displacement_batch(
    model: *const DsModel,
    n: usize,
    xyz: *const f32,
    t: *const f32,
    out: *mut f32,
) -> c_int {
    guard("ds_displacement_batch", || {
        // SAFETY: per this function's contract.
        let (model, (points, times)) =
            unsafe { (model_ref(model)?.model(), batch_inputs(n, xyz, t)?) };
        // `[f32; 3]` rows: the element-count check also bounds the float count 3n.
        // SAFETY: per this function's contract.
        let u = unsafe { batch_output(out.cast::<[f32; 3]>(), n, "out", n, xyz, t) }?;
        check_times(model, times)?;
        with_scratch(|s| model.displacement_batch(s, points, times, u))?.map_err(Failure::model)?;
        Ok(DS_OK)
    })
}

/// A static description of a return code; never NULL, also for unknown codes.
#[no_mangle]
pub extern "C" fn ds_error_string(code: c_int) -> *const c_char {
    let text: &'static CStr = match code {
        DS_OK => c"success",
        DS_E_NULL_POINTER => c"a required pointer argument is NULL",
        DS_E_IO => c"the model file could not be read",
        DS_E_TRUNCATED => c"the model is truncated",
        DS_E_BAD_FORMAT => c"not a valid DynaSlice model",
        DS_E_CHECKSUM => c"the model is corrupt (CRC mismatch)",
        DS_E_UNSUPPORTED => c"unsupported model version or platform",
        DS_E_BUFFER_TOO_SMALL => c"an output buffer is too small",
        DS_E_NO_SUCH_CLASS => c"no such class",
        DS_E_INVALID_ARGUMENT => c"invalid argument",
        DS_E_INTERNAL => c"internal error in the DynaSlice library",
        DS_E_TIME_OUT_OF_RANGE => c"the time is outside the model's time range",
        _ => c"unknown error code",
    };
    text.as_ptr()
}

/// Detail of the most recent failure on the calling thread (e.g. "ds_model_open: CRC mismatch:
/// …"), or "" if none yet. Successful calls do not clear it. Never NULL; the text stays valid
/// until the next failing call on this thread.
#[no_mangle]
pub extern "C" fn ds_last_error_message() -> *const c_char {
    LAST_ERROR
        .try_with(|slot| slot.borrow().as_ptr())
        .unwrap_or(c"".as_ptr())
}

/// The library version ("MAJOR.MINOR.PATCH"), static, never NULL.
#[no_mangle]
pub extern "C" fn ds_version() -> *const c_char {
    const VERSION: &CStr =
        match CStr::from_bytes_with_nul(concat!(env!("CARGO_PKG_VERSION"), "\0").as_bytes()) {
            Ok(v) => v,
            Err(_) => panic!("the package version contains a NUL"),
        };
    VERSION.as_ptr()
}

#[cfg(test)]
mod tests {
    use super::*;

    fn last_error() -> String {
        // SAFETY: never NULL, NUL-terminated.
        unsafe { CStr::from_ptr(ds_last_error_message()) }
            .to_string_lossy()
            .into_owned()
    }

    /// The panic path cannot be reached from C without a bug, so it is tested directly.
    #[test]
    fn panics_become_internal_errors() {
        let code = guard("ds_test", || panic!("boom {}", 42));
        assert_eq!(code, DS_E_INTERNAL);
        assert_eq!(last_error(), "ds_test: internal error (panic: boom 42)");
        let code = guard("ds_test", || panic!("static"));
        assert_eq!(code, DS_E_INTERNAL);
        assert!(last_error().contains("panic: static"));
    }

    #[test]
    fn overlapping_ranges_are_rejected() {
        assert!(disjoint(&[("a", 100, 8), ("b", 108, 4)]).is_ok());
        assert!(disjoint(&[("a", 100, 8), ("b", 104, 4), ("c", 0, 1)]).is_err());
        assert!(disjoint(&[("a", 100, 0), ("b", 100, 4)]).is_ok());
    }

    fn model() -> *mut DsModel {
        let bytes = format::ModelWriter::random_siren(&[16, 16], 2, 3).to_bytes();
        let mut m = core::ptr::null_mut();
        assert_eq!(
            unsafe { ds_model_from_bytes(bytes.as_ptr(), bytes.len(), &mut m) },
            DS_OK
        );
        m
    }

    /// The header documents DS_E_INVALID_ARGUMENT for an output overlapping an input: the
    /// single-point calls copy the point, but still refuse as documented.
    #[test]
    fn single_point_outputs_over_the_point_are_refused() {
        let m = model();
        let mut buf = [0.25f32; 6];
        let p = buf.as_mut_ptr();
        assert_eq!(unsafe { ds_eval(m, p, 0.5, p, 2) }, DS_E_INVALID_ARGUMENT);
        assert!(
            last_error().contains("`xyz` and `sdf` overlap"),
            "{}",
            last_error()
        );
        assert_eq!(
            unsafe { ds_eval(m, p, 0.5, p.add(2), 2) },
            DS_E_INVALID_ARGUMENT
        );
        assert_eq!(unsafe { ds_eval(m, p, 0.5, p.add(3), 2) }, DS_OK);
        let mut f = [0.0f32; 2];
        let fp = f.as_mut_ptr();
        assert_eq!(
            unsafe { ds_eval_grad(m, p, 0.5, fp, p, 2) },
            DS_E_INVALID_ARGUMENT
        );
        let mut g = [0.0f32; 6];
        let gp = g.as_mut_ptr();
        assert_eq!(
            unsafe { ds_eval_jacobian(m, p, 0.5, fp, gp, p.add(1), 2) },
            DS_E_INVALID_ARGUMENT
        );
        assert_eq!(
            unsafe { ds_label(m, p, 0.5, p.add(2).cast()) },
            DS_E_INVALID_ARGUMENT
        );
        unsafe { ds_model_free(m) };
    }

    /// Far finite points are answered with finite values (they gave NaN at x = 1e9), at both
    /// ends of the time range.
    #[test]
    fn far_finite_points_give_finite_values() {
        let m = model();
        let (mut f, mut g, mut d) = ([0.0f32; 2], [0.0f32; 6], [0.0f32; 2]);
        for (x, t) in [
            ([1e9f32, 0.0, 0.0], 0.5f32),
            ([3e38; 3], 0.0),
            ([-3e38; 3], 1.0),
        ] {
            let rc = unsafe {
                ds_eval_jacobian(
                    m,
                    x.as_ptr(),
                    t,
                    f.as_mut_ptr(),
                    g.as_mut_ptr(),
                    d.as_mut_ptr(),
                    2,
                )
            };
            assert_eq!(rc, DS_OK);
            let all = f.iter().chain(&g).chain(&d);
            assert!(
                all.clone().all(|v| v.is_finite()),
                "{x:?} {t}: {f:?} {g:?} {d:?}"
            );
        }
        unsafe { ds_model_free(m) };
    }

    /// Every call that takes a time refuses one outside the range (NaN and ±∞ too) with
    /// DS_E_TIME_OUT_OF_RANGE, writes nothing, and answers both edges of the range.
    #[test]
    fn times_outside_the_range_are_refused_everywhere() {
        let m = model();
        // `random_siren` models span t in [0, 1]; the slack is 1e-4 of the range.
        let (t0, t1) = (0.0f32, 1.0f32);
        let x = [0.1f32, -0.2, 0.3];
        let sentinel = 42.0f32;
        // The four single-point calls at time t, into f (K = 2), g, d and the label l.
        let every_point_call =
            |t: f32, f: &mut [f32; 2], g: &mut [f32; 6], d: &mut [f32; 2], l: &mut u32| unsafe {
                let (fp, gp, dp) = (f.as_mut_ptr(), g.as_mut_ptr(), d.as_mut_ptr());
                [
                    ds_eval(m, x.as_ptr(), t, fp, 2),
                    ds_eval_grad(m, x.as_ptr(), t, fp, gp, 2),
                    ds_eval_jacobian(m, x.as_ptr(), t, fp, gp, dp, 2),
                    ds_label(m, x.as_ptr(), t, l),
                ]
            };
        let refused = [
            t0 - 2e-4,
            t1 + 2e-4,
            -1.0,
            5.0,
            1e30,
            f32::NAN,
            f32::INFINITY,
        ];
        for t in refused {
            assert_eq!(
                unsafe { ds_check_time(m, t) },
                DS_E_TIME_OUT_OF_RANGE,
                "{t}"
            );
            let (mut f, mut g, mut d, mut l) = ([sentinel; 2], [sentinel; 6], [sentinel; 2], 7u32);
            let codes = every_point_call(t, &mut f, &mut g, &mut d, &mut l);
            assert_eq!(codes, [DS_E_TIME_OUT_OF_RANGE; 4], "{t}");
            let all = f.iter().chain(&g).chain(&d);
            assert!(
                all.clone().all(|&v| v == sentinel) && l == 7,
                "{t}: written"
            );
            assert!(
                last_error().starts_with("ds_label: t = ")
                    && last_error().contains("outside the model's time range [0, 1]"),
                "{}",
                last_error()
            );
        }
        for t in [t0, t1, t0 - 5e-5, t1 + 5e-5, 0.5] {
            assert_eq!(unsafe { ds_check_time(m, t) }, DS_OK, "{t}");
            let (mut f, mut g, mut d, mut l) = ([0.0f32; 2], [0.0f32; 6], [0.0f32; 2], 7u32);
            let codes = every_point_call(t, &mut f, &mut g, &mut d, &mut l);
            assert_eq!(codes, [DS_OK; 4], "{t}");
            assert!(f.iter().chain(&g).chain(&d).all(|v| v.is_finite()) && l <= 2);
        }
        assert_eq!(
            unsafe { ds_check_time(core::ptr::null(), 0.5) },
            DS_E_NULL_POINTER
        );

        // Batches: one bad time among good ones refuses the whole call, writing nothing.
        let n = 5;
        let xyz = [x; 5];
        let mut times = [t0, 0.25, 0.5, 0.75, t1];
        let xp = xyz.as_ptr().cast::<f32>();
        let batch = |t: &[f32], f: &mut [f32], g: &mut [[f32; 3]], l: &mut [u32]| unsafe {
            let (tp, fp, gp) = (t.as_ptr(), f.as_mut_ptr(), g.as_mut_ptr().cast::<f32>());
            [
                ds_eval_batch(m, n, xp, tp, fp),
                ds_eval_grad_batch(m, n, xp, tp, fp, gp),
                ds_label_batch(m, n, xp, tp, l.as_mut_ptr()),
            ]
        };
        let (mut f, mut g, mut l) = ([0.0f32; 10], [[0.0f32; 3]; 10], [9u32; 5]);
        assert_eq!(batch(&times, &mut f, &mut g, &mut l), [DS_OK; 3]);
        for bad in [f32::NAN, t1 + 1.0] {
            let (mut f, mut g, mut l) = ([sentinel; 10], [[sentinel; 3]; 10], [9u32; 5]);
            times[1] = bad;
            times[3] = -1.0;
            let codes = batch(&times, &mut f, &mut g, &mut l);
            assert_eq!(codes, [DS_E_TIME_OUT_OF_RANGE; 3]);
            assert!(f.iter().chain(g.as_flattened()).all(|&v| v == sentinel) && l == [9; 5]);
            let message = last_error();
            assert!(
                message.starts_with(&format!("ds_label_batch: t[1] = {bad} is outside"))
                    && message.ends_with("(and 1 more time)"),
                "{message}"
            );
        }
        unsafe { ds_model_free(m) };
    }

    /// The loaders refuse an `out` overlapping their input, as the header documents.
    #[test]
    fn loader_outputs_over_the_input_are_refused() {
        let bytes = format::ModelWriter::random_siren(&[16, 16], 2, 3).to_bytes();
        let mut copy: Vec<u64> = vec![0; bytes.len().div_ceil(8)];
        let raw = copy.as_mut_ptr().cast::<u8>();
        unsafe { core::ptr::copy_nonoverlapping(bytes.as_ptr(), raw, bytes.len()) };
        let out = unsafe { raw.add(64) }.cast::<*mut DsModel>();
        assert_eq!(
            unsafe { ds_model_from_bytes(raw, bytes.len(), out) },
            DS_E_INVALID_ARGUMENT
        );
        assert!(unsafe { out.read() }.is_null());
        assert!(
            last_error().contains("`bytes` and `out` overlap"),
            "{}",
            last_error()
        );
        // `*out` is set to NULL first: each try needs a fresh copy of the path.
        for at in [0, 1] {
            let mut path = [0u64; 8];
            let p = path.as_mut_ptr();
            unsafe { core::ptr::copy_nonoverlapping(c"/no/such/model.dsm".as_ptr(), p.cast(), 19) };
            let out = unsafe { p.add(at) }.cast::<*mut DsModel>();
            assert_eq!(
                unsafe { ds_model_open(p.cast(), out) },
                DS_E_INVALID_ARGUMENT,
                "{at}"
            );
            assert!(unsafe { out.read() }.is_null());
            assert!(
                last_error().contains("`path` and `out` overlap"),
                "{}",
                last_error()
            );
        }
    }

    /// A FIFO (whose open for reading blocks until a writer comes) and a device are refused
    /// before they are opened.
    #[cfg(unix)]
    #[test]
    fn model_open_refuses_fifos_and_devices() {
        let dir = std::env::temp_dir().join(format!("ds-ffi-fifo-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let fifo = dir.join("model.dsm");
        let _ = std::fs::remove_file(&fifo);
        let made = std::process::Command::new("mkfifo").arg(&fifo).status();
        assert!(made.is_ok_and(|s| s.success()), "mkfifo");
        for path in [fifo.to_str().unwrap(), "/dev/zero", "/"] {
            let c = std::ffi::CString::new(path).unwrap();
            let (tx, rx) = std::sync::mpsc::channel();
            std::thread::spawn(move || {
                let mut m = core::ptr::null_mut();
                let rc = unsafe { ds_model_open(c.as_ptr(), &mut m) };
                let _ = tx.send((rc, m.is_null(), last_error()));
            });
            let (rc, null, message) = rx
                .recv_timeout(std::time::Duration::from_secs(10))
                .unwrap_or_else(|_| panic!("ds_model_open({path}) blocked"));
            assert_eq!(rc, DS_E_IO, "{path}: {message}");
            assert!(null && message.contains("not a regular file"), "{message}");
        }
        std::fs::remove_dir_all(&dir).unwrap();
    }

    #[test]
    fn names_are_cut_at_character_boundaries() {
        let mut buf = [0x7f as c_char; 4];
        // "aü" is 3 bytes: a 3-byte buffer holds "a" and the NUL, not half of "ü".
        let full = unsafe { write_c_string("aü", buf.as_mut_ptr(), 3) }.unwrap();
        assert_eq!(full, 3);
        assert_eq!(&buf[..3], &[b'a' as c_char, 0, 0x7f]);
        assert_eq!(
            unsafe { write_c_string("aü", core::ptr::null_mut(), 0) }.unwrap(),
            3
        );
    }

    #[test]
    fn the_size_limit_admits_the_largest_model() {
        // Every dimension at its limit, the motion network's too, must still load; one byte
        // more is not a model.
        let widths = [format::MAX_WIDTH as u32; format::MAX_SINE_LAYERS];
        let k = format::MAX_CLASSES as u32;
        let mut w = format::ModelWriter::random_motion(&widths, k, &widths, 1);
        w.metadata = "x".repeat(format::MAX_METADATA);
        let bytes = w.to_bytes();
        assert!(bytes.len() as u64 <= format::max_file_size());
        assert!(format::max_file_size() - (bytes.len() as u64) < format::WEIGHT_ALIGN as u64);
        assert!(DsModel::new(ModelBytes::copy_from(&bytes)).is_ok());
    }

    #[test]
    fn version_matches_the_package() {
        let v = unsafe { CStr::from_ptr(ds_version()) };
        assert_eq!(v.to_str().unwrap(), env!("CARGO_PKG_VERSION"));
    }
}
