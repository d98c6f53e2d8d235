//! `dynaslice mesh` and the mesh library on a real model file whose zero sets are known: a
//! hand-built one-layer SIREN computing two spheres (`dynaslice_test_support::spheres`, see
//! [`two_spheres`]). Checks that sparse
//! extraction through the network equals dense extraction, the geometry and normal velocity
//! against closed forms, and the command line's files and errors.

use dynaslice_core::ModelBytes;
use dynaslice_mesh::{self as mesh, Options, Sampling, Surfaces};
use dynaslice_sequence::palette::class_color;
use dynaslice_test_support::spheres::{self, Sphere, SPHERES_DOMAIN};
use std::f64::consts::PI;
use std::path::Path;
use std::process::Command;

/// Class 1: radius² = R² + 2·R·V·t in normalised units (R = 0.5, V = 0.1), centred.
const R1: f64 = 0.5;
const V1: f64 = 0.1;
/// Class 2: a static sphere of radius 0.3 at normalised (0.4, 0, 0), overlapping class 1.
const R2: f64 = 0.3;
const C2: [f64; 3] = [0.4, 0.0, 0.0];

/// Normalised class-1 radius at normalised time t.
fn r1(t: f64) -> f64 {
    (R1 * R1 + 2.0 * R1 * V1 * t).sqrt()
}

/// The two classes above in [`SPHERES_DOMAIN`] (centre (10, −5, 2), half-extent 20 = σ, time
/// 0..2): f¹ = (|x|² − R² − 2RVt)/(2R) and f² = (|x − c|² − r²)/(2r), sphere SDFs to first
/// order at their surfaces.
fn two_spheres() -> Vec<u8> {
    spheres::model(
        &[Sphere::new([0.0; 3], R1, V1), Sphere::new(C2, R2, 0.0)],
        &[("ball", 1), ("small ball", 7)],
    )
}

fn rel(a: f64, b: f64) -> f64 {
    (a - b).abs() / b.abs()
}

#[test]
fn sparse_extraction_through_the_network_equals_dense_and_the_closed_forms() {
    let bytes = ModelBytes::copy_from(&two_spheres());
    let model = bytes.model().unwrap();
    let bounds = model.domain().bounds();
    let s = SPHERES_DOMAIN.scale[0] as f64;
    for surfaces in [Surfaces::Overlapping, Surfaces::Partition] {
        let sparse = Options {
            resolution: 48,
            surfaces,
            ..Options::default()
        };
        let dense = Options {
            sampling: Sampling::Dense,
            ..sparse
        };
        let t = 1.0; // world; normalised 0.5
        let a = mesh::extract(&model, bounds, t, &[0, 1], &sparse).unwrap();
        let b = mesh::extract(&model, bounds, t, &[0, 1], &dense).unwrap();
        assert_eq!(a.meshes, b.meshes, "{surfaces:?}");
        // The partition's bound is twice as wide (λ = 2), so it prunes less.
        let saving = match surfaces {
            Surfaces::Overlapping => 4,
            Surfaces::Partition => 2,
        };
        assert!(
            a.stats.value_evaluations * saving < b.stats.value_evaluations,
            "{surfaces:?} {:?}",
            a.stats
        );
        for m in &a.meshes {
            assert!(m.topology().is_closed_manifold(), "{:?}", m.topology());
        }
        if surfaces == Surfaces::Overlapping {
            let ball = |r: f64| 4.0 / 3.0 * PI * (s * r).powi(3);
            // Vertices lie on the surface, so the mesh is an inscribed polyhedron: its volume
            // falls short by O(h²/r²), 0.3% for class 2 (7 cells per radius).
            let r = r1(0.5);
            assert!(rel(a.meshes[0].enclosed_volume(), ball(r)) < 5e-3);
            assert!(rel(a.meshes[1].enclosed_volume(), ball(R2)) < 5e-3);
            // World coordinates: class 2 is centred at c + s·C2 = (18, −5, 2).
            let m = &a.meshes[1];
            let mean = |a: usize| m.positions.iter().map(|p| p[a] as f64).sum::<f64>();
            let n = m.positions.len() as f64;
            for (axis, want) in [18.0, -5.0, 2.0].into_iter().enumerate() {
                assert!((mean(axis) / n - want).abs() < 0.05, "axis {axis}");
            }
            // v_n = −(∂f/∂t)/‖∇f‖ = V·R/r in normalised units, times s/τ in world units.
            let want = V1 * R1 / r * s / SPHERES_DOMAIN.time_span as f64;
            for v in &a.meshes[0].normal_velocity {
                assert!((*v as f64 - want).abs() < 1e-2 * want, "{v} vs {want}");
            }
            assert!(a.meshes[1].normal_velocity.iter().all(|v| v.abs() < 1e-3));
        } else {
            // The partition splits the overlap between the classes, so the two regions are
            // disjoint and their volumes add up to the union's, below the sum of the balls.
            let sum: f64 = a.meshes.iter().map(|m| m.enclosed_volume()).sum();
            let balls = 4.0 / 3.0 * PI * s.powi(3) * (r1(0.5).powi(3) + R2.powi(3));
            assert!(sum < balls * 0.99, "{sum} vs {balls}");
        }
    }
}

fn dynaslice(args: &[&str]) -> std::process::Output {
    Command::new(env!("CARGO_BIN_EXE_dynaslice"))
        .args(args)
        .output()
        .unwrap()
}

fn write_model(dir: &Path) -> String {
    let path = dir.join("spheres.dsm");
    std::fs::write(&path, two_spheres()).unwrap();
    path.to_str().unwrap().to_string()
}

#[test]
fn writes_one_file_per_class_in_every_format() {
    let dir = tempfile::tempdir().unwrap();
    let model = write_model(dir.path());
    for ext in ["ply", "obj", "stl", "vtp"] {
        let out = dir.path().join(format!("heart.{ext}"));
        let o = dynaslice(&[
            "mesh",
            &model,
            "--time",
            "0.5",
            "--resolution",
            "32",
            "-o",
            out.to_str().unwrap(),
        ]);
        let stderr = String::from_utf8_lossy(&o.stderr);
        assert!(o.status.success(), "{stderr}");
        assert!(stderr.contains("value + ") && stderr.contains("dense grid: 35937 values"));
        assert!(!stderr.contains("NOT a closed manifold"), "{stderr}");
        for (k, tag) in ["class1_ball", "class2_small-ball"].iter().enumerate() {
            let file = dir.path().join(format!("heart_{tag}.{ext}"));
            assert!(std::fs::metadata(&file).unwrap().len() > 1000, "{file:?}");
            if ext == "ply" {
                // The class colour (the palette's: the model records none) on every vertex,
                // after x y z nx ny nz normal_velocity.
                let bytes = std::fs::read(&file).unwrap();
                let end = b"end_header\n";
                let at = bytes.windows(end.len()).position(|w| w == end).unwrap() + end.len();
                let header = String::from_utf8_lossy(&bytes[..at]);
                assert!(
                    header.contains(
                        "property uchar red\nproperty uchar green\nproperty uchar blue\n"
                    ),
                    "{header}"
                );
                let vertex = &bytes[at..at + 7 * 4 + 3];
                assert_eq!(vertex[28..], class_color(k, None), "{file:?}");
            }
        }
    }
    // One class by name: exactly the path given.
    let one = dir.path().join("one.stl");
    let o = dynaslice(&[
        "mesh",
        &model,
        "--time",
        "2",
        "--class",
        "small ball",
        "-o",
        one.to_str().unwrap(),
        "--resolution",
        "24",
        "--non-overlapping",
    ]);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let stl = stl_io::read_stl(&mut std::fs::File::open(&one).unwrap()).unwrap();
    assert!(stl.faces.len() > 100);
}

#[test]
fn a_time_series_goes_to_a_directory_with_a_paraview_collection() {
    let dir = tempfile::tempdir().unwrap();
    let model = write_model(dir.path());
    let out = dir.path().join("series");
    let o = dynaslice(&[
        "mesh",
        &model,
        "--times",
        "0:2:3",
        "--class",
        "1",
        "--resolution",
        "24",
        "-o",
        out.to_str().unwrap(),
    ]);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let pvd = std::fs::read_to_string(out.join("series.pvd")).unwrap();
    for (i, t) in ["0", "1", "2"].iter().enumerate() {
        let file = format!("class1_ball_t{i:04}.vtp");
        assert!(out.join(&file).exists(), "{file}");
        let entry = format!(
            "<DataSet timestep=\"{t}\" group=\"\" part=\"1\" name=\"ball\" file=\"{file}\"/>"
        );
        assert!(pvd.contains(&entry), "{pvd}");
    }
    assert_eq!(pvd.matches("<DataSet").count(), 3);
}

#[test]
fn errors_name_the_file_and_the_problem() {
    let dir = tempfile::tempdir().unwrap();
    let model = write_model(dir.path());
    let out = dir.path().join("x.ply");
    let out = out.to_str().unwrap();
    for (args, want) in [
        (
            vec!["--time", "0", "--class", "rv"],
            "no class \"rv\"; the model's classes are 1 \"ball\", 2 \"small ball\"",
        ),
        (
            vec!["--time", "3"],
            "--time 3 is outside the model's time range [0, 2]",
        ),
        (vec!["--times", "0:1"], "A:B:N takes three values"),
        (
            vec!["--time", "0", "--resolution", "0"],
            "invalid value '0' for '--resolution <RESOLUTION>'",
        ),
    ] {
        let mut all = vec!["mesh", model.as_str(), "-o", out];
        all.extend(args);
        let o = dynaslice(&all);
        let stderr = String::from_utf8_lossy(&o.stderr);
        assert!(
            !o.status.success() && stderr.contains(want),
            "{all:?}: {stderr}"
        );
    }
    // A time a series made is named with the series as typed.
    let series_dir = dir.path().join("series");
    let o = dynaslice(&[
        "mesh",
        &model,
        "--times",
        "0:3:4",
        "-o",
        series_dir.to_str().unwrap(),
    ]);
    let stderr = String::from_utf8_lossy(&o.stderr);
    assert!(
        !o.status.success()
            && stderr.contains("--times 0:3:4: time 3 is outside the model's time range [0, 2]"),
        "{stderr}"
    );
    let o = dynaslice(&["mesh", &model, "--time", "0", "-o", "mesh.off"]);
    let stderr = String::from_utf8_lossy(&o.stderr);
    assert!(
        stderr.contains("-o mesh.off: a mesh must be named *.ply or *.obj or *.stl or *.vtp"),
        "{stderr}"
    );
    let o = dynaslice(&["mesh", "missing.dsm", "--time", "0", "-o", out]);
    assert!(String::from_utf8_lossy(&o.stderr).contains("missing.dsm"));
}
