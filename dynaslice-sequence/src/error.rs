//! The one error type of the data layer: what is wrong, and exactly where.
//!
//! Every reader and the validator report a [`DataError`]: a [`Location`] (file, line, timestep,
//! plane, class, polygon; each part present when known) and an [`ErrorKind`] saying what is wrong.
//! Readers fill in the parts they know as the error travels up, so a message reads like
//! `abdomen.csl, line 423, timestep 0 (t = 0), plane 3, class "liver" (label 5), polygon 2:
//! edges 4 and 9 intersect near (12.5, -3.25)`.

use std::fmt;
use std::path::{Path, PathBuf};

/// Where in the input a problem was found. Unknown parts are `None` and left out of the message.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct Location {
    /// The file being read.
    pub file: Option<PathBuf>,
    /// 1-based line in that file (text formats).
    pub line: Option<usize>,
    /// Index of the timestep in the sequence, and its time when known.
    pub frame: Option<(usize, Option<f64>)>,
    /// Index of the plane within its timestep.
    pub plane: Option<usize>,
    /// Class name and source label value.
    pub class: Option<(String, i32)>,
    /// Index of the polygon within the class's polygons on that plane.
    pub polygon: Option<usize>,
}

impl fmt::Display for Location {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        let mut parts: Vec<String> = Vec::new();
        if let Some(file) = &self.file {
            parts.push(file.display().to_string());
        }
        if let Some(line) = self.line {
            parts.push(format!("line {line}"));
        }
        match self.frame {
            Some((i, Some(t))) => parts.push(format!("timestep {i} (t = {t})")),
            Some((i, None)) => parts.push(format!("timestep {i}")),
            None => {}
        }
        if let Some(p) = self.plane {
            parts.push(format!("plane {p}"));
        }
        if let Some((name, label)) = &self.class {
            parts.push(format!("class \"{name}\" (label {label})"));
        }
        if let Some(p) = self.polygon {
            parts.push(format!("polygon {p}"));
        }
        if parts.is_empty() {
            f.write_str("input")
        } else {
            f.write_str(&parts.join(", "))
        }
    }
}

/// What is wrong with the input.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum ErrorKind {
    /// The file could not be opened, read or written.
    #[error("i/o error: {0}")]
    Io(#[from] std::io::Error),
    /// The path is not a regular file (a FIFO, a device, a folder): never opened for reading.
    #[error("not a regular file ({0}); inputs are read from regular files")]
    NotRegularFile(&'static str),
    /// The file is larger than its format allows this reader to take.
    #[error("too large: {0}")]
    TooLarge(String),
    /// The text does not follow the format's grammar.
    #[error("{0}")]
    Syntax(String),
    /// A count in a header disagrees with what follows it.
    #[error("{what}: the header says {declared}, the file has {found}")]
    CountMismatch {
        /// Which count.
        what: String,
        /// The declared count.
        declared: usize,
        /// The count actually present.
        found: usize,
    },
    /// A coordinate, time or axis component is NaN or infinite.
    #[error("{what} is not finite ({value})")]
    NotFinite {
        /// Which value.
        what: String,
        /// The offending value.
        value: f64,
    },
    /// The plane's in-plane axes are not orthonormal (or are degenerate).
    #[error("plane axes are not orthonormal: |u| = {u_norm}, |v| = {v_norm}, u·v = {dot}")]
    AxesNotOrthonormal {
        /// Length of u.
        u_norm: f64,
        /// Length of v.
        v_norm: f64,
        /// Dot product of u and v.
        dot: f64,
    },
    /// A plane's region of interest is empty or inverted.
    #[error("region of interest is empty: min {min:?}, max {max:?}")]
    EmptyRoi {
        /// Lower corner.
        min: [f64; 2],
        /// Upper corner.
        max: [f64; 2],
    },
    /// A polygon vertex lies outside its plane's region of interest.
    #[error("vertex {vertex} at {point:?} lies outside the plane's region of interest")]
    OutsideRoi {
        /// Vertex index.
        vertex: usize,
        /// Its plane coordinates.
        point: [f64; 2],
    },
    /// A polygon that does not bound an area.
    #[error("degenerate contour: {0}")]
    Degenerate(String),
    /// A polygon crosses itself, or two polygons of one class cross.
    #[error("contours intersect: {0}")]
    SelfIntersection(String),
    /// The sequence holds nothing to train on.
    #[error("empty data: {0}")]
    Empty(String),
    /// Timesteps out of order or repeated.
    #[error("timestep times must increase strictly: {previous} then {time}")]
    TimesNotIncreasing {
        /// Time of the previous timestep.
        previous: f64,
        /// Time of this one.
        time: f64,
    },
    /// A class index, label or name that is out of range or repeated.
    #[error("bad class: {0}")]
    BadClass(String),
    /// A class that no plane of any timestep outlines.
    #[error("class has no contour on any plane of any timestep: {0}")]
    ClassNeverContoured(String),
    /// A vertex that is not on its plane (formats that give 3D vertices).
    #[error("vertex {vertex} lies {distance} off its plane (tolerance {tolerance})")]
    OffPlane {
        /// Vertex index.
        vertex: usize,
        /// Distance to the plane.
        distance: f64,
        /// Allowed distance.
        tolerance: f64,
    },
    /// A NIfTI file that is not a label volume this reader accepts.
    #[error("NIfTI: {0}")]
    Nifti(String),
    /// A DICOM file that is not an RT Structure Set this reader accepts.
    #[error("DICOM: {0}")]
    Dicom(String),
    /// An NRRD file that is not a label map this reader accepts.
    #[error("NRRD: {0}")]
    Nrrd(String),
    /// Several inputs that cannot be combined into one sequence (time grids, frames, classes).
    #[error("inputs do not combine: {0}")]
    Combine(String),
    /// A requested label that no selected frame of the volume contains, with the labels that
    /// are there (ascending).
    #[error(
        "label {label} is absent from every selected frame; {}",
        present_labels(present)
    )]
    LabelAbsent {
        /// The label asked for.
        label: i32,
        /// The labels the selected frames hold.
        present: Vec<i32>,
    },
    /// A file whose name and contents match no input format.
    #[error(
        "not a kind of input DynaSlice reads (expected .json, .csl, .seq, .cslseq, .nii, \
         .nii.gz, .nrrd, .nhdr, .seg.nrrd, or a DICOM RT Structure Set)"
    )]
    UnsupportedInput,
    /// An invalid option value (frame range, plane counts, ...).
    #[error("invalid option: {0}")]
    Option(String),
    /// A label map with more classes than a model holds: the count and what the values look
    /// like (dynaslice-data's `label_census`).
    #[error("too many classes: {0}")]
    TooManyClasses(String),
}

/// The labels a volume holds, for a message: all of them, or the first 20 and a count.
fn present_labels(present: &[i32]) -> String {
    if present.is_empty() {
        return "the selected frames hold no label".into();
    }
    let shown: Vec<String> = present.iter().take(20).map(i32::to_string).collect();
    let more = present.len().saturating_sub(20);
    let more = if more > 0 {
        format!(" and {more} more")
    } else {
        String::new()
    };
    format!("the labels there are {}{more}", shown.join(", "))
}

/// An input problem with its location. See the [module docs](self).
#[derive(Debug, thiserror::Error)]
#[error("{location}: {kind}")]
pub struct DataError {
    /// Where (boxed to keep `Result`s small on the happy path).
    pub location: Box<Location>,
    /// What.
    pub kind: ErrorKind,
}

impl DataError {
    /// An error at an unknown location; callers add what they know with the `at_*`/`in_*` methods.
    pub fn new(kind: ErrorKind) -> Self {
        DataError {
            location: Box::default(),
            kind,
        }
    }

    /// Sets the file (keeps an inner file if one was already set).
    pub fn in_file(mut self, file: &Path) -> Self {
        self.location.file.get_or_insert_with(|| file.to_path_buf());
        self
    }

    /// Sets the line (keeps an inner one).
    pub fn at_line(mut self, line: usize) -> Self {
        self.location.line.get_or_insert(line);
        self
    }

    /// Sets the timestep index and time (keeps an inner one).
    pub fn at_frame(mut self, frame: usize, time: Option<f64>) -> Self {
        self.location.frame.get_or_insert((frame, time));
        self
    }

    /// Sets the plane index (keeps an inner one).
    pub fn at_plane(mut self, plane: usize) -> Self {
        self.location.plane.get_or_insert(plane);
        self
    }

    /// Sets the class (keeps an inner one).
    pub fn for_class(mut self, name: &str, label: i32) -> Self {
        self.location
            .class
            .get_or_insert_with(|| (name.to_string(), label));
        self
    }

    /// Sets the polygon index (keeps an inner one).
    pub fn at_polygon(mut self, polygon: usize) -> Self {
        self.location.polygon.get_or_insert(polygon);
        self
    }
}

impl From<ErrorKind> for DataError {
    fn from(kind: ErrorKind) -> Self {
        DataError::new(kind)
    }
}

/// Bytes of a file's own text an error message quotes at most.
pub const EXCERPT_BYTES: usize = 80;

/// `text` for quoting in a message: whole when short, else its first [`EXCERPT_BYTES`] (on a
/// character boundary) and how long it is, so a multi-megabyte line is never echoed whole.
pub fn excerpt(text: &str) -> String {
    if text.len() <= EXCERPT_BYTES {
        return text.to_string();
    }
    let mut end = EXCERPT_BYTES;
    while !text.is_char_boundary(end) {
        end -= 1;
    }
    format!("{}… ({} bytes)", &text[..end], text.len())
}

/// Result alias of the data layer.
pub type Result<T> = std::result::Result<T, DataError>;

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn excerpts_are_bounded_and_cut_on_characters() {
        assert_eq!(excerpt("short"), "short");
        let long = "é".repeat(4 << 20);
        let e = excerpt(&long);
        assert!(e.len() < EXCERPT_BYTES + 40, "{e}");
        assert!(e.ends_with(&format!("… ({} bytes)", long.len())), "{e}");
    }
}
