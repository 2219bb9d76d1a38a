//! JSON printing (arrays of scalars on one line) and parse-error messages.

use serde::Serialize;

use super::SceneError;

/// `text` with control characters (newlines, tabs, …) escaped, so an error quoting user input
/// (an unknown field name, a scene name) stays on one line.
pub(super) fn one_line(text: &str) -> String {
    text.chars()
        .map(|c| {
            if c.is_control() {
                c.escape_default().to_string()
            } else {
                c.to_string()
            }
        })
        .collect()
}

/// Pretty-prints `value` as JSON with arrays of scalars on one line. With serde_json's
/// `float_roundtrip` feature (enabled in this workspace) every `f64` reads back bit-identically.
pub fn to_json_pretty_compact<T: Serialize + ?Sized>(
    value: &T,
) -> Result<String, serde_json::Error> {
    Ok(inline_scalar_arrays(&serde_json::to_string_pretty(value)?))
}

/// Puts every JSON array that contains no strings, objects or arrays on a single line: `[1.0, 2.0, 3.0]`.
fn inline_scalar_arrays(text: &str) -> String {
    let bytes = text.as_bytes();
    let mut out = String::with_capacity(text.len());
    let (mut i, mut start) = (0, 0);
    let mut in_string = false;
    while i < bytes.len() {
        let b = bytes[i];
        if in_string {
            match b {
                b'\\' => i += 1,
                b'"' => in_string = false,
                _ => {}
            }
        } else if b == b'"' {
            in_string = true;
        } else if b == b'[' {
            let close = bytes[i + 1..]
                .iter()
                .position(|&c| matches!(c, b'[' | b']' | b'{' | b'"'))
                .map(|p| i + 1 + p);
            if let Some(j) = close.filter(|&j| bytes[j] == b']') {
                let items: Vec<&str> = text[i + 1..j]
                    .split(',')
                    .map(str::trim)
                    .filter(|t| !t.is_empty())
                    .collect();
                out.push_str(&text[start..i]);
                out.push('[');
                out.push_str(&items.join(", "));
                out.push(']');
                i = j + 1;
                start = i;
                continue;
            }
        }
        i += 1;
    }
    out.push_str(&text[start..]);
    out
}

/// Appends the offending source line to a serde_json error message.
pub(super) fn parse_error(text: &str, err: &serde_json::Error) -> SceneError {
    let mut message = err.to_string();
    if err.line() > 0 {
        if let Some(line) = text.lines().nth(err.line() - 1) {
            let line = line.trim();
            if !line.is_empty() {
                let shown: String = line.chars().take(120).collect();
                let ellipsis = if line.chars().count() > 120 {
                    "…"
                } else {
                    ""
                };
                message.push_str(&format!(": `{shown}{ellipsis}`"));
            }
        }
    }
    SceneError::Parse {
        message: one_line(&message),
    }
}
