//! What evaluating a rollout returns: the paper's metrics and, optionally, the gradients of `L`
//! and `C` with respect to the controls (computed in [`super::grad`]).

use crate::rollout::penetration::Penetration;
use autodiff::Tensor;

/// The paper's metrics of one rollout.
#[derive(Clone, Copy, Debug, Default, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct Metrics {
    /// Target error `G`.
    #[serde(rename = "G")]
    pub g: f64,
    /// Trajectory irregularity `T` (unscaled).
    #[serde(rename = "T")]
    pub t: f64,
    /// Elastic energy `E` summed over steps 1..T (unscaled).
    #[serde(rename = "E")]
    pub e: f64,
    /// `α·T`.
    pub alpha_t: f64,
    /// `β·E`.
    pub beta_e: f64,
    /// Safety `C = −Σ_t Σ_i relu(δ − SDF)` (0 without safety obstacles).
    #[serde(rename = "C")]
    pub c: f64,
    /// Smallest signed distance of any particle at any step 1..T (∞ without safety obstacles;
    /// JSON writes ∞ as `null`, which reads back as ∞).
    #[serde(deserialize_with = "null_as_infinity")]
    pub min_sdf: f64,
    /// Smallest signed distance along the straight path of every particle between consecutive
    /// steps 0..T, exact for sphere sets and planes (∞ without safety obstacles, `null` in JSON).
    #[serde(deserialize_with = "null_as_infinity")]
    pub min_sdf_swept: f64,
    /// `L = G + αT + βE`.
    #[serde(rename = "L")]
    pub l: f64,
    /// The deepest penetration of any particle (grippers included) into the colliders at steps
    /// 1..T; `None` without colliders (and then left out of the JSON).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub max_penetration: Option<Penetration>,
}

/// Reads a number that JSON may hold as `null` (how `serde_json` writes ∞): `null` reads as ∞.
pub fn null_as_infinity<'de, D: serde::Deserializer<'de>>(d: D) -> Result<f64, D::Error> {
    let v: Option<f64> = serde::Deserialize::deserialize(d)?;
    Ok(v.unwrap_or(f64::INFINITY))
}

/// Metrics, states and (optionally) gradients of `L` and `C` with respect to the controls.
#[derive(Clone, Debug)]
pub struct Evaluation {
    /// The metrics.
    pub metrics: Metrics,
    /// `T + 1` states, the first the rest state.
    pub states: Vec<Tensor>,
    /// `dL/dU`, shaped like the controls.
    pub grad_l: Option<Tensor>,
    /// `dC/dU`, shaped like the controls.
    pub grad_c: Option<Tensor>,
}
