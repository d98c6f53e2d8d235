//! The triangle mesh type and its geometry: enclosed volume, area, topology checks and
//! area-uniform point sampling (for volume curves and surface-distance metrics).

use rand_core::{RngCore, SeedableRng};
use rand_pcg::Pcg64;
use rustc_hash::FxHashMap;

/// An indexed triangle mesh in world coordinates.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct Mesh {
    /// Vertex positions.
    pub positions: Vec<[f32; 3]>,
    /// Triangles as vertex indices, counter-clockwise seen from outside (normals outward).
    pub triangles: Vec<[u32; 3]>,
    /// Unit vertex normals, one per vertex, or empty.
    pub normals: Vec<[f32; 3]>,
    /// Normal velocity v_n = −(∂f/∂t)/‖∇ₓf‖ per vertex (positive: moving outward), or empty.
    pub normal_velocity: Vec<f32>,
    /// Per vertex, its position minus its position in the first mesh of a series whose
    /// vertices correspond (a motion model's carried meshes, `carried.rs`), or empty where the
    /// vertices correspond to no other mesh (a marched mesh).
    pub displacement: Vec<[f32; 3]>,
}

/// How far a mesh is from a closed, consistently oriented 2-manifold.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Topology {
    /// Edges used by one triangle only (holes).
    pub boundary_edges: usize,
    /// Edges used by more than two triangles.
    pub nonmanifold_edges: usize,
    /// Edges used by two triangles in the same direction (inconsistent orientation).
    pub misoriented_edges: usize,
    /// Vertices whose triangles do not form one fan (e.g. two cones touching at their tips).
    pub nonmanifold_vertices: usize,
    /// Euler characteristic V − E + F over the referenced vertices: 2 − 2·genus per closed
    /// component.
    pub euler_characteristic: i64,
}

impl Topology {
    /// Watertight, manifold and consistently oriented.
    pub fn is_closed_manifold(&self) -> bool {
        self.boundary_edges == 0
            && self.nonmanifold_edges == 0
            && self.misoriented_edges == 0
            && self.nonmanifold_vertices == 0
    }
}

impl Mesh {
    /// The axis-aligned box [lo, hi] as 12 outward triangles on its 8 corners (e.g. a
    /// reference shape with a closed-form volume and area).
    pub fn cuboid(lo: [f32; 3], hi: [f32; 3]) -> Mesh {
        let positions = (0..8)
            .map(|o: usize| std::array::from_fn(|a| if (o >> a) & 1 == 1 { hi[a] } else { lo[a] }))
            .collect();
        // Faces as corner quads, counter-clockwise from outside.
        let quads = [
            [0, 2, 3, 1],
            [4, 5, 7, 6],
            [0, 1, 5, 4],
            [2, 6, 7, 3],
            [0, 4, 6, 2],
            [1, 3, 7, 5],
        ];
        let triangles = quads
            .iter()
            .flat_map(|q| [[q[0], q[1], q[2]], [q[0], q[2], q[3]]])
            .collect();
        Mesh {
            positions,
            triangles,
            ..Mesh::default()
        }
    }

    /// The sphere of `radius` about `centre` as a closed UV mesh: a vertex at each pole and
    /// `rings − 1` rings of `segments` vertices between them (latitudes at multiples of π /
    /// `rings`), outward triangles and unit outward normals (e.g. a reference shape with a
    /// closed-form surface; its volume approaches 4/3·π·r³ from below as the counts grow).
    /// Fewer than 2 rings or 3 segments give an empty mesh.
    pub fn uv_sphere(centre: [f32; 3], radius: f32, rings: u32, segments: u32) -> Mesh {
        if rings < 2 || segments < 3 {
            return Mesh::default();
        }
        let mut mesh = Mesh::default();
        let mut vertex = |d: [f32; 3]| {
            mesh.positions
                .push(std::array::from_fn(|k| centre[k] + radius * d[k]));
            mesh.normals.push(d);
        };
        vertex([0.0, 0.0, 1.0]);
        for i in 1..rings {
            let theta = std::f32::consts::PI * i as f32 / rings as f32;
            for j in 0..segments {
                let phi = std::f32::consts::TAU * j as f32 / segments as f32;
                vertex([
                    theta.sin() * phi.cos(),
                    theta.sin() * phi.sin(),
                    theta.cos(),
                ]);
            }
        }
        vertex([0.0, 0.0, -1.0]);
        let south = mesh.positions.len() as u32 - 1;
        let at = |i: u32, j: u32| 1 + (i - 1) * segments + j % segments;
        for j in 0..segments {
            mesh.triangles.push([0, at(1, j), at(1, j + 1)]);
            for i in 1..rings - 1 {
                let (a, b, c, d) = (at(i, j), at(i, j + 1), at(i + 1, j), at(i + 1, j + 1));
                mesh.triangles.extend([[a, c, d], [a, d, b]]);
            }
            mesh.triangles
                .push([south, at(rings - 1, j + 1), at(rings - 1, j)]);
        }
        mesh
    }

    fn corners(&self, t: &[u32; 3]) -> [[f64; 3]; 3] {
        t.map(|i| self.positions[i as usize].map(|v| v as f64))
    }

    /// Signed enclosed volume Σ (a · (b × c)) / 6 over the triangles (f64 sums). Positive for a
    /// closed mesh with outward normals; only meaningful for a closed mesh. Tetrahedra are taken
    /// from the first vertex rather than the origin, which keeps the sum well conditioned far
    /// from the origin.
    pub fn enclosed_volume(&self) -> f64 {
        let Some(o) = self.positions.first().map(|p| p.map(|v| v as f64)) else {
            return 0.0;
        };
        self.triangles
            .iter()
            .map(|t| {
                let [a, b, c] = self.corners(t).map(|p| sub(p, o));
                dot(a, cross(b, c)) / 6.0
            })
            .sum()
    }

    /// Centroid of the enclosed solid: Σ V_t (o + a + b + c)/4 / Σ V_t over the signed tetrahedra
    /// of [`Mesh::enclosed_volume`] (f64 sums, exact for a closed polyhedron); `None` for a mesh
    /// enclosing no volume.
    pub fn enclosed_centroid(&self) -> Option<[f64; 3]> {
        let o = self.positions.first().map(|p| p.map(|v| v as f64))?;
        let (mut volume, mut moment) = (0.0, [0.0; 3]);
        for t in &self.triangles {
            let [a, b, c] = self.corners(t).map(|p| sub(p, o));
            let v = dot(a, cross(b, c)) / 6.0;
            volume += v;
            for k in 0..3 {
                moment[k] += v * (a[k] + b[k] + c[k]) / 4.0;
            }
        }
        (volume != 0.0).then(|| std::array::from_fn(|k| o[k] + moment[k] / volume))
    }

    /// The axis-aligned box `(lo, hi)` of the vertices; `None` for a mesh without vertices.
    pub fn bounds(&self) -> Option<([f64; 3], [f64; 3])> {
        let first = self.positions.first()?.map(|v| v as f64);
        Some(self.positions.iter().fold((first, first), |(lo, hi), p| {
            (
                std::array::from_fn(|k| lo[k].min(p[k] as f64)),
                std::array::from_fn(|k| hi[k].max(p[k] as f64)),
            )
        }))
    }

    /// Total triangle area.
    pub fn area(&self) -> f64 {
        self.triangles
            .iter()
            .map(|t| {
                let [a, b, c] = self.corners(t);
                norm(cross(sub(b, a), sub(c, a))) / 2.0
            })
            .sum()
    }

    /// The mesh as readers that weld vertices by position see it (every STL reader: the format
    /// has no shared vertices; trimesh for every format): vertices with bit-identical positions
    /// merged into the first of them, triangles re-indexed, attributes dropped. A mesh of
    /// distinct positions comes back with the same triangles; its [`Mesh::topology`] is then
    /// what those readers find.
    pub fn welded(&self) -> Mesh {
        let mut first: FxHashMap<[u32; 3], u32> = FxHashMap::default();
        let mut positions = Vec::new();
        let index: Vec<u32> = self
            .positions
            .iter()
            .map(|p| {
                // + 0.0 makes −0 and 0 one key, as they are one point.
                *first
                    .entry(p.map(|v| (v + 0.0).to_bits()))
                    .or_insert_with(|| {
                        positions.push(*p);
                        positions.len() as u32 - 1
                    })
            })
            .collect();
        Mesh {
            positions,
            triangles: self
                .triangles
                .iter()
                .map(|t| t.map(|v| index[v as usize]))
                .collect(),
            ..Mesh::default()
        }
    }

    /// Edge and vertex incidence checks (see [`Topology`]).
    pub fn topology(&self) -> Topology {
        let mut directed: FxHashMap<(u32, u32), u32> = FxHashMap::default();
        for t in &self.triangles {
            for i in 0..3 {
                *directed.entry((t[i], t[(i + 1) % 3])).or_default() += 1;
            }
        }
        let (mut edges, mut boundary, mut nonmanifold, mut misoriented) = (0, 0, 0, 0);
        for (&(a, b), &n) in &directed {
            let back = directed.get(&(b, a)).copied().unwrap_or(0);
            // Count each undirected edge once, from its smaller end (or from a if b→a is absent).
            if back > 0 && a > b {
                continue;
            }
            edges += 1;
            match (n, back) {
                (1, 1) => {}
                (1, 0) => boundary += 1,
                _ if n + back > 2 => nonmanifold += 1,
                _ => misoriented += 1,
            }
        }
        let mut used = vec![false; self.positions.len()];
        self.triangles
            .iter()
            .flatten()
            .for_each(|&v| used[v as usize] = true);
        let vertices = used.iter().filter(|&&u| u).count() as i64;
        Topology {
            boundary_edges: boundary,
            nonmanifold_edges: nonmanifold,
            misoriented_edges: misoriented,
            nonmanifold_vertices: self.nonmanifold_vertices(),
            euler_characteristic: vertices - edges as i64 + self.triangles.len() as i64,
        }
    }

    /// Vertices whose link (the opposite edges of their triangles, b → c for triangle (v, b, c))
    /// is not one cycle.
    fn nonmanifold_vertices(&self) -> usize {
        let mut links: Vec<Vec<(u32, u32)>> = vec![Vec::new(); self.positions.len()];
        for t in &self.triangles {
            for i in 0..3 {
                links[t[i] as usize].push((t[(i + 1) % 3], t[(i + 2) % 3]));
            }
        }
        links
            .iter()
            .filter(|link| !link.is_empty() && !is_one_cycle(link))
            .count()
    }

    /// `n` points uniformly distributed over the surface by area, from a seeded PCG-64 (the
    /// same seed gives the same points on every platform).
    pub fn sample_by_area(&self, n: usize, seed: u64) -> Vec<[f32; 3]> {
        let mut cumulative = Vec::with_capacity(self.triangles.len());
        let mut total = 0.0;
        for t in &self.triangles {
            let [a, b, c] = self.corners(t);
            total += norm(cross(sub(b, a), sub(c, a)));
            cumulative.push(total);
        }
        if total <= 0.0 {
            return Vec::new();
        }
        let mut rng = Pcg64::seed_from_u64(seed);
        let mut uniform = || (rng.next_u64() >> 11) as f64 * (1.0 / (1u64 << 53) as f64);
        (0..n)
            .map(|_| {
                let r = uniform() * total;
                let i = cumulative
                    .partition_point(|&c| c <= r)
                    .min(cumulative.len() - 1);
                let [a, b, c] = self.corners(&self.triangles[i]);
                // Uniform on a triangle: fold the unit square's upper half onto the lower.
                let (mut u, mut v) = (uniform(), uniform());
                if u + v > 1.0 {
                    (u, v) = (1.0 - u, 1.0 - v);
                }
                std::array::from_fn(|k| (a[k] + u * (b[k] - a[k]) + v * (c[k] - a[k])) as f32)
            })
            .collect()
    }
}

/// True when the directed edges form a single cycle through all of them.
fn is_one_cycle(link: &[(u32, u32)]) -> bool {
    let mut next: FxHashMap<u32, u32> = FxHashMap::default();
    for &(b, c) in link {
        if next.insert(b, c).is_some() {
            return false;
        }
    }
    let start = link[0].0;
    let mut at = start;
    for step in 1..=link.len() {
        match next.get(&at) {
            Some(&n) => at = n,
            None => return false,
        }
        if at == start {
            return step == link.len();
        }
    }
    false
}

fn sub(a: [f64; 3], b: [f64; 3]) -> [f64; 3] {
    std::array::from_fn(|i| a[i] - b[i])
}

fn dot(a: [f64; 3], b: [f64; 3]) -> f64 {
    a[0] * b[0] + a[1] * b[1] + a[2] * b[2]
}

fn cross(a: [f64; 3], b: [f64; 3]) -> [f64; 3] {
    [
        a[1] * b[2] - a[2] * b[1],
        a[2] * b[0] - a[0] * b[2],
        a[0] * b[1] - a[1] * b[0],
    ]
}

fn norm(a: [f64; 3]) -> f64 {
    dot(a, a).sqrt()
}

#[cfg(test)]
mod tests {
    use super::*;

    fn cube() -> Mesh {
        Mesh::cuboid([0.0; 3], [1.0; 3])
    }

    #[test]
    fn cube_volume_area_and_topology() {
        let mut m = cube();
        assert!((m.enclosed_volume() - 1.0).abs() < 1e-12);
        assert!((m.area() - 6.0).abs() < 1e-12);
        let t = m.topology();
        assert!(t.is_closed_manifold(), "{t:?}");
        assert_eq!(t.euler_characteristic, 2);
        let c = m.enclosed_centroid().unwrap();
        assert!(c.iter().all(|v| (v - 0.5).abs() < 1e-12), "{c:?}");
        assert_eq!(m.bounds(), Some(([0.0; 3], [1.0; 3])));
        // Far from the origin the volume and centroid stay exact.
        m.positions.iter_mut().for_each(|p| p[0] += 1000.0);
        assert!((m.enclosed_volume() - 1.0).abs() < 1e-9);
        let c = m.enclosed_centroid().unwrap();
        assert!(
            (c[0] - 1000.5).abs() < 1e-9 && (c[1] - 0.5).abs() < 1e-9,
            "{c:?}"
        );
        assert_eq!(Mesh::default().enclosed_centroid(), None);
        assert_eq!(Mesh::default().bounds(), None);
    }

    #[test]
    fn uv_sphere_is_closed_outward_and_on_the_sphere() {
        let centre = [3.0, -2.0, 1.0];
        let m = Mesh::uv_sphere(centre, 2.0, 24, 48);
        let t = m.topology();
        assert!(t.is_closed_manifold(), "{t:?}");
        assert_eq!(t.euler_characteristic, 2);
        assert_eq!(
            (m.positions.len(), m.triangles.len()),
            (2 + 23 * 48, 2 * 23 * 48)
        );
        for (p, n) in m.positions.iter().zip(&m.normals) {
            let d: [f32; 3] = std::array::from_fn(|k| (p[k] - centre[k]) / 2.0);
            assert!(d.iter().zip(n).all(|(a, b)| (a - b).abs() < 1e-6), "{p:?}");
        }
        // Inscribed: a little under the sphere's volume and area, and converging to them.
        let (volume, area) = (
            4.0 / 3.0 * std::f64::consts::PI * 8.0,
            16.0 * std::f64::consts::PI,
        );
        assert!(m.enclosed_volume() < volume && m.enclosed_volume() > 0.99 * volume);
        assert!(m.area() < area && m.area() > 0.99 * area);
        assert_eq!(Mesh::uv_sphere(centre, 1.0, 1, 8), Mesh::default());
    }

    #[test]
    fn topology_finds_holes_flips_and_pinches() {
        let mut open = cube();
        open.triangles.pop();
        let t = open.topology();
        assert_eq!((t.boundary_edges, t.is_closed_manifold()), (3, false));

        let mut flipped = cube();
        flipped.triangles[0].swap(1, 2);
        let t = flipped.topology();
        assert_eq!(t.misoriented_edges, 3);

        // Two cubes sharing corner 7 ↔ 0: every edge is fine, the shared vertex is not.
        let mut pinched = cube();
        let other = cube();
        pinched
            .positions
            .extend(other.positions[1..].iter().map(|p| p.map(|v| v + 1.0)));
        let remap = |i: u32| if i == 0 { 7 } else { i + 7 };
        pinched
            .triangles
            .extend(other.triangles.iter().map(|t| t.map(remap)));
        let t = pinched.topology();
        assert_eq!(
            (t.boundary_edges, t.nonmanifold_edges, t.misoriented_edges),
            (0, 0, 0)
        );
        assert_eq!(t.nonmanifold_vertices, 1);
        assert!(!t.is_closed_manifold());
        assert!((pinched.enclosed_volume() - 2.0).abs() < 1e-12);
    }

    #[test]
    fn area_samples_are_on_the_surface_and_spread_by_area() {
        let mut m = cube();
        // Stretched 4x along x: four side faces of area 4 and two end faces of area 1, so the
        // x = 0 face holds 1/18 of the area.
        m.positions.iter_mut().for_each(|p| p[0] *= 4.0);
        let pts = m.sample_by_area(18_000, 3);
        assert_eq!(pts, m.sample_by_area(18_000, 3));
        let on_x0 = pts.iter().filter(|p| p[0] == 0.0).count() as f64 / pts.len() as f64;
        assert!((on_x0 - 1.0 / 18.0).abs() < 0.01, "{on_x0}");
        for p in &pts {
            let on_face = (0..3).any(|a| {
                let hi = if a == 0 { 4.0 } else { 1.0 };
                p[a] == 0.0 || (p[a] - hi).abs() < 1e-5
            });
            assert!(on_face, "{p:?}");
        }
    }
}
