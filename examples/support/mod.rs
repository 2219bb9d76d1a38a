//! Helpers shared by the measuring examples (`accuracy_vs_time`, `speed_vs_jax`, `routes`).

#![allow(dead_code)]

use anyhow::{anyhow, ensure, Context, Result};
use serde::de::DeserializeOwned;
use std::path::Path;
use std::process::Command;

/// A `/proc/self/status` field in kB (`VmHWM`, `VmRSS`); `None` where there is no procfs.
pub fn proc_status_kb(field: &str) -> Option<f64> {
    let text = std::fs::read_to_string("/proc/self/status").ok()?;
    text.lines()
        .find_map(|l| l.strip_prefix(field)?.strip_prefix(':'))
        .and_then(|v| v.split_whitespace().next()?.parse().ok())
}

/// Runs the JAX reference `python script SCENE n n_iter` (`SCENE` as the script names it, e.g.
/// `U` for `u_obstacle`) and parses the last JSON line it prints.
pub fn run_jax<T: DeserializeOwned>(
    python: &Path,
    script: &Path,
    scene: &str,
    n: usize,
    n_iter: usize,
) -> Result<T> {
    let out = Command::new(python)
        .arg(script)
        .args([scene, &n.to_string(), &n_iter.to_string()])
        .output()
        .with_context(|| format!("cannot run {}", python.display()))?;
    ensure!(
        out.status.success(),
        "the JAX benchmark failed: {}",
        String::from_utf8_lossy(&out.stderr).trim()
    );
    let text = String::from_utf8_lossy(&out.stdout);
    let line = text
        .lines()
        .rev()
        .find(|l| l.trim_start().starts_with('{'))
        .ok_or_else(|| anyhow!("the JAX benchmark printed no JSON"))?;
    Ok(serde_json::from_str(line)?)
}
