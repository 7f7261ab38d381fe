//! The Bevy system that writes the near place's weather onto the slotted layers.

use bevy::platform::collections::HashMap;
use bevy::prelude::*;

use super::inputs::Inputs;
use super::{LayerSlot, MappedWeather, WeatherMapping};
use crate::layers::{CloudLayer, FarCoverage, Haze, HazeTransition, LayerTransition};
use crate::scene::UtcInstant;
use crate::weather::preset::ActivePreset;

/// Writes the near place's [`CurrentWeather`](crate::weather::CurrentWeather) onto every
/// [`CloudLayer`] with a [`LayerSlot`], when the weather changed, a slot was inserted or a
/// preset ended. While an [`ActivePreset`] exists the preset drives the slots and the haze, and
/// this writes nothing. A layer with a
/// [`LayerTransition`] gets the weather as its target (the first one as a cut, so a scene starts
/// with its clouds); any other is written directly. Between two forecast steps the layers mapped
/// at each step are blended ([`CloudLayer::lerp`]), so no threshold or weather code of the
/// mapping makes a layer step at the hour. Layers are only written when their values change, so
/// change detection stays meaningful; mapping warnings are logged when they change, not every
/// frame.
pub(crate) fn map_weather_onto_layers(
    current: Res<crate::weather::CurrentWeather>,
    mapping: Option<Res<WeatherMapping>>,
    forecasts: Res<Assets<crate::weather::Forecast>>,
    source: Option<Res<crate::weather::WeatherSource>>,
    mut layers: Query<(
        Entity,
        &LayerSlot,
        &mut CloudLayer,
        Option<&mut LayerTransition>,
    )>,
    new_slots: Query<Entity, Added<LayerSlot>>,
    preset: Option<Res<ActivePreset>>,
    haze: Option<ResMut<Haze>>,
    haze_transition: Option<ResMut<HazeTransition>>,
    mut last_warnings: Local<Vec<String>>,
    mut steps_mapped: Local<HashMap<Entity, StepLayers>>,
    mut preset_was_active: Local<bool>,
) {
    let preset_ended = std::mem::replace(&mut *preset_was_active, preset.is_some());
    if preset.is_some() {
        // Mapped again from the preset's layers when it ends.
        steps_mapped.clear();
        return;
    }
    // A slot inserted again (the end of "play" mode) is mapped from the layer as it is now.
    for entity in &new_slots {
        steps_mapped.remove(&entity);
    }
    if mapping.as_ref().is_some_and(|m| m.is_changed()) {
        steps_mapped.clear();
    } else if !current.is_changed() && !preset_ended && new_slots.is_empty() {
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
    let elevation = near.place.elevation_m as f32;
    let mapped = rules.map(&near.state, elevation);
    let steps = near.steps.as_ref().map(|steps| {
        (
            rules.map(&steps.before, elevation),
            rules.map(&steps.after, elevation),
            steps.fraction,
            (steps.before.time, steps.after.time),
        )
    });
    if let Some(visibility) = mapped.haze_visibility_m() {
        set_haze(haze, haze_transition, visibility);
    }
    // Far places: their own mapping, of which only the coverage is used (Thomann 2021 §4.5: the
    // distant weather shows on the horizon toward its place). Heights are above each place's
    // own ground.
    let far: Vec<(&crate::weather::PlaceWeather, MappedWeather)> = current
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
    steps_mapped.retain(|entity, _| layers.contains(*entity));
    for (entity, slot, mut layer, transition) in &mut layers {
        let previous = transition.as_ref().map_or(&*layer, |t| &t.target);
        let mut updated = match &steps {
            Some((before, after, fraction, key)) => {
                // Both steps are mapped once, when the scene time enters the step, from the
                // layer as it was then: the mapping keeps a kind's shape from the layer it
                // writes, so mapping onto a blend every frame would feed the blend back.
                // Keyed by the steps' mapped inputs too, so a reloaded forecast is mapped again.
                let key = (*key, before.inputs, after.inputs);
                let mapped = steps_mapped
                    .entry(entity)
                    .and_modify(|cached| {
                        if cached.key != key {
                            *cached = StepLayers::new(key, previous, *slot, before, after);
                        }
                    })
                    .or_insert_with(|| StepLayers::new(key, previous, *slot, before, after));
                mapped.before.lerp(&mapped.after, *fraction)
            }
            None => {
                let mut updated = previous.clone();
                mapped.apply(*slot, &mut updated);
                updated
            }
        };
        updated.far_coverage = far
            .iter()
            .map(|(place, mapped_far)| {
                // Applied to a copy of the near layer: an input the far file lacks keeps the
                // near value, so a missing far cover means "no change", never 0.
                let mut there = updated.clone();
                mapped_far.apply(*slot, &mut there);
                FarCoverage {
                    from_m: east_north(near.scene_position),
                    to_m: east_north(place.scene_position),
                    coverage: there.coverage,
                }
            })
            .collect();
        match transition {
            Some(mut transition) => {
                if transition.target != updated {
                    transition.target = updated;
                }
                if !transition.has_weather {
                    transition.has_weather = true;
                    let mut cut = layer.clone();
                    transition.cut(&mut cut);
                    *layer = cut;
                }
            }
            None => {
                if updated != *layer {
                    *layer = updated;
                }
            }
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

/// The forecast steps' instants and what the mapping read at each.
type StepKey = ((UtcInstant, UtcInstant), Inputs, Inputs);

/// The layers one slot gets at the two forecast steps around the scene time.
pub(crate) struct StepLayers {
    key: StepKey,
    before: CloudLayer,
    after: CloudLayer,
}

impl StepLayers {
    fn new(
        key: StepKey,
        previous: &CloudLayer,
        slot: LayerSlot,
        before: &MappedWeather,
        after: &MappedWeather,
    ) -> Self {
        let mut at_before = previous.clone();
        before.apply(slot, &mut at_before);
        let mut at_after = at_before.clone();
        after.apply(slot, &mut at_after);
        Self {
            key,
            before: at_before,
            after: at_after,
        }
    }
}

/// Sets the weather's visibility on the haze: as the [`HazeTransition`]'s target when there is
/// one (the first as a cut), else on the [`Haze`] itself; nothing when the haze is not
/// weather-driven.
fn set_haze(
    haze: Option<ResMut<Haze>>,
    transition: Option<ResMut<HazeTransition>>,
    visibility_m: f32,
) {
    let Some(mut haze) = haze else {
        return;
    };
    match transition {
        Some(mut transition) => {
            let first = transition.target.is_none();
            let mut target = transition.target.clone().unwrap_or_else(|| haze.clone());
            if !target.weather_driven || target.visibility_m == visibility_m {
                return;
            }
            target.visibility_m = visibility_m;
            if first {
                *haze = target.clone();
            }
            transition.target = Some(target);
        }
        None => {
            if haze.weather_driven && haze.visibility_m != visibility_m {
                haze.visibility_m = visibility_m;
            }
        }
    }
}
