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

use std::collections::BTreeMap;
use std::path::Path;

use super::error::{DataError, ErrorKind, Result};
use super::sequence::ClassInfo;

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
                .ok_or_else(|| at(format!("expected `<label> <name>`, found `{line}`")))?;
            let (value, rest) = line.split_at(split);
            // The separator is the whole run of whitespace and commas after the value. (This
            // sliced off one byte, `rest[1..]`, which panicked inside multi-byte whitespace such
            // as U+00A0 or U+3000; and its "one char, spaces, commas, spaces" kept the leading
            // comma of `5 , ,x`, a name `to_text` could not write back.)
            let name = rest.trim_start_matches(|c: char| c.is_whitespace() || c == ',');
            let value: i32 = value
                .parse()
                .map_err(|_| at(format!("label `{value}` is not an integer")))?;
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
        let text =
            std::fs::read_to_string(path).map_err(|e| DataError::new(e.into()).in_file(path))?;
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
}
