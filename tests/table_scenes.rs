//! The table set (`examples/scenes/table/`, planned by `experiments --bin table`): every scene
//! loads and validates, starts from a plain guess (zeros or one constant vector per gripper),
//! rests strictly outside every collider with a gap (a smooth contact model needs every particle
//! outside) and outside its safety margins, and simulates its initial guess. No planning.

use cloth::scene::InitialControls;
use cloth::{Model, Scene};
use clothopt::plan::initial_controls;
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
