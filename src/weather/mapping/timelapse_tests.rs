#![allow(clippy::needless_range_loop)] // Slots and values are indexed together.
//! A week of forecast played at 3600×: the layers change smoothly through every forecast step.

use std::time::Duration;

use bevy::prelude::*;

use super::{LayerSlot, map_weather_onto_layers};
use crate::layers::{CloudLayer, LayerTransition, run_transitions};
use crate::scene::{Place, UtcInstant};
use crate::weather::{CurrentWeather, Forecast, ForecastSteps, PlaceWeather, Sampler};

/// 60 frames a second at 3600×: a minute of forecast a frame.
const FRAME_S: f64 = 1.0 / 60.0;
const SPEED: f64 = 3600.0;

/// The values the issue bounds: coverage, density (1/m), base and top (m).
fn watched(layer: &CloudLayer) -> [f32; 4] {
    [layer.coverage, layer.density, layer.base_m, layer.top_m]
}
const NAMES: [&str; 4] = ["coverage", "density", "base_m", "top_m"];

struct Run {
    /// Per frame: the scene time, and per slot the layer's and the target's watched values.
    frames: Vec<(f64, Vec<[f32; 4]>, Vec<[f32; 4]>)>,
}

/// Plays the bundled Bern week. `smooth` uses the crate as shipped; without it the layers are
/// written directly from the state interpolated at the scene time (no transition, no blending
/// of forecast steps), as a reference for what a step looks like.
fn play_week(smooth: bool) -> Run {
    let bern =
        Forecast::from_slice(include_bytes!("../../../assets/weather/bern.json"), None).unwrap();
    let mut app = App::new();
    app.init_resource::<CurrentWeather>()
        .init_resource::<Assets<Forecast>>()
        .init_resource::<Time>()
        .add_systems(Update, (map_weather_onto_layers, run_transitions).chain());
    let entities: Vec<Entity> = LayerSlot::ALL
        .iter()
        .map(|&slot| {
            let mut entity = app.world_mut().spawn((slot, slot.initial_layer()));
            if smooth {
                entity.insert(LayerTransition::new(slot.initial_layer()));
            }
            entity.id()
        })
        .collect();
    let place = Place {
        name: "Bern".into(),
        latitude_deg: bern.place.latitude_deg,
        longitude_deg: bern.place.longitude_deg,
        elevation_m: bern.place.elevation_m,
    };
    let start = bern.times[0].unix_seconds() as f64;
    let end = bern.end().unwrap().unix_seconds() as f64;
    let mut sampler = Sampler::new();
    let mut frames = Vec::new();
    let mut t = start;
    while t <= end {
        app.world_mut().resource_mut::<CurrentWeather>().near = Some(PlaceWeather {
            place: place.clone(),
            scene_position: Vec3::ZERO,
            state: sampler.sample_unix_seconds(&bern, t),
            steps: if smooth {
                ForecastSteps::around(&bern, t)
            } else {
                None
            },
        });
        app.world_mut()
            .resource_mut::<Time>()
            .advance_by(Duration::from_secs_f64(FRAME_S));
        app.update();
        let world = app.world();
        let layers = entities
            .iter()
            .map(|e| watched(world.get::<CloudLayer>(*e).unwrap()))
            .collect();
        let targets = entities
            .iter()
            .map(|e| {
                world.get::<LayerTransition>(*e).map_or_else(
                    || watched(world.get::<CloudLayer>(*e).unwrap()),
                    |t| watched(&t.target),
                )
            })
            .collect();
        frames.push((t, layers, targets));
        t += FRAME_S * SPEED;
    }
    Run { frames }
}

/// The largest per-frame change of each slot's watched values, with the scene time of the frame.
fn largest_changes(run: &Run, of_target: bool) -> Vec<[(f32, f64); 4]> {
    let mut out = vec![[(0.0f32, 0.0f64); 4]; LayerSlot::COUNT];
    for pair in run.frames.windows(2) {
        let (t, now, target_now) = &pair[1];
        let (_, before, target_before) = &pair[0];
        let (now, before) = if of_target {
            (target_now, target_before)
        } else {
            (now, before)
        };
        for slot in 0..LayerSlot::COUNT {
            for v in 0..4 {
                let change = (now[slot][v] - before[slot][v]).abs();
                if change > out[slot][v].0 {
                    out[slot][v] = (change, *t);
                }
            }
        }
    }
    out
}

#[test]
fn a_week_at_3600x_changes_no_faster_than_the_forecast_and_never_steps_at_the_hour() {
    let smooth = play_week(true);
    let instant = play_week(false);
    let hour_frames = (3600.0 / (FRAME_S * SPEED)).round() as usize;

    // 1. The targets are linear ramps between the forecast steps: in a step of N frames no
    //    frame changes a value by more than 1/(N − 1) of the change from that step's first frame
    //    to the next step's. A value that jumped at the hour would change by the whole
    //    difference in one frame.
    let starts: Vec<usize> = (0..smooth.frames.len())
        .filter(|&i| (smooth.frames[i].0 - smooth.frames[0].0).rem_euclid(3600.0) == 0.0)
        .collect();
    for pair in starts.windows(2) {
        let (a, b) = (pair[0], pair[1]);
        for slot in 0..LayerSlot::COUNT {
            for v in 0..4 {
                let across = (smooth.frames[b].2[slot][v] - smooth.frames[a].2[slot][v]).abs();
                let bound = across / (hour_frames - 1) as f32;
                for i in a + 1..=b {
                    let change =
                        (smooth.frames[i].2[slot][v] - smooth.frames[i - 1].2[slot][v]).abs();
                    let slack = 1e-5 * smooth.frames[i].2[slot][v].abs().max(1e-3);
                    assert!(
                        change <= bound + slack,
                        "{} {}: target moved {change} in one frame at {}, its hour moved {across}",
                        LayerSlot::ALL[slot],
                        NAMES[v],
                        smooth.frames[i].0
                    );
                }
            }
        }
    }

    // 2. The layers never move faster than their targets (the spring's impulse response is
    //    positive with unit integral).
    let layer_max = largest_changes(&smooth, false);
    let target_max = largest_changes(&smooth, true);
    let instant_max = largest_changes(&instant, false);
    let mut stepped = false;
    for slot in 0..LayerSlot::COUNT {
        for v in 0..4 {
            let (layer, at) = layer_max[slot][v];
            let (target, _) = target_max[slot][v];
            let (jump, jump_at) = instant_max[slot][v];
            println!(
                "{:>10} {:>8}: largest change per frame {layer:.6} at {} (target {target:.6}); \
                 written at once: {jump:.6} at {}",
                LayerSlot::ALL[slot].name(),
                NAMES[v],
                UtcInstant::from_unix_seconds(at as i64),
                UtcInstant::from_unix_seconds(jump_at as i64),
            );
            let slack = 1e-5 * target.max(1e-3);
            assert!(
                layer <= target + slack,
                "{} {}: {layer} > {target}",
                LayerSlot::ALL[slot],
                NAMES[v]
            );
            stepped |= jump > 4.0 * target.max(1e-6);
        }
    }
    // Written at once, the same week does step: the test can see one.
    assert!(stepped, "the reference run should show a step at some hour");
}
