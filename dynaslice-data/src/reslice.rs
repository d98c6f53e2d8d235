//! Reslicing a label volume into cross-sections, with the paper's protocol (Sec. 4, real data):
//! planes rotated about the volume's z axis through the centre of the labelled region, plus every
//! k-th axial slice; contours by marching squares on the trilinearly interpolated class indicator.
//!
//! Why interpolate the indicator: contouring the nearest-neighbour label image would put every
//! contour on voxel faces (staircases the network would faithfully learn). The interpolated
//! indicator of one label crosses ½ between voxel centres, which places the contour with
//! sub-voxel accuracy, and since the indicators of all labels sum to 1, two classes can never both
//! exceed ½: resliced classes never overlap. See `docs/data-format.md`.

use std::collections::{BTreeMap, BTreeSet};

use rayon::prelude::*;

use super::label_table::LabelTable;
use super::label_volume::{det3, LabelVolume};
use dynaslice_geometry::marching_squares::contours;
use dynaslice_sequence::error::{ErrorKind, Result};
use dynaslice_sequence::sequence::{
    cross, dot, Annotation, ClassInfo, Frame, Plane, Rect, Sequence,
};

pub use crate::frame_range::FrameRange;

/// Reslicing options; [`Default`] is the paper's protocol for real data.
#[derive(Debug, Clone, PartialEq)]
pub struct ResliceOptions {
    /// Planes rotated about the z axis (paper: 20).
    pub rotated: usize,
    /// Take every `axial_step`-th axial slice of the labelled range (paper: 2); 0 takes none.
    /// Either way, a label that no such slice crosses gets one axial slice through its middle.
    pub axial_step: usize,
    /// Frames to use.
    pub frames: FrameRange,
    /// Labels to use, one class each; `None` uses every nonzero label present.
    pub labels: Option<Vec<i32>>,
    /// In-plane sampling step in world units; `None` means half the smallest voxel spacing, or
    /// the labelled box's longest diagonal / 1536 where that is coarser.
    pub pixel: Option<f64>,
}

impl Default for ResliceOptions {
    fn default() -> Self {
        ResliceOptions {
            rotated: 20,
            axial_step: 2,
            frames: FrameRange::ALL,
            labels: None,
            pixel: None,
        }
    }
}

/// Grid points per plane axis above which reslicing refuses (a mistaken `pixel`).
const MAX_GRID: usize = 8192;

/// Grid points per plane above which reslicing refuses: sampling keeps a 128-byte stencil per
/// point, so this bounds one plane's memory at 2 GiB whatever the axes' split.
const MAX_GRID_POINTS: usize = 1 << 24;

/// Grid points along the labelled box's diagonal that the default pixel never exceeds: half the
/// smallest voxel spacing over a box that is long along coarsely sampled axes (e.g. 1 × 256 ×
/// 256 mm voxels) would otherwise ask for gigabytes per plane for a handful of voxels.
const DEFAULT_DIAGONAL_POINTS: f64 = 1536.0;

/// A plane of the protocol and its sampling grid.
struct GridPlane {
    plane: Plane,
    nx: usize,
    ny: usize,
    /// Plane coordinates of grid point (0, 0).
    start: [f64; 2],
}

/// Reslices `volume` per `options`; classes are named from `names`.
pub fn reslice(
    volume: &LabelVolume,
    options: &ResliceOptions,
    names: &LabelTable,
) -> Result<Sequence> {
    let frames = options.frames.indices(volume.frames);
    if frames.is_empty() {
        return Err(ErrorKind::Option(format!(
            "frames {:?} select nothing from a volume with {} frames",
            options.frames, volume.frames
        ))
        .into());
    }
    if options.rotated == 0 && options.axial_step == 0 {
        return Err(ErrorKind::Option("no planes: rotated = 0 and axial_step = 0".into()).into());
    }
    let voxels = volume.dims.iter().product::<usize>();
    let mut present = BTreeSet::new();
    // Voxel slices (z) each label occupies, to make sure some axial slice crosses every label.
    let mut label_slices: BTreeMap<i32, BTreeSet<usize>> = BTreeMap::new();
    let (mut lo, mut hi) = ([usize::MAX; 3], [0usize; 3]);
    let wanted = |l: i32| l != 0 && options.labels.as_ref().is_none_or(|ls| ls.contains(&l));
    for &f in &frames {
        for (n, &l) in volume.labels[f * voxels..(f + 1) * voxels]
            .iter()
            .enumerate()
        {
            if l == 0 {
                continue;
            }
            present.insert(l);
            if wanted(l) {
                let q = [
                    n % volume.dims[0],
                    n / volume.dims[0] % volume.dims[1],
                    n / (volume.dims[0] * volume.dims[1]),
                ];
                label_slices.entry(l).or_default().insert(q[2]);
                for k in 0..3 {
                    lo[k] = lo[k].min(q[k]);
                    hi[k] = hi[k].max(q[k]);
                }
            }
        }
    }
    let labels: Vec<i32> = match &options.labels {
        Some(ls) => {
            if let Some(&l) = ls.iter().find(|l| !present.contains(l)) {
                return Err(ErrorKind::LabelAbsent {
                    label: l,
                    present: present.iter().copied().collect(),
                }
                .into());
            }
            let mut ls = ls.clone();
            ls.sort_unstable();
            ls.dedup();
            ls
        }
        None => present.into_iter().collect(),
    };
    if labels.is_empty() {
        return Err(ErrorKind::Empty("no nonzero label in the selected frames".into()).into());
    }
    let planes = protocol_planes(volume, options, lo, hi, &label_slices)?;
    let classes: Vec<ClassInfo> = labels.iter().map(|&label| names.class(label)).collect();
    let jobs: Vec<(usize, usize)> = (0..frames.len())
        .flat_map(|fi| (0..planes.len()).map(move |pi| (fi, pi)))
        .collect();
    let sliced: Vec<Plane> = jobs
        .par_iter()
        .map(|&(fi, pi)| slice_plane(volume, frames[fi], &planes[pi], &labels))
        .collect();
    let mut sliced = sliced.into_iter();
    let frames = frames
        .iter()
        .map(|&f| Frame {
            time: f as f64 * volume.frame_interval,
            planes: sliced.by_ref().take(planes.len()).collect(),
        })
        .collect();
    Sequence::new(classes, frames)
}

/// `a` scaled to unit length (NaN for the zero vector: callers check).
pub(crate) fn normalize(a: [f64; 3]) -> [f64; 3] {
    let n = dot(a, a).sqrt();
    a.map(|x| x / n)
}

/// In-plane axes (u, v) of a plane with unit normal `n`: u the world axis least aligned with
/// `n`, made orthogonal to it (so axial planes get u = x, v = y), and v = n × u.
pub(crate) fn plane_axes(n: [f64; 3]) -> ([f64; 3], [f64; 3]) {
    let axis = (0..3)
        .min_by(|&i, &j| n[i].abs().total_cmp(&n[j].abs()))
        .unwrap_or(0);
    let mut e = [0.0; 3];
    e[axis] = 1.0;
    let u = orthogonal(e, n);
    (u, cross(n, u))
}

/// Unit `a` made orthogonal to unit `n`.
pub(crate) fn orthogonal(a: [f64; 3], n: [f64; 3]) -> [f64; 3] {
    let d = dot(a, n);
    normalize(std::array::from_fn(|k| a[k] - d * n[k]))
}

/// The rotated and axial planes (plus an axial slice through any label the regular ones miss),
/// with grids covering the labelled voxel box [lo, hi] grown by two
/// voxels.
fn protocol_planes(
    v: &LabelVolume,
    o: &ResliceOptions,
    lo: [usize; 3],
    hi: [usize; 3],
    label_slices: &BTreeMap<i32, BTreeSet<usize>>,
) -> Result<Vec<GridPlane>> {
    let a = v.affine;
    let column = |c: usize| [a[0][c], a[1][c], a[2][c]];
    let spacing = (0..3)
        .map(|c| dot(column(c), column(c)).sqrt())
        .fold(f64::INFINITY, f64::min);
    let z_axis = normalize(column(2));
    let centre_voxel: [f64; 3] = std::array::from_fn(|k| 0.5 * (lo[k] + hi[k]) as f64);
    let centre = v.to_world(centre_voxel);
    let corners: Vec<[f64; 3]> = (0..8)
        .map(|c| {
            v.to_world(std::array::from_fn(|k| {
                if c >> k & 1 == 1 {
                    hi[k] as f64 + 2.0
                } else {
                    lo[k] as f64 - 2.0
                }
            }))
        })
        .collect();
    // Every plane's grid lies within the box, so its longest diagonal bounds both grid axes.
    let diagonal = corners
        .iter()
        .flat_map(|a| {
            corners
                .iter()
                .map(move |b| std::array::from_fn(|k| a[k] - b[k]))
        })
        .map(|d: [f64; 3]| dot(d, d).sqrt())
        .fold(0.0, f64::max);
    let pixel = o
        .pixel
        .unwrap_or_else(|| (0.5 * spacing).max(diagonal / DEFAULT_DIAGONAL_POINTS));
    if !(pixel.is_finite() && pixel > 0.0) {
        return Err(ErrorKind::Option(format!("pixel size {pixel} must be positive")).into());
    }
    let mut planes = Vec::new();
    let mut add = |origin: [f64; 3], u: [f64; 3], v: [f64; 3]| -> Result<()> {
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
        let (mut pmin, mut pmax) = ([f64::INFINITY; 2], [f64::NEG_INFINITY; 2]);
        for c in &corners {
            let q = plane.to_plane(*c);
            pmin = std::array::from_fn(|k| pmin[k].min(q[k]));
            pmax = std::array::from_fn(|k| pmax[k].max(q[k]));
        }
        let n: [usize; 2] =
            std::array::from_fn(|k| ((pmax[k] - pmin[k]) / pixel).ceil() as usize + 1);
        if n.iter().any(|&m| m > MAX_GRID) || n[0] * n[1] > MAX_GRID_POINTS {
            return Err(ErrorKind::Option(format!(
                "pixel size {pixel} gives a {}×{} grid per plane (limits: {MAX_GRID} per axis, \
                 {MAX_GRID_POINTS} points)",
                n[0], n[1]
            ))
            .into());
        }
        // The region of interest is the grid grown by one pixel: marching squares closes contours
        // that reach the grid border half a pixel outside it.
        plane.roi = Rect {
            min: [pmin[0] - pixel, pmin[1] - pixel],
            max: [pmin[0] + n[0] as f64 * pixel, pmin[1] + n[1] as f64 * pixel],
        };
        planes.push(GridPlane {
            plane,
            nx: n[0],
            ny: n[1],
            start: pmin,
        });
        Ok(())
    };
    let ex = orthogonal(normalize(column(0)), z_axis);
    let ey = cross(z_axis, ex);
    for j in 0..o.rotated {
        let th = std::f64::consts::PI * j as f64 / o.rotated as f64;
        let u = std::array::from_fn(|k| th.cos() * ex[k] + th.sin() * ey[k]);
        add(centre, u, z_axis)?;
    }
    let mut axial: BTreeSet<usize> = if o.axial_step > 0 {
        (lo[2]..=hi[2]).step_by(o.axial_step).collect()
    } else {
        BTreeSet::new()
    };
    // A label thinner than the axial step (or with no axial slices asked for) could be missed by
    // every plane; rather than lose it, slice once through its middle occupied slice.
    let regular = axial.clone();
    for zs in label_slices.values() {
        if zs.is_disjoint(&regular) {
            if let Some(&mid) = zs.iter().nth(zs.len() / 2) {
                axial.insert(mid);
            }
        }
    }
    if !axial.is_empty() {
        // The voxel plane k = const has world normal A⁻ᵀ e_z, i.e. the cross product of the
        // images of the x and y voxel axes (also right under shear).
        let mut n = normalize(cross(column(0), column(1)));
        if det3(&a) < 0.0 {
            n = n.map(|x| -x);
        }
        let u = orthogonal(normalize(column(0)), n);
        let vv = cross(n, u);
        for &k in &axial {
            add(
                v.to_world([centre_voxel[0], centre_voxel[1], k as f64]),
                u,
                vv,
            )?;
        }
    }
    Ok(planes)
}

/// Inverse of the affine's 3×3 part, rows.
fn inverse3(a: &[[f64; 4]; 3]) -> [[f64; 3]; 3] {
    let d = det3(a);
    let m = |r: usize, c: usize| a[r][c];
    let cof =
        |r0: usize, r1: usize, c0: usize, c1: usize| m(r0, c0) * m(r1, c1) - m(r0, c1) * m(r1, c0);
    [
        [
            cof(1, 2, 1, 2) / d,
            -cof(0, 2, 1, 2) / d,
            cof(0, 1, 1, 2) / d,
        ],
        [
            -cof(1, 2, 0, 2) / d,
            cof(0, 2, 0, 2) / d,
            -cof(0, 1, 0, 2) / d,
        ],
        [
            cof(1, 2, 0, 1) / d,
            -cof(0, 2, 0, 1) / d,
            cof(0, 1, 0, 1) / d,
        ],
    ]
}

/// Samples frame `f` on the plane's grid and contours every class.
fn slice_plane(v: &LabelVolume, f: usize, g: &GridPlane, labels: &[i32]) -> Plane {
    let inv = inverse3(&v.affine);
    let t = [v.affine[0][3], v.affine[1][3], v.affine[2][3]];
    let pixel = (g.plane.roi.max[0] - g.start[0]) / g.nx as f64;
    // For every grid point, the trilinear weights of its 8 neighbouring voxels and their labels.
    let mut stencil: Vec<[(i32, f64); 8]> = Vec::with_capacity(g.nx * g.ny);
    let mut seen = BTreeSet::new();
    for j in 0..g.ny {
        for i in 0..g.nx {
            let p = g
                .plane
                .to_world([g.start[0] + i as f64 * pixel, g.start[1] + j as f64 * pixel]);
            let d = [p[0] - t[0], p[1] - t[1], p[2] - t[2]];
            let q: [f64; 3] =
                std::array::from_fn(|r| inv[r][0] * d[0] + inv[r][1] * d[1] + inv[r][2] * d[2]);
            let base = q.map(f64::floor);
            let w = [q[0] - base[0], q[1] - base[1], q[2] - base[2]];
            let s: [(i32, f64); 8] = std::array::from_fn(|c| {
                let o = [c & 1, c >> 1 & 1, c >> 2 & 1];
                let label = v.label(
                    (base[0] as isize).saturating_add(o[0] as isize),
                    (base[1] as isize).saturating_add(o[1] as isize),
                    (base[2] as isize).saturating_add(o[2] as isize),
                    f,
                );
                let weight: f64 = (0..3)
                    .map(|k| if o[k] == 1 { w[k] } else { 1.0 - w[k] })
                    .product();
                (label, weight)
            });
            seen.extend(
                s.iter()
                    .filter(|(l, w)| *l != 0 && *w > 0.0)
                    .map(|(l, _)| *l),
            );
            stencil.push(s);
        }
    }
    let mut field = vec![0.0; g.nx * g.ny];
    let annotations = labels
        .iter()
        .enumerate()
        .map(|(k, &label)| {
            let polygons = if seen.contains(&label) {
                for (value, s) in field.iter_mut().zip(&stencil) {
                    let indicator: f64 =
                        s.iter().filter(|(l, _)| *l == label).map(|(_, w)| w).sum();
                    *value = 0.5 - indicator;
                }
                contours(&field, g.nx, g.ny)
                    .into_iter()
                    .map(|poly| {
                        poly.into_iter()
                            .map(|p| [g.start[0] + p[0] * pixel, g.start[1] + p[1] * pixel])
                            .collect()
                    })
                    .collect()
            } else {
                Vec::new()
            };
            Annotation { class: k, polygons }
        })
        .collect();
    Plane {
        annotations,
        ..g.plane.clone()
    }
}
