//! Mesh file formats, one file each. Every writer builds the file in memory and writes it
//! atomically (temporary file, fsync, rename), so an interrupted run leaves no partial mesh.
//!
//! | format | geometry | vertex normals | `normal_velocity` |
//! |--------|----------|----------------|-------------------|
//! | PLY (binary little-endian) | indexed | `nx ny nz` | `normal_velocity` float property |
//! | OBJ | indexed | `vn` | — (no per-vertex scalars in OBJ) |
//! | STL (binary) | triangle soup (the format has no indices) | facet normals only | — |
//! | VTP (VTK XML PolyData) | indexed | point data `Normals` | point data `normal_velocity` |

mod files;
mod obj;
mod ply;
pub mod pvd;
mod stl;
mod vtp;

pub use files::{class_tag, MeshFiles};
pub use stl::read_stl;

use super::Mesh;
use anyhow::{bail, Context, Result};
use dynaslice_data::atomic::write_atomically;
use std::path::Path;

/// A mesh file format.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Format {
    /// Binary little-endian PLY.
    Ply,
    /// Wavefront OBJ (text).
    Obj,
    /// Binary STL.
    Stl,
    /// VTK XML PolyData (.vtp), readable by ParaView.
    Vtp,
}

impl Format {
    /// Every format, in the order of the table above.
    pub const ALL: [Format; 4] = [Format::Ply, Format::Obj, Format::Stl, Format::Vtp];

    /// The file extension (without the dot).
    pub fn extension(self) -> &'static str {
        match self {
            Format::Ply => "ply",
            Format::Obj => "obj",
            Format::Stl => "stl",
            Format::Vtp => "vtp",
        }
    }

    /// The format named by an extension or name such as "ply" (case-insensitive).
    pub fn from_name(name: &str) -> Option<Format> {
        Format::ALL
            .into_iter()
            .find(|f| f.extension().eq_ignore_ascii_case(name))
    }

    /// The format of `path`, from its extension.
    pub fn from_path(path: &Path) -> Result<Format> {
        let ext = path.extension().and_then(|e| e.to_str()).unwrap_or("");
        match Format::from_name(ext) {
            Some(f) => Ok(f),
            None => bail!(
                "{}: unknown mesh format {ext:?}; use .ply, .obj, .stl or .vtp",
                path.display()
            ),
        }
    }
}

/// `mesh` encoded as a file of `format`; `name` (e.g. the class name) goes in the header where
/// the format has one.
pub fn encode(mesh: &Mesh, format: Format, name: &str) -> Result<Vec<u8>> {
    match format {
        Format::Ply => ply::encode(mesh, name),
        Format::Obj => Ok(obj::encode(mesh, name)),
        Format::Stl => stl::encode(mesh),
        Format::Vtp => vtp::encode(mesh, name),
    }
}

/// Writes `mesh` to `path` as `format`, atomically.
pub fn write(path: &Path, mesh: &Mesh, format: Format, name: &str) -> Result<()> {
    let bytes =
        encode(mesh, format, name).with_context(|| format!("cannot encode {}", path.display()))?;
    write_atomically(path, &bytes)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A tetrahedron with per-vertex attributes.
    pub(super) fn tetrahedron() -> Mesh {
        Mesh {
            positions: vec![
                [0.0, 0.0, 0.0],
                [1.0, 0.0, 0.0],
                [0.0, 1.0, 0.0],
                [0.0, 0.0, 1.0],
            ],
            triangles: vec![[0, 2, 1], [0, 1, 3], [0, 3, 2], [1, 2, 3]],
            normals: vec![
                [-0.577, -0.577, -0.577],
                [1.0, 0.0, 0.0],
                [0.0, 1.0, 0.0],
                [0.0, 0.0, 1.0],
            ],
            normal_velocity: vec![0.5, -1.0, 2.0, 0.25],
        }
    }

    #[test]
    fn formats_from_paths() {
        assert_eq!(
            Format::from_path(Path::new("a/b.PLY")).unwrap(),
            Format::Ply
        );
        assert_eq!(Format::from_path(Path::new("x.vtp")).unwrap(), Format::Vtp);
        let e = Format::from_path(Path::new("dir/out.off"))
            .unwrap_err()
            .to_string();
        assert!(e.contains("dir/out.off") && e.contains("\"off\""), "{e}");
        assert!(tetrahedron().topology().is_closed_manifold());
    }
}
