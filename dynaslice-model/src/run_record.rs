//! The run record: what a model file's metadata says about the run that trained it, typed
//! (smoltcp's `Repr` idea). The trainer writes its metadata only through [`RunRecord::emit`];
//! every reader goes through [`RunRecord::parse`] or [`RunRecord::parse_lossy`]. The text is
//! `key = value` lines in a fixed order ([`RunRecord::emit`]), what `dynaslice info` prints.
//!
//! # Models written before a key existed
//!
//! One rule, the same for every consumer: **a key a model lacks reads as `None`**, and nothing
//! is guessed from other keys (no file-name extensions, no manifests). Where a consumer needs a
//! value anyway, the record's accessors give it:
//!
//! - [`RunRecord::space`]: LPS, the frame every output of those models was tagged with
//!   ([`Space::default`]);
//! - [`RunRecord::units`]: [`Units::Plain`], no unit claimed where none was recorded;
//! - [`RunRecord::time_unit`]: [`TimeUnit::Plain`], likewise;
//! - [`RunRecord::channel_colors`]: no colour (the palette's colour for the channel).
//!
//! A line whose key the record does not know is kept verbatim ([`RunRecord::other`]), and
//! emitted after the known keys.

use dynaslice_core::Model;
use dynaslice_sequence::nesting::{from_labels, Nested};
use dynaslice_sequence::palette::{parse_hex, to_hex};
use dynaslice_sequence::{ClassInfo, Space, TimeUnit, Units};
use std::fmt::Write as _;

/// The samples one training step draws (dynaslice-train's `SampleCounts`), as recorded.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct SampleRecord {
    /// Contour points per class, up to `budget_classes` classes.
    pub contour_per_class: usize,
    /// Plane samples per class, up to `budget_classes` classes.
    pub plane_per_class: usize,
    /// Classes whose full per-class counts make the per-step budget.
    pub budget_classes: usize,
    /// The fewest contour and plane samples a class gets when classes share the budget.
    pub min_per_class: usize,
    /// Space-time samples, shared by all channels.
    pub space_time: usize,
}

impl SampleRecord {
    /// The recorded text: `1024 contour + 1024 plane per class up to 3 classes, shared beyond
    /// (at least 64 per class), 1024 space-time`.
    pub fn describe(&self) -> String {
        format!(
            "{} contour + {} plane per class up to {} classes, shared beyond (at least {} per \
             class), {} space-time",
            self.contour_per_class,
            self.plane_per_class,
            self.budget_classes,
            self.min_per_class,
            self.space_time
        )
    }
}

/// A recorded class colour: (source label, `#rrggbb`).
pub type ClassColor = (i32, [u8; 3]);

/// A recorded nesting: (inner, outer) by source label.
pub type NestedLabels = (i32, i32);

/// The typed metadata of a model file: every key the trainer writes, each `None` where a model
/// does not record it (see the module's rule for older models). Fields are in the order
/// [`RunRecord::emit`] writes them.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct RunRecord {
    /// `trainer`: the program and version that wrote the model (`dynaslice 0.1.0`).
    pub trainer: Option<String>,
    /// `input`: the inputs as the user named them (`a.nii.gz + b.nii.gz`).
    pub input: Option<String>,
    /// `frames`: the timesteps kept (`A:B:STEP`).
    pub frames: Option<String>,
    /// `reading`: the input options training read its input with, by flag name
    /// (`labels=1,2,3; planes=sparse`: dynaslice-data's `InputSpec::reading`); commands given
    /// the input again read it the same way.
    pub reading: Option<String>,
    /// `space`: the patient frame of the input's coordinates, which outputs default to.
    pub space: Option<Space>,
    /// `units`: the input's length unit.
    pub units: Option<Units>,
    /// `time_unit`: the unit of the input's times.
    pub time_unit: Option<TimeUnit>,
    /// `nesting`: classes drawn nested and trained disjoint, `(inner, outer)` by source label
    /// (`3:7 5:3`), each class with its direct outer (`dynaslice_sequence::nesting`).
    pub nesting: Option<Vec<NestedLabels>>,
    /// `widths`: the sine layers' widths.
    pub widths: Option<Vec<u32>>,
    /// `steps`: steps of the full schedule.
    pub steps: Option<u64>,
    /// `seed`: seed of initialisation and sampling.
    pub seed: Option<u64>,
    /// `threads`: worker threads.
    pub threads: Option<usize>,
    /// `omega_0`: SIREN's ω₀.
    pub omega_0: Option<f32>,
    /// `offset`: initial value of every channel, normalised units.
    pub offset: Option<f32>,
    /// `omega_t_max`: ω_t^max in normalised time (Eq. 4); `inf` where temporal control was off.
    pub omega_t_max: Option<f32>,
    /// `plane_band`: the bound on the first layer's |⟨ω_x, n⟩| across the data's parallel
    /// planes, in normalised units (c·π/Δs); absent where the planes were not all parallel or
    /// the band was switched off (and in models trained before it existed).
    pub plane_band: Option<f32>,
    /// `extent_margin`: how far past its outermost contour points (world units: half the
    /// planes' spacing) each class's box reached, beyond which training held the class
    /// outside; absent where the planes were not all parallel (and in models trained before
    /// it existed).
    pub extent_margin: Option<f32>,
    /// `between_pairs`: per class, the neighbouring parallel planes that both outline it,
    /// between which training asked f to take the side of their blended in-plane distances
    /// (`[3, 6, 5]`); absent where no two such planes exist (and in models trained before it
    /// existed).
    pub between_pairs: Option<Vec<u32>>,
    /// `lr`: the initial and final learning rates (`0.001 -> 0.00001`).
    pub lr: Option<(f32, f32)>,
    /// `warmup_steps`: steps of the learning-rate ramp.
    pub warmup_steps: Option<u64>,
    /// `lambda_orientation`: λ_n (Eq. 6).
    pub lambda_orientation: Option<f32>,
    /// `lambda_plane`: λ_d (Eq. 7).
    pub lambda_plane: Option<f32>,
    /// `lambda_regulariser`: λ_r (Eq. 8).
    pub lambda_regulariser: Option<f32>,
    /// `alpha`: α of exp(−α|f|), normalised units.
    pub alpha: Option<f32>,
    /// `temporal_factor`: c of ω_t^max = c·π/Δt (Eq. 4).
    pub temporal_factor: Option<f32>,
    /// `steps_done`: steps completed.
    pub steps_done: Option<u64>,
    /// `planned_steps`: a timed run's schedule length, what its cosine was fitted to.
    pub planned_steps: Option<u64>,
    /// `samples`: the samples of one step.
    pub samples: Option<SampleRecord>,
    /// `class_weights`: per-class weights of the contour and plane terms.
    pub class_weights: Option<Vec<f32>>,
    /// `class_colors`: the input's class colours, (label, colour) in class order, for the
    /// classes that had one (`1:#e6194b 2:#3cb44b`).
    pub class_colors: Option<Vec<ClassColor>>,
    /// `final_loss`: the weighted loss of the last step.
    pub final_loss: Option<f64>,
    /// Lines this record does not know (another writer's keys, lines without `=`) and known
    /// keys whose value did not parse ([`RunRecord::parse_lossy`]), verbatim, in order.
    pub other: Vec<String>,
}

/// A value of one metadata key: its text form both ways.
trait Field: Sized {
    /// The value of `text` (trimmed), or what is wrong with it.
    fn parse(text: &str) -> Result<Self, String>;
    /// The text written after `key = `.
    fn emit(&self, out: &mut String);
}

impl Field for String {
    fn parse(text: &str) -> Result<Self, String> {
        Ok(text.to_string())
    }
    fn emit(&self, out: &mut String) {
        out.push_str(self);
    }
}

/// Numbers written with `Display` (the shortest text that reads back to the same value).
macro_rules! display_field {
    ($($t:ty),*) => {$(
        impl Field for $t {
            fn parse(text: &str) -> Result<Self, String> {
                text.parse().map_err(|_| format!("{text:?} is not a number"))
            }
            fn emit(&self, out: &mut String) {
                let _ = write!(out, "{self}");
            }
        }
    )*};
}
display_field!(u64, usize, f32, f64);

impl Field for Space {
    fn parse(text: &str) -> Result<Self, String> {
        Space::from_name(text).ok_or_else(|| format!("{text:?} is not RAS or LPS"))
    }
    fn emit(&self, out: &mut String) {
        out.push_str(self.name());
    }
}

impl Field for Units {
    fn parse(text: &str) -> Result<Self, String> {
        Units::from_name(text).ok_or_else(|| format!("{text:?} is not mm or none"))
    }
    fn emit(&self, out: &mut String) {
        out.push_str(self.name());
    }
}

impl Field for TimeUnit {
    fn parse(text: &str) -> Result<Self, String> {
        TimeUnit::from_name(text)
            .ok_or_else(|| format!("{text:?} is not s, ms, us, manifest or none"))
    }
    fn emit(&self, out: &mut String) {
        out.push_str(self.name());
    }
}

/// A list as Rust's `Debug` writes it (`[256, 256]`, `[3.0, 1.0]`).
fn parse_list<T: std::str::FromStr>(text: &str) -> Result<Vec<T>, String> {
    let inner = text
        .strip_prefix('[')
        .and_then(|t| t.strip_suffix(']'))
        .ok_or_else(|| format!("{text:?} is not a [a, b, …] list"))?;
    if inner.trim().is_empty() {
        return Ok(Vec::new());
    }
    inner
        .split(',')
        .map(|v| {
            v.trim()
                .parse()
                .map_err(|_| format!("{:?} in {text:?} is not a number", v.trim()))
        })
        .collect()
}

impl Field for Vec<u32> {
    fn parse(text: &str) -> Result<Self, String> {
        parse_list(text)
    }
    fn emit(&self, out: &mut String) {
        let _ = write!(out, "{self:?}");
    }
}

impl Field for Vec<f32> {
    fn parse(text: &str) -> Result<Self, String> {
        parse_list(text)
    }
    fn emit(&self, out: &mut String) {
        let _ = write!(out, "{self:?}");
    }
}

impl Field for (f32, f32) {
    fn parse(text: &str) -> Result<Self, String> {
        let (a, b) = text
            .split_once("->")
            .ok_or_else(|| format!("{text:?} is not FIRST -> LAST"))?;
        Ok((f32::parse(a.trim())?, f32::parse(b.trim())?))
    }
    fn emit(&self, out: &mut String) {
        let _ = write!(out, "{} -> {}", self.0, self.1);
    }
}

impl Field for SampleRecord {
    fn parse(text: &str) -> Result<Self, String> {
        // The literal pieces between the five numbers of `SampleRecord::describe`.
        const PIECES: [&str; 5] = [
            " contour + ",
            " plane per class up to ",
            " classes, shared beyond (at least ",
            " per class), ",
            " space-time",
        ];
        let bad = || format!("{text:?} is not {:?}", SampleRecord::describe(&EXAMPLE));
        let mut rest = text;
        let mut n = [0usize; 5];
        for (value, piece) in n.iter_mut().zip(PIECES) {
            let (number, after) = rest.split_once(piece).ok_or_else(bad)?;
            *value = number.trim().parse().map_err(|_| bad())?;
            rest = after;
        }
        if !rest.is_empty() {
            return Err(bad());
        }
        Ok(SampleRecord {
            contour_per_class: n[0],
            plane_per_class: n[1],
            budget_classes: n[2],
            min_per_class: n[3],
            space_time: n[4],
        })
    }
    fn emit(&self, out: &mut String) {
        out.push_str(&self.describe());
    }
}

/// The shape of a `samples` value, named in its parse error.
const EXAMPLE: SampleRecord = SampleRecord {
    contour_per_class: 1024,
    plane_per_class: 1024,
    budget_classes: 3,
    min_per_class: 64,
    space_time: 1024,
};

impl Field for Vec<NestedLabels> {
    fn parse(text: &str) -> Result<Self, String> {
        text.split_whitespace()
            .map(|entry| {
                entry
                    .split_once(':')
                    .and_then(|(inner, outer)| Some((inner.parse().ok()?, outer.parse().ok()?)))
                    .ok_or_else(|| format!("entry {entry:?} is not INNER:OUTER (two labels)"))
            })
            .collect()
    }
    fn emit(&self, out: &mut String) {
        let entries: Vec<String> = self.iter().map(|(i, o)| format!("{i}:{o}")).collect();
        out.push_str(&entries.join(" "));
    }
}

impl Field for Vec<ClassColor> {
    fn parse(text: &str) -> Result<Self, String> {
        let mut colors: Vec<ClassColor> = Vec::new();
        for entry in text.split_whitespace() {
            let parsed = entry
                .split_once(':')
                .and_then(|(label, hex)| Some((label.parse::<i32>().ok()?, parse_hex(hex)?)));
            let Some((label, color)) = parsed else {
                return Err(format!("entry {entry:?} is not LABEL:#rrggbb"));
            };
            if colors.iter().any(|&(l, _)| l == label) {
                return Err(format!("label {label} is given twice"));
            }
            colors.push((label, color));
        }
        Ok(colors)
    }
    fn emit(&self, out: &mut String) {
        let entries: Vec<String> = self
            .iter()
            .map(|&(label, color)| format!("{label}:{}", to_hex(color)))
            .collect();
        out.push_str(&entries.join(" "));
    }
}

/// The record's keys and fields, in the order they are written: one list for both directions.
macro_rules! fields {
    ($($field:ident = $key:literal),* $(,)?) => {
        impl RunRecord {
            /// Every key the record knows, in the order [`RunRecord::emit`] writes them.
            pub const KEYS: &'static [&'static str] = &[$($key),*];

            /// Sets the field of `key` from `value`: `None` when the key is unknown, else
            /// whether the value parsed (an error names the key).
            fn set(&mut self, key: &str, value: &str) -> Option<Result<(), String>> {
                match key {
                    $($key => Some(match Field::parse(value) {
                        Ok(v) => {
                            self.$field = Some(v);
                            Ok(())
                        }
                        Err(e) => Err(format!("{}: {e}", $key)),
                    }),)*
                    _ => None,
                }
            }

            /// Whether the field of `key` is set.
            fn has(&self, key: &str) -> bool {
                match key {
                    $($key => self.$field.is_some(),)*
                    _ => false,
                }
            }

            /// The recorded fields as (key, value) in the order of [`RunRecord::KEYS`], each
            /// value as [`RunRecord::emit`] writes it, then [`RunRecord::other`]'s lines that
            /// have a `=`: what a page or a listing shows.
            pub fn entries(&self) -> Vec<(String, String)> {
                let mut out = Vec::new();
                $(if let Some(v) = &self.$field {
                    let mut value = String::new();
                    v.emit(&mut value);
                    out.push(($key.to_string(), value));
                })*
                for line in &self.other {
                    if let Some((k, v)) = line.split_once('=') {
                        out.push((k.trim().to_string(), v.trim().to_string()));
                    }
                }
                out
            }

            /// The metadata text: one `key = value` line per recorded field in the order of
            /// [`RunRecord::KEYS`], then [`RunRecord::other`]'s lines; each line ends in `\n`.
            pub fn emit(&self) -> String {
                let mut out = String::new();
                $(if let Some(v) = &self.$field {
                    out.push_str($key);
                    out.push_str(" = ");
                    v.emit(&mut out);
                    out.push('\n');
                })*
                for line in &self.other {
                    out.push_str(line);
                    out.push('\n');
                }
                out
            }
        }
    };
}

fields! {
    trainer = "trainer",
    input = "input",
    frames = "frames",
    reading = "reading",
    space = "space",
    units = "units",
    time_unit = "time_unit",
    nesting = "nesting",
    widths = "widths",
    steps = "steps",
    seed = "seed",
    threads = "threads",
    omega_0 = "omega_0",
    offset = "offset",
    omega_t_max = "omega_t_max",
    plane_band = "plane_band",
    extent_margin = "extent_margin",
    between_pairs = "between_pairs",
    lr = "lr",
    warmup_steps = "warmup_steps",
    lambda_orientation = "lambda_orientation",
    lambda_plane = "lambda_plane",
    lambda_regulariser = "lambda_regulariser",
    alpha = "alpha",
    temporal_factor = "temporal_factor",
    steps_done = "steps_done",
    planned_steps = "planned_steps",
    samples = "samples",
    class_weights = "class_weights",
    class_colors = "class_colors",
    final_loss = "final_loss",
}

impl RunRecord {
    /// The record of `metadata`: every `key = value` line of a known key sets its field (the
    /// key is the text before the first `=`, key and value trimmed; the first of a repeated key
    /// counts). Also returns what is wrong, one line per problem naming its key: a value that
    /// does not parse (its line is kept in [`RunRecord::other`] and the field left `None`) or a
    /// key given twice. Readers that must go on (a model is still usable with a malformed line)
    /// warn with these; [`RunRecord::parse`] refuses them.
    pub fn parse_lossy(metadata: &str) -> (RunRecord, Vec<String>) {
        let mut record = RunRecord::default();
        let mut problems = Vec::new();
        for line in metadata.lines() {
            let Some((key, value)) = line.split_once('=') else {
                record.other.push(line.to_string());
                continue;
            };
            let key = key.trim();
            if record.has(key) {
                problems.push(format!("{key}: given twice; the first is used"));
                continue;
            }
            match record.set(key, value.trim()) {
                Some(Ok(())) => {}
                Some(Err(e)) => {
                    problems.push(e);
                    record.other.push(line.to_string());
                }
                None => record.other.push(line.to_string()),
            }
        }
        (record, problems)
    }

    /// The record of `metadata` ([`RunRecord::parse_lossy`]), or its first problem.
    pub fn parse(metadata: &str) -> Result<RunRecord, String> {
        match RunRecord::parse_lossy(metadata) {
            (record, problems) if problems.is_empty() => Ok(record),
            (_, problems) => Err(problems.join("; ")),
        }
    }

    /// The record `model`'s metadata holds ([`RunRecord::parse`]).
    pub fn of(model: &Model) -> Result<RunRecord, String> {
        RunRecord::parse(model.metadata())
    }

    /// The patient frame of the input's coordinates; LPS where none is recorded (the module's
    /// rule).
    pub fn space(&self) -> Space {
        self.space.unwrap_or_default()
    }

    /// The input's length unit; [`Units::Plain`] where none is recorded (the module's rule).
    pub fn units(&self) -> Units {
        self.units.unwrap_or(Units::Plain)
    }

    /// The unit of the input's times; [`TimeUnit::Plain`] where none is recorded (the
    /// module's rule).
    pub fn time_unit(&self) -> TimeUnit {
        self.time_unit.unwrap_or(TimeUnit::Plain)
    }

    /// The nesting of `model`'s classes ([`RunRecord::nesting`] as class indices, checked);
    /// empty where none is recorded.
    pub fn nested(&self, model: &Model) -> Result<Vec<Nested>, String> {
        let labels: Vec<i32> = model.classes().map(|c| c.label).collect();
        from_labels(self.nesting.as_deref().unwrap_or_default(), &labels)
    }

    /// The recorded colours of `classes` that have one, in class order (`None`: no class has
    /// one, and the line is not written).
    pub fn colors_of(classes: &[ClassInfo]) -> Option<Vec<ClassColor>> {
        let colors: Vec<ClassColor> = classes
            .iter()
            .filter_map(|c| Some((c.label, c.color?)))
            .collect();
        (!colors.is_empty()).then_some(colors)
    }

    /// The colour recorded for each of `model`'s channels, matched by label, `None` for a
    /// channel it records none for (the module's rule).
    pub fn channel_colors(&self, model: &Model) -> Vec<Option<[u8; 3]>> {
        let recorded = self.class_colors.as_deref().unwrap_or_default();
        model
            .classes()
            .map(|c| {
                recorded
                    .iter()
                    .find(|&&(label, _)| label == c.label)
                    .map(|&(_, color)| color)
            })
            .collect()
    }
}

/// The colour `model`'s metadata records for each of its channels
/// ([`RunRecord::channel_colors`]); an error says what is malformed in its `class_colors` line
/// (other keys' problems are not this function's).
pub fn recorded_class_colors(model: &Model) -> Result<Vec<Option<[u8; 3]>>, String> {
    let (record, problems) = RunRecord::parse_lossy(model.metadata());
    match problems
        .into_iter()
        .find(|p| p.starts_with("class_colors:"))
    {
        Some(p) => Err(p),
        None => Ok(record.channel_colors(model)),
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use dynaslice_core::ModelBytes;

    /// Metadata as the trainer writes it, every key present.
    const FULL: &str = "trainer = dynaslice 0.1.0\ninput = a.nii.gz + b.nii.gz\nframes = 0:\n\
        reading = labels=1,2,3; planes=sparse\nspace = RAS\nunits = mm\ntime_unit = ms\nnesting = 2:1 -3:2\nwidths = [256, 256, 256]\nsteps = 3000\nseed = 7\nthreads = 2\n\
        omega_0 = 20\noffset = 0.2\nomega_t_max = inf\nplane_band = 3.1101768\nextent_margin = 1.5\nbetween_pairs = [3, 0]\nlr = 0.0001 -> 0.000001\n\
        warmup_steps = 0\nlambda_orientation = 0.1\nlambda_plane = 1\nlambda_regulariser = 0.05\n\
        alpha = 100\ntemporal_factor = 0.5\nsteps_done = 3000\nplanned_steps = 2871\n\
        samples = 1024 contour + 1024 plane per class up to 3 classes, shared beyond (at least \
        64 per class), 1024 space-time\nclass_weights = [3.0, 1.5]\n\
        class_colors = 1:#e6194b -7:#0000ff\nfinal_loss = 0.012345678901234\n";

    #[test]
    fn every_key_round_trips_byte_for_byte() {
        let record = RunRecord::parse(FULL).unwrap();
        assert_eq!(record.emit(), FULL);
        for key in RunRecord::KEYS {
            assert!(record.has(key), "{key} not parsed");
        }
        assert!(record.other.is_empty());
        assert_eq!(record.lr, Some((1e-4, 1e-6)));
        assert_eq!(record.omega_t_max, Some(f32::INFINITY));
        assert_eq!(record.plane_band, Some(3.1101768));
        assert_eq!(record.extent_margin, Some(1.5));
        assert_eq!(record.between_pairs, Some(vec![3, 0]));
        assert_eq!(record.samples.unwrap().min_per_class, 64);
        assert_eq!(
            record.class_colors.as_deref().unwrap()[1],
            (-7, [0, 0, 255])
        );
        assert_eq!(record.nesting.as_deref(), Some(&[(2, 1), (-3, 2)][..]));
        assert_eq!(RunRecord::parse(&record.emit()).unwrap(), record);
    }

    /// The one rule for models written before a key existed: absent reads as `None`, and the
    /// accessors give LPS, plain units and no colours, whatever else the model records.
    #[test]
    fn missing_keys_follow_the_one_rule() {
        let old = RunRecord::parse("trainer = dynaslice 0.1.0\ninput = RS.dcm\n").unwrap();
        assert_eq!(old.space, None);
        assert_eq!(old.space(), Space::Lps);
        assert_eq!(old.units(), Units::Plain);
        assert_eq!(old.time_unit(), TimeUnit::Plain);
        assert_eq!(old.class_colors, None);
        assert_eq!(RunRecord::parse("").unwrap(), RunRecord::default());
    }

    #[test]
    fn unknown_lines_are_kept_and_bad_values_named() {
        let text = "note without equals\nfuture_key = 3\nsteps = 10\n";
        let record = RunRecord::parse(text).unwrap();
        assert_eq!(record.steps, Some(10));
        assert_eq!(record.other, ["note without equals", "future_key = 3"]);
        for (bad, key) in [
            ("steps = ten", "steps"),
            ("space = XYZ", "space"),
            ("widths = 256, 256", "widths"),
            ("lr = 0.1", "lr"),
            ("samples = 1024 contour", "samples"),
            ("class_colors = 1:#zz0000", "class_colors"),
            ("class_colors = 1=#ff0000", "class_colors"),
            ("class_colors = x:#ff0000", "class_colors"),
            ("class_colors = 1:#ff0000 1:#00ff00", "class_colors"),
            ("nesting = 2-1", "nesting"),
            ("nesting = 2:x", "nesting"),
            ("seed = 1\nseed = 2", "seed"),
        ] {
            let e = RunRecord::parse(bad).unwrap_err();
            assert!(e.starts_with(&format!("{key}:")), "{bad}: {e}");
            let (lossy, problems) = RunRecord::parse_lossy(bad);
            assert_eq!(problems.len(), 1, "{bad}");
            if key != "seed" {
                assert!(!lossy.has(key), "{bad}");
            }
        }
    }

    #[test]
    fn class_colours_are_recorded_for_the_classes_that_have_one() {
        let class = |name: &str, label, color| ClassInfo {
            name: name.into(),
            label,
            color,
        };
        let classes = [
            class("a", 1, Some([0xe6, 0x19, 0x4b])),
            class("b", 2, None),
            class("c", -7, Some([0, 0, 255])),
        ];
        let record = RunRecord {
            class_colors: RunRecord::colors_of(&classes),
            ..RunRecord::default()
        };
        assert_eq!(record.emit(), "class_colors = 1:#e6194b -7:#0000ff\n");
        assert_eq!(RunRecord::colors_of(&classes[1..2]), None);
    }

    /// Each channel gets the colour recorded for its label, in channel order whatever the
    /// line's order; a channel without one gets `None`; a malformed line is an error.
    #[test]
    fn recorded_colours_follow_the_channels_by_label() {
        use dynaslice_core::format::ModelWriter;
        let mut w = ModelWriter::random_siren(&[8], 3, 1);
        w.classes = vec![("a".into(), 5), ("b".into(), 1), ("c".into(), 9)];
        w.metadata = "class_colors = 9:#0000ff 5:#e6194b\nsteps = x\n".into();
        let bytes = ModelBytes::copy_from(&w.to_bytes());
        let model = bytes.model().unwrap();
        assert_eq!(
            recorded_class_colors(&model).unwrap(),
            [Some([0xe6, 0x19, 0x4b]), None, Some([0, 0, 255])]
        );
        w.metadata = "class_colors = 9:blue\n".into();
        let bytes = ModelBytes::copy_from(&w.to_bytes());
        let e = recorded_class_colors(&bytes.model().unwrap()).unwrap_err();
        assert!(e.contains("\"9:blue\" is not LABEL:#rrggbb"), "{e}");
    }
}
