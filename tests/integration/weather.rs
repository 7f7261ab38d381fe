//! Forecast files as hot-reloading assets, sampled into `CurrentWeather` in a running app.

use std::{
    path::{Path, PathBuf},
    time::{Duration, Instant},
};

use bevy::{asset::AssetPlugin, prelude::*};
use bevy_cloudscape::prelude::*;

/// A folder of its own under `target/`, so parallel runs don't share files.
fn scratch_assets(name: &str) -> PathBuf {
    let dir = Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("target/test-assets")
        .join(format!("{name}-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    dir
}

/// A headless app with the cloud plugins, reading assets from `dir` and watching it for
/// changes, with `extra` added before it is finished.
fn watching_app(dir: &Path, extra: impl FnOnce(&mut App)) -> App {
    let mut app = App::new();
    app.add_plugins((
        MinimalPlugins,
        AssetPlugin {
            file_path: dir.to_string_lossy().into_owned(),
            watch_for_changes_override: Some(true),
            ..default()
        },
        CloudscapePlugin,
    ));
    extra(&mut app);
    app.finish();
    app.cleanup();
    app
}

/// The bundled Bern forecast with every `lowclouds` value replaced by `percent`.
fn bern_with_low_clouds(percent: f64) -> String {
    let text = include_str!("../../assets/weather/bern.json");
    let mut json: serde_json::Value = serde_json::from_str(text).unwrap();
    let low = json["data_1h"]["lowclouds"].as_array_mut().unwrap();
    for value in low.iter_mut() {
        *value = serde_json::json!(percent);
    }
    json.to_string()
}

/// Coverage of the weather-driven low layer entity.
fn low_layer_coverage(app: &mut App) -> f32 {
    let mut layers = app.world_mut().query::<(&LayerSlot, &CloudLayer)>();
    layers
        .iter(app.world())
        .find(|(slot, _)| **slot == LayerSlot::Low)
        .map(|(_, layer)| layer.coverage)
        .expect("low layer spawned")
}

/// The near place's low cloud cover in `CurrentWeather`, once sampled.
pub(crate) fn low_cover(app: &App) -> Option<f32> {
    app.world()
        .resource::<CurrentWeather>()
        .near
        .as_ref()
        .and_then(|near| near.state.low_cover())
}

/// Updates the app until `done`; fails once `limit` passes without it.
pub(crate) fn update_until(app: &mut App, limit: Duration, mut done: impl FnMut(&App) -> bool) {
    let start = Instant::now();
    while !done(app) {
        assert!(start.elapsed() < limit, "not reached within {limit:?}");
        app.update();
        std::thread::sleep(Duration::from_millis(20));
    }
}

#[test]
fn replacing_a_forecast_file_updates_the_weather_and_bad_files_keep_the_last_good() {
    let dir = scratch_assets("hot-reload");
    let file = dir.join("bern.json");
    std::fs::write(&file, bern_with_low_clouds(20.0)).unwrap();

    let mut app = watching_app(&dir, |app| {
        app.insert_resource(SceneClock::at("2021-05-04T10:00:00Z".parse().unwrap()));
    });
    let source = WeatherSource::load(app.world().resource::<AssetServer>(), "bern.json", []);
    app.insert_resource(source);
    for slot in LayerSlot::ALL {
        app.world_mut().spawn((slot, slot.initial_layer()));
    }

    update_until(&mut app, Duration::from_secs(20), |app| {
        low_cover(app).is_some()
    });
    assert_eq!(low_cover(&app), Some(0.2));
    app.update();
    assert_eq!(
        low_layer_coverage(&mut app),
        0.2,
        "the mapping drives the low layer"
    );

    // The file watcher needs a moment to start watching before a change is seen.
    std::thread::sleep(Duration::from_millis(500));
    std::fs::write(&file, bern_with_low_clouds(70.0)).unwrap();
    // The 10 s limit only guards against a reload that never comes: the latency itself is the
    // file watcher's debounce plus a frame, and a wall-clock bound here would measure the
    // machine's load (tests run in parallel), not the reload.
    update_until(&mut app, Duration::from_secs(10), |app| {
        low_cover(app) == Some(0.7)
    });
    app.update();
    assert_eq!(low_layer_coverage(&mut app), 0.7);

    // A broken file is reported and the last good forecast stays in use.
    std::fs::write(&file, "{ \"metadata\": ").unwrap();
    let start = Instant::now();
    while start.elapsed() < Duration::from_millis(1500) {
        app.update();
        std::thread::sleep(Duration::from_millis(20));
    }
    assert_eq!(low_cover(&app), Some(0.7), "last good data kept");
    assert_eq!(low_layer_coverage(&mut app), 0.7);
    let _ = std::fs::remove_dir_all(&dir);
}

/// The failures of preset files, as the asset server reports them.
#[derive(Resource, Default)]
struct PresetFailures(Vec<String>);

fn record_preset_failures(
    mut failures: MessageReader<bevy::asset::AssetLoadFailedEvent<CloudPreset>>,
    mut seen: ResMut<PresetFailures>,
) {
    for failure in failures.read() {
        seen.0.push(format!("{}: {}", failure.path, failure.error));
    }
}

#[test]
fn a_preset_file_drives_the_layers_and_a_broken_edit_keeps_the_last_good() {
    let dir = scratch_assets("preset");
    let file = dir.join("sky.preset.json");
    let sky = |coverage: &str| {
        format!(
            r#"{{"visibility_m": 12000,
                "layers": [{{"slot": "low", "kind": "stratocumulus", "coverage": {coverage}}}]}}"#
        )
    };
    std::fs::write(&file, sky("0.3")).unwrap();

    let mut app = watching_app(&dir, |app| {
        app.init_resource::<PresetFailures>()
            .add_systems(Update, record_preset_failures);
    });
    spawn_weather_layers(&mut app.world_mut().commands());
    app.world_mut().flush();
    let preset = app
        .world()
        .resource::<AssetServer>()
        .load::<CloudPreset>("sky.preset.json");
    app.insert_resource(ActivePreset {
        preset,
        duration_s: 0.0,
    });

    update_until(&mut app, Duration::from_secs(20), |app| {
        (low_layer_coverage_of(app) - 0.3).abs() < 1e-6
    });
    let haze = app.world().resource::<bevy_cloudscape::layers::Haze>();
    assert_eq!(haze.visibility_m, 12_000.0, "the preset sets the haze");

    // An edit of the file is a new preset.
    std::thread::sleep(Duration::from_millis(500));
    std::fs::write(&file, sky("0.6")).unwrap();
    update_until(&mut app, Duration::from_secs(10), |app| {
        (low_layer_coverage_of(app) - 0.6).abs() < 1e-6
    });

    // A broken edit fails to load with an error naming the file and the key, and the sky
    // stays.
    std::fs::write(&file, sky("1.5")).unwrap();
    update_until(&mut app, Duration::from_secs(10), |app| {
        !app.world().resource::<PresetFailures>().0.is_empty()
    });
    for _ in 0..20 {
        app.update();
        std::thread::sleep(Duration::from_millis(20));
    }
    let failures = &app.world().resource::<PresetFailures>().0;
    assert!(
        failures[0].contains("sky.preset.json") && failures[0].contains("layers[0].coverage"),
        "{}",
        failures[0]
    );
    assert!((low_layer_coverage_of(&app) - 0.6).abs() < 1e-6);
    let _ = std::fs::remove_dir_all(&dir);
}

/// Coverage of the low layer, without a mutable borrow.
fn low_layer_coverage_of(app: &App) -> f32 {
    let world = app.world();
    world
        .iter_entities()
        .filter_map(|e| Some((e.get::<LayerSlot>()?, e.get::<CloudLayer>()?)))
        .find(|(slot, _)| **slot == LayerSlot::Low)
        .map_or(f32::NAN, |(_, layer)| layer.coverage)
}
