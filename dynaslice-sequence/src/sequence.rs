//! The data model: a sequence of annotated timesteps of planar cross-sections.
//!
//! A [`Sequence`] is the paper's input {𝒞ᵢ} (Sec. 3.1): for each timestep tᵢ, a set of planes, and
//! on each plane, for each class k annotated there, the closed contours of the k-th structure
//! (outer boundaries and holes, several components). A class annotated on a plane with no contour
//! means "k is absent from this plane" (within the plane's region of interest); real multi-organ
//! data is mostly such absences, and the samplers turn them into lower-bound targets.
//!
//! A `Sequence` can only be built through [`Sequence::new`], which validates everything and puts
//! the polygons in canonical form (see there); every reader goes through it, so the rest of the
//! crate never sees malformed geometry.

use std::collections::HashMap;

use rayon::prelude::*;
use serde::{Deserialize, Serialize};

use crate::error::{DataError, ErrorKind, Result};
use crate::nesting::Nested;
use dynaslice_geometry::polygon::{find_crossing, orient_by_nesting, signed_area};
use dynaslice_geometry::{Point2, Polygon};

/// Tolerance on ‖u‖ − 1, ‖v‖ − 1 and u·v for a plane's axes.
pub const AXIS_TOLERANCE: f64 = 1e-6;

/// One class (structure) of the sequence.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ClassInfo {
    /// Human-readable name ("liver", "label 5").
    pub name: String,
    /// The label value the class has in its source (NIfTI voxel value, `.csl` label).
    pub label: i32,
    /// Display colour (sRGB) where the source gives one (RTSTRUCT ROI Display Color,
    /// `.seg.nrrd` segment colour); outputs use a fixed palette otherwise.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub color: Option<[u8; 3]>,
}

/// An axis-aligned rectangle in plane coordinates.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Rect {
    /// Lower corner (u, v).
    pub min: Point2,
    /// Upper corner (u, v).
    pub max: Point2,
}

impl Rect {
    /// Whether `p` lies in the closed rectangle.
    pub fn contains(&self, p: Point2) -> bool {
        p[0] >= self.min[0] && p[0] <= self.max[0] && p[1] >= self.min[1] && p[1] <= self.max[1]
    }
}

/// The contours of one class on one plane.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Annotation {
    /// Index into [`Sequence::classes`].
    pub class: usize,
    /// Closed polygons in plane coordinates; empty means the class is absent from the plane.
    pub polygons: Vec<Polygon>,
}

impl Annotation {
    /// Whether this annotation says "the class is absent from this plane".
    pub fn is_absent(&self) -> bool {
        self.polygons.is_empty()
    }
}

/// One cross-section plane: world frame, region of interest and per-class annotations.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Plane {
    /// World position of plane coordinates (0, 0).
    pub origin: [f64; 3],
    /// World direction of the plane's first axis (unit).
    pub u: [f64; 3],
    /// World direction of the plane's second axis (unit, orthogonal to `u`). The plane normal is
    /// u × v; outer boundaries run counter-clockwise about it.
    pub v: [f64; 3],
    /// Where on the plane the annotations hold (plane coordinates): every contour lies inside,
    /// and "absent" means absent within it. Samplers draw plane samples from it.
    pub roi: Rect,
    /// The classes annotated on this plane, at most one entry per class.
    pub annotations: Vec<Annotation>,
}

impl Plane {
    /// World point of plane coordinates `p`.
    #[inline]
    pub fn to_world(&self, p: Point2) -> [f64; 3] {
        std::array::from_fn(|k| self.origin[k] + p[0] * self.u[k] + p[1] * self.v[k])
    }

    /// World vector of the in-plane vector `d`.
    #[inline]
    pub fn vector_to_world(&self, d: Point2) -> [f64; 3] {
        std::array::from_fn(|k| d[0] * self.u[k] + d[1] * self.v[k])
    }

    /// Plane coordinates of the orthogonal projection of world point `x`.
    pub fn to_plane(&self, x: [f64; 3]) -> Point2 {
        let w: [f64; 3] = std::array::from_fn(|k| x[k] - self.origin[k]);
        [dot(w, self.u), dot(w, self.v)]
    }

    /// The unit normal u × v.
    pub fn normal(&self) -> [f64; 3] {
        cross(self.u, self.v)
    }

    /// The rectangle (plane coordinates) of the projection of the world box `lo`..`hi` onto the
    /// plane: a region of interest that covers everything the box holds.
    pub fn box_roi(&self, lo: [f64; 3], hi: [f64; 3]) -> Rect {
        let mut roi = Rect {
            min: [f64::INFINITY; 2],
            max: [f64::NEG_INFINITY; 2],
        };
        for corner in 0..8 {
            let x = std::array::from_fn(|k| if corner >> k & 1 == 1 { hi[k] } else { lo[k] });
            let q = self.to_plane(x);
            roi.min = std::array::from_fn(|k| roi.min[k].min(q[k]));
            roi.max = std::array::from_fn(|k| roi.max[k].max(q[k]));
        }
        roi
    }

    /// The annotation of class `class`, if the plane annotates it.
    pub fn annotation(&self, class: usize) -> Option<&Annotation> {
        // Readers annotate every class in class order: look there first, so that a lookup per
        // class is not a search per class (cubic in the classes over every pair of them).
        match self.annotations.get(class) {
            Some(a) if a.class == class => Some(a),
            _ => self.annotations.iter().find(|a| a.class == class),
        }
    }
}

/// One annotated timestep.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Frame {
    /// Time in world units.
    pub time: f64,
    /// The planes annotated at this time.
    pub planes: Vec<Plane>,
}

/// World-space axis-aligned box.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Aabb {
    /// Lower corner.
    pub min: [f64; 3],
    /// Upper corner.
    pub max: [f64; 3],
}

/// A validated sequence of annotated timesteps. See the [module docs](self).
#[derive(Debug, Clone, PartialEq)]
pub struct Sequence {
    classes: Vec<ClassInfo>,
    frames: Vec<Frame>,
    nesting: Vec<Nested>,
}

impl Sequence {
    /// Validates and canonicalises a sequence.
    ///
    /// Checks (each failure names timestep, plane, class and polygon): at least one class, names
    /// non-empty and unique, labels unique; at least one timestep, times finite and strictly
    /// increasing; every timestep has a plane, every plane annotates a class; origin and axes
    /// finite, axes orthonormal within [`AXIS_TOLERANCE`]; region of interest finite and
    /// non-empty; class indices valid and not repeated on a plane; every polygon has ≥ 3
    /// vertices, finite coordinates, no repeated consecutive vertex, non-zero area, lies in the
    /// region of interest; the polygons of one class on one plane neither cross nor touch
    /// (self-intersections are errors, not repaired: any repair would guess the user's intent);
    /// and every class has a contour somewhere.
    ///
    /// Canonical form: a closing vertex equal to the first is dropped (the closing edge is
    /// implicit), and polygons are reoriented by nesting (outer boundaries counter-clockwise,
    /// holes clockwise). Validating a canonical sequence changes nothing, so formats round-trip.
    pub fn new(classes: Vec<ClassInfo>, mut frames: Vec<Frame>) -> Result<Self> {
        validate_classes(&classes)?;
        if frames.is_empty() {
            return Err(ErrorKind::Empty("the sequence has no timestep".into()).into());
        }
        for i in 1..frames.len() {
            let (previous, time) = (frames[i - 1].time, frames[i].time);
            if time.is_finite() && previous.is_finite() && time <= previous {
                return Err(
                    DataError::new(ErrorKind::TimesNotIncreasing { previous, time })
                        .at_frame(i, Some(time)),
                );
            }
        }
        // Frames are independent: validate them in parallel, report the first failure in order.
        let results: Vec<Result<()>> = frames
            .par_iter_mut()
            .enumerate()
            .map(|(i, frame)| {
                let time = frame.time;
                validate_frame(&classes, frame).map_err(|e| e.at_frame(i, Some(time)))
            })
            .collect();
        results.into_iter().collect::<Result<Vec<()>>>()?;
        for (k, class) in classes.iter().enumerate() {
            let contoured = frames.iter().any(|f| {
                f.planes
                    .iter()
                    .any(|p| p.annotation(k).is_some_and(|a| !a.is_absent()))
            });
            if !contoured {
                return Err(DataError::new(ErrorKind::ClassNeverContoured(
                    "nothing to fit; drop the class or add planes that cross it".into(),
                ))
                .for_class(&class.name, class.label));
            }
        }
        Ok(Sequence {
            classes,
            frames,
            nesting: Vec::new(),
        })
    }

    /// The sequence recording that its classes were drawn nested as `pairs` say, its polygons
    /// already disjoint (the outer's with the inner's as holes): the model records the pairs
    /// and its outputs recompose the outer ([`crate::nesting`]). Refuses invalid pairs
    /// ([`crate::nesting::validate`]).
    pub fn with_nesting(mut self, pairs: Vec<Nested>) -> Result<Self> {
        crate::nesting::validate(&pairs, self.classes.len())
            .map_err(|e| DataError::new(ErrorKind::BadClass(e)))?;
        self.nesting = pairs;
        Ok(self)
    }

    /// The classes drawn nested whose polygons were made disjoint ([`Sequence::with_nesting`]);
    /// empty for most inputs.
    pub fn nesting(&self) -> &[Nested] {
        &self.nesting
    }

    /// The classes; class index k is the network's output channel k.
    pub fn classes(&self) -> &[ClassInfo] {
        &self.classes
    }

    /// The timesteps in increasing time.
    pub fn frames(&self) -> &[Frame] {
        &self.frames
    }

    /// Takes the sequence apart (e.g. to edit it and validate again).
    pub fn into_parts(self) -> (Vec<ClassInfo>, Vec<Frame>) {
        (self.classes, self.frames)
    }

    /// First and last timestep times.
    pub fn time_range(&self) -> (f64, f64) {
        (self.frames[0].time, self.frames[self.frames.len() - 1].time)
    }

    /// The world box of every contour vertex (tight; callers add the margin they want).
    pub fn bounding_box(&self) -> Aabb {
        let mut b = Aabb {
            min: [f64::INFINITY; 3],
            max: [f64::NEG_INFINITY; 3],
        };
        for plane in self.frames.iter().flat_map(|f| &f.planes) {
            for p in plane
                .annotations
                .iter()
                .flat_map(|a| a.polygons.iter().flatten())
            {
                grow(&mut b, plane.to_world(*p));
            }
        }
        b
    }

    /// The world box of every plane's region of interest (its four corners).
    pub fn roi_bounding_box(&self) -> Aabb {
        let mut b = Aabb {
            min: [f64::INFINITY; 3],
            max: [f64::NEG_INFINITY; 3],
        };
        for plane in self.frames.iter().flat_map(|f| &f.planes) {
            let (lo, hi) = (plane.roi.min, plane.roi.max);
            for c in [lo, [hi[0], lo[1]], hi, [lo[0], hi[1]]] {
                grow(&mut b, plane.to_world(c));
            }
        }
        b
    }

    /// The sequence of class `class` alone (its name and label kept, as class 0): planes that
    /// do not annotate it and frames left without planes are dropped. For training an
    /// independent per-class model.
    pub fn only_class(&self, class: usize) -> Result<Sequence> {
        let info = self.classes.get(class).cloned().ok_or_else(|| {
            DataError::new(ErrorKind::Empty(format!(
                "there is no class {} among {}",
                class + 1,
                self.classes.len()
            )))
        })?;
        let frames = self
            .frames
            .iter()
            .filter_map(|f| {
                let planes: Vec<Plane> = f
                    .planes
                    .iter()
                    .filter_map(|p| {
                        let a = p.annotation(class)?;
                        Some(Plane {
                            annotations: vec![Annotation {
                                class: 0,
                                polygons: a.polygons.clone(),
                            }],
                            ..p.clone()
                        })
                    })
                    .collect();
                (!planes.is_empty()).then_some(Frame {
                    time: f.time,
                    planes,
                })
            })
            .collect();
        Sequence::new(vec![info], frames)
    }
}

fn grow(b: &mut Aabb, x: [f64; 3]) {
    b.min = std::array::from_fn(|k| b.min[k].min(x[k]));
    b.max = std::array::from_fn(|k| b.max[k].max(x[k]));
}

/// The dot product a·b of two 3-vectors.
pub fn dot(a: [f64; 3], b: [f64; 3]) -> f64 {
    a[0] * b[0] + a[1] * b[1] + a[2] * b[2]
}

/// The cross product a × b of two 3-vectors (right-handed).
pub fn cross(a: [f64; 3], b: [f64; 3]) -> [f64; 3] {
    [
        a[1] * b[2] - a[2] * b[1],
        a[2] * b[0] - a[0] * b[2],
        a[0] * b[1] - a[1] * b[0],
    ]
}

fn validate_classes(classes: &[ClassInfo]) -> Result<()> {
    if classes.is_empty() {
        return Err(ErrorKind::Empty("the sequence has no class".into()).into());
    }
    for (i, c) in classes.iter().enumerate() {
        let at = |kind| DataError::new(kind).for_class(&c.name, c.label);
        if c.name.trim().is_empty() {
            return Err(at(ErrorKind::BadClass(format!(
                "class {i} has an empty name"
            ))));
        }
        if let Some(j) = classes[..i].iter().position(|d| d.name == c.name) {
            return Err(at(ErrorKind::BadClass(format!("same name as class {j}"))));
        }
        if let Some(j) = classes[..i].iter().position(|d| d.label == c.label) {
            return Err(at(ErrorKind::BadClass(format!("same label as class {j}"))));
        }
    }
    Ok(())
}

fn check_finite(what: &str, values: &[f64]) -> Result<()> {
    match values.iter().find(|v| !v.is_finite()) {
        Some(&value) => Err(ErrorKind::NotFinite {
            what: what.into(),
            value,
        }
        .into()),
        None => Ok(()),
    }
}

fn validate_frame(classes: &[ClassInfo], frame: &mut Frame) -> Result<()> {
    check_finite("time", &[frame.time])?;
    if frame.planes.is_empty() {
        return Err(ErrorKind::Empty("the timestep has no plane".into()).into());
    }
    for (pi, plane) in frame.planes.iter_mut().enumerate() {
        validate_plane(classes, plane).map_err(|e| e.at_plane(pi))?;
    }
    Ok(())
}

fn validate_plane(classes: &[ClassInfo], plane: &mut Plane) -> Result<()> {
    check_finite("plane origin", &plane.origin)?;
    check_finite("plane axis u", &plane.u)?;
    check_finite("plane axis v", &plane.v)?;
    let (un, vn, uv) = (
        dot(plane.u, plane.u).sqrt(),
        dot(plane.v, plane.v).sqrt(),
        dot(plane.u, plane.v),
    );
    if (un - 1.0).abs() > AXIS_TOLERANCE
        || (vn - 1.0).abs() > AXIS_TOLERANCE
        || uv.abs() > AXIS_TOLERANCE
    {
        return Err(ErrorKind::AxesNotOrthonormal {
            u_norm: un,
            v_norm: vn,
            dot: uv,
        }
        .into());
    }
    check_finite("region of interest", &[plane.roi.min[0], plane.roi.min[1]])?;
    check_finite("region of interest", &[plane.roi.max[0], plane.roi.max[1]])?;
    if !(plane.roi.min[0] < plane.roi.max[0] && plane.roi.min[1] < plane.roi.max[1]) {
        return Err(ErrorKind::EmptyRoi {
            min: plane.roi.min,
            max: plane.roi.max,
        }
        .into());
    }
    if plane.annotations.is_empty() {
        return Err(ErrorKind::Empty("the plane annotates no class".into()).into());
    }
    let roi = plane.roi;
    for i in 0..plane.annotations.len() {
        let k = plane.annotations[i].class;
        let Some(class) = classes.get(k) else {
            return Err(ErrorKind::BadClass(format!(
                "annotation {i} names class {k}, but there are {} classes",
                classes.len()
            ))
            .into());
        };
        let at = |e: DataError| e.for_class(&class.name, class.label);
        if plane.annotations[..i].iter().any(|a| a.class == k) {
            return Err(at(ErrorKind::BadClass(
                "annotated twice on this plane".into(),
            )
            .into()));
        }
        validate_polygons(&mut plane.annotations[i].polygons, &roi).map_err(at)?;
    }
    Ok(())
}

fn validate_polygons(polys: &mut [Polygon], roi: &Rect) -> Result<()> {
    for (gi, poly) in polys.iter_mut().enumerate() {
        let at = |kind: ErrorKind| DataError::new(kind).at_polygon(gi);
        for (vi, p) in poly.iter().enumerate() {
            check_finite(&format!("vertex {vi}"), p).map_err(|e| e.at_polygon(gi))?;
        }
        if poly.len() > 3 && poly.first() == poly.last() {
            poly.pop();
        }
        if poly.len() < 3 {
            return Err(at(ErrorKind::Degenerate(format!(
                "{} vertices; a closed contour needs at least 3",
                poly.len()
            ))));
        }
        let n = poly.len();
        if let Some(vi) = (0..n).find(|&i| poly[i] == poly[(i + 1) % n]) {
            return Err(at(ErrorKind::Degenerate(format!(
                "vertices {vi} and {} coincide at {:?} (zero-length edge)",
                (vi + 1) % n,
                poly[vi]
            ))));
        }
        if let Some((vi, p)) = poly.iter().enumerate().find(|(_, p)| !roi.contains(**p)) {
            return Err(at(ErrorKind::OutsideRoi {
                vertex: vi,
                point: *p,
            }));
        }
    }
    separate_pinches(polys);
    if let Some(c) = find_crossing(polys) {
        let what = if c.first.0 == c.second.0 {
            format!(
                "edges {} and {} of the polygon cross or touch near {:?}",
                c.first.1, c.second.1, c.near
            )
        } else {
            format!(
                "edge {} crosses or touches edge {} of polygon {} near {:?}",
                c.first.1, c.second.1, c.second.0, c.near
            )
        };
        return Err(DataError::new(ErrorKind::SelfIntersection(what)).at_polygon(c.first.0));
    }
    // Without crossings a zero area needs all vertices collinear, which folds back and is caught
    // above; this guard keeps the orientation step well defined regardless.
    if let Some(gi) = polys.iter().position(|p| signed_area(p) == 0.0) {
        return Err(DataError::new(ErrorKind::Degenerate("zero area".into())).at_polygon(gi));
    }
    orient_by_nesting(polys);
    Ok(())
}

/// Fraction of the shortest incident edge cut off at a pinch vertex (see `separate_pinches`).
pub const PINCH_CUT: f64 = 1e-3;

/// The one repair the validator makes: contours of a class that touch at a *shared vertex*
/// (the same point appearing in two polygons, or twice in one) are separated by cutting the
/// corner at every occurrence: the vertex is replaced by two points on its incident edges at
/// [`PINCH_CUT`] × the shortest incident edge length from it. Real segmentations produce such
/// pinches (upstream `Abdomen.csl` has them), the region they bound is unambiguous, and the cut
/// moves the contour by far less than its sampling; touching anywhere else, and any crossing,
/// remains an error. After the repair the contours no longer share a point, so validation of a
/// repaired sequence changes nothing (formats still round-trip exactly).
fn separate_pinches(polys: &mut [Polygon]) {
    let mut seen: HashMap<[u64; 2], Vec<(usize, usize)>> = HashMap::new();
    for (pi, poly) in polys.iter().enumerate() {
        for (vi, p) in poly.iter().enumerate() {
            seen.entry(p.map(f64::to_bits)).or_default().push((pi, vi));
        }
    }
    // Per polygon, the cut vertices and their cut lengths.
    let mut cuts: Vec<Vec<(usize, f64)>> = vec![Vec::new(); polys.len()];
    for occurrences in seen.values().filter(|o| o.len() > 1) {
        let shortest = occurrences
            .iter()
            .map(|&(pi, vi)| {
                let poly = &polys[pi];
                let n = poly.len();
                let v = poly[vi];
                let len = |q: Point2| (q[0] - v[0]).hypot(q[1] - v[1]);
                len(poly[(vi + n - 1) % n]).min(len(poly[(vi + 1) % n]))
            })
            .fold(f64::INFINITY, f64::min);
        for &(pi, vi) in occurrences {
            cuts[pi].push((vi, PINCH_CUT * shortest));
        }
    }
    // Each cut polygon is rebuilt in one pass (inserting at every cut would cost O(n) a cut).
    for (poly, mut cuts) in polys.iter_mut().zip(cuts) {
        if cuts.is_empty() {
            continue;
        }
        cuts.sort_by_key(|c| c.0);
        let n = poly.len();
        let mut cut = cuts.into_iter().peekable();
        let mut out = Vec::with_capacity(n + cut.len());
        for (vi, &v) in poly.iter().enumerate() {
            let Some((_, d)) = cut.next_if(|c| c.0 == vi) else {
                out.push(v);
                continue;
            };
            let toward = |q: Point2| {
                let len = (q[0] - v[0]).hypot(q[1] - v[1]);
                [
                    v[0] + d * (q[0] - v[0]) / len,
                    v[1] + d * (q[1] - v[1]) / len,
                ]
            };
            out.push(toward(poly[(vi + n - 1) % n]));
            out.push(toward(poly[(vi + 1) % n]));
        }
        *poly = out;
    }
}
