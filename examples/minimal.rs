//! The smallest cloud scene, self-contained so it can be copied into a new project as it is:
//! Bevy's atmosphere over a ground plane, the sun, and one layer of cumulus.
//!
//! ```text
//! cargo run --release --example minimal
//! ```
//!
//! The `forecast` example drives the layers from a weather forecast instead.

use bevy::{
    camera::Exposure,
    light::{Atmosphere, atmosphere::ScatteringMedium, light_consts::lux},
    pbr::AtmosphereSettings,
    prelude::*,
};
use bevy_cloudscape::prelude::*;

fn main() {
    App::new()
        .add_plugins((DefaultPlugins, CloudscapePlugin))
        .add_systems(Startup, setup)
        .run();
}

fn setup(
    mut commands: Commands,
    mut meshes: ResMut<Assets<Mesh>>,
    mut materials: ResMut<Assets<StandardMaterial>>,
    mut media: ResMut<Assets<ScatteringMedium>>,
) {
    // The camera opts in to clouds; `VolumetricClouds` brings a depth prepass and HDR.
    commands.spawn((
        Camera3d::default(),
        Transform::from_xyz(0.0, 1.8, 0.0).looking_to(Vec3::new(0.0, 0.2, -1.0), Vec3::Y),
        AtmosphereSettings::default(),
        Exposure { ev100: 13.0 },
        VolumetricClouds::MEDIUM,
    ));
    commands.spawn(Atmosphere::earth(
        media.add(ScatteringMedium::earth(256, 256)),
    ));
    // The sun, 25° up and 30° right of the view (its light as above the atmosphere).
    commands.spawn((
        DirectionalLight {
            illuminance: lux::RAW_SUNLIGHT,
            ..default()
        },
        Transform::default().looking_to(Vec3::new(-0.45, -0.42, 0.78), Vec3::Y),
    ));
    commands.spawn((
        Mesh3d(meshes.add(Plane3d::default().mesh().size(200_000.0, 200_000.0))),
        MeshMaterial3d(materials.add(Color::srgb(0.32, 0.42, 0.22))),
    ));
    // One layer of fair-weather cumulus, set by hand: without a `LayerSlot` no forecast
    // touches it.
    commands.spawn(CloudLayer {
        coverage: 0.45,
        ..CloudLayer::new(CloudKind::Cumulus)
    });
}
