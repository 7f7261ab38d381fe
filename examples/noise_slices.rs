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

/// Writes PNG slices of the cloud-noise textures.
#[derive(clap::Parser)]
struct Args {
    /// Folder the slices go to.
    #[arg(long, default_value = "noise_slices")]
    out: PathBuf,
    /// Seed of every noise.
    #[arg(long, default_value_t = 0)]
    seed: u32,
    /// 32³/16³/64² textures instead of 128³/32³/256² (quicker on software Vulkan).
    #[arg(long)]
    small: bool,
}

impl Args {
    /// The noise recipe the options ask for.
    fn recipe(&self) -> NoiseRecipe {
        let mut recipe = NoiseRecipe {
            seed: self.seed,
            ..NoiseRecipe::default()
        };
        if self.small {
            recipe.base_size = 32;
            recipe.detail_size = 16;
            recipe.weather_size = 64;
        }
        recipe
    }
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
    let recipe = args.recipe();
    let mut app = Headless::new(UVec2::splat(4), TextureFormat::Rgba8UnormSrgb, |app| {
        app.add_plugins(CloudNoisePlugin)
            .insert_resource(CloudNoiseSettings(recipe.clone()));
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
        ("base", &textures.base.texture, recipe.base_size),
        ("detail", &textures.detail.texture, recipe.detail_size),
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
        write_tiled(&path, &weather, recipe.weather_size, channel)?;
        written += 1;
    }
    println!("wrote {written} PNGs to {}", args.out.display());
    Ok(())
}

fn main() -> std::process::ExitCode {
    match run(&<Args as clap::Parser>::parse()) {
        Ok(()) => std::process::ExitCode::SUCCESS,
        Err(message) => {
            eprintln!("noise_slices: {message}");
            std::process::ExitCode::from(2)
        }
    }
}
