//! The Bevy side of the weather stage: forecasts as hot-reloading assets, the [`WeatherSource`]
//! that names them, and the [`CurrentWeather`] sampled from them every frame.
//!
//! Forecast files load through the asset server with [`ForecastLoader`] (extension `.json`), so a
//! scheduled job that replaces `assets/weather/bern.json` with a fresh download changes the sky a
//! moment later when Bevy's `file_watcher` feature is on. A file that fails to load or reload is
//! reported with `warn!` naming the file, key and index, and the last good forecast stays in use.

use bevy::{
    asset::{
        AssetLoadError, AssetLoadFailedEvent, AssetLoader, AssetPath, LoadContext, io::Reader,
    },
    platform::collections::HashMap,
    prelude::*,
};

use super::{Forecast, ForecastError, SampleWarning, Sampler, WeatherState};
use crate::scene::{GeoOrigin, Place, SceneClock};

/// Reads meteoblue and Open-Meteo JSON files into [`Forecast`] assets (format detected).
#[derive(Debug, Default, Clone, Copy, TypePath)]
pub struct ForecastLoader;

impl AssetLoader for ForecastLoader {
    type Asset = Forecast;
    type Settings = ();
    type Error = ForecastError;

    async fn load(
        &self,
        reader: &mut dyn Reader,
        _settings: &(),
        load_context: &mut LoadContext<'_>,
    ) -> Result<Forecast, ForecastError> {
        let path = load_context.path().path().to_path_buf();
        let mut bytes = Vec::new();
        reader
            .read_to_end(&mut bytes)
            .await
            .map_err(|e| ForecastError::Io {
                file: Some(path.clone()),
                message: e.to_string(),
            })?;
        let mut forecast = Forecast::from_slice(&bytes, None).map_err(|e| e.with_file(&path))?;
        if forecast.place.name.is_empty()
            && let Some(stem) = path.file_stem()
        {
            forecast.place.name = stem.to_string_lossy().into_owned();
        }
        Ok(forecast)
    }

    fn extensions(&self) -> &[&str] {
        &["json"]
    }
}

/// A forecast for a place other than the scene origin (Thomann 2021 §4.4–4.5: Solothurn or
/// Fribourg on the horizon while Bern fills the foreground).
#[derive(Debug, Clone, Reflect)]
pub struct FarForecast {
    /// The forecast file.
    pub forecast: Handle<Forecast>,
}

/// Which forecasts drive the scene.
///
/// The near forecast fills the foreground; each far forecast shows toward its own place, blended
/// in space by the weather map (its position comes from the file's latitude and longitude through
/// [`GeoOrigin::to_scene`] of the [`GeoOrigin`] resource). Without a near forecast the weather stage does nothing and layers
/// keep their hand-set values.
#[derive(Resource, Debug, Clone, Default, Reflect)]
#[reflect(Resource)]
pub struct WeatherSource {
    /// The forecast for the scene's own place.
    pub near: Option<Handle<Forecast>>,
    /// Forecasts for distant places.
    pub far: Vec<FarForecast>,
}

impl WeatherSource {
    /// A source that loads `near` and each of `far` through the asset server.
    pub fn load<'a>(
        asset_server: &AssetServer,
        near: impl Into<AssetPath<'a>>,
        far: impl IntoIterator<Item = AssetPath<'a>>,
    ) -> Self {
        Self {
            near: Some(asset_server.load(near.into())),
            far: far
                .into_iter()
                .map(|path| FarForecast {
                    forecast: asset_server.load(path),
                })
                .collect(),
        }
    }
}

/// The weather at one place, sampled at the scene time.
#[derive(Debug, Clone)]
pub struct PlaceWeather {
    /// Where the forecast is for.
    pub place: Place,
    /// The place in scene metres (see [`GeoOrigin::to_scene`]).
    pub scene_position: Vec3,
    /// The interpolated state.
    pub state: WeatherState,
    /// The forecast's own steps on either side of the scene time, which the weather mapping
    /// blends so that nothing it derives (a cloud kind from a cover threshold, a weather code)
    /// steps at the hour. `None` outside the forecast, or for a state made by hand.
    pub steps: Option<ForecastSteps>,
}

/// The states at the forecast steps around an instant ([`PlaceWeather::steps`]).
#[derive(Debug, Clone)]
pub struct ForecastSteps {
    /// The state at the last step at or before the instant.
    pub before: WeatherState,
    /// The state at the next step.
    pub after: WeatherState,
    /// Where the instant lies from `before` (0) to `after` (1).
    pub fraction: f32,
}

impl ForecastSteps {
    /// The steps of `forecast` around `unix_seconds`, or `None` outside its times (or for a NaN
    /// time). Each state is sampled exactly at its step.
    #[must_use]
    pub fn around(forecast: &Forecast, unix_seconds: f64) -> Option<Self> {
        let times = &forecast.times;
        let after = times.partition_point(|t| (t.unix_seconds() as f64) <= unix_seconds);
        if after == 0 || after >= times.len() {
            return None;
        }
        let (t0, t1) = (times[after - 1], times[after]);
        let span = (t1.unix_seconds() - t0.unix_seconds()) as f64;
        if span <= 0.0 {
            return None;
        }
        Some(Self {
            before: forecast.sample(t0),
            after: forecast.sample(t1),
            fraction: ((unix_seconds - t0.unix_seconds() as f64) / span).clamp(0.0, 1.0) as f32,
        })
    }
}

/// The forecasts of [`WeatherSource`] sampled at the [`SceneClock`] time; updated every frame in
/// [`crate::CloudscapeSystems::Weather`].
///
/// A forecast that has not loaded yet, or failed to load, keeps its last good state (or `None`
/// before the first).
#[derive(Resource, Debug, Clone, Default)]
pub struct CurrentWeather {
    /// The near place.
    pub near: Option<PlaceWeather>,
    /// The far places, in the order of [`WeatherSource::far`] (`None` until loaded).
    pub far: Vec<Option<PlaceWeather>>,
}

/// One sampler per forecast, so each warns once per excursion rather than once per frame.
#[derive(Default)]
pub(crate) struct Samplers {
    near: Sampler,
    far: Vec<Sampler>,
}

fn sample_place(
    forecasts: &Assets<Forecast>,
    handle: &Handle<Forecast>,
    sampler: &mut Sampler,
    origin: &GeoOrigin,
    unix_seconds: f64,
) -> Option<PlaceWeather> {
    let forecast = forecasts.get(handle)?;
    let state = sampler.sample_unix_seconds(forecast, unix_seconds);
    while let Some(warning) = sampler.take_warning() {
        report(&forecast.place.name, &warning);
    }
    let place = &forecast.place;
    Some(PlaceWeather {
        scene_position: origin.to_scene(place.latitude_deg, place.longitude_deg, place.elevation_m),
        place: place.clone(),
        state,
        steps: ForecastSteps::around(forecast, unix_seconds),
    })
}

fn report(place: &str, warning: &SampleWarning) {
    warn!("bevy_cloudscape: forecast for {place}: {warning}");
}

/// Samples every forecast of the [`WeatherSource`] at the scene time.
pub(crate) fn sample_weather(
    source: Option<Res<WeatherSource>>,
    origin: Option<Res<GeoOrigin>>,
    clock: Res<SceneClock>,
    forecasts: Res<Assets<Forecast>>,
    mut current: ResMut<CurrentWeather>,
    mut samplers: Local<Samplers>,
) {
    let Some(source) = source else {
        return;
    };
    let origin = origin.map_or_else(GeoOrigin::default, |origin| *origin);
    let t = clock.unix_seconds();
    if let Some(near) = &source.near
        && let Some(sampled) = sample_place(&forecasts, near, &mut samplers.near, &origin, t)
    {
        current.near = Some(sampled);
    }
    samplers.far.resize_with(source.far.len(), Sampler::new);
    current.far.resize(source.far.len(), None);
    for ((far, sampler), slot) in source
        .far
        .iter()
        .zip(&mut samplers.far)
        .zip(&mut current.far)
    {
        if let Some(sampled) = sample_place(&forecasts, &far.forecast, sampler, &origin, t) {
            *slot = Some(sampled);
        }
    }
}

/// Logs forecast files that failed to load, naming file, key and index; the last good forecast
/// stays in `Assets<Forecast>`.
pub(crate) fn report_failed_forecasts(
    mut failures: MessageReader<AssetLoadFailedEvent<Forecast>>,
    mut loaded: MessageReader<AssetEvent<Forecast>>,
    server: Res<AssetServer>,
    mut reported: Local<HashMap<AssetPath<'static>, String>>,
) {
    let _ = report_load_failures::<Forecast, ForecastError>(
        "forecast",
        "data",
        &mut failures,
        &mut loaded,
        &server,
        &mut reported,
    );
}

/// Warns once for each file that fails to load or reload with the loader's own message (the
/// file and the key, without the asset server's backtrace), until the file loads again: a
/// file watcher that sees one edit twice gives one warning. Returns the warnings given.
pub(crate) fn report_load_failures<A: Asset, E: std::error::Error + 'static>(
    what: &str,
    kept: &str,
    failures: &mut MessageReader<AssetLoadFailedEvent<A>>,
    loaded: &mut MessageReader<AssetEvent<A>>,
    server: &AssetServer,
    reported: &mut HashMap<AssetPath<'static>, String>,
) -> Vec<String> {
    let mut given = Vec::new();
    for event in loaded.read() {
        if let AssetEvent::Modified { id } | AssetEvent::LoadedWithDependencies { id } = event
            && let Some(path) = server.get_path(*id)
        {
            reported.remove(&path.into_owned());
        }
    }
    for failure in failures.read() {
        let message = match &failure.error {
            AssetLoadError::AssetLoaderError(error) => error
                .error()
                .downcast_ref::<E>()
                .map_or_else(|| error.error().to_string(), ToString::to_string),
            other => other.to_string(),
        };
        if reported.get(&failure.path) == Some(&message) {
            continue;
        }
        let warning = format!(
            "bevy_cloudscape: cannot use {what} {}: {message} (keeping the last good {kept})",
            failure.path
        );
        warn!("{warning}");
        given.push(warning);
        reported.insert(failure.path.clone(), message);
    }
    given
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn tangent_plane_distances_match_known_baselines() {
        let bern = GeoOrigin::default();
        // WGS 84 geodesics (Karney's algorithm, GeographicLib 2.0): Bern → Solothurn
        // 29 701.955 m at azimuth 13.2713°, Bern → Fribourg 26 855.124 m at −125.8982°.
        for (lat, lon, distance_m, azimuth_deg) in [
            (47.208, 7.537, 29_701.955, 13.271_31),
            (46.806, 7.162, 26_855.124, -125.898_18),
        ] {
            let p = bern.to_scene(lat, lon, 610.0);
            let d = f64::from(p.xz().length());
            // Azimuth clockwise from north: east is +X, north is -Z.
            let azimuth = f64::from(p.x).atan2(f64::from(-p.z)).to_degrees();
            assert!(
                (d - distance_m).abs() / distance_m < 1e-3,
                "{d} m vs {distance_m} m"
            );
            // The plane ignores the convergence of meridians, which turns bearings by about
            // Δλ·sin φ / 2 (0.10° for Fribourg, 0.03° for Solothurn): allow twice that.
            assert!(
                (azimuth - azimuth_deg).abs() < 0.2,
                "{azimuth}° vs {azimuth_deg}°"
            );
            assert_eq!(p.y, 610.0);
        }
    }
}
