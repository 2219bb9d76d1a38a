//! Figures as PNG files: plain data in, picture out.
//!
//! Every function takes plain numbers (`[f64; 3]` positions, `(x, y)` pairs, bar values) and writes one
//! PNG; nothing here knows about the simulator or the optimizer, so any caller can draw with it.
//!
//! - [`draw_trajectory_3d`] and [`draw_trajectory_top`]: a cloth manipulation trajectory (cloth frames as
//!   wireframes, control-point paths, obstacle spheres with the δ margin, targets, ground) in an
//!   axonometric 3-D view and seen from above, like the paper's Fig. 4 (`delta_result`);
//!   [`draw_trajectory_panels`] puts several trajectories side by side on the same axes, like its
//!   Fig. 5 (`qualitative_result`).
//! - [`draw_bar_chart`]: grouped bars of padded cost terms per variant, like the paper's
//!   `quantitative_result` chart.
//! - [`draw_xy`]: lines with markers, optional per-point labels, labelled horizontal reference lines and
//!   logarithmic axes (e.g. gradient error against time).
//!
//! Text is rendered with DejaVu Sans, embedded in the binary (`assets/fonts/`), so drawing needs no
//! system fonts.

use std::f64::consts::PI;
use std::path::{Path, PathBuf};
use std::sync::OnceLock;

use plotters::coord::cartesian::Cartesian3d;
use plotters::coord::ranged1d::{AsRangedCoord, ValueFormatter};
use plotters::coord::types::RangedCoordf64;
use plotters::coord::Shift;
use plotters::prelude::*;
use plotters::style::text_anchor::{HPos, Pos, VPos};
use plotters_backend::{BackendColor, BackendCoord, DrawingErrorKind};

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

/// A cloth trajectory to draw with [`draw_trajectory_3d`] or [`draw_trajectory_top`].
#[derive(Debug, Clone)]
pub struct TrajectoryFigure<'a> {
    /// Figure title.
    pub title: String,
    /// Cloth grid `(rows, cols)`; particle `p = r * cols + c`, used to draw each frame as a wireframe.
    pub grid: (usize, usize),
    /// Cloth states to draw (e.g. initial, intermediate, final), each with its legend label.
    pub frames: Vec<(&'a [[f64; 3]], String)>,
    /// Path of each control point over the steps (`T + 1` points each).
    pub control_paths: Vec<Vec<[f64; 3]>>,
    /// Obstacle spheres (may be empty).
    pub spheres: &'a [Sphere],
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

impl Default for TrajectoryFigure<'_> {
    /// An empty figure with the default view; fill in the fields you need.
    fn default() -> Self {
        TrajectoryFigure {
            title: String::new(),
            grid: (0, 0),
            frames: Vec::new(),
            control_paths: Vec::new(),
            spheres: &[],
            targets: &[],
            target_particles: &[],
            ground_z: None,
            safety_margin: None,
            view: View3d::default(),
        }
    }
}

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

// ---------------------------------------------------------------------------------------------------
// Shared helpers
// ---------------------------------------------------------------------------------------------------

type Area<'a> = DrawingArea<Canvas<'a>, Shift>;
type Coord3 = Cartesian3d<RangedCoordf64, RangedCoordf64, RangedCoordf64>;

static FONT_BYTES: &[u8] = include_bytes!("../assets/fonts/DejaVuSans.ttf");
const FAMILY: &str = "sans-serif";

const SIZE_3D: (u32, u32) = (1000, 800);
const SIZE_2D: (u32, u32) = (900, 600);

const FRAME_COLORS: [RGBColor; 7] = [
    RGBColor(31, 119, 180),
    RGBColor(255, 127, 14),
    RGBColor(40, 40, 40),
    RGBColor(23, 190, 207),
    RGBColor(140, 86, 75),
    RGBColor(227, 119, 194),
    RGBColor(188, 189, 34),
];
const PATH_COLORS: [RGBColor; 4] = [
    RGBColor(128, 0, 170),
    RGBColor(0, 150, 60),
    RGBColor(0, 90, 200),
    RGBColor(200, 100, 0),
];
const SERIES_COLORS: [RGBColor; 7] = [
    RGBColor(31, 119, 180),
    RGBColor(230, 100, 0),
    RGBColor(44, 160, 44),
    RGBColor(148, 103, 189),
    RGBColor(140, 86, 75),
    RGBColor(227, 119, 194),
    RGBColor(23, 190, 207),
];
/// Bar colours follow the paper's chart: target error yellow, irregularity red, energy purple.
const BAR_COLORS: [RGBColor; 6] = [
    RGBColor(240, 190, 30),
    RGBColor(215, 48, 39),
    RGBColor(117, 80, 170),
    RGBColor(31, 119, 180),
    RGBColor(44, 160, 44),
    RGBColor(140, 86, 75),
];
const TARGET_RED: RGBColor = RGBColor(225, 20, 20);
const MARGIN_RED: RGBColor = RGBColor(200, 40, 40);
const GROUND: RGBColor = RGBColor(205, 185, 150);
const GRID_GRAY: RGBColor = RGBColor(215, 215, 215);

fn ensure_font() -> Result<(), PlotError> {
    static REGISTERED: OnceLock<bool> = OnceLock::new();
    let ok = *REGISTERED.get_or_init(|| {
        plotters::style::register_font(FAMILY, FontStyle::Normal, FONT_BYTES).is_ok()
    });
    if ok {
        Ok(())
    } else {
        Err(PlotError::Font)
    }
}

fn text(size: f64) -> TextStyle<'static> {
    TextStyle::from(FontDesc::new(
        FontFamily::SansSerif,
        size,
        FontStyle::Normal,
    ))
    .color(&BLACK)
}

fn text_c(size: f64, color: RGBColor) -> TextStyle<'static> {
    let mut style = text(size);
    style.color = color.to_backend_color();
    style
}

fn de<E: std::error::Error + Send + Sync>(e: DrawingAreaErrorKind<E>) -> PlotError {
    PlotError::Draw(e.to_string())
}

/// Draws into a white in-memory RGB bitmap of `size` pixels with `draw`, then writes it to `path` as
/// a PNG.
fn render(
    path: &Path,
    size: (u32, u32),
    draw: impl FnOnce(&Area) -> Result<(), PlotError>,
) -> Result<(), PlotError> {
    ensure_font()?;
    let write_err = |message: String| PlotError::Write {
        path: path.to_path_buf(),
        message,
    };
    match path.extension().and_then(|e| e.to_str()) {
        Some(e) if e.eq_ignore_ascii_case("png") => {}
        _ => return Err(write_err("the file name must end in .png".into())),
    }
    let mut buf = vec![255u8; size.0 as usize * size.1 as usize * 3];
    {
        let root = Canvas {
            inner: BitMapBackend::with_buffer(&mut buf, size),
        }
        .into_drawing_area();
        draw(&root)?;
        root.present().map_err(de)?;
    }
    let file = std::fs::File::create(path).map_err(|e| write_err(e.to_string()))?;
    let mut encoder = png::Encoder::new(std::io::BufWriter::new(file), size.0, size.1);
    encoder.set_color(png::ColorType::Rgb);
    encoder.set_depth(png::BitDepth::Eight);
    encoder.set_adaptive_filter(png::AdaptiveFilterType::Adaptive);
    let mut writer = encoder
        .write_header()
        .map_err(|e| write_err(e.to_string()))?;
    writer
        .write_image_data(&buf)
        .map_err(|e| write_err(e.to_string()))?;
    writer.finish().map_err(|e| write_err(e.to_string()))
}

fn check_finite(what: &str, v: f64) -> Result<(), PlotError> {
    if v.is_finite() {
        Ok(())
    } else {
        Err(PlotError::InvalidData(format!("{what} is {v}")))
    }
}

fn check_point(what: &str, p: &[f64; 3]) -> Result<(), PlotError> {
    if p.iter().all(|v| v.is_finite()) {
        Ok(())
    } else {
        Err(PlotError::InvalidData(format!(
            "{what} is not finite: [{}, {}, {}]",
            p[0], p[1], p[2]
        )))
    }
}

/// A compact number: plain decimals between 1e-3 and 1e4, else `m×10ⁿ`; minus signs as `−`.
fn fmt_num(v: f64) -> String {
    fmt_num_ascii(v).replace('-', "−")
}

fn fmt_num_ascii(v: f64) -> String {
    if v == 0.0 || !v.is_finite() {
        return if v == 0.0 { "0".into() } else { format!("{v}") };
    }
    let a = v.abs();
    if (1e-3..1e4).contains(&a) {
        let digits = (3 - 1 - a.log10().floor() as i32).clamp(0, 6) as usize;
        let s = format!("{v:.digits$}");
        if s.contains('.') {
            s.trim_end_matches('0').trim_end_matches('.').to_string()
        } else {
            s
        }
    } else {
        let e = a.log10().floor() as i32;
        let m = v / 10f64.powi(e);
        let ms = format!("{m:.2}");
        let ms = ms.trim_end_matches('0').trim_end_matches('.');
        if ms == "1" {
            format!("10{}", superscript(e))
        } else if ms == "-1" {
            format!("-10{}", superscript(e))
        } else {
            format!("{ms}×10{}", superscript(e))
        }
    }
}

/// A tick label on a linear axis: short decimals, `−0` shown as `0`.
fn fmt_tick(v: f64) -> String {
    if v.abs() < 1e-12 {
        return "0".into();
    }
    fmt_num(v)
}

fn superscript(e: i32) -> String {
    e.to_string()
        .chars()
        .map(|c| match c {
            '-' => '⁻',
            '0' => '⁰',
            '1' => '¹',
            '2' => '²',
            '3' => '³',
            '4' => '⁴',
            '5' => '⁵',
            '6' => '⁶',
            '7' => '⁷',
            '8' => '⁸',
            _ => '⁹',
        })
        .collect()
}

// ---------------------------------------------------------------------------------------------------
// Text rendering
// ---------------------------------------------------------------------------------------------------

/// A bitmap backend that lays text out itself (side bearings, kerning, baseline), because the text
/// path of plotters' `ab_glyph` feature drops the glyphs' side bearings, which makes small labels
/// hard to read ("vi sible"). Everything else goes to [`BitMapBackend`].
struct Canvas<'a> {
    inner: BitMapBackend<'a>,
}

fn font_ref() -> Option<&'static ab_glyph::FontRef<'static>> {
    static FONT: OnceLock<Option<ab_glyph::FontRef<'static>>> = OnceLock::new();
    FONT.get_or_init(|| ab_glyph::FontRef::try_from_slice(FONT_BYTES).ok())
        .as_ref()
}

/// One laid-out line of text: glyphs positioned on a baseline at y = 0, starting at x = 0.
struct Laid {
    glyphs: Vec<ab_glyph::Glyph>,
    width: f32,
    ascent: f32,
    descent: f32,
    cap: f32,
}

fn lay_out(text: &str, size: f64) -> Option<Laid> {
    use ab_glyph::{Font, ScaleFont};
    let font = font_ref()?;
    let scaled = font.as_scaled(size as f32);
    let mut caret = 0.0f32;
    let mut prev = None;
    let mut glyphs = Vec::with_capacity(text.len());
    for ch in text.chars() {
        let id = scaled.glyph_id(ch);
        if let Some(p) = prev {
            caret += scaled.kern(p, id);
        }
        glyphs.push(id.with_scale_and_position(scaled.scale(), ab_glyph::point(caret, 0.0)));
        caret += scaled.h_advance(id);
        prev = Some(id);
    }
    let cap = scaled.glyph_bounds(&scaled.glyph_id('H').with_scale(scaled.scale()));
    Some(Laid {
        glyphs,
        width: caret,
        ascent: scaled.ascent(),
        descent: scaled.descent(),
        cap: -cap.min.y,
    })
}

impl DrawingBackend for Canvas<'_> {
    type ErrorType = <BitMapBackend<'static> as DrawingBackend>::ErrorType;

    fn get_size(&self) -> (u32, u32) {
        self.inner.get_size()
    }
    fn ensure_prepared(&mut self) -> Result<(), DrawingErrorKind<Self::ErrorType>> {
        self.inner.ensure_prepared()
    }
    fn present(&mut self) -> Result<(), DrawingErrorKind<Self::ErrorType>> {
        self.inner.present()
    }
    fn draw_pixel(
        &mut self,
        point: BackendCoord,
        color: BackendColor,
    ) -> Result<(), DrawingErrorKind<Self::ErrorType>> {
        self.inner.draw_pixel(point, color)
    }
    fn draw_line<S: plotters_backend::BackendStyle>(
        &mut self,
        from: BackendCoord,
        to: BackendCoord,
        style: &S,
    ) -> Result<(), DrawingErrorKind<Self::ErrorType>> {
        self.inner.draw_line(from, to, style)
    }
    fn draw_rect<S: plotters_backend::BackendStyle>(
        &mut self,
        upper_left: BackendCoord,
        bottom_right: BackendCoord,
        style: &S,
        fill: bool,
    ) -> Result<(), DrawingErrorKind<Self::ErrorType>> {
        self.inner.draw_rect(upper_left, bottom_right, style, fill)
    }
    fn draw_path<S: plotters_backend::BackendStyle, I: IntoIterator<Item = BackendCoord>>(
        &mut self,
        path: I,
        style: &S,
    ) -> Result<(), DrawingErrorKind<Self::ErrorType>> {
        self.inner.draw_path(path, style)
    }
    fn draw_circle<S: plotters_backend::BackendStyle>(
        &mut self,
        center: BackendCoord,
        radius: u32,
        style: &S,
        fill: bool,
    ) -> Result<(), DrawingErrorKind<Self::ErrorType>> {
        self.inner.draw_circle(center, radius, style, fill)
    }
    fn fill_polygon<S: plotters_backend::BackendStyle, I: IntoIterator<Item = BackendCoord>>(
        &mut self,
        vert: I,
        style: &S,
    ) -> Result<(), DrawingErrorKind<Self::ErrorType>> {
        self.inner.fill_polygon(vert, style)
    }
    fn blit_bitmap(
        &mut self,
        pos: BackendCoord,
        size: (u32, u32),
        src: &[u8],
    ) -> Result<(), DrawingErrorKind<Self::ErrorType>> {
        self.inner.blit_bitmap(pos, size, src)
    }

    fn estimate_text_size<TStyle: plotters_backend::BackendTextStyle>(
        &self,
        text: &str,
        style: &TStyle,
    ) -> Result<(u32, u32), DrawingErrorKind<Self::ErrorType>> {
        match lay_out(text, style.size()) {
            Some(l) => Ok((l.width.ceil() as u32, (l.ascent - l.descent).ceil() as u32)),
            None => self.inner.estimate_text_size(text, style),
        }
    }

    fn draw_text<TStyle: plotters_backend::BackendTextStyle>(
        &mut self,
        text: &str,
        style: &TStyle,
        pos: BackendCoord,
    ) -> Result<(), DrawingErrorKind<Self::ErrorType>> {
        let color = style.color();
        if color.alpha == 0.0 {
            return Ok(());
        }
        let Some(laid) = lay_out(text, style.size()) else {
            return self.inner.draw_text(text, style, pos);
        };
        let anchor = style.anchor();
        let dx = match anchor.h_pos {
            HPos::Left => 0.0,
            HPos::Right => -laid.width,
            HPos::Center => -laid.width / 2.0,
        };
        // Baseline position relative to the anchor: the whole line box (ascent to descent) for top and
        // bottom, the middle of the capitals for centre, so that numbers sit centred on tick marks.
        let baseline = match anchor.v_pos {
            VPos::Top => laid.ascent,
            VPos::Center => laid.cap / 2.0,
            VPos::Bottom => laid.descent,
        };
        let trans = style.transform();
        let font = match font_ref() {
            Some(f) => f,
            None => return self.inner.draw_text(text, style, pos),
        };
        let mut failed = None;
        for g in laid.glyphs {
            use ab_glyph::Font;
            let Some(outline) = font.outline_glyph(g) else {
                continue;
            };
            let b = outline.px_bounds();
            let inner = &mut self.inner;
            outline.draw(|x, y, cover| {
                if failed.is_some() || cover <= 0.0 {
                    return;
                }
                let tx = (b.min.x + x as f32 + dx).round() as i32;
                let ty = (b.min.y + y as f32 + baseline).round() as i32;
                let (rx, ry) = trans.transform(tx, ty);
                let c = BackendColor {
                    alpha: color.alpha * f64::from(cover.min(1.0)),
                    rgb: color.rgb,
                };
                if let Err(e) = inner.draw_pixel((pos.0 + rx, pos.1 + ry), c) {
                    failed = Some(e);
                }
            });
            if let Some(e) = failed {
                return Err(e);
            }
        }
        Ok(())
    }
}

// ---------------------------------------------------------------------------------------------------
// Legends
// ---------------------------------------------------------------------------------------------------

enum Swatch {
    Line(RGBColor, u32),
    LineMarker(RGBColor, usize),
    PathMarkers(RGBColor),
    Dot(RGBColor),
    Ring(RGBColor),
    DashedRing(RGBColor),
    Sphere,
    Patch(RGBAColor),
}

const LEGEND_ROW: i32 = 26;

/// Width and height of a legend box (an empty heading takes no room).
fn legend_size(
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
fn draw_legend(
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
fn draw_dashed_envelope(
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

/// The safety margin around the obstacle: the outline of all spheres grown by δ, as projected.
fn render_margin(
    root: &Area,
    proj: &dyn Projector,
    fig: &TrajectoryFigure,
) -> Result<(), PlotError> {
    let Some(d) = fig.safety_margin else {
        return Ok(());
    };
    let circles: Vec<_> = fig
        .spheres
        .iter()
        .map(|s| (proj.px(s.center), (s.radius + d) * proj.px_per_unit()))
        .collect();
    draw_dashed_envelope(root, &circles, MARGIN_RED)
}

/// A grey disc shaded like a sphere lit from the upper left.
fn draw_shaded_disc(root: &Area, (cx, cy): (i32, i32), r: i32) -> Result<(), PlotError> {
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

// ---------------------------------------------------------------------------------------------------
// Trajectory figures
// ---------------------------------------------------------------------------------------------------

/// Maps world points to pixels for one view.
trait Projector {
    fn px(&self, p: [f64; 3]) -> (i32, i32);
    /// Larger = farther from the viewer (drawn first).
    fn depth(&self, p: [f64; 3]) -> f64;
    /// Pixels per world unit (the same in every direction).
    fn px_per_unit(&self) -> f64;
}

struct AxonometricView<'c> {
    coord: &'c Coord3,
    scale: f64,
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

struct TopView<'c> {
    coord: &'c Cartesian2d<RangedCoordf64, RangedCoordf64>,
    scale: f64,
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

enum Prim {
    Quad([[f64; 3]; 4], RGBAColor),
    Segment([f64; 3], [f64; 3], RGBColor, u32),
    Ball(Sphere),
    Marker([f64; 3], RGBColor, i32),
}

fn mid(a: [f64; 3], b: [f64; 3]) -> [f64; 3] {
    [
        (a[0] + b[0]) / 2.0,
        (a[1] + b[1]) / 2.0,
        (a[2] + b[2]) / 2.0,
    ]
}

fn validate_trajectory(fig: &TrajectoryFigure) -> Result<(), PlotError> {
    let (rows, cols) = fig.grid;
    for (k, (frame, label)) in fig.frames.iter().enumerate() {
        if frame.len() != rows * cols {
            return Err(PlotError::InvalidData(format!(
                "frame {k} (\"{label}\") has {} particles but the grid {rows}×{cols} needs {}",
                frame.len(),
                rows * cols
            )));
        }
        for (i, p) in frame.iter().enumerate() {
            check_point(&format!("particle {i} of frame {k} (\"{label}\")"), p)?;
        }
    }
    for (k, path) in fig.control_paths.iter().enumerate() {
        for (t, p) in path.iter().enumerate() {
            check_point(&format!("point {t} of control path {k}"), p)?;
        }
    }
    for (k, s) in fig.spheres.iter().enumerate() {
        check_point(&format!("centre of sphere {k}"), &s.center)?;
        if !(s.radius.is_finite() && s.radius > 0.0) {
            return Err(PlotError::InvalidData(format!(
                "sphere {k} has radius {}; it must be finite and > 0",
                s.radius
            )));
        }
    }
    for (k, p) in fig.targets.iter().enumerate() {
        check_point(&format!("target {k}"), p)?;
    }
    if let Some(&bad) = fig.target_particles.iter().find(|&&i| i >= rows * cols) {
        return Err(PlotError::InvalidData(format!(
            "target particle {bad} is outside the {rows}×{cols} grid"
        )));
    }
    if let Some(z) = fig.ground_z {
        check_finite("ground_z", z)?;
    }
    if let Some(d) = fig.safety_margin {
        if !(d.is_finite() && d >= 0.0) {
            return Err(PlotError::InvalidData(format!(
                "safety_margin is {d}; it must be finite and ≥ 0"
            )));
        }
    }
    let empty = fig.frames.is_empty()
        && fig.control_paths.iter().all(|p| p.is_empty())
        && fig.spheres.is_empty()
        && fig.targets.is_empty();
    if empty {
        return Err(PlotError::InvalidData(
            "the trajectory figure has nothing to draw".into(),
        ));
    }
    Ok(())
}

/// Axis-aligned bounds of everything drawn, padded; each axis at least `min_span` wide.
fn trajectory_bounds(fig: &TrajectoryFigure) -> [[f64; 2]; 3] {
    let mut b = [[f64::INFINITY, f64::NEG_INFINITY]; 3];
    let mut add = |p: [f64; 3], r: f64| {
        for a in 0..3 {
            b[a][0] = b[a][0].min(p[a] - r);
            b[a][1] = b[a][1].max(p[a] + r);
        }
    };
    for (f, _) in &fig.frames {
        f.iter().for_each(|&p| add(p, 0.0));
    }
    for path in &fig.control_paths {
        path.iter().for_each(|&p| add(p, 0.0));
    }
    for s in fig.spheres {
        add(s.center, s.radius);
    }
    fig.targets.iter().for_each(|&p| add(p, 0.0));
    if let Some(z) = fig.ground_z {
        b[2][0] = b[2][0].min(z);
        b[2][1] = b[2][1].max(z);
    }
    let largest = b.iter().map(|r| r[1] - r[0]).fold(0.0, f64::max).max(1e-6);
    for r in b.iter_mut() {
        let span = r[1] - r[0];
        let pad = 0.04 * largest + 0.5 * (0.15 * largest - span).max(0.0);
        r[0] -= pad;
        r[1] += pad;
    }
    b
}

/// Cloth wireframes, control paths and spheres as depth-sortable primitives.
fn scene_prims(fig: &TrajectoryFigure) -> Vec<Prim> {
    let (rows, cols) = fig.grid;
    let mut prims = Vec::new();
    for (k, (frame, _)) in fig.frames.iter().enumerate() {
        let c = FRAME_COLORS[k % FRAME_COLORS.len()];
        let at = |r: usize, cc: usize| frame[r * cols + cc];
        for r in 0..rows {
            for cc in 0..cols {
                if r + 1 < rows && cc + 1 < cols {
                    prims.push(Prim::Quad(
                        [at(r, cc), at(r, cc + 1), at(r + 1, cc + 1), at(r + 1, cc)],
                        c.mix(0.10),
                    ));
                }
                if cc + 1 < cols {
                    prims.push(Prim::Segment(at(r, cc), at(r, cc + 1), c, 1));
                }
                if r + 1 < rows {
                    prims.push(Prim::Segment(at(r, cc), at(r + 1, cc), c, 1));
                }
            }
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
    prims
}

fn prim_depth(proj: &dyn Projector, p: &Prim) -> f64 {
    match p {
        Prim::Quad(q, _) => {
            let c = mid(mid(q[0], q[2]), mid(q[1], q[3]));
            proj.depth(c)
        }
        Prim::Segment(a, b, _, _) => proj.depth(mid(*a, *b)),
        Prim::Ball(s) => proj.depth(s.center),
        Prim::Marker(p, _, _) => proj.depth(*p) - 1e-3,
    }
}

/// Farthest first (painter's algorithm); ties keep their order.
fn paint_order(proj: &dyn Projector, prims: Vec<Prim>) -> Vec<Prim> {
    let mut items: Vec<(f64, Prim)> = prims
        .into_iter()
        .map(|p| (prim_depth(proj, &p), p))
        .collect();
    items.sort_by(|a, b| b.0.total_cmp(&a.0));
    items.into_iter().map(|(_, p)| p).collect()
}

fn render_prims(root: &Area, proj: &dyn Projector, prims: Vec<Prim>) -> Result<(), PlotError> {
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

/// Pixels drawn, then skipped, along a dashed line.
const DASH: (f64, f64) = (5.0, 4.0);

/// Every cloth frame's wireframe again, dashed in its colour and on top of everything, so a frame
/// hidden behind obstacles (e.g. the start and end cloth behind a wall of spheres) still shows.
fn render_hidden_cloth(
    root: &Area,
    proj: &dyn Projector,
    fig: &TrajectoryFigure,
) -> Result<(), PlotError> {
    if fig.spheres.is_empty() {
        return Ok(());
    }
    let (rows, cols) = fig.grid;
    for (k, (frame, _)) in fig.frames.iter().enumerate() {
        let c = FRAME_COLORS[k % FRAME_COLORS.len()];
        let at = |r: usize, cc: usize| proj.px(frame[r * cols + cc]);
        for r in 0..rows {
            for cc in 0..cols {
                if cc + 1 < cols {
                    draw_dashed(root, at(r, cc), at(r, cc + 1), c)?;
                }
                if r + 1 < rows {
                    draw_dashed(root, at(r, cc), at(r + 1, cc), c)?;
                }
            }
        }
    }
    Ok(())
}

/// A 1-pixel dashed line from `a` to `b` (dash pattern [`DASH`], starting with a dash).
fn draw_dashed(root: &Area, a: (i32, i32), b: (i32, i32), c: RGBColor) -> Result<(), PlotError> {
    let (dx, dy) = ((b.0 - a.0) as f64, (b.1 - a.1) as f64);
    let len = dx.hypot(dy);
    let point = |s: f64| {
        let t = if len > 0.0 { (s / len).min(1.0) } else { 0.0 };
        (a.0 + (dx * t).round() as i32, a.1 + (dy * t).round() as i32)
    };
    let mut s = 0.0;
    while s < len {
        root.draw(&PathElement::new(
            vec![point(s), point(s + DASH.0)],
            c.stroke_width(1),
        ))
        .map_err(de)?;
        s += DASH.0 + DASH.1;
    }
    Ok(())
}

/// Targets and the particles meant to reach them, always on top.
fn render_targets(
    root: &Area,
    proj: &dyn Projector,
    fig: &TrajectoryFigure,
) -> Result<(), PlotError> {
    if let Some((last, _)) = fig.frames.last() {
        for &i in fig.target_particles {
            root.draw(&Circle::new(
                proj.px(last[i]),
                7,
                TARGET_RED.stroke_width(2),
            ))
            .map_err(de)?;
        }
    }
    for &t in fig.targets {
        let at = proj.px(t);
        root.draw(&Circle::new(at, 5, TARGET_RED.filled()))
            .map_err(de)?;
        root.draw(&Circle::new(at, 5, BLACK.stroke_width(1)))
            .map_err(de)?;
    }
    Ok(())
}

fn trajectory_legend(fig: &TrajectoryFigure, with_ground: bool) -> Vec<(Swatch, String)> {
    let mut e = Vec::new();
    for (k, (_, label)) in fig.frames.iter().enumerate() {
        e.push((
            Swatch::Line(FRAME_COLORS[k % FRAME_COLORS.len()], 2),
            format!("cloth: {label}"),
        ));
    }
    for k in 0..fig.control_paths.len() {
        e.push((
            Swatch::PathMarkers(PATH_COLORS[k % PATH_COLORS.len()]),
            format!("control point {} path", k + 1),
        ));
    }
    if !fig.spheres.is_empty() {
        e.push((
            Swatch::Sphere,
            format!("obstacle ({} spheres)", fig.spheres.len()),
        ));
    }
    if let (false, Some(d)) = (fig.spheres.is_empty(), fig.safety_margin) {
        e.push((
            Swatch::DashedRing(MARGIN_RED),
            format!("safety margin δ = {}", fmt_tick(d)),
        ));
    }
    if !fig.targets.is_empty() {
        e.push((Swatch::Dot(TARGET_RED), "target positions".into()));
    }
    if !fig.target_particles.is_empty() && !fig.frames.is_empty() {
        e.push((Swatch::Ring(TARGET_RED), "target particles (last)".into()));
    }
    if let (true, Some(z)) = (with_ground, fig.ground_z) {
        e.push((
            Swatch::Patch(GROUND.mix(0.45)),
            format!("ground z = {}", fmt_tick(z)),
        ));
    }
    e
}

/// Draws a cloth trajectory in an axonometric 3-D view (equal scale on all axes, `z` up) to a PNG
/// (1000×800): cloth frames as wireframes in distinct colours, control-point paths as thick purple
/// and green polylines with a marker per step, obstacle spheres as shaded discs, targets as red
/// points, the ground plane, axis labels in metres and a legend.
pub fn draw_trajectory_3d(fig: &TrajectoryFigure, path: &Path) -> Result<(), PlotError> {
    validate_trajectory(fig)?;
    render(path, SIZE_3D, |root| {
        let titled = root
            .titled(
                &fig.title,
                text(24.0).pos(Pos::new(HPos::Center, VPos::Top)),
            )
            .map_err(de)?;
        let legend_w = 250;
        let (plot_area, legend_area) = titled.split_horizontally(SIZE_3D.0 as i32 - legend_w);

        scene_3d(root, &plot_area, fig, &trajectory_bounds(fig), 17.0)?;
        let view = fig.view;

        let (lx, ly) = legend_area.get_base_pixel();
        let bottom = draw_legend(root, (lx, ly + 20), "Legend", &trajectory_legend(fig, true))?;
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
    })
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
fn scene_3d(
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
    let k = k0 * f;
    set_size(&mut chart, k);

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

/// Puts "x [m]", "y [m]", "z [m]" beside the box edges on which plotters draws the tick labels (the
/// same choice as plotters' `draw_axis`: the nearest back-panel edge, then the highest).
fn draw_axis_titles(
    root: &Area,
    coord: &Coord3,
    b: &[[f64; 2]; 3],
    plot_area: &Area,
    size: f64,
) -> Result<(), PlotError> {
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
        root.draw(&Text::new(
            names[idx].to_string(),
            at,
            text(size).pos(Pos::new(HPos::Center, VPos::Center)),
        ))
        .map_err(de)?;
    }
    Ok(())
}

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
        let legend_w = 240;
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
        let bottom = draw_legend(
            root,
            (lx, ly + 20),
            "Top view",
            &trajectory_legend(fig, false),
        )?;
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
fn equal_aspect(b: [[f64; 2]; 2], (pw, ph): (u32, u32)) -> ([f64; 2], [f64; 2]) {
    let (dx, dy) = (b[0][1] - b[0][0], b[1][1] - b[1][0]);
    let s = (pw as f64 / dx).min(ph as f64 / dy);
    let (ex, ey) = ((pw as f64 / s - dx) / 2.0, (ph as f64 / s - dy) / 2.0);
    ([b[0][0] - ex, b[0][1] + ex], [b[1][0] - ey, b[1][1] + ey])
}

// ---------------------------------------------------------------------------------------------------
// Bar chart
// ---------------------------------------------------------------------------------------------------

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

fn bar_body<YR>(
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

// ---------------------------------------------------------------------------------------------------
// XY plot
// ---------------------------------------------------------------------------------------------------

fn axis_range(vals: impl Iterator<Item = f64>, log: bool, extra_hi: f64) -> (f64, f64) {
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

fn xy_body<XR, YR>(root: &Area, fig: &XyFigure, xr: XR, yr: YR) -> Result<(), PlotError>
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

/// Pixel boxes already covered by markers, lines and labels, for placing labels where they collide
/// the least.
#[derive(Default)]
struct Obstacles {
    boxes: Vec<(i32, i32, i32, i32)>,
    labels: Vec<(i32, i32, i32, i32)>,
    line_points: Vec<(i32, i32)>,
}

impl Obstacles {
    fn add_polyline(&mut self, pts: &[(i32, i32)]) {
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

    fn cost(&self, r: (i32, i32, i32, i32)) -> i64 {
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
fn place_label(
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

fn darker(c: RGBColor) -> RGBColor {
    RGBColor(
        (c.0 as f64 * 0.7) as u8,
        (c.1 as f64 * 0.7) as u8,
        (c.2 as f64 * 0.7) as u8,
    )
}

/// Marker shape `k` (circle, triangle, square, diamond, …) centred at a pixel.
fn marker<DB: DrawingBackend>(
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

#[cfg(test)]
mod tests {
    use super::*;

    /// A fresh, empty directory under the system temp dir.
    fn scratch(name: &str) -> PathBuf {
        let dir = std::env::temp_dir().join(format!("clothopt-plot-{}-{name}", std::process::id()));
        let _ = std::fs::remove_dir_all(&dir);
        std::fs::create_dir_all(&dir).expect("temp dir");
        dir
    }

    /// Width, height and RGB(A) pixels of a PNG file.
    fn decode(path: &Path) -> (u32, u32, Vec<[u8; 3]>) {
        let file = std::fs::File::open(path).expect("png exists");
        let mut reader = png::Decoder::new(std::io::BufReader::new(file))
            .read_info()
            .expect("png header");
        let mut buf = vec![0; reader.output_buffer_size()];
        let info = reader.next_frame(&mut buf).expect("png frame");
        let step = info.color_type.samples();
        let px = buf[..info.buffer_size()]
            .chunks(step)
            .map(|c| [c[0], c[1], c[2]])
            .collect();
        (info.width, info.height, px)
    }

    fn count(px: &[[u8; 3]], c: RGBColor) -> usize {
        px.iter().filter(|p| **p == [c.0, c.1, c.2]).count()
    }

    fn sheet(y: f64) -> Vec<[f64; 3]> {
        (0..9)
            .map(|p| [(p % 3) as f64 * 0.5 - 0.5, y, 2.0 - (p / 3) as f64 * 0.5])
            .collect()
    }

    #[test]
    fn trajectory_views_draw_every_element() {
        let dir = scratch("traj");
        let (a, b) = (sheet(-1.0), sheet(1.0));
        let spheres = [Sphere {
            center: [0.0, 0.0, 1.0],
            radius: 0.3,
        }];
        let targets = [[-0.5, 1.2, 1.0], [0.5, 1.2, 1.0]];
        let fig = TrajectoryFigure {
            title: "test".into(),
            grid: (3, 3),
            frames: vec![(&a[..], "initial".into()), (&b[..], "final".into())],
            control_paths: vec![vec![a[0], [-0.5, 0.0, 2.5], b[0]], vec![a[2], b[2]]],
            spheres: &spheres,
            targets: &targets,
            target_particles: &[6, 8],
            ground_z: Some(0.0),
            safety_margin: Some(0.1),
            ..Default::default()
        };
        for (name, size) in [("3d.png", SIZE_3D), ("top.png", SIZE_2D)] {
            let path = dir.join(name);
            if name == "3d.png" {
                draw_trajectory_3d(&fig, &path).expect("3-D view");
            } else {
                draw_trajectory_top(&fig, &path).expect("top view");
            }
            let (w, h, px) = decode(&path);
            assert_eq!((w, h), size, "{name}");
            // Markers and solid fills are drawn without anti-aliasing, so exact colours are found.
            assert!(count(&px, PATH_COLORS[0]) > 100, "{name}: purple path");
            assert!(count(&px, PATH_COLORS[1]) > 100, "{name}: green path");
            assert!(count(&px, TARGET_RED) > 30, "{name}: targets");
            assert!(count(&px, FRAME_COLORS[0]) > 20, "{name}: first frame");
            assert!(count(&px, MARGIN_RED) > 20, "{name}: safety margin");
            assert!(count(&px, RGBColor(105, 110, 125)) > 50, "{name}: sphere");
        }
        let panels = [fig.clone(), fig.clone(), fig];
        let path = dir.join("panels.png");
        draw_trajectory_panels("three", &panels, 2, &path).expect("panels");
        let (w, h, px) = decode(&path);
        assert_eq!((w, h), (2 * 460 + 250, 2 * 440 + 50));
        assert!(count(&px, PATH_COLORS[0]) > 300, "three purple paths");
        assert!(matches!(
            draw_trajectory_panels("none", &[], 2, &path),
            Err(PlotError::InvalidData(_))
        ));
        let _ = std::fs::remove_dir_all(&dir);
    }

    #[test]
    fn bar_chart_and_xy_write_pngs() {
        let dir = scratch("charts");
        let mut bars = BarChart {
            title: "bars".into(),
            y_label: "cost".into(),
            groups: vec![
                ("G".into(), vec![0.0, 1.0, 2.0]),
                ("G+αT".into(), vec![0.5, 0.1, 3.0]),
            ],
            series_names: vec!["G".into(), "αT".into(), "βE".into()],
            pad: 0.1,
            log_y: false,
        };
        for log_y in [false, true] {
            bars.log_y = log_y;
            let path = dir.join(format!("bars_{log_y}.png"));
            draw_bar_chart(&bars, &path).expect("bar chart");
            let (w, h, px) = decode(&path);
            assert_eq!((w, h), SIZE_2D);
            for c in &BAR_COLORS[..3] {
                assert!(count(&px, *c) > 200, "bar colour {c:?} (log {log_y})");
            }
        }
        let fig = XyFigure {
            title: "xy".into(),
            x_label: "time [ms]".into(),
            y_label: "error".into(),
            series: vec![Series {
                name: "a".into(),
                points: vec![(1.0, 1.0), (10.0, 0.1), (100.0, 0.001)],
                labels: vec!["n=1".into(), String::new(), "n=100".into()],
            }],
            log_x: true,
            log_y: true,
            ref_lines: vec![RefLine {
                y: 0.01,
                label: "1 %".into(),
            }],
        };
        let path = dir.join("xy.png");
        draw_xy(&fig, &path).expect("xy plot");
        let (_, _, px) = decode(&path);
        assert!(count(&px, SERIES_COLORS[0]) > 100);
        let _ = std::fs::remove_dir_all(&dir);
    }

    #[test]
    fn bad_data_and_bad_paths_are_errors_not_panics() {
        let dir = scratch("errors");
        let a = sheet(0.0);
        let fig = TrajectoryFigure {
            grid: (3, 4),
            frames: vec![(&a[..], "initial".into())],
            ..Default::default()
        };
        let e = draw_trajectory_3d(&fig, &dir.join("x.png")).unwrap_err();
        assert!(
            matches!(&e, PlotError::InvalidData(m) if m.contains("3×4") && m.contains("9 particles")),
            "{e}"
        );
        assert!(matches!(
            draw_trajectory_top(&TrajectoryFigure::default(), &dir.join("x.png")),
            Err(PlotError::InvalidData(_))
        ));

        let mut xy = XyFigure {
            series: vec![Series {
                name: "s".into(),
                points: vec![(1.0, 0.0), (2.0, 1.0)],
                labels: Vec::new(),
            }],
            log_y: true,
            ..Default::default()
        };
        let e = draw_xy(&xy, &dir.join("x.png")).unwrap_err();
        assert!(
            matches!(&e, PlotError::InvalidData(m) if m.contains("y = 0")),
            "{e}"
        );
        xy.log_y = false;
        xy.series[0].labels = vec!["only one".into()];
        assert!(matches!(
            draw_xy(&xy, &dir.join("x.png")),
            Err(PlotError::InvalidData(_))
        ));
        xy.series[0].labels.clear();
        xy.series[0].points[1].1 = f64::NAN;
        assert!(matches!(
            draw_xy(&xy, &dir.join("x.png")),
            Err(PlotError::InvalidData(_))
        ));

        let bars = BarChart {
            title: String::new(),
            y_label: String::new(),
            groups: vec![("G".into(), vec![1.0])],
            series_names: vec!["G".into(), "αT".into()],
            pad: 0.1,
            log_y: false,
        };
        let e = draw_bar_chart(&bars, &dir.join("x.png")).unwrap_err();
        assert!(
            matches!(&e, PlotError::InvalidData(m) if m.contains("1 values")),
            "{e}"
        );

        // I/O problems surface as `Write` errors naming the file.
        xy.series[0].points[1].1 = 1.0;
        let missing = dir.join("no-such-dir").join("x.png");
        let e = draw_xy(&xy, &missing).unwrap_err();
        assert!(
            matches!(&e, PlotError::Write { path, .. } if *path == missing),
            "{e}"
        );
        let e = draw_xy(&xy, &dir.join("x.jpg")).unwrap_err();
        assert!(matches!(e, PlotError::Write { .. }), "{e}");
        let _ = std::fs::remove_dir_all(&dir);
    }

    #[test]
    fn text_is_rendered_with_the_embedded_font_and_anchored() {
        ensure_font().expect("font");
        let (w, h) = (200u32, 100u32);
        let mut buf = vec![255u8; (w * h * 3) as usize];
        {
            let root = Canvas {
                inner: BitMapBackend::with_buffer(&mut buf, (w, h)),
            }
            .into_drawing_area();
            root.draw(&Text::new(
                "Hxy 0.1".to_string(),
                (100, 50),
                text(20.0).pos(Pos::new(HPos::Center, VPos::Center)),
            ))
            .expect("text");
            root.present().expect("present");
        }
        let dark: Vec<(u32, u32)> = (0..w * h)
            .filter(|&i| buf[(i * 3) as usize] < 128)
            .map(|i| (i % w, i / w))
            .collect();
        assert!(dark.len() > 60, "text drawn: {} dark pixels", dark.len());
        let (x0, x1) = (
            dark.iter().map(|p| p.0).min().unwrap_or(0),
            dark.iter().map(|p| p.0).max().unwrap_or(0),
        );
        // Horizontally centred on x = 100 within 2 px.
        assert!(
            (x0 as i32 + x1 as i32 - 200).abs() <= 4,
            "x from {x0} to {x1}"
        );
        // Capitals are centred on y = 50: the 'H' stem spans rows symmetric about 50.
        let h_rows: Vec<u32> = dark.iter().filter(|p| p.0 <= x0 + 1).map(|p| p.1).collect();
        let (top, bottom) = (
            h_rows.iter().min().copied().unwrap_or(0),
            h_rows.iter().max().copied().unwrap_or(0),
        );
        assert!(
            (top as i32 + bottom as i32 - 100).abs() <= 2,
            "H from {top} to {bottom}"
        );
    }

    struct Flat;
    impl Projector for Flat {
        fn px(&self, p: [f64; 3]) -> (i32, i32) {
            (p[0] as i32, p[1] as i32)
        }
        fn depth(&self, p: [f64; 3]) -> f64 {
            -p[2]
        }
        fn px_per_unit(&self) -> f64 {
            1.0
        }
    }

    #[test]
    fn higher_elements_are_painted_over_lower_ones() {
        let prims = vec![
            Prim::Marker([0.0, 0.0, 2.0], BLACK, 3),
            Prim::Ball(Sphere {
                center: [0.0, 0.0, 0.0],
                radius: 1.0,
            }),
            Prim::Segment([0.0; 3], [0.0, 0.0, 1.0], BLACK, 1),
        ];
        let order: Vec<&str> = paint_order(&Flat, prims)
            .iter()
            .map(|p| match p {
                Prim::Ball(_) => "ball",
                Prim::Segment(..) => "segment",
                Prim::Marker(..) => "marker",
                Prim::Quad(..) => "quad",
            })
            .collect();
        assert_eq!(order, ["ball", "segment", "marker"]);
    }

    /// Pixels of the first frame's colour in the plot area of a 3-D view of a 3×3 sheet (plane
    /// `y = 1`, `x` from −0.5 to 0.5, `z` from 1 to 2) and a sphere of radius 0.9 on the line of
    /// sight through the sheet's centre, `toward_camera` in front of it (negative: behind it).
    fn frame_pixels_with_sphere(toward_camera: f64, name: &str) -> usize {
        let dir = scratch(name);
        let sheet = sheet(1.0);
        let view = View3d::default();
        // Unit vector from the scene towards the camera (see `View3d`).
        let eye = [
            view.yaw.sin() * view.pitch.cos(),
            -view.yaw.cos() * view.pitch.cos(),
            view.pitch.sin(),
        ];
        let centre = [0.0, 1.0, 1.5];
        let spheres = [Sphere {
            center: std::array::from_fn(|k| centre[k] + toward_camera * eye[k]),
            radius: 0.9,
        }];
        let fig = TrajectoryFigure {
            title: "wall".into(),
            grid: (3, 3),
            frames: vec![(&sheet[..], "start".into())],
            spheres: &spheres,
            ..Default::default()
        };
        let path = dir.join("wall.png");
        draw_trajectory_3d(&fig, &path).expect("3-D view");
        let (w, _, px) = decode(&path);
        let _ = std::fs::remove_dir_all(&dir);
        // The plot area only: the legend column (250 px on the right) has its own swatch.
        px.chunks(w as usize)
            .flat_map(|row| &row[..w as usize - 250])
            .filter(|p| **p == [FRAME_COLORS[0].0, FRAME_COLORS[0].1, FRAME_COLORS[0].2])
            .count()
    }

    #[test]
    fn cloth_behind_an_obstacle_still_shows() {
        let in_front = frame_pixels_with_sphere(1.5, "hidden");
        let behind = frame_pixels_with_sphere(-1.5, "visible");
        // Hidden behind the sphere, the sheet's outline is drawn dashed: at least a third of the
        // pixels it has in full view (the views' scales differ a little with the bounds).
        assert!(
            in_front * 3 >= behind,
            "{in_front} frame pixels behind the sphere, {behind} in full view"
        );
    }

    #[test]
    fn top_view_ranges_have_equal_scale() {
        let (xr, yr) = equal_aspect([[-1.0, 1.0], [-1.5, 1.5]], (600, 500));
        let sx = 600.0 / (xr[1] - xr[0]);
        let sy = 500.0 / (yr[1] - yr[0]);
        assert!((sx - sy).abs() < 1e-9, "{sx} vs {sy}");
        assert!(xr[0] <= -1.0 && xr[1] >= 1.0 && yr[0] <= -1.5 && yr[1] >= 1.5);
        assert!(
            (yr[0] + 1.5).abs() < 1e-12,
            "y is the limiting axis and stays tight"
        );
    }

    #[test]
    fn numbers_are_compact() {
        assert_eq!(fmt_num(0.0), "0");
        assert_eq!(fmt_num(0.5), "0.5");
        assert_eq!(fmt_num(0.123456), "0.123");
        assert_eq!(fmt_num(1234.0), "1234");
        assert_eq!(fmt_num(1e-5), "10⁻⁵");
        assert_eq!(fmt_num(2.5e-7), "2.5×10⁻⁷");
        assert_eq!(fmt_num(3e6), "3×10⁶");
        assert_eq!(fmt_tick(-1e-15), "0");
        assert_eq!(fmt_num(-0.25), "−0.25");
        assert_eq!(fmt_num(-1e-6), "−10⁻⁶");
    }
}
