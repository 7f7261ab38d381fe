//! Sampling a [`Forecast`] at an instant into a [`WeatherState`]; [`Sampler`] documents the
//! interpolation rules.
//!
//! [`Forecast`]: crate::weather::Forecast

mod interpolate;
mod sampler;
mod state;

pub use sampler::{SampleWarning, Sampler};
pub use state::{DataEdge, LevelState, VariableSet, WeatherState};

/// Default longest gap between valid values that sampling bridges: 3 hours, in seconds.
pub const DEFAULT_MAX_BRIDGE_S: f64 = 3.0 * 3600.0;

/// Pressure levels sampled into [`WeatherState::upper_air`], hPa: the levels that the format notes
/// map to cloud altitudes (850 hPa ≈ 1.5 km, 700 ≈ 3.0 km, 500 ≈ 5.6 km, 300 ≈ 9.2 km).
pub const STANDARD_LEVELS_HPA: [f32; 4] = [850.0, 700.0, 500.0, 300.0];

#[cfg(test)]
mod tests;
