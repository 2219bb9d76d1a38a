//! Whether a task's targets are a state the cloth can rest in: the cloth put at its targets
//! (every particle must have one), its grippers held there, simulated under the scene's physics
//! with zero moves; prints the largest target error and the targets within the tolerance at
//! each step. A task whose targets settle beyond its tolerance asks for a state the grippers
//! cannot hold: a plan can only end at another equilibrium.
//! `cargo run --release -p cloth --example settle_targets -- --scene FILE.json [--steps 20]
//! [--lift 0.002] [--spread 2] [--offset dx,dy,dz] [--out STATES.json]`
//! The targets are raised off the colliders by `--lift` metres, and their heights above the
//! lowest spread by `--spread`, so that layers a target set puts at the self-contact thickness
//! start apart; `--offset` moves every gripper from its target.
use cloth::{Model, Scene};

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let args: Vec<String> = std::env::args().collect();
    let value = |f: &str| {
        args.iter()
            .position(|a| a == f)
            .and_then(|i| args.get(i + 1).cloned())
    };
    let mut scene = Scene::load(value("--scene").ok_or("--scene FILE.json is required")?)?;
    let steps: usize = value("--steps").map_or(Ok(20), |v| v.parse())?;
    let lift: f64 = value("--lift").map_or(Ok(0.002), |v| v.parse())?;
    let spread: f64 = value("--spread").map_or(Ok(2.0), |v| v.parse())?;
    let offset: Vec<f64> = match value("--offset") {
        Some(v) => v.split(',').map(str::parse).collect::<Result<_, _>>()?,
        None => vec![0.0; 3],
    };
    if offset.len() != 3 {
        return Err("--offset takes dx,dy,dz".into());
    }
    scene.cloth.initial_state = None;
    scene.task.horizon = steps;
    scene.task.initial_controls = cloth::scene::InitialControls::Zeros;
    let mut model = Model::from_scene(&scene)?;
    let (targets, at) = (
        model.task.targets.clone(),
        model.task.target_positions.clone(),
    );
    let n = model.n_particles();
    if targets.as_slice().len() != n {
        return Err(format!(
            "{} targets for {n} particles: every particle needs one",
            targets.as_slice().len()
        )
        .into());
    }
    let lowest = (0..n).map(|i| at.get(i, 2)).fold(f64::INFINITY, f64::min);
    for (i, &p) in targets.as_slice().iter().enumerate() {
        let z = lowest + lift + spread * (at.get(i, 2) - lowest);
        let held = model.controls.as_slice().contains(&p);
        for (k, v) in [at.get(i, 0), at.get(i, 1), z].into_iter().enumerate() {
            model.start.data_mut()[3 * p + k] = v + if held { offset[k] } else { 0.0 };
        }
    }
    let states = model.simulate(&scene.initial_controls())?;
    let tolerance = model.task.tolerance;
    println!("step  largest error  within {tolerance}");
    for (t, x) in states.iter().enumerate() {
        let errors: Vec<f64> = (targets.as_slice().iter().enumerate())
            .map(|(i, &p)| {
                let d: f64 = (0..3).map(|k| (x.get(p, k) - at.get(i, k)).powi(2)).sum();
                d.sqrt()
            })
            .collect();
        let largest = errors.iter().fold(0.0_f64, |m, &e| m.max(e));
        let within = errors.iter().filter(|&&e| e <= tolerance).count();
        println!("{t:>4}  {largest:>13.4}  {within} / {n}");
    }
    if let Some(path) = value("--out") {
        let rows: Vec<Vec<[f64; 3]>> = (states.iter())
            .map(|x| x.data().chunks(3).map(|c| [c[0], c[1], c[2]]).collect())
            .collect();
        std::fs::write(
            path,
            serde_json::to_string(&serde_json::json!({ "states": rows }))?,
        )?;
    }
    Ok(())
}
