//! Where the meshes of one extraction run go: one file per (time, class), named so that a
//! directory of them sorts by class then time, and for a VTP series the ParaView collection
//! (`series.pvd`) that animates them.

use super::super::Mesh;
use super::{pvd, write, Format, MeshInfo, Space};
use anyhow::{Context, Result};
use dynaslice_core::ClassInfo;
use dynaslice_output::write_atomically;
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

/// The mesh files of one run, and the collection entries of those written so far.
#[derive(Debug)]
pub struct MeshFiles {
    output: PathBuf,
    format: Format,
    space: Space,
    kind: Kind,
    entries: Vec<pvd::Entry>,
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
        })
    }

    /// The files of a time series in directory `dir` (created if missing):
    /// `classK_name_tIIII.EXT`, IIII the time's index, vertices in `space`.
    pub fn series(dir: &Path, format: Format, space: Space) -> Result<MeshFiles> {
        std::fs::create_dir_all(dir)
            .with_context(|| format!("cannot create directory {}", dir.display()))?;
        Ok(MeshFiles {
            output: dir.to_path_buf(),
            format,
            space,
            kind: Kind::Series,
            entries: Vec::new(),
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
    /// `class`, its display colour `color`) at the `i`-th time, world time `t`, atomically, and
    /// records it for the collection.
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
        write(&path, mesh, self.format, &info)?;
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

    /// Ends the run: for a series of VTK XML files writes `series.pvd` (ParaView collections list
    /// VTK XML files only) and returns its path; `None` otherwise.
    pub fn finish(self) -> Result<Option<PathBuf>> {
        let Some(path) = self.collection() else {
            return Ok(None);
        };
        write_atomically(&path, pvd::encode(&self.entries).as_bytes())?;
        Ok(Some(path))
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
        let vtp = std::fs::read(series_dir.join("class1_a_t0001.vtp")).unwrap();
        let vtp = String::from_utf8_lossy(&vtp);
        assert!(vtp.contains("Name=\"TimeValue\" NumberOfTuples=\"1\" format=\"ascii\">0.5<"));
        assert!(vtp.contains("Name=\"Label\" NumberOfTuples=\"1\" format=\"ascii\">4<"));
        assert!(vtp.contains("type=\"UInt8\" Name=\"Colors\" NumberOfComponents=\"3\""));
        let pvd = series.finish().unwrap().unwrap();
        let text = std::fs::read_to_string(pvd).unwrap();
        assert!(text.contains(
            "timestep=\"0.5\" group=\"\" part=\"1\" name=\"a\" file=\"class1_a_t0001.vtp\""
        ));

        let mut ply = MeshFiles::series(&series_dir, Format::Ply, Space::Lps).unwrap();
        ply.write(0, 0.0, 0, a, [1, 2, 3], &mesh).unwrap();
        assert_eq!(ply.finish().unwrap(), None);
    }
}
