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
//! per slot (or several, or none). In the ECS, a [`CloudLayer`] entity with a [`LayerSlot`]
//! component follows the forecast; without one it is left untouched and its values are the
//! user's ("play" mode). [`map_weather`] and [`layers_for_weather`] are one-call shortcuts.
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
//! | `lightning_potential` (Open-Meteo, ICON models) | Convective: present | a cumulonimbus layer appears at ≥ 1 J/kg, its coverage as above | the index is the potential for charge separation in a convective cloud (Yair et al. 2010): a storm that flashes; it is a potential, not a flash rate, so it decides only whether the storm is there |
//! | `pictocode` / WMO `weather_code` | Convective, Fog, Low: kind | thunder 10–12, 27–30 (WMO 95–99) → cumulonimbus; fog 16–18 (WMO 45, 48) → fog coverage ≥ 0.8 and stratus; showers 31–32 (WMO 80–86) → cumulus; steady precipitation 23–26, 33–35 (WMO 51–77) → stratus | the codes say what the model's variables only imply (meteoblue's pictocode table, docs.meteoblue.com) |
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
//!
//! [`WeatherState`]: crate::weather::WeatherState
//! [`CloudLayer`]: crate::layers::CloudLayer
//! [`CloudKind::defaults`]: crate::layers::CloudKind::defaults

mod band;
mod inputs;
mod mapped;
mod rules;
mod slot;
mod systems;
mod table;
mod warning;
mod weather_layers;

use crate::weather::STANDARD_LEVELS_HPA;

pub use band::{CloudBand, CloudBands};
pub use mapped::MappedWeather;
pub use rules::WeatherMapping;
pub use slot::LayerSlot;
pub(crate) use systems::map_weather_onto_layers;
pub use table::{MAPPING_TABLE, MappingRow};
pub use warning::{InputFault, MappingWarning};
pub use weather_layers::{WeatherLayers, layers_for_weather, map_weather, spawn_weather_layers};

/// Heights of [`STANDARD_LEVELS_HPA`] (850, 700, 500, 300 hPa) in the ICAO standard atmosphere,
/// metres above sea level (ICAO Doc 7488). The mapping uses them when the forecast has a level's
/// wind but not its geopotential height.
pub const STANDARD_LEVEL_HEIGHTS_M: [f32; STANDARD_LEVELS_HPA.len()] =
    [1_457.0, 3_012.0, 5_574.0, 9_164.0];

pub use crate::layers::KOSCHMIEDER_CONSTANT;

#[cfg(test)]
mod tests;
#[cfg(test)]
mod timelapse_tests;
