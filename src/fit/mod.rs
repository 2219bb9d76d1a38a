//! `clothopt fit`: the material that makes the simulated cloth move as the real one was seen to.
//!
//! The fit varies the chosen [`Parameter`]s, each a factor on the scene's values, through their
//! logarithms `s` (so values stay positive), within bounds, and minimizes the weighted tracking
//! error `½ Σᵢ |x̂ᵢ(s) − oᵢ|² / σᵢ²` of the tracked points ([`observations`]) by
//! Levenberg–Marquardt, its Jacobian from the forward sensitivities of the rollout
//! ([`cloth::Model::parameter_tangents`]): one factorization per step for every parameter.
//! At the fit, the Gauss–Newton curvature `JᵀJ` gives each parameter's standard error
//! ([`estimate`]); one the observations do not determine is reported as not identifiable.

pub mod estimate;
pub mod observations;
mod summary;
pub mod synthetic;

use crate::{Error, Result};
use autodiff::Tensor;
use cloth::{ConstraintRegistry, Model, Parameter, Scene};
use estimate::{standard_errors, Spread};
pub use observations::{Observations, TrackedPoint};
use serde::Serialize;
use std::collections::BTreeMap;
use std::time::Instant;

/// Settings of a fit.
#[derive(Clone, Debug)]
pub struct FitOptions {
    /// Most Levenberg–Marquardt iterations. Default 50.
    pub max_iterations: usize,
    /// Each parameter stays within `[v/range, v·range]` of the scene's value `v`. Default 1e3.
    pub range: f64,
    /// The fit has converged when a full Gauss–Newton step would lower the cost by less than
    /// this fraction of it, or would move no parameter by more than about 1e-3 of its standard
    /// error. Default 1e-10.
    pub tolerance: f64,
}

impl Default for FitOptions {
    fn default() -> Self {
        FitOptions {
            max_iterations: 50,
            range: 1e3,
            tolerance: 1e-10,
        }
    }
}

/// How a fit ended.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize)]
#[serde(rename_all = "snake_case")]
pub enum FitStatus {
    /// A full Gauss–Newton step would gain less than the tolerance or move the parameters by
    /// less than about 1e-3 of their standard errors, or the observations are matched to
    /// round-off (1e-9 of the cloth's size).
    Converged,
    /// No step along the damped Gauss–Newton directions lowered the cost.
    Stalled,
    /// [`FitOptions::max_iterations`] ran out.
    IterationLimit,
}

/// One fitted parameter.
#[derive(Clone, Debug, Serialize)]
pub struct FittedParameter {
    /// The scene field it was read from (the first, where it scales several).
    pub field: String,
    /// The scene's value, where the fit started.
    pub start: f64,
    /// The fitted value.
    pub value: f64,
    /// Its standard error (from the Gauss–Newton curvature; `null` when not determined).
    pub std_error: Option<f64>,
    /// The standard error of its logarithm: the relative uncertainty.
    pub relative_std_error: Option<f64>,
    /// Whether the observations determine it (relative standard error at most
    /// [`estimate::IDENTIFIABLE`], taking noise no smaller than the identifiability floor).
    pub identifiable: bool,
    /// Whether it ended at a bound of its range.
    pub at_bound: bool,
}

/// The noise of the observations: given, or estimated from the residuals.
#[derive(Clone, Debug, Serialize)]
pub struct Noise {
    /// The standard deviation of a coordinate (length units; the smallest given, when points
    /// differ).
    pub value: f64,
    /// `"given"` or `"estimated"`.
    pub source: &'static str,
}

/// What a fit found.
#[derive(Clone, Debug, Serialize)]
pub struct FitResult {
    /// The scene's name.
    pub scene: String,
    /// How it ended.
    pub status: FitStatus,
    /// The fitted parameters by name.
    pub parameters: BTreeMap<String, FittedParameter>,
    /// Levenberg–Marquardt iterations.
    pub iterations: usize,
    /// Rollouts simulated (each accepted one also differentiated).
    pub simulations: usize,
    /// Wall time (s).
    pub wall_s: f64,
    /// The observations' noise.
    pub noise: Noise,
    /// Tracked points.
    pub points: usize,
    /// Root mean square of the tracked points' distances to where they were seen, at the start
    /// and at the fit.
    pub rms_error_start: f64,
    /// At the fit.
    pub rms_error: f64,
    /// The largest such distance at the fit.
    pub max_error: f64,
    /// Per step (index = step), the RMS distance of the points seen then; `null` where none was.
    pub residual_per_step: Vec<Option<f64>>,
    /// The scene with the fitted values (and its contact barrier pinned).
    #[serde(skip)]
    pub fitted_scene: Scene,
}

/// One evaluation of the fit's objective.
struct Trial {
    model: Model,
    states: Vec<Tensor>,
    /// Weighted residuals `(x̂ − o)/σ`, 3 per point.
    residual: Vec<f64>,
}

impl Trial {
    fn cost(&self) -> f64 {
        0.5 * self.residual.iter().map(|r| r * r).sum::<f64>()
    }
}

/// The fit's problem: the scene, its start and the observations.
struct Problem<'a> {
    scene: Scene,
    registry: &'a ConstraintRegistry,
    start: Tensor,
    params: Vec<Parameter>,
    observed: &'a Observations,
    /// `1/σ` per point (1 when the noise is unknown).
    weight: Vec<f64>,
}

impl Problem<'_> {
    /// The rollout at log-factors `s` and its weighted residuals.
    fn trial(&self, s: &[f64]) -> Result<Trial> {
        let scene = Parameter::scaled(&self.scene, &self.params, s.iter().map(|si| si.exp()))?;
        let mut model = Model::from_scene_with(&scene, self.registry)?;
        model.start = self.start.clone();
        let states = model.simulate(&self.observed.controls)?;
        let mut residual = Vec::with_capacity(3 * self.observed.points.len());
        for (pt, w) in self.observed.points.iter().zip(&self.weight) {
            let x = pt.locate(&states[pt.step]);
            residual.extend((0..3).map(|k| (x[k] - pt.position[k]) * w));
        }
        Ok(Trial {
            model,
            states,
            residual,
        })
    }

    /// `∂r/∂s`, rows by residual, columns by parameter (row-major).
    fn jacobian(&self, t: &Trial) -> Result<Vec<f64>> {
        let tangents =
            (t.model).parameter_tangents(&t.states, &self.observed.controls, &self.params)?;
        let np = self.params.len();
        let mut jac = vec![0.0; 3 * self.observed.points.len() * np];
        for (i, (pt, w)) in self.observed.points.iter().zip(&self.weight).enumerate() {
            for (j, tangent) in tangents[pt.step].iter().enumerate() {
                let d = pt.locate(tangent);
                for k in 0..3 {
                    jac[(3 * i + k) * np + j] = d[k] * w;
                }
            }
        }
        Ok(jac)
    }
}

/// Fits `params` of `scene` (custom constraint types from `registry`) to `observed`.
///
/// # Errors
/// A parameter the scene has nothing of ([`cloth::Parameter::value`]); a rollout at the scene's
/// own values that fails; bad options (naming them).
pub fn fit(
    scene: &Scene,
    registry: &ConstraintRegistry,
    observed: &Observations,
    params: &[Parameter],
    options: &FitOptions,
) -> Result<FitResult> {
    let started = Instant::now();
    crate::validate::ensure_iterations("max_iterations", options.max_iterations)?;
    if !(options.range.is_finite() && options.range > 1.0) {
        return Err(Error::InvalidSetting {
            name: "range".into(),
            requirement: format!("must be a finite factor > 1, got {}", options.range),
        });
    }
    if params.is_empty() {
        return Err(Error::InvalidSetting {
            name: "params".into(),
            requirement: "must name at least one parameter".into(),
        });
    }
    let mut scene = scene.clone();
    let base = Model::from_scene_with(&scene, registry)?;
    let pinned = Parameter::pin_contact(&mut scene, &base);
    if let Some(p) =
        (params.iter()).find(|p| !pinned && matches!(p, Parameter::Mass | Parameter::Gravity))
    {
        return Err(Error::InvalidSetting {
            name: "params".into(),
            requirement: format!(
                "cannot fit `{p}` here: beside rigid colliders, Newton's self-contact barrier \
                 stiffness follows the mass and gravity (m·|g|/d̂) and the scene cannot hold it \
                 fixed; use physics.contact.model \"smooth\""
            ),
        });
    }
    let starts = params
        .iter()
        .map(|p| p.value(&scene))
        .collect::<std::result::Result<Vec<_>, _>>()?;
    let noise_known = observed.points.iter().all(|p| p.noise.is_some());
    let problem = Problem {
        weight: (observed.points.iter())
            .map(|p| {
                if noise_known {
                    1.0 / p.noise.unwrap_or(1.0)
                } else {
                    1.0
                }
            })
            .collect(),
        scene,
        registry,
        start: base.start.clone(),
        params: params.to_vec(),
        observed,
    };
    let np = params.len();
    let bound = options.range.ln();
    let mut s = vec![0.0; np];
    let mut current = problem.trial(&s)?;
    let rms_error_start = rms(&observed.points, &current.states, None);
    let mut jac = problem.jacobian(&current)?;
    let (mut simulations, mut iterations) = (1, 0);
    let mut lambda = 1e-3;
    let extent = problem.scene.longest_side();
    let status = loop {
        let (a, g) = estimate::normal_equations(&jac, &current.residual, np);
        let cost = current.cost();
        // What a full Gauss–Newton step would still gain.
        let gauss_newton = estimate::damped_step(&a, &g, 0.0);
        let predicted = -0.5 * g.iter().zip(&gauss_newton).map(|(a, b)| a * b).sum::<f64>();
        // Matched to round-off (synthetic, exact observations) is converged too.
        let matched = rms(&observed.points, &current.states, None) <= 1e-9 * extent;
        // A step within a thousandth of the standard errors gains nothing worth a rollout:
        // ½·1e-6·σ², σ² = 1 in the units of residuals weighted by a given noise, else estimated.
        let dof = current.residual.len().saturating_sub(np).max(1) as f64;
        let sigma2 = if noise_known { 1.0 } else { 2.0 * cost / dof };
        let negligible = 0.5 * STEP_IN_ERRORS_SQUARED * sigma2;
        if matched || predicted <= (options.tolerance * cost).max(negligible) {
            break FitStatus::Converged;
        }
        if iterations == options.max_iterations {
            break FitStatus::IterationLimit;
        }
        iterations += 1;
        let mut accepted = None;
        for _ in 0..12 {
            let step = estimate::damped_step(&a, &g, lambda);
            let next: Vec<f64> = (s.iter().zip(&step))
                .map(|(si, d)| (si + d).clamp(-bound, bound))
                .collect();
            if next == s {
                break;
            }
            simulations += 1;
            match problem.trial(&next) {
                Ok(t) if t.cost() < cost => {
                    accepted = Some((next, t));
                    lambda = (lambda / 3.0).max(1e-12);
                    break;
                }
                // A worse point, or one the simulator cannot solve: damp more.
                _ => lambda *= 4.0,
            }
        }
        let Some((next, t)) = accepted else {
            break FitStatus::Stalled;
        };
        s = next;
        current = t;
        jac = problem.jacobian(&current)?;
    };
    let m = current.residual.len();
    let ssr: f64 = current.residual.iter().map(|r| r * r).sum();
    let noise = if noise_known {
        Noise {
            value: (observed.points.iter())
                .filter_map(|p| p.noise)
                .fold(f64::INFINITY, f64::min),
            source: "given",
        }
    } else {
        Noise {
            value: if m > np {
                (ssr / (m - np) as f64).sqrt()
            } else {
                f64::NAN
            },
            source: "estimated",
        }
    };
    let spread = standard_errors(&jac, np, noise_known, noise.value, extent);
    let fitted_scene = Parameter::scaled(&problem.scene, params, s.iter().map(|si| si.exp()))?;
    let parameters = (params.iter().enumerate())
        .map(|(j, p)| {
            let value = starts[j] * s[j].exp();
            let Spread { log, identifiable } = spread[j];
            let fitted = FittedParameter {
                field: p.field(&problem.scene),
                start: starts[j],
                value,
                std_error: log.map(|l| l * value),
                relative_std_error: log,
                identifiable,
                at_bound: s[j].abs() >= bound,
            };
            (p.to_string(), fitted)
        })
        .collect();
    let (max_error, residual_per_step) = per_step(&observed.points, &current.states);
    Ok(FitResult {
        scene: problem.scene.name.clone(),
        status,
        parameters,
        iterations,
        simulations,
        wall_s: started.elapsed().as_secs_f64(),
        noise,
        points: observed.points.len(),
        rms_error_start,
        rms_error: rms(&observed.points, &current.states, None),
        max_error,
        residual_per_step,
        fitted_scene,
    })
}

/// The squared size, in standard errors, of a Gauss–Newton step that counts as converged: such a
/// step gains at most `½·1e-6·σ²`, which no rollout's precision resolves reliably (the fits of
/// `experiments --bin fit` stalled short of 1e-10 of the cost on contact rollouts).
const STEP_IN_ERRORS_SQUARED: f64 = 1e-6;

/// The RMS distance of the tracked points (those seen at `step`, or all) to their observations.
fn rms(points: &[TrackedPoint], states: &[Tensor], step: Option<usize>) -> f64 {
    let d2: Vec<f64> = (points.iter())
        .filter(|p| step.is_none_or(|s| p.step == s))
        .map(|p| {
            let x = p.locate(&states[p.step]);
            (0..3).map(|k| (x[k] - p.position[k]).powi(2)).sum()
        })
        .collect();
    (d2.iter().sum::<f64>() / d2.len().max(1) as f64).sqrt()
}

/// The largest distance of a tracked point to its observation, and the RMS distance per step.
fn per_step(points: &[TrackedPoint], states: &[Tensor]) -> (f64, Vec<Option<f64>>) {
    let max = (points.iter())
        .map(|p| {
            let x = p.locate(&states[p.step]);
            (0..3)
                .map(|k| (x[k] - p.position[k]).powi(2))
                .sum::<f64>()
                .sqrt()
        })
        .fold(0.0, f64::max);
    let steps = (0..states.len())
        .map(|t| {
            points
                .iter()
                .any(|p| p.step == t)
                .then(|| rms(points, states, Some(t)))
        })
        .collect();
    (max, steps)
}
