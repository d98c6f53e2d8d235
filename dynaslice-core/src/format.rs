//! The model file format, versions 1 and 2 (byte by byte in `docs/model-format.md`).
//!
//! ```text
//! offset              size          content
//! 0                   256           Header (little-endian, bytemuck Pod)
//! 256                 64·K          K class records
//! 256 + 64·K          L             metadata, UTF-8 (L ≤ MAX_METADATA)
//! align64(…)          0..63         zero padding
//! weights_offset      4·N or 2·N    N weights, f32 or f16, layer by layer (see Layout)
//!                     4·M or 2·M    version 2 only: the motion network's M weights, same type
//! file_size − 4       4             CRC-32 of bytes [0, file_size − 4)
//! ```
//! Version 1 holds one network (the shape network g); version 2 adds a motion network u
//! ([`crate::Model::motion`]), described by header fields that version 1 keeps zero. A model
//! without motion is always written as version 1. The layout is canonical: every offset is
//! implied by the dimensions, and readers reject a file whose offsets disagree. Weights start
//! 64-byte aligned, so a model embedded with a 64-byte aligned `include_bytes!` is read in place.

pub use crate::class_record::{CLASS_RECORD_SIZE, MAX_NAME_LEN};
pub use crate::layout::{MAX_CLASSES, MAX_SINE_LAYERS, MAX_WIDTH};

use crate::class_record::ClassRecord;
use crate::layout::Layout;
use crate::model::{Model, Siren, Weights};
use crate::{crc32, Domain, Error};
use bytemuck::{Pod, Zeroable};
use half::f16;

/// The first 8 bytes of every model file.
pub const MAGIC: [u8; 8] = *b"DYNSLICE";
/// The newest format version this library reads and writes: 2, a model with a motion network.
/// It reads version 1 too, and writes a model without motion as version 1 ([`VERSION_STATIC`]).
pub const VERSION: u32 = 2;
/// The version of a model without motion (one network), unchanged since the first release.
pub const VERSION_STATIC: u32 = 1;
/// Outputs of the motion network: the displacement's x, y, z in normalised coordinates.
pub const MOTION_OUTPUTS: u32 = 3;
/// Size of [`Header`] in bytes.
pub const HEADER_SIZE: usize = 256;
/// Longest metadata section, in bytes.
pub const MAX_METADATA: usize = 1 << 20;
/// Alignment of the weight section, from the start of the file.
pub const WEIGHT_ALIGN: usize = 64;

/// Weight data type codes.
pub const DTYPE_F32: u32 = 0;
/// See [`DTYPE_F32`].
pub const DTYPE_F16: u32 = 1;

/// The fixed 256-byte header. All integers and floats little-endian.
#[repr(C)]
#[derive(Debug, Clone, Copy, Pod, Zeroable)]
pub struct Header {
    /// [`MAGIC`].
    pub magic: [u8; 8],
    /// [`VERSION_STATIC`] (1) without motion, [`VERSION`] (2) with a motion network.
    pub version: u32,
    /// [`HEADER_SIZE`].
    pub header_size: u32,
    /// Total file size including the CRC trailer.
    pub file_size: u64,
    /// [`DTYPE_F32`] or [`DTYPE_F16`].
    pub dtype: u32,
    /// K.
    pub num_classes: u32,
    /// d + 1.
    pub num_sine_layers: u32,
    /// Reserved, zero.
    pub flags: u32,
    /// Widths of the sine layers; unused slots zero.
    pub widths: [u32; MAX_SINE_LAYERS],
    /// [`Domain::center`].
    pub center: [f32; 3],
    /// [`Domain::scale`].
    pub scale: [f32; 3],
    /// [`Domain::time_origin`].
    pub time_origin: f32,
    /// [`Domain::time_span`].
    pub time_span: f32,
    /// [`Domain::output_scale`].
    pub output_scale: f32,
    /// ω_t^max (Eq. 4), in normalised time.
    pub omega_t_max: f32,
    /// Always [`HEADER_SIZE`].
    pub classes_offset: u64,
    /// Always `HEADER_SIZE + 64·K`.
    pub metadata_offset: u64,
    /// Metadata length in bytes.
    pub metadata_len: u64,
    /// `align64(metadata_offset + metadata_len)`.
    pub weights_offset: u64,
    /// Number of weights of the shape network, [`Layout::param_count`].
    pub weights_count: u64,
    /// Version 2: the motion network's sine layer count (1 ..= [`MAX_SINE_LAYERS`]); version 1:
    /// zero.
    pub motion_sine_layers: u32,
    /// Version 2: the motion network's sine layer widths; unused slots (and all in version 1)
    /// zero.
    pub motion_widths: [u32; MAX_SINE_LAYERS],
    /// Version 2: the motion network's own ω_t^max (Eq. 4), in normalised time; version 1:
    /// zero bits.
    pub motion_omega_t_max: f32,
    /// Version 2: the motion network's weight count, [`Layout::param_count`] of its layout
    /// with 3 outputs; version 1: zero.
    pub motion_weights_count: u64,
    /// Reserved, zero.
    pub reserved: [u8; 56],
}

const _: () = assert!(core::mem::size_of::<Header>() == HEADER_SIZE);

/// The largest file a valid model can be: every dimension at its limit, the motion network's
/// too (about 15 MB). Readers stop past it, so opening a huge file that is not a model fails
/// fast instead of reading all of it.
pub fn max_file_size() -> u64 {
    let widths = [MAX_WIDTH as u32; MAX_SINE_LAYERS];
    let params = |outputs: u32| {
        Layout::new(&widths, outputs)
            .map(|l| l.param_count())
            .unwrap_or(0) as u64
    };
    let before_weights =
        (HEADER_SIZE + CLASS_RECORD_SIZE * MAX_CLASSES + MAX_METADATA + WEIGHT_ALIGN - 1) as u64; // at most WEIGHT_ALIGN - 1 bytes of padding before the weights
    before_weights + 4 * (params(MAX_CLASSES as u32) + params(MOTION_OUTPUTS)) + 4
}

/// The motion network's layout from its header widths, with the errors of a motion field:
/// `BadDimension` "motion sine layer count" (0, which version 2 does not allow, or above
/// [`MAX_SINE_LAYERS`]) or "motion layer width".
fn motion_layout(widths: &[u32]) -> Result<Layout, Error> {
    if widths.is_empty() || widths.len() > MAX_SINE_LAYERS {
        return Err(Error::BadDimension {
            what: "motion sine layer count",
            value: widths.len() as u64,
            max: MAX_SINE_LAYERS as u64,
        });
    }
    if let Some(&w) = widths.iter().find(|&&w| w == 0 || w as usize > MAX_WIDTH) {
        return Err(Error::BadDimension {
            what: "motion layer width",
            value: w as u64,
            max: MAX_WIDTH as u64,
        });
    }
    Layout::new(widths, MOTION_OUTPUTS)
}

/// True for a valid ω_t^max: finite and ≥ 0 (−0 included).
fn valid_omega(omega_t_max: f32) -> bool {
    omega_t_max.is_finite() && omega_t_max >= 0.0
}

fn align_up(v: u64, a: u64) -> Option<u64> {
    v.checked_add(a - 1).map(|x| x / a * a)
}

/// Where every section lives, from the dimensions alone (checked arithmetic throughout).
struct Sections {
    metadata_offset: u64,
    weights_offset: u64,
    weights_bytes: u64,
    file_size: u64,
}

/// `motion`: the motion network's layout, whose weights follow the shape network's.
fn sections(
    layout: &Layout,
    motion: Option<&Layout>,
    metadata_len: u64,
    elem: u64,
) -> Option<Sections> {
    let metadata_offset =
        (HEADER_SIZE as u64).checked_add((layout.num_classes() as u64).checked_mul(64)?)?;
    let weights_offset = align_up(
        metadata_offset.checked_add(metadata_len)?,
        WEIGHT_ALIGN as u64,
    )?;
    let motion_count = motion.map_or(0, |m| m.param_count()) as u64;
    let weights_bytes = (layout.param_count() as u64)
        .checked_add(motion_count)?
        .checked_mul(elem)?;
    let file_size = weights_offset.checked_add(weights_bytes)?.checked_add(4)?;
    Some(Sections {
        metadata_offset,
        weights_offset,
        weights_bytes,
        file_size,
    })
}

impl<'a> Model<'a> {
    /// Validates `bytes` as a model file (see `docs/model-format.md`) and borrows its weights.
    ///
    /// Checks magic, version, every size with overflow-checked arithmetic, dimensions against
    /// the limits in [`crate::format`], the CRC32 trailer, the domain, class records, metadata
    /// and that every weight is finite. Never panics and never reads outside `bytes`. The bytes
    /// must start at an address aligned to 4 (f32 weights) or 2 (f16), else
    /// [`Error::Misaligned`].
    pub fn from_bytes(bytes: &'a [u8]) -> Result<Model<'a>, Error> {
        parse(bytes)
    }
}

/// Validates a model file; see [`Model::from_bytes`].
pub(crate) fn parse(bytes: &[u8]) -> Result<Model<'_>, Error> {
    if cfg!(target_endian = "big") {
        return Err(Error::BigEndianHost);
    }
    let available = bytes.len() as u64;
    let head = bytes.get(..HEADER_SIZE).ok_or(Error::Truncated {
        needed: HEADER_SIZE as u64,
        available,
    })?;
    let h: Header = bytemuck::pod_read_unaligned(head);
    if h.magic != MAGIC {
        return Err(Error::BadMagic);
    }
    let with_motion = match h.version {
        VERSION_STATIC => false,
        VERSION => true,
        v => return Err(Error::UnsupportedVersion(v)),
    };
    if h.header_size as usize != HEADER_SIZE {
        return Err(Error::BadHeaderSize(h.header_size));
    }
    let elem = match h.dtype {
        DTYPE_F32 => 4,
        DTYPE_F16 => 2,
        d => return Err(Error::BadDtype(d)),
    };
    let n_layers = h.num_sine_layers as usize;
    if n_layers == 0 || n_layers > MAX_SINE_LAYERS {
        return Err(Error::BadDimension {
            what: "sine layer count",
            value: n_layers as u64,
            max: MAX_SINE_LAYERS as u64,
        });
    }
    // Version 2: the motion network's layer count, as the shape network's above.
    let motion_layers = h.motion_sine_layers as usize;
    if with_motion && (motion_layers == 0 || motion_layers > MAX_SINE_LAYERS) {
        return Err(Error::BadDimension {
            what: "motion sine layer count",
            value: motion_layers as u64,
            max: MAX_SINE_LAYERS as u64,
        });
    }
    // Version 1 keeps every motion field zero (they were reserved bytes).
    let motion_fields_zero = h.motion_sine_layers == 0
        && h.motion_widths.iter().all(|&w| w == 0)
        && h.motion_omega_t_max.to_bits() == 0
        && h.motion_weights_count == 0;
    let unused_motion_widths = match with_motion {
        true => &h.motion_widths[motion_layers..],
        false => &[][..],
    };
    if h.widths[n_layers..].iter().any(|&w| w != 0)
        || h.flags != 0
        || h.reserved.iter().any(|&b| b != 0)
        || (!with_motion && !motion_fields_zero)
        || unused_motion_widths.iter().any(|&w| w != 0)
    {
        return Err(Error::NonZeroPadding);
    }
    let layout = Layout::new(&h.widths[..n_layers], h.num_classes)?;
    let motion_layout = match with_motion {
        true => Some(motion_layout(&h.motion_widths[..motion_layers])?),
        false => None,
    };
    if h.metadata_len > MAX_METADATA as u64 {
        return Err(Error::BadDimension {
            what: "metadata length",
            value: h.metadata_len,
            max: MAX_METADATA as u64,
        });
    }
    let s = sections(&layout, motion_layout.as_ref(), h.metadata_len, elem)
        .ok_or(Error::BadLayout("size overflow"))?;
    if h.classes_offset != HEADER_SIZE as u64 {
        return Err(Error::BadLayout("class table offset"));
    }
    if h.metadata_offset != s.metadata_offset {
        return Err(Error::BadLayout("metadata offset"));
    }
    if h.weights_offset != s.weights_offset {
        return Err(Error::BadLayout("weights offset"));
    }
    if h.weights_count != layout.param_count() as u64 {
        return Err(Error::BadLayout(
            "weight count does not match the layer widths",
        ));
    }
    if let Some(m) = &motion_layout {
        if h.motion_weights_count != m.param_count() as u64 {
            return Err(Error::BadLayout(
                "motion weight count does not match the motion layer widths",
            ));
        }
    }
    if h.file_size != s.file_size {
        return Err(Error::BadLayout("file size does not match the dimensions"));
    }
    if available < s.file_size {
        return Err(Error::Truncated {
            needed: s.file_size,
            available,
        });
    }
    if available > s.file_size {
        return Err(Error::BadLayout("bytes after the CRC trailer"));
    }
    // Every offset below is now known to lie inside `bytes` (all ≤ file_size = len).
    let body_len = bytes.len() - 4;
    let (body, trailer) = bytes.split_at(body_len);
    let stored = u32::from_le_bytes([trailer[0], trailer[1], trailer[2], trailer[3]]);
    let computed = crc32(body);
    if stored != computed {
        return Err(Error::CrcMismatch { stored, computed });
    }

    let domain = Domain {
        center: h.center,
        scale: h.scale,
        time_origin: h.time_origin,
        time_span: h.time_span,
        output_scale: h.output_scale,
    };
    domain.validate()?;
    if !valid_omega(h.omega_t_max) {
        return Err(Error::BadHeaderValue(
            "omega_t_max is not a non-negative finite number",
        ));
    }
    if with_motion && !valid_omega(h.motion_omega_t_max) {
        return Err(Error::BadHeaderValue(
            "motion omega_t_max is not a non-negative finite number",
        ));
    }

    let meta_start = s.metadata_offset as usize;
    let meta_end = meta_start + h.metadata_len as usize;
    let classes = &body[HEADER_SIZE..meta_start];
    for (i, raw) in classes.chunks_exact(CLASS_RECORD_SIZE).enumerate() {
        ClassRecord::decode(raw, i as u32 + 1)?;
    }
    let metadata =
        core::str::from_utf8(&body[meta_start..meta_end]).map_err(|_| Error::BadMetadata)?;
    let w_start = s.weights_offset as usize;
    if body[meta_end..w_start].iter().any(|&b| b != 0) {
        return Err(Error::NonZeroPadding);
    }
    let raw = &body[w_start..w_start + s.weights_bytes as usize];
    let weights = match h.dtype {
        DTYPE_F32 => Weights::F32(bytemuck::try_cast_slice(raw).map_err(|_| Error::Misaligned)?),
        _ => Weights::F16(bytemuck::try_cast_slice::<u8, f16>(raw).map_err(|_| Error::Misaligned)?),
    };
    let bad = match weights {
        Weights::F32(w) => w.iter().position(|v| !v.is_finite()),
        Weights::F16(w) => w.iter().position(|v| !v.is_finite()),
    };
    if let Some(index) = bad {
        return Err(Error::NonFiniteWeight {
            index: index as u64,
        });
    }
    // The shape network's N weights, then the motion network's (all N + M checked above).
    let n = layout.param_count();
    let motion = motion_layout.map(|m| Siren {
        layout: m,
        omega_t_max: h.motion_omega_t_max,
        weights: weights.sub(n, m.param_count()),
    });
    Ok(Model {
        layout,
        domain,
        omega_t_max: h.omega_t_max,
        weights: weights.sub(0, n),
        motion,
        classes,
        metadata,
    })
}

#[cfg(feature = "std")]
pub use writer::{ModelWriter, MotionWriter, WeightType};

#[cfg(feature = "std")]
mod writer {
    use super::*;
    use std::string::String;
    use std::vec::Vec;

    /// Storage precision of the weights in a written file.
    #[derive(Debug, Clone, Copy, PartialEq, Eq)]
    pub enum WeightType {
        /// 4 bytes per weight: exact.
        F32,
        /// 2 bytes per weight: half the size; see docs/model-format.md for the measured error.
        F16,
    }

    /// The motion network u of a [`ModelWriter`]: a SIREN with the shape network's conventions
    /// (first layer rows ω_x, ω_y, ω_z, ω_t then φ; [`Layout`] order) and 3 outputs, the
    /// displacement in normalised coordinates (y = x_n + u(x_n, t_n)).
    #[derive(Debug, Clone, PartialEq)]
    pub struct MotionWriter {
        /// Widths of its sine layers (1 ..= [`MAX_SINE_LAYERS`] entries, each ≤ [`MAX_WIDTH`]).
        pub widths: Vec<u32>,
        /// Its own ω_t^max (Eq. 4) in normalised time, finite and ≥ 0.
        pub omega_t_max: f32,
        /// All its parameters in [`Layout`] order, for `Layout::new(&widths, 3)`.
        pub params: Vec<f32>,
    }

    impl MotionWriter {
        /// The validated layout of this motion network (3 outputs), with the reader's errors.
        pub fn layout(&self) -> Result<Layout, Error> {
            motion_layout(&self.widths)
        }
    }

    /// An owned model to be written: the exact inverse of [`Model::from_bytes`].
    #[derive(Debug, Clone, PartialEq)]
    pub struct ModelWriter {
        /// Widths of the sine layers (d + 1 entries).
        pub widths: Vec<u32>,
        /// (name, source label value) per class, K entries.
        pub classes: Vec<(String, i32)>,
        /// World ↔ normalised map.
        pub domain: Domain,
        /// ω_t^max of Eq. 4 in normalised time.
        pub omega_t_max: f32,
        /// All parameters in [`Layout`] order.
        pub params: Vec<f32>,
        /// Free-form UTF-8 (the trainer records its options here).
        pub metadata: String,
        /// Storage precision (of both networks' weights).
        pub weight_type: WeightType,
        /// The motion network of a motion model (written as version 2), or `None` (version 1,
        /// the bytes every writer before motion models wrote).
        pub motion: Option<MotionWriter>,
    }

    impl ModelWriter {
        /// A SIREN-initialised network (Sitzmann et al. 2020, with ω₀ = 30 folded into the
        /// weights): first layer U(−ω₀/4, ω₀/4) for ω_x, ω_t in [−ω_t^max, ω_t^max] with
        /// ω_t^max = 2π·4; hidden layers U(−√(6/fan_in), √(6/fan_in)); an identity domain; a
        /// deterministic function of `seed`. Useful as a fixture for tests and benchmarks.
        pub fn random_siren(widths: &[u32], num_classes: u32, seed: u64) -> ModelWriter {
            let mut rng = SplitMix64(seed);
            let omega_t_max = 8.0 * core::f32::consts::PI;
            let classes = (1..=num_classes)
                .map(|k| (std::format!("class {k}"), k as i32))
                .collect();
            let mut w = ModelWriter {
                widths: widths.to_vec(),
                classes,
                domain: Domain::IDENTITY,
                omega_t_max,
                params: Vec::new(),
                metadata: String::new(),
                weight_type: WeightType::F32,
                motion: None,
            };
            if let Ok(layout) = w.layout() {
                w.params = siren_params(&layout, omega_t_max, 1.0, &mut rng);
            }
            w
        }

        /// A random motion model, a fixture like [`ModelWriter::random_siren`]: that shape
        /// network (`widths`, K = `num_classes`, `seed`) and a SIREN-initialised motion network
        /// of `motion_widths` whose ω_t^max is 2π·2, with first-layer ω_t drawn from twice that
        /// range (so the clamp of Eq. 4 acts on about half of them) and its output layer scaled
        /// by 0.1 (displacements of a few tenths of the normalised cube).
        pub fn random_motion(
            widths: &[u32],
            num_classes: u32,
            motion_widths: &[u32],
            seed: u64,
        ) -> ModelWriter {
            let mut w = ModelWriter::random_siren(widths, num_classes, seed);
            let mut rng = SplitMix64(seed ^ 0x6d6f_7469_6f6e); // "motion"
            let omega_t_max = 4.0 * core::f32::consts::PI;
            let mut motion = MotionWriter {
                widths: motion_widths.to_vec(),
                omega_t_max,
                params: Vec::new(),
            };
            if let Ok(layout) = motion.layout() {
                motion.params = siren_params(&layout, 2.0 * omega_t_max, 0.1, &mut rng);
            }
            w.motion = Some(motion);
            w
        }

        /// The validated layout of this model.
        pub fn layout(&self) -> Result<Layout, Error> {
            Layout::new(&self.widths, self.classes.len() as u32)
        }

        /// Serialises the model, checking everything [`Model::from_bytes`] checks: version 1
        /// without motion, version 2 with it.
        pub fn try_to_bytes(&self) -> Result<Vec<u8>, Error> {
            let layout = self.layout()?;
            if self.params.len() != layout.param_count() {
                return Err(Error::InvalidModel(
                    "parameter count does not match the widths",
                ));
            }
            let motion_layout = self.motion.as_ref().map(|m| m.layout()).transpose()?;
            let motion_params = self.motion.as_ref().map_or(&[][..], |m| &m.params[..]);
            if motion_params.len() != motion_layout.map_or(0, |m| m.param_count()) {
                return Err(Error::InvalidModel(
                    "motion parameter count does not match the motion widths",
                ));
            }
            // Indices in the weight section: the shape network's, then the motion network's.
            let all = || self.params.iter().chain(motion_params);
            if let Some(i) = all().position(|v| !v.is_finite()) {
                return Err(Error::NonFiniteWeight { index: i as u64 });
            }
            if self.weight_type == WeightType::F16 && all().any(|&v| !f16::from_f32(v).is_finite())
            {
                return Err(Error::InvalidModel("a weight overflows f16"));
            }
            self.domain.validate()?;
            if !valid_omega(self.omega_t_max) {
                return Err(Error::InvalidModel(
                    "omega_t_max must be finite and non-negative",
                ));
            }
            if self
                .motion
                .as_ref()
                .is_some_and(|m| !valid_omega(m.omega_t_max))
            {
                return Err(Error::InvalidModel(
                    "motion omega_t_max must be finite and non-negative",
                ));
            }
            if self.metadata.len() > MAX_METADATA {
                return Err(Error::InvalidModel("metadata too long"));
            }
            if self
                .classes
                .iter()
                .any(|(name, _)| name.len() > MAX_NAME_LEN)
            {
                return Err(Error::InvalidModel("class name longer than 56 bytes"));
            }
            let (elem, dtype) = match self.weight_type {
                WeightType::F32 => (4, DTYPE_F32),
                WeightType::F16 => (2, DTYPE_F16),
            };
            let s = sections(
                &layout,
                motion_layout.as_ref(),
                self.metadata.len() as u64,
                elem,
            )
            .ok_or(Error::InvalidModel("model too large"))?;
            let mut widths = [0u32; MAX_SINE_LAYERS];
            widths[..self.widths.len()].copy_from_slice(&self.widths);
            let mut motion_widths = [0u32; MAX_SINE_LAYERS];
            if let Some(m) = &self.motion {
                motion_widths[..m.widths.len()].copy_from_slice(&m.widths);
            }
            let header = Header {
                magic: MAGIC,
                version: match self.motion {
                    Some(_) => VERSION,
                    None => VERSION_STATIC,
                },
                header_size: HEADER_SIZE as u32,
                file_size: s.file_size,
                dtype,
                num_classes: self.classes.len() as u32,
                num_sine_layers: self.widths.len() as u32,
                flags: 0,
                widths,
                center: self.domain.center,
                scale: self.domain.scale,
                time_origin: self.domain.time_origin,
                time_span: self.domain.time_span,
                output_scale: self.domain.output_scale,
                omega_t_max: self.omega_t_max,
                classes_offset: HEADER_SIZE as u64,
                metadata_offset: s.metadata_offset,
                metadata_len: self.metadata.len() as u64,
                weights_offset: s.weights_offset,
                weights_count: self.params.len() as u64,
                motion_sine_layers: self.motion.as_ref().map_or(0, |m| m.widths.len() as u32),
                motion_widths,
                motion_omega_t_max: self.motion.as_ref().map_or(0.0, |m| m.omega_t_max),
                motion_weights_count: motion_params.len() as u64,
                reserved: [0; 56],
            };
            let mut out = Vec::with_capacity(s.file_size as usize);
            out.extend_from_slice(bytemuck::bytes_of(&header));
            for (name, label) in &self.classes {
                let mut rec = [0u8; CLASS_RECORD_SIZE];
                rec[0..4].copy_from_slice(&label.to_le_bytes());
                rec[4..8].copy_from_slice(&(name.len() as u32).to_le_bytes());
                rec[8..8 + name.len()].copy_from_slice(name.as_bytes());
                out.extend_from_slice(&rec);
            }
            out.extend_from_slice(self.metadata.as_bytes());
            out.resize(s.weights_offset as usize, 0);
            match self.weight_type {
                WeightType::F32 => all().for_each(|v| out.extend_from_slice(&v.to_le_bytes())),
                WeightType::F16 => {
                    all().for_each(|&v| out.extend_from_slice(&f16::from_f32(v).to_le_bytes()))
                }
            }
            let crc = crc32(&out);
            out.extend_from_slice(&crc.to_le_bytes());
            debug_assert_eq!(out.len() as u64, s.file_size);
            Ok(out)
        }

        /// Serialises a model known to be valid; panics with the reason otherwise (use
        /// [`ModelWriter::try_to_bytes`] for models built from untrusted values).
        pub fn to_bytes(&self) -> Vec<u8> {
            match self.try_to_bytes() {
                Ok(b) => b,
                Err(e) => panic!("invalid model: {e}"),
            }
        }

        /// Reads a model back into an owned writer (f16 weights widened to f32), its motion
        /// network included.
        pub fn from_model(model: &Model) -> ModelWriter {
            let weights = model.weights();
            let params = |w: Weights| (0..w.len()).filter_map(|i| w.get(i)).collect();
            let widths = |l: &Layout| l.widths().iter().map(|&w| w as u32).collect();
            ModelWriter {
                widths: widths(model.layout()),
                classes: model.classes().map(|c| (c.name.into(), c.label)).collect(),
                domain: *model.domain(),
                omega_t_max: model.omega_t_max(),
                params: params(weights),
                metadata: model.metadata().into(),
                weight_type: match weights {
                    Weights::F32(_) => WeightType::F32,
                    Weights::F16(_) => WeightType::F16,
                },
                motion: model.motion().map(|m| MotionWriter {
                    widths: widths(m.layout()),
                    omega_t_max: m.omega_t_max(),
                    params: params(m.weights()),
                }),
            }
        }
    }

    /// SIREN initial parameters for `layout` (Sitzmann et al. 2020, ω₀ = 30 folded in): first
    /// layer ω_x ~ U(−ω₀/4, ω₀/4), ω_t ~ U(−`omega_t`, `omega_t`), hidden layers
    /// U(−√(6/fan_in), √(6/fan_in)), biases U(−1/√fan_in, 1/√fan_in); the output layer's
    /// weights and bias times `output_gain`.
    fn siren_params(
        layout: &Layout,
        omega_t: f32,
        output_gain: f32,
        rng: &mut SplitMix64,
    ) -> Vec<f32> {
        let mut params = Vec::with_capacity(layout.param_count());
        for l in 0..layout.num_layers() {
            let (fan_in, fan_out) = layout.layer_dims(l);
            let gain = if l + 1 == layout.num_layers() {
                output_gain
            } else {
                1.0
            };
            let bound = if l == 0 {
                30.0 / fan_in as f32
            } else {
                (6.0 / fan_in as f32).sqrt()
            };
            for i in 0..fan_in {
                let b = if l == 0 && i == 3 { omega_t } else { bound };
                params.extend((0..fan_out).map(|_| gain * rng.uniform(-b, b)));
            }
            let bb = 1.0 / (fan_in as f32).sqrt();
            params.extend((0..fan_out).map(|_| gain * rng.uniform(-bb, bb)));
        }
        params
    }

    /// SplitMix64 (Steele et al. 2014): tiny, seedable, good enough for initial weights.
    struct SplitMix64(u64);

    impl SplitMix64 {
        fn next(&mut self) -> u64 {
            self.0 = self.0.wrapping_add(0x9E37_79B9_7F4A_7C15);
            let mut z = self.0;
            z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
            z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
            z ^ (z >> 31)
        }
        fn uniform(&mut self, lo: f32, hi: f32) -> f32 {
            let u = (self.next() >> 40) as f32 / (1u64 << 24) as f32;
            lo + (hi - lo) * u
        }
    }
}

#[cfg(all(test, feature = "std"))]
mod tests {
    // Here rather than in model.rs: the model's tests need the writer, which needs the model,
    // and the core keeps no file circle, tests included (tests/architecture.rs).
    use super::ModelWriter;
    use crate::ModelBytes;
    use std::string::ToString;
    use std::vec;

    #[test]
    fn find_class_takes_numbers_first_then_names() {
        let mut w = ModelWriter::random_siren(&[8], 3, 1);
        w.classes = vec![
            ("liver".to_string(), 5),
            ("3".to_string(), 7),
            ("lung left".to_string(), 2),
        ];
        let bytes = ModelBytes::copy_from(&w.to_bytes());
        let m = bytes.model().unwrap();
        assert_eq!(m.find_class("1"), Some(0));
        assert_eq!(m.find_class("3"), Some(2), "a number wins over a name");
        assert_eq!(m.find_class("lung left"), Some(2));
        assert_eq!(m.find_class("liver"), Some(0));
        assert_eq!(m.find_class("0"), None);
        assert_eq!(m.find_class("4"), None);
        assert_eq!(m.find_class("Liver"), None);
        assert_eq!(m.find_class(""), None);
    }
}
