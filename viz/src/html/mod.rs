//! A rollout you can watch: one self-contained HTML file (inline data, script and style; no
//! network) with the cloth mesh, obstacles, targets and gripper paths in 3-D, orbit with the mouse,
//! a time slider, a play button, and where the cloth comes closest to the obstacles at each step.

use std::path::Path;

use crate::render::{check_point, write_atomic};
use crate::{PlotError, Solid, SolidRole, Sphere};

/// The viewer script (Canvas 2-D: its own projection and painter's sort, so it needs no WebGL).
const VIEWER_JS: &str = include_str!("viewer.js");

/// Where the cloth comes closest to the safety obstacles at one step.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Closest {
    /// The particle nearest to the obstacles.
    pub particle: usize,
    /// Its signed distance to them (negative inside).
    pub distance: f64,
}

/// A rollout for [`write_rollout_html`]: every state of the cloth and the scene around it.
#[derive(Debug, Clone, Default)]
pub struct Rollout {
    /// Shown above the view.
    pub title: String,
    /// The cloth at each step (`T + 1` states of equally many particles).
    pub states: Vec<Vec<[f64; 3]>>,
    /// The cloth mesh: triangles of particle indices (see [`grid_triangles`]).
    pub triangles: Vec<[usize; 3]>,
    /// The gripped particles; their paths over the steps are drawn.
    pub control_particles: Vec<usize>,
    /// Obstacle spheres.
    pub spheres: Vec<Sphere>,
    /// Obstacles as closed triangle meshes.
    pub solids: Vec<Solid>,
    /// Height of a horizontal ground plane, if any.
    pub ground_z: Option<f64>,
    /// Target positions.
    pub targets: Vec<[f64; 3]>,
    /// Particles meant to reach the targets (ringed).
    pub target_particles: Vec<usize>,
    /// Safety margin δ: drawn as a dashed outline around the spheres; a closest distance below it
    /// is shown in red.
    pub safety_margin: Option<f64>,
    /// Per step (empty, or one per state): the particle nearest to the safety obstacles.
    pub closest: Vec<Closest>,
}

/// The triangles of a `rows × cols` grid cloth (particle `r * cols + c`), two per cell.
pub fn grid_triangles(rows: usize, cols: usize) -> Vec<[usize; 3]> {
    let mut out = Vec::new();
    for r in 0..rows.saturating_sub(1) {
        for c in 0..cols.saturating_sub(1) {
            let p = r * cols + c;
            out.push([p, p + 1, p + cols + 1]);
            out.push([p, p + cols + 1, p + cols]);
        }
    }
    out
}

/// Writes `rollout` as one self-contained HTML page to `path` (atomically).
pub fn write_rollout_html(rollout: &Rollout, path: &Path) -> Result<(), PlotError> {
    write_atomic(path, rollout_html(rollout)?.as_bytes())
}

/// The HTML page of `rollout`.
pub fn rollout_html(rollout: &Rollout) -> Result<String, PlotError> {
    validate(rollout)?;
    let data = serde_json::json!({
        "title": rollout.title,
        "states": rollout.states,
        "triangles": rollout.triangles,
        "control_particles": rollout.control_particles,
        "spheres": rollout.spheres.iter()
            .map(|s| serde_json::json!({"center": s.center, "radius": s.radius}))
            .collect::<Vec<_>>(),
        "solids": rollout.solids.iter()
            .map(|s| serde_json::json!({
                "vertices": s.vertices, "triangles": s.triangles, "role": role_name(s.role),
            }))
            .collect::<Vec<_>>(),
        "ground_z": rollout.ground_z,
        "targets": rollout.targets,
        "target_particles": rollout.target_particles,
        "safety_margin": rollout.safety_margin,
        "closest": rollout.closest.iter()
            .map(|c| serde_json::json!({"particle": c.particle, "distance": c.distance}))
            .collect::<Vec<_>>(),
    });
    // Inside <script>, only "</" could end the element early; JSON allows "<\/" for it.
    let json = data.to_string().replace("</", "<\\/");
    Ok(format!(
        r#"<!DOCTYPE html>
<html lang="en">
<head>
<meta charset="utf-8">
<meta name="viewport" content="width=device-width, initial-scale=1">
<title>{title}</title>
<style>
html, body {{ margin: 0; height: 100%; overflow: hidden; font: 14px sans-serif; background: #fff; }}
#view {{ display: block; width: 100%; height: calc(100% - 46px); touch-action: none; cursor: grab; }}
#info {{ position: absolute; left: 12px; top: 8px; pointer-events: none; line-height: 1.5; }}
#bar {{ position: absolute; left: 0; right: 0; bottom: 0; height: 45px; display: flex; gap: 12px;
  align-items: center; padding: 0 12px; background: #f4f4f4; border-top: 1px solid #ccc; }}
#slider {{ flex: 1; }}
#help {{ color: #666; }}
</style>
</head>
<body data-status="loading">
<canvas id="view"></canvas>
<div id="info"></div>
<div id="bar"><button id="play" type="button">Play</button><input id="slider" type="range" min="0" max="0" step="1" value="0"><span id="step"></span><span id="help">drag: orbit · wheel: zoom</span></div>
<script id="rollout" type="application/json">{json}</script>
<script>
{script}
</script>
</body>
</html>
"#,
        title = escape_html(&rollout.title),
        script = VIEWER_JS,
    ))
}

fn role_name(role: SolidRole) -> &'static str {
    match role {
        SolidRole::Safety => "safety",
        SolidRole::Collider => "collider",
        SolidRole::Both => "both",
    }
}

fn escape_html(text: &str) -> String {
    text.replace('&', "&amp;")
        .replace('<', "&lt;")
        .replace('>', "&gt;")
}

/// Every number finite, every index in range, states of equal size, one closest entry per state.
fn validate(r: &Rollout) -> Result<(), PlotError> {
    let bad = |m: String| Err(PlotError::InvalidData(m));
    let Some(first) = r.states.first() else {
        return bad("a rollout needs at least one state".into());
    };
    let n = first.len();
    for (t, state) in r.states.iter().enumerate() {
        if state.len() != n {
            return bad(format!(
                "state {t} has {} particles, state 0 has {n}",
                state.len()
            ));
        }
        for (i, p) in state.iter().enumerate() {
            check_point(&format!("particle {i} of state {t}"), p)?;
        }
    }
    let particle_lists = [
        (
            "triangles",
            r.triangles.iter().flatten().copied().collect::<Vec<_>>(),
        ),
        ("control_particles", r.control_particles.clone()),
        ("target_particles", r.target_particles.clone()),
        ("closest", r.closest.iter().map(|c| c.particle).collect()),
    ];
    for (what, list) in particle_lists {
        if let Some(&i) = list.iter().find(|&&i| i >= n) {
            return bad(format!("{what}: particle {i}, but the cloth has {n}"));
        }
    }
    if !r.closest.is_empty() && r.closest.len() != r.states.len() {
        return bad(format!(
            "closest has {} entries for {} states",
            r.closest.len(),
            r.states.len()
        ));
    }
    if let Some(c) = r.closest.iter().find(|c| !c.distance.is_finite()) {
        return bad(format!("closest distance {} is not finite", c.distance));
    }
    for (k, s) in r.spheres.iter().enumerate() {
        check_point(&format!("centre of sphere {k}"), &s.center)?;
        if !(s.radius.is_finite() && s.radius > 0.0) {
            return bad(format!("sphere {k} has radius {}", s.radius));
        }
    }
    for (k, solid) in r.solids.iter().enumerate() {
        crate::trajectory::validate_solid(k, solid)?;
    }
    for (k, p) in r.targets.iter().enumerate() {
        check_point(&format!("target {k}"), p)?;
    }
    for (what, v) in [("ground_z", r.ground_z), ("safety_margin", r.safety_margin)] {
        if let Some(v) = v.filter(|v| !v.is_finite()) {
            return bad(format!("{what} is {v}"));
        }
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    fn sheet() -> Rollout {
        let state = |z: f64| {
            (0..9)
                .map(|p| [(p % 3) as f64, (p / 3) as f64, z])
                .collect()
        };
        Rollout {
            title: "a <b> & c".into(),
            states: vec![state(1.0), state(2.0)],
            triangles: grid_triangles(3, 3),
            control_particles: vec![0, 2],
            spheres: vec![Sphere {
                center: [1.0, 1.0, 0.0],
                radius: 0.5,
            }],
            safety_margin: Some(0.1),
            closest: vec![
                Closest {
                    particle: 4,
                    distance: 0.5,
                },
                Closest {
                    particle: 4,
                    distance: 1.5,
                },
            ],
            ..Rollout::default()
        }
    }

    #[test]
    fn a_grid_has_two_triangles_per_cell_covering_every_particle() {
        let t = grid_triangles(3, 4);
        assert_eq!(t.len(), 2 * 2 * 3);
        let mut used: Vec<usize> = t.iter().flatten().copied().collect();
        used.sort_unstable();
        used.dedup();
        assert_eq!(used, (0..12).collect::<Vec<_>>());
    }

    #[test]
    fn the_page_is_self_contained_and_escapes_its_text() {
        let mut r = sheet();
        r.title = "x </script><script>alert(1)</script>".into();
        let html = rollout_html(&r).unwrap();
        assert!(
            !html.contains("http://") && !html.contains("https://"),
            "no network"
        );
        assert!(!html.contains("src="), "no external script or image");
        // One closing tag per script element: the title cannot end the data early.
        assert_eq!(html.matches("</script>").count(), 2);
        assert!(html.contains("<title>x &lt;/script&gt;"));
    }

    #[test]
    fn bad_rollouts_are_errors_naming_what_is_wrong() {
        let mut r = sheet();
        r.closest.pop();
        let e = rollout_html(&r).unwrap_err().to_string();
        assert!(e.contains("closest has 1 entries for 2 states"), "{e}");
        let mut r = sheet();
        r.triangles.push([0, 1, 9]);
        let e = rollout_html(&r).unwrap_err().to_string();
        assert!(e.contains("triangles: particle 9"), "{e}");
        let mut r = sheet();
        r.states[1][3][2] = f64::NAN;
        let e = rollout_html(&r).unwrap_err().to_string();
        assert!(e.contains("particle 3 of state 1"), "{e}");
        assert!(rollout_html(&Rollout::default()).is_err());
    }
}
