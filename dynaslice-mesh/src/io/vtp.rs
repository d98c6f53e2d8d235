//! VTK XML PolyData (.vtp), written directly: points, triangle `Polys`, point data `Normals`
//! (3 components), `normal_velocity` (1 component), `displacement` (3 components, where the mesh
//! has one: a motion model's carried series, the active vectors so that ParaView's Warp By
//! Vector and `vtkWarpVector` take it by default) and, when the class colour is known,
//! `Colors` (UInt8, 3 components: VTK's direct RGB colours; ParaView shows them with "Map
//! Scalars" off, 3D Slicer with direct colour mapping) as raw little-endian arrays in the
//! appended section (UInt64 byte-count headers), and field data that 3D Slicer and ParaView
//! read: `SPACE` (string, `RAS`/`LPS`: Slicer's frame tag), `ClassName` (string), `Label`
//! (Int32) and `TimeValue` (Float64, the name VTK's time-aware writers use), the last two when
//! known.
//!
//! Why not `vtkio`: its XML writer has no field data and no string arrays, which the frame tag
//! and class name need; the format itself is a few elements.

use super::super::Mesh;
use super::MeshInfo;
use std::fmt::Write;

/// One array of the appended section: its XML attributes and its bytes.
struct Appended {
    attributes: String,
    bytes: Vec<u8>,
}

fn floats(name: &str, components: usize, values: impl Iterator<Item = f32>) -> Appended {
    Appended {
        attributes: format!("type=\"Float32\" Name=\"{name}\" NumberOfComponents=\"{components}\""),
        bytes: values.flat_map(f32::to_le_bytes).collect(),
    }
}

fn bytes(name: &str, components: usize, values: impl Iterator<Item = u8>) -> Appended {
    Appended {
        attributes: format!("type=\"UInt8\" Name=\"{name}\" NumberOfComponents=\"{components}\""),
        bytes: values.collect(),
    }
}

fn ints(name: &str, values: impl Iterator<Item = i64>) -> Appended {
    Appended {
        attributes: format!("type=\"Int64\" Name=\"{name}\""),
        bytes: values.flat_map(i64::to_le_bytes).collect(),
    }
}

/// A string as VTK writes string arrays in ASCII: each byte's code, then a terminating 0.
fn string_codes(s: &str) -> String {
    let mut out = String::with_capacity(4 * s.len() + 1);
    for b in s.bytes().filter(|&b| b != 0) {
        // Writing to a String cannot fail.
        let _ = write!(out, "{b} ");
    }
    out.push('0');
    out
}

/// `mesh`, already in `info.space`, as VTK XML PolyData.
pub(super) fn encode(mesh: &Mesh, info: &MeshInfo) -> Vec<u8> {
    let mut xml = String::from(
        "<?xml version=\"1.0\"?>\n<VTKFile type=\"PolyData\" version=\"1.0\" \
         byte_order=\"LittleEndian\" header_type=\"UInt64\">\n  <PolyData>\n    <FieldData>\n",
    );
    let mut field = |line: String| {
        xml.push_str("      ");
        xml.push_str(&line);
        xml.push('\n');
    };
    field(format!(
        "<Array type=\"String\" Name=\"SPACE\" NumberOfTuples=\"1\" format=\"ascii\">{}</Array>",
        string_codes(info.space.name())
    ));
    field(format!(
        "<Array type=\"String\" Name=\"ClassName\" NumberOfTuples=\"1\" format=\"ascii\">{}</Array>",
        string_codes(info.name)
    ));
    if let Some(label) = info.label {
        field(format!(
            "<DataArray type=\"Int32\" Name=\"Label\" NumberOfTuples=\"1\" format=\"ascii\">{label}</DataArray>"
        ));
    }
    if let Some(t) = info.time {
        field(format!(
            "<DataArray type=\"Float64\" Name=\"TimeValue\" NumberOfTuples=\"1\" format=\"ascii\">{t:?}</DataArray>"
        ));
    }
    xml.push_str("    </FieldData>\n");
    let _ = writeln!(
        xml,
        "    <Piece NumberOfPoints=\"{}\" NumberOfVerts=\"0\" NumberOfLines=\"0\" \
         NumberOfStrips=\"0\" NumberOfPolys=\"{}\">",
        mesh.positions.len(),
        mesh.triangles.len()
    );

    let mut point_data = Vec::new();
    if !mesh.normals.is_empty() {
        point_data.push(floats("Normals", 3, mesh.normals.iter().flatten().copied()));
    }
    if !mesh.normal_velocity.is_empty() {
        point_data.push(floats(
            "normal_velocity",
            1,
            mesh.normal_velocity.iter().copied(),
        ));
    }
    if !mesh.displacement.is_empty() {
        point_data.push(floats(
            "displacement",
            3,
            mesh.displacement.iter().flatten().copied(),
        ));
    }
    if let Some(color) = info.color {
        let n = mesh.positions.len();
        point_data.push(bytes("Colors", 3, color.into_iter().cycle().take(3 * n)));
    }
    let points = floats("Points", 3, mesh.positions.iter().flatten().copied());
    let connectivity = ints(
        "connectivity",
        mesh.triangles.iter().flatten().map(|&i| i64::from(i)),
    );
    let offsets = ints("offsets", (1..=mesh.triangles.len() as i64).map(|i| 3 * i));

    // Each appended array is its UInt64 byte count followed by its bytes; `offset` counts from
    // the byte after the `_` that opens the section.
    let mut appended: Vec<u8> = Vec::new();
    let mut element = |xml: &mut String, indent: &str, array: &Appended| {
        let _ = writeln!(
            xml,
            "{indent}<DataArray {} format=\"appended\" offset=\"{}\"/>",
            array.attributes,
            appended.len()
        );
        appended.extend((array.bytes.len() as u64).to_le_bytes());
        appended.extend(&array.bytes);
    };
    let mut names = String::new();
    if !mesh.normals.is_empty() {
        names.push_str(" Normals=\"Normals\"");
    }
    if !mesh.normal_velocity.is_empty() {
        names.push_str(" Scalars=\"normal_velocity\"");
    }
    if !mesh.displacement.is_empty() {
        names.push_str(" Vectors=\"displacement\"");
    }
    let _ = writeln!(xml, "      <PointData{names}>");
    for array in &point_data {
        element(&mut xml, "        ", array);
    }
    xml.push_str("      </PointData>\n      <Points>\n");
    element(&mut xml, "        ", &points);
    xml.push_str("      </Points>\n      <Polys>\n");
    element(&mut xml, "        ", &connectivity);
    element(&mut xml, "        ", &offsets);
    xml.push_str(
        "      </Polys>\n    </Piece>\n  </PolyData>\n  <AppendedData encoding=\"raw\">\n   _",
    );
    let mut out = xml.into_bytes();
    out.extend(appended);
    out.extend(b"\n  </AppendedData>\n</VTKFile>\n");
    out
}

#[cfg(test)]
mod tests {
    use super::super::tests::tetrahedron;
    use super::super::Space;
    use super::*;

    #[test]
    fn names_every_array_and_tag() {
        // VTK itself reads these files back in tests/frames.rs (points, normals, velocity,
        // colours and field data, as ParaView and 3D Slicer get them).
        let info = MeshInfo::new("lv", Space::Ras)
            .with_label(7)
            .with_time(0.25)
            .with_color([31, 119, 180]);
        let bytes = encode(&tetrahedron(), &info);
        let text = String::from_utf8_lossy(&bytes);
        assert!(text.contains("type=\"PolyData\""), "{text}");
        assert!(text.contains("Name=\"normal_velocity\"") && text.contains("Name=\"Normals\""));
        assert!(
            !text.contains("displacement"),
            "a marched mesh has none: {text}"
        );
        assert!(text.contains("Name=\"SPACE\" NumberOfTuples=\"1\" format=\"ascii\">82 65 83 0<"));
        assert!(
            text.contains("Name=\"ClassName\" NumberOfTuples=\"1\" format=\"ascii\">108 118 0<")
        );
        assert!(text.contains("Name=\"Label\" NumberOfTuples=\"1\" format=\"ascii\">7<"));
        assert!(text.contains("Name=\"TimeValue\" NumberOfTuples=\"1\" format=\"ascii\">0.25<"));
    }

    #[test]
    fn a_displacement_is_the_active_vectors() {
        let mut mesh = tetrahedron();
        mesh.displacement = vec![[1.0, 2.0, 3.0]; 4];
        let text =
            String::from_utf8_lossy(&encode(&mesh, &MeshInfo::new("x", Space::Ras))).into_owned();
        assert!(text.contains(" Vectors=\"displacement\">"), "{text}");
        assert!(
            text.contains("type=\"Float32\" Name=\"displacement\" NumberOfComponents=\"3\""),
            "{text}"
        );
    }

    #[test]
    fn a_mesh_without_attributes_or_label_has_only_geometry_and_names() {
        let mut mesh = tetrahedron();
        mesh.normals.clear();
        mesh.normal_velocity.clear();
        let text =
            String::from_utf8_lossy(&encode(&mesh, &MeshInfo::new("x", Space::Lps))).into_owned();
        assert!(text.contains("<PointData>\n      </PointData>"), "{text}");
        assert!(!text.contains("Label") && !text.contains("TimeValue") && !text.contains("Colors"));
        assert!(text.contains(">76 80 83 0<"));
    }
}
