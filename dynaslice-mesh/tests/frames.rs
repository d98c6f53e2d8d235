//! Mesh files as other programs read them: every format in both frames, read back by trimesh
//! (PLY, OBJ, STL) and VTK (VTP), with the frame tag 3D Slicer looks for; VTP field data and the
//! ParaView collection read by VTK and `xml.etree`. Skips with a notice where the Python
//! libraries are missing (CI installs them and sets DYNASLICE_REQUIRE_PYTHON).

use dynaslice_core::ClassInfo;
use dynaslice_mesh::io::{read_stl, write, Format, MeshFiles, MeshInfo, Space};
use dynaslice_mesh::Mesh;
use dynaslice_test_support::python::run_python;

/// [`Mesh::uv_sphere`] of `radius` about `centre` (`n` rings, `2n` segments), with a normal
/// velocity equal to the vertex's z (any per-vertex scalar will do).
fn uv_sphere(centre: [f32; 3], radius: f32, n: u32) -> Mesh {
    let mut mesh = Mesh::uv_sphere(centre, radius, n, 2 * n);
    mesh.normal_velocity = mesh.positions.iter().map(|p| p[2]).collect();
    mesh
}

/// An off-centre sphere (RAS): its centre must come out as (x, y, z) in RAS files and
/// (−x, −y, z) in LPS ones.
const CENTRE: [f32; 3] = [30.0, -20.0, 12.0];
/// A class colour (sRGB) that every vertex of a coloured format must carry.
const COLOR: [u8; 3] = [230, 25, 75];

#[test]
fn sphere_is_outward_and_closed_in_rust() {
    let mesh = uv_sphere(CENTRE, 10.0, 24);
    let topology = mesh.topology();
    assert!(topology.is_closed_manifold(), "{topology:?}");
    assert!(mesh.enclosed_volume() > 0.0);
}

#[test]
fn every_format_and_frame_reads_back_where_it_belongs() {
    let dir = tempfile::tempdir().unwrap();
    let mesh = uv_sphere(CENTRE, 10.0, 24);
    let mut paths = Vec::new();
    for space in Space::ALL {
        for format in Format::ALL {
            let path = dir
                .path()
                .join(format!("sphere_{space}.{}", format.extension()));
            let info = MeshInfo::new("left ventricle", space)
                .with_label(3)
                .with_time(0.5)
                .with_color(COLOR);
            write(&path, &mesh, format, &info).unwrap();
            paths.push(path);
        }
        // Our own reader takes both frames back to RAS.
        let back = read_stl(&dir.path().join(format!("sphere_{space}.stl"))).unwrap();
        let max_x = back.positions.iter().map(|p| p[0]).fold(f32::MIN, f32::max);
        assert!(
            (max_x - (CENTRE[0] + 10.0)).abs() < 1e-4,
            "{space}: {max_x}"
        );
    }
    let refs: Vec<&std::path::Path> = paths.iter().map(|p| p.as_path()).collect();
    let script = r#"
import sys, trimesh, vtk
from vtk.util.numpy_support import vtk_to_numpy
import numpy as np

def tag_of(path):
    # The header text 3D Slicer's model reader gets from VTK's readers, where it looks for
    # SPACE=RAS / SPACE=LPS (vtkMRMLModelStorageNode::GetCoordinateSystemFromFileHeader).
    if path.endswith('.ply'):
        r = vtk.vtkPLYReader()
        r.SetFileName(path)
        r.Update()
        c = r.GetComments()
        texts = [c.GetValue(i) for i in range(c.GetNumberOfValues())]
    elif path.endswith('.obj'):
        r = vtk.vtkOBJReader()
        r.SetFileName(path)
        r.Update()
        texts = r.GetComment().splitlines()
    else:
        r = vtk.vtkSTLReader()
        r.SetFileName(path)
        r.Update()
        texts = [r.GetHeader()]
    return [t for t in texts if 'SPACE=' in t][0].replace(' ', '_')

for path in sys.argv[1:]:
    if path.endswith('.vtp'):
        r = vtk.vtkXMLPolyDataReader()
        r.SetFileName(path)
        r.Update()
        poly = r.GetOutput()
        fd = poly.GetFieldData()
        space = fd.GetAbstractArray('SPACE').GetValue(0)
        name = fd.GetAbstractArray('ClassName').GetValue(0)
        label = fd.GetArray('Label').GetValue(0)
        time = fd.GetArray('TimeValue').GetValue(0)
        points = vtk_to_numpy(poly.GetPoints().GetData())
        normals = vtk_to_numpy(poly.GetPointData().GetArray('Normals'))
        velocity = vtk_to_numpy(poly.GetPointData().GetArray('normal_velocity'))
        centre = (points.min(0) + points.max(0)) / 2
        outward = float(np.min(np.sum(normals * (points - centre), 1)))
        colors = vtk_to_numpy(poly.GetPointData().GetArray('Colors'))
        print('colour', path, len(colors), *np.unique(colors, axis=0).ravel())
        print(path, 'SPACE=' + space, name, int(label), time,
              poly.GetNumberOfPolys(), outward, float(velocity.max()), *centre)
    else:
        m = trimesh.load(path, force='mesh', process=False)
        if path.endswith('.ply'):
            colors = m.visual.vertex_colors[:, :3]
            print('colour', path, len(colors), *np.unique(colors, axis=0).ravel())
        centre = (m.bounds[0] + m.bounds[1]) / 2
        # A positive volume means the winding is outward in the file's frame too.
        print(path, tag_of(path), len(m.faces), float(m.volume), *centre)
"#;
    let Some(out) = run_python(&["trimesh", "vtk", "numpy"], script, &refs) else {
        return;
    };
    let triangles = mesh.triangles.len();
    // Every vertex of the PLY (read by trimesh) and VTP (read by VTK) files has the colour.
    let colours: Vec<&str> = out.lines().filter(|l| l.starts_with("colour ")).collect();
    assert_eq!(colours.len(), 4, "{out}");
    for line in colours {
        let fields: Vec<&str> = line.split_whitespace().collect();
        assert_eq!(fields[2], mesh.positions.len().to_string(), "{line}");
        assert_eq!(fields[3..], ["230", "25", "75"], "{line}");
    }
    for line in out.lines().filter(|l| !l.starts_with("colour ")) {
        let (path, rest) = line.split_once(' ').unwrap();
        let space = if path.contains("_lps.") {
            Space::Lps
        } else {
            Space::Ras
        };
        assert!(rest.contains(&space.tag()), "{line}");
        let fields: Vec<&str> = rest.split_whitespace().collect();
        let centre: Vec<f32> = fields[fields.len() - 3..]
            .iter()
            .map(|v| v.parse().unwrap())
            .collect();
        let expected = space.from_ras(CENTRE);
        for k in 0..3 {
            assert!((centre[k] - expected[k]).abs() < 1e-3, "{line}: {centre:?}");
        }
        let number = |i: usize| fields[fields.len() - 3 - i].parse::<f64>().unwrap();
        if path.ends_with(".vtp") {
            // SPACE=…, name (two words), label, time, polys, outward, max velocity, centre.
            assert_eq!(&fields[1..3], ["left", "ventricle"], "{line}");
            assert_eq!(fields[3], "3");
            assert_eq!(fields[4].parse::<f64>().unwrap(), 0.5);
            assert_eq!(fields[5].parse::<usize>().unwrap(), triangles);
            assert!(
                number(2) > 0.0,
                "normals outward in the file's frame: {line}"
            );
            assert!(
                (number(1) - 22.0).abs() < 1e-4,
                "normal velocity kept: {line}"
            );
        } else {
            let faces_at = fields.len() - 5;
            assert_eq!(
                fields[faces_at].parse::<usize>().unwrap(),
                triangles,
                "{line}"
            );
            let volume = number(1);
            let sphere = 4.0 / 3.0 * std::f64::consts::PI * 1000.0;
            assert!(volume > 0.97 * sphere && volume < sphere, "{line}");
        }
    }
    assert_eq!(out.lines().count(), 8 + 4, "{out}");
}

#[test]
fn paraview_collection_names_blocks_and_vtp_field_data_agree() {
    let dir = tempfile::tempdir().unwrap();
    let series = dir.path().join("series");
    let mut files = MeshFiles::series(&series, Format::Vtp, Space::Lps).unwrap();
    let classes = [
        ClassInfo {
            name: "liver",
            label: 5,
        },
        ClassInfo {
            name: "spleen & <kidney>",
            label: 1,
        },
    ];
    for (i, t) in [0.0f32, 0.25].into_iter().enumerate() {
        for (k, class) in classes.iter().enumerate() {
            let sphere = uv_sphere([k as f32 * 30.0, 0.0, t * 10.0], 5.0, 8);
            files.write(i, t, k, *class, COLOR, &sphere).unwrap();
        }
    }
    let pvd = files.finish().unwrap().unwrap();
    let script = r#"
import sys, os, vtk
import xml.etree.ElementTree as ET
pvd = sys.argv[1]
root = ET.parse(pvd).getroot()
for ds in root.find('Collection').findall('DataSet'):
    r = vtk.vtkXMLPolyDataReader()
    r.SetFileName(os.path.join(os.path.dirname(pvd), ds.get('file')))
    r.Update()
    fd = r.GetOutput().GetFieldData()
    print('|'.join([ds.get('timestep'), ds.get('part'), ds.get('group'), ds.get('name'),
                    fd.GetAbstractArray('ClassName').GetValue(0),
                    str(int(fd.GetArray('Label').GetValue(0))),
                    repr(fd.GetArray('TimeValue').GetValue(0)),
                    fd.GetAbstractArray('SPACE').GetValue(0)]))
"#;
    let Some(out) = run_python(&["vtk"], script, &[&pvd]) else {
        return;
    };
    let expected = [
        "0|1||liver|liver|5|0.0|LPS",
        "0|2||spleen & <kidney>|spleen & <kidney>|1|0.0|LPS",
        "0.25|1||liver|liver|5|0.25|LPS",
        "0.25|2||spleen & <kidney>|spleen & <kidney>|1|0.25|LPS",
    ];
    assert_eq!(out.lines().collect::<Vec<_>>(), expected, "{out}");
}
