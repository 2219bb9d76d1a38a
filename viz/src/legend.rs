//! Boxed legends and the swatches they show (also the shaded sphere disc and dashed envelopes).

use std::f64::consts::PI;

use plotters::prelude::*;
use plotters::style::text_anchor::{HPos, Pos, VPos};

use crate::render::{de, Area};
use crate::style::{marker, text};
use crate::PlotError;

pub(crate) enum Swatch {
    Line(RGBColor, u32),
    LineMarker(RGBColor, usize),
    PathMarkers(RGBColor),
    Dot(RGBColor),
    Ring(RGBColor),
    DashedRing(RGBColor),
    Sphere,
    Patch(RGBAColor),
}

pub(crate) const LEGEND_ROW: i32 = 26;

/// Width and height of a legend box (an empty heading takes no room).
pub(crate) fn legend_size(
    root: &Area,
    heading: &str,
    entries: &[(Swatch, String)],
) -> Result<(i32, i32), PlotError> {
    let mut width = root.estimate_text_size(heading, &text(16.0)).map_err(de)?.0 as i32;
    for (_, label) in entries {
        width = width.max(root.estimate_text_size(label, &text(15.0)).map_err(de)?.0 as i32 + 46);
    }
    let head = if heading.is_empty() { 6 } else { 34 };
    Ok((width + 20, head + 4 + LEGEND_ROW * entries.len() as i32))
}

/// Draws a boxed legend with its top-left corner at `(x, y)`; returns its bottom y.
pub(crate) fn draw_legend(
    root: &Area,
    (x, y): (i32, i32),
    heading: &str,
    entries: &[(Swatch, String)],
) -> Result<i32, PlotError> {
    let style = text(15.0);
    let row = LEGEND_ROW;
    let (w, height) = legend_size(root, heading, entries)?;
    let head = if heading.is_empty() { 6 } else { 34 };
    root.draw(&Rectangle::new(
        [(x, y), (x + w, y + height)],
        WHITE.filled(),
    ))
    .map_err(de)?;
    root.draw(&Rectangle::new(
        [(x, y), (x + w, y + height)],
        RGBColor(150, 150, 150).stroke_width(1),
    ))
    .map_err(de)?;
    if !heading.is_empty() {
        root.draw(&Text::new(heading.to_string(), (x + 10, y + 8), text(16.0)))
            .map_err(de)?;
    }
    for (i, (sw, label)) in entries.iter().enumerate() {
        let cy = y + head + row * i as i32 + row / 2;
        let sx = x + 10;
        match sw {
            Swatch::Line(c, w) => {
                root.draw(&PathElement::new(
                    vec![(sx, cy), (sx + 30, cy)],
                    c.stroke_width(*w),
                ))
                .map_err(de)?;
            }
            Swatch::LineMarker(c, k) => {
                root.draw(&PathElement::new(
                    vec![(sx, cy), (sx + 30, cy)],
                    c.stroke_width(2),
                ))
                .map_err(de)?;
                root.draw(&marker(*k, (sx + 15, cy), *c)).map_err(de)?;
            }
            Swatch::PathMarkers(c) => {
                root.draw(&PathElement::new(
                    vec![(sx, cy), (sx + 30, cy)],
                    c.stroke_width(4),
                ))
                .map_err(de)?;
                root.draw(&Circle::new((sx + 15, cy), 5, c.filled()))
                    .map_err(de)?;
                root.draw(&Circle::new((sx + 15, cy), 5, BLACK.stroke_width(1)))
                    .map_err(de)?;
            }
            Swatch::Dot(c) => {
                root.draw(&Circle::new((sx + 15, cy), 6, c.filled()))
                    .map_err(de)?;
                root.draw(&Circle::new((sx + 15, cy), 6, BLACK.stroke_width(1)))
                    .map_err(de)?;
            }
            Swatch::Ring(c) => {
                root.draw(&Circle::new((sx + 15, cy), 7, c.stroke_width(2)))
                    .map_err(de)?;
            }
            Swatch::DashedRing(c) => {
                draw_shaded_disc(root, (sx + 15, cy), 6)?;
                draw_dashed_envelope(root, &[((sx + 15, cy), 10.0)], *c)?;
            }
            Swatch::Sphere => draw_shaded_disc(root, (sx + 15, cy), 10)?,
            Swatch::Patch(c) => {
                root.draw(&Rectangle::new(
                    [(sx + 2, cy - 8), (sx + 28, cy + 8)],
                    c.filled(),
                ))
                .map_err(de)?;
                root.draw(&Rectangle::new(
                    [(sx + 2, cy - 8), (sx + 28, cy + 8)],
                    RGBColor(120, 110, 90).stroke_width(1),
                ))
                .map_err(de)?;
            }
        }
        root.draw(&Text::new(
            label.clone(),
            (sx + 40, cy),
            style.pos(Pos::new(HPos::Left, VPos::Center)),
        ))
        .map_err(de)?;
    }
    Ok(y + height)
}

/// The outline of the union of circles (centre, radius in pixels), dashed (dashes of about 6 px).
pub(crate) fn draw_dashed_envelope(
    root: &Area,
    circles: &[((i32, i32), f64)],
    color: RGBColor,
) -> Result<(), PlotError> {
    for (i, &((cx, cy), r)) in circles.iter().enumerate() {
        let n = ((2.0 * PI * r / 6.0).round() as usize).max(8) & !1;
        let at = |k: usize| {
            let a = 2.0 * PI * k as f64 / n as f64;
            (cx as f64 + r * a.cos(), cy as f64 + r * a.sin())
        };
        let inside_other = |p: (f64, f64)| {
            circles.iter().enumerate().any(|(j, &((ox, oy), or))| {
                j != i && (p.0 - ox as f64).hypot(p.1 - oy as f64) < or - 0.5
            })
        };
        for k in (0..n).step_by(2) {
            let (a, b) = (at(k), at(k + 1));
            if inside_other(a) || inside_other(b) {
                continue;
            }
            let px = |p: (f64, f64)| (p.0.round() as i32, p.1.round() as i32);
            root.draw(&PathElement::new(vec![px(a), px(b)], color.stroke_width(1)))
                .map_err(de)?;
        }
    }
    Ok(())
}

/// A grey disc shaded like a sphere lit from the upper left.
pub(crate) fn draw_shaded_disc(root: &Area, (cx, cy): (i32, i32), r: i32) -> Result<(), PlotError> {
    let r = r.max(2);
    let (dark, light) = ((105.0, 110.0, 125.0), (238.0, 238.0, 242.0));
    root.draw(&Circle::new(
        (cx, cy),
        r,
        RGBColor(dark.0 as u8, dark.1 as u8, dark.2 as u8).filled(),
    ))
    .map_err(de)?;
    let steps = 7;
    for k in 1..=steps {
        let t = k as f64 / steps as f64;
        let rr = (r as f64 * (1.0 - 0.85 * t)).round() as i32;
        let off = (r as f64 * 0.35 * t).round() as i32;
        let mix = |a: f64, b: f64| (a + (b - a) * t) as u8;
        let c = RGBColor(
            mix(dark.0, light.0),
            mix(dark.1, light.1),
            mix(dark.2, light.2),
        );
        root.draw(&Circle::new((cx - off, cy - off), rr.max(1), c.filled()))
            .map_err(de)?;
    }
    root.draw(&Circle::new(
        (cx, cy),
        r,
        RGBColor(60, 60, 70).stroke_width(1),
    ))
    .map_err(de)?;
    Ok(())
}
