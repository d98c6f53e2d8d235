//! Output paths, checked in one place before any work starts: the right extension for what is
//! written, the parent folder exists, never a directory where a file goes (nor a file where a
//! directory goes), never one of the run's inputs (by file identity, so `./a.json`, a symlink or
//! a hard link to an input are caught too), never the same path twice in one run, and never an
//! existing model, training input or label volume unless `--force`. Then
//! [`dynaslice_data::atomic::write_via`] writes a library's output under a temporary name and
//! renames it into place, so a failed run leaves neither a partial file nor a damaged old one.

use anyhow::{bail, Result};
use std::ffi::OsStr;
use std::path::{Path, PathBuf};

/// What a file output holds: its allowed extensions and whether it may replace a file.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Kind {
    /// A model (`.dsm`); replacing one needs `--force`.
    Model,
    /// Cross-sections for training (native JSON); replacing one needs `--force`.
    TrainingInput,
    /// A label volume (`.nii`, `.nii.gz`, or 3D Slicer's `.seg.nrrd`); replacing one needs
    /// `--force`.
    LabelVolume,
    /// A table (`.csv`).
    Csv,
    /// A picture or chart (`.png`).
    Png,
    /// A mesh (`.ply`, `.obj`, `.stl`, `.vtp`).
    Mesh,
}

impl Kind {
    fn extensions(self) -> &'static [&'static str] {
        match self {
            Kind::Model => &[".dsm"],
            Kind::TrainingInput => &[".json"],
            Kind::LabelVolume => &[".nii", ".nii.gz", ".seg.nrrd"],
            Kind::Csv => &[".csv"],
            Kind::Png => &[".png"],
            Kind::Mesh => &[".ply", ".obj", ".stl", ".vtp"],
        }
    }

    fn what(self) -> &'static str {
        match self {
            Kind::Model => "model",
            Kind::TrainingInput => "training input",
            Kind::LabelVolume => "label volume",
            Kind::Csv => "CSV table",
            Kind::Png => "PNG picture",
            Kind::Mesh => "mesh",
        }
    }

    /// Data a run may have taken hours to make: never replaced without `--force`.
    fn precious(self) -> bool {
        matches!(self, Kind::Model | Kind::TrainingInput | Kind::LabelVolume)
    }
}

/// Extensions of files this tool reads or writes: a series directory named like one is
/// almost certainly a mistaken `-o file.vtp`.
const FILE_EXTENSIONS: [&str; 14] = [
    "ply", "obj", "stl", "vtp", "pvd", "json", "csv", "png", "nii", "gz", "dsm", "csl", "txt",
    "ckpt",
];

/// The outputs of one run, checked against its inputs and each other.
#[derive(Debug)]
pub struct Plan {
    inputs: Vec<PathBuf>,
    outputs: Vec<PathBuf>,
    force: bool,
}

impl Plan {
    /// A run reading `inputs`; `force`: existing models, training inputs and label volumes may
    /// be replaced.
    pub fn new<P: AsRef<Path>>(inputs: impl IntoIterator<Item = P>, force: bool) -> Plan {
        Plan {
            inputs: inputs
                .into_iter()
                .map(|p| p.as_ref().to_path_buf())
                .collect(),
            outputs: Vec::new(),
            force,
        }
    }

    /// Checks the file output `path` given by `option` (e.g. `-o`) holding `kind`.
    pub fn file(&mut self, option: &str, path: &Path, kind: Kind) -> Result<()> {
        file_name(option, path)?;
        let name = path.to_string_lossy().to_ascii_lowercase();
        let exts = kind.extensions();
        if !exts
            .iter()
            .any(|e| name.ends_with(e) && name.len() > e.len())
        {
            bail!(
                "{option} {}: a {} must be named *{}",
                path.display(),
                kind.what(),
                exts.join(" or *")
            );
        }
        self.check_file(option, path)?;
        if kind.precious() && !self.force && path.exists() {
            bail!(
                "{option} {}: the file exists (a {}); add --force to replace it",
                path.display(),
                kind.what()
            );
        }
        Ok(())
    }

    /// Checks a file written beside the main output (a loss log, a chart, a checkpoint): any
    /// name, the same checks otherwise; an existing one is replaced.
    pub fn beside(&mut self, path: &Path) -> Result<()> {
        self.check_file("the output", path)
    }

    /// Checks the directory output `path` of `option`: not named like a file, not an existing
    /// file, its parent exists. It is created by the writer where missing.
    pub fn directory(&mut self, option: &str, path: &Path) -> Result<()> {
        if let Some(ext) = path.extension().and_then(OsStr::to_str) {
            if FILE_EXTENSIONS.contains(&ext.to_ascii_lowercase().as_str()) {
                bail!(
                    "{option} {}: this output is a directory, and the name looks like a \
                     file (.{ext}); give a directory name",
                    path.display()
                );
            }
        }
        if path.exists() && !path.is_dir() {
            bail!("{option} {}: exists and is not a directory", path.display());
        }
        parent_exists(option, path)?;
        self.not_an_input(option, path)?;
        self.outputs.push(absolute(path));
        Ok(())
    }

    fn check_file(&mut self, option: &str, path: &Path) -> Result<()> {
        file_name(option, path)?;
        if let Ok(meta) = std::fs::metadata(path) {
            if meta.is_dir() {
                bail!(
                    "{option} {}: is a directory; give a file name",
                    path.display()
                );
            }
            if !meta.is_file() {
                bail!("{option} {}: not a regular file", path.display());
            }
        }
        parent_exists(option, path)?;
        self.not_an_input(option, path)?;
        let abs = absolute(path);
        if self.outputs.contains(&abs) {
            bail!(
                "{option} {}: the run would write this file twice",
                path.display()
            );
        }
        self.outputs.push(abs);
        Ok(())
    }

    fn not_an_input(&self, option: &str, path: &Path) -> Result<()> {
        for input in &self.inputs {
            // A missing output cannot be an existing input; errors mean "not the same".
            let same = same_file::is_same_file(path, input).unwrap_or(false)
                || absolute(path) == absolute(input);
            if same {
                bail!(
                    "{option} {}: this is an input of the command ({}); writing it would \
                     destroy it, choose another output",
                    path.display(),
                    input.display()
                );
            }
        }
        Ok(())
    }
}

/// An error unless `path` names a file: not `dir/`, `..` or `/`.
fn file_name(option: &str, path: &Path) -> Result<()> {
    let text = path.as_os_str().to_string_lossy();
    if path.file_name().is_none() || text.ends_with('/') || text.ends_with("/.") {
        bail!("{option} {}: not a file name", path.display());
    }
    Ok(())
}

/// `path` made absolute against the current directory (lexically: `a/../b` stays as is, and
/// file identity is left to `same_file`).
fn absolute(path: &Path) -> PathBuf {
    std::path::absolute(path).unwrap_or_else(|_| path.to_path_buf())
}

fn parent_exists(option: &str, path: &Path) -> Result<()> {
    let parent = path
        .parent()
        .filter(|p| !p.as_os_str().is_empty())
        .unwrap_or(Path::new("."));
    if !parent.is_dir() {
        bail!(
            "{option} {}: the folder {} does not exist",
            path.display(),
            parent.display()
        );
    }
    Ok(())
}

/// `path` as an input: it exists and is a regular file (a FIFO would block the open, a device
/// like /dev/zero would never end), checked by the readers' own rule
/// ([`dynaslice_data::input_file::regular_file`]). `what` names it in the message (e.g. "model").
pub fn regular_file(what: &str, path: &Path) -> Result<()> {
    match dynaslice_data::input_file::regular_file(path) {
        Ok(_) => Ok(()),
        Err(e) => bail!("cannot read {what} {}: {}", path.display(), e.kind),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn refuses_inputs_wrong_extensions_and_existing_models() {
        let dir = tempfile::tempdir().unwrap();
        let input = dir.path().join("in.json");
        std::fs::write(&input, "x").unwrap();
        let mut plan = Plan::new([&input], false);
        let e = plan.file("-o", &input, Kind::TrainingInput).unwrap_err();
        assert!(e.to_string().contains("input of the command"), "{e}");
        let e = plan
            .file("-o", &dir.path().join("x.txt"), Kind::Model)
            .unwrap_err();
        assert!(e.to_string().contains("*.dsm"), "{e}");
        let e = plan
            .file("-o", &dir.path().join("no/m.dsm"), Kind::Model)
            .unwrap_err();
        assert!(e.to_string().contains("does not exist"), "{e}");
        let model = dir.path().join("m.dsm");
        std::fs::write(&model, "x").unwrap();
        let e = plan.file("-o", &model, Kind::Model).unwrap_err();
        assert!(e.to_string().contains("--force"), "{e}");
        assert!(Plan::new([&input], true)
            .file("-o", &model, Kind::Model)
            .is_ok());
        let e = plan.directory("-o", &dir.path().join("a.vtp")).unwrap_err();
        assert!(e.to_string().contains("looks like a file"), "{e}");
        let csv = dir.path().join("v.csv");
        plan.file("-o", &csv, Kind::Csv).unwrap();
        assert!(plan.beside(&csv).unwrap_err().to_string().contains("twice"));
    }
}
