//! Weather presets: named skies (sparse, fair-weather cumulus, cloudy, overcast, stormy, foggy)
//! as constants and as `.preset.json` assets, applied to the slotted layers through their
//! [`LayerTransition`]s so that picking one, or another halfway, is a smooth change.
//!
//! A preset file lists layers by slot; anything a layer leaves out is its kind's default
//! ([`CloudKind::defaults`]). Slots the preset does not list clear (coverage 0).
//!
//! ```json
//! {
//!   "name": "stormy",
//!   "visibility_m": 6000,
//!   "layers": [
//!     { "slot": "low", "kind": "stratocumulus", "coverage": 0.8, "precipitation": 0.6 },
//!     { "slot": "convective", "kind": "cumulonimbus", "coverage": 0.5, "rain_mm_per_h": 8 }
//!   ]
//! }
//! ```
//!
//! A file that cannot be read (bad JSON, an unknown key, a value out of range) fails to load
//! with an error naming the file and the key (`layers[1].coverage: 1.5 is outside 0–1`); the
//! preset last applied stays.

use std::borrow::Cow;
use std::fmt;

use bevy::{
    asset::{AssetLoadFailedEvent, AssetLoader, AssetPath, LoadContext, io::Reader},
    platform::collections::HashMap,
    prelude::*,
};
use serde_json::Value;

use super::mapping::{KOSCHMIEDER_CONSTANT, LayerSlot};
use crate::layers::{CloudKind, CloudLayer, Haze, HazeTransition, LayerTransition};

/// One layer of a [`CloudPreset`]: a slot, a kind, and the values that differ from the kind's
/// defaults (`None` keeps the default).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct PresetLayer {
    /// The slot the layer fills.
    pub slot: LayerSlot,
    /// The genus; its [`CloudKind::defaults`] fill whatever is `None`.
    pub kind: CloudKind,
    /// Fraction of the sky covered, 0–1.
    pub coverage: Option<f32>,
    /// Extinction coefficient of the densest cloud, 1/m (≥ 0).
    pub density: Option<f32>,
    /// Cloud base, metres above the ground.
    pub base_m: Option<f32>,
    /// Cloud top, metres above the ground (above the base).
    pub top_m: Option<f32>,
    /// Wind carrying the layer, `[east, north]` m/s. `None` keeps the layer's wind.
    pub wind_m_s: Option<[f32; 2]>,
    /// Darkening by precipitation, 0–1. Default 0.
    pub precipitation: Option<f32>,
    /// Rain from the layer's base, mm/h (≥ 0). Default 0.
    pub rain_mm_per_h: Option<f32>,
}

impl PresetLayer {
    /// A layer of `kind` in `slot` with the kind's defaults.
    #[must_use]
    pub const fn new(slot: LayerSlot, kind: CloudKind) -> Self {
        Self {
            slot,
            kind,
            coverage: None,
            density: None,
            base_m: None,
            top_m: None,
            wind_m_s: None,
            precipitation: None,
            rain_mm_per_h: None,
        }
    }

    /// The same layer with `coverage` (0–1).
    #[must_use]
    pub const fn coverage(mut self, coverage: f32) -> Self {
        self.coverage = Some(coverage);
        self
    }

    /// The same layer with base and top, metres above the ground.
    #[must_use]
    pub const fn between(mut self, base_m: f32, top_m: f32) -> Self {
        self.base_m = Some(base_m);
        self.top_m = Some(top_m);
        self
    }

    /// The same layer with precipitation darkening (0–1) and rain (mm/h).
    #[must_use]
    pub const fn raining(mut self, precipitation: f32, rain_mm_per_h: f32) -> Self {
        self.precipitation = Some(precipitation);
        self.rain_mm_per_h = Some(rain_mm_per_h);
        self
    }

    /// The same layer with density (extinction, 1/m).
    #[must_use]
    pub const fn density(mut self, density: f32) -> Self {
        self.density = Some(density);
        self
    }

    /// The layer this entry makes from `current` (whose wind it keeps unless it sets one).
    /// The fog slot starts from its fog profile ([`LayerSlot::initial_layer`]).
    #[must_use]
    pub fn layer(&self, current: &CloudLayer) -> CloudLayer {
        let mut layer = if self.slot == LayerSlot::Fog {
            let mut fog = self.slot.initial_layer();
            fog.kind = self.kind;
            fog
        } else {
            CloudLayer::new(self.kind)
        };
        let defaults = (layer.base_m, layer.top_m);
        layer.coverage = self.coverage.unwrap_or(self.kind.defaults().coverage);
        if let Some(density) = self.density {
            layer.density = density;
        }
        layer.base_m = self.base_m.unwrap_or(defaults.0);
        layer.top_m = self.top_m.unwrap_or(defaults.1);
        layer.wind_m_s = self.wind_m_s.unwrap_or(current.wind_m_s);
        layer.precipitation = self.precipitation.unwrap_or(0.0);
        layer.rain_mm_per_h = self.rain_mm_per_h.unwrap_or(0.0);
        layer.sanitized()
    }
}

/// A named sky: layers by slot plus the haze's visibility. Apply it with [`ActivePreset`], or
/// by hand with [`CloudPreset::target_for`]. Load files with [`PresetLoader`]
/// (`*.preset.json`, hot-reloaded when Bevy's `file_watcher` feature is on).
#[derive(Asset, TypePath, Clone, Debug, PartialEq)]
pub struct CloudPreset {
    /// A short name, e.g. `"stormy"`.
    pub name: Cow<'static, str>,
    /// The layers, at most one per slot. Slots not listed clear.
    pub layers: Cow<'static, [PresetLayer]>,
    /// Meteorological visibility of the haze, metres; `None` is clear air. Default `None`.
    pub visibility_m: Option<f32>,
}

impl CloudPreset {
    /// A few small cumulus and a trace of cirrus; 40 km visibility.
    pub const SPARSE: Self = Self {
        name: Cow::Borrowed("sparse"),
        layers: Cow::Borrowed(&[
            PresetLayer::new(LayerSlot::Low, CloudKind::Cumulus).coverage(0.15),
            PresetLayer::new(LayerSlot::High, CloudKind::Cirrus).coverage(0.2),
        ]),
        visibility_m: Some(40_000.0),
    };

    /// Fair-weather cumulus: scattered heaps, 30 km visibility.
    pub const FAIR_WEATHER: Self = Self {
        name: Cow::Borrowed("fair weather"),
        layers: Cow::Borrowed(&[
            PresetLayer::new(LayerSlot::Low, CloudKind::Cumulus).coverage(0.4),
            PresetLayer::new(LayerSlot::High, CloudKind::Cirrus).coverage(0.1),
        ]),
        visibility_m: Some(30_000.0),
    };

    /// Broken stratocumulus under altocumulus and a cirrus veil; 20 km visibility.
    pub const CLOUDY: Self = Self {
        name: Cow::Borrowed("cloudy"),
        layers: Cow::Borrowed(&[
            PresetLayer::new(LayerSlot::Low, CloudKind::Stratocumulus).coverage(0.75),
            PresetLayer::new(LayerSlot::Mid, CloudKind::Altocumulus).coverage(0.4),
            PresetLayer::new(LayerSlot::High, CloudKind::Cirrostratus).coverage(0.5),
        ]),
        visibility_m: Some(20_000.0),
    };

    /// A closed grey deck: stratus under altostratus, a little drizzle; 10 km visibility.
    pub const OVERCAST: Self = Self {
        name: Cow::Borrowed("overcast"),
        layers: Cow::Borrowed(&[
            PresetLayer::new(LayerSlot::Low, CloudKind::Stratus)
                .coverage(0.95)
                .raining(0.3, 0.3),
            PresetLayer::new(LayerSlot::Mid, CloudKind::Altostratus).coverage(0.9),
        ]),
        visibility_m: Some(10_000.0),
    };

    /// A thunderstorm: cumulonimbus with heavy rain, dark stratocumulus and altostratus;
    /// 6 km visibility.
    pub const STORMY: Self = Self {
        name: Cow::Borrowed("stormy"),
        layers: Cow::Borrowed(&[
            PresetLayer::new(LayerSlot::Low, CloudKind::Stratocumulus)
                .coverage(0.8)
                .raining(0.6, 2.0),
            PresetLayer::new(LayerSlot::Mid, CloudKind::Altostratus)
                .coverage(0.6)
                .raining(0.6, 0.0),
            PresetLayer::new(LayerSlot::Convective, CloudKind::Cumulonimbus)
                .coverage(0.5)
                .raining(0.8, 8.0),
        ]),
        visibility_m: Some(6_000.0),
    };

    /// Ground fog of 200 m visibility, 150 m deep, under thin stratus; the haze at the mist
    /// limit (5 km), the fog layer carrying the rest.
    pub const FOGGY: Self = Self {
        name: Cow::Borrowed("foggy"),
        layers: Cow::Borrowed(&[
            PresetLayer::new(LayerSlot::Fog, CloudKind::Stratus)
                .coverage(1.0)
                .between(0.0, 150.0)
                .density(KOSCHMIEDER_CONSTANT / 200.0),
            PresetLayer::new(LayerSlot::Low, CloudKind::Stratus).coverage(0.5),
        ]),
        visibility_m: Some(5_000.0),
    };

    /// Every built-in preset, from clear to foggy.
    pub const ALL: [Self; 6] = [
        Self::SPARSE,
        Self::FAIR_WEATHER,
        Self::CLOUDY,
        Self::OVERCAST,
        Self::STORMY,
        Self::FOGGY,
    ];

    /// The layer `slot` should move to, from its `current` target: the preset's layer for that
    /// slot, or `current` cleared (coverage 0, rain 0) when the preset has none. Either way
    /// the layer is no longer weather-driven.
    #[must_use]
    pub fn target_for(&self, slot: LayerSlot, current: &CloudLayer) -> CloudLayer {
        match self.layers.iter().find(|l| l.slot == slot) {
            Some(entry) => entry.layer(current),
            None => CloudLayer {
                coverage: 0.0,
                precipitation: 0.0,
                rain_mm_per_h: 0.0,
                ..current.clone()
            },
        }
    }

    /// The haze this preset moves `current` to: its visibility (∞ for `None`), the rest kept.
    #[must_use]
    pub fn haze(&self, current: &Haze) -> Haze {
        Haze {
            visibility_m: self.visibility_m.unwrap_or(f32::INFINITY),
            ..current.clone()
        }
    }

    /// Reads a preset from JSON (the format in the [module docs](self)). Errors name the key.
    ///
    /// # Errors
    ///
    /// [`PresetError`] for JSON that does not parse, a missing or unknown key, a value of the
    /// wrong type or out of range, or a slot listed twice.
    pub fn from_json(bytes: &[u8]) -> Result<Self, PresetError> {
        let value: Value = serde_json::from_slice(bytes).map_err(|e| PresetError {
            key: String::new(),
            message: e.to_string(),
        })?;
        parse_preset(&value)
    }
}

/// Why a preset file cannot be used: the key (`layers[1].coverage`, empty for the file as a
/// whole) and what is wrong with it.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
pub struct PresetError {
    /// The JSON key, as a path: `visibility_m`, `layers[0].kind`. Empty for a syntax error.
    pub key: String,
    /// What is wrong.
    pub message: String,
}

impl fmt::Display for PresetError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        if self.key.is_empty() {
            write!(f, "{}", self.message)
        } else {
            write!(f, "{}: {}", self.key, self.message)
        }
    }
}

fn error(key: impl Into<String>, message: impl Into<String>) -> PresetError {
    PresetError {
        key: key.into(),
        message: message.into(),
    }
}

fn parse_preset(value: &Value) -> Result<CloudPreset, PresetError> {
    let object = value
        .as_object()
        .ok_or_else(|| error("", "a preset is a JSON object"))?;
    for key in object.keys() {
        if !["name", "visibility_m", "layers"].contains(&key.as_str()) {
            return Err(error(
                key.clone(),
                "unknown key (name, visibility_m, layers)",
            ));
        }
    }
    let name = match object.get("name") {
        None => String::new(),
        Some(Value::String(name)) => name.clone(),
        Some(_) => return Err(error("name", "expected a string")),
    };
    let visibility_m = match object.get("visibility_m") {
        None | Some(Value::Null) => None,
        Some(v) => Some(number(v, "visibility_m", |x| x > 0.0, "above 0 m")?),
    };
    let layers = match object.get("layers") {
        None => Vec::new(),
        Some(Value::Array(layers)) => layers
            .iter()
            .enumerate()
            .map(|(i, layer)| parse_layer(layer, &format!("layers[{i}]")))
            .collect::<Result<Vec<_>, _>>()?,
        Some(_) => return Err(error("layers", "expected an array of layers")),
    };
    for (i, layer) in layers.iter().enumerate() {
        if layers[..i].iter().any(|l| l.slot == layer.slot) {
            return Err(error(
                format!("layers[{i}].slot"),
                format!("slot {} is listed twice", layer.slot),
            ));
        }
    }
    Ok(CloudPreset {
        name: Cow::Owned(name),
        layers: Cow::Owned(layers),
        visibility_m,
    })
}

fn number(
    value: &Value,
    key: &str,
    valid: impl Fn(f32) -> bool,
    range: &str,
) -> Result<f32, PresetError> {
    let x = value
        .as_f64()
        .ok_or_else(|| error(key, format!("expected a number, found {value}")))? as f32;
    if x.is_finite() && valid(x) {
        Ok(x)
    } else {
        Err(error(key, format!("{value} is outside {range}")))
    }
}

fn parse_layer(value: &Value, at: &str) -> Result<PresetLayer, PresetError> {
    let object = value
        .as_object()
        .ok_or_else(|| error(at, "a layer is a JSON object"))?;
    let key = |k: &str| format!("{at}.{k}");
    let name_of = |k: &str| -> Result<String, PresetError> {
        match object.get(k) {
            Some(Value::String(s)) => Ok(s.clone()),
            Some(_) => Err(error(key(k), "expected a string")),
            None => Err(error(key(k), "missing")),
        }
    };
    let slot_name = name_of("slot")?;
    let slot = LayerSlot::ALL
        .into_iter()
        .find(|s| s.name() == slot_name)
        .ok_or_else(|| {
            error(
                key("slot"),
                format!("unknown slot {slot_name:?} (fog, low, mid, high, convective)"),
            )
        })?;
    let kind_name = name_of("kind")?;
    let kind = CloudKind::ALL
        .into_iter()
        .find(|k| k.name().eq_ignore_ascii_case(&kind_name))
        .ok_or_else(|| error(key("kind"), format!("unknown cloud kind {kind_name:?}")))?;
    let mut layer = PresetLayer::new(slot, kind);
    let unit = |x: f32| (0.0..=1.0).contains(&x);
    let non_negative = |x: f32| x >= 0.0;
    let any = |_: f32| true;
    for (k, v) in object {
        let k = k.as_str();
        match k {
            "slot" | "kind" => {}
            "coverage" => layer.coverage = Some(number(v, &key(k), unit, "0–1")?),
            "density" => layer.density = Some(number(v, &key(k), non_negative, "0 1/m and up")?),
            "base_m" => layer.base_m = Some(number(v, &key(k), any, "finite metres")?),
            "top_m" => layer.top_m = Some(number(v, &key(k), any, "finite metres")?),
            "precipitation" => layer.precipitation = Some(number(v, &key(k), unit, "0–1")?),
            "rain_mm_per_h" => {
                layer.rain_mm_per_h = Some(number(v, &key(k), non_negative, "0 mm/h and up")?);
            }
            "wind_m_s" => {
                let pair = v
                    .as_array()
                    .filter(|a| a.len() == 2)
                    .ok_or_else(|| error(key(k), "expected [east, north] in m/s"))?;
                layer.wind_m_s = Some([
                    number(&pair[0], &format!("{at}.wind_m_s[0]"), any, "finite m/s")?,
                    number(&pair[1], &format!("{at}.wind_m_s[1]"), any, "finite m/s")?,
                ]);
            }
            _ => {
                return Err(error(
                    key(k),
                    "unknown key (slot, kind, coverage, density, base_m, top_m, wind_m_s, \
                     precipitation, rain_mm_per_h)",
                ));
            }
        }
    }
    let defaults = kind.defaults();
    let (base, top) = (
        layer.base_m.unwrap_or(defaults.base_m),
        layer.top_m.unwrap_or(defaults.top_m),
    );
    if top <= base {
        return Err(error(
            key("top_m"),
            format!("the top ({top} m) must be above the base ({base} m)"),
        ));
    }
    Ok(layer)
}

/// Reads `*.preset.json` files into [`CloudPreset`] assets.
#[derive(Debug, Default, Clone, Copy, TypePath)]
pub struct PresetLoader;

/// A preset file that cannot be loaded: the file and the [`PresetError`].
#[derive(Debug, thiserror::Error)]
#[error("{error}")]
pub struct PresetFileError {
    /// The file, as the asset server names it.
    pub file: String,
    /// What is wrong, and where.
    pub error: PresetError,
}

impl AssetLoader for PresetLoader {
    type Asset = CloudPreset;
    type Settings = ();
    type Error = PresetFileError;

    async fn load(
        &self,
        reader: &mut dyn Reader,
        _settings: &(),
        load_context: &mut LoadContext<'_>,
    ) -> Result<CloudPreset, PresetFileError> {
        let file = load_context.path().to_string();
        let mut bytes = Vec::new();
        if let Err(e) = reader.read_to_end(&mut bytes).await {
            return Err(PresetFileError {
                file,
                error: error("", e.to_string()),
            });
        }
        let mut preset =
            CloudPreset::from_json(&bytes).map_err(|error| PresetFileError { file, error })?;
        if preset.name.is_empty() {
            let stem = load_context.path().path().file_stem();
            let stem = stem
                .map(|s| s.to_string_lossy().into_owned())
                .unwrap_or_default();
            preset.name = Cow::Owned(stem.trim_end_matches(".preset").to_owned());
        }
        Ok(preset)
    }

    fn extensions(&self) -> &[&str] {
        &["preset.json"]
    }
}

/// The preset the slotted layers follow. While this resource exists, the layers with a
/// [`LayerSlot`] and a [`LayerTransition`] move to the preset's layers, and the haze to its
/// visibility, over [`ActivePreset::duration_s`]; the forecast no longer drives them. Changing
/// the handle, the duration, or the file itself (hot reload) starts a new transition from
/// wherever the layers are. To give the sky back to the forecast, remove the resource: the
/// weather mapping moves the layers and the haze back over their durations.
#[derive(Resource, Clone, Debug)]
pub struct ActivePreset {
    /// The preset: a file from the asset server, or a constant added with
    /// `assets.add(CloudPreset::STORMY)`.
    pub preset: Handle<CloudPreset>,
    /// Seconds the change takes ([`LayerTransition::duration_s`]); 0 cuts. Default
    /// [`crate::layers::DEFAULT_TRANSITION_S`].
    pub duration_s: f32,
}

impl ActivePreset {
    /// Follow `preset` with the default transition.
    #[must_use]
    pub fn new(preset: Handle<CloudPreset>) -> Self {
        Self {
            preset,
            duration_s: crate::layers::DEFAULT_TRANSITION_S,
        }
    }
}

/// Moves the slotted layers and the haze to the [`ActivePreset`] when it, or its asset,
/// changes.
pub(crate) fn apply_active_preset(
    active: Option<Res<ActivePreset>>,
    presets: Res<Assets<CloudPreset>>,
    mut events: MessageReader<AssetEvent<CloudPreset>>,
    mut layers: Query<(&LayerSlot, &mut LayerTransition)>,
    haze: Option<Res<Haze>>,
    mut haze_transition: Option<ResMut<HazeTransition>>,
    mut applied: Local<Option<(AssetId<CloudPreset>, f32)>>,
) {
    let Some(active) = active else {
        events.clear();
        *applied = None;
        return;
    };
    let id = active.preset.id();
    // Read every event (not just up to the first match), so none is left for the next frame.
    let reloaded = events
        .read()
        .filter(|event| {
            matches!(event, AssetEvent::Modified { id: e } | AssetEvent::Added { id: e } if *e == id)
        })
        .count()
        > 0;
    let key = (id, active.duration_s);
    if !reloaded && *applied == Some(key) {
        return;
    }
    let Some(preset) = presets.get(id) else {
        return;
    };
    *applied = Some(key);
    for (slot, mut transition) in &mut layers {
        transition.duration_s = active.duration_s;
        transition.target = preset.target_for(*slot, &transition.target);
    }
    if let Some(transition) = haze_transition.as_mut() {
        let current = transition
            .target
            .clone()
            .or_else(|| haze.as_deref().cloned())
            .unwrap_or_default();
        transition.duration_s = active.duration_s;
        transition.target = Some(preset.haze(&current));
    }
}

/// Logs preset files that failed to load or reload, once per edit, naming the file and key; the
/// preset last applied stays.
pub(crate) fn report_failed_presets(
    mut failures: MessageReader<AssetLoadFailedEvent<CloudPreset>>,
    mut loaded: MessageReader<AssetEvent<CloudPreset>>,
    server: Res<AssetServer>,
    mut reported: Local<HashMap<AssetPath<'static>, String>>,
) {
    let _ = super::source::report_load_failures::<CloudPreset, PresetFileError>(
        "preset",
        "preset",
        &mut failures,
        &mut loaded,
        &server,
        &mut reported,
    );
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn every_builtin_preset_is_valid_and_distinct() {
        for (i, preset) in CloudPreset::ALL.iter().enumerate() {
            assert!(!preset.name.is_empty());
            for layer in preset.layers.iter() {
                let made = layer.layer(&CloudLayer::default());
                assert_eq!(made, made.sanitized(), "{}", preset.name);
                assert!(made.is_visible(), "{}: {:?}", preset.name, layer.slot);
            }
            for other in &CloudPreset::ALL[..i] {
                assert_ne!(preset.layers, other.layers);
            }
        }
        let stormy = CloudPreset::STORMY;
        let cb = stormy.target_for(LayerSlot::Convective, &CloudLayer::default());
        assert_eq!(cb.kind, CloudKind::Cumulonimbus);
        assert!(cb.rain_mm_per_h > 0.0 && cb.coverage > 0.0);
        let fog = CloudPreset::FOGGY.target_for(LayerSlot::Fog, &LayerSlot::Fog.initial_layer());
        assert_eq!((fog.base_m, fog.top_m), (0.0, 150.0));
        // A slot the preset leaves out clears, keeping its shape (so it fades, not pops).
        let high = CloudLayer::new(CloudKind::Cirrus);
        let cleared = stormy.target_for(LayerSlot::High, &high);
        assert_eq!(cleared.coverage, 0.0);
        assert_eq!((cleared.base_m, cleared.kind), (high.base_m, high.kind));
    }

    #[test]
    fn a_preset_file_reads_back_as_the_constant() {
        let json = br#"{
            "name": "stormy",
            "visibility_m": 6000,
            "layers": [
                { "slot": "low", "kind": "stratocumulus", "coverage": 0.8,
                  "precipitation": 0.6, "rain_mm_per_h": 2 },
                { "slot": "mid", "kind": "altostratus", "coverage": 0.6,
                  "precipitation": 0.6, "rain_mm_per_h": 0 },
                { "slot": "convective", "kind": "Cumulonimbus", "coverage": 0.5,
                  "precipitation": 0.8, "rain_mm_per_h": 8 }
            ]
        }"#;
        assert_eq!(CloudPreset::from_json(json).unwrap(), CloudPreset::STORMY);
    }

    #[test]
    fn a_broken_preset_names_the_key() {
        let cases: [(&str, &str); 8] = [
            (
                r#"{"layers": [{"slot": "low", "kind": "cumulus", "coverage": 1.5}]}"#,
                "layers[0].coverage",
            ),
            (
                r#"{"layers": [{"slot": "low", "kind": "cumulus"},
                            {"slot": "low", "kind": "stratus"}]}"#,
                "layers[1].slot",
            ),
            (
                r#"{"layers": [{"slot": "attic", "kind": "cumulus"}]}"#,
                "layers[0].slot",
            ),
            (
                r#"{"layers": [{"slot": "low", "kind": "nimbus"}]}"#,
                "layers[0].kind",
            ),
            (
                r#"{"layers": [{"slot": "low", "kind": "cumulus", "cover": 0.5}]}"#,
                "layers[0].cover",
            ),
            (
                r#"{"layers": [{"slot": "low", "kind": "cumulus", "base_m": 900, "top_m": 800}]}"#,
                "layers[0].top_m",
            ),
            (r#"{"visibility_m": -3}"#, "visibility_m"),
            (
                r#"{"layers": [{"slot": "low", "kind": "cumulus", "wind_m_s": [1, "x"]}]}"#,
                "layers[0].wind_m_s[1]",
            ),
        ];
        for (json, key) in cases {
            let error = CloudPreset::from_json(json.as_bytes()).unwrap_err();
            assert_eq!(error.key, key, "{json}: {error}");
            assert!(error.to_string().starts_with(key));
        }
        let syntax = CloudPreset::from_json(b"{ \"layers\": [").unwrap_err();
        assert!(
            syntax.key.is_empty() && syntax.to_string().contains("line"),
            "{syntax}"
        );
    }

    #[test]
    fn one_warning_per_broken_edit() {
        use bevy::asset::{AssetLoadError, AssetPlugin};
        #[derive(Resource, Default)]
        struct Given(Vec<String>);
        fn record(
            mut failures: MessageReader<AssetLoadFailedEvent<CloudPreset>>,
            mut loaded: MessageReader<AssetEvent<CloudPreset>>,
            server: Res<AssetServer>,
            mut reported: Local<HashMap<AssetPath<'static>, String>>,
            mut given: ResMut<Given>,
        ) {
            given.0.extend(super::super::source::report_load_failures::<
                CloudPreset,
                PresetFileError,
            >(
                "preset",
                "preset",
                &mut failures,
                &mut loaded,
                &server,
                &mut reported,
            ));
        }
        let mut app = App::new();
        app.add_plugins((MinimalPlugins, AssetPlugin::default()))
            .init_asset::<CloudPreset>()
            .init_resource::<Given>()
            .add_systems(Update, record);
        let failure = |extension: &str| AssetLoadFailedEvent::<CloudPreset> {
            id: AssetId::default(),
            path: AssetPath::from("sky.preset.json").into_owned(),
            error: AssetLoadError::MissingAssetLoader {
                asset_type_id: None,
                asset_path: extension.to_owned(),
            },
        };
        // The watcher reports one edit twice: one warning.
        app.world_mut().write_message(failure("a"));
        app.world_mut().write_message(failure("a"));
        app.update();
        app.world_mut().write_message(failure("a"));
        app.update();
        assert_eq!(app.world().resource::<Given>().0.len(), 1);
        let warning = &app.world().resource::<Given>().0[0];
        assert!(warning.contains("sky.preset.json"), "{warning}");
        // A different fault is news.
        app.world_mut().write_message(failure("b"));
        app.update();
        assert_eq!(app.world().resource::<Given>().0.len(), 2);
    }
}
