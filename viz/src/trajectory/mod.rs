//! Trajectory figures: validation, bounds, overlays (hidden cloth, margin, targets) and legend;
//! the 3-D views are in `view3d`, the top view in `top`, the depth-sorted primitives in `prims`.

use plotters::prelude::*;

use crate::format::fmt_tick;
use crate::legend::{draw_dashed_envelope, Swatch};
use crate::render::{check_finite, check_point, de, Area};
use crate::style::*;
use crate::{PlotError, Solid, TrajectoryFigure};

pub(crate) mod prims;
pub(crate) mod top;
pub(crate) mod view3d;

pub(crate) use prims::Projector;

pub(crate) fn validate_trajectory(fig: &TrajectoryFigure) -> Result<(), PlotError> {
    let (rows, cols) = fig.grid;
    let mesh = !fig.cloth_triangles.is_empty();
    let needed = fig.cloth_particles();
    for (k, (frame, label)) in fig.frames.iter().enumerate() {
        if mesh && frame.len() < needed {
            return Err(PlotError::InvalidData(format!(
                "frame {k} (\"{label}\") has {} particles but the cloth triangles use particle {}",
                frame.len(),
                needed - 1
            )));
        }
        if !mesh && frame.len() != rows * cols {
            return Err(PlotError::InvalidData(format!(
                "frame {k} (\"{label}\") has {} particles but the grid {rows}×{cols} needs {}",
                frame.len(),
                rows * cols
            )));
        }
        for (i, p) in frame.iter().enumerate() {
            check_point(&format!("particle {i} of frame {k} (\"{label}\")"), p)?;
        }
    }
    for (k, path) in fig.control_paths.iter().enumerate() {
        for (t, p) in path.iter().enumerate() {
            check_point(&format!("point {t} of control path {k}"), p)?;
        }
    }
    for (k, s) in fig.spheres.iter().enumerate() {
        check_point(&format!("centre of sphere {k}"), &s.center)?;
        if !(s.radius.is_finite() && s.radius > 0.0) {
            return Err(PlotError::InvalidData(format!(
                "sphere {k} has radius {}; it must be finite and > 0",
                s.radius
            )));
        }
    }
    for (k, solid) in fig.solids.iter().enumerate() {
        validate_solid(k, solid)?;
    }
    for (k, p) in fig.targets.iter().enumerate() {
        check_point(&format!("target {k}"), p)?;
    }
    let particles = if mesh {
        fig.frames.first().map_or(needed, |(f, _)| f.len())
    } else {
        rows * cols
    };
    if let Some(&bad) = fig.target_particles.iter().find(|&&i| i >= particles) {
        return Err(PlotError::InvalidData(if mesh {
            format!("target particle {bad} is outside the cloth's {particles} particles")
        } else {
            format!("target particle {bad} is outside the {rows}×{cols} grid")
        }));
    }
    if let Some(z) = fig.ground_z {
        check_finite("ground_z", z)?;
    }
    if let Some(d) = fig.safety_margin {
        if !(d.is_finite() && d >= 0.0) {
            return Err(PlotError::InvalidData(format!(
                "safety_margin is {d}; it must be finite and ≥ 0"
            )));
        }
    }
    let empty = fig.frames.is_empty()
        && fig.control_paths.iter().all(|p| p.is_empty())
        && fig.spheres.is_empty()
        && fig.solids.is_empty()
        && fig.targets.is_empty();
    if empty {
        return Err(PlotError::InvalidData(
            "the trajectory figure has nothing to draw".into(),
        ));
    }
    Ok(())
}

/// Axis-aligned bounds of everything drawn, padded; each axis at least `min_span` wide.
pub(crate) fn trajectory_bounds(fig: &TrajectoryFigure) -> [[f64; 2]; 3] {
    let mut b = [[f64::INFINITY, f64::NEG_INFINITY]; 3];
    let mut add = |p: [f64; 3], r: f64| {
        for a in 0..3 {
            b[a][0] = b[a][0].min(p[a] - r);
            b[a][1] = b[a][1].max(p[a] + r);
        }
    };
    for (f, _) in &fig.frames {
        f.iter().for_each(|&p| add(p, 0.0));
    }
    for path in &fig.control_paths {
        path.iter().for_each(|&p| add(p, 0.0));
    }
    for s in fig.spheres {
        add(s.center, s.radius);
    }
    for solid in fig.solids {
        solid.vertices.iter().for_each(|&p| add(p, 0.0));
    }
    fig.targets.iter().for_each(|&p| add(p, 0.0));
    if let Some(z) = fig.ground_z {
        b[2][0] = b[2][0].min(z);
        b[2][1] = b[2][1].max(z);
    }
    let largest = b.iter().map(|r| r[1] - r[0]).fold(0.0, f64::max).max(1e-6);
    for r in b.iter_mut() {
        let span = r[1] - r[0];
        let pad = 0.04 * largest + 0.5 * (0.15 * largest - span).max(0.0);
        r[0] -= pad;
        r[1] += pad;
    }
    b
}

/// Pixels drawn, then skipped, along a dashed line.
pub(crate) const DASH: (f64, f64) = (5.0, 4.0);

/// Every cloth frame's wireframe again, dashed in its colour and on top of everything, so a frame
/// hidden behind obstacles (e.g. the start and end cloth behind a wall of spheres) still shows.
pub(crate) fn render_hidden_cloth(
    root: &Area,
    proj: &dyn Projector,
    fig: &TrajectoryFigure,
) -> Result<(), PlotError> {
    if fig.spheres.is_empty() && fig.solids.is_empty() {
        return Ok(());
    }
    let pieces = fig.cloth_pieces();
    for (k, (frame, _)) in fig.frames.iter().enumerate() {
        let c = FRAME_COLORS[k % FRAME_COLORS.len()];
        for piece in &pieces {
            if let crate::ClothPiece::Edge([a, b]) = *piece {
                draw_dashed(root, proj.px(frame[a]), proj.px(frame[b]), c)?;
            }
        }
    }
    Ok(())
}

/// A 1-pixel dashed line from `a` to `b` (dash pattern [`DASH`], starting with a dash).
pub(crate) fn draw_dashed(
    root: &Area,
    a: (i32, i32),
    b: (i32, i32),
    c: RGBColor,
) -> Result<(), PlotError> {
    let (dx, dy) = ((b.0 - a.0) as f64, (b.1 - a.1) as f64);
    let len = dx.hypot(dy);
    let point = |s: f64| {
        let t = if len > 0.0 { (s / len).min(1.0) } else { 0.0 };
        (a.0 + (dx * t).round() as i32, a.1 + (dy * t).round() as i32)
    };
    let mut s = 0.0;
    while s < len {
        root.draw(&PathElement::new(
            vec![point(s), point(s + DASH.0)],
            c.stroke_width(1),
        ))
        .map_err(de)?;
        s += DASH.0 + DASH.1;
    }
    Ok(())
}

/// Targets and the particles meant to reach them, always on top.
pub(crate) fn render_targets(
    root: &Area,
    proj: &dyn Projector,
    fig: &TrajectoryFigure,
) -> Result<(), PlotError> {
    if let Some((last, _)) = fig.frames.last() {
        for &i in fig.target_particles {
            root.draw(&Circle::new(
                proj.px(last[i]),
                7,
                TARGET_RED.stroke_width(2),
            ))
            .map_err(de)?;
        }
    }
    for &t in fig.targets {
        let at = proj.px(t);
        root.draw(&Circle::new(at, 5, TARGET_RED.filled()))
            .map_err(de)?;
        root.draw(&Circle::new(at, 5, BLACK.stroke_width(1)))
            .map_err(de)?;
    }
    Ok(())
}

pub(crate) fn trajectory_legend(
    fig: &TrajectoryFigure,
    with_ground: bool,
) -> Vec<(Swatch, String)> {
    let mut e = Vec::new();
    for (k, (_, label)) in fig.frames.iter().enumerate() {
        e.push((
            Swatch::Line(FRAME_COLORS[k % FRAME_COLORS.len()], 2),
            format!("cloth: {label}"),
        ));
    }
    for k in 0..fig.control_paths.len() {
        e.push((
            Swatch::PathMarkers(PATH_COLORS[k % PATH_COLORS.len()]),
            format!("control point {} path", k + 1),
        ));
    }
    if !fig.spheres.is_empty() {
        e.push((
            Swatch::Sphere,
            format!("obstacle ({} spheres)", fig.spheres.len()),
        ));
    }
    for (k, solid) in fig.solids.iter().enumerate() {
        e.push((
            Swatch::Patch(prims::solid_color(solid.role).to_rgba()),
            format!("{} {} ({:?})", solid.kind, k + 1, solid.role).to_lowercase(),
        ));
    }
    if let (false, Some(d)) = (fig.spheres.is_empty(), fig.safety_margin) {
        e.push((
            Swatch::DashedRing(MARGIN_RED),
            format!("safety margin δ = {}", fmt_tick(d)),
        ));
    }
    if !fig.targets.is_empty() {
        e.push((Swatch::Dot(TARGET_RED), "target positions".into()));
    }
    if !fig.target_particles.is_empty() && !fig.frames.is_empty() {
        e.push((Swatch::Ring(TARGET_RED), "target particles (last)".into()));
    }
    if let (true, Some(z)) = (with_ground, fig.ground_z) {
        e.push((
            Swatch::Patch(GROUND.mix(0.45)),
            format!("ground z = {}", fmt_tick(z)),
        ));
    }
    e
}

/// The safety margin around the obstacle: the outline of all spheres grown by δ, as projected.
pub(crate) fn render_margin(
    root: &Area,
    proj: &dyn Projector,
    fig: &TrajectoryFigure,
) -> Result<(), PlotError> {
    let Some(d) = fig.safety_margin else {
        return Ok(());
    };
    let circles: Vec<_> = fig
        .spheres
        .iter()
        .map(|s| (proj.px(s.center), (s.radius + d) * proj.px_per_unit()))
        .collect();
    draw_dashed_envelope(root, &circles, MARGIN_RED)
}

/// A solid needs finite vertices, at least one triangle, and indices inside its vertex list.
pub(crate) fn validate_solid(k: usize, solid: &Solid) -> Result<(), PlotError> {
    for (i, p) in solid.vertices.iter().enumerate() {
        check_point(&format!("vertex {i} of solid {k}"), p)?;
    }
    if solid.triangles.is_empty() {
        return Err(PlotError::InvalidData(format!(
            "solid {k} has no triangles"
        )));
    }
    let n = solid.vertices.len();
    for (t, tri) in solid.triangles.iter().enumerate() {
        if let Some(&bad) = tri.iter().find(|&&i| i >= n) {
            return Err(PlotError::InvalidData(format!(
                "triangle {t} of solid {k} uses vertex {bad}, but the solid has {n} vertices"
            )));
        }
    }
    Ok(())
}
