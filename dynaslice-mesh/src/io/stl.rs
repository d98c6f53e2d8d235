//! STL through `stl_io`, both ways: binary STL out, one record per triangle with its facet
//! normal, the 80-byte header naming the frame (`SPACE=LPS`, as 3D Slicer writes and reads it)
//! and the class; binary or ASCII STL in (reference meshes for the Chamfer distance), back into
//! our RAS world by the same tag. STL stores no connectivity or vertex attributes; `stl_io`
//! re-indexes by position when reading.

use super::super::Mesh;
use super::{MeshInfo, Space};
use anyhow::{ensure, Context, Result};
use std::io::Read;
use std::path::Path;
use stl_io::{Normal, Triangle, Vertex};

/// Bytes of a binary STL header.
const HEADER: usize = 80;

/// Reads an STL file (binary or ASCII) as a mesh of positions and triangles in our RAS world
/// (no normals or normal velocity: STL has neither per vertex). A file whose header (binary) or
/// first line (ASCII) says `SPACE=LPS` has x and y negated back; one saying `SPACE=RAS`, or
/// nothing, is taken as world coordinates as they stand (reference meshes come untagged from
/// the tools that made their cross-sections, in the same coordinates). Errors name the file.
pub fn read_stl(path: &Path) -> Result<Mesh> {
    let file = std::fs::File::open(path)
        .with_context(|| format!("cannot open reference mesh {}", path.display()))?;
    let mut head = Vec::with_capacity(HEADER);
    (&file)
        .take(HEADER as u64)
        .read_to_end(&mut head)
        .with_context(|| format!("cannot read {}", path.display()))?;
    let space = header_space(&head);
    let mut reader = std::io::BufReader::new(file);
    std::io::Seek::rewind(&mut reader)
        .with_context(|| format!("cannot read {}", path.display()))?;
    let stl = stl_io::read_stl(&mut reader)
        .with_context(|| format!("{}: not a readable STL file", path.display()))?;
    let positions: Vec<[f32; 3]> = stl
        .vertices
        .iter()
        .map(|v| space.to_ras([v[0], v[1], v[2]]))
        .collect();
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

/// The frame an STL file's first bytes name: within the first line of an ASCII file
/// (`solid …`), anywhere in a binary file's 80-byte header; RAS when untagged.
fn header_space(head: &[u8]) -> Space {
    let text = match head.iter().position(|&b| b == b'\n') {
        Some(end) if head.starts_with(b"solid") => &head[..end],
        _ => head,
    };
    Space::find_tag(text).unwrap_or(Space::Ras)
}

/// The 80-byte header: `DynaSlice SPACE=LPS <name>`, cut at 80 bytes and padded with spaces.
/// It never starts with `solid`, which would make readers take the file for ASCII STL.
fn header(info: &MeshInfo) -> [u8; HEADER] {
    let text = format!("DynaSlice {} {}", info.space.tag(), info.name);
    let mut out = [b' '; HEADER];
    // Byte-wise: a name cut inside a UTF-8 character is harmless in a header nobody decodes.
    for (o, b) in out.iter_mut().zip(text.bytes()) {
        *o = b;
    }
    out
}

/// `mesh`, already in `info.space`, as binary STL.
pub(super) fn encode(mesh: &Mesh, info: &MeshInfo) -> Result<Vec<u8>> {
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
    ensure!(
        u32::try_from(mesh.triangles.len()).is_ok(),
        "{} triangles: binary STL counts at most 2^32 - 1",
        mesh.triangles.len()
    );
    let mut out = Vec::with_capacity(HEADER + 4 + 50 * mesh.triangles.len());
    stl_io::write_stl(&mut out, triangles)?;
    // `stl_io` writes a zeroed header; ours names the frame.
    out[..HEADER].copy_from_slice(&header(info));
    Ok(out)
}

#[cfg(test)]
mod tests {
    use super::super::tests::tetrahedron;
    use super::super::{encode as encode_in, Format};
    use super::*;

    #[test]
    fn round_trips_through_the_reader() {
        let mesh = tetrahedron();
        let bytes = encode(&mesh, &MeshInfo::new("lv", Space::Lps)).unwrap();
        assert_eq!(bytes.len(), 84 + 50 * 4);
        assert!(bytes.starts_with(b"DynaSlice SPACE=LPS lv   "));
        let read = stl_io::read_stl(&mut std::io::Cursor::new(bytes)).unwrap();
        assert_eq!((read.vertices.len(), read.faces.len()), (4, 4));
        // The last face is the slanted one: its normal is (1, 1, 1)/√3, outward.
        let n = read.faces[3].normal;
        assert!((n[0] - 1.0 / 3f32.sqrt()).abs() < 1e-6, "{n:?}");
    }

    #[test]
    fn long_names_are_cut_to_the_header() {
        let name = "x".repeat(200);
        let h = header(&MeshInfo::new(&name, Space::Ras));
        assert!(h.starts_with(b"DynaSlice SPACE=RAS xxx"));
        assert_eq!(h[HEADER - 1], b'x');
    }

    #[test]
    fn the_frame_comes_from_the_header_or_first_line() {
        assert_eq!(header_space(b"DynaSlice SPACE=LPS a"), Space::Lps);
        assert_eq!(header_space(b"3D Slicer output. SPACE=RAS"), Space::Ras);
        assert_eq!(header_space(&[0; 80]), Space::Ras);
        assert_eq!(header_space(b"solid SPACE=LPS\nfacet"), Space::Lps);
        // In an ASCII file only the first line counts.
        assert_eq!(header_space(b"solid x\n SPACE=LPS"), Space::Ras);
    }

    #[test]
    fn read_back_is_in_ras_whatever_the_frame_written() {
        let dir = tempfile::tempdir().unwrap();
        let mut mesh = tetrahedron();
        mesh.positions.iter_mut().for_each(|p| p[0] += 5.0);
        for space in Space::ALL {
            let path = dir.path().join(format!("t_{space}.stl"));
            let bytes = encode_in(&mesh, Format::Stl, &MeshInfo::new("t", space)).unwrap();
            std::fs::write(&path, bytes).unwrap();
            let back = read_stl(&path).unwrap();
            assert_eq!(back.triangles.len(), mesh.triangles.len());
            let rel = (back.enclosed_volume() / mesh.enclosed_volume() - 1.0).abs();
            assert!(rel < 1e-6, "{rel}");
            let max_x = back.positions.iter().map(|p| p[0]).fold(f32::MIN, f32::max);
            assert_eq!(max_x, 6.0, "{space}");
        }
    }

    #[test]
    fn read_errors_name_the_file() {
        let dir = tempfile::tempdir().unwrap();
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
