//! Renders the showcase cloud scenes under Bevy's atmosphere to PNG, with no window.
//!
//! ```text
//! cargo run --release --example showcase -- [--width W] [--height H] [--frames N] [--out DIR]
//!     [--scene NAME]
//! ```
//!
//! Writes `DIR/SCENE.png` (default `showcase/`, 1280×720) for the scenes of the `bench` example
//! plus a view of cumulus from above the layer, with the `HIGH` preset, after `N` frames of each
//! scene (default 24), over which the temporal accumulation averages the jittered frames.
//! `--scene NAME` renders that scene alone.

mod common;

use std::{path::PathBuf, process::ExitCode};

use bevy::{camera::RenderTarget, prelude::*, render::render_resource::TextureFormat};
use bevy_cloudscape::prelude::*;
use common::{
    headless::Headless,
    scenes::{Scene, showcase_scenes},
};

/// What to render: the image size, the frames per scene, where to write and, if given, the one
/// scene to render.
struct Args {
    size: UVec2,
    frames: u32,
    out: PathBuf,
    scene: Option<String>,
}

fn parse_args() -> Result<Args, String> {
    let usage = "usage: showcase [--width W] [--height H] [--frames N] [--out DIR] [--scene NAME]";
    let mut args = Args {
        size: UVec2::new(1280, 720),
        frames: 24,
        out: PathBuf::from("showcase"),
        scene: None,
    };
    let mut it = std::env::args().skip(1);
    while let Some(arg) = it.next() {
        let mut value = || it.next().ok_or(format!("{arg} needs a value ({usage})"));
        match arg.as_str() {
            "--width" | "--height" | "--frames" => {
                let text = value()?;
                let n: u32 = text
                    .parse()
                    .ok()
                    .filter(|n| *n > 0)
                    .ok_or(format!("{arg}: {text:?} is not a positive whole number"))?;
                match arg.as_str() {
                    "--width" => args.size.x = n,
                    "--height" => args.size.y = n,
                    _ => args.frames = n,
                }
            }
            "--out" => args.out = value()?.into(),
            "--scene" => args.scene = Some(value()?),
            other => return Err(format!("unknown argument {other:?} ({usage})")),
        }
    }
    Ok(args)
}

fn scenes() -> Vec<Scene> {
    let mut scenes = showcase_scenes();
    let mut above = scenes[0].clone();
    above.name = "cumulus_from_above";
    above.camera =
        Transform::from_xyz(0.0, 4_500.0, 0.0).looking_to(Vec3::new(0.0, -0.35, -1.0), Vec3::Y);
    scenes.push(above);
    for scene in &mut scenes {
        scene.settings = VolumetricClouds::HIGH;
    }
    scenes
}

fn run(args: &Args) -> Result<(), String> {
    let (size, out) = (args.size, args.out.as_path());
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
    for scene in scenes {
        scene.apply(app.world(), camera, sun);
        app.run_frames(args.frames);
        let pixels = app.read_target();
        let path = out.join(format!("{}.png", scene.name));
        pixels.save_png(&path, 1.0);
        println!("wrote {}", path.display());
    }
    Ok(())
}

fn main() -> ExitCode {
    match parse_args().and_then(|args| run(&args)) {
        Ok(()) => ExitCode::SUCCESS,
        Err(message) => {
            eprintln!("showcase: {message}");
            ExitCode::from(2)
        }
    }
}
