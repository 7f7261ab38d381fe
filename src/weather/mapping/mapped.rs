//! [`MappedWeather`]: a digested state, and the rules that write each slot's layer.

use super::inputs::{Inputs, LEVELS_HIGH, LEVELS_LOW, LEVELS_MID, LevelWind, saturate};
use super::{
    CloudBand, KOSCHMIEDER_CONSTANT, LayerSlot, MappingWarning, WeatherLayers, WeatherMapping,
};
use crate::layers::{CloudKind, CloudLayer};

/// A forecast state digested by [`WeatherMapping::map`], ready to write layers with
/// [`MappedWeather::apply`]. It holds no references, so one map per frame can write any number
/// of layers.
#[derive(Clone, Debug, PartialEq)]
pub struct MappedWeather {
    pub(super) mapping: WeatherMapping,
    pub(super) inputs: Inputs,
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
    /// [module docs](super)). The layer is cleaned with [`CloudLayer::sanitize`] at the end,
    /// so no NaN reaches it, even from a hand-set NaN field. It allocates only when the kind
    /// changes (the new kind's profile).
    pub fn apply(&self, slot: LayerSlot, layer: &mut CloudLayer) {
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
