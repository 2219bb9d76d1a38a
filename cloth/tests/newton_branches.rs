//! A quasi-static step can have several minimizers of `Φ` (a cloth that can buckle either way), and
//! which one Newton's method ends in depends on its path. Measured at the controls where the SQP
//! planner stalled on `u_obstacle` (`optimize u_obstacle --physics newton --search off`, κ = 200):
//! moving the controls by `1e-10` along the planner's step switches step 3's state to another
//! minimum (both found after 200+ projected-Hessian iterations, `Φ` equal to 2e-6 relative), so
//! the rollout, `L` and the safety rows jump — no line search can pass such a jump. Load steps
//! ([`NewtonSettings::load_steps`]) follow one branch from the previous state, and the jump is gone.

use autodiff::Tensor;
use cloth::newton::solve::NewtonSystem;
use cloth::newton::NewtonSettings;
use cloth::{Model, Scene};

/// The planner's iterate at the stall (10 steps × 2 control points × xyz).
const STALL: [f64; 60] = [
    0.13207925862320705,
    0.5093062749650523,
    -0.13638489641387294,
    -0.08622542782169774,
    0.4101008722622403,
    -0.096196334159729,
    0.1320792586061631,
    0.5093062749595695,
    -0.13638489640634974,
    -0.08622542780836266,
    0.41010087226692304,
    -0.09619633416007066,
    0.13207925844689938,
    0.5093062748988881,
    -0.13638489633560721,
    -0.08622542767445172,
    0.4101008723262721,
    -0.09619633415701632,
    0.12976271087978855,
    0.5080640697359046,
    -0.13579426222644575,
    -0.08442369319273803,
    0.4108712150496568,
    -0.09625481582660482,
    -0.03962508694179245,
    0.39841366544667006,
    -0.10609886688620968,
    0.041520957173370905,
    0.46044334029747425,
    -0.10568538744261333,
    -0.08578552849623128,
    0.3618459443794205,
    -0.09677610017853144,
    0.07422753865921312,
    0.4695778118074164,
    -0.1111775731649624,
    -0.08578552903088724,
    0.36184594366382034,
    -0.09677610003332904,
    0.07422753913276613,
    0.4695778118892274,
    -0.1111775732826277,
    -0.0857855290494763,
    0.3618459435896187,
    -0.09677610002323785,
    0.07422753917177412,
    0.46957781188800013,
    -0.11117757329713632,
    -0.08578552904977542,
    0.36184594357590066,
    -0.09677610002197472,
    0.074227539178144,
    0.46957781188522113,
    -0.11117757330063253,
    -0.08578552904894614,
    0.36184594357154193,
    -0.09677610002179513,
    0.07422753917978324,
    0.4695778118832201,
    -0.11117757330190285,
];

/// [`STALL`] plus `1e-10` times the planner's step there.
const STALL_NUDGED: [f64; 60] = [
    0.132079258623813,
    0.5093062749677488,
    -0.13638489640184812,
    -0.08622542782588549,
    0.4101008722557362,
    -0.0961963341815509,
    0.13207925860676906,
    0.509306274962266,
    -0.1363848963943249,
    -0.08622542781255041,
    0.41010087226041897,
    -0.09619633418189255,
    0.13207925844750534,
    0.5093062749015846,
    -0.1363848963235824,
    -0.08622542767863947,
    0.41010087231976805,
    -0.09619633417883822,
    0.1297627108806262,
    0.5080640697387253,
    -0.13579426221448,
    -0.08442369319710595,
    0.41087121504307567,
    -0.09625481584842085,
    -0.039625086936564996,
    0.3984136654459608,
    -0.10609886687525366,
    0.0415209571678892,
    0.46044334029522,
    -0.10568538745822804,
    -0.08578552849287165,
    0.36184594437211626,
    -0.09677610016778056,
    0.07422753865708315,
    0.46957781180998587,
    -0.1111775731770322,
    -0.0857855290275276,
    0.36184594365651607,
    -0.09677610002257815,
    0.07422753913063615,
    0.46957781189179687,
    -0.11117757329469749,
    -0.08578552904611667,
    0.3618459435823144,
    -0.09677610001248696,
    0.07422753916964414,
    0.4695778118905696,
    -0.1111775733092061,
    -0.08578552904641579,
    0.3618459435685964,
    -0.09677610001122383,
    0.07422753917601402,
    0.4695778118877906,
    -0.11117757331270232,
    -0.0857855290455865,
    0.36184594356423766,
    -0.09677610001104424,
    0.07422753917765326,
    0.46957781188578956,
    -0.11117757331397264,
];

fn model() -> Model {
    Model::from_scene(&Scene::builtin("u_obstacle").unwrap()).unwrap()
}

fn controls(v: &[f64; 60]) -> Tensor {
    Tensor::new(10, 6, v.to_vec())
}

fn settings(load_steps: usize) -> NewtonSettings {
    NewtonSettings {
        load_steps,
        ..NewtonSettings::default()
    }
}

/// Largest coordinate difference of two states.
fn max_diff(a: &Tensor, b: &Tensor) -> f64 {
    a.data()
        .iter()
        .zip(b.data())
        .map(|(x, y)| (x - y).abs())
        .fold(0.0, f64::max)
}

#[test]
fn one_solve_per_step_switches_minimum_under_a_tiny_control_change() {
    let m = model();
    let (ua, ub) = (controls(&STALL), controls(&STALL_NUDGED));
    assert!(max_diff(&ua, &ub) < 1e-10);
    let (sa, _) = m.simulate_newton(&ua, &settings(1)).unwrap();
    let (sb, stats) = m.simulate_newton(&ub, &settings(1)).unwrap();
    // Steps 1–2 move with the controls; step 3 lands in another minimum.
    assert!(
        max_diff(&sa[2], &sb[2]) < 1e-9,
        "{}",
        max_diff(&sa[2], &sb[2])
    );
    let jump = max_diff(&sa[3], &sb[3]);
    assert!(jump > 1e-2, "step 3 moved by {jump:.3e}");
    assert!(stats[2].projected > 100, "{:?}", stats[2]);
    // Both are minimizers of (to 1e-10) the same Φ, with energies 2e-6 apart.
    let mut system = NewtonSystem::new(&m).unwrap();
    let xt = m.begin_step(&sa[2], &m.step_controls(&ua, 2));
    for s in [&sa[3], &sb[3]] {
        assert!(
            system.factorize_exact(s.data(), xt.data()),
            "not a minimizer"
        );
    }
    let (pa, pb) = (
        system.pattern.energy(sa[3].data(), xt.data()),
        system.pattern.energy(sb[3].data(), xt.data()),
    );
    assert!((pa - pb).abs() < 1e-5 * pa, "Φ {pa} vs {pb}");
}

#[test]
fn load_steps_follow_one_branch() {
    let m = model();
    let (ua, ub) = (controls(&STALL), controls(&STALL_NUDGED));
    let (sa, _) = m.simulate_newton(&ua, &settings(16)).unwrap();
    let (sb, _) = m.simulate_newton(&ub, &settings(16)).unwrap();
    for t in 0..sa.len() {
        let d = max_diff(&sa[t], &sb[t]);
        assert!(d < 1e-8, "step {t} moved by {d:.3e}");
    }
}

#[test]
fn one_load_step_is_the_plain_solve() {
    // load_steps 1 is bitwise the solve from x̃ (the former behaviour).
    let m = model();
    let u = controls(&STALL);
    let (states, _) = m.simulate_newton(&u, &settings(1)).unwrap();
    let mut system = NewtonSystem::new(&m).unwrap();
    let xt = m.begin_step(&states[0], &m.step_controls(&u, 0));
    let (x, _) = system.solve(&xt, 1, &settings(1)).unwrap();
    assert_eq!(x.data(), states[1].data());
}
