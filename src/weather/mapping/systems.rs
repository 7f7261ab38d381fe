//! The Bevy system that writes the near place's weather onto the slotted layers.

use bevy::prelude::*;

use super::{LayerSlot, MappedWeather, WeatherMapping};
use crate::layers::{CloudLayer, FarCoverage};

/// Writes the near place's [`CurrentWeather`](crate::weather::CurrentWeather) onto every weather-driven
/// [`CloudLayer`] with a [`LayerSlot`], when the weather changed. Layers are only written when
/// their values change, so change detection stays meaningful; mapping warnings are logged when
/// they change, not every frame.
pub(crate) fn map_weather_onto_layers(
    current: Res<crate::weather::CurrentWeather>,
    mapping: Option<Res<WeatherMapping>>,
    forecasts: Res<Assets<crate::weather::Forecast>>,
    source: Option<Res<crate::weather::WeatherSource>>,
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
