//! The ablation's jobs: one optimization per (task, variant, solver), run on worker threads
//! with a progress bar each.

use super::{Args, Task, Variant};
use anyhow::Result;
use autodiff::Tensor;
use clothopt::plan::{self, Optimizer, PlanOptions};
use clothopt::problem::TargetModel;
use clothopt::result::{states_of, PlanResult};
use indicatif::{MultiProgress, ProgressBar, ProgressStyle};
use std::sync::atomic::{AtomicUsize, Ordering};
use std::sync::Mutex;

/// One optimization to run: a task, a variant, and the solver.
#[derive(Clone, Copy)]
pub(crate) struct Job {
    pub(crate) task: usize,
    pub(crate) variant: Variant,
    pub(crate) solver: Optimizer,
}

/// A finished job.
pub(crate) struct Run {
    pub(crate) job: Job,
    pub(crate) result: PlanResult,
    pub(crate) states: Vec<Tensor>,
    /// Lowest z of any particle in any frame.
    pub(crate) min_z: f64,
    /// The objective after two iterations (`None` if the run stopped earlier).
    pub(crate) objective_at_2: Option<f64>,
}

impl Run {
    /// The scene's `(α, β)` (the variant's own weights score `result.metrics`).
    pub(crate) fn scene_weights(&self, tasks: &[Task]) -> (f64, f64) {
        let weights = &tasks[self.job.task].model.task;
        (weights.alpha, weights.beta)
    }
    /// `α·T` with the scene's α, whatever the variant optimized.
    pub(crate) fn alpha_t(&self, tasks: &[Task]) -> f64 {
        self.scene_weights(tasks).0 * self.result.metrics.t
    }
    /// `β·E` with the scene's β.
    pub(crate) fn beta_e(&self, tasks: &[Task]) -> f64 {
        self.scene_weights(tasks).1 * self.result.metrics.e
    }
}

/// The lowest z of any particle over every state.
pub(crate) fn min_z(states: &[Tensor]) -> f64 {
    states
        .iter()
        .flat_map(|x| (0..x.rows()).map(move |p| x.get(p, 2)))
        .fold(f64::INFINITY, f64::min)
}

/// Progress display shared by the workers: bars, or iteration lines with `--verbose`.
pub(crate) struct Progress {
    pub(crate) multi: MultiProgress,
    pub(crate) verbose: bool,
}

impl Progress {
    /// A bar for one run (hidden with `--verbose`).
    pub(crate) fn bar(&self, len: usize, label: &str) -> ProgressBar {
        if self.verbose {
            return ProgressBar::hidden();
        }
        let bar = self.multi.add(ProgressBar::new(len as u64));
        bar.set_style(
            ProgressStyle::with_template(
                "{prefix:<24} [{elapsed_precise}] {bar:30} {pos}/{len} {msg}",
            )
            .unwrap_or_else(|_| ProgressStyle::default_bar()),
        );
        bar.set_prefix(label.to_string());
        bar
    }

    /// A line on stderr that does not tear the bars.
    fn line(&self, text: &str) {
        if self.verbose || self.multi.println(text).is_err() {
            eprintln!("{text}");
        }
    }
}

/// Runs one job.
pub(crate) fn run_job(job: Job, task: &Task, args: &Args, progress: &Progress) -> Result<Run> {
    let mut options = PlanOptions::for_model(&task.model);
    let scene_weights = &task.model.task;
    let (alpha, beta) = job.variant.weights(scene_weights.alpha, scene_weights.beta);
    options.task.alpha = alpha;
    options.task.beta = beta;
    options.task.safety = None;
    // The paper's formulation unless `--target-model` says otherwise: G in the smooth objective
    // (L-BFGS needs it there; SQP learns its curvature by BFGS). Pinned so that the ablation
    // stays reproducible whatever `clothopt optimize --target-model` defaults to.
    options.task.target_model = match job.solver {
        Optimizer::Lbfgs => TargetModel::Bfgs,
        _ => args.target_model,
    };
    options.solver = job.solver;
    options.iterations = task.settings.iterations;
    options.step_bound = task.settings.step_bound;
    options.tol_optimality = args.tol_optimality.unwrap_or(options.tol_optimality);
    let label = format!(
        "{} {}{}",
        task.name,
        job.variant.name(),
        if job.solver == Optimizer::Lbfgs {
            " L-BFGS"
        } else {
            ""
        }
    );
    let bar = progress.bar(options.iterations, &label);
    let mut objective_at_2 = None;
    let mut result = plan::plan(&task.model, &task.scene, &task.start, &options, |info| {
        if info.iteration == 2 {
            objective_at_2 = Some(info.objective);
        }
        if progress.verbose {
            eprintln!("{label:<22} {info}");
        }
        bar.set_position(info.iteration as u64);
        bar.set_message(format!("f {:.5}", info.objective));
    })?;
    bar.finish_and_clear();
    progress.line(&format!(
        "{label:<24} G {:.4}  {} after {} iterations, {:.1} s",
        result.metrics.g, result.status, result.iterations, result.wall_s
    ));
    let states = states_of(&result)?;
    result.states = None;
    Ok(Run {
        job,
        min_z: min_z(&states),
        result,
        states,
        objective_at_2,
    })
}

/// Runs `jobs` on `threads` worker threads; the results come back in the order of `jobs`.
pub(crate) fn run_all(
    jobs: &[Job],
    tasks: &[Task],
    args: &Args,
    threads: usize,
    progress: &Progress,
) -> Result<Vec<Run>> {
    let next = AtomicUsize::new(0);
    let slots: Mutex<Vec<Option<Result<Run>>>> =
        Mutex::new((0..jobs.len()).map(|_| None).collect());
    std::thread::scope(|scope| {
        for _ in 0..threads.clamp(1, jobs.len().max(1)) {
            scope.spawn(|| loop {
                let i = next.fetch_add(1, Ordering::SeqCst);
                let Some(&job) = jobs.get(i) else { break };
                let run = run_job(job, &tasks[job.task], args, progress);
                if let Ok(mut slots) = slots.lock() {
                    slots[i] = Some(run);
                }
            });
        }
    });
    let slots = slots
        .into_inner()
        .map_err(|_| anyhow::anyhow!("a worker thread panicked"))?;
    slots
        .into_iter()
        .map(|s| s.unwrap_or_else(|| Err(anyhow::anyhow!("a run did not finish"))))
        .collect()
}
