//! Compact number formatting for ticks and labels.

/// A compact number: plain decimals between 1e-3 and 1e4, else `m×10ⁿ`; minus signs as `−`.
pub(crate) fn fmt_num(v: f64) -> String {
    fmt_num_ascii(v).replace('-', "−")
}

pub(crate) fn fmt_num_ascii(v: f64) -> String {
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
pub(crate) fn fmt_tick(v: f64) -> String {
    if v.abs() < 1e-12 {
        return "0".into();
    }
    fmt_num(v)
}

pub(crate) fn superscript(e: i32) -> String {
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
