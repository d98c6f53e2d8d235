//! Valid inputs for every reader target, made with the crates' own writers and test fixtures
//! (and, for RT Structure Sets, dicom-rs): the seeds `examples/seed_corpus.rs` writes, and the
//! files of the `manifest` target's sandbox.
//!
//! [`seeds`] gives a target's seeds, [`crate::readers::write_seeds`] writes them after checking that the
//! target's reader accepts each.
//!
//! A fuzzer that starts from valid files reaches the checks behind the first few bytes (and the
//! code that builds planes and sequences) within seconds; from nothing it would spend its whole
//! budget learning magic numbers. Every input is small (at most a few KiB) so each run is fast,
//! and each varies what its format can vary: voxel types, endianness, 3D and 4D, gzip and raw,
//! attached and detached headers, layered segmentations, implicit and explicit VR.
//!
//! Functions that use a writer which only writes files take a `work` folder for them.

use std::io::Write;
use std::path::Path;

use dicom_core::value::DataSetSequence;
use dicom_core::{DataElement, PrimitiveValue, VR};
use dicom_dictionary_std::{tags, uids};
use dicom_object::{FileMetaTableBuilder, InMemDicomObject};
use dynaslice_core::format::{ModelWriter, WeightType};
use dynaslice_core::Domain;
use dynaslice_data::label_volume::LabelVolume;
use dynaslice_data::nifti::write_volume;
use dynaslice_data::nrrd::{write_segmentation, SegmentationHeader};
use dynaslice_data::{csl, ClassInfo, LabelTable, Sequence};
use dynaslice_sequence::native;
use dynaslice_test_support::fixtures::{csl_file, SQUARE_WITH_HOLE_PLANE, TRIANGLE_PLANE};
use dynaslice_optim::adam::{Adam, AdamConfig};
use dynaslice_optim::checkpoint::Checkpoint;
use dynaslice_optim::schedule_plan::SchedulePlan;

/// A named input: the file name it is written under and its bytes.
pub type Named = (String, Vec<u8>);

/// Any failure while making fixtures (they are made from constants, so one is a bug here).
pub type Error = Box<dyn std::error::Error>;

fn named(name: &str, bytes: impl Into<Vec<u8>>) -> Named {
    (name.to_string(), bytes.into())
}

/// The seeds of fuzz target `target` (one of [`crate::TARGETS`]); `work` is an empty folder for
/// writers that write files.
pub fn seeds(target: &str, work: &Path) -> Result<Vec<Named>, Error> {
    Ok(match target {
        "from_bytes" | "from_bytes_crc" => model_files()?,
        "nifti" => nifti_files(work)?,
        "nrrd" => nrrd_files(work)?,
        "rtstruct" => rtstruct_files()?,
        "csl" => csl_files(),
        "native_json" => native_files()?,
        "manifest" => manifests(),
        "label_table" => label_tables(),
        "checkpoint" => checkpoint_files(work)?,
        _ => return Err(format!("no fuzz target {target}").into()),
    })
}

/// Model files for `from_bytes` and `from_bytes_crc`. Without valid seeds a fuzzer essentially
/// never produces a file whose CRC matches, so it would only ever test the header checks. They
/// vary every dimension the format has: depth, widths (including ones that are not multiples
/// of any SIMD width), class count, weight type, metadata length (so padding before the weights
/// ranges from 0 to 63 bytes), multi-byte UTF-8 names and a non-identity domain, and are kept
/// small (≤ ~2 KiB) so the fuzzer runs many inputs per second. Each shape also comes as a
/// motion model (a version-2 file) with a motion network of its own depth and widths, so the
/// version-2 fields and the warp's evaluation are reached too.
pub fn model_files() -> Result<Vec<Named>, Error> {
    let motion: [&[u32]; 6] = [
        &[1],
        &[3],
        &[2, 5],
        &[4, 4, 4],
        &[7],
        &[1, 1, 1, 1, 1, 1, 1, 1],
    ];
    let shapes: [(&[u32], u32); 6] = [
        (&[1], 1),
        (&[4], 2),
        (&[8, 8], 3),
        (&[5, 7, 3], 1),
        (&[16, 12], 4),
        (&[2, 2, 2, 2, 2, 2, 2, 2], 2),
    ];
    let metadata = ["", "x", "{\"epochs\":3}", "ü€𝄞 multi-byte metadata"];
    let mut out = Vec::new();
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
            let bytes = w.try_to_bytes().map_err(|e| format!("{e:?}"))?;
            out.push((format!("{i}-{weight_type:?}.dsm"), bytes));
            w.motion = ModelWriter::random_motion(&[1], 1, motion[i], i as u64).motion;
            let bytes = w.try_to_bytes().map_err(|e| format!("{e:?}"))?;
            out.push((format!("{i}-{weight_type:?}-motion.dsm"), bytes));
        }
    }
    Ok(out)
}

/// `.csl` files: the reader tests' square-with-hole and triangle planes, alone and together,
/// and one timestep of a ball cut by five planes (48-gons).
pub fn csl_files() -> Vec<Named> {
    let ball = ball_planes(10.0, 12);
    vec![
        named(
            "square_triangle.csl",
            csl_file(2, &[SQUARE_WITH_HOLE_PLANE, TRIANGLE_PLANE]),
        ),
        named("square.csl", csl_file(2, &[SQUARE_WITH_HOLE_PLANE])),
        // Alone it is plane 1.
        named(
            "triangle.csl",
            csl_file(1, &[TRIANGLE_PLANE.replacen("2 ", "1 ", 1)]),
        ),
        named("ball.csl", csl_file(1, &ball)),
    ]
}

/// The planes of a ball of radius `r` cut at z = −6, −3, 0, 3, 6 by `n`-gons (label 1), as the
/// `.csl` plane records of `dynaslice_test_support::fixtures::write_sequence`.
fn ball_planes(r: f64, n: usize) -> Vec<String> {
    [-6.0f64, -3.0, 0.0, 3.0, 6.0]
        .iter()
        .enumerate()
        .map(|(p, z)| {
            let rc = (r * r - z * z).sqrt();
            let mut plane = format!("{} {n} 1 0 0 1 {}\n\n", p + 1, -z);
            for j in 0..n {
                let a = std::f64::consts::TAU * j as f64 / n as f64;
                plane += &format!("{:.4} {:.4} {z}\n", rc * a.cos(), rc * a.sin());
            }
            let indices: Vec<String> = (0..n).map(|j| j.to_string()).collect();
            plane + &format!("\n{n} 1 {}\n\n", indices.join(" "))
        })
        .collect()
}

/// Sequences to write as native JSON: every `.csl` file's, and a three-timestep one (the
/// ball growing) so the frames' time order is exercised.
pub fn sequences() -> Result<Vec<(String, Sequence)>, Error> {
    let table = LabelTable::default();
    let mut out = Vec::new();
    for (name, text) in csl_files() {
        let text = String::from_utf8(text)?;
        let seq = csl::parse(&text, Path::new(&name), &table)?;
        out.push((name.replace(".csl", ".json"), seq));
    }
    let mut classes = Vec::new();
    let mut frames = Vec::new();
    for (i, r) in [9.0, 10.0, 11.0].into_iter().enumerate() {
        let text = csl_file(1, &ball_planes(r, 8));
        let (c, mut f) = csl::parse(&text, Path::new("ball.csl"), &table)?.into_parts();
        f[0].time = 0.5 * i as f64;
        classes = c;
        frames.extend(f);
    }
    out.push(("ball_moving.json".into(), Sequence::new(classes, frames)?));
    Ok(out)
}

/// Native JSON documents of [`sequences`].
pub fn native_files() -> Result<Vec<Named>, Error> {
    Ok(sequences()?
        .into_iter()
        .map(|(name, seq)| (name, native::to_json(&seq).into_bytes()))
        .collect())
}

/// Label tables: both separators, comments, blank lines, negative labels, multi-byte names.
pub fn label_tables() -> Vec<Named> {
    vec![
        named(
            "two.txt",
            "# TotalSegmentator labels\n1 spleen\n\n5, right kidney\n",
        ),
        named(
            "mixed.txt",
            "-3 below zero\n0,background\n2147483647 largest\n7\tLV myocardium ♥\n",
        ),
        named("one.txt", "42 a\n"),
        named(
            "slicer.ctbl",
            "# Color table file heart.ctbl\n0 Background 0 0 0 0\n1 left_ventricle 221 130 101 255\n",
        ),
        named(
            "itksnap.label.txt",
            "# ITK-SNAP Label Description File\n    0     0    0    0        0  0  0    \"Clear Label\"\n    2   255    0   10        1  1  1    \"right kidney\"\n",
        ),
        named("caret.xml", CARET_XML),
    ]
}

/// An XML label table as Connectome Workbench and TotalSegmentator write it in a NIfTI header
/// extension.
const CARET_XML: &str = r#"<?xml version="1.0" encoding="UTF-8"?> <CaretExtension>
<VolumeInformation Index="0"> <LabelTable>
<Label Key="1" Red="0.0" Green="1.0" Blue="0.0" Alpha="1"><![CDATA[spleen]]></Label>
<Label Key="2" Red="0.0" Green="0.0" Blue="1.0" Alpha="1"><![CDATA[kidney_right]]></Label>
</LabelTable> </VolumeInformation></CaretExtension>"#;

/// `nii` (a single-file NIfTI written by [`write_volume`], voxels at byte 352) with `xml` as a
/// header extension of code 0 before its voxels, `vox_offset` moved past it.
fn with_xml_extension(mut nii: Vec<u8>, xml: &str) -> Vec<u8> {
    let mut content = xml.as_bytes().to_vec();
    // esize (8 + content) is a multiple of 16.
    content.resize((content.len() + 8).div_ceil(16) * 16 - 8, 0);
    let esize = content.len() + 8;
    let mut extension = (esize as i32).to_le_bytes().to_vec();
    extension.extend(0i32.to_le_bytes());
    extension.extend(content);
    nii[108..112].copy_from_slice(&((352 + esize) as f32).to_le_bytes());
    nii[348] = 1;
    nii.splice(352..352, extension);
    nii
}

/// The names of [`sandbox_files`], the only files a manifest may list for the `manifest`
/// target to read it whole.
pub const SANDBOX_NAMES: [&str; 6] = ["a.csl", "b.csl", "c.json", "d.nii", "e.nrrd", "f.dcm"];

/// The files the `manifest` target's sandbox holds, by the names its manifests may list: two
/// `.csl` files, a native JSON sequence, a NIfTI label map, a 3D Slicer segmentation and an RT
/// Structure Set, each one timestep.
pub fn sandbox_files(work: &Path) -> Result<Vec<Named>, Error> {
    let csl = csl_files();
    let native = native_files()?;
    let nifti = nifti_files(work)?;
    let nrrd = nrrd_files(work)?;
    let dcm = rtstruct_files()?;
    let pick = |files: &[Named], name: &str| -> Result<Vec<u8>, Error> {
        let found = files.iter().find(|(n, _)| n == name);
        Ok(found.ok_or(format!("no fixture {name}"))?.1.clone())
    };
    let contents = [
        pick(&csl, "square_triangle.csl")?,
        pick(&csl, "ball.csl")?,
        pick(&native, "ball.json")?,
        pick(&nifti, "blobs_u8.nii")?,
        pick(&nrrd, "written.seg.nrrd")?,
        pick(&dcm, "explicit.dcm")?,
    ];
    Ok(SANDBOX_NAMES
        .iter()
        .zip(contents)
        .map(|(name, bytes)| named(name, bytes))
        .collect())
}

/// Manifests over [`sandbox_files`]: one input, timesteps of one kind, and entries of equal
/// time joined into one timestep across kinds.
pub fn manifests() -> Vec<Named> {
    vec![
        named("one.seq", "0 a.csl\n"),
        named("ball.seq", "# the ball, twice\n0 b.csl\n0.5 c.json\n"),
        named("labels.seq", "0 d.nii\n1 e.nrrd\n"),
        named("joined.cslseq", "0 a.csl\n0 f.dcm\n 2.5\tb.csl\n"),
    ]
}

/// A small label map: two blobs (labels `a` and `b`) in a `dims` grid, the second growing
/// with the frame.
fn blobs(dims: [usize; 3], frames: usize, (a, b): (i32, i32)) -> Vec<i32> {
    let [nx, ny, nz] = dims;
    let mut labels = vec![0; nx * ny * nz * frames];
    for f in 0..frames {
        for k in 0..nz {
            for j in 0..ny {
                for i in 0..nx {
                    let v = &mut labels[i + nx * (j + ny * (k + nz * f))];
                    if (1..=nx / 2).contains(&i) && (1..ny - 1).contains(&j) {
                        *v = a;
                    } else if i + 1 >= nx - f.min(nx / 2) && j + 2 >= ny && k > 0 {
                        *v = b;
                    }
                }
            }
        }
    }
    labels
}

/// NIfTI-1 label maps written by `nifti::write_volume`: 3D and 4D, plain and gzip, voxel types
/// from u8 to i32 (chosen by the labels' range), axis-aligned and oblique.
pub fn nifti_files(work: &Path) -> Result<Vec<Named>, Error> {
    let diag = [
        [1.5, 0.0, 0.0, -4.0],
        [0.0, 1.5, 0.0, 2.0],
        [0.0, 0.0, 3.0, 10.0],
    ];
    let (c, s) = (0.8f64, 0.6f64);
    let oblique = [[c, -s, 0.0, 1.0], [s, c, 0.0, -1.0], [0.0, 0.0, 2.0, 0.5]];
    // Name, dims, frames, the blobs' two labels, affine.
    type Case<'a> = (&'a str, [usize; 3], usize, (i32, i32), [[f64; 4]; 3]);
    let cases: [Case; 5] = [
        ("blobs_u8.nii", [6, 5, 4], 1, (1, 2), diag),
        ("blobs_u8.nii.gz", [6, 5, 4], 1, (1, 2), diag),
        ("moving_i16.nii", [5, 5, 3], 3, (-1, 300), diag),
        ("oblique_u16.nii.gz", [5, 4, 3], 2, (7, 60000), oblique),
        ("wide_i32.nii", [4, 4, 3], 1, (1, 100_000), oblique),
    ];
    let mut out = Vec::new();
    for (name, dims, frames, pair, affine) in cases {
        let volume = LabelVolume {
            dims,
            frames,
            affine,
            frame_interval: 0.25,
            labels: blobs(dims, frames, pair),
        };
        let path = work.join(name);
        write_volume(&volume, &path)?;
        out.push(named(name, std::fs::read(&path)?));
    }
    let plain = out[0].1.clone();
    out.push(named(
        "labelled_u8.nii",
        with_xml_extension(plain, CARET_XML),
    ));
    Ok(out)
}

/// The detached data file the `detached.nhdr` seed names: a 5-byte preamble (`byte skip: 5`),
/// then a 4×3×2 uchar label map.
pub const NRRD_DATA_FILE: &str = "detached.raw";

/// The contents of [`NRRD_DATA_FILE`].
pub fn nrrd_data_file() -> Vec<u8> {
    let mut bytes = b"skip!".to_vec();
    bytes.extend(blobs([4, 3, 2], 1, (1, 2)).iter().map(|&v| v as u8));
    bytes
}

/// An attached-header NRRD with raw data.
fn nrrd_raw(fields: &str, data: &[u8]) -> Vec<u8> {
    let mut bytes = format!("NRRD0004\n{fields}\nencoding: raw\n\n").into_bytes();
    bytes.extend_from_slice(data);
    bytes
}

/// NRRD files: a 3D Slicer segmentation by `nrrd::write_segmentation` (gzip), and hand-written
/// raw ones, which mutations can change without breaking a gzip checksum: a plain label map in
/// RAS, a big-endian 4D series with a time axis, a two-layer segmentation in LPS with Slicer's
/// segment keys, a little-endian int map with `spacings` only, and a detached header.
pub fn nrrd_files(work: &Path) -> Result<Vec<Named>, Error> {
    let mut out = Vec::new();
    let dims = [5, 4, 3];
    let header = SegmentationHeader {
        dims,
        affine: [
            [-0.7, 0.0, 0.0, 12.0],
            [0.0, -0.7, 0.0, 30.5],
            [0.0, 0.0, 1.5, -40.0],
        ],
        classes: vec![
            ClassInfo {
                name: "liver".into(),
                label: 1,
                color: Some([221, 130, 101]),
            },
            ClassInfo {
                name: "spleen\\2".into(),
                label: 2,
                color: None,
            },
        ],
    };
    let path = work.join("written.seg.nrrd");
    write_segmentation(&path, &header, &blobs(dims, 1, (1, 2)))?;
    out.push(named("written.seg.nrrd", std::fs::read(&path)?));

    let u8s = |labels: Vec<i32>| labels.into_iter().map(|v| v as u8).collect::<Vec<_>>();
    out.push(named(
        "plain.nrrd",
        nrrd_raw(
            "type: uchar\ndimension: 3\nsizes: 4 3 2\nspace: RAS\n\
             space directions: (1,0,0) (0,2,0) (0,0,3)\nspace origin: (1,2,3)",
            &u8s(blobs([4, 3, 2], 1, (1, 2))),
        ),
    ));
    let series: Vec<u8> = blobs([3, 3, 2], 2, (1, 258))
        .into_iter()
        .flat_map(|v| (v as i16).to_be_bytes())
        .collect();
    out.push(named(
        "series_be.nrrd",
        nrrd_raw(
            "type: short\nendian: big\ndimension: 4\nsizes: 3 3 2 2\n\
             kinds: domain domain domain time\nspacings: nan nan nan 0.5",
            &series,
        ),
    ));
    let (l0, l1) = (
        u8s(blobs([4, 3, 2], 1, (1, 2))),
        u8s(blobs([4, 3, 2], 1, (0, 1))),
    );
    // Layer axis first (fastest): the two layers' values interleaved per voxel.
    let layered: Vec<u8> = l0.iter().zip(&l1).flat_map(|(&a, &b)| [a, b]).collect();
    out.push(named(
        "layers.seg.nrrd",
        nrrd_raw(
            "type: unsigned char\ndimension: 4\nsizes: 2 4 3 2\nkinds: list domain domain domain\n\
             space: left-posterior-superior\n\
             space directions: none (-0.7,0,0) (0,-0.7,0) (0,0,1.5)\nspace origin: (12,30.5,-40)\n\
             Segment0_ID:=id_liver\nSegment0_Name:=liver\nSegment0_Color:=0.86 0.5 0.39\n\
             Segment0_LabelValue:=1\nSegment0_Layer:=0\nSegment0_Extent:=0 3 0 2 0 1\n\
             Segment1_ID:=id_spleen\nSegment1_Name:=spleen\nSegment1_LabelValue:=2\n\
             Segment1_Layer:=0\nSegment2_ID:=id_tumour\nSegment2_Color:=1 0 0\n\
             Segment2_LabelValue:=1\nSegment2_Layer:=1\nSegment2_Extent:=1 3 0 2 1 1",
            &layered,
        ),
    ));
    let ints: Vec<u8> = blobs([3, 4, 2], 1, (-5, 70_000))
        .into_iter()
        .flat_map(i32::to_le_bytes)
        .collect();
    out.push(named(
        "spacings_le.nrrd",
        nrrd_raw(
            "type: int\nendian: little\ndimension: 3\nsizes: 3 4 2\nspacings: 0.5 nan 2",
            &ints,
        ),
    ));
    out.push(named(
        "detached.nrrd",
        format!(
            "NRRD0005\ntype: uint8\ndimension: 3\nsizes: 4 3 2\nencoding: raw\n\
             data file: {NRRD_DATA_FILE}\nbyte skip: 5\n"
        ),
    ));
    Ok(out)
}

/// One ROI of an RT Structure Set fixture.
struct Roi {
    number: i32,
    name: &'static str,
    color: Option<[u8; 3]>,
    /// Closed planar contours, patient LPS millimetres.
    contours: Vec<Vec<[f64; 3]>>,
}

/// A regular `n`-gon of radius `r` about (cx, cy) at height z, counter-clockwise.
fn ngon(cx: f64, cy: f64, z: f64, r: f64, n: usize) -> Vec<[f64; 3]> {
    (0..n)
        .map(|j| {
            let a = std::f64::consts::TAU * j as f64 / n as f64;
            [cx + r * a.cos(), cy + r * a.sin(), z]
        })
        .collect()
}

/// An RT Structure Set as DICOM Part 10 bytes, as the reader tests' pydicom writer makes it:
/// SOP class RT Structure Set Storage, Modality `RTSTRUCT`, the StructureSetROISequence and
/// the ROIContourSequence with `CLOSED_PLANAR` contours (DS values, 4 decimals).
fn rtstruct(rois: &[Roi], transfer_syntax: &str) -> Result<Vec<u8>, Error> {
    let is = |v: i32| PrimitiveValue::from(v.to_string());
    let text = |s: &str| PrimitiveValue::from(s.to_string());
    let instance = "2.25.1234567890123456789";
    let frame = "2.25.987654321";
    let mut defined = Vec::new();
    let mut contoured = Vec::new();
    for roi in rois {
        defined.push(InMemDicomObject::from_element_iter([
            DataElement::new(tags::ROI_NUMBER, VR::IS, is(roi.number)),
            DataElement::new(tags::REFERENCED_FRAME_OF_REFERENCE_UID, VR::UI, text(frame)),
            DataElement::new(tags::ROI_NAME, VR::LO, text(roi.name)),
            DataElement::new(tags::ROI_GENERATION_ALGORITHM, VR::CS, text("MANUAL")),
        ]));
        let items: Vec<InMemDicomObject> = roi
            .contours
            .iter()
            .map(|points| {
                let data: Vec<String> =
                    points.iter().flatten().map(|v| format!("{v:.4}")).collect();
                InMemDicomObject::from_element_iter([
                    DataElement::new(tags::CONTOUR_GEOMETRIC_TYPE, VR::CS, text("CLOSED_PLANAR")),
                    DataElement::new(
                        tags::NUMBER_OF_CONTOUR_POINTS,
                        VR::IS,
                        is(points.len() as i32),
                    ),
                    DataElement::new(
                        tags::CONTOUR_DATA,
                        VR::DS,
                        PrimitiveValue::Strs(data.into()),
                    ),
                ])
            })
            .collect();
        let mut item = InMemDicomObject::from_element_iter([
            DataElement::new(tags::REFERENCED_ROI_NUMBER, VR::IS, is(roi.number)),
            DataElement::new(tags::CONTOUR_SEQUENCE, VR::SQ, DataSetSequence::from(items)),
        ]);
        if let Some(c) = roi.color {
            let rgb: Vec<String> = c.iter().map(u8::to_string).collect();
            item.put(DataElement::new(
                tags::ROI_DISPLAY_COLOR,
                VR::IS,
                PrimitiveValue::Strs(rgb.into()),
            ));
        }
        contoured.push(item);
    }
    let obj = InMemDicomObject::from_element_iter([
        DataElement::new(
            tags::SOP_CLASS_UID,
            VR::UI,
            text(uids::RT_STRUCTURE_SET_STORAGE),
        ),
        DataElement::new(tags::SOP_INSTANCE_UID, VR::UI, text(instance)),
        DataElement::new(tags::MODALITY, VR::CS, text("RTSTRUCT")),
        DataElement::new(tags::PATIENT_NAME, VR::PN, text("Phantom")),
        DataElement::new(tags::STRUCTURE_SET_LABEL, VR::SH, text("fuzz")),
        DataElement::new(
            tags::STRUCTURE_SET_ROI_SEQUENCE,
            VR::SQ,
            DataSetSequence::from(defined),
        ),
        DataElement::new(
            tags::ROI_CONTOUR_SEQUENCE,
            VR::SQ,
            DataSetSequence::from(contoured),
        ),
    ]);
    let file = obj.with_meta(FileMetaTableBuilder::new().transfer_syntax(transfer_syntax))?;
    let mut bytes = Vec::new();
    file.write_all(&mut bytes)?;
    Ok(bytes)
}

/// RT Structure Sets: a GTV (octagons on three axial planes) and a ring-shaped lung (an outer
/// contour and a hole on two planes, coloured), in explicit and implicit VR little endian; and
/// a file with one sagittal contour besides the axial ones.
pub fn rtstruct_files() -> Result<Vec<Named>, Error> {
    let gtv = || Roi {
        number: 3,
        name: "GTV",
        color: None,
        contours: [45.0, 50.0, 55.0]
            .iter()
            .map(|&z| ngon(30.0, -40.0, z, 8.0 + (z - 50.0f64).abs() / 5.0, 8))
            .collect(),
    };
    let lung = || Roi {
        number: 7,
        name: "Lung right",
        color: Some([255, 128, 0]),
        contours: [45.0, 50.0]
            .iter()
            .flat_map(|&z| {
                [
                    ngon(-60.0, 10.0, z, 30.0, 10),
                    ngon(-60.0, 10.0, z, 15.0, 6),
                ]
            })
            .collect(),
    };
    let sagittal = Roi {
        number: 9,
        name: "cord",
        color: Some([0, 0, 255]),
        contours: vec![[
            [0.0, -10.0, 40.0],
            [0.0, 10.0, 40.0],
            [0.0, 10.0, 60.0],
            [0.0, -10.0, 60.0],
        ]
        .to_vec()],
    };
    Ok(vec![
        named(
            "explicit.dcm",
            rtstruct(&[gtv(), lung()], uids::EXPLICIT_VR_LITTLE_ENDIAN)?,
        ),
        named(
            "implicit.dcm",
            rtstruct(&[lung(), gtv()], uids::IMPLICIT_VR_LITTLE_ENDIAN)?,
        ),
        named(
            "two_orientations.dcm",
            rtstruct(&[gtv(), sagittal], uids::EXPLICIT_VR_LITTLE_ENDIAN)?,
        ),
        named(
            "bare_implicit.dcm",
            data_set(&rtstruct(&[gtv()], uids::IMPLICIT_VR_LITTLE_ENDIAN)?).to_vec(),
        ),
        named(
            "deflated.dcm",
            deflated(&rtstruct(&[lung()], uids::EXPLICIT_VR_LITTLE_ENDIAN)?)?,
        ),
    ])
}

/// The data set of a Part 10 file written by [`rtstruct`]: what follows the file meta group,
/// whose length (0002,0000) is the first meta element's value (bytes 140..144).
fn data_set(part10: &[u8]) -> &[u8] {
    let meta = u32::from_le_bytes(part10[140..144].try_into().expect("4 bytes")) as usize;
    &part10[144 + meta..]
}

/// An explicit-VR Part 10 file rewritten with the deflated transfer syntax: preamble, a file
/// meta group naming it, then the data set deflated (raw deflate, PS3.5 A.5).
fn deflated(explicit: &[u8]) -> Result<Vec<u8>, Error> {
    let meta = FileMetaTableBuilder::new()
        .transfer_syntax(uids::DEFLATED_EXPLICIT_VR_LITTLE_ENDIAN)
        .media_storage_sop_class_uid(uids::RT_STRUCTURE_SET_STORAGE)
        .media_storage_sop_instance_uid("2.25.1234567890123456789")
        .build()?;
    let mut bytes = vec![0u8; 128];
    bytes.extend(b"DICM");
    meta.write(&mut bytes)?;
    let mut encoder = flate2::write::DeflateEncoder::new(bytes, flate2::Compression::default());
    encoder.write_all(data_set(explicit))?;
    Ok(encoder.finish()?)
}

/// What the `checkpoint` target's first byte asks (see [`crate::readers::checkpoint`]): load
/// as the file's own run, CRC recomputed.
pub const CHECKPOINT_OWN_RUN: u8 = 0b01;

/// Checkpoints written by `Checkpoint::save` (format `DSCKPT03`, with and without a planned
/// schedule length, 0 to 5 parameters) and one in the first format (`DSCKPT01`), each behind
/// the target's mode byte.
pub fn checkpoint_files(work: &Path) -> Result<Vec<Named>, Error> {
    let mut out = Vec::new();
    for (n, planned) in [(0usize, None), (1, Some(1234)), (5, None)] {
        let mut adam = Adam::new(n, AdamConfig::default());
        let mut params: Vec<f32> = (0..n).map(|i| 0.5 - i as f32).collect();
        let grad: Vec<f32> = (0..n).map(|i| 0.1 * i as f32 - 0.2).collect();
        adam.step(&mut params, &grad, 1e-3);
        let c = Checkpoint {
            fingerprint: 0x0123_4567_89ab_cdef ^ n as u64,
            step: 7 + n as u64,
            params,
            adam,
            plan: planned.map(|length| SchedulePlan {
                anchor_step: 12,
                anchor_phase: 0.25,
                length,
            }),
        };
        let path = work.join("seed.ckpt");
        c.save(&path)?;
        let mut bytes = vec![CHECKPOINT_OWN_RUN];
        bytes.extend(std::fs::read(&path)?);
        out.push((format!("v3_n{n}.ckpt"), bytes));
    }
    // The first format: the second file without its planned length, CRC written anew.
    let v3 = &out[1].1[1..];
    let mut v1 = [b"DSCKPT01".as_slice(), &v3[8..40], &v3[64..v3.len() - 4]].concat();
    let crc = dynaslice_core::crc32(&v1);
    v1.extend_from_slice(&crc.to_le_bytes());
    let mut bytes = vec![CHECKPOINT_OWN_RUN];
    bytes.write_all(&v1)?;
    out.push(named("v1_n1.ckpt", bytes));
    Ok(out)
}
