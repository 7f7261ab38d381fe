//! [`Forecast`]: one place's weather over time, in UTC and SI units, whichever file it came from.

use bevy::{asset::Asset, reflect::TypePath};
use std::io::Read;
use std::path::Path;

use serde::Deserialize;
use serde::de::{DeserializeSeed, IgnoredAny, SeqAccess, Visitor};

use super::error::ForecastError;
use super::meteoblue::MeteoblueFile;
use super::open_meteo::OpenMeteoFile;
use super::raw::RawTime;
use super::units::{Linear, Quantity};
use crate::scene::{Place, UtcInstant};

/// A forecast variable's values, one per entry of [`Forecast::times`]; `None` where the file has
/// `null` (a gap that sampling bridges or reports, never a silent zero).
pub type Series = Vec<Option<f32>>;

/// The file formats [`Forecast`] reads (`shared/formats/meteoblue.md`, `open-meteo.md`).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum ForecastFormat {
    /// meteoblue Packages API JSON (`basic-1h`, `clouds-1h`, merged packages, profile packages).
    Meteoblue,
    /// Open-Meteo forecast API JSON (a single location or an array of them).
    OpenMeteo,
}

/// The continuous forecast variables, each stored as a [`Series`] in [`Forecast::series`] and
/// sampled into [`WeatherState::values`](super::WeatherState::values) (index with
/// `variable as usize` or use the accessors).
///
/// Units are SI-like and the same for both formats. Amounts that a file gives "over the preceding
/// step" (precipitation, sunshine) stay amounts in a [`Forecast`] and become rates when sampled;
/// [`Variable::unit`] and [`Variable::sampled_unit`] say which.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub enum Variable {
    /// Total cloud cover, fraction 0–1 (meteoblue `totalcloudcover`, Open-Meteo `cloud_cover`).
    TotalCover,
    /// Low cloud cover, fraction 0–1 (`lowclouds`; meteoblue: surface–2 km, Open-Meteo: up to
    /// 3 km above ground).
    LowCover,
    /// Mid-level cloud cover, fraction 0–1 (`midclouds`; meteoblue 2–7 km, Open-Meteo 3–8 km).
    MidCover,
    /// High cloud cover, fraction 0–1 (`highclouds`; meteoblue 5–13 km, Open-Meteo above 8 km).
    HighCover,
    /// Precipitation: mm of water over the preceding step in a [`Forecast`] (the value stamped
    /// 14:00 covers 13:00–14:00); a rate in mm/h when sampled.
    Precipitation,
    /// Convective (shower) part of the precipitation, same units as [`Variable::Precipitation`]
    /// (meteoblue `convective_precipitation`, Open-Meteo `showers`).
    ConvectivePrecipitation,
    /// Fraction 0–1 of the precipitation that falls as snow (meteoblue `snowfraction`; derived
    /// from Open-Meteo `snowfall` / `precipitation` when both are present).
    SnowFraction,
    /// Probability of precipitation, fraction 0–1.
    PrecipitationProbability,
    /// Air temperature at 2 m in degrees Celsius (not kelvin).
    Temperature,
    /// Relative humidity at 2 m, fraction 0–1.
    RelativeHumidity,
    /// Air pressure reduced to mean sea level, Pa.
    SeaLevelPressure,
    /// Wind speed at 10 m, m/s.
    WindSpeed,
    /// Direction the 10 m wind blows FROM, degrees clockwise from north, [0, 360) (meteorological
    /// convention: 270 is a west wind).
    WindDirection,
    /// Horizontal visibility, m.
    Visibility,
    /// Probability of fog, fraction 0–1 (meteoblue `fog_probability`).
    FogProbability,
    /// Sunshine: seconds of sunshine over the preceding step in a [`Forecast`]; the fraction 0–1
    /// of time with sunshine when sampled.
    SunshineDuration,
    /// Base of convective cloud above sea level, m (Open-Meteo `convective_cloud_base`).
    ConvectiveCloudBase,
    /// Top of convective cloud above sea level, m (Open-Meteo `convective_cloud_top`).
    ConvectiveCloudTop,
}

impl Variable {
    /// Number of variables.
    pub const COUNT: usize = 18;

    /// Every variable, in index order.
    pub const ALL: [Self; Self::COUNT] = [
        Self::TotalCover,
        Self::LowCover,
        Self::MidCover,
        Self::HighCover,
        Self::Precipitation,
        Self::ConvectivePrecipitation,
        Self::SnowFraction,
        Self::PrecipitationProbability,
        Self::Temperature,
        Self::RelativeHumidity,
        Self::SeaLevelPressure,
        Self::WindSpeed,
        Self::WindDirection,
        Self::Visibility,
        Self::FogProbability,
        Self::SunshineDuration,
        Self::ConvectiveCloudBase,
        Self::ConvectiveCloudTop,
    ];

    /// A `snake_case` name for messages and JSON output, e.g. `"low_cover"`.
    #[must_use]
    pub const fn name(self) -> &'static str {
        match self {
            Self::TotalCover => "total_cover",
            Self::LowCover => "low_cover",
            Self::MidCover => "mid_cover",
            Self::HighCover => "high_cover",
            Self::Precipitation => "precipitation",
            Self::ConvectivePrecipitation => "convective_precipitation",
            Self::SnowFraction => "snow_fraction",
            Self::PrecipitationProbability => "precipitation_probability",
            Self::Temperature => "temperature",
            Self::RelativeHumidity => "relative_humidity",
            Self::SeaLevelPressure => "sea_level_pressure",
            Self::WindSpeed => "wind_speed",
            Self::WindDirection => "wind_direction",
            Self::Visibility => "visibility",
            Self::FogProbability => "fog_probability",
            Self::SunshineDuration => "sunshine_duration",
            Self::ConvectiveCloudBase => "convective_cloud_base",
            Self::ConvectiveCloudTop => "convective_cloud_top",
        }
    }

    /// The unit of this variable inside a [`Forecast`].
    #[must_use]
    pub const fn unit(self) -> &'static str {
        match self {
            Self::TotalCover
            | Self::LowCover
            | Self::MidCover
            | Self::HighCover
            | Self::SnowFraction
            | Self::PrecipitationProbability
            | Self::RelativeHumidity
            | Self::FogProbability => "fraction 0-1",
            Self::Precipitation | Self::ConvectivePrecipitation => "mm over the preceding step",
            Self::Temperature => "°C",
            Self::SeaLevelPressure => "Pa",
            Self::WindSpeed => "m/s",
            Self::WindDirection => "° from north, direction the wind comes from",
            Self::Visibility | Self::ConvectiveCloudBase | Self::ConvectiveCloudTop => "m",
            Self::SunshineDuration => "s over the preceding step",
        }
    }

    /// The unit of this variable in a sampled [`WeatherState`](super::WeatherState).
    #[must_use]
    pub const fn sampled_unit(self) -> &'static str {
        match self {
            Self::Precipitation | Self::ConvectivePrecipitation => "mm/h",
            Self::SunshineDuration => "fraction 0-1 of the time",
            other => other.unit(),
        }
    }

    /// True for amounts over the preceding step (precipitation, sunshine), which sampling turns
    /// into rates.
    #[must_use]
    pub const fn is_preceding_step_amount(self) -> bool {
        matches!(
            self,
            Self::Precipitation | Self::ConvectivePrecipitation | Self::SunshineDuration
        )
    }
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
    /// meteoblue hourly pictocode 1–35 per time (see `shared/formats/meteoblue.md`).
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

/// Where a column's values go.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(crate) enum Target {
    Series(Variable),
    Pictocode,
    WmoWeatherCode,
    IsDaylight,
    /// Open-Meteo `snowfall`, kept only to derive [`Variable::SnowFraction`].
    SnowWaterEquivalent,
    Level {
        pressure_hpa: u16,
        field: LevelField,
    },
}

/// A field of [`PressureLevel`].
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(crate) enum LevelField {
    WindSpeed,
    WindDirection,
    Height,
    CloudCover,
}

/// Builds a [`Forecast`] from a file's raw columns, checking lengths, units and ranges and naming
/// keys as `{prefix}{block}.{variable}`.
pub(crate) struct ForecastBuilder {
    forecast: Forecast,
    /// `""` or `"[i]."` inside a multi-location array.
    prefix: String,
    /// `data_1h`, `hourly`, …
    block: &'static str,
    snow_water_mm: Option<Series>,
}

impl ForecastBuilder {
    pub fn new(format: ForecastFormat, place: Place, prefix: &str, block: &'static str) -> Self {
        let mut forecast = Forecast::new(place, Vec::new());
        forecast.format = Some(format);
        Self {
            forecast,
            prefix: prefix.to_owned(),
            block,
            snow_water_mm: None,
        }
    }

    pub fn forecast_mut(&mut self) -> &mut Forecast {
        &mut self.forecast
    }

    /// The full key of a variable in the data block, e.g. `data_1h.lowclouds`.
    pub fn column_key(&self, name: &str) -> String {
        format!("{}{}.{name}", self.prefix, self.block)
    }

    /// Converts and checks the `time` array. Strings without an offset are local time at
    /// `local_offset_s` east of UTC; when that is `None`, such a string is an error naming
    /// `offset_key` (the metadata key that should have given the offset).
    pub fn set_times(
        &mut self,
        raw: Option<Vec<RawTime>>,
        local_offset_s: Option<i64>,
        offset_key: &str,
    ) -> Result<(), ForecastError> {
        let key = self.column_key("time");
        let raw = raw.ok_or_else(|| ForecastError::MissingKey {
            file: None,
            key: key.clone(),
        })?;
        if raw.is_empty() {
            return Err(ForecastError::EmptyTime { file: None, key });
        }
        let mut times = Vec::with_capacity(raw.len());
        for (index, entry) in raw.iter().enumerate() {
            let bad = |reason: &str| ForecastError::BadTime {
                file: None,
                key: key.clone(),
                index,
                value: entry.to_string(),
                reason: reason.to_owned(),
            };
            let time = match entry {
                RawTime::Text(text) => UtcInstant::parse_with_default_offset(text, local_offset_s)
                    .map_err(|error| {
                        if local_offset_s.is_none() && error.reason().starts_with("no UTC offset") {
                            ForecastError::MissingKey {
                                file: None,
                                key: format!("{}{offset_key}", self.prefix),
                            }
                        } else {
                            bad(error.reason())
                        }
                    })?,
                RawTime::Unix(seconds) => UtcInstant::from_unix_seconds(*seconds),
                RawTime::BadNumber(_) => return Err(bad("not a whole number of Unix seconds")),
                RawTime::Null => return Err(bad("a time stamp cannot be null")),
            };
            if let Some(&previous) = times.last() {
                if time == previous {
                    return Err(ForecastError::DuplicateTime {
                        file: None,
                        key: key.clone(),
                        index,
                        time,
                    });
                }
                if time < previous {
                    return Err(ForecastError::TimesNotIncreasing {
                        file: None,
                        key: key.clone(),
                        index,
                        previous,
                        found: time,
                    });
                }
            }
            times.push(time);
        }
        self.forecast.times = times;
        Ok(())
    }

    /// Checks, converts and stores one column. Must be called after [`Self::set_times`].
    pub fn add_column(
        &mut self,
        name: &str,
        values: &[Option<f64>],
        target: Target,
        quantity: Quantity,
        conversion: Linear,
    ) -> Result<(), ForecastError> {
        let key = self.column_key(name);
        let expected = self.forecast.times.len();
        if values.len() != expected {
            return Err(ForecastError::LengthMismatch {
                file: None,
                key,
                expected,
                found: values.len(),
            });
        }
        let mut series: Series = Vec::with_capacity(values.len());
        for (index, value) in values.iter().enumerate() {
            let Some(raw) = *value else {
                series.push(None);
                continue;
            };
            if quantity == Quantity::CloudCover {
                // Checked on the raw percentage so the message shows what the file says.
                if raw.is_nan() || raw < 0.0 {
                    return Err(ForecastError::InvalidCover {
                        file: None,
                        key,
                        index,
                        value: raw,
                    });
                }
                if raw > 100.0 {
                    return Err(ForecastError::CoverAbove100 {
                        file: None,
                        key,
                        index,
                        value: raw,
                    });
                }
            }
            let mut si = conversion.apply(raw);
            if let Some(expected) = quantity.range_violation(raw, si) {
                return Err(ForecastError::OutOfRange {
                    file: None,
                    key,
                    index: Some(index),
                    value: raw,
                    expected,
                });
            }
            if quantity == Quantity::Direction {
                si = si.rem_euclid(360.0);
            }
            // f32 keeps ~7 significant digits, far finer than any forecast.
            series.push(Some(si as f32));
        }
        self.store(target, series);
        Ok(())
    }

    fn store(&mut self, target: Target, series: Series) {
        let forecast = &mut self.forecast;
        match target {
            Target::Series(variable) => forecast.series[variable as usize] = Some(series),
            // Range checks above guarantee integers 0–255 and 0/1 flags.
            Target::Pictocode => {
                forecast.pictocode = Some(series.iter().map(|v| v.map(|v| v as u8)).collect());
            }
            Target::WmoWeatherCode => {
                forecast.wmo_weather_code =
                    Some(series.iter().map(|v| v.map(|v| v as u8)).collect());
            }
            Target::IsDaylight => {
                forecast.is_daylight = Some(series.iter().map(|v| v.map(|v| v != 0.0)).collect());
            }
            Target::SnowWaterEquivalent => self.snow_water_mm = Some(series),
            Target::Level {
                pressure_hpa,
                field,
            } => {
                let pressure = f32::from(pressure_hpa);
                let position = forecast
                    .pressure_levels
                    .iter()
                    .position(|level| level.pressure_hpa == pressure);
                let level = if let Some(position) = position {
                    &mut forecast.pressure_levels[position]
                } else {
                    forecast.pressure_levels.push(PressureLevel {
                        pressure_hpa: pressure,
                        ..PressureLevel::default()
                    });
                    let last = forecast.pressure_levels.len() - 1;
                    &mut forecast.pressure_levels[last]
                };
                let slot = match field {
                    LevelField::WindSpeed => &mut level.wind_speed_m_s,
                    LevelField::WindDirection => &mut level.wind_direction_deg,
                    LevelField::Height => &mut level.height_m,
                    LevelField::CloudCover => &mut level.cloud_cover,
                };
                *slot = Some(series);
            }
        }
    }

    /// Derived variables, level order, then the finished forecast.
    pub fn finish(mut self) -> Forecast {
        let forecast = &mut self.forecast;
        if forecast.series[Variable::SnowFraction as usize].is_none()
            && let (Some(snow), Some(total)) = (
                &self.snow_water_mm,
                &forecast.series[Variable::Precipitation as usize],
            )
        {
            // Open-Meteo gives snowfall depth and total precipitation separately; their ratio
            // (water equivalents) is meteoblue's snowfraction. No precipitation: no snow.
            let fraction = snow
                .iter()
                .zip(total)
                .map(|(snow, total)| match (snow, total) {
                    (Some(snow), Some(total)) if *total > 0.0 => {
                        Some((snow / total).clamp(0.0, 1.0))
                    }
                    (Some(_), Some(_)) => Some(0.0),
                    _ => None,
                })
                .collect();
            forecast.series[Variable::SnowFraction as usize] = Some(fraction);
        }
        forecast
            .pressure_levels
            .sort_by(|a, b| b.pressure_hpa.total_cmp(&a.pressure_hpa));
        self.forecast
    }
}

/// Parses `"{prefix}{number}{suffix}"` keys such as `windspeedprofile_850_mb` or
/// `wind_speed_850hPa` to the pressure in hPa (1–1100).
pub(crate) fn level_from_key(key: &str, prefix: &str, suffix: &str) -> Option<u16> {
    let digits = key.strip_prefix(prefix)?.strip_suffix(suffix)?;
    if digits.is_empty() || !digits.bytes().all(|b| b.is_ascii_digit()) {
        return None;
    }
    digits
        .parse::<u16>()
        .ok()
        .filter(|hpa| (1..=1100).contains(hpa))
}

/// Checks an optional scalar metadata value against a range, naming its key.
pub(crate) fn check_scalar(
    key: impl Fn() -> String,
    value: f64,
    range: std::ops::RangeInclusive<f64>,
    expected: &'static str,
) -> Result<f64, ForecastError> {
    if range.contains(&value) {
        Ok(value)
    } else {
        Err(ForecastError::OutOfRange {
            file: None,
            key: key(),
            index: None,
            value,
            expected,
        })
    }
}

/// What the first, cheap pass finds at the top of each location object.
#[derive(Deserialize)]
struct Probe {
    metadata: Option<IgnoredAny>,
    data_1h: Option<IgnoredAny>,
    data_3h: Option<IgnoredAny>,
    hourly: Option<IgnoredAny>,
    error: Option<serde_json::Value>,
    reason: Option<serde_json::Value>,
    error_message: Option<serde_json::Value>,
}

impl Probe {
    /// The reason text if this object is an API error response.
    fn api_error(&self) -> Option<String> {
        let flagged = match &self.error {
            Some(serde_json::Value::Bool(flag)) => *flag,
            Some(serde_json::Value::Null) | None => false,
            Some(_) => true,
        } || self.error_message.is_some();
        if !flagged {
            return None;
        }
        let text = |value: &serde_json::Value| match value {
            serde_json::Value::String(text) => text.clone(),
            other => other.to_string(),
        };
        Some(
            self.reason
                .as_ref()
                .or(self.error_message.as_ref())
                .or(self.error.as_ref().filter(|e| !e.is_boolean()))
                .map_or_else(|| "no reason given".to_owned(), text),
        )
    }

    fn looks_like_meteoblue(&self) -> bool {
        self.metadata.is_some() || self.data_1h.is_some() || self.data_3h.is_some()
    }

    fn format(&self, hint: Option<ForecastFormat>) -> Result<ForecastFormat, String> {
        let meteoblue = self.looks_like_meteoblue();
        let open_meteo = self.hourly.is_some();
        match hint {
            Some(ForecastFormat::Meteoblue) if open_meteo && !meteoblue => {
                Err("meteoblue was asked for, but the file has Open-Meteo's `hourly`".to_owned())
            }
            Some(ForecastFormat::OpenMeteo) if meteoblue && !open_meteo => Err(
                "Open-Meteo was asked for, but the file has meteoblue's `metadata`/`data_1h`"
                    .to_owned(),
            ),
            Some(format) => Ok(format),
            None if meteoblue => Ok(ForecastFormat::Meteoblue),
            None if open_meteo => Ok(ForecastFormat::OpenMeteo),
            None => Err(
                "expected `metadata` and `data_1h` (meteoblue) or `hourly` (Open-Meteo)".to_owned(),
            ),
        }
    }
}

/// A location parsed with its format's typed structs.
enum TypedLocation {
    Meteoblue(MeteoblueFile),
    OpenMeteo(OpenMeteoFile),
}

impl TypedLocation {
    fn into_forecast(self, prefix: &str) -> Result<Forecast, ForecastError> {
        match self {
            Self::Meteoblue(file) => file.into_forecast(prefix),
            Self::OpenMeteo(file) => file.into_forecast(prefix),
        }
    }
}

/// Deserializes one location with the struct of the format the probe found.
struct LocationSeed(ForecastFormat);

impl<'de> DeserializeSeed<'de> for LocationSeed {
    type Value = TypedLocation;

    fn deserialize<D: serde::Deserializer<'de>>(
        self,
        deserializer: D,
    ) -> Result<Self::Value, D::Error> {
        Ok(match self.0 {
            ForecastFormat::Meteoblue => {
                TypedLocation::Meteoblue(MeteoblueFile::deserialize(deserializer)?)
            }
            ForecastFormat::OpenMeteo => {
                TypedLocation::OpenMeteo(OpenMeteoFile::deserialize(deserializer)?)
            }
        })
    }
}

/// Deserializes a JSON array of locations, each with its own format.
struct ArraySeed<'a>(&'a [ForecastFormat]);

impl<'de> DeserializeSeed<'de> for ArraySeed<'_> {
    type Value = Vec<TypedLocation>;

    fn deserialize<D: serde::Deserializer<'de>>(
        self,
        deserializer: D,
    ) -> Result<Self::Value, D::Error> {
        deserializer.deserialize_seq(self)
    }
}

impl<'de> Visitor<'de> for ArraySeed<'_> {
    type Value = Vec<TypedLocation>;

    fn expecting(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str("an array of forecast locations")
    }

    fn visit_seq<A: SeqAccess<'de>>(self, mut seq: A) -> Result<Self::Value, A::Error> {
        let mut locations = Vec::with_capacity(self.0.len());
        for &format in self.0 {
            match seq.next_element_seed(LocationSeed(format))? {
                Some(location) => locations.push(location),
                None => break,
            }
        }
        Ok(locations)
    }
}

/// Two passes: a cheap probe of every location's top-level keys (finds syntax errors, API error
/// objects and the format), then typed deserialization with the right structs.
fn parse_document(
    bytes: &[u8],
    hint: Option<ForecastFormat>,
) -> Result<Vec<Forecast>, ForecastError> {
    // Editors on Windows may prepend a UTF-8 byte-order mark, which JSON parsers reject.
    let bytes = bytes.strip_prefix(b"\xEF\xBB\xBF").unwrap_or(bytes);
    let json_error = |error: serde_json::Error| ForecastError::from_json(&error, bytes);
    let is_array = bytes
        .iter()
        .find(|b| !b.is_ascii_whitespace())
        .is_some_and(|&b| b == b'[');

    let probes: Vec<Probe> = if is_array {
        serde_json::from_slice(bytes).map_err(json_error)?
    } else {
        vec![serde_json::from_slice(bytes).map_err(json_error)?]
    };
    if probes.is_empty() {
        return Err(ForecastError::EmptyDocument { file: None });
    }
    let prefix = |index: usize| {
        if is_array {
            format!("[{index}].")
        } else {
            String::new()
        }
    };
    let mut formats = Vec::with_capacity(probes.len());
    for (index, probe) in probes.iter().enumerate() {
        if let Some(reason) = probe.api_error() {
            let reason = if is_array {
                format!("location {index}: {reason}")
            } else {
                reason
            };
            return Err(ForecastError::ApiError { file: None, reason });
        }
        let format = probe
            .format(hint)
            .map_err(|detail| ForecastError::UnknownFormat {
                file: None,
                detail: format!("{}{detail}", prefix(index)),
            })?;
        formats.push(format);
    }

    let mut deserializer = serde_json::Deserializer::from_slice(bytes);
    let typed = if is_array {
        ArraySeed(&formats).deserialize(&mut deserializer)
    } else {
        LocationSeed(formats[0])
            .deserialize(&mut deserializer)
            .map(|location| vec![location])
    }
    .map_err(json_error)?;

    typed
        .into_iter()
        .enumerate()
        .map(|(index, location)| location.into_forecast(&prefix(index)))
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Fixtures are included relative to this file so the tests find them from any crate root.
    macro_rules! fixture {
        ($name:literal) => {
            include_bytes!(concat!("../../tests/fixtures/weather/", $name)).as_slice()
        };
    }

    macro_rules! asset {
        ($name:literal) => {
            include_bytes!(concat!("../../assets/weather/", $name)).as_slice()
        };
    }

    fn parse(bytes: &[u8]) -> Forecast {
        match Forecast::from_slice(bytes, None) {
            Ok(forecast) => forecast,
            Err(error) => panic!("{error}"),
        }
    }

    fn utc(text: &str) -> UtcInstant {
        text.parse().unwrap()
    }

    /// 2021-05-03 12:00–17:00 CEST, the fixtures' hours, in UTC.
    fn fixture_times() -> Vec<UtcInstant> {
        (0..6)
            .map(|i| UtcInstant::from_unix_seconds(1_620_036_000 + 3600 * i))
            .collect()
    }

    fn close(a: Option<f32>, b: f32, tolerance: f32) -> bool {
        a.is_some_and(|a| (a - b).abs() <= tolerance)
    }

    #[test]
    fn merged_meteoblue_with_every_extra_block() {
        let forecast = parse(fixture!("meteoblue_basic-1h_clouds-1h.json"));
        assert_eq!(forecast.format, Some(ForecastFormat::Meteoblue));
        assert_eq!(
            forecast.place,
            Place {
                name: "Bern".into(),
                latitude_deg: 46.95,
                longitude_deg: 7.45,
                elevation_m: 540.0,
            }
        );
        assert_eq!(forecast.times, fixture_times());
        assert_eq!(forecast.times[0].to_string(), "2021-05-03T10:00:00Z");
        assert_eq!(forecast.utc_offset_s, 7200);
        assert_eq!(forecast.timezone_abbreviation.as_deref(), Some("CEST"));
        assert_eq!(forecast.model_run, Some(utc("2021-05-03T00:00:00Z")));
        assert!(forecast.warnings.is_empty(), "{:?}", forecast.warnings);

        // Percent → fraction, nulls kept as gaps.
        assert_eq!(
            forecast.series(Variable::LowCover).unwrap(),
            &[Some(0.1), Some(0.3), Some(0.6), None, Some(1.0), Some(0.9)]
        );
        assert_eq!(forecast.series(Variable::Precipitation).unwrap()[0], None);
        assert_eq!(
            forecast.series(Variable::Precipitation).unwrap()[2],
            Some(0.27)
        );
        assert_eq!(
            forecast.series(Variable::SunshineDuration).unwrap()[1],
            Some(3000.0)
        );
        assert_eq!(
            forecast.series(Variable::SeaLevelPressure).unwrap()[0],
            Some(101_550.0)
        );
        assert_eq!(
            forecast.series(Variable::RelativeHumidity).unwrap()[0],
            Some(0.55)
        );
        assert_eq!(
            forecast.series(Variable::FogProbability).unwrap()[2],
            Some(0.03)
        );
        assert_eq!(
            forecast.series(Variable::WindDirection).unwrap()[0],
            Some(350.0)
        );
        assert_eq!(
            forecast.pictocode.as_deref().unwrap(),
            &[Some(4), Some(7), Some(31), None, Some(23), Some(33)]
        );
        assert_eq!(forecast.is_daylight.as_deref().unwrap()[0], Some(true));
        assert!(forecast.series(Variable::ConvectiveCloudBase).is_none());

        // Profile packages: levels sorted from the ground up, fields per level.
        let pressures: Vec<f32> = forecast
            .pressure_levels
            .iter()
            .map(|level| level.pressure_hpa)
            .collect();
        assert_eq!(pressures, [850.0, 500.0]);
        let level = forecast.pressure_level(850.0).unwrap();
        assert_eq!(level.height_m.as_ref().unwrap()[0], Some(1520.0));
        assert_eq!(level.cloud_cover.as_ref().unwrap()[2], Some(0.5));
        let upper = forecast.pressure_level(500.0).unwrap();
        assert_eq!(upper.wind_speed_m_s.as_ref().unwrap()[3], None);
        assert!(upper.height_m.is_none());
    }

    #[test]
    fn iso_times_and_imperial_units_convert_to_the_same_forecast() {
        let reference = parse(fixture!("meteoblue_basic-1h_clouds-1h.json"));
        let iso = parse(fixture!("meteoblue_iso8601.json"));
        assert_eq!(iso.times, reference.times);
        assert_eq!(iso.timezone_abbreviation.as_deref(), Some("CEST"));
        for (variable, tolerance) in [
            (Variable::Temperature, 0.05),
            (Variable::WindSpeed, 0.02),
            (Variable::Precipitation, 0.01),
            (Variable::ConvectivePrecipitation, 0.01),
            (Variable::LowCover, 0.0),
        ] {
            let (a, b) = (
                iso.series(variable).unwrap(),
                reference.series(variable).unwrap(),
            );
            for (i, (a, b)) in a.iter().zip(b).enumerate() {
                match (a, b) {
                    (Some(a), Some(b)) => {
                        assert!((a - b).abs() <= tolerance, "{variable:?}[{i}]: {a} vs {b}");
                    }
                    (None, None) => {}
                    _ => panic!("{variable:?}[{i}]: {a:?} vs {b:?}"),
                }
            }
        }
        assert!(iso.pressure_levels.is_empty());
    }

    #[test]
    fn utc_timestamps_and_knots() {
        let forecast = parse(fixture!("meteoblue_timestamp_utc.json"));
        assert_eq!(forecast.times, fixture_times());
        // 6.8 kn = 3.498 m/s.
        assert!(close(
            forecast.series(Variable::WindSpeed).unwrap()[0],
            3.498,
            0.001
        ));
        assert_eq!(forecast.utc_offset_s, 0);
    }

    #[test]
    fn single_packages_and_three_hourly_blocks() {
        let basic = parse(fixture!("meteoblue_basic-1h.json"));
        assert!(basic.series(Variable::LowCover).is_none());
        assert!(basic.series(Variable::Visibility).is_none());
        // 7.8 mph = 3.487 m/s.
        assert!(close(
            basic.series(Variable::WindSpeed).unwrap()[0],
            3.487,
            0.001
        ));
        assert!(basic.pictocode.is_some());

        let clouds = parse(fixture!("meteoblue_clouds-1h.json"));
        assert!(clouds.series(Variable::WindSpeed).is_none());
        assert_eq!(clouds.series(Variable::HighCover).unwrap()[0], Some(0.1));

        let three_hourly = parse(fixture!("meteoblue_basic-3h.json"));
        assert_eq!(three_hourly.len(), 3);
        assert_eq!(
            three_hourly.times[1].unix_seconds() - three_hourly.times[0].unix_seconds(),
            10_800
        );
    }

    #[test]
    fn open_meteo_single_location() {
        let forecast = parse(fixture!("open_meteo.json"));
        assert_eq!(forecast.format, Some(ForecastFormat::OpenMeteo));
        assert_eq!(forecast.place.elevation_m, 540.0);
        assert_eq!(forecast.place.name, "");
        assert_eq!(forecast.times, fixture_times()[..4]);
        assert_eq!(forecast.utc_offset_s, 7200);
        assert_eq!(forecast.series(Variable::TotalCover).unwrap()[2], None);
        // 12.6 km/h = 3.5 m/s.
        assert!(close(
            forecast.series(Variable::WindSpeed).unwrap()[0],
            3.5,
            1e-5
        ));
        assert_eq!(
            forecast.series(Variable::ConvectivePrecipitation).unwrap()[1],
            Some(0.3)
        );
        assert_eq!(
            forecast.series(Variable::ConvectiveCloudTop).unwrap()[1],
            Some(4200.0)
        );
        assert_eq!(forecast.wmo_weather_code.as_deref().unwrap()[1], Some(80));
        // 0.7 cm of snow = 1 mm of water out of 2 mm: half falls as snow.
        assert_eq!(
            forecast.series(Variable::SnowFraction).unwrap(),
            &[Some(0.0), Some(0.0), None, Some(0.5)]
        );
        let pressures: Vec<f32> = forecast
            .pressure_levels
            .iter()
            .map(|level| level.pressure_hpa)
            .collect();
        assert_eq!(pressures, [850.0, 700.0]);
        assert!(close(
            forecast
                .pressure_level(850.0)
                .unwrap()
                .wind_speed_m_s
                .as_ref()
                .unwrap()[0],
            25.0 / 3.6,
            1e-5
        ));
        assert_eq!(
            forecast
                .pressure_level(700.0)
                .unwrap()
                .cloud_cover
                .as_ref()
                .unwrap()[3],
            Some(0.9)
        );
        assert_eq!(forecast.warnings.len(), 1, "{:?}", forecast.warnings);
        assert!(forecast.warnings[0].contains("wind_speed_500hPa"));
    }

    #[test]
    fn open_meteo_unixtime_and_imperial_units() {
        let forecast = parse(fixture!("open_meteo_unixtime.json"));
        assert_eq!(forecast.times[0], utc("2021-05-03T12:00:00Z"));
        assert!(close(
            forecast.series(Variable::Temperature).unwrap()[2],
            15.0,
            1e-4
        ));
        assert!(close(
            forecast.series(Variable::Precipitation).unwrap()[2],
            2.032,
            1e-4
        ));
        assert!(close(
            forecast.series(Variable::WindSpeed).unwrap()[2],
            5.990,
            1e-3
        ));
        assert!(close(
            forecast.series(Variable::Visibility).unwrap()[2],
            8000.1,
            0.1
        ));
    }

    #[test]
    fn open_meteo_multi_location_array() {
        let bytes = fixture!("open_meteo_multi.json");
        let first = parse(bytes);
        assert_eq!(first.place.latitude_deg, 46.94);
        assert!(first.warnings.iter().any(|w| w.contains("2 locations")));
        let all = Forecast::all_from_slice(bytes, None).unwrap();
        assert_eq!(all.len(), 2);
        assert_eq!(all[1].place.elevation_m, 432.0);
        assert_eq!(all[1].series(Variable::LowCover).unwrap()[0], Some(0.9));
        assert!(
            all[1]
                .warnings
                .iter()
                .any(|w| w.starts_with("[1].hourly.wind_speed_500hPa"))
        );
    }

    #[test]
    fn format_hints() {
        let meteoblue = fixture!("meteoblue_basic-1h.json");
        assert!(Forecast::from_slice(meteoblue, Some(ForecastFormat::Meteoblue)).is_ok());
        let error = Forecast::from_slice(meteoblue, Some(ForecastFormat::OpenMeteo)).unwrap_err();
        assert!(
            matches!(error, ForecastError::UnknownFormat { .. }),
            "{error}"
        );
        let open_meteo = fixture!("open_meteo.json");
        let error = Forecast::from_slice(open_meteo, Some(ForecastFormat::Meteoblue)).unwrap_err();
        assert!(
            matches!(error, ForecastError::UnknownFormat { .. }),
            "{error}"
        );
    }

    #[test]
    fn byte_order_mark_and_whitespace_are_accepted() {
        let mut bytes = b"\xEF\xBB\xBF\n  ".to_vec();
        bytes.extend_from_slice(fixture!("meteoblue_clouds-1h.json"));
        assert_eq!(parse(&bytes).len(), 6);
    }

    /// What a bad fixture must give: the variant (by name), the key and the index.
    fn expect_error(bytes: &[u8], variant: &str, key: Option<&str>, index: Option<usize>) {
        let error = Forecast::from_slice(bytes, None).unwrap_err();
        let debug = format!("{error:?}");
        assert!(
            debug.starts_with(variant),
            "expected {variant}, got {error:?}"
        );
        assert_eq!(error.key(), key, "{error}");
        assert_eq!(error.index(), index, "{error}");
        let text = error.clone().with_file("forecast.json").to_string();
        assert!(text.starts_with("forecast.json: "), "{text}");
        if let Some(key) = key {
            assert!(text.contains(key), "{text}");
        }
        if let Some(index) = index {
            assert!(text.contains(&index.to_string()), "{text}");
        }
    }

    #[test]
    fn bad_files_give_typed_errors_naming_key_and_index() {
        expect_error(
            fixture!("bad_length_mismatch.json"),
            "LengthMismatch",
            Some("data_1h.lowclouds"),
            None,
        );
        expect_error(
            fixture!("bad_unknown_unit.json"),
            "UnknownUnit",
            Some("units.windspeed"),
            None,
        );
        expect_error(
            fixture!("bad_empty_time.json"),
            "EmptyTime",
            Some("data_1h.time"),
            None,
        );
        expect_error(
            fixture!("bad_times_not_increasing.json"),
            "TimesNotIncreasing",
            Some("data_1h.time"),
            Some(3),
        );
        expect_error(
            fixture!("bad_duplicate_time.json"),
            "DuplicateTime",
            Some("data_1h.time"),
            Some(4),
        );
        expect_error(
            fixture!("bad_nan_cover.json"),
            "NonFiniteLiteral",
            Some("data_1h.midclouds"),
            Some(2),
        );
        expect_error(
            fixture!("bad_negative_cover.json"),
            "InvalidCover",
            Some("data_1h.highclouds"),
            Some(1),
        );
        expect_error(
            fixture!("bad_cover_above_100.json"),
            "CoverAbove100",
            Some("data_1h.totalcloudcover"),
            Some(4),
        );
        expect_error(
            fixture!("bad_open_meteo_error.json"),
            "ApiError",
            None,
            None,
        );
        expect_error(
            fixture!("bad_missing_key.json"),
            "MissingKey",
            Some("metadata.latitude"),
            None,
        );
        expect_error(
            fixture!("bad_time_string.json"),
            "BadTime",
            Some("data_1h.time"),
            Some(2),
        );
        expect_error(
            fixture!("bad_unknown_format.json"),
            "UnknownFormat",
            None,
            None,
        );
        expect_error(
            fixture!("bad_negative_precipitation.json"),
            "OutOfRange",
            Some("data_1h.precipitation"),
            Some(5),
        );
        expect_error(
            fixture!("bad_open_meteo_length_mismatch.json"),
            "LengthMismatch",
            Some("[1].hourly.wind_speed_10m"),
            None,
        );
        let error = Forecast::from_slice(fixture!("bad_broken_json.json"), None).unwrap_err();
        let ForecastError::Json { line, path, .. } = &error else {
            panic!("{error:?}");
        };
        assert!(*line > 1 && path.is_some(), "{error}");
        let error = Forecast::from_slice(fixture!("bad_open_meteo_error.json"), None).unwrap_err();
        assert!(error.to_string().contains("cloud_covr"), "{error}");
    }

    #[test]
    fn inline_bad_cases() {
        let case = |text: &str| Forecast::from_slice(text.as_bytes(), None).unwrap_err();
        assert!(matches!(case(""), ForecastError::Json { line: 1, .. }));
        assert!(matches!(case("[]"), ForecastError::EmptyDocument { .. }));
        assert!(matches!(case("42"), ForecastError::Json { .. }));
        // A string where a cover belongs: broken JSON that still names the key and index.
        let error = case(
            r#"{"metadata": {"latitude": 1, "longitude": 2}, "units": {},
                "data_1h": {"time": ["2021-05-03 00:00"], "lowclouds": ["NaN"]}}"#,
        );
        assert_eq!(error.key(), Some("data_1h.lowclouds"));
        assert_eq!(error.index(), Some(0));
        // A cover without its unit category.
        let error = case(
            r#"{"metadata": {"latitude": 1, "longitude": 2, "utc_timeoffset": 0}, "units": {},
                "data_1h": {"time": ["2021-05-03 00:00"], "lowclouds": [3]}}"#,
        );
        assert_eq!(error.key(), Some("units.cloudcover"), "{error}");
        // Local times without an offset anywhere.
        let error = case(
            r#"{"metadata": {"latitude": 1, "longitude": 2}, "units": {},
                "data_1h": {"time": ["2021-05-03 00:00"]}}"#,
        );
        assert_eq!(error.key(), Some("metadata.utc_timeoffset"), "{error}");
        // Latitude out of range.
        let error = case(
            r#"{"metadata": {"latitude": 91, "longitude": 2}, "units": {},
                "data_1h": {"time": [0]}}"#,
        );
        assert!(matches!(error, ForecastError::OutOfRange { .. }), "{error}");
        // An unknown time unit, an error object from meteoblue, a null time.
        let error = case(
            r#"{"metadata": {"latitude": 1, "longitude": 2}, "units": {"time": "DD.MM.YYYY"},
                "data_1h": {"time": [0]}}"#,
        );
        assert_eq!(error.key(), Some("units.time"));
        assert!(matches!(
            case(r#"{"error_message": "API key invalid"}"#),
            ForecastError::ApiError { reason, .. } if reason == "API key invalid"
        ));
        let error = case(r#"{"latitude": 1, "longitude": 2, "hourly": {"time": [0, null]}}"#);
        assert_eq!((error.key(), error.index()), (Some("hourly.time"), Some(1)));
    }

    #[test]
    fn from_path_names_the_file_and_the_place() {
        let directory =
            std::env::temp_dir().join(format!("cloudscape_forecast_{}", std::process::id()));
        std::fs::create_dir_all(&directory).unwrap();
        let good = directory.join("bern_open_meteo.json");
        std::fs::write(&good, asset!("bern_open_meteo.json")).unwrap();
        let forecast = Forecast::from_path(&good, None).unwrap();
        assert_eq!(forecast.place.name, "bern_open_meteo");

        let bad = directory.join("bad.json");
        std::fs::write(&bad, fixture!("bad_cover_above_100.json")).unwrap();
        let error = Forecast::from_path(&bad, None).unwrap_err();
        assert_eq!(error.file(), Some(bad.as_path()));
        assert!(error.to_string().starts_with(&bad.display().to_string()));

        let missing = directory.join("missing.json");
        let error = Forecast::from_path(&missing, None).unwrap_err();
        assert!(
            matches!(error, ForecastError::Io { .. }) && error.file() == Some(missing.as_path())
        );
        std::fs::remove_dir_all(&directory).unwrap();

        struct Failing;
        impl Read for Failing {
            fn read(&mut self, _: &mut [u8]) -> std::io::Result<usize> {
                Err(std::io::Error::other("disk on fire"))
            }
        }
        let error = Forecast::from_reader(Failing, None).unwrap_err();
        assert!(error.to_string().contains("disk on fire"));
        assert!(Forecast::from_reader(fixture!("open_meteo.json"), None).is_ok());
    }

    #[test]
    fn bundled_forecasts_parse() {
        let start = utc("2021-05-02T22:00:00Z");
        let end = utc("2021-05-09T22:00:00Z");
        for (bytes, name, latitude, longitude, elevation) in [
            (asset!("bern.json"), "Bern", 46.948, 7.447, 540.0),
            (asset!("solothurn.json"), "Solothurn", 47.208, 7.537, 432.0),
            (asset!("fribourg.json"), "Fribourg", 46.806, 7.162, 610.0),
        ] {
            let forecast = parse(bytes);
            assert_eq!(forecast.place.name, name);
            assert_eq!(
                (
                    forecast.place.latitude_deg,
                    forecast.place.longitude_deg,
                    forecast.place.elevation_m
                ),
                (latitude, longitude, elevation)
            );
            assert_eq!(forecast.len(), 169);
            assert_eq!((forecast.start(), forecast.end()), (Some(start), Some(end)));
            for variable in Variable::ALL {
                let has = forecast.series(variable).is_some();
                let expected = !matches!(
                    variable,
                    Variable::ConvectiveCloudBase | Variable::ConvectiveCloudTop
                );
                assert_eq!(has, expected, "{name} {variable:?}");
            }
            assert!(forecast.warnings.is_empty(), "{:?}", forecast.warnings);
        }
        assert_eq!(
            parse(asset!("solothurn.json"))
                .series(Variable::Precipitation)
                .unwrap()[0],
            None
        );

        let open_meteo = parse(asset!("bern_open_meteo.json"));
        assert_eq!(open_meteo.len(), 169);
        assert_eq!(
            (open_meteo.start(), open_meteo.end()),
            (Some(start), Some(end))
        );
        assert_eq!(open_meteo.pressure_levels.len(), 4);
        let top = open_meteo.pressure_level(300.0).unwrap();
        assert_eq!(top.wind_speed_m_s.as_ref().unwrap()[168], None);
        assert!(top.wind_speed_m_s.as_ref().unwrap()[162].is_some());
    }

    /// xorshift64 (Marsaglia 2003): a deterministic stream for the mutation test.
    struct XorShift(u64);

    impl XorShift {
        fn next(&mut self) -> u64 {
            self.0 ^= self.0 << 13;
            self.0 ^= self.0 >> 7;
            self.0 ^= self.0 << 17;
            self.0
        }

        fn below(&mut self, n: usize) -> usize {
            (self.next() % n.max(1) as u64) as usize
        }
    }

    /// Replacement pieces that reach the parser's checks rather than only its syntax errors.
    const TOKENS: [&[u8]; 24] = [
        b"null",
        b"NaN",
        b"-5",
        b"101",
        b"1e400",
        b"\"x\"",
        b"[]",
        b"{}",
        b"true",
        b",",
        b":",
        b"]",
        b"}",
        b"\"",
        b"0",
        b"-",
        "é".as_bytes(),
        b"\xFF",
        b"\"2021-13-45 99:99\"",
        b"99999999999999999999",
        b"-0.0",
        b"\"kmh\"",
        b"\"ISO8601\"",
        b"1620036000",
    ];

    fn mutate(rng: &mut XorShift, original: &[u8]) -> Vec<u8> {
        let mut bytes = original.to_vec();
        for _ in 0..=rng.below(3) {
            let at = rng.below(bytes.len());
            match rng.below(7) {
                0 => {
                    let byte = rng.next() as u8;
                    bytes[at] = byte;
                }
                1 => {
                    let end = (at + 1 + rng.below(8)).min(bytes.len());
                    bytes.drain(at..end);
                }
                2 => {
                    let token = TOKENS[rng.below(TOKENS.len())];
                    bytes.splice(at..at, token.iter().copied());
                }
                3 => {
                    // Replace a whole number (value-level mutation).
                    let start = (at..bytes.len()).find(|&i| bytes[i].is_ascii_digit());
                    if let Some(start) = start {
                        let end = (start..bytes.len())
                            .find(|&i| !(bytes[i].is_ascii_digit() || bytes[i] == b'.'))
                            .unwrap_or(bytes.len());
                        let token = TOKENS[rng.below(TOKENS.len())];
                        bytes.splice(start..end, token.iter().copied());
                    }
                }
                4 => bytes.truncate(at),
                5 => {
                    let end = (at + rng.below(40)).min(bytes.len());
                    let copy = bytes[at..end].to_vec();
                    let to = rng.below(bytes.len());
                    bytes.splice(to..to, copy);
                }
                _ => {
                    let punctuation = b"{}[],:\"0123456789 -.eE";
                    bytes[at] = punctuation[rng.below(punctuation.len())];
                }
            }
            if bytes.is_empty() {
                break;
            }
        }
        bytes
    }

    /// Checks the invariants a parsed forecast promises, then samples it everywhere.
    fn check_forecast(forecast: &Forecast) {
        assert!(!forecast.times.is_empty());
        assert!(forecast.times.windows(2).all(|w| w[0] < w[1]));
        for variable in Variable::ALL {
            if let Some(series) = forecast.series(variable) {
                assert_eq!(series.len(), forecast.len());
                for value in series.iter().flatten() {
                    assert!(value.is_finite());
                    if variable.unit() == "fraction 0-1" {
                        assert!((0.0..=1.0).contains(value), "{variable:?} {value}");
                    }
                }
            }
        }
        let mut sampler = crate::weather::Sampler::new();
        let (start, end) = (
            forecast.times[0].unix_seconds(),
            forecast.end().unwrap().unix_seconds(),
        );
        for t in [
            start - 7200,
            start,
            (start + end) / 2,
            end,
            end + 1,
            i64::MIN,
            i64::MAX,
        ] {
            let state = sampler.sample(forecast, UtcInstant::from_unix_seconds(t));
            for value in state.values.iter().flatten() {
                assert!(value.is_finite());
            }
            let _ = sampler.take_warning();
        }
    }

    #[test]
    fn thousands_of_mutations_never_panic() {
        let mut rng = XorShift(0x9E37_79B9_7F4A_7C15);
        let mut outcomes = std::collections::BTreeMap::<String, usize>::new();
        let inputs: [(&[u8], usize); 4] = [
            (fixture!("meteoblue_basic-1h_clouds-1h.json"), 2500),
            (fixture!("open_meteo_multi.json"), 1000),
            (fixture!("meteoblue_timestamp_utc.json"), 500),
            (asset!("bern.json"), 200),
        ];
        for (original, count) in inputs {
            for _ in 0..count {
                let bytes = mutate(&mut rng, original);
                let result = std::panic::catch_unwind(|| {
                    let parsed = Forecast::all_from_slice(&bytes, None);
                    if let Ok(forecasts) = &parsed {
                        forecasts.iter().for_each(check_forecast);
                    }
                    parsed
                });
                let outcome = match result {
                    Ok(Ok(_)) => "ok".to_owned(),
                    Ok(Err(error)) => {
                        // Every message is one line and never empty.
                        let text = error.to_string();
                        assert!(!text.is_empty() && !text.contains('\n'), "{text}");
                        format!("{error:?}")
                            .split([' ', '{'])
                            .next()
                            .unwrap()
                            .to_owned()
                    }
                    Err(_) => panic!("panicked on input:\n{}", String::from_utf8_lossy(&bytes)),
                };
                *outcomes.entry(outcome).or_default() += 1;
            }
        }
        eprintln!("mutation outcomes: {outcomes:?}");
        // The mutations reach well past the JSON syntax check.
        assert!(
            outcomes.get("ok").copied().unwrap_or(0) > 100,
            "{outcomes:?}"
        );
        assert!(outcomes.len() >= 8, "{outcomes:?}");
    }
}
