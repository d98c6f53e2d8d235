//! Binary STL through `stl_io`: one record per triangle with its facet normal. STL stores no
//! connectivity or vertex attributes; readers re-index by position.

use super::super::Mesh;
use anyhow::Result;
use stl_io::{Normal, Triangle, Vertex};

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
}
