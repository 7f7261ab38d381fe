//! Places the scene's sun where it really is for the scene's place and time.

use bevy::{light::light_consts::lux, prelude::*};

use super::solar::{Observer, SolarOptions, SolarPosition, solar_position_unix_seconds};
use crate::scene::{GeoOrigin, SceneClock};

/// Put on a `DirectionalLight` to have the crate aim it from the sun's true position for the
/// [`GeoOrigin`] (or [`GeoOrigin::default`], Bern, without one) at the [`SceneClock`] time, and
/// set its illuminance.
#[derive(Component, Debug, Clone, Copy, PartialEq, Reflect)]
#[reflect(Component, Default)]
pub struct Sun {
    /// Illuminance with the sun fully above the horizon, lux. Default
    /// `lux::RAW_SUNLIGHT` (sunlight above the atmosphere), right for Bevy's `Atmosphere`, which
    /// attenuates the light itself.
    pub illuminance_lux: f32,
}

impl Default for Sun {
    fn default() -> Self {
        Self {
            illuminance_lux: lux::RAW_SUNLIGHT,
        }
    }
}

/// Where the sun is now, updated every frame in [`crate::CloudscapeSystems::Sun`].
#[derive(Resource, Debug, Clone, Copy, Default)]
pub struct SunPosition(pub Option<SolarPosition>);

/// Angular radius of the sun's disc, degrees: the light fades while the disc crosses the horizon.
const SUN_ANGULAR_RADIUS_DEG: f64 = 0.267;

/// Unit vector toward the sun in scene space (+X east, +Y up, −Z north).
pub fn sun_direction_scene(position: &SolarPosition) -> Vec3 {
    let [east, north, up] = position.direction_enu();
    Vec3::new(east as f32, up as f32, -north as f32).normalize()
}

/// Fraction of the sun's disc above the horizon, approximated linearly in elevation: 0 at
/// night, 1 by day. Keeps a light under the ground from lighting the scene from below.
pub fn sun_visibility(elevation_deg: f64) -> f32 {
    (((elevation_deg + SUN_ANGULAR_RADIUS_DEG) / (2.0 * SUN_ANGULAR_RADIUS_DEG)).clamp(0.0, 1.0))
        as f32
}

pub(crate) fn place_sun(
    clock: Res<SceneClock>,
    origin: Option<Res<GeoOrigin>>,
    mut position: ResMut<SunPosition>,
    mut suns: Query<(&Sun, &mut Transform, &mut DirectionalLight)>,
) {
    let origin = origin.map_or_else(GeoOrigin::default, |origin| *origin);
    let solar = solar_position_unix_seconds(
        &Observer::from(&origin),
        clock.unix_seconds(),
        &SolarOptions::default(),
    );
    position.0 = Some(solar);
    let toward_sun = sun_direction_scene(&solar);
    let up = if toward_sun.y.abs() > 0.999 {
        Vec3::NEG_Z
    } else {
        Vec3::Y
    };
    for (sun, mut transform, mut light) in &mut suns {
        // A directional light shines along its forward (-Z) axis, away from the sun. Only the
        // rotation is set: translation and scale place the cloud-shadow texture
        // (`render::shadow`) and do not affect the light.
        transform.rotation = Transform::default().looking_to(-toward_sun, up).rotation;
        light.illuminance = sun.illuminance_lux * sun_visibility(solar.elevation_deg);
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn direction_follows_azimuth_and_elevation() {
        let bern = Observer::from(&GeoOrigin::default());
        // Bern, 2021-06-21 11:30 UTC: near the June solstice culmination (local noon ≈ 11:28
        // UTC), so the sun stands due south at 90 − (46.948 − 23.44) ≈ 66.5°.
        let noon = crate::scene::UtcInstant::from_civil(2021, 6, 21, 11, 30, 0).unwrap();
        let p = solar_position_unix_seconds(
            &bern,
            noon.unix_seconds() as f64,
            &SolarOptions::default(),
        );
        let d = sun_direction_scene(&p);
        assert!(d.z > 0.0, "south is +Z: {d}");
        assert!((d.y - (p.elevation_deg.to_radians().sin() as f32)).abs() < 1e-5);
        assert!((p.elevation_deg - 66.5).abs() < 0.3, "{}", p.elevation_deg);
    }

    #[test]
    fn light_fades_across_the_horizon() {
        assert_eq!(sun_visibility(-5.0), 0.0);
        assert_eq!(sun_visibility(5.0), 1.0);
        assert!((sun_visibility(0.0) - 0.5).abs() < 1e-6);
        assert!(sun_visibility(-0.1) < sun_visibility(0.1));
    }
}
