//! # `bevy_cloudscape`
//!
//! Weather-driven volumetric clouds for the [Bevy](https://bevyengine.org) game engine.
//!
//! Add [`CloudscapePlugin`] to an app. The crate is organised in the order data flows through
//! it, from a forecast value to a pixel:
//!
//! | stage | module | what it does |
//! |---|---|---|
//! | place and time | [`scene`] | [`scene::UtcInstant`], [`scene::Place`], the scene's [`scene::GeoOrigin`] and [`scene::SceneClock`]: what the weather and the sky both read |
//! | weather | [`weather`] | meteoblue / Open-Meteo files to a [`weather::Forecast`], sampled into a [`weather::WeatherState`] and mapped onto layers; weather presets ([`weather::CloudPreset`]) |
//! | sky | [`sky`] | where the sun is for a place and a UTC instant (NREL SPA), and the light it aims |
//! | world | [`world`] | [`world::CloudWorld`]: the planet, its anchoring, the cloud noise and phase function, shared by every camera |
//! | layers | [`layers`] | [`layers::CloudLayer`]: altitude, coverage, density, kind and profile, wind; [`layers::LayerTransition`] moves a layer smoothly to a target |
//! | noise | [`render::noise`] | compute pass filling tileable 3D cloud-noise textures once |
//! | march | [`render::march`] | fullscreen ray-march of the layers per camera, stopped by the depth prepass, composited in HDR |
//! | shadow | [`render::shadow`] | the cloud shadow map along the sun, applied to the sun's light on every `StandardMaterial` |
//! | CPU queries | [`query`] | [`query::CloudQuery`]: density, "in cloud?" and sunlight at any point, for game logic |
//! | precipitation | [`precipitation`] | rain and snow near the camera, from the layers' rain rate |
//! | lightning | [`lightning`] | cumulonimbus layers flash: light inside the cloud and on the ground |
//! | terrain | `terrain` | DEM readers and a terrain mesh builder (for the Bern demo and your own scenes; the default `terrain` feature) |
//!
//! Compatible with Bevy 0.19.
//!
//! # References
//!
//! The docs cite sources by author and year:
//!
//! - Hillaire 2016, "Physically Based Sky, Atmosphere and Cloud Rendering in Frostbite".
//! - Jennings et al. 2018, "Spatial variation of the rain–snow temperature threshold across the
//!   Northern Hemisphere".
//! - Karis 2014, "High Quality Temporal Supersampling".
//! - Marshall & Palmer 1948, "The distribution of raindrops with size".
//! - Pérez Martín 2022, "Aetherius: Real-Time Volumetric Cloud Generation Tool for Unity".
//! - Perlin 2002, "Improving Noise".
//! - Reda & Andreas 2004, "Solar position algorithm for solar radiation applications".
//! - Rosa 2013, "Large-scale cloudscapes using noise".
//! - Schneider 2015, "The real-time volumetric cloudscapes of Horizon Zero Dawn".
//! - Stephens 1978, "Radiation profiles in extended water clouds. II: Parameterization schemes".
//! - Thomann 2020, "Procedural cloud shader".
//! - Thomann 2021, "Near Real-time Weather Rendering System".
//! - Wrenninge 2013, "Oz: the great and volumetric".
#![deny(missing_docs)]

use bevy::{
    app::{PluginGroup, PluginGroupBuilder},
    prelude::*,
};

mod clean;
pub mod layers;
pub mod lightning;
pub mod precipitation;
pub mod query;
#[doc(hidden)]
pub mod reference;
pub mod render;
pub mod scene;
pub mod sky;
#[cfg(feature = "terrain")]
pub mod terrain;
mod validation;
pub mod weather;
pub mod world;

/// Everything a game needs to add clouds, in one import.
pub mod prelude {
    pub use crate::layers::{CloudGrowth, CloudKind, CloudLayer, DensityProfile, LayerTransition};
    pub use crate::precipitation::{
        PrecipitationPlugin, PrecipitationSettings, PrecipitationState,
    };
    pub use crate::query::{CloudQuery, CloudQueryPlugin};
    pub use crate::render::{
        CloudQuality, CloudRenderPlugin, VolumetricClouds,
        haze::Haze,
        noise::{CloudNoisePlugin, CloudNoiseSettings},
        shadow::CloudShadows,
    };
    pub use crate::scene::{ClockMode, GeoOrigin, SceneClock, UtcInstant};
    pub use crate::sky::{SkyPlugin, Sun};
    pub use crate::weather::{
        ActivePreset, CloudPreset, CurrentWeather, Forecast, LayerSlot, WeatherPlugin,
        WeatherSource, spawn_weather_layers,
    };
    pub use crate::world::{CloudWorld, PlanetAnchor};
    pub use crate::{CloudscapePlugin, CloudscapeSystems};
}

/// Adds every stage of the cloud pipeline.
///
/// It is a [`PluginGroup`]: stages can be left out or replaced, for example
/// `CloudscapePlugin.build().disable::<PrecipitationPlugin>()` for a sky without rain and snow.
///
/// [`PrecipitationPlugin`]: precipitation::PrecipitationPlugin
#[derive(Debug, Default, Clone, Copy)]
pub struct CloudscapePlugin;

impl PluginGroup for CloudscapePlugin {
    fn build(self) -> PluginGroupBuilder {
        PluginGroupBuilder::start::<Self>()
            .add(SchedulePlugin)
            .add(weather::WeatherPlugin)
            .add(sky::SkyPlugin)
            .add(render::CloudRenderPlugin)
            .add(precipitation::PrecipitationPlugin)
            .add(lightning::LightningPlugin)
    }
}

/// Where the crate's main-world systems run in `Update`, in this order. Order your own systems
/// against them, e.g. set the [`scene::SceneClock`] `.before(CloudscapeSystems::Clock)`.
#[derive(SystemSet, Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum CloudscapeSystems {
    /// Advances the [`scene::SceneClock`].
    Clock,
    /// Samples the [`weather::WeatherSource`] forecasts into [`weather::CurrentWeather`].
    Weather,
    /// Maps the weather onto weather-driven [`layers::CloudLayer`]s (or their
    /// [`layers::LayerTransition`] targets), then moves every transition.
    Layers,
    /// Aims the [`sky::Sun`] lights.
    Sun,
}

/// Orders the [`CloudscapeSystems`] sets, and reports values the renderer cannot draw as given.
struct SchedulePlugin;

impl Plugin for SchedulePlugin {
    fn build(&self, app: &mut App) {
        app.add_plugins(validation::plugin).configure_sets(
            Update,
            (
                CloudscapeSystems::Clock,
                CloudscapeSystems::Weather,
                CloudscapeSystems::Layers,
                CloudscapeSystems::Sun,
            )
                .chain(),
        );
    }
}

/// Compiles the code blocks of `README.md` as doctests, so the quick start cannot rot.
#[doc = include_str!("../README.md")]
#[cfg(doctest)]
pub struct ReadmeDoctests;
