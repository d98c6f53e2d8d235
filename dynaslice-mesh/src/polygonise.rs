//! Marching tetrahedra over the sampled cells: each cell is cut into the 6 tetrahedra of its
//! Kuhn subdivision (paths 000 → 111 along the axes in every order), and each tetrahedron's
//! part of the zero set of the linearly interpolated field is one triangle or one quad.
//!
//! The Kuhn subdivision is the same in every cell, so neighbouring tetrahedra share faces and
//! edges exactly and the interpolated zero set is a closed 2-manifold with no ambiguous cases
//! (marching cubes needs case tables and face disambiguation for that). A value of exactly 0
//! counts as outside, so every lattice vertex is strictly on one side; the linear zero of an
//! edge from such a vertex is at that vertex, which [`crate::vertices`] moves off (vertices of
//! different edges must never share a position). Mesh vertices are keyed by their lattice edge,
//! shared by every triangle touching it, and never merged by position. Triangles are oriented from exact integer
//! arithmetic on the edge midpoints, with normals towards the positive (outside) side.

use super::lattice::{key, Lattice};
use super::sampling::Samples;
use rustc_hash::FxHashMap;

/// The 6 tetrahedra of a cell as corner indices (bit a = axis a), each a monotone path.
const TETS: [[usize; 4]; 6] = [
    [0, 1, 3, 7],
    [0, 1, 5, 7],
    [0, 2, 3, 7],
    [0, 2, 6, 7],
    [0, 4, 5, 7],
    [0, 4, 6, 7],
];

/// The lattice edge a mesh vertex lies on, in world coordinates from its lower lattice corner
/// `from` to `to`, with F < 0 at one end and F ≥ 0 at the other. Vertices kept on their edges
/// keep the mesh embedded (see [`crate::vertices`]). Positions are measured from the same end
/// for every class, so a wall shared by two partition surfaces gets identical vertices.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Edge {
    /// The lower lattice corner (f64: a vertex on an edge in the clip box's face stays in it).
    pub from: [f64; 3],
    /// The other end.
    pub to: [f64; 3],
    /// Whether F < 0 at `from` (else at `to`).
    pub negative_at_from: bool,
    /// Where the linear interpolant vanishes, as a fraction of the way from `from`.
    pub s: f64,
}

impl Edge {
    /// The point a fraction `s` of the way from `from` to `to`.
    pub fn at(&self, s: f64) -> [f32; 3] {
        std::array::from_fn(|a| (self.from[a] + s * (self.to[a] - self.from[a])) as f32)
    }
}

/// A polygonised level set before vertex refinement.
pub struct Polygons {
    /// World positions, interpolated linearly along each vertex's lattice edge.
    pub positions: Vec<[f32; 3]>,
    /// Each vertex's lattice edge (same order as `positions`).
    pub edges: Vec<Edge>,
    /// Triangles, oriented with normals towards increasing F.
    pub triangles: Vec<[u32; 3]>,
}

/// Polygonises channel `channel` of `samples` over its cells.
pub fn polygonise(samples: &Samples, channel: usize) -> Polygons {
    let lattice = samples.lattice;
    let mut out = Polygons {
        positions: Vec::new(),
        edges: Vec::new(),
        triangles: Vec::new(),
    };
    let mut vertex_of_edge: FxHashMap<u64, u32> = FxHashMap::default();
    for &cell in &samples.cells {
        let base = super::lattice::unkey(cell);
        let corners: [[u32; 3]; 8] =
            std::array::from_fn(|o| std::array::from_fn(|a| base[a] + ((o >> a) & 1) as u32));
        let values: [f32; 8] = std::array::from_fn(|o| {
            samples
                .get(corners[o])
                .expect("corners of polygonised cells are sampled")[channel]
        });
        let inside = values.map(|v| v < 0.0);
        if inside.iter().all(|&b| b == inside[0]) {
            continue;
        }
        for tet in TETS {
            let tv = tet.map(|o| (corners[o], values[o]));
            let mut edge_vertex = |a: usize, b: usize| -> (u32, [i64; 3]) {
                // Along the path a lower index is a sub-corner: key the edge from that end.
                let (a, b) = (a.min(b), a.max(b));
                let (pa, fa) = tv[a];
                let (pb, fb) = tv[b];
                let direction = (0..3).fold(0u64, |m, ax| m | ((pb[ax] - pa[ax]) as u64) << ax);
                let edge_key = key(pa) << 3 | direction;
                let index = *vertex_of_edge.entry(edge_key).or_insert_with(|| {
                    let edge = interpolate(&lattice, pa, fa, pb, fb);
                    out.positions.push(edge.at(edge.s));
                    out.edges.push(edge);
                    out.positions.len() as u32 - 1
                });
                (
                    index,
                    std::array::from_fn(|ax| pa[ax] as i64 + pb[ax] as i64),
                )
            };
            let ins: Vec<usize> = (0..4).filter(|&i| tv[i].1 < 0.0).collect();
            let outs: Vec<usize> = (0..4).filter(|&i| tv[i].1 >= 0.0).collect();
            // Any outside corner, doubled like the midpoints, fixes the orientation.
            let outside = match outs.first() {
                Some(&o) => tv[o].0.map(|x| 2 * x as i64),
                None => continue,
            };
            let polygon: Vec<(u32, [i64; 3])> = match (ins.len(), outs.len()) {
                (0, _) => continue,
                (1, _) => outs.iter().map(|&o| edge_vertex(ins[0], o)).collect(),
                (3, _) => ins.iter().map(|&i| edge_vertex(i, outs[0])).collect(),
                _ => {
                    // Quad: the four edges between {a, b} and {c, d} in cyclic order.
                    let (a, b, c, d) = (ins[0], ins[1], outs[0], outs[1]);
                    vec![
                        edge_vertex(a, c),
                        edge_vertex(a, d),
                        edge_vertex(b, d),
                        edge_vertex(b, c),
                    ]
                }
            };
            for i in 1..polygon.len() - 1 {
                out.triangles
                    .push(oriented([polygon[0], polygon[i], polygon[i + 1]], outside));
            }
        }
    }
    out
}

/// The lattice edge from a (value fa) to b (value fb), one of them negative, with the zero of
/// the linear interpolant on it.
fn interpolate(lattice: &Lattice, a: [u32; 3], fa: f32, b: [u32; 3], fb: f32) -> Edge {
    let world = |v: [u32; 3]| -> [f64; 3] {
        std::array::from_fn(|ax| lattice.origin[ax] + v[ax] as f64 * lattice.h)
    };
    Edge {
        from: world(a),
        to: world(b),
        negative_at_from: fa < 0.0,
        s: fa as f64 / (fa as f64 - fb as f64),
    }
}

/// The triangle's indices, ordered so that its normal (from the exact doubled midpoints) points
/// to `outside`. The triangle lies in a plane separating the tetrahedron's inside corners from
/// its outside ones, so the test is never 0.
fn oriented(t: [(u32, [i64; 3]); 3], outside: [i64; 3]) -> [u32; 3] {
    let sub = |p: [i64; 3], q: [i64; 3]| -> [i64; 3] { std::array::from_fn(|a| p[a] - q[a]) };
    let (u, v, w) = (
        sub(t[1].1, t[0].1),
        sub(t[2].1, t[0].1),
        sub(outside, t[0].1),
    );
    let n = [
        u[1] * v[2] - u[2] * v[1],
        u[2] * v[0] - u[0] * v[2],
        u[0] * v[1] - u[1] * v[0],
    ];
    if n[0] * w[0] + n[1] * w[1] + n[2] * w[2] > 0 {
        [t[0].0, t[1].0, t[2].0]
    } else {
        [t[0].0, t[2].0, t[1].0]
    }
}
