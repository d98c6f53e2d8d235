//! Wavefront OBJ: `v` positions, `vn` normals (when present) and `f v//vn` faces, one `o` object
//! named after the class. OBJ has no per-vertex scalars, so the normal velocity is not written.

use super::super::Mesh;
use std::fmt::Write;

pub(super) fn encode(mesh: &Mesh, name: &str) -> Vec<u8> {
    let mut s = String::with_capacity(mesh.positions.len() * 64 + mesh.triangles.len() * 32);
    // Writing to a String cannot fail.
    let _ = writeln!(
        s,
        "# DynaSlice surface\no {}",
        name.replace(char::is_whitespace, "_")
    );
    for p in &mesh.positions {
        let _ = writeln!(s, "v {} {} {}", p[0], p[1], p[2]);
    }
    for n in &mesh.normals {
        let _ = writeln!(s, "vn {} {} {}", n[0], n[1], n[2]);
    }
    let normals = !mesh.normals.is_empty();
    for t in &mesh.triangles {
        let [a, b, c] = t.map(|i| i + 1);
        let _ = if normals {
            writeln!(s, "f {a}//{a} {b}//{b} {c}//{c}")
        } else {
            writeln!(s, "f {a} {b} {c}")
        };
    }
    s.into_bytes()
}

#[cfg(test)]
mod tests {
    use super::super::tests::tetrahedron;
    use super::*;

    #[test]
    fn writes_indexed_faces_with_normals() {
        let text = String::from_utf8(encode(&tetrahedron(), "left ventricle")).unwrap();
        let lines: Vec<&str> = text.lines().collect();
        assert_eq!(lines[1], "o left_ventricle");
        assert_eq!(lines.iter().filter(|l| l.starts_with("v ")).count(), 4);
        assert_eq!(lines.iter().filter(|l| l.starts_with("vn ")).count(), 4);
        assert!(lines.contains(&"v 0 0 1"));
        assert_eq!(*lines.last().unwrap(), "f 2//2 3//3 4//4");
    }
}
