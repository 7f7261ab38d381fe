//! The smallest cloud scene: Bevy's atmosphere over a ground plane, the sun, one cumulus layer.
//!
//! ```text
//! cargo run --release --example minimal                      # a window
//! cargo run --release --example minimal -- --headless --out minimal.png
//! ```

mod common;

use bevy::prelude::*;
use bevy_cloudscape::prelude::*;
use clap::Parser;
use common::{CommonArgs, HeadlessCapturePlugin};

/// The smallest cloud scene.
#[derive(Parser)]
struct Cli {
    #[command(flatten)]
    common: CommonArgs,
}

fn main() -> AppExit {
    let args = Cli::parse().common.for_example("minimal");
    let mut app = App::new();
    app.add_plugins((
        common::default_plugins(&args, "bevy_cloudscape: minimal"),
        CloudscapePlugin,
    ))
    .add_systems(Startup, (common::spawn_sky_scene, spawn_camera_and_clouds));
    if args.headless {
        app.add_plugins(HeadlessCapturePlugin);
    }
    app.insert_resource(args).run()
}

fn spawn_camera_and_clouds(mut commands: Commands) {
    // The camera opts in to clouds; `VolumetricClouds` brings a depth prepass and HDR.
    commands.spawn((common::sky_scene_camera(), VolumetricClouds::MEDIUM));
    // One layer of fair-weather cumulus, set by hand rather than by a forecast.
    commands.spawn(CloudLayer {
        coverage: 0.45,
        weather_driven: false,
        ..CloudLayer::new(CloudKind::Cumulus)
    });
}
