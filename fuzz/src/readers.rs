//! The reader targets' checks: each function takes the fuzzer's bytes, hands them to one reader
//! and returns; a panic anywhere in the reader (or a failed check of what an accepted input must
//! satisfy) is the finding. Readers that take a path read a per-process scratch file
//! ([`scratch_file`]) rewritten on every input.
//!
//! What is checked of an accepted input, besides "no panic, no stray memory access":
//! - every [`Sequence`] a reader returns survives native JSON unchanged: written by
//!   `native::to_json` and read back by `native::from_json` it is equal, so it was valid (the
//!   JSON reader validates through `Sequence::new` again) and nothing it holds is lost;
//! - a label volume's voxel count is its dims × frames, its affine finite and invertible, its
//!   frame interval finite and positive (what `LabelVolume` promises its users);
//! - a manifest's entries: at least one, times finite and never decreasing, lines increasing;
//! - a label table and a native JSON document re-serialise to what parses equal;
//! - a checkpoint's fields are exactly the bytes of the documented format.

use std::path::{Path, PathBuf};
use std::sync::OnceLock;

use dynaslice_data::input::{self, InputOptions};
use dynaslice_data::label_volume::{det3, LabelVolume};
use dynaslice_data::rtstruct::{self, RoiExtent};
use dynaslice_data::{csl, manifest, nrrd, LabelTable, Sequence};
use dynaslice_sequence::native;
use dynaslice_optim::adam::{Adam, AdamConfig};
use dynaslice_optim::checkpoint::Checkpoint;
use dynaslice_optim::schedule_plan::SchedulePlan;

use crate::fixtures;

/// This process's scratch folder, `dynaslice-fuzz-<pid>` in the temporary folder (`TMPDIR`),
/// made on first use with the files inputs may refer to: the detached NRRD data file and the
/// manifest sandbox's fixtures ([`fixtures::sandbox_files`]). Per process, so parallel jobs
/// never share a file.
pub fn scratch_dir() -> &'static Path {
    static DIR: OnceLock<PathBuf> = OnceLock::new();
    DIR.get_or_init(|| {
        let dir = std::env::temp_dir().join(format!("dynaslice-fuzz-{}", std::process::id()));
        let work = dir.join("work");
        std::fs::create_dir_all(&work).expect("cannot create the fuzz scratch folder");
        std::fs::write(
            dir.join(fixtures::NRRD_DATA_FILE),
            fixtures::nrrd_data_file(),
        )
        .expect("cannot write the detached NRRD data file");
        for (name, bytes) in fixtures::sandbox_files(&work).expect("sandbox fixtures") {
            std::fs::write(dir.join(name), bytes).expect("cannot write a sandbox file");
        }
        dir
    })
}

/// Writes `bytes` to `name` in [`scratch_dir`] (replacing the previous input) and returns its
/// path.
pub fn scratch_file(name: &str, bytes: &[u8]) -> PathBuf {
    let path = scratch_dir().join(name);
    std::fs::write(&path, bytes).expect("cannot write the fuzz input to the scratch folder");
    path
}

/// The bytes as text, or `None`: the text readers take `&str`, and their file-reading
/// wrappers refuse invalid UTF-8 before parsing.
fn text(data: &[u8]) -> Option<&str> {
    std::str::from_utf8(data).ok()
}

/// Checks that `seq` survives native JSON unchanged (see the module docs).
pub fn check_sequence(seq: &Sequence) {
    let json = native::to_json(seq);
    match native::from_json(&json) {
        Ok(back) => assert!(
            back == *seq,
            "an accepted sequence changed through native JSON"
        ),
        Err(e) => panic!("an accepted sequence's native JSON is refused: {e}"),
    }
}

/// Checks what a `LabelVolume` promises (see the module docs).
pub fn check_volume(v: &LabelVolume) {
    let count = v
        .dims
        .iter()
        .chain([&v.frames])
        .try_fold(1usize, |n, &d| n.checked_mul(d));
    assert_eq!(
        count,
        Some(v.labels.len()),
        "dims {:?} × {} frames disagree with {} labels",
        v.dims,
        v.frames,
        v.labels.len()
    );
    assert!(
        !v.dims.contains(&0) && v.frames > 0,
        "an empty volume: {:?} × {}",
        v.dims,
        v.frames
    );
    assert!(
        v.affine.iter().flatten().all(|x| x.is_finite()) && det3(&v.affine) != 0.0,
        "a singular or non-finite affine: {:?}",
        v.affine
    );
    assert!(
        v.frame_interval.is_finite() && v.frame_interval > 0.0,
        "frame interval {}",
        v.frame_interval
    );
}

/// The whole entry point on one file, as the command line reads it.
fn whole_entry(path: &Path) {
    if let Ok(seq) = input::read(&[path.to_path_buf()], &InputOptions::default()) {
        check_sequence(&seq);
    }
}

/// `nifti::read_volume`, then (when it accepts) `input::read`, which reslices the volume into
/// planes.
pub fn nifti(data: &[u8]) {
    let path = scratch_file("input.nii", data);
    if let Ok(volume) = dynaslice_data::nifti::read_volume(&path) {
        check_volume(&volume);
        whole_entry(&path);
    }
}

/// `nrrd::read_volume`, then (when it accepts) `input::read`. A detached header may name
/// [`fixtures::NRRD_DATA_FILE`] beside it.
pub fn nrrd(data: &[u8]) {
    let path = scratch_file("input.nrrd", data);
    if let Ok((volume, _table)) = nrrd::read_volume(&path) {
        check_volume(&volume);
        whole_entry(&path);
    }
}

/// `rtstruct::read` with [`RoiExtent::File`] and, when that accepts, with [`RoiExtent::Own`]
/// (the same file, a different absence rule). `input::read` adds nothing for this kind.
pub fn rtstruct(data: &[u8]) {
    let path = scratch_file("input.dcm", data);
    if let Ok(seq) = rtstruct::read(&path, RoiExtent::File) {
        check_sequence(&seq);
        match rtstruct::read(&path, RoiExtent::Own) {
            Ok(own) => {
                check_sequence(&own);
                assert_eq!(
                    own.classes(),
                    seq.classes(),
                    "absence rules changed the classes"
                );
            }
            Err(e) => panic!("accepted with RoiExtent::File, refused with Own: {e}"),
        }
    }
}

/// `csl::parse` with an empty label table (the in-memory form of `csl::read`, which
/// `input::read` uses for this kind).
pub fn csl(data: &[u8]) {
    let Some(text) = text(data) else { return };
    if let Ok(seq) = csl::parse(text, Path::new("input.csl"), &LabelTable::default()) {
        check_sequence(&seq);
    }
}

/// `native::from_json`; an accepted document's sequence re-serialises to JSON that parses to
/// an equal sequence and serialises to the same text.
pub fn native_json(data: &[u8]) {
    let Some(text) = text(data) else { return };
    if let Ok(seq) = native::from_json(text) {
        let json = native::to_json(&seq);
        let back = native::from_json(&json)
            .unwrap_or_else(|e| panic!("an accepted sequence's native JSON is refused: {e}"));
        assert!(
            back == seq,
            "an accepted sequence changed through native JSON"
        );
        assert_eq!(native::to_json(&back), json, "native JSON is not canonical");
    }
}

/// `LabelTable::parse`; an accepted table written by `to_text` parses to an equal table. The
/// other label-table readers (XML, Slicer `.ctbl`, ITK-SNAP) on the same text must not panic.
pub fn label_table(data: &[u8]) {
    let Some(text) = text(data) else { return };
    let _ = LabelTable::from_xml(text);
    let _ = LabelTable::parse_slicer_ctbl(text);
    let _ = LabelTable::parse_itksnap(text);
    if let Ok(table) = LabelTable::parse(text) {
        match LabelTable::parse(&table.to_text()) {
            Ok(back) => assert!(back == table, "a label table changed through to_text"),
            Err(e) => panic!("an accepted table's to_text is refused: {e}"),
        }
    }
}

/// `manifest::parse` relative to the sandbox ([`scratch_dir`]). When every entry names one of
/// the sandbox's files ([`fixtures::sandbox_files`]), the manifest is also written there and
/// read whole by `input::read`, which reads, times and combines those files. Other manifests
/// are not read: their entries could name any file of the machine (`/dev/stdin` would block).
pub fn manifest(data: &[u8]) {
    let Some(text) = text(data) else { return };
    let dir = scratch_dir();
    let Ok(entries) = manifest::parse(text, dir) else {
        return;
    };
    assert!(!entries.is_empty() && entries.len() <= manifest::MAX_ENTRIES);
    for pair in entries.windows(2) {
        assert!(pair[0].line < pair[1].line, "entry lines out of order");
        assert!(pair[0].time <= pair[1].time, "entry times decrease");
    }
    assert!(entries.iter().all(|e| e.time.is_finite()));
    let sandboxed = entries.iter().all(|e| {
        e.path.parent() == Some(dir)
            && e.path
                .file_name()
                .and_then(|n| n.to_str())
                .is_some_and(|n| fixtures::SANDBOX_NAMES.contains(&n))
    });
    if sandboxed {
        whole_entry(&scratch_file("input.seq", data));
    }
}

/// `Checkpoint::load`. The first byte says how to load the rest, the file:
/// - bit 0: recompute the CRC trailer first (as `from_bytes_crc` does), so mutations reach the
///   checks behind it;
/// - bit 1: expect another run's fingerprint (the file's, one bit flipped), else the file's own;
/// - bit 2: expect the parameter count the file's header states (at most what its length can
///   hold), else the count its length implies.
///
/// An accepted checkpoint must hold exactly the file's fields (see [`checkpoint_fields_match`]).
pub fn checkpoint(data: &[u8]) {
    let Some((&mode, file)) = data.split_first() else {
        return;
    };
    let mut bytes = file.to_vec();
    if mode & 1 != 0 {
        crate::fix_crc(&mut bytes);
    }
    let word = |i: usize| {
        bytes
            .get(8 + 8 * i..16 + 8 * i)
            .map_or(0, |w| u64::from_le_bytes(w.try_into().expect("8 bytes")))
    };
    let header = if bytes.starts_with(b"DSCKPT01") {
        40
    } else if bytes.starts_with(b"DSCKPT02") {
        48
    } else {
        64
    };
    let by_length = bytes.len().saturating_sub(header + 4) / 12;
    let n = if mode & 4 != 0 {
        // Bounded by the length: the caller's count comes from its network, never huge.
        usize::try_from(word(3)).map_or(by_length, |n| n.min(bytes.len()))
    } else {
        by_length
    };
    let fingerprint = word(0) ^ u64::from(mode & 2 != 0);
    let path = scratch_file("input.ckpt", &bytes);
    let adam = Adam::new(n, AdamConfig::default());
    if let Ok(c) = Checkpoint::load(&path, fingerprint, n, &adam) {
        checkpoint_fields_match(&c, &bytes, n);
    }
}

/// Checks that `c` holds exactly the fields of `bytes` (the documented layout: magic, u64
/// fingerprint, step, Adam t, n, the plan (`DSCKPT03`: length, anchor step, anchor phase;
/// `DSCKPT02`: length; `DSCKPT01`: none), then n f32 each of parameters, m and v, CRC-32), with
/// `n` parameters and the defaults' hyper-parameters.
pub fn checkpoint_fields_match(c: &Checkpoint, bytes: &[u8], n: usize) {
    let magic: &[u8; 8] = if bytes.starts_with(b"DSCKPT01") {
        b"DSCKPT01"
    } else if bytes.starts_with(b"DSCKPT02") {
        b"DSCKPT02"
    } else {
        b"DSCKPT03"
    };
    let mut expect = magic.to_vec();
    let mut words = vec![c.fingerprint, c.step, c.adam.t, n as u64];
    match magic {
        b"DSCKPT03" => words.extend(c.plan.map_or([0, 0, 0], |p| {
            [p.length, p.anchor_step, p.anchor_phase.to_bits()]
        })),
        b"DSCKPT02" => {
            words.push(c.plan.map_or(0, |p| p.length));
            assert!(
                c.plan.is_none_or(|p| p == SchedulePlan::plain(p.length)),
                "a second-format checkpoint's plan is not a plain one"
            );
        }
        _ => assert_eq!(c.plan, None, "a first-format checkpoint has a plan"),
    }
    assert!(
        c.plan
            .is_none_or(|p| p.length > 0 && (0.0..=1.0).contains(&p.anchor_phase)),
        "a plan of length 0 or a phase outside [0, 1]"
    );
    for w in words {
        expect.extend_from_slice(&w.to_le_bytes());
    }
    assert!(c.params.len() == n && c.adam.m.len() == n && c.adam.v.len() == n);
    for v in c.params.iter().chain(&c.adam.m).chain(&c.adam.v) {
        expect.extend_from_slice(&v.to_le_bytes());
    }
    expect.extend_from_slice(&dynaslice_core::crc32(&expect).to_le_bytes());
    assert!(
        expect == bytes,
        "an accepted checkpoint is not the file's fields"
    );
    assert_eq!(
        c.adam.config,
        AdamConfig::default(),
        "hyper-parameters not the caller's"
    );
}

/// Whether `target`'s reader accepts the seed `name` (`bytes`), with the target's checks of an
/// accepted input; the error says why not.
pub fn accepts(target: &str, name: &str, bytes: &[u8]) -> Result<(), fixtures::Error> {
    let utf8 = || std::str::from_utf8(bytes);
    // Named as in the seeds, beside the sandbox's files (a detached NRRD header's data file).
    let file = || scratch_file(&format!("seed-{name}"), bytes);
    match target {
        "from_bytes" | "from_bytes_crc" => {
            let aligned = dynaslice_core::ModelBytes::copy_from(bytes);
            aligned.model().map_err(|e| format!("{e:?}"))?;
            crate::check(bytes);
        }
        "nifti" => {
            let path = file();
            check_volume(&dynaslice_data::nifti::read_volume(&path)?);
            check_sequence(&input::read(&[path], &InputOptions::default())?);
        }
        "nrrd" => {
            let path = file();
            check_volume(&nrrd::read_volume(&path)?.0);
            check_sequence(&input::read(&[path], &InputOptions::default())?);
        }
        "rtstruct" => {
            let path = file();
            check_sequence(&rtstruct::read(&path, RoiExtent::File)?);
            check_sequence(&rtstruct::read(&path, RoiExtent::Own)?);
        }
        "csl" => check_sequence(&csl::parse(
            utf8()?,
            Path::new(name),
            &LabelTable::default(),
        )?),
        "native_json" => {
            native::from_json(utf8()?)?;
            native_json(bytes);
        }
        "label_table" => {
            // Each seed is a table of one of the formats, by its name.
            let text = utf8()?;
            if name.ends_with(".ctbl") {
                LabelTable::parse_slicer_ctbl(text)?;
            } else if name.ends_with(".label.txt") {
                LabelTable::parse_itksnap(text)?;
            } else if name.ends_with(".xml") {
                LabelTable::from_xml(text).ok_or("no XML label table")??;
            } else {
                LabelTable::parse(text)?;
            }
            label_table(bytes);
        }
        "manifest" => {
            manifest::parse(utf8()?, scratch_dir())?;
            check_sequence(&input::read(&[file()], &InputOptions::default())?);
        }
        "checkpoint" => {
            let (&mode, rest) = bytes.split_first().ok_or("empty")?;
            if mode != fixtures::CHECKPOINT_OWN_RUN {
                return Err(
                    format!("mode {mode}, expected {}", fixtures::CHECKPOINT_OWN_RUN).into(),
                );
            }
            let header = if rest.starts_with(b"DSCKPT01") {
                40
            } else if rest.starts_with(b"DSCKPT02") {
                48
            } else {
                64
            };
            let n = rest.len().checked_sub(header + 4).ok_or("too short")? / 12;
            let fingerprint = u64::from_le_bytes(rest.get(8..16).ok_or("too short")?.try_into()?);
            let adam = Adam::new(n, AdamConfig::default());
            let path = scratch_file(&format!("seed-{name}"), rest);
            let c = Checkpoint::load(&path, fingerprint, n, &adam).map_err(|e| format!("{e:#}"))?;
            checkpoint_fields_match(&c, rest, n);
        }
        _ => return Err(format!("no fuzz target {target}").into()),
    }
    Ok(())
}

/// Writes the seeds of `target` into `dir` as `seed-NAME`, after checking that the target's
/// reader accepts each ([`accepts`]): a refused seed would only test the first
/// error path. Returns how many were written.
pub fn write_seeds(target: &str, dir: &Path) -> Result<usize, fixtures::Error> {
    let work = scratch_dir().join("work").join(target);
    std::fs::create_dir_all(&work)?;
    let files = fixtures::seeds(target, &work)?;
    std::fs::create_dir_all(dir)?;
    for (name, bytes) in &files {
        accepts(target, name, bytes)
            .map_err(|e| format!("the {target} seed {name} is refused: {e}"))?;
        std::fs::write(dir.join(format!("seed-{name}")), bytes)?;
    }
    Ok(files.len())
}
