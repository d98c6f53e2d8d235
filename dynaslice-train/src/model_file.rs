//! A trained network's model file: the network, its classes and domain, and the metadata every
//! way of training records (the `dynaslice train` command and the lab's experiments alike).

use crate::data_sampler::SampleCounts;
use crate::trainer::{Outcome, TrainOptions};
use dynaslice_core::format::{MAX_CLASSES, MAX_NAME_LEN};
use dynaslice_core::{Domain, Error, Model, ModelBytes};
use dynaslice_data::palette::{parse_hex, to_hex};
use dynaslice_data::ClassInfo;

/// Checks, before any training, that a model of `classes` in `domain` (from
/// [`crate::data_sampler::domain_for`]) fits the model format: at most [`MAX_CLASSES`] classes,
/// names of at most [`MAX_NAME_LEN`] bytes, and a domain whose centre, scale and time range are
/// representable in the f32 header ([`Domain::validate`]: coordinates or an affine near 1e30
/// are not). Without it such input is refused only when the trained model is written.
pub fn check_model_limits(classes: &[ClassInfo], domain: &Domain) -> Result<(), String> {
    if classes.len() > MAX_CLASSES {
        return Err(format!(
            "{} classes; a model holds at most {MAX_CLASSES} (select fewer, e.g. --labels)",
            classes.len()
        ));
    }
    if let Some(c) = classes.iter().find(|c| c.name.len() > MAX_NAME_LEN) {
        return Err(format!(
            "class name {:?} (label {}) is {} bytes long; a model stores at most {MAX_NAME_LEN} \
             (rename it, e.g. with --label-names)",
            c.name,
            c.label,
            c.name.len()
        ));
    }
    domain.validate().map_err(|e| {
        format!(
            "the cross-sections' extent (centre {:?}, half-width {}, times {} + {}) does not fit \
             a model's 32-bit header: {e}",
            domain.center, domain.scale[0], domain.time_origin, domain.time_span
        )
    })
}

/// A training run's result with everything its model file records.
pub struct TrainedModel<'a> {
    /// What training produced.
    pub outcome: &'a Outcome,
    /// The world ↔ normalised map the network was trained in.
    pub domain: Domain,
    /// The trained classes, in channel order.
    pub classes: &'a [ClassInfo],
    /// The options it was trained with.
    pub options: &'a TrainOptions,
    /// Samples drawn per step.
    pub counts: SampleCounts,
    /// c of ω_t^max = c·π/Δt (Eq. 4), recorded even where temporal control was off.
    pub temporal_factor: f32,
    /// Per-class weights of the contour and plane terms, where given.
    pub class_weights: Option<&'a [f32]>,
    /// What was trained on, as `key = value` lines (`dynaslice train`: `input = PATH` and
    /// `frames = A:B:STEP`).
    pub input: &'a str,
}

impl TrainedModel<'_> {
    /// The model file, in aligned storage ready for [`ModelBytes::model`].
    pub fn to_bytes(&self) -> Result<ModelBytes, Error> {
        let classes = self
            .classes
            .iter()
            .map(|c| (c.name.clone(), c.label))
            .collect();
        let bytes = self
            .outcome
            .network
            .to_writer(self.domain, classes, self.metadata())
            .try_to_bytes()?;
        Ok(ModelBytes::copy_from(&bytes))
    }

    /// The metadata `dynaslice info` prints: `key = value` lines, in a fixed order.
    fn metadata(&self) -> String {
        let mut m = format!("trainer = dynaslice {}\n", env!("CARGO_PKG_VERSION"));
        m += self.input;
        m.push('\n');
        m += &self.options.describe();
        m += &format!(
            "temporal_factor = {}\nsteps_done = {}\n",
            self.temporal_factor, self.outcome.steps_done
        );
        if let Some(planned) = self.outcome.planned_steps {
            // A timed run's schedule length: what its cosine was fitted to (--minutes).
            m += &format!("planned_steps = {planned}\n");
        }
        m += &self.counts.describe();
        m.push('\n');
        if let Some(w) = self.class_weights {
            m += &format!("class_weights = {w:?}\n");
        }
        if let Some(line) = class_colors_line(self.classes) {
            m += &line;
            m.push('\n');
        }
        if let Some(last) = self.outcome.history.last() {
            m += &format!("final_loss = {}\n", last.2);
        }
        m
    }
}

/// The metadata key of the input's class colours ([`class_colors_line`]).
pub const CLASS_COLORS_KEY: &str = "class_colors";

/// The metadata line recording the colours of the `classes` that have one, in class order:
/// `class_colors = 1:#e6194b 2:#3cb44b` (label, then `#rrggbb`); `None` when no class has a
/// colour. At most 64 classes of ≤ 20 bytes each: far below the metadata's size limit.
pub fn class_colors_line(classes: &[ClassInfo]) -> Option<String> {
    let entries: Vec<String> = classes
        .iter()
        .filter_map(|c| Some(format!("{}:{}", c.label, to_hex(c.color?))))
        .collect();
    (!entries.is_empty()).then(|| format!("{CLASS_COLORS_KEY} = {}", entries.join(" ")))
}

/// The class colours a model's `metadata` records ([`class_colors_line`]), as (label, colour)
/// in the line's order: empty when there is no such line (models written before it, inputs
/// without colours). An error says what is malformed: an entry that is not `LABEL:#rrggbb`, or
/// a label given twice.
pub fn parse_class_colors(metadata: &str) -> Result<Vec<(i32, [u8; 3])>, String> {
    let Some(value) = metadata.lines().find_map(|line| {
        let (key, value) = line.split_once('=')?;
        (key.trim() == CLASS_COLORS_KEY).then_some(value)
    }) else {
        return Ok(Vec::new());
    };
    let mut colors: Vec<(i32, [u8; 3])> = Vec::new();
    for entry in value.split_whitespace() {
        let parsed = entry
            .split_once(':')
            .and_then(|(label, hex)| Some((label.parse::<i32>().ok()?, parse_hex(hex)?)));
        let Some((label, color)) = parsed else {
            return Err(format!(
                "{CLASS_COLORS_KEY}: entry {entry:?} is not LABEL:#rrggbb"
            ));
        };
        if colors.iter().any(|&(l, _)| l == label) {
            return Err(format!("{CLASS_COLORS_KEY}: label {label} is given twice"));
        }
        colors.push((label, color));
    }
    Ok(colors)
}

/// The colour `model`'s metadata records for each of its channels ([`parse_class_colors`],
/// matched by label), `None` for a channel it records none for: the training input's colours.
/// Outputs show a channel without one in the palette's colour for it
/// ([`dynaslice_data::palette::class_color`]). An error says what is malformed.
pub fn recorded_class_colors(model: &Model) -> Result<Vec<Option<[u8; 3]>>, String> {
    let recorded = parse_class_colors(model.metadata())?;
    Ok(model
        .classes()
        .map(|c| {
            recorded
                .iter()
                .find(|&&(label, _)| label == c.label)
                .map(|&(_, color)| color)
        })
        .collect())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn class_colours_round_trip_through_the_metadata_line() {
        let classes = [
            ClassInfo {
                name: "a".into(),
                label: 1,
                color: Some([0xe6, 0x19, 0x4b]),
            },
            ClassInfo {
                name: "b".into(),
                label: 2,
                color: None,
            },
            ClassInfo {
                name: "c".into(),
                label: -7,
                color: Some([0, 0, 255]),
            },
        ];
        let line = class_colors_line(&classes).unwrap();
        assert_eq!(line, "class_colors = 1:#e6194b -7:#0000ff");
        let metadata = format!("trainer = dynaslice\n{line}\nfinal_loss = 1\n");
        assert_eq!(
            parse_class_colors(&metadata).unwrap(),
            [(1, [0xe6, 0x19, 0x4b]), (-7, [0, 0, 255])]
        );
        assert_eq!(class_colors_line(&classes[1..2]), None);
        assert_eq!(parse_class_colors("trainer = x\n").unwrap(), []);
        for bad in ["1:#zz0000", "1=#ff0000", "x:#ff0000", "1:#ff0000 1:#00ff00"] {
            let e = parse_class_colors(&format!("class_colors = {bad}")).unwrap_err();
            assert!(e.contains("class_colors"), "{e}");
        }
    }

    /// Each channel gets the colour recorded for its label, in channel order whatever the
    /// line's order; a channel without one gets `None`; a malformed line is an error.
    #[test]
    fn recorded_colours_follow_the_channels_by_label() {
        use dynaslice_core::format::ModelWriter;
        let mut w = ModelWriter::random_siren(&[8], 3, 1);
        w.classes = vec![("a".into(), 5), ("b".into(), 1), ("c".into(), 9)];
        w.metadata = "class_colors = 9:#0000ff 5:#e6194b\n".into();
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

    fn class(name: &str, label: i32) -> ClassInfo {
        ClassInfo {
            name: name.into(),
            label,
            color: None,
        }
    }

    #[test]
    fn limits_of_the_format_are_checked() {
        let d = Domain::IDENTITY;
        assert!(check_model_limits(&[class("liver", 1)], &d).is_ok());
        let long = "x".repeat(MAX_NAME_LEN + 1);
        let e = check_model_limits(&[class(&long, 3)], &d).unwrap_err();
        assert!(e.contains("57 bytes") && e.contains("label 3"), "{e}");
        let many: Vec<ClassInfo> = (0..65).map(|i| class("c", i)).collect();
        assert!(check_model_limits(&many, &d)
            .unwrap_err()
            .contains("65 classes"));
        let huge = Domain {
            scale: [f32::INFINITY; 3],
            ..d
        };
        assert!(check_model_limits(&[class("a", 1)], &huge)
            .unwrap_err()
            .contains("32-bit"));
    }
}
