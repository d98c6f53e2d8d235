//! Mesh file formats, one file each. Every writer builds the file in memory and writes it
//! atomically (temporary file, fsync, rename), so an interrupted run leaves no partial mesh.
//!
//! | format | geometry | vertex normals | `normal_velocity` | `displacement` (a carried series) | class colour | coordinate frame tag |
//! |--------|----------|----------------|-------------------|-------------------|--------------|----------------------|
//! | PLY (binary little-endian) | indexed | `nx ny nz` | `normal_velocity` float property | `dx dy dz` float properties | `red green blue` uchar properties | `comment SPACE=…` |
//! | OBJ | indexed | `vn` | — (no per-vertex scalars in OBJ) | — | — | `# … SPACE=…` first comment |
//! | STL (binary) | triangle soup (the format has no indices) | facet normals only | — | — | — | `SPACE=…` in the 80-byte header |
//! | VTP (VTK XML PolyData) | indexed | point data `Normals` | point data `normal_velocity` | point data `displacement` (the active vectors) | point data `Colors` (UInt8, 3 components) | field data string array `SPACE` |
//!
//! Meshes are computed in our world frame, RAS (NIfTI's: +x right, +y anterior, +z superior).
//! Every writer converts positions, normals and displacements into the [`Space`] asked for and
//! says which in the file, the way 3D Slicer reads it (`vtkMRMLModelStorageNode`: a `SPACE=RAS`
//! / `SPACE=LPS` substring in the PLY comments, the OBJ's leading comment or the STL header; a
//! `SPACE` string array in a VTP's field data). VTP files also carry the class name, label value and time as
//! field data (`ClassName`, `Label`, `TimeValue`), which ParaView shows.

mod files;
mod obj;
mod ply;
pub mod pvd;
mod stl;
mod vtp;

/// The frame mesh vertices are written in (re-exported: meshes, label maps and the model's
/// record of its input share it).
pub use dynaslice_sequence::Space;
pub use files::{class_tag, is_class_tag, MeshFiles};
pub use stl::read_stl;

use super::Mesh;
use anyhow::{bail, ensure, Context, Result};
use dynaslice_output::write_atomically;
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

/// What a mesh file records besides its geometry.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct MeshInfo<'a> {
    /// The class name: PLY comment, OBJ object name, STL header, VTP `ClassName`.
    pub name: &'a str,
    /// The class's label value in its source (VTP field data `Label`), when known.
    pub label: Option<i32>,
    /// World time of the mesh (VTP field data `TimeValue`), when known.
    pub time: Option<f64>,
    /// The frame the vertices are written in.
    pub space: Space,
    /// The class's display colour (sRGB), given to every vertex where the format has vertex
    /// colours (PLY, VTP), when known.
    pub color: Option<[u8; 3]>,
}

impl<'a> MeshInfo<'a> {
    /// A mesh named `name` written in `space`, with no label or time.
    pub fn new(name: &'a str, space: Space) -> Self {
        MeshInfo {
            name,
            label: None,
            time: None,
            space,
            color: None,
        }
    }

    /// With the class's label value.
    pub fn with_label(self, label: i32) -> Self {
        MeshInfo {
            label: Some(label),
            ..self
        }
    }

    /// With the mesh's world time.
    pub fn with_time(self, time: f64) -> Self {
        MeshInfo {
            time: Some(time),
            ..self
        }
    }

    /// With the class's display colour.
    pub fn with_color(self, color: [u8; 3]) -> Self {
        MeshInfo {
            color: Some(color),
            ..self
        }
    }
}

/// `text` with every control character (line breaks included) replaced by a space, so a class
/// name cannot end a header line or comment early.
pub(crate) fn one_line(text: &str) -> String {
    text.chars()
        .map(|c| if c.is_control() { ' ' } else { c })
        .collect()
}

/// `mesh` with positions and normals converted from RAS into `space`, after checking that its
/// parts fit together (indices in range, attributes one per vertex), so no encoder can index
/// out of bounds.
fn in_space(mesh: &Mesh, space: Space) -> Result<Mesh> {
    let n = mesh.positions.len();
    ensure!(
        mesh.normals.is_empty() || mesh.normals.len() == n,
        "{} normals for {n} vertices",
        mesh.normals.len()
    );
    ensure!(
        mesh.normal_velocity.is_empty() || mesh.normal_velocity.len() == n,
        "{} normal velocities for {n} vertices",
        mesh.normal_velocity.len()
    );
    ensure!(
        mesh.displacement.is_empty() || mesh.displacement.len() == n,
        "{} displacements for {n} vertices",
        mesh.displacement.len()
    );
    if let Some(t) = mesh
        .triangles
        .iter()
        .find(|t| t.iter().any(|&i| i as usize >= n))
    {
        bail!("triangle {t:?} refers to a vertex beyond the {n} vertices");
    }
    Ok(Mesh {
        positions: mesh.positions.iter().map(|&p| space.from_ras(p)).collect(),
        triangles: mesh.triangles.clone(),
        normals: mesh.normals.iter().map(|&v| space.from_ras(v)).collect(),
        normal_velocity: mesh.normal_velocity.clone(),
        // A displacement is a vector: the frame's rotation applies to it as to normals.
        displacement: mesh
            .displacement
            .iter()
            .map(|&v| space.from_ras(v))
            .collect(),
    })
}

/// `mesh` (in RAS world coordinates) encoded as a file of `format`, its vertices in
/// `info.space` and the file tagged with it.
pub fn encode(mesh: &Mesh, format: Format, info: &MeshInfo) -> Result<Vec<u8>> {
    let mesh = in_space(mesh, info.space)?;
    match format {
        Format::Ply => ply::encode(&mesh, info),
        Format::Obj => Ok(obj::encode(&mesh, info)),
        Format::Stl => stl::encode(&mesh, info),
        Format::Vtp => Ok(vtp::encode(&mesh, info)),
    }
}

/// Writes `mesh` (in RAS world coordinates) to `path` as `format`, atomically, its vertices in
/// `info.space` and the file tagged with it.
pub fn write(path: &Path, mesh: &Mesh, format: Format, info: &MeshInfo) -> Result<()> {
    let bytes =
        encode(mesh, format, info).with_context(|| format!("cannot encode {}", path.display()))?;
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
            displacement: Vec::new(),
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

    #[test]
    fn spaces_parse_print_and_map() {
        assert_eq!("RAS".parse::<Space>().unwrap(), Space::Ras);
        assert_eq!("lps".parse::<Space>().unwrap(), Space::Lps);
        let e = "xyz".parse::<Space>().unwrap_err().to_string();
        assert!(e.contains("\"xyz\"") && e.contains("ras or lps"), "{e}");
        assert_eq!(Space::default(), Space::Lps);
        for s in Space::ALL {
            assert_eq!(s.to_string().parse::<Space>().unwrap(), s);
            assert_eq!(Space::find_tag(s.tag().as_bytes()), Some(s));
            assert_eq!(s.to_ras(s.from_ras([1.0, 2.0, 3.0])), [1.0, 2.0, 3.0]);
        }
        assert_eq!(Space::Lps.from_ras([1.0, -2.0, 3.0]), [-1.0, 2.0, 3.0]);
        assert_eq!(
            Space::find_tag(b"3D Slicer output. SPACE=LPS"),
            Some(Space::Lps)
        );
        assert_eq!(Space::find_tag(b"space=lps"), None);
    }

    #[test]
    fn lps_keeps_the_winding_outward() {
        // x, y -> -x, -y is a rotation: the enclosed volume keeps its sign.
        let mesh = tetrahedron();
        let lps = in_space(&mesh, Space::Lps).unwrap();
        assert_eq!(lps.positions[1], [-1.0, 0.0, 0.0]);
        assert_eq!(lps.normals[2], [0.0, -1.0, 0.0]);
        assert!((lps.enclosed_volume() - mesh.enclosed_volume()).abs() < 1e-12);
        assert!(mesh.enclosed_volume() > 0.0);
    }

    #[test]
    fn inconsistent_meshes_are_refused_not_indexed() {
        let mut bad = tetrahedron();
        bad.triangles.push([0, 1, 9]);
        for format in Format::ALL {
            let e = encode(&bad, format, &MeshInfo::new("x", Space::Ras))
                .unwrap_err()
                .to_string();
            assert!(e.contains("[0, 1, 9]") && e.contains("4 vertices"), "{e}");
        }
        let mut bad = tetrahedron();
        bad.normals.pop();
        let e = encode(&bad, Format::Ply, &MeshInfo::new("x", Space::Ras)).unwrap_err();
        assert!(e.to_string().contains("3 normals for 4 vertices"), "{e}");
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("bad.obj");
        let e = write(&path, &bad, Format::Obj, &MeshInfo::new("x", Space::Ras)).unwrap_err();
        assert!(format!("{e:#}").contains("bad.obj"), "{e:#}");
        assert!(!path.exists());
    }
}
