//! [`WeatherLayers`], one layer per slot, and the one-call shortcuts that fill them.

use std::ops::{Index, IndexMut};

use bevy::prelude::*;

use super::{LayerSlot, MappingWarning, WeatherMapping};
use crate::layers::{CloudLayer, LayerTransition};
use crate::weather::WeatherState;

/// One [`CloudLayer`] per [`LayerSlot`], indexable by slot: `layers[LayerSlot::Low].coverage`.
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
    /// Every slot at its [`LayerSlot::initial_layer`]: coverage 0.
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
/// Missing inputs keep previous values. `ground_elevation_m` is the ground above sea level, metres.
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
/// weather to fill, with a [`LayerTransition`] (default duration) that the weather and the
/// presets drive. Returns the entities in [`LayerSlot::ALL`] order.
pub fn spawn_weather_layers(commands: &mut Commands) -> Vec<Entity> {
    LayerSlot::ALL
        .iter()
        .map(|&slot| {
            commands
                .spawn((
                    Name::new(format!("cloud layer: {slot}")),
                    slot,
                    slot.initial_layer(),
                    LayerTransition::new(slot.initial_layer()),
                ))
                .id()
        })
        .collect()
}
