//! [`WeatherState`]: a forecast sampled at one instant, with its levels and variable sets.

use std::fmt;

use super::STANDARD_LEVELS_HPA;
use crate::scene::UtcInstant;
use crate::weather::forecast::Variable;

/// Which end of the data an instant was clamped to.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum DataEdge {
    /// Before the first time step: the first values are used.
    Start,
    /// After the last time step: the last values are used.
    End,
}

/// A small set of [`Variable`]s (a bit set; `Copy`, no allocation).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Hash)]
pub struct VariableSet(u32);

impl VariableSet {
    /// The empty set.
    pub const EMPTY: Self = Self(0);

    /// Adds `variable`.
    pub fn insert(&mut self, variable: Variable) {
        self.0 |= 1 << variable as u32;
    }

    /// Whether `variable` is in the set.
    #[must_use]
    pub const fn contains(self, variable: Variable) -> bool {
        self.0 & (1 << variable as u32) != 0
    }

    /// Whether the set is empty.
    #[must_use]
    pub const fn is_empty(self) -> bool {
        self.0 == 0
    }

    /// Number of variables in the set.
    #[must_use]
    pub const fn len(self) -> usize {
        self.0.count_ones() as usize
    }

    /// The variables in the set, in [`Variable::ALL`] order.
    pub fn iter(self) -> impl Iterator<Item = Variable> {
        Variable::ALL.into_iter().filter(move |&v| self.contains(v))
    }
}

impl fmt::Display for VariableSet {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        for (i, variable) in self.iter().enumerate() {
            if i > 0 {
                f.write_str(", ")?;
            }
            f.write_str(variable.name())?;
        }
        Ok(())
    }
}

/// Variables at one pressure level, sampled at an instant.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct LevelState {
    /// The level's pressure, hPa.
    pub pressure_hpa: f32,
    /// Wind speed, m/s.
    pub wind_speed_m_s: Option<f32>,
    /// Direction the wind blows from, degrees clockwise from north.
    pub wind_direction_deg: Option<f32>,
    /// Geopotential height above sea level, m.
    pub height_m: Option<f32>,
    /// Cloud cover, fraction 0–1.
    pub cloud_cover: Option<f32>,
}

/// A [`Forecast`] sampled at one instant. `Copy`, so sampling never allocates.
///
/// [`Forecast`]: crate::weather::Forecast
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct WeatherState {
    /// The instant asked for (not clamped).
    pub time: UtcInstant,
    /// `Some` when [`WeatherState::time`] lies outside the data and the values are those of that
    /// end.
    pub clamped: Option<DataEdge>,
    /// Each [`Variable`] at this instant (index with `variable as usize`, or use [`Self::get`]),
    /// in [`Variable::sampled_unit`]: precipitation as mm/h, sunshine as a fraction of the time.
    /// `None` when the forecast lacks the variable or the value is in a long gap.
    pub values: [Option<f32>; Variable::COUNT],
    /// Variables whose value here was interpolated across `null` entries.
    pub bridged: VariableSet,
    /// Variables the forecast has but which have no value here (a gap longer than
    /// [`Sampler::max_bridge_s`], or `null` at the clamped end).
    ///
    /// [`Sampler::max_bridge_s`]: super::Sampler::max_bridge_s
    pub missing: VariableSet,
    /// meteoblue pictocode of the nearest time step.
    pub pictocode: Option<u8>,
    /// WMO weather code of the nearest time step (Open-Meteo).
    pub wmo_weather_code: Option<u8>,
    /// Daylight flag of the nearest time step.
    pub is_daylight: Option<bool>,
    /// Wind, height and cover at [`STANDARD_LEVELS_HPA`], where the forecast has those levels.
    pub upper_air: [Option<LevelState>; STANDARD_LEVELS_HPA.len()],
}

impl WeatherState {
    /// A state with no values at `time`.
    #[must_use]
    pub const fn empty(time: UtcInstant) -> Self {
        Self {
            time,
            clamped: None,
            values: [None; Variable::COUNT],
            bridged: VariableSet::EMPTY,
            missing: VariableSet::EMPTY,
            pictocode: None,
            wmo_weather_code: None,
            is_daylight: None,
            upper_air: [None; STANDARD_LEVELS_HPA.len()],
        }
    }

    /// The value of `variable`, in [`Variable::sampled_unit`].
    #[must_use]
    pub const fn get(&self, variable: Variable) -> Option<f32> {
        self.values[variable as usize]
    }

    /// Total cloud cover, fraction 0–1.
    #[must_use]
    pub const fn total_cover(&self) -> Option<f32> {
        self.get(Variable::TotalCover)
    }

    /// Low cloud cover, fraction 0–1.
    #[must_use]
    pub const fn low_cover(&self) -> Option<f32> {
        self.get(Variable::LowCover)
    }

    /// Mid-level cloud cover, fraction 0–1.
    #[must_use]
    pub const fn mid_cover(&self) -> Option<f32> {
        self.get(Variable::MidCover)
    }

    /// High cloud cover, fraction 0–1.
    #[must_use]
    pub const fn high_cover(&self) -> Option<f32> {
        self.get(Variable::HighCover)
    }

    /// Precipitation rate, mm/h.
    #[must_use]
    pub const fn precipitation_mm_per_h(&self) -> Option<f32> {
        self.get(Variable::Precipitation)
    }

    /// Convective (shower) precipitation rate, mm/h.
    #[must_use]
    pub const fn convective_precipitation_mm_per_h(&self) -> Option<f32> {
        self.get(Variable::ConvectivePrecipitation)
    }

    /// Wind speed at 10 m, m/s.
    #[must_use]
    pub const fn wind_speed_m_s(&self) -> Option<f32> {
        self.get(Variable::WindSpeed)
    }

    /// Direction the 10 m wind blows from, degrees clockwise from north, [0, 360).
    #[must_use]
    pub const fn wind_direction_deg(&self) -> Option<f32> {
        self.get(Variable::WindDirection)
    }

    /// The 10 m wind as a velocity `[east, north]` in m/s: where the air moves TO (opposite to the
    /// meteorological "from" direction).
    #[must_use]
    pub fn wind_velocity_m_s(&self) -> Option<[f32; 2]> {
        let speed = self.wind_speed_m_s()?;
        let from = self.wind_direction_deg()?.to_radians();
        Some([-speed * from.sin(), -speed * from.cos()])
    }

    /// Air temperature at 2 m, °C.
    #[must_use]
    pub const fn temperature_c(&self) -> Option<f32> {
        self.get(Variable::Temperature)
    }

    /// Visibility, m.
    #[must_use]
    pub const fn visibility_m(&self) -> Option<f32> {
        self.get(Variable::Visibility)
    }

    /// Fog probability, fraction 0–1.
    #[must_use]
    pub const fn fog_probability(&self) -> Option<f32> {
        self.get(Variable::FogProbability)
    }

    /// The sampled pressure level at `pressure_hpa` (one of [`STANDARD_LEVELS_HPA`]).
    #[must_use]
    pub fn level(&self, pressure_hpa: f32) -> Option<&LevelState> {
        self.upper_air
            .iter()
            .flatten()
            .find(|level| (level.pressure_hpa - pressure_hpa).abs() < 0.5)
    }
}
