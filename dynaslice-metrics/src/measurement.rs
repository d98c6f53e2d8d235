//! A model measured at its times ([`crate::motion`]), with what the numbers mean (the input's
//! units and patient frame, the classes' names, labels and colours): what `dynaslice measure`
//! prints and writes and `dynaslice report` shows, in one typed value.

use crate::motion::{round, Cycle, Frame, Motion, Units};
use anyhow::Result;
use dynaslice_core::Model;
use dynaslice_data::ClassInfo;
use dynaslice_sequence::palette;
use serde_json::{json, Value};
use std::path::Path;

/// What the figures of a model mean: its input's units and frame (from its run record) and its
/// classes.
pub struct Described {
    /// The input's units.
    pub units: Units,
    /// The input's patient frame.
    pub frame: Frame,
    /// Names, source labels and recorded colours, channel order.
    pub classes: Vec<ClassInfo>,
    /// Display colour per class (recorded or the palette's).
    pub colors: Vec<[u8; 3]>,
}

/// A model measured at its times, with what the numbers mean.
pub struct Measurement {
    /// The figures, in the model's RAS world and units.
    pub motion: Motion,
    /// The input's units.
    pub units: Units,
    /// The input's patient frame.
    pub frame: Frame,
    /// Names, source labels and recorded colours, channel order.
    pub classes: Vec<ClassInfo>,
    /// Display colour per class (recorded or the palette's).
    pub colors: Vec<[u8; 3]>,
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
            units: what.units,
            frame: what.frame,
            classes: what.classes,
            colors: what.colors,
        })
    }
}

/// The time axis's name for `frame`'s inputs: NIfTI frames are seconds apart
/// (`pixdim[4]`), a DICOM manifest's times are its own (often % of the breathing cycle).
pub fn time_axis(frame: Frame) -> &'static str {
    match frame {
        Frame::Ras => "time (s)",
        Frame::Lps => "time (manifest)",
        Frame::Plain => "time",
    }
}

impl Measurement {
    /// Source labels, channel order.
    pub fn labels(&self) -> Vec<i32> {
        self.classes.iter().map(|c| c.label).collect()
    }

    /// The per-time CSV table.
    pub fn to_csv(&self) -> String {
        self.motion.to_csv(&self.labels(), self.units, self.frame)
    }

    /// Class `k`'s figures over the times.
    pub fn cycle(&self, k: usize) -> Cycle {
        self.motion.cycle(k)
    }

    /// A world volume in the reported unit, rounded as every output prints it.
    pub fn volume(&self, v: f64) -> f64 {
        round(self.units.from_world_volume(v))
    }

    /// Everything as one JSON object (`classes[k]`: `name`, `label`, `color`, `volume_ml` per
    /// time, `amplitude_mm` {`lr`, `ap`, `si`}, `ejection_fraction`, …), numbers rounded as in
    /// the CSV. Where the units are not millimetres, `volume_ml` and `amplitude_mm` are null and
    /// `volume` and `amplitude` hold the plain values.
    pub fn to_json(&self, model: &Path) -> Value {
        let m = &self.motion;
        let mm = self.units == Units::Millimetres;
        let point = |p: Option<[f64; 3]>| p.map(|p| self.frame.from_world(p).map(round));
        let classes: Vec<Value> = self
            .classes
            .iter()
            .enumerate()
            .map(|(k, c)| {
                let cycle = m.cycle(k);
                let volumes: Vec<f64> = m.shapes.iter().map(|s| self.volume(s[k].volume)).collect();
                let amplitude = cycle.amplitude.map(|a| a.map(round));
                let anatomical = amplitude
                    .filter(|_| self.frame.is_anatomical())
                    .map(|[lr, ap, si]| json!({"lr": lr, "ap": ap, "si": si}));
                let boxes: Vec<Option<Value>> = m
                    .shapes
                    .iter()
                    .map(|s| {
                        s[k].bounds.map(|(lo, hi)| {
                            let (a, b) = (self.frame.from_world(lo), self.frame.from_world(hi));
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
                    "stroke_volume": self.volume(cycle.stroke_volume),
                    "ejection_fraction": cycle.ejection_fraction.map(round),
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
                "time": time_axis(self.frame),
            },
            "frame": {
                "name": self.frame.name(),
                "positive": self.frame.positive(),
            },
            "times": m.times,
            "classes": classes,
        })
    }
}
