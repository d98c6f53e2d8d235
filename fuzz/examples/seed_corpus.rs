//! Writes valid models as seed inputs for both fuzz targets:
//! `cargo run --manifest-path fuzz/Cargo.toml --example seed_corpus -- fuzz/corpus`
//! creates `fuzz/corpus/from_bytes/` and `fuzz/corpus/from_bytes_crc/` (the directories
//! `cargo fuzz run TARGET` reads by default).
//!
//! Without valid seeds a fuzzer essentially never produces a file whose CRC matches, so it
//! would only ever test the header checks. The seeds vary every dimension the format has:
//! depth, widths (including ones that are not multiples of any SIMD width), class count,
//! weight type, metadata length (so padding before the weights ranges from 0 to 63 bytes),
//! multi-byte UTF-8 names and a non-identity domain. They are kept small (≤ ~6 KiB) so the
//! fuzzer runs many inputs per second.

use dynaslice_core::format::{ModelWriter, WeightType};
use dynaslice_core::Domain;
use std::path::PathBuf;

fn main() -> std::io::Result<()> {
    let root = PathBuf::from(std::env::args().nth(1).unwrap_or_else(|| "corpus".into()));
    let shapes: [(&[u32], u32); 6] = [
        (&[1], 1),
        (&[4], 2),
        (&[8, 8], 3),
        (&[5, 7, 3], 1),
        (&[16, 12], 4),
        (&[2, 2, 2, 2, 2, 2, 2, 2], 2),
    ];
    let metadata = ["", "x", "{\"epochs\":3}", "ü€𝄞 multi-byte metadata"];
    let mut n = 0;
    for (i, &(widths, k)) in shapes.iter().enumerate() {
        for weight_type in [WeightType::F32, WeightType::F16] {
            let mut w = ModelWriter::random_siren(widths, k, i as u64);
            w.weight_type = weight_type;
            w.metadata = metadata[i % metadata.len()].into();
            w.classes[0].0 = [
                "",
                "Myokard ♥",
                "LV",
                "a class name of exactly fifty-six bytes, padded out.....",
            ][i % 4]
                .into();
            if i % 2 == 1 {
                w.domain = Domain {
                    center: [12.5, -40.0, 7.25],
                    scale: [80.0, 80.0, 64.0],
                    time_origin: 0.1,
                    time_span: 0.8,
                    output_scale: 80.0,
                };
            }
            let bytes = w.try_to_bytes().map_err(std::io::Error::other)?;
            for target in ["from_bytes", "from_bytes_crc"] {
                let dir = root.join(target);
                std::fs::create_dir_all(&dir)?;
                std::fs::write(dir.join(format!("seed-{i}-{weight_type:?}.dsm")), &bytes)?;
            }
            n += 1;
        }
    }
    println!(
        "wrote {n} seed models to {}/{{from_bytes,from_bytes_crc}}",
        root.display()
    );
    Ok(())
}
