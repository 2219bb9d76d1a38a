//! Where Newton's time goes: forward + ∇L on a built-in scene (u_obstacle unless `--scene NAME`,
//! or a scene file `--scene FILE.json`)
//! refined to n × n (0 keeps the scene's grid), per-step iteration and factorization counts, then
//! `reps` timings interleaved with XPBD at the scene's iterations.
//! `RAYON_NUM_THREADS=1 cargo run --release -p cloth --example newton_counts -- 40 3 [flags]`
//! Prints the saddle searches (Lanczos runs) beside the escapes.
//! Flags: `--no-chord` (no chord steps), `--halvings H` (`physics.load_halvings`), `--budget MIB`
//! (`Model::checkpoint_budget`), `--ref` (∇L error against tolerance 1e-12), `--newton-only`
//! (time Newton alone, for `perf record`), `--pcg` (conjugate gradients preconditioned with a
//! reused factorization, default tolerance and iterations; `--pcg TOL,MAX` to choose them),
//! `--direct` (a factorization per Newton matrix), `--controls FILE` (a plan's JSON `controls`
//! instead of the scene's initial guess).
use cloth::scene::SolverKind;
use cloth::StepStats;
use cloth::{LinearSolver, Solver};
use cloth::{Model, Scene};
use std::time::Instant;

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let args: Vec<String> = std::env::args().collect();
    let n: usize = args.get(1).map_or(40, |a| a.parse().unwrap());
    let reps: usize = args.get(2).map_or(3, |a| a.parse().unwrap());
    let flag = |f: &str| args.iter().any(|a| a == f);
    let value = |f: &str| {
        args.iter()
            .position(|a| a == f)
            .map(|i| args[i + 1].clone())
    };
    let scene_name = value("--scene").unwrap_or("u_obstacle".into());
    let base = if scene_name.ends_with(".json") {
        Scene::load(&scene_name)?
    } else {
        Scene::builtin(&scene_name)?
    };
    let base = if n > 0 { base.refined(n, n)? } else { base };
    let mut ns = base.clone();
    ns.physics.solver = Some(SolverKind::Newton);
    let t = Instant::now();
    let mut newton = Model::from_scene(&ns)?;
    println!("model {:.3} s", t.elapsed().as_secs_f64());
    let Solver::Newton(mut settings) = newton.solver else {
        unreachable!()
    };
    if flag("--no-chord") {
        settings.chord_steps = false;
    }
    if flag("--direct") {
        settings.linear_solver = LinearSolver::Direct;
    }
    if let Some(i) = args.iter().position(|a| a == "--pcg") {
        settings.linear_solver = match args.get(i + 1).and_then(|a| a.split_once(',')) {
            Some((tol, max)) => LinearSolver::Pcg {
                tolerance: tol.parse()?,
                max_iterations: max.parse()?,
            },
            None => LinearSolver::PCG,
        };
    }
    if let Some(h) = value("--halvings") {
        settings.load_halvings = h.parse()?;
    }
    newton.solver = Solver::Newton(settings);
    if let Some(b) = value("--budget") {
        newton.checkpoint_budget = b.parse::<usize>()? << 20;
    }
    let xpbd = Model::from_scene(&base)?;
    let u = match value("--controls") {
        Some(path) => cloth::controls_from_file(path.as_ref())?,
        None => base.initial_controls(),
    };
    let delta = base.task.delta;
    let t = Instant::now();
    let r = newton.simulate_newton_keeping(&u, &settings, newton.checkpoint_budget)?;
    let tf = t.elapsed().as_secs_f64();
    let it: Vec<usize> = r.stats.iter().map(|s| s.iterations).collect();
    println!("iterations {:?} total {}", it, it.iter().sum::<usize>());
    let f: Vec<usize> = r.stats.iter().map(|s| s.factorizations).collect();
    println!("factorizations {:?} total {}", f, f.iter().sum::<usize>());
    let tot = r.stats.iter().fold(StepStats::default(), sum);
    println!(
        "{:?}: pcg solves {} iterations {} fallbacks {}",
        settings.linear_solver, tot.pcg_solves, tot.pcg_iterations, tot.pcg_fallbacks
    );
    println!(
        "chord {} failed {} projected {} loads {} rejected {} escapes {} saddle {} searches {}; kept {} steps {:.1} MB; forward {:.3} s",
        tot.chord_steps, tot.failed_factorizations, tot.projected, tot.loads, tot.rejected_loads,
        tot.escapes, tot.at_saddle, r.kept.saddle_searches(), r.kept.steps(), r.kept.bytes() as f64 / 1e6, tf
    );
    println!(
        "self-contact: pattern rebuilds {} reuses {}, pair searches {} filters {}, grid searches {}, step filters {}",
        tot.pattern_rebuilds, tot.pattern_reuses, tot.pair_searches, tot.pair_filters, tot.grid_searches, tot.step_filters
    );
    let t = Instant::now();
    let ev = newton.evaluate_loss_gradient(&u, delta)?;
    println!("forward + gradient {:.3} s", t.elapsed().as_secs_f64());
    let g = ev.grad_l.unwrap();
    println!("L {:.12} |gL| {:.12e}", ev.metrics.l, norm(g.data()));
    if flag("--ref") {
        let mut reference = newton.clone();
        reference.solver = Solver::Newton(cloth::NewtonSettings {
            tolerance: 1e-12,
            ..settings
        });
        let er = reference.evaluate_loss_gradient(&u, delta)?;
        let gr = er.grad_l.unwrap();
        let d: Vec<f64> = g.data().iter().zip(gr.data()).map(|(a, b)| a - b).collect();
        println!(
            "reference L {:.12} rel grad err {:.3e}",
            er.metrics.l,
            norm(&d) / norm(gr.data())
        );
    }
    if flag("--newton-only") {
        for _ in 0..reps {
            std::hint::black_box(newton.evaluate_loss_gradient(&u, delta)?);
        }
        return Ok(());
    }
    for _ in 0..reps {
        let t = Instant::now();
        std::hint::black_box(xpbd.evaluate_loss_gradient(&u, delta)?);
        let tx = t.elapsed().as_secs_f64();
        let t = Instant::now();
        std::hint::black_box(newton.evaluate_loss_gradient(&u, delta)?);
        let tn = t.elapsed().as_secs_f64();
        println!("xpbd {tx:.3} s newton {tn:.3} s ratio {:.2}", tn / tx);
    }
    Ok(())
}

fn norm(v: &[f64]) -> f64 {
    v.iter().map(|a| a * a).sum::<f64>().sqrt()
}

fn sum(mut a: StepStats, s: &StepStats) -> StepStats {
    a.add_work(s);
    a.loads += s.loads;
    a.rejected_loads += s.rejected_loads;
    a
}
