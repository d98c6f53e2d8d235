//! `A:B:N` time series (`--times 0:1:37`): N times evenly spaced from A to B inclusive, the
//! frames of `dynaslice mesh`, `labels` and `eval volume`.

use std::str::FromStr;

/// N evenly spaced times from `start` to `end` inclusive: finite, increasing (`end > start`),
/// or a single time (`N = 1`, `start = end`).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct TimeSeries {
    start: f64,
    end: f64,
    count: usize,
}

impl TimeSeries {
    /// `count` times across `[start, end]` given in f32 (a model's time range), each end taken at
    /// its shortest decimal form, exactly as if the user had typed `START:END:COUNT`, so that a
    /// default series and the same series typed by hand give the same times.
    pub fn across(start: f32, end: f32, count: usize) -> Result<TimeSeries, String> {
        format!("{start}:{end}:{count}").parse()
    }

    /// The times, `start + (end − start) · i / (N − 1)` for i = 0..N.
    pub fn times(&self) -> Vec<f64> {
        if self.count == 1 {
            return vec![self.start];
        }
        let (a, b, n) = (self.start, self.end, self.count);
        (0..n)
            .map(|i| a + (b - a) * i as f64 / (n - 1) as f64)
            .collect()
    }
}

impl FromStr for TimeSeries {
    type Err = String;

    fn from_str(s: &str) -> Result<Self, Self::Err> {
        let bad = |why: String| format!("time series {s:?}: {why} (expected A:B:N, e.g. 0:1:37)");
        let parts: Vec<&str> = s.split(':').collect();
        let [a, b, n] = parts[..] else {
            return Err(bad("not three values separated by ':'".into()));
        };
        let number = |v: &str, what: &str| {
            v.trim()
                .parse::<f64>()
                .ok()
                .filter(|x| x.is_finite())
                .ok_or_else(|| bad(format!("{what} {v:?} is not a finite number")))
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
        Ok(TimeSeries { start, end, count })
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
            ("0:1", "not three values"),
            ("0:1:3:4", "not three values"),
            ("", "not three values"),
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
                e.contains(why) && e.contains("expected A:B:N"),
                "{bad}: {e}"
            );
        }
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
