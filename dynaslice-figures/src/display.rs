//! Which way round a plane is drawn. Radiology reads axial and coronal images as if facing the
//! patient: the patient's left on the right of the screen, anterior (axial) or superior
//! (coronal) up. Neurology draws the patient's left on the left. A plane is turned to the chosen
//! convention by a signed swap of its own axes, so the labels, contours, ticks and direction
//! letters of the picture all follow; oblique and sagittal planes, which have no such
//! convention, are drawn as the input gives them.

use dynaslice_sequence::{Plane, Rect};

/// A plane axis within this of a world axis (cosine) counts as that axis (about 2.6°).
const ALIGNED: f64 = 0.999;

/// The left–right convention of axial and coronal pictures.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Default)]
pub enum Display {
    /// The patient's left on the right of the picture, as radiology viewers and PACS show it.
    #[default]
    Radiological,
    /// The patient's left on the left of the picture.
    Neurological,
}

impl Display {
    /// Both conventions, in the order a help text lists them.
    pub const ALL: [Display; 2] = [Display::Radiological, Display::Neurological];

    /// The convention's name in options: `radiological` or `neurological`.
    pub fn name(self) -> &'static str {
        match self {
            Display::Radiological => "radiological",
            Display::Neurological => "neurological",
        }
    }

    /// Where the patient's left is, for help texts.
    pub fn help(self) -> &'static str {
        match self {
            Display::Radiological => "The patient's left on the right of the picture",
            Display::Neurological => "The patient's left on the left of the picture",
        }
    }

    /// The words a legend uses for the convention.
    pub fn describe(self) -> &'static str {
        match self {
            Display::Radiological => "radiological convention: the patient's left on the right",
            Display::Neurological => "neurological convention: the patient's left on the left",
        }
    }

    /// `plane` turned for this convention (RAS world: +x toward the patient's right), with its
    /// region and contours in the turned coordinates: an axial or coronal plane whose axes lie
    /// along world axes gets the patient's left on the picture's right (radiological) or left
    /// (neurological), and anterior (axial) or superior (coronal) up. `None` for a plane the
    /// convention says nothing of (sagittal, oblique): draw it as it is.
    pub fn orient(self, plane: &Plane) -> Option<Plane> {
        let n = plane.normal();
        // Screen right and screen up in the RAS world.
        let right_x = match self {
            Display::Radiological => -1.0,
            Display::Neurological => 1.0,
        };
        let (right, up) = if n[2].abs() > ALIGNED {
            ([right_x, 0.0, 0.0], [0.0, 1.0, 0.0])
        } else if n[1].abs() > ALIGNED {
            ([right_x, 0.0, 0.0], [0.0, 0.0, 1.0])
        } else {
            return None;
        };
        let dot = |a: [f64; 3], b: [f64; 3]| a[0] * b[0] + a[1] * b[1] + a[2] * b[2];
        // New coordinates p' = M p, M a signed permutation: row 0 gives screen right.
        let m: [[f64; 2]; 2] = if dot(plane.u, right).abs() > ALIGNED {
            [
                [dot(plane.u, right).signum(), 0.0],
                [0.0, dot(plane.v, up).signum()],
            ]
        } else if dot(plane.v, right).abs() > ALIGNED {
            [
                [0.0, dot(plane.v, right).signum()],
                [dot(plane.u, up).signum(), 0.0],
            ]
        } else {
            return None;
        };
        let map = |p: [f64; 2]| {
            [
                m[0][0] * p[0] + m[0][1] * p[1],
                m[1][0] * p[0] + m[1][1] * p[1],
            ]
        };
        // World axes of the new coordinates: x = o + p·(u, v) = o + (Mᵀp')·(u, v).
        let axis = |row: [f64; 2]| -> [f64; 3] {
            std::array::from_fn(|k| row[0] * plane.u[k] + row[1] * plane.v[k])
        };
        let (a, b) = (map(plane.roi.min), map(plane.roi.max));
        let mut turned = plane.clone();
        turned.u = axis(m[0]);
        turned.v = axis(m[1]);
        turned.roi = Rect {
            min: [a[0].min(b[0]), a[1].min(b[1])],
            max: [a[0].max(b[0]), a[1].max(b[1])],
        };
        for annotation in &mut turned.annotations {
            for polygon in &mut annotation.polygons {
                for q in polygon.iter_mut() {
                    *q = map(*q);
                }
            }
        }
        Some(turned)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use dynaslice_sequence::Annotation;

    /// An axial plane at z = 5 as a NIfTI slice gives it: u = +x (toward the patient's right),
    /// v = +y (anterior), with one contour point at world (10, 20, 5).
    fn axial() -> Plane {
        Plane {
            origin: [0.0, 0.0, 5.0],
            u: [1.0, 0.0, 0.0],
            v: [0.0, 1.0, 0.0],
            roi: Rect {
                min: [-50.0, -40.0],
                max: [60.0, 30.0],
            },
            annotations: vec![Annotation {
                class: 0,
                polygons: vec![vec![[10.0, 20.0], [11.0, 20.0], [10.0, 21.0]]],
            }],
        }
    }

    #[test]
    fn radiological_axial_puts_the_patients_left_on_the_right() {
        let plane = axial();
        let turned = Display::Radiological.orient(&plane).unwrap();
        // Screen right (+u') is the patient's left (−x in RAS); up (+v') is anterior.
        assert_eq!(turned.u, [-1.0, 0.0, 0.0]);
        assert_eq!(turned.v, [0.0, 1.0, 0.0]);
        assert_eq!(turned.roi.min, [-60.0, -40.0]);
        assert_eq!(turned.roi.max, [50.0, 30.0]);
        // Every point stays where it is in the world.
        let q = turned.annotations[0].polygons[0][0];
        assert_eq!(turned.to_world(q), [10.0, 20.0, 5.0]);
        assert_eq!(Display::Neurological.orient(&plane), Some(plane));
    }

    #[test]
    fn a_coronal_plane_with_swapped_axes_is_turned_upright() {
        // A coronal plane (normal ±y) whose u runs superior and v toward the patient's right.
        let mut plane = axial();
        plane.u = [0.0, 0.0, 1.0];
        plane.v = [1.0, 0.0, 0.0];
        let turned = Display::Radiological.orient(&plane).unwrap();
        assert_eq!((turned.u, turned.v), ([-1.0, 0.0, 0.0], [0.0, 0.0, 1.0]));
        let q = plane.annotations[0].polygons[0][0];
        let t = turned.annotations[0].polygons[0][0];
        assert_eq!(plane.to_world(q), turned.to_world(t));
        // p' = (−v, u): the region's u runs over −v's range, v over u's.
        assert_eq!(turned.roi.min, [-30.0, -50.0]);
        assert_eq!(turned.roi.max, [40.0, 60.0]);
    }

    #[test]
    fn sagittal_and_oblique_planes_are_left_as_given() {
        let mut plane = axial();
        plane.u = [0.0, 1.0, 0.0];
        plane.v = [0.0, 0.0, 1.0];
        assert_eq!(Display::Radiological.orient(&plane), None);
        let s = std::f64::consts::FRAC_1_SQRT_2;
        plane.u = [s, s, 0.0];
        plane.v = [-s, s, 0.0];
        assert_eq!(Display::Radiological.orient(&plane), None);
    }
}
