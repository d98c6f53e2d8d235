//! A motion model's series as meshes in correspondence (`src/carried.rs`): hand-made motion
//! models whose shape network is a sphere (test-support's `spheres`) and whose motion network
//! is written out by hand: a rigid translation along x (the carried vertices must be the first
//! time's moved by exactly the translation, on the surface marching finds), the same with a
//! growing sphere (the projection's work), a sphere growing too fast for the motion to carry
//! and a motion that folds (both refused and marched instead), and the files a series writes:
//! the `displacement` array of every carried time, read back by VTK and trimesh, none at a
//! marched time, none for a model without motion.

use dynaslice_core::format::{ModelWriter, MotionWriter};
use dynaslice_core::Model;
use dynaslice_mesh::carried::{Carrier, Fallback};
use dynaslice_mesh::io::{Format, MeshFiles, Space};
use dynaslice_mesh::{extract, write_meshes, Lattice, LevelSets, Mesh, Meshed, Options, Surfaces};
use dynaslice_test_support::python::{read_vtp_series, run_python};
use dynaslice_test_support::spheres::{
    translated, translation_x, writer_in, Sphere, SPHERES_DOMAIN,
};

/// The folding motion's sine layer frequency (normalised units).
const EPS: f64 = 0.5;
/// World times of the series (the domain's times are 0..2 s, t_n = t / 2).
const TIMES: [f32; 4] = [0.0, 0.5, 1.2, 2.0];
/// Lattice cells along the longest axis: a cell of 40 / 48 = 0.83 mm.
const RESOLUTION: u32 = 48;
/// How far from its zero set the spheres' field can put a point by f32 rounding alone (mm):
/// f is a difference of cosines near 1 divided by ε² = 0.01 (test-support's `spheres`), so its
/// rounding is about σ·3·2⁻²⁴/(ε²R) ≈ 1.2·10⁻³ mm; 2.7·10⁻³ measured after the projection.
const NOISE: f64 = 5e-3;

/// The translation along x of [`translating`], normalised: the sphere's centre moves by
/// A·sin(ε t_n)/ε (≈ A t_n; test-support's `translated`).
const A: f64 = 0.2;

/// The sphere of radius 0.3 (6 mm) at normalised (0.1, −0.05, 0.02), growing at `rate`
/// (test-support's quadratic field) and carried along x by test-support's `translated` motion.
fn translating(rate: f64) -> ModelWriter {
    translated(&[ball(rate)], &[("ball", 4)], A)
}

fn ball(rate: f64) -> Sphere {
    Sphere::new([0.1, -0.05, 0.02], 0.3, rate)
}

/// The same sphere carried by u_x = k sin(ε x_n) sin(ε t_n) / ε² (two units: cos(ε(x − t)) −
/// cos(ε(x + t)) = 2 sin(εx) sin(εt)): J_u's xx entry reaches about 2k sin(ε t_n), so with
/// k = −1.5 the warp stops being invertible by the fixed point (and folds) late in the series.
fn folding(k: f64) -> ModelWriter {
    let mut w = sphere(0.0);
    let pi2 = std::f64::consts::FRAC_PI_2;
    // First layer Wᵀ (rows x, y, z, t of the two units), the phases; then the output layer.
    let first = [EPS, EPS, 0.0, 0.0, 0.0, 0.0, -EPS, EPS, pi2, pi2];
    let c = k / (2.0 * EPS * EPS);
    let output = [c, 0.0, 0.0, -c, 0.0, 0.0, 0.0, 0.0, 0.0];
    w.motion = Some(motion(vec![2], first.iter().chain(&output)));
    w
}

fn sphere(rate: f64) -> ModelWriter {
    writer_in(SPHERES_DOMAIN, &[ball(rate)], &[("ball", 4)])
}

fn motion<'a>(widths: Vec<u32>, params: impl Iterator<Item = &'a f64>) -> MotionWriter {
    MotionWriter {
        widths,
        omega_t_max: 1.0,
        params: params.map(|&v| v as f32).collect(),
    }
}

/// World x of the translating sphere's centre at world time t.
fn centre_x(t: f32) -> f64 {
    ball(0.0).world_centre()[0] + translation_x(A, f64::from(t))
}

fn options() -> Options {
    Options {
        resolution: RESOLUTION,
        ..Options::default()
    }
}

/// The marched mesh of the model's one class at `t`, and the lattice.
fn marched(model: &Model, t: f32) -> (Mesh, Lattice) {
    let x = extract(model, model.domain().bounds(), t, &[0], &options()).unwrap();
    (x.meshes.into_iter().next().unwrap(), x.lattice)
}

/// The first time's mesh carried to each later time.
fn carried(model: &Model) -> Vec<Result<Mesh, Fallback>> {
    let (reference, lattice) = marched(model, TIMES[0]);
    let field = |t| LevelSets::new(model, t, vec![0], Surfaces::Overlapping, lattice.clip_box());
    let mut carrier = Carrier::new(model, reference, &field(TIMES[0]), 0, lattice.h, TIMES[0]);
    std::iter::once(Ok(carrier.reference()))
        .chain(
            TIMES[1..]
                .iter()
                .map(|&t| carrier.carry(model, &field(t), 0, lattice.h, t).0),
        )
        .collect()
}

/// The largest |f| / ‖∇f‖ of the model at `mesh`'s vertices (world units).
fn off_surface(model: &Model, mesh: &Mesh, t: f32) -> f64 {
    let (mut f, mut g) = ([0.0f32], [[0.0f32; 3]]);
    mesh.positions
        .iter()
        .map(|&p| {
            model.eval_grad(p, t, &mut f, &mut g).unwrap();
            let n = g[0]
                .iter()
                .map(|v| f64::from(*v).powi(2))
                .sum::<f64>()
                .sqrt();
            f64::from(f[0]).abs() / n
        })
        .fold(0.0, f64::max)
}

#[test]
fn a_translation_carries_every_vertex_by_itself_onto_the_marched_surface() {
    let bytes = translating(0.0).to_bytes();
    let model = Model::from_bytes(&bytes).unwrap();
    let series = carried(&model);
    let reference = series[0].as_ref().unwrap();
    let (marched_first, _) = marched(&model, TIMES[0]);
    assert_eq!(reference.triangles, marched_first.triangles);
    // Marching leaves its vertices up to a few hundredths of a cell off the surface (one Newton
    // step along each lattice edge, bisection where the step would leave it); the reference is
    // projected onto the surface, as every later time is.
    let settling = off_surface(&model, &marched_first, TIMES[0]);
    let off = off_surface(&model, reference, TIMES[0]);
    println!("first time: marched vertices up to {settling} mm off the surface, projected {off}");
    assert!(off < NOISE && settling > off, "{settling} {off}");
    for (mesh, &t) in series[1..].iter().zip(&TIMES[1..]) {
        let mesh = mesh.as_ref().unwrap_or_else(|e| panic!("t = {t}: {e}"));
        assert_eq!(mesh.triangles, reference.triangles, "t = {t}");
        let topology = mesh.topology();
        assert!(topology.is_closed_manifold(), "t = {t}: {topology:?}");
        assert_eq!(topology.euler_characteristic, 2);
        // Every vertex moved by the translation, and only by it (up to the field's rounding).
        let shift = centre_x(t) - centre_x(TIMES[0]);
        assert!(shift > 0.9, "{shift}");
        for d in &mesh.displacement {
            let want = [shift, 0.0, 0.0];
            for a in 0..3 {
                assert!((f64::from(d[a]) - want[a]).abs() < NOISE, "t = {t}: {d:?}");
            }
        }
        for ((p, p0), d) in mesh
            .positions
            .iter()
            .zip(&reference.positions)
            .zip(&mesh.displacement)
        {
            assert_eq!(*p, std::array::from_fn(|a| p0[a] + d[a]));
        }
        // On the surface marching finds at t: the field vanishes there, the enclosed volumes
        // agree (the same sphere, moved).
        let off = off_surface(&model, mesh, t);
        assert!(off < NOISE, "t = {t}: {off}");
        let (at_t, _) = marched(&model, t);
        let (v, v_t) = (mesh.enclosed_volume(), at_t.enclosed_volume());
        assert!((v - v_t).abs() < 2e-3 * v_t, "t = {t}: {v} vs {v_t}");
        // Unit outward normals (the centre is at y = −6, z = 2.4 mm).
        for (n, p) in mesh.normals.iter().zip(&mesh.positions) {
            let r = [
                f64::from(p[0]) - centre_x(t),
                f64::from(p[1]) + 6.0,
                f64::from(p[2]) - 2.4,
            ];
            let len = r.iter().map(|v| v * v).sum::<f64>().sqrt();
            let cos: f64 = (0..3).map(|a| f64::from(n[a]) * r[a] / len).sum();
            assert!(cos > 0.999, "t = {t}: normal {n:?} at {p:?}");
        }
    }
}

#[test]
fn a_growing_shape_is_projected_onto_its_surface_at_each_time() {
    // The radius grows by 0.01 normalised units (0.2 mm) per unit t_n: a quarter of a cell at
    // the end, which the motion does not carry and the projection makes up.
    let bytes = translating(0.01).to_bytes();
    let model = Model::from_bytes(&bytes).unwrap();
    let sphere = ball(0.01);
    let series = carried(&model);
    let c = sphere.world_centre();
    for (mesh, &t) in series.iter().zip(&TIMES) {
        let mesh = mesh.as_ref().unwrap_or_else(|e| panic!("t = {t}: {e}"));
        assert!(mesh.topology().is_closed_manifold());
        let off = off_surface(&model, mesh, t);
        assert!(off < NOISE, "t = {t}: {off}");
        // On the closed-form sphere at t (the field departs from it by a few µm).
        let r = sphere.world_radius(f64::from(t));
        let worst = mesh
            .positions
            .iter()
            .map(|p| {
                let d = [
                    f64::from(p[0]) - centre_x(t),
                    f64::from(p[1]) - c[1],
                    f64::from(p[2]) - c[2],
                ];
                (d.iter().map(|v| v * v).sum::<f64>().sqrt() - r).abs()
            })
            .fold(0.0, f64::max);
        assert!(worst < 0.02, "t = {t}: {worst}");
        // The growth is along the normal: the displacement less the shift is radial, by the
        // growth of the radius.
        let shift = centre_x(t) - centre_x(TIMES[0]);
        let growth = r - sphere.world_radius(f64::from(TIMES[0]));
        for (p, d) in mesh.positions.iter().zip(&mesh.displacement) {
            let n = [
                f64::from(p[0]) - centre_x(t),
                f64::from(p[1]) - c[1],
                f64::from(p[2]) - c[2],
            ];
            let len = n.iter().map(|v| v * v).sum::<f64>().sqrt();
            let rest = [f64::from(d[0]) - shift, f64::from(d[1]), f64::from(d[2])];
            let radial: f64 = (0..3).map(|a| rest[a] * n[a] / len).sum();
            assert!(
                (radial - growth).abs() < 0.02,
                "t = {t}: {radial} vs {growth}"
            );
        }
        if t > 1.0 {
            assert!(growth > 0.1, "{growth}");
        }
    }
}

#[test]
fn a_shape_that_outgrows_the_motion_or_a_folding_motion_is_refused() {
    // Growing 0.06 normalised (1.2 mm, 1.4 cells) per unit t_n: the first later time (0.3 mm,
    // 0.36 cells) projects, the others (0.72 and 1.2 mm) not.
    let bytes = translating(0.06).to_bytes();
    let model = Model::from_bytes(&bytes).unwrap();
    let outcomes = carried(&model);
    assert!(outcomes[1].is_ok(), "{:?}", outcomes[1].as_ref().err());
    for outcome in &outcomes[2..] {
        assert!(
            matches!(outcome, Err(Fallback::Projection { .. })),
            "{:?}",
            outcome.as_ref().err()
        );
    }
    // The folding motion: invertible early, not late.
    let bytes = folding(-1.5).to_bytes();
    let model = Model::from_bytes(&bytes).unwrap();
    let outcomes = carried(&model);
    let (early, last) = (&outcomes[1], &outcomes[outcomes.len() - 1]);
    assert!(early.is_ok(), "{:?}", early.as_ref().err());
    assert!(
        matches!(
            last,
            Err(Fallback::NotConverged { .. } | Fallback::Folded { .. })
        ),
        "{:?}",
        last.as_ref().err()
    );
}

/// Writes the series of `model` at [`TIMES`] into `dir` in `space` and `format`, and returns
/// the log lines.
fn write_series(model: &Model, dir: &std::path::Path, format: Format, space: Space) -> Vec<String> {
    let mut files = MeshFiles::series(dir, format, space).unwrap();
    let mut lines = Vec::new();
    write_meshes(
        model,
        &TIMES,
        &[0],
        &[[200, 30, 40]],
        &options(),
        &mut files,
        |step| {
            if let Meshed::Fallback { .. } = step {
                lines.push(format!("FALLBACK {}", step.line().unwrap()));
            } else if let Some(line) = step.line() {
                lines.push(line);
            }
        },
    )
    .unwrap();
    files.finish().unwrap();
    lines
}

#[test]
fn a_series_writes_the_displacement_vtk_and_trimesh_read_back() {
    let dir = tempfile::tempdir().unwrap();
    let bytes = translating(0.01).to_bytes();
    let model = Model::from_bytes(&bytes).unwrap();
    let lps = dir.path().join("lps");
    let lines = write_series(&model, &lps, Format::Vtp, Space::Lps);
    assert!(
        !lines.iter().any(|l| l.starts_with("FALLBACK")),
        "{lines:#?}"
    );
    assert_eq!(
        lines
            .iter()
            .filter(|l| l.contains("carried 1 of 1 classes"))
            .count(),
        3,
        "{lines:#?}"
    );
    // A fast-growing shape: the later times are marched, and say so.
    let bytes = translating(0.06).to_bytes();
    let growing = Model::from_bytes(&bytes).unwrap();
    let marched_dir = dir.path().join("marched");
    let lines = write_series(&growing, &marched_dir, Format::Vtp, Space::Ras);
    let fallbacks: Vec<&String> = lines.iter().filter(|l| l.starts_with("FALLBACK")).collect();
    assert_eq!(fallbacks.len(), 2, "{lines:#?}");
    assert!(
        fallbacks[0].contains("not carried to t = 1.2"),
        "{}",
        fallbacks[0]
    );
    // A model without motion: no displacement anywhere.
    let bytes = sphere(0.01).to_bytes();
    let still = Model::from_bytes(&bytes).unwrap();
    let plain = dir.path().join("plain");
    write_series(&still, &plain, Format::Vtp, Space::Ras);
    for d in [&lps, &marched_dir, &plain] {
        assert_eq!(std::fs::read_dir(d).unwrap().count(), TIMES.len() + 1);
    }
    // PLY carries the displacement as dx dy dz.
    let ply = dir.path().join("ply");
    write_series(&model, &ply, Format::Ply, Space::Ras);
    // Each VTP series read back by VTK and trimesh ([`read_vtp_series`]): watertight, the first
    // time's faces, and the first mesh warped by the displacement (ParaView's Warp By Vector).
    let Some(lps_rows) = read_vtp_series(&lps) else {
        return;
    };
    let shift = |i: usize| centre_x(TIMES[i]) - centre_x(TIMES[0]);
    let series = [&lps, &marched_dir, &plain].map(|d| read_vtp_series(d).unwrap());
    for rows in &series {
        assert_eq!(rows.len(), TIMES.len(), "{rows:?}");
        for row in rows {
            assert_eq!(row[2], "True", "watertight: {row:?}");
        }
    }
    for (i, row) in lps_rows.iter().enumerate() {
        assert_eq!(row[3], "True", "the first time's faces: {row:?}");
        let err: f64 = row[4].parse().unwrap();
        assert!(err < 0.1, "{row:?}");
        // LPS: x negated, as the points are.
        let dx: f64 = row[5].parse().unwrap();
        assert!(
            (dx + shift(i)).abs() < 0.05,
            "{dx} vs {}: {row:?}",
            -shift(i)
        );
    }
    for row in &series[1] {
        let t: usize = row[1][13..17].parse().unwrap();
        let carried = t < 2;
        assert_eq!(row[4] != "none", carried, "{row:?}");
    }
    for row in &series[2] {
        assert_eq!(row[4], "none", "{row:?}");
    }
    let script = r#"
import sys, glob, os
import numpy as np
import trimesh
for path in sorted(glob.glob(os.path.join(sys.argv[1], '*.ply'))):
    m = trimesh.load(path, process=False)
    v = m.metadata['_ply_raw']['vertex']['data']
    d = np.stack([v['dx'], v['dy'], v['dz']], 1)
    print(trimesh.load(path).is_watertight, *d.mean(0))
"#;
    let out = run_python(&["trimesh", "numpy"], script, &[ply.as_path()]).unwrap();
    let rows: Vec<Vec<&str>> = out
        .lines()
        .map(|l| l.split_whitespace().collect())
        .collect();
    assert_eq!(rows.len(), TIMES.len(), "{out}");
    for (i, row) in rows.iter().enumerate() {
        assert_eq!(row[0], "True", "watertight: {out}");
        let dx: f64 = row[1].parse().unwrap();
        assert!((dx - shift(i)).abs() < 0.05, "{out}");
    }
}
