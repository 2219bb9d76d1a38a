//! Report output shared by the experiments: checked claims (PASS/FAIL), table cells for values
//! that may be missing, and JSON result files written atomically.

use anyhow::Result;
use serde::Serialize;
use std::fmt;
use std::path::Path;

/// One checked claim of an experiment.
#[derive(Serialize, Clone, Debug, PartialEq)]
pub struct Verdict {
    /// Whether the measurement supports the claim.
    pub pass: bool,
    /// The claim, with the numbers it was checked on.
    pub claim: String,
}

impl fmt::Display for Verdict {
    /// `PASS claim` or `FAIL claim`.
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "{} {}", pass_fail(self.pass), self.claim)
    }
}

/// `PASS` or `FAIL`.
pub fn pass_fail(pass: bool) -> &'static str {
    if pass {
        "PASS"
    } else {
        "FAIL"
    }
}

/// A table cell: `v` with `prec` decimals, or `—` when missing.
pub fn fmt_opt(v: Option<f64>, prec: usize) -> String {
    v.map_or("—".into(), |v| format!("{v:.prec$}"))
}

/// An error on one line (serde's parse errors quote the source line below the message).
pub fn one_line(e: &impl fmt::Display) -> String {
    e.to_string()
        .split_whitespace()
        .collect::<Vec<_>>()
        .join(" ")
}

/// The last non-empty line of a child's error (its progress lines come first).
pub fn last_line(text: &str) -> String {
    let line = text.lines().rev().find(|l| !l.trim().is_empty());
    line.unwrap_or(text).trim().to_string()
}

/// Writes `value` as JSON to `path` atomically (temp file + rename) and says so on stdout.
pub fn write_json(path: &Path, value: &impl Serialize) -> Result<()> {
    clothopt::output::write_json_atomic(path, value)?;
    println!("wrote {}", path.display());
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn verdicts_and_cells_print_as_in_the_tables() {
        let v = Verdict {
            pass: false,
            claim: "G ≤ 0.05".into(),
        };
        assert_eq!(v.to_string(), "FAIL G ≤ 0.05");
        assert_eq!(pass_fail(true), "PASS");
        assert_eq!(fmt_opt(Some(0.12345), 2), "0.12");
        assert_eq!(fmt_opt(None, 2), "—");
    }

    #[test]
    fn json_is_written_whole() {
        let dir = std::env::temp_dir().join(format!("experiments-report-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let path = dir.join("r.json");
        write_json(&path, &serde_json::json!({"runs": [1, 2]})).unwrap();
        let back: serde_json::Value =
            serde_json::from_str(&std::fs::read_to_string(&path).unwrap()).unwrap();
        assert_eq!(back["runs"][1], 2);
        std::fs::remove_dir_all(&dir).unwrap();
    }

    #[test]
    fn errors_print_on_one_line() {
        assert_eq!(one_line(&"a\n  12 | b\n"), "a 12 | b");
        assert_eq!(
            last_line("x failed: [ 5 s] iteration 0\nerror: bad\n\n"),
            "error: bad"
        );
    }
}
