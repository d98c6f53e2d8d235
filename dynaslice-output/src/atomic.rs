//! Writing output files so that neither a killed job, a failed write nor a second run on the
//! same output ever leaves a half-written or mixed file:
//!
//! - the content goes to a uniquely named temporary file beside the output
//!   ([`create_temporary`]: `.NAME.XXXXXX.EXT`), which is synced and renamed over it when
//!   complete ([`persist`]) and deleted otherwise; it gets the mode a plain `File::create`
//!   would give (`0666 & ~umask` for a new file, the old file's mode for a replaced one), not
//!   tempfile's private 0600, so colleagues on a shared server can open the results;
//! - a run claims each output before any work ([`claim`]): an exclusive lock on `.NAME.lock`
//!   beside it, held until the run ends, so a second run on the same output refuses at once
//!   instead of mixing its files with the first's;
//! - temporaries that no live writer holds (a killed run's) are removed when the output is
//!   claimed ([`remove_stale_temporaries`]): each writer holds a lock on its own temporary,
//!   so only dead runs' files are taken.
//!
//! Locks are `flock`-style advisory locks from the standard library (`File::try_lock`,
//! stable since Rust 1.89): no dependency, released by the kernel when a process dies however
//! it dies, so a killed run never leaves a claim behind.

use anyhow::{bail, Context, Result};
use std::fs::{File, OpenOptions};
use std::io::{Read, Write};
use std::path::{Path, PathBuf};
use tempfile::TempPath;

/// The folder of `path` (`.` for a bare name) and its file name.
fn split(path: &Path) -> Result<(&Path, String)> {
    let dir = path
        .parent()
        .filter(|p| !p.as_os_str().is_empty())
        .unwrap_or(Path::new("."));
    let name = path
        .file_name()
        .with_context(|| format!("{} is not a file path", path.display()))?
        .to_string_lossy()
        .into_owned();
    Ok((dir, name))
}

/// The extension a temporary of `name` keeps, so writers that pick the format by it still do
/// (`.nii.gz` counts as one).
pub(crate) fn suffix(name: &str) -> &str {
    if name.to_ascii_lowercase().ends_with(".nii.gz") {
        &name[name.len() - 7..]
    } else {
        name.rfind('.').map_or("", |i| &name[i..])
    }
}

/// Random characters in a temporary's name (tempfile's default).
pub(crate) const RANDOM_CHARS: usize = 6;

/// Creates a temporary file beside `path`, `.NAME.XXXXXX.EXT` (a unique name, so concurrent
/// writers never share one), with the mode a new `File::create` would give, and locked while
/// the returned file is open so that [`remove_stale_temporaries`] leaves it alone. The
/// [`TempPath`] deletes it when dropped; [`persist`] puts it in place.
pub fn create_temporary(path: &Path) -> Result<(File, TempPath)> {
    let (dir, name) = split(path)?;
    let prefix = format!(".{name}.");
    let mut builder = tempfile::Builder::new();
    builder
        .prefix(&prefix)
        .rand_bytes(RANDOM_CHARS)
        .suffix(suffix(&name));
    // Mode 0666: the open applies the umask, as `File::create` does (elsewhere there is only
    // read-only, and tempfile's default is writable).
    #[cfg(unix)]
    builder.permissions(std::os::unix::fs::PermissionsExt::from_mode(0o666));
    let tmp = builder
        .tempfile_in(dir)
        .with_context(|| format!("cannot create a temporary file in {}", dir.display()))?;
    tmp.as_file()
        .try_lock()
        .with_context(|| format!("cannot lock {}", tmp.path().display()))?;
    // Removed if a signal ends the process before it is renamed or deleted.
    crate::cleanup::register(tmp.path());
    Ok(tmp.into_parts())
}

/// Completes a temporary of [`create_temporary`] holding `path`'s new content: takes the mode
/// of the file it replaces (as `File::create` keeps it), syncs it and renames it over `path`
/// (a symlink there is replaced, its target left alone). `file` may be any handle of the
/// temporary; its lock is released after the rename.
pub fn persist(file: File, tmp: TempPath, path: &Path) -> Result<()> {
    if let Ok(old) = std::fs::symlink_metadata(path) {
        if old.is_file() {
            file.set_permissions(old.permissions())
                .with_context(|| format!("cannot set the mode of {}", tmp.display()))?;
        }
    }
    file.sync_all()
        .with_context(|| format!("cannot sync {}", tmp.display()))?;
    // The rename and the list's update as one step for a signal handler
    // ([`crate::cleanup::remove_all_and_exit`] takes the same lock).
    let mut list = crate::cleanup::lock();
    let name = tmp.to_path_buf();
    let renamed = tmp.persist(path);
    if renamed.is_ok() {
        list.forget(&name);
    }
    drop(list);
    renamed.with_context(|| format!("cannot write {}", path.display()))?;
    drop(file);
    Ok(())
}

/// Writes `path` through `write`, a writer that takes a path: it writes a temporary file of
/// [`create_temporary`] (writers pick the format by its extension), which is put in place by
/// [`persist`] when `write` succeeds and deleted when it fails.
pub fn write_via<T>(path: &Path, write: impl FnOnce(&Path) -> Result<T>) -> Result<T> {
    let (file, tmp) = create_temporary(path)?;
    let value = match write(&tmp) {
        Ok(value) => value,
        Err(e) => {
            crate::cleanup::forget(&tmp);
            return Err(e);
        }
    };
    persist(file, tmp, path)?;
    Ok(value)
}

/// Writes `bytes` to `path` atomically ([`write_via`]), so a killed job never leaves a
/// half-written model or checkpoint.
pub fn write_atomically(path: &Path, bytes: &[u8]) -> Result<()> {
    let (mut file, tmp) = create_temporary(path)?;
    file.write_all(bytes)
        .with_context(|| format!("cannot write {}", tmp.display()))?;
    persist(file, tmp, path)
}

/// An exclusive claim on an output path for the life of a run ([`claim`]); dropping it
/// releases the claim and removes its lock file.
#[derive(Debug)]
pub struct Claim {
    lock: PathBuf,
    file: File,
    stale: Vec<PathBuf>,
}

impl Claim {
    /// The lock file, `.NAME.lock` beside the output.
    pub fn lock_path(&self) -> &Path {
        &self.lock
    }

    /// The killed runs' temporaries of the output removed when it was claimed.
    pub fn stale_removed(&self) -> &[PathBuf] {
        &self.stale
    }
}

impl Drop for Claim {
    fn drop(&mut self) {
        // Removed while still locked: a run waiting on this file finds it gone (or replaced)
        // after locking it and starts over on a fresh one ([`claim`]).
        let _ = std::fs::remove_file(&self.lock);
        crate::cleanup::forget(&self.lock);
        let _ = self.file.unlock();
    }
}

/// The lock file of `path`.
pub fn lock_path(path: &Path) -> Result<PathBuf> {
    let (dir, name) = split(path)?;
    Ok(dir.join(format!(".{name}.lock")))
}

/// Claims `path` (a file or a directory about to be written) for this run: locks
/// `.NAME.lock` beside it, or fails at once, naming the other run's process, when another
/// run holds it. Then removes the output's stale temporaries ([`remove_stale_temporaries`]).
/// Hold the claim until every file of the output is written.
pub fn claim(path: &Path) -> Result<Claim> {
    let lock = lock_path(path)?;
    // A few rounds at most: each retry means another run released the lock file between our
    // open and our lock.
    for _ in 0..16 {
        let mut options = OpenOptions::new();
        options.read(true).write(true).create(true);
        #[cfg(unix)]
        std::os::unix::fs::OpenOptionsExt::mode(&mut options, 0o666);
        let mut file = options
            .open(&lock)
            .with_context(|| format!("cannot create the lock file {}", lock.display()))?;
        match file.try_lock() {
            Ok(()) => {}
            Err(std::fs::TryLockError::WouldBlock) => {
                let mut holder = String::new();
                let _ = file.read_to_string(&mut holder);
                let holder = holder.trim();
                let who = if holder.is_empty() || holder.len() > 20 {
                    "another run".to_string()
                } else {
                    format!("another run (process {holder})")
                };
                bail!(
                    "{}: {who} is writing this output (it holds {}); wait for it to end or \
                     choose another output",
                    path.display(),
                    lock.display()
                );
            }
            Err(std::fs::TryLockError::Error(e)) => {
                return Err(e).with_context(|| format!("cannot lock {}", lock.display()));
            }
        }
        if !still_named(&file, &lock) {
            continue;
        }
        if let Err(e) = file
            .set_len(0)
            .and_then(|()| write!(file, "{}", std::process::id()))
        {
            // Ours (we hold its lock): not left behind, e.g. on a full disk.
            let _ = std::fs::remove_file(&lock);
            return Err(e)
                .with_context(|| format!("cannot write the lock file {}", lock.display()));
        }
        crate::cleanup::register(&lock);
        let mut claim = Claim {
            lock,
            file,
            stale: Vec::new(),
        };
        claim.stale = remove_stale_temporaries(path)?;
        return Ok(claim);
    }
    bail!(
        "{}: cannot claim this output: its lock file {} keeps changing (other runs starting \
         and ending); try again",
        path.display(),
        lock.display()
    )
}

/// Whether the open `file` is still the one named `path` (its last holder may have removed
/// it between our open and our lock).
#[cfg(unix)]
fn still_named(file: &File, path: &Path) -> bool {
    use std::os::unix::fs::MetadataExt;
    match (file.metadata(), std::fs::symlink_metadata(path)) {
        (Ok(a), Ok(b)) => a.dev() == b.dev() && a.ino() == b.ino(),
        _ => false,
    }
}

#[cfg(not(unix))]
fn still_named(_: &File, path: &Path) -> bool {
    path.exists()
}

/// Removes the temporaries of `path` that no live writer holds, and returns them: the
/// `.NAME.XXXXXX.EXT` files of [`create_temporary`] whose lock is free (their run was killed
/// before it could delete them) and the fixed `.NAME.tmp` of older versions. Call it only
/// with `path` claimed, so no run of this program is about to create one.
pub fn remove_stale_temporaries(path: &Path) -> Result<Vec<PathBuf>> {
    let (dir, name) = split(path)?;
    let prefix = format!(".{name}.");
    let suffix = suffix(&name);
    let legacy = format!(".{name}.tmp");
    let entries = match std::fs::read_dir(dir) {
        Ok(entries) => entries,
        // A directory output not created yet has nothing in it.
        Err(_) => return Ok(Vec::new()),
    };
    let mut removed = Vec::new();
    for entry in entries.flatten() {
        let file_name = entry.file_name();
        let Some(candidate) = file_name.to_str() else {
            continue;
        };
        let ours = candidate == legacy
            || candidate
                .strip_prefix(&prefix)
                .and_then(|rest| rest.strip_suffix(suffix))
                .is_some_and(|random| {
                    random.len() == RANDOM_CHARS
                        && random.bytes().all(|b| b.is_ascii_alphanumeric())
                });
        if !ours || !entry.file_type().is_ok_and(|t| t.is_file()) {
            continue;
        }
        let path = entry.path();
        // A writer holds its temporary locked until it is renamed; a free lock means a dead
        // writer. (The lock is taken after the open: a writer of this very output cannot be
        // between the two, as the output is claimed.)
        let free = File::open(&path).is_ok_and(|f| f.try_lock().is_ok());
        if free && std::fs::remove_file(&path).is_ok() {
            removed.push(path);
        }
    }
    Ok(removed)
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
    fn the_output_appears_whole_and_nothing_else_is_left() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("labels.nii.gz");
        std::fs::write(&path, b"old").unwrap();
        let seen = write_via(&path, |tmp| {
            let name = tmp.file_name().unwrap().to_string_lossy().into_owned();
            assert!(name.starts_with(".labels.nii.gz.") && name.ends_with(".nii.gz"));
            // The old file stays in place until the new one is complete.
            assert_eq!(std::fs::read(&path).unwrap(), b"old");
            std::fs::write(tmp, b"new")?;
            Ok(name)
        })
        .unwrap();
        assert_eq!(std::fs::read(&path).unwrap(), b"new");
        assert_eq!(names(dir.path()), ["labels.nii.gz"], "{seen} left behind");
        write_atomically(&dir.path().join("m.dsm"), b"model").unwrap();
        assert_eq!(names(dir.path()), ["labels.nii.gz", "m.dsm"]);
    }

    #[test]
    fn a_failed_write_keeps_the_old_file_and_leaves_no_temporary() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("m.dsm");
        std::fs::write(&path, b"old").unwrap();
        let err = write_via(&path, |tmp| -> Result<()> {
            std::fs::write(tmp, b"half")?;
            anyhow::bail!("the writer failed")
        })
        .unwrap_err();
        assert_eq!(err.to_string(), "the writer failed");
        assert_eq!(std::fs::read(&path).unwrap(), b"old");
        assert_eq!(names(dir.path()), ["m.dsm"]);
        let missing = dir.path().join("no-such-folder/m.dsm");
        let err = write_atomically(&missing, b"x").unwrap_err();
        assert!(
            format!("{err:#}").contains("cannot create a temporary file in"),
            "{err:#}"
        );
    }

    #[cfg(unix)]
    #[test]
    fn a_replaced_file_keeps_its_mode_and_a_symlink_is_replaced_not_followed() {
        use std::fs::Permissions;
        use std::os::unix::fs::PermissionsExt;
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("m.dsm");
        std::fs::write(&path, b"old").unwrap();
        std::fs::set_permissions(&path, Permissions::from_mode(0o640)).unwrap();
        write_atomically(&path, b"new").unwrap();
        let mode = std::fs::metadata(&path).unwrap().permissions().mode() & 0o777;
        assert_eq!(mode, 0o640);
        let target = dir.path().join("target.ply");
        std::fs::write(&target, b"reference").unwrap();
        let link = dir.path().join("link.ply");
        std::os::unix::fs::symlink(&target, &link).unwrap();
        write_atomically(&link, b"mesh").unwrap();
        assert_eq!(std::fs::read(&target).unwrap(), b"reference");
        assert!(std::fs::symlink_metadata(&link).unwrap().is_file());
    }

    /// Writes through this module's writers into `DYNASLICE_UMASK_DIR`; run in a child process
    /// under a chosen umask by [`new_files_get_the_mode_file_create_gives`].
    #[test]
    #[ignore = "run by new_files_get_the_mode_file_create_gives in a child process"]
    fn write_for_the_umask_test() {
        let dir = PathBuf::from(std::env::var_os("DYNASLICE_UMASK_DIR").expect("the folder"));
        write_atomically(&dir.join("a.dsm"), b"model").unwrap();
        write_via(&dir.join("b.png"), |tmp| Ok(std::fs::write(tmp, b"png")?)).unwrap();
        let (mut file, tmp) = create_temporary(&dir.join("c.nii.gz")).unwrap();
        file.write_all(b"volume").unwrap();
        persist(file, tmp, &dir.join("c.nii.gz")).unwrap();
    }

    #[cfg(unix)]
    #[test]
    fn new_files_get_the_mode_file_create_gives() {
        use std::os::unix::fs::PermissionsExt;
        for (umask, expected) in [("022", 0o644), ("077", 0o600), ("002", 0o664)] {
            let dir = tempfile::tempdir().unwrap();
            let status = std::process::Command::new("sh")
                .arg("-c")
                .arg(format!(
                    "umask {umask} && exec \"$0\" --ignored --exact --quiet \
                     atomic::tests::write_for_the_umask_test"
                ))
                .arg(std::env::current_exe().unwrap())
                .env("DYNASLICE_UMASK_DIR", dir.path())
                .stdout(std::process::Stdio::null())
                .status()
                .unwrap();
            assert!(status.success(), "umask {umask}: the writer failed");
            assert_eq!(names(dir.path()), ["a.dsm", "b.png", "c.nii.gz"]);
            for name in ["a.dsm", "b.png", "c.nii.gz"] {
                let meta = std::fs::metadata(dir.path().join(name)).unwrap();
                let mode = meta.permissions().mode() & 0o777;
                assert_eq!(mode, expected, "{name} under umask {umask}: {mode:o}");
            }
        }
    }

    #[test]
    fn a_second_claim_is_refused_until_the_first_ends() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("lab.nii.gz");
        let first = claim(&path).unwrap();
        assert_eq!(
            std::fs::read_to_string(first.lock_path()).unwrap(),
            std::process::id().to_string()
        );
        // flock locks belong to open files, so a second open in this process conflicts as
        // another process's would.
        let err = claim(&path).unwrap_err().to_string();
        assert!(
            err.contains("is writing this output")
                && err.contains(&format!("process {}", std::process::id())),
            "{err}"
        );
        drop(first);
        assert_eq!(names(dir.path()), Vec::<String>::new(), "lock file left");
        let again = claim(&path).unwrap();
        drop(again);
    }

    #[test]
    fn only_dead_writers_temporaries_are_removed() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("m.dsm.ckpt");
        // A killed run's temporary (unlocked), an old version's fixed name, a live writer's
        // temporary (locked), and files that only look similar.
        std::fs::write(dir.path().join(".m.dsm.ckpt.a1B2c3.ckpt"), b"dead").unwrap();
        std::fs::write(dir.path().join(".m.dsm.ckpt.tmp"), b"dead").unwrap();
        let (live, live_path) = create_temporary(&path).unwrap();
        for other in [
            ".m.dsm.ckpt.toolong7.ckpt",
            ".m.dsm.a1B2c3.dsm",
            "m.dsm.ckpt",
        ] {
            std::fs::write(dir.path().join(other), b"keep").unwrap();
        }
        let c = claim(&path).unwrap();
        let mut removed: Vec<String> = c
            .stale_removed()
            .iter()
            .map(|p| p.file_name().unwrap().to_string_lossy().into_owned())
            .collect();
        removed.sort();
        assert_eq!(removed, [".m.dsm.ckpt.a1B2c3.ckpt", ".m.dsm.ckpt.tmp"]);
        assert!(live_path.exists(), "a live writer's temporary was removed");
        persist(live, live_path, &path).unwrap();
        drop(c);
        assert_eq!(
            names(dir.path()),
            [
                ".m.dsm.a1B2c3.dsm",
                ".m.dsm.ckpt.toolong7.ckpt",
                "m.dsm.ckpt"
            ]
        );
    }
}
