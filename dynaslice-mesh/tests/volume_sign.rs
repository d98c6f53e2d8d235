//! Meshes cannot have a negative volume: on random SIRENs (small, wiggly fields with thin and
//! tiny components) at coarse resolutions, in both surface modes and with 0 to 3 Newton steps,
//! every class's enclosed volume is ≥ 0 and every closed component encloses its inside, unless
//! it is a cavity wall nested in another component. Newton steps along ∇ₓF, clamped to one cell,
//! folded such meshes (a trained model's class at resolution 16 had volume −0.000451).

use dynaslice_core::format::ModelWriter;
use dynaslice_core::Model;
use dynaslice_mesh::{extract, Mesh, Options, Sampling, Surfaces};
use proptest::prelude::*;

/// The triangles of each connected component (triangles sharing a vertex).
fn components(mesh: &Mesh) -> Vec<Vec<[u32; 3]>> {
    let mut parent: Vec<usize> = (0..mesh.positions.len()).collect();
    fn root(parent: &mut [usize], mut v: usize) -> usize {
        while parent[v] != v {
            parent[v] = parent[parent[v]];
            v = parent[v];
        }
        v
    }
    for t in &mesh.triangles {
        for e in [(t[0], t[1]), (t[1], t[2])] {
            let (a, b) = (
                root(&mut parent, e.0 as usize),
                root(&mut parent, e.1 as usize),
            );
            parent[a] = b;
        }
    }
    let mut groups: std::collections::BTreeMap<usize, Vec<[u32; 3]>> = Default::default();
    for t in &mesh.triangles {
        groups
            .entry(root(&mut parent, t[0] as usize))
            .or_default()
            .push(*t);
    }
    groups.into_values().collect()
}

fn corners(mesh: &Mesh, t: &[u32; 3]) -> [[f64; 3]; 3] {
    t.map(|i| mesh.positions[i as usize].map(f64::from))
}

fn volume(mesh: &Mesh, triangles: &[[u32; 3]]) -> f64 {
    triangles
        .iter()
        .map(|t| {
            let [a, b, c] = corners(mesh, t);
            (a[0] * (b[1] * c[2] - b[2] * c[1]) - a[1] * (b[0] * c[2] - b[2] * c[0])
                + a[2] * (b[0] * c[1] - b[1] * c[0]))
                / 6.0
        })
        .sum()
}

/// Winding number of the closed surface `triangles` around `p` (solid angles, Van Oosterom and
/// Strackee): 1 inside an outward surface, 0 outside.
fn winding(mesh: &Mesh, triangles: &[[u32; 3]], p: [f64; 3]) -> f64 {
    let total: f64 = triangles
        .iter()
        .map(|t| {
            let [a, b, c] = corners(mesh, t).map(|q| [q[0] - p[0], q[1] - p[1], q[2] - p[2]]);
            let n = |v: [f64; 3]| (v[0] * v[0] + v[1] * v[1] + v[2] * v[2]).sqrt();
            let dot = |u: [f64; 3], v: [f64; 3]| u[0] * v[0] + u[1] * v[1] + u[2] * v[2];
            let det = a[0] * (b[1] * c[2] - b[2] * c[1]) - a[1] * (b[0] * c[2] - b[2] * c[0])
                + a[2] * (b[0] * c[1] - b[1] * c[0]);
            let (la, lb, lc) = (n(a), n(b), n(c));
            let den = la * lb * lc + dot(a, b) * lc + dot(b, c) * la + dot(c, a) * lb;
            2.0 * det.atan2(den)
        })
        .sum();
    total / (4.0 * std::f64::consts::PI)
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(48))]

    #[test]
    fn volumes_are_never_negative(
        widths in proptest::collection::vec(8u32..24, 1..=2),
        k in 1u32..=3,
        seed in any::<u64>(),
        shift in -0.6f32..0.2,
        resolution in 3u32..=16,
        partition in any::<bool>(),
        newton_steps in 0u32..=3,
        time in 0.0f32..1.0,
    ) {
        let mut w = ModelWriter::random_siren(&widths, k, seed);
        // Shift the output biases so that the classes have insides of many sizes.
        let layout = w.layout().unwrap();
        let out = layout.num_layers() - 1;
        let (fan_in, fan_out) = layout.layer_dims(out);
        let bias = layout.layer_offset(out) + fan_in * fan_out;
        for b in &mut w.params[bias..bias + fan_out] {
            *b += shift;
        }
        let bytes = w.to_bytes();
        let model = Model::from_bytes(&bytes).unwrap();
        let classes: Vec<usize> = (0..k as usize).collect();
        let options = Options {
            resolution,
            sampling: Sampling::Dense,
            surfaces: if partition { Surfaces::Partition } else { Surfaces::Overlapping },
            newton_steps,
        };
        let x = extract(&model, model.domain().bounds(), time, &classes, &options).unwrap();
        for (c, mesh) in x.meshes.iter().enumerate() {
            let parts = components(mesh);
            let volumes: Vec<f64> = parts.iter().map(|p| volume(mesh, p)).collect();
            let total: f64 = volumes.iter().sum();
            prop_assert!(total >= 0.0, "class {c}: volume {total:e}, components {volumes:?}");
            for (i, (part, v)) in parts.iter().zip(&volumes).enumerate() {
                if *v >= 0.0 {
                    continue;
                }
                // A negative component must be a cavity: inside another component.
                let p = mesh.positions[part[0][0] as usize].map(f64::from);
                let nested = parts.iter().enumerate().any(|(j, other)| {
                    j != i && volumes[j] > -v && winding(mesh, other, p) > 0.5
                });
                prop_assert!(nested, "class {c}: component {i} of volume {v:e} is inside out");
            }
        }
    }
}
