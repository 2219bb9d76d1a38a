//! The `check` section of a result: the physics a plan was checked under ([`CheckPhysics`], also
//! how `--check` and Python's `check=` spell it) and what each check found
//! ([`crate::physics_check`] runs the checks).

use crate::error::{Error, Result};
use cloth::scene::SolverKind;
use cloth::Scene;
use serde::{Deserialize, Serialize};
use std::fmt;
use std::str::FromStr;

/// The physics a plan is checked under.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case", tag = "solver")]
pub enum CheckPhysics {
    /// XPBD with this many Gauss–Seidel iterations per step.
    Xpbd {
        /// Iterations per step (≥ 1).
        iterations: usize,
    },
    /// Newton's minimizer of `Φ` to this relative tolerance.
    Newton {
        /// Relative `‖∇Φ‖` tolerance, in (0, 1).
        tolerance: f64,
    },
    /// Newton with branch following ([`cloth::NewtonSettings::load_halvings`]) at the scene's
    /// tolerance: each step's load applied in increments halved until each solve stays in the
    /// convex neighbourhood of a minimizer, so that the cloth takes the equilibrium it reaches
    /// continuously from the previous one. Where a step has several equilibria (a buckling
    /// cloth, a towel lying down with friction), one solve from the predictor or the previous
    /// state may end in another: a plan whose verdict changes under this check depends on
    /// which equilibrium the solver's path lands in. Costs 23–70 rollouts of the default
    /// physics (measured on the task suite, docs/experiments.md).
    NewtonBranch {
        /// Most halvings of a load increment, 1 to [`cloth::scene::MAX_LOAD_HALVINGS`].
        halvings: usize,
    },
}

/// `newton-branch`'s halvings when none are given.
pub const BRANCH_HALVINGS: usize = 10;

impl FromStr for CheckPhysics {
    type Err = Error;

    /// `xpbd:N` (N iterations per step), `newton` (tolerance 1e-12), `newton:TOL`,
    /// `newton-branch` ([`BRANCH_HALVINGS`] halvings) or `newton-branch:H`.
    fn from_str(s: &str) -> Result<Self> {
        let bad = |requirement: String| Error::InvalidSetting {
            name: "check".into(),
            requirement,
        };
        let (name, value) = match s.split_once(':') {
            Some((n, v)) => (n, Some(v)),
            None => (s, None),
        };
        match (name, value) {
            ("xpbd", Some(v)) => match v.parse::<usize>() {
                Ok(iterations) if iterations >= 1 => Ok(CheckPhysics::Xpbd { iterations }),
                _ => Err(bad(format!(
                    "needs XPBD's iterations as a count ≥ 1 (`xpbd:3000`), got `{s}`"
                ))),
            },
            ("newton", v) => match v.map_or(Ok(1e-12), str::parse::<f64>) {
                Ok(tolerance) if tolerance > 0.0 && tolerance < 1.0 => {
                    Ok(CheckPhysics::Newton { tolerance })
                }
                _ => Err(bad(format!(
                    "needs Newton's tolerance in (0, 1) (`newton:1e-12`), got `{s}`"
                ))),
            },
            ("newton-branch", v) => match v.map_or(Ok(BRANCH_HALVINGS), str::parse::<usize>) {
                Ok(halvings) if (1..=cloth::scene::MAX_LOAD_HALVINGS).contains(&halvings) => {
                    Ok(CheckPhysics::NewtonBranch { halvings })
                }
                _ => Err(bad(format!(
                    "needs the most load halvings as a count from 1 to {} \
                     (`newton-branch:10`), got `{s}`",
                    cloth::scene::MAX_LOAD_HALVINGS
                ))),
            },
            _ => Err(bad(format!(
                "must be `xpbd:N`, `newton`, `newton:TOL`, `newton-branch` or \
                 `newton-branch:H`, got `{s}`"
            ))),
        }
    }
}

impl fmt::Display for CheckPhysics {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            CheckPhysics::Xpbd { iterations } => write!(f, "XPBD at {iterations} iterations"),
            CheckPhysics::Newton { tolerance } => write!(f, "Newton at tolerance {tolerance:e}"),
            CheckPhysics::NewtonBranch { halvings } => {
                write!(f, "Newton with branch following ({halvings} load halvings)")
            }
        }
    }
}

impl CheckPhysics {
    /// `scene` with its step solver replaced by this physics.
    pub fn apply(&self, scene: &Scene) -> Scene {
        let mut s = scene.clone();
        match *self {
            CheckPhysics::Xpbd { iterations } => {
                s.physics.solver = Some(SolverKind::Xpbd);
                s.physics.iterations = iterations;
            }
            CheckPhysics::Newton { tolerance } => {
                s.physics.solver = Some(SolverKind::Newton);
                s.physics.tolerance = Some(tolerance);
            }
            CheckPhysics::NewtonBranch { halvings } => {
                s.physics.solver = Some(SolverKind::Newton);
                s.physics.load_halvings = Some(halvings);
            }
        }
        s
    }
}

/// One check of one plan.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct CheckRound {
    /// The margin the checked plan was planned with.
    pub planned_delta: f64,
    /// Smallest signed distance of any particle at any step under the check's physics (∞
    /// without safety obstacles, `null` in JSON).
    #[serde(deserialize_with = "cloth::null_as_infinity")]
    pub min_sdf: f64,
    /// `C` at the user's margin under the check's physics.
    #[serde(rename = "C")]
    pub c: f64,
    /// `C ≥ −1e−6` ([`super::is_safe`]).
    pub safe: bool,
    /// Largest final distance of a target from its position under the check's physics.
    pub max_target_error: f64,
}

/// What checking a plan under other physics found (the `check` section of a result).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct PhysicsCheck {
    /// The physics the plan was checked under.
    pub physics: CheckPhysics,
    /// The user's margin, at which the check judges safety.
    pub delta: f64,
    /// Every check made, the last one of the returned plan.
    pub rounds: Vec<CheckRound>,
}

impl PhysicsCheck {
    /// The returned plan's check.
    pub fn last(&self) -> &CheckRound {
        self.rounds.last().expect("a check has at least one round")
    }

    /// One line for the summary.
    pub fn summary(&self) -> String {
        let last = self.last();
        let replans = match self.rounds.len() - 1 {
            0 => String::new(),
            k => format!(
                " (planned at δ′ = {:.4} after {k} re-plan{})",
                last.planned_delta,
                if k == 1 { "" } else { "s" }
            ),
        };
        let safety = if last.min_sdf.is_finite() {
            format!(
                "min SDF {:.4} against δ = {}, {}",
                last.min_sdf,
                self.delta,
                if last.safe { "safe" } else { "NOT safe" }
            )
        } else {
            "no safety obstacle".to_string()
        };
        format!(
            "checked under {}: {safety}; largest target error {:.4}{replans}",
            self.physics, last.max_target_error
        )
    }
}
