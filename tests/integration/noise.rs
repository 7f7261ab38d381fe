//! The noise compute pass against the f64 CPU reference, read back from the GPU.

use bevy::{prelude::*, render::render_resource::TextureFormat};
use bevy_cloudscape::{
    reference::noise::{self, NoiseRecipe},
    render::noise::{CloudNoisePlugin, CloudNoiseSettings, CloudNoiseTextures},
};

use crate::harness::Headless;

/// The default recipe at test sizes (the full 128³ takes seconds on lavapipe).
fn small_recipe(seed: u32) -> NoiseRecipe {
    NoiseRecipe {
        seed,
        base_size: 32,
        detail_size: 16,
        weather_size: 64,
        ..default()
    }
}

fn noise_app(recipe: NoiseRecipe) -> Headless {
    Headless::new(UVec2::splat(4), TextureFormat::Rgba8UnormSrgb, |app| {
        app.add_plugins(CloudNoisePlugin)
            .insert_resource(CloudNoiseSettings(recipe));
    })
}

fn textures(app: &mut Headless) -> CloudNoiseTextures {
    app.render_world()
        .get_resource::<CloudNoiseTextures>()
        .expect("noise generated")
        .clone()
}

/// Compares GPU bytes with the quantised reference: returns (texels off by more than one
/// step, largest difference in steps), over every channel.
fn compare(gpu: &[u8], reference: &[[f64; 4]]) -> (usize, u8) {
    assert_eq!(gpu.len(), reference.len() * 4);
    let mut off_by_more_than_one = 0;
    let mut worst = 0;
    for (texel, expected) in gpu.chunks_exact(4).zip(reference) {
        for c in 0..4 {
            let d = texel[c].abs_diff(noise::quantize_unorm8(expected[c]));
            worst = worst.max(d);
            if d > 1 {
                off_by_more_than_one += 1;
            }
        }
    }
    (off_by_more_than_one, worst)
}

/// Fraction of channel values that differ from the reference by more than 1/255 must stay
/// under 0.1 %, and nothing may differ by more than 2/255.
fn assert_matches(name: &str, gpu: &[u8], reference: &[[f64; 4]]) {
    let (over_one, worst) = compare(gpu, reference);
    let values = reference.len() * 4;
    // "Within 1/255 on at least 99.9 % of texels": count channel values more than one step off.
    let within_one = 1.0 - over_one as f64 / values as f64;
    assert!(
        within_one >= 0.999 && worst <= 2,
        "{name}: {within_one:.5} of values within 1/255, worst {worst}/255"
    );
}

/// Largest absolute byte jump between neighbours along x inside rows, and across the wrap
/// (last texel of a row to the first), for one channel of a cube texture of side `n`.
fn jumps_along_x(bytes: &[u8], n: usize, channel: usize) -> (u8, u8) {
    let at = |x: usize, yz: usize| bytes[(yz * n + x) * 4 + channel];
    let (mut inside, mut wrap) = (0, 0);
    for yz in 0..bytes.len() / 4 / n {
        for x in 0..n - 1 {
            inside = inside.max(at(x, yz).abs_diff(at(x + 1, yz)));
        }
        wrap = wrap.max(at(n - 1, yz).abs_diff(at(0, yz)));
    }
    (inside, wrap)
}

fn channel_stats(bytes: &[u8], channel: usize) -> (f64, f64) {
    let values: Vec<f64> = bytes
        .chunks_exact(4)
        .map(|t| f64::from(t[channel]) / 255.0)
        .collect();
    let mean = values.iter().sum::<f64>() / values.len() as f64;
    let var = values.iter().map(|v| (v - mean).powi(2)).sum::<f64>() / values.len() as f64;
    (mean, var.sqrt())
}

#[test]
fn gpu_noise_matches_reference_and_tiles() {
    let recipe = small_recipe(7);
    let mut app = noise_app(recipe.clone());
    app.run_frames(3);
    let tex = textures(&mut app);
    assert_eq!(tex.generation, 1, "generated exactly once");

    let base = app.read_texture(&tex.base.texture, 0);
    let detail = app.read_texture(&tex.detail.texture, 0);
    let weather = app.read_texture(&tex.weather.texture, 0);
    assert_matches("base", &base, &noise::generate_base(&recipe, 32));
    assert_matches("detail", &detail, &noise::generate_detail(&recipe, 16));
    assert_matches("weather", &weather, &noise::generate_weather(&recipe, 64));

    // Seamless: the step across the wrap is no bigger than steps inside the texture.
    for (name, bytes, n) in [("base", &base, 32), ("detail", &detail, 16)] {
        for channel in 0..3 {
            let (inside, wrap) = jumps_along_x(bytes, n, channel);
            assert!(
                wrap <= inside,
                "{name} channel {channel}: wrap jump {wrap} > largest inner jump {inside}"
            );
        }
    }

    // Health: every noise channel varies. Floors are a third of the reference's own
    // standard-deviation floors at full size (Worley fBm ≥ 0.05 there), so a constant or
    // collapsed channel fails while small textures pass.
    for (name, bytes, channels) in [
        ("base", &base, 4),
        ("detail", &detail, 3),
        ("weather", &weather, 4),
    ] {
        for channel in 0..channels {
            let (_, std) = channel_stats(bytes, channel);
            assert!(
                std > 0.02,
                "{name} channel {channel} is nearly constant: std {std}"
            );
        }
    }

    // Mips: each level keeps the level-0 mean within 1/255 and equals the box filter of the
    // GPU's own previous level within one rounding step.
    for (name, texture, size) in [
        ("base", &tex.base.texture, 32u32),
        ("detail", &tex.detail.texture, 16),
    ] {
        let level0 = app.read_texture(texture, 0);
        let mut previous: Vec<[f64; 4]> = level0
            .chunks_exact(4)
            .map(|t| std::array::from_fn(|c| f64::from(t[c]) / 255.0))
            .collect();
        let mut previous_size = size;
        for level in 1..noise::mip_level_count(size) {
            let bytes = app.read_texture(texture, level);
            let expected = noise::downsample_3d(&previous, previous_size);
            let (_, worst) = compare(&bytes, &expected);
            assert!(
                worst <= 1,
                "{name} mip {level}: {worst}/255 from the box filter"
            );
            for channel in 0..4 {
                let (mean0, _) = channel_stats(&level0, channel);
                let (mean, _) = channel_stats(&bytes, channel);
                assert!(
                    (mean - mean0).abs() <= 1.0 / 255.0,
                    "{name} mip {level} channel {channel}: mean {mean} vs level 0 {mean0}"
                );
            }
            previous = bytes
                .chunks_exact(4)
                .map(|t| std::array::from_fn(|c| f64::from(t[c]) / 255.0))
                .collect();
            previous_size = noise::mip_size(previous_size);
        }
    }
}

#[test]
fn noise_regenerates_only_when_settings_change() {
    let mut app = noise_app(small_recipe(0));
    app.run_frames(3);
    let first = textures(&mut app);
    let first_base = app.read_texture(&first.base.texture, 0);
    app.run_frames(5);
    assert_eq!(
        textures(&mut app).generation,
        1,
        "frames without a settings change dispatch nothing"
    );

    app.world().resource_mut::<CloudNoiseSettings>().seed = 1;
    app.run_frames(2);
    let second = textures(&mut app);
    assert_eq!(second.generation, 2, "a settings change regenerates once");
    assert_eq!(second.recipe.seed, 1);
    let second_base = app.read_texture(&second.base.texture, 0);
    let changed = first_base
        .iter()
        .zip(&second_base)
        .filter(|(a, b)| a != b)
        .count();
    assert!(
        changed > first_base.len() / 2,
        "a new seed changes most values ({changed} of {})",
        first_base.len()
    );

    // A recipe the GPU cannot make is rejected and the last good textures stay.
    app.world().resource_mut::<CloudNoiseSettings>().base_size = 0;
    app.run_frames(2);
    let kept = textures(&mut app);
    assert_eq!(
        (kept.generation, kept.recipe.seed, kept.recipe.base_size),
        (2, 1, 32)
    );
}
