//! The sky over the scene: where the sun and the moon are for a place and a UTC instant.
//!
//! - [`solar_position`] implements NREL's Solar Position Algorithm (Reda & Andreas 2004),
//!   checked against the paper's worked example and against published ephemeris tables; see
//!   [`solar`].
//! - [`lunar_position`] gives the moon's direction, distance and illuminated fraction (Meeus
//!   1998, chapters 47 and 48); see [`moon`].
//! - A `DirectionalLight` with the [`Sun`] component is aimed from the true solar position for
//!   the [`GeoOrigin`] at the [`SceneClock`]'s instant, and dims to
//!   nothing as the sun's disc sets; then it is the moon's light, aimed from the moon with its
//!   illuminance for the phase, until the moon sets or the sun rises.
//! - [`stars::StarField`] puts stars on the night sky, turning with the sidereal time; the
//!   clouds hide them.

pub mod light;
pub mod moon;
#[cfg(test)]
mod pvlib;
pub mod solar;
pub mod stars;
mod sun;

use bevy::prelude::*;

pub use moon::{LunarPosition, lunar_position, lunar_position_unix_seconds};
pub use solar::{
    Observer, SolarOptions, SolarPosition, direction_enu, estimate_delta_t_s, julian_day,
    solar_position, solar_position_unix_seconds,
};
pub use sun::{
    MoonPosition, Sun, SunPosition, TWILIGHT_END_DEG, TWILIGHT_FULL_DEG, moon_direction_scene,
    sun_direction_scene, sun_or_moon_light, sun_visibility, twilight_share,
};

use crate::{
    CloudscapeSystems,
    scene::{GeoOrigin, SceneClock, advance_scene_clock},
};

/// The scene clock, the scene origin and the sun; part of [`crate::CloudscapePlugin`].
#[derive(Debug, Default, Clone, Copy)]
pub struct SkyPlugin;

impl Plugin for SkyPlugin {
    fn build(&self, app: &mut App) {
        app.init_resource::<SceneClock>()
            .init_resource::<GeoOrigin>()
            .init_resource::<SunPosition>()
            .init_resource::<MoonPosition>()
            .init_resource::<stars::StarField>()
            .init_resource::<stars::StarSky>()
            .register_type::<stars::StarField>()
            .register_type::<SceneClock>()
            .register_type::<GeoOrigin>()
            .register_type::<Sun>()
            .add_systems(
                Update,
                (
                    advance_scene_clock.in_set(CloudscapeSystems::Clock),
                    (sun::place_sun, stars::place_stars)
                        .chain()
                        .in_set(CloudscapeSystems::Sun),
                ),
            );
    }
}
