//! How to read a training run's inputs, as the command line's flags and Python's keywords give
//! it: every field optional, `None` meaning [`InputOptions::default`]'s value. The one mapping
//! from those options to [`InputOptions`], so that the front ends cannot drift.

use crate::drawn_slices::{PlaneMode, SparseAxes};
use crate::frame_range::FrameRange;
use crate::input::{self, InputOptions};
use crate::input_kind::InputKind;
use crate::label_table::LabelTable;
use crate::manifest;
use crate::nesting::{self, NestingMode};
use crate::nifti::HeaderSpacing;
use crate::reslice::ResliceOptions;
use crate::rtstruct::RoiExtent;
use dynaslice_sequence::error::{ErrorKind, Result};
use dynaslice_sequence::sequence::Sequence;
use dynaslice_sequence::space::{Space, TimeUnit, Units};
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
        self.check_options_apply()?;
        let seq = input::read(&self.inputs, &self.options()?)?;
        nesting::apply(seq, &self.nesting.clone().unwrap_or_default())
            .map_err(|e| e.in_file(std::path::Path::new(&self.describe())))
    }

    /// Refuses an option no input reads, as a user expects of a flag that would otherwise be
    /// silently ignored: the label-map options without a NIfTI or NRRD label map among the
    /// inputs (a manifest's entries counted), `roi-extent` without an RT Structure Set.
    fn check_options_apply(&self) -> Result<()> {
        let mut kinds = Vec::new();
        for path in &self.inputs {
            match InputKind::of(path) {
                // A manifest that cannot be read is reported by the reading itself.
                Ok(InputKind::Manifest) => kinds.extend(
                    manifest::read(path)
                        .unwrap_or_default()
                        .iter()
                        .filter_map(|e| InputKind::of(&e.path).ok()),
                ),
                Ok(kind) => kinds.push(kind),
                Err(_) => {}
            }
        }
        let has = |k: InputKind| kinds.contains(&k);
        let label_map = has(InputKind::Nifti) || has(InputKind::Nrrd);
        let set = |given: bool, name: &'static str| given.then_some(name);
        let label_map_only = [
            set(self.planes.is_some(), "--planes"),
            set(self.drawn_axes.is_some(), "--drawn-axes"),
            set(self.rotated_planes.is_some(), "--rotated-planes"),
            set(self.axial_step.is_some(), "--axial-step"),
            set(self.labels.is_some(), "--labels"),
            set(self.pixel.is_some(), "--pixel"),
            set(self.header_spacing.is_some(), "--header-spacing"),
        ];
        let refuse = |option: &str, applies_to: &str| -> Result<()> {
            Err(ErrorKind::Option(format!(
                "{option} applies to {applies_to}, and {} holds none: leave it out",
                self.describe()
            ))
            .into())
        };
        if !label_map {
            if let Some(option) = label_map_only.into_iter().flatten().next() {
                return refuse(option, "label maps (NIfTI, NRRD)");
            }
        }
        if self.roi_extent.is_some() && !has(InputKind::RtStruct) {
            return refuse("--roi-extent", "DICOM RT Structure Sets");
        }
        Ok(())
    }

    /// How this spec reads its inputs, beyond the inputs and frames: every option it sets, by
    /// the command line's flag names (`labels=1,2,3; planes=sparse`), `None` where it sets none.
    /// A model records it ([`InputSpec::with_reading`] reads it back), so that a command given
    /// the input again reads it as training did.
    pub fn reading(&self) -> Option<String> {
        let mut entries: Vec<String> = Vec::new();
        let mut add = |key: &str, value: Option<String>| {
            if let Some(v) = value {
                entries.push(format!("{key}={v}"));
            }
        };
        add(
            "label-names",
            self.label_names.as_ref().map(|p| p.display().to_string()),
        );
        add("planes", self.planes.map(|v| v.to_string()));
        add("drawn-axes", self.drawn_axes.map(|v| v.to_string()));
        add("roi-extent", self.roi_extent.map(|v| v.to_string()));
        add("rotated-planes", self.rotated_planes.map(|v| v.to_string()));
        add("axial-step", self.axial_step.map(|v| v.to_string()));
        add(
            "labels",
            self.labels
                .as_ref()
                .map(|l| l.iter().map(i32::to_string).collect::<Vec<_>>().join(",")),
        );
        add("pixel", self.pixel.map(|v| v.to_string()));
        add("nesting", self.nesting.as_ref().map(|v| v.to_string()));
        add("header-spacing", self.header_spacing.map(|v| v.to_string()));
        (!entries.is_empty()).then(|| entries.join("; "))
    }

    /// The input options by the command line's flag names (without `--`): what
    /// [`InputSpec::set`] and [`InputSpec::reading`] take.
    pub const KEYS: [&'static str; 11] = [
        "frames",
        "label-names",
        "planes",
        "drawn-axes",
        "roi-extent",
        "rotated-planes",
        "axial-step",
        "labels",
        "pixel",
        "nesting",
        "header-spacing",
    ];

    /// Sets option `key` (one of [`InputSpec::KEYS`], `_` or `-`) from the command line's text
    /// of it, parsed as the flag's: the one reading of a keyword (Python's) or a record's entry.
    /// An error says what is wrong with the value (a list's item quoted).
    pub fn set(&mut self, key: &str, value: &str) -> std::result::Result<(), String> {
        fn parse<T: std::str::FromStr>(value: &str) -> std::result::Result<T, String>
        where
            T::Err: std::fmt::Display,
        {
            value.trim().parse().map_err(|e: T::Err| e.to_string())
        }
        match key.replace('_', "-").as_str() {
            "frames" => self.frames = Some(parse(value)?),
            "label-names" => self.label_names = Some(PathBuf::from(value)),
            "planes" => self.planes = Some(parse(value)?),
            "drawn-axes" => self.drawn_axes = Some(parse(value)?),
            "roi-extent" => self.roi_extent = Some(parse(value)?),
            "rotated-planes" => self.rotated_planes = Some(parse(value)?),
            "axial-step" => self.axial_step = Some(parse(value)?),
            "labels" => {
                let item = |l: &str| parse(l).map_err(|e| format!("{:?}: {e}", l.trim()));
                self.labels = Some(
                    value
                        .split(',')
                        .map(item)
                        .collect::<std::result::Result<_, _>>()?,
                )
            }
            "pixel" => self.pixel = Some(parse(value)?),
            "nesting" => self.nesting = Some(parse(value)?),
            "header-spacing" => self.header_spacing = Some(parse(value)?),
            _ => return Err(format!("{key:?} is not an input option")),
        }
        Ok(())
    }

    /// Whether option `key` (one of [`InputSpec::KEYS`]) is given.
    fn is_set(&self, key: &str) -> bool {
        match key {
            "frames" => self.frames.is_some(),
            "label-names" => self.label_names.is_some(),
            "planes" => self.planes.is_some(),
            "drawn-axes" => self.drawn_axes.is_some(),
            "roi-extent" => self.roi_extent.is_some(),
            "rotated-planes" => self.rotated_planes.is_some(),
            "axial-step" => self.axial_step.is_some(),
            "labels" => self.labels.is_some(),
            "pixel" => self.pixel.is_some(),
            "nesting" => self.nesting.is_some(),
            "header-spacing" => self.header_spacing.is_some(),
            _ => false,
        }
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
            if key == "frames" || !Self::KEYS.contains(&key) {
                return Err(format!("recorded reading {key:?} is not an input option"));
            }
            if !self.is_set(key) {
                self.set(key, value)
                    .map_err(|e| format!("recorded {key}={value}: {e}"))?;
            }
        }
        Ok(self)
    }

    /// The frame and units of the inputs' coordinates ([`input::space_of`]).
    pub fn space(&self) -> Result<(Space, Units)> {
        input::space_of(&self.inputs)
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
}
