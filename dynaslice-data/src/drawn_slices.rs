//! Label maps cut into planes *as drawn*: the image's own voxel slices become the annotated
//! planes, instead of resampling a dense volume along the paper's protocol ([`crate::reslice`]).
//!
//! Two kinds of users need this:
//!
//! - **Cine MRI** ([`slices`]): a short-axis stack (10–15 parallel slices 8–10 mm apart) and
//!   long-axis views (one slice each), every slice of every image segmented. Each voxel slice
//!   along the image's third axis is a plane placed by the image's affine; every class is
//!   annotated on every slice of every frame, so a class not drawn on a slice is *absent* there.
//! - **A few slices drawn by hand** in 3D Slicer or ITK-SNAP ([`sparse`]): only the drawn voxel
//!   slices, along any of the three voxel axes, are planes. Every other slice is *unobserved*,
//!   not background.
//!
//! # Planes
//!
//! Voxel slice `s` along voxel axis `a` spans the two other voxel axes `p < q` (for the usual
//! `a = 2`: `p = 0`, `q = 1`). Its plane has origin = the world position of the voxel with
//! coordinate `s` on axis `a` and 0 on the others, `u` = the affine's column `p` normalised, `v`
//! = column `q` made orthogonal to `u` and normalised (Gram–Schmidt: a sheared affine still gives
//! an orthonormal frame, and pixel (x, y) lands at plane coordinates `(a·x + b·y, d·y)` with
//! `a = |c_p|`, `b = c_q·u`, `d = c_q·v`, exactly where the affine puts it). Columns that are
//! zero or nearly parallel (sine of their angle below 10⁻⁶) are refused. The region of interest
//! is the slice's pixel extent, half a pixel beyond the outermost centres (the bounding box of
//! that parallelogram under shear).
//!
//! # Contours
//!
//! Marching squares ([`dynaslice_geometry::marching_squares`]) on each class's indicator over the
//! slice's pixels at level ½, i.e. the bilinear interpolation of the indicator, as
//! [`crate::reslice`] does in 3D: contours pass through the midpoints between a class's pixels
//! and the others, classes never overlap, and pixels touching only diagonally are separate
//! components. **Area**: such a contour cuts ⅛ pixel at every convex pixel corner and adds ⅛ at
//! every concave one, so the polygons of a class enclose its pixel count minus ½ pixel per outer
//! contour plus ½ per hole (exactly, for contours away from the image border; a contour on the
//! border runs ⅓ pixel beyond the centres instead of ½, inside the region of interest). Vertices
//! number at most 4 per labelled pixel, so the output is linear in the input.
//!
//! # `Auto`: which mode an image gets ([`resolve`])
//!
//! 1. At most [`FEW_SLICES`] slices along the third axis (a 2D(+t) image, e.g. a long-axis
//!    view): [`PlaneMode::Slices`].
//! 2. Otherwise, if every frame that has labelled voxels looks sparsely drawn (below: isolated
//!    slices hold at least [`ISOLATED_SHARE`] of its labelled voxels): [`PlaneMode::Sparse`].
//! 3. Otherwise, thick slices (the distance between slice planes, `|c₂ · n̂|` with `n̂` the unit
//!    normal of columns 0 and 1, at least [`THICK_RATIO`] × the coarser in-plane spacing
//!    `max(|c₀|, |c₁|)`): [`PlaneMode::Slices`] (a cine short-axis stack, 1.5 × 1.5 × 8 mm).
//! 4. Otherwise [`PlaneMode::Reslice`] (a dense, near-isotropic segmentation such as
//!    TotalSegmentator's 3 mm output).
//!
//! # Detecting drawn slices ([`drawn_slices`])
//!
//! In a volume drawn on axial slices, many sagittal and coronal slices contain labelled voxels
//! (where they cross the drawn slices) without being drawn, so "has labelled voxels" is not the
//! test. Per frame, with every nonzero label counting as labelled:
//!
//! 1. A labelled voxel is *thin along axis a* when both its neighbours along `a` are unlabelled
//!    (or outside the volume): a voxel of a slice drawn with unlabelled slices on both sides. A
//!    voxel of an axial drawing is thin along z but not along x or y (its neighbours in the
//!    drawing are labelled), so the sagittal slice through it is not evidence.
//! 2. *Isolated* slices: a slice is drawn when at least [`DRAWN_FRACTION`] of its labelled voxels
//!    are thin along its axis. Drawings on two or three axes at once pass too: only the lines
//!    where an orthogonal drawing crosses a drawn slice are not thin (e.g. axial every 5th slice
//!    plus two sagittal slices: about 93 % and 80 % thin, while the slices that merely cross the
//!    drawings have almost no thin voxel).
//! 3. *Cover*: labelled voxels on no drawn slice yet (drawn slices next to each other, or a
//!    drawing crossed so often that it fell below the fraction) are covered greedily: the slice
//!    with most such voxels is drawn, until none is left. Every labelled voxel ends on a plane.
//!
//! With [`SparseAxes::Detect`] a frame whose isolated slices hold less than [`ISOLATED_SHARE`]
//! of its labelled voxels is refused as densely segmented: step 3 alone would cut a dense volume
//! into an arbitrary stack. A frame without labelled voxels is unobserved and skipped, with a
//! warning.
//!
//! **Limits.** Slices drawn next to each other are indistinguishable from a structure thicker
//! than one slice (step 3 usually recovers them, but along the axis with the largest residual);
//! a drawn structure one voxel wide within its slice (a scribbled line) is thin along two axes
//! and can make the slice across it look drawn; a 3D brush (several slices thick) is not a
//! drawing on slices. [`SparseAxes::Only`] forces the axes: with one axis, every slice along it
//! that has a labelled voxel is drawn (no thinness test, so adjacent drawn slices work); with
//! several, steps 1–3 run on those axes only.
//!
//! # Limits on the input
//!
//! Checked before anything is allocated for the planes: the label count against dims × frames
//! (overflow-checked), a finite affine, at most [`MAX_SLICE_PIXELS`] pixels per slice, at most
//! [`MAX_ANNOTATIONS`] (plane, class) annotations in all, and at most [`MAX_CONTOUR_SAMPLES`]
//! samples contoured (the sum over planes and classes of each class's bounding box on the slice).

use std::collections::{BTreeSet, BinaryHeap};
use std::fmt;
use std::str::FromStr;

use rayon::prelude::*;

use crate::frame_range::FrameRange;
use crate::label_table::LabelTable;
use crate::label_volume::LabelVolume;
use crate::reslice::{normalize, orthogonal};
use dynaslice_geometry::marching_squares::contours;
use dynaslice_geometry::Polygon;
use dynaslice_sequence::error::{DataError, ErrorKind, Result};
use dynaslice_sequence::sequence::{cross, dot, Annotation, Frame, Plane, Rect, Sequence};

/// How a label map becomes planes. See the [module docs](self).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum PlaneMode {
    /// Chosen per image by [`resolve`].
    #[default]
    Auto,
    /// Every voxel slice along the third axis is a plane annotating every class ([`slices`]):
    /// segmented 2D(+t) images and stacks of thick slices (cine MRI).
    Slices,
    /// The paper's protocol: rotated planes and axial slices resampled from the dense volume
    /// ([`crate::reslice`]).
    Reslice,
    /// Only the voxel slices that were drawn, along any axis ([`sparse`]); the others are
    /// unobserved.
    Sparse,
}

impl fmt::Display for PlaneMode {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(match self {
            PlaneMode::Auto => "auto",
            PlaneMode::Slices => "slices",
            PlaneMode::Reslice => "reslice",
            PlaneMode::Sparse => "sparse",
        })
    }
}

impl FromStr for PlaneMode {
    type Err = String;

    fn from_str(s: &str) -> std::result::Result<Self, Self::Err> {
        match s.trim().to_ascii_lowercase().as_str() {
            "auto" => Ok(PlaneMode::Auto),
            "slices" => Ok(PlaneMode::Slices),
            "reslice" => Ok(PlaneMode::Reslice),
            "sparse" => Ok(PlaneMode::Sparse),
            _ => Err(format!(
                "unknown plane mode {s:?} (expected auto, slices, reslice or sparse)"
            )),
        }
    }
}

/// Which voxel axes drawn slices may lie along, for [`sparse_with_axes`] and [`drawn_slices`].
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum SparseAxes {
    /// Any axis, found by the detection of the [module docs](self).
    #[default]
    Detect,
    /// Only the voxel axes i, j, k marked `true`. With one axis, every slice along it that has a
    /// labelled voxel is drawn; with several, the detection runs on those axes only.
    Only([bool; 3]),
}

/// Names of the voxel axes in [`SparseAxes`]'s text form.
const AXIS_NAMES: [char; 3] = ['i', 'j', 'k'];

impl fmt::Display for SparseAxes {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            SparseAxes::Detect => f.write_str("auto"),
            SparseAxes::Only(mask) => {
                let names: Vec<String> = (0..3)
                    .filter(|&a| mask[a])
                    .map(|a| AXIS_NAMES[a].to_string())
                    .collect();
                f.write_str(&names.join(","))
            }
        }
    }
}

impl FromStr for SparseAxes {
    type Err = String;

    /// `auto`, or voxel axes `i`, `j`, `k` separated by commas (`k`, `i,k`).
    fn from_str(s: &str) -> std::result::Result<Self, Self::Err> {
        let t = s.trim().to_ascii_lowercase();
        if t == "auto" {
            return Ok(SparseAxes::Detect);
        }
        let bad = |why: String| {
            format!(
                "invalid drawn axes {s:?}: {why} (expected auto, or voxel axes such as k or i,k)"
            )
        };
        let mut mask = [false; 3];
        for part in t.split(',') {
            let part = part.trim();
            let a = match part {
                "i" => 0,
                "j" => 1,
                "k" => 2,
                _ => return Err(bad(format!("{part:?} is not i, j or k"))),
            };
            if mask[a] {
                return Err(bad(format!("{part} is listed twice")));
            }
            mask[a] = true;
        }
        Ok(SparseAxes::Only(mask))
    }
}

/// One voxel slice: the voxels whose coordinate along voxel axis `axis` (0 = i, 1 = j, 2 = k)
/// is `index`.
#[derive(Debug, Clone, Copy, PartialEq, Eq, PartialOrd, Ord, Hash)]
pub struct VoxelSlice {
    /// The voxel axis across the slice.
    pub axis: usize,
    /// The slice's coordinate along it.
    pub index: usize,
}

/// Slices along the third axis up to which [`resolve`] takes an image slice by slice.
pub const FEW_SLICES: usize = 3;

/// Slice distance over in-plane spacing from which [`resolve`] calls slices thick.
pub const THICK_RATIO: f64 = 2.0;

/// Share of a slice's labelled voxels that must be thin along its axis for it to count as an
/// isolated drawn slice.
pub const DRAWN_FRACTION: f64 = 0.5;

/// Share of a frame's labelled voxels that isolated drawn slices must hold for the frame to look
/// sparsely drawn.
pub const ISOLATED_SHARE: f64 = 0.5;

/// Pixels per slice above which planes are refused (a marching-squares pass keeps about 40
/// bytes per sample: 16 M pixels bound one slice's working memory near 700 MB).
pub const MAX_SLICE_PIXELS: usize = 1 << 24;

/// (plane, class) annotations above which the planes are refused: each is a few dozen bytes
/// even when absent, and the validator visits each.
pub const MAX_ANNOTATIONS: usize = 1 << 22;

/// Samples contoured (over every plane and class, each class's bounding box on the slice grown
/// by a pixel) above which the planes are refused: bounds the work.
pub const MAX_CONTOUR_SAMPLES: u64 = 1 << 32;

/// Smallest sine of the angle between a slice's two in-plane affine columns.
const MIN_SINE: f64 = 1e-6;

/// The plane mode for `volume`: `mode` itself unless it is [`PlaneMode::Auto`], which is
/// decided by the rule of the [module docs](self). Never fails: a volume the chosen mode cannot
/// use (inconsistent sizes, degenerate affine) is reported by that mode's function.
pub fn resolve(mode: PlaneMode, volume: &LabelVolume) -> PlaneMode {
    if mode != PlaneMode::Auto {
        return mode;
    }
    if volume.dims[2] <= FEW_SLICES {
        return PlaneMode::Slices;
    }
    if looks_sparse(volume) {
        return PlaneMode::Sparse;
    }
    let a = volume.affine;
    let column = |c: usize| [a[0][c], a[1][c], a[2][c]];
    let norm = |c: usize| dot(column(c), column(c)).sqrt();
    let normal = cross(column(0), column(1));
    let slice_distance = dot(column(2), normal).abs() / dot(normal, normal).sqrt();
    if slice_distance >= THICK_RATIO * norm(0).max(norm(1)) {
        PlaneMode::Slices
    } else {
        PlaneMode::Reslice
    }
}

/// Whether every frame with labelled voxels looks sparsely drawn (and one has them).
fn looks_sparse(volume: &LabelVolume) -> bool {
    let Ok(voxels) = check_volume(volume) else {
        return false;
    };
    let mut any = false;
    for f in 0..volume.frames {
        let d = detect(volume, voxels, f, [true; 3], false);
        if d.labelled == 0 {
            continue;
        }
        if !d.is_sparse() {
            return false;
        }
        any = true;
    }
    any
}

/// Every voxel slice along the third axis of every selected frame as a plane; see the
/// [module docs](self).
///
/// Classes: `labels` (sorted, each present in some selected frame), or every nonzero label of
/// the selected frames; named by `table`. Every class is annotated on every plane (absent where
/// it has no pixel). Frame f is at time f × `frame_interval`. A selected frame without any
/// labelled voxel is kept (every class absent on its slices) with a warning.
pub fn slices(
    volume: &LabelVolume,
    frames: FrameRange,
    labels: Option<&[i32]>,
    table: &LabelTable,
) -> Result<Sequence> {
    let voxels = check_volume(volume)?;
    let selected = select_frames(volume, frames)?;
    check_times(volume, &selected)?;
    let nz = volume.dims[2];
    let (classes, empty) = class_labels(volume, voxels, &selected, labels)?;
    check_annotations(selected.len().checked_mul(nz), classes.len())?;
    for &f in &empty {
        log::warn!(
            "frame {f} (t = {}) of the label map has no labelled voxel: its {nz} slice(s) mark \
             every class absent; select only drawn frames (frames option) if it was not drawn",
            f as f64 * volume.frame_interval
        );
    }
    let planes = selected
        .iter()
        .map(|_| (0..nz).map(|index| VoxelSlice { axis: 2, index }).collect())
        .collect();
    build(volume, voxels, &selected, planes, &classes, table)
}

/// Only the drawn voxel slices of each selected frame, along any axis, as planes: equivalent to
/// [`sparse_with_axes`] with [`SparseAxes::Detect`].
pub fn sparse(
    volume: &LabelVolume,
    frames: FrameRange,
    labels: Option<&[i32]>,
    table: &LabelTable,
) -> Result<Sequence> {
    sparse_with_axes(volume, frames, labels, table, SparseAxes::Detect)
}

/// Only the drawn voxel slices of each selected frame ([`drawn_slices`] with `axes`) as planes.
///
/// Classes as in [`slices`]. A drawn slice annotates every class (absent where not drawn on it);
/// undrawn slices give nothing. Selected frames without any labelled voxel are unobserved:
/// skipped, with a warning. Planes are ordered by axis, then index.
pub fn sparse_with_axes(
    volume: &LabelVolume,
    frames: FrameRange,
    labels: Option<&[i32]>,
    table: &LabelTable,
    axes: SparseAxes,
) -> Result<Sequence> {
    let voxels = check_volume(volume)?;
    let selected = select_frames(volume, frames)?;
    check_times(volume, &selected)?;
    let mut kept = Vec::new();
    let mut planes = Vec::new();
    for &f in &selected {
        match drawn_in_frame(volume, voxels, f, axes)? {
            Some(drawn) => {
                kept.push(f);
                planes.push(drawn);
            }
            None => log::warn!(
                "frame {f} (t = {}) of the label map has no labelled voxel: unobserved, skipped",
                f as f64 * volume.frame_interval
            ),
        }
    }
    if kept.is_empty() {
        return Err(ErrorKind::Empty(
            "no selected frame of the label map has a labelled voxel".into(),
        )
        .into());
    }
    let (classes, _) = class_labels(volume, voxels, &kept, labels)?;
    let total = planes.iter().map(Vec::len).sum::<usize>();
    check_annotations(Some(total), classes.len())?;
    build(volume, voxels, &kept, planes, &classes, table)
}

/// The drawn voxel slices of frame `frame`, ordered by axis, then index; empty when the frame
/// has no labelled voxel. See the [module docs](self) for the detection and its limits; with
/// [`SparseAxes::Detect`], a densely segmented frame is an error.
pub fn drawn_slices(
    volume: &LabelVolume,
    frame: usize,
    axes: SparseAxes,
) -> Result<Vec<VoxelSlice>> {
    let voxels = check_volume(volume)?;
    if frame >= volume.frames {
        return Err(ErrorKind::Option(format!(
            "frame {frame} of a label map with {} frames",
            volume.frames
        ))
        .into());
    }
    Ok(drawn_in_frame(volume, voxels, frame, axes)?.unwrap_or_default())
}

/// The drawn slices of frame `f`, `None` when it has no labelled voxel.
fn drawn_in_frame(
    volume: &LabelVolume,
    voxels: usize,
    f: usize,
    axes: SparseAxes,
) -> Result<Option<Vec<VoxelSlice>>> {
    let allowed = match axes {
        SparseAxes::Detect => [true; 3],
        SparseAxes::Only(mask) if mask.contains(&true) => mask,
        SparseAxes::Only(_) => {
            return Err(ErrorKind::Option("no voxel axis allowed for drawn slices".into()).into())
        }
    };
    let d = detect(volume, voxels, f, allowed, true);
    if d.labelled == 0 {
        return Ok(None);
    }
    if axes == SparseAxes::Detect && !d.is_sparse() {
        return Err(DataError::new(ErrorKind::Option(format!(
            "sparse planes need slices drawn with unlabelled slices beside them, but only {} of \
             the {} labelled voxels lie on such slices: the frame looks densely segmented (use \
             reslice or slices planes), or force the drawn axes",
            d.isolated, d.labelled
        )))
        .at_frame(f, Some(f as f64 * volume.frame_interval)));
    }
    Ok(Some(d.drawn))
}

/// The outcome of the detection on one frame.
struct Detection {
    /// Drawn slices, by axis then index.
    drawn: Vec<VoxelSlice>,
    /// Labelled voxels of the frame.
    labelled: usize,
    /// Labelled voxels on isolated slices (step 2 of the detection).
    isolated: usize,
}

impl Detection {
    fn is_sparse(&self) -> bool {
        self.labelled > 0 && self.isolated as f64 >= ISOLATED_SHARE * self.labelled as f64
    }
}

/// The two voxel axes spanning a slice across `axis`, in increasing order.
fn in_plane(axis: usize) -> [usize; 2] {
    match axis {
        0 => [1, 2],
        1 => [0, 2],
        _ => [0, 1],
    }
}

/// The drawn-slice detection of the [module docs](self) on frame `f` of a checked volume, along
/// the `allowed` axes; `cover` runs step 3 (and with one allowed axis, takes every labelled
/// slice along it).
fn detect(
    volume: &LabelVolume,
    voxels: usize,
    f: usize,
    allowed: [bool; 3],
    cover: bool,
) -> Detection {
    let dims = volume.dims;
    let [nx, ny, nz] = dims;
    let stride = [1, nx, nx * ny];
    let lab = &volume.labels[f * voxels..(f + 1) * voxels];
    let mut count = dims.map(|n| vec![0usize; n]);
    let mut thin = dims.map(|n| vec![0usize; n]);
    let mut labelled = 0;
    for k in 0..nz {
        for j in 0..ny {
            for i in 0..nx {
                let idx = i + nx * (j + ny * k);
                if lab[idx] == 0 {
                    continue;
                }
                labelled += 1;
                let c = [i, j, k];
                for a in 0..3 {
                    count[a][c[a]] += 1;
                    let below = c[a] == 0 || lab[idx - stride[a]] == 0;
                    let above = c[a] + 1 == dims[a] || lab[idx + stride[a]] == 0;
                    if below && above {
                        thin[a][c[a]] += 1;
                    }
                }
            }
        }
    }
    let single = allowed.iter().filter(|&&x| x).count() == 1;
    let mut drawn = dims.map(|n| vec![false; n]);
    for a in (0..3).filter(|&a| allowed[a]) {
        for s in 0..dims[a] {
            drawn[a][s] = if cover && single {
                count[a][s] > 0
            } else {
                thin[a][s] > 0 && thin[a][s] as f64 >= DRAWN_FRACTION * count[a][s] as f64
            };
        }
    }
    let on_drawn = |drawn: &[Vec<bool>; 3], c: [usize; 3]| (0..3).any(|a| drawn[a][c[a]]);
    // Labelled voxels on no drawn slice yet, per allowed slice.
    let mut residual = dims.map(|n| vec![0usize; n]);
    let mut isolated = 0;
    for k in 0..nz {
        for j in 0..ny {
            for i in 0..nx {
                if lab[i + nx * (j + ny * k)] == 0 {
                    continue;
                }
                let c = [i, j, k];
                if on_drawn(&drawn, c) {
                    isolated += 1;
                } else {
                    for a in (0..3).filter(|&a| allowed[a]) {
                        residual[a][c[a]] += 1;
                    }
                }
            }
        }
    }
    if cover {
        // Greedy cover with lazy updates: residuals only fall, so a popped entry whose count is
        // stale goes back with its current count. Ties prefer axis k, then j, then the lower
        // index (`Reverse`).
        let mut heap: BinaryHeap<(usize, usize, std::cmp::Reverse<usize>)> = BinaryHeap::new();
        for a in (0..3).filter(|&a| allowed[a]) {
            for (s, &r) in residual[a].iter().enumerate() {
                if r > 0 {
                    heap.push((r, a, std::cmp::Reverse(s)));
                }
            }
        }
        while let Some((r, a, std::cmp::Reverse(s))) = heap.pop() {
            let now = residual[a][s];
            if now == 0 {
                continue;
            }
            if now != r {
                heap.push((now, a, std::cmp::Reverse(s)));
                continue;
            }
            let [p, q] = in_plane(a);
            for y in 0..dims[q] {
                for x in 0..dims[p] {
                    let mut c = [0; 3];
                    c[a] = s;
                    c[p] = x;
                    c[q] = y;
                    if lab[c[0] + nx * (c[1] + ny * c[2])] == 0 || on_drawn(&drawn, c) {
                        continue;
                    }
                    for b in (0..3).filter(|&b| b != a && allowed[b]) {
                        residual[b][c[b]] -= 1;
                    }
                }
            }
            residual[a][s] = 0;
            drawn[a][s] = true;
        }
    }
    let drawn = (0..3)
        .flat_map(|axis| {
            let d = &drawn[axis];
            (0..dims[axis])
                .filter(move |&s| d[s])
                .map(move |index| VoxelSlice { axis, index })
        })
        .collect();
    Detection {
        drawn,
        labelled,
        isolated,
    }
}

/// Checks what a [`LabelVolume`] built anywhere may get wrong; returns the voxels per frame.
fn check_volume(volume: &LabelVolume) -> Result<usize> {
    let [nx, ny, nz] = volume.dims;
    if volume.dims.contains(&0) || volume.frames == 0 {
        return Err(ErrorKind::Empty(format!(
            "label map of {nx}×{ny}×{nz} voxels and {} frames",
            volume.frames
        ))
        .into());
    }
    let voxels = nx.checked_mul(ny).and_then(|n| n.checked_mul(nz));
    let total = voxels.and_then(|n| n.checked_mul(volume.frames));
    match (voxels, total) {
        (Some(voxels), Some(total)) if total == volume.labels.len() => {
            for (r, row) in volume.affine.iter().enumerate() {
                for (c, &value) in row.iter().enumerate() {
                    if !value.is_finite() {
                        return Err(ErrorKind::NotFinite {
                            what: format!("voxel-to-world affine[{r}][{c}]"),
                            value,
                        }
                        .into());
                    }
                }
            }
            Ok(voxels)
        }
        _ => Err(ErrorKind::CountMismatch {
            what: format!(
                "label values of a {nx}×{ny}×{nz} label map with {} frames",
                volume.frames
            ),
            declared: total.unwrap_or(usize::MAX),
            found: volume.labels.len(),
        }
        .into()),
    }
}

fn select_frames(volume: &LabelVolume, frames: FrameRange) -> Result<Vec<usize>> {
    let selected = frames.indices(volume.frames);
    if selected.is_empty() {
        return Err(ErrorKind::Option(format!(
            "frames {frames} select nothing from a label map with {} frames",
            volume.frames
        ))
        .into());
    }
    Ok(selected)
}

/// The selected frames' times must be finite and increasing: checked before any work.
fn check_times(volume: &LabelVolume, selected: &[usize]) -> Result<()> {
    let time = |f: usize| f as f64 * volume.frame_interval;
    if !volume.frame_interval.is_finite() {
        return Err(ErrorKind::NotFinite {
            what: "time between frames".into(),
            value: volume.frame_interval,
        }
        .into());
    }
    if let [a, b, ..] = selected {
        if time(*b) <= time(*a) {
            return Err(DataError::new(ErrorKind::TimesNotIncreasing {
                previous: time(*a),
                time: time(*b),
            })
            .at_frame(*b, Some(time(*b))));
        }
    }
    Ok(())
}

fn check_annotations(planes: Option<usize>, classes: usize) -> Result<()> {
    match planes.and_then(|p| p.checked_mul(classes)) {
        Some(n) if n <= MAX_ANNOTATIONS => Ok(()),
        _ => Err(ErrorKind::Option(format!(
            "{} planes × {classes} classes exceed the limit of {MAX_ANNOTATIONS} annotations; \
             select fewer frames or labels",
            planes.map_or("too many".to_string(), |p| p.to_string())
        ))
        .into()),
    }
}

/// The class labels (sorted) and the selected frames without any labelled voxel.
fn class_labels(
    volume: &LabelVolume,
    voxels: usize,
    selected: &[usize],
    labels: Option<&[i32]>,
) -> Result<(Vec<i32>, Vec<usize>)> {
    let mut present = BTreeSet::new();
    let mut empty = Vec::new();
    for &f in selected {
        let mut last = 0;
        for &l in &volume.labels[f * voxels..(f + 1) * voxels] {
            // Runs of one label are the rule: skip the set for them.
            if l != 0 && l != last {
                present.insert(l);
                last = l;
            }
        }
        if last == 0 {
            empty.push(f);
        }
    }
    let classes: Vec<i32> = match labels {
        Some(ls) => {
            if ls.contains(&0) {
                return Err(
                    ErrorKind::Option("label 0 is the background, not a class".into()).into(),
                );
            }
            if let Some(&l) = ls.iter().find(|l| !present.contains(l)) {
                return Err(ErrorKind::LabelAbsent {
                    label: l,
                    present: present.iter().copied().collect(),
                }
                .into());
            }
            let set: BTreeSet<i32> = ls.iter().copied().collect();
            set.into_iter().collect()
        }
        None => present.into_iter().collect(),
    };
    if classes.is_empty() {
        return Err(ErrorKind::Empty("no nonzero label in the selected frames".into()).into());
    }
    Ok((classes, empty))
}

/// How the slices across one voxel axis lie in the world (the origin aside).
#[derive(Clone, Copy)]
struct SliceFrame {
    /// In-plane voxel axes (x along `axes[0]`, y along `axes[1]`).
    axes: [usize; 2],
    /// Pixels along them.
    n: [usize; 2],
    u: [f64; 3],
    v: [f64; 3],
    /// Pixel (x, y) is at plane coordinates (m[0]·x + m[1]·y, m[2]·y).
    m: [f64; 3],
    roi: Rect,
}

fn slice_frame(volume: &LabelVolume, axis: usize) -> Result<SliceFrame> {
    let axes = in_plane(axis);
    let a = volume.affine;
    let column = |c: usize| [a[0][c], a[1][c], a[2][c]];
    let (cp, cq) = (column(axes[0]), column(axes[1]));
    let (np, nq) = (dot(cp, cp).sqrt(), dot(cq, cq).sqrt());
    let sine = {
        let c = cross(cp, cq);
        dot(c, c).sqrt() / (np * nq)
    };
    // `!(x >= y)` also catches NaN from zero columns.
    if !(np > 0.0 && nq > 0.0 && sine >= MIN_SINE) {
        return Err(ErrorKind::AxesNotOrthonormal {
            u_norm: np,
            v_norm: nq,
            dot: if np > 0.0 && nq > 0.0 {
                dot(cp, cq) / (np * nq)
            } else {
                0.0
            },
        }
        .into());
    }
    let n = axes.map(|p| volume.dims[p]);
    if n[0].saturating_mul(n[1]) > MAX_SLICE_PIXELS {
        return Err(ErrorKind::Option(format!(
            "slices across voxel axis {} have {}×{} pixels (limit {MAX_SLICE_PIXELS})",
            AXIS_NAMES[axis], n[0], n[1]
        ))
        .into());
    }
    let u = normalize(cp);
    let v = orthogonal(normalize(cq), u);
    let m = [np, dot(cq, u), dot(cq, v)];
    let (mut lo, mut hi) = ([f64::INFINITY; 2], [f64::NEG_INFINITY; 2]);
    for (x, y) in [
        (-0.5, -0.5),
        (n[0] as f64 - 0.5, -0.5),
        (-0.5, n[1] as f64 - 0.5),
        (n[0] as f64 - 0.5, n[1] as f64 - 0.5),
    ] {
        let p = [m[0] * x + m[1] * y, m[2] * y];
        lo = [lo[0].min(p[0]), lo[1].min(p[1])];
        hi = [hi[0].max(p[0]), hi[1].max(p[1])];
    }
    Ok(SliceFrame {
        axes,
        n,
        u,
        v,
        m,
        roi: Rect { min: lo, max: hi },
    })
}

/// Pixel bounding box of one class on a slice: (class, [x0, x1, y0, y1], inclusive).
type ClassBox = (usize, [usize; 4]);

/// Contours `planes[i]` (the slices of frame `frames[i]`) into a validated sequence.
fn build(
    volume: &LabelVolume,
    voxels: usize,
    frames: &[usize],
    planes: Vec<Vec<VoxelSlice>>,
    classes: &[i32],
    table: &LabelTable,
) -> Result<Sequence> {
    let mut geometry: [Option<SliceFrame>; 3] = [None; 3];
    for s in planes.iter().flatten() {
        if geometry[s.axis].is_none() {
            geometry[s.axis] = Some(slice_frame(volume, s.axis)?);
        }
    }
    let dims = volume.dims;
    let stride = [1, dims[0], dims[0] * dims[1]];
    let jobs: Vec<(usize, VoxelSlice, SliceFrame)> = frames
        .iter()
        .zip(&planes)
        .flat_map(|(&f, slices)| {
            slices
                .iter()
                .filter_map(move |s| Some((f, *s, geometry[s.axis]?)))
        })
        .collect();
    // Pixel (x, y) of slice `s` of frame `f`, as an index into `volume.labels`.
    let index = move |f: usize, s: VoxelSlice, g: &SliceFrame, x: usize, y: usize| {
        f * voxels + s.index * stride[s.axis] + x * stride[g.axes[0]] + y * stride[g.axes[1]]
    };
    // Pass 1: every class's bounding box on every slice, to bound the contouring work before
    // doing it.
    let boxes: Vec<Vec<ClassBox>> = jobs
        .par_iter()
        .map(|(f, s, g)| {
            let mut found: Vec<ClassBox> = Vec::new();
            let mut last: Option<(i32, usize)> = None;
            for y in 0..g.n[1] {
                for x in 0..g.n[0] {
                    let l = volume.labels[index(*f, *s, g, x, y)];
                    if l == 0 {
                        continue;
                    }
                    let slot = match last {
                        Some((ll, slot)) if ll == l => slot,
                        _ => {
                            let Ok(class) = classes.binary_search(&l) else {
                                continue;
                            };
                            let slot =
                                found.iter().position(|b| b.0 == class).unwrap_or_else(|| {
                                    found.push((class, [x, x, y, y]));
                                    found.len() - 1
                                });
                            last = Some((l, slot));
                            slot
                        }
                    };
                    let b = &mut found[slot].1;
                    *b = [b[0].min(x), b[1].max(x), b[2].min(y), b[3].max(y)];
                }
            }
            found
        })
        .collect();
    let samples: u64 = boxes
        .iter()
        .flatten()
        .map(|(_, b)| (b[1] - b[0] + 3) as u64 * (b[3] - b[2] + 3) as u64)
        .sum();
    if samples > MAX_CONTOUR_SAMPLES {
        return Err(ErrorKind::Option(format!(
            "contouring {} planes would take {samples} samples (limit {MAX_CONTOUR_SAMPLES}); \
             select fewer frames or labels",
            jobs.len()
        ))
        .into());
    }
    let contoured: Vec<Plane> = jobs
        .par_iter()
        .zip(&boxes)
        .map(|((f, s, g), found)| {
            let mut c = [0usize; 3];
            c[s.axis] = s.index;
            let origin = volume.to_world(c.map(|x| x as f64));
            let mut annotations: Vec<Annotation> = (0..classes.len())
                .map(|class| Annotation {
                    class,
                    polygons: Vec::new(),
                })
                .collect();
            for &(class, b) in found {
                // The box grown by a pixel within the slice: outside it the indicator is 0, so
                // the contours are those of the whole slice.
                let (x0, x1) = (b[0].saturating_sub(1), (b[1] + 1).min(g.n[0] - 1));
                let (y0, y1) = (b[2].saturating_sub(1), (b[3] + 1).min(g.n[1] - 1));
                let (w, h) = (x1 - x0 + 1, y1 - y0 + 1);
                let label = classes[class];
                let field: Vec<f64> = (0..h)
                    .flat_map(|y| (0..w).map(move |x| (x0 + x, y0 + y)))
                    .map(|(x, y)| {
                        if volume.labels[index(*f, *s, g, x, y)] == label {
                            -0.5
                        } else {
                            0.5
                        }
                    })
                    .collect();
                annotations[class].polygons = contours(&field, w, h)
                    .into_iter()
                    .map(|poly| -> Polygon {
                        poly.into_iter()
                            .map(|[px, py]| {
                                let (x, y) = (x0 as f64 + px, y0 as f64 + py);
                                [g.m[0] * x + g.m[1] * y, g.m[2] * y]
                            })
                            .collect()
                    })
                    .collect();
            }
            Plane {
                origin,
                u: g.u,
                v: g.v,
                roi: g.roi,
                annotations,
            }
        })
        .collect();
    let mut contoured = contoured.into_iter();
    let frames = frames
        .iter()
        .zip(&planes)
        .map(|(&f, slices)| Frame {
            time: f as f64 * volume.frame_interval,
            planes: contoured.by_ref().take(slices.len()).collect(),
        })
        .collect();
    let classes = classes.iter().map(|&l| table.class(l)).collect();
    Sequence::new(classes, frames)
}
