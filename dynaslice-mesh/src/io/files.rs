//! Where the meshes of one extraction run go: one file per (time, class), named so that a
//! directory of them sorts by class then time, and for a VTP series the ParaView collection
//! (`series.pvd`) that animates them. The files of a run are one output set
//! ([`dynaslice_output::OutputSet`]): none appears until [`MeshFiles::finish`], and a run that
//! fails or is dropped before it leaves nothing new and an earlier set untouched.

use super::super::Mesh;
use super::{encode, pvd, Format, MeshInfo, Space};
use anyhow::{Context, Result};
use dynaslice_core::ClassInfo;
use dynaslice_output::OutputSet;
use std::path::{Path, PathBuf};

/// The class part of file names: `class{k}_{name}` (k 1-based) with the name reduced to
/// `[A-Za-z0-9-]`, or `class{k}` when nothing of the name is left.
pub fn class_tag(k: usize, name: &str) -> String {
    let slug: String = name
        .chars()
        .map(|c| {
            if c.is_ascii_alphanumeric() || c == '-' {
                c
            } else {
                '-'
            }
        })
        .collect();
    let slug = slug.trim_matches('-');
    if slug.is_empty() {
        format!("class{}", k + 1)
    } else {
        format!("class{}_{slug}", k + 1)
    }
}

/// Whether `name` is a file of a series [`MeshFiles::series`] writes: `series.pvd`, or
/// `classK[_slug]_tIIII.EXT` with EXT a mesh format's extension.
fn is_series_file(name: &str) -> bool {
    if name == "series.pvd" {
        return true;
    }
    let Some((stem, ext)) = name.rsplit_once('.') else {
        return false;
    };
    let digits = |s: &str| !s.is_empty() && s.bytes().all(|b| b.is_ascii_digit());
    let Some((tag, index)) = stem.rsplit_once("_t") else {
        return false;
    };
    ["ply", "obj", "stl", "vtp"].contains(&ext) && digits(index) && is_class_tag(tag)
}

/// Whether `tag` is one of [`class_tag`]'s tags (`classK` or `classK_slug`), for telling a set's
/// files from others.
pub fn is_class_tag(tag: &str) -> bool {
    let Some(rest) = tag.strip_prefix("class") else {
        return false;
    };
    let (k, slug) = rest.split_once('_').unwrap_or((rest, ""));
    !k.is_empty()
        && k.bytes().all(|b| b.is_ascii_digit())
        && slug.bytes().all(|b| b.is_ascii_alphanumeric() || b == b'-')
}

/// The mesh files of one run, and the collection entries of those written so far.
#[derive(Debug)]
pub struct MeshFiles {
    output: PathBuf,
    format: Format,
    space: Space,
    kind: Kind,
    entries: Vec<pvd::Entry>,
    /// The files written so far, under temporary names until [`MeshFiles::finish`].
    set: OutputSet,
}

#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Kind {
    /// One time, one class: the output path itself.
    One,
    /// One time, several classes: `STEM_classK_name.EXT` beside the output path.
    PerClass,
    /// Several times: `DIR/classK_name_tIIII.EXT`.
    Series,
}

impl MeshFiles {
    /// The files of a mesh at one time of `classes` classes: `path` itself for one class, else
    /// `STEM_classK_name.EXT` beside it; the format from the extension, vertices in `space`.
    pub fn single(path: &Path, classes: usize, space: Space) -> Result<MeshFiles> {
        Ok(MeshFiles {
            output: path.to_path_buf(),
            format: Format::from_path(path)?,
            space,
            kind: if classes == 1 {
                Kind::One
            } else {
                Kind::PerClass
            },
            entries: Vec::new(),
            set: OutputSet::new(),
        })
    }

    /// The files of a time series in directory `dir` (created if missing, and removed again
    /// if the run does not finish): `classK_name_tIIII.EXT`, IIII the time's index, vertices
    /// in `space`. Written over an earlier series (`--force`), the earlier series' files this
    /// one does not write again are removed at the commit ([`OutputSet::supersede`]).
    pub fn series(dir: &Path, format: Format, space: Space) -> Result<MeshFiles> {
        let mut set = OutputSet::new();
        set.create_dir(dir)?;
        set.supersede(dir, is_series_file);
        Ok(MeshFiles {
            output: dir.to_path_buf(),
            format,
            space,
            kind: Kind::Series,
            entries: Vec::new(),
            set,
        })
    }

    /// The path of class `k` (0-based, named `name`) at the `i`-th time.
    pub fn path(&self, i: usize, k: usize, name: &str) -> PathBuf {
        let tag = class_tag(k, name);
        let ext = self.format.extension();
        match self.kind {
            Kind::One => self.output.clone(),
            Kind::PerClass => {
                let stem = self
                    .output
                    .file_stem()
                    .unwrap_or_default()
                    .to_string_lossy();
                self.output.with_file_name(format!("{stem}_{tag}.{ext}"))
            }
            Kind::Series => self.output.join(format!("{tag}_t{i:04}.{ext}")),
        }
    }

    /// The frame the files' vertices are written in.
    pub fn space(&self) -> Space {
        self.space
    }

    /// Writes the mesh (RAS world coordinates) of class `k` (0-based; its name and label in
    /// `class`, its display colour `color`) at the `i`-th time, world time `t`, under a
    /// temporary name until [`MeshFiles::finish`], and records it for the collection.
    pub fn write(
        &mut self,
        i: usize,
        t: f32,
        k: usize,
        class: ClassInfo<'_>,
        color: [u8; 3],
        mesh: &Mesh,
    ) -> Result<()> {
        let path = self.path(i, k, class.name);
        let info = MeshInfo::new(class.name, self.space)
            .with_label(class.label)
            .with_time(f64::from(t))
            .with_color(color);
        let bytes = encode(mesh, self.format, &info)
            .with_context(|| format!("cannot encode {}", path.display()))?;
        self.set.write(&path, &bytes)?;
        self.entries.push(pvd::Entry {
            time: t,
            part: k as u32 + 1,
            name: class.name.to_string(),
            file: path
                .file_name()
                .unwrap_or_default()
                .to_string_lossy()
                .into_owned(),
        });
        Ok(())
    }

    /// Ends the run: for a series of VTK XML files adds `series.pvd` (ParaView collections
    /// list VTK XML files only), then puts every file in place at once (all or none), and
    /// returns the collection's path; `None` where there is none.
    pub fn finish(mut self) -> Result<Option<PathBuf>> {
        let collection = self.collection();
        if let Some(path) = &collection {
            self.set
                .write(path, pvd::encode(&self.entries).as_bytes())?;
        }
        self.set.commit()?;
        Ok(collection)
    }

    /// The collection [`MeshFiles::finish`] writes: `series.pvd` in the directory of a series
    /// of VTK XML files (ParaView collections list VTK XML files only), else none.
    pub fn collection(&self) -> Option<PathBuf> {
        (self.kind == Kind::Series && self.format == Format::Vtp)
            .then(|| self.output.join("series.pvd"))
    }
}

#[cfg(test)]
mod tests {
    use super::super::tests::tetrahedron;
    use super::*;

    #[test]
    fn series_files_are_told_from_others() {
        for name in [
            "series.pvd",
            "class1_LV_t0000.vtp",
            "class12_t0005.ply",
            "class2_a-b_t0001.stl",
        ] {
            assert!(is_series_file(name), "{name}");
        }
        for name in [
            "notes.txt",
            "class1_LV_t0000.vtp.bak",
            "classX_t0001.vtp",
            "class1_a_t.vtp",
            "heart.vtp",
        ] {
            assert!(!is_series_file(name), "{name}");
        }
    }

    #[test]
    fn class_tags_are_file_name_safe() {
        assert_eq!(class_tag(0, "LV blood pool"), "class1_LV-blood-pool");
        assert_eq!(class_tag(2, "myo/cardium"), "class3_myo-cardium");
        assert_eq!(class_tag(1, "??"), "class2");
    }

    #[test]
    fn paths_per_kind_and_the_collection_of_a_vtp_series() {
        let dir = tempfile::tempdir().unwrap();
        let one = MeshFiles::single(&dir.path().join("a.ply"), 1, Space::Lps).unwrap();
        assert_eq!(one.path(0, 0, "x"), dir.path().join("a.ply"));
        assert_eq!(one.space(), Space::Lps);
        let many = MeshFiles::single(&dir.path().join("a.ply"), 2, Space::Ras).unwrap();
        assert_eq!(
            many.path(0, 1, "lung"),
            dir.path().join("a_class2_lung.ply")
        );
        assert!(MeshFiles::single(&dir.path().join("a.txt"), 1, Space::Lps).is_err());

        let series_dir = dir.path().join("s");
        let mut series = MeshFiles::series(&series_dir, Format::Vtp, Space::Lps).unwrap();
        let mesh = tetrahedron();
        let a = ClassInfo {
            name: "a",
            label: 4,
        };
        series.write(0, 0.0, 0, a, [1, 2, 3], &mesh).unwrap();
        series.write(1, 0.5, 0, a, [1, 2, 3], &mesh).unwrap();
        assert!(
            !series_dir.join("class1_a_t0001.vtp").exists(),
            "a file of an unfinished set is visible"
        );
        let pvd = series.finish().unwrap().unwrap();
        let vtp = std::fs::read(series_dir.join("class1_a_t0001.vtp")).unwrap();
        let vtp = String::from_utf8_lossy(&vtp);
        assert!(vtp.contains("Name=\"TimeValue\" NumberOfTuples=\"1\" format=\"ascii\">0.5<"));
        assert!(vtp.contains("Name=\"Label\" NumberOfTuples=\"1\" format=\"ascii\">4<"));
        assert!(vtp.contains("type=\"UInt8\" Name=\"Colors\" NumberOfComponents=\"3\""));
        let text = std::fs::read_to_string(pvd).unwrap();
        assert!(text.contains(
            "timestep=\"0.5\" group=\"\" part=\"1\" name=\"a\" file=\"class1_a_t0001.vtp\""
        ));

        let mut ply = MeshFiles::series(&series_dir, Format::Ply, Space::Lps).unwrap();
        ply.write(0, 0.0, 0, a, [1, 2, 3], &mesh).unwrap();
        assert_eq!(ply.finish().unwrap(), None);
        assert!(series_dir.join("class1_a_t0000.ply").exists());
    }

    #[test]
    fn an_unfinished_run_leaves_nothing_and_an_earlier_set_untouched() {
        let dir = tempfile::tempdir().unwrap();
        let mesh = tetrahedron();
        let class = |name| ClassInfo { name, label: 1 };
        // An earlier per-class set, then a run over it that stops after its first class (an
        // error in the second class's extraction, a full disk): the old set stays whole.
        let out = dir.path().join("m.ply");
        let mut first = MeshFiles::single(&out, 2, Space::Ras).unwrap();
        first
            .write(0, 0.0, 0, class("a"), [1, 1, 1], &mesh)
            .unwrap();
        first
            .write(0, 0.0, 1, class("b"), [1, 1, 1], &mesh)
            .unwrap();
        first.finish().unwrap();
        let before: Vec<_> = ["m_class1_a.ply", "m_class2_b.ply"]
            .map(|n| std::fs::read(dir.path().join(n)).unwrap())
            .into();
        let mut second = MeshFiles::single(&out, 2, Space::Lps).unwrap();
        second
            .write(0, 0.0, 0, class("a"), [1, 1, 1], &mesh)
            .unwrap();
        drop(second);
        let after: Vec<_> = ["m_class1_a.ply", "m_class2_b.ply"]
            .map(|n| std::fs::read(dir.path().join(n)).unwrap())
            .into();
        assert_eq!(before, after);
        assert_eq!(std::fs::read_dir(dir.path()).unwrap().count(), 2);
        // A series directory the unfinished run created is removed.
        let series = dir.path().join("series");
        let mut s = MeshFiles::series(&series, Format::Vtp, Space::Lps).unwrap();
        s.write(0, 0.0, 0, class("a"), [1, 1, 1], &mesh).unwrap();
        drop(s);
        assert!(!series.exists());
    }
}
