//! Synthetic observations: a scene's own rollout seen at some particles with seeded Gaussian
//! noise, as an observation file. For validating fits against known parameters (tests, the
//! `fit` experiment, the fit-then-plan example).

use super::observations::{Observations, TrackedPoint};
use crate::result::controls_to_nested;
use crate::Result;
use cloth::{Controls, Model};
use rand::{RngExt, SeedableRng};
use rand_xorshift::XorShiftRng;

/// What to observe.
#[derive(Clone, Debug)]
pub struct Sampling {
    /// How many particles are tracked: spread evenly over the free particles.
    pub points: usize,
    /// Every how many steps they are seen (the last step always is).
    pub every: usize,
    /// The standard deviation of each coordinate's noise (0: exact); written as the file's
    /// `noise` when positive.
    pub noise: f64,
    /// The noise's seed.
    pub seed: u64,
}

impl Sampling {
    /// `points` particles seen every `every` steps, without noise.
    pub fn exact(points: usize, every: usize) -> Sampling {
        Sampling {
            points,
            every,
            noise: 0.0,
            seed: 0,
        }
    }
}

/// `model`'s rollout under `controls`, observed as `sampling` says: the observations and the
/// same as an observation file's JSON.
///
/// # Errors
/// The rollout fails.
pub fn synthetic(
    model: &Model,
    controls: &Controls,
    sampling: &Sampling,
) -> Result<(Observations, serde_json::Value)> {
    let states = model.simulate(controls)?;
    let free: Vec<usize> = (0..model.n_particles())
        .filter(|&p| model.inv_mass[p] > 0.0)
        .collect();
    let count = sampling.points.clamp(1, free.len().max(1));
    let tracked: Vec<usize> = (0..count)
        .map(|i| free[(i * free.len()) / count + free.len() / (2 * count)])
        .collect();
    let horizon = model.task.horizon;
    let every = sampling.every.max(1);
    let steps: Vec<usize> = (1..=horizon)
        .filter(|t| t % every == 0 || *t == horizon)
        .collect();
    let mut rng = XorShiftRng::seed_from_u64(sampling.seed);
    let mut points = Vec::new();
    let mut json_points = Vec::new();
    for &t in &steps {
        for &p in &tracked {
            let position: [f64; 3] =
                std::array::from_fn(|k| states[t].get(p, k) + sampling.noise * gaussian(&mut rng));
            json_points.push(serde_json::json!({"particle": p, "step": t, "position": position}));
            points.push(TrackedPoint {
                weights: vec![(p, 1.0)],
                step: t,
                position,
                noise: (sampling.noise > 0.0).then_some(sampling.noise),
            });
        }
    }
    let mut file = serde_json::json!({
        "controls": controls_to_nested(controls),
        "points": json_points,
    });
    if sampling.noise > 0.0 {
        file["noise"] = sampling.noise.into();
    }
    let observations = Observations {
        controls: controls.clone(),
        points,
    };
    Ok((observations, file))
}

/// A standard normal sample (Box–Muller).
fn gaussian(rng: &mut XorShiftRng) -> f64 {
    let u1: f64 = rng.random_range(f64::MIN_POSITIVE..1.0);
    let u2: f64 = rng.random_range(0.0..1.0);
    (-2.0 * u1.ln()).sqrt() * (std::f64::consts::TAU * u2).cos()
}
