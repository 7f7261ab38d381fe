//! The forecast inputs as the mapping reads them: cleaned values, weather-code hints, level winds.

use super::{InputFault, MappingWarning};
use crate::weather::{STANDARD_LEVELS_HPA, Variable, VariableSet, WeatherState};

pub(super) const LEVELS_LOW: &[f32] = &[850.0];
pub(super) const LEVELS_MID: &[f32] = &[700.0, 500.0];
pub(super) const LEVELS_HIGH: &[f32] = &[300.0];

/// Wind at one pressure level, placed above ground.
#[derive(Clone, Copy, Debug, PartialEq)]
pub(super) struct LevelWind {
    pub(super) pressure_hpa: f32,
    pub(super) height_m: f32,
    pub(super) velocity_m_s: [f32; 2],
}

/// What the weather code (meteoblue pictocode, else WMO code) says.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub(super) struct CodeHints {
    /// A code was present.
    pub(super) known: bool,
    pub(super) thunder: bool,
    pub(super) fog: bool,
    pub(super) showers: bool,
    pub(super) steady_precipitation: bool,
}

impl CodeHints {
    pub(super) fn from_state(state: &WeatherState) -> Self {
        if let Some(code) = state.pictocode.filter(|c| (1..=35).contains(c)) {
            // meteoblue's Packages API documentation (docs.meteoblue.com), hourly pictocodes.
            Self {
                known: true,
                thunder: matches!(code, 10..=12 | 27..=30),
                fog: matches!(code, 16..=18),
                showers: matches!(code, 31 | 32),
                steady_precipitation: matches!(code, 23..=26 | 33..=35),
            }
        } else if let Some(code) = state.wmo_weather_code.filter(|c| *c <= 99) {
            // WMO code table 4677 as Open-Meteo uses it: 45/48 fog, 51–67 drizzle and rain,
            // 71–77 snow, 80–86 showers, 95–99 thunderstorms.
            Self {
                known: true,
                thunder: matches!(code, 95..=99),
                fog: matches!(code, 45 | 48),
                showers: matches!(code, 80..=86),
                steady_precipitation: matches!(code, 51..=77),
            }
        } else {
            Self::default()
        }
    }
}

/// The state's values, cleaned: finite, in range, heights above ground.
#[derive(Clone, Copy, Debug, PartialEq)]
pub(super) struct Inputs {
    pub(super) ground_m: f32,
    pub(super) low: Option<f32>,
    pub(super) mid: Option<f32>,
    pub(super) high: Option<f32>,
    pub(super) precipitation: Option<f32>,
    pub(super) convective: Option<f32>,
    pub(super) fog_probability: Option<f32>,
    pub(super) visibility: Option<f32>,
    pub(super) surface_wind: Option<[f32; 2]>,
    pub(super) levels: [Option<LevelWind>; STANDARD_LEVELS_HPA.len()],
    pub(super) convective_base_m: Option<f32>,
    pub(super) convective_top_m: Option<f32>,
    /// Lightning potential index, J/kg.
    pub(super) lightning_potential: Option<f32>,
    pub(super) codes: CodeHints,
}

pub(super) struct Reader<'a> {
    pub(super) state: &'a WeatherState,
    pub(super) not_finite: VariableSet,
    pub(super) warnings: Vec<MappingWarning>,
}

impl Reader<'_> {
    pub(super) fn read(&mut self, variable: Variable) -> Option<f32> {
        let value = self.state.get(variable)?;
        if value.is_finite() {
            Some(value)
        } else {
            self.not_finite.insert(variable);
            None
        }
    }

    /// Reports that what `variable` drives keeps its previous value.
    pub(super) fn held(&mut self, variable: Variable, consequence: &'static str) {
        let fault = if self.not_finite.contains(variable) {
            InputFault::NotFinite
        } else {
            InputFault::NoValue
        };
        // Reported here, so not again in the generic not-finite pass.
        let mut remaining = VariableSet::EMPTY;
        for other in self.not_finite.iter().filter(|&v| v != variable) {
            remaining.insert(other);
        }
        self.not_finite = remaining;
        self.warnings.push(MappingWarning {
            input: variable.name(),
            fault,
            consequence,
        });
    }
}

/// `[east, north]` velocity, m/s, of a wind of `speed` blowing FROM `from_deg` (clockwise from
/// north), the same convention as [`WeatherState::wind_velocity_m_s`].
pub(super) fn velocity(speed: f32, from_deg: f32) -> [f32; 2] {
    let from = from_deg.to_radians();
    [-speed * from.sin(), -speed * from.cos()]
}

pub(super) fn saturate(x: f32) -> f32 {
    if x.is_nan() { 0.0 } else { x.clamp(0.0, 1.0) }
}
