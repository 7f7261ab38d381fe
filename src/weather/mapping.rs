//! From a sampled forecast ([`WeatherState`]) to cloud layers ([`CloudLayer`]).
//!
//! The mapping fills five named [`LayerSlot`]s, following the layer structure of Thomann 2021 §4.2.
//! A high layer holds the cirrus family, a mid layer altostratus or altocumulus, and a low layer
//! cumulus, stratocumulus or stratus. Ground fog gets its own layer. A cumulonimbus layer spans
//! the others. Nimbostratus is not a kind of its own; as Thomann 2021 §4.2.6 proposes, it is imitated
//! by darkened, thickened altostratus over darkened stratus.
//!
//! [`WeatherMapping::map`] digests a state once into a [`MappedWeather`].
//! [`MappedWeather::apply`] then writes any layer given its slot, so a game can keep one entity
//! per slot (or several, or none). A layer whose [`CloudLayer::weather_driven`] is false is left
//! untouched, and its values are the user's ("play" mode). [`map_weather`] and
//! [`layers_for_weather`] are one-call shortcuts.
//!
//! # The mapping table
//!
//! Thresholds are [`WeatherMapping`]'s defaults; every one is a field you can change.
//! [`MAPPING_TABLE`] holds the same rows as data.
//!
//! | forecast input | drives | rule | why |
//! |---|---|---|---|
//! | `lowclouds` (`low_cover`) | Low: coverage, kind; Convective: coverage | coverage = cover. Kind: stratus when the weather code says fog (16–18) or steady precipitation (23–26, 33–35), or when cover ≥ 0.9 with precipitation ≥ 0.1 mm/h; otherwise cumulus when the code says showers or thunder, or convective precipitation ≥ 0.1 mm/h; otherwise stratocumulus when cover ≥ 0.6, else cumulus | the meteoblue low band is surface–2 km; broken convective cloud is cumulus, a closed deck stratocumulus, a raining closed deck stratus (Thomann 2021 §3.3.7–3.3.9) |
//! | `midclouds` (`mid_cover`) | Mid: coverage, kind | coverage = cover; altostratus when cover ≥ 0.7, or ≥ 0.5 with precipitation, else altocumulus | altostratus "usually cover the whole sky" and precede rain; altocumulus are patches (Thomann 2021 §3.3.4–3.3.5) |
//! | `highclouds` (`high_cover`) | High: coverage, kind | coverage = cover; cirrostratus when cover ≥ 0.7, else cirrus (cirrocumulus is never chosen: it is rare and not predictable from these variables; set it by hand) | a sky-wide high veil is cirrostratus (Thomann 2021 §3.3.2) |
//! | `convective_precipitation` | Convective: present, coverage, rain; Low: kind | a cumulonimbus layer appears at ≥ 1 mm/h (or on a thunder code); coverage = 0.15 + 0.45 · max(1 − e^(−rate/5 mm/h), low cover) | an hourly, grid-mean shower rate of 1 mm/h means intense local cells |
//! | `pictocode` / WMO `weather_code` | Convective, Fog, Low: kind | thunder 10–12, 27–30 (WMO 95–99) → cumulonimbus; fog 16–18 (WMO 45, 48) → fog coverage ≥ 0.8 and stratus; showers 31–32 (WMO 80–86) → cumulus; steady precipitation 23–26, 33–35 (WMO 51–77) → stratus | the codes say what the model's variables only imply (`shared/formats/meteoblue.md`) |
//! | `fog_probability` | Fog: coverage | coverage = (p − 0.2) / 0.8, clamped to 0–1 | below 20 % the fog would be noise on a clear view |
//! | `visibility` | Fog: coverage, density; [`Haze`](crate::layers::Haze) | coverage from 0 at 5 km (mist) to 1 at 1 km (fog), faded out by rain; density = 3.912 / min(visibility, 1 km). Haze visibility = max(visibility, 5 km) | Koschmieder: a 2 % contrast threshold gives σ = ln 50 / V = 3.912 / V; WMO fog is visibility < 1 km; above 5 km the air is haze, not fog |
//! | `precipitation` | all but High: `precipitation`, `rain_mm_per_h`; Mid: thickness | darkening = 1 − e^(−rate/2.5 mm/h); rain goes to the lowest covered layer (the cumulonimbus takes the convective part); raining altostratus thickens downward by up to 1 km | 2.5 mm/h is where AMS "light" rain ends (moderate darkens 63 %); Thomann 2021 §6.2: precipitation drives cloud colour and the rain particles |
//! | `windspeed`, `winddirection` (10 m) | every layer without level wind: wind | v(z) = v₁₀ · (z / 10 m)^(1/7) at the layer's mid-height | the 1/7 power law (Hellmann; Peterson & Hennessey 1978) |
//! | wind at 850 / 700 / 500 / 300 hPa | Low / Mid / High / Convective: wind | Low 850 hPa; Mid interpolated between 700 and 500 hPa by height; High 300 hPa; Convective: the mean of all levels | the air at cloud altitude carries the cloud; a storm moves with the mean 850–300 hPa wind (its steering flow) |
//! | geopotential height of a level | level heights | height above sea level − ground elevation; ICAO standard heights when absent | levels are placed above ground |
//! | `convective_cloud_base` / `_top` (Open-Meteo) | Convective, cumulus Low: base, top | above sea level − ground elevation | the model's own convective cloud |
//! | `ground_elevation_m` (argument) | every height above sea level | subtracted | layers are above ground |
//!
//! Altitudes: every layer is placed at its kind's default altitudes ([`CloudKind::defaults`]),
//! with the base clamped into its slot's [`CloudBand`]. These are the bands of the format notes
//! ([`CloudBands::METEOBLUE`], [`CloudBands::OPEN_METEO`]), above ground. Fog spans 0 to
//! [`WeatherMapping::fog_top_m`].
//!
//! Not used: total cover (the sum of the layers; Thomann 2021 uses it only for distant weather, which
//! is the weather source's job), precipitation probability (the sampled precipitation is already
//! the expected amount), snow fraction (the layers carry water-equivalent precipitation;
//! rendering snow is left to a particle system), temperature, humidity, pressure, sunshine, and
//! the daylight flag.
//!
//! # What the mapping writes, and what it keeps
//!
//! A weather-driven layer's kind, base, top, coverage, precipitation darkening, rain and wind are
//! set on every call. The fog layer's density is set on every call too. The shape fields
//! (profile, coverage height, density, weather-map period, skew) are reset to the new kind's
//! defaults only when the mapping changes the kind. Hand edits to the shape therefore last while
//! the weather keeps the same kind.
//!
//! **Missing values are never zeros.** When a forecast input has no value (absent from the file,
//! in a long gap, or not finite), everything it drives keeps the layer's previous value. A
//! [`MappingWarning`] naming the input says so, once per input per call. A layer that has never
//! had a value keeps its initial one: [`WeatherLayers::new`] starts every slot at coverage 0, so
//! a layer shows nothing until the forecast says it should. [`layers_for_weather`], which starts
//! from [`WeatherLayers::new`], therefore leaves out the layer of a missing cover and reports it.
//! Inputs with a fallback are not warnings: a missing pressure level falls back to the surface
//! wind, a missing weather code to the variables.

use std::fmt;
use std::ops::{Index, IndexMut};

use bevy::prelude::*;

use crate::layers::{CloudKind, CloudLayer, DensityProfile, FarCoverage};
use crate::weather::{ForecastFormat, STANDARD_LEVELS_HPA, Variable, VariableSet, WeatherState};

/// Heights of [`STANDARD_LEVELS_HPA`] (850, 700, 500, 300 hPa) in the ICAO standard atmosphere,
/// metres above sea level (ICAO Doc 7488). The mapping uses them when the forecast has a level's
/// wind but not its geopotential height.
pub const STANDARD_LEVEL_HEIGHTS_M: [f32; STANDARD_LEVELS_HPA.len()] =
    [1_457.0, 3_012.0, 5_574.0, 9_164.0];

/// Koschmieder's constant: `ln(1 / 0.02)`, for a 2 % contrast threshold. Extinction is
/// `KOSCHMIEDER_CONSTANT / visibility` (Koschmieder 1924; WMO-No. 8, meteorological optical
/// range).
pub const KOSCHMIEDER_CONSTANT: f32 = 3.912;

/// The named layers the mapping fills (Thomann 2021 §4.2: "Layers of Cloud Shaders").
///
/// As a component beside a [`CloudLayer`], it tells the crate's mapping system which slot the
/// entity is; see [`spawn_weather_layers`].
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, Component, Reflect)]
#[reflect(Component)]
pub enum LayerSlot {
    /// Ground fog: a stratus layer from the ground up to [`WeatherMapping::fog_top_m`], driven
    /// by fog probability, visibility and fog weather codes.
    Fog,
    /// Low clouds (`lowclouds`): cumulus, stratocumulus or stratus.
    Low,
    /// Mid-level clouds (`midclouds`): altocumulus or altostratus.
    Mid,
    /// High clouds (`highclouds`): the cirrus family.
    High,
    /// Cumulonimbus, present with thunderstorm codes or heavy convective precipitation.
    Convective,
}

impl LayerSlot {
    /// Number of slots.
    pub const COUNT: usize = 5;

    /// Every slot, from the ground up, then the convective slot.
    pub const ALL: [Self; Self::COUNT] = [
        Self::Fog,
        Self::Low,
        Self::Mid,
        Self::High,
        Self::Convective,
    ];

    /// A lowercase name for messages and JSON output, e.g. `"low"`.
    #[must_use]
    pub const fn name(self) -> &'static str {
        match self {
            Self::Fog => "fog",
            Self::Low => "low",
            Self::Mid => "mid",
            Self::High => "high",
            Self::Convective => "convective",
        }
    }

    /// The kind a slot starts with: stratus for fog, cumulus low, altocumulus mid, cirrus high,
    /// cumulonimbus convective.
    #[must_use]
    pub const fn initial_kind(self) -> CloudKind {
        match self {
            Self::Fog => CloudKind::Stratus,
            Self::Low => CloudKind::Cumulus,
            Self::Mid => CloudKind::Altocumulus,
            Self::High => CloudKind::Cirrus,
            Self::Convective => CloudKind::Cumulonimbus,
        }
    }

    /// The layer a slot holds before any forecast: [`LayerSlot::initial_kind`]'s defaults with
    /// coverage 0, so nothing shows until the forecast says so. The fog layer sits on the
    /// ground, up to the default [`WeatherMapping::fog_top_m`], with the
    /// [`DensityProfile::fog`] profile and no shape noise.
    #[must_use]
    pub fn initial_layer(self) -> CloudLayer {
        let mut layer = CloudLayer::new(self.initial_kind());
        layer.coverage = 0.0;
        if self == Self::Fog {
            let mapping = WeatherMapping::METEOBLUE;
            layer.base_m = 0.0;
            layer.top_m = mapping.fog_top_m;
            layer.density = KOSCHMIEDER_CONSTANT / mapping.fog_default_visibility_m;
            // Homogeneous from the ground up with a soft top: the extinction at eye level is
            // the visibility's, and fog has no billows (patches come from the coverage).
            layer.profile = DensityProfile::fog();
            layer.shape_noise = 0.0;
        }
        layer
    }
}

impl fmt::Display for LayerSlot {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(self.name())
    }
}

/// An altitude band above ground, metres: where a slot's layer base may lie.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct CloudBand {
    /// Lowest base, metres above ground.
    pub bottom_m: f32,
    /// Highest base, metres above ground.
    pub top_m: f32,
}

impl CloudBand {
    /// Clamps a base altitude into the band. It never panics, even for an inverted or NaN band.
    #[must_use]
    pub fn clamp_base(self, base_m: f32) -> f32 {
        base_m.max(self.bottom_m).min(self.top_m)
    }
}

/// The low, mid and high bands that a forecast's `lowclouds`, `midclouds` and `highclouds`
/// describe (`shared/formats/meteoblue.md`, "Cloud layer altitudes").
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct CloudBands {
    /// Low-cloud band.
    pub low: CloudBand,
    /// Mid-cloud band.
    pub mid: CloudBand,
    /// High-cloud band.
    pub high: CloudBand,
}

impl CloudBands {
    /// meteoblue (WMO étages for mid latitudes): low surface–2 km, mid 2–7 km, high 5–13 km
    /// above ground.
    pub const METEOBLUE: Self = Self {
        low: CloudBand {
            bottom_m: 0.0,
            top_m: 2_000.0,
        },
        mid: CloudBand {
            bottom_m: 2_000.0,
            top_m: 7_000.0,
        },
        high: CloudBand {
            bottom_m: 5_000.0,
            top_m: 13_000.0,
        },
    };

    /// Open-Meteo: low up to 3 km, mid 3–8 km, high above 8 km (capped at 13 km, the top of the
    /// WMO high étage).
    pub const OPEN_METEO: Self = Self {
        low: CloudBand {
            bottom_m: 0.0,
            top_m: 3_000.0,
        },
        mid: CloudBand {
            bottom_m: 3_000.0,
            top_m: 8_000.0,
        },
        high: CloudBand {
            bottom_m: 8_000.0,
            top_m: 13_000.0,
        },
    };
}

/// Tunable rules of the weather → layers mapping. The [module docs](self) give the table; every
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

    /// The mapping for a forecast's format ([`Forecast::format`](super::Forecast::format)):
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
    fn thunderstorm(&self, inputs: &Inputs) -> Option<bool> {
        if inputs.codes.thunder {
            return Some(true);
        }
        match inputs.convective {
            Some(rate) => Some(rate >= self.thunderstorm_threshold_mm_per_h),
            None => inputs.codes.known.then_some(false),
        }
    }
}

/// What went wrong with a forecast input.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum InputFault {
    /// No value: the forecast lacks the variable, or the instant is in a long gap.
    NoValue,
    /// NaN or infinite; treated as no value.
    NotFinite,
}

/// A forecast input the mapping could not use, and what it did instead. Each input is reported
/// at most once per [`WeatherMapping::map`] call.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub struct MappingWarning {
    /// The input: a [`Variable::name`] such as `"low_cover"`, `"pressure-level wind"` or
    /// `"ground_elevation_m"`.
    pub input: &'static str,
    /// What is wrong with it.
    pub fault: InputFault,
    /// What the mapping did instead, e.g. which layer keeps which previous value.
    pub consequence: &'static str,
}

impl fmt::Display for MappingWarning {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        let fault = match self.fault {
            InputFault::NoValue => "has no value",
            InputFault::NotFinite => "is not a finite number",
        };
        write!(f, "{} {fault}: {}", self.input, self.consequence)
    }
}

/// One row of the mapping table, as data (the [module docs](self) render it with reasons).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct MappingRow {
    /// The forecast input: a [`Variable::name`], `"pictocode"`, `"weather_code"`,
    /// `"level_wind"`, `"level_height"` or `"ground_elevation_m"`.
    pub input: &'static str,
    /// The slots it drives.
    pub slots: &'static [LayerSlot],
    /// What it drives, and how.
    pub rule: &'static str,
}

/// The mapping table as data, in the order of the [module docs](self)' table.
pub const MAPPING_TABLE: [MappingRow; 13] = {
    use LayerSlot::{Convective, Fog, High, Low, Mid};
    [
        MappingRow {
            input: "low_cover",
            slots: &[Low, Convective],
            rule: "low coverage; kind cumulus < 0.6 ≤ stratocumulus, stratus at ≥ 0.9 with precipitation; raises cumulonimbus coverage",
        },
        MappingRow {
            input: "mid_cover",
            slots: &[Mid],
            rule: "mid coverage; altocumulus < 0.7 ≤ altostratus (≥ 0.5 when raining)",
        },
        MappingRow {
            input: "high_cover",
            slots: &[High],
            rule: "high coverage; cirrus < 0.7 ≤ cirrostratus",
        },
        MappingRow {
            input: "convective_precipitation",
            slots: &[Convective, Low],
            rule: "cumulonimbus at ≥ 1 mm/h, coverage 0.15 + 0.45·max(1 − e^(−rate/5), low cover), its rain; cumulus low layer at ≥ 0.1 mm/h",
        },
        MappingRow {
            input: "pictocode",
            slots: &[Convective, Fog, Low],
            rule: "10–12, 27–30 cumulonimbus; 16–18 fog ≥ 0.8 and stratus; 31–32 cumulus; 23–26, 33–35 stratus",
        },
        MappingRow {
            input: "weather_code",
            slots: &[Convective, Fog, Low],
            rule: "WMO 95–99 cumulonimbus; 45, 48 fog ≥ 0.8 and stratus; 80–86 cumulus; 51–77 stratus",
        },
        MappingRow {
            input: "fog_probability",
            slots: &[Fog],
            rule: "fog coverage (p − 0.2) / 0.8",
        },
        MappingRow {
            input: "visibility",
            slots: &[Fog],
            rule: "fog coverage 0 at 5 km to 1 at 1 km, less in rain; density 3.912 / min(visibility, 1 km) (Koschmieder)",
        },
        MappingRow {
            input: "precipitation",
            slots: &[Fog, Low, Mid, Convective],
            rule: "darkening 1 − e^(−rate/2.5 mm/h); rain to the lowest covered layer; altostratus thickens downward",
        },
        MappingRow {
            input: "wind_speed",
            slots: &[Fog, Low, Mid, High, Convective],
            rule: "with wind_direction: layer wind where no level wind, v₁₀·(z/10 m)^(1/7)",
        },
        MappingRow {
            input: "level_wind",
            slots: &[Low, Mid, High, Convective],
            rule: "850 hPa low, 700–500 hPa mid (interpolated by height), 300 hPa high, mean of all for cumulonimbus",
        },
        MappingRow {
            input: "convective_cloud_base",
            slots: &[Convective, Low],
            rule: "with convective_cloud_top: cumulonimbus and cumulus base and top, above sea level − ground",
        },
        MappingRow {
            input: "ground_elevation_m",
            slots: &[Low, Mid, High, Convective],
            rule: "subtracted from heights above sea level (level heights, convective cloud base and top)",
        },
    ]
};

const LEVELS_LOW: &[f32] = &[850.0];
const LEVELS_MID: &[f32] = &[700.0, 500.0];
const LEVELS_HIGH: &[f32] = &[300.0];

/// Wind at one pressure level, placed above ground.
#[derive(Clone, Copy, Debug, PartialEq)]
struct LevelWind {
    pressure_hpa: f32,
    height_m: f32,
    velocity_m_s: [f32; 2],
}

/// What the weather code (meteoblue pictocode, else WMO code) says.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
struct CodeHints {
    /// A code was present.
    known: bool,
    thunder: bool,
    fog: bool,
    showers: bool,
    steady_precipitation: bool,
}

impl CodeHints {
    fn from_state(state: &WeatherState) -> Self {
        if let Some(code) = state.pictocode.filter(|c| (1..=35).contains(c)) {
            // shared/formats/meteoblue.md, hourly pictocodes.
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
struct Inputs {
    ground_m: f32,
    low: Option<f32>,
    mid: Option<f32>,
    high: Option<f32>,
    precipitation: Option<f32>,
    convective: Option<f32>,
    fog_probability: Option<f32>,
    visibility: Option<f32>,
    surface_wind: Option<[f32; 2]>,
    levels: [Option<LevelWind>; STANDARD_LEVELS_HPA.len()],
    convective_base_m: Option<f32>,
    convective_top_m: Option<f32>,
    codes: CodeHints,
}

struct Reader<'a> {
    state: &'a WeatherState,
    not_finite: VariableSet,
    warnings: Vec<MappingWarning>,
}

impl Reader<'_> {
    fn read(&mut self, variable: Variable) -> Option<f32> {
        let value = self.state.get(variable)?;
        if value.is_finite() {
            Some(value)
        } else {
            self.not_finite.insert(variable);
            None
        }
    }

    /// Reports that what `variable` drives keeps its previous value.
    fn held(&mut self, variable: Variable, consequence: &'static str) {
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
fn velocity(speed: f32, from_deg: f32) -> [f32; 2] {
    let from = from_deg.to_radians();
    [-speed * from.sin(), -speed * from.cos()]
}

fn saturate(x: f32) -> f32 {
    if x.is_nan() { 0.0 } else { x.clamp(0.0, 1.0) }
}

/// A forecast state digested by [`WeatherMapping::map`], ready to write layers with
/// [`MappedWeather::apply`]. It holds no references, so one map per frame can write any number
/// of layers.
#[derive(Clone, Debug, PartialEq)]
pub struct MappedWeather {
    mapping: WeatherMapping,
    inputs: Inputs,
    /// Inputs that could not be used, each once, with what the mapping did instead.
    pub warnings: Vec<MappingWarning>,
}

impl MappedWeather {
    /// The mapping rules used.
    #[must_use]
    pub const fn mapping(&self) -> &WeatherMapping {
        &self.mapping
    }

    /// The cleaned ground elevation above sea level, metres (0 when the one given was not
    /// finite).
    #[must_use]
    pub const fn ground_elevation_m(&self) -> f32 {
        self.inputs.ground_m
    }

    /// Writes `layer` as the forecast says a layer in `slot` should be (the rules in the
    /// [module docs](self)). A layer whose [`CloudLayer::weather_driven`] is false is left
    /// exactly as it is. A weather-driven layer is cleaned with [`CloudLayer::sanitize`] at
    /// the end, so no NaN reaches it, even from a hand-set NaN field. It allocates only when the kind changes (the
    /// new kind's profile).
    pub fn apply(&self, slot: LayerSlot, layer: &mut CloudLayer) {
        if !layer.weather_driven {
            return;
        }
        match slot {
            LayerSlot::Fog => self.apply_fog(layer),
            LayerSlot::Low => self.apply_low(layer),
            LayerSlot::Mid => self.apply_mid(layer),
            LayerSlot::High => self.apply_high(layer),
            LayerSlot::Convective => self.apply_convective(layer),
        }
        layer.sanitize();
    }

    /// The visibility the haze should have, metres ([`Haze::visibility_m`]): the forecast's,
    /// but at least [`WeatherMapping::mist_visibility_m`], below which the fog layer carries
    /// the rest of the extinction (so the two never count the same air twice). `None` when the
    /// forecast has no usable visibility: the haze keeps its previous value.
    ///
    /// [`Haze::visibility_m`]: crate::layers::Haze::visibility_m
    #[must_use]
    pub fn haze_visibility_m(&self) -> Option<f32> {
        let floor = if self.mapping.mist_visibility_m.is_finite() {
            self.mapping.mist_visibility_m.max(1.0)
        } else {
            1.0
        };
        self.inputs.visibility.map(|v| v.max(floor))
    }

    /// [`MappedWeather::apply`] to every slot of `layers`.
    pub fn apply_all(&self, layers: &mut WeatherLayers) {
        for slot in LayerSlot::ALL {
            self.apply(slot, &mut layers[slot]);
        }
    }

    fn darkening(&self) -> Option<f32> {
        let m = &self.mapping;
        self.inputs
            .precipitation
            .map(|rate| m.precipitation_darkening(rate))
    }

    /// Rain (mm/h) falling from the base of the layer in `slot`. The cumulonimbus takes the
    /// convective part when it is present. The rest falls from the lowest slot with cover (low,
    /// else mid), or from the low slot when the covers are unknown. `None` when precipitation is
    /// unknown.
    fn rain(&self, slot: LayerSlot) -> Option<f32> {
        let inputs = &self.inputs;
        let total = inputs.precipitation?;
        let storm = self.mapping.thunderstorm(inputs) == Some(true);
        let convective = if storm {
            inputs.convective.unwrap_or(total)
        } else {
            0.0
        };
        let stratiform = (total - convective).max(0.0);
        let covered = |cover: Option<f32>| cover.is_none_or(|c| c > 0.05);
        let carrier = if covered(inputs.low) || !covered(inputs.mid) {
            LayerSlot::Low
        } else {
            LayerSlot::Mid
        };
        Some(match slot {
            LayerSlot::Convective => convective,
            s if s == carrier => stratiform,
            _ => 0.0,
        })
    }

    /// Wind at `height_m` from the levels in `pressures` (interpolated in height between the
    /// nearest below and above, held beyond them), else the surface wind by the power law.
    fn wind(&self, pressures: &[f32], height_m: f32) -> Option<[f32; 2]> {
        let mut below: Option<LevelWind> = None;
        let mut above: Option<LevelWind> = None;
        for level in self.inputs.levels.iter().flatten() {
            if !pressures.contains(&level.pressure_hpa) {
                continue;
            }
            if level.height_m <= height_m && below.is_none_or(|b| level.height_m > b.height_m) {
                below = Some(*level);
            }
            if level.height_m >= height_m && above.is_none_or(|a| level.height_m < a.height_m) {
                above = Some(*level);
            }
        }
        match (below, above) {
            (Some(b), Some(a)) if a.height_m > b.height_m => {
                let t = (height_m - b.height_m) / (a.height_m - b.height_m);
                Some(
                    [0, 1].map(|i| b.velocity_m_s[i] + (a.velocity_m_s[i] - b.velocity_m_s[i]) * t),
                )
            }
            (Some(level), _) | (None, Some(level)) => Some(level.velocity_m_s),
            (None, None) => self.surface_wind_at(height_m),
        }
    }

    /// The 10 m wind scaled to `height_m` by the power law (Peterson & Hennessey 1978).
    fn surface_wind_at(&self, height_m: f32) -> Option<[f32; 2]> {
        let [east, north] = self.inputs.surface_wind?;
        let z = if height_m.is_finite() {
            height_m.max(10.0)
        } else {
            10.0
        };
        let factor = (z / 10.0).powf(self.mapping.wind_shear_exponent);
        let factor = if factor.is_finite() { factor } else { 1.0 };
        Some([east * factor, north * factor])
    }

    /// Sets the kind, resetting the shape fields to the new kind's defaults if it changed.
    fn set_kind(layer: &mut CloudLayer, kind: Option<CloudKind>) {
        let Some(kind) = kind else {
            return;
        };
        if layer.kind != kind {
            let fresh = CloudLayer::new(kind);
            layer.kind = kind;
            layer.profile = fresh.profile;
            layer.coverage_height = fresh.coverage_height;
            layer.density = fresh.density;
            layer.weather_map_scale_m = fresh.weather_map_scale_m;
            layer.skew = fresh.skew;
        }
    }

    /// Places the layer at its kind's default altitudes, base clamped into `band`.
    fn place_in_band(layer: &mut CloudLayer, band: CloudBand) {
        let defaults = layer.kind.defaults();
        layer.base_m = band.clamp_base(defaults.base_m);
        layer.top_m = layer.base_m + (defaults.top_m - defaults.base_m);
    }

    fn set_weather(&self, layer: &mut CloudLayer, slot: LayerSlot) {
        if let Some(darkening) = self.darkening() {
            layer.precipitation = darkening;
        }
        if let Some(rain) = self.rain(slot) {
            layer.rain_mm_per_h = rain;
        }
    }

    fn set_wind(&self, layer: &mut CloudLayer, pressures: &[f32]) {
        let middle = 0.5 * (layer.base_m + layer.top_m);
        if let Some(wind) = self.wind(pressures, middle) {
            layer.wind_m_s = wind;
        }
    }

    fn apply_fog(&self, layer: &mut CloudLayer) {
        let (m, inputs) = (&self.mapping, &self.inputs);
        Self::set_kind(layer, Some(CloudKind::Stratus));
        layer.base_m = 0.0;
        layer.top_m = m.fog_top_m;

        let from_probability = inputs.fog_probability.map(|p| {
            let floor = m.fog_probability_floor;
            if floor < 1.0 {
                saturate((p - floor) / (1.0 - floor))
            } else {
                0.0
            }
        });
        // Low visibility in rain is the rain's doing: fade the visibility term with darkening.
        let rain_fade = 1.0 - self.darkening().unwrap_or(0.0);
        let from_visibility = inputs.visibility.map(|v| {
            let (fog, mist) = (m.fog_visibility_m, m.mist_visibility_m);
            let foggy = if mist > fog {
                saturate((mist - v) / (mist - fog))
            } else if v <= fog {
                1.0
            } else {
                0.0
            };
            foggy * rain_fade
        });
        let from_code = inputs.codes.known.then_some(if inputs.codes.fog {
            m.fog_code_coverage
        } else {
            0.0
        });
        let coverage = [from_probability, from_visibility, from_code]
            .into_iter()
            .flatten()
            .reduce(f32::max);
        if let Some(coverage) = coverage {
            layer.coverage = coverage;
        }

        // Koschmieder: σ = 3.912 / V. Inside fog V < 1 km by definition, so a larger station
        // visibility (the fog is patchy, or elsewhere) caps at the fog threshold.
        let visibility = inputs
            .visibility
            .unwrap_or(m.fog_default_visibility_m)
            .min(m.fog_visibility_m)
            .max(10.0);
        layer.density = KOSCHMIEDER_CONSTANT / visibility;
        self.set_weather(layer, LayerSlot::Fog);
        if let Some(wind) = self.surface_wind_at(0.5 * (layer.base_m + layer.top_m)) {
            layer.wind_m_s = wind;
        }
    }

    fn apply_low(&self, layer: &mut CloudLayer) {
        let (m, inputs) = (&self.mapping, &self.inputs);
        let codes = inputs.codes;
        let raining = inputs
            .precipitation
            .is_some_and(|p| p >= m.precipitation_threshold_mm_per_h);
        let showers = codes.thunder
            || codes.showers
            || inputs
                .convective
                .is_some_and(|c| c >= m.shower_threshold_mm_per_h);
        let kind = if codes.fog || codes.steady_precipitation {
            Some(CloudKind::Stratus)
        } else if showers {
            Some(CloudKind::Cumulus)
        } else {
            inputs.low.map(|cover| {
                if cover >= m.stratus_cover && raining {
                    CloudKind::Stratus
                } else if cover >= m.stratocumulus_cover {
                    CloudKind::Stratocumulus
                } else {
                    CloudKind::Cumulus
                }
            })
        };
        Self::set_kind(layer, kind);
        if let Some(cover) = inputs.low {
            layer.coverage = cover;
        }
        Self::place_in_band(layer, m.bands.low);
        if layer.kind == CloudKind::Cumulus
            && let Some(base) = inputs.convective_base_m.filter(|b| *b >= 0.0)
        {
            let default_depth = layer.thickness_m();
            let depth = inputs
                .convective_top_m
                .map(|top| top - base)
                .filter(|depth| *depth >= 100.0)
                .unwrap_or(default_depth)
                .min(m.max_cumulus_depth_m);
            layer.base_m = base;
            layer.top_m = base + depth.max(100.0);
        }
        self.set_weather(layer, LayerSlot::Low);
        self.set_wind(layer, LEVELS_LOW);
    }

    fn apply_mid(&self, layer: &mut CloudLayer) {
        let (m, inputs) = (&self.mapping, &self.inputs);
        let raining = inputs
            .precipitation
            .is_some_and(|p| p >= m.precipitation_threshold_mm_per_h);
        let kind = inputs.mid.map(|cover| {
            if cover >= m.altostratus_cover || (cover >= 0.5 && raining) {
                CloudKind::Altostratus
            } else {
                CloudKind::Altocumulus
            }
        });
        Self::set_kind(layer, kind);
        if let Some(cover) = inputs.mid {
            layer.coverage = cover;
        }
        Self::place_in_band(layer, m.bands.mid);
        if layer.kind == CloudKind::Altostratus {
            // Nimbostratus substitute (Thomann 2021 §4.2.6): thicker downward as the rain darkens.
            let grow = m.nimbostratus_thickening_m * self.darkening().unwrap_or(0.0);
            let lowest = m.bands.mid.bottom_m.min(layer.base_m);
            layer.base_m = (layer.base_m - grow).max(lowest);
        }
        self.set_weather(layer, LayerSlot::Mid);
        self.set_wind(layer, LEVELS_MID);
    }

    fn apply_high(&self, layer: &mut CloudLayer) {
        let (m, inputs) = (&self.mapping, &self.inputs);
        let kind = inputs.high.map(|cover| {
            if cover >= m.cirrostratus_cover {
                CloudKind::Cirrostratus
            } else {
                CloudKind::Cirrus
            }
        });
        Self::set_kind(layer, kind);
        if let Some(cover) = inputs.high {
            layer.coverage = cover;
        }
        Self::place_in_band(layer, m.bands.high);
        // Ice cloud high above: it does not rain on the scene, and precipitation does not darken
        // it.
        layer.precipitation = 0.0;
        layer.rain_mm_per_h = 0.0;
        self.set_wind(layer, LEVELS_HIGH);
    }

    fn apply_convective(&self, layer: &mut CloudLayer) {
        let (m, inputs) = (&self.mapping, &self.inputs);
        Self::set_kind(layer, Some(CloudKind::Cumulonimbus));
        match m.thunderstorm(inputs) {
            Some(true) => {
                let scale = m.thunderstorm_scale_mm_per_h;
                let from_rate = inputs.convective.map_or(0.0, |rate| {
                    if scale > 0.0 {
                        saturate(-(-rate / scale).exp_m1())
                    } else {
                        1.0
                    }
                });
                let strength = from_rate.max(inputs.low.unwrap_or(0.0));
                let (lo, hi) = (m.cumulonimbus_min_coverage, m.cumulonimbus_max_coverage);
                layer.coverage = lo + (hi - lo) * strength;
            }
            Some(false) => layer.coverage = 0.0,
            None => {}
        }
        let defaults = CloudKind::Cumulonimbus.defaults();
        layer.base_m = inputs
            .convective_base_m
            .filter(|b| *b >= 0.0)
            .unwrap_or(defaults.base_m);
        layer.top_m = inputs
            .convective_top_m
            .filter(|top| *top >= layer.base_m + 1_000.0)
            .unwrap_or(layer.base_m.max(defaults.base_m) + (defaults.top_m - defaults.base_m));
        self.set_weather(layer, LayerSlot::Convective);
        // A storm moves with its steering flow: the mean wind of the levels it spans.
        let levels = inputs.levels.iter().flatten();
        let count = levels.clone().count();
        if count > 0 {
            let sum = levels.fold([0.0, 0.0], |acc, l| {
                [acc[0] + l.velocity_m_s[0], acc[1] + l.velocity_m_s[1]]
            });
            layer.wind_m_s = sum.map(|v| v / count as f32);
        } else if let Some(wind) = self.surface_wind_at(0.5 * (layer.base_m + layer.top_m)) {
            layer.wind_m_s = wind;
        }
    }
}

/// One [`CloudLayer`] per [`LayerSlot`], indexable by slot:
/// `layers[LayerSlot::Low].weather_driven = false`.
#[derive(Clone, Debug, PartialEq)]
pub struct WeatherLayers {
    layers: [CloudLayer; LayerSlot::COUNT],
}

impl Default for WeatherLayers {
    fn default() -> Self {
        Self::new()
    }
}

impl WeatherLayers {
    /// Every slot at its [`LayerSlot::initial_layer`]: weather-driven, coverage 0.
    #[must_use]
    pub fn new() -> Self {
        Self {
            layers: LayerSlot::ALL.map(LayerSlot::initial_layer),
        }
    }

    /// The slots and their layers, in [`LayerSlot::ALL`] order.
    pub fn iter(&self) -> impl Iterator<Item = (LayerSlot, &CloudLayer)> {
        LayerSlot::ALL.into_iter().zip(&self.layers)
    }

    /// The slots and their layers, mutably.
    pub fn iter_mut(&mut self) -> impl Iterator<Item = (LayerSlot, &mut CloudLayer)> {
        LayerSlot::ALL.into_iter().zip(&mut self.layers)
    }

    /// The layers that [`CloudLayer::is_visible`] says show anything (the ones to render).
    pub fn visible(&self) -> impl Iterator<Item = (LayerSlot, &CloudLayer)> {
        self.iter().filter(|(_, layer)| layer.is_visible())
    }
}

impl Index<LayerSlot> for WeatherLayers {
    type Output = CloudLayer;

    fn index(&self, slot: LayerSlot) -> &CloudLayer {
        &self.layers[slot as usize]
    }
}

impl IndexMut<LayerSlot> for WeatherLayers {
    fn index_mut(&mut self, slot: LayerSlot) -> &mut CloudLayer {
        &mut self.layers[slot as usize]
    }
}

/// Maps `state` onto `layers` with the default [`WeatherMapping`] and returns the warnings.
/// Layers with [`CloudLayer::weather_driven`] false are left alone; missing inputs keep previous
/// values. `ground_elevation_m` is the ground above sea level, metres.
pub fn map_weather(
    state: &WeatherState,
    ground_elevation_m: f32,
    layers: &mut WeatherLayers,
) -> Vec<MappingWarning> {
    let mapped = WeatherMapping::default().map(state, ground_elevation_m);
    mapped.apply_all(layers);
    mapped.warnings
}

/// The visible layers for `state` from fresh [`WeatherLayers`] (default mapping), in
/// [`LayerSlot::ALL`] order, with the warnings. A missing cover gives no layer (fresh slots start
/// at coverage 0) and a warning naming it. `ground_elevation_m` is the ground above sea level,
/// metres.
#[must_use]
pub fn layers_for_weather(
    state: &WeatherState,
    ground_elevation_m: f32,
) -> (Vec<CloudLayer>, Vec<MappingWarning>) {
    let mut layers = WeatherLayers::new();
    let warnings = map_weather(state, ground_elevation_m, &mut layers);
    let visible = layers.visible().map(|(_, layer)| layer.clone()).collect();
    (visible, warnings)
}

/// Spawns one [`CloudLayer`] entity per [`LayerSlot`], each starting at coverage 0, for the
/// weather to fill. Returns the entities in [`LayerSlot::ALL`] order.
pub fn spawn_weather_layers(commands: &mut Commands) -> Vec<Entity> {
    LayerSlot::ALL
        .iter()
        .map(|&slot| {
            commands
                .spawn((
                    Name::new(format!("cloud layer: {slot}")),
                    slot,
                    slot.initial_layer(),
                ))
                .id()
        })
        .collect()
}

/// Writes the near place's [`CurrentWeather`](super::CurrentWeather) onto every weather-driven
/// [`CloudLayer`] with a [`LayerSlot`], when the weather changed. Layers are only written when
/// their values change, so change detection stays meaningful; mapping warnings are logged when
/// they change, not every frame.
pub(crate) fn map_weather_onto_layers(
    current: Res<super::CurrentWeather>,
    mapping: Option<Res<WeatherMapping>>,
    forecasts: Res<Assets<super::Forecast>>,
    source: Option<Res<super::WeatherSource>>,
    mut layers: Query<(&LayerSlot, &mut CloudLayer)>,
    haze: Option<ResMut<crate::layers::Haze>>,
    mut last_warnings: Local<Vec<String>>,
) {
    if !current.is_changed() && !mapping.as_ref().is_some_and(|m| m.is_changed()) {
        return;
    }
    let Some(near) = &current.near else {
        return;
    };
    let rules = mapping.map_or_else(
        || {
            let format = source
                .as_ref()
                .and_then(|s| s.near.as_ref())
                .and_then(|h| forecasts.get(h))
                .and_then(|f| f.format);
            WeatherMapping::for_format(format)
        },
        |m| *m,
    );
    let mapped = rules.map(&near.state, near.place.elevation_m as f32);
    if let (Some(mut haze), Some(visibility)) = (haze, mapped.haze_visibility_m())
        && haze.weather_driven
        && haze.visibility_m != visibility
    {
        haze.visibility_m = visibility;
    }
    // Far places: their own mapping, of which only the coverage is used (Thomann 2021 §4.5: the
    // distant weather shows on the horizon toward its place). Heights are above each place's
    // own ground.
    let far: Vec<(&super::PlaceWeather, MappedWeather)> = current
        .far
        .iter()
        .flatten()
        .map(|place| {
            (
                place,
                rules.map(&place.state, place.place.elevation_m as f32),
            )
        })
        .collect();
    let east_north = |p: Vec3| [p.x, -p.z];
    for (slot, mut layer) in &mut layers {
        let mut updated = layer.clone();
        mapped.apply(*slot, &mut updated);
        if updated.weather_driven {
            updated.far_coverage = far
                .iter()
                .map(|(place, mapped_far)| {
                    // Applied to a copy of the near layer: an input the far file lacks keeps
                    // the near value, so a missing far cover means "no change", never 0.
                    let mut there = updated.clone();
                    mapped_far.apply(*slot, &mut there);
                    FarCoverage {
                        from_m: east_north(near.scene_position),
                        to_m: east_north(place.scene_position),
                        coverage: there.coverage,
                    }
                })
                .collect();
        }
        if updated != *layer {
            *layer = updated;
        }
    }
    let warnings: Vec<String> = mapped.warnings.iter().map(ToString::to_string).collect();
    if warnings != *last_warnings {
        for warning in &warnings {
            warn!(
                "bevy_cloudscape: weather for {}: {warning}",
                near.place.name
            );
        }
        *last_warnings = warnings;
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::scene::UtcInstant;
    use crate::weather::LevelState;

    const BERN_M: f32 = 540.0;

    fn state(values: &[(Variable, f32)]) -> WeatherState {
        let mut state = WeatherState::empty(UtcInstant::from_unix_seconds(1_620_000_000));
        for &(variable, value) in values {
            state.values[variable as usize] = Some(value);
        }
        state
    }

    #[test]
    fn far_places_set_far_coverage_on_weather_driven_layers() {
        use crate::scene::Place;
        use crate::weather::{CurrentWeather, PlaceWeather};
        let place = |name: &str, position: Vec3, state: WeatherState| PlaceWeather {
            place: Place {
                name: name.into(),
                latitude_deg: 47.0,
                longitude_deg: 7.4,
                elevation_m: f64::from(BERN_M),
            },
            scene_position: position,
            state,
        };
        let mut overcast_far = fair();
        overcast_far.values[Variable::LowCover as usize] = Some(0.95);
        // The far file lacks mid cover: the far coverage keeps the near value, not 0.
        overcast_far.values[Variable::MidCover as usize] = None;
        let mut app = App::new();
        app.insert_resource(CurrentWeather {
            near: Some(place("Bern", Vec3::ZERO, fair())),
            far: vec![
                Some(place(
                    "Solothurn",
                    Vec3::new(3_000.0, 0.0, -30_000.0),
                    overcast_far,
                )),
                None,
            ],
        })
        .insert_resource(WeatherMapping::default())
        .init_resource::<Assets<crate::weather::Forecast>>()
        .add_systems(Update, map_weather_onto_layers);
        let low = app
            .world_mut()
            .spawn((LayerSlot::Low, LayerSlot::Low.initial_layer()))
            .id();
        let mid = app
            .world_mut()
            .spawn((LayerSlot::Mid, LayerSlot::Mid.initial_layer()))
            .id();
        let manual = app
            .world_mut()
            .spawn((
                LayerSlot::High,
                CloudLayer {
                    weather_driven: false,
                    ..LayerSlot::High.initial_layer()
                },
            ))
            .id();
        app.update();
        let low = app.world().get::<CloudLayer>(low).unwrap();
        assert!((low.coverage - 0.3).abs() < 1e-6);
        assert_eq!(
            low.far_coverage,
            vec![FarCoverage {
                from_m: [0.0, 0.0],
                to_m: [3_000.0, 30_000.0],
                coverage: 0.95,
            }]
        );
        let mid = app.world().get::<CloudLayer>(mid).unwrap();
        assert_eq!(mid.far_coverage.len(), 1);
        assert!((mid.far_coverage[0].coverage - mid.coverage).abs() < 1e-6);
        let manual = app.world().get::<CloudLayer>(manual).unwrap();
        assert!(
            manual.far_coverage.is_empty(),
            "play-mode layers are left alone"
        );
    }

    #[test]
    fn visibility_sets_the_haze_and_a_gap_keeps_it() {
        use crate::layers::Haze;
        use crate::scene::Place;
        use crate::weather::{CurrentWeather, PlaceWeather};
        let place = |state: WeatherState| PlaceWeather {
            place: Place {
                name: "Bern".into(),
                latitude_deg: 47.0,
                longitude_deg: 7.4,
                elevation_m: f64::from(BERN_M),
            },
            scene_position: Vec3::ZERO,
            state,
        };
        let mut app = App::new();
        app.insert_resource(CurrentWeather {
            near: Some(place(with(fair(), Variable::Visibility, Some(24_000.0)))),
            far: vec![],
        })
        .init_resource::<Haze>()
        .init_resource::<Assets<crate::weather::Forecast>>()
        .add_systems(Update, map_weather_onto_layers);
        app.update();
        assert_eq!(app.world().resource::<Haze>().visibility_m, 24_000.0);
        // Below the mist limit the fog layer takes over; the haze stops at 5 km.
        app.world_mut().resource_mut::<CurrentWeather>().near =
            Some(place(with(fair(), Variable::Visibility, Some(800.0))));
        app.update();
        assert_eq!(app.world().resource::<Haze>().visibility_m, 5_000.0);
        // A missing value keeps the last good one, never a wall of haze or none.
        app.world_mut().resource_mut::<CurrentWeather>().near =
            Some(place(with(fair(), Variable::Visibility, None)));
        app.update();
        assert_eq!(app.world().resource::<Haze>().visibility_m, 5_000.0);
        // Hand-set haze is left alone.
        app.world_mut().resource_mut::<Haze>().weather_driven = false;
        app.world_mut().resource_mut::<Haze>().visibility_m = 70_000.0;
        app.world_mut().resource_mut::<CurrentWeather>().near =
            Some(place(with(fair(), Variable::Visibility, Some(9_000.0))));
        app.update();
        assert_eq!(app.world().resource::<Haze>().visibility_m, 70_000.0);
    }

    /// A fair afternoon: every variable the mapping reads, with little weather.
    fn fair() -> WeatherState {
        let mut s = state(&[
            (Variable::LowCover, 0.3),
            (Variable::MidCover, 0.1),
            (Variable::HighCover, 0.2),
            (Variable::Precipitation, 0.0),
            (Variable::ConvectivePrecipitation, 0.0),
            (Variable::FogProbability, 0.01),
            (Variable::Visibility, 30_000.0),
            (Variable::WindSpeed, 4.0),
            (Variable::WindDirection, 270.0),
        ]);
        s.pictocode = Some(7);
        s
    }

    fn with(mut s: WeatherState, variable: Variable, value: Option<f32>) -> WeatherState {
        s.values[variable as usize] = value;
        s
    }

    fn mapped(s: &WeatherState) -> (WeatherLayers, Vec<MappingWarning>) {
        let mut layers = WeatherLayers::new();
        let warnings = map_weather(s, BERN_M, &mut layers);
        (layers, warnings)
    }

    fn level(pressure_hpa: f32, speed: f32, from_deg: f32, height_m: Option<f32>) -> LevelState {
        LevelState {
            pressure_hpa,
            wind_speed_m_s: Some(speed),
            wind_direction_deg: Some(from_deg),
            height_m,
            cloud_cover: None,
        }
    }

    fn set_level(s: &mut WeatherState, level: LevelState) {
        let index = STANDARD_LEVELS_HPA
            .iter()
            .position(|p| *p == level.pressure_hpa)
            .unwrap();
        s.upper_air[index] = Some(level);
    }

    fn assert_all_finite(layers: &WeatherLayers) {
        for (slot, layer) in layers.iter() {
            let numbers = [
                layer.base_m,
                layer.top_m,
                layer.coverage,
                layer.density,
                layer.weather_map_scale_m,
                layer.wind_m_s[0],
                layer.wind_m_s[1],
                layer.skew,
                layer.precipitation,
                layer.rain_mm_per_h,
            ];
            assert!(numbers.iter().all(|v| v.is_finite()), "{slot}: {layer:?}");
            assert!((0.0..=1.0).contains(&layer.coverage), "{slot}");
            assert!((0.0..=1.0).contains(&layer.precipitation), "{slot}");
            assert!(layer.top_m >= layer.base_m, "{slot}");
            for h in 0..=20 {
                assert!(layer.profile.evaluate(h as f32 / 20.0).is_finite());
            }
        }
    }

    #[test]
    fn covers_set_layer_coverage_in_their_bands() {
        let s = with(fair(), Variable::LowCover, Some(0.6));
        let s = with(s, Variable::MidCover, Some(0.45));
        let s = with(s, Variable::HighCover, Some(0.25));
        let (layers, warnings) = mapped(&s);
        assert!(warnings.is_empty(), "{warnings:?}");
        assert_eq!(layers[LayerSlot::Low].coverage, 0.6);
        assert_eq!(layers[LayerSlot::Mid].coverage, 0.45);
        assert_eq!(layers[LayerSlot::High].coverage, 0.25);
        // Above ground, within the format notes' bands (meteoblue: low < 2 km, mid 2–7 km,
        // high 5–13 km); the ground elevation does not shift them.
        let band_of = |slot: LayerSlot| {
            let b = CloudBands::METEOBLUE;
            match slot {
                LayerSlot::Low => b.low,
                LayerSlot::Mid => b.mid,
                _ => b.high,
            }
        };
        for slot in [LayerSlot::Low, LayerSlot::Mid, LayerSlot::High] {
            let layer = &layers[slot];
            let band = band_of(slot);
            assert!(
                layer.base_m >= band.bottom_m && layer.base_m <= band.top_m,
                "{slot}: {layer:?}"
            );
            assert!(layer.is_visible(), "{slot}");
        }
        let mut at_sea = WeatherLayers::new();
        map_weather(&s, 0.0, &mut at_sea);
        assert_eq!(at_sea[LayerSlot::Low].base_m, layers[LayerSlot::Low].base_m);
        // Layers are stacked: fog < low < mid < high.
        assert!(layers[LayerSlot::Fog].top_m <= layers[LayerSlot::Low].base_m);
        assert!(layers[LayerSlot::Low].top_m <= layers[LayerSlot::Mid].base_m);
        assert!(layers[LayerSlot::Mid].top_m <= layers[LayerSlot::High].base_m);
    }

    #[test]
    fn open_meteo_bands_place_layers_higher() {
        let s = with(fair(), Variable::HighCover, Some(0.9));
        let mut layers = WeatherLayers::new();
        let mapped = WeatherMapping::for_format(Some(ForecastFormat::OpenMeteo)).map(&s, 0.0);
        mapped.apply_all(&mut layers);
        // Cirrostratus defaults to 7.5 km; Open-Meteo's high band starts at 8 km.
        assert_eq!(layers[LayerSlot::High].kind, CloudKind::Cirrostratus);
        assert_eq!(layers[LayerSlot::High].base_m, 8_000.0);
        assert_eq!(
            WeatherMapping::for_format(Some(ForecastFormat::Meteoblue)),
            WeatherMapping::default()
        );
        assert_eq!(WeatherMapping::for_format(None), WeatherMapping::METEOBLUE);
    }

    #[test]
    fn low_kind_follows_cover_showers_and_codes() {
        let low_kind = |s: &WeatherState| mapped(s).0[LayerSlot::Low].kind;
        let mut s = with(fair(), Variable::LowCover, Some(0.3));
        assert_eq!(low_kind(&s), CloudKind::Cumulus);
        s = with(s, Variable::LowCover, Some(0.75));
        assert_eq!(low_kind(&s), CloudKind::Stratocumulus);
        // Closed deck with rain: stratus (nimbostratus substitute).
        s = with(s, Variable::LowCover, Some(0.95));
        s = with(s, Variable::Precipitation, Some(1.0));
        assert_eq!(low_kind(&s), CloudKind::Stratus);
        // Closed deck, dry: stratocumulus.
        s = with(s, Variable::Precipitation, Some(0.0));
        assert_eq!(low_kind(&s), CloudKind::Stratocumulus);
        // Showers make even a broken deck convective.
        s = with(s, Variable::ConvectivePrecipitation, Some(0.3));
        s = with(s, Variable::Precipitation, Some(0.3));
        assert_eq!(low_kind(&s), CloudKind::Cumulus);
        // Codes: fog 16 → stratus; showers 31 → cumulus; steady rain 23 → stratus.
        let mut coded = with(fair(), Variable::LowCover, Some(0.8));
        coded.pictocode = Some(16);
        assert_eq!(low_kind(&coded), CloudKind::Stratus);
        coded.pictocode = Some(31);
        assert_eq!(low_kind(&coded), CloudKind::Cumulus);
        coded.pictocode = Some(23);
        assert_eq!(low_kind(&coded), CloudKind::Stratus);
        // Open-Meteo WMO codes when there is no pictocode.
        coded.pictocode = None;
        coded.wmo_weather_code = Some(81);
        assert_eq!(low_kind(&coded), CloudKind::Cumulus);
        coded.wmo_weather_code = Some(45);
        assert_eq!(low_kind(&coded), CloudKind::Stratus);
    }

    #[test]
    fn mid_and_high_kinds_follow_cover() {
        let kinds = |s: &WeatherState| {
            let (layers, _) = mapped(s);
            (layers[LayerSlot::Mid].kind, layers[LayerSlot::High].kind)
        };
        let s = with(fair(), Variable::MidCover, Some(0.3));
        let s = with(s, Variable::HighCover, Some(0.3));
        assert_eq!(kinds(&s), (CloudKind::Altocumulus, CloudKind::Cirrus));
        let s = with(s, Variable::MidCover, Some(0.8));
        let s = with(s, Variable::HighCover, Some(0.9));
        assert_eq!(kinds(&s), (CloudKind::Altostratus, CloudKind::Cirrostratus));
        // Half-covered mid level in rain: altostratus (it precedes and brings rain).
        let s = with(s, Variable::MidCover, Some(0.55));
        assert_eq!(kinds(&s).0, CloudKind::Altocumulus);
        let s = with(s, Variable::Precipitation, Some(0.5));
        assert_eq!(kinds(&s).0, CloudKind::Altostratus);
        let high = mapped(&s).0[LayerSlot::High].clone();
        assert!(high.kind.is_cirrus_family());
    }

    #[test]
    fn thunderstorm_codes_add_a_cumulonimbus() {
        for code in [10, 11, 12, 27, 28, 29, 30] {
            let mut s = fair();
            s.pictocode = Some(code);
            let (layers, _) = mapped(&s);
            let cb = &layers[LayerSlot::Convective];
            assert_eq!(cb.kind, CloudKind::Cumulonimbus);
            assert!(cb.is_visible(), "pictocode {code}");
            assert!(cb.coverage >= 0.15, "pictocode {code}");
        }
        let mut wmo = fair();
        wmo.pictocode = None;
        wmo.wmo_weather_code = Some(95);
        assert!(mapped(&wmo).0[LayerSlot::Convective].is_visible());
        // No thunder, no heavy showers: no cumulonimbus.
        for code in [1, 7, 16, 22, 23, 31] {
            let mut s = fair();
            s.pictocode = Some(code);
            assert_eq!(
                mapped(&s).0[LayerSlot::Convective].coverage,
                0.0,
                "pictocode {code}"
            );
        }
        // The pictocode-27 case of the brief, through layers_for_weather.
        let mut s = fair();
        s.pictocode = Some(27);
        let (layers, _) = layers_for_weather(&s, BERN_M);
        assert!(layers.iter().any(|l| l.kind == CloudKind::Cumulonimbus));
    }

    #[test]
    fn convective_precipitation_adds_and_grows_a_cumulonimbus() {
        let coverage = |rate: f32| {
            let s = with(fair(), Variable::ConvectivePrecipitation, Some(rate));
            let s = with(s, Variable::Precipitation, Some(rate));
            mapped(&s).0[LayerSlot::Convective].coverage
        };
        assert_eq!(coverage(0.5), 0.0, "below the 1 mm/h threshold");
        let mut last = 0.0;
        for rate in [1.0, 2.0, 5.0, 10.0, 40.0] {
            let c = coverage(rate);
            assert!(c > last, "{rate}: {c}");
            assert!(c <= 0.6 + 1e-6);
            last = c;
        }
        // More low cover → more storm cover, for the same rain.
        let s = with(fair(), Variable::ConvectivePrecipitation, Some(1.0));
        let s = with(s, Variable::Precipitation, Some(1.5));
        let sparse = mapped(&s).0[LayerSlot::Convective].coverage;
        let s = with(s, Variable::LowCover, Some(0.9));
        let (layers, _) = mapped(&s);
        assert!(layers[LayerSlot::Convective].coverage > sparse);
        // The storm takes the convective rain; the rest falls from the low layer.
        assert_eq!(layers[LayerSlot::Convective].rain_mm_per_h, 1.0);
        assert!((layers[LayerSlot::Low].rain_mm_per_h - 0.5).abs() < 1e-6);
        assert_eq!(layers[LayerSlot::Mid].rain_mm_per_h, 0.0);
    }

    #[test]
    fn convective_cloud_base_and_top_are_placed_above_ground() {
        let s = with(fair(), Variable::ConvectiveCloudBase, Some(1_840.0));
        let s = with(s, Variable::ConvectiveCloudTop, Some(11_540.0));
        let s = with(s, Variable::ConvectivePrecipitation, Some(3.0));
        let s = with(s, Variable::Precipitation, Some(3.0));
        let (layers, _) = mapped(&s);
        let cb = &layers[LayerSlot::Convective];
        assert_eq!((cb.base_m, cb.top_m), (1_300.0, 11_000.0));
        let cu = &layers[LayerSlot::Low];
        assert_eq!(cu.kind, CloudKind::Cumulus);
        assert_eq!(cu.base_m, 1_300.0);
        assert_eq!(cu.top_m, 1_300.0 + 3_000.0, "capped at the deepest cumulus");
    }

    #[test]
    fn fog_probability_adds_fog() {
        let (layers, _) = mapped(&with(fair(), Variable::FogProbability, Some(0.9)));
        let fog = &layers[LayerSlot::Fog];
        assert!(fog.is_visible());
        assert!((fog.coverage - 0.875).abs() < 1e-6, "{}", fog.coverage);
        assert_eq!(fog.kind, CloudKind::Stratus);
        assert_eq!(fog.base_m, 0.0);
        assert_eq!(fog.top_m, 150.0);
        // Low probabilities are no fog.
        let (layers, _) = mapped(&with(fair(), Variable::FogProbability, Some(0.15)));
        assert!(!layers[LayerSlot::Fog].is_visible());
    }

    #[test]
    fn low_visibility_adds_fog_with_koschmieder_density() {
        let s = with(fair(), Variable::FogProbability, None);
        let s = with(s, Variable::Visibility, Some(300.0));
        let (layers, _) = mapped(&s);
        let fog = &layers[LayerSlot::Fog];
        assert_eq!(fog.coverage, 1.0);
        assert!((fog.density - 3.912 / 300.0).abs() < 1e-6);
        // Mist: partial fog, density capped at the fog threshold's.
        let (layers, _) = mapped(&with(s, Variable::Visibility, Some(3_000.0)));
        let mist = &layers[LayerSlot::Fog];
        assert!((mist.coverage - 0.5).abs() < 1e-6, "{}", mist.coverage);
        assert!((mist.density - 3.912 / 1_000.0).abs() < 1e-6);
        // Clear air: none.
        let (layers, _) = mapped(&with(s, Variable::Visibility, Some(20_000.0)));
        assert!(!layers[LayerSlot::Fog].is_visible());
        // The same low visibility in heavy rain is mostly the rain's doing.
        let wet = with(
            with(s, Variable::Visibility, Some(1_000.0)),
            Variable::Precipitation,
            Some(8.0),
        );
        assert!(mapped(&wet).0[LayerSlot::Fog].coverage < 0.1);
    }

    #[test]
    fn fog_pictocodes_add_fog() {
        for code in [16, 17, 18] {
            let mut s = fair();
            s.pictocode = Some(code);
            let (layers, _) = mapped(&s);
            assert!(layers[LayerSlot::Fog].coverage >= 0.8, "pictocode {code}");
            assert_eq!(layers[LayerSlot::Low].kind, CloudKind::Stratus);
        }
        let mut wmo = fair();
        wmo.pictocode = None;
        wmo.wmo_weather_code = Some(48);
        assert!(mapped(&wmo).0[LayerSlot::Fog].coverage >= 0.8);
    }

    #[test]
    fn precipitation_darkens_monotonically_and_sets_rain() {
        let m = WeatherMapping::default();
        assert_eq!(m.precipitation_darkening(0.0), 0.0);
        assert_eq!(m.precipitation_darkening(-1.0), 0.0);
        assert_eq!(m.precipitation_darkening(f32::NAN), 0.0);
        assert!((m.precipitation_darkening(2.5) - (1.0 - (-1.0f32).exp())).abs() < 1e-6);
        let mut last = 0.0;
        for i in 1..=80 {
            let d = m.precipitation_darkening(i as f32 * 0.25);
            assert!(d > last && d <= 1.0, "{i}: {d}");
            last = d;
        }
        assert_eq!(m.precipitation_darkening(f32::INFINITY), 1.0);
        // Tiny rates stay accurate (expm1 form).
        assert!((m.precipitation_darkening(1e-6) - 4e-7).abs() < 1e-12);

        let (dry, _) = mapped(&fair());
        for (slot, layer) in dry.iter() {
            assert_eq!(layer.precipitation, 0.0, "{slot}");
            assert_eq!(layer.rain_mm_per_h, 0.0, "{slot}");
        }
        let wet = with(fair(), Variable::Precipitation, Some(2.0));
        let (layers, _) = mapped(&wet);
        let expected = m.precipitation_darkening(2.0);
        for slot in [
            LayerSlot::Fog,
            LayerSlot::Low,
            LayerSlot::Mid,
            LayerSlot::Convective,
        ] {
            assert_eq!(layers[slot].precipitation, expected, "{slot}");
        }
        assert_eq!(layers[LayerSlot::High].precipitation, 0.0);
        assert_eq!(layers[LayerSlot::Low].rain_mm_per_h, 2.0);
        // No low cloud: the rain falls from the mid layer.
        let (layers, _) = mapped(&with(wet, Variable::LowCover, Some(0.0)));
        assert_eq!(layers[LayerSlot::Low].rain_mm_per_h, 0.0);
        assert_eq!(layers[LayerSlot::Mid].rain_mm_per_h, 2.0);
    }

    #[test]
    fn raining_altostratus_thickens_downward() {
        let s = with(fair(), Variable::MidCover, Some(0.9));
        let dry = mapped(&s).0[LayerSlot::Mid].clone();
        let wet = mapped(&with(s, Variable::Precipitation, Some(6.0))).0[LayerSlot::Mid].clone();
        assert_eq!(dry.kind, CloudKind::Altostratus);
        assert_eq!(wet.top_m, dry.top_m);
        assert!(wet.base_m < dry.base_m - 500.0);
        assert!(wet.base_m >= CloudBands::METEOBLUE.mid.bottom_m);
    }

    #[test]
    fn northerly_winds_either_side_of_north() {
        for from in [350.0, 10.0, 0.0] {
            let s = with(fair(), Variable::WindDirection, Some(from));
            let s = with(s, Variable::WindSpeed, Some(10.0));
            let (layers, _) = mapped(&s);
            for (slot, layer) in layers.iter() {
                let [east, north] = layer.wind_m_s;
                // A north wind blows toward the south.
                assert!(north < -9.0, "{from}° {slot}: {:?}", layer.wind_m_s);
                assert!(east.abs() < 0.2 * north.abs(), "{from}° {slot}");
                if from == 350.0 {
                    assert!(east > 0.0, "from NNW toward SSE");
                }
                if from == 10.0 {
                    assert!(east < 0.0, "from NNE toward SSW");
                }
            }
        }
    }

    #[test]
    fn surface_wind_grows_with_height_by_the_power_law() {
        let s = with(fair(), Variable::WindDirection, Some(180.0));
        let s = with(s, Variable::WindSpeed, Some(5.0));
        let (layers, _) = mapped(&s);
        let speed = |slot: LayerSlot| layers[slot].wind_m_s[1];
        let expected = |slot: LayerSlot| {
            let l = &layers[slot];
            5.0 * (0.5 * (l.base_m + l.top_m) / 10.0).powf(1.0 / 7.0)
        };
        for slot in [
            LayerSlot::Fog,
            LayerSlot::Low,
            LayerSlot::Mid,
            LayerSlot::High,
        ] {
            assert!((speed(slot) - expected(slot)).abs() < 1e-4, "{slot}");
        }
        assert!(speed(LayerSlot::Fog) < speed(LayerSlot::Low));
        assert!(speed(LayerSlot::Low) < speed(LayerSlot::Mid));
        assert!(speed(LayerSlot::Mid) < speed(LayerSlot::High));
    }

    #[test]
    fn pressure_level_wind_is_used_when_present() {
        let mut s = fair(); // 4 m/s west wind at the surface
        set_level(&mut s, level(850.0, 12.0, 180.0, Some(1_540.0)));
        set_level(&mut s, level(700.0, 20.0, 0.0, Some(3_040.0)));
        set_level(&mut s, level(500.0, 30.0, 0.0, None)); // standard 5 574 m
        set_level(&mut s, level(300.0, 40.0, 90.0, Some(9_540.0)));
        let (layers, warnings) = mapped(&s);
        assert!(warnings.is_empty(), "{warnings:?}");
        let close =
            |a: [f32; 2], b: [f32; 2]| (a[0] - b[0]).abs() < 1e-4 && (a[1] - b[1]).abs() < 1e-4;
        // Low: the 850 hPa wind from the south.
        assert!(close(layers[LayerSlot::Low].wind_m_s, [0.0, 12.0]));
        // High: 300 hPa from the east.
        assert!(close(layers[LayerSlot::High].wind_m_s, [-40.0, 0.0]));
        // Mid: between 700 hPa (2 500 m above Bern) and 500 hPa (5 034 m), by height.
        let mid = &layers[LayerSlot::Mid];
        let z = 0.5 * (mid.base_m + mid.top_m);
        let t = (z - 2_500.0) / (5_574.0 - BERN_M - 2_500.0);
        assert!(
            close(mid.wind_m_s, [0.0, -(20.0 + 10.0 * t)]),
            "{:?}",
            mid.wind_m_s
        );
        // Convective: the mean of the four levels.
        let cb = layers[LayerSlot::Convective].wind_m_s;
        assert!(close(cb, [-10.0, (12.0 - 20.0 - 30.0) / 4.0]), "{cb:?}");
        // Fog stays with the surface wind.
        assert!(layers[LayerSlot::Fog].wind_m_s[0] > 4.0);

        // Only 300 hPa present: the others fall back to the surface wind, no warning.
        let mut sparse = fair();
        set_level(&mut sparse, level(300.0, 40.0, 90.0, None));
        let (layers, warnings) = mapped(&sparse);
        assert!(warnings.is_empty());
        assert!(layers[LayerSlot::Low].wind_m_s[0] > 4.0);
        assert!(close(layers[LayerSlot::High].wind_m_s, [-40.0, 0.0]));
    }

    #[test]
    fn levels_below_a_mountain_site_are_ignored() {
        let mut s = fair();
        set_level(&mut s, level(850.0, 30.0, 0.0, Some(1_500.0)));
        let mut layers = WeatherLayers::new();
        WeatherMapping::default()
            .map(&s, 3_000.0)
            .apply_all(&mut layers);
        // The 850 hPa surface is underground at 3 000 m: surface wind (from the west) instead.
        assert!(layers[LayerSlot::Low].wind_m_s[0] > 4.0);
    }

    #[test]
    fn play_mode_layers_are_untouched() {
        let mut layers = WeatherLayers::new();
        let mut hand_made = CloudLayer::new(CloudKind::Cirrocumulus);
        hand_made.coverage = 0.33;
        hand_made.base_m = f32::NAN; // even garbage is the user's business
        hand_made.weather_driven = false;
        layers[LayerSlot::Low] = hand_made.clone();
        let mut stormy = with(fair(), Variable::LowCover, Some(1.0));
        stormy.pictocode = Some(30);
        let stormy = with(stormy, Variable::Precipitation, Some(20.0));
        map_weather(&stormy, BERN_M, &mut layers);
        let low = &layers[LayerSlot::Low];
        assert_eq!(low.kind, hand_made.kind);
        assert_eq!(low.coverage, 0.33);
        assert!(low.base_m.is_nan());
        assert_eq!(low.precipitation, 0.0);
        // The other slots are still driven.
        assert!(layers[LayerSlot::Convective].is_visible());
        // Back to weather-driven: the mapping takes over again.
        layers[LayerSlot::Low].weather_driven = true;
        map_weather(&stormy, BERN_M, &mut layers);
        assert_eq!(layers[LayerSlot::Low].coverage, 1.0);
        assert!(layers[LayerSlot::Low].base_m.is_finite());
    }

    #[test]
    fn shape_edits_survive_while_the_kind_stays() {
        let s = with(fair(), Variable::LowCover, Some(0.3));
        let mut layers = WeatherLayers::new();
        map_weather(&s, BERN_M, &mut layers);
        layers[LayerSlot::Low].density = 0.02;
        layers[LayerSlot::Low].skew = 0.7;
        map_weather(&with(s, Variable::LowCover, Some(0.4)), BERN_M, &mut layers);
        assert_eq!(layers[LayerSlot::Low].density, 0.02);
        assert_eq!(layers[LayerSlot::Low].skew, 0.7);
        // A new kind brings its own shape.
        map_weather(&with(s, Variable::LowCover, Some(0.8)), BERN_M, &mut layers);
        let low = &layers[LayerSlot::Low];
        assert_eq!(low.kind, CloudKind::Stratocumulus);
        assert_eq!(*low, {
            let mut expected = CloudLayer::new(CloudKind::Stratocumulus);
            expected.coverage = 0.8;
            expected.base_m = low.base_m;
            expected.top_m = low.top_m;
            expected.wind_m_s = low.wind_m_s;
            expected
        });
    }

    #[test]
    fn missing_covers_hold_previous_values_and_are_reported() {
        let mut layers = WeatherLayers::new();
        let s = with(fair(), Variable::LowCover, Some(0.7));
        let s = with(s, Variable::MidCover, Some(0.8));
        map_weather(&s, BERN_M, &mut layers);
        let before = layers.clone();
        let gap = with(with(s, Variable::LowCover, None), Variable::MidCover, None);
        let warnings = map_weather(&gap, BERN_M, &mut layers);
        assert_eq!(layers[LayerSlot::Low].coverage, 0.7);
        assert_eq!(layers[LayerSlot::Low].kind, before[LayerSlot::Low].kind);
        assert_eq!(layers[LayerSlot::Mid].coverage, 0.8);
        assert_eq!(layers[LayerSlot::Mid].kind, CloudKind::Altostratus);
        let inputs: Vec<_> = warnings.iter().map(|w| w.input).collect();
        assert_eq!(inputs, ["low_cover", "mid_cover"]);
        assert!(warnings.iter().all(|w| w.fault == InputFault::NoValue));
        assert!(
            warnings[0]
                .to_string()
                .starts_with("low_cover has no value: the low layer keeps")
        );

        // From scratch, a missing cover gives no layer at all, and says so.
        let (fresh, warnings) =
            layers_for_weather(&with(fair(), Variable::HighCover, None), BERN_M);
        assert!(fresh.iter().all(|l| !l.kind.is_cirrus_family()));
        assert_eq!(warnings.len(), 1);
        assert_eq!(warnings[0].input, "high_cover");
    }

    #[test]
    fn every_held_input_is_reported_once() {
        let mut layers = WeatherLayers::new();
        map_weather(&fair(), BERN_M, &mut layers);
        let before = layers.clone();
        let empty = WeatherState::empty(UtcInstant::from_unix_seconds(0));
        let warnings = map_weather(&empty, BERN_M, &mut layers);
        let inputs: Vec<_> = warnings.iter().map(|w| w.input).collect();
        assert_eq!(
            inputs,
            [
                "low_cover",
                "mid_cover",
                "high_cover",
                "precipitation",
                "convective_precipitation",
                "fog_probability",
                "wind_speed"
            ]
        );
        // Nothing was zeroed: coverage, darkening, rain and wind are as before.
        for (slot, layer) in layers.iter() {
            let old = &before[slot];
            assert_eq!(layer.coverage, old.coverage, "{slot}");
            assert_eq!(layer.wind_m_s, old.wind_m_s, "{slot}");
            assert_eq!(layer.precipitation, old.precipitation, "{slot}");
            assert_eq!(layer.rain_mm_per_h, old.rain_mm_per_h, "{slot}");
        }
    }

    #[test]
    fn nan_inputs_never_reach_the_layers() {
        let nan = f32::NAN;
        let mut s = state(&Variable::ALL.map(|v| (v, nan)));
        s.pictocode = Some(99);
        let mut bad = level(850.0, nan, 0.0, Some(nan));
        bad.wind_direction_deg = Some(f32::INFINITY);
        set_level(&mut s, bad);
        set_level(&mut s, level(300.0, 20.0, nan, None));
        let mut layers = WeatherLayers::new();
        let digested = WeatherMapping::default().map(&s, nan);
        digested.apply_all(&mut layers);
        assert_all_finite(&layers);
        let warnings = digested.warnings;
        assert!(warnings.iter().any(|w| w.input == "ground_elevation_m"));
        assert!(warnings.iter().any(|w| w.input == "pressure-level wind"));
        let low = warnings.iter().find(|w| w.input == "low_cover").unwrap();
        assert_eq!(low.fault, InputFault::NotFinite);
        assert!(low.to_string().contains("is not a finite number"));
        // Each input at most once.
        let mut inputs: Vec<_> = warnings.iter().map(|w| w.input).collect();
        let count = inputs.len();
        inputs.sort_unstable();
        inputs.dedup();
        assert_eq!(inputs.len(), count, "{warnings:?}");
        // NaN visibility next to a good fog probability: used the probability, reported.
        let s = with(fair(), Variable::Visibility, Some(nan));
        let s = with(s, Variable::FogProbability, Some(0.6));
        let (layers, warnings) = mapped(&s);
        assert!((layers[LayerSlot::Fog].coverage - 0.5).abs() < 1e-6);
        assert_eq!(warnings.len(), 1);
        assert_eq!(warnings[0].input, "visibility");
        assert_eq!(warnings[0].fault, InputFault::NotFinite);
        // Out-of-range values are clamped, not propagated.
        let wild = with(fair(), Variable::LowCover, Some(7.0));
        let wild = with(wild, Variable::Precipitation, Some(-3.0));
        let wild = with(wild, Variable::WindSpeed, Some(f32::MAX));
        let (layers, _) = mapped(&wild);
        assert_eq!(layers[LayerSlot::Low].coverage, 1.0);
        assert_eq!(layers[LayerSlot::Low].precipitation, 0.0);
        assert_all_finite(&layers);
        // Hand-set NaN fields of a weather-driven layer are repaired by the next mapping.
        let mut layers = WeatherLayers::new();
        layers[LayerSlot::Mid].skew = nan;
        layers[LayerSlot::Mid].coverage = nan;
        map_weather(&with(fair(), Variable::MidCover, None), BERN_M, &mut layers);
        assert_all_finite(&layers);
    }

    #[test]
    fn nonsense_mapping_settings_do_not_panic() {
        let mut m = WeatherMapping::default();
        m.bands.low = CloudBand {
            bottom_m: 5_000.0,
            top_m: 100.0,
        };
        m.bands.mid.bottom_m = f32::NAN;
        m.fog_probability_floor = 1.0;
        m.mist_visibility_m = 500.0;
        m.darkening_scale_mm_per_h = 0.0;
        m.thunderstorm_scale_mm_per_h = -1.0;
        m.wind_shear_exponent = f32::INFINITY;
        let mut s = with(fair(), Variable::Precipitation, Some(3.0));
        s = with(s, Variable::ConvectivePrecipitation, Some(3.0));
        s = with(s, Variable::Visibility, Some(400.0));
        let mut layers = WeatherLayers::new();
        m.map(&s, BERN_M).apply_all(&mut layers);
        assert_all_finite(&layers);
        assert_eq!(m.precipitation_darkening(1.0), 1.0);
    }

    #[test]
    fn the_bundled_bern_week_maps_to_plausible_layers() {
        use crate::weather::Forecast;
        let bern =
            Forecast::from_slice(include_bytes!("../../assets/weather/bern.json"), None).unwrap();
        let ground = bern.place.elevation_m as f32;
        let local = |day: u8, hour: u8| {
            UtcInstant::from_civil(2021, 5, day, hour, 0, 0)
                .unwrap()
                .saturating_add_seconds(-2 * 3600)
        };
        let layers_at = |day, hour| layers_for_weather(&bern.sample(local(day, hour)), ground);
        // Monday afternoon: cumulus.
        let (monday, _) = layers_at(3, 15);
        assert!(monday.iter().any(|l| l.kind == CloudKind::Cumulus));
        // Thursday morning: fog.
        let (thursday, _) = layers_at(6, 7);
        assert!(
            thursday
                .iter()
                .any(|l| l.base_m == 0.0 && l.coverage >= 0.8)
        );
        // Friday afternoon: a thunderstorm.
        let (friday, _) = layers_at(7, 16);
        assert!(friday.iter().any(|l| l.kind == CloudKind::Cumulonimbus));
        // Every hour of the week maps to finite layers.
        let mut all = WeatherLayers::new();
        let mut t = bern.times[0];
        while t <= bern.end().unwrap() {
            map_weather(&bern.sample(t), ground, &mut all);
            assert_all_finite(&all);
            t = t.saturating_add_seconds(1800);
        }
    }

    #[test]
    fn the_table_names_real_inputs_and_every_slot() {
        let extra = [
            "pictocode",
            "weather_code",
            "level_wind",
            "ground_elevation_m",
        ];
        for row in &MAPPING_TABLE {
            assert!(
                extra.contains(&row.input) || Variable::ALL.iter().any(|v| v.name() == row.input),
                "{}",
                row.input
            );
            assert!(!row.slots.is_empty() && !row.rule.is_empty());
        }
        for slot in LayerSlot::ALL {
            assert!(
                MAPPING_TABLE.iter().any(|row| row.slots.contains(&slot)),
                "{slot}"
            );
        }
        // The variables the mapping reads all have a row (wind direction rides with speed and
        // the convective top with the base).
        for variable in [
            Variable::LowCover,
            Variable::MidCover,
            Variable::HighCover,
            Variable::ConvectivePrecipitation,
            Variable::FogProbability,
            Variable::Visibility,
            Variable::Precipitation,
            Variable::WindSpeed,
            Variable::ConvectiveCloudBase,
        ] {
            assert!(
                MAPPING_TABLE.iter().any(|row| row.input == variable.name()),
                "{}",
                variable.name()
            );
        }
    }

    #[test]
    fn slots_and_layers() {
        let layers = WeatherLayers::default();
        assert_eq!(layers.visible().count(), 0, "nothing before a forecast");
        for (slot, layer) in layers.iter() {
            assert_eq!(layer.kind, slot.initial_kind());
            assert!(layer.weather_driven);
            assert_eq!(*layer, slot.initial_layer());
        }
        assert_eq!(LayerSlot::Convective.to_string(), "convective");
        let mut layers = layers;
        for (_, layer) in layers.iter_mut() {
            layer.coverage = 0.5;
        }
        assert_eq!(layers.visible().count(), LayerSlot::COUNT);
        let band = CloudBand {
            bottom_m: 10.0,
            top_m: 0.0,
        };
        assert!(band.clamp_base(5.0).is_finite());
        let mapped = WeatherMapping::default().map(&fair(), BERN_M);
        assert_eq!(mapped.ground_elevation_m(), BERN_M);
        assert_eq!(*mapped.mapping(), WeatherMapping::METEOBLUE);
    }
}
