//! The smallest scene: Bevy's atmosphere over a ground plane, lit by the sun.
//!
//! ```text
//! cargo run --release --example minimal                      # a window
//! cargo run --release --example minimal -- --headless --out minimal.png
//! ```

mod common;

use bevy::prelude::*;
use common::{ExampleArgs, HeadlessCapturePlugin};

fn main() -> AppExit {
    let args = match ExampleArgs::from_env("minimal") {
        Ok(args) => args,
        Err(message) => {
            eprintln!("{message}");
            return AppExit::error();
        }
    };
    let mut app = App::new();
    app.add_plugins(common::default_plugins(&args, "bevy_cloudscape: minimal"))
        .add_systems(Startup, (common::spawn_sky_scene, spawn_camera));
    if args.headless {
        app.add_plugins(HeadlessCapturePlugin);
    }
    app.insert_resource(args).run()
}

fn spawn_camera(mut commands: Commands) {
    commands.spawn(common::sky_scene_camera());
}
