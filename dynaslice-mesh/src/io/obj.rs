//! Wavefront OBJ: a leading comment naming the class and the frame (`SPACE=LPS`, which 3D
//! Slicer reads from the file's first comments), `v` positions, `vn` normals (when present) and
//! `f v//vn` faces, one `o` object named after the class. OBJ has no per-vertex scalars, so the
//! normal velocity is not written.

use super::super::Mesh;
use super::{one_line, MeshInfo};
use std::fmt::Write;

/// `mesh`, already in `info.space`, as OBJ text.
pub(super) fn encode(mesh: &Mesh, info: &MeshInfo) -> Vec<u8> {
    let mut s = String::with_capacity(mesh.positions.len() * 64 + mesh.triangles.len() * 32);
    // Writing to a String cannot fail.
    let _ = writeln!(
        s,
        "# DynaSlice surface: {} {}",
        one_line(info.name),
        info.space.tag()
    );
    if let Some(label) = info.label {
        let _ = writeln!(s, "# label {label}");
    }
    if let Some(t) = info.time {
        let _ = writeln!(s, "# time {t}");
    }
    let _ = writeln!(
        s,
        "o {}",
        one_line(info.name).replace(char::is_whitespace, "_")
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
    use super::super::Space;
    use super::*;

    #[test]
    fn writes_indexed_faces_with_normals() {
        let info = MeshInfo::new("left ventricle", Space::Lps);
        let text = String::from_utf8(encode(&tetrahedron(), &info)).unwrap();
        let lines: Vec<&str> = text.lines().collect();
        assert_eq!(lines[0], "# DynaSlice surface: left ventricle SPACE=LPS");
        assert_eq!(lines[1], "o left_ventricle");
        assert_eq!(lines.iter().filter(|l| l.starts_with("v ")).count(), 4);
        assert_eq!(lines.iter().filter(|l| l.starts_with("vn ")).count(), 4);
        assert!(lines.contains(&"v 0 0 1"));
        assert_eq!(*lines.last().unwrap(), "f 2//2 3//3 4//4");
    }

    #[test]
    fn a_name_with_line_breaks_stays_in_its_comment() {
        let info = MeshInfo::new("a\nv 9 9 9", Space::Ras).with_time(0.5);
        let text = String::from_utf8(encode(&tetrahedron(), &info)).unwrap();
        assert!(text.starts_with("# DynaSlice surface: a v 9 9 9 SPACE=RAS\n# time 0.5\n"));
        assert_eq!(text.lines().filter(|l| l.starts_with("v ")).count(), 4);
    }
}
