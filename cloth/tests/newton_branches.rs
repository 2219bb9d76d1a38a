//! A quasi-static step can have several minimizers of `Φ` (a cloth that can buckle either way), and
//! which one Newton's method ends in depends on its path. Measured at the controls where the SQP
//! planner stalled on `u_obstacle` (`optimize u_obstacle --physics newton --search off`, κ = 200,
//! one solve per step from `x̃`): moving the controls by `1e-10` along the planner's step switches
//! step 3's state to another minimum (both found after 200+ projected-Hessian iterations, `Φ`
//! equal to 2e-6 relative), so the rollout, `L` and the safety rows jump — no line search can
//! pass such a jump. Branch following ([`NewtonSettings::load_halvings`], the default) continues
//! the previous state's branch, and the jump is gone; a jump remains only where that branch
//! ends (a fold), measured on an 8 × 8 `u_obstacle`.

use autodiff::Tensor;
use cloth::internals::NewtonSystem;
use cloth::NewtonSettings;
use cloth::{Model, Scene};
use common::XorShift;

mod common;

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

/// Where the planner with branch following stalled on `u_obstacle` refined to 8 × 8 (`--search
/// off`, 254 SQP iterations): step 3's branch ends (a fold) within `1e-9` of these controls.
const FOLD: [f64; 60] = [
    0.13278898399223238,
    0.4260891923523508,
    -0.12416368874942979,
    -0.10659501245171303,
    0.3864630196596416,
    -0.08801631140983543,
    0.13278849095994313,
    0.4260887677562951,
    -0.12416329070863034,
    -0.10659471819251931,
    0.3864628728535431,
    -0.08801665717701222,
    0.13278363268401291,
    0.4260896821503879,
    -0.12416083261145111,
    -0.10659156157526392,
    0.3864652282937328,
    -0.0880155206477687,
    0.13277531373461537,
    0.42607543071231446,
    -0.12416272210265152,
    -0.10658124843590192,
    0.3864756492990784,
    -0.08801404285415214,
    -0.0371430185218168,
    0.4118975055262849,
    -0.10913558996746758,
    0.02415768162919298,
    0.44452018688373063,
    -0.10418109726715452,
    -0.09393146831929962,
    0.408401038710873,
    -0.10353572179046214,
    0.07466095852558219,
    0.4648023342048028,
    -0.11040602791526326,
    -0.09393115182963169,
    0.4084014136502669,
    -0.10353595212972334,
    0.07466038403012225,
    0.46480198858121696,
    -0.11040581400560405,
    -0.09393115183223594,
    0.40840141365372223,
    -0.10353595211025439,
    0.07466038419586601,
    0.4648019885987951,
    -0.11040581404433407,
    -0.09393115296517679,
    0.4084014140847875,
    -0.103535951956401,
    0.07466038530818615,
    0.464801989573333,
    -0.11040581423569465,
    -0.09393115665542862,
    0.4084013883226229,
    -0.10353593381975369,
    0.07466041184305806,
    0.4648020144601718,
    -0.1104058305842036,
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

/// `load_steps` parts without branch following (`halvings` 0), or with it.
fn settings(load_steps: usize, load_halvings: usize) -> NewtonSettings {
    NewtonSettings {
        load_steps,
        load_halvings,
        ..NewtonSettings::default()
    }
}

/// `base` without chord steps and shifts: Newton's path as it was when the knife-edge controls
/// of these tests were found. Where a solve's end depends on the last bits of its path (a jump
/// between minima, the end of a branch at a fold), chord steps and shifted Hessians move the
/// knife edge: at `STALL` and `FOLD` their rollouts do not jump under the same perturbations.
fn newton_path(base: NewtonSettings) -> NewtonSettings {
    NewtonSettings {
        chord_steps: false,
        shift_stalled: false,
        ..base
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
    let plain = newton_path(settings(1, 0));
    let (sa, _) = m.simulate_newton(&ua, &plain).unwrap();
    let (sb, stats) = m.simulate_newton(&ub, &plain).unwrap();
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
fn branch_following_removes_the_jump() {
    let m = model();
    let (ua, ub) = (controls(&STALL), controls(&STALL_NUDGED));
    let default = NewtonSettings::default();
    assert!(default.load_halvings > 0, "branch following is the default");
    let (sa, stats) = m.simulate_newton(&ua, &default).unwrap();
    let (sb, _) = m.simulate_newton(&ub, &default).unwrap();
    for t in 0..sa.len() {
        let d = max_diff(&sa[t], &sb[t]);
        assert!(d < 1e-8, "step {t} moved by {d:.3e}");
    }
    // Step 3's load was split where a solve left the convex neighbourhood of the branch.
    assert!(
        stats[2].rejected_loads > 0 && stats[2].loads > 1,
        "{:?}",
        stats[2]
    );
}

#[test]
fn load_steps_follow_one_branch() {
    let m = model();
    let (ua, ub) = (controls(&STALL), controls(&STALL_NUDGED));
    let (sa, _) = m.simulate_newton(&ua, &settings(16, 0)).unwrap();
    let (sb, _) = m.simulate_newton(&ub, &settings(16, 0)).unwrap();
    for t in 0..sa.len() {
        let d = max_diff(&sa[t], &sb[t]);
        assert!(d < 1e-8, "step {t} moved by {d:.3e}");
    }
}

#[test]
fn one_load_step_without_halvings_is_the_plain_solve() {
    // load_steps 1, load_halvings 0 is bitwise the solve from x̃ (the former behaviour).
    let m = model();
    let u = controls(&STALL);
    let (states, _) = m.simulate_newton(&u, &settings(1, 0)).unwrap();
    let mut system = NewtonSystem::new(&m).unwrap();
    let xt = m.begin_step(&states[0], &m.step_controls(&u, 0));
    let (x, _) = system.solve(&xt, 1, &settings(1, 0)).unwrap();
    assert_eq!(x.data(), states[1].data());
}

#[test]
fn the_previous_state_is_the_minimizer_where_the_load_path_starts() {
    // x̂₀ = x + M⁻¹∇E(x): ∇Φ(x; x̂₀) = 0, so the solve from x̂₀'s minimizer x takes no iteration.
    let m = model();
    let u = controls(&STALL);
    let (states, _) = m.simulate_newton(&u, &NewtonSettings::default()).unwrap();
    let mut system = NewtonSystem::new(&m).unwrap();
    let x = &states[4];
    let x0 = system.rest_predicted(x, &m.inv_mass);
    assert!(max_diff(&x0, x) > 1e-3, "the shift is not trivial");
    let (y, stats) = system.solve_from(x, &x0, 5, &settings(1, 0)).unwrap();
    assert_eq!(stats.iterations, 0, "{stats:?}");
    assert_eq!(y.data(), x.data());
}

#[test]
fn a_jump_remains_where_the_branch_ends() {
    // On u_obstacle at 8 × 8, where the planner with branch following stalled: a 1e-9 change of
    // the controls moves step 3 by 2e-2, and Newton started from the first state at the changed
    // controls does not stay near it (its branch has ended: a fold), while the second state at
    // the first controls is still a minimizer (one iteration): the planner is at the edge of a
    // branch, where no smooth method finds a KKT point.
    let scene = Scene::builtin("u_obstacle").unwrap().refined(8, 8).unwrap();
    let m = Model::from_scene(&scene).unwrap();
    let ua = controls(&FOLD);
    let mut rng = XorShift::new(7);
    let mut ub = ua.clone();
    for v in ub.data_mut() {
        *v += 1e-9 * rng.uniform(-1.0, 1.0);
    }
    let set = newton_path(NewtonSettings::default());
    let (sa, _) = m.simulate_newton(&ua, &set).unwrap();
    let (sb, _) = m.simulate_newton(&ub, &set).unwrap();
    assert!(max_diff(&sa[2], &sb[2]) < 1e-8);
    let jump = max_diff(&sa[3], &sb[3]);
    assert!(jump > 1e-2, "step 3 moved by {jump:.3e}");
    let mut system = NewtonSystem::new(&m).unwrap();
    let xt_b = m.begin_step(&sb[2], &m.step_controls(&ub, 2));
    let (from_a, _) = system
        .solve_from(&sa[3], &xt_b, 3, &newton_path(settings(1, 0)))
        .unwrap();
    assert!(max_diff(&from_a, &sa[3]) > 1e-2, "A's branch goes on");
    assert!(max_diff(&from_a, &sb[3]) < 1e-8);
    let xt_a = m.begin_step(&sa[2], &m.step_controls(&ua, 2));
    let (from_b, stats) = system
        .solve_from(&sb[3], &xt_a, 3, &newton_path(settings(1, 0)))
        .unwrap();
    assert!(
        max_diff(&from_b, &sb[3]) < 1e-8 && stats.iterations <= 2,
        "{stats:?}"
    );
}

#[test]
fn a_symmetric_cloth_leaves_the_saddle_its_branch_crosses() {
    // u_obstacle at 20 × 20 from its initial guess: continuing the flat, symmetric state crosses
    // a buckling point, where the state is a saddle of Φ (this was `NewtonSaddle`); it is left
    // along the unstable mode, and every returned state is a minimizer.
    let scene = Scene::builtin("u_obstacle")
        .unwrap()
        .refined(20, 20)
        .unwrap();
    let m = Model::from_scene(&scene).unwrap();
    let u = scene.initial_controls();
    let (states, stats) = m.simulate_newton(&u, &NewtonSettings::default()).unwrap();
    let escapes: usize = stats.iter().map(|s| s.escapes).sum();
    assert!(escapes >= 1, "{stats:?}");
    common::assert_minimizers(&m, &states, &u);
}
