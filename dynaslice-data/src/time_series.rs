//! The one time syntax of every command that evaluates a model at several times (`--times` of
//! `mesh`, `labels`, `measure`, `report`, `rtstruct`, `eval volume` and `picture`): either a
//! list, `0,0.25,1` (one time is a list of one, `0.5`), or `A:B:N`, N times evenly spaced from
//! A to B inclusive (`0:1:37`). Both are in the model's own time units (seconds, milliseconds,
//! or a normalised cycle: whatever the input's times were).

use std::fmt;
use std::str::FromStr;

/// The times a user asked for, as typed: finite and increasing, at least one. `Display` gives
/// back the text the user typed, so that a message about one of the times can quote it.
#[derive(Clone, Debug, PartialEq)]
pub struct TimeSeries {
    times: Times,
    text: String,
}

/// The two spellings of [`TimeSeries`].
#[derive(Clone, Debug, PartialEq)]
enum Times {
    /// `A:B:N`: N evenly spaced times from A to B inclusive (N = 1 needs A = B).
    Range { start: f64, end: f64, count: usize },
    /// `t1,t2,…`: the times as listed.
    List(Vec<f64>),
}

/// What every message about a bad time series ends with: the two accepted forms.
const EXPECTED: &str = "expected a list such as 0,0.5,1 or A:B:N (N evenly spaced times from \
                        A to B inclusive) such as 0:1:37";

impl TimeSeries {
    /// `count` times across `[start, end]` given in f32 (a model's time range), each end taken at
    /// its shortest decimal form, exactly as if the user had typed `START:END:COUNT`, so that a
    /// default series and the same series typed by hand give the same times.
    pub fn across(start: f32, end: f32, count: usize) -> Result<TimeSeries, String> {
        format!("{start}:{end}:{count}").parse()
    }

    /// How many times the series holds (known before they are made: a count check costs
    /// nothing even for `0:1:4000000000`).
    pub fn len(&self) -> usize {
        match &self.times {
            Times::Range { count, .. } => *count,
            Times::List(list) => list.len(),
        }
    }

    /// Never true: a series holds at least one time (the parser refuses an empty one).
    pub fn is_empty(&self) -> bool {
        self.len() == 0
    }

    /// The times: for `A:B:N`, `A + (B − A) · i / (N − 1)` for i = 0..N; for a list, as listed.
    pub fn times(&self) -> Vec<f64> {
        match &self.times {
            Times::List(list) => list.clone(),
            Times::Range {
                start, count: 1, ..
            } => vec![*start],
            &Times::Range {
                start: a,
                end: b,
                count: n,
            } => (0..n)
                .map(|i| a + (b - a) * i as f64 / (n - 1) as f64)
                .collect(),
        }
    }
}

impl fmt::Display for TimeSeries {
    /// The series as the user typed it (surrounding blanks removed).
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(&self.text)
    }
}

impl FromStr for TimeSeries {
    type Err = String;

    fn from_str(s: &str) -> Result<Self, Self::Err> {
        let bad = |why: String| format!("times {s:?}: {why} ({EXPECTED})");
        let number = |v: &str, what: &str| {
            v.trim()
                .parse::<f64>()
                .ok()
                .filter(|x| x.is_finite())
                .ok_or_else(|| bad(format!("{what} {v:?} is not a finite number")))
        };
        let times = if s.contains(':') {
            let parts: Vec<&str> = s.split(':').collect();
            let [a, b, n] = parts[..] else {
                return Err(bad("A:B:N takes three values separated by ':'".into()));
            };
            let (start, end) = (number(a, "start")?, number(b, "end")?);
            let count = n
                .trim()
                .parse::<usize>()
                .ok()
                .filter(|&n| n >= 1)
                .ok_or_else(|| bad(format!("count {n:?} is not a whole number ≥ 1")))?;
            if count == 1 {
                if start != end {
                    return Err(bad("one time needs A = B".into()));
                }
            } else if end <= start {
                return Err(bad("the end must come after the start".into()));
            } else if !(end - start).is_finite() {
                // Finite ends whose difference overflows would give infinite and NaN times.
                return Err(bad("the span B − A is too large".into()));
            }
            Times::Range { start, end, count }
        } else {
            if s.trim().is_empty() {
                return Err(bad("no time given".into()));
            }
            let list = s
                .split(',')
                .map(|v| number(v, "time"))
                .collect::<Result<Vec<f64>, String>>()?;
            if let Some(w) = list.windows(2).find(|w| w[1] <= w[0]) {
                return Err(bad(format!(
                    "the times must increase, but {} comes after {}",
                    w[1], w[0]
                )));
            }
            Times::List(list)
        };
        Ok(TimeSeries {
            times,
            text: s.trim().to_string(),
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn times(s: &str) -> Vec<f64> {
        s.parse::<TimeSeries>().unwrap().times()
    }

    #[test]
    fn evenly_spaced_inclusive() {
        assert_eq!(times("0:1:3"), [0.0, 0.5, 1.0]);
        assert_eq!(times("-1:1:5"), [-1.0, -0.5, 0.0, 0.5, 1.0]);
        assert_eq!(times(" 0 : 2 : 2 "), [0.0, 2.0]);
        assert_eq!(times("2:2:1"), [2.0]);
        let demo = times("0:1:37");
        assert_eq!((demo.len(), demo[0], demo[36]), (37, 0.0, 1.0));
        assert_eq!(demo[9], 0.25);
    }

    /// `dynaslice mesh` samples in f32: the f64 times rounded once are the times it computed in
    /// f32 before the parsers were merged, for the demo's series and the usual unit ranges.
    #[test]
    fn rounded_to_f32_as_computed_in_f32() {
        for (a, b, n) in [
            (0.0f32, 1.0f32, 37usize),
            (0.0, 1.0, 5),
            (-1.0, 1.0, 3),
            (0.0, 2.0, 20),
        ] {
            let f32_times: Vec<f32> = (0..n)
                .map(|i| a + (b - a) * i as f32 / (n - 1) as f32)
                .collect();
            let rounded: Vec<f32> = times(&format!("{a}:{b}:{n}"))
                .into_iter()
                .map(|t| t as f32)
                .collect();
            assert_eq!(rounded, f32_times, "{a}:{b}:{n}");
        }
    }

    #[test]
    fn bad_series_are_refused_with_the_reason() {
        for (bad, why) in [
            ("0:1", "three values"),
            ("0:1:3:4", "three values"),
            ("", "no time given"),
            (" ", "no time given"),
            ("0,x", "time \"x\" is not a finite number"),
            ("0,,1", "time \"\" is not a finite number"),
            ("0,NaN", "time \"NaN\""),
            ("1,0.5", "must increase, but 0.5 comes after 1"),
            ("0,0", "must increase"),
            ("0:x:3", "end \"x\" is not a finite number"),
            ("NaN:1:3", "start \"NaN\""),
            ("0:inf:3", "end \"inf\""),
            ("0:1:0", "count \"0\""),
            ("0:1:-2", "count \"-2\""),
            ("0:1:2.5", "count \"2.5\""),
            ("0:1:1", "one time needs A = B"),
            ("1:0:3", "the end must come after the start"),
            ("1:1:3", "the end must come after the start"),
            ("-1e308:1e308:3", "too large"),
        ] {
            let e = bad.parse::<TimeSeries>().unwrap_err();
            assert!(
                e.contains(why) && e.contains("0,0.5,1") && e.contains("A:B:N"),
                "{bad}: {e}"
            );
        }
    }

    #[test]
    fn a_list_is_taken_as_listed_and_quoted_as_typed() {
        assert_eq!(times("0,0.25,1"), [0.0, 0.25, 1.0]);
        assert_eq!(times(" -1 , 2 "), [-1.0, 2.0]);
        assert_eq!(times("287.7"), [287.7]);
        let typed = " 0:2:5 ".parse::<TimeSeries>().unwrap();
        assert_eq!(typed.to_string(), "0:2:5");
        assert_eq!((typed.len(), typed.is_empty()), (5, false));
        assert_eq!("0,1,2".parse::<TimeSeries>().unwrap().len(), 3);
    }

    #[test]
    fn across_reads_f32_ends_as_typed() {
        let typed = times("0.1:0.7:4");
        assert_eq!(TimeSeries::across(0.1, 0.7, 4).unwrap().times(), typed);
        assert_eq!(typed[0], 0.1, "not 0.1f32 widened");
        assert!(TimeSeries::across(1.0, 0.0, 3).is_err());
        assert!(TimeSeries::across(f32::NAN, 1.0, 3).is_err());
    }
}
