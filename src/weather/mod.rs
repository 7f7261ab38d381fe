//! Weather forecasts: reading meteoblue and Open-Meteo files into a [`Forecast`], and sampling it
//! at an instant into a [`WeatherState`].
//!
//! This is the first stage of the crate's data flow (forecast files → `weather/` → layers →
//! render): everything after it sees UTC instants and SI units only.
//!
//! # Reading
//!
//! [`Forecast::from_path`], [`Forecast::from_reader`] and [`Forecast::from_slice`] detect the format
//! (or take a [`ForecastFormat`]) and read
//!
//! - meteoblue Packages API JSON: `basic-1h`, `clouds-1h`, both merged, with or without
//!   `data_day`, `data_xmin`, `data_3h`, `data_current` and profile blocks; local
//!   `"YYYY-MM-DD hh:mm"` times with `metadata.utc_timeoffset`, ISO 8601 or UTC timestamps; the
//!   API's misspelt `timezone_abbrevation` (meteoblue's Packages API documentation (docs.meteoblue.com));
//! - Open-Meteo JSON, one location or an array (Open-Meteo's forecast API documentation (open-meteo.com/en/docs)).
//!
//! Typed serde structs do the reading, so unknown keys are ignored and missing required keys are
//! errors. `null` values stay explicit gaps ([`Series`] holds `Option<f32>`). A bad file never
//! panics: it gives a [`ForecastError`] naming the file, key and index.
//!
//! # Sampling
//!
//! A [`Sampler`] interpolates linearly in time, turns wind into vectors and precipitation amounts
//! into rates, bridges short gaps, clamps instants outside the data, and warns once per excursion;
//! [`Sampler`] documents the rules. It does not allocate.
//!
//! # Mapping, presets and transitions
//!
//! [`mapping`] turns the sampled weather into the [`LayerSlot`] layers; between two forecast
//! steps it blends the layers of both, so nothing steps at the hour. [`preset`] holds named skies
//! ([`CloudPreset`]) that [`ActivePreset`] applies instead of the forecast. Both write the
//! targets of the layers' [`LayerTransition`](crate::layers::LayerTransition)s, which move the
//! layers there smoothly.
//!
//! # Example
//!
//! ```no_run
//! # use bevy_cloudscape::{scene::UtcInstant, weather::{Forecast, Sampler}};
//! let forecast = Forecast::from_path("assets/weather/bern.json", None)?;
//! let mut sampler = Sampler::new();
//! let noon: UtcInstant = "2021-05-03T12:00:00Z".parse()?;
//! let state = sampler.sample(&forecast, noon);
//! if let Some(warning) = sampler.take_warning() {
//!     eprintln!("{warning}");
//! }
//! println!("low cloud cover {:?}", state.low_cover());
//! # Ok::<(), Box<dyn std::error::Error>>(())
//! ```

mod error;
mod forecast;
#[cfg(feature = "live")]
mod live;
pub mod mapping;
mod meteoblue;
mod open_meteo;
pub mod preset;
mod raw;
mod sample;
mod source;
mod units;

use bevy::prelude::*;

use crate::CloudscapeSystems;

pub use error::ForecastError;
pub use forecast::{Forecast, ForecastFormat, PressureLevel, Series, Variable};
#[cfg(feature = "live")]
pub use live::{
    LiveForecast, LiveForecastError, LiveForecasts, LiveStatus, MIN_REFRESH,
    OPEN_METEO_FORECAST_URL, OPEN_METEO_HOURLY,
};
pub use mapping::{
    CloudBand, CloudBands, InputFault, LayerSlot, MAPPING_TABLE, MappedWeather, MappingRow,
    MappingWarning, WeatherLayers, WeatherMapping, layers_for_weather, map_weather,
    spawn_weather_layers,
};
pub use preset::{ActivePreset, CloudPreset, PresetLoader};
pub use sample::{
    DEFAULT_MAX_BRIDGE_S, DataEdge, LevelState, STANDARD_LEVELS_HPA, SampleWarning, Sampler,
    VariableSet, WeatherState,
};
pub use source::{
    CurrentWeather, FarForecast, ForecastLoader, ForecastSteps, PlaceWeather, WeatherSource,
};

/// Forecast assets, their loader, the per-frame sampling of the [`WeatherSource`] into
/// [`CurrentWeather`], and the mapping of that weather onto [`LayerSlot`] layers; part of
/// [`crate::CloudscapePlugin`].
#[derive(Debug, Default, Clone, Copy)]
pub struct WeatherPlugin;

impl Plugin for WeatherPlugin {
    fn build(&self, app: &mut App) {
        app.init_asset::<Forecast>()
            .register_asset_loader(ForecastLoader)
            .init_asset::<CloudPreset>()
            .register_asset_loader(PresetLoader)
            .init_resource::<CurrentWeather>()
            .register_type::<WeatherSource>()
            .register_type::<LayerSlot>()
            .register_type::<crate::layers::CloudLayer>()
            .register_type::<crate::layers::LayerTransition>()
            .register_type::<crate::layers::HazeTransition>()
            .init_resource::<crate::layers::HazeTransition>();
        #[cfg(feature = "live")]
        app.init_resource::<LiveForecasts>().add_systems(
            Update,
            live::refresh_live_forecasts
                .before(source::report_failed_forecasts)
                .in_set(CloudscapeSystems::Weather),
        );
        app.add_systems(
            Update,
            (
                (source::report_failed_forecasts, source::sample_weather)
                    .chain()
                    .in_set(CloudscapeSystems::Weather),
                (
                    preset::report_failed_presets,
                    preset::apply_active_preset,
                    mapping::map_weather_onto_layers,
                    crate::layers::run_transitions,
                )
                    .chain()
                    .in_set(CloudscapeSystems::Layers),
            ),
        );
    }
}
