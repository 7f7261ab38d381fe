//! Renders the showcase cloud scenes under Bevy's atmosphere to PNG, with no window.
//!
//! ```text
//! cargo run --release --example showcase -- [--width W] [--height H] [--out DIR]
//! ```
//!
//! Writes `DIR/SCENE.png` (default `showcase/`, 1280×720) for the scenes of the `bench` example
//! plus a view of cumulus from above the layer, with the `HIGH` preset.

mod common;

use std::{path::PathBuf, process::ExitCode};

use bevy::{camera::RenderTarget, prelude::*, render::render_resource::TextureFormat};
use bevy_cloudscape::prelude::*;
use common::{
    headless::Headless,
    scenes::{Scene, showcase_scenes},
};

fn parse_args() -> Result<(UVec2, PathBuf), String> {
    let usage = "usage: showcase [--width W] [--height H] [--out DIR]";
    let (mut size, mut out) = (UVec2::new(1280, 720), PathBuf::from("showcase"));
    let mut it = std::env::args().skip(1);
    while let Some(arg) = it.next() {
        let mut value = || it.next().ok_or(format!("{arg} needs a value ({usage})"));
        match arg.as_str() {
            "--width" | "--height" => {
                let text = value()?;
                let n: u32 = text
                    .parse()
                    .ok()
                    .filter(|n| *n > 0)
                    .ok_or(format!("{arg}: {text:?} is not a positive whole number"))?;
                if arg == "--width" {
                    size.x = n;
                } else {
                    size.y = n;
                }
            }
            "--out" => out = value()?.into(),
            other => return Err(format!("unknown argument {other:?} ({usage})")),
        }
    }
    Ok((size, out))
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

fn run(size: UVec2, out: &std::path::Path) -> Result<(), String> {
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
    for scene in scenes() {
        scene.apply(app.world(), camera, sun);
        app.run_frames(4);
        let pixels = app.read_target();
        let path = out.join(format!("{}.png", scene.name));
        pixels.save_png(&path, 1.0);
        println!("wrote {}", path.display());
    }
    Ok(())
}

fn main() -> ExitCode {
    match parse_args().and_then(|(size, out)| run(size, &out)) {
        Ok(()) => ExitCode::SUCCESS,
        Err(message) => {
            eprintln!("showcase: {message}");
            ExitCode::from(2)
        }
    }
}
