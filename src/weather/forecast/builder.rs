//! [`ForecastBuilder`]: raw columns into a checked [`Forecast`], and the readers' shared checks.

use super::{Forecast, ForecastError, ForecastFormat, PressureLevel, Series, Variable};
use crate::scene::{Place, UtcInstant};
use crate::weather::raw::RawTime;
use crate::weather::units::{Linear, Quantity};

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
