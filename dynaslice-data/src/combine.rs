//! Combining the sequences read from several inputs into one: the timesteps of a `.seq` manifest,
//! and several images of one subject (a short-axis stack and long-axis views).
//!
//! **Classes are matched by name** (ignoring case and surrounding blanks), not by label value:
//! the ROI numbers of two RT Structure Sets of one patient differ from phase to phase while their
//! names agree. A name the reader made up (`label N`, for a label value that neither the file nor
//! the user's table names: [`Part::generated`]) matches only names made up by the reader of the
//! same format: label 1 of two NIfTI phases of one series is one structure, but label 1 of a
//! `.csl` file and label 1 of a NIfTI map are unrelated, and they stay two classes (the later one
//! renamed `label 1 (FILE)`, with a warning) unless a name from the file or from `--label-names`
//! says they are one. The combined class keeps the first input's spelling, label value and colour.
//! A later class whose label value is already taken by another name gets the next free value,
//! with a warning, so the combined classes' values stay unique (label volumes are written with
//! them).
//!
//! **Timesteps are matched by time** (within [`TIME_TOLERANCE`]): planes of equal times join
//! one timestep.
//!
//! **Absence**, chosen per input ([`Part::absence`]). With [`Absence::Union`] every plane of the
//! input annotates every combined class, a class the input did not annotate there being *absent*:
//! right for complete segmentations (a `.csl` plane, a label map's slice) and for views of one
//! subject segmented with the same structures (a 2-chamber view shows no right ventricle: it is
//! absent there). With [`Absence::AsRead`] a plane annotates what its input annotated and nothing
//! else, a class from another input being unobserved there: right for RT Structure Sets, whose
//! ROI lists vary from file to file.

use std::path::{Path, PathBuf};

use crate::input_kind::InputKind;
use dynaslice_sequence::error::{DataError, ErrorKind, Result};
use dynaslice_sequence::sequence::{Annotation, ClassInfo, Frame, Sequence};

/// Times closer than this (relative to the larger magnitude, or absolute below 1) are one time.
pub const TIME_TOLERANCE: f64 = 1e-6;

/// What a plane says about the classes its input did not annotate. See the [module docs](self).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Absence {
    /// Every plane annotates every combined class (missing ones absent).
    Union,
    /// Planes keep their input's annotations; other classes are unobserved there.
    AsRead,
}

/// One input to combine.
#[derive(Debug, Clone)]
pub struct Part {
    /// The file it was read from (for messages).
    pub path: PathBuf,
    /// What it holds.
    pub sequence: Sequence,
    /// What its planes say about the classes of other inputs.
    pub absence: Absence,
    /// Per class of `sequence`: the kind of input whose reader made up its name (`label N`),
    /// or `None` where the file or the user named it. See the [module docs](self).
    pub generated: Vec<Option<InputKind>>,
    /// The DICOM Frame of Reference UID its coordinates are in, where it gives one: inputs in
    /// different frames cannot be combined.
    pub frame_of_reference: Option<String>,
}

/// Whether two times are one time (see [`TIME_TOLERANCE`]).
pub fn same_time(a: f64, b: f64) -> bool {
    (a - b).abs() <= TIME_TOLERANCE * a.abs().max(b.abs()).max(1.0)
}

/// Combines `parts` (each with the file it came from, for messages) into one sequence, and says
/// of each of its classes what [`Part::generated`] says. See the [module docs](self).
pub fn combine(parts: Vec<Part>) -> Result<(Sequence, Vec<Option<InputKind>>)> {
    check_frames_of_reference(&parts)?;
    let mut classes: Vec<ClassInfo> = Vec::new();
    // Per combined class: the key it matches by (its first input's name, before any renaming)
    // and what `Part::generated` says of it.
    let mut keys: Vec<(String, Option<InputKind>)> = Vec::new();
    let mut frames: Vec<Frame> = Vec::new();
    // Planes of `Absence::Union` inputs, by (frame time, plane index in that frame), filled in
    // once every class is known.
    let mut complete: Vec<(f64, usize)> = Vec::new();
    for Part {
        path,
        sequence,
        absence,
        generated: own_generated,
        frame_of_reference: _,
    } in parts
    {
        let (own_classes, own_frames) = sequence.into_parts();
        let map: Vec<usize> = own_classes
            .into_iter()
            .enumerate()
            .map(|(k, c)| {
                let source = own_generated.get(k).copied().flatten();
                merge_class(&mut classes, &mut keys, (c, source), &path)
            })
            .collect::<Result<_>>()?;
        for mut frame in own_frames {
            for plane in &mut frame.planes {
                for a in &mut plane.annotations {
                    a.class = map[a.class];
                }
            }
            let index = match frames.iter().position(|f| same_time(f.time, frame.time)) {
                Some(i) => i,
                None => {
                    frames.push(Frame {
                        time: frame.time,
                        planes: Vec::new(),
                    });
                    frames.len() - 1
                }
            };
            let target = &mut frames[index];
            if absence == Absence::Union {
                let first = target.planes.len();
                complete.extend((first..first + frame.planes.len()).map(|p| (target.time, p)));
            }
            target.planes.extend(frame.planes);
        }
    }
    for (time, p) in complete {
        if let Some(plane) = frames
            .iter_mut()
            .find(|f| f.time == time)
            .and_then(|f| f.planes.get_mut(p))
        {
            for k in 0..classes.len() {
                if plane.annotation(k).is_none() {
                    plane.annotations.push(Annotation {
                        class: k,
                        polygons: Vec::new(),
                    });
                }
            }
            plane.annotations.sort_by_key(|a| a.class);
        }
    }
    frames.sort_by(|a, b| a.time.total_cmp(&b.time));
    let generated = keys.into_iter().map(|(_, source)| source).collect();
    Ok((Sequence::new(classes, frames)?, generated))
}

/// Refuses parts in different DICOM Frames of Reference: their coordinates are in unrelated
/// patient frames (another scan, another registration), naming both files and UIDs.
fn check_frames_of_reference(parts: &[Part]) -> Result<()> {
    let mut first: Option<(&Path, &str)> = None;
    for part in parts {
        let Some(uid) = part.frame_of_reference.as_deref() else {
            continue;
        };
        match first {
            None => first = Some((&part.path, uid)),
            Some((path, other)) if other != uid => {
                return Err(DataError::new(ErrorKind::Combine(format!(
                    "its Frame of Reference UID {uid} differs from {other} of {}: the contours \
                     are in different patient frames",
                    path.display()
                )))
                .in_file(&part.path))
            }
            Some(_) => {}
        }
    }
    Ok(())
}

/// The index of `class` (with the kind of input that made up its name, if one did) among
/// `classes`, adding it if no class matches it (see the [module docs](self)).
fn merge_class(
    classes: &mut Vec<ClassInfo>,
    keys: &mut Vec<(String, Option<InputKind>)>,
    (class, source): (ClassInfo, Option<InputKind>),
    path: &Path,
) -> Result<usize> {
    let key = (class.name.trim().to_lowercase(), source);
    if let Some(k) = keys.iter().position(|k| *k == key) {
        return Ok(k);
    }
    let mut class = class;
    if let Some(k) = keys.iter().position(|k| k.0 == key.0) {
        // A made-up name meeting an unrelated class of that name: kept apart, renamed.
        let file = path
            .file_name()
            .unwrap_or(path.as_os_str())
            .to_string_lossy();
        let renamed = format!("{} ({file})", class.name);
        log::warn!(
            "{}: class {:?} is kept apart from the class {:?} of an earlier input, as one of the \
             two names was made up from a label value; it is called {renamed:?} (name the labels, \
             e.g. with --label-names, to make them one class)",
            path.display(),
            class.name,
            classes[k].name,
        );
        class.name = renamed;
    }
    if let Some(other) = classes.iter().find(|c| c.label == class.label) {
        let free = classes
            .iter()
            .map(|c| c.label)
            .max()
            .and_then(|m| m.checked_add(1))
            .ok_or_else(|| {
                DataError::new(ErrorKind::Combine(format!(
                    "no free label value for class {:?}",
                    class.name
                )))
                .in_file(path)
            })?;
        log::warn!(
            "{}: class {:?} has label value {}, already used by {:?} of an earlier input; it gets \
             label value {free}",
            path.display(),
            class.name,
            class.label,
            other.name
        );
        class.label = free;
    }
    classes.push(class);
    keys.push(key);
    Ok(classes.len() - 1)
}

#[cfg(test)]
mod tests {
    use super::*;
    use dynaslice_sequence::sequence::{Plane, Rect};
    use Absence::{AsRead, Union};

    fn part(path: &str, sequence: Sequence, absence: Absence) -> Part {
        Part {
            path: path.into(),
            generated: vec![None; sequence.classes().len()],
            frame_of_reference: None,
            sequence,
            absence,
        }
    }

    fn square(class: usize, x: f64) -> Annotation {
        Annotation {
            class,
            polygons: vec![vec![[x, 0.0], [x + 1.0, 0.0], [x + 1.0, 1.0], [x, 1.0]]],
        }
    }

    fn one_plane(
        time: f64,
        z: f64,
        classes: &[(&str, i32)],
        annotations: Vec<Annotation>,
    ) -> Sequence {
        let classes = classes
            .iter()
            .map(|&(name, label)| ClassInfo {
                name: name.into(),
                label,
                color: None,
            })
            .collect();
        let plane = Plane {
            origin: [0.0, 0.0, z],
            u: [1.0, 0.0, 0.0],
            v: [0.0, 1.0, 0.0],
            roi: Rect {
                min: [-5.0, -5.0],
                max: [5.0, 5.0],
            },
            annotations,
        };
        Sequence::new(
            classes,
            vec![Frame {
                time,
                planes: vec![plane],
            }],
        )
        .unwrap()
    }

    #[test]
    fn classes_match_by_name_and_labels_stay_unique() {
        // Phase 1 numbers GTV 1 and Lung 2; phase 2 numbers them the other way; a third file
        // at phase 2 brings Heart as 2, a value Lung already has.
        let a = one_plane(
            0.0,
            0.0,
            &[("GTV", 1), ("Lung", 2)],
            vec![square(0, 0.0), square(1, 2.0)],
        );
        let b = one_plane(
            1.0,
            0.0,
            &[("lung ", 1), ("gtv", 2)],
            vec![square(0, 2.0), square(1, 0.0)],
        );
        let c = one_plane(1.0, 1.0, &[("Heart", 2)], vec![square(0, -3.0)]);
        let seq = combine(vec![
            part("a", a, AsRead),
            part("b", b, AsRead),
            part("c", c, AsRead),
        ])
        .unwrap()
        .0;
        let names: Vec<(&str, i32)> = seq
            .classes()
            .iter()
            .map(|c| (c.name.as_str(), c.label))
            .collect();
        assert_eq!(names, [("GTV", 1), ("Lung", 2), ("Heart", 3)]);
        assert_eq!(seq.frames().len(), 2);
        // b's lung (its class 0) is the combined class 1, its square at x = 2.
        let p = &seq.frames()[1].planes[0];
        assert_eq!(p.annotation(1).unwrap().polygons[0][0], [2.0, 0.0]);
        // c's plane joined time 1 and, as read, says nothing about GTV or Lung.
        let p = &seq.frames()[1].planes[1];
        assert!(p.annotation(0).is_none() && p.annotation(1).is_none());
        assert!(!p.annotation(2).unwrap().is_absent());
    }

    #[test]
    fn union_absence_annotates_every_class_on_every_plane() {
        let a = one_plane(0.0, 0.0, &[("LV", 1)], vec![square(0, 0.0)]);
        let b = one_plane(0.0, 1.0, &[("RV", 2)], vec![square(0, 0.0)]);
        let c = one_plane(0.0, 2.0, &[("LV", 1)], vec![square(0, 0.0)]);
        let seq = combine(vec![
            part("a", a, Union),
            part("b", b, Union),
            part("c", c, AsRead),
        ])
        .unwrap()
        .0;
        assert_eq!(seq.frames().len(), 1);
        let planes = &seq.frames()[0].planes;
        assert!(planes[0].annotation(1).unwrap().is_absent());
        assert!(planes[1].annotation(0).unwrap().is_absent());
        assert!(!planes[1].annotation(1).unwrap().is_absent());
        // The as-read input's plane says nothing about RV.
        assert!(planes[2].annotation(1).is_none());
    }

    #[test]
    fn times_within_tolerance_are_one_timestep() {
        assert!(same_time(0.04 * 3.0, 0.12));
        assert!(!same_time(0.12, 0.1201));
        let a = one_plane(0.12, 0.0, &[("LV", 1)], vec![square(0, 0.0)]);
        let b = one_plane(0.04 * 3.0, 1.0, &[("LV", 1)], vec![square(0, 0.0)]);
        let seq = combine(vec![part("a", a, AsRead), part("b", b, AsRead)])
            .unwrap()
            .0;
        assert_eq!(seq.frames().len(), 1);
    }

    #[test]
    fn made_up_names_match_only_made_up_names_of_the_same_kind() {
        let csl = one_plane(0.0, 0.0, &[("label 1", 1)], vec![square(0, 0.0)]);
        let nifti = |z| one_plane(0.0, z, &[("label 1", 1)], vec![square(0, 2.0)]);
        let made_up = |kind, sequence, path| Part {
            generated: vec![Some(kind)],
            ..part(path, sequence, Union)
        };
        let (seq, generated) = combine(vec![
            made_up(InputKind::Csl, csl.clone(), "a.csl"),
            made_up(InputKind::Nifti, nifti(1.0), "b.nii.gz"),
            made_up(InputKind::Nifti, nifti(2.0), "c.nii.gz"),
        ])
        .unwrap();
        let names: Vec<(&str, i32)> = seq
            .classes()
            .iter()
            .map(|c| (c.name.as_str(), c.label))
            .collect();
        // The two NIfTI maps' label 1 is one class; the .csl's is another.
        assert_eq!(names, [("label 1", 1), ("label 1 (b.nii.gz)", 2)]);
        assert_eq!(generated, [Some(InputKind::Csl), Some(InputKind::Nifti)]);
        // A name from the file or the user is not made up: it matches a made-up one no more.
        let (seq, _) = combine(vec![
            made_up(InputKind::Csl, csl, "a.csl"),
            part("b.json", nifti(1.0), Union),
        ])
        .unwrap();
        assert_eq!(seq.classes().len(), 2);
    }
}
