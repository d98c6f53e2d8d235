//! Surface extraction: the zero-level sets of a model's classes at a time, as closed, oriented,
//! manifold triangle meshes in world coordinates, with the cost growing with the surface area.
//!
//! The pipeline, one file per step (method and measurements in `docs/meshing.md`):
//! 1. [`field`]: the scalar field F per extracted class (own level set or Eq. 11 partition
//!    boundary), clipped to the lattice so that every surface closes.
//! 2. [`sampling`]: coarse-to-fine sampling of a lattice near the surfaces with the SDF distance
//!    bound, then closure over sign-changing edges (watertightness).
//! 3. [`polygonise`]: marching tetrahedra on the Kuhn subdivision (manifold, no ambiguities).
//! 4. [`vertices`]: Newton steps onto F = 0 along each vertex's lattice edge; normals and
//!    normal velocity.
//! 5. [`geometry`]: the [`Mesh`] type, volume, area, topology checks; [`io`]: file formats.
//!
//! [`model_meshes`] is the whole job of a model: its classes at several times, written to files;
//! for a motion model, [`carried`] carries the first time's meshes through the series (the same
//! vertices and triangles at every time, with each vertex's displacement).
//!
//! [`planar`] contours the same fields on a plane (closed polygons, for RT Structure Sets).

#![warn(missing_docs)]

#[cfg(test)]
mod analytic;
pub mod carried;
pub mod field;
pub mod geometry;
pub mod io;
pub mod lattice;
pub mod model_meshes;
pub mod planar;
pub mod polygonise;
pub mod sampling;
pub mod vertices;

pub use field::{LevelSets, PointField, Source, Surfaces};
pub use geometry::{Mesh, Topology};
pub use lattice::Lattice;
pub use model_meshes::{surfaces_at, write_meshes, Meshed};
pub use sampling::Sampling;

use anyhow::Result;

/// Default safety factor s on the distance bound (measured in `docs/meshing.md`).
pub const DEFAULT_SAFETY: f32 = 1.5;

/// How to extract surfaces.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Options {
    /// Cells along the longest axis of the box.
    pub resolution: u32,
    /// Sparse (with its safety factor) or dense sampling.
    pub sampling: Sampling,
    /// Overlapping class surfaces or the Eq. 11 partition's boundaries.
    pub surfaces: Surfaces,
    /// Newton steps per vertex along its lattice edge (0 keeps the linearly interpolated
    /// positions).
    pub newton_steps: u32,
}

impl Default for Options {
    fn default() -> Self {
        Options {
            resolution: lattice::DEFAULT_RESOLUTION,
            sampling: Sampling::Sparse {
                safety: DEFAULT_SAFETY,
            },
            surfaces: Surfaces::Overlapping,
            newton_steps: DEFAULT_NEWTON_STEPS,
        }
    }
}

/// Newton steps per vertex along its lattice edge by default (`dynaslice mesh
/// --newton-steps`, Python's `newton_steps`). A step that would leave the edge's sign-change
/// interval falls back to bisection, so vertices never cross and meshes cannot fold; one step
/// leaves them within 5.4·10⁻⁴ of the analytic sphere at a cell of 0.042.
pub const DEFAULT_NEWTON_STEPS: u32 = 1;

/// What an extraction cost.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub struct Stats {
    /// Field value evaluations (lattice vertices sampled).
    pub value_evaluations: u64,
    /// Jacobian evaluations (f, ∇ₓf, ∂f/∂t) for vertex placement and attributes.
    pub jacobian_evaluations: u64,
    /// Value evaluations a dense grid of the same resolution needs (its vertex count).
    pub dense_evaluations: u64,
    /// Cells visited by the polygoniser.
    pub cells: u64,
    /// Motion-network evaluations u(x, t) of a motion model's carried series (`carried.rs`).
    pub displacement_evaluations: u64,
}

/// The meshes of one extraction, in the order of the requested classes.
pub struct Extraction {
    /// One mesh per requested class.
    pub meshes: Vec<Mesh>,
    /// The lattice used.
    pub lattice: Lattice,
    /// Evaluation counts.
    pub stats: Stats,
}

/// Extracts the surfaces of `classes` (0-based channels of `source`) at world time `time` on a
/// lattice covering the world box `bounds` (e.g. a model's `domain().bounds()`).
pub fn extract<S: Source>(
    source: &S,
    bounds: ([f32; 3], [f32; 3]),
    time: f32,
    classes: &[usize],
    options: &Options,
) -> Result<Extraction> {
    let lattice = Lattice::covering(bounds.0, bounds.1, options.resolution)?;
    if let Sampling::Sparse { safety } = options.sampling {
        anyhow::ensure!(
            safety.is_finite() && safety >= 1.0,
            "safety factor {safety} must be a finite number ≥ 1"
        );
    }
    let field = LevelSets::new(
        source,
        time,
        classes.to_vec(),
        options.surfaces,
        lattice.clip_box(),
    );
    let samples = sampling::sample(&field, lattice, options.sampling);
    let mut jacobian_evaluations = 0;
    let meshes = (0..classes.len())
        .map(|c| {
            let polygons = polygonise::polygonise(&samples, c);
            let mut positions = polygons.positions;
            let refined = vertices::refine(
                &field,
                c,
                &mut positions,
                &polygons.edges,
                options.newton_steps,
                lattice.clip_box(),
            );
            jacobian_evaluations += positions.len() as u64 * (options.newton_steps as u64 + 1);
            Mesh {
                positions,
                triangles: polygons.triangles,
                normals: refined.normals,
                normal_velocity: refined.normal_velocity,
                displacement: Vec::new(),
            }
        })
        .collect();
    Ok(Extraction {
        meshes,
        lattice,
        stats: Stats {
            value_evaluations: samples.evaluations(),
            jacobian_evaluations,
            dense_evaluations: lattice.vertex_count(),
            cells: samples.cells.len() as u64,
            displacement_evaluations: 0,
        },
    })
}

#[cfg(test)]
mod tests {
    use super::analytic::{Analytic, Shape};
    use super::*;
    use std::f64::consts::PI;

    const CUBE: ([f32; 3], [f32; 3]) = ([-1.0; 3], [1.0; 3]);

    fn options(resolution: u32) -> Options {
        Options {
            resolution,
            ..Options::default()
        }
    }

    fn rel(a: f64, b: f64) -> f64 {
        (a - b).abs() / b.abs()
    }

    #[test]
    fn sphere_is_closed_accurate_outward_with_its_velocity() {
        let field = Analytic::new(vec![Shape::sphere([0.1, -0.05, 0.02], 0.5, 0.2)]);
        let (t, r) = (0.5, 0.6);
        let x = extract(&field, CUBE, t, &[0], &options(48)).unwrap();
        let m = &x.meshes[0];
        let topology = m.topology();
        assert!(topology.is_closed_manifold(), "{topology:?}");
        assert_eq!(topology.euler_characteristic, 2);
        let mut worst = 0.0f32;
        assert!(rel(m.enclosed_volume(), 4.0 / 3.0 * PI * r * r * r) < 2e-3);
        assert!(rel(m.area(), 4.0 * PI * r * r) < 5e-3);
        for ((p, n), v) in m.positions.iter().zip(&m.normals).zip(&m.normal_velocity) {
            let d: [f32; 3] = [p[0] - 0.1, p[1] + 0.05, p[2] - 0.02];
            let dist = (d[0] * d[0] + d[1] * d[1] + d[2] * d[2]).sqrt();
            worst = worst.max((dist - r as f32).abs());
            assert!((0..3).map(|a| n[a] * d[a] / dist).sum::<f32>() > 0.9999);
            assert!((v - 0.2).abs() < 1e-6);
        }
        // One safeguarded Newton step along the lattice edges: measured 5.4e-4 at h = 0.042
        // (steps along ∇ₓF landed within 1e-5, but could fold meshes).
        assert!(worst < 1e-3, "max |dist - r| = {worst:e}");
        // Without Newton steps the vertices stay on their lattice edges, inside the sphere's
        // chords: less accurate, still closed.
        let linear = Options {
            newton_steps: 0,
            ..options(48)
        };
        let m0 = &extract(&field, CUBE, t, &[0], &linear).unwrap().meshes[0];
        assert!(m0.topology().is_closed_manifold());
        let err = |m: &Mesh| rel(m.enclosed_volume(), 4.0 / 3.0 * PI * r * r * r);
        assert!(err(m0) > 2.0 * err(m), "{} vs {}", err(m0), err(m));
    }

    #[test]
    fn torus_has_genus_one_and_its_volume() {
        let torus = Shape::Torus {
            centre: [0.0, 0.0, 0.1],
            major: 0.55,
            minor: 0.2,
        };
        let x = extract(&Analytic::new(vec![torus]), CUBE, 0.0, &[0], &options(64)).unwrap();
        let m = &x.meshes[0];
        let topology = m.topology();
        assert!(topology.is_closed_manifold(), "{topology:?}");
        assert_eq!(topology.euler_characteristic, 0);
        assert!(rel(m.enclosed_volume(), 2.0 * PI * PI * 0.55 * 0.2 * 0.2) < 3e-3);
        assert!(rel(m.area(), 4.0 * PI * PI * 0.55 * 0.2) < 5e-3);
    }

    /// Two boxes overlapping in x ∈ [−0.1, 0.1], each 0.6 × 0.6 × 0.6. Where they overlap
    /// near their shared side faces the two distances tie, so the partition is degenerate
    /// there: a stress case for sampling, not for volumes.
    fn two_boxes() -> Analytic {
        Analytic::new(vec![
            Shape::Cuboid {
                lo: [-0.5, -0.3, -0.3],
                hi: [0.1, 0.3, 0.3],
            },
            Shape::Cuboid {
                lo: [-0.1, -0.3, -0.3],
                hi: [0.5, 0.3, 0.3],
            },
        ])
    }

    #[test]
    fn partition_surfaces_do_not_overlap_and_share_their_boundary() {
        // Two balls of radius 0.4, centres 0.5 apart: the Eq. 11 partition splits their union
        // at the bisecting plane x = 0.01 (off the lattice planes, h = 1/32).
        let r = 0.4;
        let balls = Analytic::new(vec![
            Shape::sphere([-0.24, 0.0, 0.0], r as f32, 0.0),
            Shape::sphere([0.26, 0.0, 0.0], r as f32, 0.0),
        ]);
        let extract_with = |surfaces| {
            let o = Options {
                surfaces,
                ..options(64)
            };
            let x = extract(&balls, CUBE, 0.0, &[0, 1], &o).unwrap();
            for m in &x.meshes {
                assert!(m.topology().is_closed_manifold(), "{:?}", m.topology());
            }
            x.meshes
        };
        let ball = 4.0 / 3.0 * PI * r * r * r;
        let lens = PI * (4.0 * r + 0.5) * (2.0 * r - 0.5) * (2.0 * r - 0.5) / 12.0;
        for m in extract_with(Surfaces::Overlapping) {
            assert!(
                rel(m.enclosed_volume(), ball) < 2e-3,
                "{}",
                m.enclosed_volume()
            );
        }
        let part = extract_with(Surfaces::Partition);
        for m in &part {
            // The crease where the sphere meets the wall is chamfered by O(h²) per length.
            let v = m.enclosed_volume();
            assert!(rel(v, ball - lens / 2.0) < 3e-3, "{v}");
        }
        // The shared wall (away from its rim, radius 0.31): the same vertices in both meshes,
        // bit for bit (g_B = −g_A there), with opposite normals.
        let wall = |m: &Mesh, sign: f32| {
            let mut w: Vec<[u32; 3]> = m
                .positions
                .iter()
                .zip(&m.normals)
                .filter(|(p, n)| {
                    (p[0] - 0.01).abs() < 1e-5 && p[1].hypot(p[2]) < 0.25 && n[0] * sign > 0.999
                })
                .map(|(p, _)| p.map(f32::to_bits))
                .collect();
            w.sort_unstable();
            w
        };
        assert!(wall(&part[0], 1.0).len() > 100);
        assert_eq!(wall(&part[0], 1.0), wall(&part[1], -1.0));
    }

    #[test]
    fn sparse_sampling_gives_exactly_the_dense_meshes() {
        let cases: Vec<(Analytic, Vec<usize>, Surfaces)> = vec![
            (
                Analytic::new(vec![
                    Shape::sphere([0.2, 0.0, 0.0], 0.3, 0.0),
                    Shape::Torus {
                        centre: [-0.2, 0.1, 0.0],
                        major: 0.5,
                        minor: 0.12,
                    },
                ]),
                vec![0, 1],
                Surfaces::Overlapping,
            ),
            (two_boxes(), vec![1, 0], Surfaces::Partition),
            // Tiny: a sphere of 1.5 cells.
            (
                Analytic::new(vec![Shape::sphere([0.31, 0.27, -0.33], 0.05, 0.0)]),
                vec![0],
                Surfaces::Overlapping,
            ),
        ];
        for (field, classes, surfaces) in cases {
            let sparse = Options {
                surfaces,
                ..options(64)
            };
            let dense = Options {
                sampling: Sampling::Dense,
                ..sparse
            };
            let s = extract(&field, CUBE, 0.0, &classes, &sparse).unwrap();
            let d = extract(&field, CUBE, 0.0, &classes, &dense).unwrap();
            assert_eq!(s.meshes, d.meshes);
            assert!(s.meshes.iter().all(|m| !m.triangles.is_empty()));
            assert_eq!(d.stats.value_evaluations, 65 * 65 * 65);
            assert!(s.stats.value_evaluations * 3 < d.stats.value_evaluations);
            assert_eq!(s.stats.jacobian_evaluations, d.stats.jacobian_evaluations);
        }
    }

    #[test]
    fn surfaces_leaving_the_box_are_closed_by_caps() {
        let ball = Analytic::new(vec![Shape::sphere([0.5, 0.0, 0.0], 0.8, 0.0)]);
        let x = extract(&ball, CUBE, 0.0, &[0], &options(32)).unwrap();
        let m = &x.meshes[0];
        assert!(m.topology().is_closed_manifold(), "{:?}", m.topology());
        let (_, hi) = x.lattice.clip_box();
        assert!(m.positions.iter().all(|p| p[0] <= hi[0] + 1e-6));
        // The cap at x = hi: a disc of radius √(0.8² − (hi − 0.5)²).
        let cap = m
            .positions
            .iter()
            .filter(|p| (p[0] - hi[0]).abs() < 1e-6)
            .count();
        assert!(cap > 20, "{cap}");
    }

    /// The target: at 256³, at least 10x fewer evaluations than the dense grid (the
    /// figures in docs/meshing.md come from this test's output at 128 and 256).
    #[test]
    fn sparse_sampling_costs_a_tenth_of_dense_at_256() {
        let ball = Analytic::new(vec![Shape::sphere([0.0; 3], 0.6, 0.0)]);
        for resolution in [128, 256] {
            let x = extract(&ball, CUBE, 0.0, &[0], &options(resolution)).unwrap();
            let s = x.stats;
            println!("sphere r = 0.6 in [-1, 1]^3 at {resolution}: {s:?}");
            assert_eq!(s.dense_evaluations, (resolution as u64 + 1).pow(3));
            assert!(rel(x.meshes[0].enclosed_volume(), 0.288 * PI) < 1e-3);
            if resolution == 256 {
                assert!(s.value_evaluations * 10 < s.dense_evaluations, "{s:?}");
            }
        }
    }

    /// Every edge of the mesh in exactly two triangles, consistently oriented, also after
    /// welding by position (what STL readers and trimesh do), and welding merges nothing.
    fn assert_watertight_as_read(m: &Mesh, what: &str) {
        let topology = m.topology();
        assert!(topology.is_closed_manifold(), "{what}: {topology:?}");
        let welded = m.welded();
        assert_eq!(
            welded.positions.len(),
            m.positions.len(),
            "{what}: vertices of different edges at one position"
        );
        assert_eq!(welded.topology(), topology, "{what}");
    }

    #[test]
    fn surfaces_through_lattice_vertices_keep_distinct_vertices() {
        // Faces on lattice planes (h = 1/8): F is exactly 0 at every lattice vertex of the
        // faces, where the linear zeros of all the edges into the box meet. They used to be one
        // position, which welding made edges of four triangles.
        let cube = Analytic::new(vec![Shape::Cuboid {
            lo: [-0.5; 3],
            hi: [0.5; 3],
        }]);
        // A sphere through lattice vertices on the axes (radius 4 cells).
        let ball = Analytic::new(vec![Shape::sphere([0.0; 3], 0.5, 0.0)]);
        for (name, field) in [("cube", &cube), ("ball", &ball)] {
            for newton_steps in [0, 1, 4] {
                for surfaces in [Surfaces::Overlapping, Surfaces::Partition] {
                    let o = Options {
                        newton_steps,
                        surfaces,
                        ..options(16)
                    };
                    let x = extract(field, CUBE, 0.0, &[0], &o).unwrap();
                    let m = &x.meshes[0];
                    assert!(!m.triangles.is_empty());
                    let what = format!("{name}, {newton_steps} steps, {surfaces:?}");
                    assert_watertight_as_read(m, &what);
                    // The cube less the chamfers along its edges where the Kuhn diagonals
                    // cut across them (at most h²/2 per unit length: 12 · 1 · h²/2); 0.9565
                    // measured.
                    let v = m.enclosed_volume();
                    if name == "cube" {
                        assert!((1.0 - 6.0 / 64.0..1.0).contains(&v), "{what}: {v}");
                    } else {
                        assert!(v > 0.0, "{what}: {v}");
                    }
                }
            }
        }
    }

    #[test]
    fn bad_options_are_refused() {
        let ball = Analytic::new(vec![Shape::sphere([0.0; 3], 0.6, 0.0)]);
        let unsafe_factor = Options {
            sampling: Sampling::Sparse { safety: 0.5 },
            ..options(16)
        };
        let e = extract(&ball, CUBE, 0.0, &[0], &unsafe_factor)
            .err()
            .unwrap();
        assert!(e.to_string().contains("safety factor 0.5"), "{e}");
        let e = extract(&ball, CUBE, 0.0, &[0], &options(1)).err().unwrap();
        assert!(e.to_string().contains("resolution 1"), "{e}");
    }
}
