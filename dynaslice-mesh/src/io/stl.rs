//! STL through `stl_io`, both ways: binary STL out, one record per triangle with its facet
//! normal; binary or ASCII STL in (reference meshes for the Chamfer distance). STL stores no
//! connectivity or vertex attributes; `stl_io` re-indexes by position when reading.

use super::super::Mesh;
use anyhow::{ensure, Context, Result};
use std::path::Path;
use stl_io::{Normal, Triangle, Vertex};

/// Reads an STL file (binary or ASCII) as a mesh of positions and triangles (no normals or
/// normal velocity: STL has neither per vertex). Errors name the file.
pub fn read_stl(path: &Path) -> Result<Mesh> {
    let file = std::fs::File::open(path)
        .with_context(|| format!("cannot open reference mesh {}", path.display()))?;
    let stl = stl_io::read_stl(&mut std::io::BufReader::new(file))
        .with_context(|| format!("{}: not a readable STL file", path.display()))?;
    let positions: Vec<[f32; 3]> = stl.vertices.iter().map(|v| [v[0], v[1], v[2]]).collect();
    ensure!(
        positions.iter().flatten().all(|v| v.is_finite()),
        "{}: a vertex is not finite",
        path.display()
    );
    let triangles = stl
        .faces
        .iter()
        .map(|f| f.vertices.map(|i| i as u32))
        .collect::<Vec<_>>();
    ensure!(!triangles.is_empty(), "{}: no triangles", path.display());
    Ok(Mesh {
        positions,
        triangles,
        ..Mesh::default()
    })
}

pub(super) fn encode(mesh: &Mesh) -> Result<Vec<u8>> {
    let triangles = mesh.triangles.iter().map(|t| {
        let [a, b, c] = t.map(|i| mesh.positions[i as usize]);
        let u: [f32; 3] = std::array::from_fn(|k| b[k] - a[k]);
        let v: [f32; 3] = std::array::from_fn(|k| c[k] - a[k]);
        let n = [
            u[1] * v[2] - u[2] * v[1],
            u[2] * v[0] - u[0] * v[2],
            u[0] * v[1] - u[1] * v[0],
        ];
        let len = (n[0] * n[0] + n[1] * n[1] + n[2] * n[2]).sqrt();
        // A degenerate triangle gets the zero normal, which readers recompute from the winding.
        let n = if len > 0.0 {
            n.map(|x| x / len)
        } else {
            [0.0; 3]
        };
        Triangle {
            normal: Normal::new(n),
            vertices: [Vertex::new(a), Vertex::new(b), Vertex::new(c)],
        }
    });
    let mut out = Vec::new();
    stl_io::write_stl(&mut out, triangles)?;
    Ok(out)
}

#[cfg(test)]
mod tests {
    use super::super::tests::tetrahedron;
    use super::*;

    #[test]
    fn round_trips_through_the_reader() {
        let mesh = tetrahedron();
        let bytes = encode(&mesh).unwrap();
        assert_eq!(bytes.len(), 84 + 50 * 4);
        let read = stl_io::read_stl(&mut std::io::Cursor::new(bytes)).unwrap();
        assert_eq!((read.vertices.len(), read.faces.len()), (4, 4));
        // The last face is the slanted one: its normal is (1, 1, 1)/√3, outward.
        let n = read.faces[3].normal;
        assert!((n[0] - 1.0 / 3f32.sqrt()).abs() < 1e-6, "{n:?}");
    }

    #[test]
    fn read_back_keeps_the_geometry_and_errors_name_the_file() {
        let dir = tempfile::tempdir().unwrap();
        let mesh = tetrahedron();
        let path = dir.path().join("t.stl");
        std::fs::write(&path, encode(&mesh).unwrap()).unwrap();
        let back = read_stl(&path).unwrap();
        assert_eq!(back.triangles.len(), mesh.triangles.len());
        let rel = (back.enclosed_volume() / mesh.enclosed_volume() - 1.0).abs();
        assert!(rel < 1e-6, "{rel}");
        let bad = dir.path().join("bad.stl");
        std::fs::write(&bad, b"solid x\nfacet oops\n").unwrap();
        let e = read_stl(&bad).unwrap_err().to_string();
        assert!(e.contains("bad.stl"), "{e}");
        let e = read_stl(&dir.path().join("none.stl"))
            .unwrap_err()
            .to_string();
        assert!(e.contains("none.stl"), "{e}");
    }
}
