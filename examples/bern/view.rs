//! Switching views, flying, the clock keys and the help overlay.

use super::*;

/// Whether an egui widget has the keyboard (then the scene's keys stay quiet).
#[derive(Resource, Default, PartialEq)]
pub(crate) struct UiCapturesKeyboard(pub(crate) bool);

pub(crate) fn view_keys(
    keys: Res<ButtonInput<KeyCode>>,
    captured: Res<UiCapturesKeyboard>,
    mut view: ResMut<ViewState>,
) {
    if captured.0 {
        return;
    }
    let mut next = *view;
    if keys.just_pressed(KeyCode::Digit1) {
        next = ViewState::on(Viewpoint::Gurten);
    }
    if keys.just_pressed(KeyCode::Digit2) {
        next = ViewState::on(Viewpoint::Bantiger);
    }
    if keys.just_pressed(KeyCode::KeyF) {
        next.free = !next.free;
    }
    view.set_if_neq(next);
}

/// Puts the camera on its summit (or hands it to the free-fly controller) and swaps the far
/// forecast, whenever the view changes.
pub(crate) fn apply_view(
    mut commands: Commands,
    view: Res<ViewState>,
    terrain: Res<Terrain>,
    far: Res<FarForecasts>,
    mut source: ResMut<WeatherSource>,
    mut cameras: Query<(Entity, &mut Transform, Option<&mut VolumetricClouds>), With<MainCamera>>,
) {
    if !view.is_changed() {
        return;
    }
    let index = Viewpoint::ALL
        .iter()
        .position(|v| *v == view.viewpoint)
        .unwrap_or(0);
    source.far = vec![FarForecast {
        forecast: far.0[index].clone(),
    }];
    for (camera, mut transform, clouds) in &mut cameras {
        // Another viewpoint (or the free camera's start) is a camera cut: the clouds'
        // temporal accumulation starts over instead of fading the old view out.
        if let Some(mut clouds) = clouds {
            clouds.reset_history = true;
        }
        if view.free {
            // Metres per second: the scene is 100 km across.
            commands.entity(camera).insert(FreeCamera {
                walk_speed: 100.0,
                run_speed: 1500.0,
                ..default()
            });
        } else {
            // Removing the state too makes the controller start from the new pose next time.
            commands
                .entity(camera)
                .remove::<(FreeCamera, FreeCameraState)>();
            *transform = viewpoint_transform(&view, &terrain);
        }
    }
}

pub(crate) fn clock_keys(
    keys: Res<ButtonInput<KeyCode>>,
    captured: Res<UiCapturesKeyboard>,
    mut clock: ResMut<SceneClock>,
) {
    if captured.0 {
        return;
    }
    if keys.just_pressed(KeyCode::Space) {
        if clock.mode == ClockMode::WallClock {
            // Pausing the wall clock means holding the current instant.
            let now = clock.unix_seconds();
            clock.set_unix_seconds(now);
            clock.paused = true;
        } else {
            clock.paused = !clock.paused;
        }
    }
    let faster = keys.any_just_pressed([KeyCode::Equal, KeyCode::NumpadAdd]);
    let slower = keys.any_just_pressed([KeyCode::Minus, KeyCode::NumpadSubtract]);
    if faster || slower {
        let current = CLOCK_SPEEDS
            .iter()
            .position(|s| *s >= clock.speed)
            .unwrap_or(CLOCK_SPEEDS.len() - 1);
        let next = if faster {
            (current + 1).min(CLOCK_SPEEDS.len() - 1)
        } else {
            current.saturating_sub(1)
        };
        clock.speed = CLOCK_SPEEDS[next];
    }
    for (key, hours) in [(KeyCode::ArrowLeft, -1.0), (KeyCode::ArrowRight, 1.0)] {
        if keys.just_pressed(key) {
            let t = clock.unix_seconds() + hours * 3600.0;
            clock.set_unix_seconds(t);
        }
    }
}

/// The near forecast, once loaded.
pub(crate) fn near_forecast<'a>(
    source: &WeatherSource,
    forecasts: &'a Assets<Forecast>,
) -> Option<&'a Forecast> {
    source.near.as_ref().and_then(|h| forecasts.get(h))
}

/// The scene time in the forecast's local time and in UTC, e.g.
/// `2021-05-03 16:00 CEST (14:00 UTC)`.
pub(crate) fn time_label(unix_seconds: f64, forecast: Option<&Forecast>) -> String {
    let instant = UtcInstant::from_unix_seconds(unix_seconds.floor() as i64);
    let utc = instant.to_civil();
    let Some(forecast) = forecast.filter(|f| f.utc_offset_s != 0) else {
        return format!(
            "{:04}-{:02}-{:02} {:02}:{:02} UTC",
            utc.year, utc.month, utc.day, utc.hour, utc.minute
        );
    };
    let local = instant
        .saturating_add_seconds(i64::from(forecast.utc_offset_s))
        .to_civil();
    let zone = forecast
        .timezone_abbreviation
        .clone()
        .unwrap_or_else(|| format!("UTC{:+}", f64::from(forecast.utc_offset_s) / 3600.0));
    format!(
        "{:04}-{:02}-{:02} {:02}:{:02} {zone} ({:02}:{:02} UTC)",
        local.year, local.month, local.day, local.hour, local.minute, utc.hour, utc.minute
    )
}

/// One line of what a forecast says now: cover per band, precipitation, wind.
pub(crate) fn weather_label(state: &WeatherState) -> String {
    let percent = |v: Option<f32>| v.map_or("-".into(), |v| format!("{:.0}%", v * 100.0));
    let number = |v: Option<f32>, digits: usize| v.map_or("-".into(), |v| format!("{v:.digits$}"));
    format!(
        "low {} mid {} high {}, rain {} mm/h, wind {} m/s from {} deg",
        percent(state.low_cover()),
        percent(state.mid_cover()),
        percent(state.high_cover()),
        number(state.precipitation_mm_per_h(), 1),
        number(state.wind_speed_m_s(), 1),
        number(state.wind_direction_deg(), 0),
    )
}

pub(crate) fn clock_label(clock: &SceneClock) -> String {
    match clock.mode {
        ClockMode::WallClock => "live (wall clock)".into(),
        ClockMode::Manual if clock.paused => "paused".into(),
        ClockMode::Manual => format!("x{}", clock.speed),
    }
}
