//! The in-memory canvas every figure draws on, PNG encoding, and data checks.

use std::path::Path;

use plotters::coord::Shift;
use plotters::prelude::*;

use crate::text::{ensure_font, Canvas};
use crate::PlotError;

pub(crate) type Area<'a> = DrawingArea<Canvas<'a>, Shift>;

pub(crate) fn de<E: std::error::Error + Send + Sync>(e: DrawingAreaErrorKind<E>) -> PlotError {
    PlotError::Draw(e.to_string())
}

/// Draws into a white in-memory RGB bitmap of `size` pixels with `draw`, then writes it to `path` as
/// a PNG (atomically: a temporary file beside it, renamed over it).
pub(crate) fn render(
    path: &Path,
    size: (u32, u32),
    draw: impl FnOnce(&Area) -> Result<(), PlotError>,
) -> Result<(), PlotError> {
    let write_err = |message: String| PlotError::Write {
        path: path.to_path_buf(),
        message,
    };
    match path.extension().and_then(|e| e.to_str()) {
        Some(e) if e.eq_ignore_ascii_case("png") => {}
        _ => return Err(write_err("the file name must end in .png".into())),
    }
    let buf = draw_rgb(size, draw)?;
    let bytes = encode_png(size, &buf).map_err(write_err)?;
    write_atomic(path, &bytes)
}

/// Draws into a white in-memory RGB bitmap of `size` pixels with `draw` and returns its pixels
/// (row-major, 3 bytes each).
pub(crate) fn draw_rgb(
    size: (u32, u32),
    draw: impl FnOnce(&Area) -> Result<(), PlotError>,
) -> Result<Vec<u8>, PlotError> {
    ensure_font()?;
    let mut buf = vec![255u8; size.0 as usize * size.1 as usize * 3];
    {
        let root = Canvas {
            inner: BitMapBackend::with_buffer(&mut buf, size),
        }
        .into_drawing_area();
        draw(&root)?;
        root.present().map_err(de)?;
    }
    Ok(buf)
}

/// An 8-bit RGB PNG of `rgb` (adaptive filter).
fn encode_png(size: (u32, u32), rgb: &[u8]) -> Result<Vec<u8>, String> {
    let mut out = Vec::new();
    let mut encoder = png::Encoder::new(&mut out, size.0, size.1);
    encoder.set_color(png::ColorType::Rgb);
    encoder.set_depth(png::BitDepth::Eight);
    encoder.set_adaptive_filter(png::AdaptiveFilterType::Adaptive);
    let mut writer = encoder.write_header().map_err(|e| e.to_string())?;
    writer.write_image_data(rgb).map_err(|e| e.to_string())?;
    writer.finish().map_err(|e| e.to_string())?;
    Ok(out)
}

/// Writes `bytes` to `path` atomically: into a temporary file in the same directory, then renamed
/// over `path`, so a reader never sees half a file. Errors name `path`.
pub fn write_atomic(path: &Path, bytes: &[u8]) -> Result<(), PlotError> {
    let write_err = |e: std::io::Error| PlotError::Write {
        path: path.to_path_buf(),
        message: e.to_string(),
    };
    let name = path
        .file_name()
        .ok_or_else(|| write_err(std::io::Error::other("not a file name")))?;
    let mut tmp_name = std::ffi::OsString::from(".");
    tmp_name.push(name);
    tmp_name.push(format!(".{}.tmp", std::process::id()));
    let tmp = path.with_file_name(tmp_name);
    let result = (|| {
        let mut f = std::fs::File::create(&tmp)?;
        std::io::Write::write_all(&mut f, bytes)?;
        f.sync_all()?;
        std::fs::rename(&tmp, path)
    })();
    if result.is_err() {
        let _ = std::fs::remove_file(&tmp);
    }
    result.map_err(write_err)
}

pub(crate) fn check_finite(what: &str, v: f64) -> Result<(), PlotError> {
    if v.is_finite() {
        Ok(())
    } else {
        Err(PlotError::InvalidData(format!("{what} is {v}")))
    }
}

pub(crate) fn check_point(what: &str, p: &[f64; 3]) -> Result<(), PlotError> {
    if p.iter().all(|v| v.is_finite()) {
        Ok(())
    } else {
        Err(PlotError::InvalidData(format!(
            "{what} is not finite: [{}, {}, {}]",
            p[0], p[1], p[2]
        )))
    }
}
