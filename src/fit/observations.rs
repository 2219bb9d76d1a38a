//! Observed motion: the controls a real cloth was moved with and where tracked points of it were
//! seen, read from JSON and checked against the scene, every bad value named by its field.
//!
//! ```json
//! {"controls": [[[dx, dy, dz], …], …],
//!  "points": [{"particle": [r, c], "step": 4, "position": [x, y, z]},
//!             {"particle": 17, "step": 4, "position": [x, y, z], "noise": 0.002},
//!             {"triangle": 12, "barycentric": [0.2, 0.3, 0.5], "step": 8, "position": [x, y, z]}],
//!  "noise": 0.001}
//! ```
//!
//! `controls` is a controls file's array (one entry per step, one displacement per gripper);
//! a point is a particle (`[row, col]` on a grid, or its index) or a point on one of the cloth's
//! triangles (its index in [`cloth::Model::triangles`], with barycentric weights summing to 1),
//! seen at `step` (1 to the horizon) at `position`. `noise` is the standard deviation of every
//! coordinate (length units; a point's own `noise` overrides it); without it the fit estimates
//! one from its residuals.

use crate::result::controls_from_nested;
use crate::{Error, Result};
use autodiff::Tensor;
use cloth::scene::ParticleRef;
use cloth::{Controls, Model, Scene};
use serde::Deserialize;

/// A tracked point of the cloth: the particles it is a weighted sum of.
#[derive(Clone, Debug, PartialEq)]
pub struct TrackedPoint {
    /// `(particle, weight)` pairs: one particle with weight 1, or a triangle's three corners.
    pub weights: Vec<(usize, f64)>,
    /// The step it was seen at (1 to the horizon).
    pub step: usize,
    /// Where it was seen.
    pub position: [f64; 3],
    /// The standard deviation of each of its coordinates, when known.
    pub noise: Option<f64>,
}

impl TrackedPoint {
    /// Its position in the state `x`.
    pub fn locate(&self, x: &Tensor) -> [f64; 3] {
        let mut p = [0.0; 3];
        for &(q, w) in &self.weights {
            for (k, pk) in p.iter_mut().enumerate() {
                *pk += w * x.get(q, k);
            }
        }
        p
    }
}

/// A checked observation file.
#[derive(Clone, Debug)]
pub struct Observations {
    /// The controls the cloth was moved with.
    pub controls: Controls,
    /// The tracked points.
    pub points: Vec<TrackedPoint>,
}

/// The file as written.
#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct File {
    controls: Vec<Vec<[f64; 3]>>,
    points: Vec<Point>,
    #[serde(default)]
    noise: Option<f64>,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct Point {
    #[serde(default)]
    particle: Option<ParticleRef>,
    #[serde(default)]
    triangle: Option<usize>,
    #[serde(default)]
    barycentric: Option<[f64; 3]>,
    step: usize,
    position: [f64; 3],
    #[serde(default)]
    noise: Option<f64>,
}

impl Observations {
    /// Reads observations from JSON `text` for `model` (compiled from `scene`).
    ///
    /// # Errors
    /// [`Error::Observation`] naming the field: malformed JSON (with its line), controls of the
    /// wrong shape, a particle or triangle not on the cloth, a step outside `1..=T`, weights that
    /// do not sum to 1, a non-finite or negative value, no points.
    pub fn parse(text: &str, scene: &Scene, model: &Model) -> Result<Observations> {
        let (text, non_finite) = non_finite_as_null(text);
        let de = &mut serde_json::Deserializer::from_str(&text);
        let file: File = serde_path_to_error::deserialize(de).map_err(|e| {
            let field = e.path().to_string();
            let field = if field == "." {
                "(file)".to_string()
            } else {
                field
            };
            let reason = e.inner().to_string();
            if non_finite && reason.starts_with("invalid type: null") {
                bad(field, "not a finite number (NaN or Infinity)".into())
            } else {
                bad(field, reason)
            }
        })?;
        let controls = controls_from_nested(model, &file.controls)
            .map_err(|e| bad("controls", e.to_string()))?;
        if file.points.is_empty() {
            return Err(bad("points", "no tracked points: nothing to fit to".into()));
        }
        check_noise("noise", file.noise)?;
        let points = (file.points.iter().enumerate())
            .map(|(i, p)| point(scene, model, i, p, file.noise))
            .collect::<Result<Vec<_>>>()?;
        Ok(Observations { controls, points })
    }

    /// Reads the observation file `path`; errors name the file.
    ///
    /// # Errors
    /// As [`Observations::parse`], or the file cannot be read.
    pub fn read(path: &std::path::Path, scene: &Scene, model: &Model) -> Result<Observations> {
        let text = std::fs::read_to_string(path).map_err(|e| Error::Observation {
            field: "(file)".into(),
            reason: format!("cannot read {}: {e}", path.display()),
        })?;
        Observations::parse(&text, scene, model).map_err(|e| match e {
            Error::Observation { field, reason } => Error::Observation {
                field: format!("{}: {field}", path.display()),
                reason,
            },
            other => other,
        })
    }
}

/// `text` with the bare tokens `NaN`, `Infinity` and `-Infinity` (which JSON does not have, but
/// Python's `json` writes) outside strings replaced by `null`, so that the parser reaches them and
/// names their field; whether there were any.
fn non_finite_as_null(text: &str) -> (String, bool) {
    let mut out = String::with_capacity(text.len());
    let (mut in_string, mut escaped, mut found) = (false, false, false);
    let mut rest = text;
    while let Some(c) = rest.chars().next() {
        if in_string {
            (escaped, in_string) = (!escaped && c == '\\', escaped || c != '"');
        } else if c == '"' {
            in_string = true;
        } else if let Some(token) = ["NaN", "Infinity", "-Infinity"]
            .into_iter()
            .find(|t| rest.starts_with(t))
        {
            out.push_str("null");
            rest = &rest[token.len()..];
            found = true;
            continue;
        }
        out.push(c);
        rest = &rest[c.len_utf8()..];
    }
    (out, found)
}

fn bad(field: impl Into<String>, reason: String) -> Error {
    Error::Observation {
        field: field.into(),
        reason,
    }
}

fn check_noise(field: &str, noise: Option<f64>) -> Result<()> {
    match noise {
        Some(s) if !(s.is_finite() && s > 0.0) => Err(bad(
            field,
            format!("must be a finite standard deviation > 0, got {s}"),
        )),
        _ => Ok(()),
    }
}

/// Point `i` of the file, checked.
fn point(
    scene: &Scene,
    model: &Model,
    i: usize,
    p: &Point,
    noise: Option<f64>,
) -> Result<TrackedPoint> {
    let field = |name: &str| format!("points[{i}].{name}");
    let n = model.n_particles();
    let weights = match (p.particle, p.triangle, p.barycentric) {
        (Some(particle), None, None) => {
            vec![(particle_index(scene, n, particle, &field("particle"))?, 1.0)]
        }
        (None, Some(t), Some(w)) => {
            let tri = model.triangles.get(t).ok_or_else(|| {
                bad(
                    field("triangle"),
                    format!(
                        "triangle {t} is not on the cloth ({} triangles, 0-based)",
                        model.triangles.len()
                    ),
                )
            })?;
            let sum: f64 = w.iter().sum();
            if w.iter().any(|v| !v.is_finite() || *v < 0.0) || (sum - 1.0).abs() > 1e-9 {
                return Err(bad(
                    field("barycentric"),
                    format!("weights must be ≥ 0 and sum to 1, got {w:?}"),
                ));
            }
            tri.iter().copied().zip(w).collect()
        }
        (None, Some(_), None) => {
            return Err(bad(
                field("barycentric"),
                "a triangle point needs its barycentric weights".into(),
            ))
        }
        _ => {
            return Err(bad(
                format!("points[{i}]"),
                "name either a `particle`, or a `triangle` with its `barycentric` weights".into(),
            ))
        }
    };
    let horizon = model.task.horizon;
    if p.step == 0 || p.step > horizon {
        return Err(bad(
            field("step"),
            format!(
                "step {} is not one of the simulated steps 1 to {horizon} (task.horizon)",
                p.step
            ),
        ));
    }
    if let Some(k) = p.position.iter().position(|v| !v.is_finite()) {
        return Err(bad(
            format!("points[{i}].position[{k}]"),
            "not a finite number".into(),
        ));
    }
    check_noise(&field("noise"), p.noise)?;
    Ok(TrackedPoint {
        weights,
        step: p.step,
        position: p.position,
        noise: p.noise.or(noise),
    })
}

/// The particle index of a reference: `[row, col]` on a grid, or an index below `n`.
fn particle_index(scene: &Scene, n: usize, particle: ParticleRef, field: &str) -> Result<usize> {
    let (index, fits) = match particle {
        ParticleRef::Grid([r, c]) if !scene.cloth.is_mesh() => (
            r * scene.cloth.cols + c,
            r < scene.cloth.rows && c < scene.cloth.cols,
        ),
        ParticleRef::Grid(_) => (usize::MAX, false),
        ParticleRef::Vertex(v) => (v, v < n),
    };
    if fits {
        Ok(index)
    } else {
        Err(bad(
            field,
            format!(
                "{particle} is not a particle of the cloth ({} × {} grid, {n} particles)",
                scene.cloth.rows, scene.cloth.cols
            ),
        ))
    }
}
