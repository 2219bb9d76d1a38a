//! Fitting the material: how well `clothopt fit` recovers stretch, bending and friction from a
//! recorded motion, and whether its standard errors can be trusted.
//!
//! For the towel laid onto a table and the towel folded on it (`examples/scenes/fit/`), the
//! scene's own rollout of a recorded motion is observed at 24 particles every 2nd step with
//! Gaussian noise of 0, 1 and 5 mm (`clothopt::fit::synthetic`), and the three parameters are
//! fitted from a start off by factors (2.5, 0.4, 1.6). Per case it prints truth, fit, relative
//! error, reported standard error, |error| / standard error, the identifiable flag and the fit's
//! counts; for the noisy levels it repeats the fit over `--seeds` noise seeds and prints the
//! coverage (the fraction of (parameter, seed) pairs whose truth lies within 1 and 2 reported
//! standard errors; nominal 68% and 95%; also judged on the log-factor, and which side the misses
//! fall on) and the estimates' sample spread and bias over the mean reported standard error. Last, a hanging towel lifted straight up: bending and friction should come
//! out not identifiable.
//!
//! ```sh
//! cargo run --release -p experiments --bin fit                 # 20 seeds, writes out/fit.json
//! cargo run --release -p experiments --bin fit -- --seeds 5 --out fit.json
//! ```

use anyhow::{Context, Result};
use clap::Parser;
use cloth::{ConstraintRegistry, Controls, Model, Parameter, Scene};
use clothopt::fit::synthetic::{synthetic, Sampling};
use clothopt::fit::{fit, FitOptions, FitResult, FitStatus};
use experiments::report::{fmt_opt, write_json};
use serde::Serialize;
use std::path::{Path, PathBuf};

#[derive(Parser)]
#[command(
    about = "How well `clothopt fit` recovers the material, and its standard errors' coverage"
)]
struct Cli {
    /// Noise seeds per noisy case for the coverage (1 to N).
    #[arg(long, default_value_t = 20)]
    seeds: u64,
    /// Noise levels (standard deviation per coordinate, metres).
    #[arg(long, value_delimiter = ',', default_values_t = [0.0, 1e-3, 5e-3])]
    noise: Vec<f64>,
    /// Directory of the scenes `lay.json` and `fold.json`.
    #[arg(long, default_value = "examples/scenes/fit")]
    dir: PathBuf,
    /// Write every fit and the coverage as JSON here.
    #[arg(long, default_value = "out/fit.json")]
    out: PathBuf,
}

/// The fitted parameters, and the factors the fit's start is off by.
const PARAMS: [&str; 3] = ["stretch", "bending", "friction"];
const OFF: [f64; 3] = [2.5, 0.4, 1.6];
/// Tracked particles, and every how many steps they are seen.
const POINTS: usize = 24;
const EVERY: usize = 2;

/// One parameter of one fit, against the truth.
#[derive(Serialize)]
struct Estimate {
    name: &'static str,
    truth: f64,
    start: f64,
    value: f64,
    /// `value / truth − 1`.
    relative_error: f64,
    std_error: Option<f64>,
    /// `|value − truth| / std_error`.
    z: Option<f64>,
    /// `|ln(value / truth)|` over the relative standard error (the fit's own, of the log-factor).
    z_log: Option<f64>,
    identifiable: bool,
    at_bound: bool,
}

/// One fit.
#[derive(Serialize)]
struct Run {
    scene: String,
    /// The recorded motion: `lay`, `fold` or `lift`.
    motion: &'static str,
    noise: f64,
    seed: u64,
    /// The noise the fit weighed the residuals by: given, or estimated from them (noise 0).
    fit_noise: f64,
    fit_noise_source: &'static str,
    status: FitStatus,
    iterations: usize,
    simulations: usize,
    wall_s: f64,
    rms_error_start: f64,
    rms_error: f64,
    parameters: Vec<Estimate>,
}

/// The coverage of one parameter (or of all, `parameter = "all"`) over the seeds of a case.
#[derive(Serialize)]
struct Coverage {
    scene: String,
    noise: f64,
    parameter: &'static str,
    /// (parameter, seed) pairs, and those with a standard error.
    pairs: usize,
    with_std_error: usize,
    identifiable: usize,
    within_1: f64,
    within_2: f64,
    /// Within 2 standard errors of the log-factor: `|ln(value / truth)| ≤ 2 · relative error`.
    within_2_log: f64,
    /// Pairs outside 2 standard errors, and how many of those fitted below the truth.
    misses_2: usize,
    misses_2_below: usize,
    /// The estimates' sample standard deviation over the mean reported standard error.
    spread_ratio: Option<f64>,
    /// The estimates' mean minus the truth, over the mean reported standard error.
    bias_ratio: Option<f64>,
}

/// A fit that failed with an error (none did in the runs documented).
#[derive(Serialize)]
struct Failure {
    motion: &'static str,
    noise: f64,
    seed: u64,
    error: String,
}

fn main() -> Result<()> {
    let cli = Cli::parse();
    let (mut runs, mut coverage, mut failures) = (Vec::new(), Vec::new(), Vec::new());
    // One fit of `motion` on `truth` (the lay scene's for `lift`); an error is printed and kept.
    let mut run = |truth: &Scene, motion: &'static str, noise: f64, seed: u64| {
        let scene = if motion == "lift" { "lay" } else { motion };
        match fit_one(&cli.dir, truth, scene, motion, noise, seed) {
            Ok(r) => Some(r),
            Err(e) => {
                println!("  {motion}, noise {noise}, seed {seed}: ERROR {e:#}");
                let error = format!("{e:#}");
                failures.push(Failure {
                    motion,
                    noise,
                    seed,
                    error,
                });
                None
            }
        }
    };
    for motion in ["lay", "fold"] {
        let truth = Scene::load(cli.dir.join(format!("{motion}.json")))
            .with_context(|| format!("loading {motion}.json from {}", cli.dir.display()))?;
        for &noise in &cli.noise {
            let seeds = if noise > 0.0 {
                1..=cli.seeds.max(1)
            } else {
                0..=0
            };
            let mut case: Vec<Run> = Vec::new();
            for seed in seeds {
                let Some(r) = run(&truth, motion, noise, seed) else {
                    continue;
                };
                if case.is_empty() {
                    print_run(&r);
                } else if r.status != FitStatus::Converged {
                    print_short(&r);
                }
                case.push(r);
            }
            if noise > 0.0 && !case.is_empty() {
                let rows = coverage_of(&case);
                print_coverage(&case, &rows);
                coverage.extend(rows);
            }
            runs.extend(case);
        }
    }
    // The lay scene's towel lifted straight up: it neither bends nor touches the table.
    let truth = Scene::load(cli.dir.join("lay.json"))?;
    if let Some(lift) = run(&truth, "lift", 0.0, 0) {
        print_run(&lift);
        let flag = |name: &str| {
            let flagged = (lift.parameters.iter()).any(|p| p.name == name && !p.identifiable);
            if flagged {
                "flagged not identifiable (as it should be)"
            } else {
                "NOT flagged (it should be)"
            }
        };
        let (b, f) = (flag("bending"), flag("friction"));
        println!("identifiability: bending {b}, friction {f}");
        runs.push(lift);
    }
    if !failures.is_empty() {
        println!(
            "{} fits failed with an error (listed above)",
            failures.len()
        );
    }
    write_out(&cli, &runs, &coverage, &failures)
}

/// The recorded motion `<kind>_motion.json` beside the scenes in `dir` (`lay`: the grippers
/// lowered 0.25 while drawn 0.3 along +y; `fold`: carried on a half circle of radius 0.15 to
/// 0.8π; `lift`: raised 0.1).
fn motion(dir: &Path, model: &Model, kind: &str) -> Result<Controls> {
    let path = dir.join(format!("{kind}_motion.json"));
    let text =
        std::fs::read_to_string(&path).with_context(|| format!("reading {}", path.display()))?;
    let file: serde_json::Value = serde_json::from_str(&text)?;
    let steps: Vec<Vec<[f64; 3]>> = serde_json::from_value(file["controls"].clone())?;
    Ok(clothopt::result::controls_from_nested(model, &steps)?)
}

/// Observes `truth`'s rollout of `motion` and fits the parameters from a start off by `OFF`.
fn fit_one(
    dir: &Path,
    truth: &Scene,
    scene: &str,
    motion_kind: &'static str,
    noise: f64,
    seed: u64,
) -> Result<Run> {
    let model = Model::from_scene(truth)?;
    let u = motion(dir, &model, motion_kind)?;
    let sampling = Sampling {
        points: POINTS,
        every: EVERY,
        noise,
        seed,
    };
    let (observed, _) = synthetic(&model, &u, &sampling)?;
    let params: Vec<Parameter> = PARAMS.iter().map(|p| Parameter::parse(p)).collect();
    let start = Parameter::scaled(truth, &params, OFF)?;
    let registry = ConstraintRegistry::new();
    let r = fit(
        &start,
        &registry,
        &observed,
        &params,
        &FitOptions::default(),
    )?;
    let parameters = (PARAMS.iter().zip(&params))
        .map(|(&name, p)| estimate(name, p.value(truth), &r))
        .collect::<Result<_>>()?;
    Ok(Run {
        scene: scene.into(),
        motion: motion_kind,
        noise,
        seed,
        fit_noise: r.noise.value,
        fit_noise_source: r.noise.source,
        status: r.status,
        iterations: r.iterations,
        simulations: r.simulations,
        wall_s: r.wall_s,
        rms_error_start: r.rms_error_start,
        rms_error: r.rms_error,
        parameters,
    })
}

/// Parameter `name` of the fit `r`, against its true value.
fn estimate(
    name: &'static str,
    truth: std::result::Result<f64, cloth::ClothError>,
    r: &FitResult,
) -> Result<Estimate> {
    let truth = truth?;
    let p = (r.parameters.get(name)).with_context(|| format!("the fit has no `{name}`"))?;
    Ok(Estimate {
        name,
        truth,
        start: p.start,
        value: p.value,
        relative_error: p.value / truth - 1.0,
        std_error: p.std_error,
        z: p.std_error.map(|se| (p.value - truth).abs() / se),
        z_log: (p.relative_std_error).map(|rel| (p.value / truth).ln().abs() / rel),
        identifiable: p.identifiable,
        at_bound: p.at_bound,
    })
}

fn status_name(s: FitStatus) -> &'static str {
    match s {
        FitStatus::Converged => "converged",
        FitStatus::Stalled => "STALLED (no damped step lowered the error)",
        FitStatus::IterationLimit => "STOPPED at the iteration limit",
    }
}

/// A seed's fit that did not converge, on one line.
fn print_short(r: &Run) {
    let z: Vec<String> = (r.parameters.iter())
        .map(|p| format!("{} {}", p.name, fmt_opt(p.z, 2)))
        .collect();
    println!(
        "  seed {}: {} after {} iterations, RMS {:.3e} m; |err|/se: {}",
        r.seed,
        status_name(r.status),
        r.iterations,
        r.rms_error,
        z.join(", ")
    );
}

fn print_run(r: &Run) {
    let seed = if r.noise > 0.0 {
        format!(", seed {}", r.seed)
    } else {
        format!(" (estimated from the residuals: {:.1e} m)", r.fit_noise)
    };
    println!(
        "\n{} ({} motion), noise {} mm{seed}: {} after {} iterations, {} simulations, {:.2} s; \
         RMS tracking error {:.2e} → {:.2e} m",
        r.scene,
        r.motion,
        1e3 * r.noise,
        status_name(r.status),
        r.iterations,
        r.simulations,
        r.wall_s,
        r.rms_error_start,
        r.rms_error
    );
    println!(
        "  {:<9} {:>11} {:>11} {:>10} {:>11} {:>9} {:>12}",
        "parameter", "truth", "fitted", "rel. error", "std error", "|err|/se", "identifiable"
    );
    for p in &r.parameters {
        let mut flag = if p.identifiable { "yes" } else { "NO" }.to_string();
        if p.at_bound {
            flag += ", at bound";
        }
        println!(
            "  {:<9} {:>11.4e} {:>11.4e} {:>10} {:>11} {:>9} {:>12}",
            p.name,
            p.truth,
            p.value,
            percent(p.relative_error),
            p.std_error.map_or("—".into(), |s| format!("{s:.3e}")),
            fmt_opt(p.z, 2),
            flag
        );
    }
}

/// A relative error in percent; below 0.001% in e-notation (exact observations).
fn percent(rel: f64) -> String {
    if rel.abs() < 1e-5 {
        format!("{:+.1e}%", 100.0 * rel)
    } else {
        format!("{:+.3}%", 100.0 * rel)
    }
}

/// The coverage per parameter and over all of them, for the seeds of one case.
fn coverage_of(case: &[Run]) -> Vec<Coverage> {
    let (scene, noise) = (case[0].scene.clone(), case[0].noise);
    let one = |name: &'static str| {
        let ests: Vec<&Estimate> = (case.iter())
            .flat_map(|r| &r.parameters)
            .filter(|p| name == "all" || p.name == name)
            .collect();
        let pairs = ests.len();
        let with_se = ests.iter().filter(|p| p.z.is_some()).count();
        let share = |n: usize| n as f64 / pairs.max(1) as f64;
        let within = |k: f64| share(ests.iter().filter(|p| p.z.is_some_and(|z| z <= k)).count());
        let misses: Vec<_> = ests
            .iter()
            .filter(|p| p.z.is_none_or(|z| z > 2.0))
            .collect();
        // Spread and bias in value units make sense for one parameter only.
        let (spread_ratio, bias_ratio) = if name == "all" || with_se < 2 {
            (None, None)
        } else {
            let n = ests.len() as f64;
            let mean = ests.iter().map(|p| p.value).sum::<f64>() / n;
            let var = ests.iter().map(|p| (p.value - mean).powi(2)).sum::<f64>() / (n - 1.0);
            let ses: Vec<f64> = ests.iter().filter_map(|p| p.std_error).collect();
            let se = ses.iter().sum::<f64>() / ses.len() as f64;
            (Some(var.sqrt() / se), Some((mean - ests[0].truth) / se))
        };
        Coverage {
            scene: scene.clone(),
            noise,
            parameter: name,
            pairs,
            with_std_error: with_se,
            identifiable: ests.iter().filter(|p| p.identifiable).count(),
            within_1: within(1.0),
            within_2: within(2.0),
            within_2_log: share(
                ests.iter()
                    .filter(|p| p.z_log.is_some_and(|z| z <= 2.0))
                    .count(),
            ),
            misses_2: misses.len(),
            misses_2_below: misses.iter().filter(|p| p.value < p.truth).count(),
            spread_ratio,
            bias_ratio,
        }
    };
    PARAMS.iter().copied().chain(["all"]).map(one).collect()
}

fn print_coverage(case: &[Run], rows: &[Coverage]) {
    let converged = case
        .iter()
        .filter(|r| r.status == FitStatus::Converged)
        .count();
    println!(
        "  coverage over {} seeds, {converged} of them converged (nominal: 68% of the truths \
         within 1 se, 95% within 2 se):",
        case.len()
    );
    println!(
        "  {:<9} {:>7} {:>12} {:>8} {:>8} {:>12} {:>16} {:>12} {:>14}",
        "parameter",
        "with se",
        "identifiable",
        "within 1",
        "within 2",
        "within 2 log",
        "misses (below)",
        "sd / mean se",
        "bias / mean se"
    );
    for c in rows {
        println!(
            "  {:<9} {:>7} {:>12} {:>7.0}% {:>7.0}% {:>11.0}% {:>16} {:>12} {:>14}",
            c.parameter,
            format!("{}/{}", c.with_std_error, c.pairs),
            c.identifiable,
            100.0 * c.within_1,
            100.0 * c.within_2,
            100.0 * c.within_2_log,
            format!("{} ({})", c.misses_2, c.misses_2_below),
            fmt_opt(c.spread_ratio, 2),
            fmt_opt(c.bias_ratio, 2)
        );
    }
}

fn write_out(cli: &Cli, runs: &[Run], coverage: &[Coverage], failures: &[Failure]) -> Result<()> {
    if let Some(dir) = cli.out.parent().filter(|d| !d.as_os_str().is_empty()) {
        std::fs::create_dir_all(dir).with_context(|| format!("creating {}", dir.display()))?;
    }
    let settings = serde_json::json!({
        "dir": cli.dir, "params": PARAMS, "start_factors": OFF, "points": POINTS,
        "every": EVERY, "noise": cli.noise, "seeds": cli.seeds,
    });
    let value = serde_json::json!({
        "settings": settings, "runs": runs, "coverage": coverage, "failures": failures,
    });
    write_json(Path::new(&cli.out), &value)
}
