//! The input options every command that reads cross-sections shares, and reading them through
//! [`dynaslice_data::input`].

use super::progress::Progress;
use super::times::note;
use anyhow::Result;
use dynaslice_data::drawn_slices::{PlaneMode, SparseAxes};
use dynaslice_data::frame_range::FrameRange;
use dynaslice_data::input_spec::InputSpec;
use dynaslice_data::nesting::NestingMode;
use dynaslice_data::nifti::HeaderSpacing;
use dynaslice_data::rtstruct::RoiExtent;
use dynaslice_data::Sequence;
use dynaslice_model::ModelFile;
use dynaslice_train::job::input_as_trained;
use std::path::PathBuf;

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
    /// Frames to use, A:B:STEP (Python slice; e.g. 0:37:4 = every 4th of 37; an end past the
    /// last frame is cut there, with a warning) [default: 0:, or as the model was trained where
    /// a command takes a model]
    #[arg(long, value_name = "A:B:STEP")]
    pub frames: Option<FrameRange>,
    /// Label-name table ("<label> <name>" per line) for inputs that carry label numbers only.
    #[arg(long, value_name = "FILE")]
    pub label_names: Option<PathBuf>,
    /// Label maps: how they become planes. `slices`: every slice of the image as drawn (cine
    /// short-axis stacks, long-axis views); `sparse`: only the slices that carry labels, along any
    /// voxel axis, the rest unobserved (a few slices drawn in Slicer or ITK-SNAP); `reslice`: the
    /// paper's protocol for dense segmentations; `auto`: slices for 3 slices or fewer or slices
    /// at least 2× thicker than the pixels, sparse for sparsely drawn maps, reslice otherwise.
    /// [default: auto]
    #[arg(long, value_name = "auto|slices|reslice|sparse")]
    pub planes: Option<PlaneMode>,
    /// Sparsely drawn label maps: the voxel axes drawn on (`auto` detects them; `k`, `i,k`, …)
    /// [default: auto]
    #[arg(long, value_name = "auto|AXES")]
    pub drawn_axes: Option<SparseAxes>,
    /// RT Structure Sets: `file` takes each ROI as contoured on every contour plane of its file
    /// (absent where it has no contour); `own` only between its own first and last contour.
    /// [default: file]
    #[arg(long, value_name = "file|own")]
    pub roi_extent: Option<RoiExtent>,
    /// Label maps: planes rotated about the volume's z axis through the labelled region's centre
    /// [default: 20]
    #[arg(long, value_parser = count(0, MAX_ROTATED_PLANES))]
    pub rotated_planes: Option<usize>,
    /// Label maps: use every k-th axial slice of the labelled range (0: none) [default: 2]
    #[arg(long, value_parser = count(0, usize::MAX))]
    pub axial_step: Option<usize>,
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
    /// drawn; `INNER:OUTER,…` (labels) names the pairs. [default: auto]
    #[arg(long, value_name = "auto|off|INNER:OUTER,…")]
    pub nesting: Option<NestingMode>,
    /// NIfTI label maps: the voxel spacing where the header disagrees with itself. `auto`: the
    /// sform where sform_code > 0, else the qform (nibabel's rule), warning where the sform's
    /// spacing and pixdim differ; `sform`; `qform`; `pixdim`: the sform's orientation and
    /// origin with pixdim's spacing. [default: auto]
    #[arg(long, value_name = "auto|sform|qform|pixdim")]
    pub header_spacing: Option<HeaderSpacing>,
}

impl InputArgs {
    /// The inputs for messages: `a.nii.gz`, or `a.nii.gz + b.nii.gz`.
    pub fn describe(&self) -> String {
        self.spec().describe()
    }

    /// These options as the one input specification the front ends share: an option not given
    /// is `None` (the reader's default, or the model's record: [`InputArgs::spec_as_trained`]).
    pub fn spec(&self) -> InputSpec {
        InputSpec {
            inputs: self.inputs.clone(),
            frames: self.frames,
            label_names: self.label_names.clone(),
            planes: self.planes,
            drawn_axes: self.drawn_axes,
            roi_extent: self.roi_extent,
            rotated_planes: self.rotated_planes,
            axial_step: self.axial_step,
            labels: self.labels.clone(),
            pixel: self.pixel,
            nesting: self.nesting.clone(),
            header_spacing: self.header_spacing,
        }
    }

    /// [`InputArgs::spec`] with every option not given taken from how `file`'s model read its
    /// input ([`input_as_trained`]); its note, where anything was taken, on standard error.
    pub fn spec_as_trained(&self, file: &ModelFile) -> Result<InputSpec> {
        let (spec, taken) = input_as_trained(self.spec(), file)?;
        if let Some(taken) = taken {
            note(&taken);
        }
        Ok(spec)
    }
}

/// Reads the inputs of `file`'s model as it was trained on them ([`InputArgs::spec_as_trained`]).
pub fn read_as_trained(args: &InputArgs, file: &ModelFile) -> Result<Sequence> {
    let spec = args.spec_as_trained(file)?;
    // Reading and reslicing a label map takes seconds (8 s for a 64³ × 9 map on a loaded
    // 2-core machine): a progress line every few seconds meanwhile, not silence (issue 39).
    let progress = Progress::new(&format!("reading {}: input", spec.describe()), 1);
    let seq = spec.read()?;
    progress.inc();
    progress.finish();
    Ok(seq)
}

#[cfg(test)]
mod tests {
    use crate::Cli;
    use clap::CommandFactory;
    use dynaslice_data::reslice::ResliceOptions;

    /// The defaults the help states are the reader's.
    #[test]
    fn the_help_states_the_readers_defaults() {
        let cli = Cli::command();
        let train = cli.find_subcommand("train").unwrap();
        let help = |name: &str| {
            let arg = train.get_arguments().find(|a| a.get_id() == name).unwrap();
            arg.get_help().unwrap().to_string()
        };
        let d = ResliceOptions::default();
        assert!(help("rotated_planes").ends_with(&format!("[default: {}]", d.rotated)));
        assert!(help("axial_step").ends_with(&format!("[default: {}]", d.axial_step)));
        let options = dynaslice_data::input::InputOptions::default();
        assert!(help("planes").ends_with(&format!("[default: {}]", options.planes)));
        assert!(help("drawn_axes").ends_with(&format!("[default: {}]", options.sparse_axes)));
        assert!(help("roi_extent").ends_with(&format!("[default: {}]", options.roi_extent)));
        assert!(help("header_spacing").ends_with(&format!("[default: {}]", options.header_spacing)));
    }
}
