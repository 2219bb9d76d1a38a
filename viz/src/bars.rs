//! Grouped bar charts.

use std::path::Path;

use plotters::coord::ranged1d::{AsRangedCoord, ValueFormatter};
use plotters::prelude::*;
use plotters::style::text_anchor::{HPos, Pos, VPos};

use crate::format::fmt_num;
use crate::render::{check_finite, de, render, Area};
use crate::style::*;
use crate::PlotError;

/// A grouped bar chart for [`draw_bar_chart`].
#[derive(Debug, Clone)]
pub struct BarChart {
    /// Figure title.
    pub title: String,
    /// Y-axis label (the padding note is appended automatically when `pad > 0`).
    pub y_label: String,
    /// One group of bars per entry (e.g. per variant `"G+αT"`), one value per series.
    pub groups: Vec<(String, Vec<f64>)>,
    /// Series names (e.g. `G`, `αT`, `βE`), one colour each, shown in the legend.
    pub series_names: Vec<String>,
    /// Added to every value before drawing so that tiny values stay visible (the paper uses 0.1);
    /// the numbers printed above the bars are the unpadded values.
    pub pad: f64,
    /// Logarithmic y axis.
    pub log_y: bool,
}

/// Draws grouped bars (one group per entry of `fig.groups`, one coloured bar per series) to a PNG
/// (900×600), like the paper's `quantitative_result` chart: bar heights are `value + pad`, the
/// unpadded value is printed above each bar, optional logarithmic y axis, legend.
pub fn draw_bar_chart(fig: &BarChart, path: &Path) -> Result<(), PlotError> {
    let ns = fig.series_names.len();
    if fig.groups.is_empty() || ns == 0 {
        return Err(PlotError::InvalidData(
            "a bar chart needs at least one group and one series".into(),
        ));
    }
    check_finite("pad", fig.pad)?;
    for (g, vals) in &fig.groups {
        if vals.len() != ns {
            return Err(PlotError::InvalidData(format!(
                "group \"{g}\" has {} values but there are {ns} series",
                vals.len()
            )));
        }
        for (s, v) in vals.iter().enumerate() {
            check_finite(
                &format!("value of \"{}\" in \"{g}\"", fig.series_names[s]),
                *v,
            )?;
            if fig.log_y && v + fig.pad <= 0.0 {
                return Err(PlotError::InvalidData(format!(
                    "value of \"{}\" in \"{g}\" plus pad is {} ≤ 0, which a log axis cannot show",
                    fig.series_names[s],
                    v + fig.pad
                )));
            }
        }
    }
    let padded = fig
        .groups
        .iter()
        .flat_map(|(_, v)| v.iter().map(|x| x + fig.pad));
    let (lo, hi) = padded.fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), v| {
        (a.min(v), b.max(v))
    });
    render(path, SIZE_2D, |root| {
        let y_desc = if fig.pad > 0.0 {
            format!("{} (+{} padding)", fig.y_label, fmt_num(fig.pad))
        } else {
            fig.y_label.clone()
        };
        let note = if fig.pad > 0.0 {
            format!(
            "Bar height = value + {} (dashed line: value 0), so that small values stay visible; numbers above the bars are the unpadded values.",
            fmt_num(fig.pad)
        )
        } else {
            "Numbers above the bars are the values.".to_string()
        };
        let (main, foot) = root.split_vertically(SIZE_2D.1 as i32 - 28);
        foot.draw(&Text::new(
            note,
            (SIZE_2D.0 as i32 / 2, 8),
            text_c(13.0, RGBColor(80, 80, 80)).pos(Pos::new(HPos::Center, VPos::Top)),
        ))
        .map_err(de)?;
        let ng = fig.groups.len() as f64;
        if fig.log_y {
            let y0 = lo / 2.0;
            let y1 = hi * 4.0;
            bar_body(&main, fig, (0.0..ng, (y0..y1).log_scale()), y0, &y_desc)?;
        } else {
            let y0 = lo.min(0.0);
            let span = hi.max(0.0) - y0;
            let y1 = if span > 1e-12 {
                hi.max(0.0) + 0.15 * span
            } else {
                1.0
            };
            let y0 = if y0 < 0.0 { y0 - 0.05 * (y1 - y0) } else { y0 };
            bar_body(&main, fig, (0.0..ng, y0..y1), 0.0f64.max(y0), &y_desc)?;
        }
        Ok(())
    })
}

pub(crate) fn bar_body<YR>(
    area: &Area,
    fig: &BarChart,
    (xr, yr): (std::ops::Range<f64>, YR),
    base: f64,
    y_desc: &str,
) -> Result<(), PlotError>
where
    YR: AsRangedCoord<Value = f64>,
    YR::CoordDescType: Ranged<ValueType = f64> + ValueFormatter<f64>,
{
    let mut chart = ChartBuilder::on(area)
        .caption(&fig.title, text(22.0))
        .margin(15)
        .x_label_area_size(40)
        .y_label_area_size(80)
        .build_cartesian_2d(xr, yr)
        .map_err(de)?;
    let fmt_y = |v: &f64| fmt_num(*v);
    let fmt_none = |_: &f64| String::new();
    chart
        .configure_mesh()
        .disable_x_mesh()
        .x_labels(0)
        .x_label_formatter(&fmt_none)
        .y_label_formatter(&fmt_y)
        .y_desc(y_desc)
        .axis_desc_style(text(16.0))
        .label_style(text(14.0))
        .y_max_light_lines(if fig.log_y { 9 } else { 1 })
        .light_line_style(RGBColor(242, 242, 242))
        .bold_line_style(RGBColor(215, 215, 215))
        .draw()
        .map_err(de)?;
    let ns = fig.series_names.len() as f64;
    let width = 0.8 / ns;
    let (y_lo, _) = {
        let r = chart.plotting_area().get_pixel_range();
        (r.1.end, r.1.start)
    };
    for (g, (name, vals)) in fig.groups.iter().enumerate() {
        for (s, &v) in vals.iter().enumerate() {
            let x0 = g as f64 + 0.1 + width * s as f64;
            let x1 = x0 + width;
            let c = BAR_COLORS[s % BAR_COLORS.len()];
            let top = v + fig.pad;
            let bar =
                |style: ShapeStyle| Rectangle::new([(x0 + 0.01, base), (x1 - 0.01, top)], style);
            chart
                .draw_series([bar(c.filled()), bar(BLACK.stroke_width(1))])
                .map_err(de)?;
            let (cx, ty) = chart.backend_coord(&((x0 + x1) / 2.0, top.max(base)));
            area.draw(&Text::new(
                fmt_num(v),
                (
                    cx - area.get_base_pixel().0,
                    ty - 4 - area.get_base_pixel().1,
                ),
                text(12.0).pos(Pos::new(HPos::Center, VPos::Bottom)),
            ))
            .map_err(de)?;
        }
        let (gx, _) = chart.backend_coord(&(g as f64 + 0.5, base));
        area.draw(&Text::new(
            name.clone(),
            (
                gx - area.get_base_pixel().0,
                y_lo + 10 - area.get_base_pixel().1,
            ),
            text(17.0).pos(Pos::new(HPos::Center, VPos::Top)),
        ))
        .map_err(de)?;
    }
    if fig.pad > 0.0 {
        let ng = fig.groups.len() as f64;
        chart
            .draw_series(DashedLineSeries::new(
                [(0.0, fig.pad), (ng, fig.pad)],
                6,
                4,
                RGBColor(60, 60, 60).stroke_width(1),
            ))
            .map_err(de)?;
    }
    // Legend (plotters' own, anchored top-right).
    for (s, name) in fig.series_names.iter().enumerate() {
        let c = BAR_COLORS[s % BAR_COLORS.len()];
        chart
            .draw_series(std::iter::empty::<Rectangle<(f64, f64)>>())
            .map_err(de)?
            .label(name.clone())
            .legend(move |(x, y)| Rectangle::new([(x, y - 7), (x + 18, y + 7)], c.filled()));
    }
    chart
        .configure_series_labels()
        .position(SeriesLabelPosition::UpperRight)
        .label_font(text(15.0))
        .background_style(WHITE.mix(0.9))
        .border_style(RGBColor(150, 150, 150))
        .draw()
        .map_err(de)?;
    Ok(())
}
