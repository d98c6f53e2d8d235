//! Classes drawn one inside another (`dynaslice_sequence::nesting`): found from the contours,
//! and made disjoint for training.
//!
//! # Detection
//! Class i is nested in class o when, on the planes that draw both, i's region lies within
//! o's: on each such plane at most [`PLANE_TOLERANCE`] of i's area lies outside o (hand-drawn
//! contours of a shared wall cross it by a pixel or two), and at least [`DATA_FRACTION`] of the
//! planes that draw i and annotate o are such planes (a plane that draws i where o is annotated
//! absent counts against). Where it holds on most planes but not all, the pair is still taken
//! as nested and a warning names the worst plane; where two classes overlap on some plane
//! without one holding the other, a warning says that Eq. 11 gives the overlap to one of them.
//! Of several classes holding i, the innermost (the one held by most others) is its direct
//! outer, so GTV ⊂ CTV ⊂ PTV is a chain.
//!
//! # Disjoint regions
//! On every plane that draws both, the direct outer's polygons become its region minus the
//! inner's whole region ([`dynaslice_geometry::boolean::difference`]: for an inner strictly
//! inside, the inner's rings become the outer's holes, read by the even-odd rule as every
//! reader here does), and an outer left without area there is annotated absent. The sequence
//! records the pairs ([`Sequence::with_nesting`]); the model records them in its metadata, and
//! the outputs read as whole structures (volumes, RT Structure Sets) recompose the outer.

use std::fmt;
use std::str::FromStr;

use dynaslice_geometry::boolean::{difference, intersection, region_area};
use dynaslice_geometry::Polygon;
use dynaslice_sequence::error::{DataError, ErrorKind, Result};
use dynaslice_sequence::nesting::validate;
pub use dynaslice_sequence::nesting::{from_labels, to_labels, whole_structures, Nested};
use dynaslice_sequence::sequence::{Frame, Sequence};
use dynaslice_sequence::ClassInfo;

/// Largest fraction of the inner's area on a plane that may lie outside the outer for the
/// plane to count as nested: hand-drawn walls are crossed by a pixel's width, about 1 % of a
/// 30 mm cavity's area at 1.5 mm pixels.
pub const PLANE_TOLERANCE: f64 = 0.02;

/// Smallest fraction of the planes drawing the inner (and annotating the outer) that must be
/// nested for the pair to be nested over the data.
pub const DATA_FRACTION: f64 = 0.8;

/// How nested classes are treated when reading inputs.
#[derive(Debug, Clone, Default, PartialEq, Eq)]
pub enum NestingMode {
    /// Detect nesting from the contours (see the [module docs](self)).
    #[default]
    Auto,
    /// Train every class on its contours as drawn (Eq. 11 then splits overlaps).
    Off,
    /// These (inner label, outer label) pairs, checked against the contours.
    Pairs(Vec<(i32, i32)>),
}

impl fmt::Display for NestingMode {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            NestingMode::Auto => f.write_str("auto"),
            NestingMode::Off => f.write_str("off"),
            NestingMode::Pairs(p) => {
                let v: Vec<String> = p.iter().map(|(i, o)| format!("{i}:{o}")).collect();
                f.write_str(&v.join(","))
            }
        }
    }
}

impl FromStr for NestingMode {
    type Err = String;

    /// `auto`, `off`, or `INNER:OUTER[,INNER:OUTER…]` by label.
    fn from_str(s: &str) -> std::result::Result<Self, String> {
        match s.trim() {
            "auto" => return Ok(NestingMode::Auto),
            "off" => return Ok(NestingMode::Off),
            _ => {}
        }
        let bad =
            || format!("expected `auto`, `off` or INNER:OUTER label pairs (2:1,4:3), found `{s}`");
        s.split(',')
            .map(|pair| {
                let (i, o) = pair.trim().split_once(':').ok_or_else(bad)?;
                Ok((
                    i.trim().parse().map_err(|_| bad())?,
                    o.trim().parse().map_err(|_| bad())?,
                ))
            })
            .collect::<std::result::Result<Vec<_>, String>>()
            .map(NestingMode::Pairs)
    }
}

/// How class `inner` sits in class `outer` over a sequence's planes.
#[derive(Debug, Clone, PartialEq)]
pub struct Containment {
    /// The class inside.
    pub inner: usize,
    /// The class around it.
    pub outer: usize,
    /// Planes drawing the inner and annotating the outer (drawn or absent).
    pub planes: usize,
    /// Of those, the planes where the inner lies within the outer ([`PLANE_TOLERANCE`]).
    pub nested: usize,
    /// Planes where the two regions share area.
    pub overlapping: usize,
    /// The plane with the largest fraction of the inner outside the outer: (frame, plane,
    /// fraction).
    pub worst: (usize, usize, f64),
    /// The inner's area on the planes drawing both.
    pub inner_area: f64,
    /// The outer's area on the planes drawing both.
    pub outer_area: f64,
}

impl Containment {
    /// Whether the inner is nested in the outer over the data ([`DATA_FRACTION`]).
    pub fn holds(&self) -> bool {
        self.nested > 0 && self.nested as f64 >= DATA_FRACTION * self.planes as f64
    }
}

/// Whether the bounding boxes of two regions' vertices overlap with positive area.
fn boxes_overlap(a: &[Polygon], b: &[Polygon]) -> bool {
    let bounds = |polygons: &[Polygon]| {
        polygons.iter().flatten().fold(
            ([f64::INFINITY; 2], [f64::NEG_INFINITY; 2]),
            |(lo, hi), p| {
                (
                    [lo[0].min(p[0]), lo[1].min(p[1])],
                    [hi[0].max(p[0]), hi[1].max(p[1])],
                )
            },
        )
    };
    let ((alo, ahi), (blo, bhi)) = (bounds(a), bounds(b));
    (0..2).all(|k| alo[k] < bhi[k] && blo[k] < ahi[k])
}

/// Every ordered pair of classes whose regions share area on some plane, with how the first
/// sits in the second.
pub fn containments(seq: &Sequence) -> Vec<Containment> {
    let k = seq.classes().len();
    let mut out = Vec::new();
    for inner in 0..k {
        for outer in (0..k).filter(|&o| o != inner) {
            let mut c = Containment {
                inner,
                outer,
                planes: 0,
                nested: 0,
                overlapping: 0,
                worst: (0, 0, 0.0),
                inner_area: 0.0,
                outer_area: 0.0,
            };
            for (fi, frame) in seq.frames().iter().enumerate() {
                for (pi, plane) in frame.planes.iter().enumerate() {
                    let (Some(i), Some(o)) = (plane.annotation(inner), plane.annotation(outer))
                    else {
                        continue;
                    };
                    if i.is_absent() {
                        continue;
                    }
                    c.planes += 1;
                    let area = region_area(&i.polygons);
                    let shared = if o.is_absent() {
                        0.0
                    } else {
                        c.inner_area += area;
                        c.outer_area += region_area(&o.polygons);
                        // Regions whose boxes do not overlap share no area: no boolean
                        // operation for them (most pairs of many classes).
                        if boxes_overlap(&i.polygons, &o.polygons) {
                            intersection(&i.polygons, &o.polygons).map_or(0.0, |r| region_area(&r))
                        } else {
                            0.0
                        }
                    };
                    let outside = ((area - shared) / area).clamp(0.0, 1.0);
                    if outside <= PLANE_TOLERANCE {
                        c.nested += 1;
                    }
                    if shared > 0.0 {
                        c.overlapping += 1;
                    }
                    if outside > c.worst.2 || c.planes == 1 {
                        c.worst = (fi, pi, outside);
                    }
                }
            }
            if c.overlapping > 0 {
                out.push(c);
            }
        }
    }
    out
}

fn name(classes: &[ClassInfo], k: usize) -> String {
    format!("\"{}\" (label {})", classes[k].name, classes[k].label)
}

/// The nested pairs of `seq` (each inner with its direct outer), and the warnings a user should
/// read: pairs nested on most planes but not all, and classes overlapping without nesting.
pub fn detect(seq: &Sequence) -> (Vec<Nested>, Vec<String>) {
    let classes = seq.classes();
    let all = containments(seq);
    let mut warnings = Vec::new();
    // Nested pairs; of two classes each "holding" the other (drawn alike), the smaller is inside.
    let holds: Vec<&Containment> = all
        .iter()
        .filter(|c| c.holds())
        .filter(|c| {
            let mutual = all
                .iter()
                .find(|d| d.inner == c.outer && d.outer == c.inner && d.holds());
            match mutual {
                Some(d) if d.inner_area < c.inner_area => false,
                Some(d) if d.inner_area == c.inner_area => {
                    if c.inner < c.outer {
                        warnings.push(format!(
                            "{} and {} are drawn alike on every plane both are drawn on; they \
                             are trained as drawn (not nested)",
                            name(classes, c.inner),
                            name(classes, c.outer)
                        ));
                    }
                    false
                }
                _ => true,
            }
        })
        .collect();
    for c in &all {
        let (fi, pi, outside) = c.worst;
        if holds
            .iter()
            .any(|h| h.inner == c.inner && h.outer == c.outer)
        {
            if c.nested < c.planes {
                warnings.push(format!(
                    "{} lies inside {} on {} of the {} planes that draw it, not on the rest \
                     (worst: timestep {fi}, plane {pi}, {:.0} % of it outside); trained as \
                     nested: the outer gives up only what they share",
                    name(classes, c.inner),
                    name(classes, c.outer),
                    c.nested,
                    c.planes,
                    100.0 * outside
                ));
            }
        } else if c.inner < c.outer
            && !holds
                .iter()
                .any(|h| h.inner == c.outer && h.outer == c.inner)
        {
            warnings.push(format!(
                "{} and {} overlap on {} planes without one lying inside the other (timestep \
                 {fi}, plane {pi}: {:.0} % of the first outside the second); Eq. 11 gives each \
                 point of the overlap to one of them",
                name(classes, c.inner),
                name(classes, c.outer),
                c.overlapping,
                100.0 * outside
            ));
        }
    }
    // Direct outer: of the classes holding i, the one held by the most others.
    let depth = |k: usize| holds.iter().filter(|h| h.inner == k).count();
    let mut pairs: Vec<Nested> = Vec::new();
    for inner in 0..classes.len() {
        let direct = holds
            .iter()
            .filter(|h| h.inner == inner)
            .max_by_key(|h| (depth(h.outer), std::cmp::Reverse(h.outer)));
        if let Some(h) = direct {
            pairs.push(Nested {
                inner,
                outer: h.outer,
            });
        }
    }
    (pairs, warnings)
}

/// `seq` with every outer of `pairs` made its region minus its direct inners' (see the
/// [module docs](self#disjoint-regions)), recording `pairs`.
pub fn disjoin(seq: &Sequence, pairs: &[Nested]) -> Result<Sequence> {
    validate(pairs, seq.classes().len()).map_err(|e| DataError::new(ErrorKind::Option(e)))?;
    if pairs.is_empty() {
        return Ok(seq.clone());
    }
    let classes = seq.classes().to_vec();
    let frames: Vec<Frame> = seq
        .frames()
        .iter()
        .enumerate()
        .map(|(fi, frame)| {
            let mut frame = frame.clone();
            for (pi, plane) in frame.planes.iter_mut().enumerate() {
                let original = plane.annotations.clone();
                for a in plane.annotations.iter_mut().filter(|a| !a.is_absent()) {
                    let inners: Vec<_> = pairs
                        .iter()
                        .filter(|p| p.outer == a.class)
                        .filter_map(|p| original.iter().find(|o| o.class == p.inner))
                        .flat_map(|o| o.polygons.iter().cloned())
                        .collect();
                    if inners.is_empty() {
                        continue;
                    }
                    a.polygons = difference(&a.polygons, &inners).ok_or_else(|| {
                        DataError::new(ErrorKind::Option(format!(
                            "timestep {fi}, plane {pi}: the contours of {} cannot be cut by \
                             those inside it (a coordinate beyond ±1e150)",
                            name(&classes, a.class)
                        )))
                    })?;
                }
            }
            Ok(frame)
        })
        .collect::<Result<_>>()?;
    Sequence::new(classes, frames)?.with_nesting(pairs.to_vec())
}

/// `seq` as `mode` asks: nesting detected (or the given pairs checked), warnings logged, and
/// the nested classes made disjoint ([`disjoin`]); `seq` itself with [`NestingMode::Off`] or
/// where nothing is nested.
pub fn apply(seq: Sequence, mode: &NestingMode) -> Result<Sequence> {
    let classes = seq.classes();
    let pairs = match mode {
        NestingMode::Off => return Ok(seq),
        NestingMode::Auto => {
            let (pairs, warnings) = detect(&seq);
            for w in warnings {
                log::warn!("{w}");
            }
            pairs
        }
        NestingMode::Pairs(labels) => {
            let index = |label: i32| {
                classes
                    .iter()
                    .position(|c| c.label == label)
                    .ok_or_else(|| {
                        DataError::new(ErrorKind::Option(format!(
                            "--nesting names label {label}, which no class of the input has"
                        )))
                    })
            };
            let pairs = labels
                .iter()
                .map(|&(i, o)| {
                    Ok(Nested {
                        inner: index(i)?,
                        outer: index(o)?,
                    })
                })
                .collect::<Result<Vec<_>>>()?;
            let found = containments(&seq);
            for p in &pairs {
                let held = found
                    .iter()
                    .find(|c| c.inner == p.inner && c.outer == p.outer);
                if !held.is_some_and(Containment::holds) {
                    log::warn!(
                        "--nesting: {} does not lie inside {} on most planes drawing both; \
                         trained as nested as asked",
                        name(classes, p.inner),
                        name(classes, p.outer)
                    );
                }
            }
            pairs
        }
    };
    if pairs.is_empty() {
        return Ok(seq);
    }
    // Said as a warning: the structures are trained otherwise than drawn, which a user must
    // know (and can turn off).
    for p in &pairs {
        log::warn!(
            "{} is drawn inside {}: trained as disjoint regions ({} as its region minus {}'s), \
             recomposed in volumes and RT Structure Sets (--nesting off to train them as drawn)",
            name(classes, p.inner),
            name(classes, p.outer),
            classes[p.outer].name,
            classes[p.inner].name
        );
    }
    disjoin(&seq, &pairs)
}

#[cfg(test)]
mod tests {
    use super::*;
    use dynaslice_sequence::{Annotation, Plane, Rect};
    use std::f64::consts::TAU;

    fn circle(c: [f64; 2], r: f64) -> Vec<[f64; 2]> {
        (0..48)
            .map(|i| {
                let a = TAU * i as f64 / 48.0;
                [c[0] + r * a.cos(), c[1] + r * a.sin()]
            })
            .collect()
    }

    fn plane(z: f64, annotations: Vec<Annotation>) -> Plane {
        Plane {
            origin: [0.0, 0.0, z],
            u: [1.0, 0.0, 0.0],
            v: [0.0, 1.0, 0.0],
            roi: Rect {
                min: [-50.0; 2],
                max: [50.0; 2],
            },
            annotations,
        }
    }

    fn class(name: &str, label: i32) -> ClassInfo {
        ClassInfo {
            name: name.into(),
            label,
            color: None,
        }
    }

    /// Epicardium (class 0) around an endocardium (class 1) on five planes, the endocardium
    /// shifted by `shift` on the middle plane; a separate structure (class 2) overlapping the
    /// epicardium on one plane.
    fn heart(shift: f64) -> Sequence {
        let planes = (0..5)
            .map(|z| {
                let s = if z == 2 { shift } else { 0.0 };
                let mut a = vec![
                    Annotation {
                        class: 0,
                        polygons: vec![circle([0.0, 0.0], 20.0)],
                    },
                    Annotation {
                        class: 1,
                        polygons: vec![circle([s, 0.0], 12.0)],
                    },
                ];
                a.push(Annotation {
                    class: 2,
                    polygons: if z == 4 {
                        vec![circle([25.0, 0.0], 8.0)]
                    } else {
                        vec![]
                    },
                });
                plane(z as f64 * 10.0, a)
            })
            .collect();
        Sequence::new(
            vec![class("epi", 1), class("endo", 2), class("rv", 3)],
            vec![Frame { time: 0.0, planes }],
        )
        .unwrap()
    }

    #[test]
    fn an_endocardium_inside_its_epicardium_is_found_and_cut_out() {
        let seq = heart(0.0);
        let (pairs, warnings) = detect(&seq);
        assert_eq!(pairs, [Nested { inner: 1, outer: 0 }]);
        assert_eq!(warnings.len(), 1, "{warnings:?}");
        assert!(warnings[0].contains("\"epi\"") && warnings[0].contains("overlap"));
        let cut = apply(seq.clone(), &NestingMode::Auto).unwrap();
        assert_eq!(cut.nesting(), pairs);
        for (before, after) in seq.frames()[0].planes.iter().zip(&cut.frames()[0].planes) {
            let ring = &after.annotation(0).unwrap().polygons;
            assert_eq!(
                ring.len(),
                2,
                "the epicardium gets the endocardium as its hole"
            );
            let whole = region_area(&before.annotation(0).unwrap().polygons);
            let cavity = region_area(&before.annotation(1).unwrap().polygons);
            assert!((region_area(ring) - (whole - cavity)).abs() < 1e-9 * whole);
            assert_eq!(after.annotation(1), before.annotation(1));
        }
        let off = apply(seq.clone(), &NestingMode::Off).unwrap();
        assert_eq!(off, seq);
    }

    #[test]
    fn nesting_that_holds_on_most_planes_warns_and_cuts_only_the_overlap() {
        // The endocardium crosses the epicardium on the middle plane.
        let seq = heart(12.0);
        let (pairs, warnings) = detect(&seq);
        assert_eq!(pairs, [Nested { inner: 1, outer: 0 }]);
        let partial = warnings
            .iter()
            .find(|w| w.contains("on 4 of the 5 planes"))
            .unwrap_or_else(|| panic!("{warnings:?}"));
        assert!(partial.contains("timestep 0, plane 2"), "{partial}");
        let cut = disjoin(&seq, &pairs).unwrap();
        let p = &seq.frames()[0].planes[2];
        let shared = intersection(
            &p.annotation(1).unwrap().polygons,
            &p.annotation(0).unwrap().polygons,
        )
        .unwrap();
        let rest = &cut.frames()[0].planes[2].annotation(0).unwrap().polygons;
        let whole = region_area(&p.annotation(0).unwrap().polygons);
        assert!((region_area(rest) - (whole - region_area(&shared))).abs() < 1e-9 * whole);
    }

    #[test]
    fn chains_get_their_direct_outer_and_modes_parse() {
        // PTV ⊃ CTV ⊃ GTV on three planes.
        let planes = (0..3)
            .map(|z| {
                let a = [(0, 30.0), (1, 20.0), (2, 10.0)]
                    .into_iter()
                    .map(|(k, r)| Annotation {
                        class: k,
                        polygons: vec![circle([0.0, 0.0], r)],
                    })
                    .collect();
                plane(z as f64, a)
            })
            .collect();
        let seq = Sequence::new(
            vec![class("PTV", 5), class("CTV", 6), class("GTV", 7)],
            vec![Frame { time: 0.0, planes }],
        )
        .unwrap();
        let (pairs, warnings) = detect(&seq);
        assert!(warnings.is_empty(), "{warnings:?}");
        assert_eq!(
            pairs,
            [Nested { inner: 1, outer: 0 }, Nested { inner: 2, outer: 1 }]
        );
        let cut = apply(seq.clone(), &"7:6,6:5".parse().unwrap()).unwrap();
        let a = |k| region_area(&cut.frames()[0].planes[0].annotation(k).unwrap().polygons);
        let disc = |r: f64| region_area(&[circle([0.0, 0.0], r)]);
        assert!((a(0) - (disc(30.0) - disc(20.0))).abs() < 1e-9);
        assert!((a(1) - (disc(20.0) - disc(10.0))).abs() < 1e-9);
        assert_eq!("off".parse::<NestingMode>().unwrap(), NestingMode::Off);
        assert!("2-1"
            .parse::<NestingMode>()
            .unwrap_err()
            .contains("INNER:OUTER"));
        assert_eq!(
            NestingMode::Pairs(vec![(7, 6), (6, 5)]).to_string(),
            "7:6,6:5"
        );
        let e = apply(seq, &"9:5".parse().unwrap()).unwrap_err();
        assert!(e.to_string().contains("label 9"), "{e}");
    }
}
