//! Colour tables written beside a label volume, so viewers show each label value under its
//! class's name and colour: 3D Slicer's `.ctbl` and ITK-SNAP's label description file.
//!
//! Both list the background (label 0) and then the classes by increasing label; a class's
//! colour is its own or the [`dynaslice_sequence::palette::palette`] entry of its position.
//!
//! - **3D Slicer** (`NAME.ctbl`, what `vtkMRMLColorTableStorageNode` reads and writes): `#`
//!   comment lines, then one `label name R G B A` line per entry, components 0–255. Slicer
//!   reads the name as one whitespace-free word and turns `_` back into spaces, so names are
//!   written as Slicer writes them, every run of whitespace replaced by `_`. Slicer allows label
//!   values 0 to 32768; a class outside that range is left out, with a warning.
//! - **ITK-SNAP** (`NAME.label.txt`, its "Label Description File"): the comment block ITK-SNAP
//!   writes, then `IDX -R- -G- -B- -A-- VIS MSH "LABEL"` lines in ITK-SNAP's column widths,
//!   opacity 0–1, the background as ITK-SNAP's `0 0 0 0 0 0 0 "Clear Label"`. The name is
//!   between double quotes, so a `"` in it becomes `'` and control characters become spaces.
//!   ITK-SNAP's labels are 16-bit unsigned: a class outside 1 to 65535 is left out, with a
//!   warning.
//!
//! [`table_paths`] names the two files beside a volume; each is written under a temporary name
//! and renamed ([`dynaslice_output::OutputSet`]).

use std::path::{Path, PathBuf};

use dynaslice_output::OutputSet;
use dynaslice_sequence::error::{DataError, ErrorKind, Result};
use dynaslice_sequence::palette::class_color;
use dynaslice_sequence::sequence::ClassInfo;

/// Largest label a 3D Slicer colour table may hold (`vtkMRMLColorTableStorageNode`'s
/// `MaximumColorID`).
pub const SLICER_MAX_LABEL: i32 = 32768;

/// Largest label ITK-SNAP holds (its label type is an unsigned 16-bit integer).
pub const ITKSNAP_MAX_LABEL: i32 = 65535;

/// The colour tables beside the volume `path`: `(NAME.ctbl, NAME.label.txt)`, NAME being the
/// file name without `.nii.gz`, `.nii`, `.seg.nrrd` or its last extension (any case), e.g.
/// `out/heart.nii.gz` → `out/heart.ctbl`, `out/heart.label.txt`.
pub fn table_paths(path: &Path) -> (PathBuf, PathBuf) {
    let name = path
        .file_name()
        .map_or(String::new(), |n| n.to_string_lossy().into_owned());
    let lower = name.to_ascii_lowercase();
    let stem = [".nii.gz", ".nii", ".seg.nrrd", ".nrrd"]
        .iter()
        .find(|ext| lower.ends_with(*ext) && lower.len() > ext.len())
        .map(|ext| &name[..name.len() - ext.len()])
        .or_else(|| name.rfind('.').filter(|&i| i > 0).map(|i| &name[..i]))
        .unwrap_or(&name);
    (
        path.with_file_name(format!("{stem}.ctbl")),
        path.with_file_name(format!("{stem}.label.txt")),
    )
}

/// The classes sorted by label with their display colours, and those whose label lies
/// outside `1..=max` (left out).
fn entries(classes: &[ClassInfo], max: i32) -> (Vec<(&ClassInfo, [u8; 3])>, Vec<&ClassInfo>) {
    let mut kept = Vec::new();
    let mut left_out = Vec::new();
    for (k, c) in classes.iter().enumerate() {
        if (1..=max).contains(&c.label) {
            kept.push((c, class_color(k, c.color)));
        } else {
            left_out.push(c);
        }
    }
    kept.sort_by_key(|(c, _)| c.label);
    (kept, left_out)
}

/// The 3D Slicer colour table of `classes` (`title` names it in the first comment) and the
/// classes left out for their labels. See the [module docs](self).
pub fn slicer_ctbl<'a>(title: &str, classes: &'a [ClassInfo]) -> (String, Vec<&'a ClassInfo>) {
    let (kept, left_out) = entries(classes, SLICER_MAX_LABEL);
    let word = |name: &str| {
        let w = name.split_whitespace().collect::<Vec<_>>().join("_");
        if w.is_empty() {
            "unnamed".to_string()
        } else {
            w
        }
    };
    let mut text = format!(
        "# Color table file {}\n# {} values\n0 Background 0 0 0 0\n",
        word(title),
        kept.len() + 1
    );
    for (c, [r, g, b]) in kept {
        text += &format!("{} {} {r} {g} {b} 255\n", c.label, word(&c.name));
    }
    (text, left_out)
}

/// The ITK-SNAP label description of `classes` and the classes left out for their labels.
/// See the [module docs](self).
pub fn itksnap_labels(classes: &[ClassInfo]) -> (String, Vec<&ClassInfo>) {
    let (kept, left_out) = entries(classes, ITKSNAP_MAX_LABEL);
    let mut text = String::from(
        "################################################\n\
         # ITK-SnAP Label Description File\n\
         # File format:\n\
         # IDX   -R-  -G-  -B-  -A--  VIS MSH  LABEL\n\
         # Fields:\n\
         #    IDX:   Zero-based index\n\
         #    -R-:   Red color component (0..255)\n\
         #    -G-:   Green color component (0..255)\n\
         #    -B-:   Blue color component (0..255)\n\
         #    -A-:   Label transparency (0.00 .. 1.00)\n\
         #    VIS:   Label visibility (0 or 1)\n\
         #    IDX:   Label mesh visibility (0 or 1)\n\
         #  LABEL:   Label description\n\
         ################################################\n",
    );
    // ITK-SNAP's own column widths.
    let mut line = |label: i32, [r, g, b]: [u8; 3], on: u8, name: &str| {
        text += &format!("{label:>5} {r:>5} {g:>4} {b:>4} {on:>8} {on:>2} {on:>2}    \"{name}\"\n");
    };
    line(0, [0; 3], 0, "Clear Label");
    for (c, rgb) in kept {
        let name: String = c
            .name
            .chars()
            .map(|ch| match ch {
                '"' => '\'',
                ch if ch.is_control() => ' ',
                ch => ch,
            })
            .collect();
        line(c.label, rgb, 1, &name);
    }
    (text, left_out)
}

/// Writes [`slicer_ctbl`] to `path` and [`itksnap_labels`] to `label_path`, both or neither
/// ([`OutputSet`]); a class left out of a table is named in a warning.
pub fn write_tables(ctbl_path: &Path, label_path: &Path, classes: &[ClassInfo]) -> Result<()> {
    let mut set = OutputSet::new();
    stage_tables(&mut set, ctbl_path, label_path, classes)?;
    set.commit()
        .map_err(|e| DataError::new(ErrorKind::Io(std::io::Error::other(format!("{e:#}")))))
}

/// Adds the two tables of [`write_tables`] to `set`, which puts them in place with the set's
/// other files (the label volume they describe).
pub fn stage_tables(
    set: &mut OutputSet,
    ctbl_path: &Path,
    label_path: &Path,
    classes: &[ClassInfo],
) -> Result<()> {
    let title = ctbl_path
        .file_stem()
        .map_or(String::new(), |s| s.to_string_lossy().into_owned());
    let (ctbl, out_ctbl) = slicer_ctbl(&title, classes);
    let (labels, out_labels) = itksnap_labels(classes);
    for (path, text, left_out, range) in [
        (ctbl_path, ctbl, out_ctbl, SLICER_MAX_LABEL),
        (label_path, labels, out_labels, ITKSNAP_MAX_LABEL),
    ] {
        for c in left_out {
            log::warn!(
                "{}: class {:?} left out: its label {} is outside the 1 to {range} this table \
                 format holds",
                path.display(),
                c.name,
                c.label
            );
        }
        set.write(path, text.as_bytes()).map_err(|e| {
            DataError::new(ErrorKind::Io(std::io::Error::other(format!("{e:#}")))).in_file(path)
        })?;
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;
    use dynaslice_sequence::palette::palette;

    fn class(name: &str, label: i32, color: Option<[u8; 3]>) -> ClassInfo {
        ClassInfo {
            name: name.into(),
            label,
            color,
        }
    }

    #[test]
    fn paths_drop_the_volume_extension() {
        let t = |p: &str| {
            let (a, b) = table_paths(Path::new(p));
            (a.display().to_string(), b.display().to_string())
        };
        assert_eq!(
            t("out/heart.nii.gz"),
            ("out/heart.ctbl".into(), "out/heart.label.txt".into())
        );
        assert_eq!(t("a.NII").0, "a.ctbl");
        assert_eq!(t("a.seg.nrrd").0, "a.ctbl");
        assert_eq!(t("x.v1.img").0, "x.v1.ctbl");
        assert_eq!(t(".nii").0, ".nii.ctbl");
    }

    #[test]
    fn slicer_table_sorts_by_label_and_writes_names_as_one_word() {
        let classes = [
            class("right  kidney", 7, Some([1, 2, 3])),
            class("liver", 2, None),
            class("far", 40000, None),
            class(" ", 3, None),
        ];
        let (text, left_out) = slicer_ctbl("my table", &classes);
        let lines: Vec<&str> = text.lines().collect();
        assert_eq!(lines[0], "# Color table file my_table");
        assert_eq!(lines[1], "# 4 values");
        assert_eq!(lines[2], "0 Background 0 0 0 0");
        let [r, g, b] = palette(1);
        assert_eq!(lines[3], format!("2 liver {r} {g} {b} 255"));
        let [r, g, b] = palette(3);
        assert_eq!(lines[4], format!("3 unnamed {r} {g} {b} 255"));
        assert_eq!(lines[5], "7 right_kidney 1 2 3 255");
        assert_eq!(lines.len(), 6);
        assert_eq!(left_out.len(), 1);
        assert_eq!(left_out[0].label, 40000);
    }

    #[test]
    fn itksnap_table_has_the_header_background_and_quoted_names() {
        let classes = [
            class("say \"hi\"", 12, Some([250, 0, 9])),
            class("neg", -1, None),
        ];
        let (text, left_out) = itksnap_labels(&classes);
        assert!(text.starts_with("################################################\n"));
        assert!(text.contains("# IDX   -R-  -G-  -B-  -A--  VIS MSH  LABEL\n"));
        let entries: Vec<&str> = text.lines().filter(|l| !l.starts_with('#')).collect();
        assert_eq!(
            entries,
            [
                "    0     0    0    0        0  0  0    \"Clear Label\"",
                "   12   250    0    9        1  1  1    \"say 'hi'\"",
            ]
        );
        assert_eq!(left_out[0].label, -1);
    }

    #[test]
    fn tables_are_written_beside_the_volume() {
        let dir = tempfile::tempdir().unwrap();
        let (ctbl, labels) = table_paths(&dir.path().join("v.nii.gz"));
        write_tables(&ctbl, &labels, &[class("a", 1, None)]).unwrap();
        assert!(std::fs::read_to_string(&ctbl).unwrap().contains("\n1 a "));
        assert!(std::fs::read_to_string(&labels).unwrap().contains("\"a\""));
        let missing = dir.path().join("no/v.ctbl");
        let e = write_tables(&missing, &labels, &[])
            .unwrap_err()
            .to_string();
        assert!(e.contains("no/v.ctbl"), "{e}");
    }
}
