//! Coordinate frames and length units: what an input's coordinates mean, recorded in the
//! model so that every output defaults to the input's own frame and states its units.
//!
//! | input | [`Space`] | [`Units`] |
//! |---|---|---|
//! | DICOM RT Structure Set, NRRD / `.seg.nrrd` | LPS | mm |
//! | NIfTI | RAS | mm |
//! | `.csl`, native JSON, the synthetic benchmark | RAS (the file's own coordinates, unchanged) | none stated |

use std::fmt;
use std::str::FromStr;

/// A patient coordinate frame: what a file's coordinates mean, and what a model's input came
/// in (outputs default to it).
///
/// Our world is RAS; [`Space::Lps`] (the default) negates x and y, a rotation by 180° about z,
/// so triangle winding and outward normals stay outward. LPS is what 3D Slicer assumes for a
/// model file without a tag and what ITK-based tools use, so the default lands on the label
/// volume in Slicer with or without the tag; RAS suits tools that place meshes in NIfTI world
/// coordinates directly (e.g. nibabel, FreeSurfer surfaces).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Hash)]
pub enum Space {
    /// Right, anterior, superior: our world frame, unchanged.
    Ras,
    /// Left, posterior, superior: x and y negated (DICOM's and ITK's patient frame).
    #[default]
    Lps,
}

impl Space {
    /// Both frames.
    pub const ALL: [Space; 2] = [Space::Ras, Space::Lps];

    /// The frame's name as the file tags spell it: `RAS` or `LPS`.
    pub fn name(self) -> &'static str {
        match self {
            Space::Ras => "RAS",
            Space::Lps => "LPS",
        }
    }

    /// The tag 3D Slicer looks for in headers and comments: `SPACE=RAS` or `SPACE=LPS`.
    pub fn tag(self) -> String {
        format!("SPACE={}", self.name())
    }

    /// A point or vector of our RAS world in this frame. The map is its own inverse, so it also
    /// takes this frame's coordinates back to RAS.
    #[inline]
    pub fn from_ras(self, p: [f32; 3]) -> [f32; 3] {
        match self {
            Space::Ras => p,
            Space::Lps => [-p[0], -p[1], p[2]],
        }
    }

    /// A point or vector of this frame in our RAS world (the same map as [`Space::from_ras`]).
    #[inline]
    pub fn to_ras(self, p: [f32; 3]) -> [f32; 3] {
        self.from_ras(p)
    }

    /// The frame a header or comment names, by 3D Slicer's rule: the first of `SPACE=RAS`,
    /// `SPACE=LPS` found as a substring (RAS checked first, as Slicer does); `None` when neither.
    pub fn find_tag(text: &[u8]) -> Option<Space> {
        let has = |needle: &[u8]| text.windows(needle.len()).any(|w| w == needle);
        if has(b"SPACE=RAS") {
            Some(Space::Ras)
        } else if has(b"SPACE=LPS") {
            Some(Space::Lps)
        } else {
            None
        }
    }
}

impl fmt::Display for Space {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(match self {
            Space::Ras => "ras",
            Space::Lps => "lps",
        })
    }
}

impl FromStr for Space {
    type Err = String;

    /// `ras` or `lps`, case-insensitive.
    fn from_str(s: &str) -> Result<Space, String> {
        match s.to_ascii_lowercase().as_str() {
            "ras" => Ok(Space::Ras),
            "lps" => Ok(Space::Lps),
            _ => Err(format!("unknown coordinate frame {s:?}; use ras or lps")),
        }
    }
}

impl Space {
    /// The model metadata key recording the input's frame ([`Space::name`] as its value).
    pub const METADATA_KEY: &'static str = "space";

    /// The frame a metadata value names (`RAS` or `LPS`).
    pub fn from_name(name: &str) -> Option<Space> {
        name.trim().parse().ok()
    }
}

/// The length unit of an input's coordinates.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum Units {
    /// Millimetres: DICOM, NIfTI and NRRD patient coordinates.
    Millimetres,
    /// Whatever the file's numbers are (`.csl`, native JSON): no unit is stated.
    Plain,
}

impl Units {
    /// The model metadata key recording the input's units ([`Units::name`] as its value).
    pub const METADATA_KEY: &'static str = "units";

    /// `mm` or `none`.
    pub fn name(self) -> &'static str {
        match self {
            Units::Millimetres => "mm",
            Units::Plain => "none",
        }
    }

    /// The units a metadata value names.
    pub fn from_name(name: &str) -> Option<Units> {
        match name.trim() {
            "mm" => Some(Units::Millimetres),
            "none" => Some(Units::Plain),
            _ => None,
        }
    }

    /// A length's unit for display: `mm`, or `units` where none is stated.
    pub fn length(self) -> &'static str {
        match self {
            Units::Millimetres => "mm",
            Units::Plain => "units",
        }
    }

    /// A volume's unit for display: `mL`, or `units³`.
    pub fn volume(self) -> &'static str {
        match self {
            Units::Millimetres => "mL",
            Units::Plain => "units³",
        }
    }

    /// A volume in the world's length unit cubed, in [`Units::volume`]'s unit (mm³ / 1000 =
    /// mL).
    pub fn from_world_volume(self, v: f64) -> f64 {
        match self {
            Units::Millimetres => v / 1000.0,
            Units::Plain => v,
        }
    }
}

/// The unit of an input's times, which the model records and every output labels its time
/// axis with.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum TimeUnit {
    /// Seconds: a NIfTI's `pixdim[4]` and `toffset` with `xyzt_units` in seconds.
    Seconds,
    /// Milliseconds (`xyzt_units`), as cine MRI trigger times are often given.
    Milliseconds,
    /// Microseconds (`xyzt_units`).
    Microseconds,
    /// A sequence manifest's own times (`<time> <path>` lines): a trigger time, a breathing
    /// phase in %, whatever the user wrote.
    Manifest,
    /// No unit stated (a NIfTI without one, NRRD, `.csl`, native JSON).
    Plain,
}

impl TimeUnit {
    /// The model metadata key recording the input's time unit ([`TimeUnit::name`]).
    pub const METADATA_KEY: &'static str = "time_unit";

    /// Every unit, in [`TimeUnit::name`]'s order.
    pub const ALL: [TimeUnit; 5] = [
        TimeUnit::Seconds,
        TimeUnit::Milliseconds,
        TimeUnit::Microseconds,
        TimeUnit::Manifest,
        TimeUnit::Plain,
    ];

    /// `s`, `ms`, `us`, `manifest` or `none`.
    pub fn name(self) -> &'static str {
        match self {
            TimeUnit::Seconds => "s",
            TimeUnit::Milliseconds => "ms",
            TimeUnit::Microseconds => "us",
            TimeUnit::Manifest => "manifest",
            TimeUnit::Plain => "none",
        }
    }

    /// The unit a metadata value names.
    pub fn from_name(name: &str) -> Option<TimeUnit> {
        TimeUnit::ALL.into_iter().find(|u| u.name() == name.trim())
    }

    /// The time axis's name for display: `time (s)`, `time (ms)`, `time (µs)`,
    /// `time (manifest)`, or `time`.
    pub fn axis(self) -> &'static str {
        match self {
            TimeUnit::Seconds => "time (s)",
            TimeUnit::Milliseconds => "time (ms)",
            TimeUnit::Microseconds => "time (µs)",
            TimeUnit::Manifest => "time (manifest)",
            TimeUnit::Plain => "time",
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn names_round_trip() {
        for s in Space::ALL {
            assert_eq!(Space::from_name(s.name()), Some(s));
        }
        for u in [Units::Millimetres, Units::Plain] {
            assert_eq!(Units::from_name(u.name()), Some(u));
        }
        for u in TimeUnit::ALL {
            assert_eq!(TimeUnit::from_name(u.name()), Some(u));
        }
        assert_eq!(Space::from_name("xyz"), None);
        assert_eq!(TimeUnit::from_name("min"), None);
    }
}
