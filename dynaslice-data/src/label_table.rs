//! Label tables: which name (and display colour) each source label value gets.
//!
//! Text, one entry per line: the label value, then the name (the rest of the line, trimmed), the
//! two separated by whitespace or a comma. Blank lines and lines starting with `#` are ignored.
//! ```text
//! # TotalSegmentator labels
//! 1 spleen
//! 5, liver
//! ```
//! Labels without an entry are named `label <value>`.
//!
//! The tables label maps carry or come with are read too:
//! - the XML `LabelTable` of a NIfTI header extension, as Connectome Workbench (Caret) and
//!   TotalSegmentator write it: `<Label Key="1" Red="0.0" Green="1.0" Blue="0.0"
//!   Alpha="1">spleen</Label>`, components 0–1 ([`LabelTable::from_xml`]);
//! - the 3D Slicer colour table and the ITK-SNAP label description file found beside a label
//!   map under its name, as [`crate::color_table::table_paths`] names them (`heart.ctbl`,
//!   `heart.label.txt` beside `heart.nii.gz`; [`LabelTable::beside`]).

use std::collections::BTreeMap;
use std::path::Path;

use dynaslice_sequence::error::{excerpt, DataError, ErrorKind, Result};
use dynaslice_sequence::input_file;
use dynaslice_sequence::sequence::ClassInfo;

/// Bytes a label table file may hold: far more than any label set needs.
pub const MAX_BYTES: u64 = 16 << 20;

/// Label value → class name and, where the source gives one, display colour.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct LabelTable {
    names: BTreeMap<i32, String>,
    colors: BTreeMap<i32, [u8; 3]>,
}

impl LabelTable {
    /// Parses a table; errors name the line.
    pub fn parse(text: &str) -> Result<Self> {
        let mut map = BTreeMap::new();
        for (i, line) in text.lines().enumerate() {
            let line = line.trim();
            if line.is_empty() || line.starts_with('#') {
                continue;
            }
            let at = |what: String| DataError::new(ErrorKind::Syntax(what)).at_line(i + 1);
            let split = line
                .find(|c: char| c.is_whitespace() || c == ',')
                .ok_or_else(|| {
                    at(format!(
                        "expected `<label> <name>`, found `{}`",
                        excerpt(line)
                    ))
                })?;
            let (value, rest) = line.split_at(split);
            // The separator is the whole run of whitespace and commas after the value. (This
            // sliced off one byte, `rest[1..]`, which panicked inside multi-byte whitespace such
            // as U+00A0 or U+3000; and its "one char, spaces, commas, spaces" kept the leading
            // comma of `5 , ,x`, a name `to_text` could not write back.)
            let name = rest.trim_start_matches(|c: char| c.is_whitespace() || c == ',');
            let value: i32 = value
                .parse()
                .map_err(|_| at(format!("label `{}` is not an integer", excerpt(value))))?;
            if name.is_empty() {
                return Err(at(format!("label {value} has an empty name")));
            }
            if map.insert(value, name.to_string()).is_some() {
                return Err(at(format!("label {value} is listed twice")));
            }
        }
        Ok(LabelTable {
            names: map,
            colors: BTreeMap::new(),
        })
    }

    /// Reads a table file.
    pub fn read(path: &Path) -> Result<Self> {
        let text = input_file::read_text(path, MAX_BYTES, "a label table")?;
        Self::parse(&text).map_err(|e| e.in_file(path))
    }

    /// Adds or replaces an entry's name.
    pub fn insert(&mut self, label: i32, name: impl Into<String>) {
        self.names.insert(label, name.into());
    }

    /// Adds or replaces an entry's display colour (sRGB).
    pub fn insert_color(&mut self, label: i32, color: [u8; 3]) {
        self.colors.insert(label, color);
    }

    /// This table with `over`'s entries replacing or adding to its own (a user's table over the
    /// names and colours a file carries).
    pub fn overlaid(&self, over: &LabelTable) -> LabelTable {
        let mut t = self.clone();
        t.names
            .extend(over.names.iter().map(|(&l, n)| (l, n.clone())));
        t.colors.extend(over.colors.iter().map(|(&l, &c)| (l, c)));
        t
    }

    /// Whether the table has no entry.
    pub fn is_empty(&self) -> bool {
        self.names.is_empty() && self.colors.is_empty()
    }

    /// Whether the table names `label` (else [`LabelTable::name`] makes one up).
    pub fn has_name(&self, label: i32) -> bool {
        self.names.contains_key(&label)
    }

    /// The name of `label`: its entry, or `label <value>`.
    pub fn name(&self, label: i32) -> String {
        self.names
            .get(&label)
            .cloned()
            .unwrap_or_else(|| format!("label {label}"))
    }

    /// The display colour of `label`, if the table has one.
    pub fn color(&self, label: i32) -> Option<[u8; 3]> {
        self.colors.get(&label).copied()
    }

    /// The class `label` becomes: its name and colour from the table.
    pub fn class(&self, label: i32) -> ClassInfo {
        ClassInfo {
            name: self.name(label),
            label,
            color: self.color(label),
        }
    }

    /// The names and colours of an XML label table (`<Label Key=… Red=… Green=… Blue=…>NAME
    /// </Label>` elements, wherever they sit in the document), or `None` when `text` is not
    /// XML or holds no such element. A label whose key is not an integer or whose colour is
    /// not three numbers in 0–1 is an error.
    pub fn from_xml(text: &str) -> Option<std::result::Result<LabelTable, String>> {
        let doc = roxmltree::Document::parse(text).ok()?;
        let labels: Vec<roxmltree::Node> = doc
            .descendants()
            .filter(|n| n.has_tag_name("Label") && n.attribute("Key").is_some())
            .collect();
        if labels.is_empty() {
            return None;
        }
        let mut table = LabelTable::default();
        let read =
            |table: &mut LabelTable, node: &roxmltree::Node| -> std::result::Result<(), String> {
                let key = node.attribute("Key").unwrap_or_default();
                let label: i32 = key
                    .trim()
                    .parse()
                    .map_err(|_| format!("label key `{}` is not an integer", excerpt(key)))?;
                let name: String = node
                    .descendants()
                    .filter(|n| n.is_text())
                    .filter_map(|n| n.text())
                    .collect::<String>()
                    .trim()
                    .to_string();
                if !name.is_empty() {
                    table.insert(label, name);
                }
                let component = |c: &str| -> std::result::Result<Option<u8>, String> {
                    let Some(v) = node.attribute(c) else {
                        return Ok(None);
                    };
                    match v.trim().parse::<f64>() {
                        Ok(x) if (0.0..=1.0).contains(&x) => Ok(Some((x * 255.0).round() as u8)),
                        _ => Err(format!(
                            "label {label}: {c} `{}` is not a number in 0–1",
                            excerpt(v)
                        )),
                    }
                };
                if let (Some(r), Some(g), Some(b)) =
                    (component("Red")?, component("Green")?, component("Blue")?)
                {
                    table.insert_color(label, [r, g, b]);
                }
                Ok(())
            };
        for node in &labels {
            if let Err(e) = read(&mut table, node) {
                return Some(Err(e));
            }
        }
        Some(Ok(table))
    }

    /// Parses a 3D Slicer colour table (`.ctbl`): `label name R G B A` lines, components
    /// 0–255, `#` comments; `_` in a name is a space (as Slicer reads it). Label 0 (the
    /// background) is skipped.
    pub fn parse_slicer_ctbl(text: &str) -> Result<Self> {
        let mut table = LabelTable::default();
        for (i, line) in text.lines().enumerate() {
            let line = line.trim();
            if line.is_empty() || line.starts_with('#') {
                continue;
            }
            let at = |what: String| DataError::new(ErrorKind::Syntax(what)).at_line(i + 1);
            let words: Vec<&str> = line.split_whitespace().collect();
            let bad = || {
                at(format!(
                    "expected `label name R G B A`, found `{}`",
                    excerpt(line)
                ))
            };
            let [label, name, r, g, b, ..] = words[..] else {
                return Err(bad());
            };
            let label: i32 = label.parse().map_err(|_| bad())?;
            let rgb = [r, g, b].map(|c| c.parse::<u8>().ok());
            let [Some(r), Some(g), Some(b)] = rgb else {
                return Err(bad());
            };
            if label != 0 {
                table.insert(label, name.replace('_', " "));
                table.insert_color(label, [r, g, b]);
            }
        }
        Ok(table)
    }

    /// Parses an ITK-SNAP label description file: `IDX R G B A VIS MSH "LABEL"` lines,
    /// `#` comments. Label 0 (ITK-SNAP's "Clear Label") is skipped.
    pub fn parse_itksnap(text: &str) -> Result<Self> {
        let mut table = LabelTable::default();
        for (i, line) in text.lines().enumerate() {
            let line = line.trim();
            if line.is_empty() || line.starts_with('#') {
                continue;
            }
            let at = |what: String| DataError::new(ErrorKind::Syntax(what)).at_line(i + 1);
            let bad = || {
                at(format!(
                    "expected `IDX R G B A VIS MSH \"LABEL\"`, found `{}`",
                    excerpt(line)
                ))
            };
            let (numbers, name) = line.split_once('"').ok_or_else(bad)?;
            let name = name.strip_suffix('"').ok_or_else(bad)?;
            let numbers: Vec<&str> = numbers.split_whitespace().collect();
            let [label, r, g, b, ..] = numbers[..] else {
                return Err(bad());
            };
            let label: i32 = label.parse().map_err(|_| bad())?;
            let rgb = [r, g, b].map(|c| c.parse::<u8>().ok());
            let [Some(r), Some(g), Some(b)] = rgb else {
                return Err(bad());
            };
            if label != 0 {
                table.insert(label, name);
                table.insert_color(label, [r, g, b]);
            }
        }
        Ok(table)
    }

    /// The table of the colour tables found beside the label map `path` (see the
    /// [module docs](self)): the Slicer `.ctbl` over the ITK-SNAP file where both are there;
    /// empty when neither is. A table that is there but unreadable is an error naming it.
    pub fn beside(path: &Path) -> Result<Self> {
        let (ctbl, itksnap) = crate::color_table::table_paths(path);
        let mut table = LabelTable::default();
        type Parser = fn(&str) -> Result<LabelTable>;
        let parsers: [(&Path, Parser); 2] = [
            (&itksnap, LabelTable::parse_itksnap),
            (&ctbl, LabelTable::parse_slicer_ctbl),
        ];
        for (file, parse) in parsers {
            if !file.exists() {
                continue;
            }
            let text = input_file::read_text(file, MAX_BYTES, "a label table")?;
            let found = parse(&text).map_err(|e| e.in_file(file))?;
            log::info!(
                "{}: label names and colours from {}",
                path.display(),
                file.display()
            );
            table = table.overlaid(&found);
        }
        Ok(table)
    }

    /// Serialises the names in the format [`LabelTable::parse`] reads.
    pub fn to_text(&self) -> String {
        self.names
            .iter()
            .map(|(v, n)| format!("{v} {n}\n"))
            .collect()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn parses_both_separators_and_round_trips() {
        let t = LabelTable::parse("# c\n1 spleen\n\n5, right kidney\n").unwrap();
        assert_eq!(t.name(1), "spleen");
        assert_eq!(t.name(5), "right kidney");
        assert_eq!(t.name(7), "label 7");
        assert_eq!(LabelTable::parse(&t.to_text()).unwrap(), t);
    }

    #[test]
    fn errors_name_the_line() {
        let e = LabelTable::parse("1 a\n1 b\n").unwrap_err();
        assert_eq!(e.location.line, Some(2));
        assert!(e.to_string().contains("twice"), "{e}");
        let e = LabelTable::parse("x liver\n").unwrap_err();
        assert!(e.to_string().contains("line 1"), "{e}");
        assert!(LabelTable::parse("3\n").is_err());
    }

    #[test]
    fn reads_caret_xml_slicer_and_itksnap_tables() {
        let xml = r#"<?xml version="1.0" encoding="UTF-8"?> <CaretExtension><VolumeInformation>
            <LabelTable>
            <Label Key="1" Red="0.0" Green="1.0" Blue="0.0" Alpha="1"><![CDATA[spleen]]></Label>
            <Label Key="6" Red="1.0" Green="0.5019607843137255" Blue="0.0">stomach</Label>
            </LabelTable></VolumeInformation></CaretExtension>"#;
        let t = LabelTable::from_xml(xml).unwrap().unwrap();
        assert_eq!(
            (t.name(1), t.color(1)),
            ("spleen".into(), Some([0, 255, 0]))
        );
        assert_eq!(
            (t.name(6), t.color(6)),
            ("stomach".into(), Some([255, 128, 0]))
        );
        assert!(LabelTable::from_xml("<a><b/></a>").is_none());
        assert!(LabelTable::from_xml("not xml").is_none());
        let bad = LabelTable::from_xml(r#"<T><Label Key="x">a</Label></T>"#).unwrap();
        assert!(bad.unwrap_err().contains("not an integer"));
        let bad =
            LabelTable::from_xml(r#"<T><Label Key="1" Red="2" Green="0" Blue="0">a</Label></T>"#);
        assert!(bad.unwrap().unwrap_err().contains("0–1"));

        let c = LabelTable::parse_slicer_ctbl(
            "# t\n0 Background 0 0 0 0\n3 left_kidney 10 20 30 255\n",
        )
        .unwrap();
        assert_eq!(
            (c.name(3), c.color(3)),
            ("left kidney".into(), Some([10, 20, 30]))
        );
        assert!(!c.has_name(0));
        assert!(LabelTable::parse_slicer_ctbl("3 a b\n").is_err());
        let i = LabelTable::parse_itksnap(
            "# ITK-SNAP Label Description File\n    0     0    0    0        0  0  0    \"Clear Label\"\n    2   255    0   10        1  1  1    \"right kidney\"\n",
        )
        .unwrap();
        assert_eq!(
            (i.name(2), i.color(2)),
            ("right kidney".into(), Some([255, 0, 10]))
        );
        assert!(!i.has_name(0));
        assert!(LabelTable::parse_itksnap("2 1 2 3 no quotes\n").is_err());
    }

    #[test]
    fn tables_beside_a_map_are_found_by_its_name() {
        let dir = tempfile::tempdir().unwrap();
        let map = dir.path().join("heart.nii.gz");
        assert!(LabelTable::beside(&map).unwrap().is_empty());
        std::fs::write(
            dir.path().join("heart.label.txt"),
            "1 1 2 3 1 1 1 \"LV\"\n2 4 5 6 1 1 1 \"RV\"\n",
        )
        .unwrap();
        std::fs::write(
            dir.path().join("heart.ctbl"),
            "1 left_ventricle 7 8 9 255\n",
        )
        .unwrap();
        let t = LabelTable::beside(&map).unwrap();
        assert_eq!(
            (t.name(1), t.color(1)),
            ("left ventricle".into(), Some([7, 8, 9]))
        );
        assert_eq!((t.name(2), t.color(2)), ("RV".into(), Some([4, 5, 6])));
        std::fs::write(dir.path().join("heart.ctbl"), "garbage\n").unwrap();
        let e = LabelTable::beside(&map).unwrap_err().to_string();
        assert!(e.contains("heart.ctbl") && e.contains("line 1"), "{e}");
    }
}
