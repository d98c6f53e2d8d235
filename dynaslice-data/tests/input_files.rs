//! What every reader does with files that are not plain input: FIFOs, devices and folders are
//! refused before they are opened (a FIFO would block the open), endless input cannot eat
//! memory, headers that promise more than the file holds are refused at once, and messages quote
//! a bounded excerpt of the file.

#![cfg(unix)]

use std::path::{Path, PathBuf};
use std::sync::mpsc;
use std::time::Duration;

use dynaslice_data::input::{read, InputOptions};
use dynaslice_data::label_volume::LabelVolume;
use dynaslice_data::nifti::{read_geometry, read_volume, write_volume};
use dynaslice_data::{DataError, LabelTable};

/// Runs `f` on another thread: a reader that blocks fails the test instead of hanging it.
fn within_10_s<T: Send + 'static>(what: &str, f: impl FnOnce() -> T + Send + 'static) -> T {
    let (send, receive) = mpsc::channel();
    std::thread::spawn(move || send.send(f()));
    receive
        .recv_timeout(Duration::from_secs(10))
        .unwrap_or_else(|_| panic!("{what}: still reading after 10 s"))
}

fn mkfifo(path: &Path) -> bool {
    let made = std::process::Command::new("mkfifo").arg(path).status();
    if !made.is_ok_and(|s| s.success()) {
        eprintln!("skipped: mkfifo is not available");
        return false;
    }
    true
}

fn read_one(path: &Path) -> Result<dynaslice_data::Sequence, DataError> {
    let path = path.to_path_buf();
    within_10_s(&path.display().to_string(), move || {
        read(&[path], &InputOptions::default())
    })
}

fn small_volume() -> LabelVolume {
    let (nx, ny, nz) = (24, 24, 12);
    LabelVolume {
        dims: [nx, ny, nz],
        frames: 1,
        affine: [
            [1.0, 0.0, 0.0, 0.0],
            [0.0, 1.0, 0.0, 0.0],
            [0.0, 0.0, 3.0, 0.0],
        ],
        frame_interval: 1.0,
        labels: (0..nx * ny * nz).map(|i| i32::from(i % 7 == 0)).collect(),
    }
}

#[test]
fn fifos_are_refused_by_every_reader_naming_the_file() {
    let dir = tempfile::tempdir().unwrap();
    for name in [
        "a.csl",
        "a.nii",
        "a.nii.gz",
        "a.nrrd",
        "a.nhdr",
        "a.seg.nrrd",
        "a.dcm",
        "a.json",
        "a.seq",
        "RS_no_extension",
    ] {
        let fifo = dir.path().join(name);
        if !mkfifo(&fifo) {
            return;
        }
        let e = read_one(&fifo).unwrap_err().to_string();
        assert!(e.contains(name) && e.contains("a FIFO"), "{name}: {e}");
    }
    // A FIFO listed in a manifest, and one named as an NRRD's detached data file.
    let listed = dir.path().join("listed.csl");
    mkfifo(&listed);
    let manifest = dir.path().join("m.seq");
    std::fs::write(&manifest, "0 listed.csl\n").unwrap();
    let e = read_one(&manifest).unwrap_err().to_string();
    assert!(e.contains("listed.csl") && e.contains("a FIFO"), "{e}");
    let data = dir.path().join("data.raw");
    mkfifo(&data);
    let nhdr = dir.path().join("d.nhdr");
    std::fs::write(
        &nhdr,
        "NRRD0004\ntype: uint8\ndimension: 3\nsizes: 2 2 2\nencoding: raw\n\
         space directions: (1,0,0) (0,1,0) (0,0,1)\nspace origin: (0,0,0)\n\
         space: left-posterior-superior\ndata file: data.raw\n\n",
    )
    .unwrap();
    let e = read_one(&nhdr).unwrap_err().to_string();
    assert!(e.contains("data.raw") && e.contains("a FIFO"), "{e}");
    // The label-name table and a reference header (`labels --like`).
    let table = dir.path().join("names.txt");
    mkfifo(&table);
    let e = within_10_s("label table", move || LabelTable::read(&table))
        .unwrap_err()
        .to_string();
    assert!(e.contains("names.txt") && e.contains("a FIFO"), "{e}");
    let reference = dir.path().join("ref.nii.gz");
    mkfifo(&reference);
    let e = within_10_s("reference", move || read_geometry(&reference))
        .unwrap_err()
        .to_string();
    assert!(e.contains("ref.nii.gz") && e.contains("a FIFO"), "{e}");
}

#[test]
fn devices_and_folders_are_refused_before_reading() {
    let dir = tempfile::tempdir().unwrap();
    // Endless input behind an input's name: refused, not read until memory runs out.
    for name in [
        "z.csl", "z.json", "z.nii", "z.nii.gz", "z.nrrd", "z.dcm", "z.seq",
    ] {
        let link = dir.path().join(name);
        std::os::unix::fs::symlink("/dev/zero", &link).unwrap();
        let e = read_one(&link).unwrap_err().to_string();
        assert!(e.contains(name) && e.contains("a device"), "{name}: {e}");
    }
    let folder = dir.path().join("f.csl");
    std::fs::create_dir(&folder).unwrap();
    let e = read_one(&folder).unwrap_err().to_string();
    assert!(e.contains("f.csl") && e.contains("a folder"), "{e}");
}

#[test]
fn headers_promising_more_than_the_file_holds_are_refused_at_once() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("ref.nii");
    write_volume(&small_volume(), &path).unwrap();
    let mut bytes = std::fs::read(&path).unwrap();
    // dim[0] = 4 and dim[4] = 32767 frames (dim starts at byte 40, i16 little endian).
    bytes[40..42].copy_from_slice(&4i16.to_le_bytes());
    bytes[48..50].copy_from_slice(&32767i16.to_le_bytes());
    std::fs::write(&path, &bytes).unwrap();
    for e in [
        read_geometry(&path).unwrap_err(),
        read_volume(&path).unwrap_err(),
    ] {
        let e = e.to_string();
        assert!(
            e.contains("ref.nii") && e.contains("24×24×12×32767") && e.contains("can hold"),
            "{e}"
        );
    }
    // The honest header still reads.
    bytes[40..42].copy_from_slice(&3i16.to_le_bytes());
    bytes[48..50].copy_from_slice(&1i16.to_le_bytes());
    std::fs::write(&path, &bytes).unwrap();
    assert_eq!(read_geometry(&path).unwrap().frames, 1);
}

/// Writes `text` at `dir/name` and returns the error reading it as an input.
fn error_of(dir: &Path, name: &str, text: &str) -> String {
    let path: PathBuf = dir.join(name);
    std::fs::write(&path, text).unwrap();
    read_one(&path).unwrap_err().to_string()
}

#[test]
fn messages_quote_a_bounded_excerpt_of_long_lines() {
    let dir = tempfile::tempdir().unwrap();
    let line = "x".repeat(8 << 20);
    let bound = 1000;
    for (name, text) in [
        ("long.csl", format!("{line}\n")),
        ("long2.csl", format!("CSLC\n1 {line}\n")),
        ("long.seq", format!("{line}\n")),
        ("long2.seq", format!("{line} a.csl\n")),
        ("long.nrrd", format!("NRRD0004\n{line}\n\n")),
    ] {
        let e = error_of(dir.path(), name, &text);
        assert!(e.len() < bound, "{name}: a {}-byte message", e.len());
        assert!(e.contains("bytes)"), "{name}: {e}");
    }
    let table = dir.path().join("names.txt");
    std::fs::write(&table, format!("{line}\n")).unwrap();
    let e = LabelTable::read(&table).unwrap_err().to_string();
    assert!(e.len() < bound, "label table: a {}-byte message", e.len());
}
