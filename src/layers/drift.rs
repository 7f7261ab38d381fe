//! How far the wind has carried each layer's clouds: scene data that the renderer reads.

use bevy::prelude::*;

use super::CloudLayer;
use crate::scene::SceneClock;

/// Horizontal distance the wind has carried a layer's clouds since start-up, metres, as
/// `[east, north]` in f64 so a week of wind keeps millimetre precision. Added to every
/// [`CloudLayer`] automatically; advanced with the [`SceneClock`], so the clouds move at the
/// scene's speed (1×, 60×, 3600×).
#[derive(Component, Debug, Clone, Copy, Default, PartialEq, Reflect)]
#[reflect(Component, Default)]
pub struct LayerDrift {
    /// Distance travelled, `[east, north]`, metres.
    pub offset_m: [f64; 2],
}

/// Scene-time jumps longer than this (scrubbing the clock) do not move the clouds: a cloud field
/// blown for a day is no more "right" than the one shown.
const MAX_DRIFT_STEP_S: f64 = 3_600.0;

pub(crate) fn drift_cloud_layers(
    mut commands: Commands,
    clock: Res<SceneClock>,
    mut last_time: Local<Option<f64>>,
    mut layers: Query<(Entity, &CloudLayer, Option<&mut LayerDrift>)>,
) {
    let now = clock.unix_seconds();
    let dt = last_time.map_or(0.0, |last| now - last);
    *last_time = Some(now);
    let dt = if dt.abs() <= MAX_DRIFT_STEP_S {
        dt
    } else {
        0.0
    };
    for (entity, layer, drift) in &mut layers {
        let Some(mut drift) = drift else {
            commands.entity(entity).insert(LayerDrift::default());
            continue;
        };
        let [east, north] = layer
            .wind_m_s
            .map(|v| if v.is_finite() { f64::from(v) } else { 0.0 });
        if dt != 0.0 && (east != 0.0 || north != 0.0) {
            drift.offset_m[0] += east * dt;
            drift.offset_m[1] += north * dt;
        }
    }
}
