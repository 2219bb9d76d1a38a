//! The table set (`examples/scenes/table/`, planned by `experiments --bin table`): every scene
//! loads and validates, starts from a plain guess (zeros or one constant vector per gripper),
//! rests strictly outside every collider with a gap (a smooth contact model needs every particle
//! outside) and outside its safety margins, and simulates its initial guess. No planning.

use cloth::scene::{ContactModel, ContactSpec, InitialControls};
use cloth::{Model, Scene};
use clothopt::plan::{self, initial_controls, PlanOptions};
use clothopt::result;
use std::path::{Path, PathBuf};

/// The scenes of the set, by file name.
const SET: [&str; 5] = [
    "bar_to_table",
    "drape_box",
    "fold_towel",
    "lay_flat",
    "place_beside",
];

/// The smallest distance at which the rest state may lie from a collider (m): cloths that rest
/// on a table lie a few millimetres above its top.
const GAP: f64 = 1e-3;

fn set_dir() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("examples/scenes/table")
}

#[test]
fn the_set_is_its_five_scene_files() {
    let mut names: Vec<String> = std::fs::read_dir(set_dir())
        .unwrap()
        .map(|e| e.unwrap().path())
        .filter(|p| p.extension().is_some_and(|e| e == "json"))
        .map(|p| p.file_stem().unwrap().to_string_lossy().into_owned())
        .collect();
    names.sort();
    assert_eq!(names, SET);
}

#[test]
fn every_scene_loads_starts_clear_of_the_obstacles_and_simulates_its_guess() {
    for name in SET {
        let scene = Scene::load(set_dir().join(format!("{name}.json")))
            .unwrap_or_else(|e| panic!("{name}: {e}"));
        assert_eq!(scene.name, name);
        assert!(
            !matches!(scene.task.initial_controls, InitialControls::Explicit(_)),
            "{name}: the guess is a hand-made path"
        );
        let rest = scene.rest_positions();
        for (i, obstacle) in scene.obstacles.iter().enumerate() {
            let closest = rest
                .iter()
                .map(|&p| obstacle.signed_distance(p))
                .fold(f64::INFINITY, f64::min);
            if obstacle.role().is_collider() {
                assert!(
                    closest >= GAP,
                    "{name}: obstacles[{i}] is {closest} from the rest state"
                );
            }
            if obstacle.role().is_safety() {
                assert!(
                    closest >= scene.task.delta,
                    "{name}: obstacles[{i}] is {closest} from the rest state, inside δ"
                );
            }
        }
        let model = Model::from_scene(&scene).unwrap_or_else(|e| panic!("{name}: {e}"));
        let guess = initial_controls(&scene, &model).unwrap();
        let states = model
            .simulate(&guess)
            .unwrap_or_else(|e| panic!("{name}: the guess does not simulate: {e}"));
        assert_eq!(states.len(), scene.task.horizon + 1, "{name}");
        assert!(
            states
                .iter()
                .all(|x| x.data().iter().all(|v| v.is_finite())),
            "{name}"
        );
    }
}

/// With smooth contact, `lay_flat` is planned from its plain guess to an achieved, safe plan whose
/// rollout keeps every particle strictly outside the table (the rigid model with Newton's branch
/// following stopped at its time limit after 6 SQP iterations: docs/experiments.md "The table
/// set").
#[test]
fn lay_flat_with_smooth_contact_is_achieved_from_its_plain_guess() {
    let mut scene = Scene::load(set_dir().join("lay_flat.json")).unwrap();
    scene.physics.contact = Some(ContactSpec {
        model: ContactModel::Smooth,
        d_hat: None,
        stiffness: None,
        friction_epsilon: None,
    });
    scene.validate().unwrap();
    let model = Model::from_scene(&scene).unwrap();
    let options = PlanOptions::for_model(&model);
    let start = initial_controls(&scene, &model).unwrap();
    let result = plan::plan(&model, &scene, &start, &options, |_| {}).unwrap();
    assert!(result.task.achieved, "{:?}", result.task);
    assert!(result.is_feasible() && result.is_safe());
    assert!(
        result.task.max_target_error < 0.01,
        "{}",
        result.task.max_target_error
    );
    let u = result::controls_from_nested(&model, &result.controls).unwrap();
    let states = model.simulate(&u).unwrap();
    let table = &scene.obstacles[0];
    assert!(table.role().is_collider());
    let closest = states
        .iter()
        .flat_map(|x| {
            x.data()
                .chunks(3)
                .map(|p| table.signed_distance([p[0], p[1], p[2]]))
        })
        .fold(f64::INFINITY, f64::min);
    assert!(closest > 0.0, "a particle reached the table: {closest}");
}
