//! One table of the input options (`--frames`, `--planes`, …), as dynaslice-train's `flags`
//! keeps the training options: each option's flag, value name, help, default and allowed
//! values, in the order `--help` lists them. [`crate::input_spec::InputSpec`] sets, records and
//! checks its options by these rows, so Python's keywords and a model's recorded reading are
//! refused with the words the command line uses; the command line makes its input arguments of
//! them (dynaslice-cli's `input.rs`). An option is one row here and one field of `InputSpec`.

use crate::input::InputOptions;
use crate::limit::Limit;
use crate::nesting::NestingMode;
use crate::reslice::ResliceOptions;
use std::fmt;

/// Most rotated planes a label map is resliced into (the paper uses 20).
pub const MAX_ROTATED_PLANES: usize = 1000;

/// Which inputs read an option: given with none of them among the inputs, it is refused, as a
/// flag that would otherwise be silently ignored.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum AppliesTo {
    /// Every input.
    Every,
    /// NIfTI and NRRD label maps.
    LabelMaps,
    /// DICOM RT Structure Sets.
    RtStructs,
}

/// An input option's default, as its help shows it.
#[derive(Clone, Copy, Debug)]
pub enum Shown {
    /// None shown: the help's prose says what happens without the option.
    Nothing,
    /// The reader's own default, shown as it displays.
    Reader(fn() -> String),
    /// Words, where the default depends on the command.
    Words(&'static str),
}

impl fmt::Display for Shown {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            Shown::Nothing => Ok(()),
            Shown::Reader(of) => f.write_str(&of()),
            Shown::Words(w) => f.write_str(w),
        }
    }
}

/// One input option.
#[derive(Clone, Copy, Debug)]
pub struct InputFlag {
    /// The command line's flag without `--`, and the key of a model's recorded reading;
    /// Python's keyword has `_` for `-`.
    pub name: &'static str,
    /// The placeholder of the value in the help.
    pub value_name: &'static str,
    /// The summary the short help (`-h`) shows, without a final period.
    pub help: &'static str,
    /// The whole text the long help (`--help`) shows, where more than the summary.
    pub long: Option<&'static str>,
    /// The default the help shows.
    pub default: Shown,
    /// The allowed values of a number.
    pub limit: Option<Limit>,
    /// Comma-separated items, and given again adds items (`--labels 1,2 --labels 3`).
    pub list: bool,
    /// The inputs that read it.
    pub applies_to: AppliesTo,
}

impl InputFlag {
    /// The summary, with the default where one is shown.
    pub fn short_help(&self) -> String {
        self.with_default(self.help)
    }

    /// The whole text, with the default where one is shown.
    pub fn long_help(&self) -> String {
        self.with_default(self.long.unwrap_or(self.help))
    }

    fn with_default(&self, text: &str) -> String {
        match self.default.to_string().as_str() {
            "" => text.to_string(),
            d => format!("{text} [default: {d}]"),
        }
    }

    /// A whole-number option's value from its text, checked against its limit.
    pub fn whole(&self, text: &str) -> Result<usize, String> {
        let limit = self.limit.unwrap_or(Limit::count(0, usize::MAX as u64));
        // The limits are at most `usize::MAX`.
        limit.whole(text).map(|v| v as usize)
    }

    /// A real option's value from its text, checked against its limit.
    pub fn real(&self, text: &str) -> Result<f64, String> {
        let limit = self
            .limit
            .unwrap_or(Limit::between(f64::NEG_INFINITY, f64::INFINITY));
        limit.real(text)
    }
}

/// The input option named `name` (its flag without `--`; `_` for `-` too).
pub fn find(name: &str) -> Option<&'static InputFlag> {
    let name = name.replace('_', "-");
    INPUT_FLAGS.iter().find(|f| f.name == name)
}

const fn row(
    name: &'static str,
    value_name: &'static str,
    help: &'static str,
    long: Option<&'static str>,
    default: Shown,
    applies_to: AppliesTo,
) -> InputFlag {
    InputFlag {
        name,
        value_name,
        help,
        long,
        default,
        limit: None,
        list: false,
        applies_to,
    }
}

/// Every input option, in the order of `--help`.
pub const INPUT_FLAGS: [InputFlag; 11] = [
    row(
        "frames",
        "A:B:STEP",
        "Frames to use, A:B:STEP",
        Some(
            "Frames to use, A:B:STEP (Python slice; e.g. 0:37:4 = every 4th of 37; an end past \
             the last frame is cut there, with a warning)",
        ),
        Shown::Words("0:, or as the model was trained where a command takes a model"),
        AppliesTo::Every,
    ),
    row(
        "label-names",
        "FILE",
        "Label-name table (\"<label> <name>\" per line) for inputs that carry label numbers only",
        None,
        Shown::Nothing,
        AppliesTo::Every,
    ),
    row(
        "planes",
        "auto|slices|reslice|sparse",
        "Label maps: how they become planes",
        Some(
            "Label maps: how they become planes. `slices`: every slice of the image as drawn \
             (cine short-axis stacks, long-axis views); `sparse`: only the slices that carry \
             labels, along any voxel axis, the rest unobserved (a few slices drawn in Slicer or \
             ITK-SNAP); `reslice`: the paper's protocol for dense segmentations; `auto`: slices \
             for 3 slices or fewer or slices at least 2× thicker than the pixels, sparse for \
             sparsely drawn maps, reslice otherwise.",
        ),
        Shown::Reader(|| InputOptions::default().planes.to_string()),
        AppliesTo::LabelMaps,
    ),
    row(
        "drawn-axes",
        "auto|AXES",
        "Sparsely drawn label maps: the voxel axes drawn on",
        Some(
            "Sparsely drawn label maps: the voxel axes drawn on (`auto` detects them; `k`, \
             `i,k`, …)",
        ),
        Shown::Reader(|| InputOptions::default().sparse_axes.to_string()),
        AppliesTo::LabelMaps,
    ),
    row(
        "roi-extent",
        "file|own",
        "RT Structure Sets: where an ROI without a contour on a plane is absent",
        Some(
            "RT Structure Sets: `file` takes each ROI as contoured on every contour plane of \
             its file (absent where it has no contour); `own` only between its own first and \
             last contour.",
        ),
        Shown::Reader(|| InputOptions::default().roi_extent.to_string()),
        AppliesTo::RtStructs,
    ),
    InputFlag {
        limit: Some(Limit::count(0, MAX_ROTATED_PLANES as u64)),
        ..row(
            "rotated-planes",
            "ROTATED_PLANES",
            "Label maps: planes rotated about the volume's z axis through the labelled region's \
             centre",
            None,
            Shown::Reader(|| ResliceOptions::default().rotated.to_string()),
            AppliesTo::LabelMaps,
        )
    },
    InputFlag {
        limit: Some(Limit::count(0, usize::MAX as u64)),
        ..row(
            "axial-step",
            "AXIAL_STEP",
            "Label maps: use every k-th axial slice of the labelled range (0: none)",
            None,
            Shown::Reader(|| ResliceOptions::default().axial_step.to_string()),
            AppliesTo::LabelMaps,
        )
    },
    InputFlag {
        list: true,
        ..row(
            "labels",
            "LABELS",
            "Label maps: label values to reconstruct, one class each (default: every nonzero \
             label)",
            None,
            Shown::Nothing,
            AppliesTo::LabelMaps,
        )
    },
    InputFlag {
        limit: Some(Limit::positive(f64::INFINITY)),
        ..row(
            "pixel",
            "PIXEL",
            "Label maps: in-plane sampling step of the resliced planes, world units",
            Some(
                "Label maps: in-plane sampling step of the resliced planes, world units \
                 (default: half the smallest voxel spacing, or the labelled box's longest \
                 diagonal / 1536 where coarser)",
            ),
            Shown::Nothing,
            AppliesTo::LabelMaps,
        )
    },
    row(
        "nesting",
        "auto|off|INNER:OUTER,…",
        "Classes drawn one inside another: found, named, or trained as drawn",
        Some(
            "Classes drawn one inside another (an endocardium inside its epicardium, a GTV \
             inside its organ): `auto` finds them from the contours and trains the outer as its \
             region minus the inner's, recomposed in volumes and RT Structure Sets; `off` \
             trains every class as drawn; `INNER:OUTER,…` (labels) names the pairs.",
        ),
        Shown::Reader(|| NestingMode::default().to_string()),
        AppliesTo::Every,
    ),
    row(
        "header-spacing",
        "auto|sform|qform|pixdim",
        "NIfTI label maps: the voxel spacing where the header disagrees with itself",
        Some(
            "NIfTI label maps: the voxel spacing where the header disagrees with itself. \
             `auto`: the sform where sform_code > 0, else the qform (nibabel's rule), warning \
             where the sform's spacing and pixdim differ; `sform`; `qform`; `pixdim`: the \
             sform's orientation and origin with pixdim's spacing.",
        ),
        Shown::Reader(|| InputOptions::default().header_spacing.to_string()),
        AppliesTo::LabelMaps,
    ),
];

#[cfg(test)]
mod tests {
    use super::*;

    /// The help ends with the default where one is shown, as the training options' does.
    #[test]
    fn the_help_ends_with_the_default() {
        for f in &INPUT_FLAGS {
            assert!(!f.help.ends_with('.'), "{}", f.name);
            if !matches!(f.default, Shown::Nothing) {
                let default = format!(" [default: {}]", f.default);
                assert!(f.short_help().ends_with(&default), "{}", f.name);
                assert!(f.long_help().ends_with(&default), "{}", f.name);
            }
        }
        let planes = find("planes").unwrap();
        assert!(planes
            .long_help()
            .ends_with("reslice otherwise. [default: auto]"));
        assert_eq!(
            planes.short_help(),
            "Label maps: how they become planes [default: auto]"
        );
        assert_eq!(
            find("rotated_planes").map(|f| f.name),
            Some("rotated-planes")
        );
        assert!(find("colour").is_none());
    }
}
