//! Writes PNG slices of every channel and mip of the cloud-noise textures the GPU generates,
//! each tiled 2×2 so a seam at the wrap would show as a line through the middle.
//!
//! ```text
//! cargo run --release --example noise_slices -- --out DIR [--seed N] [--small]
//! ```
//!
//! For each 3D texture (base, detail) and mip level it writes `DIR/<texture>_mip<level>_<channel>.png`
//! (the z = 0 slice), and `DIR/weather_<channel>.png` for the 2D weather noise. `--small` uses
//! 32³/16³/64² textures instead of the default 128³/32³/256², which is quicker on software Vulkan.

mod common;

use std::path::{Path, PathBuf};

use bevy::{prelude::*, render::render_resource::TextureFormat};
use bevy_cloudscape::{
    reference::noise::{NoiseRecipe, mip_level_count, mip_size, quantize_unorm8},
    render::noise::{CloudNoisePlugin, CloudNoiseSettings, CloudNoiseTextures},
};
use common::headless::{Headless, rgba16float_texels};

struct Args {
    out: PathBuf,
    recipe: NoiseRecipe,
}

fn parse_args() -> Result<Args, String> {
    let mut args = Args {
        out: PathBuf::from("noise_slices"),
        recipe: NoiseRecipe::default(),
    };
    let mut it = std::env::args().skip(1);
    while let Some(arg) = it.next() {
        match arg.as_str() {
            "--out" => args.out = it.next().ok_or("--out needs a folder")?.into(),
            "--seed" => {
                let text = it.next().ok_or("--seed needs a number")?;
                args.recipe.seed = text.parse().map_err(|_| format!("--seed: {text:?}"))?;
            }
            "--small" => {
                args.recipe.base_size = 32;
                args.recipe.detail_size = 16;
                args.recipe.weather_size = 64;
            }
            other => {
                return Err(format!(
                    "unknown argument {other:?}\nusage: noise_slices [--out DIR] [--seed N] [--small]"
                ));
            }
        }
    }
    Ok(args)
}

/// Writes one channel of a `size`×`size` slice (tightly packed RGBA8) as a grey PNG tiled 2×2.
fn write_tiled(path: &Path, rgba: &[u8], size: u32, channel: usize) -> Result<(), String> {
    let n = size as usize;
    let tiled = image::GrayImage::from_fn(size * 2, size * 2, |x, y| {
        let (x, y) = (x as usize % n, y as usize % n);
        image::Luma([rgba[(y * n + x) * 4 + channel]])
    });
    tiled
        .save(path)
        .map_err(|e| format!("cannot write {}: {e}", path.display()))
}

/// `Rgba16Float` texels (as the base and detail noise are stored) as RGBA8.
fn half_floats_to_rgba8(bytes: &[u8]) -> Vec<u8> {
    rgba16float_texels(bytes)
        .into_iter()
        .flat_map(|t| t.map(|v| quantize_unorm8(f64::from(v))))
        .collect()
}

fn run(args: &Args) -> Result<(), String> {
    std::fs::create_dir_all(&args.out)
        .map_err(|e| format!("cannot create {}: {e}", args.out.display()))?;
    let recipe = args.recipe.clone();
    let mut app = Headless::new(UVec2::splat(4), TextureFormat::Rgba8UnormSrgb, |app| {
        app.add_plugins(CloudNoisePlugin)
            .insert_resource(CloudNoiseSettings(recipe));
    });
    app.run_frames(3);
    let textures = app
        .render_world()
        .get_resource::<CloudNoiseTextures>()
        .cloned()
        .ok_or("the GPU did not generate the noise (see the warnings above)")?;

    let channels = ["r", "g", "b", "a"];
    let mut written = 0;
    for (name, texture, size) in [
        ("base", &textures.base.texture, args.recipe.base_size),
        ("detail", &textures.detail.texture, args.recipe.detail_size),
    ] {
        let mut level_size = size;
        for level in 0..mip_level_count(size) {
            let bytes = half_floats_to_rgba8(&app.read_texture(texture, level));
            // The z = 0 slice is the first level_size² texels.
            let slice = &bytes[..(level_size * level_size * 4) as usize];
            for (channel, suffix) in channels.iter().enumerate() {
                let path = args.out.join(format!("{name}_mip{level}_{suffix}.png"));
                write_tiled(&path, slice, level_size, channel)?;
                written += 1;
            }
            level_size = mip_size(level_size);
        }
    }
    let weather = app.read_texture(&textures.weather.texture, 0);
    for (channel, suffix) in channels.iter().enumerate() {
        let path = args.out.join(format!("weather_{suffix}.png"));
        write_tiled(&path, &weather, args.recipe.weather_size, channel)?;
        written += 1;
    }
    println!("wrote {written} PNGs to {}", args.out.display());
    Ok(())
}

fn main() -> std::process::ExitCode {
    match parse_args().and_then(|args| run(&args)) {
        Ok(()) => std::process::ExitCode::SUCCESS,
        Err(message) => {
            eprintln!("noise_slices: {message}");
            std::process::ExitCode::from(2)
        }
    }
}
