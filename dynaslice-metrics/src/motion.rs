//! Motion and function over a cycle (a breathing cycle, a heartbeat): per class and time the
//! volume, centroid and bounding box ([`volume::class_shapes`]: the closed Eq. 11 partition
//! meshes, so the values are those of the label volume), and per class over the times the
//! minimum and maximum volume and their times, stroke volume, ejection fraction and the
//! centroid's peak-to-peak amplitude along each axis.
//!
//! The model's world is RAS (docs/data-format.md): +x towards the patient's right, +y
//! anterior, +z superior. Results are given in the input's [`Frame`] (LPS for DICOM: +x left,
//! +y posterior, +z superior; RAS for NIfTI) and [`Units`] (mm and mL where the input's are
//! millimetres); the x, y, z axes are then left–right, anterior–posterior and
//! superior–inferior, and a peak-to-peak amplitude is the same in either frame.

use crate::volume::{self, ClassShape};
use anyhow::{ensure, Result};
use dynaslice_core::Model;
use std::fmt::Write as _;

use dynaslice_data::Space;
/// The length unit of a model's world: the input's, as the model records it.
pub use dynaslice_data::Units;

/// The patient coordinate frame results are given in.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Frame {
    /// DICOM's: +x left, +y posterior, +z superior.
    Lps,
    /// NIfTI's and the model world's: +x right, +y anterior, +z superior.
    Ras,
    /// No anatomical meaning known: the world's x, y, z as given.
    Plain,
}

impl Frame {
    /// The frame results are given in for an input in `units` and patient frame `space` (what
    /// a model's run record says): an input without a length unit (`.csl`, native JSON) has no
    /// known anatomical axes.
    pub fn of(units: Units, space: Space) -> Frame {
        match (units, space) {
            (Units::Plain, _) => Frame::Plain,
            (Units::Millimetres, Space::Lps) => Frame::Lps,
            (Units::Millimetres, Space::Ras) => Frame::Ras,
        }
    }

    /// The frame's name: `LPS`, `RAS` or `xyz`.
    pub fn name(self) -> &'static str {
        match self {
            Frame::Lps => "LPS",
            Frame::Ras => "RAS",
            Frame::Plain => "xyz",
        }
    }

    /// What the positive direction of each axis points to (`L`, `P`, `S` in LPS).
    pub fn positive(self) -> [&'static str; 3] {
        match self {
            Frame::Lps => ["L", "P", "S"],
            Frame::Ras => ["R", "A", "S"],
            Frame::Plain => ["+x", "+y", "+z"],
        }
    }

    /// Whether the axes are anatomical (x left–right, y anterior–posterior, z
    /// superior–inferior).
    pub fn is_anatomical(self) -> bool {
        self != Frame::Plain
    }

    /// A point of the model's RAS world in this frame (LPS negates x and y).
    pub fn from_world(self, p: [f64; 3]) -> [f64; 3] {
        match self {
            Frame::Lps => [-p[0], -p[1], p[2]],
            Frame::Ras | Frame::Plain => p,
        }
    }
}

/// Every class's solid at a list of times.
#[derive(Debug, Clone, PartialEq)]
pub struct Motion {
    /// Class names, in model order.
    pub classes: Vec<String>,
    /// World times, increasing.
    pub times: Vec<f64>,
    /// `shapes[time][class]`, in the model's (RAS) world.
    pub shapes: Vec<Vec<ClassShape>>,
}

/// A volume and when it occurs.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Extremum {
    /// World volume (world units cubed).
    pub volume: f64,
    /// World time (the first where it is attained).
    pub time: f64,
}

/// One class's figures over the measured times.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Cycle {
    /// Smallest volume (end-systolic for a ventricle, ESV).
    pub min: Extremum,
    /// Largest volume (end-diastolic, EDV).
    pub max: Extremum,
    /// max − min (world units cubed).
    pub stroke_volume: f64,
    /// (max − min) / max; `None` for a class that is never present.
    pub ejection_fraction: Option<f64>,
    /// Peak-to-peak range of the centroid along world x, y, z (left–right, anterior–posterior,
    /// superior–inferior), over the times the class is present; `None` if it never is.
    pub amplitude: Option<[f64; 3]>,
}

impl Motion {
    /// Measures every class of `model` at `times` (increasing, at least one) with meshes of
    /// `resolution` cells along the longest axis of its domain, calling `measured` after each
    /// time (a caller's progress: each time meshes every class, seconds of work).
    pub fn measure(
        model: &Model,
        times: &[f64],
        resolution: u32,
        mut measured: impl FnMut(),
    ) -> Result<Motion> {
        ensure!(!times.is_empty(), "no times to measure at");
        ensure!(
            times.windows(2).all(|w| w[0] < w[1]),
            "the times to measure at must increase"
        );
        let shapes = times
            .iter()
            .map(|&t| {
                let shapes = volume::class_shapes(model, t, resolution);
                measured();
                shapes
            })
            .collect::<Result<_>>()?;
        Ok(Motion {
            classes: model.classes().map(|c| c.name.to_string()).collect(),
            times: times.to_vec(),
            shapes,
        })
    }

    /// Class `class`'s figures over the measured times.
    pub fn cycle(&self, class: usize) -> Cycle {
        let at = |f: usize| Extremum {
            volume: self.shapes[f][class].volume,
            time: self.times[f],
        };
        let (mut min, mut max) = (at(0), at(0));
        for f in 1..self.times.len() {
            let e = at(f);
            if e.volume < min.volume {
                min = e;
            }
            if e.volume > max.volume {
                max = e;
            }
        }
        let stroke_volume = max.volume - min.volume;
        let centroids: Vec<[f64; 3]> = self
            .shapes
            .iter()
            .filter_map(|s| s[class].centroid)
            .collect();
        let amplitude = (!centroids.is_empty()).then(|| {
            std::array::from_fn(|a| {
                let (lo, hi) = centroids.iter().fold((f64::MAX, f64::MIN), |(lo, hi), c| {
                    (lo.min(c[a]), hi.max(c[a]))
                });
                hi - lo
            })
        });
        Cycle {
            min,
            max,
            stroke_volume,
            ejection_fraction: (max.volume > 0.0).then(|| stroke_volume / max.volume),
            amplitude,
        }
    }

    /// The per-time table as CSV, one row per time and class, in `frame` and `units`: `time`,
    /// `class`, `label` (the given source labels), the volume, the centroid and the bounding
    /// box (columns named with the unit and the frame's axis directions, empty where the class
    /// is absent). Numbers are rounded by [`round`], as every other presentation of them is.
    pub fn to_csv(&self, labels: &[i32], units: Units, frame: Frame) -> String {
        let [x, y, z] = frame.positive();
        let (l, v) = (units.length(), units.volume());
        let mut s = format!("time,class,label,volume_{v}");
        for what in ["centroid", "bbox_min", "bbox_max"] {
            for axis in [x, y, z] {
                let _ = write!(s, ",{what}_{axis}_{l}");
            }
        }
        s = s.replace('³', "3");
        s.push('\n');
        for (t, shapes) in self.times.iter().zip(&self.shapes) {
            for (k, shape) in shapes.iter().enumerate() {
                let _ = write!(
                    s,
                    "{},{},{},{}",
                    t,
                    csv_field(&self.classes[k]),
                    labels.get(k).map(|l| l.to_string()).unwrap_or_default(),
                    round(units.from_world_volume(shape.volume))
                );
                let mut point = |p: Option<[f64; 3]>| {
                    for a in 0..3 {
                        match p {
                            Some(p) => {
                                let _ = write!(s, ",{}", round(p[a]));
                            }
                            None => s.push(','),
                        }
                    }
                };
                point(shape.centroid.map(|c| frame.from_world(c)));
                // LPS flips x and y: the box's corners are recombined so lo ≤ hi per axis.
                let corners = shape.bounds.map(|(lo, hi)| {
                    let (a, b) = (frame.from_world(lo), frame.from_world(hi));
                    (
                        std::array::from_fn(|i| a[i].min(b[i])),
                        std::array::from_fn(|i| a[i].max(b[i])),
                    )
                });
                point(corners.map(|c: ([f64; 3], [f64; 3])| c.0));
                point(corners.map(|c| c.1));
                s.push('\n');
            }
        }
        s
    }
}

/// A reported number: rounded to 6 significant digits (far below any measurement's accuracy
/// here, and readable), printed as the shortest decimal that reads back to it. The CSV, the
/// JSON and the report all print numbers through it, so they agree digit for digit.
pub fn round(v: f64) -> f64 {
    if !v.is_finite() || v == 0.0 {
        return v;
    }
    format!("{v:.5e}").parse().unwrap_or(v)
}

/// A CSV field, quoted where it holds a comma, quote or line break.
fn csv_field(s: &str) -> String {
    if s.contains([',', '"', '\n', '\r']) {
        format!("\"{}\"", s.replace('"', "\"\""))
    } else {
        s.to_string()
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use dynaslice_core::Domain;
    use dynaslice_synth::shapes::chambers;
    use dynaslice_test_support::spheres::{self, Sphere};
    use std::f64::consts::PI;

    /// The synthetic benchmark's chambers scaled to a heart in millimetres: 50 mm per unit.
    const MM: f64 = 50.0;
    const HEART: Domain = Domain {
        center: [10.0, -20.0, 5.0],
        scale: [MM as f32; 3],
        time_origin: 0.0,
        time_span: 1.0,
        output_scale: MM as f32,
    };

    /// The cardiac synthetic case: the chambers' exact spheres at 37 phases (each phase a model
    /// of the exact shapes at that instant), measured as one cycle. EDV, ESV and EF within 2 %
    /// of the closed forms, every volume within 1 %, centroids and their peak-to-peak amplitude
    /// within 0.5 mm of the exact centres'.
    #[test]
    fn chambers_cycle_matches_closed_forms() {
        let times: Vec<f64> = (0..37).map(|i| i as f64 / 36.0).collect();
        let classes = [("a", 1), ("b", 2), ("c", 3)];
        let mut truth_centres: Vec<[[f64; 3]; 3]> = Vec::new();
        let shapes = times
            .iter()
            .map(|&t| {
                let (centres, radii) = chambers(t);
                let s: Vec<Sphere> = (0..3)
                    .map(|k| Sphere::new(centres[k], radii[k], 0.0))
                    .collect();
                truth_centres.push(
                    centres
                        .map(|c| std::array::from_fn(|a| f64::from(HEART.center[a]) + MM * c[a])),
                );
                let bytes = spheres::model_in(HEART, &s, &classes);
                let model = Model::from_bytes(&bytes).unwrap();
                volume::class_shapes(&model, 0.0, 128)
            })
            .collect::<Result<Vec<_>>>()
            .unwrap();
        let motion = Motion {
            classes: classes.iter().map(|c| c.0.to_string()).collect(),
            times: times.clone(),
            shapes,
        };
        let base = [0.34, 0.29, 0.24];
        let ml = |r: f64| Units::Millimetres.from_world_volume(4.0 / 3.0 * PI * (MM * r).powi(3));
        for k in 0..3 {
            for (f, &t) in times.iter().enumerate() {
                let want = ml(chambers(t).1[k]);
                let got = Units::Millimetres.from_world_volume(motion.shapes[f][k].volume);
                assert!(
                    (got - want).abs() < 0.01 * want,
                    "{k} {t}: {got} vs {want} mL"
                );
                let c = motion.shapes[f][k].centroid.unwrap();
                let d = (0..3)
                    .map(|a| (c[a] - truth_centres[f][k][a]).powi(2))
                    .sum::<f64>()
                    .sqrt();
                assert!(d < 0.5, "{k} {t}: centroid {c:?} is {d} mm off");
            }
            let cycle = motion.cycle(k);
            let (edv, esv) = (ml(base[k] * 1.15), ml(base[k] * 0.85));
            let ef = (edv - esv) / edv;
            let got_edv = Units::Millimetres.from_world_volume(cycle.max.volume);
            let got_esv = Units::Millimetres.from_world_volume(cycle.min.volume);
            let got_ef = cycle.ejection_fraction.unwrap();
            assert!(
                (got_edv - edv).abs() < 0.02 * edv,
                "{k}: EDV {got_edv} vs {edv}"
            );
            assert!(
                (got_esv - esv).abs() < 0.02 * esv,
                "{k}: ESV {got_esv} vs {esv}"
            );
            assert!((got_ef - ef).abs() < 0.02 * ef, "{k}: EF {got_ef} vs {ef}");
            // Peaks of sin(2πt + 2πk/3): end-diastole at t = 1/4 − k/3 (mod 1), end-systole half
            // a cycle later; 37 phases hit both exactly.
            let peak = (0.25 - k as f64 / 3.0).rem_euclid(1.0);
            assert!(
                (cycle.max.time - peak).abs() < 1e-9,
                "{k}: {}",
                cycle.max.time
            );
            assert!(
                (cycle.min.time - (peak + 0.5).rem_euclid(1.0)).abs() < 1e-9,
                "{k}: {}",
                cycle.min.time
            );
            let amplitude = cycle.amplitude.unwrap();
            for a in 0..3 {
                let (lo, hi) = truth_centres
                    .iter()
                    .fold((f64::MAX, f64::MIN), |(lo, hi), c| {
                        (lo.min(c[k][a]), hi.max(c[k][a]))
                    });
                assert!(
                    (amplitude[a] - (hi - lo)).abs() < 0.5,
                    "{k} axis {a}: {} vs {} mm",
                    amplitude[a],
                    hi - lo
                );
            }
            // The group spins about z: the chambers move tens of mm along x and y.
            assert!(amplitude[0] > 10.0 && amplitude[1] > 5.0, "{amplitude:?}");
        }
    }

    /// One growing sphere through a real model's time axis: exact volumes at every time, a
    /// still centroid (zero amplitude), the extremes at the ends, and the table in LPS.
    #[test]
    fn growing_sphere_measured_through_time() {
        let s = Sphere::new([0.1, -0.2, 0.05], 0.3, 0.1);
        let bytes = spheres::model(&[s], &[("tumour", 7)]);
        let model = Model::from_bytes(&bytes).unwrap();
        let times = [0.0, 0.5, 1.0, 1.5, 2.0];
        let motion = Motion::measure(&model, &times, 96, || {}).unwrap();
        for (f, &t) in times.iter().enumerate() {
            let shape = motion.shapes[f][0];
            let want = s.world_volume(t);
            assert!((shape.volume - want).abs() < 0.01 * want, "{t}: {shape:?}");
            let c = shape.centroid.unwrap();
            let truth = s.world_centre();
            assert!((0..3).all(|a| (c[a] - truth[a]).abs() < 0.05), "{c:?}");
            let (lo, hi) = shape.bounds.unwrap();
            let r = s.world_radius(t);
            for a in 0..3 {
                assert!(
                    (lo[a] - (truth[a] - r)).abs() < 0.1 && (hi[a] - (truth[a] + r)).abs() < 0.1
                );
            }
        }
        let cycle = motion.cycle(0);
        assert_eq!((cycle.min.time, cycle.max.time), (0.0, 2.0));
        let amplitude = cycle.amplitude.unwrap();
        assert!(amplitude.iter().all(|&a| a < 0.05), "{amplitude:?}");
        let csv = motion.to_csv(&[7], Units::Millimetres, Frame::Lps);
        let mut lines = csv.lines();
        assert_eq!(
            lines.next().unwrap(),
            "time,class,label,volume_mL,centroid_L_mm,centroid_P_mm,centroid_S_mm,\
             bbox_min_L_mm,bbox_min_P_mm,bbox_min_S_mm,bbox_max_L_mm,bbox_max_P_mm,bbox_max_S_mm"
        );
        let row: Vec<f64> = lines
            .next()
            .unwrap()
            .split(',')
            .enumerate()
            .filter(|(i, _)| *i != 1)
            .map(|(_, v)| v.parse().unwrap())
            .collect();
        let volume = Units::Millimetres.from_world_volume(motion.shapes[0][0].volume);
        assert_eq!(row[..3], [0.0, 7.0, round(volume)]);
        // LPS: the RAS centre's x and y negated, the box's corners recombined.
        let truth = s.world_centre();
        assert!((row[3] + truth[0]).abs() < 0.05 && (row[5] - truth[2]).abs() < 0.05);
        assert!(row[6] < row[9] && row[7] < row[10], "{row:?}");
        assert!(
            (row[6] + truth[0] + s.world_radius(0.0)).abs() < 0.1,
            "{row:?}"
        );
        assert_eq!(csv.lines().count(), 1 + times.len());
    }

    #[test]
    fn rounding_and_quoting() {
        assert_eq!(round(123.456789123), 123.457);
        assert_eq!(round(-0.000123456789), -0.000123457);
        assert_eq!(round(0.0), 0.0);
        assert_eq!(csv_field("a,b"), "\"a,b\"");
        assert_eq!(csv_field("lung"), "lung");
    }
}
