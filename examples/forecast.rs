//! Clouds from a weather forecast: the bundled meteoblue forecast for Bern sets the layers, the
//! haze and the rain, and the sun stands where it stood over Bern, over fields in cloud shadow:
//! `cargo run --release --example forecast -- [--time 2021-05-03T14:00:00Z] [--headless]`.

mod common;

use bevy::light::{Atmosphere, AtmosphereEnvironmentMapLight, atmosphere::ScatteringMedium};
use bevy::{light::light_consts::lux, prelude::*};
use bevy_cloudscape::prelude::*;
use clap::Parser;
use common::{CommonArgs, HeadlessCapturePlugin, HeadlessProgress};

/// Clouds from the bundled Bern forecast.
#[derive(Parser)]
struct Cli {
    /// The instant to show, UTC (RFC 3339); the bundled forecast covers 3–9 May 2021.
    #[arg(long, default_value = "2021-05-03T14:00:00Z")]
    time: UtcInstant,
    #[command(flatten)]
    common: CommonArgs,
}

fn main() -> AppExit {
    let cli = Cli::parse();
    let args = cli.common.for_example("forecast");
    let mut app = App::new();
    app.add_plugins((
        common::default_plugins(&args, "bevy_cloudscape: forecast"),
        CloudscapePlugin,
    ))
    // The place (Bern is the default `GeoOrigin`) and the instant the sky shows.
    .insert_resource(GeoOrigin::default())
    .insert_resource(SceneClock::at(cli.time))
    .add_systems(Startup, setup);
    if args.headless {
        app.add_plugins(HeadlessCapturePlugin)
            .add_systems(Update, wait_for_the_forecast);
    }
    app.insert_resource(args).run()
}

fn setup(
    mut commands: Commands,
    asset_server: Res<AssetServer>,
    mut media: ResMut<Assets<ScatteringMedium>>,
    mut meshes: ResMut<Assets<Mesh>>,
    mut materials: ResMut<Assets<StandardMaterial>>,
) {
    // The forecast drives every layer with a `LayerSlot`; `spawn_weather_layers` makes one each.
    commands.insert_resource(WeatherSource::load(&asset_server, "weather/bern.json", []));
    spawn_weather_layers(&mut commands);
    commands.spawn(Atmosphere::earth(
        media.add(ScatteringMedium::earth(256, 256)),
    ));
    // `Sun` aims the light from the solar position for the place and instant.
    let light = DirectionalLight {
        illuminance: lux::RAW_SUNLIGHT,
        ..default()
    };
    commands.spawn((light, Sun::default()));
    // Fields to the horizon, lit by the sun (dimmed in the clouds' shadows) and the sky.
    commands.spawn((
        Mesh3d(meshes.add(Plane3d::default().mesh().size(2e5, 2e5))),
        MeshMaterial3d(materials.add(Color::srgb(0.32, 0.42, 0.22))),
    ));
    commands.spawn((
        common::sky_scene_camera(),
        VolumetricClouds::MEDIUM,
        AtmosphereEnvironmentMapLight::default(),
    ));
}

/// The headless capture waits until the forecast has loaded and set the layers.
fn wait_for_the_forecast(weather: Res<CurrentWeather>, mut progress: ResMut<HeadlessProgress>) {
    progress.ready = weather.near.is_some();
}
