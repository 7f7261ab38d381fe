//! Renders the showcase cloud scenes under Bevy's atmosphere to PNG, with no window.
//!
//! ```text
//! cargo run --release --example showcase -- [--width W] [--height H] [--frames N] [--out DIR]
//!     [--scene NAME]
//! ```
//!
//! Writes `DIR/SCENE.png` (default `showcase/`, 1280×720) for the scenes of the `bench` example
//! plus a view of cumulus from above the layer and a cirrostratus veil around the sun (its 22°
//! halo), with the `HIGH` preset, after `N` frames of each scene (default 24), and at least
//! until the temporal accumulation has settled (`common::accumulation_frames`: 128 frames at a
//! quarter of the resolution), so the image shows no dotted edges of a half-filled upsampling.
//! `--scene NAME` renders that scene alone. `--storm` renders the storm time-lapse instead: a
//! cumulonimbus at dusk, one image per second of scene time for six seconds, side by side in
//! `DIR/storm_strip.png`, with its lightning (a fixed rate and seed, so the strip repeats): the
//! flashes light the cloud from within, and a ground stroke's channel shows below it.

mod common;

use std::{path::PathBuf, process::ExitCode};

use bevy::{camera::RenderTarget, prelude::*, render::render_resource::TextureFormat};
use bevy_cloudscape::prelude::*;
use common::{
    headless::Headless,
    scenes::{self, Scene, showcase_scenes},
};

/// Renders the showcase cloud scenes to PNG, with no window.
#[derive(clap::Parser)]
struct Args {
    /// Image width, pixels.
    #[arg(long, default_value_t = 1280, value_parser = clap::value_parser!(u32).range(1..))]
    width: u32,
    /// Image height, pixels.
    #[arg(long, default_value_t = 720, value_parser = clap::value_parser!(u32).range(1..))]
    height: u32,
    /// Frames of each scene before its image is taken (at least until the temporal
    /// accumulation has settled).
    #[arg(long, default_value_t = 24, value_parser = clap::value_parser!(u32).range(1..))]
    frames: u32,
    /// Folder the images go to.
    #[arg(long, default_value = "showcase")]
    out: PathBuf,
    /// Render only the scene of this name.
    #[arg(long)]
    scene: Option<String>,
    /// Render the storm time-lapse (`storm_strip.png`) instead of the scenes.
    #[arg(long, conflicts_with = "scene")]
    storm: bool,
}

/// The storm time-lapse's first second (a whole second: a flash of the sequence starts there
/// at its brightest stroke) and its lightning: 20 flashes a minute within 6 km.
const STORM_START: &str = "2021-05-07T19:30:00Z";
const STORM_IMAGES: u32 = 6;

fn storm_lightning() -> bevy_cloudscape::lightning::Lightning {
    bevy_cloudscape::lightning::Lightning {
        rate_override: Some(20.0),
        radius_m: 6_000.0,
        seed: 167,
        ..default()
    }
}

/// A cumulonimbus at dusk (the sun 4° below the horizon behind the camera), seen from the
/// ground at 12° up, exposed for the dusk.
fn storm_scene() -> Scene {
    Scene {
        name: "storm",
        camera: scenes::looking(Vec3::new(0.0, 2.0, 0.0), 12.0, 0.0),
        sun_deg: (-4.0, 180.0),
        layers: vec![scenes::layer(CloudKind::Cumulonimbus, 0.7)],
        settings: VolumetricClouds::HIGH,
    }
}

fn scenes() -> Vec<Scene> {
    let mut scenes = showcase_scenes();
    let mut above = scenes[0].clone();
    above.name = "cumulus_from_above";
    above.camera =
        Transform::from_xyz(0.0, 4_500.0, 0.0).looking_to(Vec3::new(0.0, -0.35, -1.0), Vec3::Y);
    scenes.push(above);
    // A cirrostratus veil with the sun in the middle of the view: the 22° halo around it.
    scenes.push(Scene {
        name: "cirrostratus_halo",
        camera: scenes::looking(Vec3::new(0.0, 2.0, 0.0), 35.0, 150.0),
        sun_deg: (35.0, 150.0),
        layers: vec![scenes::layer(CloudKind::Cirrostratus, 1.0)],
        ..scenes[0].clone()
    });
    for scene in &mut scenes {
        scene.settings = VolumetricClouds::HIGH;
    }
    scenes
}

fn run(args: &Args) -> Result<(), String> {
    let (size, out) = (UVec2::new(args.width, args.height), args.out.as_path());
    let mut scenes = scenes();
    if let Some(name) = &args.scene {
        let names: Vec<&str> = scenes.iter().map(|scene| scene.name).collect();
        scenes.retain(|scene| scene.name == name);
        if scenes.is_empty() {
            return Err(format!(
                "no scene {name:?}; the scenes are {}",
                names.join(", ")
            ));
        }
    }
    std::fs::create_dir_all(out).map_err(|e| format!("cannot create {}: {e}", out.display()))?;
    let mut app = Headless::new(size, TextureFormat::Rgba8UnormSrgb, |app| {
        app.add_plugins(CloudscapePlugin)
            .add_systems(Startup, common::spawn_sky_scene);
    });
    let target = app.target.clone();
    let camera = app
        .world()
        .spawn((
            common::sky_scene_camera(),
            RenderTarget::Image(target.into()),
        ))
        .id();
    app.run_frames(1);
    let sun = {
        let world = app.world();
        world
            .query_filtered::<Entity, With<DirectionalLight>>()
            .single(world)
            .map_err(|e| e.to_string())?
    };
    if args.storm {
        return storm_strip(&mut app, camera, sun, args.frames, size, out);
    }
    for scene in scenes {
        scene.apply(app.world(), camera, sun);
        app.run_frames(
            args.frames
                .max(common::accumulation_frames(&scene.settings)),
        );
        let pixels = app.read_target();
        let path = out.join(format!("{}.png", scene.name));
        pixels.save_png(&path, 1.0);
        println!("wrote {}", path.display());
    }
    Ok(())
}

/// The storm time-lapse: [`STORM_IMAGES`] images one second of scene time apart from
/// [`STORM_START`], side by side.
fn storm_strip(
    app: &mut Headless,
    camera: Entity,
    sun: Entity,
    frames: u32,
    size: UVec2,
    out: &std::path::Path,
) -> Result<(), String> {
    let start: UtcInstant = STORM_START.parse().map_err(|e| format!("{e}"))?;
    storm_scene().apply(app.world(), camera, sun);
    app.world()
        .entity_mut(camera)
        .insert(bevy::camera::Exposure { ev100: 9.0 });
    *app.world()
        .resource_mut::<bevy_cloudscape::lightning::Lightning>() = storm_lightning();
    // The storm places its flashes inside the cloud with the CPU copies of the cloud noise,
    // which it asks for once it flashes: wait for them, so the strip is the same every run.
    let waiting = std::time::Instant::now();
    while !app
        .world()
        .get_resource::<bevy_cloudscape::query::CpuCloudTextures>()
        .is_some_and(bevy_cloudscape::query::CpuCloudTextures::is_ready)
    {
        if waiting.elapsed() > std::time::Duration::from_secs(900) {
            return Err("the CPU cloud noise was not made within 15 minutes".into());
        }
        app.update();
    }
    println!(
        "the CPU cloud noise took {:.1} s",
        waiting.elapsed().as_secs_f64()
    );
    let mut strip = Vec::new();
    for k in 0..STORM_IMAGES {
        let mut clock = SceneClock::at(start.saturating_add_seconds(i64::from(k)));
        clock.paused = true;
        app.world().insert_resource(clock);
        app.run_frames(frames);
        let lit = app
            .world()
            .resource::<bevy_cloudscape::lightning::ActiveFlash>()
            .flash
            .is_some();
        let bolt = {
            let world = app.world();
            world
                .query_filtered::<(), With<bevy_cloudscape::lightning::LightningBolt>>()
                .iter(world)
                .count()
                > 0
        };
        println!(
            "storm image {k}: {}",
            match (lit, bolt) {
                (true, true) => "a flash striking the ground",
                (true, false) => "a flash in the cloud",
                _ => "no flash",
            }
        );
        strip.push(app.read_target());
    }
    let images = strip.len() as u32;
    let mut rgba = Vec::with_capacity(strip.iter().map(|p| p.rgba.len()).sum());
    for y in 0..size.y {
        for image in &strip {
            rgba.extend((0..size.x).map(|x| image.at(x, y)));
        }
    }
    let path = out.join("storm_strip.png");
    common::headless::Pixels {
        size: UVec2::new(size.x * images, size.y),
        rgba,
    }
    .save_png(&path, 1.0);
    println!("wrote {}", path.display());
    Ok(())
}

fn main() -> ExitCode {
    match run(&<Args as clap::Parser>::parse()) {
        Ok(()) => ExitCode::SUCCESS,
        Err(message) => {
            eprintln!("showcase: {message}");
            ExitCode::from(2)
        }
    }
}
