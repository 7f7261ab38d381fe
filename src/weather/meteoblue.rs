//! meteoblue Packages API files (meteoblue's Packages API documentation (docs.meteoblue.com)).
//!
//! Reads `basic-1h`, `clouds-1h` and their merge `basic-1h_clouds-1h` (one `data_1h` block with one
//! `time` array), tolerates `data_xmin`, `data_3h`, `data_day` and `data_current` blocks (the
//! hourly block is used; `data_3h` only when there is no `data_1h`), and keeps the profile packages'
//! pressure-level variables (`windspeedprofile_850_mb`, …) as optional extras.
//!
//! Units are keyed by category (`units.cloudcover` covers all four cloud variables,
//! `units.pressure` covers `sealevelpressure`, `units.probability` covers `fog_probability`).
//! Times are local `"YYYY-MM-DD hh:mm"` shifted by the file-wide `metadata.utc_timeoffset` (hours),
//! ISO 8601 strings, or integer UTC timestamps (`timeformat=timestamp_utc`).

use std::collections::BTreeMap;

use serde::Deserialize;

use super::error::ForecastError;
use super::forecast::{
    Forecast, ForecastBuilder, ForecastFormat, LevelField, Target, Variable, check_scalar,
    level_from_key,
};
use super::raw::{ColumnFilter, RawBlock};
use super::units::{Linear, Quantity};
use crate::scene::{Place, UtcInstant};

/// The top level of a meteoblue file. Only the keys read here are declared; serde skips the rest
/// (`data_day`, `data_xmin`, `data_current`, …).
#[derive(Debug, Deserialize)]
pub(crate) struct MeteoblueFile {
    metadata: Option<Metadata>,
    units: Option<BTreeMap<String, Option<String>>>,
    data_1h: Option<RawBlock<MeteoblueColumns>>,
    data_3h: Option<RawBlock<MeteoblueColumns>>,
}

#[derive(Debug, Deserialize)]
struct Metadata {
    name: Option<String>,
    latitude: Option<f64>,
    longitude: Option<f64>,
    /// Elevation above sea level, m.
    height: Option<f64>,
    /// The API's own spelling.
    timezone_abbrevation: Option<String>,
    /// The dictionary spelling, accepted too.
    timezone_abbreviation: Option<String>,
    /// Hours east of UTC of the local time stamps, e.g. 2.0 for CEST, 5.5 for India.
    utc_timeoffset: Option<f64>,
    modelrun_utc: Option<String>,
}

/// How one meteoblue variable is read.
struct ColumnSpec {
    target: Target,
    quantity: Quantity,
    /// The `units` category of the variable.
    unit_category: &'static str,
    /// The unit assumed when the category is absent; `None` makes it a required key.
    default_unit: Option<&'static str>,
}

const fn spec(target: Target, quantity: Quantity, unit_category: &'static str) -> ColumnSpec {
    ColumnSpec {
        target,
        quantity,
        unit_category,
        default_unit: None,
    }
}

/// The basic-1h and clouds-1h variables this crate reads, by key (format notes, "basic-1h
/// variables" and "clouds-1h variables"). `rainspot`, `felttemperature` and `uvindex` are skipped.
fn column_spec(key: &str) -> Option<ColumnSpec> {
    use Quantity as Q;
    use Variable as V;
    let series = Target::Series;
    Some(match key {
        "totalcloudcover" => spec(series(V::TotalCover), Q::CloudCover, "cloudcover"),
        "lowclouds" => spec(series(V::LowCover), Q::CloudCover, "cloudcover"),
        "midclouds" => spec(series(V::MidCover), Q::CloudCover, "cloudcover"),
        "highclouds" => spec(series(V::HighCover), Q::CloudCover, "cloudcover"),
        "precipitation" => spec(
            series(V::Precipitation),
            Q::PrecipitationAmount,
            "precipitation",
        ),
        "convective_precipitation" => spec(
            series(V::ConvectivePrecipitation),
            Q::PrecipitationAmount,
            "precipitation",
        ),
        "snowfraction" => spec(series(V::SnowFraction), Q::Fraction, ""),
        "precipitation_probability" => spec(
            series(V::PrecipitationProbability),
            Q::Percentage,
            "precipitation_probability",
        ),
        "temperature" => spec(series(V::Temperature), Q::Temperature, "temperature"),
        "relativehumidity" => spec(
            series(V::RelativeHumidity),
            Q::Percentage,
            "relativehumidity",
        ),
        "sealevelpressure" => spec(series(V::SeaLevelPressure), Q::Pressure, "pressure"),
        "windspeed" => spec(series(V::WindSpeed), Q::Speed, "windspeed"),
        "winddirection" => spec(series(V::WindDirection), Q::Direction, "winddirection"),
        "visibility" => spec(series(V::Visibility), Q::Distance, "visibility"),
        "fog_probability" => spec(series(V::FogProbability), Q::Percentage, "probability"),
        "sunshinetime" => spec(series(V::SunshineDuration), Q::Duration, "sunshinetime"),
        "pictocode" => spec(Target::Pictocode, Q::Code, ""),
        "isdaylight" => spec(Target::IsDaylight, Q::Flag, ""),
        _ => return profile_spec(key),
    })
}

/// Profile-package keys such as `windspeedprofile_850_mb`.
fn profile_spec(key: &str) -> Option<ColumnSpec> {
    let level = |prefix| level_from_key(key, prefix, "_mb");
    let target = |pressure_hpa, field| Target::Level {
        pressure_hpa,
        field,
    };
    if let Some(hpa) = level("windspeedprofile_") {
        Some(spec(
            target(hpa, LevelField::WindSpeed),
            Quantity::Speed,
            "windspeed",
        ))
    } else if let Some(hpa) = level("winddirectionprofile_") {
        Some(spec(
            target(hpa, LevelField::WindDirection),
            Quantity::Direction,
            "winddirection",
        ))
    } else if let Some(hpa) = level("cloudcoverprofile_") {
        Some(spec(
            target(hpa, LevelField::CloudCover),
            Quantity::CloudCover,
            "cloudcover",
        ))
    } else {
        // The notes give no unit category for heights; metres unless `units.height` says else.
        level("heightprofile_").map(|hpa| ColumnSpec {
            default_unit: Some("m"),
            ..spec(target(hpa, LevelField::Height), Quantity::Height, "height")
        })
    }
}

/// Keeps the block keys [`column_spec`] knows.
#[derive(Debug)]
pub(crate) struct MeteoblueColumns;

impl ColumnFilter for MeteoblueColumns {
    fn wanted(key: &str) -> bool {
        column_spec(key).is_some()
    }
}

/// The `units.time` values the API writes (plus `timeformat` variants); the stamps themselves
/// decide how each is read, this only rejects a unit we do not understand.
fn known_time_unit(unit: &str) -> bool {
    matches!(
        unit.trim().to_ascii_lowercase().as_str(),
        "yyyy-mm-dd hh:mm" | "iso8601" | "iso8601_utc" | "timestamp_utc" | "unixtime" | "utc"
    )
}

impl MeteoblueFile {
    /// Checks and converts to a [`Forecast`]; keys in errors are prefixed with `prefix`.
    pub(crate) fn into_forecast(self, prefix: &str) -> Result<Forecast, ForecastError> {
        let key = |name: &str| format!("{prefix}{name}");
        let missing = |name: &str| ForecastError::MissingKey {
            file: None,
            key: key(name),
        };

        let metadata = self.metadata.ok_or_else(|| missing("metadata"))?;
        let latitude = metadata
            .latitude
            .ok_or_else(|| missing("metadata.latitude"))?;
        let latitude = check_scalar(
            || key("metadata.latitude"),
            latitude,
            -90.0..=90.0,
            "-90 to 90",
        )?;
        let longitude = metadata
            .longitude
            .ok_or_else(|| missing("metadata.longitude"))?;
        let longitude = check_scalar(
            || key("metadata.longitude"),
            longitude,
            -180.0..=360.0,
            "-180 to 360",
        )?;
        let longitude = if longitude > 180.0 {
            longitude - 360.0
        } else {
            longitude
        };
        let offset_hours = metadata
            .utc_timeoffset
            .map(|hours| {
                check_scalar(
                    || key("metadata.utc_timeoffset"),
                    hours,
                    -18.0..=18.0,
                    "-18 to 18 h",
                )
            })
            .transpose()?;
        // Whole seconds: offsets are whole quarter hours in practice (5.75 h for Nepal).
        let offset_s = offset_hours.map(|hours| (hours * 3600.0).round() as i64);

        let units = self.units.ok_or_else(|| missing("units"))?;
        let unit = |category: &str| units.get(category).and_then(Option::as_deref);
        if let Some(time_unit) = unit("time")
            && !known_time_unit(time_unit)
        {
            return Err(ForecastError::UnknownUnit {
                file: None,
                key: key("units.time"),
                unit: time_unit.to_owned(),
            });
        }

        let (block_name, block) = match (self.data_1h, self.data_3h) {
            (Some(block), _) => ("data_1h", block),
            (None, Some(block)) => ("data_3h", block),
            (None, None) => return Err(missing("data_1h")),
        };

        let place = Place {
            name: metadata.name.unwrap_or_default(),
            latitude_deg: latitude,
            longitude_deg: longitude,
            elevation_m: metadata.height.unwrap_or(0.0),
        };
        let mut builder =
            ForecastBuilder::new(ForecastFormat::Meteoblue, place, prefix, block_name);
        builder.set_times(block.time, offset_s, "metadata.utc_timeoffset")?;

        for (name, values) in &block.columns {
            let Some(spec) = column_spec(name) else {
                continue;
            };
            let conversion = if spec.quantity.has_unit() {
                let unit_key = key(&format!("units.{}", spec.unit_category));
                let written = unit(spec.unit_category)
                    .or(spec.default_unit)
                    .ok_or_else(|| ForecastError::MissingKey {
                        file: None,
                        key: unit_key.clone(),
                    })?;
                spec.quantity
                    .conversion(written)
                    .ok_or_else(|| ForecastError::UnknownUnit {
                        file: None,
                        key: unit_key,
                        unit: written.to_owned(),
                    })?
            } else {
                Linear::IDENTITY
            };
            builder.add_column(name, values, spec.target, spec.quantity, conversion)?;
        }

        let forecast = builder.forecast_mut();
        forecast.utc_offset_s = offset_s.map_or(0, |s| s as i32);
        forecast.timezone_abbreviation = metadata
            .timezone_abbrevation
            .or(metadata.timezone_abbreviation);
        if metadata.height.is_none() {
            forecast
                .warnings
                .push(format!("{prefix}metadata.height is missing; assuming 0 m"));
        }
        if let Some(run) = metadata.modelrun_utc {
            match UtcInstant::parse_local(&run, 0) {
                Ok(instant) => forecast.model_run = Some(instant),
                Err(error) => forecast
                    .warnings
                    .push(format!("{prefix}metadata.modelrun_utc \"{run}\": {error}")),
            }
        }
        Ok(builder.finish())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn profile_keys_parse() {
        let spec = column_spec("windspeedprofile_850_mb").unwrap();
        assert_eq!(
            spec.target,
            Target::Level {
                pressure_hpa: 850,
                field: LevelField::WindSpeed
            }
        );
        assert!(
            column_spec("heightprofile_300_mb")
                .unwrap()
                .default_unit
                .is_some()
        );
        assert!(column_spec("windspeedprofile_x_mb").is_none());
        assert!(column_spec("windspeedprofile_0_mb").is_none());
        assert!(column_spec("rainspot").is_none());
        assert!(column_spec("lowclouds_mean").is_none());
    }

    #[test]
    fn time_units() {
        assert!(known_time_unit("YYYY-MM-DD hh:mm"));
        assert!(known_time_unit("ISO8601"));
        assert!(known_time_unit("timestamp_utc"));
        assert!(!known_time_unit("DD.MM.YYYY"));
    }
}
