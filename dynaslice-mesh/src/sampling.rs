//! Where the fields are evaluated: a sparse set of lattice vertices near the surfaces, found
//! coarse to fine with the SDF distance bound, so the cost grows with the surface area.
//!
//! **Refinement.** The lattice is covered by coarse cells of 2^L fine cells (about 8 along the
//! longest axis) whose corners are evaluated. A cell of side H is split into its 8 children, and
//! child o is kept only if the parent corner it shares, c_o, satisfies
//! min_c |F_c(c_o)| ≤ s · λ · (√3/2) · H, where λ is the fields' nominal Lipschitz constant
//! ([`LevelSets::lipschitz`]) and s the safety factor. Every point of the child lies within the
//! child's diagonal √3/2 · H of c_o, so for a λ-Lipschitz field a pruned child cannot hold a zero
//! (s = 1 would suffice); s > 1 absorbs a learned SIREN's departure from ‖∇f‖ = 1. Kept children
//! have their corners evaluated and are split again, down to single cells. Corners are lattice
//! vertices, so every evaluation is a sample the polygoniser uses, and coarse samples are reused
//! at every finer level.
//!
//! **Closure.** The polygoniser (marching tetrahedra on the Kuhn subdivision of each cell) puts a
//! vertex on every lattice edge whose ends have different signs. Its mesh is closed exactly when
//! every cell around such an edge is visited, so after refinement the active cells are grown
//! until that holds: any cell around a sign-changing edge of an active cell becomes active and
//! has its corners evaluated. This makes the result watertight whatever the field's Lipschitz
//! constant, and follows any surface the pruning touched even partly; only a component lying
//! entirely in pruned cells (thinner than the bound allows) can be missed — which the dense
//! comparison in the tests and `--dense` check.

use super::field::{LevelSets, Source};
use super::lattice::{key, unkey, Lattice};
use rustc_hash::{FxHashMap, FxHashSet};

/// How the lattice is sampled.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Sampling {
    /// Coarse-to-fine near the surfaces, with this safety factor s on the distance bound.
    Sparse {
        /// s ≥ 1; the bound prunes a cell when |F| > s · λ · half-diagonal.
        safety: f32,
    },
    /// Every lattice vertex (the reference the sparse result is checked against).
    Dense,
}

/// Field values at a sparse set of lattice vertices, and the cells to polygonise.
pub struct Samples {
    /// The lattice.
    pub lattice: Lattice,
    channels: usize,
    index: FxHashMap<u64, u32>,
    values: Vec<f32>,
    /// Cells (keys of their lowest corner), sorted, whose 8 corners are all sampled.
    pub cells: Vec<u64>,
}

impl Samples {
    /// Number of field evaluations made: the sampled vertices.
    pub fn evaluations(&self) -> u64 {
        self.index.len() as u64
    }

    /// The values of every channel at vertex `v`, if it was sampled.
    #[inline]
    pub fn get(&self, v: [u32; 3]) -> Option<&[f32]> {
        let i = *self.index.get(&key(v))? as usize * self.channels;
        Some(&self.values[i..i + self.channels])
    }

    /// Evaluates the vertices among `keys` not sampled yet (one parallel batch).
    fn ensure<S: Source>(&mut self, field: &LevelSets<S>, mut keys: Vec<u64>) {
        keys.sort_unstable();
        keys.dedup();
        keys.retain(|k| !self.index.contains_key(k));
        let points: Vec<[f32; 3]> = keys.iter().map(|&k| self.lattice.point(unkey(k))).collect();
        let values = field.par_values(&points);
        let first = self.index.len() as u32;
        self.index
            .extend(keys.iter().enumerate().map(|(i, &k)| (k, first + i as u32)));
        self.values.extend_from_slice(&values);
    }

    /// Smallest |F_c| over the channels at sampled vertex `v`.
    fn distance(&self, v: [u32; 3]) -> f32 {
        self.get(v)
            .map_or(0.0, |f| f.iter().fold(f32::INFINITY, |m, x| m.min(x.abs())))
    }
}

/// Offsets of the 8 corners of a cell, bit a of `o` giving axis a.
#[inline]
fn corner(base: [u32; 3], o: usize, size: u32) -> [u32; 3] {
    std::array::from_fn(|a| base[a] + ((o >> a) & 1) as u32 * size)
}

/// Samples `field` on `lattice` as `sampling` says.
pub fn sample<S: Source>(field: &LevelSets<S>, lattice: Lattice, sampling: Sampling) -> Samples {
    let mut samples = Samples {
        lattice,
        channels: field.channels(),
        index: FxHashMap::default(),
        values: Vec::new(),
        cells: Vec::new(),
    };
    let cells = match sampling {
        Sampling::Dense => {
            let all: Vec<[u32; 3]> = cell_bases(lattice.cells, 1).collect();
            samples.ensure(
                field,
                cell_bases(lattice.cells.map(|c| c + 1), 1)
                    .map(key)
                    .collect(),
            );
            all
        }
        Sampling::Sparse { safety } => refine(&mut samples, field, safety),
    };
    samples.cells = close(&mut samples, field, cells);
    samples
}

/// Bases of the cells of side `size` covering `cells` lattice cells per axis.
fn cell_bases(cells: [u32; 3], size: u32) -> impl Iterator<Item = [u32; 3]> {
    let n = cells.map(|c| c.div_ceil(size));
    (0..n[2]).flat_map(move |k| {
        (0..n[1]).flat_map(move |j| (0..n[0]).map(move |i| [i * size, j * size, k * size]))
    })
}

/// The coarse-to-fine descent (module documentation); returns the kept single cells.
fn refine<S: Source>(samples: &mut Samples, field: &LevelSets<S>, safety: f32) -> Vec<[u32; 3]> {
    let lattice = samples.lattice;
    let longest = lattice.cells.iter().copied().max().unwrap_or(1);
    // Coarse cells of about 1/8 of the longest axis: below that the top level costs nothing,
    // above it most coarse cells would hold some surface and the bound would prune little.
    let levels = (longest / 8).max(1).ilog2();
    let mut size = 1u32 << levels;
    let corners_of = |cells: &[[u32; 3]], size: u32| -> Vec<u64> {
        cells
            .iter()
            .flat_map(|&b| (0..8).map(move |o| corner(b, o, size)))
            .filter(|&v| lattice.contains(v))
            .map(key)
            .collect()
    };
    let mut cells: Vec<[u32; 3]> = cell_bases(lattice.cells, size).collect();
    samples.ensure(field, corners_of(&cells, size));
    let half_diagonal = 3f32.sqrt() / 2.0 * lattice.h as f32;
    while size > 1 {
        let bound = safety * field.lipschitz() * half_diagonal * size as f32;
        let half = size / 2;
        let mut children = Vec::new();
        for &b in &cells {
            for o in 0..8 {
                let child = corner(b, o, half);
                // Coarse cells overhang the lattice's far faces; their outer children are empty.
                if (0..3).any(|a| child[a] >= lattice.cells[a]) {
                    continue;
                }
                // A shared corner off the lattice has no value: keep the child, it is checked
                // again at the next level from its own corners.
                let c = corner(b, o, size);
                if !lattice.contains(c) || samples.distance(c) <= bound {
                    children.push(child);
                }
            }
        }
        samples.ensure(field, corners_of(&children, half));
        cells = children;
        size = half;
    }
    cells
}

/// The 19 edges of a cell's Kuhn subdivision: corner pairs (a, b) with a ⊂ b as bit sets.
pub(crate) const KUHN_EDGES: [(usize, usize); 19] = [
    (0, 1),
    (0, 2),
    (0, 4),
    (0, 3),
    (0, 5),
    (0, 6),
    (0, 7),
    (1, 3),
    (1, 5),
    (1, 7),
    (2, 3),
    (2, 6),
    (2, 7),
    (4, 5),
    (4, 6),
    (4, 7),
    (3, 7),
    (5, 7),
    (6, 7),
];

/// Grows `cells` until every cell around a sign-changing Kuhn edge of a kept cell is kept
/// (module documentation); returns the sorted keys.
fn close<S: Source>(samples: &mut Samples, field: &LevelSets<S>, cells: Vec<[u32; 3]>) -> Vec<u64> {
    let lattice = samples.lattice;
    let channels = samples.channels;
    let mut kept = FxHashSet::default();
    let mut frontier = cells;
    while !frontier.is_empty() {
        frontier.retain(|&c| kept.insert(key(c)));
        samples.ensure(
            field,
            frontier
                .iter()
                .flat_map(|&b| (0..8).map(move |o| key(corner(b, o, 1))))
                .collect(),
        );
        let mut next = Vec::new();
        for &b in &frontier {
            let values: [&[f32]; 8] = std::array::from_fn(|o| {
                samples
                    .get(corner(b, o, 1))
                    .expect("corners of kept cells are sampled")
            });
            for &(lo, hi) in &KUHN_EDGES {
                if !(0..channels).any(|c| (values[lo][c] < 0.0) != (values[hi][c] < 0.0)) {
                    continue;
                }
                // The cells containing edge (v, v + e): fixed along e, either side elsewhere.
                let v = corner(b, lo, 1);
                let e = hi & !lo;
                for u in 0..8usize {
                    if u & e != 0 {
                        continue;
                    }
                    let n: [i64; 3] = std::array::from_fn(|a| v[a] as i64 - ((u >> a) & 1) as i64);
                    if !(0..3).all(|a| n[a] >= 0) {
                        continue;
                    }
                    let n = n.map(|x| x as u32);
                    if (0..3).all(|a| n[a] < lattice.cells[a]) && !kept.contains(&key(n)) {
                        next.push(n);
                    }
                }
            }
        }
        next.sort_unstable();
        next.dedup();
        frontier = next;
    }
    let mut keys: Vec<u64> = kept.into_iter().collect();
    keys.sort_unstable();
    keys
}
