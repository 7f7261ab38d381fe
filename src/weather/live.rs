//! Live forecasts: a forecast downloaded over `http` or `https` and refreshed on a schedule
//! (crate feature `live`).
//!
//! Each [`LiveForecast`] in [`LiveForecasts`] is downloaded with Bevy's own web asset reader
//! ([`WebAssetReader`], `bevy_asset`'s `http` and `https` features) on the IO task pool, so a
//! download never holds up a frame. The reply is parsed there too, like a forecast file
//! ([`Forecast::from_slice`]: meteoblue or Open-Meteo JSON) and replaces the forecast behind the
//! feed's handle in `Assets<Forecast>`, which sends the same `AssetEvent::Modified` a
//! hot-reloaded file does. A failed download or a bad reply (an HTTP error, a cut-off body, a
//! page that is not a forecast, no reply within [`LiveForecast::timeout`]) keeps the last good
//! forecast, warns once per distinct reason, and is retried after [`LiveForecast::retry`], twice
//! as long after each further failure, at most [`LiveForecast::refresh`].

use std::path::Path;
use std::time::Duration;

use bevy::{
    asset::io::{AssetReader, AssetReaderError, web::WebAssetReader},
    prelude::*,
    tasks::{IoTaskPool, Task, futures_lite::future},
};
use thiserror::Error;

use super::{Forecast, ForecastError};

/// Open-Meteo's forecast API (open-meteo.com/en/docs), which [`LiveForecast::open_meteo`] asks.
pub const OPEN_METEO_FORECAST_URL: &str = "https://api.open-meteo.com/v1/forecast";

/// The hourly variables [`LiveForecast::open_meteo`] asks for: every one the weather mapping
/// reads (cover per level, precipitation and showers, snowfall, the weather code, visibility,
/// the wind at 10 m and on four pressure levels with their heights).
pub const OPEN_METEO_HOURLY: &str = "temperature_2m,relative_humidity_2m,precipitation,showers,\
snowfall,weather_code,pressure_msl,cloud_cover,cloud_cover_low,cloud_cover_mid,cloud_cover_high,\
visibility,wind_speed_10m,wind_direction_10m,is_day,wind_speed_850hPa,wind_direction_850hPa,\
geopotential_height_850hPa,wind_speed_700hPa,wind_direction_700hPa,geopotential_height_700hPa,\
wind_speed_500hPa,wind_direction_500hPa,geopotential_height_500hPa,wind_speed_300hPa,\
wind_direction_300hPa,geopotential_height_300hPa,lightning_potential";

/// One forecast fetched from the web and refreshed on a schedule; add it with
/// [`LiveForecasts::add`].
#[derive(Debug, Clone, PartialEq, Reflect)]
pub struct LiveForecast {
    /// The address of a meteoblue or Open-Meteo JSON forecast, `http://` or `https://`. It may
    /// hold an API key: messages show it without its query.
    pub url: String,
    /// The place's name, which the forecast and the messages carry when the reply names none.
    /// Default: the address without its query.
    pub name: String,
    /// Time between downloads once one succeeded, at least [`MIN_REFRESH`]. Default one hour.
    pub refresh: Duration,
    /// Wait before the first retry after a failed download, at least [`MIN_REFRESH`]; each
    /// further failure doubles it, up to [`LiveForecast::refresh`]. Default one minute.
    pub retry: Duration,
    /// A download that has not finished after this long counts as failed (and is abandoned).
    /// Default 60 s.
    pub timeout: Duration,
}

impl LiveForecast {
    /// The forecast at `url` (meteoblue's API with a key, Open-Meteo, or any server of either
    /// format), refreshed hourly.
    #[must_use]
    pub fn url(url: impl Into<String>) -> Self {
        let url = url.into();
        Self {
            name: without_query(&url).to_owned(),
            url,
            refresh: Duration::from_secs(3600),
            retry: Duration::from_secs(60),
            timeout: Duration::from_secs(60),
        }
    }

    /// Open-Meteo's forecast for a latitude and longitude (degrees north and east): every
    /// variable the crate reads ([`OPEN_METEO_HOURLY`]), in UTC, from the day before to two days
    /// ahead, refreshed hourly. Open-Meteo's free API needs no key.
    #[must_use]
    pub fn open_meteo(latitude_deg: f64, longitude_deg: f64) -> Self {
        Self::open_meteo_at(OPEN_METEO_FORECAST_URL, latitude_deg, longitude_deg)
    }

    /// [`LiveForecast::open_meteo`] from another server with Open-Meteo's API at `base_url` (a
    /// self-hosted instance, a commercial endpoint, a test server).
    #[must_use]
    pub fn open_meteo_at(base_url: &str, latitude_deg: f64, longitude_deg: f64) -> Self {
        let mut live = Self::url(format!(
            "{base_url}?latitude={latitude_deg:.4}&longitude={longitude_deg:.4}\
             &hourly={OPEN_METEO_HOURLY}&timezone=GMT&past_days=1&forecast_days=2"
        ));
        live.name = format!("Open-Meteo {latitude_deg:.3}, {longitude_deg:.3}");
        live
    }

    /// The same forecast under another name.
    #[must_use]
    pub fn named(mut self, name: impl Into<String>) -> Self {
        self.name = name.into();
        self
    }

    /// The same forecast refreshed every `refresh`.
    #[must_use]
    pub fn with_refresh(mut self, refresh: Duration) -> Self {
        self.refresh = refresh;
        self
    }

    /// The same forecast with another first retry delay and download timeout.
    #[must_use]
    pub fn with_retry(mut self, retry: Duration, timeout: Duration) -> Self {
        self.retry = retry;
        self.timeout = timeout;
        self
    }

    /// The same forecast with its refresh and first retry at least [`MIN_REFRESH`] each, as
    /// [`LiveForecasts::add`] keeps them.
    fn with_min_refresh(mut self) -> Self {
        self.refresh = self.refresh.max(MIN_REFRESH);
        self.retry = self.retry.max(MIN_REFRESH);
        self
    }
}

/// The shortest [`LiveForecast::refresh`] and [`LiveForecast::retry`] it keeps: shorter ones
/// would ask the server many times a second. A shorter one is raised to this with a warning.
pub const MIN_REFRESH: Duration = Duration::from_secs(1);

/// The address without its query (which may hold an API key).
fn without_query(url: &str) -> &str {
    url.split_once('?').map_or(url, |(path, _)| path)
}

/// Why a live forecast could not be refreshed.
#[derive(Clone, Debug, Error, PartialEq)]
pub enum LiveForecastError {
    /// The address is neither `http://` nor `https://`.
    #[error("the address must start with http:// or https://")]
    Scheme,
    /// The server answered with an HTTP error status.
    #[error("the server answered HTTP {status}")]
    Status {
        /// The HTTP status code.
        status: u16,
    },
    /// The connection failed or broke off (no server, a body cut short).
    #[error("the download failed: {0}")]
    Download(String),
    /// No complete reply within [`LiveForecast::timeout`].
    #[error("no complete reply within {0:?}")]
    Timeout(Duration),
    /// The reply is not a forecast the crate can read.
    #[error("the reply is not a usable forecast: {0}")]
    Forecast(ForecastError),
}

impl From<AssetReaderError> for LiveForecastError {
    fn from(error: AssetReaderError) -> Self {
        match error {
            AssetReaderError::NotFound(_) => Self::Status { status: 404 },
            AssetReaderError::HttpError(status) => Self::Status { status },
            AssetReaderError::Io(error) => Self::Download(error.to_string()),
        }
    }
}

/// How a live forecast is doing, for a status line in a game's UI and for tests.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct LiveStatus {
    /// Downloads that gave a usable forecast.
    pub downloads: u32,
    /// Downloads that failed, in all.
    pub failures: u32,
    /// Failures since the last good download (0 after a good one).
    pub failures_in_a_row: u32,
    /// Why the last download failed, until one succeeds again.
    pub last_error: Option<LiveForecastError>,
    /// Warnings logged: one per distinct reason in a row of failures.
    pub warnings: u32,
    /// Whether a download is under way.
    pub downloading: bool,
}

/// A download under way: the task downloads and parses, so the frame only stores the result.
struct Download {
    task: Task<Result<Forecast, LiveForecastError>>,
    started: Duration,
}

/// One feed: its settings, its handle, its schedule and its status.
struct Feed {
    live: LiveForecast,
    handle: Handle<Forecast>,
    /// Real time (since the app started) of the next download.
    next: Duration,
    download: Option<Download>,
    status: LiveStatus,
}

/// The live forecasts of the app (crate feature `live`). Each one's forecast is kept in
/// `Assets<Forecast>` behind the handle [`LiveForecasts::add`] returns, which a
/// [`WeatherSource`](super::WeatherSource) takes like a loaded file's.
#[derive(Resource, Default)]
pub struct LiveForecasts {
    feeds: Vec<Feed>,
}

impl LiveForecasts {
    /// Starts fetching `live` (its first download in the next frame) and returns the handle its
    /// forecast will be stored under; the handle holds no forecast until a download succeeds.
    pub fn add(&mut self, forecasts: &Assets<Forecast>, live: LiveForecast) -> Handle<Forecast> {
        if live.refresh < MIN_REFRESH || live.retry < MIN_REFRESH {
            warn!(
                "bevy_cloudscape: the live forecast {} refreshes every {:?} and retries after \
                 {:?}; each is at least {MIN_REFRESH:?}",
                live.name, live.refresh, live.retry
            );
        }
        let live = live.with_min_refresh();
        let handle = forecasts.reserve_handle();
        self.feeds.push(Feed {
            live,
            handle: handle.clone(),
            next: Duration::ZERO,
            download: None,
            status: LiveStatus::default(),
        });
        handle
    }

    /// Stops refreshing the forecast behind `handle`; the last one stays in `Assets<Forecast>`
    /// while a handle to it lives. Returns whether it was a live forecast.
    pub fn remove(&mut self, handle: &Handle<Forecast>) -> bool {
        let before = self.feeds.len();
        self.feeds.retain(|feed| feed.handle.id() != handle.id());
        self.feeds.len() < before
    }

    /// How the live forecast behind `handle` is doing; `None` for a handle it did not give.
    #[must_use]
    pub fn status(&self, handle: &Handle<Forecast>) -> Option<&LiveStatus> {
        self.feeds
            .iter()
            .find(|feed| feed.handle.id() == handle.id())
            .map(|feed| &feed.status)
    }
}

/// Downloads `url` with Bevy's web asset reader.
async fn download(url: String) -> Result<Vec<u8>, LiveForecastError> {
    let (reader, rest) = if let Some(rest) = url.strip_prefix("https://") {
        (WebAssetReader::Https, rest)
    } else if let Some(rest) = url.strip_prefix("http://") {
        (WebAssetReader::Http, rest)
    } else {
        return Err(LiveForecastError::Scheme);
    };
    // The reader's messages quote the whole address: without its query, which may hold a key.
    let redact = |error: LiveForecastError| match error {
        LiveForecastError::Download(message) => {
            LiveForecastError::Download(message.replace(&url, without_query(&url)))
        }
        other => other,
    };
    let mut body = reader
        .read(Path::new(rest))
        .await
        .map_err(|e| redact(e.into()))?;
    let mut bytes = Vec::new();
    body.read_to_end(&mut bytes)
        .await
        .map_err(|e| redact(LiveForecastError::Download(e.to_string())))?;
    Ok(bytes)
}

/// The forecast in a reply, named after the feed when the reply names no place.
fn parse_reply(live: &LiveForecast, bytes: &[u8]) -> Result<Forecast, LiveForecastError> {
    let mut forecast = Forecast::from_slice(bytes, None)
        .map_err(|e| LiveForecastError::Forecast(e.with_file(without_query(&live.url))))?;
    if forecast.place.name.is_empty() {
        forecast.place.name.clone_from(&live.name);
    }
    Ok(forecast)
}

/// The wait before the next try after `failures_in_a_row` failures: [`LiveForecast::retry`]
/// doubled for each failure after the first, at most [`LiveForecast::refresh`].
fn retry_delay(live: &LiveForecast, failures_in_a_row: u32) -> Duration {
    let doubling = 2u32.saturating_pow(failures_in_a_row.saturating_sub(1).min(16));
    live.retry.saturating_mul(doubling).min(live.refresh)
}

/// Starts each live forecast's download when it is due, and files the finished ones: a good
/// forecast into `Assets<Forecast>`, a failure into the feed's status with one warning per
/// distinct reason and a retry with back-off. Runs on real time, not the scene clock.
pub(crate) fn refresh_live_forecasts(
    live: Option<ResMut<LiveForecasts>>,
    time: Res<Time<Real>>,
    mut forecasts: ResMut<Assets<Forecast>>,
) {
    let Some(mut live) = live else {
        return;
    };
    let now = time.elapsed();
    for feed in &mut live.feeds {
        let outcome = match &mut feed.download {
            Some(download) => {
                if let Some(result) = future::block_on(future::poll_once(&mut download.task)) {
                    Some(result)
                } else if now.saturating_sub(download.started) > feed.live.timeout {
                    Some(Err(LiveForecastError::Timeout(feed.live.timeout)))
                } else {
                    None
                }
            }
            None => {
                if now >= feed.next {
                    let live = feed.live.clone();
                    let task = IoTaskPool::get().spawn(async move {
                        let bytes = download(live.url.clone()).await?;
                        parse_reply(&live, &bytes)
                    });
                    feed.download = Some(Download { task, started: now });
                }
                None
            }
        };
        feed.status.downloading = feed.download.is_some();
        let Some(outcome) = outcome else {
            continue;
        };
        // Dropping the task abandons a download that timed out.
        feed.download = None;
        feed.status.downloading = false;
        match outcome {
            Ok(forecast) => {
                if feed.status.failures_in_a_row > 0 {
                    info!(
                        "bevy_cloudscape: live forecast {} downloaded again",
                        feed.live.name
                    );
                }
                if let Err(error) = forecasts.insert(&feed.handle, forecast) {
                    warn!(
                        "bevy_cloudscape: cannot store the live forecast {}: {error}",
                        feed.live.name
                    );
                }
                feed.status.downloads += 1;
                feed.status.failures_in_a_row = 0;
                feed.status.last_error = None;
                feed.next = now + feed.live.refresh;
            }
            Err(error) => {
                feed.status.failures += 1;
                feed.status.failures_in_a_row += 1;
                let delay = retry_delay(&feed.live, feed.status.failures_in_a_row);
                if feed.status.last_error.as_ref() != Some(&error) {
                    warn!(
                        "bevy_cloudscape: cannot refresh the live forecast {}: {error} (keeping \
                         the last good forecast, retrying in {delay:?})",
                        feed.live.name
                    );
                    feed.status.warnings += 1;
                }
                feed.status.last_error = Some(error);
                feed.next = now + delay;
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn retries_back_off_to_the_refresh_interval() {
        let live = LiveForecast::url("https://example.org/f.json")
            .with_retry(Duration::from_secs(60), Duration::from_secs(10));
        let delays: Vec<u64> = (1..=8).map(|n| retry_delay(&live, n).as_secs()).collect();
        assert_eq!(delays, [60, 120, 240, 480, 960, 1920, 3600, 3600]);
        assert_eq!(retry_delay(&live, u32::MAX), live.refresh);
        // A zero retry or refresh would ask the server every frame: both are at least a second.
        let eager = live
            .with_refresh(Duration::ZERO)
            .with_retry(Duration::ZERO, Duration::ZERO);
        let eager = eager.with_min_refresh();
        assert_eq!((eager.refresh, eager.retry), (MIN_REFRESH, MIN_REFRESH));
        assert_eq!(retry_delay(&eager, 1), MIN_REFRESH);
        assert_eq!(retry_delay(&eager, 5), MIN_REFRESH);
    }

    #[test]
    fn open_meteo_asks_for_every_variable_the_mapping_reads_in_utc() {
        let live = LiveForecast::open_meteo(46.948, 7.447);
        assert!(live.url.starts_with(
            "https://api.open-meteo.com/v1/forecast?latitude=46.9480&longitude=7.4470&hourly="
        ));
        assert!(live.url.contains("&timezone=GMT"));
        // The bundled Open-Meteo file has the variables the mapping was tuned on.
        let bundled: serde_json::Value =
            serde_json::from_str(include_str!("../../assets/weather/bern_open_meteo.json"))
                .unwrap();
        let asked: Vec<&str> = OPEN_METEO_HOURLY.split(',').collect();
        for key in bundled["hourly"].as_object().unwrap().keys() {
            assert!(
                key == "time" || asked.contains(&key.as_str()),
                "{key} is not asked for"
            );
        }
        // And the storms' lightning potential, which the ICON models give.
        assert!(asked.contains(&"lightning_potential"));
    }

    #[test]
    fn messages_hide_the_query_that_may_hold_a_key() {
        let live = LiveForecast::url("https://my.meteoblue.com/packages/basic-1h?apikey=SECRET");
        assert_eq!(live.name, "https://my.meteoblue.com/packages/basic-1h");
        let error = parse_reply(&live, b"<html>busy</html>").unwrap_err();
        let text = error.to_string();
        assert!(
            text.starts_with("the reply is not a usable forecast: "),
            "{text}"
        );
        assert!(!text.contains("SECRET"), "{text}");
    }
}
