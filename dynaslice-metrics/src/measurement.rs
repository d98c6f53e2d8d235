//! A model measured at its times ([`crate::motion`]), with what the numbers mean (the input's
//! units and patient frame, the classes' names, labels and colours): what `dynaslice measure`
//! prints and writes and `dynaslice report` shows, in one typed value.

use crate::motion::{self, reported_space, round, Cycle, Motion, Space, Units, RIGID_WITHIN};
use anyhow::Result;
use dynaslice_core::Model;
use dynaslice_data::{ClassInfo, TimeSeries, TimeUnit};
use dynaslice_model::ModelFile;
use dynaslice_sequence::palette;
use serde_json::{json, Value};
use std::path::Path;

/// Times measured by default over a moving model's time range.
pub const DEFAULT_TIMES: usize = 21;

/// What the figures of a model mean: its input's units and patient frame (from its run record) and its
/// classes.
pub struct Described {
    /// The input's units.
    pub units: Units,
    /// The input's patient frame; `None` where its axes have no anatomical meaning
    /// ([`reported_space`]).
    pub space: Option<Space>,
    /// The unit of the input's times.
    pub time_unit: TimeUnit,
    /// Names, source labels and recorded colours, channel order.
    pub classes: Vec<ClassInfo>,
    /// Display colour per class (recorded or the palette's).
    pub colors: Vec<[u8; 3]>,
}

impl Described {
    /// What `file`'s run record says its figures mean ([`dynaslice_model::RunRecord`]: plain
    /// units and times, LPS where it records none).
    pub fn of(file: &ModelFile) -> Described {
        let units = file.units();
        Described {
            units,
            space: reported_space(units, file.space()),
            time_unit: file.record().time_unit(),
            classes: file.classes(),
            colors: file.class_colors(),
        }
    }
}

/// A model measured at its times, with what the numbers mean.
pub struct Measurement {
    /// The figures, in the model's RAS world and units.
    pub motion: Motion,
    /// Meshing lattice cells along the longest axis of the model's domain they were measured
    /// with.
    pub resolution: u32,
    /// The input's units.
    pub units: Units,
    /// The input's patient frame; `None` where its axes have no anatomical meaning (reported
    /// as the world's x, y, z).
    pub space: Option<Space>,
    /// The unit of the input's times.
    pub time_unit: TimeUnit,
    /// Names, source labels and recorded colours, channel order.
    pub classes: Vec<ClassInfo>,
    /// Display colour per class (recorded or the palette's).
    pub colors: Vec<[u8; 3]>,
}

/// The times to measure `file` at: `requested` (named `option` in messages, e.g. `--times`),
/// each checked against the model's range, or by default [`DEFAULT_TIMES`] times over a
/// moving model's range, a static model's one time.
pub fn times_of(
    file: &ModelFile,
    requested: Option<&TimeSeries>,
    option: &str,
) -> Result<Vec<f64>> {
    let times = match requested {
        Some(series) => series.times(),
        None if file.is_static() => vec![f64::from(file.time(option, None)?)],
        None => {
            let (t0, t1) = file.model().domain().time_range();
            TimeSeries::across(t0, t1, DEFAULT_TIMES)
                .map_err(anyhow::Error::msg)?
                .times()
        }
    };
    for &t in &times {
        file.check_time(option, t as f32)?;
    }
    Ok(times)
}

impl Measurement {
    /// Measures every class of `model` at `times` with meshes of `resolution` cells
    /// ([`Motion::measure`]; `measured` after each time), described by `what`.
    pub fn measure(
        model: &Model,
        times: &[f64],
        resolution: u32,
        what: Described,
        measured: impl FnMut(),
    ) -> Result<Measurement> {
        let motion = Motion::measure(model, times, resolution, measured)?;
        Ok(Measurement {
            motion,
            resolution,
            units: what.units,
            space: what.space,
            time_unit: what.time_unit,
            classes: what.classes,
            colors: what.colors,
        })
    }

    /// Measures every class of `file` at `times` with meshes of `resolution` cells, in the units
    /// and frame its run record gives ([`Described::of`]); `measured` after each time.
    pub fn of_file(
        file: &ModelFile,
        times: &[f64],
        resolution: u32,
        measured: impl FnMut(),
    ) -> Result<Measurement> {
        Self::measure(
            &file.model(),
            times,
            resolution,
            Described::of(file),
            measured,
        )
    }

    /// The name of the frame positions are given in: `LPS`, `RAS` or `xyz`.
    pub fn space_name(&self) -> &'static str {
        motion::space_name(self.space)
    }

    /// What the positive direction of each axis points to (`L`, `P`, `S` in LPS).
    pub fn positive(&self) -> [&'static str; 3] {
        motion::positive(self.space)
    }

    /// Whether the axes are anatomical (x left–right, y anterior–posterior, z
    /// superior–inferior).
    pub fn is_anatomical(&self) -> bool {
        self.space.is_some()
    }

    /// Short names of the axes: `LR`, `AP`, `SI`, or `x`, `y`, `z` where not anatomical.
    pub fn axis_names(&self) -> [&'static str; 3] {
        if self.is_anatomical() {
            ["LR", "AP", "SI"]
        } else {
            ["x", "y", "z"]
        }
    }

    /// A point of the model's RAS world in the reported frame.
    pub fn from_world(&self, p: [f64; 3]) -> [f64; 3] {
        motion::from_world(self.space, p)
    }

    /// The time axis's name, with the unit the model records for its input's times
    /// ([`TimeUnit::axis`]).
    pub fn time_axis(&self) -> &'static str {
        self.time_unit.axis()
    }
}

impl Measurement {
    /// Source labels, channel order.
    pub fn labels(&self) -> Vec<i32> {
        self.classes.iter().map(|c| c.label).collect()
    }

    /// The per-time CSV table.
    pub fn to_csv(&self) -> String {
        self.motion.to_csv(&self.labels(), self.units, self.space)
    }

    /// Class `k`'s figures over the times.
    pub fn cycle(&self, k: usize) -> Cycle {
        self.motion.cycle(k)
    }

    /// A world volume in the reported unit, rounded as every output prints it.
    pub fn volume(&self, v: f64) -> f64 {
        round(self.units.from_world_volume(v))
    }

    /// The per-class figures over the times as lines of text (what `dynaslice measure` prints
    /// on standard error): a header naming the units and frame, then per class its volume
    /// range, as rigid where the volume is constant within [`RIGID_WITHIN`] and with its volume
    /// change otherwise, and the centroid's peak-to-peak range.
    pub fn summary(&self) -> Vec<String> {
        let (v, l) = (self.units.volume(), self.units.length());
        let [x, y, z] = self.positive();
        let times = &self.motion.times;
        let mut lines = vec![format!(
            "{} times from {} to {}; {} in {v}, positions in {l} ({}: +x {x}, +y {y}, +z {z})",
            times.len(),
            times[0],
            times[times.len() - 1],
            if self.units == Units::Plain {
                "plain input units (the input names none)"
            } else {
                "volumes"
            },
            self.space_name(),
        )];
        let [p, q, r] = self.axis_names();
        let percent = |r: Option<f64>| r.map_or("-".into(), |r| format!("{:.1} %", 100.0 * r));
        let mut changing = false;
        for (k, c) in self.classes.iter().enumerate() {
            let cycle = self.cycle(k);
            let amplitude = cycle.amplitude.map_or("absent at every time".into(), |a| {
                let a = a.map(round);
                format!("{p} {} / {q} {} / {r} {} {l}", a[0], a[1], a[2])
            });
            let (lo, hi) = (cycle.min, cycle.max);
            let range = format!(
                "volume {} {v} (t = {}) to {} {v} (t = {})",
                self.volume(lo.volume),
                lo.time,
                self.volume(hi.volume),
                hi.time,
            );
            let volume = if times.len() == 1 {
                format!("volume {} {v}", self.volume(lo.volume))
            } else if cycle.is_rigid() {
                format!(
                    "rigid: {range}, constant within {:.0} % (changes {})",
                    100.0 * RIGID_WITHIN,
                    percent(cycle.relative_change)
                )
            } else {
                changing = true;
                format!(
                    "{range}, change {} {v} = {} of the largest",
                    self.volume(cycle.volume_change),
                    percent(cycle.relative_change)
                )
            };
            lines.push(format!(
                "  {:?}: {volume}; peak-to-peak {amplitude}",
                c.name
            ));
        }
        if changing {
            lines.push(
                "  (for a ventricle the change is the stroke volume, and its share of the \
                 largest the ejection fraction)"
                    .into(),
            );
        }
        lines
    }

    /// Everything as one JSON object (`classes[k]`: `name`, `label`, `color`, `volume_ml` per
    /// time, `amplitude_mm` {`lr`, `ap`, `si`}, `volume_change`, `relative_volume_change`,
    /// `rigid`, …), numbers rounded as in the CSV. `stroke_volume` and `ejection_fraction` are
    /// `volume_change` and `relative_volume_change` under their cardiac names, kept for the
    /// scripts that read them. Where the units are not millimetres, `volume_ml` and `amplitude_mm` are null and
    /// `volume` and `amplitude` hold the plain values.
    pub fn to_json(&self, model: &Path) -> Value {
        let m = &self.motion;
        let mm = self.units == Units::Millimetres;
        let point = |p: Option<[f64; 3]>| p.map(|p| self.from_world(p).map(round));
        let classes: Vec<Value> = self
            .classes
            .iter()
            .enumerate()
            .map(|(k, c)| {
                let cycle = m.cycle(k);
                let volumes: Vec<f64> = m.shapes.iter().map(|s| self.volume(s[k].volume)).collect();
                let amplitude = cycle.amplitude.map(|a| a.map(round));
                let anatomical = amplitude
                    .filter(|_| self.is_anatomical())
                    .map(|[lr, ap, si]| json!({"lr": lr, "ap": ap, "si": si}));
                let boxes: Vec<Option<Value>> = m
                    .shapes
                    .iter()
                    .map(|s| {
                        s[k].bounds.map(|(lo, hi)| {
                            let (a, b) = (self.from_world(lo), self.from_world(hi));
                            let min: [f64; 3] = std::array::from_fn(|i| round(a[i].min(b[i])));
                            let max: [f64; 3] = std::array::from_fn(|i| round(a[i].max(b[i])));
                            json!({"min": min, "max": max})
                        })
                    })
                    .collect();
                let centroids: Vec<Option<[f64; 3]>> =
                    m.shapes.iter().map(|s| point(s[k].centroid)).collect();
                json!({
                    "name": c.name,
                    "label": c.label,
                    "color": palette::to_hex(self.colors[k]),
                    "volume": volumes,
                    "volume_ml": if mm { json!(volumes) } else { Value::Null },
                    "centroid": centroids,
                    "bounding_box": boxes,
                    "min_volume": {"volume": self.volume(cycle.min.volume), "time": cycle.min.time},
                    "max_volume": {"volume": self.volume(cycle.max.volume), "time": cycle.max.time},
                    "volume_change": self.volume(cycle.volume_change),
                    "relative_volume_change": cycle.relative_change.map(round),
                    "rigid": cycle.is_rigid(),
                    "stroke_volume": self.volume(cycle.volume_change),
                    "ejection_fraction": cycle.relative_change.map(round),
                    "amplitude": amplitude.map(|[x, y, z]| json!({"x": x, "y": y, "z": z})),
                    "amplitude_mm": if mm { anatomical.unwrap_or(Value::Null) } else { Value::Null },
                })
            })
            .collect();
        json!({
            "model": model.display().to_string(),
            "units": {
                "length": self.units.length(),
                "volume": self.units.volume(),
                "time": self.time_axis(),
            },
            "frame": {
                "name": self.space_name(),
                "positive": self.positive(),
            },
            "times": m.times,
            "classes": classes,
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use dynaslice_core::ModelBytes;
    use dynaslice_test_support::spheres::{writer_in, Sphere, SPHERES_DOMAIN};

    /// The time axis names the unit the run record holds, and no unit where it holds none
    /// (whatever the patient frame).
    #[test]
    fn the_time_axis_names_the_recorded_unit() {
        for (metadata, axis) in [
            ("space = RAS\ntime_unit = ms\n", "time (ms)"),
            ("space = LPS\ntime_unit = manifest\n", "time (manifest)"),
            ("space = RAS\n", "time"),
        ] {
            let ball = Sphere::new([0.0; 3], 0.3, 0.1);
            let mut writer = writer_in(SPHERES_DOMAIN, &[ball], &[("ball", 1)]);
            writer.metadata = metadata.into();
            let bytes = ModelBytes::copy_from(&writer.to_bytes());
            let file = ModelFile::from_bytes(bytes, Path::new("m.dsm")).unwrap();
            let m = Measurement::of_file(&file, &[0.5], 8, || {}).unwrap();
            assert_eq!(m.time_axis(), axis, "{metadata}");
        }
    }
}
