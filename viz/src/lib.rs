//! viz: figures of cloth manipulation plans — plain data in, picture out (PNG, GIF, HTML).
//!
//! Every function takes plain numbers (`[f64; 3]` positions, `(x, y)` pairs, bar values) and writes one
//! file (atomically); nothing here knows about the simulator or the optimizer, so any caller can draw
//! with it.
//!
//! - [`draw_trajectory_3d`] and [`draw_trajectory_top`]: a cloth manipulation trajectory (cloth frames as
//!   wireframes, control-point paths, obstacle spheres with the δ margin, [`Solid`] obstacles as
//!   shaded triangle meshes, targets, ground) in an
//!   axonometric 3-D view and seen from above, like the paper's Fig. 4 (`delta_result`);
//!   [`draw_trajectory_panels`] puts several trajectories side by side on the same axes, like its
//!   Fig. 5 (`qualitative_result`).
//! - [`draw_bar_chart`]: grouped bars of padded cost terms per variant, like the paper's
//!   `quantitative_result` chart.
//! - [`draw_xy`]: lines with markers, optional per-point labels, labelled horizontal reference lines and
//!   logarithmic axes (e.g. gradient error against time).
//! - [`draw_trajectory_gif`]: an animated GIF, one 3-D view per step on fixed axes.
//! - [`write_rollout_html`]: a self-contained page to watch a [`Rollout`] (orbit, time slider, play,
//!   the closest approach to the obstacles per step).
//!
//! Modules: `text` (font, text layout), `legend`, `trajectory` (3-D and top views, depth-sorted
//! primitives), `bars`, `xy`, `labels` (label placement), `animation` (GIF), `html` (viewer),
//! `render` (canvas, PNG, atomic writes).
//!
//! Text is rendered with DejaVu Sans, embedded in the binary (`viz/assets/fonts/`), so drawing needs no
//! system fonts.

use std::path::PathBuf;

mod animation;
mod bars;
mod format;
mod html;
mod labels;
mod legend;
mod render;
mod style;
mod text;
mod trajectory;
mod xy;

pub use animation::draw_trajectory_gif;
pub use bars::{draw_bar_chart, BarChart};
pub use html::{grid_triangles, rollout_html, write_rollout_html, Closest, Rollout};
pub use render::write_atomic;
pub use trajectory::top::draw_trajectory_top;
pub use trajectory::view3d::{draw_trajectory_3d, draw_trajectory_panels};
pub use xy::{draw_xy, RefLine, Series, XyFigure};

/// An error while drawing a figure.
#[derive(Debug, thiserror::Error)]
pub enum PlotError {
    /// The figure's data cannot be drawn (wrong sizes, NaN, non-positive values on a log axis, …).
    #[error("invalid figure data: {0}")]
    InvalidData(String),
    /// The PNG could not be written (missing directory, permissions, unsupported extension, …).
    #[error("cannot write {path}: {message}")]
    Write {
        /// The file that was being written.
        path: PathBuf,
        /// What went wrong.
        message: String,
    },
    /// Drawing into the in-memory bitmap failed.
    #[error("drawing failed: {0}")]
    Draw(String),
    /// The embedded font could not be parsed.
    #[error("the embedded font could not be loaded")]
    Font,
}

/// An obstacle sphere.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Sphere {
    /// Centre `[x, y, z]`.
    pub center: [f64; 3],
    /// Radius (> 0).
    pub radius: f64,
}

/// What an obstacle is for: a safety obstacle (the cloth keeps δ away), a collider (the cloth
/// cannot pass through it) or both. It sets the colour of a [`Solid`].
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum SolidRole {
    /// Only the safety margin keeps the cloth away (blue-grey).
    Safety,
    /// The simulator pushes the cloth out of it (sand).
    Collider,
    /// Both (grey).
    Both,
}

/// A generic obstacle: a closed triangle mesh (e.g. a tessellated capsule, box or mesh obstacle),
/// drawn as flat-shaded triangles, depth-sorted with the cloth, paths and spheres.
#[derive(Debug, Clone, PartialEq)]
pub struct Solid {
    /// Vertex positions `[x, y, z]`.
    pub vertices: Vec<[f64; 3]>,
    /// Triangles as indices into `vertices`, counter-clockwise seen from outside.
    pub triangles: Vec<[usize; 3]>,
    /// What the obstacle is for (its colour).
    pub role: SolidRole,
    /// The obstacle's kind for the legend, e.g. `"capsule"`, `"box"`, `"mesh"`.
    pub kind: String,
}

/// The viewing direction of [`draw_trajectory_3d`] (an orthographic, axonometric view with equal scale
/// on all three axes; `z` is drawn upwards).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct View3d {
    /// Rotation about the vertical (`z`) axis in radians: 0 looks along `+y` (camera on the `−y` side),
    /// positive values swing the camera towards `+x`.
    pub yaw: f64,
    /// Elevation of the camera above the horizontal plane in radians (0 = side view, π/2 = top view).
    pub pitch: f64,
}

impl Default for View3d {
    /// Three-quarter view from the `−y`/`+x` side and above (yaw ≈ 52°, pitch ≈ 29°): `+y` runs from
    /// left to right across the picture, so a trajectory along `y` reads left to right.
    fn default() -> Self {
        View3d {
            yaw: 0.9,
            pitch: 0.5,
        }
    }
}

/// One piece of a drawn cloth frame ([`TrajectoryFigure::cloth_pieces`]).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum ClothPiece {
    /// A translucent face through four particles (a triangle repeats its last one).
    Face([usize; 4]),
    /// A line between two particles.
    Edge([usize; 2]),
}

/// A cloth trajectory to draw with [`draw_trajectory_3d`] or [`draw_trajectory_top`].
#[derive(Debug, Clone)]
pub struct TrajectoryFigure<'a> {
    /// Figure title.
    pub title: String,
    /// Cloth grid `(rows, cols)`; particle `p = r * cols + c`, used to draw each frame as a wireframe.
    /// Ignored when `cloth_triangles` is not empty.
    pub grid: (usize, usize),
    /// The triangles of a cloth of any shape (particle indices into every frame); when not empty
    /// each frame is drawn from them (faces and edges) instead of from `grid`.
    pub cloth_triangles: &'a [[usize; 3]],
    /// Cloth states to draw (e.g. initial, intermediate, final), each with its legend label.
    pub frames: Vec<(&'a [[f64; 3]], String)>,
    /// Path of each control point over the steps (`T + 1` points each).
    pub control_paths: Vec<Vec<[f64; 3]>>,
    /// Obstacle spheres (may be empty).
    pub spheres: &'a [Sphere],
    /// Obstacles as closed triangle meshes (may be empty); the δ outline is drawn for spheres only.
    pub solids: &'a [Solid],
    /// Target positions, drawn as red points.
    pub targets: &'a [[f64; 3]],
    /// Particles that should reach the targets; ringed in red on the last frame (may be empty).
    pub target_particles: &'a [usize],
    /// Height of the ground plane, drawn in the 3-D view if `Some`.
    pub ground_z: Option<f64>,
    /// Safety threshold δ: if `Some`, the outline of the obstacle grown by δ (every sphere at radius
    /// `r + δ`, as projected) is drawn dashed red: the zone the cloth is meant to stay out of.
    pub safety_margin: Option<f64>,
    /// Viewing direction of the 3-D view.
    pub view: View3d,
}

impl TrajectoryFigure<'_> {
    /// The cloth's pieces in drawing order, as particle indices: a grid's quads `[a, b, e, d]`
    /// with its row and column edges, cell by cell; a mesh's triangles as `[a, b, c, c]`, then
    /// every triangle edge once.
    pub fn cloth_pieces(&self) -> Vec<ClothPiece> {
        let mut pieces = Vec::new();
        if self.cloth_triangles.is_empty() {
            let (rows, cols) = self.grid;
            for r in 0..rows {
                for c in 0..cols {
                    let p = r * cols + c;
                    if r + 1 < rows && c + 1 < cols {
                        pieces.push(ClothPiece::Face([p, p + 1, p + cols + 1, p + cols]));
                    }
                    if c + 1 < cols {
                        pieces.push(ClothPiece::Edge([p, p + 1]));
                    }
                    if r + 1 < rows {
                        pieces.push(ClothPiece::Edge([p, p + cols]));
                    }
                }
            }
        } else {
            let mut seen = std::collections::HashSet::new();
            for t in self.cloth_triangles {
                pieces.push(ClothPiece::Face([t[0], t[1], t[2], t[2]]));
            }
            for t in self.cloth_triangles {
                for k in 0..3 {
                    let (a, b) = (t[k], t[(k + 1) % 3]);
                    if seen.insert([a.min(b), a.max(b)]) {
                        pieces.push(ClothPiece::Edge([a, b]));
                    }
                }
            }
        }
        pieces
    }

    /// Particles every frame must have: `rows·cols` for a grid, one more than the largest index
    /// of `cloth_triangles` otherwise (at least).
    fn cloth_particles(&self) -> usize {
        if self.cloth_triangles.is_empty() {
            self.grid.0 * self.grid.1
        } else {
            self.cloth_triangles
                .iter()
                .flatten()
                .max()
                .map_or(0, |&m| m + 1)
        }
    }
}

impl Default for TrajectoryFigure<'_> {
    /// An empty figure with the default view; fill in the fields you need.
    fn default() -> Self {
        TrajectoryFigure {
            title: String::new(),
            grid: (0, 0),
            cloth_triangles: &[],
            frames: Vec::new(),
            control_paths: Vec::new(),
            spheres: &[],
            solids: &[],
            targets: &[],
            target_particles: &[],
            ground_z: None,
            safety_margin: None,
            view: View3d::default(),
        }
    }
}

#[cfg(test)]
mod tests;
