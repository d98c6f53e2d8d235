//! Opening a model file (.dsm): the one way every front end reads a model, with what the file
//! records about its input.

use crate::run_record::RunRecord;
use anyhow::{anyhow, bail, Context, Result};
use dynaslice_core::{Model, ModelBytes, OwnedModel};
use dynaslice_sequence::{palette, ClassInfo, Space, Units};
use std::path::{Path, PathBuf};

/// A model file read from disk and validated, with its metadata's [`RunRecord`]: both once, at
/// open.
pub struct ModelFile {
    /// Validated once, by [`ModelFile::open`] or [`ModelFile::from_bytes`].
    owned: OwnedModel,
    record: RunRecord,
    path: PathBuf,
}

impl ModelFile {
    /// Reads and validates the model file at `path`; every error names the file. Only a
    /// regular file is opened (a FIFO would block the open), and its size is bounded by the
    /// largest model the format allows ([`ModelBytes::read`]).
    pub fn open(path: &Path) -> Result<ModelFile> {
        // The one rule of every reader: regular files only, checked before opening.
        dynaslice_sequence::input_file::regular_file(path)
            .map_err(|e| anyhow!("cannot read model {}: {}", path.display(), e.kind))?;
        let bytes = ModelBytes::read(path)
            .with_context(|| format!("cannot read model {}", path.display()))?;
        ModelFile::from_bytes(bytes, path)
    }

    /// Validates model `bytes` that came from `source` (named in errors) and reads its run
    /// record. A malformed metadata line does not make the model unusable: it is reported as a
    /// warning and its field read as not recorded ([`RunRecord::parse_lossy`]).
    pub fn from_bytes(bytes: ModelBytes, source: &Path) -> Result<ModelFile> {
        let owned = OwnedModel::new(bytes).map_err(|e| anyhow!("{}: {e}", source.display()))?;
        let (record, problems) = RunRecord::parse_lossy(owned.model().metadata());
        for p in problems {
            log::warn!("{}: metadata {p}; read as not recorded", source.display());
        }
        Ok(ModelFile {
            owned,
            record,
            path: source.to_path_buf(),
        })
    }

    /// What the model's metadata records of the run that trained it.
    pub fn record(&self) -> &RunRecord {
        &self.record
    }

    /// The model (a view validated at open: free to call).
    pub fn model(&self) -> Model<'_> {
        *self.owned.model()
    }

    /// The file's bytes.
    pub fn bytes(&self) -> &ModelBytes {
        self.owned.bytes()
    }

    /// Where the model came from.
    pub fn path(&self) -> &Path {
        &self.path
    }

    /// The model's classes in channel order, each with the display colour its input had where
    /// the model file records one (`class_colors` in its metadata), else `None`: pass them to
    /// [`palette::class_color`] with the class's index. A malformed `class_colors` line was
    /// reported at open; models written before the line existed have no colours.
    pub fn classes(&self) -> Vec<ClassInfo> {
        let model = self.model();
        let recorded = self.record.channel_colors(&model);
        model
            .classes()
            .zip(recorded)
            .map(|(c, color)| ClassInfo {
                name: c.name.to_string(),
                label: c.label,
                color,
            })
            .collect()
    }

    /// One display colour per channel: the input's where recorded ([`ModelFile::classes`]),
    /// else the palette's for that channel; what every output of the model shows the class in.
    pub fn class_colors(&self) -> Vec<[u8; 3]> {
        self.classes()
            .iter()
            .enumerate()
            .map(|(k, c)| palette::class_color(k, c.color))
            .collect()
    }

    /// The file's size in bytes.
    pub fn len(&self) -> usize {
        self.owned.bytes().len()
    }

    /// Whether the file is empty (never: a valid model has a header).
    pub fn is_empty(&self) -> bool {
        self.owned.bytes().len() == 0
    }

    /// The patient frame of the input's coordinates, which outputs default to
    /// ([`RunRecord::space`]: LPS where not recorded).
    pub fn space(&self) -> Space {
        self.record.space()
    }

    /// The input's length unit ([`RunRecord::units`]: plain where not recorded).
    pub fn units(&self) -> Units {
        self.record.units()
    }

    /// A static model does not depend on time: trained on a single timestep, where the trainer
    /// sets ω_t^max = 0 and every ω_t is clamped to 0 (dynaslice-train's `temporal_bound`), in
    /// the motion network too for a motion model ([`dynaslice_core::Model::is_static`]).
    /// Its time range is then a nominal one unit from the frame's time.
    pub fn is_static(&self) -> bool {
        self.model().is_static()
    }

    /// The time of `option`: the given one, checked against the time range, or for a static
    /// model its start; a moving model needs one.
    pub fn time(&self, option: &str, t: Option<f32>) -> Result<f32> {
        match t {
            Some(t) => {
                self.check_time(option, t)?;
                Ok(t)
            }
            None if self.is_static() => Ok(self.model().domain().time_range().0),
            None => {
                let (t0, t1) = self.model().domain().time_range();
                bail!(
                    "{}: the model moves over times {t0} to {t1}; give {option}",
                    self.path.display()
                )
            }
        }
    }

    /// An error unless `t` is in the model's time range ([`dynaslice_core::Domain::contains_time`],
    /// the rule of every front end): outside it the network was never fitted and extrapolates
    /// freely.
    pub fn check_time(&self, option: &str, t: f32) -> Result<()> {
        let model = self.model();
        let domain = model.domain();
        if !domain.contains_time(t) {
            let (t0, t1) = domain.time_range();
            bail!(
                "{}: {option} {t} is outside the model's time range [{t0}, {t1}]",
                self.path.display()
            );
        }
        Ok(())
    }

    /// The times a computation asked for at `requested` (given with `option`, e.g. `--times`)
    /// runs at: a moving model's, each checked against its time range; a static model's one
    /// time (the start of its nominal range), with a note for the front end to show where more
    /// times, or another time, were asked for: the work is done once instead of N identical
    /// times. `what` names the work in the note ("one mesh per class").
    pub fn times_for(
        &self,
        option: &str,
        requested: &[f32],
        what: &str,
    ) -> Result<(Vec<f32>, Option<String>)> {
        if !self.is_static() {
            for &t in requested {
                self.check_time(option, t)?;
            }
            return Ok((requested.to_vec(), None));
        }
        if let Some(t) = requested.iter().find(|t| !t.is_finite()) {
            bail!(
                "{}: {option} {t} is not a finite number",
                self.path.display()
            );
        }
        let t0 = self.model().domain().time_range().0;
        let note = (requested.len() > 1 || requested.iter().any(|&t| t != t0)).then(|| {
            format!(
                "{}: a static model (trained on one timestep, ω_t^max = 0) is the same at every \
                 time; {what} at its time {t0}, not at the {} time(s) of {option}",
                self.path.display(),
                requested.len()
            )
        });
        Ok((vec![t0], note))
    }

    /// [`ModelFile::check_time`] for each of `times`.
    pub fn check_times(&self, option: &str, times: impl IntoIterator<Item = f64>) -> Result<()> {
        times
            .into_iter()
            .try_for_each(|t| self.check_time(option, t as f32))
    }
}
