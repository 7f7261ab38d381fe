//! Unit strings of the two formats, their conversion to SI, and the physical range of each kind
//! of quantity.
//!
//! meteoblue keys units by category (`units.windspeed` covers every wind speed), Open-Meteo per
//! variable (`hourly_units.wind_speed_10m`); both lists are in
//! meteoblue's Packages API documentation (docs.meteoblue.com) and Open-Meteo's forecast API documentation (open-meteo.com/en/docs). Every conversion
//! here is linear (`si = value * scale + offset`), which covers °F → °C too.

/// What kind of quantity a forecast column holds: decides the unit conversion and the range check.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(crate) enum Quantity {
    /// Cloud cover in percent → fraction 0–1. Negative/NaN and above-100 values are errors of
    /// their own kinds.
    CloudCover,
    /// A probability or relative humidity in percent → fraction 0–1.
    Percentage,
    /// A plain fraction 0–1 (meteoblue `snowfraction`), no unit.
    Fraction,
    /// Wind speed → m/s, ≥ 0.
    Speed,
    /// Direction the wind comes from → degrees clockwise from north, wrapped to [0, 360).
    Direction,
    /// Air temperature → °C, above absolute zero.
    Temperature,
    /// Precipitation amount → mm of water, ≥ 0.
    PrecipitationAmount,
    /// Fresh snow depth → mm of water equivalent (Open-Meteo `snowfall`, 7 cm snow ≈ 10 mm
    /// water), ≥ 0.
    SnowDepth,
    /// Pressure → Pa, > 0.
    Pressure,
    /// A distance that cannot be negative (visibility, cloud base) → m.
    Distance,
    /// A height that may be negative (geopotential height below sea level) → m.
    Height,
    /// A duration (sunshine time) → s, ≥ 0.
    Duration,
    /// An integer code 0–255 (meteoblue pictocode, WMO weather code), no unit.
    Code,
    /// A 0/1 flag (day or night), no unit.
    Flag,
    /// Energy per mass (the lightning potential index) → J/kg, ≥ 0.
    SpecificEnergy,
}

/// `si = value * scale + offset`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub(crate) struct Linear {
    pub scale: f64,
    pub offset: f64,
}

impl Linear {
    pub const IDENTITY: Self = Self::scale(1.0);

    const fn scale(scale: f64) -> Self {
        Self { scale, offset: 0.0 }
    }

    pub fn apply(self, value: f64) -> f64 {
        value.mul_add(self.scale, self.offset)
    }
}

/// Knots to m/s: one nautical mile (1852 m) per hour.
const KNOT_M_S: f64 = 1852.0 / 3600.0;
/// Miles per hour to m/s: one international mile is 1609.344 m.
const MPH_M_S: f64 = 1609.344 / 3600.0;
/// One inch in millimetres.
const INCH_MM: f64 = 25.4;
/// One foot in metres.
const FOOT_M: f64 = 0.3048;
/// One inch of mercury in pascals (at 0 °C, standard gravity).
const INHG_PA: f64 = 3386.389;
/// Fresh snow depth to water equivalent: Open-Meteo documents `snowfall` in cm with "7 cm of snow
/// = 10 mm of precipitation water equivalent".
const SNOW_DEPTH_TO_WATER: f64 = 10.0 / 7.0;

impl Quantity {
    /// Whether files give this quantity a unit at all.
    pub fn has_unit(self) -> bool {
        !matches!(self, Self::Fraction | Self::Code | Self::Flag)
    }

    /// The conversion from `unit` (as either format writes it) to this crate's unit, or `None`
    /// for a unit we do not know.
    pub fn conversion(self, unit: &str) -> Option<Linear> {
        let unit = unit.trim();
        let linear = match self {
            Self::Fraction | Self::Code | Self::Flag => Linear::IDENTITY,
            Self::CloudCover | Self::Percentage => match unit {
                "percent" | "%" => Linear::scale(0.01),
                _ => return None,
            },
            Self::Speed => match unit {
                "ms-1" | "m/s" | "m s-1" | "ms" => Linear::IDENTITY,
                "kmh" | "km/h" | "kmh-1" => Linear::scale(1.0 / 3.6),
                "mph" | "mp/h" => Linear::scale(MPH_M_S),
                "kn" | "kt" | "knots" | "knot" => Linear::scale(KNOT_M_S),
                _ => return None,
            },
            Self::Direction => match unit {
                "degree" | "degrees" | "deg" | "°" => Linear::IDENTITY,
                _ => return None,
            },
            Self::Temperature => match unit {
                "C" | "°C" | "celsius" => Linear::IDENTITY,
                "F" | "°F" | "fahrenheit" => Linear {
                    scale: 5.0 / 9.0,
                    offset: -32.0 * 5.0 / 9.0,
                },
                "K" | "kelvin" => Linear {
                    scale: 1.0,
                    offset: -273.15,
                },
                _ => return None,
            },
            Self::PrecipitationAmount => match unit {
                "mm" => Linear::IDENTITY,
                "inch" | "in" | "inches" => Linear::scale(INCH_MM),
                _ => return None,
            },
            Self::SnowDepth => match unit {
                "cm" => Linear::scale(SNOW_DEPTH_TO_WATER),
                "mm" => Linear::scale(SNOW_DEPTH_TO_WATER / 10.0),
                "inch" | "in" | "inches" => Linear::scale(INCH_MM / 7.0),
                _ => return None,
            },
            Self::Pressure => match unit {
                "hPa" | "hpa" | "mbar" | "mb" => Linear::scale(100.0),
                "Pa" => Linear::IDENTITY,
                "kPa" => Linear::scale(1000.0),
                "inHg" => Linear::scale(INHG_PA),
                _ => return None,
            },
            Self::Distance | Self::Height => match unit {
                "m" | "meter" | "metre" | "meters" | "metres" => Linear::IDENTITY,
                "km" => Linear::scale(1000.0),
                "ft" | "feet" => Linear::scale(FOOT_M),
                "mi" | "mile" | "miles" => Linear::scale(1609.344),
                _ => return None,
            },
            Self::SpecificEnergy => match unit {
                "J/kg" | "J kg-1" | "Jkg-1" => Linear::IDENTITY,
                _ => return None,
            },
            Self::Duration => match unit {
                "s" | "seconds" | "second" => Linear::IDENTITY,
                "minutes" | "minute" | "min" => Linear::scale(60.0),
                "h" | "hours" | "hour" => Linear::scale(3600.0),
                _ => return None,
            },
        };
        Some(linear)
    }

    /// The allowed range of a value as written in the file, for [`ForecastError::OutOfRange`];
    /// `None` when `raw` (in file units) converted to `si` is acceptable.
    ///
    /// Cloud cover is checked separately because it has error variants of its own.
    ///
    /// [`ForecastError::OutOfRange`]: super::ForecastError::OutOfRange
    pub fn range_violation(self, raw: f64, si: f64) -> Option<&'static str> {
        if !raw.is_finite() || !si.is_finite() {
            return Some("a finite number");
        }
        match self {
            Self::CloudCover | Self::Direction | Self::Height => None,
            Self::Percentage => (!(0.0..=100.0).contains(&raw)).then_some("0 to 100 %"),
            Self::Fraction => (!(0.0..=1.0).contains(&raw)).then_some("0 to 1"),
            Self::Speed
            | Self::PrecipitationAmount
            | Self::SnowDepth
            | Self::Distance
            | Self::Duration
            | Self::SpecificEnergy => (raw < 0.0).then_some("≥ 0"),
            Self::Temperature => (si < -273.15).then_some("above absolute zero"),
            Self::Pressure => (raw <= 0.0).then_some("> 0"),
            Self::Code => (raw.fract() != 0.0 || !(0.0..=255.0).contains(&raw))
                .then_some("an integer code 0 to 255"),
            Self::Flag => (raw != 0.0 && raw != 1.0).then_some("0 or 1"),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn convert(quantity: Quantity, unit: &str, value: f64) -> f64 {
        quantity.conversion(unit).unwrap().apply(value)
    }

    #[test]
    fn converts_every_documented_unit() {
        let close = |a: f64, b: f64| (a - b).abs() < 1e-9;
        assert!(close(convert(Quantity::Speed, "ms-1", 3.5), 3.5));
        assert!(close(convert(Quantity::Speed, "kmh", 36.0), 10.0));
        assert!(close(convert(Quantity::Speed, "km/h", 36.0), 10.0));
        assert!(close(convert(Quantity::Speed, "mph", 10.0), 4.4704));
        assert!(close(convert(Quantity::Speed, "mp/h", 10.0), 4.4704));
        assert!(close(
            convert(Quantity::Speed, "kn", 10.0),
            5.144_444_444_444_445
        ));
        assert!(close(convert(Quantity::Temperature, "C", 11.0), 11.0));
        assert!(close(convert(Quantity::Temperature, "F", 212.0), 100.0));
        assert!(close(convert(Quantity::Temperature, "°F", 32.0), 0.0));
        assert!(close(
            convert(Quantity::PrecipitationAmount, "inch", 1.0),
            25.4
        ));
        assert!(close(
            convert(Quantity::Pressure, "hPa", 1013.25),
            101_325.0
        ));
        assert!(close(convert(Quantity::CloudCover, "percent", 40.0), 0.4));
        assert!(close(convert(Quantity::CloudCover, "%", 75.0), 0.75));
        assert!(close(convert(Quantity::Duration, "minutes", 30.0), 1800.0));
        assert!(close(convert(Quantity::Distance, "ft", 1000.0), 304.8));
        assert!(close(convert(Quantity::SnowDepth, "cm", 7.0), 10.0));
        assert_eq!(Quantity::Speed.conversion("bft"), None);
        assert_eq!(Quantity::CloudCover.conversion("octa"), None);
    }

    #[test]
    fn range_checks() {
        assert_eq!(Quantity::Speed.range_violation(-1.0, -1.0), Some("≥ 0"));
        assert_eq!(Quantity::Speed.range_violation(0.0, 0.0), None);
        assert_eq!(
            Quantity::Percentage.range_violation(101.0, 1.01),
            Some("0 to 100 %")
        );
        assert_eq!(
            Quantity::Code.range_violation(3.5, 3.5),
            Some("an integer code 0 to 255")
        );
        assert_eq!(Quantity::Flag.range_violation(2.0, 2.0), Some("0 or 1"));
        assert_eq!(
            Quantity::Temperature.range_violation(-300.0, -300.0),
            Some("above absolute zero")
        );
        assert_eq!(Quantity::Direction.range_violation(-10.0, -10.0), None);
        assert_eq!(
            Quantity::Height.range_violation(f64::NAN, f64::NAN),
            Some("a finite number")
        );
    }
}
