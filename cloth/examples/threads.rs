//! Forward + ∇L (`Model::evaluate_loss_gradient`) of `u_obstacle` refined to `n × n` (T = 10,
//! 100 iterations) on pools of the given thread counts, alternated round by round so both see
//! the same machine load; prints each run and, per thread count, the median and the minimum.
//!
//! `cargo run --release -p cloth --example threads -- [n] [rounds] [threads,…] [--forward]
//! [--seeds K]`, by default `100 3 1,2`; `--forward` times the forward pass alone
//! (`Model::simulate`) instead; `--seeds K` times `Model::gradients` of `K` costs at once from a
//! simulated rollout (the planner's multi-seed pull-back; each cost is the loss), after the
//! forward. With one round and one thread count it doubles as a peak-memory probe
//! (`/usr/bin/time -f %M`).

use cloth::{Model, Scene};
use std::time::Instant;

/// What each round times.
#[derive(Clone, Copy)]
enum Timed {
    /// `Model::evaluate_loss_gradient`.
    ForwardAndGradient,
    /// `Model::simulate`.
    Forward,
    /// `Model::gradients` of this many costs from a simulated rollout.
    Seeds(usize),
}

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let mut args: Vec<String> = std::env::args().skip(1).collect();
    let mut timed = Timed::ForwardAndGradient;
    if let Some(i) = args.iter().position(|a| a == "--forward") {
        args.remove(i);
        timed = Timed::Forward;
    }
    if let Some(i) = args.iter().position(|a| a == "--seeds") {
        if matches!(timed, Timed::Forward) {
            return Err("--forward and --seeds exclude each other".into());
        }
        let k = args.get(i + 1).ok_or("--seeds needs a count")?.parse()?;
        args.drain(i..i + 2);
        timed = Timed::Seeds(k);
    }
    let n: usize = args.first().map_or(Ok(100), |a| a.parse())?;
    let rounds: usize = args.get(1).map_or(Ok(3), |a| a.parse())?;
    let threads: Vec<usize> = match args.get(2) {
        Some(list) => list.split(',').map(str::parse).collect::<Result<_, _>>()?,
        None => vec![1, 2],
    };
    let mut scene = Scene::builtin("u_obstacle")?.refined(n, n)?;
    scene.physics.iterations = 100;
    let model = Model::from_scene(&scene)?;
    let (u, delta) = (scene.initial_controls(), scene.task.delta);
    let beta = model.task.beta;
    let loss = |tape: &mut autodiff::Tape, t: usize, _: autodiff::Var, x: autodiff::Var| {
        model.record_loss(tape, t, x, beta)
    };
    let pools = threads
        .iter()
        .map(|&t| rayon::ThreadPoolBuilder::new().num_threads(t).build())
        .collect::<Result<Vec<_>, _>>()?;
    let mut times = vec![Vec::new(); threads.len()];
    for round in 0..rounds {
        for ((pool, &t), times) in pools.iter().zip(&threads).zip(&mut times) {
            // The rollout the seeds are pulled back through, simulated before the clock starts.
            let states = match timed {
                Timed::Seeds(_) => Some(pool.install(|| model.simulate(&u))?),
                _ => None,
            };
            let start = Instant::now();
            match (timed, &states) {
                (Timed::Seeds(k), Some(states)) => {
                    let costs: Vec<cloth::StepCost<'_>> = vec![&loss; k];
                    pool.install(|| model.gradients(states, &u, &costs));
                }
                (Timed::Forward, _) => drop(pool.install(|| model.simulate(&u))?),
                _ => drop(pool.install(|| model.evaluate_loss_gradient(&u, delta))?),
            }
            let s = start.elapsed().as_secs_f64();
            println!("n = {n}, round {round}, {t} thread(s): {s:.3} s");
            times.push(s);
        }
    }
    for (t, times) in threads.iter().zip(&mut times) {
        times.sort_by(f64::total_cmp);
        let (median, min) = (times[times.len() / 2], times[0]);
        println!("{t} thread(s): median {median:.3} s, min {min:.3} s");
    }
    Ok(())
}
