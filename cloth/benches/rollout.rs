//! Whole rollouts of `u_obstacle` (T = 10, 100 Gauss–Seidel iterations per step) at mesh sizes
//! n = 10, 20, 40, from the scene's initial guess:
//! - `forward`: simulate and evaluate the metrics (`Model::evaluate(.., false)`);
//! - `forward_grad_l`: the same plus `dL/dU` (`Model::evaluate_loss_gradient`, one backward pass —
//!   the "forward + ∇L");
//! - `forward_grad_l_c`: plus `dC/dU` too (`Model::evaluate(.., true)`, the two pulled back together);
//! - `forward_grad_l_rerecord` (only where the whole rollout's recording fits the checkpoint
//!   budget, so `forward_grad_l` records during the first forward): `forward_grad_l` with the
//!   budget lowered to two whole steps, so each step is re-recorded in the backward pass — the
//!   price of the re-recording, measured in the same run. The bench prints which sizes record
//!   during the first forward.
//!
//! Single thread, as the targets are stated: `RAYON_NUM_THREADS=1 cargo bench -p cloth --bench rollout`.

use autodiff::{Tape, Tensor, Var};
use cloth::StepCost;
use cloth::{Model, Scene};
use criterion::{criterion_group, criterion_main, BenchmarkId, Criterion};
use std::hint::black_box;

fn setup(n: usize) -> (Model, Tensor, f64) {
    let base = Scene::builtin("u_obstacle").expect("built-in scene");
    let scene = base.refined(n, n).expect("refined scene");
    let model = Model::from_scene(&scene).expect("model");
    (model, scene.initial_controls(), scene.task.delta)
}

fn rollout(c: &mut Criterion) {
    let mut group = c.benchmark_group("u_obstacle");
    group.sample_size(10);
    for n in [10, 20, 40] {
        let (model, u, delta) = setup(n);
        group.bench_with_input(BenchmarkId::new("forward", n), &n, |b, _| {
            b.iter(|| black_box(model.evaluate(&u, delta, false).expect("finite")))
        });
        group.bench_with_input(BenchmarkId::new("forward_grad_l", n), &n, |b, _| {
            b.iter(|| black_box(model.evaluate_loss_gradient(&u, delta).expect("finite")))
        });
        group.bench_with_input(BenchmarkId::new("forward_grad_l_c", n), &n, |b, _| {
            b.iter(|| black_box(model.evaluate(&u, delta, true).expect("finite")))
        });
        let beta = model.task.beta;
        let loss = |tape: &mut Tape, t: usize, _: Var, x: Var| model.record_loss(tape, t, x, beta);
        let costs: [StepCost<'_>; 1] = [&loss];
        let recorded = model.simulate_recording(&u, &costs).expect("finite");
        eprintln!(
            "n = {n}: first-forward recording {}",
            match recorded.recorded_bytes() {
                Some(b) => format!("used ({:.1} MB)", b as f64 / 1e6),
                None => "not used (over the checkpoint budget)".into(),
            }
        );
        if recorded.recorded_bytes().is_some() {
            let mut rerecord = model.clone();
            rerecord.checkpoint_budget =
                2 * model.iterations * model.recorded_bytes_per_iteration() + (1 << 20);
            group.bench_with_input(
                BenchmarkId::new("forward_grad_l_rerecord", n),
                &n,
                |b, _| {
                    b.iter(|| {
                        black_box(rerecord.evaluate_loss_gradient(&u, delta).expect("finite"))
                    })
                },
            );
        }
    }
    group.finish();
}

criterion_group!(benches, rollout);
criterion_main!(benches);
