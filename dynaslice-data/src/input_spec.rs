//! How to read a training run's inputs, as the command line's flags and Python's keywords give
//! it: every field optional, `None` meaning [`InputOptions::default`]'s value. The one mapping
//! from those options to [`InputOptions`], so that the front ends cannot drift.

use crate::drawn_slices::{PlaneMode, SparseAxes};
use crate::frame_range::FrameRange;
use crate::input::{self, InputOptions};
use crate::label_table::LabelTable;
use crate::nesting::{self, NestingMode};
use crate::nifti::HeaderSpacing;
use crate::reslice::ResliceOptions;
use crate::rtstruct::RoiExtent;
use dynaslice_sequence::error::Result;
use dynaslice_sequence::sequence::Sequence;
use dynaslice_sequence::space::{Space, Units};
use std::path::PathBuf;

/// The input options of `dynaslice train` and `dynaslice.train`, by the same names.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct InputSpec {
    /// The inputs: several are views of one subject at the same times.
    pub inputs: Vec<PathBuf>,
    /// Frames to use (default: all).
    pub frames: Option<FrameRange>,
    /// A label-name table (`<label> <name>` lines) over the names the inputs carry.
    pub label_names: Option<PathBuf>,
    /// Label maps: how they become planes.
    pub planes: Option<PlaneMode>,
    /// Sparsely drawn label maps: the voxel axes drawn on.
    pub drawn_axes: Option<SparseAxes>,
    /// RT Structure Sets: where an ROI without a contour on a plane counts as absent.
    pub roi_extent: Option<RoiExtent>,
    /// Label maps: planes rotated about the volume's z axis.
    pub rotated_planes: Option<usize>,
    /// Label maps: every k-th axial slice of the labelled range (0: none).
    pub axial_step: Option<usize>,
    /// Label maps: the label values to reconstruct.
    pub labels: Option<Vec<i32>>,
    /// Label maps: the resliced planes' in-plane sampling step, world units.
    pub pixel: Option<f64>,
    /// Classes drawn one inside another: detected, given, or trained as drawn
    /// ([`crate::nesting`]).
    pub nesting: Option<NestingMode>,
    /// NIfTI label maps: where the voxel spacing comes from when the header's transforms and
    /// `pixdim` disagree ([`HeaderSpacing`]).
    pub header_spacing: Option<HeaderSpacing>,
}

impl InputSpec {
    /// The inputs for messages and metadata: `a.nii.gz`, or `a.nii.gz + b.nii.gz`.
    pub fn describe(&self) -> String {
        self.inputs
            .iter()
            .map(|p| p.display().to_string())
            .collect::<Vec<_>>()
            .join(" + ")
    }

    /// The frames kept.
    pub fn frames(&self) -> FrameRange {
        self.frames.unwrap_or(FrameRange::ALL)
    }

    /// The reading options (the label-name table read from its file).
    pub fn options(&self) -> Result<InputOptions> {
        let d = InputOptions::default();
        let table = match &self.label_names {
            Some(p) => LabelTable::read(p)?,
            None => LabelTable::default(),
        };
        Ok(InputOptions {
            frames: self.frames(),
            table,
            planes: self.planes.unwrap_or(d.planes),
            sparse_axes: self.drawn_axes.unwrap_or(d.sparse_axes),
            roi_extent: self.roi_extent.unwrap_or(d.roi_extent),
            header_spacing: self.header_spacing.unwrap_or(d.header_spacing),
            reslice: ResliceOptions {
                rotated: self.rotated_planes.unwrap_or(d.reslice.rotated),
                axial_step: self.axial_step.unwrap_or(d.reslice.axial_step),
                frames: FrameRange::ALL,
                labels: self.labels.clone(),
                pixel: self.pixel,
            },
        })
    }

    /// Reads the inputs into one sequence, nested classes made disjoint as
    /// [`InputSpec::nesting`] says ([`nesting::apply`]).
    pub fn read(&self) -> Result<Sequence> {
        let seq = input::read(&self.inputs, &self.options()?)?;
        nesting::apply(seq, &self.nesting.clone().unwrap_or_default())
            .map_err(|e| e.in_file(std::path::Path::new(&self.describe())))
    }

    /// The frame and units of the inputs' coordinates ([`input::space_of`]).
    pub fn space(&self) -> Result<(Space, Units)> {
        input::space_of(&self.inputs)
    }
}
