//! Outputs of several files written all or nothing ([`OutputSet`]): a mesh per class, a mesh
//! series and its `series.pvd`, RT Structure Sets and their `rtstruct.seq`, an ITV folder,
//! 3D Slicer frames and their `.seq.nrrd`.
//!
//! Each file is written to its own temporary beside its final name ([`create_temporary`]) and
//! only listed (staged); nothing appears under a final name until [`OutputSet::commit`], which
//! renames every temporary into place. A failure while writing (a full disk, an encoder's
//! error) or a set dropped before its commit removes every temporary and every folder the set
//! created, so nothing new is left and an earlier set is untouched. The commit itself keeps a
//! hard link to each file it replaces until all are in place, and on a failed rename puts
//! every replaced file back and removes every new one: after it, the whole new set is in place
//! or the whole old one. A signal handler ([`crate::cleanup`]) waits for a commit in progress.
//! Renames in one folder need no space, so a full disk fails before the commit, not in it.
//!
//! A set written over an earlier one with `--force` may have fewer files (a shorter series,
//! fewer classes): [`OutputSet::supersede`] names the folder and which of its files make up
//! such a set, and the commit removes those of the earlier set that it did not write again
//! (undone with the rest on a failure), so the folder holds this run's files only (issue 37).

use crate::atomic::create_temporary;
use crate::cleanup;
use anyhow::{Context, Result};
use std::fs::File;
use std::io::Write;
use std::path::{Path, PathBuf};
use tempfile::TempPath;

/// A file written under a temporary name, waiting for the commit.
#[derive(Debug)]
struct Staged {
    tmp: TempPath,
    path: PathBuf,
}

/// A test of a file name: whether it is one of a kind of set's files (for a set named after
/// its output, such as `heart_t07.seg.nrrd`, the test holds the output's stem).
struct Member(Box<dyn Fn(&str) -> bool + Send + Sync>);

impl std::fmt::Debug for Member {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str("Member(..)")
    }
}

/// The files of one multi-file output, committed together (see the module's documentation).
#[derive(Debug, Default)]
pub struct OutputSet {
    staged: Vec<Staged>,
    /// Folders this set created, outermost first: removed (when empty) unless committed.
    created: Vec<PathBuf>,
    /// Folders whose earlier set this one replaces, with the test of a file name that tells
    /// such a set's files from others.
    superseded: Vec<(PathBuf, Member)>,
}

impl OutputSet {
    /// An empty set.
    pub fn new() -> OutputSet {
        OutputSet::default()
    }

    /// Creates folder `dir` and its missing parents for the set's files; those it creates are
    /// removed again (when empty) if the set is not committed.
    pub fn create_dir(&mut self, dir: &Path) -> Result<()> {
        let mut missing = Vec::new();
        let mut at = Some(dir);
        while let Some(d) = at.filter(|d| !d.as_os_str().is_empty() && !d.exists()) {
            missing.push(d.to_path_buf());
            at = d.parent();
        }
        for d in missing.into_iter().rev() {
            let mut list = cleanup::lock();
            match std::fs::create_dir(&d) {
                Ok(()) => {
                    list.folder(&d);
                    self.created.push(d);
                }
                Err(e) if e.kind() == std::io::ErrorKind::AlreadyExists && d.is_dir() => {}
                Err(e) => {
                    return Err(e)
                        .with_context(|| format!("cannot create directory {}", d.display()))
                }
            }
        }
        Ok(())
    }

    /// Stages `path` written through `write`, a writer given a temporary path beside it (with
    /// `path`'s extension, for writers that choose the format by it).
    pub fn write_via<T>(
        &mut self,
        path: &Path,
        write: impl FnOnce(&Path) -> Result<T>,
    ) -> Result<T> {
        let (file, tmp) = create_temporary(path)?;
        let value = match write(&tmp) {
            Ok(value) => value,
            Err(e) => {
                cleanup::forget(&tmp);
                return Err(e);
            }
        };
        self.stage(file, tmp, path)?;
        Ok(value)
    }

    /// Stages `path` holding `bytes`.
    pub fn write(&mut self, path: &Path, bytes: &[u8]) -> Result<()> {
        let (mut file, tmp) = create_temporary(path)?;
        if let Err(e) = file.write_all(bytes) {
            cleanup::forget(&tmp);
            return Err(e).with_context(|| format!("cannot write {}", tmp.display()));
        }
        self.stage(file, tmp, path)
    }

    /// Stages a complete temporary of [`create_temporary`] (`file` any handle of it) as
    /// `path`'s new content: gives it the mode of the file it will replace and syncs it, so
    /// the commit only renames. The handle is closed (a set of thousands of files holds no
    /// descriptors); the set's output is claimed, so no other run removes the temporary.
    pub fn stage(&mut self, file: File, tmp: TempPath, path: &Path) -> Result<()> {
        let done = (|| -> Result<()> {
            if let Ok(old) = std::fs::symlink_metadata(path) {
                if old.is_file() {
                    file.set_permissions(old.permissions())
                        .with_context(|| format!("cannot set the mode of {}", tmp.display()))?;
                }
            }
            file.sync_all()
                .with_context(|| format!("cannot write {}", tmp.display()))
        })();
        if let Err(e) = done {
            cleanup::forget(&tmp);
            return Err(e);
        }
        drop(file);
        self.staged.push(Staged {
            tmp,
            path: path.to_path_buf(),
        });
        Ok(())
    }

    /// Declares that this set replaces an earlier set of the same kind in folder `dir`, whose
    /// files are those whose names pass `is_member` (e.g. `classK_name_tIIII.vtp` and
    /// `series.pvd`). When the commit replaces at least one existing file (a forced run over
    /// an earlier set: without `--force` the [`crate::Plan`] refuses an existing file), it
    /// also removes every such file in `dir` that this set does not write, so no file of a
    /// longer earlier series is left beside the new one. Nothing else in `dir` is touched,
    /// and a failed commit puts the removed files back.
    pub fn supersede(
        &mut self,
        dir: &Path,
        is_member: impl Fn(&str) -> bool + Send + Sync + 'static,
    ) {
        self.superseded
            .push((dir.to_path_buf(), Member(Box::new(is_member))));
    }

    /// The files of the earlier sets [`OutputSet::supersede`] names that this set does not
    /// write again, sorted; none unless the set replaces an existing file.
    fn earlier_files(&self) -> Vec<PathBuf> {
        let replaces = self
            .staged
            .iter()
            .any(|s| std::fs::symlink_metadata(&s.path).is_ok());
        if !replaces {
            return Vec::new();
        }
        let mut earlier = Vec::new();
        for (dir, is_member) in &self.superseded {
            let Ok(entries) = std::fs::read_dir(dir) else {
                continue;
            };
            for entry in entries.flatten() {
                let is_dir = entry.file_type().is_ok_and(|t| t.is_dir());
                let name = entry.file_name();
                let Some(name) = name.to_str() else { continue };
                if is_dir || !(is_member.0)(name) {
                    continue;
                }
                let path = dir.join(name);
                if !self.staged.iter().any(|s| same_place(&s.path, &path)) {
                    earlier.push(path);
                }
            }
        }
        earlier.sort();
        earlier
    }

    /// The final paths staged so far, in staging order.
    pub fn paths(&self) -> impl Iterator<Item = &Path> {
        self.staged.iter().map(|s| s.path.as_path())
    }

    /// Renames every staged file into place: afterwards all are there, or (on an error) every
    /// file is as it was before the commit and no temporary is left.
    pub fn commit(mut self) -> Result<()> {
        let earlier = self.earlier_files();
        let mut list = cleanup::lock();
        let staged = std::mem::take(&mut self.staged);
        // Per file in place: the path and the hard link keeping the file it replaced.
        let mut placed: Vec<(PathBuf, Option<TempPath>)> = Vec::new();
        let mut failure = None;
        let mut pending = staged.into_iter();
        for s in pending.by_ref() {
            let backup = match keep_old(&s.path) {
                Ok(backup) => backup,
                Err(e) => {
                    failure = Some(e);
                    list.forget(&s.tmp);
                    break;
                }
            };
            let name = s.tmp.to_path_buf();
            match s.tmp.persist(&s.path) {
                Ok(()) => {
                    list.forget(&name);
                    placed.push((s.path, backup));
                }
                Err(e) => {
                    list.forget(&name);
                    failure = Some(
                        anyhow::Error::new(e.error)
                            .context(format!("cannot write {}", s.path.display())),
                    );
                    // The file it would have replaced is still in place (its extra link goes),
                    // or back in place where it had been renamed aside.
                    if let Some(old) = backup {
                        if std::fs::symlink_metadata(&s.path).is_err() {
                            let _ = old.persist(&s.path);
                        }
                    }
                    break;
                }
            }
        }
        for s in pending {
            list.forget(&s.tmp);
        }
        // The earlier set's other files go once the new ones are all in place; each is kept
        // (a hard link) until the end, to be put back if anything fails.
        let mut removed: Vec<(PathBuf, TempPath)> = Vec::new();
        if failure.is_none() {
            for path in &earlier {
                let gone = keep_old(path).and_then(|backup| {
                    match std::fs::remove_file(path) {
                        Ok(()) => {}
                        // Renamed aside where the file system has no hard links.
                        Err(e) if e.kind() == std::io::ErrorKind::NotFound => {}
                        Err(e) => {
                            if let Some(old) = backup {
                                let _ = old.persist(path);
                            }
                            return Err(e).with_context(|| {
                                format!("cannot remove {} of the earlier output", path.display())
                            });
                        }
                    }
                    Ok(backup)
                });
                match gone {
                    Ok(Some(backup)) => removed.push((path.clone(), backup)),
                    Ok(None) => {}
                    Err(e) => {
                        failure = Some(e);
                        break;
                    }
                }
            }
        }
        if let Some(e) = failure {
            for (path, old) in removed.into_iter().rev() {
                let _ = old.persist(&path);
            }
            // Undo in reverse: the replaced files back, the new ones gone.
            for (path, backup) in placed.into_iter().rev() {
                match backup {
                    Some(old) => {
                        let _ = old.persist(&path);
                    }
                    None => {
                        let _ = std::fs::remove_file(&path);
                    }
                }
            }
            drop(list);
            return Err(e.context("nothing of this output was kept (all files or none)"));
        }
        // Committed: the folders stay, the links to replaced files go.
        for dir in std::mem::take(&mut self.created) {
            list.forget(&dir);
        }
        drop(placed);
        if !removed.is_empty() {
            log::info!(
                "removed {} file(s) of the earlier output that this run does not write again \
                 (the first: {})",
                removed.len(),
                removed[0].0.display()
            );
        }
        drop(removed);
        Ok(())
    }
}

/// Whether `a` and `b` name the same place (lexically, after making both absolute: the set's
/// paths and a folder's listing are spelled the same way).
fn same_place(a: &Path, b: &Path) -> bool {
    let abs = |p: &Path| std::path::absolute(p).unwrap_or_else(|_| p.to_path_buf());
    a == b || abs(a) == abs(b)
}

impl Drop for OutputSet {
    /// Not committed: the temporaries go (their [`TempPath`]s delete them), then the folders
    /// the set created, deepest first, where nothing else was put in them.
    fn drop(&mut self) {
        let mut list = cleanup::lock();
        for s in self.staged.drain(..) {
            list.forget(&s.tmp);
        }
        for dir in self.created.drain(..).rev() {
            let _ = std::fs::remove_dir(&dir);
            list.forget(&dir);
        }
    }
}

/// A hard link to the file (or symbolic link) at `path` under a temporary name beside it,
/// deleted when dropped, or `None` where `path` is free. Where the file system has no hard
/// links the old file is renamed aside instead (for a moment the path is then free, and a
/// SIGKILL then loses it).
fn keep_old(path: &Path) -> Result<Option<TempPath>> {
    match std::fs::symlink_metadata(path) {
        Err(_) => return Ok(None),
        Ok(meta) if meta.is_dir() => {
            anyhow::bail!(
                "{}: is a directory; a file cannot replace it",
                path.display()
            )
        }
        Ok(_) => {}
    }
    let (dir, name) = match (path.parent(), path.file_name()) {
        (Some(d), Some(n)) => (
            if d.as_os_str().is_empty() {
                Path::new(".")
            } else {
                d
            },
            n.to_string_lossy().into_owned(),
        ),
        _ => anyhow::bail!("{} is not a file path", path.display()),
    };
    // Named as the output's temporaries are: a link left by a run killed in its commit is
    // only an extra name of a complete file, removed as stale by the next claim.
    let prefix = format!(".{name}.");
    let backup = tempfile::Builder::new()
        .prefix(&prefix)
        .rand_bytes(crate::atomic::RANDOM_CHARS)
        .suffix(crate::atomic::suffix(&name))
        .make_in(dir, |link| {
            // Linux's link(2) does not follow a symbolic link: the link itself is kept.
            std::fs::hard_link(path, link).or_else(|e| {
                if link.exists() {
                    return Err(e);
                }
                std::fs::rename(path, link)
            })
        })
        .with_context(|| format!("cannot keep {} while replacing it", path.display()))?;
    Ok(Some(backup.into_temp_path()))
}

#[cfg(test)]
mod tests {
    use super::*;

    fn names(dir: &Path) -> Vec<String> {
        let mut v: Vec<String> = std::fs::read_dir(dir)
            .unwrap()
            .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
            .collect();
        v.sort();
        v
    }

    #[test]
    fn nothing_appears_before_the_commit_and_everything_after() {
        let dir = tempfile::tempdir().unwrap();
        let series = dir.path().join("series");
        let mut set = OutputSet::new();
        set.create_dir(&series).unwrap();
        set.write(&series.join("a.vtp"), b"a").unwrap();
        set.write_via(&series.join("b.vtp"), |tmp| Ok(std::fs::write(tmp, b"b")?))
            .unwrap();
        assert!(!series.join("a.vtp").exists(), "visible before the commit");
        assert_eq!(
            set.paths().collect::<Vec<_>>(),
            [series.join("a.vtp"), series.join("b.vtp")]
        );
        set.commit().unwrap();
        assert_eq!(names(&series), ["a.vtp", "b.vtp"]);
        assert_eq!(std::fs::read(series.join("b.vtp")).unwrap(), b"b");
        assert!(cleanup::listed().iter().all(|p| !p.starts_with(dir.path())));
    }

    #[test]
    fn a_failure_before_the_commit_leaves_nothing_new_and_the_old_set_untouched() {
        let dir = tempfile::tempdir().unwrap();
        std::fs::write(dir.path().join("m_class1.ply"), b"old1").unwrap();
        std::fs::write(dir.path().join("m_class2.ply"), b"old2").unwrap();
        let before = names(dir.path());
        // The second file's writer fails as a full disk would.
        let mut set = OutputSet::new();
        set.write(&dir.path().join("m_class1.ply"), b"new1")
            .unwrap();
        let err = set
            .write_via(&dir.path().join("m_class2.ply"), |tmp| -> Result<()> {
                std::fs::write(tmp, b"ne")?;
                Err(std::io::Error::from_raw_os_error(28)).context("No space left on device")
            })
            .unwrap_err();
        assert!(format!("{err:#}").contains("No space"), "{err:#}");
        drop(set);
        assert_eq!(names(dir.path()), before);
        assert_eq!(
            std::fs::read(dir.path().join("m_class1.ply")).unwrap(),
            b"old1"
        );
        // A created folder goes too, parents included.
        let deep = dir.path().join("new/deeper");
        let mut set = OutputSet::new();
        set.create_dir(&deep).unwrap();
        set.write(&deep.join("x.vtp"), b"x").unwrap();
        drop(set);
        assert_eq!(names(dir.path()), before);
        assert!(cleanup::listed().iter().all(|p| !p.starts_with(dir.path())));
    }

    /// `tIIII.vtp` and `series.pvd`: the files of a test series.
    fn series_file(name: &str) -> bool {
        name == "series.pvd" || (name.starts_with('t') && name.ends_with(".vtp"))
    }

    /// Writes a series of `n` files (and its `series.pvd`) into `dir` over whatever is there.
    fn series(dir: &Path, n: usize, content: &[u8]) -> Result<()> {
        let mut set = OutputSet::new();
        set.create_dir(dir)?;
        set.supersede(dir, series_file);
        for i in 0..n {
            set.write(&dir.join(format!("t{i:04}.vtp")), content)?;
        }
        set.write(&dir.join("series.pvd"), content)?;
        set.commit()
    }

    #[test]
    fn a_shorter_series_over_a_longer_one_leaves_none_of_its_extra_files() {
        let dir = tempfile::tempdir().unwrap();
        let out = dir.path().join("meshes");
        series(&out, 6, b"old").unwrap();
        // The user's own file in the folder is no file of a series.
        std::fs::write(out.join("notes.txt"), b"mine").unwrap();
        series(&out, 4, b"new").unwrap();
        assert_eq!(
            names(&out),
            [
                "notes.txt",
                "series.pvd",
                "t0000.vtp",
                "t0001.vtp",
                "t0002.vtp",
                "t0003.vtp"
            ]
        );
        assert_eq!(std::fs::read(out.join("t0003.vtp")).unwrap(), b"new");
        assert_eq!(std::fs::read(out.join("notes.txt")).unwrap(), b"mine");

        // A set that replaces no existing file (no --force was needed) removes nothing: the
        // files there are not an earlier run of this output.
        let other = dir.path().join("other");
        std::fs::create_dir(&other).unwrap();
        std::fs::write(other.join("t0009.vtp"), b"someone's").unwrap();
        let mut set = OutputSet::new();
        set.supersede(&other, series_file);
        set.write(&other.join("t0000.vtp"), b"new").unwrap();
        set.commit().unwrap();
        assert_eq!(names(&other), ["t0000.vtp", "t0009.vtp"]);
    }

    #[cfg(unix)]
    #[test]
    fn a_failed_commit_of_a_shorter_series_keeps_the_whole_longer_one() {
        let dir = tempfile::tempdir().unwrap();
        let out = dir.path().join("meshes");
        series(&out, 3, b"old").unwrap();
        let before = names(&out);
        let mut set = OutputSet::new();
        set.supersede(&out, series_file);
        set.write(&out.join("t0000.vtp"), b"new").unwrap();
        set.write(&out.join("series.pvd"), b"new").unwrap();
        // The second rename fails: its final name became a non-empty folder after staging.
        std::fs::remove_file(out.join("series.pvd")).unwrap();
        std::fs::create_dir(out.join("series.pvd")).unwrap();
        std::fs::write(out.join("series.pvd/keep"), b"k").unwrap();
        let err = set.commit().unwrap_err();
        assert!(format!("{err:#}").contains("all files or none"), "{err:#}");
        assert_eq!(names(&out), before);
        for name in ["t0000.vtp", "t0001.vtp", "t0002.vtp"] {
            assert_eq!(std::fs::read(out.join(name)).unwrap(), b"old", "{name}");
        }
    }

    #[cfg(unix)]
    #[test]
    fn a_failed_rename_in_the_commit_puts_the_whole_old_set_back() {
        let dir = tempfile::tempdir().unwrap();
        let a = dir.path().join("a.ply");
        let b = dir.path().join("b.ply");
        std::fs::write(&a, b"old a").unwrap();
        std::fs::write(&b, b"old b").unwrap();
        let c = dir.path().join("c.ply");
        let mut set = OutputSet::new();
        set.write(&a, b"new a").unwrap();
        set.write(&c, b"new c").unwrap();
        set.write(&b, b"new b").unwrap();
        // The third rename fails: its final name became a non-empty folder after staging.
        std::fs::remove_file(&b).unwrap();
        std::fs::create_dir(&b).unwrap();
        std::fs::write(b.join("keep"), b"k").unwrap();
        let err = set.commit().unwrap_err();
        assert!(format!("{err:#}").contains("all files or none"), "{err:#}");
        assert_eq!(std::fs::read(&a).unwrap(), b"old a");
        assert!(!c.exists(), "a new file of a failed commit was left");
        assert_eq!(names(dir.path()), ["a.ply", "b.ply"]);
    }

    #[cfg(unix)]
    #[test]
    fn a_replaced_link_is_replaced_not_followed_and_modes_are_kept() {
        use std::os::unix::fs::PermissionsExt;
        let dir = tempfile::tempdir().unwrap();
        let target = dir.path().join("user.ply");
        std::fs::write(&target, b"user").unwrap();
        let link = dir.path().join("out.ply");
        std::os::unix::fs::symlink(&target, &link).unwrap();
        let moded = dir.path().join("moded.ply");
        std::fs::write(&moded, b"old").unwrap();
        std::fs::set_permissions(&moded, std::fs::Permissions::from_mode(0o640)).unwrap();
        let mut set = OutputSet::new();
        set.write(&link, b"new").unwrap();
        set.write(&moded, b"new").unwrap();
        set.commit().unwrap();
        assert_eq!(std::fs::read(&target).unwrap(), b"user");
        assert!(std::fs::symlink_metadata(&link).unwrap().is_file());
        let mode = std::fs::metadata(&moded).unwrap().permissions().mode() & 0o777;
        assert_eq!(mode, 0o640);
        assert_eq!(names(dir.path()), ["moded.ply", "out.ply", "user.ply"]);
    }
}
