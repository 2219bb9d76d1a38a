//! Draws every figure type of `clothopt::plot` from synthetic data.
//!
//! `cargo run --release --example plot_demo -- DIR` writes `trajectory_3d.png`,
//! `trajectory_3d_side.png`, `trajectory_top.png`, `drop_3d.png`, `drop_top.png`, `panels.png`,
//! `bars.png`, `bars_log.png`, `xy_loglog.png` and `xy_linear.png` into DIR (created if missing).

use std::f64::consts::PI;
use std::path::PathBuf;

use clothopt::plot::{
    draw_bar_chart, draw_trajectory_3d, draw_trajectory_panels, draw_trajectory_top, draw_xy,
    BarChart, RefLine, Series, Sphere, TrajectoryFigure, View3d, XyFigure,
};

const N: usize = 10;
const T: usize = 10;

/// A fake cloth state: a 1 m × 1 m sheet hanging from its top edge, centred at `(0, y)`, turned by
/// `theta` about the vertical axis, top edge at height `z_top`, trailing behind when it moves.
fn cloth_state(y: f64, theta: f64, z_top: f64, trail: f64) -> Vec<[f64; 3]> {
    let mut out = Vec::with_capacity(N * N);
    for r in 0..N {
        for c in 0..N {
            let u = c as f64 / (N - 1) as f64 - 0.5; // across, −0.5..0.5
            let v = r as f64 / (N - 1) as f64; // down, 0..1
            let sag = 0.06 * (PI * (u + 0.5)).sin() * v; // a little belly
            let back = -trail * v * v; // lower rows lag behind
            let (s, co) = theta.sin_cos();
            let x = u * co - (back + sag) * s;
            let yy = y + u * s + (back + sag) * co;
            out.push([x, yy, z_top - v * (1.0 - 0.2 * trail.abs())]);
        }
    }
    out
}

fn u_obstacle() -> Vec<Sphere> {
    let mut s = Vec::new();
    for x in [-0.75, 0.75] {
        for k in 0..=6 {
            s.push(Sphere {
                center: [x, 0.0, 0.25 + k as f64 * 2.5 / 6.0],
                radius: 0.25,
            });
        }
    }
    for x in [-0.45, -0.15, 0.15, 0.45] {
        s.push(Sphere {
            center: [x, 0.0, 0.25],
            radius: 0.25,
        });
    }
    s
}

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let dir = PathBuf::from(
        std::env::args()
            .nth(1)
            .ok_or("usage: plot_demo OUTPUT_DIR")?,
    );
    std::fs::create_dir_all(&dir)?;

    // Trajectory: from y = −1.5 to y = 1.5, turning edge-on and dipping while it passes the opening.
    let states: Vec<Vec<[f64; 3]>> = (0..=T)
        .map(|t| {
            let s = t as f64 / T as f64;
            let y = -1.5 + 3.0 * s;
            let bump = (PI * s).sin();
            let theta = 0.8 * bump;
            let z_top = 2.0 - 0.35 * bump;
            let trail = 0.25 * bump;
            cloth_state(y, theta, z_top, trail)
        })
        .collect();
    let control_paths: Vec<Vec<[f64; 3]>> = [0, N - 1]
        .iter()
        .map(|&p| states.iter().map(|st| st[p]).collect())
        .collect();
    let targets: Vec<[f64; 3]> = (0..N)
        .map(|c| [c as f64 / (N - 1) as f64 - 0.5, 1.5, 1.0])
        .collect();
    let target_particles: Vec<usize> = ((N - 1) * N..N * N).collect();
    let spheres = u_obstacle();
    let fig = TrajectoryFigure {
        title: "u_obstacle, δ = 0.20 (synthetic): through the opening, turned edge-on".into(),
        grid: (N, N),
        frames: vec![
            (&states[0][..], "initial (t = 0)".into()),
            (&states[T / 2][..], format!("intermediate (t = {})", T / 2)),
            (&states[T][..], format!("final (t = {T})")),
        ],
        control_paths,
        spheres: &spheres,
        targets: &targets,
        target_particles: &target_particles,
        ground_z: Some(0.0),
        safety_margin: Some(0.2),
        ..Default::default()
    };
    draw_trajectory_3d(&fig, &dir.join("trajectory_3d.png"))?;
    // A second viewing angle (almost side-on), as the paper shows each trajectory from several.
    let side = TrajectoryFigure {
        view: View3d {
            yaw: 1.35,
            pitch: 0.3,
        },
        ..fig.clone()
    };
    draw_trajectory_3d(&side, &dir.join("trajectory_3d_side.png"))?;
    draw_trajectory_top(&fig, &dir.join("trajectory_top.png"))?;

    // An obstacle-free task with a ground plane, like the ablation's `drop`: the cloth is lowered
    // from hanging to lying flat, its four corners meeting targets on the floor.
    let drop: Vec<Vec<[f64; 3]>> = (0..=T)
        .map(|t| {
            let s = t as f64 / T as f64;
            let mut out = Vec::with_capacity(N * N);
            for r in 0..N {
                for c in 0..N {
                    let u = c as f64 / (N - 1) as f64 - 0.5;
                    let v = r as f64 / (N - 1) as f64;
                    // Hanging part and lying part: rows above `lying` still hang.
                    let top = [u, -0.5 + 1.0 * s, 1.2 * (1.0 - s)];
                    let hang = (1.0 - s) * 1.2;
                    let along = v;
                    let p = if along <= hang {
                        [top[0], top[1], top[2] - along]
                    } else {
                        [top[0], top[1] - (along - hang), 0.0]
                    };
                    out.push(p);
                }
            }
            out
        })
        .collect();
    let drop_paths: Vec<Vec<[f64; 3]>> = [0, N - 1]
        .iter()
        .map(|&p| drop.iter().map(|st| st[p]).collect())
        .collect();
    let corners = [0, N - 1, N * (N - 1), N * N - 1];
    let drop_targets: Vec<[f64; 3]> = corners.iter().map(|&i| drop[T][i]).collect();
    let drop_fig = TrajectoryFigure {
        title: "drop task, G+αT+βE (synthetic): lowered onto the floor".into(),
        grid: (N, N),
        frames: vec![
            (&drop[0][..], "initial (t = 0)".into()),
            (&drop[T / 2][..], format!("intermediate (t = {})", T / 2)),
            (&drop[T][..], format!("final (t = {T})")),
        ],
        control_paths: drop_paths,
        targets: &drop_targets,
        target_particles: &corners,
        ground_z: Some(0.0),
        ..Default::default()
    };
    draw_trajectory_3d(&drop_fig, &dir.join("drop_3d.png"))?;
    draw_trajectory_top(&drop_fig, &dir.join("drop_top.png"))?;

    // Panels like the paper's qualitative_result: one trajectory per objective variant, same axes.
    let variants = ["G", "G+αT", "G+βE", "G+αT+βE"];
    let bends = [0.5, 0.0, 0.3, 0.1];
    let variant_states: Vec<Vec<Vec<[f64; 3]>>> = bends
        .iter()
        .map(|&bend| {
            drop.iter()
                .enumerate()
                .map(|(t, st)| {
                    let s = t as f64 / T as f64;
                    let wiggle = bend * (2.0 * PI * s).sin();
                    st.iter()
                        .map(|p| [p[0] + wiggle * 0.8, p[1], p[2] + wiggle * 0.5 * p[2]])
                        .collect()
                })
                .collect()
        })
        .collect();
    let panels: Vec<TrajectoryFigure> = variants
        .iter()
        .zip(&variant_states)
        .map(|(name, states)| TrajectoryFigure {
            title: format!("drop, {name}"),
            grid: (N, N),
            frames: vec![
                (&states[0][..], "initial".into()),
                (&states[T / 2][..], "intermediate".into()),
                (&states[T][..], "final".into()),
            ],
            control_paths: [0, N - 1]
                .iter()
                .map(|&p| states.iter().map(|st| st[p]).collect())
                .collect(),
            targets: &drop_targets,
            target_particles: &corners,
            ground_z: Some(0.0),
            ..Default::default()
        })
        .collect();
    draw_trajectory_panels(
        "drop task: trajectory per objective variant (synthetic)",
        &panels,
        4,
        &dir.join("panels.png"),
    )?;

    // Bar chart like the paper's quantitative_result (drop task).
    let names: Vec<String> = ["G", "αT", "βE"].iter().map(|s| s.to_string()).collect();
    let groups = vec![
        ("G".to_string(), vec![0.012, 1.85, 0.94]),
        ("G+αT".to_string(), vec![0.020, 0.31, 1.72]),
        ("G+βE".to_string(), vec![0.035, 2.40, 0.12]),
        ("G+αT+βE".to_string(), vec![0.028, 0.36, 0.15]),
    ];
    let mut bars = BarChart {
        title: "drop task: cost terms at the optimum per objective variant (synthetic)".into(),
        y_label: "cost term value".into(),
        groups,
        series_names: names,
        pad: 0.1,
        log_y: false,
    };
    draw_bar_chart(&bars, &dir.join("bars.png"))?;
    bars.log_y = true;
    draw_bar_chart(&bars, &dir.join("bars_log.png"))?;

    // Gradient error against time (log–log), labelled by iteration count.
    let iters = [5, 10, 20, 50, 100, 200, 400, 1000];
    let series: Vec<Series> = [("u_obstacle", 0.9, 1.0), ("swing", 0.5, 1.6)]
        .iter()
        .map(|&(name, t0, e0)| Series {
            name: name.to_string(),
            points: iters
                .iter()
                .map(|&n| {
                    let n = n as f64;
                    (t0 * n / 10.0, e0 * (-n / 180.0).exp() * 0.8 + 2e-4 * e0)
                })
                .collect(),
            labels: iters.iter().map(|n| format!("n_iter={n}")).collect(),
        })
        .collect();
    draw_xy(
        &XyFigure {
            title: "Gradient accuracy vs cost of one forward + gradient (synthetic)".into(),
            x_label: "time of forward + ∇L [ms]".into(),
            y_label: "relative error of ∇L vs 5000 iterations".into(),
            series,
            log_x: true,
            log_y: true,
            ref_lines: vec![RefLine {
                y: 1e-2,
                label: "1 % error".into(),
            }],
        },
        &dir.join("xy_loglog.png"),
    )?;

    // True min SDF of the optimized plan vs optimisation time, with the safety threshold.
    let opt_time = [0.05, 0.09, 0.17, 0.4, 0.8, 1.6, 3.1, 7.9];
    let sdf = [0.02, 0.08, 0.15, 0.185, 0.198, 0.2, 0.2, 0.2];
    let g = [0.42, 0.31, 0.22, 0.19, 0.182, 0.181, 0.181, 0.181];
    let labels: Vec<String> = iters
        .iter()
        .enumerate()
        .map(|(i, n)| {
            if i == 0 {
                format!("n_iter={n}")
            } else {
                format!("{n}")
            }
        })
        .collect();
    draw_xy(
        &XyFigure {
            title: "Plan re-simulated at 5000 iterations vs optimisation time (synthetic)".into(),
            x_label: "optimisation wall time [s]".into(),
            y_label: "distance [m]".into(),
            series: vec![
                Series {
                    name: "true min SDF".into(),
                    points: opt_time.iter().copied().zip(sdf).collect(),
                    labels: labels.clone(),
                },
                Series {
                    name: "true target error G".into(),
                    points: opt_time.iter().copied().zip(g).collect(),
                    labels: Vec::new(),
                },
            ],
            log_x: true,
            log_y: false,
            ref_lines: vec![RefLine {
                y: 0.2,
                label: "δ = 0.2 (safe above)".into(),
            }],
        },
        &dir.join("xy_linear.png"),
    )?;
    println!("wrote 10 figures to {}", dir.display());
    Ok(())
}
