//! A folder a command fills with outputs of its own choosing (the demo's): made and marked by
//! the command, so that a later run may replace what an earlier one wrote there, while a
//! user's folder with files in it is never written into without the user's `--force`.
//!
//! The rule ([`prepare_owned_folder`]): a missing or empty folder is created (or taken) and
//! marked with a small file; a folder holding that mark was made by an earlier run, and its
//! outputs are replaced; any other folder with anything in it is refused unless forced.

use anyhow::{bail, Context, Result};
use std::path::Path;

/// What [`prepare_owned_folder`] found, and so whether the command may replace its outputs
/// there.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum OwnedFolder {
    /// Created now, or found empty: nothing to replace.
    Fresh,
    /// Made by an earlier run of the command (it holds the mark): its outputs are replaced.
    Earlier,
    /// A folder with other files, written into because the user forced it.
    Forced,
}

impl OwnedFolder {
    /// Whether the command may replace existing outputs in the folder.
    pub fn replaces(self) -> bool {
        self != OwnedFolder::Fresh
    }
}

/// Prepares `dir` for a command's outputs (see the module's rule). `mark` is the name of the
/// marking file, `what` the command (for the mark's text and the messages), `force` the
/// user's consent to write into a folder the command did not make.
pub fn prepare_owned_folder(
    dir: &Path,
    mark: &str,
    what: &str,
    force: bool,
) -> Result<OwnedFolder> {
    let marked = dir.join(mark);
    let text = format!(
        "This folder was made by `{what}`: a later `{what}` into it replaces the outputs it \
         wrote here.\n"
    );
    let write_mark = || {
        std::fs::write(&marked, &text).with_context(|| format!("cannot write {}", marked.display()))
    };
    match std::fs::symlink_metadata(dir) {
        Err(_) => {
            std::fs::create_dir_all(dir)
                .with_context(|| format!("cannot create directory {}", dir.display()))?;
            write_mark()?;
            return Ok(OwnedFolder::Fresh);
        }
        Ok(meta) if !meta.is_dir() && !dir.is_dir() => {
            bail!("-o {}: exists and is not a directory", dir.display())
        }
        Ok(_) => {}
    }
    if std::fs::symlink_metadata(&marked).is_ok_and(|m| m.is_file()) {
        return Ok(OwnedFolder::Earlier);
    }
    let mut entries: Vec<String> = std::fs::read_dir(dir)
        .with_context(|| format!("cannot read directory {}", dir.display()))?
        .filter_map(|e| e.ok())
        .map(|e| e.file_name().to_string_lossy().into_owned())
        .collect();
    if entries.is_empty() {
        write_mark()?;
        return Ok(OwnedFolder::Fresh);
    }
    if force {
        write_mark()?;
        return Ok(OwnedFolder::Forced);
    }
    entries.sort();
    let shown: Vec<&str> = entries.iter().take(3).map(String::as_str).collect();
    bail!(
        "-o {}: this folder holds {} entr{} `{what}` did not make ({}{}); its outputs \
         could replace them. Choose a new or empty folder, or \
         add --force to write into this one",
        dir.display(),
        entries.len(),
        if entries.len() == 1 { "y" } else { "ies" },
        shown.join(", "),
        if entries.len() > 3 { ", …" } else { "" }
    )
}

#[cfg(test)]
mod tests {
    use super::*;

    const MARK: &str = ".made-by-test";

    #[test]
    fn a_users_folder_is_refused_an_earlier_runs_folder_is_replaced() {
        let root = tempfile::tempdir().unwrap();
        let new = root.path().join("new");
        assert_eq!(
            prepare_owned_folder(&new, MARK, "test", false).unwrap(),
            OwnedFolder::Fresh
        );
        assert!(new.join(MARK).is_file());
        std::fs::write(new.join("model.dsm"), b"demo's").unwrap();
        let again = prepare_owned_folder(&new, MARK, "test", false).unwrap();
        assert_eq!(again, OwnedFolder::Earlier);
        assert!(again.replaces());

        let user = root.path().join("user");
        std::fs::create_dir(&user).unwrap();
        assert_eq!(
            prepare_owned_folder(&user, MARK, "test", false).unwrap(),
            OwnedFolder::Fresh,
            "an empty folder is taken"
        );
        let mine = root.path().join("mine");
        std::fs::create_dir(&mine).unwrap();
        std::fs::write(mine.join("model.dsm"), b"user's").unwrap();
        let e = prepare_owned_folder(&mine, MARK, "test", false).unwrap_err();
        let e = e.to_string();
        assert!(e.contains("model.dsm") && e.contains("--force"), "{e}");
        assert!(!mine.join(MARK).exists(), "a refused folder was marked");
        assert_eq!(
            prepare_owned_folder(&mine, MARK, "test", true).unwrap(),
            OwnedFolder::Forced
        );
        let file = root.path().join("file");
        std::fs::write(&file, b"x").unwrap();
        assert!(prepare_owned_folder(&file, MARK, "test", true).is_err());
    }
}
