//! VTK XML PolyData (.vtp) through `vtkio` (XML feature only, no compression): points, triangle
//! `Polys`, and point data `Normals` (3 components) and `normal_velocity` (1 component).

use super::super::Mesh;
use anyhow::Result;
use vtkio::model::{
    Attribute, Attributes, ByteOrder, DataSet, PolyDataPiece, Version, VertexNumbers, Vtk,
};

pub(super) fn encode(mesh: &Mesh, name: &str) -> Result<Vec<u8>> {
    let mut data = Attributes::new();
    if !mesh.normals.is_empty() {
        let normals: Vec<f32> = mesh.normals.iter().flatten().copied().collect();
        data.point
            .push(Attribute::normals("Normals").with_data(normals));
    }
    if !mesh.normal_velocity.is_empty() {
        data.point
            .push(Attribute::scalars("normal_velocity", 1).with_data(mesh.normal_velocity.clone()));
    }
    let piece = PolyDataPiece {
        points: mesh
            .positions
            .iter()
            .flatten()
            .copied()
            .collect::<Vec<f32>>()
            .into(),
        polys: Some(VertexNumbers::XML {
            connectivity: mesh.triangles.iter().flatten().map(|&i| i as u64).collect(),
            offsets: (1..=mesh.triangles.len() as u64).map(|i| 3 * i).collect(),
        }),
        data,
        ..Default::default()
    };
    let vtk = Vtk {
        version: Version::new((1, 0)),
        byte_order: ByteOrder::LittleEndian,
        title: name.to_string(),
        file_path: None,
        data: DataSet::inline(piece),
    };
    let mut out = Vec::new();
    vtk.write_xml(&mut out)?;
    Ok(out)
}

#[cfg(test)]
mod tests {
    use super::super::tests::tetrahedron;
    use super::*;

    #[test]
    fn round_trips_through_the_parser() {
        let bytes = encode(&tetrahedron(), "lv").unwrap();
        let text = String::from_utf8_lossy(&bytes);
        assert!(text.contains("type=\"PolyData\""), "{text}");
        assert!(text.contains("Name=\"normal_velocity\"") && text.contains("Name=\"Normals\""));
        let vtk = Vtk::parse_xml(bytes.as_slice()).unwrap();
        let DataSet::PolyData { pieces, .. } = vtk.data else {
            panic!("not poly data");
        };
        let vtkio::model::Piece::Inline(piece) = &pieces[0] else {
            panic!("not inline");
        };
        assert_eq!(piece.num_points(), 4);
        assert_eq!(piece.polys.as_ref().unwrap().num_cells(), 4);
        let velocity = piece
            .data
            .point
            .iter()
            .find(|a| a.name() == "normal_velocity");
        let Some(Attribute::DataArray(array)) = velocity else {
            panic!("no normal_velocity");
        };
        assert_eq!(
            array.data.clone().into_vec::<f32>().unwrap(),
            vec![0.5, -1.0, 2.0, 0.25]
        );
    }
}
