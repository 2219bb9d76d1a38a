//! The axonometric 3-D view of a trajectory, alone or in panels.

use std::f64::consts::PI;
use std::path::Path;

use plotters::prelude::*;
use plotters::style::text_anchor::{HPos, Pos, VPos};

use super::prims::{render_prims, scene_prims, AxonometricView, Coord3, Projector};
use super::{
    render_hidden_cloth, render_margin, render_targets, trajectory_bounds, trajectory_legend,
    validate_trajectory,
};
use crate::format::fmt_tick;
use crate::legend::{draw_legend, legend_size};
use crate::render::{de, render, Area};
use crate::style::*;
use crate::text::Canvas;
use crate::{PlotError, TrajectoryFigure};

/// Draws a cloth trajectory in an axonometric 3-D view (equal scale on all axes, `z` up) to a PNG
/// (1000×800): cloth frames as wireframes in distinct colours, control-point paths as thick purple
/// and green polylines with a marker per step, obstacle spheres as shaded discs, targets as red
/// points, the ground plane, axis labels in metres and a legend.
pub fn draw_trajectory_3d(fig: &TrajectoryFigure, path: &Path) -> Result<(), PlotError> {
    validate_trajectory(fig)?;
    render(path, SIZE_3D, |root| {
        view_3d(root, fig, &trajectory_bounds(fig))
    })
}

/// The whole 3-D figure of `fig` (title, scene within the world box `b`, legend) on `root`
/// ([`SIZE_3D`] pixels).
pub(crate) fn view_3d(
    root: &Area,
    fig: &TrajectoryFigure,
    b: &[[f64; 2]; 3],
) -> Result<(), PlotError> {
    let titled = root
        .titled(
            &fig.title,
            text(24.0).pos(Pos::new(HPos::Center, VPos::Top)),
        )
        .map_err(de)?;
    let entries = trajectory_legend(fig, true);
    // The legend column is as wide as the widest label needs (at least 250 px).
    let legend_w = 250.max(legend_size(root, "Legend", &entries)?.0 + 10);
    let (plot_area, legend_area) = titled.split_horizontally(SIZE_3D.0 as i32 - legend_w);

    scene_3d(root, &plot_area, fig, b, 17.0)?;
    let view = fig.view;

    let (lx, ly) = legend_area.get_base_pixel();
    let bottom = draw_legend(root, (lx, ly + 20), "Legend", &entries)?;
    let note = format!(
        "view: yaw {:.0}°, pitch {:.0}°",
        view.yaw * 180.0 / PI,
        view.pitch * 180.0 / PI
    );
    root.draw(&Text::new(
        note,
        (lx + 4, bottom + 12),
        text_c(13.0, RGBColor(90, 90, 90)),
    ))
    .map_err(de)?;
    root.draw(&Text::new(
        "equal scale on x, y, z".to_string(),
        (lx + 4, bottom + 30),
        text_c(13.0, RGBColor(90, 90, 90)),
    ))
    .map_err(de)?;
    Ok(())
}

/// Draws several trajectories in 3-D side by side, `cols` panels per row, to one PNG (panels of
/// 460×440 plus a legend column), e.g. the four objective variants of the paper's Fig. 5
/// (`qualitative_result`) or one panel per δ. All panels share the same axes box, so they compare
/// directly; each is titled with its figure's `title`; the legend is built from the first panel.
pub fn draw_trajectory_panels(
    title: &str,
    panels: &[TrajectoryFigure],
    cols: usize,
    path: &Path,
) -> Result<(), PlotError> {
    if panels.is_empty() || cols == 0 {
        return Err(PlotError::InvalidData(
            "a panel figure needs at least one panel and one column".into(),
        ));
    }
    for fig in panels {
        validate_trajectory(fig)?;
    }
    let cols = cols.min(panels.len());
    let rows = panels.len().div_ceil(cols);
    let (pw, ph, legend_w, title_h) = (460u32, 440u32, 250u32, 50u32);
    let size = (cols as u32 * pw + legend_w, rows as u32 * ph + title_h);
    let mut b = trajectory_bounds(&panels[0]);
    for fig in &panels[1..] {
        let o = trajectory_bounds(fig);
        for a in 0..3 {
            b[a] = [b[a][0].min(o[a][0]), b[a][1].max(o[a][1])];
        }
    }
    render(path, size, |root| {
        let titled = root
            .titled(title, text(24.0).pos(Pos::new(HPos::Center, VPos::Top)))
            .map_err(de)?;
        let (grid, legend_area) = titled.split_horizontally((cols as u32 * pw) as i32);
        let cells = grid.split_evenly((rows, cols));
        for (fig, cell) in panels.iter().zip(&cells) {
            // The 3-D axes put their tick labels and titles left of the area: leave room for them.
            let area = cell
                .titled(&fig.title, text(17.0))
                .map_err(de)?
                .margin(0, 0, 36, 0);
            scene_3d(root, &area, fig, &b, 14.0)?;
        }
        let (lx, ly) = legend_area.get_base_pixel();
        let first = &panels[0];
        let bottom = draw_legend(
            root,
            (lx, ly + 20),
            "Legend",
            &trajectory_legend(first, true),
        )?;
        root.draw(&Text::new(
            format!(
                "view: yaw {:.0}°, pitch {:.0}°",
                first.view.yaw * 180.0 / PI,
                first.view.pitch * 180.0 / PI
            ),
            (lx + 4, bottom + 12),
            text_c(13.0, RGBColor(90, 90, 90)),
        ))
        .map_err(de)?;
        root.draw(&Text::new(
            "same axes in every panel".to_string(),
            (lx + 4, bottom + 30),
            text_c(13.0, RGBColor(90, 90, 90)),
        ))
        .map_err(de)?;
        Ok(())
    })
}

/// The 3-D scene of one trajectory (axes box, ground, cloth, paths, spheres, margin, targets) in
/// `plot_area`, within the world box `b`; everything is drawn on `root` in absolute pixels.
pub(crate) fn scene_3d(
    root: &Area,
    plot_area: &Area,
    fig: &TrajectoryFigure,
    b: &[[f64; 2]; 3],
    title_size: f64,
) -> Result<(), PlotError> {
    // plotters' 3-D axes: X = world x, Y = world z (up), Z = −world y (keeps the frame right-handed).
    let mut chart = ChartBuilder::on(plot_area)
        .margin(10)
        .build_cartesian_3d(b[0][0]..b[0][1], b[2][0]..b[2][1], -b[1][1]..-b[1][0])
        .map_err(de)?;
    let spans = [b[0][1] - b[0][0], b[2][1] - b[2][0], b[1][1] - b[1][0]];
    let (xr, yr) = chart.plotting_area().get_pixel_range();
    let (avail_w, avail_h) = (
        (xr.end - xr.start) as f64 * 0.80,
        (yr.end - yr.start) as f64 * 0.82,
    );
    let view = fig.view;
    let set_size = |chart: &mut ChartContext<'_, Canvas<'_>, Coord3>, k: f64| {
        chart.set_3d_pixel_range((
            (k * spans[0]).round().max(1.0) as i32,
            (k * spans[1]).round().max(1.0) as i32,
            (k * spans[2]).round().max(1.0) as i32,
        ));
        chart.with_projection(|mut pb| {
            pb.yaw = view.yaw;
            pb.pitch = view.pitch;
            pb.scale = 1.0;
            pb.into_matrix()
        });
    };
    // Fit the projected box into the drawing area (the projection is linear in the scale k).
    let k0 = 400.0 / spans.iter().fold(0.0f64, |a, &s| a.max(s));
    set_size(&mut chart, k0);
    let corners = |coord: &Coord3| {
        let mut bb = [i32::MAX, i32::MIN, i32::MAX, i32::MIN];
        for &x in &b[0] {
            for &y in &b[1] {
                for &z in &b[2] {
                    let (px, py) = coord.translate(&(x, z, -y));
                    bb = [bb[0].min(px), bb[1].max(px), bb[2].min(py), bb[3].max(py)];
                }
            }
        }
        bb
    };
    let bb = corners(chart.plotting_area().as_coord_spec());
    let f = (avail_w / (bb[1] - bb[0]).max(1) as f64).min(avail_h / (bb[3] - bb[2]).max(1) as f64);
    let mut k = k0 * f;
    set_size(&mut chart, k);
    // Where an axis title would run off the image (the vertical axis's, beside a wide box's left
    // edge), shrink the box until it fits: the titles keep their distance from the box.
    for _ in 0..4 {
        let coord = chart.plotting_area().as_coord_spec();
        let fit = axis_titles_fit(root, coord, b, plot_area, title_size)?;
        if fit >= 1.0 {
            break;
        }
        k *= fit;
        set_size(&mut chart, k);
    }

    let fmt_y = |v: &f64| fmt_tick(-*v);
    let fmt_v = |v: &f64| fmt_tick(*v);
    chart
        .configure_axes()
        .label_style(text(13.0))
        .x_labels(6)
        .y_labels(6)
        .z_labels(6)
        .max_light_lines(1)
        .light_grid_style(RGBColor(235, 235, 235))
        .bold_grid_style(GRID_GRAY)
        .axis_panel_style(RGBColor(248, 248, 248).filled())
        .x_formatter(&fmt_v)
        .y_formatter(&fmt_v)
        .z_formatter(&fmt_y)
        .draw()
        .map_err(de)?;

    let coord = chart.plotting_area().as_coord_spec();
    // Pixels per world unit: the rows of an orthographic rotation are orthonormal, so the three
    // projected axis vectors of length L carry 2·(s·L)² in total. translate() rounds to pixels,
    // so measure on long vectors.
    let big = 1000.0 / k;
    let o = coord.translate(&(0.0, 0.0, 0.0));
    let mut sq = 0.0;
    for e in [(big, 0.0, 0.0), (0.0, big, 0.0), (0.0, 0.0, big)] {
        let p = coord.translate(&e);
        sq += ((p.0 - o.0) as f64).powi(2) + ((p.1 - o.1) as f64).powi(2);
    }
    let scale = (sq / 2.0).sqrt() / big;
    let proj = AxonometricView { coord, scale };

    draw_axis_titles(root, coord, b, plot_area, title_size)?;

    if let Some(z) = fig.ground_z {
        let q = [
            [b[0][0], b[1][0], z],
            [b[0][1], b[1][0], z],
            [b[0][1], b[1][1], z],
            [b[0][0], b[1][1], z],
        ];
        let pts: Vec<_> = q.iter().map(|&v| proj.px(v)).collect();
        root.draw(&Polygon::new(pts, GROUND.mix(0.45).filled()))
            .map_err(de)?;
    }
    render_prims(root, &proj, scene_prims(fig))?;
    render_hidden_cloth(root, &proj, fig)?;
    render_margin(root, &proj, fig)?;
    render_targets(root, &proj, fig)?;
    Ok(())
}

/// An axis title and where it goes.
struct AxisTitle {
    name: &'static str,
    /// The centre of the text, in pixels.
    at: (i32, i32),
    /// The midpoint of the box edge it labels, from the centre of the plot area, in pixels.
    edge: (f64, f64),
}

/// Where "x [m]", "y [m]", "z [m]" go: beside the box edges on which plotters draws the tick
/// labels (the same choice as plotters' `draw_axis`: the nearest back-panel edge, then the
/// highest), outwards from the centre of `plot_area`.
fn axis_titles(coord: &Coord3, b: &[[f64; 2]; 3], plot_area: &Area, size: f64) -> Vec<AxisTitle> {
    // Ranges in plotters' axis order (X = x, Y = z, Z = −y).
    let r = [[b[0][0], b[0][1]], [b[2][0], b[2][1]], [-b[1][1], -b[1][0]]];
    let depth = |p: [f64; 3]| coord.projected_depth(&p[0], &p[1], &p[2]);
    let px = |p: [f64; 3]| coord.translate(&(p[0], p[1], p[2]));
    let lo = [r[0][0], r[1][0], r[2][0]];
    // The back value of each axis: the panel farther from the viewer.
    let mut back = [0.0; 3];
    for i in 0..3 {
        let mut c = lo;
        c[i] = r[i][1];
        back[i] = if depth(lo) >= depth(c) {
            r[i][0]
        } else {
            r[i][1]
        };
    }
    let (xr, yr) = plot_area.get_pixel_range();
    let centre = ((xr.start + xr.end) / 2, (yr.start + yr.end) / 2);
    let names = ["x [m]", "z [m]", "y [m]"];
    let mut titles = Vec::with_capacity(3);
    for idx in 0..3 {
        let candidates = (0..3).filter(|&i| i != idx).flat_map(|i| {
            let j = 3 - i - idx;
            r[j].map(|vj| {
                let mut s = [0.0; 3];
                s[i] = back[i];
                s[j] = vj;
                s[idx] = r[idx][0];
                let mut e = s;
                e[idx] = r[idx][1];
                (s, e)
            })
        });
        let best = candidates.min_by_key(|&(s, e)| (depth(s) + depth(e), px(s).1 + px(e).1));
        let Some((s, e)) = best else { continue };
        let (ps, pe) = (px(s), px(e));
        let m = ((ps.0 + pe.0) as f64 / 2.0, (ps.1 + pe.1) as f64 / 2.0);
        let d = (m.0 - centre.0 as f64, m.1 - centre.1 as f64);
        let n = (d.0 * d.0 + d.1 * d.1).sqrt().max(1.0);
        // Tick labels beside a vertical edge extend sideways, so go further out there.
        let off = if d.0.abs() > d.1.abs() { 4.2 } else { 3.0 } * size;
        let at = (
            (m.0 + d.0 / n * off).round() as i32,
            (m.1 + d.1 / n * off).round() as i32,
        );
        titles.push(AxisTitle {
            name: names[idx],
            at,
            edge: d,
        });
    }
    titles
}

/// Puts the axis titles ([`axis_titles`]) on `root`.
pub(crate) fn draw_axis_titles(
    root: &Area,
    coord: &Coord3,
    b: &[[f64; 2]; 3],
    plot_area: &Area,
    size: f64,
) -> Result<(), PlotError> {
    for t in axis_titles(coord, b, plot_area, size) {
        root.draw(&Text::new(
            t.name.to_string(),
            t.at,
            text(size).pos(Pos::new(HPos::Center, VPos::Center)),
        ))
        .map_err(de)?;
    }
    Ok(())
}

/// The factor (at most 1) by which the box's scale must shrink for every axis title to lie
/// within `root`: a title that runs `over` pixels past a side of the image needs the edge it
/// labels `over` pixels closer to the centre of `plot_area` (a title keeps its distance from
/// its edge, and the edges' distances from the centre scale with the box). A title that no
/// shrinking brings in is left as it is.
fn axis_titles_fit(
    root: &Area,
    coord: &Coord3,
    b: &[[f64; 2]; 3],
    plot_area: &Area,
    size: f64,
) -> Result<f64, PlotError> {
    let (rx, ry) = root.get_pixel_range();
    let mut fit = 1.0f64;
    for t in axis_titles(coord, b, plot_area, size) {
        let (w, h) = root.estimate_text_size(t.name, &text(size)).map_err(de)?;
        // Half the text's extent, and a pixel to spare.
        let (hw, hh) = (f64::from(w) / 2.0 + 1.0, f64::from(h) / 2.0 + 1.0);
        let (x, y) = (f64::from(t.at.0), f64::from(t.at.1));
        let over_x = (f64::from(rx.start) - (x - hw)).max(x + hw - f64::from(rx.end));
        let over_y = (f64::from(ry.start) - (y - hh)).max(y + hh - f64::from(ry.end));
        for (over, dist) in [(over_x, t.edge.0.abs()), (over_y, t.edge.1.abs())] {
            if over > 0.0 && dist > over {
                fit = fit.min((dist - over) / dist);
            }
        }
    }
    Ok(fit)
}
