//! The input options every command that reads cross-sections shares, and reading them through
//! [`dynaslice_data::input`]; and the check of the other files a command reads itself (a model,
//! `--like`, a reference mesh) by the readers' regular-file rule.

use anyhow::{bail, Result};
use dynaslice_data::drawn_slices::{PlaneMode, SparseAxes};
use dynaslice_data::frame_range::FrameRange;
use dynaslice_data::input_spec::InputSpec;
use dynaslice_data::nesting::NestingMode;
use dynaslice_data::nifti::HeaderSpacing;
use dynaslice_data::reslice::ResliceOptions;
use dynaslice_data::rtstruct::RoiExtent;
use dynaslice_data::Sequence;
use std::path::{Path, PathBuf};

use crate::options::{count, positive_f64};

/// Most rotated planes a label map is resliced into (the paper uses 20).
const MAX_ROTATED_PLANES: usize = 1000;

/// Options shared by every command that reads cross-sections.
#[derive(clap::Args, Debug, Clone)]
pub struct InputArgs {
    /// Cross-sections: native JSON (.json), a .csl file, a DICOM RT Structure Set, a sequence
    /// manifest (.seq, .cslseq: `<time> <path>` lines of single-timestep inputs), or label maps
    /// (.nii, .nii.gz, .nrrd, .nhdr, .seg.nrrd). Several inputs are views of one subject at the
    /// same times (e.g. a short-axis stack and long-axis views).
    #[arg(required = true, value_name = "INPUT")]
    pub inputs: Vec<PathBuf>,
    /// Frames to use, A:B:STEP (Python slice; e.g. 0:37:4 = every 4th of 37).
    #[arg(long, default_value = "0:", value_name = "A:B:STEP")]
    pub frames: FrameRange,
    /// Label-name table ("<label> <name>" per line) for inputs that carry label numbers only.
    #[arg(long, value_name = "FILE")]
    pub label_names: Option<PathBuf>,
    /// Label maps: how they become planes. `slices`: every slice of the image as drawn (cine
    /// short-axis stacks, long-axis views); `sparse`: only the slices that carry labels, along any
    /// voxel axis, the rest unobserved (a few slices drawn in Slicer or ITK-SNAP); `reslice`: the
    /// paper's protocol for dense segmentations; `auto`: slices for 3 slices or fewer or slices
    /// at least 2× thicker than the pixels, sparse for sparsely drawn maps, reslice otherwise.
    #[arg(long, default_value_t = PlaneMode::Auto, value_name = "auto|slices|reslice|sparse")]
    pub planes: PlaneMode,
    /// Sparsely drawn label maps: the voxel axes drawn on (`auto` detects them; `k`, `i,k`, …).
    #[arg(long, default_value_t = SparseAxes::Detect, value_name = "auto|AXES")]
    pub drawn_axes: SparseAxes,
    /// RT Structure Sets: `file` takes each ROI as contoured on every contour plane of its file
    /// (absent where it has no contour); `own` only between its own first and last contour.
    #[arg(long, default_value_t = RoiExtent::File, value_name = "file|own")]
    pub roi_extent: RoiExtent,
    /// Label maps: planes rotated about the volume's z axis through the labelled region's centre.
    #[arg(long, default_value_t = ResliceOptions::default().rotated,
          value_parser = count(0, MAX_ROTATED_PLANES))]
    pub rotated_planes: usize,
    /// Label maps: use every k-th axial slice of the labelled range (0: none).
    #[arg(long, default_value_t = ResliceOptions::default().axial_step,
          value_parser = count(0, usize::MAX))]
    pub axial_step: usize,
    /// Label maps: label values to reconstruct, one class each (default: every nonzero label).
    #[arg(long, value_delimiter = ',')]
    pub labels: Option<Vec<i32>>,
    /// Label maps: in-plane sampling step of the resliced planes, world units (default: half the
    /// smallest voxel spacing, or the labelled box's longest diagonal / 1536 where coarser).
    #[arg(long, value_parser = positive_f64)]
    pub pixel: Option<f64>,
    /// Classes drawn one inside another (an endocardium inside its epicardium, a GTV inside
    /// its organ): `auto` finds them from the contours and trains the outer as its region minus
    /// the inner's, recomposed in volumes and RT Structure Sets; `off` trains every class as
    /// drawn; `INNER:OUTER,…` (labels) names the pairs.
    #[arg(long, default_value_t = NestingMode::Auto, value_name = "auto|off|INNER:OUTER,…")]
    pub nesting: NestingMode,
    /// NIfTI label maps: the voxel spacing where the header disagrees with itself. `auto`: the
    /// sform where sform_code > 0, else the qform (nibabel's rule), warning where the sform's
    /// spacing and pixdim differ; `sform`; `qform`; `pixdim`: the sform's orientation and
    /// origin with pixdim's spacing.
    #[arg(long, default_value_t = HeaderSpacing::Auto, value_name = "auto|sform|qform|pixdim")]
    pub header_spacing: HeaderSpacing,
}

impl InputArgs {
    /// The inputs for messages: `a.nii.gz`, or `a.nii.gz + b.nii.gz`.
    pub fn describe(&self) -> String {
        self.spec().describe()
    }

    /// These options as the one input specification the front ends share.
    pub fn spec(&self) -> InputSpec {
        InputSpec {
            inputs: self.inputs.clone(),
            frames: Some(self.frames),
            label_names: self.label_names.clone(),
            planes: Some(self.planes),
            drawn_axes: Some(self.drawn_axes),
            roi_extent: Some(self.roi_extent),
            rotated_planes: Some(self.rotated_planes),
            axial_step: Some(self.axial_step),
            labels: self.labels.clone(),
            pixel: self.pixel,
            nesting: Some(self.nesting.clone()),
            header_spacing: Some(self.header_spacing),
        }
    }
}

/// Reads the inputs and keeps the selected frames.
pub fn read(args: &InputArgs) -> Result<Sequence> {
    Ok(args.spec().read()?)
}

/// `path` as an input: it exists and is a regular file (a FIFO would block the open, a device
/// like /dev/zero would never end), checked by the readers' own rule
/// ([`dynaslice_sequence::input_file::regular_file`]). `what` names it in the message (e.g. "model").
pub fn regular_file(what: &str, path: &Path) -> Result<()> {
    match dynaslice_sequence::input_file::regular_file(path) {
        Ok(_) => Ok(()),
        Err(e) => bail!("cannot read {what} {}: {}", path.display(), e.kind),
    }
}
