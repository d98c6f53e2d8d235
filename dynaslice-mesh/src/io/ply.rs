//! Binary little-endian PLY through `ply-rs-bw`: `vertex` with `x y z nx ny nz normal_velocity`
//! (float; the attributes only when the mesh has them), `dx dy dz` (float, the displacement of a
//! motion model's carried series, where the mesh has one) and `red green blue` (uchar, the class
//! colour, when known: the vertex colour properties MeshLab, trimesh, ParaView and 3D Slicer
//! read), and `face` with `vertex_indices` (uchar count, uint indices). The header comments name the class and, on a line of its own
//! as 3D Slicer writes it, the frame (`comment SPACE=LPS`).

use super::super::Mesh;
use super::{one_line, MeshInfo};
use anyhow::Result;
use ply_rs_bw::ply::{
    Addable, ElementDef, Encoding, Ply, PropertyAccess, PropertyDef, PropertyType, ScalarType,
};
use ply_rs_bw::writer::Writer;

/// One PLY record: the writer asks each for its properties by name, so records borrow nothing
/// and no per-vertex map is built (`DefaultElement` would allocate one per vertex).
#[derive(Clone)]
enum Record {
    Vertex {
        position: [f32; 3],
        normal: [f32; 3],
        normal_velocity: f32,
        displacement: [f32; 3],
        color: [u8; 3],
    },
    Face([u32; 3]),
}

impl PropertyAccess for Record {
    /// Required by the trait for reading, which this type is never used for.
    fn new() -> Self {
        Record::Face([0; 3])
    }

    fn get_float(&self, name: &str) -> Option<f32> {
        let Record::Vertex {
            position: p,
            normal: n,
            normal_velocity,
            displacement: d,
            ..
        } = self
        else {
            return None;
        };
        Some(match name {
            "x" => p[0],
            "y" => p[1],
            "z" => p[2],
            "nx" => n[0],
            "ny" => n[1],
            "nz" => n[2],
            "normal_velocity" => *normal_velocity,
            "dx" => d[0],
            "dy" => d[1],
            "dz" => d[2],
            _ => return None,
        })
    }

    fn get_uchar(&self, name: &str) -> Option<u8> {
        let Record::Vertex { color, .. } = self else {
            return None;
        };
        Some(match name {
            "red" => color[0],
            "green" => color[1],
            "blue" => color[2],
            _ => return None,
        })
    }

    fn get_list_uint(&self, name: &str) -> Option<&[u32]> {
        match self {
            Record::Face(f) if name == "vertex_indices" => Some(f),
            _ => None,
        }
    }
}

/// `mesh`, already in `info.space`, as PLY.
pub(super) fn encode(mesh: &Mesh, info: &MeshInfo) -> Result<Vec<u8>> {
    let attributes = !mesh.normals.is_empty();
    let mut ply = Ply::<Record>::new();
    ply.header.encoding = Encoding::BinaryLittleEndian;
    let comments = &mut ply.header.comments;
    comments.push(format!("DynaSlice surface: {}", one_line(info.name)));
    comments.push(info.space.tag());
    if let Some(label) = info.label {
        comments.push(format!("label {label}"));
    }
    if let Some(t) = info.time {
        comments.push(format!("time {t}"));
    }
    let float = |n: &str| PropertyDef::new(n.to_string(), PropertyType::Scalar(ScalarType::Float));
    let mut vertex = ElementDef::new("vertex".to_string());
    let mut names = vec!["x", "y", "z"];
    if attributes {
        names.extend(["nx", "ny", "nz", "normal_velocity"]);
    }
    if !mesh.displacement.is_empty() {
        names.extend(["dx", "dy", "dz"]);
    }
    names
        .into_iter()
        .for_each(|n| vertex.properties.add(float(n)));
    if info.color.is_some() {
        for n in ["red", "green", "blue"] {
            vertex.properties.add(PropertyDef::new(
                n.to_string(),
                PropertyType::Scalar(ScalarType::UChar),
            ));
        }
    }
    ply.header.elements.add(vertex);
    let mut face = ElementDef::new("face".to_string());
    face.properties.add(PropertyDef::new(
        "vertex_indices".to_string(),
        PropertyType::List(ScalarType::UChar, ScalarType::UInt),
    ));
    ply.header.elements.add(face);
    let vertices = (0..mesh.positions.len())
        .map(|i| Record::Vertex {
            position: mesh.positions[i],
            normal: mesh.normals.get(i).copied().unwrap_or_default(),
            normal_velocity: mesh.normal_velocity.get(i).copied().unwrap_or_default(),
            displacement: mesh.displacement.get(i).copied().unwrap_or_default(),
            color: info.color.unwrap_or_default(),
        })
        .collect();
    ply.payload.insert("vertex".to_string(), vertices);
    ply.payload.insert(
        "face".to_string(),
        mesh.triangles.iter().map(|&t| Record::Face(t)).collect(),
    );
    let mut out = Vec::new();
    Writer::new().write_ply(&mut out, &mut ply)?;
    Ok(out)
}

#[cfg(test)]
mod tests {
    use super::super::tests::tetrahedron;
    use super::*;
    use ply_rs_bw::parser::Parser;
    use ply_rs_bw::ply::{DefaultElement, Property};

    #[test]
    fn round_trips_through_the_parser() {
        let mesh = tetrahedron();
        let info = MeshInfo::new("lv", super::super::Space::Ras)
            .with_label(3)
            .with_color([230, 25, 75]);
        let bytes = encode(&mesh, &info).unwrap();
        assert!(bytes.starts_with(b"ply\nformat binary_little_endian 1.0\n"));
        let header = String::from_utf8_lossy(&bytes[..200]);
        assert!(
            header.contains("comment DynaSlice surface: lv\ncomment SPACE=RAS\ncomment label 3\n")
        );
        let ply = Parser::<DefaultElement>::new()
            .read_ply(&mut bytes.as_slice())
            .unwrap();
        let v = &ply.payload["vertex"];
        assert_eq!(v.len(), 4);
        assert_eq!(v[3]["z"], Property::Float(1.0));
        assert_eq!(v[1]["nx"], Property::Float(1.0));
        assert_eq!(v[2]["normal_velocity"], Property::Float(2.0));
        for (i, c) in ["red", "green", "blue"].iter().enumerate() {
            assert!(v.iter().all(|r| r[*c] == Property::UChar([230, 25, 75][i])));
        }
        // Without a colour, no colour properties.
        let plain = encode(&mesh, &MeshInfo::new("lv", super::super::Space::Ras)).unwrap();
        let plain = String::from_utf8_lossy(&plain[..200]).into_owned();
        assert!(!plain.contains("property uchar red"), "{plain}");
        let f = &ply.payload["face"];
        assert_eq!(f[3]["vertex_indices"], Property::ListUInt(vec![1, 2, 3]));
        assert!(!plain.contains("property float dx"), "{plain}");
    }

    #[test]
    fn a_displacement_is_three_float_properties() {
        let mut mesh = tetrahedron();
        mesh.displacement = (0..4).map(|i| [i as f32, -0.5, 2.0]).collect();
        let bytes = encode(&mesh, &MeshInfo::new("lv", super::super::Space::Ras)).unwrap();
        let ply = Parser::<DefaultElement>::new()
            .read_ply(&mut bytes.as_slice())
            .unwrap();
        let v = &ply.payload["vertex"];
        assert_eq!(v[3]["dx"], Property::Float(3.0));
        assert_eq!(v[1]["dy"], Property::Float(-0.5));
        assert_eq!(v[2]["dz"], Property::Float(2.0));
    }
}
