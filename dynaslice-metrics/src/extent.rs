//! Classes whose extent or volume the data does not support: a surface reaching far past its
//! class's contours (a kidney 100 mm beyond the imaged slab), a volume larger than the box its
//! contours span allows, a surface cut by the edge of the model's domain. A network fitted to
//! sparse planes can grow such spurious structure where no plane constrains it, and no loss
//! term reports it; these checks do, from the model's meshes against what the data shows.
//!
//! - [`class_extents`]: each class's surface box (over a set of times) and largest volume.
//! - [`against_contours`]: with the training input, each class against its own contours' box.
//! - [`against_domain`]: with the model alone, against the domain box it records (the data's
//!   box plus a margin, [`dynaslice_train`'s `domain_for`]): a surface touching its faces is cut
//!   there, beyond every plane of the data.
//! - [`check_model`]: both, for a model and the input it was trained on (after training).
//!
//! World coordinates are the model's (RAS, mm for medical inputs; docs/data-format.md).

use anyhow::{bail, Result};
use dynaslice_core::Model;
use dynaslice_data::{Aabb, Sequence};
use dynaslice_mesh::{self as mesh, Surfaces};
use std::fmt;

/// Lattice cells along the longest axis of the domain for the check's meshes: enough to place a
/// surface to a few percent of the domain, cheap enough for `dynaslice info` (seconds).
pub const DEFAULT_RESOLUTION: u32 = 64;

/// A class's surface over a set of times.
#[derive(Debug, Clone, PartialEq)]
pub struct ClassExtent {
    /// The class's channel (0-based).
    pub class: usize,
    /// Its name.
    pub name: String,
    /// The box of its surface's vertices at every time (`None`: no surface at any time).
    pub bounds: Option<Aabb>,
    /// Its largest enclosed volume over the times (world units cubed).
    pub volume: f64,
}

/// Each class's surface box and largest volume over `times`, from the boundaries of the Eq. 11
/// partition (the classes of `dynaslice labels`) at `resolution` cells along the longest axis
/// of the model's domain. `progress` gets the number of times done after each.
pub fn class_extents(
    model: &Model,
    times: &[f32],
    resolution: u32,
    mut progress: impl FnMut(usize),
) -> Result<Vec<ClassExtent>> {
    let classes: Vec<usize> = (0..model.num_classes()).collect();
    let options = mesh::Options {
        resolution,
        surfaces: Surfaces::Partition,
        ..mesh::Options::default()
    };
    let mut extents: Vec<ClassExtent> = model
        .classes()
        .enumerate()
        .map(|(class, c)| ClassExtent {
            class,
            name: c.name.to_string(),
            bounds: None,
            volume: 0.0,
        })
        .collect();
    for (i, &t) in times.iter().enumerate() {
        let x = mesh::extract(model, model.domain().bounds(), t, &classes, &options)?;
        for (e, m) in extents.iter_mut().zip(&x.meshes) {
            for p in &m.positions {
                grow(&mut e.bounds, p.map(f64::from));
            }
            e.volume = e.volume.max(m.enclosed_volume());
        }
        progress(i + 1);
    }
    Ok(extents)
}

fn grow(b: &mut Option<Aabb>, p: [f64; 3]) {
    let b = b.get_or_insert(Aabb { min: p, max: p });
    b.min = std::array::from_fn(|a| b.min[a].min(p[a]));
    b.max = std::array::from_fn(|a| b.max[a].max(p[a]));
}

/// The world box of each class's contour vertices over every frame and plane of `seq`, in the
/// order of its classes (`None` only for a class with no contour anywhere, which a validated
/// sequence does not have).
pub fn contour_bounds(seq: &Sequence) -> Vec<Option<Aabb>> {
    let mut boxes = vec![None; seq.classes().len()];
    for plane in seq.frames().iter().flat_map(|f| &f.planes) {
        for a in &plane.annotations {
            for p in a.polygons.iter().flatten() {
                grow(&mut boxes[a.class], plane.to_world(*p));
            }
        }
    }
    boxes
}

/// How far past its contours a class may go before it is reported.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Tolerance {
    /// Reach past the contours' box, as a fraction of that box's longest side: between planes
    /// and beyond the outermost one a structure legitimately extends some way (a kidney whose
    /// contours span 110 mm may end 20 mm past its last plane), so only far more is reported.
    pub reach: f64,
    /// Volume as a multiple of the contours' box's volume: a structure inside its box has at
    /// most the box's volume.
    pub volume: f64,
}

/// The defaults: half the contours' longest side, twice the box's volume.
pub const DEFAULT_TOLERANCE: Tolerance = Tolerance {
    reach: 0.5,
    volume: 2.0,
};

/// What about a class the data does not support.
#[derive(Debug, Clone, PartialEq)]
pub enum Problem {
    /// Its surface reaches `by` past its contours' box (on the side `side`, e.g. `z+`), more
    /// than the tolerance `allowed`.
    PastContours {
        /// How far past, world units.
        by: f64,
        /// Which side: an axis and a sign, `x-` … `z+`.
        side: &'static str,
        /// The reach the tolerance allows.
        allowed: f64,
    },
    /// Its volume is `ratio` times its contours' box's volume (more than the tolerance).
    LargerThanContours {
        /// Its largest volume, world units cubed.
        volume: f64,
        /// The contours' box's volume.
        box_volume: f64,
    },
    /// Its surface touches the model domain's faces `sides`: it is cut there, past every plane
    /// of the data.
    AtDomainEdge {
        /// The faces touched, `x-` … `z+`.
        sides: Vec<&'static str>,
    },
}

/// A class the data does not support, and why.
#[derive(Debug, Clone, PartialEq)]
pub struct Warning {
    /// The class's channel (0-based).
    pub class: usize,
    /// Its name.
    pub name: String,
    /// What is wrong.
    pub problem: Problem,
}

impl fmt::Display for Warning {
    fn fmt(&self, f: &mut fmt::Formatter) -> fmt::Result {
        write!(f, "class {} {:?}: ", self.class + 1, self.name)?;
        match &self.problem {
            Problem::PastContours { by, side, allowed } => write!(
                f,
                "its surface reaches {by:.1} mm past its contours' extent (side {side}; \
                 up to {allowed:.1} is expected between and beyond planes): likely spurious \
                 structure where no plane constrains it"
            ),
            Problem::LargerThanContours { volume, box_volume } => write!(
                f,
                "its volume {volume:.1} mm³ is {:.1}× that of the box its contours span \
                 ({box_volume:.1} mm³): the data does not support it",
                volume / box_volume
            ),
            Problem::AtDomainEdge { sides } => write!(
                f,
                "its surface reaches the edge of the model's domain ({}), past every plane of \
                 the data, and is cut there: likely spurious structure where no plane \
                 constrains it",
                sides.join(", ")
            ),
        }
    }
}

const SIDES: [[&str; 2]; 3] = [["x-", "x+"], ["y-", "y+"], ["z-", "z+"]];

/// Each class of `extents` against its contours' box `contours[class]` (from
/// [`contour_bounds`]; the same classes in the same order): reported where its surface reaches
/// past the box by more than `tolerance.reach` of the box's longest side, or where its volume is
/// more than `tolerance.volume` times the box's (boxes flat along an axis, a single plane's
/// contours, are not compared by volume).
pub fn against_contours(
    extents: &[ClassExtent],
    contours: &[Option<Aabb>],
    tolerance: Tolerance,
) -> Result<Vec<Warning>> {
    if extents.len() != contours.len() {
        bail!(
            "the model has {} classes, but the data has {}",
            extents.len(),
            contours.len()
        );
    }
    let mut warnings = Vec::new();
    for (e, c) in extents.iter().zip(contours) {
        let Some(surface) = e.bounds else { continue };
        let warn = |problem| Warning {
            class: e.class,
            name: e.name.clone(),
            problem,
        };
        // A sequence contours every class somewhere (its readers refuse one that is not).
        let Some(c) = c else { continue };
        let sides: [f64; 3] = std::array::from_fn(|a| c.max[a] - c.min[a]);
        let longest = sides.iter().copied().fold(0.0, f64::max);
        let allowed = tolerance.reach * longest;
        let (by, side) = (0..3)
            .flat_map(|a| {
                [
                    (c.min[a] - surface.min[a], SIDES[a][0]),
                    (surface.max[a] - c.max[a], SIDES[a][1]),
                ]
            })
            .fold(
                (f64::NEG_INFINITY, ""),
                |m, x| if x.0 > m.0 { x } else { m },
            );
        if by > allowed {
            warnings.push(warn(Problem::PastContours { by, side, allowed }));
        }
        let box_volume: f64 = sides.iter().product();
        let flat = sides.iter().any(|&s| s < 0.01 * longest);
        if !flat && e.volume > tolerance.volume * box_volume {
            warnings.push(warn(Problem::LargerThanContours {
                volume: e.volume,
                box_volume,
            }));
        }
    }
    Ok(warnings)
}

/// Each class of `extents` against the domain box `model` records (the data's box plus a
/// margin): reported where its surface comes within `cell` (the meshing lattice's cell) of a
/// face, that is where it is cut by the domain, past every plane of the data. What the model
/// alone allows: its file records neither the contours nor the data's exact box.
pub fn against_domain(extents: &[ClassExtent], model: &Model, cell: f64) -> Vec<Warning> {
    let (lo, hi) = model.domain().bounds();
    extents
        .iter()
        .filter_map(|e| {
            let b = e.bounds?;
            let sides: Vec<&'static str> = (0..3)
                .flat_map(|a| {
                    [
                        (b.min[a] <= f64::from(lo[a]) + cell, SIDES[a][0]),
                        (b.max[a] >= f64::from(hi[a]) - cell, SIDES[a][1]),
                    ]
                })
                .filter_map(|(touches, side)| touches.then_some(side))
                .collect();
            (!sides.is_empty()).then(|| Warning {
                class: e.class,
                name: e.name.clone(),
                problem: Problem::AtDomainEdge { sides },
            })
        })
        .collect()
}

/// The lattice cell of [`class_extents`] at `resolution` over `model`'s domain.
pub fn cell(model: &Model, resolution: u32) -> f64 {
    let (lo, hi) = model.domain().bounds();
    let longest = (0..3).map(|a| hi[a] - lo[a]).fold(0.0f32, f32::max);
    f64::from(longest) / f64::from(resolution.max(1))
}

/// Times [`check`] meshes at most.
pub const CHECK_FRAMES: usize = 5;

/// The times the extent check meshes `model` at: a static model's one time; else up to
/// [`CHECK_FRAMES`] frame times of its input `seq` where given, evenly spread (first and last
/// included: a cycle's spurious structure shows at any of its frames), or [`CHECK_FRAMES`]
/// times evenly over the model's time range without it.
pub fn check_times(model: &Model, seq: Option<&Sequence>) -> Vec<f32> {
    let (t0, t1) = model.domain().time_range();
    if model.is_static() {
        return vec![t0];
    }
    let Some(seq) = seq else {
        return (0..CHECK_FRAMES)
            .map(|i| t0 + (t1 - t0) * i as f32 / (CHECK_FRAMES - 1) as f32)
            .collect();
    };
    let times: Vec<f32> = seq.frames().iter().map(|f| f.time as f32).collect();
    if times.len() <= CHECK_FRAMES {
        return times;
    }
    let n = times.len() - 1;
    (0..CHECK_FRAMES)
        .map(|i| times[i * n / (CHECK_FRAMES - 1)])
        .collect()
}

/// The checks of a model, with the input `seq` it was trained on where given (the same
/// classes in the same order): its classes' surfaces at [`check_times`] at
/// [`DEFAULT_RESOLUTION`], against their contours ([`against_contours`] with
/// [`DEFAULT_TOLERANCE`], only with `seq`) and the domain's edge ([`against_domain`]). What
/// training reports after the run and `dynaslice info` (with or without the input) prints.
/// `progress` is called with (times meshed, times to mesh) before the first and after each.
/// Returns the times checked and the warnings.
pub fn check(
    model: &Model,
    seq: Option<&Sequence>,
    mut progress: impl FnMut(usize, usize),
) -> Result<(Vec<f32>, Vec<Warning>)> {
    let times = check_times(model, seq);
    let total = times.len();
    progress(0, total);
    let extents = class_extents(model, &times, DEFAULT_RESOLUTION, |i| progress(i, total))?;
    let mut warnings = match seq {
        Some(seq) => against_contours(&extents, &contour_bounds(seq), DEFAULT_TOLERANCE)?,
        None => Vec::new(),
    };
    warnings.extend(against_domain(
        &extents,
        model,
        cell(model, DEFAULT_RESOLUTION),
    ));
    Ok((times, warnings))
}

/// [`check`] with the input: the warnings after training.
pub fn check_model(
    model: &Model,
    seq: &Sequence,
    progress: impl FnMut(usize, usize),
) -> Result<Vec<Warning>> {
    check(model, Some(seq), progress).map(|(_, warnings)| warnings)
}

#[cfg(test)]
mod tests {
    use super::*;
    use dynaslice_data::{Annotation, ClassInfo, Frame, Plane, Rect};
    use dynaslice_test_support::spheres::{self, Sphere, SPHERES_DOMAIN};

    /// An axial plane at height `z` with a square contour of half-side `r` around (cx, cy) for
    /// class 0 and one for class 1 at (cx2, cy2).
    fn plane(z: f64, squares: &[(usize, [f64; 2], f64)]) -> Plane {
        Plane {
            origin: [0.0, 0.0, z],
            u: [1.0, 0.0, 0.0],
            v: [0.0, 1.0, 0.0],
            roi: Rect {
                min: [-100.0, -100.0],
                max: [100.0, 100.0],
            },
            annotations: squares
                .iter()
                .map(|&(class, c, r)| Annotation {
                    class,
                    polygons: vec![vec![
                        [c[0] - r, c[1] - r],
                        [c[0] + r, c[1] - r],
                        [c[0] + r, c[1] + r],
                        [c[0] - r, c[1] + r],
                    ]],
                })
                .collect(),
        }
    }

    fn extent(class: usize, min: [f64; 3], max: [f64; 3], volume: f64) -> ClassExtent {
        ClassExtent {
            class,
            name: format!("c{class}"),
            bounds: Some(Aabb { min, max }),
            volume,
        }
    }

    /// The check meshes a moving model at up to 5 of its input's frame times (first and last
    /// included), or 5 times over its range without the input; a static model at its one time.
    #[test]
    fn check_times_follow_the_input_or_the_range() {
        let bytes = spheres::model(&[Sphere::new([0.0; 3], 0.5, 0.0)], &[("a", 1)]);
        let model = Model::from_bytes(&bytes).unwrap();
        let (t0, t1) = model.domain().time_range();
        let over_range = check_times(&model, None);
        assert_eq!(over_range.len(), CHECK_FRAMES);
        assert_eq!((over_range[0], over_range[CHECK_FRAMES - 1]), (t0, t1));
        let input = |n: usize| {
            let class = ClassInfo {
                name: "a".into(),
                label: 1,
                color: None,
            };
            let frames = (0..n)
                .map(|i| Frame {
                    time: i as f64,
                    planes: vec![plane(0.0, &[(0, [0.0, 0.0], 5.0)])],
                })
                .collect();
            Sequence::new(vec![class], frames).unwrap()
        };
        assert_eq!(check_times(&model, Some(&input(3))), [0.0, 1.0, 2.0]);
        assert_eq!(
            check_times(&model, Some(&input(9))),
            [0.0, 2.0, 4.0, 6.0, 8.0]
        );
        let mut w = spheres::writer_in(
            SPHERES_DOMAIN,
            &[Sphere::new([0.0; 3], 0.5, 0.0)],
            &[("a", 1)],
        );
        w.omega_t_max = 0.0;
        let bytes = w.to_bytes();
        let fixed = Model::from_bytes(&bytes).unwrap();
        assert_eq!(check_times(&fixed, Some(&input(9))), [t0]);
    }

    #[test]
    fn contour_boxes_are_per_class_over_every_plane() {
        let seq = Sequence::new(
            ["a", "b"]
                .iter()
                .zip(1..)
                .map(|(name, label)| ClassInfo {
                    name: name.to_string(),
                    label,
                    color: None,
                })
                .collect(),
            vec![Frame {
                time: 0.0,
                planes: vec![
                    plane(-5.0, &[(0, [0.0, 0.0], 10.0)]),
                    plane(5.0, &[(0, [2.0, 0.0], 10.0), (1, [30.0, 30.0], 5.0)]),
                ],
            }],
        )
        .unwrap();
        let b = contour_bounds(&seq);
        assert_eq!(
            b[0],
            Some(Aabb {
                min: [-10.0, -10.0, -5.0],
                max: [12.0, 10.0, 5.0]
            })
        );
        assert_eq!(
            b[1],
            Some(Aabb {
                min: [25.0, 25.0, 5.0],
                max: [35.0, 35.0, 5.0]
            })
        );
    }

    /// A kidney whose contours span 100 mm: 30 mm past them passes, 100 mm past (and 10× the
    /// box's volume) is reported on the side it overshoots.
    #[test]
    fn far_reaches_and_large_volumes_are_reported() {
        let contours = [
            Some(Aabb {
                min: [0.0, 0.0, 0.0],
                max: [100.0, 50.0, 40.0],
            }),
            Some(Aabb {
                min: [0.0, 0.0, 0.0],
                max: [100.0, 50.0, 40.0],
            }),
        ];
        let box_volume = 100.0 * 50.0 * 40.0;
        let fine = extent(
            0,
            [-10.0, 0.0, -30.0],
            [100.0, 55.0, 40.0],
            0.5 * box_volume,
        );
        let bad = extent(1, [0.0, 0.0, 0.0], [100.0, 50.0, 140.0], 10.0 * box_volume);
        let w = against_contours(&[fine, bad], &contours, DEFAULT_TOLERANCE).unwrap();
        assert_eq!(w.len(), 2, "{w:?}");
        assert_eq!(
            w[0].problem,
            Problem::PastContours {
                by: 100.0,
                side: "z+",
                allowed: 50.0
            }
        );
        assert!(matches!(w[1].problem, Problem::LargerThanContours { .. }));
        let text = w[0].to_string();
        assert!(
            text.starts_with("class 2 \"c1\": its surface reaches 100.0 mm"),
            "{text}"
        );
        assert!(w[1].to_string().contains("10.0×"), "{}", w[1]);
        // A class count that does not match is an error, not a silent pass.
        let three = vec![extent(0, [0.0; 3], [1.0; 3], 1.0); 3];
        assert!(against_contours(&three, &contours, DEFAULT_TOLERANCE).is_err());
    }

    /// Through a real model: a ball inside the domain is not at its edge, and its extent is its
    /// box; a ball crossing the domain's x+ and y+ faces is reported there.
    #[test]
    fn domain_edges_through_a_model() {
        // SPHERES_DOMAIN: centre (10, −5, 2), half-extent 20; normalised radii.
        let bytes = spheres::model(
            &[
                Sphere::new([0.0; 3], 0.5, 0.0),
                Sphere::new([0.8, 0.8, 0.0], 0.3, 0.0),
            ],
            &[("inside", 1), ("cut", 2)],
        );
        let model = Model::from_bytes(&bytes).unwrap();
        let extents = class_extents(&model, &[0.0], 32, |_| {}).unwrap();
        let b = extents[0].bounds.unwrap();
        let s = f64::from(SPHERES_DOMAIN.scale[0]);
        let c = SPHERES_DOMAIN.center.map(f64::from);
        for (a, c) in c.iter().enumerate() {
            assert!((b.min[a] - (c - 0.5 * s)).abs() < 0.05 * s, "{b:?}");
            assert!((b.max[a] - (c + 0.5 * s)).abs() < 0.05 * s, "{b:?}");
        }
        let w = against_domain(&extents, &model, cell(&model, 32));
        assert_eq!(w.len(), 1, "{w:?}");
        assert_eq!(w[0].class, 1);
        assert!(
            w[0].problem
                == Problem::AtDomainEdge {
                    sides: vec!["x+", "y+"]
                },
            "{w:?}"
        );
    }
}
