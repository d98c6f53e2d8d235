//! The allowed values of an option, and the words that refuse a value outside them: one type
//! for the training options (dynaslice-train's `flags`), the input options
//! ([`crate::input_flags`]) and the command line's other numbers, so that `dynaslice` and
//! Python refuse a value with the same "out of range; allowed: …". Here, below both, because
//! dynaslice-train depends on this crate.

/// An option's allowed values: a closed or half-open interval of reals, or whole numbers.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Limit {
    lo: f64,
    /// `lo` itself excluded.
    open: bool,
    hi: f64,
    whole: bool,
}

impl Limit {
    /// Reals in (0, `hi`].
    pub const fn positive(hi: f64) -> Limit {
        Limit {
            lo: 0.0,
            open: true,
            hi,
            whole: false,
        }
    }

    /// Reals in [0, `hi`].
    pub const fn non_negative(hi: f64) -> Limit {
        Limit {
            lo: 0.0,
            open: false,
            hi,
            whole: false,
        }
    }

    /// Reals in [`lo`, `hi`].
    pub const fn between(lo: f64, hi: f64) -> Limit {
        Limit {
            lo,
            open: false,
            hi,
            whole: false,
        }
    }

    /// Whole numbers in [`lo`, `hi`].
    pub const fn count(lo: u64, hi: u64) -> Limit {
        Limit {
            lo: lo as f64,
            open: false,
            hi: hi as f64,
            whole: true,
        }
    }

    /// The lowest value allowed (or, where open, the bound above it).
    pub fn lo(&self) -> f64 {
        self.lo
    }

    /// The highest value allowed.
    pub fn hi(&self) -> f64 {
        self.hi
    }

    /// What the limit allows, in words.
    pub fn allowed(&self) -> String {
        match (self.whole, self.open, self.lo, self.hi) {
            // As integers: `u64::MAX` as f64 would show as 18446744073709552000.
            (true, ..) => format!(
                "a whole number from {} to {}",
                self.lo as u64, self.hi as u64
            ),
            (_, _, f64::NEG_INFINITY, f64::INFINITY) => "any finite number".to_string(),
            (_, true, 0.0, f64::INFINITY) => "a finite number > 0".to_string(),
            (_, false, 0.0, f64::INFINITY) => "a finite number ≥ 0".to_string(),
            (_, true, lo, hi) => format!("a number > {lo} and ≤ {hi}"),
            (_, false, lo, hi) => format!("a number from {lo} to {hi}"),
        }
    }

    /// `v` if the limit allows it, else "out of range; allowed: …" (or "not a finite number;
    /// allowed: …"): the text the command line's parsers and Python's keyword checks share.
    pub fn check(&self, v: f64) -> Result<f64, String> {
        if !v.is_finite() {
            return Err(format!("not a finite number; allowed: {}", self.allowed()));
        }
        if v < self.lo
            || (self.open && v == self.lo)
            || v > self.hi
            || (self.whole && v.fract() != 0.0)
        {
            return Err(format!("out of range; allowed: {}", self.allowed()));
        }
        Ok(v)
    }

    /// The whole number `text` says, if the limit allows it; else "out of range" (`-1`,
    /// `99999999999999999999`: whole numbers, only outside) or "not a whole number", each
    /// followed by "; allowed: …".
    pub fn whole(&self, text: &str) -> Result<u64, String> {
        let text = text.trim();
        let v: u64 = text.parse().map_err(|_| {
            let digits = text.strip_prefix(['-', '+']).unwrap_or(text);
            let whole = !digits.is_empty() && digits.bytes().all(|b| b.is_ascii_digit());
            let what = if whole {
                "out of range"
            } else {
                "not a whole number"
            };
            format!("{what}; allowed: {}", self.allowed())
        })?;
        // Compared as integers where they are: u64 seeds lose digits as f64.
        if (v as f64) < self.lo || (v as f64) > self.hi {
            return Err(format!("out of range; allowed: {}", self.allowed()));
        }
        Ok(v)
    }

    /// The real number `text` says, if the limit allows it ([`Limit::check`]); else "not a
    /// number; allowed: …".
    pub fn real(&self, text: &str) -> Result<f64, String> {
        let v: f64 = text
            .trim()
            .parse()
            .map_err(|_| format!("not a number; allowed: {}", self.allowed()))?;
        self.check(v)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn values_outside_are_refused_in_words() {
        let c = Limit::count(0, 1000);
        assert_eq!(c.whole(" 1000 "), Ok(1000));
        let range = "; allowed: a whole number from 0 to 1000";
        for (text, what) in [
            ("1001", "out of range"),
            ("-1", "out of range"),
            ("99999999999999999999", "out of range"),
            ("1.5", "not a whole number"),
            ("x", "not a whole number"),
            ("", "not a whole number"),
        ] {
            assert_eq!(c.whole(text), Err(format!("{what}{range}")), "{text}");
        }
        let big = Limit::count(0, u64::MAX);
        assert_eq!(big.whole("18446744073709551615"), Ok(u64::MAX));
        assert!(big.allowed().ends_with(" 18446744073709551615"));
        let p = Limit::positive(f64::INFINITY);
        assert_eq!(p.real("0.5"), Ok(0.5));
        assert_eq!(
            p.real("0"),
            Err("out of range; allowed: a finite number > 0".into())
        );
        assert!(p
            .real("NaN")
            .unwrap_err()
            .starts_with("not a finite number"));
        assert!(p.real("x").unwrap_err().starts_with("not a number"));
    }
}
