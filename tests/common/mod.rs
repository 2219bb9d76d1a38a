//! Helpers shared by the root package's stability, honesty, bad-input and determinism tests.

#![allow(dead_code)]

use cloth::scene::{InitialControls, Target};
use cloth::Scene;
use std::path::{Path, PathBuf};
use std::process::{Command, Output};

/// The `clothopt` binary.
pub fn bin() -> Command {
    Command::new(env!("CARGO_BIN_EXE_clothopt"))
}

/// Runs a command to completion.
pub fn run(cmd: &mut Command) -> Output {
    cmd.output().expect("the binary runs")
}

pub fn stdout(o: &Output) -> String {
    String::from_utf8_lossy(&o.stdout).into_owned()
}

pub fn stderr(o: &Output) -> String {
    String::from_utf8_lossy(&o.stderr).into_owned()
}

/// A fresh scratch directory for one test, removed with everything in it when dropped.
pub struct Scratch(tempfile::TempDir);

impl std::ops::Deref for Scratch {
    type Target = Path;
    fn deref(&self) -> &Path {
        self.0.path()
    }
}

/// A fresh scratch directory for one test (`tag` and `name` appear in its name).
pub fn scratch(tag: &str, name: &str) -> Scratch {
    let prefix = format!("clothopt-{tag}-{name}-");
    Scratch(
        tempfile::Builder::new()
            .prefix(&prefix)
            .tempdir()
            .expect("a scratch directory"),
    )
}

/// The names of the files in `dir`, sorted.
pub fn files_in(dir: &Path) -> Vec<String> {
    let mut names: Vec<String> = std::fs::read_dir(dir)
        .unwrap()
        .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
        .collect();
    names.sort();
    names
}

/// A hanging `rows × cols` cloth (side 1, plane `y = −1.5`, top at `z = 2`), gripped at its two
/// top corners (one corner if `cols = 1`), stretch 1e4, distance bending 1e2 (the `swing`
/// material), `T = horizon`, targets on the bottom row, zero initial guess.
pub fn small(rows: usize, cols: usize, horizon: usize, iterations: usize) -> Scene {
    let mut s = Scene::builtin("swing").unwrap();
    s.name = format!("small{rows}x{cols}");
    s.cloth.rows = rows;
    s.cloth.cols = cols;
    s.physics.iterations = iterations;
    s.task.horizon = horizon;
    s.controls = if cols > 1 {
        vec![[0, 0].into(), [0, cols - 1].into()]
    } else {
        vec![[0, 0].into()]
    };
    let den = (cols.max(2) - 1) as f64;
    s.task.targets = (0..cols)
        .map(|c| Target {
            particle: [rows - 1, c].into(),
            position: [-0.5 + c as f64 / den, 1.0, 1.5],
        })
        .collect();
    s.task.initial_controls = InitialControls::Zeros;
    s.validate().unwrap();
    s
}

/// Writes `scene` as JSON into `dir/name` and returns the path.
pub fn write_scene(dir: &Path, name: &str, scene: &Scene) -> PathBuf {
    let path = dir.join(name);
    std::fs::write(&path, scene.to_json_pretty()).unwrap();
    path
}

/// Deterministic pseudo-random values in [-1, 1) (xorshift), so tests need no RNG crate.
pub fn noise(seed: u64, n: usize) -> Vec<f64> {
    let mut s = seed.wrapping_mul(0x9E37_79B9_7F4A_7C15) | 1;
    (0..n)
        .map(|_| {
            s ^= s << 13;
            s ^= s >> 7;
            s ^= s << 17;
            (s >> 11) as f64 / (1u64 << 53) as f64 * 2.0 - 1.0
        })
        .collect()
}

/// Every inequality row's directional derivative along `d` at `x`, analytic (from the Jacobian)
/// and by central differences with step `h`: `(analytic, fd)` per row.
pub fn row_derivatives(
    p: &mut impl optim::Problem,
    x: &[f64],
    d: &[f64],
    h: f64,
) -> Vec<(f64, f64)> {
    let (n, m) = (p.num_variables(), p.num_inequalities());
    let mut jac = optim::Jacobian::dense(m, n);
    p.inequality_jacobian(x, &mut jac).unwrap();
    let optim::Jacobian::Dense(jac) = jac else {
        panic!("dense")
    };
    let mut at = |s: f64| {
        let xs: Vec<f64> = x.iter().zip(d).map(|(a, b)| a + s * b).collect();
        let mut c = vec![0.0; m];
        p.inequalities(&xs, &mut c).unwrap();
        c
    };
    let (cp, cm) = (at(h), at(-h));
    (0..m)
        .map(|r| {
            let an: f64 = jac.row(r).iter().zip(d).map(|(a, b)| a * b).sum();
            (an, (cp[r] - cm[r]) / (2.0 * h))
        })
        .collect()
}
