//! Output paths, checked in one place before any work starts: the right extension for what is
//! written, the parent folder exists, never a directory where a file goes (nor a file where a
//! directory goes), never one of the run's inputs (by file identity, so `./a.json`, a symlink or
//! a hard link to an input are caught too), never the same path twice in one run, and never an
//! existing file (a symlink, dangling or not, counts) unless forced (`--force`, Python's
//! `force=True`): the main output, every
//! file written beside it and every file of an output directory alike. Each output is claimed
//! for the run ([`claim`]) before it is checked, so a second run on the
//! same output refuses at once and what is on disk always comes from one run; the claim also
//! removes the temporaries of killed runs. Then [`crate::write_via`] writes a
//! library's output under a temporary name and renames it into place, so a failed run leaves
//! neither a partial file nor a damaged old one.

use crate::atomic::{claim, remove_stale_temporaries, Claim};
use anyhow::{bail, Result};
use std::collections::HashSet;
use std::ffi::OsStr;
use std::path::{Path, PathBuf};

/// What a file output holds: its allowed extensions.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Kind {
    /// A model (`.dsm`).
    Model,
    /// Cross-sections for training (native JSON).
    TrainingInput,
    /// A label volume (`.nii`, `.nii.gz`, or 3D Slicer's `.seg.nrrd`).
    LabelVolume,
    /// A table (`.csv`).
    Csv,
    /// A picture or chart (`.png`).
    Png,
    /// A mesh (`.ply`, `.obj`, `.stl`, `.vtp`).
    Mesh,
    /// A web page (`.html`).
    Html,
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
            Kind::Html => &[".html", ".htm"],
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
            Kind::Html => "web page",
        }
    }
}

/// Extensions of files this tool reads or writes: a series directory named like one is
/// almost certainly a mistaken `-o file.vtp`.
const FILE_EXTENSIONS: [&str; 18] = [
    "ply", "obj", "stl", "vtp", "pvd", "json", "csv", "png", "nii", "gz", "dsm", "csl", "txt",
    "ckpt", "nrrd", "nhdr", "dcm", "html",
];

/// The outputs of one run, checked against its inputs and each other, and claimed for the run:
/// keep the plan until every output is written (dropping it releases the claims).
#[derive(Debug)]
pub struct Plan {
    inputs: Vec<PathBuf>,
    outputs: HashSet<PathBuf>,
    force: bool,
    /// How the caller's user forces a replacement, for the messages.
    force_option: &'static str,
    /// The claims on the outputs; a file inside a claimed directory output is covered by the
    /// directory's.
    claims: Vec<Claim>,
    directories: Vec<PathBuf>,
}

impl Plan {
    /// A run reading `inputs`; `force`: existing files may be replaced. Messages tell the user
    /// to add `--force`; [`Plan::force_option`] names another way (a keyword argument).
    pub fn new<P: AsRef<Path>>(inputs: impl IntoIterator<Item = P>, force: bool) -> Plan {
        Plan {
            inputs: inputs
                .into_iter()
                .map(|p| p.as_ref().to_path_buf())
                .collect(),
            outputs: HashSet::new(),
            force,
            force_option: "--force",
            claims: Vec::new(),
            directories: Vec::new(),
        }
    }

    /// The plan with `words` (e.g. `force=True`) as what the messages tell the user to add.
    pub fn force_option(mut self, words: &'static str) -> Plan {
        self.force_option = words;
        self
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
        self.claim(path)?;
        self.not_existing(option, path, &format!("a {}", kind.what()))
    }

    /// Checks a file written beside the main output or inside an output directory (a colour
    /// table, a chart, a checkpoint, a series' mesh): any name, the same checks, claim and
    /// overwrite rule otherwise.
    pub fn beside(&mut self, path: &Path) -> Result<()> {
        self.check_file("the output", path)?;
        self.claim(path)?;
        self.not_existing("the output", path, "one of this command's outputs")
    }

    /// Checks a file the run continues when it exists (a resumed checkpoint, an appended
    /// journal): as [`Plan::beside`], except that an existing one is expected.
    pub fn continued(&mut self, path: &Path) -> Result<()> {
        self.check_file("the output", path)?;
        self.claim(path)
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
        self.claim(path)?;
        self.outputs.insert(absolute(path));
        self.directories.push(absolute(path));
        Ok(())
    }

    /// Claims `path` for this run, unless a claimed directory output holds it; reports the
    /// killed runs' temporaries the claim removed.
    fn claim(&mut self, path: &Path) -> Result<()> {
        let stale = if self.in_directory(path) {
            remove_stale_temporaries(path)?
        } else {
            let claim = claim(path)?;
            let stale = claim.stale_removed().to_vec();
            self.claims.push(claim);
            stale
        };
        for file in stale {
            log::warn!(
                "removed {}: a temporary file of a run that did not finish",
                file.display()
            );
        }
        Ok(())
    }

    /// Whether `path` is a file of a directory output of this plan.
    fn in_directory(&self, path: &Path) -> bool {
        absolute(path)
            .parent()
            .is_some_and(|dir| self.directories.iter().any(|d| d == dir))
    }

    /// An error unless `path` is free or `--force` was given; `what` says what it is.
    fn not_existing(&self, option: &str, path: &Path, what: &str) -> Result<()> {
        let Ok(meta) = std::fs::symlink_metadata(path) else {
            return Ok(());
        };
        if self.force {
            return Ok(());
        }
        let link = if meta.file_type().is_symlink() {
            " as a symbolic link"
        } else {
            ""
        };
        bail!(
            "{option} {}: the file exists{link} ({what}); add {} to replace it",
            path.display(),
            self.force_option
        )
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
        // A directory output is created by its writer: its files' folder may not exist yet.
        if !self.in_directory(path) {
            parent_exists(option, path)?;
        }
        self.not_an_input(option, path)?;
        let abs = absolute(path);
        if self.outputs.contains(&abs) {
            bail!(
                "{option} {}: the run would write this file twice",
                path.display()
            );
        }
        self.outputs.insert(abs);
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

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn refuses_inputs_wrong_extensions_existing_files_and_claimed_outputs() {
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
        let e = plan.directory("-o", &dir.path().join("a.vtp")).unwrap_err();
        assert!(e.to_string().contains("looks like a file"), "{e}");
        let csv = dir.path().join("v.csv");
        plan.file("-o", &csv, Kind::Csv).unwrap();
        assert!(plan.beside(&csv).unwrap_err().to_string().contains("twice"));
        // The plan holds its outputs: another run's plan is refused until this one ends.
        let e = Plan::new([&input], true)
            .file("-o", &csv, Kind::Csv)
            .unwrap_err();
        assert!(e.to_string().contains("is writing this output"), "{e}");
        drop(plan);
        let mut forced = Plan::new([&input], true);
        forced.file("-o", &model, Kind::Model).unwrap();
        forced.file("-o", &csv, Kind::Csv).unwrap();
    }

    #[test]
    fn every_existing_output_needs_force_links_included() {
        let dir = tempfile::tempdir().unwrap();
        let png = dir.path().join("p.png");
        std::fs::write(&png, "x").unwrap();
        let dangling = dir.path().join("d.ply");
        std::os::unix::fs::symlink(dir.path().join("nowhere"), &dangling).unwrap();
        let series = dir.path().join("series");
        std::fs::create_dir(&series).unwrap();
        let pvd = series.join("series.pvd");
        std::fs::write(&pvd, "x").unwrap();
        let mut plan = Plan::new(std::iter::empty::<PathBuf>(), false);
        let e = plan.file("-o", &png, Kind::Png).unwrap_err();
        assert!(e.to_string().contains("add --force"), "{e}");
        let e = plan.beside(&dangling).unwrap_err();
        assert!(e.to_string().contains("as a symbolic link"), "{e}");
        plan.directory("-o", &series).unwrap();
        let e = plan.beside(&pvd).unwrap_err();
        assert!(e.to_string().contains("series.pvd"), "{e}");
        drop(plan);
        // Files of a directory output not created yet are checked without their folder.
        let mut plan = Plan::new(std::iter::empty::<PathBuf>(), true);
        let fresh = dir.path().join("fresh");
        plan.directory("-o", &fresh).unwrap();
        plan.beside(&fresh.join("class1_a_t0000.vtp")).unwrap();
        plan.beside(&dangling).unwrap();
    }
}
