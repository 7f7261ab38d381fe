//! Open-Meteo forecast files (Open-Meteo's forecast API documentation (open-meteo.com/en/docs)).
//!
//! One location per JSON object (a multi-location request returns an array of them; see
//! [`Forecast::all_from_slice`](super::Forecast::all_from_slice)). Units are given per variable in
//! `hourly_units`; a variable the model does not support has unit `"undefined"` and is skipped with
//! a note in [`Forecast::warnings`](super::Forecast::warnings). Times are ISO 8601 local time
//! without an offset, shifted by the file-wide `utc_offset_seconds`, or integer UTC seconds
//! (`timeformat=unixtime`). Pressure-level variables (`wind_speed_850hPa`,
//! `geopotential_height_850hPa`, `cloud_cover_850hPa`, …) become
//! [`PressureLevel`](super::PressureLevel)s. Older variable names without the underscore
//! (`cloudcover`, `windspeed_10m`) are accepted too.

use std::collections::BTreeMap;

use serde::Deserialize;

use super::error::ForecastError;
use super::forecast::{
    Forecast, ForecastBuilder, ForecastFormat, LevelField, Target, Variable, check_scalar,
    level_from_key,
};
use super::raw::{ColumnFilter, RawBlock};
use super::units::{Linear, Quantity};
use crate::scene::Place;

/// The top level of one Open-Meteo location. `daily`, `current`, `minutely_15` and any other key
/// are skipped.
#[derive(Debug, Deserialize)]
pub(crate) struct OpenMeteoFile {
    latitude: Option<f64>,
    longitude: Option<f64>,
    /// Elevation above sea level, m.
    elevation: Option<f64>,
    /// Seconds east of UTC of the local time stamps.
    utc_offset_seconds: Option<f64>,
    timezone_abbreviation: Option<String>,
    hourly_units: Option<BTreeMap<String, Option<String>>>,
    hourly: Option<RawBlock<OpenMeteoColumns>>,
}

/// The hourly variables this crate reads, by key, with their quantity.
fn column_spec(key: &str) -> Option<(Target, Quantity)> {
    use Quantity as Q;
    use Variable as V;
    let series = Target::Series;
    Some(match key {
        "cloud_cover" | "cloudcover" => (series(V::TotalCover), Q::CloudCover),
        "cloud_cover_low" | "cloudcover_low" => (series(V::LowCover), Q::CloudCover),
        "cloud_cover_mid" | "cloudcover_mid" => (series(V::MidCover), Q::CloudCover),
        "cloud_cover_high" | "cloudcover_high" => (series(V::HighCover), Q::CloudCover),
        "precipitation" => (series(V::Precipitation), Q::PrecipitationAmount),
        "showers" => (series(V::ConvectivePrecipitation), Q::PrecipitationAmount),
        "snowfall" => (Target::SnowWaterEquivalent, Q::SnowDepth),
        "precipitation_probability" => (series(V::PrecipitationProbability), Q::Percentage),
        "temperature_2m" => (series(V::Temperature), Q::Temperature),
        "relative_humidity_2m" | "relativehumidity_2m" => {
            (series(V::RelativeHumidity), Q::Percentage)
        }
        "pressure_msl" => (series(V::SeaLevelPressure), Q::Pressure),
        "wind_speed_10m" | "windspeed_10m" => (series(V::WindSpeed), Q::Speed),
        "wind_direction_10m" | "winddirection_10m" => (series(V::WindDirection), Q::Direction),
        "visibility" => (series(V::Visibility), Q::Distance),
        "sunshine_duration" => (series(V::SunshineDuration), Q::Duration),
        "convective_cloud_base" => (series(V::ConvectiveCloudBase), Q::Distance),
        "convective_cloud_top" => (series(V::ConvectiveCloudTop), Q::Distance),
        "lightning_potential" => (series(V::LightningPotential), Q::SpecificEnergy),
        "is_day" => (Target::IsDaylight, Q::Flag),
        "weather_code" | "weathercode" => (Target::WmoWeatherCode, Q::Code),
        _ => return level_spec(key),
    })
}

/// Pressure-level keys such as `wind_speed_850hPa`.
fn level_spec(key: &str) -> Option<(Target, Quantity)> {
    const LEVEL_KEYS: [(&str, LevelField, Quantity); 7] = [
        ("wind_speed_", LevelField::WindSpeed, Quantity::Speed),
        ("windspeed_", LevelField::WindSpeed, Quantity::Speed),
        (
            "wind_direction_",
            LevelField::WindDirection,
            Quantity::Direction,
        ),
        (
            "winddirection_",
            LevelField::WindDirection,
            Quantity::Direction,
        ),
        ("geopotential_height_", LevelField::Height, Quantity::Height),
        ("cloud_cover_", LevelField::CloudCover, Quantity::CloudCover),
        ("cloudcover_", LevelField::CloudCover, Quantity::CloudCover),
    ];
    LEVEL_KEYS.iter().find_map(|&(prefix, field, quantity)| {
        level_from_key(key, prefix, "hPa").map(|pressure_hpa| {
            (
                Target::Level {
                    pressure_hpa,
                    field,
                },
                quantity,
            )
        })
    })
}

/// Keeps the block keys [`column_spec`] knows.
#[derive(Debug)]
pub(crate) struct OpenMeteoColumns;

impl ColumnFilter for OpenMeteoColumns {
    fn wanted(key: &str) -> bool {
        column_spec(key).is_some()
    }
}

impl OpenMeteoFile {
    /// Checks and converts to a [`Forecast`]; keys in errors are prefixed with `prefix`.
    pub(crate) fn into_forecast(self, prefix: &str) -> Result<Forecast, ForecastError> {
        let key = |name: &str| format!("{prefix}{name}");
        let missing = |name: &str| ForecastError::MissingKey {
            file: None,
            key: key(name),
        };

        let latitude = self.latitude.ok_or_else(|| missing("latitude"))?;
        let latitude = check_scalar(|| key("latitude"), latitude, -90.0..=90.0, "-90 to 90")?;
        let longitude = self.longitude.ok_or_else(|| missing("longitude"))?;
        let longitude = check_scalar(
            || key("longitude"),
            longitude,
            -180.0..=180.0,
            "-180 to 180",
        )?;
        let offset_s = self
            .utc_offset_seconds
            .map(|seconds| {
                check_scalar(
                    || key("utc_offset_seconds"),
                    seconds,
                    -64_800.0..=64_800.0,
                    "-64800 to 64800 s",
                )
            })
            .transpose()?
            .map(|seconds| seconds.round() as i64);

        let block = self.hourly.ok_or_else(|| missing("hourly"))?;
        let units = self.hourly_units.unwrap_or_default();
        let unit = |name: &str| units.get(name).and_then(Option::as_deref);
        if let Some(time_unit) = unit("time")
            && !matches!(time_unit, "iso8601" | "unixtime")
        {
            return Err(ForecastError::UnknownUnit {
                file: None,
                key: key("hourly_units.time"),
                unit: time_unit.to_owned(),
            });
        }

        let place = Place {
            name: String::new(),
            latitude_deg: latitude,
            longitude_deg: longitude,
            elevation_m: self.elevation.unwrap_or(0.0),
        };
        let mut builder = ForecastBuilder::new(ForecastFormat::OpenMeteo, place, prefix, "hourly");
        builder.set_times(block.time, offset_s, "utc_offset_seconds")?;

        let mut skipped = Vec::new();
        for (name, values) in &block.columns {
            let Some((target, quantity)) = column_spec(name) else {
                continue;
            };
            let conversion = if quantity.has_unit() {
                let unit_key = key(&format!("hourly_units.{name}"));
                let written = unit(name).ok_or_else(|| ForecastError::MissingKey {
                    file: None,
                    key: unit_key.clone(),
                })?;
                if written == "undefined" {
                    // Open-Meteo's marker for a variable the chosen model does not provide.
                    skipped.push(name.clone());
                    continue;
                }
                quantity
                    .conversion(written)
                    .ok_or_else(|| ForecastError::UnknownUnit {
                        file: None,
                        key: unit_key,
                        unit: written.to_owned(),
                    })?
            } else {
                Linear::IDENTITY
            };
            builder.add_column(name, values, target, quantity, conversion)?;
        }

        let forecast = builder.forecast_mut();
        forecast.utc_offset_s = offset_s.map_or(0, |s| s as i32);
        forecast.timezone_abbreviation = self.timezone_abbreviation;
        for name in skipped {
            forecast.warnings.push(format!(
                "{prefix}hourly.{name}: unit \"undefined\" (not provided by the model); ignored"
            ));
        }
        if self.elevation.is_none() {
            forecast
                .warnings
                .push(format!("{prefix}elevation is missing; assuming 0 m"));
        }
        Ok(builder.finish())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn level_keys_parse() {
        assert_eq!(
            column_spec("geopotential_height_500hPa").map(|(target, _)| target),
            Some(Target::Level {
                pressure_hpa: 500,
                field: LevelField::Height
            })
        );
        assert!(column_spec("cloud_cover_low").is_some());
        assert!(column_spec("wind_speed_850hpa").is_none());
        assert!(column_spec("wind_speed_hPa").is_none());
        assert!(column_spec("wind_gusts_10m").is_none());
    }
}
