//! Reader for `.csl` planar-contour files (OReX and earlier cross-section reconstruction work)
//! (one timestep; a `.seq` manifest makes a sequence of them, see `crate::manifest`).
//!
//! # Grammar (as the upstream parser reads it)
//! Line 1 `CSLC`; line 2 `<n_planes> <n_labels>`; blank lines ignored. Per plane a header
//! `<plane id, 1-based> <n_verts> <n_components> A B C D` (the plane Ax + By + Cz + D = 0), then
//! `n_verts` lines `x y z`, then `n_components` lines `<n>[h<parent>] <label> i0 … i(n−1)`: a closed
//! polygon over 0-based indices into the plane's vertices; `h<parent>` marks a hole inside
//! component `<parent>` (0-based, same plane). `n_labels` is informational (upstream files
//! declare more labels than they use) and is not checked.
//!
//! # Labels and classes
//! - A solid component's class is its label value; the sequence's classes are the distinct solid
//!   labels of all its files, in increasing order, named by an optional [`LabelTable`] table.
//! - A hole belongs to its parent's class. Its own label must equal the parent's, or be `2` under a
//!   parent labelled `1`: upstream single-object files write 1 for solids and 2 for holes. Any
//!   other pairing is an error, and so is the `2`-under-`1` pairing in a file that also has solids
//!   labelled 2 (it would be ambiguous).
//! - Every plane annotates every class of the sequence: a `.csl` plane is a complete
//!   segmentation, so a class with no contour on it is absent there (upstream treats empty planes
//!   the same way).
//! - Nesting, not the stored orientation, decides outer boundaries and holes (see
//!   [`Sequence::new`]); a hole must still lie inside the parent it names.
//!
//! # Crossing and self-touching contours
//! The contours of one class on one plane are read by the even-odd rule. Where they cross or
//! touch in a way [`Sequence::new`] would refuse (see [`find_contacts`]: a ring crossing itself or
//! passing twice through a vertex so that it crosses there, a vertex on another edge, overlapping
//! edges, and two components of the class crossing each other), they are replaced by simple rings
//! bounding the same even-odd region ([`even_odd_rings`]), with a warning naming file, plane,
//! label and components. For crossing components this makes their overlap a hole: the even-odd
//! reading of all the class's rings, the one that trusts neither orientation nor hole markers.
//! Rings that merely share a vertex are left to the validator's pinch repair; a set of rings whose
//! even-odd region is empty is refused.
//!
//! # Plane frames and regions of interest
//! The plane is the one the vertices lie on: the stated Ax + By + Cz + D = 0 when every vertex
//! is within 10⁻⁶ × the file's bounding-box diagonal of it; else, with a warning,
//! Ax + By + Cz = D (the other sign convention) when they fit that; else their least-squares
//! plane when they are coplanar within [`COPLANAR_TOLERANCE`] × their extent; else the plane is
//! refused. The normal n is the chosen
//! plane's, oriented like (A, B, C); u is the world axis least aligned with it, made orthogonal and
//! unit; v = n × u. The origin is the projection onto the plane of the centroid of the plane's
//! vertices (of the file's vertices if it has none). The region of interest of every plane is the
//! projection of the file's vertex bounding box grown by 5 % of its diagonal on each side.
//!
//! # Sequences
//! One `.csl` file is one timestep at time 0. A `.seq` manifest (`.cslseq` is its older name)
//! lists a sequence of them with their times: see [`crate::manifest`]; classes are matched by
//! name across files, and every plane of a `.csl` file annotates every class of the sequence.

use std::collections::BTreeSet;
use std::path::Path;

use super::label_table::LabelTable;
use super::reslice::{normalize, plane_axes};
use dynaslice_geometry::polygon::contains;
use dynaslice_geometry::repair::{even_odd_rings, find_contacts};
use dynaslice_geometry::Polygon;
use dynaslice_sequence::error::{excerpt, DataError, ErrorKind, Result};
use dynaslice_sequence::input_file;
use dynaslice_sequence::sequence::{dot, Annotation, Frame, Plane, Rect, Sequence};

/// One component line of a `.csl` plane.
#[derive(Debug, Clone)]
struct Component {
    line: usize,
    label: i32,
    parent: Option<usize>,
    indices: Vec<usize>,
}

/// One plane of a `.csl` file as written.
#[derive(Debug, Clone)]
struct RawPlane {
    line: usize,
    coefficients: [f64; 4],
    vertices: Vec<[f64; 3]>,
    components: Vec<Component>,
}

/// A parsed `.csl` file before classes are assigned.
#[derive(Debug, Clone)]
struct RawFile {
    planes: Vec<RawPlane>,
}

/// Non-blank lines with their 1-based numbers.
struct Lines<'a> {
    iter: std::iter::Peekable<Box<dyn Iterator<Item = (usize, &'a str)> + 'a>>,
    /// Non-blank lines not yet taken by [`Lines::next`].
    remaining: usize,
}

impl<'a> Lines<'a> {
    fn new(text: &'a str) -> Self {
        let it: Box<dyn Iterator<Item = (usize, &'a str)>> = Box::new(
            text.lines()
                .enumerate()
                .map(|(i, l)| (i + 1, l.trim()))
                .filter(|(_, l)| !l.is_empty()),
        );
        Lines {
            iter: it.peekable(),
            remaining: text.lines().filter(|l| !l.trim().is_empty()).count(),
        }
    }

    fn next(&mut self, what: impl FnOnce() -> ErrorKind) -> Result<(usize, Vec<&'a str>)> {
        match self.iter.next() {
            Some((n, l)) => {
                self.remaining = self.remaining.saturating_sub(1);
                Ok((n, l.split_whitespace().collect()))
            }
            None => Err(what().into()),
        }
    }

    /// The line of item `index` (0-based) of `declared` items that take a line each (planes,
    /// vertices, components): running out of lines is a count mismatch.
    fn item(&mut self, what: &str, index: usize, declared: usize) -> Result<(usize, Vec<&'a str>)> {
        self.next(|| ErrorKind::CountMismatch {
            what: what.into(),
            declared,
            found: index,
        })
    }

    /// Capacity to reserve for `declared` items that take a line each (planes, vertices,
    /// components): a count field is untrusted input, so it is capped by the lines that are left.
    /// (A fixed cap let a tiny file claiming 2^31 vertices reserve 24 MiB before failing.)
    fn capacity(&self, declared: usize) -> usize {
        declared.min(self.remaining)
    }
}

fn syntax(line: usize, what: String) -> DataError {
    DataError::new(ErrorKind::Syntax(what)).at_line(line)
}

fn parse_num<T: std::str::FromStr>(line: usize, token: &str, what: &str) -> Result<T> {
    token.parse().map_err(|_| {
        syntax(
            line,
            format!("{what} `{}` is not a valid number", excerpt(token)),
        )
    })
}

fn finite(line: usize, value: f64, what: &str) -> Result<f64> {
    if value.is_finite() {
        Ok(value)
    } else {
        Err(DataError::new(ErrorKind::NotFinite {
            what: what.into(),
            value,
        })
        .at_line(line))
    }
}

fn parse_file(text: &str) -> Result<RawFile> {
    let mut lines = Lines::new(text);
    let (n, magic) = lines.next(|| ErrorKind::Empty("the file is empty".into()))?;
    if magic != ["CSLC"] {
        return Err(syntax(
            n,
            format!("expected `CSLC`, found `{}`", excerpt(&magic.join(" "))),
        ));
    }
    let (n, counts) = lines.next(|| ErrorKind::Syntax("missing `<n_planes> <n_labels>`".into()))?;
    if counts.len() != 2 {
        return Err(syntax(n, "expected `<n_planes> <n_labels>`".into()));
    }
    let n_planes: usize = parse_num(n, counts[0], "plane count")?;
    let _n_labels: usize = parse_num(n, counts[1], "label count")?;
    let mut planes = Vec::with_capacity(lines.capacity(n_planes));
    for pi in 0..n_planes {
        let plane = parse_plane(&mut lines, pi, n_planes).map_err(|e| e.at_plane(pi))?;
        planes.push(plane);
    }
    if let Some((n, _)) = lines.iter.next() {
        let extra = 1 + lines.iter.count();
        return Err(DataError::new(ErrorKind::CountMismatch {
            what: format!("content after the last plane ({extra} more lines)"),
            declared: n_planes,
            found: n_planes + 1,
        })
        .at_line(n));
    }
    if planes.is_empty() {
        return Err(ErrorKind::Empty("the file declares no plane".into()).into());
    }
    Ok(RawFile { planes })
}

fn parse_plane(lines: &mut Lines, pi: usize, n_planes: usize) -> Result<RawPlane> {
    // Declared is the header's count, not `pi + 1` (which said "the header says 2" for 2^31
    // planes).
    let (n, h) = lines.item("planes", pi, n_planes)?;
    if h.len() != 7 {
        return Err(syntax(
            n,
            format!(
                "plane header needs 7 fields `<id> <n_verts> <n_components> A B C D`, found {}",
                h.len()
            ),
        ));
    }
    let id: usize = parse_num(n, h[0], "plane id")?;
    if id != pi + 1 {
        return Err(syntax(n, format!("plane id is {id}, expected {}", pi + 1)));
    }
    let n_verts: usize = parse_num(n, h[1], "vertex count")?;
    let n_comps: usize = parse_num(n, h[2], "component count")?;
    let mut coefficients = [0.0; 4];
    for k in 0..4 {
        coefficients[k] = finite(
            n,
            parse_num(n, h[3 + k], "plane coefficient")?,
            "plane coefficient",
        )?;
    }
    let mut vertices = Vec::with_capacity(lines.capacity(n_verts));
    for vi in 0..n_verts {
        let (ln, t) = lines.item("vertices of the plane", vi, n_verts)?;
        if t.len() != 3 {
            let hint = if t.len() > 3 || t.first().is_some_and(|s| s.contains('h')) {
                " (the vertex count may be wrong)"
            } else {
                ""
            };
            return Err(syntax(
                ln,
                format!(
                    "vertex {vi}: expected `x y z`, found {} fields{hint}",
                    t.len()
                ),
            ));
        }
        let mut p = [0.0; 3];
        for k in 0..3 {
            p[k] = finite(
                ln,
                parse_num(ln, t[k], "coordinate")?,
                &format!("vertex {vi} coordinate"),
            )?;
        }
        vertices.push(p);
    }
    let mut components = Vec::with_capacity(lines.capacity(n_comps));
    for ci in 0..n_comps {
        let (ln, t) = lines.item("components of the plane", ci, n_comps)?;
        if t.len() < 2 {
            return Err(syntax(
                ln,
                format!("component {ci}: expected `<n>[h<parent>] <label> i0 …`"),
            ));
        }
        let (count, parent) = match t[0].split_once('h') {
            Some((c, p)) => (c, Some(parse_num::<usize>(ln, p, "hole parent")?)),
            None => (t[0], None),
        };
        let count: usize = parse_num(ln, count, "component vertex count")?;
        let label: i32 = parse_num(ln, t[1], "label")?;
        let idx = &t[2..];
        if idx.len() != count {
            return Err(DataError::new(ErrorKind::CountMismatch {
                what: format!("indices of component {ci}"),
                declared: count,
                found: idx.len(),
            })
            .at_line(ln));
        }
        let mut indices = Vec::with_capacity(count);
        for s in idx {
            let i: usize = parse_num(ln, s, "vertex index")?;
            if i >= n_verts {
                return Err(syntax(
                    ln,
                    format!(
                        "component {ci}: vertex index {i} out of range (the plane has {n_verts})"
                    ),
                ));
            }
            indices.push(i);
        }
        if let Some(p) = parent {
            if p >= n_comps || p == ci {
                return Err(syntax(
                    ln,
                    format!(
                        "component {ci}: hole parent {p} is not another component of this plane"
                    ),
                ));
            }
        }
        components.push(Component {
            line: ln,
            label,
            parent,
            indices,
        });
    }
    Ok(RawPlane {
        line: n,
        coefficients,
        vertices,
        components,
    })
}

/// Class label of every component: solids keep their label, holes take their parent's.
fn component_classes(plane: &RawPlane, solid_labels: &BTreeSet<i32>) -> Result<Vec<i32>> {
    plane
        .components
        .iter()
        .enumerate()
        .map(|(ci, c)| {
            let Some(p) = c.parent else {
                return Ok(c.label);
            };
            let parent = &plane.components[p];
            if parent.parent.is_some() {
                return Err(syntax(
                    c.line,
                    format!("component {ci}: its parent {p} is itself a hole"),
                ));
            }
            let upstream_marker = c.label == 2 && parent.label == 1;
            if c.label == parent.label || (upstream_marker && !solid_labels.contains(&2)) {
                Ok(parent.label)
            } else {
                Err(syntax(
                    c.line,
                    format!(
                        "component {ci}: hole labelled {} inside component {p} labelled {}; a hole \
                         must carry its parent's label (or 2 under 1 in single-object files)",
                        c.label, parent.label
                    ),
                ))
            }
        })
        .collect()
}

fn solid_labels(file: &RawFile) -> BTreeSet<i32> {
    file.planes
        .iter()
        .flat_map(|p| &p.components)
        .filter(|c| c.parent.is_none())
        .map(|c| c.label)
        .collect()
}

/// Builds the frame of one file for the given sequence classes (sorted labels).
fn to_frame(path: &Path, file: &RawFile, time: f64, labels: &[i32]) -> Result<Frame> {
    let solids = solid_labels(file);
    let all: Vec<[f64; 3]> = file
        .planes
        .iter()
        .flat_map(|p| p.vertices.iter().copied())
        .collect();
    let (mut lo, mut hi) = ([f64::INFINITY; 3], [f64::NEG_INFINITY; 3]);
    for p in &all {
        for k in 0..3 {
            lo[k] = lo[k].min(p[k]);
            hi[k] = hi[k].max(p[k]);
        }
    }
    if all.is_empty() {
        (lo, hi) = ([0.0; 3], [0.0; 3]);
    }
    let diag = (0..3).map(|k| (hi[k] - lo[k]).powi(2)).sum::<f64>().sqrt();
    let tolerance = (1e-6 * diag).max(1e-12);
    // At least one unit of margin when the file is a single point or empty.
    let margin = if diag > 0.0 { 0.05 * diag } else { 1.0 };
    let (glo, ghi) = (lo.map(|x| x - margin), hi.map(|x| x + margin));
    let centroid_all = std::array::from_fn(|k| 0.5 * (lo[k] + hi[k]));
    let mut planes = Vec::with_capacity(file.planes.len());
    for (pi, rp) in file.planes.iter().enumerate() {
        let at = Place { path, plane: pi };
        let plane = to_plane(at, rp, labels, &solids, tolerance, (glo, ghi), centroid_all)
            .map_err(|e| e.at_plane(pi).at_line(rp.line))?;
        planes.push(plane);
    }
    Ok(Frame { time, planes })
}

/// Where a repair happened, for its warning: the file and the plane (0-based).
#[derive(Clone, Copy)]
struct Place<'a> {
    path: &'a Path,
    plane: usize,
}

impl std::fmt::Display for Place<'_> {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(f, "{}, plane {}", self.path.display(), self.plane)
    }
}

/// Bytes a `.csl` file may hold (the cap on what is read; the parsed planes take about as much
/// memory again).
pub const MAX_BYTES: u64 = 1 << 30;

/// Vertices within this fraction of their plane's extent (the diagonal of their bounding box)
/// from a common plane are coplanar as far as a drawn contour goes: 0.1 % is about one pixel
/// of a 1000-pixel slice, far above rounding and far below any real out-of-plane drawing.
pub const COPLANAR_TOLERANCE: f64 = 1e-3;

/// Largest distance of `points` from the plane n·x + offset = 0, and the first point farther
/// than `tolerance` (index and distance).
fn deviation(
    points: &[[f64; 3]],
    n: [f64; 3],
    offset: f64,
    tolerance: f64,
) -> (f64, Option<(usize, f64)>) {
    let mut largest = 0.0f64;
    let mut first = None;
    for (vi, p) in points.iter().enumerate() {
        let distance = (dot(n, *p) + offset).abs();
        largest = largest.max(distance);
        if distance > tolerance && first.is_none() {
            first = Some((vi, distance));
        }
    }
    (largest, first)
}

/// Eigenvalues (increasing) and unit eigenvectors of a symmetric 3×3 matrix, by cyclic Jacobi
/// rotations (converges quadratically; a few sweeps reach f64 precision).
fn symmetric_eigen(mut m: [[f64; 3]; 3]) -> ([f64; 3], [[f64; 3]; 3]) {
    let mut v = [[1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]];
    for _sweep in 0..50 {
        let off = m[0][1].abs() + m[0][2].abs() + m[1][2].abs();
        let scale = m[0][0].abs() + m[1][1].abs() + m[2][2].abs();
        if off <= f64::EPSILON * scale * 1e-3 || off == 0.0 {
            break;
        }
        for (p, q) in [(0, 1), (0, 2), (1, 2)] {
            if m[p][q] == 0.0 {
                continue;
            }
            let theta = (m[q][q] - m[p][p]) / (2.0 * m[p][q]);
            let t = theta.signum() / (theta.abs() + (theta * theta + 1.0).sqrt());
            let t = if theta == 0.0 { 1.0 } else { t };
            let (c, s) = (1.0 / (t * t + 1.0).sqrt(), t / (t * t + 1.0).sqrt());
            // m ← Jᵀ m J with J the rotation in the (p, q) plane; columns of v ← v J.
            for row in m.iter_mut() {
                let (mkp, mkq) = (row[p], row[q]);
                row[p] = c * mkp - s * mkq;
                row[q] = s * mkp + c * mkq;
            }
            let (rp, rq) = (m[p], m[q]);
            m[p] = std::array::from_fn(|k| c * rp[k] - s * rq[k]);
            m[q] = std::array::from_fn(|k| s * rp[k] + c * rq[k]);
            for row in v.iter_mut() {
                let (vp, vq) = (row[p], row[q]);
                row[p] = c * vp - s * vq;
                row[q] = s * vp + c * vq;
            }
        }
    }
    let mut order = [0, 1, 2];
    order.sort_by(|&i, &j| m[i][i].total_cmp(&m[j][j]));
    (
        order.map(|i| m[i][i]),
        order.map(|i| [v[0][i], v[1][i], v[2][i]]),
    )
}

/// The plane a `.csl` plane's vertices lie on, as unit normal n and offset (n·x + offset = 0).
///
/// The stated equation Ax + By + Cz + D = 0 is used when every vertex lies within `tolerance`
/// of it. Otherwise, in this order (each with a warning naming file and plane):
/// - the vertices lie on Ax + By + Cz = D (files written with the other sign convention): that
///   plane is used;
/// - the vertices are coplanar within [`COPLANAR_TOLERANCE`] × their extent: the least-squares
///   plane through them is used, its normal oriented like (A, B, C);
/// - otherwise the vertices are not coplanar and the plane is refused (the first vertex off the
///   stated plane is named).
fn resolve_plane(at: Place, rp: &RawPlane, tolerance: f64) -> Result<([f64; 3], f64)> {
    let [a, b, c, d] = rp.coefficients;
    let len = (a * a + b * b + c * c).sqrt();
    if len == 0.0 {
        return Err(ErrorKind::Degenerate("plane normal (A, B, C) is zero".into()).into());
    }
    let n = [a / len, b / len, c / len];
    let offset = d / len;
    let (stated, first_off) = deviation(&rp.vertices, n, offset, tolerance);
    let Some((vertex, distance)) = first_off else {
        return Ok((n, offset));
    };
    let refuse = || {
        DataError::from(ErrorKind::OffPlane {
            vertex,
            distance,
            tolerance,
        })
    };
    if offset != 0.0 && deviation(&rp.vertices, n, -offset, tolerance).1.is_none() {
        log::warn!(
            "{at}: the vertices lie on Ax + By + Cz = D, not on the stated Ax + By + Cz + D = 0 \
             (up to {stated:.3e} off it, the mirror image); read the plane with that sign \
             convention"
        );
        return Ok((n, -offset));
    }
    // Least squares: the normal is the covariance's eigenvector of the smallest eigenvalue.
    let m = rp.vertices.len() as f64;
    let centroid: [f64; 3] =
        std::array::from_fn(|k| rp.vertices.iter().map(|p| p[k]).sum::<f64>() / m);
    let (mut lo, mut hi) = ([f64::INFINITY; 3], [f64::NEG_INFINITY; 3]);
    let mut cov = [[0.0; 3]; 3];
    for p in &rp.vertices {
        let q: [f64; 3] = std::array::from_fn(|k| p[k] - centroid[k]);
        for i in 0..3 {
            lo[i] = lo[i].min(p[i]);
            hi[i] = hi[i].max(p[i]);
            for j in 0..3 {
                cov[i][j] += q[i] * q[j];
            }
        }
    }
    let extent = (0..3).map(|k| (hi[k] - lo[k]).powi(2)).sum::<f64>().sqrt();
    let coplanar = (COPLANAR_TOLERANCE * extent).max(tolerance);
    let (values, vectors) = symmetric_eigen(cov);
    // Vertices (nearly) on a line or at a point leave the plane's orientation undetermined.
    if rp.vertices.len() < 3 || (values[1].max(0.0) / m).sqrt() <= coplanar {
        return Err(refuse());
    }
    let mut fitted = normalize(vectors[0]);
    if dot(fitted, n) < 0.0 {
        fitted = fitted.map(|x| -x);
    }
    let fitted_offset = -dot(fitted, centroid);
    let (residual, beyond) = deviation(&rp.vertices, fitted, fitted_offset, coplanar);
    if beyond.is_some() {
        return Err(refuse());
    }
    let angle = dot(fitted, n).clamp(-1.0, 1.0).acos().to_degrees();
    log::warn!(
        "{at}: the vertices are up to {stated:.3e} off the stated plane (tolerance \
         {tolerance:.3e}) but coplanar (within {residual:.3e} of their least-squares plane, \
         tolerance {coplanar:.3e}); fitted the plane to them (normal {angle:.3}° from the \
         stated one)"
    );
    Ok((fitted, fitted_offset))
}

#[allow(clippy::too_many_arguments)]
fn to_plane(
    at: Place,
    rp: &RawPlane,
    labels: &[i32],
    solids: &BTreeSet<i32>,
    tolerance: f64,
    (glo, ghi): ([f64; 3], [f64; 3]),
    centroid_all: [f64; 3],
) -> Result<Plane> {
    let (n, offset) = resolve_plane(at, rp, tolerance)?;
    let (u, v) = plane_axes(n);
    let centroid = if rp.vertices.is_empty() {
        centroid_all
    } else {
        let m = rp.vertices.len() as f64;
        std::array::from_fn(|k| rp.vertices.iter().map(|p| p[k]).sum::<f64>() / m)
    };
    let h = dot(n, centroid) + offset;
    let origin = std::array::from_fn(|k| centroid[k] - h * n[k]);
    let mut plane = Plane {
        origin,
        u,
        v,
        roi: Rect {
            min: [0.0; 2],
            max: [0.0; 2],
        },
        annotations: Vec::new(),
    };
    plane.roi = plane.box_roi(glo, ghi);
    let classes = component_classes(rp, solids)?;
    let polys: Vec<Polygon> = rp
        .components
        .iter()
        .map(|c| {
            c.indices
                .iter()
                .map(|&i| plane.to_plane(rp.vertices[i]))
                .collect()
        })
        .collect();
    for (ci, comp) in rp.components.iter().enumerate() {
        if let Some(p) = comp.parent {
            if polys[ci].len() >= 3 && polys[p].len() >= 3 && !contains(&polys[p], polys[ci][0]) {
                return Err(syntax(
                    comp.line,
                    format!(
                        "component {ci} is marked as a hole of component {p} but lies outside it"
                    ),
                ));
            }
        }
    }
    plane.annotations = labels
        .iter()
        .enumerate()
        .map(|(k, &label)| {
            let (components, polygons): (Vec<usize>, Vec<Polygon>) = polys
                .iter()
                .zip(&classes)
                .enumerate()
                .filter(|(_, (_, &l))| l == label)
                .map(|(ci, (p, _))| (ci, p.clone()))
                .unzip();
            Annotation {
                class: k,
                polygons: even_odd_repair(at, &plane, label, &components, polygons),
            }
        })
        .collect();
    Ok(plane)
}

/// The polygons of one class on one plane, with rings that cross or touch (beyond pinches at a
/// shared vertex, which [`Sequence::new`] separates) replaced by simple rings bounding the same
/// region under the even-odd rule (see [`dynaslice_geometry::repair`]). Rings the validator refuses
/// for other reasons (too few vertices, repeated vertices) are returned unchanged for it to
/// report, and so are rings whose even-odd region is empty (or beyond the engine's range).
fn even_odd_repair(
    at: Place,
    plane: &Plane,
    label: i32,
    components: &[usize],
    polygons: Vec<Polygon>,
) -> Vec<Polygon> {
    let Some(contacts) = find_contacts(&polygons) else {
        return polygons;
    };
    let Some(rings) = even_odd_rings(&polygons).filter(|r| !r.is_empty()) else {
        return polygons;
    };
    let involved: Vec<String> = contacts
        .polygons
        .iter()
        .map(|&i| components[i].to_string())
        .collect();
    let (what, whom) = if contacts.between_polygons {
        ("cross or touch each other", "components")
    } else if involved.len() == 1 {
        ("crosses or touches itself", "component")
    } else {
        ("cross or touch themselves", "components")
    };
    let near = plane.to_world(contacts.near);
    log::warn!(
        "{at}, label {label}: {whom} {} {what} (near {near:.6?}); read with the even-odd rule as \
         {} simple rings (from {})",
        involved.join(", "),
        rings.len(),
        polygons.len()
    );
    rings
}

fn read_raw(path: &Path) -> Result<RawFile> {
    let text = input_file::read_text(path, MAX_BYTES, "a .csl file")?;
    parse_file(&text).map_err(|e| e.in_file(path))
}

/// Builds the one-timestep sequence (at time 0) of a parsed file; errors name the file.
fn build(path: &Path, file: RawFile, names: &LabelTable) -> Result<Sequence> {
    let labels: Vec<i32> = solid_labels(&file).into_iter().collect();
    let classes = labels.iter().map(|&label| names.class(label)).collect();
    let frame = to_frame(path, &file, 0.0, &labels).map_err(|e| e.in_file(path))?;
    Sequence::new(classes, vec![frame]).map_err(|e| e.in_file(path))
}

/// Parses one `.csl` document held in memory as a single timestep at time 0 (`name` is used in
/// error messages).
pub fn parse(text: &str, name: &Path, names: &LabelTable) -> Result<Sequence> {
    let file = parse_file(text).map_err(|e| e.in_file(name))?;
    build(name, file, names)
}

/// Reads one `.csl` file as a static sequence (one timestep at time 0).
pub fn read(path: &Path, names: &LabelTable) -> Result<Sequence> {
    build(path, read_raw(path)?, names)
}
