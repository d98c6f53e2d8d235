//! Reading a training input of any supported kind, chosen by its file name.

use anyhow::{bail, Context, Result};
use dynaslice_data::frame_range::FrameRange;
use dynaslice_data::reslice::ResliceOptions;
use dynaslice_data::{csl, native, nifti, LabelTable, Sequence};
use std::path::{Path, PathBuf};

/// Options shared by every command that reads cross-sections.
#[derive(clap::Args, Debug, Clone)]
pub struct InputArgs {
    /// Cross-sections: native JSON (.json), a .csl file, a .csl sequence manifest (.cslseq), or
    /// a 3D/4D NIfTI label volume (.nii, .nii.gz) resliced per the paper's protocol.
    pub input: PathBuf,
    /// Frames to use, A:B:STEP (Python slice; e.g. 0:37:4 = every 4th of 37).
    #[arg(long, default_value = "0:", value_name = "A:B:STEP")]
    pub frames: FrameRange,
    /// Label-name table ("<label> <name>" per line) for inputs that carry label numbers only.
    #[arg(long, value_name = "FILE")]
    pub label_names: Option<PathBuf>,
    /// NIfTI: planes rotated about the volume's z axis through the labelled region's centre.
    #[arg(long, default_value_t = ResliceOptions::default().rotated)]
    pub rotated_planes: usize,
    /// NIfTI: use every k-th axial slice of the labelled range (0: none).
    #[arg(long, default_value_t = ResliceOptions::default().axial_step)]
    pub axial_step: usize,
    /// NIfTI: label values to reconstruct, one class each (default: every nonzero label).
    #[arg(long, value_delimiter = ',')]
    pub labels: Option<Vec<i32>>,
    /// NIfTI: in-plane sampling step of the resliced planes, world units (default: half the
    /// smallest voxel spacing, or the labelled box's longest diagonal / 1536 where coarser).
    #[arg(long)]
    pub pixel: Option<f64>,
}

/// Reads `args.input` and keeps the selected frames.
pub fn read(args: &InputArgs) -> Result<Sequence> {
    let names = match &args.label_names {
        Some(p) => LabelTable::read(p)?,
        None => LabelTable::default(),
    };
    let path = args.input.as_path();
    let name = path.to_string_lossy().to_ascii_lowercase();
    if name.ends_with(".nii") || name.ends_with(".nii.gz") {
        let options = ResliceOptions {
            rotated: args.rotated_planes,
            axial_step: args.axial_step,
            frames: args.frames,
            labels: args.labels.clone(),
            pixel: args.pixel,
        };
        return Ok(nifti::read(path, &options, &names)?);
    }
    let seq = match extension(path).as_str() {
        "json" => native::read(path)?,
        "csl" => csl::read(path, &names)?,
        "cslseq" => csl::read_sequence(path, &names)?,
        other => bail!(
            "{}: unsupported input type {other:?} (expected .json, .csl, .cslseq, .nii or .nii.gz)",
            path.display()
        ),
    };
    select_frames(seq, args.frames)
        .with_context(|| format!("{}: --frames {}", path.display(), args.frames))
}

fn extension(path: &Path) -> String {
    path.extension()
        .map(|e| e.to_string_lossy().to_ascii_lowercase())
        .unwrap_or_default()
}

/// The sequence restricted to `range`'s frames (an error if none is left).
pub fn select_frames(seq: Sequence, range: FrameRange) -> Result<Sequence> {
    if range == FrameRange::ALL {
        return Ok(seq);
    }
    let count = seq.frames().len();
    let keep = range.indices(count);
    if keep.is_empty() {
        bail!("selects no frame of the {count} in the input");
    }
    let (classes, frames) = seq.into_parts();
    let frames = frames
        .into_iter()
        .enumerate()
        .filter(|(i, _)| keep.contains(i))
        .map(|(_, f)| f)
        .collect();
    Ok(Sequence::new(classes, frames)?)
}
