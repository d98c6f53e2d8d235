//! Table 2's idea on multi-class data: K independent one-class models against one shared
//! K-class model (Eq. 9), and the shared model without temporal control (Eq. 4), all trained
//! on the same held-out split of the input and scored on the withheld slices by 2D IoU
//! ([`dynaslice_metrics::heldout`]): spatial (seen frames, withheld planes), temporal (withheld
//! frames, seen positions) and spatio-temporal (both).
//!
//! Every model trains for the same number of steps, calibrated on the shared model, so the
//! independent models together cost about K times the steps of the shared one; the
//! equal-time independent models instead share the shared model's wall time (each calibrated
//! to 1/K of it), the comparison at equal compute. Each one-class
//! model sees exactly the planes that annotate its class, as the shared model does. Every way
//! of sharing runs from the same seeds; the table shows means over them, because one seed can
//! collapse a class (lab/notes/training.md measures it on the real CT case).

use super::{cell, fit, Protocol};
use anyhow::{Context, Result};
use dynaslice_data::Sequence;
use dynaslice_metrics::heldout::{held_out, held_out_class, HeldOut, Split};
use dynaslice_metrics::iou::Overlap;
use dynaslice_train::fit::Quiet;
use dynaslice_train::spec::TrainSpec;
use std::fmt::Write as _;

/// How the classes share a network.
#[derive(Clone, Copy, Debug, PartialEq, Eq, clap::ValueEnum)]
pub enum Sharing {
    /// One model per class, each as many steps as the shared model.
    Independent,
    /// One model per class, all together in the shared model's wall time.
    IndependentEqualTime,
    /// One K-class model (DynaSlice).
    Shared,
    /// One K-class model, no temporal control.
    SharedNoTemporal,
}

impl Sharing {
    /// Row label.
    pub fn name(self) -> &'static str {
        match self {
            Sharing::Independent => "independent per-class models",
            Sharing::IndependentEqualTime => "independent, equal total time",
            Sharing::Shared => "one shared model (DynaSlice)",
            Sharing::SharedNoTemporal => "shared, no temporal control",
        }
    }
}

/// One scored way of sharing.
pub struct SharingRun {
    /// The way.
    pub sharing: Sharing,
    /// Seed of initialisation and sampling.
    pub seed: u64,
    /// Per class: IoU on (spatial, temporal, spatio-temporal) withheld slices.
    pub class_iou: Vec<[Option<f64>; 3]>,
    /// Training wall time of all its models together.
    pub seconds: f64,
    /// Steps per model.
    pub steps: u64,
}

/// A multi-class input and the split it is scored on.
pub struct Case {
    /// Name in the table.
    pub name: String,
    /// How the input was made (for the table's caption).
    pub source: String,
    /// The full input.
    pub seq: Sequence,
    /// What is withheld.
    pub split: Split,
    /// Pixels along the longer side of each withheld plane's region of interest.
    pub pixels: usize,
    /// Steps of each equal-time independent model, instead of calibrating them to 1/K of the
    /// time (to match a wall time measured in an earlier run).
    pub equal_time_steps: Option<u64>,
}

/// Every category's per-class IoU of one [`HeldOut`], as rows of `[spatial, temporal, st]`.
fn per_class(h: &HeldOut) -> Vec<[Option<f64>; 3]> {
    let [s, t, st] = [&h.spatial, &h.temporal, &h.spatio_temporal].map(Overlap::iou);
    (0..s.len()).map(|c| [s[c], t[c], st[c]]).collect()
}

impl Case {
    /// Whether the input has more than one frame (else temporal control changes nothing: the
    /// network's time input is constant).
    pub fn is_dynamic(&self) -> bool {
        self.seq.frames().len() > 1
    }

    /// The ways worth comparing on this input.
    pub fn sharings(&self) -> Vec<Sharing> {
        let mut v = vec![
            Sharing::Independent,
            Sharing::IndependentEqualTime,
            Sharing::Shared,
        ];
        if self.is_dynamic() {
            v.push(Sharing::SharedNoTemporal);
        }
        v
    }

    /// Steps of the shared model that take `p.minutes`.
    pub fn calibrate(&self, p: &Protocol) -> Result<u64> {
        p.steps_for(&self.split.training(&self.seq)?)
    }

    /// Trains and scores one way of sharing from `seed`, `steps` steps per model (equal-time
    /// independent models calibrate their own, 1/K of `p.minutes` each).
    pub fn run(&self, sharing: Sharing, seed: u64, p: &Protocol, steps: u64) -> Result<SharingRun> {
        let train = self.split.training(&self.seq)?;
        let input = format!("{}, training split", self.source);
        let spec = |steps: u64, temporal_control: bool| TrainSpec {
            seed: Some(seed),
            ..p.spec(steps, temporal_control, true)
        };
        let k = self.seq.classes().len();
        let one_class = |c: usize| {
            train
                .only_class(c)
                .with_context(|| format!("{}: class {}", self.name, c + 1))
        };
        // Equal time: one-class steps cost nearly the same whatever the class (the same
        // sample counts), so one calibration serves all K.
        let steps = match (sharing, self.equal_time_steps) {
            (Sharing::IndependentEqualTime, Some(given)) => given,
            (Sharing::IndependentEqualTime, None) => {
                p.steps_for_minutes(&one_class(0)?, p.minutes / k as f64)?
            }
            _ => steps,
        };
        let (class_iou, seconds) = match sharing {
            Sharing::Independent | Sharing::IndependentEqualTime => {
                let mut rows = Vec::new();
                let mut seconds = 0.0;
                for c in 0..k {
                    let one = one_class(c)?;
                    let input = format!("{input}, class {} alone", c + 1);
                    let fitted = fit(&one, &spec(steps, true), &input, &mut Quiet)?;
                    seconds += fitted.seconds;
                    let h =
                        held_out_class(&fitted.model(), &self.seq, c, &self.split, self.pixels)?;
                    rows.push(per_class(&h)[0]);
                }
                (rows, seconds)
            }
            Sharing::Shared | Sharing::SharedNoTemporal => {
                let control = sharing == Sharing::Shared;
                let fitted = fit(&train, &spec(steps, control), &input, &mut Quiet)?;
                let h = held_out(&fitted.model(), &self.seq, &self.split, self.pixels)?;
                (per_class(&h), fitted.seconds)
            }
        };
        Ok(SharingRun {
            sharing,
            seed,
            class_iou,
            seconds,
            steps,
        })
    }
}

fn mean(v: impl Iterator<Item = Option<f64>>) -> Option<f64> {
    let v: Vec<f64> = v.flatten().collect();
    (!v.is_empty()).then(|| v.iter().sum::<f64>() / v.len() as f64)
}

/// The runs of `runs` that share `sharing`, one per seed.
fn runs_of(runs: &[SharingRun], sharing: Sharing) -> Vec<&SharingRun> {
    runs.iter().filter(|r| r.sharing == sharing).collect()
}

/// The mean over seeds of one seed's figure.
fn seed_mean(of: &[&SharingRun], figure: impl Fn(&SharingRun) -> Option<f64>) -> Option<f64> {
    mean(of.iter().map(|r| figure(r)))
}

/// The markdown of one case's runs (any ways of sharing and seeds; every figure of a way is
/// the mean over its seeds of the figure of one seed, itself a mean over classes).
pub fn markdown(case: &Case, runs: &[SharingRun], p: &Protocol) -> String {
    let mut s = String::new();
    let k = case.seq.classes().len();
    let planes: usize = case.seq.frames().iter().map(|f| f.planes.len()).sum();
    let mut seeds: Vec<u64> = runs.iter().map(|r| r.seed).collect();
    seeds.sort_unstable();
    seeds.dedup();
    let mut sharings: Vec<Sharing> = Vec::new();
    for r in runs {
        if !sharings.contains(&r.sharing) {
            sharings.push(r.sharing);
        }
    }
    let _ = writeln!(s, "### {}\n", case.name);
    let _ = writeln!(
        s,
        "{} ({k} classes, {} frames, {planes} planes). Withheld: frames {}, planes {} (within \
         each frame); 2D IoU of the Eq. 11 labels on the withheld slices at {} pixels along each \
         region's longer side. The shared model trained {} steps ({} on it, {} \
         threads); the steps of each model are in the table; mean of the {} seed(s) {:?}.\n",
        case.source,
        case.seq.frames().len(),
        case.split.frames.map_or("none".into(), |r| r.to_string()),
        case.split.planes.map_or("none".into(), |r| r.to_string()),
        case.pixels,
        runs_of(runs, Sharing::Shared)
            .first()
            .map_or(0, |r| r.steps),
        p.budget(),
        p.options().threads,
        seeds.len(),
        seeds,
    );
    let dynamic = case.is_dynamic();
    let categories: &[(usize, &str)] = if dynamic {
        &[(0, "spatial"), (1, "temporal"), (2, "spatio-temporal")]
    } else {
        &[(0, "spatial")]
    };
    let category_iou = |r: &SharingRun, i: usize| mean(r.class_iou.iter().map(|c| c[i]));
    let _ = write!(s, "| model |");
    for (_, c) in categories {
        let _ = write!(s, " {c} IoU |");
    }
    let _ = writeln!(s, " steps per model | train time | per class |");
    let _ = writeln!(s, "|---|{}---|---|---|", "---|".repeat(categories.len()));
    for &sharing in &sharings {
        let of = runs_of(runs, sharing);
        let _ = write!(s, "| {} |", sharing.name());
        for &(i, _) in categories {
            let _ = write!(s, " {} |", cell(seed_mean(&of, |r| category_iou(r, i)), 3));
        }
        let seconds = seed_mean(&of, |r| Some(r.seconds)).unwrap_or(0.0);
        let steps = of.first().map_or(0, |r| r.steps);
        let _ = writeln!(
            s,
            " {steps} | {seconds:.0} s | {:.1} s |",
            seconds / k as f64
        );
    }
    if seeds.len() > 1 {
        let _ = writeln!(
            s,
            "\nPer seed ({} IoU; seeds {seeds:?}):\n",
            categories[0].1
        );
        for &sharing in &sharings {
            let ious: Vec<String> = runs_of(runs, sharing)
                .iter()
                .map(|r| cell(category_iou(r, 0), 3))
                .collect();
            let _ = writeln!(s, "- {}: {}", sharing.name(), ious.join(", "));
        }
    }
    let _ = writeln!(s, "\nPer class, spatial IoU:\n");
    let _ = write!(s, "| model |");
    for c in case.seq.classes() {
        let _ = write!(s, " {} ({}) |", c.name, c.label);
    }
    let _ = writeln!(s, "\n|---|{}", "---|".repeat(k));
    for &sharing in &sharings {
        let of = runs_of(runs, sharing);
        let _ = write!(s, "| {} |", sharing.name());
        for c in 0..k {
            let _ = write!(s, " {} |", cell(seed_mean(&of, |r| r.class_iou[c][0]), 3));
        }
        let _ = writeln!(s);
    }
    let _ = writeln!(s);
    s
}

#[cfg(test)]
mod tests {
    use super::*;
    use dynaslice_synth::{slice_sequence, BenchmarkOptions, Shape};

    fn case() -> Case {
        let bench = BenchmarkOptions {
            timesteps: 9,
            train_every: 2,
            planes: Some((3, 3)),
            plane_resolution: 48,
            volume_resolution: 8,
        };
        let seq = slice_sequence(Shape::Chambers, &bench).unwrap();
        Case {
            name: "tiny chambers".into(),
            source: "test".into(),
            seq,
            split: Split {
                frames: Some("1::2".parse().unwrap()),
                planes: Some("2::3".parse().unwrap()),
            },
            pixels: 24,
            equal_time_steps: None,
        }
    }

    /// A class on its own keeps its name, label and polygons on every plane that annotates it.
    #[test]
    fn one_class_of_a_sequence() {
        let c = case();
        let one = c.seq.only_class(1).unwrap();
        assert_eq!(one.classes(), &c.seq.classes()[1..2]);
        let planes = |s: &Sequence| s.frames().iter().flat_map(|f| &f.planes).count();
        let annotating = c
            .seq
            .frames()
            .iter()
            .flat_map(|f| &f.planes)
            .filter(|p| p.annotation(1).is_some())
            .count();
        assert_eq!(planes(&one), annotating);
        let (a, b) = (&c.seq.frames()[0].planes[0], &one.frames()[0].planes[0]);
        assert_eq!(b.annotations.len(), 1);
        assert_eq!(b.annotations[0].class, 0);
        assert_eq!(b.annotations[0].polygons, a.annotation(1).unwrap().polygons);
        assert!(c.seq.only_class(3).is_err());
    }

    /// Every way of sharing trains and scores every class in every category; the independent
    /// models are one per class and cost their steps each.
    #[test]
    fn every_sharing_scores_every_class() {
        let c = case();
        let p = Protocol {
            minutes: 0.0,
            steps: None,
            spec: TrainSpec {
                widths: Some(vec![16, 16]),
                threads: Some(1),
                contour_samples: Some(64),
                plane_samples: Some(64),
                space_samples: Some(64),
                temporal_factor: Some(1.0),
                ..TrainSpec::default()
            },
        };
        assert_eq!(c.sharings().len(), 4);
        for sharing in c.sharings() {
            let r = c.run(sharing, 0, &p, 3).unwrap();
            assert_eq!(r.class_iou.len(), 3, "{sharing:?}");
            for (k, row) in r.class_iou.iter().enumerate() {
                for v in row {
                    let v = v.unwrap_or_else(|| panic!("{sharing:?} class {k}: undefined"));
                    assert!((0.0..=1.0).contains(&v), "{sharing:?} class {k}: {v}");
                }
            }
        }
        let md = markdown(&c, &[c.run(Sharing::Shared, 0, &p, 2).unwrap()], &p);
        assert!(md.contains("| one shared model (DynaSlice) |"), "{md}");
        let (a, b) = (
            c.run(Sharing::Shared, 0, &p, 2),
            c.run(Sharing::Shared, 1, &p, 2),
        );
        assert_ne!(
            a.unwrap().class_iou,
            b.unwrap().class_iou,
            "the seed reaches the trainer"
        );
    }

    /// A way of sharing run from several seeds shows, per category and per class, the mean
    /// over seeds of each seed's figure (itself a mean over classes), each seed's spatial IoU,
    /// and the mean training time.
    #[test]
    fn the_table_averages_over_seeds() {
        let c = case();
        let p = Protocol {
            minutes: 1.0,
            steps: None,
            spec: TrainSpec {
                temporal_factor: Some(0.2),
                ..TrainSpec::default()
            },
        };
        let run = |sharing, seed, iou: [f64; 3], seconds| SharingRun {
            sharing,
            seed,
            class_iou: iou
                .iter()
                .map(|&v| [Some(v), Some(v / 2.0), None])
                .collect(),
            seconds,
            steps: 10,
        };
        let runs = [
            run(Sharing::Independent, 0, [0.9, 0.8, 0.7], 30.0),
            run(Sharing::Shared, 0, [0.6, 0.6, 0.6], 12.0),
            run(Sharing::Independent, 1, [0.5, 0.4, 0.3], 36.0),
            run(Sharing::Shared, 1, [0.8, 0.8, 0.8], 18.0),
        ];
        let md = markdown(&c, &runs, &p);
        // Independent: spatial (0.8 + 0.4) / 2, temporal half of it, spatio-temporal
        // undefined; 33 s over 3 classes.
        assert!(
            md.contains(
                "| independent per-class models | 0.600 | 0.300 | – | 10 | 33 s | 11.0 s |"
            ),
            "{md}"
        );
        assert!(
            md.contains("| one shared model (DynaSlice) | 0.700 | 0.350 | – | 10 | 15 s | 5.0 s |"),
            "{md}"
        );
        assert!(md.contains("mean of the 2 seed(s) [0, 1]"), "{md}");
        assert!(
            md.contains("- independent per-class models: 0.800, 0.400"),
            "{md}"
        );
        assert!(
            md.contains("| independent per-class models | 0.700 | 0.600 | 0.500 |"),
            "{md}"
        );
        assert_eq!(
            md.matches("| one shared model (DynaSlice) |").count(),
            2,
            "{md}"
        );
    }
}
