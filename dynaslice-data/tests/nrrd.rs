//! NRRD label maps and 3D Slicer segmentations: files written by pynrrd (LPS and RAS, raw and
//! gzip, several types, 3D and with a time axis, layered segmentations) read with the same
//! labels and world positions; our `.seg.nrrd` read back by pynrrd, slicerio and our reader;
//! detached headers; and every malformed-input error naming the file and the problem.

use std::io::Write;
use std::path::{Path, PathBuf};
use std::sync::{Mutex, Once};

use dynaslice_data::label_volume::LabelVolume;
use dynaslice_data::nrrd::{read_volume, write_segmentation, SegmentationHeader};
use dynaslice_data::{ClassInfo, ErrorKind};
use dynaslice_sequence::palette::palette;
use dynaslice_test_support::fixtures::shared_data;
use dynaslice_test_support::python::run_python;
use serde_json::Value;

/// Warnings logged by the reader, kept so tests can check them (filtered by file name, since
/// tests run in parallel).
static LOGS: Mutex<Vec<String>> = Mutex::new(Vec::new());

struct Capture;

impl log::Log for Capture {
    fn enabled(&self, _: &log::Metadata) -> bool {
        true
    }
    fn log(&self, record: &log::Record) {
        LOGS.lock().unwrap().push(record.args().to_string());
    }
    fn flush(&self) {}
}

fn capture_logs() {
    static INIT: Once = Once::new();
    INIT.call_once(|| {
        log::set_logger(&Capture).unwrap();
        log::set_max_level(log::LevelFilter::Warn);
    });
}

fn warnings_about(file: &Path) -> Vec<String> {
    let name = file.display().to_string();
    LOGS.lock()
        .unwrap()
        .iter()
        .filter(|m| m.contains(&name))
        .cloned()
        .collect()
}

fn f64s(v: &Value) -> Vec<f64> {
    v.as_array()
        .unwrap()
        .iter()
        .map(|x| x.as_f64().unwrap())
        .collect()
}

fn i32s(v: &Value) -> Vec<i32> {
    serde_json::from_value(v.clone()).unwrap()
}

fn assert_affine(got: &[[f64; 4]; 3], want: &Value, what: &str) {
    for r in 0..3 {
        let row = f64s(&want[r]);
        for c in 0..4 {
            assert!(
                (got[r][c] - row[c]).abs() < 1e-9,
                "{what}: affine[{r}][{c}] {} vs {}\n{got:?}",
                got[r][c],
                row[c]
            );
        }
    }
}

/// pynrrd writes label maps in every combination that matters (space LPS/RAS in long and
/// short names, raw/gzip, uint8/int16/uint16/int64, little and big endian, 3D, and a time axis
/// last or first); we read the same labels, frames and world positions of voxels.
#[test]
fn reads_pynrrd_label_maps_with_their_world_positions() {
    let dir = tempfile::tempdir().unwrap();
    let script = r#"
import json, sys, os, numpy as np, nrrd
out = sys.argv[1]
nx, ny, nz, nt = 6, 5, 4, 3
i, j, k, t = np.meshgrid(np.arange(nx), np.arange(ny), np.arange(nz), np.arange(nt), indexing='ij')
labels = (i + 2 * j + 3 * k + 5 * t) % 7
labels[labels == 6] = 200
th = 0.3
R = np.array([[np.cos(th), -np.sin(th), 0], [np.sin(th), np.cos(th), 0], [0, 0, 1]])
D = R @ np.diag([0.8, 1.25, 2.5])  # columns: the directions of axes i, j, k
origin = np.array([10.5, -20.25, 33.0])
none = [np.nan] * 3
cases = []
for name, space, enc, dtype, time in [
    ("lps_raw_i16.nrrd", "left-posterior-superior", "raw", "<i2", None),
    ("lps_gz_u8_time_last.nrrd", "left-posterior-superior", "gzip", "u1", "last"),
    ("ras_raw_u8.nrrd", "right-anterior-superior", "raw", "u1", None),
    ("ras_gz_i16be_time_first.nrrd", "RAS", "gzip", ">i2", "first"),
    ("lps_gz_i64.nrrd", "LPS", "gzip", "<i8", None),
    ("ras_raw_u16_time_last.nrrd", "right-anterior-superior", "raw", "<u2", "last"),
]:
    header = {"space": space, "space origin": origin, "encoding": enc}
    if time is None:
        data = labels[..., 0]
        header["space directions"] = D.T
        header["kinds"] = ["domain"] * 3
        want = data
    elif time == "last":
        data = labels
        header["space directions"] = np.vstack([D.T, none])
        header["kinds"] = ["domain"] * 3 + ["time"]
        header["spacings"] = [np.nan] * 3 + [0.5]
        want = labels
    else:
        data = np.moveaxis(labels, 3, 0)
        header["space directions"] = np.vstack([none, D.T])
        header["kinds"] = ["time"] + ["domain"] * 3
        header["spacings"] = [0.5] + [np.nan] * 3
        want = labels
    path = os.path.join(out, name)
    nrrd.write(path, np.ascontiguousarray(data.astype(dtype)), header)
    # The world frame of the file, then ours (RAS): LPS has x and y negated.
    to_space = np.eye(4)
    to_space[:3, :3] = D
    to_space[:3, 3] = origin
    flip = np.diag([-1.0, -1.0, 1.0, 1.0]) if space in ("left-posterior-superior", "LPS") else np.eye(4)
    affine = flip @ to_space
    points = []
    for ijk in [(0, 0, 0), (5, 0, 0), (0, 4, 0), (0, 0, 3), (5, 4, 3), (2, 3, 1)]:
        p = flip @ (to_space @ np.array([*ijk, 1.0]))
        points.append({"ijk": ijk, "ras": p[:3].tolist()})
    cases.append({
        "name": name,
        "dims": [nx, ny, nz],
        "frames": 1 if time is None else nt,
        "labels": want.flatten(order="F").tolist(),
        "affine": affine[:3].tolist(),
        "points": points,
    })
print(json.dumps(cases))
"#;
    let Some(text) = run_python(&["nrrd", "numpy"], script, &[dir.path()]) else {
        return;
    };
    let cases: Vec<Value> = serde_json::from_str(&text).unwrap();
    assert_eq!(cases.len(), 6);
    for case in &cases {
        let name = case["name"].as_str().unwrap();
        let (v, table) = read_volume(&dir.path().join(name)).unwrap();
        assert_eq!(
            v.dims.to_vec(),
            i32s(&case["dims"])
                .iter()
                .map(|&n| n as usize)
                .collect::<Vec<_>>(),
            "{name}"
        );
        assert_eq!(v.frames as u64, case["frames"].as_u64().unwrap(), "{name}");
        assert_eq!(v.labels, i32s(&case["labels"]), "{name}: labels");
        assert!(v.labels.contains(&200), "{name}: values above 127 survive");
        assert_affine(&v.affine, &case["affine"], name);
        for p in case["points"].as_array().unwrap() {
            let ijk = f64s(&p["ijk"]);
            let want = f64s(&p["ras"]);
            let got = v.to_world([ijk[0], ijk[1], ijk[2]]);
            for a in 0..3 {
                assert!(
                    (got[a] - want[a]).abs() < 1e-9,
                    "{name} {ijk:?}: {got:?} vs {want:?}"
                );
            }
        }
        let dt = if v.frames > 1 { 0.5 } else { 1.0 };
        assert_eq!(v.frame_interval, dt, "{name}");
        assert!(table.is_empty(), "{name}: a plain label map has no table");
        assert_eq!(table.name(3), "label 3");
    }
}

/// A 3D Slicer segmentation written by pynrrd with Slicer's keys: two layers whose segments
/// overlap and share label values, one single-layer file with an unclaimed value and a segment
/// outside its extent, and a legacy file (one binary layer per segment, no label values).
#[test]
fn reads_slicer_segmentations_with_their_tables() {
    capture_logs();
    let dir = tempfile::tempdir().unwrap();
    let script = r#"
import json, sys, os, numpy as np, nrrd
out = sys.argv[1]
nx, ny, nz = 8, 7, 5
D = np.diag([-0.7, -0.7, 1.5])
origin = np.array([12.0, 30.5, -40.0])
def header(layers):
    h = {"space": "left-posterior-superior", "space origin": origin, "encoding": "gzip",
         "Segmentation_MasterRepresentation": "Binary labelmap",
         "Segmentation_ContainedRepresentationNames": "Binary labelmap|Closed surface|"}
    if layers:
        h["kinds"] = ["list", "domain", "domain", "domain"]
        h["space directions"] = np.vstack([[np.nan] * 3, D.T])
    else:
        h["kinds"] = ["domain"] * 3
        h["space directions"] = D.T
    return h
def segment(h, n, name, color, value, layer, extent=None, with_name=True):
    h[f"Segment{n}_ID"] = f"id_{name}"
    if with_name:
        h[f"Segment{n}_Name"] = name
    h[f"Segment{n}_Color"] = " ".join(str(c) for c in color)
    if value is not None:
        h[f"Segment{n}_LabelValue"] = str(value)
        h[f"Segment{n}_Layer"] = str(layer)
    h[f"Segment{n}_Extent"] = extent or f"0 {nx-1} 0 {ny-1} 0 {nz-1}"
    h[f"Segment{n}_Tags"] = "Segmentation.Status:inprogress|"
result = {}

# Two layers: liver (1) and spleen (2) in layer 0, tumour (1) and vessel (3) in layer 1.
l0 = np.zeros((nx, ny, nz), np.uint8); l1 = np.zeros_like(l0)
l0[1:5, 1:5, 1:4] = 1; l0[5:8, 0:3, :] = 2
l1[3:7, 2:6, 2:5] = 1; l1[0:2, 5:7, 0:2] = 3
h = header(True)
segs = [(0, "liver", (0.866667, 0.509804, 0.396078), 1, 0),
        (1, "spleen", (0.615686, 0.423529, 0.635294), 2, 0),
        (2, "tumor", (1.0, 0.0, 0.0), 1, 1),
        (3, "vessel", (0.0, 0.5, 1.0), 3, 1)]
for n, name, color, value, layer in segs:
    segment(h, n, name, color, value, layer, with_name=(n != 3))
nrrd.write(os.path.join(out, "layers.seg.nrrd"), np.stack([l0, l1]), h)
want = np.zeros((nx, ny, nz), int)
for n, name, color, value, layer in segs:  # layer 0's segments first: the later layer wins
    want[(l0, l1)[layer] == value] = n + 1
result["layers"] = {
    "labels": want.flatten(order="F").tolist(),
    "overlap": int(((l0 > 0) & (l1 > 0)).sum()),
    "table": [[n + 1, name if n != 3 else f"id_{name}", [round(c * 255) for c in color]]
              for n, name, color, value, layer in segs],
    "affine": (np.diag([-1, -1, 1]) @ np.hstack([D, origin[:, None]])).tolist(),
}

# One layer: label values 3 and 7, value 9 has no segment, value 7 has a voxel outside its extent.
v = np.zeros((nx, ny, nz), np.uint8)
v[0:3, 0:3, 0:2] = 3; v[4:6, 4:6, 1:3] = 7; v[7, 6, 4] = 9; v[7, 0, 0] = 7
h = header(False)
segment(h, 0, "heart", (0.5, 0.25, 0.125), 3, 0)
segment(h, 1, "lung", (0.2, 0.4, 0.6), 7, 0, extent="4 5 4 5 1 2")
nrrd.write(os.path.join(out, "single.seg.nrrd"), v, h)
result["single"] = {"labels": v.flatten(order="F").tolist(),
                    "table": [[3, "heart", [128, 64, 32]], [7, "lung", [51, 102, 153]]]}

# Legacy: one binary layer per segment, no label values or layers.
b = np.zeros((2, nx, ny, nz), np.uint8)
b[0, 0:4] = 1; b[1, 3:8] = 1
h = header(True)
segment(h, 0, "left", (1, 0, 0), None, None)
segment(h, 1, "right", (0, 1, 0), None, None)
nrrd.write(os.path.join(out, "legacy.seg.nrrd"), b, h)
want = np.zeros((nx, ny, nz), int); want[b[0] == 1] = 1; want[b[1] == 1] = 2
result["legacy"] = {"labels": want.flatten(order="F").tolist(), "overlap": int((b[0] & b[1]).sum()),
                    "table": [[1, "left", [255, 0, 0]], [2, "right", [0, 255, 0]]]}
print(json.dumps(result))
"#;
    let Some(text) = run_python(&["nrrd", "numpy"], script, &[dir.path()]) else {
        return;
    };
    let want: Value = serde_json::from_str(&text).unwrap();
    let check_table = |table: &dynaslice_data::LabelTable, want: &Value, what: &str| {
        for entry in want.as_array().unwrap() {
            let label = entry[0].as_i64().unwrap() as i32;
            assert_eq!(table.name(label), entry[1].as_str().unwrap(), "{what}");
            let color: Vec<u8> = serde_json::from_value(entry[2].clone()).unwrap();
            assert_eq!(
                table.color(label).map(|c| c.to_vec()),
                Some(color),
                "{what} {label}"
            );
        }
    };

    let path = dir.path().join("layers.seg.nrrd");
    let (v, table) = read_volume(&path).unwrap();
    assert_eq!((v.dims, v.frames), ([8, 7, 5], 1));
    assert_eq!(v.labels, i32s(&want["layers"]["labels"]));
    check_table(&table, &want["layers"]["table"], "layers");
    assert_affine(&v.affine, &want["layers"]["affine"], "layers");
    let overlap = want["layers"]["overlap"].as_u64().unwrap();
    assert!(overlap > 0);
    let logs = warnings_about(&path);
    assert!(
        logs.iter().any(|m| m.contains(&format!(
            "{overlap} voxels belong to segments of more than one layer"
        ))),
        "{logs:?}"
    );

    let path = dir.path().join("single.seg.nrrd");
    let (v, table) = read_volume(&path).unwrap();
    assert_eq!(v.labels, i32s(&want["single"]["labels"]));
    check_table(&table, &want["single"]["table"], "single");
    assert_eq!(table.name(9), "label 9");
    let logs = warnings_about(&path);
    assert!(
        logs.iter()
            .any(|m| m.contains("no segment has label value 9 (1 voxels)")),
        "{logs:?}"
    );
    assert!(
        logs.iter()
            .any(|m| m.contains("1 voxels of Segment1 lie outside its Segment1_Extent")),
        "{logs:?}"
    );

    let path = dir.path().join("legacy.seg.nrrd");
    let (v, table) = read_volume(&path).unwrap();
    assert_eq!(v.labels, i32s(&want["legacy"]["labels"]));
    check_table(&table, &want["legacy"]["table"], "legacy");
}

/// An oblique, left-handed affine with anisotropic voxels, in RAS.
const AFFINE: [[f64; 4]; 3] = [
    [0.0, -1.5, 0.3, 10.25],
    [0.9, 0.0, 0.0, -20.5],
    [0.0, 0.2, -2.0, 5.0],
];

fn classes(specs: &[(&str, i32, Option<[u8; 3]>)]) -> Vec<ClassInfo> {
    specs
        .iter()
        .map(|&(name, label, color)| ClassInfo {
            name: name.into(),
            label,
            color,
        })
        .collect()
}

/// Labels of a 7×6×5 volume cycling through `values` (and background).
fn pattern(values: &[i32]) -> Vec<i32> {
    (0..7 * 6 * 5)
        .map(|n| {
            if n % 3 == 0 {
                0
            } else {
                values[n % values.len()]
            }
        })
        .collect()
}

/// Our `.seg.nrrd` as pynrrd and slicerio see it: header fields, voxels, segments (names,
/// colours, label values, layers, extents) and voxel → world (slicerio's ijkToLPS, flipped to
/// RAS, is our affine); and as our reader sees it (exact round trip).
#[test]
fn written_segmentation_is_read_by_pynrrd_slicerio_and_us() {
    let dir = tempfile::tempdir().unwrap();
    let wide = SegmentationHeader {
        dims: [7, 6, 5],
        affine: AFFINE,
        classes: classes(&[
            ("liver", 5, Some([10, 200, 30])),
            ("kidney (left)", 300, None),
            ("spleen", -2, None),
        ]),
    };
    let narrow = SegmentationHeader {
        classes: classes(&[("ball", 1, None), ("ring", 255, Some([0, 0, 0]))]),
        ..wide.clone()
    };
    let cases = [
        ("wide.seg.nrrd", &wide, pattern(&[5, 300, -2])),
        ("narrow.seg.nrrd", &narrow, pattern(&[1, 255])),
    ];
    let paths: Vec<PathBuf> = cases.iter().map(|(n, _, _)| dir.path().join(n)).collect();
    for ((_, header, labels), path) in cases.iter().zip(&paths) {
        write_segmentation(path, header, labels).unwrap();
        let (v, table) = read_volume(path).unwrap();
        assert_eq!(v.labels, *labels);
        assert_eq!((v.dims, v.frames), (header.dims, 1));
        assert_eq!(
            v.affine, AFFINE,
            "exact: shortest round-trip decimals, negation exact"
        );
        for (n, c) in header.classes.iter().enumerate() {
            assert_eq!(table.name(c.label), c.name);
            assert_eq!(table.color(c.label), Some(c.color.unwrap_or(palette(n))));
        }
    }
    let script = r#"
import json, sys, numpy as np, nrrd, slicerio
out = []
for p in sys.argv[1:]:
    data, h = nrrd.read(p)
    seg = slicerio.read_segmentation(p)
    out.append({
        "type": h["type"], "space": h["space"], "encoding": h["encoding"], "kinds": h["kinds"],
        "sizes": h["sizes"].tolist(), "endian": h.get("endian"),
        "master": h["Segmentation_MasterRepresentation"],
        "contained": h["Segmentation_ContainedRepresentationNames"],
        "labels": data.flatten(order="F").tolist(),
        "same_voxels": bool((seg["voxels"] == data).all()),
        "segments": [{k: s.get(k) for k in ("id", "name", "color", "labelValue", "layer", "extent",
                                             "colorAutoGenerated")} for s in seg["segments"]],
        "ras": (np.diag([-1.0, -1.0, 1.0, 1.0]) @ seg["ijkToLPS"])[:3].tolist(),
    })
print(json.dumps(out))
"#;
    let args: Vec<&Path> = paths.iter().map(PathBuf::as_path).collect();
    let Some(text) = run_python(&["nrrd", "numpy", "slicerio"], script, &args) else {
        return;
    };
    let seen: Vec<Value> = serde_json::from_str(&text).unwrap();
    for ((name, header, labels), s) in cases.iter().zip(&seen) {
        let want_type = if *name == "wide.seg.nrrd" {
            "short"
        } else {
            "unsigned char"
        };
        assert_eq!(s["type"], want_type, "{name}");
        assert_eq!(
            s["endian"],
            if want_type == "short" {
                "little".into()
            } else {
                Value::Null
            }
        );
        assert_eq!(s["space"], "left-posterior-superior");
        assert_eq!(s["encoding"], "gzip");
        assert_eq!(
            s["kinds"],
            serde_json::json!(["domain", "domain", "domain"])
        );
        assert_eq!(s["sizes"], serde_json::json!([7, 6, 5]));
        assert_eq!(s["master"], "Binary labelmap");
        assert_eq!(s["contained"], "Binary labelmap|");
        assert_eq!(i32s(&s["labels"]), *labels, "{name}: voxels, x fastest");
        assert_eq!(s["same_voxels"], true);
        assert_affine(&AFFINE, &s["ras"], name);
        let segments = s["segments"].as_array().unwrap();
        assert_eq!(segments.len(), header.classes.len());
        for (n, (c, seg)) in header.classes.iter().zip(segments).enumerate() {
            assert_eq!(seg["id"], format!("Segment_{}", c.label));
            assert_eq!(seg["name"], c.name.as_str());
            assert_eq!(seg["labelValue"], c.label);
            assert_eq!(seg["layer"], 0);
            assert_eq!(seg["extent"], serde_json::json!([0, 6, 0, 5, 0, 4]));
            assert_eq!(seg["colorAutoGenerated"], c.color.is_none());
            let rgb = c.color.unwrap_or(palette(n));
            let got = f64s(&seg["color"]);
            for a in 0..3 {
                assert!(
                    (got[a] - f64::from(rgb[a]) / 255.0).abs() < 1e-12,
                    "{name} {n}: {got:?}"
                );
            }
        }
    }
}

/// Names with a backslash and a newline survive our writer and reader (NRRD escapes).
#[test]
fn escaped_names_round_trip() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("names.seg.nrrd");
    let header = SegmentationHeader {
        dims: [2, 2, 1],
        affine: AFFINE,
        classes: classes(&[("a\\b", 1, None), ("two\nlines", 2, None)]),
    };
    write_segmentation(&path, &header, &[0, 1, 2, 1]).unwrap();
    let (_, table) = read_volume(&path).unwrap();
    assert_eq!(table.name(1), "a\\b");
    assert_eq!(table.name(2), "two\nlines");
}

/// A real multi-organ label map (TotalSegmentator's example, NIfTI) converted by nibabel and
/// pynrrd to an LPS `.seg.nrrd`: we read the same labels and affine as from the NIfTI file.
#[test]
fn real_label_map_through_pynrrd_matches_the_nifti_reader() {
    let Some(nii) = shared_data("nifti/example_seg.nii.gz") else {
        return;
    };
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("example.seg.nrrd");
    let script = r#"
import sys, numpy as np, nibabel as nib, nrrd
img = nib.load(sys.argv[1])
lps = np.diag([-1.0, -1.0, 1.0, 1.0]) @ img.affine
data = np.asarray(img.dataobj).astype(np.uint8)
nrrd.write(sys.argv[2], data, {"space": "left-posterior-superior", "kinds": ["domain"] * 3,
           "space directions": lps[:3, :3].T, "space origin": lps[:3, 3], "encoding": "gzip"})
"#;
    if run_python(&["nrrd", "numpy", "nibabel"], script, &[&nii, &out]).is_none() {
        return;
    }
    let from_nifti: LabelVolume = dynaslice_data::nifti::read_volume(&nii).unwrap();
    let (from_nrrd, _) = read_volume(&out).unwrap();
    assert_eq!(from_nrrd.dims, [122, 101, 30]);
    assert_eq!(from_nrrd.labels, from_nifti.labels);
    for r in 0..3 {
        for c in 0..4 {
            // nibabel's affine is f64 from the f32 sform: the same numbers both ways.
            assert!((from_nrrd.affine[r][c] - from_nifti.affine[r][c]).abs() < 1e-9);
        }
    }
}

/// Writes `header` (lines after the magic) and then `data` as an attached NRRD file.
fn nrrd_file(dir: &Path, name: &str, header: &str, data: &[u8]) -> PathBuf {
    let path = dir.join(name);
    let mut bytes = format!("NRRD0004\n{header}\n\n").into_bytes();
    bytes.extend_from_slice(data);
    std::fs::write(&path, bytes).unwrap();
    path
}

fn gzip(data: &[u8]) -> Vec<u8> {
    let mut e = flate2::write::GzEncoder::new(Vec::new(), flate2::Compression::default());
    e.write_all(data).unwrap();
    e.finish().unwrap()
}

const SPACE: &str = "space: RAS\nspace directions: (1,0,0) (0,2,0) (0,0,3)";

/// The detached forms: `data file` relative to the header, `line skip` and `byte skip` in raw
/// data, `byte skip: -1` (the data at the end), and a byte skip inside gzip data.
#[test]
fn detached_headers_with_skips() {
    let dir = tempfile::tempdir().unwrap();
    let samples: Vec<u8> = (0..24).map(|n| (n % 5) as u8).collect();
    let want: Vec<i32> = samples.iter().map(|&b| i32::from(b)).collect();
    let base = format!("type: uint8\ndimension: 3\nsizes: 4 3 2\n{SPACE}\nspace origin: (1,2,3)");
    let mut raw = b"first line\nsecond\nxyz".to_vec();
    raw.extend_from_slice(&samples);
    std::fs::write(dir.path().join("data.raw"), &raw).unwrap();
    let mut skipped = vec![7u8; 5];
    skipped.extend_from_slice(&samples);
    std::fs::write(dir.path().join("data.raw.gz"), gzip(&skipped)).unwrap();
    for (name, fields) in [
        (
            "skips.nhdr",
            "encoding: raw\ndata file: data.raw\nline skip: 2\nbyte skip: 3",
        ),
        (
            "end.nhdr",
            "encoding: raw\ndatafile: ./data.raw\nbyte skip: -1",
        ),
        (
            "gz.nhdr",
            "encoding: gz\ndata file: data.raw.gz\nbyte skip: 5",
        ),
    ] {
        let path = dir.path().join(name);
        // A detached header may end at the end of its file, without a blank line.
        std::fs::write(&path, format!("NRRD0005\n{base}\n{fields}\n")).unwrap();
        let (v, _) = read_volume(&path).unwrap_or_else(|e| panic!("{name}: {e}"));
        assert_eq!(v.labels, want, "{name}");
        assert_eq!(v.dims, [4, 3, 2]);
        assert_eq!(v.to_world([1.0, 1.0, 1.0]), [2.0, 4.0, 6.0], "{name}");
    }
    // No space at all: the spacings alone, as the NIfTI reader without sform/qform.
    let path = nrrd_file(
        dir.path(),
        "spacings.nrrd",
        "type: uchar\ndimension: 3\nsizes: 4 3 2\nspacings: 0.5 nan 2\nencoding: raw",
        &samples,
    );
    let (v, _) = read_volume(&path).unwrap();
    assert_eq!(v.to_world([1.0, 1.0, 1.0]), [0.5, 1.0, 2.0]);
}

/// Every malformed input is an NRRD error naming the file and the problem (and never a panic).
#[test]
fn malformed_inputs_are_named_errors() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let head = |ty: &str, sizes: &str, enc: &str| {
        format!("type: {ty}\ndimension: 3\nsizes: {sizes}\nencoding: {enc}\n{SPACE}")
    };
    let u8_64: Vec<u8> = (0..64).map(|n| (n % 3) as u8).collect();
    let gz = gzip(&u8_64);
    let cases: Vec<(&str, String, Vec<u8>, &str)> = vec![
        (
            "truncated.nrrd",
            head("uint8", "4 4 4", "raw"),
            u8_64[..60].to_vec(),
            "truncated: the data holds 60 of the 64 bytes",
        ),
        (
            "truncated_gz.nrrd",
            head("uint8", "4 4 4", "gzip"),
            gz[..gz.len() - 12].to_vec(),
            "corrupt",
        ),
        (
            "short_gz.nrrd",
            head("uint8", "4 4 8", "gzip"),
            gz.clone(),
            "truncated: the data holds 64 of the 128 bytes",
        ),
        (
            "bzip.nrrd",
            head("uint8", "4 4 4", "bzip2"),
            u8_64.clone(),
            "`encoding: bzip2`: not supported; a label map must be raw or gzip",
        ),
        (
            "ascii.nrrd",
            head("uint8", "4 4 4", "ascii"),
            u8_64.clone(),
            "`encoding: ascii`: not supported",
        ),
        (
            "dim7.nrrd",
            head("uint8", "4 4 4", "raw").replace("dimension: 3", "dimension: 7"),
            u8_64.clone(),
            "`dimension: 7`: a label map has 3 axes",
        ),
        (
            "dimx.nrrd",
            head("uint8", "4 4 4", "raw").replace("dimension: 3", "dimension: three"),
            u8_64.clone(),
            "`dimension: three`: not a whole number",
        ),
        (
            "nosizes.nrrd",
            head("uint8", "4 4 4", "raw").replace("sizes: 4 4 4\n", ""),
            u8_64.clone(),
            "field `sizes` is missing",
        ),
        (
            "twosizes.nrrd",
            head("uint8", "4 16", "raw"),
            u8_64.clone(),
            "`sizes: 4 16`: 2 sizes for dimension 3",
        ),
        (
            "zerosize.nrrd",
            head("uint8", "4 0 4", "raw"),
            u8_64.clone(),
            "each size must be a whole number ≥ 1",
        ),
        (
            "nan.nrrd",
            head("uint8", "4 4 4", "raw").replace("(0,2,0)", "(nan,2,0)"),
            u8_64.clone(),
            "`space directions: (1,0,0) (nan,2,0) (0,0,3)`: component NaN is not finite",
        ),
        (
            "inf_origin.nrrd",
            format!("{}\nspace origin: (0,inf,0)", head("uint8", "4 4 4", "raw")),
            u8_64.clone(),
            "`space origin: (0,inf,0)`: component inf is not finite",
        ),
        (
            "singular.nrrd",
            head("uint8", "4 4 4", "raw").replace("(0,2,0)", "(2,0,0)"),
            u8_64.clone(),
            "singular or not finite",
        ),
        (
            "huge.nrrd",
            head("uint8", "100000 100000 100000", "raw"),
            u8_64.clone(),
            "more samples than this reader's limit",
        ),
        (
            "overflow.nrrd",
            head("uint8", "18446744073709551615 2 2", "raw"),
            u8_64.clone(),
            "more samples than this reader's limit",
        ),
        (
            "bomb.nrrd",
            head("uint8", "1000 1000 100", "gzip"),
            gz.clone(),
            "need 100000000 bytes (after a byte skip of 0), more than",
        ),
        (
            "noendian.nrrd",
            head("short", "4 4 2", "raw"),
            u8_64.clone(),
            "field `endian` is missing",
        ),
        (
            "float.nrrd",
            head("float", "4 4 1", "raw") + "\nendian: little",
            u8_64.clone(),
            "`type: float`: not an integer type",
        ),
        (
            "wide.nrrd",
            head("uint32", "2 2 2", "raw") + "\nendian: big",
            [[0xff, 0xff, 0xff, 0xff]; 8].concat(),
            "label value 4294967295 does not fit in i32",
        ),
        (
            "space.nrrd",
            head("uint8", "4 4 4", "raw").replace("RAS", "scanner-xyz"),
            u8_64.clone(),
            "`space: scanner-xyz`: not supported",
        ),
        (
            "time_no_kinds.nrrd",
            head("uint8", "4 4 2 2", "raw")
                .replace("dimension: 3", "dimension: 4")
                .replace("(0,0,3)", "(0,0,3) none"),
            u8_64.clone(),
            "axis 3 is not spatial and its kind is not given",
        ),
        (
            "uneven.seq.nrrd",
            head("uint8", "2 4 2 4", "raw")
                .replace("dimension: 3", "dimension: 4")
                .replace("(0,0,3)", "(0,0,3) none")
                + "\nkinds: domain domain domain list\naxis 3 index values:=0 1 2 4",
            u8_64.clone(),
            "frame times [0.0, 1.0, 2.0, 4.0] are not increasing and evenly spaced",
        ),
        (
            "short.seq.nrrd",
            head("uint8", "2 4 2 4", "raw")
                .replace("dimension: 3", "dimension: 4")
                .replace("(0,0,3)", "(0,0,3) none")
                + "\nkinds: domain domain domain list\naxis 3 index values:=0 1",
            u8_64.clone(),
            "2 times for the 4 frames of axis 3",
        ),
        (
            "no_kinds_4d.nrrd",
            "type: uint8\ndimension: 4\nsizes: 4 4 2 2\nencoding: raw".into(),
            u8_64.clone(),
            "neither `kinds` nor `space directions`",
        ),
        (
            "layer.seg.nrrd",
            head("uint8", "4 4 4", "raw") + "\nSegment0_LabelValue:=1\nSegment0_Layer:=1",
            u8_64.clone(),
            "`Segment0_Layer:=1`: the file has 1 layer(s)",
        ),
        (
            "color.seg.nrrd",
            head("uint8", "4 4 4", "raw") + "\nSegment0_Color:=1 nan 0",
            u8_64.clone(),
            "`Segment0_Color:=1 nan 0`: not three numbers in 0..1",
        ),
        (
            "twice.nrrd",
            head("uint8", "4 4 4", "raw") + "\nsizes: 4 4 4",
            u8_64.clone(),
            "field `sizes` is given twice",
        ),
        (
            "garbage.nrrd",
            head("uint8", "4 4 4", "raw") + "\nthis is no field",
            u8_64.clone(),
            "is neither `field: description` nor `key:=value`",
        ),
    ];
    for (name, header, data, want) in cases {
        let path = nrrd_file(d, name, &header, &data);
        let e = read_volume(&path).map(|_| ()).expect_err(name);
        assert!(matches!(e.kind, ErrorKind::Nrrd(_)), "{name}: {e}");
        let msg = e.to_string();
        assert!(msg.contains(&path.display().to_string()), "{name}: {msg}");
        assert!(msg.contains(want), "{name}: {msg}");
    }
    // Whole-file problems.
    let path = d.join("magic.nrrd");
    std::fs::write(&path, b"P5\n4 4\n255\n").unwrap();
    let msg = read_volume(&path).unwrap_err().to_string();
    assert!(
        msg.contains("magic.nrrd") && msg.contains("not an NRRD file"),
        "{msg}"
    );
    let path = d.join("future.nrrd");
    std::fs::write(&path, b"NRRD0009\n").unwrap();
    let msg = read_volume(&path).unwrap_err().to_string();
    assert!(msg.contains("NRRD0009 is newer"), "{msg}");
    let path = d.join("nodata.nrrd");
    std::fs::write(
        &path,
        head("uint8", "4 4 4", "raw").replace("type", "NRRD0004\ntype"),
    )
    .unwrap();
    let msg = read_volume(&path).unwrap_err().to_string();
    assert!(msg.contains("no blank line ends the header"), "{msg}");
    let path = d.join("missing.nhdr");
    std::fs::write(
        &path,
        format!(
            "NRRD0004\n{}\ndata file: gone.raw\n",
            head("uint8", "4 4 4", "raw")
        ),
    )
    .unwrap();
    let msg = read_volume(&path).unwrap_err().to_string();
    // Both files: the data file that is absent and the header (and its line) that names it.
    assert!(
        msg.contains("gone.raw")
            && msg.contains("missing.nhdr, line ")
            && msg.contains("No such file"),
        "{msg}"
    );
    let e = read_volume(&d.join("absent.nrrd")).unwrap_err();
    assert!(matches!(e.kind, ErrorKind::Io(_)) && e.to_string().contains("absent.nrrd"));
}

/// Every prefix and many single-byte corruptions of valid raw and gzip files: an error or a
/// volume, never a panic.
#[test]
fn corrupted_files_never_panic() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("ok.seg.nrrd");
    let header = SegmentationHeader {
        dims: [3, 3, 2],
        affine: AFFINE,
        classes: classes(&[("a", 1, None), ("b", 2, None)]),
    };
    write_segmentation(&path, &header, &(0..18).map(|n| n % 3).collect::<Vec<_>>()).unwrap();
    let gz = std::fs::read(&path).unwrap();
    let raw = format!(
        "NRRD0004\ntype: short\nendian: big\ndimension: 4\nsizes: 2 3 2 2\nkinds: domain domain \
         domain time\nspacings: nan nan nan 0.5\nencoding: raw\n\n{}",
        "\u{1}".repeat(48)
    )
    .into_bytes();
    let target = dir.path().join("x.nrrd");
    let mut outcomes = [0usize; 2];
    for original in [&gz, &raw] {
        read_volume(&{
            std::fs::write(&target, original).unwrap();
            target.clone()
        })
        .unwrap();
        for n in 0..original.len() {
            std::fs::write(&target, &original[..n]).unwrap();
            outcomes[usize::from(read_volume(&target).is_ok())] += 1;
            let mut bad = original.clone();
            bad[n] ^= 0x5a;
            std::fs::write(&target, &bad).unwrap();
            outcomes[usize::from(read_volume(&target).is_ok())] += 1;
        }
    }
    assert!(outcomes[0] > 0, "{outcomes:?}");
}

/// Writer misuse: an error naming the file and the problem, and nothing left at the path.
#[test]
fn writer_refuses_bad_input_and_leaves_nothing() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("bad.seg.nrrd");
    let good = SegmentationHeader {
        dims: [2, 2, 2],
        affine: AFFINE,
        classes: classes(&[("a", 1, None), ("b", 4, None)]),
    };
    let cases: Vec<(SegmentationHeader, Vec<i32>, &str)> = vec![
        (
            good.clone(),
            vec![0, 1, 4, 1, 0, 9, 0, 0],
            "voxel (1, 0, 1) has label 9, which no class has",
        ),
        (good.clone(), vec![0; 7], "7 labels for 2×2×2 = 8 voxels"),
        (
            SegmentationHeader {
                classes: classes(&[("a", 0, None)]),
                ..good.clone()
            },
            vec![0; 8],
            "class \"a\" has label 0, the background",
        ),
        (
            SegmentationHeader {
                classes: classes(&[("a", 3, None), ("b", 3, None)]),
                ..good.clone()
            },
            vec![0; 8],
            "label 3 is given to two classes",
        ),
        (
            SegmentationHeader {
                affine: [[0.0; 4]; 3],
                ..good.clone()
            },
            vec![0; 8],
            "singular or not finite",
        ),
        (
            SegmentationHeader {
                dims: [2, 0, 2],
                ..good.clone()
            },
            vec![],
            "are not a volume",
        ),
        (
            SegmentationHeader {
                classes: classes(&[("a\rb", 1, None)]),
                ..good.clone()
            },
            vec![0; 8],
            "control character",
        ),
    ];
    for (header, labels, want) in cases {
        let msg = write_segmentation(&path, &header, &labels)
            .unwrap_err()
            .to_string();
        assert!(msg.contains("bad.seg.nrrd") && msg.contains(want), "{msg}");
        assert_eq!(
            std::fs::read_dir(dir.path()).unwrap().count(),
            0,
            "{want}: nothing written"
        );
    }
    let missing = dir.path().join("no/such/dir/x.seg.nrrd");
    let msg = write_segmentation(&missing, &good, &[0; 8])
        .unwrap_err()
        .to_string();
    assert!(msg.contains("cannot write"), "{msg}");
}

/// A single-layer segmentation whose segments have label values but no `_Layer` (as some
/// writers make them): all are in the one layer, named by `_Name`, else `_ID`.
#[test]
fn segments_without_layer_keys_are_in_the_one_layer() {
    let dir = tempfile::tempdir().unwrap();
    let header = "type: uint8\ndimension: 3\nsizes: 2 2 1\nencoding: raw\nspace: LPS\n\
                  space directions: (1,0,0) (0,1,0) (0,0,1)\nSegment0_Name:=a\n\
                  Segment0_LabelValue:=4\nSegment1_ID:=b_id\nSegment1_LabelValue:=9";
    let path = nrrd_file(dir.path(), "nolayer.seg.nrrd", header, &[0, 4, 9, 4]);
    let (v, table) = read_volume(&path).unwrap();
    assert_eq!(v.labels, [0, 4, 9, 4]);
    assert_eq!((table.name(4), table.name(9)), ("a".into(), "b_id".into()));
    assert_eq!(table.color(4), None);
    assert_eq!(v.to_world([1.0, 1.0, 0.0]), [-1.0, -1.0, 0.0], "LPS → RAS");
}
