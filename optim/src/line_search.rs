//! Strong-Wolfe line search (Nocedal & Wright, Algorithms 3.5 and 3.6, with safeguarded cubic
//! interpolation in the zoom phase). Failed evaluations count as "step too long".

use crate::error::EvalError;

/// One evaluated trial point along the search direction.
#[derive(Clone, Debug)]
pub(crate) struct Trial {
    pub alpha: f64,
    /// `φ(α) = f(x + α d)`.
    pub value: f64,
    /// `φ'(α) = ∇f(x + α d)ᵀ d`.
    pub slope: f64,
    /// The full gradient at the trial point.
    pub gradient: Vec<f64>,
}

/// Line-search result.
#[derive(Clone, Debug)]
pub(crate) enum WolfeOutcome {
    /// Strong Wolfe conditions hold.
    Wolfe(Trial),
    /// Only sufficient decrease holds (evaluation budget or interval exhausted).
    Armijo(Trial),
    /// No acceptable point found.
    Failed {
        evaluation_failures: usize,
        trials: usize,
    },
}

/// Parameters of the search.
#[derive(Clone, Copy, Debug)]
pub(crate) struct WolfeParams {
    pub c1: f64,
    pub c2: f64,
    pub max_evaluations: usize,
    pub alpha_max: f64,
}

/// Minimizer of the cubic interpolating `(a, fa, ga)` and `(b, fb, gb)`, or `None`.
fn cubic_min(a: f64, fa: f64, ga: f64, b: f64, fb: f64, gb: f64) -> Option<f64> {
    let d1 = ga + gb - 3.0 * (fa - fb) / (a - b);
    let disc = d1 * d1 - ga * gb;
    if disc < 0.0 {
        return None;
    }
    let d2 = (b - a).signum() * disc.sqrt();
    let t = b - (b - a) * (gb + d2 - d1) / (gb - ga + 2.0 * d2);
    t.is_finite().then_some(t)
}

/// Searches along a descent direction: `phi(α)` evaluates the function, its slope and gradient.
pub(crate) fn strong_wolfe(
    mut phi: impl FnMut(f64) -> Result<Trial, EvalError>,
    f0: f64,
    slope0: f64,
    alpha_init: f64,
    p: WolfeParams,
) -> WolfeOutcome {
    let mut evals = 0usize;
    let mut failures = 0usize;
    let mut best_armijo: Option<Trial> = None;
    let armijo = |t: &Trial| t.value <= f0 + p.c1 * t.alpha * slope0;
    let curvature = |t: &Trial| t.slope.abs() <= -p.c2 * slope0;
    let note = |best: &mut Option<Trial>, t: &Trial| {
        if armijo(t) && best.as_ref().is_none_or(|b| t.value < b.value) {
            *best = Some(t.clone());
        }
    };

    // Bracketing phase.
    let mut prev = Trial {
        alpha: 0.0,
        value: f0,
        slope: slope0,
        gradient: Vec::new(),
    };
    let mut alpha = alpha_init.min(p.alpha_max);
    let mut bracket: Option<(Trial, Trial)> = None;
    let mut first = true;
    while evals < p.max_evaluations {
        evals += 1;
        let t = match phi(alpha) {
            Ok(t) => t,
            Err(_) => {
                failures += 1;
                alpha = prev.alpha + 0.5 * (alpha - prev.alpha);
                continue;
            }
        };
        note(&mut best_armijo, &t);
        if !armijo(&t) || (!first && t.value >= prev.value) {
            bracket = Some((prev, t));
            break;
        }
        if curvature(&t) {
            return WolfeOutcome::Wolfe(t);
        }
        if t.slope >= 0.0 {
            bracket = Some((t, prev));
            break;
        }
        if alpha >= p.alpha_max {
            return WolfeOutcome::Armijo(t);
        }
        first = false;
        let next = (2.0 * alpha).min(p.alpha_max);
        prev = t;
        alpha = next;
    }

    // Zoom phase: `lo` satisfies Armijo and has the lowest value so far; `hi` brackets.
    if let Some((mut lo, mut hi)) = bracket {
        while evals < p.max_evaluations {
            let (a, b) = (lo.alpha, hi.alpha);
            let width = (b - a).abs();
            if width <= 1e-14 * a.abs().max(b.abs()).max(1e-300) {
                break;
            }
            let (left, right) = (a.min(b), a.max(b));
            let guess = if hi.gradient.is_empty() && hi.slope.is_nan() {
                None
            } else {
                cubic_min(a, lo.value, lo.slope, b, hi.value, hi.slope)
            };
            let alpha = match guess {
                Some(t) if t > left + 0.1 * width && t < right - 0.1 * width => t,
                _ => 0.5 * (a + b),
            };
            evals += 1;
            let t = match phi(alpha) {
                Ok(t) => t,
                Err(_) => {
                    failures += 1;
                    // Treat as a (very) high value: shrink towards `lo`.
                    hi = Trial {
                        alpha,
                        value: f64::INFINITY,
                        slope: f64::NAN,
                        gradient: Vec::new(),
                    };
                    continue;
                }
            };
            note(&mut best_armijo, &t);
            if !armijo(&t) || t.value >= lo.value {
                hi = t;
            } else {
                if curvature(&t) {
                    return WolfeOutcome::Wolfe(t);
                }
                if t.slope * (hi.alpha - lo.alpha) >= 0.0 {
                    hi = lo;
                }
                lo = t;
            }
        }
    }
    match best_armijo {
        Some(t) if t.alpha > 0.0 => WolfeOutcome::Armijo(t),
        _ => WolfeOutcome::Failed {
            evaluation_failures: failures,
            trials: evals,
        },
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn quadratic(alpha: f64) -> Result<Trial, EvalError> {
        // f(x) = (x − 3)², x = α, d = 1, x0 = 0.
        Ok(Trial {
            alpha,
            value: (alpha - 3.0).powi(2),
            slope: 2.0 * (alpha - 3.0),
            gradient: vec![2.0 * (alpha - 3.0)],
        })
    }

    #[test]
    fn finds_a_strong_wolfe_point() {
        let p = WolfeParams {
            c1: 1e-4,
            c2: 0.1,
            max_evaluations: 30,
            alpha_max: 1e10,
        };
        match strong_wolfe(quadratic, 9.0, -6.0, 0.01, p) {
            WolfeOutcome::Wolfe(t) => {
                assert!(t.value <= 9.0 + 1e-4 * t.alpha * -6.0);
                assert!(t.slope.abs() <= 0.6, "{t:?}");
            }
            other => panic!("{other:?}"),
        }
    }

    #[test]
    fn evaluation_failures_shorten_the_step() {
        let p = WolfeParams {
            c1: 1e-4,
            c2: 0.9,
            max_evaluations: 30,
            alpha_max: 1e10,
        };
        let phi = |a: f64| {
            if a > 1.0 {
                Err(EvalError::new("out of domain"))
            } else {
                quadratic(a)
            }
        };
        // α = 8, 4, 2 fail; α = 1 satisfies both conditions (φ = 4, |φ'| = 4 ≤ 0.9 · 6).
        match strong_wolfe(phi, 9.0, -6.0, 8.0, p) {
            WolfeOutcome::Wolfe(t) => assert_eq!(t.alpha, 1.0, "{t:?}"),
            other => panic!("{other:?}"),
        }
    }
}
