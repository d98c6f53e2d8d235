//! 3D IoU of a model's class against a reference mesh: cells whose centre is inside, i.e. an
//! odd number of surface crossings below it along +z. Ties at shared edges and vertices are
//! broken half-open, as if shifted by (−δ, −δ²) in xy, so each counts once and parity holds.

use dynaslice_core::{Model, Scratch};
use dynaslice_mesh::Mesh;
use rayon::prelude::*;
use std::ops::Range;

/// Points per batch call (bounds memory within a slab).
const CHUNK: usize = 4096;

/// Cell-centre coordinate of cell `i` along axis `a`.
fn centre(bounds: ([f64; 3], [f64; 3]), n: [usize; 3], a: usize, i: usize) -> f64 {
    let (lo, hi) = bounds;
    lo[a] + (i as f64 + 0.5) * (hi[a] - lo[a]) / n[a] as f64
}

/// Cells along axis `a` whose centres may lie in [u, v], one extra on each side since rounding
/// must not drop a column that the exact test would keep.
fn span(bounds: ([f64; 3], [f64; 3]), n: [usize; 3], a: usize, u: f64, v: f64) -> Range<usize> {
    let step = (bounds.1[a] - bounds.0[a]) / n[a] as f64;
    let f = |w: f64, shift: f64| ((w - bounds.0[a]) / step + shift).clamp(0.0, n[a] as f64);
    f(u, -1.5).ceil() as usize..f(v, 1.5).floor() as usize
}

/// (s, e) with s + e = a + b exactly.
fn two_sum(a: f64, b: f64) -> (f64, f64) {
    let s = a + b;
    let bb = s - a;
    (s, (a - (s - bb)) + (b - bb))
}

/// The exact sign of a·d − b·c (−1, 0 or 1), with its rounded value.
fn det2(a: f64, b: f64, c: f64, d: f64) -> (i8, f64) {
    let (p, q) = (a * d, b * c);
    let w = p - q;
    // The rounding error of w is below 2ε(|p| + |q|): outside that, its sign is exact.
    if w.abs() > 2.0 * f64::EPSILON * (p.abs() + q.abs()) {
        return (sign(w), w);
    }
    // a·d − b·c = p + (a·d − p) − q − (b·c − q), the product errors exact by fma. Two-sums
    // keep the running sum exact as non-overlapping components of increasing magnitude, so
    // the largest nonzero one has the sign of the sum.
    let terms = [p, -q, a.mul_add(d, -p), -b.mul_add(c, -q)];
    let mut parts = [0.0; 4];
    for (n, x) in terms.into_iter().enumerate() {
        let mut s = x;
        for h in &mut parts[..n] {
            (s, *h) = two_sum(s, *h);
        }
        parts[n] = s;
    }
    let s = parts
        .iter()
        .rev()
        .find(|&&h| h != 0.0)
        .map_or(0, |&h| sign(h));
    (s, w)
}

/// The least and greatest coordinate `a` of a triangle.
fn extent(p: &[[f64; 3]; 3], a: usize) -> (f64, f64) {
    (
        p[0][a].min(p[1][a]).min(p[2][a]),
        p[0][a].max(p[1][a]).max(p[2][a]),
    )
}

fn sign(v: f64) -> i8 {
    (v > 0.0) as i8 - (v < 0.0) as i8
}

/// Which side of the edge a → b the column is on (a, b relative to it): the sign of
/// cross(a, b), ties broken by the shift (−δ, −δ²), which adds δ·d_y − δ²·d_x for d = b − a.
/// Reversing the edge negates every term exactly, so the two triangles of a shared edge see
/// the column on opposite sides.
fn side(a: [f64; 2], b: [f64; 2]) -> (i8, f64) {
    let (s, w) = det2(a[0], a[1], b[0], b[1]);
    if s != 0 {
        return (s, w);
    }
    let (dx, dy) = (b[0] - a[0], b[1] - a[1]);
    (if dy != 0.0 { sign(dy) } else { -sign(dx) }, w)
}

/// Whether the centre of every cell of a regular grid over `bounds` lies inside the closed
/// `mesh` (ray parity along +z per (x, y) column, see the module doc). Index
/// x + nx·(y + ny·z) for `resolution` = [nx, ny, nz]; empty when a resolution is 0.
pub fn inside_grid(mesh: &Mesh, bounds: ([f64; 3], [f64; 3]), resolution: [usize; 3]) -> Vec<bool> {
    let [nx, ny, nz] = resolution;
    if nx * ny * nz == 0 {
        return Vec::new();
    }
    let corners = |t: &[u32; 3]| t.map(|i| mesh.positions[i as usize].map(f64::from));
    // Triangles by the rows of columns they may cover. Those with all x or all y equal cover
    // no column under the shifted rule (their edges' sides never agree), so skipping them is
    // exact; other zero-area ones fail the sign test below.
    let mut rows = vec![Vec::new(); ny];
    for (t, tri) in mesh.triangles.iter().enumerate() {
        let p = corners(tri);
        let ((x0, x1), (y0, y1)) = (extent(&p, 0), extent(&p, 1));
        if x0 == x1 || y0 == y1 {
            continue;
        }
        for row in &mut rows[span(bounds, resolution, 1, y0, y1)] {
            row.push(t as u32);
        }
    }
    let z_step = (bounds.1[2] - bounds.0[2]) / nz as f64;
    // Per column, sorted indices of the first cell at or above each crossing.
    let crossings: Vec<Vec<Vec<u32>>> = rows
        .par_iter()
        .enumerate()
        .map(|(j, row)| {
            let y = centre(bounds, resolution, 1, j);
            let mut columns = vec![Vec::new(); nx];
            for &t in row {
                let p = corners(&mesh.triangles[t as usize]);
                let (x0, x1) = extent(&p, 0);
                for i in span(bounds, resolution, 0, x0, x1) {
                    let x = centre(bounds, resolution, 0, i);
                    // Relative to the column, so every triangle rounds a shared vertex alike.
                    let q = p.map(|v| [v[0] - x, v[1] - y]);
                    let (s0, w0) = side(q[1], q[2]);
                    let (s1, w1) = side(q[2], q[0]);
                    let (s2, w2) = side(q[0], q[1]);
                    // Zero only for coincident corners in xy: no area, no crossing.
                    if s0 == 0 || s0 != s1 || s1 != s2 {
                        continue;
                    }
                    let (zlo, zhi) = extent(&p, 2);
                    // Barycentric weights w_k are opposite corner k; clamping keeps rounding
                    // (and a near-zero total) from leaving the triangle, and a flat one exact.
                    let total = w0 + w1 + w2;
                    let z = if total != 0.0 {
                        ((w0 * p[0][2] + w1 * p[1][2] + w2 * p[2][2]) / total).clamp(zlo, zhi)
                    } else {
                        zlo
                    };
                    let first = ((z - bounds.0[2]) / z_step - 0.5)
                        .ceil()
                        .clamp(0.0, nz as f64);
                    columns[i].push(first as u32);
                }
            }
            columns.iter_mut().for_each(|c| c.sort_unstable());
            columns
        })
        .collect();
    let mut inside = vec![false; nx * ny * nz];
    inside
        .par_chunks_mut(nx * ny)
        .enumerate()
        .for_each(|(k, slab)| {
            for (cells, columns) in slab.chunks_mut(nx).zip(&crossings) {
                for (cell, c) in cells.iter_mut().zip(columns) {
                    *cell = c.partition_point(|&s| s as usize <= k) % 2 == 1;
                }
            }
        });
    inside
}

/// IoU at world time `t` between the cells `model` labels class `class` (0-based; Eq. 11
/// label `class + 1`) and the cells inside `reference`, on a `resolution` grid over `bounds`
/// (world units). `None` when both sets are empty.
pub fn model_iou(
    model: &Model,
    class: usize,
    t: f32,
    reference: &Mesh,
    bounds: ([f64; 3], [f64; 3]),
    resolution: [usize; 3],
) -> Option<f64> {
    let inside = inside_grid(reference, bounds, resolution);
    let [nx, ny, nz] = resolution;
    let label = class as u32 + 1;
    let (intersection, union) = (0..nz)
        .into_par_iter()
        .map_init(Scratch::boxed, |scratch, k| {
            let z = centre(bounds, resolution, 2, k) as f32;
            let points: Vec<[f32; 3]> = (0..nx * ny)
                .map(|c| {
                    let x = centre(bounds, resolution, 0, c % nx) as f32;
                    [x, centre(bounds, resolution, 1, c / nx) as f32, z]
                })
                .collect();
            let times = vec![t; CHUNK];
            let mut labels = vec![0u32; CHUNK];
            let slab = &inside[k * nx * ny..(k + 1) * nx * ny];
            let (mut n, mut u) = (0u64, 0u64);
            for (chunk, truth) in points.chunks(CHUNK).zip(slab.chunks(CHUNK)) {
                let m = chunk.len();
                model
                    .label_batch(scratch, chunk, &times[..m], &mut labels[..m])
                    .expect("buffers sized to the chunk");
                for (&l, &b) in labels[..m].iter().zip(truth) {
                    n += (l == label && b) as u64;
                    u += (l == label || b) as u64;
                }
            }
            (n, u)
        })
        .reduce(|| (0, 0), |a, b| (a.0 + b.0, a.1 + b.1));
    (union > 0).then(|| intersection as f64 / union as f64)
}

/// The bounding box of `mesh`'s vertices grown by `margin` × its diagonal on every side (all
/// zeros for a mesh without vertices).
pub fn padded_bounds(mesh: &Mesh, margin: f64) -> ([f64; 3], [f64; 3]) {
    let Some(first) = mesh.positions.first() else {
        return ([0.0; 3], [0.0; 3]);
    };
    let first = first.map(f64::from);
    let (mut lo, mut hi) = (first, first);
    for p in &mesh.positions {
        for a in 0..3 {
            lo[a] = lo[a].min(f64::from(p[a]));
            hi[a] = hi[a].max(f64::from(p[a]));
        }
    }
    let pad = margin * (0..3).map(|a| (hi[a] - lo[a]).powi(2)).sum::<f64>().sqrt();
    (lo.map(|v| v - pad), hi.map(|v| v + pad))
}

/// A resolution with `cells_longest_axis` cells along the longest axis of `bounds` and as
/// near cubic cells as whole counts allow on the others (at least 1 per axis).
pub fn grid_for(bounds: ([f64; 3], [f64; 3]), cells_longest_axis: usize) -> [usize; 3] {
    let extent: [f64; 3] = std::array::from_fn(|a| bounds.1[a] - bounds.0[a]);
    let longest = extent.iter().fold(0.0f64, |m, &e| m.max(e));
    // NaN (flat bounds) casts to 0, then 1.
    extent.map(|e| ((e / longest * cells_longest_axis as f64).round() as usize).max(1))
}

#[cfg(test)]
mod tests {
    use super::*;
    use dynaslice_test_support::spheres::{self, Sphere};
    use std::f64::consts::PI;

    fn mesh(positions: Vec<[f64; 3]>, triangles: Vec<[u32; 3]>) -> Mesh {
        Mesh {
            positions: positions.into_iter().map(|p| p.map(|v| v as f32)).collect(),
            triangles,
            ..Mesh::default()
        }
    }

    /// The box [lo, hi], two triangles a face, outward.
    fn cuboid(lo: [f64; 3], hi: [f64; 3]) -> Mesh {
        Mesh::cuboid(lo.map(|v| v as f32), hi.map(|v| v as f32))
    }

    /// [`Mesh::uv_sphere`] at an f64 centre and radius.
    fn uv_sphere(c: [f64; 3], r: f64, stacks: u32, slices: u32) -> Mesh {
        Mesh::uv_sphere(c.map(|v| v as f32), r as f32, stacks, slices)
    }

    fn concat(a: &Mesh, b: &Mesh) -> Mesh {
        let n = a.positions.len() as u32;
        Mesh {
            positions: a.positions.iter().chain(&b.positions).copied().collect(),
            triangles: a
                .triangles
                .iter()
                .copied()
                .chain(b.triangles.iter().map(|t| t.map(|i| i + n)))
                .collect(),
            ..Mesh::default()
        }
    }

    fn count(cells: &[bool]) -> usize {
        cells.iter().filter(|&&b| b).count()
    }

    #[test]
    fn exact_sign_where_rounding_loses_it() {
        // (1 + 2⁻³⁰)² − (1 + 2⁻²⁹) = 2⁻⁶⁰, which both products round away.
        let (a, b) = (1.0 + 2f64.powi(-30), 1.0 + 2f64.powi(-29));
        assert_eq!(a * a - b, 0.0);
        assert_eq!(det2(a, b, 1.0, a).0, 1);
        assert_eq!(det2(b, a, a, 1.0).0, -1);
        assert_eq!(det2(3.0, 6.0, 1.0, 2.0).0, 0);
    }

    /// A box has exactly one cell per centre inside it, per axis: in x and y (lo, hi] by the
    /// (−δ, −δ²) shift, in z [lo, hi) (a crossing at a centre counts below it). The first box
    /// has its faces, edges and corners on cell centres (unit cells centred at i + 0.5), and
    /// the face diagonals pass through centres.
    #[test]
    fn boxes_give_exact_counts_with_ties_on_centres() {
        let bounds = ([0.0; 3], [10.0; 3]);
        let boxes = [
            ([2.5, 2.5, 2.5], [7.5, 7.5, 7.5]),
            ([0.5, 1.5, 3.5], [9.5, 4.5, 8.5]),
            ([1.3, 2.0, 0.2], [6.1, 9.7, 4.9]),
            ([-1.0, 4.4, 5.0], [3.0, 11.0, 12.0]),
        ];
        for (lo, hi) in boxes {
            let m = cuboid(lo, hi);
            assert!(m.topology().is_closed_manifold() && m.enclosed_volume() > 0.0);
            let inside = inside_grid(&m, bounds, [10; 3]);
            for (n, &b) in inside.iter().enumerate() {
                let c = [n % 10, n / 10 % 10, n / 100].map(|i| i as f64 + 0.5);
                let want =
                    (0..2).all(|a| lo[a] < c[a] && c[a] <= hi[a]) && lo[2] <= c[2] && c[2] < hi[2];
                assert_eq!(b, want, "{lo:?} {hi:?} at {c:?}");
            }
        }
        assert_eq!(
            count(&inside_grid(
                &cuboid(boxes[0].0, boxes[0].1),
                bounds,
                [10; 3]
            )),
            125
        );
    }

    /// The octahedron |x| + |y| + |z − h/4| ≤ mh with its vertices on column centres (centres at
    /// multiples of h): four triangles meet at each apex on the middle column and two at each
    /// projected edge. Column (i, j) holds the cells with centres kh, −s + 1/4 ≤ k < s + 1/4
    /// for s = m − |i| − |j|, i.e. 1 − s ≤ k ≤ s (no crossing on a centre, thanks to the h/4).
    #[test]
    fn octahedron_counts_each_vertex_and_edge_once() {
        let (n, h, m) = (63usize, 1.0 / 16.0, 20i64);
        let half = n as f64 * h / 2.0;
        let bounds = ([-half; 3], [half; 3]);
        let (a, z0) = (m as f64 * h, h / 4.0);
        let v = vec![
            [a, 0.0, z0],
            [0.0, a, z0],
            [-a, 0.0, z0],
            [0.0, -a, z0],
            [0.0, 0.0, z0 + a],
            [0.0, 0.0, z0 - a],
        ];
        let t = (0..4)
            .flat_map(|k| [[k, (k + 1) % 4, 4], [(k + 1) % 4, k, 5]])
            .collect();
        let octahedron = mesh(v, t);
        assert!(octahedron.topology().is_closed_manifold());
        let inside = inside_grid(&octahedron, bounds, [n; 3]);
        let c = n as i64 / 2;
        for y in 0..n as i64 {
            for x in 0..n as i64 {
                let s = (m - (x - c).abs() - (y - c).abs()).max(0);
                let column = (0..n).filter(|&z| inside[x as usize + n * (y as usize + n * z)]);
                let want: Vec<usize> = (c + 1 - s..c + 1 + s).map(|z| z as usize).collect();
                assert_eq!(column.collect::<Vec<_>>(), want, "column {x} {y}");
            }
        }
    }

    /// A UV sphere (convex, vertices on the sphere) with its poles on the middle column:
    /// every centre clear of the thin shell between the polyhedron's inscribed ball and the
    /// sphere is classified as the ball would be, and the volume lies within the exact bounds
    /// for cells with centres inside a convex body K: vol(K shrunk by ρ) ≤ count·h³ ≤
    /// vol(K grown by ρ), ρ = √3·h/2 (half a cell diagonal).
    #[test]
    fn sphere_cells_match_the_ball() {
        let (n, h, r) = (63usize, 1.0 / 16.0, 1.5);
        let half = n as f64 * h / 2.0;
        let sphere = uv_sphere([0.0; 3], r, 24, 48);
        assert!(sphere.topology().is_closed_manifold());
        let r_in = sphere
            .triangles
            .iter()
            .map(|t| {
                let [a, b, c] = t.map(|i| sphere.positions[i as usize].map(f64::from));
                let (u, v) = (
                    [0, 1, 2].map(|k| b[k] - a[k]),
                    [0, 1, 2].map(|k| c[k] - a[k]),
                );
                let nrm = [
                    u[1] * v[2] - u[2] * v[1],
                    u[2] * v[0] - u[0] * v[2],
                    u[0] * v[1] - u[1] * v[0],
                ];
                let len = nrm.iter().map(|x| x * x).sum::<f64>().sqrt();
                (0..3).map(|k| nrm[k] * a[k]).sum::<f64>() / len
            })
            .fold(f64::INFINITY, f64::min);
        assert!(r_in > 0.98 * r && r_in < r, "{r_in}");
        let inside = inside_grid(&sphere, ([-half; 3], [half; 3]), [n; 3]);
        let mut checked = 0;
        for (i, &b) in inside.iter().enumerate() {
            let c = [i % n, i / n % n, i / (n * n)].map(|k| (k as f64 - (n / 2) as f64) * h);
            let d = c.iter().map(|x| x * x).sum::<f64>().sqrt();
            // f32 vertices sit within 1e-6 r of the sphere.
            if d < r_in - 1e-5 || d > r + 1e-5 {
                assert_eq!(b, d < r, "at {c:?}");
                checked += 1;
            }
        }
        assert!(checked > inside.len() * 98 / 100);
        let rho = 3f64.sqrt() * h / 2.0;
        let ball = |r: f64| 4.0 / 3.0 * PI * r.powi(3);
        let v = count(&inside) as f64 * h.powi(3);
        assert!(ball(r_in - rho) <= v && v <= ball(r + rho), "{v}");
        // Far inside that bound in practice: the surface cells' errors mostly cancel.
        let polyhedron = sphere.enclosed_volume();
        assert!(
            (v - polyhedron).abs() < 0.01 * polyhedron,
            "{v} vs {polyhedron}"
        );
    }

    /// Disjoint meshes together: the inside sets add. Nested: parity leaves the shell.
    #[test]
    fn disjoint_meshes_add_and_nested_ones_subtract() {
        let bounds = ([0.0; 3], [10.0; 3]);
        let a = uv_sphere([3.0, 3.0, 3.2], 2.1, 16, 32);
        let b = cuboid([5.6, 5.2, 1.1], [9.3, 8.8, 9.9]);
        let grid = |m: &Mesh| inside_grid(m, bounds, [40; 3]);
        let (ia, ib, both) = (grid(&a), grid(&b), grid(&concat(&a, &b)));
        assert!(count(&ia) > 1000 && count(&ib) > 1000);
        for ((&x, &y), &z) in ia.iter().zip(&ib).zip(&both) {
            assert!(!(x && y));
            assert_eq!(z, x || y);
        }
        let inner = cuboid([6.1, 6.3, 2.0], [8.7, 7.9, 9.1]);
        let ic = grid(&inner);
        let shell = grid(&concat(&b, &inner));
        assert_eq!(count(&shell), count(&ib) - count(&ic));
        assert!(shell.iter().zip(&ic).all(|(&s, &c)| !(s && c)));
    }

    #[test]
    fn bounds_and_grids() {
        let m = cuboid([1.0, 2.0, 3.0], [4.0, 4.0, 4.0]);
        let (lo, hi) = padded_bounds(&m, 0.1);
        let pad = 0.1 * 14f64.sqrt();
        for (a, (l, h)) in [(1.0, 4.0), (2.0, 4.0), (3.0, 4.0)].into_iter().enumerate() {
            assert!((lo[a] - (l - pad)).abs() < 1e-12 && (hi[a] - (h + pad)).abs() < 1e-12);
        }
        assert_eq!(grid_for(([0.0; 3], [4.0, 2.0, 0.1]), 40), [40, 20, 1]);
        assert_eq!(grid_for(([1.0; 3], [1.0; 3]), 40), [1, 1, 1]);
        assert_eq!(padded_bounds(&Mesh::default(), 0.1), ([0.0; 3], [0.0; 3]));
    }

    /// The hand-built sphere model against UV spheres of the same centre: its own radius
    /// (IoU near 1, short of it by the mesh's facets) and 0.8 of it (nested balls: IoU 0.8³).
    #[test]
    fn model_against_sphere_meshes() {
        let s = Sphere::new([0.1, -0.2, 0.05], 0.4, 0.0);
        let bytes = spheres::model(&[s], &[("ball", 1)]);
        let model = Model::from_bytes(&bytes).unwrap();
        let (c, r) = (s.world_centre(), s.world_radius(0.0));
        let same = uv_sphere(c, r, 48, 96);
        let bounds = padded_bounds(&same, 0.05);
        let grid = grid_for(bounds, 64);
        assert_eq!(grid, [64; 3]);
        let iou = model_iou(&model, 0, 0.0, &same, bounds, grid).unwrap();
        assert!(iou > 0.97, "{iou}");
        let smaller = uv_sphere(c, 0.8 * r, 48, 96);
        let iou = model_iou(&model, 0, 0.0, &smaller, bounds, grid).unwrap();
        assert!((iou - 0.512).abs() < 0.02, "{iou}");
        // Far from both: nothing to compare.
        let away = ([24.0, 10.0, 16.0], [28.0, 14.0, 20.0]);
        assert_eq!(model_iou(&model, 0, 0.0, &same, away, [8; 3]), None);
    }
}
