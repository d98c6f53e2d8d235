//! Label volumes: a model's Eq. 11 labels (argmin over (0, f¹, …, f^K), background 0) on a
//! voxel grid ([`voxel_grid`]), at one or more times, written frame by frame as NIfTI-1
//! (`dynaslice_data::nifti_stream`) with each class's source label value. `dynaslice labels` is
//! the command.
//!
//! A frame's labels are computed coarse to fine ([`pruned`]): the network is evaluated where a
//! label can change (near the boundaries between labels) and blocks far from every boundary are
//! filled, with the same labels as evaluating every voxel ([`Evaluation::Dense`], the check).
//!
//! Memory is bounded by one frame: a frame's labels are computed (in parallel over z-slabs),
//! counted, encoded and written before the next frame is started.
//!
//! Besides the volume, [`write_model_labels_with`] can write companion files
//! ([`output_files`]): the colour tables of a NIfTI volume for 3D Slicer and ITK-SNAP
//! ([`dynaslice_data::color_table`]), and for a series of 3D Slicer segmentations the one
//! `.seq.nrrd` sequence Slicer's Sequences module loads ([`dynaslice_data::nrrd::SequenceWriter`]).
//! Class colours are the model input's where recorded, else the one palette's
//! ([`dynaslice_sequence::palette`]).
//!
//! The same labels on a reference geometry's planes, as DICOM RT Structure Sets for a
//! treatment planning system: [`rtstruct`] (`dynaslice rtstruct`).

#![warn(missing_docs)]

pub mod pruned;
pub mod rtstruct;
pub mod voxel_grid;

use dynaslice_data::color_table::{stage_tables, table_paths};
use dynaslice_data::nifti_stream::{NiftiStream, VolumeHeader};
use dynaslice_data::nrrd::{
    frame_name_test, frame_path, sequence_path, stage_segmentation, SegmentationHeader,
    SequenceWriter,
};
use dynaslice_data::ClassInfo;
pub use pruned::{Evaluation, PruneStats, DEFAULT_SAFETY};
pub use voxel_grid::{is_nifti, VoxelGrid};

use anyhow::{bail, Result};
use dynaslice_core::{Model, Scratch, UNDEFINED_LABEL};
use dynaslice_model::ModelFile;
use dynaslice_output::OutputSet;
use rayon::prelude::*;
use std::path::{Path, PathBuf};

/// Points per batch call: enough to amortise a call, small enough to stay in cache.
const CHUNK: usize = 4096;

/// The value written for each Eq. 11 label: entry 0 is the background (0), entry k the source
/// label of class k. An error when a class's source label is 0 or shared with another class,
/// since the volume could then not tell them apart.
pub fn source_labels(model: &Model) -> Result<Vec<i32>> {
    let mut values = vec![0];
    for (k, class) in model.classes().enumerate() {
        if let Some(j) = values.iter().position(|&v| v == class.label) {
            let other = if j == 0 {
                "the background".to_string()
            } else {
                format!("class {j}")
            };
            bail!(
                "class {} ({:?}) has source label {}, the same as {other}; the label volume \
                 could not tell them apart",
                k + 1,
                class.name,
                class.label
            );
        }
        values.push(class.label);
    }
    Ok(values)
}

/// The Eq. 11 label indices (0..=K, not source values) of every voxel of `grid` at world time
/// `t`, x fastest, into `out`, by the default [`Evaluation`]. An error if the model is not finite
/// at an evaluated voxel.
pub fn label_indices(model: &Model, grid: &VoxelGrid, t: f64, out: &mut [u32]) -> Result<()> {
    label_indices_with(model, grid, t, Evaluation::default(), out).map(|_| ())
}

/// [`label_indices`] by `evaluation`; returns how many points the network was evaluated at.
pub fn label_indices_with(
    model: &Model,
    grid: &VoxelGrid,
    t: f64,
    evaluation: Evaluation,
    out: &mut [u32],
) -> Result<PruneStats> {
    evaluation.validate()?;
    if grid.voxels_per_frame() == 0 {
        return Ok(PruneStats::default());
    }
    match evaluation {
        Evaluation::Dense => {
            dense_label_indices(model, grid, t, out)?;
            let voxels = grid.voxels_per_frame() as u64;
            Ok(PruneStats {
                evaluated: voxels,
                voxels,
            })
        }
        Evaluation::Pruned { safety } => pruned::pruned_label_indices(model, grid, t, safety, out),
    }
}

/// Every voxel through the network, in parallel over z-slices.
fn dense_label_indices(model: &Model, grid: &VoxelGrid, t: f64, out: &mut [u32]) -> Result<()> {
    let [nx, ny, _] = grid.dims;
    anyhow::ensure!(
        out.len() == grid.voxels_per_frame(),
        "one label per voxel: {} labels for {} voxels",
        out.len(),
        grid.voxels_per_frame()
    );
    out.par_chunks_mut(nx * ny).enumerate().try_for_each_init(
        || (Scratch::boxed(), Vec::with_capacity(CHUNK)),
        |(scratch, points), (k, slab)| {
            let times = [t as f32; CHUNK];
            for (c, labels) in slab.chunks_mut(CHUNK).enumerate() {
                points.clear();
                points.extend(
                    (c * CHUNK..c * CHUNK + labels.len())
                        .map(|v| grid.world(v % nx, v / nx, k).map(|x| x as f32)),
                );
                let n = labels.len();
                model
                    .label_batch(scratch, points, &times[..n], labels)
                    .expect("buffers are sized to the chunk");
                if let Some(i) = labels.iter().position(|&l| l == UNDEFINED_LABEL) {
                    bail!(
                        "the model is not finite at {:?}, time {t}: no label",
                        points[i]
                    );
                }
            }
            Ok(())
        },
    )
}

/// How [`write_model_labels_with`] computes a label volume and what it writes besides it.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct WriteOptions {
    /// How each frame's labels are computed (`Evaluation::Dense` is `dynaslice labels --dense`).
    pub evaluation: Evaluation,
    /// Each class's display colour (channel order) where the model's input gave one; the
    /// others, and classes past the end, take [`dynaslice_sequence::palette::palette`]'s.
    pub colors: Vec<Option<[u8; 3]>>,
    /// Also write the companion files ([`output_files`]): beside a NIfTI volume its colour
    /// tables (`NAME.ctbl` for 3D Slicer, `NAME.label.txt` for ITK-SNAP), beside a series of
    /// 3D Slicer segmentations the one sequence of them (`NAME.seq.nrrd`).
    pub companions: bool,
}

/// Whether `path` names 3D Slicer segmentations (`.seg.nrrd`, any case) rather than NIfTI.
fn is_segmentation(path: &Path) -> bool {
    path.to_string_lossy()
        .to_ascii_lowercase()
        .ends_with(".seg.nrrd")
}

/// Every file [`write_model_labels_with`] writes for `frames` frames to `path`, so a caller can
/// check them all before any work: `path` itself (a NIfTI volume, or the one segmentation of a
/// single frame) or each frame's segmentation ([`dynaslice_data::nrrd::frame_path`]); with
/// `companions`, then the colour tables ([`dynaslice_data::color_table::table_paths`]) or the
/// sequence ([`dynaslice_data::nrrd::sequence_path`]) of a series.
pub fn output_files(path: &Path, frames: usize, companions: bool) -> Vec<PathBuf> {
    if !is_segmentation(path) {
        let mut files = vec![path.to_path_buf()];
        if companions {
            let (ctbl, label) = table_paths(path);
            files.extend([ctbl, label]);
        }
        return files;
    }
    if frames <= 1 {
        return vec![path.to_path_buf()];
    }
    let mut files: Vec<PathBuf> = (0..frames).map(|f| frame_path(path, f, frames)).collect();
    if companions {
        files.push(sequence_path(path));
    }
    files
}

impl WriteOptions {
    /// The options of a label volume of `file`'s model with its colour tables or sequence:
    /// `evaluation`, and the classes' colours its training input had where it records them.
    pub fn for_model(file: &ModelFile, evaluation: Evaluation) -> WriteOptions {
        WriteOptions {
            evaluation,
            colors: file.classes().into_iter().map(|c| c.color).collect(),
            companions: true,
        }
    }
}

/// Bytes per voxel while a frame is labelled and written: a u32 class index and an i32 label
/// per voxel ([`write_model_labels_with`]), and up to 4 more for the frame's encoded copy (2 in
/// the NIfTI writer, up to 4 in a `.seg.nrrd` of labels beyond 16 bits; the sequence is
/// compressed in chunks).
pub const BYTES_PER_VOXEL: f64 = 12.0;

/// About how many bytes writing `grid`'s label volume holds at once: one frame's
/// [`BYTES_PER_VOXEL`] per voxel.
pub fn working_bytes(grid: &VoxelGrid) -> f64 {
    grid.dims.iter().map(|&n| n as f64).product::<f64>() * BYTES_PER_VOXEL
}

/// Applies the model's one time rule to `grid`'s frames: a static model (the same labels at
/// every time) keeps only the first frame, and the number of frames dropped is returned; a
/// moving model's frames must lie in its time range (never extrapolated), each named in the
/// error by `option` ([`ModelFile::check_times`]).
pub fn fit_times(file: &ModelFile, grid: &mut VoxelGrid, option: &str) -> Result<usize> {
    if file.is_static() {
        let dropped = grid.times.len().saturating_sub(1);
        grid.times.truncate(1);
        return Ok(dropped);
    }
    file.check_times(option, grid.times.iter().copied())?;
    Ok(0)
}

/// Each frame's class volumes from the label `counts` of [`write_model_labels_with`] (index 0
/// the background, skipped), in the unit every output reports volumes in: mL for a model of
/// millimetres, the input's plain units³ otherwise ([`ModelFile::units`]).
pub fn class_volumes(file: &ModelFile, grid: &VoxelGrid, counts: &[Vec<u64>]) -> Vec<Vec<f64>> {
    let (voxel, units) = (grid.voxel_volume(), file.units());
    counts
        .iter()
        .map(|frame| {
            frame[1..]
                .iter()
                .map(|&n| units.from_world_volume(n as f64 * voxel))
                .collect()
        })
        .collect()
}

/// The written `files` ([`output_files`]) in words: the volume (a series of frames by its
/// first and last), and the companion files, each named with what it is for.
pub fn describe_files(files: &[PathBuf]) -> (String, Vec<String>) {
    let (volume, companions): (Vec<&PathBuf>, Vec<&PathBuf>) = files
        .iter()
        .partition(|p| is_segmentation(p) || is_nifti(p));
    let volume = match volume[..] {
        [one] => one.display().to_string(),
        [first, .., last] => format!(
            "{} … {} (a segmentation per frame)",
            first.display(),
            last.display()
        ),
        [] => String::new(),
    };
    let companions = companions
        .iter()
        .map(|p| {
            let name = p.to_string_lossy().to_ascii_lowercase();
            let what = if name.ends_with(".ctbl") {
                "3D Slicer colour table"
            } else if name.ends_with(".label.txt") {
                "ITK-SNAP label descriptions"
            } else {
                "3D Slicer sequence of the frames"
            };
            format!("{} ({what})", p.display())
        })
        .collect();
    (volume, companions)
}

/// Writes `model`'s label volume on `grid` to `path` (`.nii` or `.nii.gz`: one NIfTI, a frame
/// per time; `.seg.nrrd`: a 3D Slicer segmentation per frame, named by
/// [`dynaslice_data::nrrd::frame_path`], with the classes' names and palette colours) by the
/// default [`Evaluation`], without companion files, calling `on_frame(f)` after frame f is
/// written. Returns the voxel count of each label index (0 = background, k = class k) per frame.
pub fn write_model_labels(
    model: &Model,
    grid: &VoxelGrid,
    path: &Path,
    on_frame: impl FnMut(usize),
) -> Result<Vec<Vec<u64>>> {
    write_model_labels_with(model, grid, path, &WriteOptions::default(), on_frame)
}

/// [`write_model_labels`] by `options`: its evaluation, the classes' colours (in the
/// segmentations, the sequence and the colour tables) and the companion files. Every file
/// of the run appears once every frame is in, all together
/// ([`dynaslice_output::OutputSet`]): on an error nothing new is left and an earlier output
/// is untouched.
pub fn write_model_labels_with(
    model: &Model,
    grid: &VoxelGrid,
    path: &Path,
    options: &WriteOptions,
    mut on_frame: impl FnMut(usize),
) -> Result<Vec<Vec<u64>>> {
    let evaluation = options.evaluation;
    evaluation.validate()?;
    let values = source_labels(model)?;
    let lo = values.iter().copied().min().unwrap_or(0);
    let hi = values.iter().copied().max().unwrap_or(0);
    let frames = grid.times.len();
    let header = VolumeHeader {
        dims: grid.dims,
        frames,
        affine: grid.affine,
        frame_interval: grid.frame_interval()?,
        time_offset: grid.times[0],
        label_range: (lo, hi),
        description: "dynaslice labels (Eq. 11 argmin)".into(),
    };
    let classes: Vec<ClassInfo> = model
        .classes()
        .enumerate()
        .map(|(k, c)| ClassInfo {
            name: c.name.to_string(),
            label: c.label,
            color: options.colors.get(k).copied().flatten(),
        })
        .collect();
    let segments = SegmentationHeader {
        dims: grid.dims,
        affine: grid.affine,
        classes,
    };
    let segmentation = is_segmentation(path);
    // Every file of the run (the volume and its tables, or the frames and their sequence)
    // goes in place at the end, all or none: a failure or an interruption leaves nothing new
    // and an earlier output untouched.
    let mut set = OutputSet::new();
    if segmentation && frames > 1 {
        // With --force over a longer series, its extra frames go too.
        let dir = path.parent().filter(|d| !d.as_os_str().is_empty());
        set.supersede(dir.unwrap_or(Path::new(".")), frame_name_test(path));
    }
    let mut stream = if segmentation {
        None
    } else {
        Some(NiftiStream::create(path, &header)?)
    };
    let mut sequence = if segmentation && frames > 1 && options.companions {
        Some(SequenceWriter::create(
            &sequence_path(path),
            &segments,
            &grid.times,
        )?)
    } else {
        None
    };
    let n = grid.voxels_per_frame();
    let mut indices = vec![0u32; n];
    let mut labels = vec![0i32; n];
    let mut counts = Vec::with_capacity(frames);
    for (f, &t) in grid.times.iter().enumerate() {
        label_indices_with(model, grid, t, evaluation, &mut indices)?;
        let mut count = vec![0u64; values.len()];
        for (l, &i) in labels.iter_mut().zip(&indices) {
            count[i as usize] += 1;
            *l = values[i as usize];
        }
        match &mut stream {
            Some(stream) => stream.write_frame(&labels)?,
            None => stage_segmentation(&mut set, &frame_path(path, f, frames), &segments, &labels)?,
        }
        if let Some(sequence) = &mut sequence {
            sequence.write_frame(&labels)?;
        }
        counts.push(count);
        on_frame(f);
    }
    if let Some(stream) = stream {
        stream.finish_into(&mut set)?;
        if options.companions {
            let (ctbl, label) = table_paths(path);
            stage_tables(&mut set, &ctbl, &label, &segments.classes)?;
        }
    }
    if let Some(sequence) = sequence {
        sequence.finish_into(&mut set)?;
    }
    set.commit()?;
    Ok(counts)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The summary names the volume (a series by its first and last frame) and what each
    /// companion file is for.
    #[test]
    fn written_files_are_described_by_kind() {
        let (volume, companions) = describe_files(&output_files(Path::new("v.nii.gz"), 3, true));
        assert_eq!(volume, "v.nii.gz");
        assert_eq!(
            companions,
            [
                "v.ctbl (3D Slicer colour table)",
                "v.label.txt (ITK-SNAP label descriptions)"
            ]
        );
        let (volume, companions) = describe_files(&output_files(Path::new("s.seg.nrrd"), 3, true));
        assert_eq!(
            volume,
            "s_t0.seg.nrrd … s_t2.seg.nrrd (a segmentation per frame)"
        );
        assert_eq!(
            companions,
            ["s.seq.nrrd (3D Slicer sequence of the frames)"]
        );
        assert!(is_nifti(Path::new("A.NII")) && !is_nifti(Path::new("a.nrrd")));
    }
    use dynaslice_data::nifti::read_volume;
    use dynaslice_data::TimeSeries;
    use dynaslice_test_support::spheres::Sphere;

    /// Through the whole pipeline, on two overlapping spheres whose Eq. 11 labels are known in
    /// closed form: every voxel of the file read back has the expected source label.
    #[test]
    fn volume_has_the_closed_form_labels_with_source_values() {
        let spheres = [
            Sphere::new([0.0; 3], 0.5, 0.1),
            Sphere::new([0.4, 0.0, 0.0], 0.3, 0.0),
        ];
        let bytes =
            dynaslice_test_support::spheres::model(&spheres, &[("ball", 3), ("small", 500)]);
        let model = Model::from_bytes(&bytes).unwrap();
        let (lo, hi) = model.domain().bounds();
        let times = "0:2:3".parse::<TimeSeries>().unwrap().times();
        let grid =
            VoxelGrid::from_bounds(lo.map(f64::from), hi.map(f64::from), [1.7; 3], times).unwrap();
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("labels.nii.gz");
        let mut seen = Vec::new();
        let counts = write_model_labels(&model, &grid, &path, |f| seen.push(f)).unwrap();
        assert_eq!(seen, [0, 1, 2]);
        let back = read_volume(&path).unwrap();
        assert_eq!((back.dims, back.frames), (grid.dims, 3));
        let mut mismatched = 0;
        for (f, &t) in grid.times.iter().enumerate() {
            let mut count = [0u64; 3];
            for k in 0..grid.dims[2] {
                for j in 0..grid.dims[1] {
                    for i in 0..grid.dims[0] {
                        let x = grid.world(i, j, k);
                        let d = spheres.map(|s| s.world_field(x, t));
                        let want = dynaslice_core::argmin_label(&d.map(|v| v as f32));
                        count[want as usize] += 1;
                        let got = back.label(i as isize, j as isize, k as isize, f);
                        // The network equals the field up to O(ε²) and f32 rounding: near-ties
                        // (within 0.1 mm of a surface or of the other class) may go either way.
                        let clear = d.iter().all(|v| v.abs() > 0.1) && (d[0] - d[1]).abs() > 0.1;
                        if got != [0, 3, 500][want as usize] && clear {
                            mismatched += 1;
                        }
                    }
                }
            }
            let total: u64 = count.iter().sum();
            for c in 0..3 {
                let diff = counts[f][c].abs_diff(count[c]) as f64;
                assert!(
                    diff < 2e-3 * total as f64,
                    "frame {f} label {c}: {counts:?}"
                );
            }
        }
        assert_eq!(mismatched, 0);
    }

    /// The companion files: named by `output_files`, written beside a NIfTI volume and a
    /// segmentation series, with the given colour where there is one.
    #[test]
    fn companions_are_the_files_output_files_names() {
        let spheres = [Sphere::new([0.0; 3], 0.5, 0.1)];
        let bytes = dynaslice_test_support::spheres::model(&spheres, &[("ball", 3)]);
        let model = Model::from_bytes(&bytes).unwrap();
        let (lo, hi) = model.domain().bounds();
        let grid = VoxelGrid::from_bounds(
            lo.map(f64::from),
            hi.map(f64::from),
            [4.0; 3],
            vec![0.0, 1.0, 2.0],
        )
        .unwrap();
        let dir = tempfile::tempdir().unwrap();
        let options = WriteOptions {
            colors: vec![Some([1, 2, 3])],
            companions: true,
            ..Default::default()
        };
        let names = |files: Vec<PathBuf>| -> Vec<String> {
            files
                .iter()
                .map(|p| p.file_name().unwrap().to_string_lossy().into_owned())
                .collect()
        };
        for (name, want) in [
            ("v.nii.gz", &["v.nii.gz", "v.ctbl", "v.label.txt"][..]),
            (
                "s.seg.nrrd",
                &[
                    "s_t0.seg.nrrd",
                    "s_t1.seg.nrrd",
                    "s_t2.seg.nrrd",
                    "s.seq.nrrd",
                ][..],
            ),
        ] {
            let path = dir.path().join(name);
            let files = output_files(&path, 3, true);
            assert_eq!(names(files.clone()), want);
            write_model_labels_with(&model, &grid, &path, &options, |_| {}).unwrap();
            for f in &files {
                assert!(f.exists(), "{}", f.display());
            }
        }
        let ctbl = std::fs::read_to_string(dir.path().join("v.ctbl")).unwrap();
        assert!(ctbl.contains("\n3 ball 1 2 3 255\n"), "{ctbl}");
        // Nothing else: no temporary files, no companions without `companions`.
        assert_eq!(std::fs::read_dir(dir.path()).unwrap().count(), 7);
        assert_eq!(
            names(output_files(Path::new("x.seg.nrrd"), 1, true)),
            ["x.seg.nrrd"]
        );
        assert_eq!(names(output_files(Path::new("x.nii"), 4, false)), ["x.nii"]);
    }

    #[test]
    fn ambiguous_source_labels_are_refused() {
        let s = [
            Sphere::new([0.0; 3], 0.5, 0.0),
            Sphere::new([0.3; 3], 0.2, 0.0),
        ];
        for (names, why) in [
            ([("a", 0), ("b", 2)], "the background"),
            ([("a", 2), ("b", 2)], "class 1"),
        ] {
            let bytes = dynaslice_test_support::spheres::model(&s, &names);
            let e = source_labels(&Model::from_bytes(&bytes).unwrap())
                .unwrap_err()
                .to_string();
            assert!(e.contains(why), "{e}");
        }
    }
}
