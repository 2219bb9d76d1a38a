//! Line-and-marker (x–y) plots.

use std::path::Path;

use plotters::coord::ranged1d::{AsRangedCoord, ValueFormatter};
use plotters::prelude::*;
use plotters::style::text_anchor::{HPos, VPos};

use crate::format::fmt_num;
use crate::labels::{place_label, Obstacles};
use crate::legend::{draw_legend, legend_size, Swatch};
use crate::render::{check_finite, de, render, Area};
use crate::style::*;
use crate::PlotError;

/// One line of an [`XyFigure`].
#[derive(Debug, Clone, Default)]
pub struct Series {
    /// Legend name.
    pub name: String,
    /// Points `(x, y)`, joined in the given order.
    pub points: Vec<(f64, f64)>,
    /// Optional per-point labels (e.g. `"n_iter=100"`): empty, or one per point (`""` = no label).
    pub labels: Vec<String>,
}

/// A labelled horizontal reference line (e.g. `δ = 0.2`).
#[derive(Debug, Clone)]
pub struct RefLine {
    /// Its y value.
    pub y: f64,
    /// Text drawn on the line.
    pub label: String,
}

/// A line-and-marker plot for [`draw_xy`].
#[derive(Debug, Clone, Default)]
pub struct XyFigure {
    /// Figure title.
    pub title: String,
    /// X-axis label, with units.
    pub x_label: String,
    /// Y-axis label, with units.
    pub y_label: String,
    /// The lines.
    pub series: Vec<Series>,
    /// Logarithmic x axis (all x must be > 0).
    pub log_x: bool,
    /// Logarithmic y axis (all y and reference lines must be > 0).
    pub log_y: bool,
    /// Horizontal reference lines.
    pub ref_lines: Vec<RefLine>,
}

pub(crate) fn axis_range(vals: impl Iterator<Item = f64>, log: bool, extra_hi: f64) -> (f64, f64) {
    let (mut lo, mut hi) = vals.fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), v| {
        (a.min(v), b.max(v))
    });
    if log {
        let (l, h) = (lo.log10(), hi.log10());
        let span = (h - l).max(0.3);
        let c = (l + h) / 2.0;
        let (l, h) = (c - span / 2.0, c + span / 2.0);
        (
            10f64.powf(l - 0.06 * span),
            10f64.powf(h + (0.06 + extra_hi) * span),
        )
    } else {
        if hi - lo < 1e-12 * (1.0 + lo.abs()) {
            let d = if lo == 0.0 { 1.0 } else { 0.1 * lo.abs() };
            lo -= d;
            hi += d;
        }
        let span = hi - lo;
        (lo - 0.06 * span, hi + (0.06 + extra_hi) * span)
    }
}

/// Draws lines with markers (one colour and marker shape per series) to a PNG (900×600), with
/// optional per-point labels, labelled dashed horizontal reference lines, optional log axes and a
/// legend placed in the emptiest corner.
pub fn draw_xy(fig: &XyFigure, path: &Path) -> Result<(), PlotError> {
    if fig.series.iter().all(|s| s.points.is_empty()) {
        return Err(PlotError::InvalidData(format!(
            "plot \"{}\" has no points",
            fig.title
        )));
    }
    for s in &fig.series {
        if !s.labels.is_empty() && s.labels.len() != s.points.len() {
            return Err(PlotError::InvalidData(format!(
                "series \"{}\" has {} labels for {} points",
                s.name,
                s.labels.len(),
                s.points.len()
            )));
        }
        for (i, &(x, y)) in s.points.iter().enumerate() {
            check_finite(&format!("x of point {i} of series \"{}\"", s.name), x)?;
            check_finite(&format!("y of point {i} of series \"{}\"", s.name), y)?;
            if fig.log_x && x <= 0.0 {
                return Err(PlotError::InvalidData(format!(
                    "point {i} of series \"{}\" has x = {x} on a log axis",
                    s.name
                )));
            }
            if fig.log_y && y <= 0.0 {
                return Err(PlotError::InvalidData(format!(
                    "point {i} of series \"{}\" has y = {y} on a log axis",
                    s.name
                )));
            }
        }
    }
    for l in &fig.ref_lines {
        check_finite(&format!("reference line \"{}\"", l.label), l.y)?;
        if fig.log_y && l.y <= 0.0 {
            return Err(PlotError::InvalidData(format!(
                "reference line \"{}\" at y = {} on a log axis",
                l.label, l.y
            )));
        }
    }
    let has_labels = fig
        .series
        .iter()
        .any(|s| s.labels.iter().any(|l| !l.is_empty()));
    let xs = fig.series.iter().flat_map(|s| s.points.iter().map(|p| p.0));
    let ys = fig
        .series
        .iter()
        .flat_map(|s| s.points.iter().map(|p| p.1))
        .chain(fig.ref_lines.iter().map(|l| l.y));
    let (x0, x1) = axis_range(xs, fig.log_x, if has_labels { 0.12 } else { 0.0 });
    let (y0, y1) = axis_range(ys, fig.log_y, 0.0);
    render(path, SIZE_2D, |root| {
        match (fig.log_x, fig.log_y) {
            (false, false) => xy_body(root, fig, x0..x1, y0..y1)?,
            (true, false) => xy_body(root, fig, (x0..x1).log_scale(), y0..y1)?,
            (false, true) => xy_body(root, fig, x0..x1, (y0..y1).log_scale())?,
            (true, true) => xy_body(root, fig, (x0..x1).log_scale(), (y0..y1).log_scale())?,
        }
        Ok(())
    })
}

pub(crate) fn xy_body<XR, YR>(root: &Area, fig: &XyFigure, xr: XR, yr: YR) -> Result<(), PlotError>
where
    XR: AsRangedCoord<Value = f64>,
    YR: AsRangedCoord<Value = f64>,
    XR::CoordDescType: Ranged<ValueType = f64> + ValueFormatter<f64>,
    YR::CoordDescType: Ranged<ValueType = f64> + ValueFormatter<f64>,
{
    let mut chart = ChartBuilder::on(root)
        .caption(&fig.title, text(22.0))
        .margin(18)
        .x_label_area_size(55)
        .y_label_area_size(85)
        .build_cartesian_2d(xr, yr)
        .map_err(de)?;
    let fmt = |v: &f64| fmt_num(*v);
    chart
        .configure_mesh()
        .x_desc(fig.x_label.as_str())
        .y_desc(fig.y_label.as_str())
        .axis_desc_style(text(17.0))
        .label_style(text(14.0))
        .x_label_formatter(&fmt)
        .y_label_formatter(&fmt)
        .x_max_light_lines(if fig.log_x { 9 } else { 1 })
        .y_max_light_lines(if fig.log_y { 9 } else { 1 })
        .light_line_style(RGBColor(240, 240, 240))
        .bold_line_style(RGBColor(218, 218, 218))
        .draw()
        .map_err(de)?;

    let x_range = chart.x_range();
    let (xa, xb) = (x_range.start, x_range.end);
    // Lines and reference lines first; labels are placed afterwards around everything drawn.
    let mut obstacles = Obstacles::default();
    let ref_color = RGBColor(70, 70, 70);
    for l in &fig.ref_lines {
        chart
            .draw_series(DashedLineSeries::new(
                [(xa, l.y), (xb, l.y)],
                10,
                6,
                ref_color.stroke_width(2),
            ))
            .map_err(de)?;
        obstacles.add_polyline(&[
            chart.backend_coord(&(xa, l.y)),
            chart.backend_coord(&(xb, l.y)),
        ]);
    }
    for (k, s) in fig.series.iter().enumerate() {
        let c = SERIES_COLORS[k % SERIES_COLORS.len()];
        chart
            .draw_series(LineSeries::new(s.points.iter().copied(), c.stroke_width(2)))
            .map_err(de)?;
        let px: Vec<_> = s.points.iter().map(|p| chart.backend_coord(p)).collect();
        obstacles.add_polyline(&px);
        for &at in &px {
            root.draw(&marker(k, at, c)).map_err(de)?;
            obstacles
                .boxes
                .push((at.0 - 7, at.1 - 7, at.0 + 7, at.1 + 7));
        }
    }
    let (pxr, pyr) = chart.plotting_area().get_pixel_range();
    let bounds = (pxr.start, pyr.start, pxr.end, pyr.end);

    for l in &fig.ref_lines {
        let (x0, y) = chart.backend_coord(&(xa, l.y));
        let (x1, _) = chart.backend_coord(&(xb, l.y));
        let cands = [
            (x1 - 6, y - 4, HPos::Right, VPos::Bottom),
            (x0 + 6, y - 4, HPos::Left, VPos::Bottom),
            (x1 - 6, y + 4, HPos::Right, VPos::Top),
            (x0 + 6, y + 4, HPos::Left, VPos::Top),
        ];
        let style = text_c(15.0, ref_color);
        place_label(root, &l.label, &style, &cands, &mut obstacles, bounds)?;
    }
    for (k, s) in fig.series.iter().enumerate() {
        let style = text_c(13.0, darker(SERIES_COLORS[k % SERIES_COLORS.len()]));
        for (label, p) in s.labels.iter().zip(&s.points) {
            if label.is_empty() {
                continue;
            }
            let (x, y) = chart.backend_coord(p);
            let cands = [
                (x + 8, y - 6, HPos::Left, VPos::Bottom),
                (x + 8, y + 6, HPos::Left, VPos::Top),
                (x - 8, y - 6, HPos::Right, VPos::Bottom),
                (x - 8, y + 6, HPos::Right, VPos::Top),
                (x, y - 10, HPos::Center, VPos::Bottom),
                (x, y + 10, HPos::Center, VPos::Top),
                (x + 10, y, HPos::Left, VPos::Center),
                (x - 10, y, HPos::Right, VPos::Center),
            ];
            place_label(root, label, &style, &cands, &mut obstacles, bounds)?;
        }
    }

    // Legend in the corner where it covers the least.
    let entries: Vec<(Swatch, String)> = fig
        .series
        .iter()
        .enumerate()
        .map(|(k, s)| {
            (
                Swatch::LineMarker(SERIES_COLORS[k % SERIES_COLORS.len()], k),
                s.name.clone(),
            )
        })
        .collect();
    let (w, h) = legend_size(root, "", &entries)?;
    let m = 12;
    let corners = [
        (bounds.2 - m - w, bounds.1 + m),
        (bounds.0 + m, bounds.1 + m),
        (bounds.2 - m - w, bounds.3 - m - h),
        (bounds.0 + m, bounds.3 - m - h),
    ];
    let at = corners
        .into_iter()
        .min_by_key(|&(x, y)| obstacles.cost((x, y, x + w, y + h)))
        .unwrap_or(corners[0]);
    draw_legend(root, at, "", &entries)?;
    Ok(())
}
