//! Colours, sizes, text styles and marker shapes shared by every figure.

use plotters::prelude::*;

pub(crate) const SIZE_3D: (u32, u32) = (1000, 800);
pub(crate) const SIZE_2D: (u32, u32) = (900, 600);

pub(crate) const FRAME_COLORS: [RGBColor; 7] = [
    RGBColor(31, 119, 180),
    RGBColor(255, 127, 14),
    RGBColor(40, 40, 40),
    RGBColor(23, 190, 207),
    RGBColor(140, 86, 75),
    RGBColor(227, 119, 194),
    RGBColor(188, 189, 34),
];
pub(crate) const PATH_COLORS: [RGBColor; 4] = [
    RGBColor(128, 0, 170),
    RGBColor(0, 150, 60),
    RGBColor(0, 90, 200),
    RGBColor(200, 100, 0),
];
pub(crate) const SERIES_COLORS: [RGBColor; 7] = [
    RGBColor(31, 119, 180),
    RGBColor(230, 100, 0),
    RGBColor(44, 160, 44),
    RGBColor(148, 103, 189),
    RGBColor(140, 86, 75),
    RGBColor(227, 119, 194),
    RGBColor(23, 190, 207),
];
/// Bar colours follow the paper's chart: target error yellow, irregularity red, energy purple.
pub(crate) const BAR_COLORS: [RGBColor; 6] = [
    RGBColor(240, 190, 30),
    RGBColor(215, 48, 39),
    RGBColor(117, 80, 170),
    RGBColor(31, 119, 180),
    RGBColor(44, 160, 44),
    RGBColor(140, 86, 75),
];
pub(crate) const TARGET_RED: RGBColor = RGBColor(225, 20, 20);
pub(crate) const MARGIN_RED: RGBColor = RGBColor(200, 40, 40);
pub(crate) const GROUND: RGBColor = RGBColor(205, 185, 150);
/// Solid obstacles by role: safety blue-grey, collider sand-brown, both grey.
pub(crate) const SOLID_SAFETY: RGBColor = RGBColor(150, 165, 200);
pub(crate) const SOLID_COLLIDER: RGBColor = RGBColor(200, 160, 110);
pub(crate) const SOLID_BOTH: RGBColor = RGBColor(170, 170, 175);
pub(crate) const GRID_GRAY: RGBColor = RGBColor(215, 215, 215);

pub(crate) fn text(size: f64) -> TextStyle<'static> {
    TextStyle::from(FontDesc::new(
        FontFamily::SansSerif,
        size,
        FontStyle::Normal,
    ))
    .color(&BLACK)
}

pub(crate) fn text_c(size: f64, color: RGBColor) -> TextStyle<'static> {
    let mut style = text(size);
    style.color = color.to_backend_color();
    style
}

pub(crate) fn darker(c: RGBColor) -> RGBColor {
    RGBColor(
        (c.0 as f64 * 0.7) as u8,
        (c.1 as f64 * 0.7) as u8,
        (c.2 as f64 * 0.7) as u8,
    )
}

/// Marker shape `k` (circle, triangle, square, diamond, …) centred at a pixel.
pub(crate) fn marker<DB: DrawingBackend>(
    k: usize,
    (x, y): (i32, i32),
    c: RGBColor,
) -> DynElement<'static, DB, (i32, i32)> {
    let r = 5;
    match k % 4 {
        0 => Circle::new((x, y), r, c.filled()).into_dyn(),
        1 => Polygon::new(
            vec![(x, y - r - 1), (x + r + 1, y + r), (x - r - 1, y + r)],
            c.filled(),
        )
        .into_dyn(),
        2 => Rectangle::new([(x - r, y - r), (x + r, y + r)], c.filled()).into_dyn(),
        _ => Polygon::new(
            vec![
                (x, y - r - 2),
                (x + r + 1, y),
                (x, y + r + 2),
                (x - r - 1, y),
            ],
            c.filled(),
        )
        .into_dyn(),
    }
}
