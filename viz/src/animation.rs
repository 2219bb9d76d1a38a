//! Animated GIFs of a rollout: one 3-D view per step, all on the same axes box, drawn by the same
//! renderer as [`crate::draw_trajectory_3d`].

use std::path::Path;

use crate::render::{draw_rgb, write_atomic};
use crate::style::SIZE_3D;
use crate::trajectory::view3d::view_3d;
use crate::trajectory::{trajectory_bounds, validate_trajectory};
use crate::{PlotError, TrajectoryFigure};

/// Writes `frames` (e.g. one figure per time step) as a looping animated GIF of 1000×800 frames,
/// each shown `delay_cs` hundredths of a second; every frame uses the axes box of all of them, so
/// the camera stays put. Each frame gets its own 256-colour palette (NeuQuant, deterministic).
/// Written atomically; the file name must end in `.gif`.
pub fn draw_trajectory_gif(
    frames: &[TrajectoryFigure],
    delay_cs: u16,
    path: &Path,
) -> Result<(), PlotError> {
    let write_err = |message: String| PlotError::Write {
        path: path.to_path_buf(),
        message,
    };
    match path.extension().and_then(|e| e.to_str()) {
        Some(e) if e.eq_ignore_ascii_case("gif") => {}
        _ => return Err(write_err("the file name must end in .gif".into())),
    }
    if frames.is_empty() {
        return Err(PlotError::InvalidData(
            "an animation needs at least one frame".into(),
        ));
    }
    for fig in frames {
        validate_trajectory(fig)?;
    }
    let mut b = trajectory_bounds(&frames[0]);
    for fig in &frames[1..] {
        let o = trajectory_bounds(fig);
        for a in 0..3 {
            b[a] = [b[a][0].min(o[a][0]), b[a][1].max(o[a][1])];
        }
    }
    let (w, h) = (SIZE_3D.0 as u16, SIZE_3D.1 as u16);
    let mut bytes = Vec::new();
    {
        let mut encoder =
            gif::Encoder::new(&mut bytes, w, h, &[]).map_err(|e| write_err(e.to_string()))?;
        encoder
            .set_repeat(gif::Repeat::Infinite)
            .map_err(|e| write_err(e.to_string()))?;
        for fig in frames {
            let rgb = draw_rgb(SIZE_3D, |root| view_3d(root, fig, &b))?;
            // Speed 10 of 30: a good palette at a tenth of a second per frame.
            let mut frame = gif::Frame::from_rgb_speed(w, h, &rgb, 10);
            frame.delay = delay_cs;
            encoder
                .write_frame(&frame)
                .map_err(|e| write_err(e.to_string()))?;
        }
    }
    write_atomic(path, &bytes)
}
