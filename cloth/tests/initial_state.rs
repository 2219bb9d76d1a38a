//! `cloth.initial_state`: the cloth at step 0 apart from its rest shape — given positions, an OBJ
//! file, or a recipe — used as given when at rest, settled (and said) when not, refused when it
//! lies inside a collider or passes through itself; gradients from a deformed start.

mod common;

use autodiff::Tensor;
use cloth::scene::{InitialState, SolverKind};
use cloth::{Model, Scene};
use proptest::prelude::*;

/// A 0.3 m, 5 × 5 towel (0.3 kg/m²) lying flat on a box table (top at z = 0.75, friction 0.5),
/// gripped at two corners; `extra` is spliced into `cloth`.
fn towel(extra: &str, solver: &str) -> String {
    format!(
        r#"{{"name": "towel", "cloth": {{"rows": 5, "cols": 5, "top_left": [-0.15, -0.15, 0.75],
            "right": [0.3, 0, 0], "down": [0, 0.3, 0], "particle_mass": 0.00108{extra}}},
          "material": {{"stretch": 1000, "bending": {{"model": "isometric", "stiffness": 0.002}}}},
          "physics": {{"dt": 0.1, "gravity": [0, 0, -9.81]{solver}}},
          "controls": [[4, 0], [4, 4]],
          "obstacles": [{{"type": "box", "center": [0, 0, 0.375], "half_extents": [0.5, 0.5, 0.375],
                          "role": "collider", "friction": 0.5}}],
          "task": {{"horizon": 3, "targets": [{{"particle": [4, 0], "position": [-0.15, -0.1, 0.8]}}],
            "alpha": 0.1, "beta": 0, "initial_controls": "zeros"}}}}"#
    )
}

/// The error of a scene whose model does not compile.
fn refused(scene: &Scene, what: &str) -> String {
    match Model::from_scene(scene) {
        Ok(_) => panic!("the start was accepted: {what}"),
        Err(e) => e.to_string(),
    }
}

fn rows(x: &Tensor) -> Vec<[f64; 3]> {
    x.data()
        .chunks_exact(3)
        .map(|p| [p[0], p[1], p[2]])
        .collect()
}

fn with_positions(positions: &[[f64; 3]]) -> String {
    format!(
        r#", "initial_state": {{"positions": {}}}"#,
        serde_json::to_string(positions).unwrap()
    )
}

/// The towel's far edge (rows 0–1) lifted 6 cm and pulled 3 cm back: not at rest.
fn lifted(rest: &[[f64; 3]]) -> Vec<[f64; 3]> {
    rest.iter()
        .enumerate()
        .map(|(p, &[x, y, z])| {
            if p < 10 {
                [x, y + 0.03, z + 0.06]
            } else {
                [x, y, z + 0.002]
            }
        })
        .collect()
}

#[test]
fn a_start_at_rest_is_used_as_given_and_one_that_is_not_is_settled_and_said() {
    let rest = Scene::from_json_str(&towel("", ""))
        .unwrap()
        .rest_positions();
    // Under the default physics (Newton, smooth contact: the scene has a collider).
    let given = lifted(&rest);
    let scene = Scene::from_json_str(&towel(&with_positions(&given), "")).unwrap();
    assert_eq!(scene.solver_kind(), SolverKind::Newton);
    let model = Model::from_scene(&scene).unwrap();
    let report = model.start_report.clone().unwrap();
    assert_eq!(report.source, "positions");
    assert!(report.settle_steps > 0, "{report:?}");
    // The lifted edge fell back toward the table: it moved by about its 6 cm lift.
    assert!(report.moved.0 > 0.03 && report.moved.1 < 10, "{report:?}");
    let settled = rows(&model.start);
    assert!(settled.iter().all(|p| p[2] > 0.75), "above the table");
    // The settled state, given again, is at rest: used bit for bit, no step taken.
    let again = Scene::from_json_str(&towel(&with_positions(&settled), "")).unwrap();
    let model = Model::from_scene(&again).unwrap();
    let report = model.start_report.clone().unwrap();
    assert_eq!((report.settle_steps, report.lifted), (0, 0), "{report:?}");
    assert_eq!(rows(&model.start), settled);
    let states = model.simulate(&model.zero_controls()).unwrap();
    assert_eq!(rows(&states[0]), settled, "step 0 is the start");
    // Refused when settling is off.
    let text = towel(
        &format!(
            r#", "initial_state": {{"positions": {}, "settle": false}}"#,
            serde_json::to_string(&given).unwrap()
        ),
        "",
    );
    let e = refused(&Scene::from_json_str(&text).unwrap(), "not at rest");
    assert!(
        e.starts_with("cloth.initial_state: not at rest: one step of the scene's physics"),
        "{e}"
    );
}

#[test]
fn an_obj_start_in_the_cloths_vertex_order() {
    let scene = Scene::from_json_str(&towel("", "")).unwrap();
    let rest = scene.rest_positions();
    let settled = {
        let s = Scene::from_json_str(&towel(&with_positions(&lifted(&rest)), "")).unwrap();
        rows(&Model::from_scene(&s).unwrap().start)
    };
    let dir = std::env::temp_dir().join(format!("clothopt-start-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let mut obj: String = settled
        .iter()
        .map(|p| format!("v {:e} {:e} {:e}\n", p[0], p[1], p[2]))
        .collect();
    for t in scene.mesh().triangles() {
        obj += &format!("f {} {} {}\n", t[0] + 1, t[1] + 1, t[2] + 1);
    }
    std::fs::write(dir.join("start.obj"), obj).unwrap();
    let path = dir.join("towel.json");
    std::fs::write(
        &path,
        towel(r#", "initial_state": {"obj": "start.obj"}"#, ""),
    )
    .unwrap();
    let loaded = Scene::load(&path).unwrap();
    let model = Model::from_scene(&loaded).unwrap();
    assert_eq!(model.start_report.as_ref().unwrap().source, "obj");
    assert_eq!(rows(&model.start), settled);
    // An OBJ with another vertex count names the file and both counts.
    std::fs::write(
        dir.join("short.obj"),
        "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n",
    )
    .unwrap();
    std::fs::write(
        &path,
        towel(r#", "initial_state": {"obj": "short.obj"}"#, ""),
    )
    .unwrap();
    let e = Scene::load(&path).unwrap_err().to_string();
    assert_eq!(
        e,
        "cloth.initial_state.obj: `short.obj` has 3 vertices, the cloth has 25 particles"
    );
    std::fs::remove_dir_all(&dir).unwrap();
}

#[test]
fn a_start_inside_a_collider_or_through_itself_is_a_named_error() {
    let rest = Scene::from_json_str(&towel("", ""))
        .unwrap()
        .rest_positions();
    // Particle (2, 2) 1 cm inside the table.
    let mut inside = rest.clone();
    inside[12][2] -= 0.01;
    let scene = Scene::from_json_str(&towel(&with_positions(&inside), "")).unwrap();
    let e = refused(&scene, "inside");
    assert_eq!(
        e,
        "cloth.initial_state: particle (2, 2) starts 1.0000e-2 inside obstacles[0] (box), a \
         collider (positions)"
    );
    // Rows 2–4 flat 5 cm up; row 1 above and before them, row 0 folded back under them: the
    // strip between rows 0 and 1 passes down through rows 2–4.
    let mut through = rest.clone();
    for (p, q) in through.iter_mut().enumerate() {
        let (row, [x, y, _]) = (p / 5, rest[p]);
        *q = match row {
            0 => [x, 0.10, 0.76],
            1 => [x, y, 0.85],
            _ => [x, y, 0.80],
        };
    }
    let scene = Scene::from_json_str(&towel(&with_positions(&through), "")).unwrap();
    let e = refused(&scene, "through itself");
    assert!(
        e.starts_with("cloth.initial_state: the cloth passes through itself (positions): edge"),
        "{e}"
    );
    // Shapes and numbers are named by field.
    let e = Scene::from_json_str(&towel(&with_positions(&rest[..24]), ""))
        .unwrap_err()
        .to_string();
    assert_eq!(
        e,
        "cloth.initial_state.positions: 24 positions are given, the cloth has 25 particles"
    );
    let mut far = rest.clone();
    far[3][1] = 1e10;
    let e = Scene::from_json_str(&towel(&with_positions(&far), ""))
        .unwrap_err()
        .to_string();
    assert!(
        e.starts_with("cloth.initial_state.positions[3][1]: magnitude 1e10 exceeds the limit"),
        "{e}"
    );
    let both = r#", "initial_state": {"obj": "a.obj", "positions": []}"#;
    let e = Scene::from_json_str(&towel(both, ""))
        .unwrap_err()
        .to_string();
    assert_eq!(
        e,
        "cloth.initial_state: give exactly one of `obj`, `positions` and `recipe`"
    );
    // Nothing holds a cloth in the air without grippers: it cannot rest.
    let mut air = Scene::from_json_str(&towel("", "")).unwrap();
    air.controls.clear();
    air.obstacles.clear();
    air.cloth.initial_state = Some(InitialState {
        positions: Some(rest.clone()),
        obj: None,
        recipe: None,
        settle: true,
        settle_steps: Some(5),
        obj_data: None,
    });
    let e = refused(&air, "in the air");
    assert!(
        e.starts_with("cloth.initial_state: it cannot rest where it is: after 5 settling steps"),
        "{e}"
    );
}

/// `n` steps lifting a corner over an arc of radius `r` and laying it down `(dx, dy)` away.
fn arc(n: usize, r: f64, (dx, dy): (f64, f64)) -> Vec<Vec<[f64; 3]>> {
    let pi = std::f64::consts::PI;
    (0..n)
        .map(|t| {
            let (a0, a1) = (pi * t as f64 / n as f64, pi * (t + 1) as f64 / n as f64);
            let s = (a0.cos() - a1.cos()) / 2.0;
            vec![[dx * s, dy * s, r * (a1.sin() - a0.sin()) + 0.002]]
        })
        .collect()
}

#[test]
fn a_recipe_folds_the_towel_in_two_phases() {
    // Without bending (a folded towel rests only where nothing unfolds it: the model has no
    // cloth–cloth friction): corner (0, 4) laid most of the way onto (4, 0), let go; then picked
    // up again and laid the rest of the way.
    let phase = |corner: [usize; 2], moves: Vec<Vec<[f64; 3]>>| {
        format!(
            r#"{{"hold": [{corner:?}], "steps": {}, "moves": {{"explicit": {}}}}}"#,
            moves.len(),
            serde_json::to_string(&moves).unwrap()
        )
    };
    let recipe = format!(
        r#", "initial_state": {{"recipe": [{}, {}]}}"#,
        phase([0, 4], arc(8, 0.2, (-0.22, 0.22))),
        phase([0, 4], arc(4, 0.02, (-0.07, 0.07)))
    );
    let mut scene = Scene::from_json_str(&towel(
        &recipe,
        r#", "self_collision": {"thickness": 0.005}"#,
    ))
    .unwrap();
    scene.material.bending = None;
    let model = Model::from_scene(&scene).unwrap();
    let report = model.start_report.clone().unwrap();
    assert_eq!(report.source, "recipe");
    assert!(report.recipe_steps > 12, "{report:?}");
    let x = rows(&model.start);
    // On the table, not through it, folded along its diagonal: it covers about half its area.
    assert!(x.iter().all(|p| p[2] > 0.75), "above the table");
    assert!(cloth::intersections(scene.mesh().triangles(), &model.start).is_empty());
    let coverage = model.coverage(&model.start).unwrap();
    assert!((coverage - 0.5).abs() < 0.05, "coverage {coverage}");
    // At rest: a step with the grippers held moves nothing by more than the tolerance.
    let states = model.simulate(&model.zero_controls()).unwrap();
    let moved = (0..25)
        .map(|p| {
            (0..3)
                .map(|k| (states[1].get(p, k) - x[p][k]).powi(2))
                .sum::<f64>()
                .sqrt()
        })
        .fold(0.0, f64::max);
    assert!(moved <= cloth::REST_TOLERANCE * 0.3, "{moved}");
}

proptest! {
    #![proptest_config(ProptestConfig { cases: 6, ..ProptestConfig::default() })]

    /// Gradients from a deformed start (the towel's edge lifted, settled) against central
    /// differences, under XPBD and Newton.
    #[test]
    fn gradients_from_a_deformed_start_match_central_differences(
        newton in any::<bool>(),
        seed in 1u64..1000,
        values in prop::collection::vec(-0.03f64..0.03, 18),
    ) {
        let rest = Scene::from_json_str(&towel("", "")).unwrap().rest_positions();
        let solver = if newton { "" } else { r#", "solver": "xpbd", "iterations": 20"# };
        let text = towel(&with_positions(&lifted(&rest)), solver);
        let scene = Scene::from_json_str(&text).unwrap();
        let mut model = Model::from_scene(&scene).unwrap();
        if newton {
            model.solver = cloth::Solver::Newton(cloth::NewtonSettings {
                tolerance: 1e-13,
                ..cloth::NewtonSettings::default()
            });
        }
        prop_assert!(model.start_report.as_ref().unwrap().settle_steps > 0);
        let u = common::controls_from(&model, &values);
        common::check_gradients_along_a_direction(&model, &u, seed, 0.0, 1e-5)?;
    }
}
