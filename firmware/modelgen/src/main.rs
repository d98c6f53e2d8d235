//! `dynaslice-modelgen OUT_DIR` writes, into OUT_DIR:
//! - `model_f32.dsm`, `model_f16.dsm`: one small multi-class SIREN with a non-identity world
//!   domain, stored with f32 and with f16 weights, for the firmware builds to `include_bytes!`;
//! - `model_motion.dsm`: the same shape network moved by a motion network (a version-2 file,
//!   f16 weights), so the firmware evaluates a motion model too;
//! - `expected.txt` (one `0x%08x` word a line) and `expected.h` (a C array): the transcript of
//!   `firmware/common/transcript.rs` computed here by the std build of the core, the reference
//!   the firmware builds must reproduce bit for bit;
//! - `model-info.txt`: dimensions, sizes and multiply-adds per point, for docs/firmware.md.
//!
//! Deterministic: the weights are a function of a fixed seed, so the files are the same on every
//! machine and every run.

#[path = "../../common/transcript.rs"]
mod transcript;

use dynaslice_core::format::{ModelWriter, WeightType};
use dynaslice_core::{Domain, ModelBytes};
use std::fmt::Write as _;
use std::path::Path;
use std::process::ExitCode;

/// Sine layer widths and class count of the embedded model: big enough to exercise every code
/// path (several hidden layers, K > 1, panels wider than one SIMD register), small enough that a
/// Cortex-M emulator answers in well under a second.
const WIDTHS: [u32; 3] = [64, 64, 64];
const CLASSES: [&str; 3] = [
    "left ventricle myocardium",
    "left ventricle blood pool",
    "right ventricle",
];
const SEED: u64 = 2026;
/// Sine layer widths of the motion model's motion network.
const MOTION_WIDTHS: [u32; 2] = [32, 32];

fn writer(weight_type: WeightType) -> ModelWriter {
    let mut w = ModelWriter::random_siren(&WIDTHS, CLASSES.len() as u32, SEED);
    w.classes = CLASSES
        .iter()
        .zip([2, 1, 3])
        .map(|(name, label)| (name.to_string(), label))
        .collect();
    // A cardiac-sized field of view in millimetres and one heart beat of 0.9 s.
    w.domain = Domain {
        center: [0.0, -20.0, 0.0],
        scale: [70.0, 70.0, 60.0],
        time_origin: 0.0,
        time_span: 0.9,
        output_scale: 70.0,
    };
    w.metadata = format!("{{\"generator\":\"dynaslice-modelgen\",\"seed\":{SEED}}}");
    w.weight_type = weight_type;
    w
}

fn main() -> ExitCode {
    let Some(out_dir) = std::env::args().nth(1) else {
        eprintln!("usage: dynaslice-modelgen OUT_DIR");
        return ExitCode::from(2);
    };
    match run(Path::new(&out_dir)) {
        Ok(()) => ExitCode::SUCCESS,
        Err(e) => {
            eprintln!("dynaslice-modelgen: {e}");
            ExitCode::FAILURE
        }
    }
}

fn run(out_dir: &Path) -> Result<(), Box<dyn std::error::Error>> {
    std::fs::create_dir_all(out_dir)?;
    // Aligned copies: `Model::from_bytes` reads the weights in place.
    let mut moving = writer(WeightType::F16);
    moving.motion = ModelWriter::random_motion(&[1], 1, &MOTION_WIDTHS, SEED).motion;
    let files = [
        ("model_f32.dsm", writer(WeightType::F32).try_to_bytes()?),
        ("model_f16.dsm", writer(WeightType::F16).try_to_bytes()?),
        ("model_motion.dsm", moving.try_to_bytes()?),
    ]
    .map(|(name, bytes)| (name, ModelBytes::copy_from(&bytes)));
    let views: Vec<&[u8]> = files.iter().map(|(_, b)| b.as_bytes()).collect();

    let k = CLASSES.len();
    let mut words = vec![0u32; views.len() * transcript::words_per_model(k)];
    let n = transcript::transcript(&views, &mut words)
        .map_err(|e| format!("transcript failed: {e:?}"))?;
    if n != words.len() {
        return Err(format!("transcript has {n} words, expected {}", words.len()).into());
    }

    let mut txt = String::new();
    let mut header = String::from(
        "/* Written by dynaslice-modelgen: the host (std) reference transcript. */\n\
         #include <stdint.h>\n",
    );
    writeln!(header, "#define DYNASLICE_EXPECTED_LEN {n}")?;
    header.push_str("static const uint32_t dynaslice_expected[DYNASLICE_EXPECTED_LEN] = {\n");
    for w in &words {
        writeln!(txt, "{w:#010x}")?;
        writeln!(header, "    {w:#010x}u,")?;
    }
    header.push_str("};\n");

    let model = files[0].1.model()?;
    let layout = model.layout();
    let mut info = String::new();
    writeln!(info, "widths {:?}, K = {k}", layout.widths())?;
    writeln!(info, "parameters {}", layout.param_count())?;
    writeln!(info, "macs_per_point {}", layout.macs_per_point())?;
    for (name, bytes) in &files {
        writeln!(info, "{name} {} bytes", bytes.len())?;
    }
    let f0: Vec<f32> = words[..k].iter().map(|&w| f32::from_bits(w)).collect();
    let (x, t) = transcript::QUERIES[0];
    writeln!(info, "f32 model: f({x:?}, {t}) = {f0:?}")?;
    writeln!(info, "transcript words {n}")?;

    for (name, bytes) in &files {
        std::fs::write(out_dir.join(name), bytes.as_bytes())?;
    }
    std::fs::write(out_dir.join("expected.txt"), txt)?;
    std::fs::write(out_dir.join("expected.h"), header)?;
    std::fs::write(out_dir.join("model-info.txt"), &info)?;
    print!("{info}");
    Ok(())
}
