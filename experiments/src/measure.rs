//! Wall-clock timing of repeated runs and the process's memory from procfs.

use anyhow::Result;
use serde::{Deserialize, Serialize};
use std::time::Instant;

/// Wall-clock seconds of repeated runs (`std::time::Instant`).
#[derive(Serialize, Deserialize, Clone, Copy, Debug, PartialEq)]
pub struct Timing {
    /// The median run (the mean of the middle two for an even count).
    pub median_s: f64,
    /// The fastest run: the least disturbed by other processes on a shared machine.
    pub min_s: f64,
    /// How many runs were timed.
    pub runs: usize,
}

impl Timing {
    /// A single run of `s` seconds.
    pub fn once(s: f64) -> Timing {
        Timing {
            median_s: s,
            min_s: s,
            runs: 1,
        }
    }
}

/// The median of `v` (sorted in place; the mean of the middle two for an even length; NaN if empty).
pub fn median(v: &mut [f64]) -> f64 {
    v.sort_by(f64::total_cmp);
    let n = v.len();
    if n == 0 {
        f64::NAN
    } else if n % 2 == 1 {
        v[n / 2]
    } else {
        0.5 * (v[n / 2 - 1] + v[n / 2])
    }
}

/// Runs `f` once and returns its result with the wall-clock seconds it took.
pub fn timed<T>(f: impl FnOnce() -> Result<T>) -> Result<(T, f64)> {
    let t = Instant::now();
    let value = f()?;
    Ok((value, t.elapsed().as_secs_f64()))
}

/// Times `f` over `reps` runs, stopping early once `budget_s` is spent (always at least one run).
/// Each result goes through `std::hint::black_box`, so the work is not optimized away.
pub fn time_runs<T>(
    reps: usize,
    budget_s: f64,
    mut f: impl FnMut() -> Result<T>,
) -> Result<Timing> {
    let clock = Instant::now();
    let mut times = Vec::with_capacity(reps);
    while times.len() < reps.max(1) {
        let t = Instant::now();
        std::hint::black_box(f()?);
        times.push(t.elapsed().as_secs_f64());
        if clock.elapsed().as_secs_f64() > budget_s {
            break;
        }
    }
    let min_s = times.iter().copied().fold(f64::INFINITY, f64::min);
    Ok(Timing {
        median_s: median(&mut times),
        min_s,
        runs: times.len(),
    })
}

/// A `/proc/self/status` field in kB (`VmHWM`, `VmRSS`); `None` where there is no procfs.
pub fn proc_status_kb(field: &str) -> Option<f64> {
    let text = std::fs::read_to_string("/proc/self/status").ok()?;
    parse_status_kb(&text, field)
}

/// The value in kB of `field` in the text of a `/proc/*/status` file.
fn parse_status_kb(text: &str, field: &str) -> Option<f64> {
    text.lines()
        .find_map(|l| l.strip_prefix(field)?.strip_prefix(':'))
        .and_then(|v| v.split_whitespace().next()?.parse().ok())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn median_of_odd_and_even_counts() {
        assert_eq!(median(&mut [3.0, 1.0, 2.0]), 2.0);
        assert_eq!(median(&mut [4.0, 1.0, 3.0, 2.0]), 2.5);
        assert!(median(&mut []).is_nan());
    }

    #[test]
    fn time_runs_counts_runs_and_stops_at_the_budget() {
        let mut calls = 0;
        let t = time_runs(5, f64::INFINITY, || {
            calls += 1;
            Ok(calls)
        })
        .unwrap();
        assert_eq!((t.runs, calls), (5, 5));
        assert!(t.min_s <= t.median_s);
        // A budget already spent after the first run: exactly one run.
        let t = time_runs(5, -1.0, || Ok(())).unwrap();
        assert_eq!(t.runs, 1);
        // Zero repetitions still time one run.
        assert_eq!(time_runs(0, f64::INFINITY, || Ok(())).unwrap().runs, 1);
    }

    #[test]
    fn timed_returns_the_value_and_its_time() {
        let (v, s) = timed(|| Ok(7)).unwrap();
        assert_eq!(v, 7);
        assert!(s >= 0.0);
        assert!(timed(|| -> Result<()> { anyhow::bail!("boom") }).is_err());
    }

    #[test]
    fn time_runs_passes_errors_on() {
        let e = time_runs(3, f64::INFINITY, || -> Result<()> { anyhow::bail!("boom") });
        assert_eq!(e.unwrap_err().to_string(), "boom");
    }

    #[test]
    fn status_fields_parse_in_kb() {
        let text = "Name:\tx\nVmHWM:\t  12345 kB\nVmRSS:\t 678 kB\n";
        assert_eq!(parse_status_kb(text, "VmHWM"), Some(12345.0));
        assert_eq!(parse_status_kb(text, "VmRSS"), Some(678.0));
        assert_eq!(parse_status_kb(text, "VmPeak"), None);
    }
}
