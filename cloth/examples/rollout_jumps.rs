//! Where a rollout jumps or fails: `L` along a line of controls, sampled, and each jump bisected
//! down to two controls 1e-15 of the line apart, with the step where their rollouts part. A plan
//! whose line searches creep (steps of 1e-6 accepted, larger ones rejected by far) usually has,
//! within its step, such a jump (a discrete choice of the solver that a control move flips: a
//! start, a stage, the minimum a Newton path ends in) or a rollout that fails (its first error is
//! printed).
//! `cargo run --release -p cloth --example rollout_jumps -- --scene FILE.json --controls PLAN.json
//! [--length 1e-3] [--samples 64] [--jumps 3] [--dump PREFIX] [--print]`
//! The line runs from the plan's controls (a result's or a `{"controls": …}` file) along `−∇L`,
//! scaled to `--length` metres in its largest coordinate. A sample interval is a jump when its
//! change of `L` exceeds 20 times the change the gradient predicts over it; `--dump` writes each bisected jump's two
//! controls to `PREFIX<k>a.json` and `PREFIX<k>b.json` (for `newton_counts --controls`); `--print`
//! prints every sample.
use autodiff::Tensor;
use cloth::{Controls, ControlsView, Model, Scene};

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let args: Vec<String> = std::env::args().collect();
    let value = |f: &str| {
        args.iter()
            .position(|a| a == f)
            .and_then(|i| args.get(i + 1).cloned())
    };
    let scene = Scene::load(value("--scene").ok_or("--scene FILE.json is required")?)?;
    let length: f64 = value("--length").map_or(Ok(1e-3), |v| v.parse())?;
    let samples: usize = value("--samples").map_or(Ok(64), |v| v.parse())?;
    let most: usize = value("--jumps").map_or(Ok(3), |v| v.parse())?;
    let model = Model::from_scene(&scene)?;
    let u = match value("--controls") {
        Some(path) => cloth::controls_from_file(path.as_ref())?,
        None => scene.initial_controls(),
    };
    let delta = scene.task.delta;
    let at_start = model.evaluate_loss_gradient(&u, delta)?;
    let g = at_start.grad_l.ok_or("no gradient")?;
    let scale = g.data().iter().fold(0.0_f64, |m, v| m.max(v.abs()));
    let direction: Vec<f64> = g.data().iter().map(|v| -length * v / scale).collect();
    let along = |t: f64| -> Controls {
        let data = u.data().iter().zip(&direction).map(|(a, d)| a + t * d);
        Tensor::new(u.rows(), u.cols(), data.collect())
    };
    let failures = std::cell::Cell::new(0);
    let loss = |t: f64| -> Option<(f64, Vec<Tensor>)> {
        let u = along(t);
        match model.simulate(&u) {
            Ok(states) => Some((model.metrics(&states, &u, delta).l, states)),
            Err(e) => {
                if failures.replace(failures.get() + 1) == 0 {
                    println!("the rollout at t {t:.15} fails: {e}");
                }
                None
            }
        }
    };
    println!(
        "L {:.10} at the plan; |∇L|∞ {scale:.3e}; the line is {length:.1e} m long",
        at_start.metrics.l
    );
    let ts: Vec<f64> = (0..=samples).map(|k| k as f64 / samples as f64).collect();
    let ls: Vec<Option<f64>> = ts.iter().map(|&t| loss(t).map(|(l, _)| l)).collect();
    if args.iter().any(|a| a == "--print") {
        for (t, l) in ts.iter().zip(&ls) {
            println!("t {t:.6} L {l:?}");
        }
    }
    let changes: Vec<(usize, f64)> = (0..samples)
        .filter_map(|k| Some((k, (ls[k + 1]? - ls[k]?).abs())))
        .collect();
    // The change the gradient predicts over one sample interval: a jump changes L by far more.
    let slope: f64 = g.data().iter().zip(&direction).map(|(a, b)| a * b).sum();
    let expected = slope.abs() / samples as f64;
    let mut jumps: Vec<(usize, f64)> = changes
        .into_iter()
        .filter(|&(_, c)| c > 20.0 * expected)
        .collect();
    jumps.sort_by(|a, b| b.1.total_cmp(&a.1));
    println!(
        "{} samples ({} failed); the gradient predicts |ΔL| {expected:.3e} an interval; {} of {samples} \
         intervals change L by more than 20 times that",
        samples + 1,
        failures.get(),
        jumps.len()
    );
    for &(k, change) in jumps.iter().take(most) {
        let (mut lo, mut hi) = (ts[k], ts[k + 1]);
        let (Some(mut la), Some(mut lb)) = (ls[k], ls[k + 1]) else {
            continue;
        };
        while hi - lo > 1e-15 {
            let mid = 0.5 * (lo + hi);
            let Some((m, _)) = loss(mid) else {
                println!("jump at t {mid:.15}: the rollout fails");
                break;
            };
            if (m - la).abs() > (lb - m).abs() {
                (hi, lb) = (mid, m);
            } else {
                (lo, la) = (mid, m);
            }
        }
        let (Some((_, sa)), Some((_, sb))) = (loss(lo), loss(hi)) else {
            continue;
        };
        if let Some(prefix) = value("--dump") {
            for (side, t) in [("a", lo), ("b", hi)] {
                let steps = along(t).to_nested();
                let path = format!("{prefix}{k}{side}.json");
                std::fs::write(&path, serde_json::json!({ "controls": steps }).to_string())?;
            }
        }
        let parted = sa.iter().zip(&sb).position(|(a, b)| {
            a.data()
                .iter()
                .zip(b.data())
                .any(|(p, q)| (p - q).abs() > 1e-6)
        });
        println!(
            "jump of {change:.3e} at t {lo:.15} ({:.3e} m): L {la:.10} | {lb:.10}; the rollouts part \
             by more than 1e-6 m at step {}",
            lo * length,
            parted.map_or("none".to_string(), |s| s.to_string())
        );
    }
    Ok(())
}
