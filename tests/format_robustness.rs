//! `Model::from_bytes` against damaged and hostile files (the core's promise: no panic on any input).
//!
//! The format promises three things that these tests pin down:
//! 1. **Never a panic, never a read outside the buffer**, whatever the bytes: every test below
//!    feeds bytes to `from_bytes` and, when a model is accepted, runs every kind of query on it.
//!    A panic anywhere fails the test.
//! 2. **Every damaged file is rejected.** The CRC-32 trailer covers every byte before it, and a
//!    CRC-32 detects every error burst of at most 32 bits, so any change confined to 4
//!    consecutive bytes must be rejected. Checks that run *before* the CRC (sizes, offsets) are
//!    reached by mutating the header and then recomputing the trailer, so the deep validation
//!    is exercised too, with the exact error each damage must produce.
//! 3. **The format is canonical.** Every offset is implied by the dimensions and every padding
//!    byte must be zero, so an accepted file is exactly what `ModelWriter` writes for the model it
//!    decodes to: `ModelWriter::from_model(&Model::from_bytes(b)?).to_bytes() == b` for every
//!    accepted `b`, f32 and f16 alike. This is checked on every accepted input, including the
//!    ones a mutation happened to leave valid.
//!
//! Each holds for version 1 (one network) and version 2 (a motion model: motion fields in the
//! header, the motion network's weights after the shape network's), and version-1 files keep
//! every motion field zero.
//!
//! All of it runs in a few seconds (small fixtures; the exhaustive loops are over ~1 KiB files).

use dynaslice_core::format::{
    max_file_size, Header, ModelWriter, MotionWriter, WeightType, CLASS_RECORD_SIZE, HEADER_SIZE,
    MAGIC, MAX_CLASSES, MAX_METADATA, MAX_NAME_LEN, MAX_SINE_LAYERS, MAX_WIDTH, VERSION,
    VERSION_STATIC, WEIGHT_ALIGN,
};
use dynaslice_core::{crc32, Domain, Error, Model, ModelBytes, Scratch, UNDEFINED_LABEL};
use proptest::prelude::*;
use std::mem::offset_of;

// ---------------------------------------------------------------------------------------------
// Byte offsets of the header fields, as documented in docs/model-format.md. They are written out
// here (rather than taken from `offset_of!`) so that `header_offsets_are_the_documented_ones`
// fails if the struct and the document ever drift apart.
const OFF_MAGIC: usize = 0;
const OFF_VERSION: usize = 8;
const OFF_HEADER_SIZE: usize = 12;
const OFF_FILE_SIZE: usize = 16;
const OFF_DTYPE: usize = 24;
const OFF_NUM_CLASSES: usize = 28;
const OFF_NUM_SINE_LAYERS: usize = 32;
const OFF_FLAGS: usize = 36;
const OFF_WIDTHS: usize = 40;
const OFF_CENTER: usize = 72;
const OFF_SCALE: usize = 84;
const OFF_TIME_ORIGIN: usize = 96;
const OFF_TIME_SPAN: usize = 100;
const OFF_OUTPUT_SCALE: usize = 104;
const OFF_OMEGA_T_MAX: usize = 108;
const OFF_CLASSES_OFFSET: usize = 112;
const OFF_METADATA_OFFSET: usize = 120;
const OFF_METADATA_LEN: usize = 128;
const OFF_WEIGHTS_OFFSET: usize = 136;
const OFF_WEIGHTS_COUNT: usize = 144;
const OFF_MOTION_SINE_LAYERS: usize = 152;
const OFF_MOTION_WIDTHS: usize = 156;
const OFF_MOTION_OMEGA_T_MAX: usize = 188;
const OFF_MOTION_WEIGHTS_COUNT: usize = 192;
const OFF_RESERVED: usize = 200;

// ---------------------------------------------------------------------------------------------
// Helpers.

/// An aligned copy of `misalign` zero bytes followed by `bytes`, so that `&copy[misalign..]`
/// holds `bytes` exactly `misalign` bytes past an 8-byte boundary. Every other test holds its
/// bytes in a [`ModelBytes`]: `from_bytes` reads weights in place and rightly rejects weights
/// not aligned for f32/f16 (`Error::Misaligned`), and a `Vec<u8>` is only guaranteed 1-byte
/// alignment, so a test could otherwise pass or fail depending on what the allocator returned.
fn shifted(bytes: &[u8], misalign: usize) -> ModelBytes {
    ModelBytes::copy_from(&[&vec![0; misalign], bytes].concat())
}

/// Rewrites the CRC-32 trailer (the last 4 bytes) to match the bytes before it, so that a
/// mutation reaches the checks behind the CRC. Buffers shorter than the trailer are left alone.
fn fix_crc(bytes: &mut [u8]) {
    if let Some(body_len) = bytes.len().checked_sub(4) {
        let crc = crc32(&bytes[..body_len]);
        bytes[body_len..].copy_from_slice(&crc.to_le_bytes());
    }
}

fn put_u32(bytes: &mut [u8], at: usize, v: u32) {
    bytes[at..at + 4].copy_from_slice(&v.to_le_bytes());
}

fn put_u64(bytes: &mut [u8], at: usize, v: u64) {
    bytes[at..at + 8].copy_from_slice(&v.to_le_bytes());
}

fn put_f32(bytes: &mut [u8], at: usize, v: f32) {
    put_u32(bytes, at, v.to_bits());
}

fn get_u64(bytes: &[u8], at: usize) -> u64 {
    u64::from_le_bytes(bytes[at..at + 8].try_into().unwrap())
}

/// Loads `bytes` (from an aligned copy) and, if accepted, checks the canonical round trip and
/// runs every query kind. Returns what `from_bytes` returned, so callers can check the error.
fn load(bytes: &[u8]) -> Result<(), Error> {
    let copy = ModelBytes::copy_from(bytes);
    let model = copy.model()?;
    let rewritten = ModelWriter::from_model(&model).try_to_bytes();
    assert!(
        rewritten.as_deref() == Ok(bytes),
        "an accepted file is not the canonical encoding of its model: {:?}",
        rewritten.map(|r| first_difference(&r, bytes))
    );
    query_everything(&model);
    Ok(())
}

fn first_difference(a: &[u8], b: &[u8]) -> (usize, usize, Option<usize>) {
    let at = a.iter().zip(b).position(|(x, y)| x != y);
    (a.len(), b.len(), at)
}

/// Runs every query of the public API on `model`. The queries must succeed (buffers are sized
/// right) whatever the weights are; their values may be anything for a hostile model (huge
/// finite weights overflow to ±∞ and then NaN), so only labels are range-checked.
fn query_everything(model: &Model) {
    let k = model.num_classes();
    let points = [
        ([0.0, 0.0, 0.0], 0.0),
        ([0.3, -0.7, 0.9], 0.25),
        ([-1.0, 1.0, -1.0], 1.0),
        ([1e30, -1e30, 0.0], -1e30),
        ([f32::NAN, 0.0, 0.0], 0.5),
    ];
    let (mut f, mut g, mut d) = (vec![0.0; k], vec![[0.0; 3]; k], vec![0.0; k]);
    for &(x, t) in &points {
        model.eval(x, t, &mut f).unwrap();
        model.eval_grad(x, t, &mut f, &mut g).unwrap();
        model.eval_jacobian(x, t, &mut f, &mut g, &mut d).unwrap();
        let label = model.label(x, t);
        assert!(
            label as usize <= k || label == UNDEFINED_LABEL,
            "label {label}"
        );
    }
    // Batches: empty, one point, and more points than one 12-point jacobian block.
    let mut scratch = Scratch::boxed();
    for n in [0, 1, 13] {
        let xyz: Vec<[f32; 3]> = (0..n).map(|i| points[i % points.len()].0).collect();
        let t: Vec<f32> = (0..n).map(|i| points[i % points.len()].1).collect();
        let (mut f, mut g, mut d) = (vec![0.0; n * k], vec![[0.0; 3]; n * k], vec![0.0; n * k]);
        let mut labels = vec![0u32; n];
        model.eval_batch(&mut scratch, &xyz, &t, &mut f).unwrap();
        model
            .eval_grad_batch(&mut scratch, &xyz, &t, &mut f, &mut g)
            .unwrap();
        model
            .eval_jacobian_batch(&mut scratch, &xyz, &t, &mut f, &mut g, &mut d)
            .unwrap();
        model
            .label_batch(&mut scratch, &xyz, &t, &mut labels)
            .unwrap();
        assert!(labels
            .iter()
            .all(|&l| l as usize <= k || l == UNDEFINED_LABEL));
        let mut u = vec![[0.0; 3]; n];
        model
            .displacement_batch(&mut scratch, &xyz, &t, &mut u)
            .unwrap();
    }
    for &(x, t) in &points {
        model.displacement(x, t).unwrap();
    }
}

/// A small model with everything a file can hold: two hidden widths, multi-byte UTF-8 names,
/// negative source labels, metadata whose end is not 64-aligned (so there is padding before the
/// weights), and a non-identity domain.
fn fixture(weight_type: WeightType) -> ModelWriter {
    let mut w = ModelWriter::random_siren(&[8, 6], 2, 42);
    w.classes = vec![("Myokard \u{2665}".into(), 3), ("Blutpool".into(), -7)];
    w.metadata = "{\"trainer\":\"dynaslice 0.1\",\"epochs\":3}".into();
    w.domain = Domain {
        center: [12.5, -40.0, 7.25],
        scale: [80.0, 80.0, 64.0],
        time_origin: 0.1,
        time_span: 0.8,
        output_scale: 80.0,
    };
    w.weight_type = weight_type;
    w
}

/// [`fixture`] with a motion network of widths [5, 3] (55 weights after the shape network's
/// 108), its own ω_t^max: a version-2 file.
fn motion_fixture(weight_type: WeightType) -> ModelWriter {
    let mut w = fixture(weight_type);
    w.motion = ModelWriter::random_motion(&[4], 1, &MOTION_WIDTHS, 7).motion;
    w
}

/// The motion fixture's motion widths.
const MOTION_WIDTHS: [u32; 2] = [5, 3];

/// Section offsets the header must hold for a model of these dimensions (docs/model-format.md).
struct Expected {
    metadata_offset: u64,
    weights_offset: u64,
    weights_count: u64,
    file_size: u64,
}

/// `motion`: the motion network's widths (none for version 1).
fn expected_sections(
    widths: &[u64],
    k: u64,
    motion: &[u64],
    metadata_len: u64,
    elem: u64,
) -> Expected {
    let metadata_offset = HEADER_SIZE as u64 + CLASS_RECORD_SIZE as u64 * k;
    let a = WEIGHT_ALIGN as u64;
    let weights_offset = (metadata_offset + metadata_len).div_ceil(a) * a;
    let weights_count = param_count(widths, k);
    let motion_count = if motion.is_empty() {
        0
    } else {
        param_count(motion, 3)
    };
    Expected {
        metadata_offset,
        weights_offset,
        weights_count,
        file_size: weights_offset + (weights_count + motion_count) * elem + 4,
    }
}

/// Σ (fan_in + 1)·fan_out over a network's layers (docs/model-format.md).
fn param_count(widths: &[u64], outputs: u64) -> u64 {
    let mut fan_in = 4;
    let mut count = 0;
    for &w in widths.iter().chain([outputs].iter()) {
        count += (fan_in + 1) * w;
        fan_in = w;
    }
    count
}

// ---------------------------------------------------------------------------------------------
// The layout itself.

#[test]
fn header_offsets_are_the_documented_ones() {
    assert_eq!(std::mem::size_of::<Header>(), HEADER_SIZE);
    let documented = [
        (offset_of!(Header, magic), OFF_MAGIC),
        (offset_of!(Header, version), OFF_VERSION),
        (offset_of!(Header, header_size), OFF_HEADER_SIZE),
        (offset_of!(Header, file_size), OFF_FILE_SIZE),
        (offset_of!(Header, dtype), OFF_DTYPE),
        (offset_of!(Header, num_classes), OFF_NUM_CLASSES),
        (offset_of!(Header, num_sine_layers), OFF_NUM_SINE_LAYERS),
        (offset_of!(Header, flags), OFF_FLAGS),
        (offset_of!(Header, widths), OFF_WIDTHS),
        (offset_of!(Header, center), OFF_CENTER),
        (offset_of!(Header, scale), OFF_SCALE),
        (offset_of!(Header, time_origin), OFF_TIME_ORIGIN),
        (offset_of!(Header, time_span), OFF_TIME_SPAN),
        (offset_of!(Header, output_scale), OFF_OUTPUT_SCALE),
        (offset_of!(Header, omega_t_max), OFF_OMEGA_T_MAX),
        (offset_of!(Header, classes_offset), OFF_CLASSES_OFFSET),
        (offset_of!(Header, metadata_offset), OFF_METADATA_OFFSET),
        (offset_of!(Header, metadata_len), OFF_METADATA_LEN),
        (offset_of!(Header, weights_offset), OFF_WEIGHTS_OFFSET),
        (offset_of!(Header, weights_count), OFF_WEIGHTS_COUNT),
        (
            offset_of!(Header, motion_sine_layers),
            OFF_MOTION_SINE_LAYERS,
        ),
        (offset_of!(Header, motion_widths), OFF_MOTION_WIDTHS),
        (
            offset_of!(Header, motion_omega_t_max),
            OFF_MOTION_OMEGA_T_MAX,
        ),
        (
            offset_of!(Header, motion_weights_count),
            OFF_MOTION_WEIGHTS_COUNT,
        ),
        (offset_of!(Header, reserved), OFF_RESERVED),
    ];
    for (i, (actual, doc)) in documented.iter().enumerate() {
        assert_eq!(actual, doc, "header field {i}");
    }
    assert_eq!(OFF_RESERVED + 56, HEADER_SIZE);

    // And a written file holds its sections exactly where the document says: version 1
    // without motion (every motion field zero), version 2 with it.
    let cases = [
        (fixture(WeightType::F32), 4),
        (fixture(WeightType::F16), 2),
        (motion_fixture(WeightType::F32), 4),
        (motion_fixture(WeightType::F16), 2),
    ];
    for (w, elem) in cases {
        let weight_type = w.weight_type;
        let bytes = w.to_bytes();
        let motion: Vec<u64> = match &w.motion {
            Some(m) => m.widths.iter().map(|&v| v as u64).collect(),
            None => vec![],
        };
        let e = expected_sections(&[8, 6], 2, &motion, w.metadata.len() as u64, elem);
        let motion_count = if motion.is_empty() {
            0
        } else {
            param_count(&motion, 3)
        };
        let version = u32::from_le_bytes(bytes[OFF_VERSION..OFF_VERSION + 4].try_into().unwrap());
        assert_eq!(version, if motion.is_empty() { 1 } else { 2 });
        let u32_at = |at: usize| u32::from_le_bytes(bytes[at..at + 4].try_into().unwrap());
        assert_eq!(u32_at(OFF_MOTION_SINE_LAYERS), motion.len() as u32);
        for l in 0..MAX_SINE_LAYERS {
            let want = motion.get(l).copied().unwrap_or(0) as u32;
            assert_eq!(u32_at(OFF_MOTION_WIDTHS + 4 * l), want);
        }
        let omega = w.motion.as_ref().map_or(0, |m| m.omega_t_max.to_bits());
        assert_eq!(u32_at(OFF_MOTION_OMEGA_T_MAX), omega);
        assert_eq!(get_u64(&bytes, OFF_MOTION_WEIGHTS_COUNT), motion_count);
        assert!(bytes[OFF_RESERVED..HEADER_SIZE].iter().all(|&b| b == 0));
        // The motion network's first weight follows the shape network's last.
        if let Some(m) = &w.motion {
            let at = (e.weights_offset + e.weights_count * elem) as usize;
            let first = &bytes[at..at + elem as usize];
            let value = match weight_type {
                WeightType::F32 => f32::from_le_bytes(first.try_into().unwrap()),
                WeightType::F16 => half_to_f32(u16::from_le_bytes(first.try_into().unwrap())),
            };
            let want = match weight_type {
                WeightType::F32 => m.params[0],
                WeightType::F16 => half_to_f32(half_bits(m.params[0])),
            };
            assert_eq!(value.to_bits(), want.to_bits());
        }
        assert_eq!(&bytes[..8], &MAGIC);
        assert_eq!(get_u64(&bytes, OFF_FILE_SIZE), e.file_size);
        assert_eq!(bytes.len() as u64, e.file_size);
        assert_eq!(get_u64(&bytes, OFF_CLASSES_OFFSET), HEADER_SIZE as u64);
        assert_eq!(get_u64(&bytes, OFF_METADATA_OFFSET), e.metadata_offset);
        assert_eq!(get_u64(&bytes, OFF_WEIGHTS_OFFSET), e.weights_offset);
        assert_eq!(get_u64(&bytes, OFF_WEIGHTS_COUNT), e.weights_count);
        assert_eq!(e.weights_offset % WEIGHT_ALIGN as u64, 0);
        // The first class record: label, name length, name.
        let rec = &bytes[HEADER_SIZE..HEADER_SIZE + CLASS_RECORD_SIZE];
        assert_eq!(&rec[0..4], &3i32.to_le_bytes());
        assert_eq!(&rec[4..8], &(w.classes[0].0.len() as u32).to_le_bytes());
        assert_eq!(&rec[8..8 + w.classes[0].0.len()], w.classes[0].0.as_bytes());
        // The first weight: layer 0's Wᵀ row 0 (the x row of ω), column 0.
        let first = &bytes[e.weights_offset as usize..e.weights_offset as usize + elem as usize];
        let value = match weight_type {
            WeightType::F32 => f32::from_le_bytes(first.try_into().unwrap()),
            WeightType::F16 => half_to_f32(u16::from_le_bytes(first.try_into().unwrap())),
        };
        assert_eq!(
            value,
            ModelBytes::copy_from(&bytes)
                .model()
                .unwrap()
                .weights()
                .get(0)
                .unwrap()
        );
        let tail = bytes.len() - 4;
        assert_eq!(&bytes[tail..], &crc32(&bytes[..tail]).to_le_bytes());
    }
}

/// IEEE binary16 to f32 by hand (the test must not decode f16 with the code under test).
fn half_to_f32(h: u16) -> f32 {
    let sign = if h & 0x8000 != 0 { -1.0 } else { 1.0 };
    let exp = ((h >> 10) & 0x1F) as i32;
    let frac = (h & 0x3FF) as f32;
    sign * match exp {
        0 => frac * 2f32.powi(-24),
        31 => f32::NAN,
        e => (1.0 + frac / 1024.0) * 2f32.powi(e - 15),
    }
}

// ---------------------------------------------------------------------------------------------
// Valid files.

#[test]
fn fixtures_round_trip_exactly() {
    for weight_type in [WeightType::F32, WeightType::F16] {
        for w in [fixture(weight_type), motion_fixture(weight_type)] {
            let bytes = w.to_bytes();
            load(&bytes).unwrap();
            let copy = ModelBytes::copy_from(&bytes);
            let model = copy.model().unwrap();
            assert_eq!(model.motion().is_some(), w.motion.is_some());
            if let (Some(m), Some(u)) = (&w.motion, model.motion()) {
                let widths: Vec<u32> = u.layout().widths().iter().map(|&v| v as u32).collect();
                assert_eq!(widths, m.widths);
                assert_eq!(u.layout().num_classes(), 3);
                assert_eq!(u.omega_t_max().to_bits(), m.omega_t_max.to_bits());
                assert_eq!(u.weights().len(), m.params.len());
            }
        }
    }
}

/// A model without motion is written as version 1, byte for byte what the writer wrote before
/// version 2 existed: the same bytes as its motion model with the motion dropped, apart from
/// the version, the motion fields, the weights after the shape network's, the sizes and the CRC.
#[test]
fn models_without_motion_are_version_1() {
    let still = fixture(WeightType::F32).to_bytes();
    let moving = motion_fixture(WeightType::F32).to_bytes();
    assert_eq!(VERSION_STATIC, 1);
    assert_eq!(VERSION, 2);
    assert_eq!(&still[OFF_VERSION..OFF_VERSION + 4], &1u32.to_le_bytes());
    assert_eq!(&moving[OFF_VERSION..OFF_VERSION + 4], &2u32.to_le_bytes());
    assert!(still[OFF_MOTION_SINE_LAYERS..HEADER_SIZE]
        .iter()
        .all(|&b| b == 0));
    // Everything from the dtype to the end of the shape network's weights is shared.
    let shape_end = still.len() - 4;
    assert_eq!(
        still[OFF_DTYPE..OFF_MOTION_SINE_LAYERS],
        moving[OFF_DTYPE..OFF_MOTION_SINE_LAYERS]
    );
    assert_eq!(
        still[HEADER_SIZE..shape_end],
        moving[HEADER_SIZE..shape_end]
    );
    // And from_model drops nothing and adds nothing.
    let back = ModelWriter::from_model(&ModelBytes::copy_from(&still).model().unwrap());
    assert_eq!(back.motion, None);
    assert_eq!(back.to_bytes(), still);
}

/// The largest model the limits allow loads, round-trips and evaluates; one past any limit is
/// refused by the writer with the same error the reader gives.
#[test]
fn limits_are_inclusive() {
    let widths = [MAX_WIDTH as u32; MAX_SINE_LAYERS];
    let mut w = ModelWriter::random_siren(&widths, MAX_CLASSES as u32, 1);
    w.metadata = "m".repeat(MAX_METADATA);
    w.classes[0].0 = "n".repeat(MAX_NAME_LEN);
    w.weight_type = WeightType::F16;
    let bytes = w.to_bytes();
    let copy = ModelBytes::copy_from(&bytes);
    let model = copy.model().unwrap();
    assert_eq!(ModelWriter::from_model(&model).to_bytes(), bytes);
    let mut f = [0.0; MAX_CLASSES];
    model.eval([0.1, 0.2, 0.3], 0.4, &mut f).unwrap();
    assert!(f.iter().all(|v| v.is_finite()));

    // The largest motion network too, in the largest file: f32 weights, within
    // `max_file_size` by less than the padding it allows for.
    let largest_motion = ModelWriter::random_motion(&[4], 1, &widths, 2).motion;
    w.motion = largest_motion.clone();
    w.weight_type = WeightType::F32;
    let bytes = w.to_bytes();
    assert!(bytes.len() as u64 <= max_file_size());
    assert!(max_file_size() - (bytes.len() as u64) < WEIGHT_ALIGN as u64);
    let copy = ModelBytes::copy_from(&bytes);
    let model = copy.model().unwrap();
    assert_eq!(ModelWriter::from_model(&model).to_bytes(), bytes);
    let (mut g, mut d) = ([[0.0; 3]; MAX_CLASSES], [0.0; MAX_CLASSES]);
    model
        .eval_jacobian([0.1, 0.2, 0.3], 0.4, &mut f, &mut g, &mut d)
        .unwrap();
    assert!(f
        .iter()
        .chain(g.iter().flatten())
        .chain(&d)
        .all(|v| v.is_finite()));
    let mut motion_too_wide = fixture(WeightType::F32);
    motion_too_wide.motion = largest_motion;
    if let Some(m) = &mut motion_too_wide.motion {
        m.widths[3] = MAX_WIDTH as u32 + 1;
    }
    assert_eq!(
        motion_too_wide.try_to_bytes(),
        Err(Error::BadDimension {
            what: "motion layer width",
            value: MAX_WIDTH as u64 + 1,
            max: MAX_WIDTH as u64
        })
    );
    let mut no_layers = motion_fixture(WeightType::F32);
    if let Some(m) = &mut no_layers.motion {
        m.widths.clear();
        m.params.clear();
    }
    assert_eq!(
        no_layers.try_to_bytes(),
        Err(Error::BadDimension {
            what: "motion sine layer count",
            value: 0,
            max: MAX_SINE_LAYERS as u64
        })
    );

    let too_wide = ModelWriter::random_siren(&[MAX_WIDTH as u32 + 1], 1, 1);
    assert_eq!(
        too_wide.try_to_bytes(),
        Err(Error::BadDimension {
            what: "layer width",
            value: MAX_WIDTH as u64 + 1,
            max: MAX_WIDTH as u64
        })
    );
    let too_deep = ModelWriter::random_siren(&[4; MAX_SINE_LAYERS + 1], 1, 1);
    assert!(matches!(
        too_deep.try_to_bytes(),
        Err(Error::BadDimension {
            what: "sine layer count",
            ..
        })
    ));
    let mut long_name = fixture(WeightType::F32);
    long_name.classes[0].0 = "n".repeat(MAX_NAME_LEN + 1);
    assert!(long_name.try_to_bytes().is_err());
}

/// A random motion network (or none) for [`arb_writer`]: 1–3 sine layers of width 1–12, an
/// ω_t^max in [0, 100).
fn arb_motion() -> impl Strategy<Value = Option<MotionWriter>> {
    prop_oneof![
        1 => Just(None),
        1 => (prop::collection::vec(1u32..=12, 1..=3), any::<u64>(), 0f32..100.0).prop_map(
            |(widths, seed, omega)| {
                let mut m = ModelWriter::random_motion(&[4], 1, &widths, seed).motion;
                if let Some(m) = &mut m {
                    m.omega_t_max = omega;
                }
                m
            }
        ),
    ]
}

fn arb_writer() -> impl Strategy<Value = ModelWriter> {
    (
        arb_motion(),
        prop::collection::vec(1u32..=20, 1..=3),
        prop::collection::vec(("\\PC{0,14}", any::<i32>()), 1..=5),
        "\\PC{0,40}",
        any::<u64>(),
        any::<bool>(),
        (
            prop::array::uniform3(-1e3f32..1e3),
            prop::array::uniform3(1e-3f32..1e3),
            -1e3f32..1e3,
            1e-3f32..1e3,
            1e-3f32..1e3,
            0f32..100.0,
        ),
    )
        .prop_map(|(motion, widths, classes, metadata, seed, half, d)| {
            let mut w = ModelWriter::random_siren(&widths, classes.len() as u32, seed);
            w.motion = motion;
            w.classes = classes;
            w.metadata = metadata;
            w.weight_type = if half {
                WeightType::F16
            } else {
                WeightType::F32
            };
            w.domain = Domain {
                center: d.0,
                scale: d.1,
                time_origin: d.2,
                time_span: d.3,
                output_scale: d.4,
            };
            w.omega_t_max = d.5;
            w
        })
}

proptest! {
    #![proptest_config(ProptestConfig { cases: 128, ..ProptestConfig::default() })]

    /// Any model the writer accepts is read back as the same model and re-written to the same
    /// bytes: f32 weights bit for bit, f16 weights as their f16 rounding.
    #[test]
    fn valid_files_round_trip_exactly(w in arb_writer()) {
        let bytes = w.to_bytes();
        load(&bytes).unwrap();
        let copy = ModelBytes::copy_from(&bytes);
        let back = ModelWriter::from_model(&copy.model().unwrap());
        prop_assert_eq!(&back.widths, &w.widths);
        prop_assert_eq!(&back.classes, &w.classes);
        prop_assert_eq!(&back.metadata, &w.metadata);
        prop_assert_eq!(back.domain, w.domain);
        prop_assert_eq!(back.omega_t_max.to_bits(), w.omega_t_max.to_bits());
        prop_assert_eq!(back.weight_type, w.weight_type);
        let rounded = |b: f32| match w.weight_type {
            WeightType::F32 => b,
            WeightType::F16 => half_to_f32(half_bits(b)),
        };
        prop_assert_eq!(back.params.len(), w.params.len());
        for (a, b) in back.params.iter().zip(&w.params) {
            prop_assert_eq!(a.to_bits(), rounded(*b).to_bits());
        }
        prop_assert_eq!(back.motion.is_some(), w.motion.is_some());
        if let (Some(back), Some(m)) = (&back.motion, &w.motion) {
            prop_assert_eq!(&back.widths, &m.widths);
            prop_assert_eq!(back.omega_t_max.to_bits(), m.omega_t_max.to_bits());
            prop_assert_eq!(back.params.len(), m.params.len());
            for (a, b) in back.params.iter().zip(&m.params) {
                prop_assert_eq!(a.to_bits(), rounded(*b).to_bits());
            }
        }
    }
}

/// f32 → binary16 bits, round to nearest even, for the finite, f16-representable range the
/// fixtures use (|v| < 65504); written here so the test does not trust the code under test.
fn half_bits(v: f32) -> u16 {
    let bits = v.to_bits();
    let sign = ((bits >> 16) & 0x8000) as u16;
    let a = v.abs();
    if a < 2f32.powi(-14) {
        // Subnormal half: a multiple of 2^-24, rounded to nearest even by the f32 addition.
        let q = (a * 2f32.powi(24)).round_ties_even() as u16;
        return sign | q;
    }
    let exp = ((bits >> 23) & 0xFF) as i32 - 127;
    let mant = bits & 0x7F_FFFF;
    let mut h = (((exp + 15) as u32) << 10) | (mant >> 13);
    let rest = mant & 0x1FFF;
    if rest > 0x1000 || (rest == 0x1000 && h & 1 == 1) {
        h += 1; // may carry into the exponent, which is the correct rounding
    }
    sign | h as u16
}

// ---------------------------------------------------------------------------------------------
// Damaged files: exhaustive.

/// Every single-byte change anywhere in the file, to every other value, is rejected. Past the
/// header the header's layout checks all pass, so the rejection must come from the CRC.
#[test]
fn every_single_byte_change_is_rejected() {
    let weight_types = [WeightType::F32, WeightType::F16];
    for w in weight_types
        .map(fixture)
        .into_iter()
        .chain(weight_types.map(motion_fixture))
    {
        let good = w.to_bytes();
        let mut bytes = good.clone();
        for i in 0..bytes.len() {
            for delta in 1..=255u8 {
                bytes[i] = good[i].wrapping_add(delta);
                let result = load(&bytes);
                if i < HEADER_SIZE {
                    assert!(result.is_err(), "byte {i} + {delta} accepted");
                } else {
                    assert!(
                        matches!(result, Err(Error::CrcMismatch { .. })),
                        "byte {i} + {delta}: {result:?}"
                    );
                }
            }
            bytes[i] = good[i];
        }
    }
}

/// Every proper prefix is `Truncated` with the exact size needed, and any bytes after the trailer
/// are refused (even with a trailer recomputed at the new end).
#[test]
fn truncations_and_extensions_are_rejected() {
    let weight_types = [WeightType::F32, WeightType::F16];
    for w in weight_types
        .map(fixture)
        .into_iter()
        .chain(weight_types.map(motion_fixture))
    {
        let good = w.to_bytes();
        let len = good.len() as u64;
        for cut in 0..good.len() {
            let needed = if cut < HEADER_SIZE {
                HEADER_SIZE as u64
            } else {
                len
            };
            assert_eq!(
                load(&good[..cut]),
                Err(Error::Truncated {
                    needed,
                    available: cut as u64
                }),
                "prefix of {cut} bytes"
            );
        }
        for extra in 1..=2 * WEIGHT_ALIGN {
            let mut longer = good.clone();
            longer.resize(good.len() + extra, 0);
            fix_crc(&mut longer);
            assert_eq!(
                load(&longer),
                Err(Error::BadLayout("bytes after the CRC trailer")),
                "{extra} extra bytes"
            );
        }
    }
}

/// The weights must be aligned for their type where they lie; a valid file at an odd address
/// is refused rather than read with unaligned loads.
#[test]
fn misaligned_buffers_are_refused() {
    let f32_file = fixture(WeightType::F32).to_bytes();
    let f16_file = fixture(WeightType::F16).to_bytes();
    for misalign in [1, 2, 3] {
        let copy = shifted(&f32_file, misalign);
        assert_eq!(
            Model::from_bytes(&copy[misalign..]).err(),
            Some(Error::Misaligned)
        );
    }
    for misalign in [1, 3] {
        let copy = shifted(&f16_file, misalign);
        assert_eq!(
            Model::from_bytes(&copy[misalign..]).err(),
            Some(Error::Misaligned)
        );
    }
    // f16 weights need only 2-byte alignment.
    assert!(Model::from_bytes(&shifted(&f16_file, 2)[2..]).is_ok());
}

// ---------------------------------------------------------------------------------------------
// Damaged files with the CRC recomputed: every deep check, each with its exact error.

/// A header or body edit applied to the f32 fixture (its CRC then recomputed).
type Edit = fn(&mut Vec<u8>);

fn dim(what: &'static str, value: u64, max: usize) -> Error {
    Error::BadDimension {
        what,
        value,
        max: max as u64,
    }
}

#[test]
fn deep_checks_reject_with_the_right_error() {
    let w = fixture(WeightType::F32);
    let good = w.to_bytes();
    let meta_len = w.metadata.len() as u64;
    let e = expected_sections(&[8, 6], 2, &[], meta_len, 4);
    let meta_off = e.metadata_offset as usize;
    let weights_off = e.weights_offset as usize;
    let padding_off = meta_off + meta_len as usize;
    assert!(padding_off < weights_off, "the fixture must have padding");
    let last_weight = e.weights_count - 1;

    let cases: Vec<(&str, Edit, Error)> = vec![
        ("magic", |b| b[OFF_MAGIC] = b'd', Error::BadMagic),
        (
            "version 0",
            |b| put_u32(b, OFF_VERSION, 0),
            Error::UnsupportedVersion(0),
        ),
        // Version 2 needs a motion network, which this file does not describe.
        (
            "version 2",
            |b| put_u32(b, OFF_VERSION, VERSION),
            dim("motion sine layer count", 0, MAX_SINE_LAYERS),
        ),
        (
            "version 3",
            |b| put_u32(b, OFF_VERSION, VERSION + 1),
            Error::UnsupportedVersion(3),
        ),
        // Version 1 keeps every motion field zero (reserved bytes before version 2).
        (
            "v1 motion layers",
            |b| put_u32(b, OFF_MOTION_SINE_LAYERS, 1),
            Error::NonZeroPadding,
        ),
        (
            "v1 motion width",
            |b| put_u32(b, OFF_MOTION_WIDTHS + 8, 4),
            Error::NonZeroPadding,
        ),
        (
            "v1 motion omega -0",
            |b| put_f32(b, OFF_MOTION_OMEGA_T_MAX, -0.0),
            Error::NonZeroPadding,
        ),
        (
            "v1 motion weight count",
            |b| put_u64(b, OFF_MOTION_WEIGHTS_COUNT, 55),
            Error::NonZeroPadding,
        ),
        (
            "header size",
            |b| put_u32(b, OFF_HEADER_SIZE, 255),
            Error::BadHeaderSize(255),
        ),
        ("dtype 2", |b| put_u32(b, OFF_DTYPE, 2), Error::BadDtype(2)),
        (
            "dtype max",
            |b| put_u32(b, OFF_DTYPE, u32::MAX),
            Error::BadDtype(u32::MAX),
        ),
        // Switching f32 → f16 halves the weight section, so the declared size is then wrong.
        (
            "dtype f16",
            |b| put_u32(b, OFF_DTYPE, 1),
            Error::BadLayout("file size does not match the dimensions"),
        ),
        (
            "0 layers",
            |b| put_u32(b, OFF_NUM_SINE_LAYERS, 0),
            dim("sine layer count", 0, MAX_SINE_LAYERS),
        ),
        (
            "9 layers",
            |b| put_u32(b, OFF_NUM_SINE_LAYERS, 9),
            dim("sine layer count", 9, MAX_SINE_LAYERS),
        ),
        (
            "2^32-1 layers",
            |b| put_u32(b, OFF_NUM_SINE_LAYERS, u32::MAX),
            dim("sine layer count", u32::MAX as u64, MAX_SINE_LAYERS),
        ),
        // One more layer than the widths list: its width slot is 0.
        (
            "3 layers",
            |b| put_u32(b, OFF_NUM_SINE_LAYERS, 3),
            dim("layer width", 0, MAX_WIDTH),
        ),
        // One fewer: the dropped width becomes a non-zero "unused" slot.
        (
            "1 layer",
            |b| put_u32(b, OFF_NUM_SINE_LAYERS, 1),
            Error::NonZeroPadding,
        ),
        (
            "width 0",
            |b| put_u32(b, OFF_WIDTHS, 0),
            dim("layer width", 0, MAX_WIDTH),
        ),
        (
            "width 513",
            |b| put_u32(b, OFF_WIDTHS + 4, 513),
            dim("layer width", 513, MAX_WIDTH),
        ),
        (
            "width 2^32-1",
            |b| put_u32(b, OFF_WIDTHS, u32::MAX),
            dim("layer width", u32::MAX as u64, MAX_WIDTH),
        ),
        (
            "width 512",
            |b| put_u32(b, OFF_WIDTHS, 512),
            Error::BadLayout("weight count does not match the layer widths"),
        ),
        (
            "unused width",
            |b| put_u32(b, OFF_WIDTHS + 4 * 7, 1),
            Error::NonZeroPadding,
        ),
        (
            "0 classes",
            |b| put_u32(b, OFF_NUM_CLASSES, 0),
            dim("class count", 0, MAX_CLASSES),
        ),
        (
            "65 classes",
            |b| put_u32(b, OFF_NUM_CLASSES, 65),
            dim("class count", 65, MAX_CLASSES),
        ),
        (
            "2^32-1 classes",
            |b| put_u32(b, OFF_NUM_CLASSES, u32::MAX),
            dim("class count", u32::MAX as u64, MAX_CLASSES),
        ),
        (
            "3 classes",
            |b| put_u32(b, OFF_NUM_CLASSES, 3),
            Error::BadLayout("metadata offset"),
        ),
        ("flags", |b| put_u32(b, OFF_FLAGS, 1), Error::NonZeroPadding),
        (
            "reserved",
            |b| b[HEADER_SIZE - 1] = 1,
            Error::NonZeroPadding,
        ),
        (
            "metadata 1 MiB + 1",
            |b| put_u64(b, OFF_METADATA_LEN, MAX_METADATA as u64 + 1),
            dim("metadata length", MAX_METADATA as u64 + 1, MAX_METADATA),
        ),
        (
            "metadata 2^64-1",
            |b| put_u64(b, OFF_METADATA_LEN, u64::MAX),
            dim("metadata length", u64::MAX, MAX_METADATA),
        ),
        (
            "metadata +64",
            |b| {
                let v = get_u64(b, OFF_METADATA_LEN);
                put_u64(b, OFF_METADATA_LEN, v + 64)
            },
            Error::BadLayout("weights offset"),
        ),
        (
            "class offset 0",
            |b| put_u64(b, OFF_CLASSES_OFFSET, 0),
            Error::BadLayout("class table offset"),
        ),
        (
            "metadata offset +1",
            |b| {
                let v = get_u64(b, OFF_METADATA_OFFSET);
                put_u64(b, OFF_METADATA_OFFSET, v + 1)
            },
            Error::BadLayout("metadata offset"),
        ),
        (
            "weights offset -64",
            |b| {
                let v = get_u64(b, OFF_WEIGHTS_OFFSET);
                put_u64(b, OFF_WEIGHTS_OFFSET, v - 64)
            },
            Error::BadLayout("weights offset"),
        ),
        (
            "weights offset 2^64-1",
            |b| put_u64(b, OFF_WEIGHTS_OFFSET, u64::MAX),
            Error::BadLayout("weights offset"),
        ),
        (
            "weight count -1",
            |b| {
                let v = get_u64(b, OFF_WEIGHTS_COUNT);
                put_u64(b, OFF_WEIGHTS_COUNT, v - 1)
            },
            Error::BadLayout("weight count does not match the layer widths"),
        ),
        (
            "weight count 2^64-1",
            |b| put_u64(b, OFF_WEIGHTS_COUNT, u64::MAX),
            Error::BadLayout("weight count does not match the layer widths"),
        ),
        (
            "file size +4",
            |b| {
                let v = get_u64(b, OFF_FILE_SIZE);
                put_u64(b, OFF_FILE_SIZE, v + 4)
            },
            Error::BadLayout("file size does not match the dimensions"),
        ),
        (
            "file size 2^64-1",
            |b| put_u64(b, OFF_FILE_SIZE, u64::MAX),
            Error::BadLayout("file size does not match the dimensions"),
        ),
        (
            "file size 0",
            |b| put_u64(b, OFF_FILE_SIZE, 0),
            Error::BadLayout("file size does not match the dimensions"),
        ),
        (
            "centre NaN",
            |b| put_f32(b, OFF_CENTER + 4, f32::NAN),
            Error::BadHeaderValue("domain centre is not finite"),
        ),
        (
            "centre inf",
            |b| put_f32(b, OFF_CENTER, f32::INFINITY),
            Error::BadHeaderValue("domain centre is not finite"),
        ),
        (
            "scale 0",
            |b| put_f32(b, OFF_SCALE, 0.0),
            Error::BadHeaderValue("domain scale is not a positive finite number"),
        ),
        (
            "scale -1",
            |b| put_f32(b, OFF_SCALE + 8, -1.0),
            Error::BadHeaderValue("domain scale is not a positive finite number"),
        ),
        (
            "scale 1e-31",
            |b| put_f32(b, OFF_SCALE, 1e-31),
            Error::BadHeaderValue("domain scale is not a positive finite number"),
        ),
        (
            "scale 1e31",
            |b| put_f32(b, OFF_SCALE, 1e31),
            Error::BadHeaderValue("domain scale is not a positive finite number"),
        ),
        (
            "time origin NaN",
            |b| put_f32(b, OFF_TIME_ORIGIN, f32::NAN),
            Error::BadHeaderValue("time origin is not finite"),
        ),
        (
            "time span 0",
            |b| put_f32(b, OFF_TIME_SPAN, 0.0),
            Error::BadHeaderValue("time span is not a positive finite number"),
        ),
        (
            "output scale -inf",
            |b| put_f32(b, OFF_OUTPUT_SCALE, f32::NEG_INFINITY),
            Error::BadHeaderValue("output scale is not a positive finite number"),
        ),
        (
            "omega -1",
            |b| put_f32(b, OFF_OMEGA_T_MAX, -1.0),
            Error::BadHeaderValue("omega_t_max is not a non-negative finite number"),
        ),
        (
            "omega NaN",
            |b| put_f32(b, OFF_OMEGA_T_MAX, f32::NAN),
            Error::BadHeaderValue("omega_t_max is not a non-negative finite number"),
        ),
        (
            "omega inf",
            |b| put_f32(b, OFF_OMEGA_T_MAX, f32::INFINITY),
            Error::BadHeaderValue("omega_t_max is not a non-negative finite number"),
        ),
        (
            "name length 57",
            |b| put_u32(b, HEADER_SIZE + 4, 57),
            Error::BadClassRecord { class: 1 },
        ),
        (
            "name length 2^32-1",
            |b| put_u32(b, HEADER_SIZE + 4, u32::MAX),
            Error::BadClassRecord { class: 1 },
        ),
        (
            "name length short",
            |b| put_u32(b, HEADER_SIZE + 4, 1),
            Error::BadClassRecord { class: 1 },
        ),
        (
            "name not UTF-8",
            |b| b[HEADER_SIZE + CLASS_RECORD_SIZE + 8] = 0xFF,
            Error::BadClassRecord { class: 2 },
        ),
        // "♥" is 3 bytes: cutting the name inside it leaves invalid UTF-8 (its tail then also
        // counts as non-zero padding; either way the record is refused).
        (
            "name cut in a char",
            |b| {
                let v = b[HEADER_SIZE + 4];
                b[HEADER_SIZE + 4] = v - 1
            },
            Error::BadClassRecord { class: 1 },
        ),
        (
            "name padding",
            |b| b[HEADER_SIZE + 2 * CLASS_RECORD_SIZE - 1] = b'x',
            Error::BadClassRecord { class: 2 },
        ),
        (
            "metadata not UTF-8",
            |b| b[HEADER_SIZE + 2 * CLASS_RECORD_SIZE] = 0xC0,
            Error::BadMetadata,
        ),
        (
            "padding",
            |b| {
                let at = padding_start(b);
                b[at] = 1
            },
            Error::NonZeroPadding,
        ),
        (
            "last padding byte",
            |b| {
                let at = weights_at(b) - 1;
                b[at] = 0x80
            },
            Error::NonZeroPadding,
        ),
        (
            "weight 5 NaN",
            |b| {
                let at = weights_at(b) + 5 * 4;
                put_f32(b, at, f32::NAN)
            },
            Error::NonFiniteWeight { index: 5 },
        ),
        (
            "last weight -inf",
            |b| {
                let at = b.len() - 8;
                put_f32(b, at, f32::NEG_INFINITY)
            },
            Error::NonFiniteWeight { index: last_weight },
        ),
    ];
    // The closures above cannot capture, so the few that need the fixture's section offsets
    // recover them from the (intact) header.
    fn weights_at(b: &[u8]) -> usize {
        get_u64(b, OFF_WEIGHTS_OFFSET) as usize
    }
    fn padding_start(b: &[u8]) -> usize {
        (get_u64(b, OFF_METADATA_OFFSET) + get_u64(b, OFF_METADATA_LEN)) as usize
    }
    assert_eq!(padding_start(&good), padding_off);
    assert_eq!(weights_at(&good), weights_off);

    for (name, edit, want) in cases {
        let mut bytes = good.clone();
        edit(&mut bytes);
        assert_ne!(bytes, good, "{name}: the edit changed nothing");
        fix_crc(&mut bytes);
        assert_eq!(load(&bytes), Err(want), "{name}");
        // Without the CRC fixed, the same damage is still refused (by the CRC or earlier).
        let mut stale = good.clone();
        edit(&mut stale);
        assert!(load(&stale).is_err(), "{name} with a stale CRC");
    }
}

/// A header that is self-consistent for the largest model the limits allow (≈ 8 MiB of
/// weights, 1 MiB of metadata) on a buffer of 1 KiB: refused as truncated from the header
/// alone, without touching memory past the buffer.
#[test]
fn consistent_header_for_a_huge_model_is_truncated() {
    let mut bytes = fixture(WeightType::F32).to_bytes();
    let widths = [MAX_WIDTH as u64; MAX_SINE_LAYERS];
    let e = expected_sections(&widths, MAX_CLASSES as u64, &[], MAX_METADATA as u64, 4);
    put_u32(&mut bytes, OFF_NUM_SINE_LAYERS, MAX_SINE_LAYERS as u32);
    for l in 0..MAX_SINE_LAYERS {
        put_u32(&mut bytes, OFF_WIDTHS + 4 * l, MAX_WIDTH as u32);
    }
    put_u32(&mut bytes, OFF_NUM_CLASSES, MAX_CLASSES as u32);
    put_u64(&mut bytes, OFF_METADATA_LEN, MAX_METADATA as u64);
    put_u64(&mut bytes, OFF_METADATA_OFFSET, e.metadata_offset);
    put_u64(&mut bytes, OFF_WEIGHTS_OFFSET, e.weights_offset);
    put_u64(&mut bytes, OFF_WEIGHTS_COUNT, e.weights_count);
    put_u64(&mut bytes, OFF_FILE_SIZE, e.file_size);
    fix_crc(&mut bytes);
    assert_eq!(
        load(&bytes),
        Err(Error::Truncated {
            needed: e.file_size,
            available: bytes.len() as u64
        })
    );
}

/// The version-2 fields of the motion fixture, each damaged (its CRC then recomputed), with the
/// exact error; and the huge-model header of a version-2 file, truncated from the header alone.
#[test]
fn motion_fields_reject_with_the_right_error() {
    let w = motion_fixture(WeightType::F32);
    let good = w.to_bytes();
    let e = expected_sections(&[8, 6], 2, &[5, 3], w.metadata.len() as u64, 4);
    assert_eq!(e.weights_count, 108);
    assert_eq!(param_count(&[5, 3], 3), 55);
    let cases: Vec<(&str, Edit, Error)> = vec![
        (
            "version 1",
            |b| put_u32(b, OFF_VERSION, 1),
            Error::NonZeroPadding,
        ),
        (
            "version 3",
            |b| put_u32(b, OFF_VERSION, 3),
            Error::UnsupportedVersion(3),
        ),
        (
            "0 motion layers",
            |b| put_u32(b, OFF_MOTION_SINE_LAYERS, 0),
            dim("motion sine layer count", 0, MAX_SINE_LAYERS),
        ),
        (
            "9 motion layers",
            |b| put_u32(b, OFF_MOTION_SINE_LAYERS, 9),
            dim("motion sine layer count", 9, MAX_SINE_LAYERS),
        ),
        (
            "2^32-1 motion layers",
            |b| put_u32(b, OFF_MOTION_SINE_LAYERS, u32::MAX),
            dim("motion sine layer count", u32::MAX as u64, MAX_SINE_LAYERS),
        ),
        (
            "3 motion layers",
            |b| put_u32(b, OFF_MOTION_SINE_LAYERS, 3),
            dim("motion layer width", 0, MAX_WIDTH),
        ),
        (
            "1 motion layer",
            |b| put_u32(b, OFF_MOTION_SINE_LAYERS, 1),
            Error::NonZeroPadding,
        ),
        (
            "motion width 0",
            |b| put_u32(b, OFF_MOTION_WIDTHS, 0),
            dim("motion layer width", 0, MAX_WIDTH),
        ),
        (
            "motion width 513",
            |b| put_u32(b, OFF_MOTION_WIDTHS + 4, 513),
            dim("motion layer width", 513, MAX_WIDTH),
        ),
        (
            "motion width 2^32-1",
            |b| put_u32(b, OFF_MOTION_WIDTHS, u32::MAX),
            dim("motion layer width", u32::MAX as u64, MAX_WIDTH),
        ),
        (
            "motion width 512",
            |b| put_u32(b, OFF_MOTION_WIDTHS, 512),
            Error::BadLayout("motion weight count does not match the motion layer widths"),
        ),
        (
            "unused motion width",
            |b| put_u32(b, OFF_MOTION_WIDTHS + 4 * 7, 1),
            Error::NonZeroPadding,
        ),
        (
            "motion weight count 0",
            |b| put_u64(b, OFF_MOTION_WEIGHTS_COUNT, 0),
            Error::BadLayout("motion weight count does not match the motion layer widths"),
        ),
        (
            "motion weight count +1",
            |b| put_u64(b, OFF_MOTION_WEIGHTS_COUNT, 56),
            Error::BadLayout("motion weight count does not match the motion layer widths"),
        ),
        (
            "motion weight count 2^64-1",
            |b| put_u64(b, OFF_MOTION_WEIGHTS_COUNT, u64::MAX),
            Error::BadLayout("motion weight count does not match the motion layer widths"),
        ),
        // The shape network's count holding both networks' weights is still wrong.
        (
            "shape weight count + motion's",
            |b| put_u64(b, OFF_WEIGHTS_COUNT, 108 + 55),
            Error::BadLayout("weight count does not match the layer widths"),
        ),
        (
            "file size without the motion weights",
            |b| {
                let v = get_u64(b, OFF_FILE_SIZE);
                put_u64(b, OFF_FILE_SIZE, v - 55 * 4)
            },
            Error::BadLayout("file size does not match the dimensions"),
        ),
        (
            "motion omega -1",
            |b| put_f32(b, OFF_MOTION_OMEGA_T_MAX, -1.0),
            Error::BadHeaderValue("motion omega_t_max is not a non-negative finite number"),
        ),
        (
            "motion omega NaN",
            |b| put_f32(b, OFF_MOTION_OMEGA_T_MAX, f32::NAN),
            Error::BadHeaderValue("motion omega_t_max is not a non-negative finite number"),
        ),
        (
            "motion omega -inf",
            |b| put_f32(b, OFF_MOTION_OMEGA_T_MAX, f32::NEG_INFINITY),
            Error::BadHeaderValue("motion omega_t_max is not a non-negative finite number"),
        ),
        (
            "reserved first",
            |b| b[OFF_RESERVED] = 1,
            Error::NonZeroPadding,
        ),
        (
            "reserved last",
            |b| b[HEADER_SIZE - 1] = 1,
            Error::NonZeroPadding,
        ),
        (
            "first motion weight NaN",
            |b| {
                let at = get_u64(b, OFF_WEIGHTS_OFFSET) as usize + 108 * 4;
                put_f32(b, at, f32::NAN)
            },
            Error::NonFiniteWeight { index: 108 },
        ),
        (
            "last motion weight inf",
            |b| {
                let at = b.len() - 8;
                put_f32(b, at, f32::INFINITY)
            },
            Error::NonFiniteWeight {
                index: 108 + 55 - 1,
            },
        ),
    ];
    for (name, edit, want) in cases {
        let mut bytes = good.clone();
        edit(&mut bytes);
        assert_ne!(bytes, good, "{name}: the edit changed nothing");
        fix_crc(&mut bytes);
        assert_eq!(load(&bytes), Err(want), "{name}");
        let mut stale = good.clone();
        edit(&mut stale);
        assert!(load(&stale).is_err(), "{name} with a stale CRC");
    }

    // A self-consistent version-2 header for the largest model on this small buffer.
    let mut bytes = good.clone();
    let widths = [MAX_WIDTH as u64; MAX_SINE_LAYERS];
    let e = expected_sections(&widths, MAX_CLASSES as u64, &widths, MAX_METADATA as u64, 4);
    put_u32(&mut bytes, OFF_NUM_SINE_LAYERS, MAX_SINE_LAYERS as u32);
    put_u32(&mut bytes, OFF_MOTION_SINE_LAYERS, MAX_SINE_LAYERS as u32);
    for l in 0..MAX_SINE_LAYERS {
        put_u32(&mut bytes, OFF_WIDTHS + 4 * l, MAX_WIDTH as u32);
        put_u32(&mut bytes, OFF_MOTION_WIDTHS + 4 * l, MAX_WIDTH as u32);
    }
    put_u32(&mut bytes, OFF_NUM_CLASSES, MAX_CLASSES as u32);
    put_u64(&mut bytes, OFF_METADATA_LEN, MAX_METADATA as u64);
    put_u64(&mut bytes, OFF_METADATA_OFFSET, e.metadata_offset);
    put_u64(&mut bytes, OFF_WEIGHTS_OFFSET, e.weights_offset);
    put_u64(&mut bytes, OFF_WEIGHTS_COUNT, e.weights_count);
    put_u64(
        &mut bytes,
        OFF_MOTION_WEIGHTS_COUNT,
        param_count(&widths, 3),
    );
    put_u64(&mut bytes, OFF_FILE_SIZE, e.file_size);
    fix_crc(&mut bytes);
    assert!(e.file_size <= max_file_size());
    assert_eq!(
        load(&bytes),
        Err(Error::Truncated {
            needed: e.file_size,
            available: bytes.len() as u64
        })
    );
}

// ---------------------------------------------------------------------------------------------
// Damaged files: random.

/// Interesting values for a header integer: zero, one, the limits and their neighbours, the
/// value already there, and anything at all.
fn arb_u64_field() -> impl Strategy<Value = Option<u64>> {
    prop_oneof![
        2 => Just(None),
        1 => prop::sample::select(vec![
            0u64, 1, 2, 3, 4, 8, 9, 63, 64, 65, 256, 511, 512, 513,
            MAX_METADATA as u64, MAX_METADATA as u64 + 1,
            u32::MAX as u64, u32::MAX as u64 + 1, u64::MAX / 4 + 1, u64::MAX,
        ]).prop_map(Some),
        1 => any::<u64>().prop_map(Some),
    ]
}

proptest! {
    #![proptest_config(ProptestConfig { cases: 512, ..ProptestConfig::default() })]

    /// Arbitrary bytes, with and without a valid magic and version in front and with and
    /// without a matching trailer: never a panic (and an accepted file must be canonical).
    #[test]
    fn random_bytes_never_panic(
        mut bytes in prop::collection::vec(any::<u8>(), 0..1200),
        prefix in 0usize..3,
        version in prop::sample::select(vec![VERSION_STATIC, VERSION]),
        crc in any::<bool>(),
    ) {
        if prefix >= 1 && bytes.len() >= 12 {
            bytes[..8].copy_from_slice(&MAGIC);
            put_u32(&mut bytes, OFF_VERSION, version);
        }
        if prefix >= 2 && bytes.len() >= 16 {
            put_u32(&mut bytes, OFF_HEADER_SIZE, HEADER_SIZE as u32);
        }
        if crc {
            fix_crc(&mut bytes);
        }
        let _ = load(&bytes);
    }

    /// A valid file with up to 8 random byte writes, maybe a truncation or extension, maybe the
    /// CRC recomputed. A change confined to 4 consecutive bytes with a stale CRC must be
    /// rejected (a CRC-32 detects every burst of up to 32 bits); any accepted file must be
    /// canonical and answer every query.
    #[test]
    fn mutated_files_never_panic(
        half in any::<bool>(),
        motion in any::<bool>(),
        writes in prop::collection::vec((any::<prop::sample::Index>(), any::<u8>()), 0..8),
        resize in prop_oneof![4 => Just(None), 1 => (0usize..2000).prop_map(Some)],
        crc in any::<bool>(),
    ) {
        let weight_type = if half { WeightType::F16 } else { WeightType::F32 };
        let good = match motion {
            true => motion_fixture(weight_type),
            false => fixture(weight_type),
        }.to_bytes();
        let mut bytes = good.clone();
        for (at, v) in &writes {
            let i = at.index(bytes.len());
            bytes[i] = *v;
        }
        if let Some(n) = resize {
            bytes.resize(n, 0xA5);
        }
        if crc {
            fix_crc(&mut bytes);
        }
        let result = load(&bytes);
        if !crc && bytes.len() == good.len() {
            let changed: Vec<usize> = (0..good.len()).filter(|&i| bytes[i] != good[i]).collect();
            if let (Some(first), Some(last)) = (changed.first(), changed.last()) {
                if last - first < 4 {
                    prop_assert!(result.is_err(), "burst {first}..={last} accepted");
                }
            }
        }
    }

    /// Every integer field of the header replaced by an interesting value, the CRC recomputed so
    /// that the layout, domain and body checks all run: never a panic, accepted only when
    /// canonical (in practice: only when the values are the original ones).
    #[test]
    fn header_fields_with_fixed_crc_never_panic(
        half in any::<bool>(),
        motion in any::<bool>(),
        fields in prop::collection::vec(arb_u64_field(), 26),
        floats in prop::collection::vec(
            prop_oneof![
                3 => Just(None),
                1 => prop::sample::select(vec![
                    0.0f32, -0.0, 1e-31, 1e31, -1.0, f32::NAN, f32::INFINITY, f32::MIN_POSITIVE,
                ]).prop_map(Some),
            ],
            12,
        ),
    ) {
        let weight_type = if half { WeightType::F16 } else { WeightType::F32 };
        let mut bytes = match motion {
            true => motion_fixture(weight_type),
            false => fixture(weight_type),
        }.to_bytes();
        let u32_fields = [
            OFF_VERSION, OFF_HEADER_SIZE, OFF_DTYPE, OFF_NUM_CLASSES, OFF_NUM_SINE_LAYERS,
            OFF_FLAGS, OFF_WIDTHS, OFF_WIDTHS + 4, OFF_WIDTHS + 8, OFF_WIDTHS + 28,
            OFF_MOTION_SINE_LAYERS, OFF_MOTION_WIDTHS, OFF_MOTION_WIDTHS + 4,
            OFF_MOTION_WIDTHS + 28, HEADER_SIZE + 4, HEADER_SIZE + CLASS_RECORD_SIZE + 4,
        ];
        let u64_fields = [
            OFF_FILE_SIZE, OFF_CLASSES_OFFSET, OFF_METADATA_OFFSET, OFF_METADATA_LEN,
            OFF_WEIGHTS_OFFSET, OFF_WEIGHTS_COUNT, OFF_MOTION_WEIGHTS_COUNT, OFF_RESERVED,
            OFF_RESERVED + 48, HEADER_SIZE,
        ];
        let (f32s, f64s) = fields.split_at(u32_fields.len());
        for (&at, v) in u32_fields.iter().zip(f32s) {
            if let Some(v) = v {
                put_u32(&mut bytes, at, *v as u32);
            }
        }
        for (&at, v) in u64_fields.iter().zip(f64s) {
            if let Some(v) = v {
                put_u64(&mut bytes, at, *v);
            }
        }
        let float_fields = (0..11).map(|i| OFF_CENTER + 4 * i).chain([OFF_MOTION_OMEGA_T_MAX]);
        for (at, v) in float_fields.zip(&floats) {
            if let Some(v) = v {
                put_f32(&mut bytes, at, *v);
            }
        }
        fix_crc(&mut bytes);
        let _ = load(&bytes);
    }
}
