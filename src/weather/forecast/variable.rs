//! [`Variable`]: the continuous forecast variables, their names and units.

/// The continuous forecast variables, each stored as a [`Series`] in [`Forecast::series`] and
/// sampled into [`WeatherState::values`](crate::weather::WeatherState::values) (index with
/// `variable as usize` or use the accessors).
///
/// Units are SI-like and the same for both formats. Amounts that a file gives "over the preceding
/// step" (precipitation, sunshine) stay amounts in a [`Forecast`] and become rates when sampled;
/// [`Variable::unit`] and [`Variable::sampled_unit`] say which.
///
/// [`Series`]: super::Series
/// [`Forecast::series`]: super::Forecast::series
/// [`Forecast`]: super::Forecast
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
    ///
    /// [`Forecast`]: super::Forecast
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
    ///
    /// [`Forecast`]: super::Forecast
    SunshineDuration,
    /// Base of convective cloud above sea level, m (Open-Meteo `convective_cloud_base`).
    ConvectiveCloudBase,
    /// Top of convective cloud above sea level, m (Open-Meteo `convective_cloud_top`).
    ConvectiveCloudTop,
    /// Lightning potential index, J/kg (Open-Meteo `lightning_potential`, from the ICON
    /// models): the potential for charge separation in a convective cloud (Yair et al. 2010,
    /// "Predicting the potential for lightning activity in Mediterranean storms based on the
    /// Weather Research and Forecasting (WRF) model dynamic and microphysical fields"), 0 where
    /// no lightning is expected.
    LightningPotential,
}

impl Variable {
    /// Number of variables.
    pub const COUNT: usize = 19;

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
        Self::LightningPotential,
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
            Self::LightningPotential => "lightning_potential",
        }
    }

    /// The unit of this variable inside a [`Forecast`].
    ///
    /// [`Forecast`]: super::Forecast
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
            Self::LightningPotential => "J/kg",
        }
    }

    /// The unit of this variable in a sampled [`WeatherState`](crate::weather::WeatherState).
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
