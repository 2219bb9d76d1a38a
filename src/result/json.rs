//! How the result JSON holds numbers that JSON cannot (NaN, ∞ are written as `null`) and
//! wall-clock times that are not reported (left out, read back as NaN).

/// The value of a time that is not reported (`optimize --no-timing`): NaN.
pub(crate) fn not_timed() -> f64 {
    f64::NAN
}

/// True for a time that is not reported (NaN): such a time is left out of the JSON.
pub(crate) fn is_nan(v: &f64) -> bool {
    v.is_nan()
}

/// A number that JSON may hold as `null` (how `serde_json` writes NaN and ∞): `null` reads as NaN.
pub(crate) fn null_as_nan<'de, D: serde::Deserializer<'de>>(d: D) -> Result<f64, D::Error> {
    let v: Option<f64> = serde::Deserialize::deserialize(d)?;
    Ok(v.unwrap_or(f64::NAN))
}
