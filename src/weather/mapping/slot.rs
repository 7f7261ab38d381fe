//! [`LayerSlot`]: the named layers the mapping fills.

use std::fmt;

use bevy::prelude::*;

use super::{KOSCHMIEDER_CONSTANT, WeatherMapping};
use crate::layers::{CloudKind, CloudLayer, DensityProfile};

/// The named layers the mapping fills (Thomann 2021 §4.2: "Layers of Cloud Shaders").
///
/// As a component beside a [`CloudLayer`], it tells the crate's mapping system which slot the
/// entity is; see [`spawn_weather_layers`].
///
/// [`spawn_weather_layers`]: super::spawn_weather_layers
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
