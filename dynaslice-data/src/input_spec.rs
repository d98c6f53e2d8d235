//! How to read a training run's inputs, as the command line's flags and Python's keywords give
//! it: every field optional, `None` meaning [`InputOptions::default`]'s value. The one mapping
//! from those options to [`InputOptions`], so that the front ends cannot drift. The options'
//! names, limits and the inputs they apply to are the rows of [`crate::input_flags`].

use crate::drawn_slices::{PlaneMode, SparseAxes};
use crate::frame_range::FrameRange;
use crate::input::{self, InputOptions};
use crate::input_flags::{self, AppliesTo, INPUT_FLAGS};
use crate::input_kind::InputKind;
use crate::label_table::LabelTable;
use crate::nesting::{self, NestingMode};
use crate::nifti::HeaderSpacing;
use crate::reslice::ResliceOptions;
use crate::rtstruct::RoiExtent;
use dynaslice_sequence::error::{ErrorKind, Result};
use dynaslice_sequence::sequence::Sequence;
use dynaslice_sequence::space::{Space, TimeUnit, Units};
use std::path::PathBuf;

/// The input options of `dynaslice train` and `dynaslice.train`, by the same names: one field
/// per row of [`INPUT_FLAGS`].
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
        self.read_opened(&input::open(&self.inputs)?)
    }

    /// [`InputSpec::read`], with the frame and units of the inputs' coordinates
    /// ([`input::space_of`]): each manifest among the inputs parsed once for the options'
    /// check, the reading and the frame.
    pub fn read_with_space(&self) -> Result<(Sequence, Space, Units)> {
        let inputs = input::open(&self.inputs)?;
        let seq = self.read_opened(&inputs)?;
        let (space, units) = input::space_of(&inputs)?;
        Ok((seq, space, units))
    }

    fn read_opened(&self, inputs: &[input::Opened]) -> Result<Sequence> {
        self.check_options_apply(inputs)?;
        let seq = input::read_opened(inputs, &self.options()?)?;
        nesting::apply(seq, &self.nesting.clone().unwrap_or_default())
            .map_err(|e| e.in_file(std::path::Path::new(&self.describe())))
    }

    /// Refuses an option no input reads, as a user expects of a flag that would otherwise be
    /// silently ignored: the label-map options without a NIfTI or NRRD label map among the
    /// inputs (a manifest's entries counted), `roi-extent` without an RT Structure Set.
    fn check_options_apply(&self, inputs: &[input::Opened]) -> Result<()> {
        let mut kinds = Vec::new();
        for input in inputs {
            match input.kind {
                InputKind::Manifest => kinds.extend(
                    input
                        .entries
                        .iter()
                        .filter_map(|e| InputKind::of(&e.path).ok()),
                ),
                kind => kinds.push(kind),
            }
        }
        let has = |k: InputKind| kinds.contains(&k);
        let label_map = has(InputKind::Nifti) || has(InputKind::Nrrd);
        let given = |to: AppliesTo| {
            INPUT_FLAGS
                .iter()
                .find(|f| f.applies_to == to && self.is_set(f.name))
                .map(|f| format!("--{}", f.name))
        };
        let refuse = |option: &str, applies_to: &str| -> Result<()> {
            Err(ErrorKind::Option(format!(
                "{option} applies to {applies_to}, and {} holds none: leave it out",
                self.describe()
            ))
            .into())
        };
        if !label_map {
            if let Some(option) = given(AppliesTo::LabelMaps) {
                return refuse(&option, "label maps (NIfTI, NRRD)");
            }
        }
        if !has(InputKind::RtStruct) {
            if let Some(option) = given(AppliesTo::RtStructs) {
                return refuse(&option, "DICOM RT Structure Sets");
            }
        }
        Ok(())
    }

    /// How this spec reads its inputs, beyond the inputs and frames: every option it sets, by
    /// the command line's flag names (`labels=1,2,3; planes=sparse`), `None` where it sets none.
    /// A model records it ([`InputSpec::with_reading`] reads it back), so that a command given
    /// the input again reads it as training did.
    pub fn reading(&self) -> Option<String> {
        let entries: Vec<String> = INPUT_FLAGS
            .iter()
            // `frames` is recorded on its own (the run record's `frames`).
            .filter(|f| f.name != "frames")
            .filter_map(|f| Some(format!("{}={}", f.name, self.text_of(f.name)?)))
            .collect();
        (!entries.is_empty()).then(|| entries.join("; "))
    }

    /// Sets option `key` (a row of [`INPUT_FLAGS`], `_` or `-`) from the command line's text of
    /// it, parsed and checked as the flag's (numbers against the row's limit): the one reading
    /// of a flag (the command line's value parsers call it), a keyword (Python's) or a record's
    /// entry. An error says what is wrong with the value (a list's item quoted) in the command
    /// line's words.
    pub fn set(&mut self, key: &str, value: &str) -> std::result::Result<(), String> {
        fn parse<T: std::str::FromStr>(value: &str) -> std::result::Result<T, String>
        where
            T::Err: std::fmt::Display,
        {
            value.trim().parse().map_err(|e: T::Err| e.to_string())
        }
        let not_an_option = || format!("{key:?} is not an input option");
        let flag = input_flags::find(key).ok_or_else(not_an_option)?;
        match flag.name {
            "frames" => self.frames = Some(parse(value)?),
            "label-names" if value.is_empty() => return Err("an empty path".into()),
            "label-names" => self.label_names = Some(PathBuf::from(value)),
            "planes" => self.planes = Some(parse(value)?),
            "drawn-axes" => self.drawn_axes = Some(parse(value)?),
            "roi-extent" => self.roi_extent = Some(parse(value)?),
            "rotated-planes" => self.rotated_planes = Some(flag.whole(value)?),
            "axial-step" => self.axial_step = Some(flag.whole(value)?),
            "labels" => {
                let item = |l: &str| parse(l).map_err(|e| format!("{:?}: {e}", l.trim()));
                self.labels = Some(
                    value
                        .split(',')
                        .map(item)
                        .collect::<std::result::Result<_, _>>()?,
                )
            }
            "pixel" => self.pixel = Some(flag.real(value)?),
            "nesting" => self.nesting = Some(parse(value)?),
            "header-spacing" => self.header_spacing = Some(parse(value)?),
            _ => return Err(not_an_option()),
        }
        Ok(())
    }

    /// Option `name`'s value (a row of [`INPUT_FLAGS`]) as [`InputSpec::set`] reads it, `None`
    /// where it is not given.
    fn text_of(&self, name: &str) -> Option<String> {
        fn shown<T: ToString>(v: &Option<T>) -> Option<String> {
            v.as_ref().map(T::to_string)
        }
        match name {
            "frames" => shown(&self.frames),
            "label-names" => self.label_names.as_ref().map(|p| p.display().to_string()),
            "planes" => shown(&self.planes),
            "drawn-axes" => shown(&self.drawn_axes),
            "roi-extent" => shown(&self.roi_extent),
            "rotated-planes" => shown(&self.rotated_planes),
            "axial-step" => shown(&self.axial_step),
            "labels" => self
                .labels
                .as_ref()
                .map(|l| l.iter().map(i32::to_string).collect::<Vec<_>>().join(",")),
            "pixel" => shown(&self.pixel),
            "nesting" => shown(&self.nesting),
            "header-spacing" => shown(&self.header_spacing),
            _ => None,
        }
    }

    /// Whether option `name` (a row of [`INPUT_FLAGS`]) is given.
    fn is_set(&self, name: &str) -> bool {
        self.text_of(name).is_some()
    }

    /// This spec with every option it leaves unset taken from `reading` ([`InputSpec::reading`]'s
    /// text): what the user gives wins, what they leave out is read as the model's training
    /// read it. An entry that does not parse is an error naming it.
    pub fn with_reading(mut self, reading: &str) -> std::result::Result<InputSpec, String> {
        for entry in reading.split("; ").filter(|e| !e.trim().is_empty()) {
            let (key, value) = entry
                .split_once('=')
                .ok_or_else(|| format!("recorded reading {entry:?} is not KEY=VALUE"))?;
            let (key, value) = (key.trim(), value.trim());
            // `frames` is recorded on its own (the run record's `frames`), not in the reading.
            if key == "frames" || input_flags::find(key).is_none_or(|f| f.name != key) {
                return Err(format!("recorded reading {key:?} is not an input option"));
            }
            if !self.is_set(key) {
                self.set(key, value)
                    .map_err(|e| format!("recorded {key}={value}: {e}"))?;
            }
        }
        Ok(self)
    }

    /// The unit of the inputs' times ([`input::time_unit_of`]).
    pub fn time_unit(&self) -> Result<TimeUnit> {
        input::time_unit_of(&self.inputs)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_reading_round_trips_and_what_is_given_wins() {
        let trained = InputSpec {
            inputs: vec!["seg.nii.gz".into()],
            labels: Some(vec![1, 2, 3]),
            planes: Some(PlaneMode::Sparse),
            drawn_axes: Some("i,k".parse().unwrap()),
            roi_extent: Some(RoiExtent::Own),
            rotated_planes: Some(8),
            axial_step: Some(2),
            pixel: Some(0.75),
            nesting: Some("2:1".parse().unwrap()),
            header_spacing: Some(HeaderSpacing::Pixdim),
            label_names: Some("names.txt".into()),
            ..InputSpec::default()
        };
        let text = trained.reading().unwrap();
        assert!(
            text.starts_with("label-names=names.txt; planes=sparse"),
            "{text}"
        );
        let again = InputSpec {
            inputs: vec!["seg.nii.gz".into()],
            ..InputSpec::default()
        }
        .with_reading(&text)
        .unwrap();
        assert_eq!(again, trained);
        // What the user gives wins over the record.
        let given = InputSpec {
            labels: Some(vec![4]),
            ..InputSpec::default()
        }
        .with_reading(&text)
        .unwrap();
        assert_eq!(given.labels, Some(vec![4]));
        assert_eq!(given.planes, Some(PlaneMode::Sparse));
        assert_eq!(InputSpec::default().reading(), None);
        let e = InputSpec::default()
            .with_reading("planes=flat")
            .unwrap_err();
        assert!(e.contains("recorded planes=flat"), "{e}");
        let e = InputSpec::default().with_reading("colour=red").unwrap_err();
        assert!(e.contains("not an input option"), "{e}");
        // Python's keywords: underscores, and a list's bad item quoted.
        let mut spec = InputSpec::default();
        spec.set("rotated_planes", "8").unwrap();
        assert_eq!(spec.rotated_planes, Some(8));
        assert_eq!(
            spec.set("labels", "1,x").unwrap_err().split(':').next(),
            Some("\"x\"")
        );
        assert!(spec.set("colour", "red").is_err());
    }

    /// What the command line refuses (its value parsers call `set`) is refused here, for
    /// Python's keywords and a record's entries, in the same words.
    #[test]
    fn out_of_range_values_are_refused_as_the_command_line_does() {
        let mut spec = InputSpec::default();
        for (key, value, message) in [
            (
                "rotated_planes",
                "100000",
                "out of range; allowed: a whole number from 0 to 1000",
            ),
            (
                "rotated-planes",
                "-1",
                "out of range; allowed: a whole number from 0 to 1000",
            ),
            (
                "rotated_planes",
                "2.5",
                "not a whole number; allowed: a whole number from 0 to 1000",
            ),
            (
                "axial_step",
                "-2",
                "out of range; allowed: a whole number from 0 to 18446744073709551615",
            ),
            ("pixel", "-1", "out of range; allowed: a finite number > 0"),
            ("pixel", "0", "out of range; allowed: a finite number > 0"),
            (
                "pixel",
                "inf",
                "not a finite number; allowed: a finite number > 0",
            ),
            ("pixel", "x", "not a number; allowed: a finite number > 0"),
            ("label_names", "", "an empty path"),
        ] {
            assert_eq!(
                spec.set(key, value),
                Err(message.to_string()),
                "{key}={value}"
            );
        }
        assert_eq!(spec, InputSpec::default(), "nothing refused is set");
        spec.set("rotated_planes", "1000").unwrap();
        spec.set("axial_step", "0").unwrap();
        spec.set("pixel", "0.25").unwrap();
        assert_eq!(
            (spec.rotated_planes, spec.axial_step, spec.pixel),
            (Some(1000), Some(0), Some(0.25))
        );
        let e = InputSpec::default()
            .with_reading("rotated-planes=5000")
            .unwrap_err();
        assert!(e.contains("out of range"), "{e}");
    }

    /// Every row of the table is a field: set from its text, recorded, and read back.
    #[test]
    fn every_option_of_the_table_is_set_and_recorded() {
        let texts = [
            ("frames", "0:5:2"),
            ("label-names", "names.txt"),
            ("planes", "reslice"),
            ("drawn-axes", "k"),
            ("roi-extent", "own"),
            ("rotated-planes", "3"),
            ("axial-step", "0"),
            ("labels", "4,5"),
            ("pixel", "0.5"),
            ("nesting", "off"),
            ("header-spacing", "qform"),
        ];
        let names: Vec<&str> = INPUT_FLAGS.iter().map(|f| f.name).collect();
        assert_eq!(names, texts.map(|t| t.0));
        let mut spec = InputSpec::default();
        for (key, text) in texts {
            assert!(!spec.is_set(key), "{key}");
            spec.set(key, text).unwrap();
            assert!(spec.is_set(key), "{key}");
        }
        let again = InputSpec {
            frames: spec.frames,
            ..InputSpec::default()
        }
        .with_reading(&spec.reading().unwrap())
        .unwrap();
        assert_eq!(again, spec);
    }
}
