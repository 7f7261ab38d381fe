//! [`Forecast`]: one place's weather over time, in UTC and SI units, whichever file it came from.

mod builder;
mod parse;
mod variable;

use bevy::{asset::Asset, reflect::TypePath};
use std::io::Read;
use std::path::Path;

use super::error::ForecastError;
use crate::scene::{Place, UtcInstant};
use parse::parse_document;

pub(crate) use builder::{ForecastBuilder, LevelField, Target, check_scalar, level_from_key};
pub use variable::Variable;

/// A forecast variable's values, one per entry of [`Forecast::times`]; `None` where the file has
/// `null` (a gap that sampling bridges or reports, never a silent zero).
pub type Series = Vec<Option<f32>>;

/// The file formats [`Forecast`] reads (documented at docs.meteoblue.com and open-meteo.com/en/docs).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum ForecastFormat {
    /// meteoblue Packages API JSON (`basic-1h`, `clouds-1h`, merged packages, profile packages).
    Meteoblue,
    /// Open-Meteo forecast API JSON (a single location or an array of them).
    OpenMeteo,
}

/// Variables at one pressure level (meteoblue profile packages, Open-Meteo `…_850hPa` keys).
/// Optional extras: wind at cloud altitude drives the layer winds when present.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct PressureLevel {
    /// The level's pressure in hPa, e.g. 850 (≈ 1.5 km), 700 (≈ 3 km), 500 (≈ 5.6 km),
    /// 300 (≈ 9.2 km).
    pub pressure_hpa: f32,
    /// Wind speed at the level, m/s.
    pub wind_speed_m_s: Option<Series>,
    /// Direction the wind at the level blows from, degrees clockwise from north.
    pub wind_direction_deg: Option<Series>,
    /// Geopotential height of the level above sea level, m.
    pub height_m: Option<Series>,
    /// Cloud cover at the level, fraction 0–1.
    pub cloud_cover: Option<Series>,
}

/// One place's forecast: UTC instants, SI units, explicit gaps.
///
/// Read one with [`Forecast::from_path`], [`Forecast::from_reader`] or [`Forecast::from_slice`]
/// (the format is detected unless you name it), or build one in code with [`Forecast::new`] and
/// fill [`Forecast::series`]. Sample it at an instant with a
/// [`Sampler`](super::Sampler) or [`Forecast::sample`].
///
/// Every series has the length of [`Forecast::times`], which is non-empty and strictly increasing
/// for parsed forecasts; sampling tolerates hand-built forecasts that break this (it never panics)
/// but the values are then unspecified.
#[derive(Clone, Debug, PartialEq, Asset, TypePath)]
pub struct Forecast {
    /// Where the forecast is for.
    pub place: Place,
    /// The file format it was read from; `None` when built in code.
    pub format: Option<ForecastFormat>,
    /// The instants of the values, strictly increasing.
    pub times: Vec<UtcInstant>,
    /// The continuous variables, indexed by `Variable as usize`; `None` for a variable the file
    /// does not have.
    pub series: [Option<Series>; Variable::COUNT],
    /// meteoblue hourly pictocode 1–35 per time (see meteoblue's Packages API documentation (docs.meteoblue.com)).
    pub pictocode: Option<Vec<Option<u8>>>,
    /// WMO weather interpretation code 0–99 per time (Open-Meteo `weather_code`).
    pub wmo_weather_code: Option<Vec<Option<u8>>>,
    /// Daylight flag per time (meteoblue `isdaylight`, Open-Meteo `is_day`).
    pub is_daylight: Option<Vec<Option<bool>>>,
    /// Pressure-level variables, sorted from the highest pressure (lowest altitude) up.
    pub pressure_levels: Vec<PressureLevel>,
    /// Offset of the file's local time stamps east of UTC, seconds (informational: all times are
    /// already UTC).
    pub utc_offset_s: i32,
    /// Time-zone abbreviation from the file, e.g. `"CEST"`.
    pub timezone_abbreviation: Option<String>,
    /// When the weather model that produced the forecast was run (meteoblue `modelrun_utc`).
    pub model_run: Option<UtcInstant>,
    /// Non-fatal remarks found while reading, e.g. a variable Open-Meteo marked `"undefined"`.
    pub warnings: Vec<String>,
}

impl Forecast {
    /// An empty forecast for `place` at `times`, with no variables yet (fill
    /// [`Forecast::series`] and the other fields by hand).
    #[must_use]
    pub fn new(place: Place, times: Vec<UtcInstant>) -> Self {
        Self {
            place,
            format: None,
            times,
            series: Default::default(),
            pictocode: None,
            wmo_weather_code: None,
            is_daylight: None,
            pressure_levels: Vec::new(),
            utc_offset_s: 0,
            timezone_abbreviation: None,
            model_run: None,
            warnings: Vec::new(),
        }
    }

    /// Parses a forecast file's bytes. `format: None` detects meteoblue (`metadata`/`data_1h`)
    /// or Open-Meteo (`hourly`).
    ///
    /// A multi-location file (a JSON array, as Open-Meteo returns for several coordinates) gives
    /// its FIRST location here, with a note in [`Forecast::warnings`]; use
    /// [`Forecast::all_from_slice`] to get every location.
    ///
    /// # Errors
    /// A [`ForecastError`] naming the key and index of the first fault. Never panics.
    pub fn from_slice(bytes: &[u8], format: Option<ForecastFormat>) -> Result<Self, ForecastError> {
        let mut all = parse_document(bytes, format)?.into_iter();
        let count = all.len();
        let mut first = all
            .next()
            .ok_or(ForecastError::EmptyDocument { file: None })?;
        if count > 1 {
            first.warnings.push(format!(
                "the file holds {count} locations; using the first (Forecast::all_from_slice reads all)"
            ));
        }
        Ok(first)
    }

    /// Parses every location of a forecast file: one for a JSON object, one per element for a
    /// JSON array. See [`Forecast::from_slice`].
    ///
    /// # Errors
    /// A [`ForecastError`]; keys inside an array are prefixed with the element, e.g.
    /// `[1].hourly.time`.
    pub fn all_from_slice(
        bytes: &[u8],
        format: Option<ForecastFormat>,
    ) -> Result<Vec<Self>, ForecastError> {
        parse_document(bytes, format)
    }

    /// Reads a whole forecast file from `reader` and parses it like [`Forecast::from_slice`].
    ///
    /// # Errors
    /// [`ForecastError::Io`] if reading fails, otherwise as [`Forecast::from_slice`]. The file is
    /// not known here: name it with [`ForecastError::with_file`].
    pub fn from_reader(
        mut reader: impl Read,
        format: Option<ForecastFormat>,
    ) -> Result<Self, ForecastError> {
        let mut bytes = Vec::new();
        reader
            .read_to_end(&mut bytes)
            .map_err(|error| ForecastError::Io {
                file: None,
                message: error.to_string(),
            })?;
        Self::from_slice(&bytes, format)
    }

    /// Reads and parses a forecast file like [`Forecast::from_slice`]; errors name `path`, and a
    /// place without a name takes the file stem (`bern_open_meteo.json` → `"bern_open_meteo"`).
    ///
    /// # Errors
    /// A [`ForecastError`] whose [`ForecastError::file`] is `path`.
    pub fn from_path(
        path: impl AsRef<Path>,
        format: Option<ForecastFormat>,
    ) -> Result<Self, ForecastError> {
        let path = path.as_ref();
        let bytes = std::fs::read(path).map_err(|error| ForecastError::Io {
            file: Some(path.to_path_buf()),
            message: error.to_string(),
        })?;
        let mut forecast =
            Self::from_slice(&bytes, format).map_err(|error| error.with_file(path))?;
        if forecast.place.name.is_empty()
            && let Some(stem) = path.file_stem()
        {
            forecast.place.name = stem.to_string_lossy().into_owned();
        }
        Ok(forecast)
    }

    /// The values of `variable`, if the forecast has it.
    #[must_use]
    pub fn series(&self, variable: Variable) -> Option<&[Option<f32>]> {
        self.series[variable as usize].as_deref()
    }

    /// Number of time steps.
    #[must_use]
    pub fn len(&self) -> usize {
        self.times.len()
    }

    /// True when there are no time steps (only possible for hand-built forecasts).
    #[must_use]
    pub fn is_empty(&self) -> bool {
        self.times.is_empty()
    }

    /// The first instant with data.
    #[must_use]
    pub fn start(&self) -> Option<UtcInstant> {
        self.times.first().copied()
    }

    /// The last instant with data.
    #[must_use]
    pub fn end(&self) -> Option<UtcInstant> {
        self.times.last().copied()
    }

    /// The pressure level at `pressure_hpa` (within 0.5 hPa), if present.
    #[must_use]
    pub fn pressure_level(&self, pressure_hpa: f32) -> Option<&PressureLevel> {
        self.pressure_levels
            .iter()
            .find(|level| (level.pressure_hpa - pressure_hpa).abs() < 0.5)
    }
}

#[cfg(test)]
mod tests;
