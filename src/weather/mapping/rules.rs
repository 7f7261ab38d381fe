//! [`WeatherMapping`]: the tunable rules, and [`WeatherMapping::map`], which digests a state.

use bevy::prelude::*;

use super::inputs::{CodeHints, Inputs, LevelWind, Reader, velocity};
use super::{CloudBands, InputFault, MappedWeather, MappingWarning, STANDARD_LEVEL_HEIGHTS_M};
use crate::weather::{ForecastFormat, STANDARD_LEVELS_HPA, Variable, VariableSet, WeatherState};

/// Tunable rules of the weather → layers mapping. The [module docs](super) give the table; every
/// threshold there is a field here. `Default` is [`WeatherMapping::METEOBLUE`].
///
/// As a resource it configures the crate's mapping system; without one the system uses
/// [`WeatherMapping::for_format`] of the near forecast.
#[derive(Clone, Copy, Debug, PartialEq, Resource)]
pub struct WeatherMapping {
    /// Altitude bands of the low, mid and high slots. Default [`CloudBands::METEOBLUE`].
    pub bands: CloudBands,
    /// Top of the fog layer, metres above ground (its base is the ground). Default 150 m: the
    /// depth of a typical radiation fog, and the base of the default stratus.
    pub fog_top_m: f32,
    /// Fog probability (0–1) below which it adds no fog; above it, coverage rises linearly to 1
    /// at probability 1. Default 0.2.
    pub fog_probability_floor: f32,
    /// Visibility, metres, at and below which the air is fog: the fog layer's coverage from
    /// visibility reaches 1, and its density stops growing. Default 1 000 m (WMO definition of
    /// fog).
    pub fog_visibility_m: f32,
    /// Visibility, metres, at and above which visibility adds no fog. Default 5 000 m (the upper
    /// limit of mist).
    pub mist_visibility_m: f32,
    /// Fog coverage when the weather code says fog (pictocodes 16–18, WMO 45 and 48).
    /// Default 0.8.
    pub fog_code_coverage: f32,
    /// Visibility, metres, assumed inside the fog when the forecast has none; it sets the fog
    /// density. Default 200 m (moderate fog).
    pub fog_default_visibility_m: f32,
    /// Precipitation rate, mm/h, at which the darkening `1 − e^(−rate / scale)` reaches
    /// `1 − 1/e ≈ 0.63`. Default 2.5 mm/h (the upper end of "light rain", AMS Glossary).
    pub darkening_scale_mm_per_h: f32,
    /// Precipitation rate, mm/h, above which precipitation counts as falling when choosing
    /// kinds. Default 0.1 mm/h (the usual threshold for a measurable amount).
    pub precipitation_threshold_mm_per_h: f32,
    /// Convective precipitation rate, mm/h, at and above which the low layer is cumulus.
    /// Default 0.1 mm/h.
    pub shower_threshold_mm_per_h: f32,
    /// Convective precipitation rate, mm/h, at and above which a cumulonimbus layer appears.
    /// Default 1 mm/h: an hourly grid-mean shower rate this high means intense local cells.
    pub thunderstorm_threshold_mm_per_h: f32,
    /// Lightning potential index, J/kg, at and above which a cumulonimbus layer appears (Open-Meteo
    /// `lightning_potential`, where the forecast has it). Default 1 J/kg: a clearly positive
    /// index, above the small values a model's grid leaves around a cell. The index is the
    /// potential for charge separation, not a flash rate, so it decides only whether the storm
    /// is there.
    pub lightning_potential_threshold_j_per_kg: f32,
    /// Convective precipitation rate, mm/h, that brings the cumulonimbus coverage 63 % of the
    /// way from its minimum to its maximum. Default 5 mm/h.
    pub thunderstorm_scale_mm_per_h: f32,
    /// Cumulonimbus coverage when the layer just appears (0–1). Default 0.15: isolated cells.
    pub cumulonimbus_min_coverage: f32,
    /// Cumulonimbus coverage at most (0–1). Default 0.6: a squall line; storms are never one
    /// unbroken deck.
    pub cumulonimbus_max_coverage: f32,
    /// Low cover at and above which a non-convective low layer is stratocumulus rather than
    /// cumulus. Default 0.6 (broken to overcast).
    pub stratocumulus_cover: f32,
    /// Low cover at and above which, with precipitation, the low layer is stratus (nimbostratus
    /// substitute). Default 0.9.
    pub stratus_cover: f32,
    /// Mid cover at and above which the mid layer is altostratus. Default 0.7.
    pub altostratus_cover: f32,
    /// High cover at and above which the high layer is cirrostratus. Default 0.7.
    pub cirrostratus_cover: f32,
    /// Exponent α of the wind power law `v(z) = v₁₀ · (z / 10 m)^α`. Default 1/7 (neutral
    /// stability; Peterson & Hennessey 1978).
    pub wind_shear_exponent: f32,
    /// Deepest cumulus, metres, when the forecast gives convective cloud base and top. Default
    /// 3 000 m (a towering cumulus; deeper is cumulonimbus).
    pub max_cumulus_depth_m: f32,
    /// How far, metres, a raining altostratus layer grows down at full darkening. Default
    /// 1 000 m. Thomann 2021 §4.2.6 imitates nimbostratus by darkening altostratus "as well making
    /// them thicker".
    pub nimbostratus_thickening_m: f32,
}

impl Default for WeatherMapping {
    fn default() -> Self {
        Self::METEOBLUE
    }
}

impl WeatherMapping {
    /// The defaults documented on each field, with meteoblue's altitude bands.
    pub const METEOBLUE: Self = Self {
        bands: CloudBands::METEOBLUE,
        fog_top_m: 150.0,
        fog_probability_floor: 0.2,
        fog_visibility_m: 1_000.0,
        mist_visibility_m: 5_000.0,
        fog_code_coverage: 0.8,
        fog_default_visibility_m: 200.0,
        darkening_scale_mm_per_h: 2.5,
        precipitation_threshold_mm_per_h: 0.1,
        shower_threshold_mm_per_h: 0.1,
        thunderstorm_threshold_mm_per_h: 1.0,
        lightning_potential_threshold_j_per_kg: 1.0,
        thunderstorm_scale_mm_per_h: 5.0,
        cumulonimbus_min_coverage: 0.15,
        cumulonimbus_max_coverage: 0.6,
        stratocumulus_cover: 0.6,
        stratus_cover: 0.9,
        altostratus_cover: 0.7,
        cirrostratus_cover: 0.7,
        wind_shear_exponent: 1.0 / 7.0,
        max_cumulus_depth_m: 3_000.0,
        nimbostratus_thickening_m: 1_000.0,
    };

    /// [`WeatherMapping::METEOBLUE`] with Open-Meteo's altitude bands.
    pub const OPEN_METEO: Self = Self {
        bands: CloudBands::OPEN_METEO,
        ..Self::METEOBLUE
    };

    /// The mapping for a forecast's format ([`Forecast::format`](crate::weather::Forecast::format)):
    /// Open-Meteo's bands for Open-Meteo files, meteoblue's otherwise.
    #[must_use]
    pub const fn for_format(format: Option<ForecastFormat>) -> Self {
        match format {
            Some(ForecastFormat::OpenMeteo) => Self::OPEN_METEO,
            Some(ForecastFormat::Meteoblue) | None => Self::METEOBLUE,
        }
    }

    /// Darkening (0–1) for a precipitation rate in mm/h: `1 − e^(−rate / scale)` with
    /// [`WeatherMapping::darkening_scale_mm_per_h`]. It is 0 for no (or negative or NaN) rain,
    /// rises strictly with the rate and saturates toward 1. With the default 2.5 mm/h scale,
    /// 1 mm/h gives 0.33, 2.5 mm/h 0.63 and 7.6 mm/h (the start of heavy rain) 0.95.
    #[must_use]
    pub fn precipitation_darkening(&self, rate_mm_per_h: f32) -> f32 {
        if rate_mm_per_h.is_nan() || rate_mm_per_h <= 0.0 {
            return 0.0;
        }
        let scale = self.darkening_scale_mm_per_h;
        if scale.is_finite() && scale > 0.0 {
            (-(-rate_mm_per_h / scale).exp_m1()).clamp(0.0, 1.0)
        } else {
            1.0
        }
    }

    /// Digests `state` into a [`MappedWeather`] that can write layers. `ground_elevation_m` is
    /// the scene's ground above sea level, in metres; it is subtracted from heights the forecast
    /// gives above sea level. A non-finite ground elevation is taken as 0 m, with a warning.
    #[must_use]
    pub fn map(&self, state: &WeatherState, ground_elevation_m: f32) -> MappedWeather {
        let mut reader = Reader {
            state,
            not_finite: VariableSet::EMPTY,
            warnings: Vec::new(),
        };
        let ground_m = if ground_elevation_m.is_finite() {
            ground_elevation_m
        } else {
            reader.warnings.push(MappingWarning {
                input: "ground_elevation_m",
                fault: InputFault::NotFinite,
                consequence: "0 m is used",
            });
            0.0
        };
        let unit = |v: f32| v.clamp(0.0, 1.0);
        let rate = |v: f32| v.max(0.0);
        let low = reader.read(Variable::LowCover).map(unit);
        let mid = reader.read(Variable::MidCover).map(unit);
        let high = reader.read(Variable::HighCover).map(unit);
        let precipitation = reader.read(Variable::Precipitation).map(rate);
        let mut convective = reader.read(Variable::ConvectivePrecipitation).map(rate);
        if let (Some(c), Some(p)) = (convective.as_mut(), precipitation) {
            // Part of the total: a larger convective value is a rounding or model artefact.
            *c = c.min(p);
        }
        let fog_probability = reader.read(Variable::FogProbability).map(unit);
        let visibility = reader.read(Variable::Visibility).map(|v| v.max(0.0));
        let wind_speed = reader.read(Variable::WindSpeed);
        let wind_direction = reader.read(Variable::WindDirection);
        let surface_wind = match (wind_speed, wind_direction) {
            (Some(speed), Some(from_deg)) => Some(velocity(speed.max(0.0), from_deg)),
            _ => None,
        };
        let above_ground = |v: f32| v - ground_m;
        let convective_base_m = reader.read(Variable::ConvectiveCloudBase).map(above_ground);
        let convective_top_m = reader.read(Variable::ConvectiveCloudTop).map(above_ground);
        let lightning_potential = reader.read(Variable::LightningPotential).map(rate);

        let mut levels = [None; STANDARD_LEVELS_HPA.len()];
        let mut level_not_finite = false;
        for ((slot, pressure), standard_height) in levels
            .iter_mut()
            .zip(STANDARD_LEVELS_HPA)
            .zip(STANDARD_LEVEL_HEIGHTS_M)
        {
            let Some(level) = state.level(pressure) else {
                continue;
            };
            let (Some(speed), Some(from_deg)) = (level.wind_speed_m_s, level.wind_direction_deg)
            else {
                continue;
            };
            if !(speed.is_finite() && from_deg.is_finite()) {
                level_not_finite = true;
                continue;
            }
            let height_asl_m = match level.height_m {
                Some(h) if h.is_finite() => h,
                _ => standard_height,
            };
            let height_m = height_asl_m - ground_m;
            // A level below the ground (a mountain site) says nothing about the air above it.
            if height_m >= 0.0 {
                *slot = Some(LevelWind {
                    pressure_hpa: pressure,
                    height_m,
                    velocity_m_s: velocity(speed.max(0.0), from_deg),
                });
            }
        }
        if level_not_finite {
            reader.warnings.push(MappingWarning {
                input: "pressure-level wind",
                fault: InputFault::NotFinite,
                consequence: "that level is ignored",
            });
        }

        let codes = CodeHints::from_state(state);
        let inputs = Inputs {
            ground_m,
            low,
            mid,
            high,
            precipitation,
            convective,
            fog_probability,
            visibility,
            surface_wind,
            levels,
            convective_base_m,
            convective_top_m,
            lightning_potential,
            codes,
        };

        // Everything held for lack of a value is reported once, naming the input.
        if low.is_none() {
            reader.held(
                Variable::LowCover,
                "the low layer keeps its previous coverage (and kind, unless a weather code decides it)",
            );
        }
        if mid.is_none() {
            reader.held(
                Variable::MidCover,
                "the mid layer keeps its previous coverage and kind",
            );
        }
        if high.is_none() {
            reader.held(
                Variable::HighCover,
                "the high layer keeps its previous coverage and kind",
            );
        }
        if precipitation.is_none() {
            reader.held(
                Variable::Precipitation,
                "layers keep their previous darkening and rain",
            );
        }
        if self.thunderstorm(&inputs).is_none() {
            reader.held(
                Variable::ConvectivePrecipitation,
                "no weather code either: the cumulonimbus layer keeps its previous coverage",
            );
        }
        if fog_probability.is_none() && visibility.is_none() && !codes.known {
            reader.held(
                Variable::FogProbability,
                "no visibility or weather code either: the fog layer keeps its previous coverage",
            );
        }
        // The fog layer always follows the surface wind, so without it something is held.
        if surface_wind.is_none() {
            let variable = if wind_speed.is_none() {
                Variable::WindSpeed
            } else {
                Variable::WindDirection
            };
            reader.held(
                variable,
                "the fog layer, and layers without pressure-level wind, keep their previous wind",
            );
        }
        for variable in reader.not_finite.iter() {
            reader.warnings.push(MappingWarning {
                input: variable.name(),
                fault: InputFault::NotFinite,
                consequence: "ignored; the mapping uses the other inputs",
            });
        }

        MappedWeather {
            mapping: *self,
            inputs,
            warnings: reader.warnings,
        }
    }

    /// Whether a cumulonimbus layer is present: `Some(true)` on a thunder code or heavy
    /// convective precipitation, `Some(false)` when either says no, `None` when nothing says.
    pub(super) fn thunderstorm(&self, inputs: &Inputs) -> Option<bool> {
        if inputs.codes.thunder
            || inputs
                .lightning_potential
                .is_some_and(|lpi| lpi >= self.lightning_potential_threshold_j_per_kg)
        {
            return Some(true);
        }
        match inputs.convective {
            Some(rate) => Some(rate >= self.thunderstorm_threshold_mm_per_h),
            None => inputs.codes.known.then_some(false),
        }
    }
}
