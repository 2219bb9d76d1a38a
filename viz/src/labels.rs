//! Label placement: put each label where it covers the least of what is already drawn.

use plotters::prelude::*;
use plotters::style::text_anchor::{HPos, Pos, VPos};

use crate::render::{de, Area};
use crate::PlotError;

/// Pixel boxes already covered by markers, lines and labels, for placing labels where they collide
/// the least.
#[derive(Default)]
pub(crate) struct Obstacles {
    pub(crate) boxes: Vec<(i32, i32, i32, i32)>,
    labels: Vec<(i32, i32, i32, i32)>,
    line_points: Vec<(i32, i32)>,
}

impl Obstacles {
    pub(crate) fn add_polyline(&mut self, pts: &[(i32, i32)]) {
        for w in pts.windows(2) {
            let (a, b) = (w[0], w[1]);
            let len = (((b.0 - a.0).pow(2) + (b.1 - a.1).pow(2)) as f64).sqrt();
            let n = (len / 3.0).ceil().max(1.0) as i32;
            for i in 0..=n {
                let t = i as f64 / n as f64;
                self.line_points.push((
                    a.0 + ((b.0 - a.0) as f64 * t).round() as i32,
                    a.1 + ((b.1 - a.1) as f64 * t).round() as i32,
                ));
            }
        }
    }

    pub(crate) fn cost(&self, r: (i32, i32, i32, i32)) -> i64 {
        let hit = |o: &(i32, i32, i32, i32)| {
            let w = (r.2.min(o.2) - r.0.max(o.0)).max(0) as i64;
            let h = (r.3.min(o.3) - r.1.max(o.1)).max(0) as i64;
            w * h
        };
        let labels: i64 = self.labels.iter().map(hit).sum::<i64>() * 20;
        let boxes: i64 = self.boxes.iter().map(hit).sum::<i64>() * 8;
        let lines = self
            .line_points
            .iter()
            .filter(|p| p.0 >= r.0 && p.0 <= r.2 && p.1 >= r.1 && p.1 <= r.3)
            .count() as i64
            * 30;
        labels + boxes + lines
    }
}

/// Draws `label` at the candidate anchor that collides least with `obs` (earlier candidates win
/// ties; leaving the plot area is expensive), and records its box.
pub(crate) fn place_label(
    root: &Area,
    label: &str,
    style: &TextStyle,
    cands: &[(i32, i32, HPos, VPos)],
    obs: &mut Obstacles,
    bounds: (i32, i32, i32, i32),
) -> Result<(), PlotError> {
    let (w, h) = root.estimate_text_size(label, style).map_err(de)?;
    let (w, h) = (w as i32, h as i32);
    let rect = |&(x, y, hp, vp): &(i32, i32, HPos, VPos)| {
        let x0 = match hp {
            HPos::Left => x,
            HPos::Center => x - w / 2,
            HPos::Right => x - w,
        };
        let y0 = match vp {
            VPos::Top => y,
            VPos::Center => y - h / 2,
            VPos::Bottom => y - h,
        };
        (x0, y0, x0 + w, y0 + h)
    };
    let cost = |i: usize| {
        let r = rect(&cands[i]);
        let outside = (bounds.0 - r.0).max(0)
            + (r.2 - bounds.2).max(0)
            + (bounds.1 - r.1).max(0)
            + (r.3 - bounds.3).max(0);
        obs.cost(r) + outside as i64 * 1000 + i as i64
    };
    let Some(i) = (0..cands.len()).min_by_key(|&i| cost(i)) else {
        return Ok(());
    };
    let (x, y, hp, vp) = cands[i];
    obs.labels.push(rect(&cands[i]));
    root.draw(&Text::new(
        label.to_string(),
        (x, y),
        style.pos(Pos::new(hp, vp)),
    ))
    .map_err(de)?;
    Ok(())
}
