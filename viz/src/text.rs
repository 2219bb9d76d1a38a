//! Text: the embedded DejaVu Sans font and a bitmap backend that lays text out itself.

use std::sync::OnceLock;

use plotters::prelude::*;
use plotters::style::text_anchor::{HPos, VPos};
use plotters_backend::{BackendColor, BackendCoord, DrawingErrorKind};

use crate::PlotError;

pub(crate) static FONT_BYTES: &[u8] = include_bytes!("../assets/fonts/DejaVuSans.ttf");
pub(crate) const FAMILY: &str = "sans-serif";

pub(crate) fn ensure_font() -> Result<(), PlotError> {
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

/// A bitmap backend that lays text out itself (side bearings, kerning, baseline), because the text
/// path of plotters' `ab_glyph` feature drops the glyphs' side bearings, which makes small labels
/// hard to read ("vi sible"). Everything else goes to [`BitMapBackend`].
pub(crate) struct Canvas<'a> {
    pub(crate) inner: BitMapBackend<'a>,
}

pub(crate) fn font_ref() -> Option<&'static ab_glyph::FontRef<'static>> {
    static FONT: OnceLock<Option<ab_glyph::FontRef<'static>>> = OnceLock::new();
    FONT.get_or_init(|| ab_glyph::FontRef::try_from_slice(FONT_BYTES).ok())
        .as_ref()
}

/// One laid-out line of text: glyphs positioned on a baseline at y = 0, starting at x = 0.
pub(crate) struct Laid {
    glyphs: Vec<ab_glyph::Glyph>,
    width: f32,
    ascent: f32,
    descent: f32,
    cap: f32,
}

pub(crate) fn lay_out(text: &str, size: f64) -> Option<Laid> {
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
