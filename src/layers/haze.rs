//! The haze of the scene, beside the cloud layers: scene data that the weather sets and the
//! renderer draws ([`crate::render::haze`] explains how).

use bevy::prelude::*;

/// Koschmieder's constant: `ln(1 / 0.02)`, for a 2 % contrast threshold. Extinction is
/// `KOSCHMIEDER_CONSTANT / visibility` (Koschmieder 1924; WMO-No. 8, meteorological optical
/// range). The f32 of the CPU twin's [`crate::reference::haze::KOSCHMIEDER_CONSTANT`].
pub const KOSCHMIEDER_CONSTANT: f32 = crate::reference::haze::KOSCHMIEDER_CONSTANT as f32;

/// The haze of the scene: aerosol whose density follows the meteorological visibility.
/// Live-editable. With [`Haze::weather_driven`] on, the weather sets the visibility from the
/// forecast.
#[derive(Resource, Reflect, Clone, Debug, PartialEq)]
#[reflect(Resource, Default)]
pub struct Haze {
    /// Meteorological visibility at the ground, metres (the distance at which a black target
    /// keeps 2 % contrast). Default infinity: clear air, no haze. From 245 km up it adds
    /// nothing to the clear air Bevy's atmosphere draws; below 5 km the weather mapping hands
    /// the rest to the fog layer.
    pub visibility_m: f32,
    /// Height over which the haze density falls by a factor e, metres. Default 1 200 (the
    /// boundary-layer aerosol).
    pub scale_height_m: f32,
    /// Fraction of the intercepted light the haze scatters, 0–1. Default 0.9 (continental
    /// aerosol).
    pub albedo: f32,
    /// Henyey-Greenstein asymmetry of the scattering, −1–1 (positive: forward). Default 0.7.
    pub asymmetry: f32,
    /// Let the weather set [`Haze::visibility_m`] from the forecast. Default true.
    pub weather_driven: bool,
}

impl Default for Haze {
    fn default() -> Self {
        Self {
            visibility_m: f32::INFINITY,
            scale_height_m: 1200.0,
            albedo: 0.9,
            asymmetry: 0.7,
            weather_driven: true,
        }
    }
}

impl Haze {
    /// Haze with the default optics and `visibility_m` metres of visibility.
    pub fn with_visibility(visibility_m: f32) -> Self {
        Self {
            visibility_m,
            ..default()
        }
    }
}
