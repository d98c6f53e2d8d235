//! Label maps cut into planes as drawn (`dynaslice_data::drawn_slices`): plane placement against
//! the affine, contour areas against pixel counts, absences and times on a cine short-axis stack
//! and an oblique, sheared long-axis view; the `Auto` rule; the drawn-slice detection on drawings
//! along one, two and three axes; input limits; and a 2D+t NIfTI written by nibabel.

use std::collections::BTreeSet;

use dynaslice_data::drawn_slices::{
    drawn_slices, resolve, slices, sparse, sparse_with_axes, PlaneMode, SparseAxes, VoxelSlice,
    MAX_ANNOTATIONS,
};
use dynaslice_data::label_volume::LabelVolume;
use dynaslice_data::nifti::read_volume;
use dynaslice_data::{ErrorKind, FrameRange, LabelTable, Plane, Sequence};
use dynaslice_geometry::polygon::signed_area;
use dynaslice_test_support::fixtures::shared_data;
use dynaslice_test_support::python::run_python;

type Affine = [[f64; 4]; 3];

fn column(a: &Affine, c: usize) -> [f64; 3] {
    [a[0][c], a[1][c], a[2][c]]
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

fn unit(a: [f64; 3]) -> [f64; 3] {
    let n = dot(a, a).sqrt();
    a.map(|x| x / n)
}

fn assert_close(a: [f64; 3], b: [f64; 3], tol: f64, what: &str) {
    let d = (0..3).map(|k| (a[k] - b[k]).abs()).fold(0.0, f64::max);
    assert!(d <= tol, "{what}: {a:?} vs {b:?}");
}

/// Rotation by `angle` about `axis` (Rodrigues), columns scaled by `spacing`, then `offset`.
fn oblique(axis: [f64; 3], angle: f64, spacing: [f64; 3], offset: [f64; 3]) -> Affine {
    let k = unit(axis);
    let (s, c) = angle.sin_cos();
    let r = |i: usize, j: usize| {
        let delta = if i == j { 1.0 } else { 0.0 };
        let eps = match (i, j) {
            (0, 1) => -k[2],
            (1, 0) => k[2],
            (0, 2) => k[1],
            (2, 0) => -k[1],
            (1, 2) => -k[0],
            (2, 1) => k[0],
            _ => 0.0,
        };
        c * delta + s * eps + (1.0 - c) * k[i] * k[j]
    };
    std::array::from_fn(|i| {
        [
            r(i, 0) * spacing[0],
            r(i, 1) * spacing[1],
            r(i, 2) * spacing[2],
            offset[i],
        ]
    })
}

/// Voxel coordinates of world point `w` (Cramer's rule on the affine's linear part).
fn to_voxel(a: &Affine, w: [f64; 3]) -> [f64; 3] {
    let cols = [column(a, 0), column(a, 1), column(a, 2)];
    let d: [f64; 3] = std::array::from_fn(|r| w[r] - a[r][3]);
    let det = dot(cols[0], cross(cols[1], cols[2]));
    [
        dot(d, cross(cols[1], cols[2])) / det,
        dot(cols[0], cross(d, cols[2])) / det,
        dot(cols[0], cross(cols[1], d)) / det,
    ]
}

/// Labels from `f(i, j, k, frame)` over `dims` × `frames`.
fn volume(
    dims: [usize; 3],
    frames: usize,
    affine: Affine,
    frame_interval: f64,
    f: impl Fn(usize, usize, usize, usize) -> i32,
) -> LabelVolume {
    let mut labels = Vec::with_capacity(dims.iter().product::<usize>() * frames);
    for t in 0..frames {
        for k in 0..dims[2] {
            for j in 0..dims[1] {
                for i in 0..dims[0] {
                    labels.push(f(i, j, k, t));
                }
            }
        }
    }
    LabelVolume {
        dims,
        frames,
        affine,
        frame_interval,
        labels,
    }
}

fn in_ellipse(x: usize, y: usize, centre: [f64; 2], semi: [f64; 2]) -> bool {
    let dx = (x as f64 - centre[0]) / semi[0];
    let dy = (y as f64 - centre[1]) / semi[1];
    dx * dx + dy * dy <= 1.0
}

/// A cine short-axis stack: 1.5 × 1.5 × 8 mm, 12 slices, 4 phases 0.04 s apart, oblique. Three
/// disjoint ellipses (labels 1, 2, 3) that taper towards the apex (high k) and breathe with the
/// phase; label 3 stops at slice 8 and slice 11 holds nothing.
fn cine_stack() -> LabelVolume {
    let affine = oblique([1.0, 2.0, 3.0], 0.7, [1.5, 1.5, 8.0], [-40.0, 12.5, 80.0]);
    volume([48, 40, 12], 4, affine, 0.04, |i, j, k, t| {
        if k == 11 {
            return 0;
        }
        let taper = 1.0 - 0.05 * k as f64 + 0.04 * t as f64;
        if in_ellipse(i, j, [14.0, 18.0], [8.0 * taper, 6.5 * taper]) {
            1
        } else if in_ellipse(i, j, [33.0, 12.5], [5.5 * taper, 4.0 * taper]) {
            2
        } else if k <= 8 && in_ellipse(i, j, [32.5, 28.0], [7.0 * taper, 5.0 * taper]) {
            3
        } else {
            0
        }
    })
}

/// Pixels of `label` on slice `s` of frame `t`, and whether pixel (x, y) has it.
fn slice_pixels(
    v: &LabelVolume,
    s: VoxelSlice,
    t: usize,
    label: i32,
) -> (usize, Vec<bool>, [usize; 2]) {
    let axes = match s.axis {
        0 => [1, 2],
        1 => [0, 2],
        _ => [0, 1],
    };
    let n = axes.map(|a| v.dims[a]);
    let mut has = Vec::with_capacity(n[0] * n[1]);
    for y in 0..n[1] {
        for x in 0..n[0] {
            let mut c = [0isize; 3];
            c[s.axis] = s.index as isize;
            c[axes[0]] = x as isize;
            c[axes[1]] = y as isize;
            has.push(v.label(c[0], c[1], c[2], t) == label);
        }
    }
    (has.iter().filter(|&&b| b).count(), has, n)
}

/// Checks one plane of slice `s` of frame `t` against the volume: placement from the affine,
/// every class annotated, absent exactly where it has no pixel, and contour areas and vertices
/// against the pixels.
fn check_plane(v: &LabelVolume, seq: &Sequence, plane: &Plane, s: VoxelSlice, t: usize) {
    let axes = match s.axis {
        0 => [1, 2],
        1 => [0, 2],
        _ => [0, 1],
    };
    let mut origin = [0.0; 3];
    origin[s.axis] = s.index as f64;
    assert_close(
        plane.origin,
        v.to_world(origin),
        1e-9,
        "origin = world of the slice's first voxel",
    );
    let (cp, cq) = (column(&v.affine, axes[0]), column(&v.affine, axes[1]));
    assert_close(plane.u, unit(cp), 1e-12, "u = normalised affine column");
    assert_close(
        plane.normal(),
        unit(cross(cp, cq)),
        1e-12,
        "normal = unit(c_p × c_q)",
    );
    // The ROI's corners reach half a pixel beyond the outermost pixel centres.
    let n = axes.map(|a| v.dims[a] as f64);
    for corner in [[-0.5, -0.5], [n[0] - 0.5, n[1] - 0.5]] {
        let mut q = origin;
        q[axes[0]] = corner[0];
        q[axes[1]] = corner[1];
        let p = plane.to_plane(v.to_world(q));
        assert!(
            (0..2).all(|k| p[k] >= plane.roi.min[k] - 1e-9 && p[k] <= plane.roi.max[k] + 1e-9),
            "pixel corner {corner:?} at {p:?} outside the ROI {:?}",
            plane.roi
        );
    }
    let pixel_area = dot(cross(cp, cq), cross(cp, cq)).sqrt();
    assert_eq!(
        plane.annotations.len(),
        seq.classes().len(),
        "every class annotated"
    );
    for (k, class) in seq.classes().iter().enumerate() {
        let a = plane.annotation(k).expect("annotated");
        let (count, has, dims) = slice_pixels(v, s, t, class.label);
        assert_eq!(
            a.is_absent(),
            count == 0,
            "class {} absent iff no pixel",
            class.label
        );
        if count == 0 {
            continue;
        }
        // Documented: the contours enclose the pixel count minus ½ pixel per outer contour plus
        // ½ per hole (contours away from the image border).
        let areas: Vec<f64> = a.polygons.iter().map(|p| signed_area(p)).collect();
        let outer = areas.iter().filter(|&&x| x > 0.0).count() as f64;
        let holes = areas.iter().filter(|&&x| x < 0.0).count() as f64;
        let total: f64 = areas.iter().sum();
        let want = (count as f64 - 0.5 * (outer - holes)) * pixel_area;
        assert!(
            (total - want).abs() <= 1e-9 * want.max(1.0),
            "class {}: area {total} vs {want} ({count} pixels of {pixel_area})",
            class.label
        );
        // Every vertex on the slice, midway between a pixel of the class and one without it.
        for p in a.polygons.iter().flatten() {
            let q = to_voxel(&v.affine, plane.to_world(*p));
            assert!(
                (q[s.axis] - s.index as f64).abs() < 1e-9,
                "vertex {q:?} off slice {s:?}"
            );
            let (x, y) = (q[axes[0]], q[axes[1]]);
            let half_x = (x - x.floor() - 0.5).abs() < 1e-9 && (y - y.round()).abs() < 1e-9;
            let half_y = (y - y.floor() - 0.5).abs() < 1e-9 && (x - x.round()).abs() < 1e-9;
            assert!(
                half_x || half_y,
                "vertex {q:?} is not midway between pixel centres"
            );
            let (a0, b0) = if half_x {
                ((x.floor(), y.round()), (x.floor() + 1.0, y.round()))
            } else {
                ((x.round(), y.floor()), (x.round(), y.floor() + 1.0))
            };
            let at = |(px, py): (f64, f64)| has[py as usize * dims[0] + px as usize];
            assert_ne!(
                at(a0),
                at(b0),
                "vertex {q:?} does not separate the class from the rest"
            );
        }
    }
}

#[test]
fn cine_stack_every_slice_is_a_plane_placed_by_the_affine() {
    let v = cine_stack();
    assert_eq!(resolve(PlaneMode::Auto, &v), PlaneMode::Slices);
    let table = LabelTable::parse("1 LV\n2 LA\n3 RV\n").unwrap();
    let seq = slices(&v, FrameRange::ALL, None, &table).unwrap();
    let names: Vec<&str> = seq.classes().iter().map(|c| c.name.as_str()).collect();
    assert_eq!(names, ["LV", "LA", "RV"]);
    assert_eq!(seq.frames().len(), 4);
    for (t, frame) in seq.frames().iter().enumerate() {
        assert!(
            (frame.time - 0.04 * t as f64).abs() < 1e-15,
            "time of frame {t}"
        );
        assert_eq!(frame.planes.len(), 12);
        for (k, plane) in frame.planes.iter().enumerate() {
            check_plane(&v, &seq, plane, VoxelSlice { axis: 2, index: k }, t);
        }
        // The RV ends at slice 8; slice 11 holds nothing, yet annotates every class as absent.
        assert!(frame.planes[9].annotation(2).unwrap().is_absent());
        assert!(frame.planes[11].annotations.iter().all(|a| a.is_absent()));
        assert!(!frame.planes[8].annotation(2).unwrap().is_absent());
    }
    // A frame and label selection.
    let some = slices(&v, "1:4:2".parse().unwrap(), Some(&[3, 1]), &table).unwrap();
    let times: Vec<f64> = some.frames().iter().map(|f| f.time).collect();
    assert_eq!(times, [0.04, 0.12]);
    let labels: Vec<i32> = some.classes().iter().map(|c| c.label).collect();
    assert_eq!(labels, [1, 3]);
    check_plane(
        &v,
        &some,
        &some.frames()[1].planes[4],
        VoxelSlice { axis: 2, index: 4 },
        3,
    );
}

/// A 4-chamber view: one slice, oblique, with an in-plane shear (the columns 0 and 1 at 80°).
fn long_axis() -> LabelVolume {
    let mut affine = oblique([0.3, -1.0, 0.4], 1.1, [1.4, 1.4, 6.0], [10.0, -30.0, 55.0]);
    let (c0, c1) = (column(&affine, 0), column(&affine, 1));
    let (sin, cos) = 10f64.to_radians().sin_cos();
    for r in 0..3 {
        affine[r][1] = c1[r] * cos + c0[r] * sin;
    }
    volume([40, 36, 1], 3, affine, 0.05, |i, j, _, t| {
        let grow = 1.0 + 0.1 * t as f64;
        if in_ellipse(i, j, [13.0, 17.0], [6.0 * grow, 10.0]) {
            4
        } else if in_ellipse(i, j, [27.0, 17.0], [5.0, 9.0 * grow]) {
            7
        } else if t == 1 && in_ellipse(i, j, [20.0, 31.0], [4.0, 2.5]) {
            9
        } else {
            0
        }
    })
}

#[test]
fn long_axis_view_with_sheared_affine_is_one_orthonormal_plane() {
    let v = long_axis();
    let (c0, c1) = (column(&v.affine, 0), column(&v.affine, 1));
    assert!(
        dot(unit(c0), unit(c1)).abs() > 0.1,
        "the fixture is sheared"
    );
    assert_eq!(resolve(PlaneMode::Auto, &v), PlaneMode::Slices);
    let seq = slices(&v, FrameRange::ALL, None, &LabelTable::default()).unwrap();
    assert_eq!(seq.classes().len(), 3);
    for (t, frame) in seq.frames().iter().enumerate() {
        assert!((frame.time - 0.05 * t as f64).abs() < 1e-15);
        assert_eq!(frame.planes.len(), 1);
        check_plane(
            &v,
            &seq,
            &frame.planes[0],
            VoxelSlice { axis: 2, index: 0 },
            t,
        );
        // Label 9 is drawn in frame 1 only: absent on the view's other phases.
        assert_eq!(frame.planes[0].annotation(2).unwrap().is_absent(), t != 1);
    }
    // The same view read as sparse: a single slice is drawn, the same plane comes out.
    let drawn = drawn_slices(&v, 0, SparseAxes::Detect).unwrap();
    assert_eq!(drawn, [VoxelSlice { axis: 2, index: 0 }]);
    assert_eq!(
        sparse(&v, FrameRange::ALL, None, &LabelTable::default()).unwrap(),
        seq
    );
}

/// A 40 × 36 × 30 volume, 1 mm voxels turned about z, labelled by `f(i, j, k)`.
fn drawing(f: impl Fn(usize, usize, usize) -> i32) -> LabelVolume {
    let affine = oblique([0.0, 0.0, 1.0], 0.3, [1.0, 1.0, 1.0], [5.0, 6.0, 7.0]);
    volume([40, 36, 30], 1, affine, 1.0, |i, j, k, _| f(i, j, k))
}

const AXIAL: [usize; 5] = [3, 8, 13, 18, 23];

/// Axial drawings: two classes on every 5th slice.
fn axial(i: usize, j: usize, k: usize) -> i32 {
    if !AXIAL.contains(&k) {
        0
    } else if in_ellipse(i, j, [14.0, 17.0], [9.0, 7.0 + 0.1 * k as f64]) {
        1
    } else if in_ellipse(i, j, [30.0, 17.0], [5.0, 11.0]) {
        2
    } else {
        0
    }
}

/// Sagittal drawings (across voxel axis i) at i = 12 and 27: a class-3 ellipse in (j, k).
fn sagittal(i: usize, j: usize, k: usize) -> i32 {
    if (i == 12 || i == 27) && in_ellipse(j, k, [18.0, 14.0], [10.0, 11.0]) {
        3
    } else {
        0
    }
}

fn slices_of(axis: usize, indices: &[usize]) -> Vec<VoxelSlice> {
    indices
        .iter()
        .map(|&index| VoxelSlice { axis, index })
        .collect()
}

/// The planes of a sparse sequence (one frame) are exactly `want`, each placed and contoured
/// from its slice.
fn check_sparse(v: &LabelVolume, want: &[VoxelSlice]) {
    assert_eq!(drawn_slices(v, 0, SparseAxes::Detect).unwrap(), want);
    let seq = sparse(v, FrameRange::ALL, None, &LabelTable::default()).unwrap();
    let planes = &seq.frames()[0].planes;
    assert_eq!(planes.len(), want.len());
    for (plane, &s) in planes.iter().zip(want) {
        check_plane(v, &seq, plane, s, 0);
    }
}

#[test]
fn sparse_axial_drawing_gives_exactly_the_drawn_slices() {
    let v = drawing(axial);
    // The premise: sagittal and coronal slices crossing the drawings hold labelled voxels.
    let (crossing, _, _) = slice_pixels(&v, VoxelSlice { axis: 0, index: 14 }, 0, 1);
    assert!(crossing > 50, "{crossing}");
    assert_eq!(resolve(PlaneMode::Auto, &v), PlaneMode::Sparse);
    check_sparse(&v, &slices_of(2, &AXIAL));
    // Undrawn slices are not planes: no plane lies between the drawn ones.
    let seq = sparse(&v, FrameRange::ALL, None, &LabelTable::default()).unwrap();
    for plane in &seq.frames()[0].planes {
        let k = to_voxel(&v.affine, plane.origin)[2];
        assert!(
            AXIAL.iter().any(|&d| (k - d as f64).abs() < 1e-9),
            "plane at k = {k}"
        );
    }
}

#[test]
fn sparse_drawing_on_two_and_three_axes_is_detected_exactly() {
    let two = drawing(|i, j, k| axial(i, j, k).max(sagittal(i, j, k)));
    assert_eq!(resolve(PlaneMode::Auto, &two), PlaneMode::Sparse);
    let mut want = slices_of(0, &[12, 27]);
    want.extend(slices_of(2, &AXIAL));
    check_sparse(&two, &want);

    // Plus one coronal drawing (across j) at j = 20, crossing all the others.
    let three = drawing(|i, j, k| {
        let coronal = j == 20 && in_ellipse(i, k, [20.0, 15.0], [15.0, 9.0]);
        if coronal {
            4
        } else {
            axial(i, j, k).max(sagittal(i, j, k))
        }
    });
    let mut want = slices_of(0, &[12, 27]);
    want.extend(slices_of(1, &[20]));
    want.extend(slices_of(2, &AXIAL));
    check_sparse(&three, &want);
}

#[test]
fn adjacent_drawn_slices_are_covered_and_can_be_forced() {
    // Slices 10 and 11 drawn next to each other, among isolated ones.
    let v = drawing(|i, j, k| {
        if [3, 10, 11, 18, 25].contains(&k) && in_ellipse(i, j, [20.0, 18.0], [10.0, 8.0]) {
            1
        } else {
            0
        }
    });
    let want = slices_of(2, &[3, 10, 11, 18, 25]);
    // The isolated slices hold 3 of 5 drawings: sparse; step 3 covers the adjacent pair.
    assert_eq!(drawn_slices(&v, 0, SparseAxes::Detect).unwrap(), want);
    let forced = SparseAxes::Only([false, false, true]);
    assert_eq!(drawn_slices(&v, 0, forced).unwrap(), want);
    // Forcing a wrong axis gives that axis's slices: the caller's choice.
    let sagittal_only = drawn_slices(&v, 0, SparseAxes::Only([true, false, false])).unwrap();
    assert!(sagittal_only.iter().all(|s| s.axis == 0));
}

#[test]
fn resolve_follows_the_documented_rule() {
    for mode in [PlaneMode::Slices, PlaneMode::Reslice, PlaneMode::Sparse] {
        assert_eq!(resolve(mode, &cine_stack()), mode, "explicit modes stay");
    }
    // A dense ball, 1.5 × 1.5 × 2 mm, 30 slices: thin slices, reslice.
    let ball = |spacing: [f64; 3]| {
        let affine = oblique([1.0, 0.0, 0.0], 0.2, spacing, [0.0; 3]);
        volume([30, 30, 30], 1, affine, 1.0, |i, j, k, _| {
            let d = [i as f64 - 15.0, j as f64 - 14.0, k as f64 - 15.5];
            i32::from(dot(d, d) < 100.0)
        })
    };
    assert_eq!(
        resolve(PlaneMode::Auto, &ball([1.5, 1.5, 2.0])),
        PlaneMode::Reslice
    );
    // The same voxels 3 mm apart: thick slices.
    assert_eq!(
        resolve(PlaneMode::Auto, &ball([1.5, 1.5, 3.0])),
        PlaneMode::Slices
    );
    // Three slices of anything: slice by slice.
    let three = volume(
        [8, 8, 3],
        1,
        oblique([0.0, 0.0, 1.0], 0.0, [1.0; 3], [0.0; 3]),
        1.0,
        |i, _, _, _| i32::from(i > 3),
    );
    assert_eq!(resolve(PlaneMode::Auto, &three), PlaneMode::Slices);
    // TotalSegmentator's 3 mm isotropic, 30-slice output stays resliced.
    if let Some(path) = shared_data("nifti/example_seg.nii.gz") {
        let ts = read_volume(&path).unwrap();
        assert_eq!(resolve(PlaneMode::Auto, &ts), PlaneMode::Reslice);
        let e = sparse(&ts, FrameRange::ALL, None, &LabelTable::default()).unwrap_err();
        assert!(e.to_string().contains("densely segmented"), "{e}");
    }
}

#[test]
fn modes_and_axes_parse_and_print() {
    for mode in [
        PlaneMode::Auto,
        PlaneMode::Slices,
        PlaneMode::Reslice,
        PlaneMode::Sparse,
    ] {
        assert_eq!(mode.to_string().parse::<PlaneMode>().unwrap(), mode);
    }
    assert_eq!(" Sparse ".parse::<PlaneMode>().unwrap(), PlaneMode::Sparse);
    assert!("slice".parse::<PlaneMode>().is_err());
    assert_eq!("auto".parse::<SparseAxes>().unwrap(), SparseAxes::Detect);
    let ik = "k, i".parse::<SparseAxes>().unwrap();
    assert_eq!(ik, SparseAxes::Only([true, false, true]));
    assert_eq!(ik.to_string(), "i,k");
    assert_eq!(ik.to_string().parse::<SparseAxes>().unwrap(), ik);
    for bad in ["", "x", "k,k", "i,,j"] {
        assert!(bad.parse::<SparseAxes>().is_err(), "{bad:?}");
    }
}

#[test]
fn frames_without_labels_are_absences_in_slices_and_unobserved_in_sparse() {
    // Frame 1 holds nothing.
    let affine = oblique([0.0, 0.0, 1.0], 0.0, [1.0, 1.0, 1.0], [0.0; 3]);
    let v = volume([20, 20, 12], 3, affine, 0.5, |i, j, k, t| {
        i32::from(t != 1 && k % 4 == 1 && in_ellipse(i, j, [10.0, 10.0], [5.0, 4.0]))
    });
    let seq = slices(&v, FrameRange::ALL, None, &LabelTable::default()).unwrap();
    assert_eq!(seq.frames().len(), 3);
    assert!(seq.frames()[1]
        .planes
        .iter()
        .all(|p| p.annotations[0].is_absent()));
    let seq = sparse(&v, FrameRange::ALL, None, &LabelTable::default()).unwrap();
    let times: Vec<f64> = seq.frames().iter().map(|f| f.time).collect();
    assert_eq!(times, [0.0, 1.0]);
    assert!(seq.frames().iter().all(|f| f.planes.len() == 3));
    let e = sparse(&v, "1".parse().unwrap(), None, &LabelTable::default()).unwrap_err();
    assert!(matches!(e.kind, ErrorKind::Empty(_)), "{e}");
}

#[test]
fn bad_inputs_are_refused_with_clear_errors() {
    let good = cine_stack();
    let table = LabelTable::default();
    let run = |v: &LabelVolume| slices(v, FrameRange::ALL, None, &table).unwrap_err();

    let mut short = good.clone();
    short.labels.pop();
    let e = run(&short);
    assert!(matches!(e.kind, ErrorKind::CountMismatch { .. }), "{e}");
    assert!(sparse(&short, FrameRange::ALL, None, &table).is_err());
    assert_eq!(
        resolve(PlaneMode::Auto, &short),
        PlaneMode::Slices,
        "never panics"
    );

    let mut nan = good.clone();
    nan.affine[1][2] = f64::NAN;
    let e = run(&nan);
    assert!(matches!(e.kind, ErrorKind::NotFinite { .. }), "{e}");
    assert!(e.to_string().contains("affine[1][2]"), "{e}");

    let mut flat = good.clone();
    for r in 0..3 {
        flat.affine[r][1] = 2.0 * flat.affine[r][0];
    }
    let e = run(&flat);
    assert!(
        matches!(e.kind, ErrorKind::AxesNotOrthonormal { .. }),
        "{e}"
    );

    let mut backwards = good.clone();
    backwards.frame_interval = -0.04;
    let e = run(&backwards);
    assert!(
        matches!(e.kind, ErrorKind::TimesNotIncreasing { .. }),
        "{e}"
    );

    let e = slices(&good, "7:9".parse().unwrap(), None, &table).unwrap_err();
    assert!(matches!(e.kind, ErrorKind::Option(_)), "{e}");
    let e = slices(&good, FrameRange::ALL, Some(&[1, 5]), &table).unwrap_err();
    assert!(
        matches!(e.kind, ErrorKind::LabelAbsent { label: 5, .. }),
        "{e}"
    );
    let e = slices(&good, FrameRange::ALL, Some(&[0, 1]), &table).unwrap_err();
    assert!(e.to_string().contains("background"), "{e}");
    let e = sparse_with_axes(
        &good,
        FrameRange::ALL,
        None,
        &table,
        SparseAxes::Only([false; 3]),
    )
    .unwrap_err();
    assert!(matches!(e.kind, ErrorKind::Option(_)), "{e}");

    // Too many (plane, class) annotations: refused before any plane is built.
    let n = MAX_ANNOTATIONS / 2 + 1;
    let many = volume([1, 1, n], 1, good.affine, 1.0, |_, _, k, _| {
        (k % 2) as i32 + 1
    });
    let e = run(&many);
    assert!(e.to_string().contains("annotations"), "{e}");
}

/// nibabel writes a 2D+t long-axis view (nz = 1, oblique affine, pixdim[4] = 0.04); we read it
/// and cut it: the plane sits where nibabel's affine puts the image, the contours where it puts
/// the pixels.
#[test]
fn nibabel_long_axis_view_is_placed_by_its_affine() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("la.nii.gz");
    let write = r#"
import sys, json, numpy as np, nibabel as nib
from nibabel.affines import apply_affine
a, b = 0.6, -0.35
rz = np.array([[np.cos(a), -np.sin(a), 0], [np.sin(a), np.cos(a), 0], [0, 0, 1]])
rx = np.array([[1, 0, 0], [0, np.cos(b), -np.sin(b)], [0, np.sin(b), np.cos(b)]])
affine = np.eye(4)
affine[:3, :3] = rz @ rx @ np.diag([1.25, 1.25, 7.0])
affine[:3, 3] = [-31.5, 44.0, 12.25]
i, j = np.meshgrid(np.arange(30), np.arange(26), indexing="ij")
data = np.zeros((30, 26, 1, 5), np.int16)
for t in range(5):
    r = 5 + 0.5 * t
    data[..., 0, t][((i - 14) / r) ** 2 + ((j - 12) / 7.0) ** 2 <= 1] = 2
img = nib.Nifti1Image(data, affine)
img.header.set_xyzt_units("mm", "sec")
img.header["pixdim"][4] = 0.04
nib.save(img, sys.argv[1])
back = nib.load(sys.argv[1])
centroids = []
for t in range(5):
    ii, jj = np.nonzero(np.asarray(back.dataobj)[..., 0, t] == 2)
    pts = apply_affine(back.affine, np.c_[ii, jj, np.zeros_like(ii)])
    centroids.append(pts.mean(axis=0).tolist())
print(json.dumps({"affine": back.affine[:3].tolist(), "centroids": centroids}))
"#;
    let Some(text) = run_python(&["nibabel", "numpy"], write, &[&path]) else {
        return;
    };
    let theirs: serde_json::Value = serde_json::from_str(&text).unwrap();
    let affine: Vec<Vec<f64>> = serde_json::from_value(theirs["affine"].clone()).unwrap();
    let centroids: Vec<[f64; 3]> = serde_json::from_value(theirs["centroids"].clone()).unwrap();
    let v = read_volume(&path).unwrap();
    assert_eq!((v.dims, v.frames), ([30, 26, 1], 5));
    assert_eq!(resolve(PlaneMode::Auto, &v), PlaneMode::Slices);
    let seq = slices(&v, FrameRange::ALL, None, &LabelTable::default()).unwrap();
    let col = |c: usize| [affine[0][c], affine[1][c], affine[2][c]];
    for (t, frame) in seq.frames().iter().enumerate() {
        // pixdim[4] is stored as f32.
        assert!(
            (frame.time - 0.04 * t as f64).abs() < 1e-7,
            "time {}",
            frame.time
        );
        let plane = &frame.planes[0];
        // The sform is stored in f32.
        assert_close(
            plane.origin,
            col(3),
            1e-5,
            "origin = nibabel's affine · (0, 0, 0)",
        );
        assert_close(
            plane.u,
            unit(col(0)),
            1e-6,
            "u along nibabel's first column",
        );
        assert_close(plane.normal(), unit(cross(col(0), col(1))), 1e-6, "normal");
        // The contour's area centroid, in the world, against nibabel's pixel centroid: a
        // symmetric shape, so equal up to the f32 sform.
        let poly = &plane.annotations[0].polygons;
        assert_eq!(poly.len(), 1);
        let (mut a, mut c) = (0.0, [0.0; 2]);
        let p = &poly[0];
        for k in 0..p.len() {
            let (p0, p1) = (p[k], p[(k + 1) % p.len()]);
            let w = p0[0] * p1[1] - p1[0] * p0[1];
            a += w;
            c = [c[0] + (p0[0] + p1[0]) * w, c[1] + (p0[1] + p1[1]) * w];
        }
        let centroid = plane.to_world([c[0] / (3.0 * a), c[1] / (3.0 * a)]);
        assert_close(
            centroid,
            centroids[t],
            1e-4,
            "contour centroid vs nibabel's pixels",
        );
    }
}

/// Every drawn plane annotates every class, absent ones too.
#[test]
fn every_drawn_plane_annotates_every_class() {
    let v = drawing(|i, j, k| axial(i, j, k).max(sagittal(i, j, k)));
    let seq = sparse(&v, FrameRange::ALL, None, &LabelTable::default()).unwrap();
    for plane in &seq.frames()[0].planes {
        let classes: BTreeSet<usize> = plane.annotations.iter().map(|a| a.class).collect();
        assert_eq!(classes, (0..3).collect());
    }
    // A drawn slice shows every label it holds: the sagittal drawing at i = 12 (label 3) also
    // holds the lines where the axial drawings of label 1 cross it.
    let sag = &seq.frames()[0].planes[0];
    assert!(!sag.annotation(2).unwrap().is_absent());
    assert!(!sag.annotation(0).unwrap().is_absent());
}
