//! Every mesh `dynaslice mesh` writes is a closed, consistently wound 2-manifold as other
//! programs read it, in every format: the shared `.csl` shapes (OReX's, trained briefly) and the
//! synthetic benchmark's moving chambers, written as PLY, OBJ, STL and VTP, read back by trimesh
//! (VTP through VTK), which welds vertices by position as every STL reader must. Each edge must
//! have exactly two faces. Our own STL reader's welded topology is checked too. Skips with a
//! notice where the shared data or the Python libraries are missing (CI has both and sets
//! DYNASLICE_REQUIRE_PYTHON).

mod common;

use common::{succeeded, train_command};
use dynaslice_mesh::io::read_stl;
use dynaslice_test_support::fixtures::shared_data;
use dynaslice_test_support::python::run_python;
use std::path::{Path, PathBuf};
use std::process::Command;

const FORMATS: [&str; 4] = ["ply", "obj", "stl", "vtp"];

fn dynaslice(args: &[&str]) -> std::process::Output {
    Command::new(env!("CARGO_BIN_EXE_dynaslice"))
        .args(args)
        .output()
        .unwrap()
}

fn s(p: &Path) -> &str {
    p.to_str().unwrap()
}

/// The files with extension `ext` in `dir`, sorted.
fn files(dir: &Path, ext: &str) -> Vec<PathBuf> {
    let mut out: Vec<PathBuf> = std::fs::read_dir(dir)
        .unwrap()
        .map(|e| e.unwrap().path())
        .filter(|p| p.extension().is_some_and(|e| e == ext))
        .collect();
    out.sort();
    out
}

/// trimesh's verdict on each mesh file: `path watertight winding_consistent max_faces_per_edge
/// faces`. PLY, OBJ and STL are loaded as trimesh loads them (merging vertices by position);
/// VTP through VTK into a trimesh built the same way.
const CHECK: &str = r#"
import sys
import numpy as np
import trimesh

for path in sys.argv[1:]:
    if path.endswith('.vtp'):
        import vtk
        from vtk.util.numpy_support import vtk_to_numpy
        r = vtk.vtkXMLPolyDataReader()
        r.SetFileName(path)
        r.Update()
        poly = r.GetOutput()
        vertices = vtk_to_numpy(poly.GetPoints().GetData())
        faces = vtk_to_numpy(poly.GetPolys().GetConnectivityArray()).reshape(-1, 3)
        m = trimesh.Trimesh(vertices, faces, process=True)
    else:
        m = trimesh.load(path, force='mesh')
    edges = np.sort(m.edges, axis=1)
    _, per_edge = np.unique(edges, axis=0, return_counts=True)
    print(path, m.is_watertight, m.is_winding_consistent, int(per_edge.max()), len(m.faces))
"#;

/// The mesh files of every format in `dir` (per-class files of one mesh, or a series).
fn meshes_in(dir: &Path) -> Vec<PathBuf> {
    FORMATS.iter().flat_map(|ext| files(dir, ext)).collect()
}

/// Checks mesh files (each of the four formats among them) with our STL reader and trimesh.
fn assert_watertight(paths: &[PathBuf]) {
    for ext in FORMATS {
        assert!(
            paths
                .iter()
                .any(|p| p.extension().is_some_and(|e| e == ext)),
            "no .{ext} file among {paths:?}"
        );
    }
    // Our reader welds STL vertices by position, as every STL reader must.
    for stl in paths
        .iter()
        .filter(|p| p.extension().is_some_and(|e| e == "stl"))
    {
        let mesh = read_stl(stl).unwrap();
        let topology = mesh.topology();
        assert!(
            topology.is_closed_manifold(),
            "{}: {topology:?}",
            stl.display()
        );
    }
    let refs: Vec<&Path> = paths.iter().map(|p| p.as_path()).collect();
    let Some(out) = run_python(&["trimesh", "vtk", "numpy"], CHECK, &refs) else {
        return;
    };
    assert_eq!(out.lines().count(), paths.len(), "{out}");
    for line in out.lines() {
        let fields: Vec<&str> = line.split_whitespace().collect();
        assert_eq!(
            fields[1..4],
            ["True", "True", "2"],
            "not watertight, misoriented or an edge of more than two faces: {line}"
        );
        assert!(fields[4].parse::<usize>().unwrap() > 0, "{line}");
    }
    println!("{} meshes checked:\n{out}", paths.len());
}

#[test]
fn shared_csl_shapes_mesh_watertight_in_every_format() {
    let Some(data) = shared_data("csl") else {
        return;
    };
    let dir = tempfile::tempdir().unwrap();
    let mut paths = Vec::new();
    for csl in files(&data, "csl") {
        let name = csl.file_stem().unwrap().to_str().unwrap().to_string();
        let model = dir.path().join(format!("{name}.dsm"));
        succeeded(
            &train_command(&csl, &model, &["--steps", "150"])
                .output()
                .unwrap(),
        );
        let out = dir.path().join(&name);
        std::fs::create_dir(&out).unwrap();
        for ext in FORMATS {
            let file = out.join(format!("{name}.{ext}"));
            succeeded(&dynaslice(&[
                "mesh",
                s(&model),
                "--resolution",
                "96",
                "--threads",
                "2",
                "-o",
                s(&file),
            ]));
        }
        paths.extend(meshes_in(&out));
    }
    assert!(paths.len() >= 4 * 3, "{paths:?}");
    assert_watertight(&paths);
}

#[test]
fn synthetic_benchmark_meshes_watertight_in_every_format() {
    let dir = tempfile::tempdir().unwrap();
    let data = dir.path().join("synth");
    succeeded(&dynaslice(&[
        "synth",
        "-o",
        s(&data),
        "--shape",
        "chambers",
        "--timesteps",
        "5",
        "--train-every",
        "2",
        "--planes",
        "6,6",
        "--plane-resolution",
        "96",
        "--volume-resolution",
        "8",
    ]));
    let model = dir.path().join("chambers.dsm");
    succeeded(
        &train_command(
            &data.join("chambers").join("slices.json"),
            &model,
            &["--steps", "150"],
        )
        .output()
        .unwrap(),
    );
    let mut paths = Vec::new();
    for ext in FORMATS {
        let out = dir.path().join(format!("series_{ext}"));
        succeeded(&dynaslice(&[
            "mesh",
            s(&model),
            "--times",
            "0:1:3",
            "--format",
            ext,
            "--resolution",
            "80",
            "--threads",
            "2",
            "-o",
            s(&out),
        ]));
        paths.extend(meshes_in(&out));
    }
    // Every class at each of the 3 times, in each format.
    assert!(paths.len() >= 4 * 3, "{paths:?}");
    assert_watertight(&paths);
}
