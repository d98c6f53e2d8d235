//! The class colours a model records: one metadata line, written by the trainer and read by
//! every output (meshes, segmentations, colour tables, pictures).

use dynaslice_core::Model;
use dynaslice_sequence::palette::{parse_hex, to_hex};
use dynaslice_sequence::ClassInfo;

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
/// ([`dynaslice_sequence::palette::class_color`]). An error says what is malformed.
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
    use dynaslice_core::ModelBytes;

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
}
