//! Where and when the scene is: the base of the weather and sky stages, which both read it and
//! neither of which imports the other.
//!
//! - [`UtcInstant`]: an instant in UTC, parsed from and printed as ISO 8601.
//! - [`Place`]: a point on Earth (WGS 84) with a name and an elevation.
//! - [`GeoOrigin`]: the resource that puts the scene origin at a geographic point.
//! - [`SceneClock`]: the resource that holds the instant the scene shows.

mod clock;
mod time;

use bevy::prelude::*;

pub(crate) use clock::advance_scene_clock;
pub use clock::{ClockMode, SceneClock};
pub use time::{CivilDateTime, TimeParseError, UtcInstant};

/// A place on Earth (WGS 84).
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Place {
    /// Name for display, e.g. `"Bern"`; meteoblue's `metadata.name`, otherwise the file stem when
    /// read with [`Forecast::from_path`](crate::weather::Forecast::from_path), otherwise empty.
    pub name: String,
    /// Latitude in degrees, north positive, −90 to 90.
    pub latitude_deg: f64,
    /// Longitude in degrees, east positive, −180 to 180.
    pub longitude_deg: f64,
    /// Ground elevation above mean sea level in metres (meteoblue `metadata.height`, Open-Meteo
    /// `elevation`); 0 when the file does not say, with a note in [`Forecast::warnings`](crate::weather::Forecast::warnings).
    pub elevation_m: f64,
}

/// The geographic point at the scene origin, a resource: scene metres are measured on the local
/// tangent plane there, +X east, +Y up, −Z north. The sun is placed for this point, and far
/// forecasts are placed relative to it. Default: Bern at sea level.
#[derive(Resource, Debug, Clone, Copy, PartialEq, Reflect)]
#[reflect(Resource, Default)]
pub struct GeoOrigin {
    /// Latitude, degrees north. Default 46.948 (Bern).
    pub latitude_deg: f64,
    /// Longitude, degrees east. Default 7.447 (Bern).
    pub longitude_deg: f64,
    /// Height of the scene's y = 0 above sea level, metres. Default 0: scene y is altitude.
    pub elevation_m: f64,
}

impl Default for GeoOrigin {
    fn default() -> Self {
        Self {
            latitude_deg: 46.948,
            longitude_deg: 7.447,
            elevation_m: 0.0,
        }
    }
}

/// WGS 84 semi-major axis, metres.
const WGS84_A_M: f64 = 6_378_137.0;
/// WGS 84 first eccentricity squared.
const WGS84_E2: f64 = 6.694_379_990_14e-3;

impl GeoOrigin {
    /// Scene position (metres; +X east, −Z north, +Y up) of a geographic point.
    ///
    /// Uses the local tangent plane with the WGS 84 radii of curvature at the origin (meridional
    /// `M` for north, prime vertical `N cos φ` for east). At 50 km from the origin the distance
    /// error from neglecting the curvature of the meridians is under 0.1 % — well inside a weather
    /// cell — which is why a full ECEF→ENU transform is not needed at this scale.
    pub fn to_scene(&self, latitude_deg: f64, longitude_deg: f64, elevation_m: f64) -> Vec3 {
        let phi = self.latitude_deg.to_radians();
        let w = 1.0 - WGS84_E2 * phi.sin().powi(2);
        let prime_vertical = WGS84_A_M / w.sqrt();
        let meridional = WGS84_A_M * (1.0 - WGS84_E2) / w.powf(1.5);
        let east = prime_vertical * phi.cos() * (longitude_deg - self.longitude_deg).to_radians();
        let north = meridional * (latitude_deg - self.latitude_deg).to_radians();
        Vec3::new(
            east as f32,
            (elevation_m - self.elevation_m) as f32,
            -north as f32,
        )
    }
}
