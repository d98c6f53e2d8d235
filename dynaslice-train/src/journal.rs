//! The loss log: one row per step, kept beside the checkpoint while a run goes (the journal,
//! `MODEL.dsm.ckpt.loss.csv`, appended and flushed every step) so that a resumed run's log
//! starts at step 1, and written beside the model when the run ends (`MODEL.dsm.loss.csv`).

use crate::loss::LossTerms;
use anyhow::{Context, Result};
use dynaslice_output::write_atomically;
use std::fs::File;
use std::io::{BufRead, BufReader, Read, Write};
use std::path::{Path, PathBuf};

/// The loss log's header; a row is the step then these values.
pub const CSV_HEADER: &str =
    "step,total,surface,orientation,plane,eikonal,spurious,outside,motion,between";

/// The headers of loss logs written before the outside, the motion and the between terms
/// existed (rows of six, seven and eight values).
const CSV_HEADERS_BEFORE: [&str; 3] = [
    "step,total,surface,orientation,plane,eikonal,spurious",
    "step,total,surface,orientation,plane,eikonal,spurious,outside",
    "step,total,surface,orientation,plane,eikonal,spurious,outside,motion",
];

/// The names of a row's values after the step, in column order, for plots.
pub const TERM_NAMES: [&str; 9] = [
    "total",
    "surface |f|",
    "orientation",
    "plane SDF",
    "eikonal",
    "spurious exp(-a|f|)",
    "outside ReLU(b-f)",
    "motion (strain, fold)",
    "between ReLU(sign(b)(b/2-f))",
];

/// One step's losses: the step (1-based), then total, surface, orientation, plane, eikonal,
/// spurious, outside, motion, between.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct LossRow(pub u64, pub [f64; 9]);

impl LossRow {
    /// The row of step `step` with `terms` and weighted `total`.
    pub fn of(step: u64, t: &LossTerms, total: f64) -> LossRow {
        let mut values = [total; 9];
        for (slot, (_, value)) in values[1..].iter_mut().zip(t.named()) {
            *slot = value;
        }
        LossRow(step, values)
    }

    /// The CSV line (f64 `Display` is the shortest exact form, so [`LossRow::parse`] restores
    /// it).
    pub fn line(&self) -> String {
        let v = self.1;
        format!(
            "{},{},{},{},{},{},{},{},{},{}\n",
            self.0, v[0], v[1], v[2], v[3], v[4], v[5], v[6], v[7], v[8]
        )
    }

    /// The row of a CSV line, or `None` if it is not one (a torn last line). A row of a
    /// journal written before the outside, the motion or the between term existed (six to
    /// eight values) reads with them 0.
    pub fn parse(line: &str) -> Option<LossRow> {
        let mut it = line.trim().split(',');
        let step = it.next()?.parse().ok()?;
        let values: Vec<f64> = it.map(|x| x.parse().ok()).collect::<Option<_>>()?;
        let mut v = [0.0; 9];
        match values.len() {
            6..=9 => v[..values.len()].copy_from_slice(&values),
            _ => return None,
        }
        Some(LossRow(step, v))
    }
}

/// The rows as a CSV file's text, header first.
pub fn csv(rows: &[LossRow]) -> String {
    let mut text = format!("{CSV_HEADER}\n");
    rows.iter().for_each(|r| text += &r.line());
    text
}

/// The rows of the journal at `path`, in step order (none if it is missing). A torn last line
/// (a kill mid-write) ends it; the file's size is bounded by `max_steps` rows first.
pub fn read(path: &Path, max_steps: u64) -> Result<Vec<LossRow>> {
    let Ok(file) = File::open(path) else {
        return Ok(Vec::new());
    };
    // The longest line is 20 digits and nine f64s of at most 24 characters, plus commas.
    let max = max_steps.saturating_add(1).saturating_mul(260);
    let mut rows = Vec::new();
    let reader = BufReader::new(file.take(max));
    for line in reader.lines().skip(1) {
        let line = line.with_context(|| format!("cannot read {}", path.display()))?;
        match LossRow::parse(&line) {
            Some(r) if rows.last().is_none_or(|l: &LossRow| l.0 < r.0) => rows.push(r),
            _ => break,
        }
    }
    Ok(rows)
}

/// Whether `path` may be taken as a journal: nothing is there, or a regular file (not a link)
/// whose first line is the loss log's header ([`CSV_HEADER`], or the header of a journal
/// written before the outside, the motion or the between term existed), as every journal's is from its
/// first write; a user's file there is not.
pub fn is_journal(path: &Path) -> bool {
    match std::fs::symlink_metadata(path) {
        Err(e) => e.kind() == std::io::ErrorKind::NotFound,
        Ok(m) if !m.is_file() => false,
        Ok(_) => File::open(path).is_ok_and(|f| {
            let mut first = String::new();
            BufReader::new(f.take(CSV_HEADER.len() as u64 + 1))
                .read_line(&mut first)
                .is_ok()
                && CSV_HEADERS_BEFORE
                    .iter()
                    .chain([&CSV_HEADER])
                    .any(|h| *h == first.trim_end_matches('\n'))
        }),
    }
}

/// The journal as a run goes: rewritten at the run's first step with the rows its checkpoint
/// covers, then one row appended (and flushed) per step.
pub struct Journal {
    path: Option<PathBuf>,
    file: Option<File>,
    earlier: Vec<LossRow>,
    rows: Vec<LossRow>,
}

impl Journal {
    /// A journal at `path` (none: rows kept in memory only) continuing `earlier` rows.
    pub fn new(path: Option<PathBuf>, earlier: Vec<LossRow>) -> Journal {
        Journal {
            path,
            file: None,
            earlier,
            rows: Vec::new(),
        }
    }

    /// Records `row`. The first row of a process at step s keeps the earlier rows of steps
    /// before s (what the checkpoint it resumed from covers) and returns how many of those
    /// s − 1 steps have no row, so the caller can say so.
    pub fn record(&mut self, row: LossRow) -> Result<Option<u64>> {
        let mut missing = None;
        if self.rows.is_empty() && self.file.is_none() {
            let start = row.0 - 1;
            self.rows = self.earlier.drain(..).filter(|r| r.0 <= start).collect();
            if start > 0 {
                missing = Some(start - self.rows.len() as u64);
            }
            if let Some(path) = &self.path {
                write_atomically(path, csv(&self.rows).as_bytes())?;
                let file = std::fs::OpenOptions::new()
                    .append(true)
                    .open(path)
                    .with_context(|| format!("cannot append to {}", path.display()))?;
                self.file = Some(file);
            }
        }
        if let (Some(file), Some(path)) = (&mut self.file, &self.path) {
            file.write_all(row.line().as_bytes())
                .with_context(|| format!("cannot write {}", path.display()))?;
        }
        self.rows.push(row);
        Ok(missing)
    }

    /// The rows from step 1 to `steps_done`: those recorded, or where this process ran no step
    /// (its checkpoint already held every step), the earlier ones.
    pub fn into_rows(self, steps_done: u64) -> Vec<LossRow> {
        if self.rows.is_empty() {
            self.earlier
                .into_iter()
                .filter(|r| r.0 <= steps_done)
                .collect()
        } else {
            self.rows
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn rows_round_trip_and_torn_lines_end_the_journal() {
        let r = LossRow(3, [0.1, 1e-30, 0.0, 2.5, 1.0 / 3.0, 7.0, 0.25, 0.125, 0.5]);
        assert_eq!(LossRow::parse(&r.line()), Some(r));
        let older = LossRow::parse("3,0.1,1e-30,0,2.5,0.5,7").unwrap();
        assert_eq!(
            older.1[6..],
            [0.0; 3],
            "a six-value row has no outside, motion or between term"
        );
        let older = LossRow::parse("3,0.1,1e-30,0,2.5,0.5,7,0.25").unwrap();
        assert_eq!(
            (older.1[6], older.1[7]),
            (0.25, 0.0),
            "a seven-value row has no motion"
        );
        let older = LossRow::parse("3,0.1,1e-30,0,2.5,0.5,7,0.25,0.125").unwrap();
        assert_eq!(
            (older.1[7], older.1[8]),
            (0.125, 0.0),
            "an eight-value row has no between"
        );
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("j.csv");
        let text = format!(
            "{CSV_HEADER}\n{}{}4,0.5,1",
            LossRow(1, r.1).line(),
            LossRow(2, r.1).line()
        );
        std::fs::write(&path, text).unwrap();
        let rows = read(&path, 100).unwrap();
        assert_eq!(rows.iter().map(|r| r.0).collect::<Vec<_>>(), [1, 2]);
        assert!(read(&dir.path().join("none"), 100).unwrap().is_empty());
    }

    /// A journal of this version or of one before the outside, the motion or the between term is a
    /// journal; a user's file at its path is not.
    #[test]
    fn journals_of_either_header_are_journals_and_other_files_are_not() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("j.csv");
        assert!(is_journal(&path), "nothing there");
        for header in CSV_HEADERS_BEFORE.iter().chain([&CSV_HEADER]) {
            std::fs::write(&path, format!("{header}\n1,0.5,0.5,0,0,0,0\n")).unwrap();
            assert!(is_journal(&path), "{header}");
        }
        std::fs::write(&path, "step,total\n1,2\n").unwrap();
        assert!(!is_journal(&path), "a user's CSV");
    }

    #[test]
    fn a_resumed_journal_keeps_the_rows_its_checkpoint_covers() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("j.csv");
        let v = [1.0; 9];
        let earlier = (1..=5).map(|s| LossRow(s, v)).collect();
        let mut j = Journal::new(Some(path.clone()), earlier);
        // Resumed from a checkpoint at step 3: rows 4 and 5 of the earlier run are dropped.
        assert_eq!(j.record(LossRow(4, [2.0; 9])).unwrap(), Some(0));
        assert_eq!(j.record(LossRow(5, [2.0; 9])).unwrap(), None);
        let on_disk = read(&path, 100).unwrap();
        assert_eq!(on_disk.len(), 5);
        assert_eq!(on_disk[3].1, [2.0; 9]);
        assert_eq!(j.into_rows(5), on_disk);
    }
}
