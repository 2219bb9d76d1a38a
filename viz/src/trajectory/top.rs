//! The top view of a trajectory (x–y plane, equal aspect ratio).

use std::path::Path;

use plotters::prelude::*;
use plotters::style::text_anchor::{HPos, Pos, VPos};

use super::prims::{render_prims, scene_prims, TopView};
use super::{
    render_margin, render_targets, trajectory_bounds, trajectory_legend, validate_trajectory,
};
use crate::format::fmt_tick;
use crate::legend::{draw_legend, legend_size};
use crate::render::{de, render};
use crate::style::*;
use crate::{PlotError, TrajectoryFigure};

/// Draws the same trajectory seen from above (x–y plane, equal aspect ratio) to a PNG (900×600):
/// higher elements cover lower ones; spheres appear as shaded discs; the ground is not drawn.
pub fn draw_trajectory_top(fig: &TrajectoryFigure, path: &Path) -> Result<(), PlotError> {
    validate_trajectory(fig)?;
    render(path, SIZE_2D, |root| {
        let titled = root
            .titled(
                &fig.title,
                text(22.0).pos(Pos::new(HPos::Center, VPos::Top)),
            )
            .map_err(de)?;
        let entries = trajectory_legend(fig, false);
        // The legend column is as wide as the widest label needs (at least 240 px).
        let legend_w = 240.max(legend_size(root, "Top view", &entries)?.0 + 10);
        let (plot_area, legend_area) = titled.split_horizontally(SIZE_2D.0 as i32 - legend_w);
        let b = trajectory_bounds(fig);

        let build = |xr: std::ops::Range<f64>, yr: std::ops::Range<f64>| {
            ChartBuilder::on(&plot_area)
                .margin(12)
                .x_label_area_size(45)
                .y_label_area_size(60)
                .build_cartesian_2d(xr, yr)
        };
        // Measure the plotting area, then widen one range so that 1 m is as long on both axes.
        let probe = build(b[0][0]..b[0][1], b[1][0]..b[1][1]).map_err(de)?;
        let (pw, ph) = probe.plotting_area().dim_in_pixel();
        drop(probe);
        let (xr, yr) = equal_aspect([b[0], b[1]], (pw, ph));
        let mut chart = build(xr[0]..xr[1], yr[0]..yr[1]).map_err(de)?;
        let fmt = |v: &f64| fmt_tick(*v);
        chart
            .configure_mesh()
            .x_desc("x [m]")
            .y_desc("y [m]")
            .axis_desc_style(text(17.0))
            .label_style(text(14.0))
            .x_label_formatter(&fmt)
            .y_label_formatter(&fmt)
            .max_light_lines(1)
            .light_line_style(RGBColor(242, 242, 242))
            .bold_line_style(RGBColor(220, 220, 220))
            .draw()
            .map_err(de)?;
        let coord = chart.plotting_area().as_coord_spec();
        let (p0, p1) = (
            coord.translate(&(xr[0], yr[0])),
            coord.translate(&(xr[1], yr[0])),
        );
        let scale = (p1.0 - p0.0) as f64 / (xr[1] - xr[0]);
        let proj = TopView { coord, scale };
        render_prims(root, &proj, scene_prims(fig))?;
        render_margin(root, &proj, fig)?;
        render_targets(root, &proj, fig)?;

        let (lx, ly) = legend_area.get_base_pixel();
        let bottom = draw_legend(root, (lx, ly + 20), "Top view", &entries)?;
        root.draw(&Text::new(
            "seen from above (+z);".to_string(),
            (lx + 4, bottom + 12),
            text_c(13.0, RGBColor(90, 90, 90)),
        ))
        .map_err(de)?;
        root.draw(&Text::new(
            "higher parts cover lower ones".to_string(),
            (lx + 4, bottom + 30),
            text_c(13.0, RGBColor(90, 90, 90)),
        ))
        .map_err(de)?;
        Ok(())
    })
}

/// Widens the x or the y range around its centre so that one unit is as long on both axes of a
/// `pw × ph` pixel plot.
pub(crate) fn equal_aspect(b: [[f64; 2]; 2], (pw, ph): (u32, u32)) -> ([f64; 2], [f64; 2]) {
    let (dx, dy) = (b[0][1] - b[0][0], b[1][1] - b[1][0]);
    let s = (pw as f64 / dx).min(ph as f64 / dy);
    let (ex, ey) = ((pw as f64 / s - dx) / 2.0, (ph as f64 / s - dy) / 2.0);
    ([b[0][0] - ex, b[0][1] + ex], [b[1][0] - ey, b[1][1] + ey])
}
