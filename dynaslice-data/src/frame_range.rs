//! `A:B:STEP` frame selections (`--frames 0:37:4`), Python-slice style: frames A, A+STEP, …
//! below B; `A:` or `A::STEP` run to the end, a single `N` selects frame N.

use std::fmt;
use std::str::FromStr;

/// A half-open, strided range of frame indices.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct FrameRange {
    /// First frame.
    pub start: usize,
    /// One past the last frame (`None`: to the end).
    pub end: Option<usize>,
    /// Stride (≥ 1).
    pub step: usize,
}

impl Default for FrameRange {
    /// Every frame.
    fn default() -> Self {
        FrameRange::ALL
    }
}

impl FrameRange {
    /// Every frame.
    pub const ALL: FrameRange = FrameRange {
        start: 0,
        end: None,
        step: 1,
    };

    /// The selected indices among `count` frames. A range whose end lies past the last frame
    /// is cut there, as a Python slice is, with a warning: the user may have counted the
    /// frames wrong.
    pub fn indices(&self, count: usize) -> Vec<usize> {
        if let Some(end) = self.end.filter(|&e| e > count) {
            log::warn!(
                "frames {self}: the input has {count} frames, so the range ends at frame {} \
                 (not {})",
                count.saturating_sub(1),
                end - 1
            );
        }
        let end = self.end.unwrap_or(count).min(count);
        (self.start..end).step_by(self.step).collect()
    }

    /// Whether frame `index` is selected among `count` frames.
    pub fn contains(&self, index: usize, count: usize) -> bool {
        let end = self.end.unwrap_or(count).min(count);
        (self.start..end).contains(&index) && (index - self.start).is_multiple_of(self.step)
    }
}

impl fmt::Display for FrameRange {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self.end {
            Some(e) => write!(f, "{}:{}:{}", self.start, e, self.step),
            None => write!(f, "{}::{}", self.start, self.step),
        }
    }
}

impl FromStr for FrameRange {
    type Err = String;

    fn from_str(s: &str) -> Result<Self, Self::Err> {
        let bad = |why: &str| {
            format!("invalid frame range {s:?}: {why} (expected A:B:STEP, e.g. 0:37:4)")
        };
        let number = |p: &str| {
            p.trim()
                .parse::<usize>()
                .map_err(|_| bad(&format!("{p:?} is not a frame number")))
        };
        let parts: Vec<&str> = s.split(':').collect();
        let (start, end, step) = match parts.as_slice() {
            [n] => {
                let n = number(n)?;
                (n, Some(n + 1), 1)
            }
            [a, b] | [a, b, ""] => (
                if a.is_empty() { 0 } else { number(a)? },
                if b.is_empty() { None } else { Some(number(b)?) },
                1,
            ),
            [a, b, c] => (
                if a.is_empty() { 0 } else { number(a)? },
                if b.is_empty() { None } else { Some(number(b)?) },
                number(c)?,
            ),
            _ => return Err(bad("too many ':'")),
        };
        if step == 0 {
            return Err(bad("STEP must be at least 1"));
        }
        if end.is_some_and(|e| e <= start) {
            return Err(bad("B must be greater than A"));
        }
        Ok(FrameRange { start, end, step })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn parses_and_selects() {
        let r: FrameRange = "0:37:4".parse().unwrap();
        assert_eq!(r.indices(37), vec![0, 4, 8, 12, 16, 20, 24, 28, 32, 36]);
        assert_eq!(
            "2:".parse::<FrameRange>().unwrap().indices(5),
            vec![2, 3, 4]
        );
        assert_eq!(
            "::2".parse::<FrameRange>().unwrap().indices(5),
            vec![0, 2, 4]
        );
        assert_eq!("3".parse::<FrameRange>().unwrap().indices(5), vec![3]);
        assert_eq!(
            "0:100:10".parse::<FrameRange>().unwrap().indices(25).len(),
            3
        );
        for bad in ["", "a", "-1", "a:3", "0:3:0", "1:2:0", "5:2", "1:2:3:4"] {
            assert!(bad.parse::<FrameRange>().is_err(), "{bad}");
        }
    }
}
