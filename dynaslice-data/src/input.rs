//! Reading the cross-sections of one or several inputs of any supported kind into one
//! [`Sequence`]: the one entry point the command line and the bindings use.
//!
//! | kind | chosen by | one input gives |
//! |------|-----------|-----------------|
//! | native JSON | `.json` | the sequence it holds |
//! | `.csl` | `.csl` | one timestep at time 0 |
//! | manifest | `.seq`, `.cslseq` | one timestep per line ([`crate::manifest`]) |
//! | NIfTI label map | `.nii`, `.nii.gz` | planes per [`PlaneMode`] at every selected frame |
//! | NRRD label map, 3D Slicer segmentation | `.nrrd`, `.nhdr`, `.seg.nrrd` | as NIfTI, with the segments' names and colours |
//! | DICOM RT Structure Set | `.dcm`, or any file with DICOM's `DICM` marker (at byte 128 or 0) | one timestep at time 0 |
//!
//! Several inputs are views of one subject ([`read`]): their time grids must agree, and every
//! plane of an image annotates every class of them all (see [`crate::combine`]).

use std::path::{Path, PathBuf};

use super::combine::{combine, same_time, Absence, Part};
use super::drawn_slices::{self, PlaneMode, SparseAxes};
use super::frame_range::FrameRange;
use super::label_census::check_classes;
use super::label_table::LabelTable;
use super::label_volume::LabelVolume;
use super::reslice::{reslice, ResliceOptions};
use super::rtstruct::{self, RoiExtent};
use super::{csl, manifest, nifti, nrrd};
use crate::input_kind::InputKind;
use crate::nifti::HeaderSpacing;
use dynaslice_sequence::error::{DataError, ErrorKind, Result};
use dynaslice_sequence::native;
use dynaslice_sequence::sequence::Sequence;
use dynaslice_sequence::space::{Space, TimeUnit, Units};

/// How the inputs are read. [`Default`] is what the command line does without options.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct InputOptions {
    /// Frames to keep (by index, of every input alike).
    pub frames: FrameRange,
    /// Names (and colours) for label values, over those the inputs carry.
    pub table: LabelTable,
    /// Label maps: how they become planes (see [`drawn_slices`]).
    pub planes: PlaneMode,
    /// Label maps read as sparsely drawn: the voxel axes drawn on.
    pub sparse_axes: SparseAxes,
    /// RT Structure Sets: where an ROI without a contour on a plane counts as absent.
    pub roi_extent: RoiExtent,
    /// NIfTI label maps: where the voxel spacing comes from ([`HeaderSpacing`]).
    pub header_spacing: HeaderSpacing,
    /// Label maps: the reslicing protocol and the label values to use (its `frames` is ignored:
    /// [`InputOptions::frames`] applies).
    pub reslice: ResliceOptions,
}

impl InputKind {
    /// The frame and units this kind's coordinates come in (`None` for a manifest: its
    /// entries').
    pub fn space(self) -> Option<(Space, Units)> {
        match self {
            InputKind::Nifti => Some((Space::Ras, Units::Millimetres)),
            // Slicer and ITK write NRRD in LPS; RT Structure Sets are in DICOM's LPS.
            InputKind::Nrrd | InputKind::RtStruct => Some((Space::Lps, Units::Millimetres)),
            InputKind::Native | InputKind::Csl => Some((Space::Ras, Units::Plain)),
            InputKind::Manifest => None,
        }
    }
}

/// The frame and units of inputs read together: the first input's (a manifest's first
/// entry's), which the model records and its outputs default to.
pub fn space_of(inputs: &[Opened]) -> Result<(Space, Units)> {
    let Some(first) = inputs.first() else {
        return Err(ErrorKind::Empty("no input".into()).into());
    };
    match first.kind.space() {
        Some(space) => Ok(space),
        None => {
            let entry = first.entries.first().ok_or_else(|| {
                DataError::new(ErrorKind::Empty("an empty manifest".into())).in_file(&first.path)
            })?;
            Ok(InputKind::of(&entry.path)?
                .space()
                .unwrap_or((Space::Ras, Units::Plain)))
        }
    }
}

/// The unit of the times of inputs read together: the first input's (every input has the
/// same times): a NIfTI's `xyzt_units`, a manifest's own ([`TimeUnit::Manifest`]), none for
/// the other formats.
pub fn time_unit_of(paths: &[PathBuf]) -> Result<TimeUnit> {
    let Some(first) = paths.first() else {
        return Err(ErrorKind::Empty("no input".into()).into());
    };
    Ok(match InputKind::of(first)? {
        InputKind::Nifti => nifti::read_time_unit(first)?,
        InputKind::Manifest => TimeUnit::Manifest,
        InputKind::Nrrd | InputKind::RtStruct | InputKind::Native | InputKind::Csl => {
            TimeUnit::Plain
        }
    })
}

/// Reads `paths` into one sequence, keeping the selected frames.
///
/// With several inputs, each is read alone, their frame times must agree (frame i of every
/// input at one time), and every plane of an image annotates every class of the union (absent
/// where the image does not show it); RT Structure Sets keep their own annotations.
pub fn read(paths: &[PathBuf], options: &InputOptions) -> Result<Sequence> {
    read_opened(&open(paths)?, options)
}

/// An input by kind, a manifest with its entries: parsed once however many of reading
/// ([`read_opened`]), [`space_of`] and the options' check (`InputSpec::read`) look into it.
#[derive(Clone, Debug)]
pub struct Opened {
    /// The input's path.
    pub path: PathBuf,
    /// Its kind.
    pub kind: InputKind,
    /// A manifest's entries (none for the other kinds).
    pub entries: Vec<manifest::Entry>,
}

/// `paths` by kind, each manifest's entries parsed.
pub fn open(paths: &[PathBuf]) -> Result<Vec<Opened>> {
    paths
        .iter()
        .map(|path| {
            let kind = InputKind::of(path)?;
            let entries = match kind {
                InputKind::Manifest => manifest::read(path)?,
                _ => Vec::new(),
            };
            Ok(Opened {
                path: path.clone(),
                kind,
                entries,
            })
        })
        .collect()
}

/// [`read`] of inputs already opened.
pub fn read_opened(inputs: &[Opened], options: &InputOptions) -> Result<Sequence> {
    let parts = inputs
        .iter()
        .map(|input| read_part(input, options))
        .collect::<Result<Vec<Part>>>()?;
    if parts.is_empty() {
        return Err(ErrorKind::Empty("no input".into()).into());
    }
    check_time_grids(&parts)?;
    if parts.len() == 1 {
        return Ok(parts.into_iter().next().expect("one part").sequence);
    }
    Ok(combine(parts)?.0)
}

/// Reads one input, frames selected, as a part to combine.
fn read_part(input: &Opened, options: &InputOptions) -> Result<Part> {
    let (path, kind) = (input.path.as_path(), input.kind);
    let at = |e: DataError| e.in_file(path);
    // Per class: whether this reader made up its name (see `Part::generated`).
    let made_up = |sequence: &Sequence, table: &LabelTable| -> Vec<Option<InputKind>> {
        sequence
            .classes()
            .iter()
            .map(|c| (!table.has_name(c.label)).then_some(kind))
            .collect()
    };
    let mut frame_of_reference = None;
    let (sequence, absence, generated) = match kind {
        InputKind::Nifti | InputKind::Nrrd => {
            let map = match kind {
                InputKind::Nifti => nifti::read_labelled_volume_with(path, options.header_spacing)?,
                _ => nrrd::read_label_map(path)?,
            };
            // Counted in one pass before any contour is traced: an image given for its
            // segmentation is refused in a second, not after minutes of tracing.
            check_classes(
                &map.volume,
                options.frames,
                options.reslice.labels.as_deref(),
                &map.stored,
            )
            .map_err(at)?;
            // The file's own table, then the colour tables beside it, then the user's.
            let table = map
                .table
                .overlaid(&LabelTable::beside(path)?)
                .overlaid(&options.table);
            let sequence = planes_of(&map.volume, &table, options).map_err(at)?;
            // Frame f is at toffset + f × pixdim[4] (NIfTI; NRRD has no time origin), as
            // `--like` places a reference's frames.
            let sequence = match kind {
                InputKind::Nifti => {
                    shift_times(sequence, nifti::read_time_origin(path)?).map_err(at)?
                }
                _ => sequence,
            };
            let generated = made_up(&sequence, &table);
            return Ok(Part {
                path: path.to_path_buf(),
                sequence,
                absence: Absence::Union,
                generated,
                frame_of_reference: None,
            });
        }
        InputKind::RtStruct => {
            let (sequence, frame) = rtstruct::read_with_frame(path, options.roi_extent)?;
            frame_of_reference = frame;
            let named = vec![None; sequence.classes().len()];
            (sequence, Absence::AsRead, named)
        }
        InputKind::Native => {
            let sequence = native::read(path)?;
            let named = vec![None; sequence.classes().len()];
            (sequence, Absence::AsRead, named)
        }
        InputKind::Csl => {
            let sequence = csl::read(path, &options.table)?;
            let generated = made_up(&sequence, &options.table);
            (sequence, Absence::Union, generated)
        }
        InputKind::Manifest => {
            let (sequence, generated, frame) = read_manifest(input, options)?;
            frame_of_reference = frame;
            (sequence, Absence::AsRead, generated)
        }
    };
    Ok(Part {
        path: path.to_path_buf(),
        sequence: select_frames(sequence, options.frames).map_err(at)?,
        absence,
        generated,
        frame_of_reference,
    })
}

/// `seq` with every frame's time moved by `origin`.
fn shift_times(seq: Sequence, origin: f64) -> Result<Sequence> {
    if origin == 0.0 {
        return Ok(seq);
    }
    let (classes, mut frames) = seq.into_parts();
    for f in &mut frames {
        f.time += origin;
    }
    Sequence::new(classes, frames)
}

/// The planes of a label map, per [`InputOptions::planes`] (`table`: the file's own names and
/// colours under the user's).
fn planes_of(volume: &LabelVolume, table: &LabelTable, options: &InputOptions) -> Result<Sequence> {
    let labels = options.reslice.labels.as_deref();
    match drawn_slices::resolve(options.planes, volume) {
        PlaneMode::Slices => drawn_slices::slices(volume, options.frames, labels, table),
        PlaneMode::Sparse => drawn_slices::sparse_with_axes(
            volume,
            options.frames,
            labels,
            table,
            options.sparse_axes,
        ),
        PlaneMode::Reslice | PlaneMode::Auto => {
            let reslice_options = ResliceOptions {
                frames: options.frames,
                ..options.reslice.clone()
            };
            reslice(volume, &reslice_options, table)
        }
    }
}

/// What a manifest holds: the sequence, what [`Part::generated`] says of each class, and the
/// Frame of Reference of its entries.
type Manifest = (Sequence, Vec<Option<InputKind>>, Option<String>);

/// Reads a manifest: every entry a single timestep, placed at its time.
fn read_manifest(manifest: &Opened, options: &InputOptions) -> Result<Manifest> {
    let path = manifest.path.as_path();
    let entry_options = InputOptions {
        frames: FrameRange::ALL,
        ..options.clone()
    };
    let mut parts = Vec::new();
    for entry in &manifest.entries {
        let kind = match InputKind::of(&entry.path) {
            Ok(InputKind::Manifest) => {
                return Err(manifest_error(
                    path,
                    entry.line,
                    "a manifest cannot list a manifest",
                ))
            }
            Ok(kind) => kind,
            Err(e) => {
                return Err(manifest_error(
                    path,
                    entry.line,
                    &format!("{}: {}", entry.path.display(), e.kind),
                ))
            }
        };
        // An entry that cannot be opened (absent, a folder, a device) is the manifest line's
        // mistake: the message names the manifest, its line and the entry.
        if let Err(e) = dynaslice_sequence::input_file::regular_file(&entry.path) {
            return Err(DataError::new(ErrorKind::Syntax(format!(
                "{}: {}",
                entry.path.display(),
                e.kind
            )))
            .in_file(path)
            .at_line(entry.line));
        }
        let single = Opened {
            path: entry.path.clone(),
            kind,
            entries: Vec::new(),
        };
        let mut part = read_part(&single, &entry_options)?;
        let count = part.sequence.frames().len();
        if count != 1 {
            return Err(manifest_error(
                path,
                entry.line,
                &format!(
                    "{} holds {count} timesteps; a manifest lists single-timestep inputs",
                    entry.path.display()
                ),
            ));
        }
        let (classes, mut frames) = part.sequence.into_parts();
        frames[0].time = entry.time;
        part.sequence = Sequence::new(classes, frames).map_err(|e| e.in_file(&entry.path))?;
        parts.push(part);
    }
    let frame = parts.iter().find_map(|p| p.frame_of_reference.clone());
    // Whole-sequence errors (a class never contoured) name the manifest.
    let (sequence, generated) = combine(parts).map_err(|e| e.in_file(path))?;
    Ok((sequence, generated, frame))
}

fn manifest_error(path: &Path, line: usize, what: &str) -> DataError {
    DataError::new(ErrorKind::Combine(what.into()))
        .in_file(path)
        .at_line(line)
}

/// Refuses inputs whose frame times differ (count or value), naming both.
fn check_time_grids(parts: &[Part]) -> Result<()> {
    let times = |p: &Part| -> Vec<f64> { p.sequence.frames().iter().map(|f| f.time).collect() };
    let Some(first) = parts.first() else {
        return Ok(());
    };
    let reference = times(first);
    for part in &parts[1..] {
        let own = times(part);
        let agree = own.len() == reference.len()
            && own.iter().zip(&reference).all(|(&a, &b)| same_time(a, b));
        if !agree {
            return Err(DataError::new(ErrorKind::Combine(format!(
                "its time grid ({}) differs from that of {} ({}); several inputs must be views \
                 at the same times (frame i of each at i × its frame interval)",
                describe_grid(&own),
                first.path.display(),
                describe_grid(&reference)
            )))
            .in_file(&part.path));
        }
    }
    Ok(())
}

fn describe_grid(times: &[f64]) -> String {
    // Frame intervals come from f32 headers: 0.04 is stored as 0.0399999991.
    let short = |t: f64| (t * 1e6).round() / 1e6;
    match times {
        [] => "no frame".into(),
        [t] => format!("1 frame at {}", short(*t)),
        [a, b, ..] => format!(
            "{} frames, {} to {} every {}",
            times.len(),
            short(*a),
            short(times[times.len() - 1]),
            short(b - a)
        ),
    }
}

/// The sequence restricted to `range`'s frames (an error if none is left).
pub fn select_frames(seq: Sequence, range: FrameRange) -> Result<Sequence> {
    if range == FrameRange::ALL {
        return Ok(seq);
    }
    let count = seq.frames().len();
    let keep = range.indices(count);
    if keep.is_empty() {
        return Err(ErrorKind::Option(format!(
            "frames {range} select no frame of the {count} in the input"
        ))
        .into());
    }
    let (classes, frames) = seq.into_parts();
    let frames = frames
        .into_iter()
        .enumerate()
        .filter(|(i, _)| keep.contains(i))
        .map(|(_, f)| f)
        .collect();
    Sequence::new(classes, frames)
}
