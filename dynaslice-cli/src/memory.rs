//! Memory estimates of the big allocations (label volumes, dense meshing, held-out rows, the
//! synthetic benchmark's volumes, the Chamfer samples of `eval synthetic`), checked before the
//! work starts against the memory the machine has available, so a too-fine grid ends with a
//! message naming the figure instead of an abort on allocation halfway through.
//! The formulas are in docs/robustness.md.

use anyhow::{bail, Result};

/// `--allow-memory`: skip the check (the estimate may be pessimistic, or swap may be wanted).
#[derive(clap::Args, Debug, Clone, Copy, Default)]
pub struct MemoryArgs {
    /// Run even where the memory estimate exceeds the memory available (MemAvailable).
    #[arg(long)]
    pub allow_memory: bool,
}

/// Bytes the kernel reports as available to new allocations without swapping (`MemAvailable`
/// of /proc/meminfo); `None` where that is unknown (not Linux), and no check is made.
pub fn available() -> Option<f64> {
    let text = std::fs::read_to_string("/proc/meminfo").ok()?;
    let line = text.lines().find(|l| l.starts_with("MemAvailable:"))?;
    let kib: f64 = line.split_whitespace().nth(1)?.parse().ok()?;
    Some(kib * 1024.0)
}

/// A byte count for messages: `46.8 GB`.
pub fn human(bytes: f64) -> String {
    const UNITS: [&str; 6] = ["bytes", "kB", "MB", "GB", "TB", "PB"];
    let mut v = bytes;
    let mut u = 0;
    while v >= 1000.0 && u + 1 < UNITS.len() {
        v /= 1000.0;
        u += 1;
    }
    if u == 0 {
        format!("{v:.0} bytes")
    } else {
        format!("{v:.1} {}", UNITS[u])
    }
}

/// Refuses `bytes` (an estimate; computed in f64 so no product overflows) of `what` where it
/// exceeds the available memory, unless `args.allow_memory`; `hint` says what to lower.
pub fn check(what: &str, bytes: f64, hint: &str, args: MemoryArgs) -> Result<()> {
    if args.allow_memory {
        return Ok(());
    }
    if let Some(free) = available() {
        if bytes > free {
            bail!(
                "{what} needs about {} of memory, more than the {} available \
                 (MemAvailable); {hint}, or add --allow-memory to try anyway",
                human(bytes),
                human(free)
            );
        }
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn refuses_what_no_machine_has_unless_allowed() {
        let err = check("x", 1e20, "lower it", MemoryArgs::default());
        if available().is_some() {
            let e = err.unwrap_err().to_string();
            assert!(e.contains("100000.0 PB") && e.contains("lower it"), "{e}");
        }
        let allow = MemoryArgs { allow_memory: true };
        assert!(check("x", 1e20, "", allow).is_ok());
        assert!(check("x", 1.0, "", MemoryArgs::default()).is_ok());
        assert_eq!(human(46.8e9), "46.8 GB");
    }
}
