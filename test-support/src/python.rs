//! Running Python scripts that use the libraries our users use (nibabel, pydicom, pynrrd, …) to
//! make test inputs and to read our outputs.
//!
//! On a developer's machine without those libraries the tests skip with a notice. CI installs
//! them and sets `DYNASLICE_REQUIRE_PYTHON`, so there a missing module is a failure, not a skip.

use std::path::Path;
use std::process::Command;

/// Runs `script` with `python3 -c script args…` when every module of `modules` imports, and
/// returns its stdout; `None`, after printing why, when one does not. Panics (failing the test)
/// when the script fails, showing its stderr, or when a module is missing while
/// `DYNASLICE_REQUIRE_PYTHON` is set.
pub fn run_python(modules: &[&str], script: &str, args: &[&Path]) -> Option<String> {
    let probe = modules
        .iter()
        .map(|m| format!("import {m}"))
        .collect::<Vec<_>>()
        .join("; ");
    let importable = Command::new("python3")
        .args(["-c", &probe])
        .output()
        .is_ok_and(|o| o.status.success());
    if !importable {
        assert!(
            std::env::var_os("DYNASLICE_REQUIRE_PYTHON").is_none(),
            "`python3 -c '{probe}'` fails but DYNASLICE_REQUIRE_PYTHON is set"
        );
        println!(
            "SKIPPED: `python3 -c '{probe}'` fails (pip install {})",
            modules.join(" ")
        );
        return None;
    }
    let out = Command::new("python3")
        .arg("-c")
        .arg(script)
        .args(args)
        .output()
        .expect("python3 runs");
    assert!(
        out.status.success(),
        "python script failed:\n{}",
        String::from_utf8_lossy(&out.stderr)
    );
    Some(String::from_utf8(out.stdout).expect("python prints UTF-8"))
}

/// For each VTP series in DIR (argv[1]) as `dynaslice mesh --times` writes it, class by class and time by time: the class, the file,
/// whether trimesh finds it watertight, whether its faces are the first time's, and where it
/// has a `displacement` the largest |first + displacement − points| after `vtkWarpVector` and
/// the mean displacement; else `none`.
const READ_VTP_SERIES: &str = r#"
import sys, glob, os
import numpy as np
import trimesh, vtk
from vtk.util.numpy_support import vtk_to_numpy

def read(path):
    r = vtk.vtkXMLPolyDataReader()
    r.SetFileName(path)
    r.Update()
    return r.GetOutput()

def faces(poly):
    return vtk_to_numpy(poly.GetPolys().GetConnectivityArray()).reshape(-1, 3)

d = sys.argv[1]
tags = sorted({os.path.basename(p).rsplit('_t', 1)[0] for p in glob.glob(os.path.join(d, '*.vtp'))})
for tag in tags:
    paths = sorted(glob.glob(os.path.join(d, tag + '_t*.vtp')))
    first = read(paths[0])
    for path in paths:
        poly = read(path)
        pts = vtk_to_numpy(poly.GetPoints().GetData()).astype(np.float64)
        watertight = trimesh.Trimesh(pts, faces(poly)).is_watertight
        same = len(pts) == first.GetNumberOfPoints() and np.array_equal(faces(poly), faces(first))
        array = poly.GetPointData().GetArray('displacement')
        if array is None:
            print(tag, os.path.basename(path), watertight, same, 'none')
            continue
        first.GetPointData().SetVectors(array)
        warp = vtk.vtkWarpVector()
        warp.SetInputData(first)
        warp.Update()
        warped = vtk_to_numpy(warp.GetOutput().GetPoints().GetData()).astype(np.float64)
        print(tag, os.path.basename(path), watertight, same,
              float(np.abs(warped - pts).max()), *vtk_to_numpy(array).mean(0))
"#;

/// The rows of the script `READ_VTP_SERIES` (above) for the series in `dir`, split on
/// whitespace; `None` where the Python libraries (trimesh, vtk, numpy) are missing.
pub fn read_vtp_series(dir: &Path) -> Option<Vec<Vec<String>>> {
    let out = run_python(&["trimesh", "vtk", "numpy"], READ_VTP_SERIES, &[dir])?;
    Some(
        out.lines()
            .map(|l| l.split_whitespace().map(str::to_string).collect())
            .collect(),
    )
}
