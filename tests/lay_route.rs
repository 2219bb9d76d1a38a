//! The lay route (`src/search/lay/`): a towel hanging behind a rail is lifted over it and laid
//! on the table behind it, within the scene's step limit, and is offered only where it fits.

use autodiff::Tensor;
use cloth::sdf::SignedDistance;
use cloth::{Model, Scene};
use clothopt::plan::initial_controls;
use clothopt::search::routes::{carried, paths_of};
use nalgebra::Vector3;

/// A 7 × 7, 0.3 m towel hanging from its top corners at z = 1.3, y = −0.65, behind a 4 cm rail
/// at z = 1.1, y = −0.5, to be laid flat on a 0.75 m table: held edge at y = −0.15, free edge at
/// y = +0.15. The guess moves straight to the held edge's targets, through the rail's line.
fn rail_scene(horizon: usize) -> Scene {
    let step = |d: f64| d / horizon as f64;
    let text = format!(
        r#"{{
      "name": "rail_lay",
      "cloth": {{"rows": 7, "cols": 7, "top_left": [-0.15, -0.65, 1.3], "right": [0.3, 0.0, 0.0],
                "down": [0.0, 0.0, -0.3], "particle_mass": 0.000988}},
      "material": {{"stretch": 1000.0, "bending": {{"model": "distance", "stiffness": 1.0}}}},
      "physics": {{"dt": 0.1, "gravity": [0.0, 0.0, -9.81], "iterations": 100, "solver": "xpbd"}},
      "controls": [[0, 0], [0, 6]],
      "obstacles": [
        {{"type": "box", "center": [0.0, 0.0, 0.375], "half_extents": [0.6, 0.4, 0.375],
          "role": "collider", "friction": 0.4}},
        {{"type": "capsule", "a": [-0.5, -0.5, 1.1], "b": [0.5, -0.5, 1.1], "radius": 0.02,
          "role": "collider"}}
      ],
      "task": {{"horizon": {horizon}, "alpha": 0.1, "beta": 0.0001,
        "targets": [
          {{"particle": [0, 0], "position": [-0.15, -0.15, 0.75]}},
          {{"particle": [0, 6], "position": [0.15, -0.15, 0.75]}},
          {{"particle": [6, 0], "position": [-0.15, 0.15, 0.75]}},
          {{"particle": [6, 6], "position": [0.15, 0.15, 0.75]}},
          {{"particle": [3, 3], "position": [0.0, 0.0, 0.75]}}],
        "limits": {{"max_step": 0.1, "max_strain": 0.1}},
        "initial_controls": {{"constant": [[0.0, {dy}, {dz}], [0.0, {dy}, {dz}]]}}}}
    }}"#,
        dy = step(0.5),
        dz = step(-0.55),
    );
    Scene::from_json_str(&text).unwrap()
}

/// The largest distance of a particle of the last state from its target.
fn largest_error(model: &Model, states: &[Tensor]) -> f64 {
    let last = states.last().unwrap();
    let targets = model.task.targets.as_slice();
    (0..targets.len())
        .map(|i| {
            (0..3)
                .map(|j| (last.get(targets[i], j) - model.task.target_positions.get(i, j)).powi(2))
                .sum::<f64>()
                .sqrt()
        })
        .fold(0.0, f64::max)
}

#[test]
fn a_towel_behind_a_rail_is_carried_over_it_and_laid_on_the_table() {
    let scene = rail_scene(24);
    let model = Model::from_scene(&scene).unwrap();
    let guess = initial_controls(&scene, &model).unwrap();
    let guess_states = model.simulate(&guess).unwrap();
    let (routes, built) = carried(&model, &guess, &guess_states);
    assert!(
        (1..=8).contains(&built),
        "{built} rollouts built the lay route"
    );
    assert_eq!(
        routes[0].route,
        "lay",
        "{:?}",
        routes.iter().map(|r| &r.route).collect::<Vec<_>>()
    );
    let lay = &routes[0].controls;
    // Every step within the scene's 0.1, and the route ends on the held edge's targets.
    let paths = paths_of(&model, lay);
    for w in paths.windows(2) {
        for (a, b) in w[0].iter().zip(&w[1]) {
            let step: f64 = (0..3).map(|j| (b[j] - a[j]).powi(2)).sum::<f64>();
            assert!(step.sqrt() <= 0.1 + 1e-9, "{}", step.sqrt());
        }
    }
    assert!((paths[24][0][1] + 0.15).abs() < 1e-12 && (paths[24][0][2] - 0.75).abs() < 1e-12);
    // The towel never touches the rail, unlike the guess, and ends far nearer its targets.
    let states = model.simulate(lay).unwrap();
    let rail = &model.colliders.capsules[0];
    let clearance = |states: &[Tensor]| {
        states
            .iter()
            .flat_map(|x| {
                x.data()
                    .chunks_exact(3)
                    .map(|p| rail.distance(&Vector3::new(p[0], p[1], p[2])))
            })
            .fold(f64::INFINITY, f64::min)
    };
    let (lay_error, guess_error) = (
        largest_error(&model, &states),
        largest_error(&model, &guess_states),
    );
    let (lay_clear, guess_clear) = (clearance(&states), clearance(&guess_states));
    println!(
        "rail clearance {lay_clear:.4} (guess {guess_clear:.4}), largest error {lay_error:.4} \
         (guess {guess_error:.4})"
    );
    // Measured: clearance 0.043 (the margin δ + tolerance is 0.04), the guess's 0.0003; largest
    // error 0.052, the guess's 0.57.
    assert!(
        lay_clear > 0.02 && guess_clear < 0.005,
        "{lay_clear} {guess_clear}"
    );
    assert!(
        lay_error < 0.15 && guess_error > 0.5,
        "{lay_error} {guess_error}"
    );
}

#[test]
fn no_lay_route_where_the_horizon_is_too_short_for_the_step_limit() {
    // Ten steps of 0.1 m: over the rail and down onto the table is about 1.4 m.
    let scene = rail_scene(10);
    let model = Model::from_scene(&scene).unwrap();
    let guess = initial_controls(&scene, &model).unwrap();
    let states = model.simulate(&guess).unwrap();
    let (routes, _) = carried(&model, &guess, &states);
    assert!(routes.iter().all(|c| c.route != "lay"));
}
