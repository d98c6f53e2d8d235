//! Opening a model file (.dsm): the one way every subcommand reads a model, and the checks of
//! a time against the model's time range that `mesh`, `query` and `eval reference` share.

use super::output::regular_file;
use anyhow::{anyhow, bail, Context, Result};
use dynaslice_core::{Model, ModelBytes};
use dynaslice_data::{palette, ClassInfo};
use dynaslice_train::model_file::recorded_class_colors;
use std::path::{Path, PathBuf};

/// A model file read from disk and validated.
pub struct ModelFile {
    /// Valid: [`ModelFile::open`] checked them.
    bytes: ModelBytes,
    path: PathBuf,
}

impl ModelFile {
    /// Reads and validates the model file at `path`; every error names the file. Only a
    /// regular file is opened (a FIFO would block the open), and its size is bounded by the
    /// largest model the format allows ([`ModelBytes::read`]).
    pub fn open(path: &Path) -> Result<ModelFile> {
        regular_file("model", path)?;
        let bytes = ModelBytes::read(path)
            .with_context(|| format!("cannot read model {}", path.display()))?;
        bytes
            .model()
            .map_err(|e| anyhow!("{}: {e}", path.display()))?;
        Ok(ModelFile {
            bytes,
            path: path.to_path_buf(),
        })
    }

    /// The model.
    pub fn model(&self) -> Model<'_> {
        self.bytes.model().expect("validated by open")
    }

    /// The model's classes in channel order, each with the display colour its input had where
    /// the model file records one (`class_colors` in its metadata), else `None`: pass them to
    /// `dynaslice_figures::class_color` (or `dynaslice_data::palette::class_color`) with the
    /// class's index. A malformed `class_colors` line is ignored with a warning; models
    /// written before the line existed have no colours.
    pub fn classes(&self) -> Vec<ClassInfo> {
        let model = self.model();
        let recorded = recorded_class_colors(&model).unwrap_or_else(|e| {
            log::warn!(
                "{}: {e}; the classes take the palette's colours",
                self.path.display()
            );
            vec![None; model.num_classes()]
        });
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
        self.bytes.len()
    }

    /// A static model does not depend on time: trained on a single timestep, where the trainer
    /// sets ω_t^max = 0 and every ω_t is clamped to 0 (dynaslice-train's `temporal_bound`).
    /// Its time range is then a nominal one unit from the frame's time.
    pub fn is_static(&self) -> bool {
        self.model().omega_t_max() == 0.0
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

    /// An error unless `t` is in the model's time range (to rounding): outside it the network
    /// was never fitted and extrapolates freely.
    pub fn check_time(&self, option: &str, t: f32) -> Result<()> {
        let (t0, t1) = self.model().domain().time_range();
        let slack = 1e-4 * (t1 - t0).abs().max(1e-6);
        if !(t >= t0 - slack && t <= t1 + slack) {
            bail!(
                "{}: {option} {t} is outside the model's time range [{t0}, {t1}]",
                self.path.display()
            );
        }
        Ok(())
    }
}
