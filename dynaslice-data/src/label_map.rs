//! A label map as a reader gives it: the voxels, the names and colours its file carries, and
//! what the file says of its values (for the class count's refusal,
//! [`crate::label_census::check_classes`]).

use crate::label_census::Stored;
use crate::label_table::LabelTable;
use crate::label_volume::LabelVolume;

/// A label map read from a NIfTI or NRRD file.
#[derive(Debug, Clone, PartialEq)]
pub struct LabelMap {
    /// The labels on their grid.
    pub volume: LabelVolume,
    /// The names and colours of the file itself (empty where it carries none).
    pub table: LabelTable,
    /// The file's voxel type and what its header says the values are.
    pub stored: Stored,
}
