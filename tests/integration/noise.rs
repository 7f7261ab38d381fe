//! The noise compute pass against the f64 CPU reference, read back from the GPU.

use bevy::{
    prelude::*,
    render::render_resource::{Texture, TextureFormat},
};
use bevy_cloudscape::{
    reference::noise::{self, NoiseRecipe},
    render::noise::{CloudNoisePlugin, CloudNoiseSettings, CloudNoiseTextures},
};

use crate::common::headless::rgba16float_texels;
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

/// How a texture stores the noise: the base and detail on the grid of `quantize_noise` in half
/// floats, the weather as bytes.
#[derive(Clone, Copy)]
enum Storage {
    Grid,
    Bytes,
}

/// Level `level` of a noise texture read back: how the texture stores values (from its format),
/// and the values.
fn read(app: &mut Headless, texture: &Texture, level: u32) -> (Storage, Vec<[f64; 4]>) {
    let bytes = app.read_texture(texture, level);
    match texture.format() {
        TextureFormat::Rgba16Float => (
            Storage::Grid,
            rgba16float_texels(&bytes)
                .into_iter()
                .map(|t| t.map(f64::from))
                .collect(),
        ),
        TextureFormat::Rgba8Unorm => (
            Storage::Bytes,
            bytes
                .chunks_exact(4)
                .map(|t| std::array::from_fn(|c| f64::from(t[c]) / 255.0))
                .collect(),
        ),
        other => panic!("unexpected noise format {other:?}"),
    }
}

impl Storage {
    /// One storage step.
    fn step(self) -> f64 {
        match self {
            Storage::Grid => 1.0 / noise::NOISE_LEVELS,
            Storage::Bytes => 1.0 / 255.0,
        }
    }

    /// The value the texture stores for `value`.
    fn quantize(self, value: f64) -> f64 {
        match self {
            Storage::Grid => noise::quantize_noise(value),
            Storage::Bytes => f64::from(noise::quantize_unorm8(value)) / 255.0,
        }
    }
}

/// Compares GPU values with the reference as the texture stores it: returns (values off by more
/// than one storage step, largest difference in steps, mean signed difference in steps), over
/// every channel.
fn compare(gpu: &[[f64; 4]], reference: &[[f64; 4]], storage: Storage) -> (usize, f64, f64) {
    assert_eq!(gpu.len(), reference.len());
    let mut off_by_more_than_one = 0;
    let mut worst: f64 = 0.0;
    let mut sum = 0.0;
    for (texel, expected) in gpu.iter().zip(reference) {
        for c in 0..4 {
            let d = (texel[c] - storage.quantize(expected[c])) / storage.step();
            worst = worst.max(d.abs());
            sum += d;
            if d.abs() > 1.0 + 1e-9 {
                off_by_more_than_one += 1;
            }
        }
    }
    (off_by_more_than_one, worst, sum / (4 * gpu.len()) as f64)
}

/// Fraction of channel values that differ from the reference by more than one storage step must
/// stay under 0.1 %, nothing may differ by more than two steps, and the differences must not
/// lean one way: a GPU that rounded every texel down would pass the first two and still shift
/// every cloud's density (half a step of the 2^-11 grid moves the sunset showcase by 2 %).
fn assert_matches(name: &str, gpu: &[[f64; 4]], reference: &[[f64; 4]], storage: Storage) {
    let (over_one, worst, mean) = compare(gpu, reference, storage);
    let values = reference.len() * 4;
    let within_one = 1.0 - over_one as f64 / values as f64;
    assert!(
        within_one >= 0.999 && worst <= 2.0 + 1e-9 && mean.abs() < 0.05,
        "{name}: {within_one:.5} of values within one step, worst {worst} steps, mean {mean} steps"
    );
}

/// Largest absolute jump between neighbours along x inside rows, and across the wrap (last
/// texel of a row to the first), for one channel of a cube texture of side `n`.
fn jumps_along_x(values: &[[f64; 4]], n: usize, channel: usize) -> (f64, f64) {
    let at = |x: usize, yz: usize| values[yz * n + x][channel];
    let (mut inside, mut wrap): (f64, f64) = (0.0, 0.0);
    for yz in 0..values.len() / n {
        for x in 0..n - 1 {
            inside = inside.max((at(x, yz) - at(x + 1, yz)).abs());
        }
        wrap = wrap.max((at(n - 1, yz) - at(0, yz)).abs());
    }
    (inside, wrap)
}

fn channel_stats(values: &[[f64; 4]], channel: usize) -> (f64, f64) {
    let n = values.len() as f64;
    let mean = values.iter().map(|t| t[channel]).sum::<f64>() / n;
    let var = values
        .iter()
        .map(|t| (t[channel] - mean).powi(2))
        .sum::<f64>()
        / n;
    (mean, var.sqrt())
}

#[test]
fn gpu_noise_matches_reference_and_tiles() {
    let recipe = small_recipe(7);
    let mut app = noise_app(recipe.clone());
    app.run_frames(3);
    let tex = textures(&mut app);
    assert_eq!(tex.generation, 1, "generated exactly once");

    let (base_storage, base) = read(&mut app, &tex.base.texture, 0);
    let (detail_storage, detail) = read(&mut app, &tex.detail.texture, 0);
    let (weather_storage, weather) = read(&mut app, &tex.weather.texture, 0);
    let base_reference = noise::generate_base(&recipe, 32);
    assert_matches("base", &base, &base_reference, base_storage);
    let detail_reference = noise::generate_detail(&recipe, 16);
    assert_matches("detail", &detail, &detail_reference, detail_storage);
    let weather_reference = noise::generate_weather(&recipe, 64);
    assert_matches("weather", &weather, &weather_reference, weather_storage);

    // Seamless: the step across the wrap is no bigger than steps inside the texture.
    for (name, values, n) in [("base", &base, 32), ("detail", &detail, 16)] {
        for channel in 0..3 {
            let (inside, wrap) = jumps_along_x(values, n, channel);
            assert!(
                wrap <= inside,
                "{name} channel {channel}: wrap jump {wrap} > largest inner jump {inside}"
            );
        }
    }

    // Health: every noise channel varies. Floors are a third of the reference's own
    // standard-deviation floors at full size (Worley fBm ≥ 0.05 there), so a constant or
    // collapsed channel fails while small textures pass.
    for (name, values, channels) in [
        ("base", &base, 4),
        ("detail", &detail, 3),
        ("weather", &weather, 4),
    ] {
        for channel in 0..channels {
            let (_, std) = channel_stats(values, channel);
            assert!(
                std > 0.02,
                "{name} channel {channel} is nearly constant: std {std}"
            );
        }
    }

    // Mips: each level keeps the level-0 mean within 1/255 and equals the box filter of the
    // GPU's own previous level, rounded to the grid, within one step.
    for (name, texture, size, level0) in [
        ("base", &tex.base.texture, 32u32, &base),
        ("detail", &tex.detail.texture, 16, &detail),
    ] {
        let mut previous = level0.clone();
        let mut previous_size = size;
        for level in 1..noise::mip_level_count(size) {
            let (storage, values) = read(&mut app, texture, level);
            let expected = noise::downsample_3d(&previous, previous_size);
            let (_, worst, _) = compare(&values, &expected, storage);
            assert!(
                worst <= 1.0 + 1e-9,
                "{name} mip {level}: {worst} steps from the box filter"
            );
            for channel in 0..4 {
                let (mean0, _) = channel_stats(level0, channel);
                let (mean, _) = channel_stats(&values, channel);
                assert!(
                    (mean - mean0).abs() <= 1.0 / 255.0,
                    "{name} mip {level} channel {channel}: mean {mean} vs level 0 {mean0}"
                );
            }
            previous = values;
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
