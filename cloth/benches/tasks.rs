//! Contact rollouts where users meet them: the task suite's `fold_half` (15 × 15 towel on a table
//! with friction, self-contact, T = 14) and `lay_aside` (11 × 11 towel laid on a table, T = 12),
//! under the physics they call for (Newton, smooth contact), at controls a 120 s plan of the
//! suite returned (`benches/data/`): `lay_aside` at their mid-point (half of them, neither the
//! trivial guess nor the plan), `fold_half` at the plan itself, since at its mid-point (and at
//! 0.4, 0.6 and 0.75 of it) Newton does not converge at step 14 (docs/performance.md, "Contact
//! rollouts of the task suite"):
//! - `forward`: simulate and evaluate the metrics (`Model::evaluate`);
//! - `forward_grad_l`: the same plus `dL/dU` by implicit differentiation.
//!
//! How the cost grows with the particle count: `lay_aside@15` and `lay_aside@40` are the same
//! task and controls on a 15 × 15 and a 40 × 40 towel (`Scene::refined`, the particle mass scaled
//! so the towel weighs the same).
//!
//! Before the timings it prints each rollout's counts (Newton iterations, chord steps,
//! factorizations and failed ones, control stages, self-contact pair searches and filters,
//! step filters, pattern rebuilds), which do not depend on the machine's load.
//!
//! `RAYON_NUM_THREADS=1 cargo bench -p cloth --bench tasks`. With `TASKS_ONCE=<scene>` the bench
//! runs that scene's forward + ∇L once, prints its wall and the process's peak resident memory,
//! and exits (for `perf record` / callgrind, and the memory of one rollout with its gradient).
//! `TASKS_PREDICTOR=off` runs every scene without the Newton predictor (`physics.predictor`), the
//! solver as it was before it, for a comparison in the same run. `TASKS_FRICTION_EPSILON=<m>` sets
//! every scene's `physics.contact.friction_epsilon` (the smoothing slip of its friction), for the
//! cost of friction's accuracy in the same run (docs/performance.md).

use autodiff::Tensor;
use cloth::scene::{ContactModel, ContactSpec};
use cloth::{Model, Scene, Solver, StepStats};
use criterion::{criterion_group, BenchmarkId, Criterion};
use std::hint::black_box;
use std::path::PathBuf;

/// The bench's scenes (`name` or `name@n`, refined to `n × n`), each with its controls file.
const TASKS: [(&str, &str); 4] = [
    ("fold_half", "plan"),
    ("lay_aside", "mid"),
    ("lay_aside@15", "mid"),
    ("lay_aside@40", "mid"),
];

fn root() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("..")
}

/// The scene and its controls (`benches/data/<name>_<which>.json`), refined for `name@n`.
fn task(task: &str) -> (Scene, Model, Tensor) {
    let which = TASKS
        .iter()
        .find(|(n, _)| *n == task)
        .map_or("mid", |t| t.1);
    let (name, size) = match task.split_once('@') {
        Some((name, n)) => (name, Some(n.parse::<usize>().expect("name@n"))),
        None => (task, None),
    };
    let mut scene = Scene::load(root().join(format!("examples/scenes/tasks/{name}.json")))
        .expect("the task scene");
    if std::env::var("TASKS_PREDICTOR").as_deref() == Ok("off") {
        scene.physics.predictor = Some(false);
    }
    if let Ok(eps) = std::env::var("TASKS_FRICTION_EPSILON") {
        let contact = scene.physics.contact.get_or_insert(ContactSpec {
            model: ContactModel::Smooth,
            d_hat: None,
            stiffness: None,
            friction_epsilon: None,
        });
        contact.friction_epsilon = Some(eps.parse().expect("TASKS_FRICTION_EPSILON in metres"));
    }
    if let Some(n) = size {
        let before = (scene.cloth.rows * scene.cloth.cols) as f64;
        scene = scene.refined(n, n).expect("a grid scene");
        scene.cloth.particle_mass *= before / (n * n) as f64;
    }
    let model = Model::from_scene(&scene).expect("its model");
    let path = root().join(format!("cloth/benches/data/{name}_{which}.json"));
    let text = std::fs::read_to_string(&path).expect("the controls");
    let value: serde_json::Value = serde_json::from_str(&text).expect("JSON");
    let steps: Vec<Vec<[f64; 3]>> =
        serde_json::from_value(value["controls"].clone()).expect("controls[t][k] = [x, y, z]");
    let u = cloth::controls_from_steps(&steps).expect("as many vectors at every step");
    model
        .check_controls(&u)
        .expect("controls of the scene's shape");
    (scene, model, u)
}

/// One rollout's counts, summed over its steps.
fn counts(model: &Model, u: &Tensor) -> StepStats {
    let Solver::Newton(settings) = &model.solver else {
        panic!("the task scenes run Newton")
    };
    let (_, stats) = model.simulate_newton(u, settings).expect("converged");
    stats.iter().fold(StepStats::default(), |mut sum, s| {
        sum.add_work(s);
        sum.loads += s.loads;
        sum
    })
}

fn tasks(c: &mut Criterion) {
    let mut group = c.benchmark_group("tasks");
    group.sample_size(10);
    for (name, _) in TASKS {
        let (scene, model, u) = task(name);
        print_counts(name, &model, &u);
        let delta = scene.task.delta;
        group.bench_with_input(BenchmarkId::new("forward", name), &name, |b, _| {
            b.iter(|| black_box(model.evaluate(&u, delta, false).expect("converged")))
        });
        group.bench_with_input(BenchmarkId::new("forward_grad_l", name), &name, |b, _| {
            b.iter(|| black_box(model.evaluate_loss_gradient(&u, delta).expect("converged")))
        });
    }
    group.finish();
}

/// Prints one rollout's counts (they do not depend on the machine's load).
fn print_counts(name: &str, model: &Model, u: &Tensor) {
    let s = counts(model, u);
    eprintln!(
        "{name}: {} Newton iterations ({} chord), {} factorizations ({} failed), {} loads, \
             pair searches {} (grid {}), filtered {}, step filters {}, pattern rebuilds {} \
             (reused {})",
        s.iterations,
        s.chord_steps,
        s.factorizations,
        s.failed_factorizations,
        s.loads,
        s.pair_searches,
        s.grid_searches,
        s.pair_filters,
        s.step_filters,
        s.pattern_rebuilds,
        s.pattern_reuses
    );
}

/// The process's peak resident memory (`VmHWM` in `/proc/self/status`; Linux).
fn peak_memory() -> String {
    std::fs::read_to_string("/proc/self/status")
        .ok()
        .and_then(|s| {
            s.lines()
                .find(|l| l.starts_with("VmHWM:"))
                .map(|l| l["VmHWM:".len()..].trim().to_string())
        })
        .unwrap_or_else(|| "unknown".into())
}

criterion_group!(benches, tasks);

fn main() {
    if let Ok(name) = std::env::var("TASKS_ONCE") {
        let (scene, model, u) = task(&name);
        print_counts(&name, &model, &u);
        let start = std::time::Instant::now();
        black_box(
            model
                .evaluate_loss_gradient(&u, scene.task.delta)
                .expect("converged"),
        );
        eprintln!(
            "{name}: {} particles, forward + ∇L {:.3} s, peak resident memory {}",
            model.n_particles(),
            start.elapsed().as_secs_f64(),
            peak_memory()
        );
        return;
    }
    benches();
    Criterion::default().configure_from_args().final_summary();
}
