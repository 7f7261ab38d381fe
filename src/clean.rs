//! The rules the `sanitize` methods of the user's components share: what a value the renderer
//! cannot use becomes.

/// `value` clamped to `min..=max`; NaN becomes `nan`.
pub(crate) fn clamp_or(value: f32, min: f32, max: f32, nan: f32) -> f32 {
    if value.is_nan() {
        nan
    } else {
        value.clamp(min, max)
    }
}

/// `value` when it is finite, otherwise `default`.
pub(crate) fn finite_or(value: f32, default: f32) -> f32 {
    if value.is_finite() { value } else { default }
}

/// `value` when it is finite and above 0, otherwise `default`.
pub(crate) fn positive_or(value: f32, default: f32) -> f32 {
    if value.is_finite() && value > 0.0 {
        value
    } else {
        default
    }
}

/// `value` raised to 0 when negative; a non-finite value becomes 0.
pub(crate) fn non_negative(value: f32) -> f32 {
    if value.is_finite() {
        value.max(0.0)
    } else {
        0.0
    }
}
