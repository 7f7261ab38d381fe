//! Headless runs: time-lapse shots and waiting for the forecasts.

use super::*;

/// Each time-lapse image shows `--time` plus `--step` per image (`--live`: now).
pub(crate) fn follow_headless_shots(
    progress: Res<HeadlessProgress>,
    options: Res<BernOptions>,
    mut clock: ResMut<SceneClock>,
) {
    if options.live {
        // The scene time is the wall clock's, as the forecasts are.
        return;
    }
    let offset_s = options.step_s.saturating_mul(i64::from(progress.shot));
    let t = options.time.saturating_add_seconds(offset_s).unix_seconds() as f64;
    if clock.unix_seconds() != t {
        clock.set_unix_seconds(t);
    }
}

/// Holds the capture until the forecasts have loaded (or failed: then the frame shows what the
/// layers have, and the log says why).
pub(crate) fn wait_for_forecasts(
    mut progress: ResMut<HeadlessProgress>,
    source: Res<WeatherSource>,
    server: Res<AssetServer>,
    forecasts: Res<Assets<Forecast>>,
    #[cfg(feature = "live")] live: Res<bevy_cloudscape::weather::LiveForecasts>,
) {
    if progress.ready {
        return;
    }
    // A file has loaded or failed; a live forecast (`--live`) has arrived or failed once.
    let settled = |handle: &Handle<Forecast>| {
        #[cfg(feature = "live")]
        if live
            .status(handle)
            .is_some_and(|status| status.failures > 0)
        {
            return true;
        }
        forecasts.contains(handle.id())
            || matches!(
                server.load_state(handle.id()),
                LoadState::Loaded | LoadState::Failed(_)
            )
    };
    if source.near.iter().all(settled) && source.far.iter().all(|far| settled(&far.forecast)) {
        progress.ready = true;
    }
}

/// Headless images are each a moment of the forecast: the layers cut to the weather instead of
/// taking a transition's seconds of (real) time to get there. The mapping stays continuous in
/// scene time, so a time-lapse still has no pops.
pub(crate) fn cut_transitions(
    mut layers: Query<&mut bevy_cloudscape::layers::LayerTransition, Added<LayerSlot>>,
    mut haze: ResMut<bevy_cloudscape::layers::HazeTransition>,
) {
    for mut transition in &mut layers {
        transition.duration_s = 0.0;
    }
    if haze.duration_s != 0.0 {
        haze.duration_s = 0.0;
    }
}

/// A time-lapse image of growing clouds (`--growth`) waits until the automaton has caught up
/// with the scene time, so each image shows the clouds of its time, settled in the temporal
/// accumulation.
pub(crate) fn wait_for_growth(
    mut progress: ResMut<HeadlessProgress>,
    runs: Query<&bevy_cloudscape::render::growth::GrowthRun>,
) {
    if runs.iter().any(|run| !run.is_idle()) {
        progress.ready = false;
    }
}
