//! Depth-sortable primitives (cloth quads and edges, paths, markers, spheres) and the painter's
//! algorithm that draws them farthest first.

use plotters::coord::cartesian::Cartesian3d;
use plotters::coord::types::RangedCoordf64;
use plotters::prelude::*;

use crate::legend::draw_shaded_disc;
use crate::render::{de, Area};
use crate::style::*;
use crate::{ClothPiece, PlotError, Solid, SolidRole, Sphere, TrajectoryFigure};

pub(crate) type Coord3 = Cartesian3d<RangedCoordf64, RangedCoordf64, RangedCoordf64>;

/// Maps world points to pixels for one view.
pub(crate) trait Projector {
    fn px(&self, p: [f64; 3]) -> (i32, i32);
    /// Larger = farther from the viewer (drawn first).
    fn depth(&self, p: [f64; 3]) -> f64;
    /// Pixels per world unit (the same in every direction).
    fn px_per_unit(&self) -> f64;
}

pub(crate) struct AxonometricView<'c> {
    pub(crate) coord: &'c Coord3,
    pub(crate) scale: f64,
}

impl Projector for AxonometricView<'_> {
    fn px(&self, p: [f64; 3]) -> (i32, i32) {
        self.coord.translate(&(p[0], p[2], -p[1]))
    }
    fn depth(&self, p: [f64; 3]) -> f64 {
        self.coord.projected_depth(&p[0], &p[2], &-p[1]) as f64
    }
    fn px_per_unit(&self) -> f64 {
        self.scale
    }
}

pub(crate) struct TopView<'c> {
    pub(crate) coord: &'c Cartesian2d<RangedCoordf64, RangedCoordf64>,
    pub(crate) scale: f64,
}

impl Projector for TopView<'_> {
    fn px(&self, p: [f64; 3]) -> (i32, i32) {
        self.coord.translate(&(p[0], p[1]))
    }
    fn depth(&self, p: [f64; 3]) -> f64 {
        -p[2]
    }
    fn px_per_unit(&self) -> f64 {
        self.scale
    }
}

pub(crate) enum Prim {
    Quad([[f64; 3]; 4], RGBAColor),
    Segment([f64; 3], [f64; 3], RGBColor, u32),
    Ball(Sphere),
    /// One triangle of a [`Solid`], already shaded.
    Tri([[f64; 3]; 3], RGBColor),
    Marker([f64; 3], RGBColor, i32),
}

pub(crate) fn mid(a: [f64; 3], b: [f64; 3]) -> [f64; 3] {
    [
        (a[0] + b[0]) / 2.0,
        (a[1] + b[1]) / 2.0,
        (a[2] + b[2]) / 2.0,
    ]
}

/// Cloth wireframes, control paths and spheres as depth-sortable primitives.
pub(crate) fn scene_prims(fig: &TrajectoryFigure) -> Vec<Prim> {
    let pieces = fig.cloth_pieces();
    let mut prims = Vec::new();
    for (k, (frame, _)) in fig.frames.iter().enumerate() {
        let c = FRAME_COLORS[k % FRAME_COLORS.len()];
        for piece in &pieces {
            prims.push(match *piece {
                ClothPiece::Face(face) => Prim::Quad(face.map(|p| frame[p]), c.mix(0.10)),
                ClothPiece::Edge([a, b]) => Prim::Segment(frame[a], frame[b], c, 1),
            });
        }
    }
    for (k, path) in fig.control_paths.iter().enumerate() {
        let c = PATH_COLORS[k % PATH_COLORS.len()];
        for w in path.windows(2) {
            prims.push(Prim::Segment(w[0], w[1], c, 4));
        }
        for &p in path {
            prims.push(Prim::Marker(p, c, 5));
        }
    }
    for &s in fig.spheres {
        prims.push(Prim::Ball(s));
    }
    for solid in fig.solids {
        solid_prims(solid, &mut prims);
    }
    prims
}

pub(crate) fn prim_depth(proj: &dyn Projector, p: &Prim) -> f64 {
    match p {
        Prim::Quad(q, _) => {
            let c = mid(mid(q[0], q[2]), mid(q[1], q[3]));
            proj.depth(c)
        }
        Prim::Segment(a, b, _, _) => proj.depth(mid(*a, *b)),
        Prim::Ball(s) => proj.depth(s.center),
        Prim::Tri(t, _) => proj.depth(centroid(t)),
        Prim::Marker(p, _, _) => proj.depth(*p) - 1e-3,
    }
}

/// Farthest first (painter's algorithm); ties keep their order.
pub(crate) fn paint_order(proj: &dyn Projector, prims: Vec<Prim>) -> Vec<Prim> {
    let mut items: Vec<(f64, Prim)> = prims
        .into_iter()
        .map(|p| (prim_depth(proj, &p), p))
        .collect();
    items.sort_by(|a, b| b.0.total_cmp(&a.0));
    items.into_iter().map(|(_, p)| p).collect()
}

pub(crate) fn render_prims(
    root: &Area,
    proj: &dyn Projector,
    prims: Vec<Prim>,
) -> Result<(), PlotError> {
    for p in paint_order(proj, prims) {
        match p {
            Prim::Quad(q, c) => {
                let pts: Vec<_> = q.iter().map(|&v| proj.px(v)).collect();
                root.draw(&Polygon::new(pts, c.filled())).map_err(de)?;
            }
            Prim::Segment(a, b, c, w) => {
                root.draw(&PathElement::new(
                    vec![proj.px(a), proj.px(b)],
                    c.stroke_width(w),
                ))
                .map_err(de)?;
            }
            Prim::Tri(t, c) => {
                let pts: Vec<_> = t.iter().map(|&v| proj.px(v)).collect();
                root.draw(&Polygon::new(pts.clone(), c.filled()))
                    .map_err(de)?;
                // The outline in the same colour closes the hairline gaps between neighbours.
                root.draw(&PathElement::new(
                    vec![pts[0], pts[1], pts[2], pts[0]],
                    c.stroke_width(1),
                ))
                .map_err(de)?;
            }
            Prim::Ball(s) => {
                let r = (s.radius * proj.px_per_unit()).round() as i32;
                draw_shaded_disc(root, proj.px(s.center), r)?;
            }
            Prim::Marker(p, c, r) => {
                let at = proj.px(p);
                root.draw(&Circle::new(at, r, c.filled())).map_err(de)?;
                root.draw(&Circle::new(at, r, BLACK.stroke_width(1)))
                    .map_err(de)?;
            }
        }
    }
    Ok(())
}

/// The base colour of a solid of `role`.
pub(crate) fn solid_color(role: SolidRole) -> RGBColor {
    match role {
        SolidRole::Safety => SOLID_SAFETY,
        SolidRole::Collider => SOLID_COLLIDER,
        SolidRole::Both => SOLID_BOTH,
    }
}

/// The triangles of `solid`, each flat-shaded by the angle between its normal and a fixed light
/// from the upper left (either side lit alike, so the winding does not matter).
fn solid_prims(solid: &Solid, prims: &mut Vec<Prim>) {
    let base = solid_color(solid.role);
    let light = {
        let l: [f64; 3] = [-0.3, -0.5, 0.8];
        let n = (l[0] * l[0] + l[1] * l[1] + l[2] * l[2]).sqrt();
        l.map(|v| v / n)
    };
    for t in &solid.triangles {
        let [a, b, c] = t.map(|i| solid.vertices[i]);
        let (u, v) = (sub(b, a), sub(c, a));
        let n = [
            u[1] * v[2] - u[2] * v[1],
            u[2] * v[0] - u[0] * v[2],
            u[0] * v[1] - u[1] * v[0],
        ];
        let len = (n[0] * n[0] + n[1] * n[1] + n[2] * n[2]).sqrt();
        let lit = if len > 0.0 {
            ((n[0] * light[0] + n[1] * light[1] + n[2] * light[2]) / len).abs()
        } else {
            0.0
        };
        let k = 0.55 + 0.45 * lit;
        let shade = |x: u8| (f64::from(x) * k).round() as u8;
        prims.push(Prim::Tri(
            [a, b, c],
            RGBColor(shade(base.0), shade(base.1), shade(base.2)),
        ));
    }
}

fn sub(a: [f64; 3], b: [f64; 3]) -> [f64; 3] {
    [a[0] - b[0], a[1] - b[1], a[2] - b[2]]
}

fn centroid(t: &[[f64; 3]; 3]) -> [f64; 3] {
    std::array::from_fn(|k| (t[0][k] + t[1][k] + t[2][k]) / 3.0)
}
