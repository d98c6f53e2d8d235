//! Writing output files atomically, so that a killed job or a failed write never leaves a
//! half-written file: the content goes to a uniquely named temporary file beside the output,
//! which is synced and renamed over it when complete, and deleted otherwise.

use anyhow::{Context, Result};
use std::path::Path;

/// Writes `path` through `write`, a writer that takes a path: it writes a temporary file beside
/// `path` with the same extension (writers pick the format by it; `.nii.gz` counts as one),
/// which is synced and renamed over `path` when `write` succeeds and deleted when it fails.
pub fn write_via<T>(path: &Path, write: impl FnOnce(&Path) -> Result<T>) -> Result<T> {
    let dir = path
        .parent()
        .filter(|p| !p.as_os_str().is_empty())
        .unwrap_or(Path::new("."));
    let name = path
        .file_name()
        .with_context(|| format!("{} is not a file path", path.display()))?
        .to_string_lossy()
        .into_owned();
    let lower = name.to_ascii_lowercase();
    let suffix = if lower.ends_with(".nii.gz") {
        &name[name.len() - 7..]
    } else {
        name.rfind('.').map_or("", |i| &name[i..])
    };
    let tmp = tempfile::Builder::new()
        .prefix(&format!(".{name}."))
        .suffix(suffix)
        .tempfile_in(dir)
        .with_context(|| format!("cannot create a temporary file in {}", dir.display()))?;
    let value = write(tmp.path())?;
    std::fs::File::open(tmp.path())
        .and_then(|f| f.sync_all())
        .with_context(|| format!("cannot sync {}", tmp.path().display()))?;
    tmp.persist(path)
        .with_context(|| format!("cannot write {}", path.display()))?;
    Ok(value)
}

/// Writes `bytes` to `path` atomically ([`write_via`]), so a killed job never leaves a
/// half-written model or checkpoint.
pub fn write_atomically(path: &Path, bytes: &[u8]) -> Result<()> {
    write_via(path, |tmp| {
        std::fs::write(tmp, bytes).with_context(|| format!("cannot write {}", tmp.display()))
    })
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
}
