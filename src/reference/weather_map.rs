//! The weather map: each layer's local coverage per weather texel around the camera, as the GPU
//! caches it.
//!
//! The density model reads the local coverage `κ` of a layer as the bilinear filter of
//! [`weather_texel_coverage`] over four weather texels ([`weather_coverage`]). Each texel's value
//! needs the layer's coverage at the texel (the blend toward far places, [`layer_coverage`]) and
//! the coverage remap. The weather-map pass (`src/render/weather_map/`) computes them once per
//! frame for a square of `size²` texels around the camera, one slice per layer, and the march
//! reads the four taps from the map instead of recomputing them at every sample. Each texel also
//! carries the shape warp there ([`texel_shape_warp`]: the fine and the broad curl), which
//! [`shape_warp`] filters over the same four texels, so a sample inside the map reads four
//! texels instead of eight or more. Outside the square the march computes the taps itself, so
//! the map changes the cost and not the image.
//!
//! The map's texels are the weather noise's texels, not a resampling of them: texel `(i, j)` of
//! the map is weather texel `origin + (i, j)`. The origin is chosen from the layer's wrapped
//! weather offset ([`weather_map_origin`]), which holds the camera position and the wind drift
//! in f64 (`MarchLayer::set_noise_origin`), so the map scrolls with the wind by whole texels and
//! the fraction of a texel stays in the look-up; a week of wind keeps full precision.
//!
//! [`layer_coverage`]: super::render::layer_coverage
//! [`weather_coverage`]: super::render::weather_coverage
//! [`shape_warp`]: super::render::shape_warp

use super::render::{MarchLayer, NoiseTexture2d, texel_shape_warp, weather_texel_coverage};

/// Default side of each layer's weather map, texels (a slice of `size²` `Rgba32Float` values,
/// 4 MiB at 512). At the default cumulus weather period (12 km over 256 texels) it covers 24 km around
/// the camera.
pub const DEFAULT_WEATHER_MAP_SIZE: u32 = 512;

/// Largest side of a weather map, texels (WebGPU's guaranteed 2D texture size).
pub const MAX_WEATHER_MAP_SIZE: u32 = 8192;

/// The weather texel at map texel `(0, 0)` of a layer's map of side `size` texels, on a weather
/// noise of `noise_size` texels per side: the texel nearest the camera minus half the side, so
/// the map is centred on the camera. Indices are along the noise axes and not wrapped (the look-up
/// wraps them). WGSL: the pass reads it from the layer (`CloudLayerGpu::weather_map`).
pub fn weather_map_origin(layer: &MarchLayer, noise_size: u32, size: u32) -> [i64; 2] {
    let n = f64::from(noise_size.max(1));
    layer.weather_offset_m.map(|offset| {
        let camera = offset / layer.weather_scale_m * n;
        let camera = if camera.is_finite() { camera } else { 0.0 };
        camera.round() as i64 - i64::from(size / 2)
    })
}

/// Whether a look-up whose first tap is weather texel `texel` reads all four taps from a map of
/// side `size` at `origin`: both taps on each axis inside the map. WGSL: `weather_coverage`.
pub fn weather_map_holds(origin: [i64; 2], size: u32, texel: [i64; 2]) -> bool {
    let last = i64::from(size) - 2;
    (0..2).all(|a| {
        let local = texel[a] - origin[a];
        (0..=last).contains(&local)
    })
}

/// One layer's weather map: `size²` texels, x fastest, texel `(i, j)` holding weather texel
/// `origin + (i, j)`: its [`weather_texel_coverage`] and its [`texel_shape_warp`] (in shape
/// periods). The GPU pass writes the same values in f32.
/// WGSL twin: `build_weather_map` in `src/render/weather_map/weather_map.wgsl`.
pub fn build_weather_map(
    weather: &NoiseTexture2d,
    layer: &MarchLayer,
    origin: [i64; 2],
    size: u32,
) -> Vec<[f64; 3]> {
    let size = i64::from(size);
    (0..size * size)
        .map(|i| {
            let texel = [origin[0] + i % size, origin[1] + i / size];
            let [x, y] = texel_shape_warp(weather, layer, texel);
            [weather_texel_coverage(weather, layer, texel), x, y]
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::reference::noise::{NoiseRecipe, generate_weather};
    use crate::reference::render::{shape_warp, weather_coverage, weather_taps};

    fn weather() -> NoiseTexture2d {
        let recipe = NoiseRecipe {
            weather_size: 32,
            ..NoiseRecipe::default()
        };
        NoiseTexture2d::from_texels(&generate_weather(&recipe, 32), 32)
    }

    fn layer() -> MarchLayer {
        let mut layer = MarchLayer {
            coverage: 0.45,
            weather_scale_m: 3200.0,
            skew: [0.3, -0.2],
            far_count: 1,
            ..MarchLayer::default()
        };
        // Far coverage 0.9 toward +x, 4 km away: the map's texels carry the blend.
        layer.far[0] = [1.0 / 4000.0, 0.0, 0.0, 0.9];
        layer.set_noise_origin([123_456.7, -98_765.4]);
        layer
    }

    /// Bilinear read of a map, as the march does inside it: the coverage and the shape warp.
    fn read_map(
        map: &[[f64; 3]],
        origin: [i64; 2],
        size: u32,
        taps: [[(i64, f64); 2]; 2],
    ) -> [f64; 3] {
        let mut sum = [0.0; 3];
        for corner in 0..4_usize {
            let (x, wx) = taps[0][corner & 1];
            let (y, wy) = taps[1][corner >> 1];
            let local = (x - origin[0]) as usize + size as usize * (y - origin[1]) as usize;
            for (s, v) in sum.iter_mut().zip(map[local]) {
                *s += wx * wy * v;
            }
        }
        sum
    }

    #[test]
    fn the_map_reproduces_the_coverage_it_caches() {
        let weather = weather();
        let layer = layer();
        let size = 40;
        let origin = weather_map_origin(&layer, weather.size, size);
        let map = build_weather_map(&weather, &layer, origin, size);
        let mut inside = 0;
        let mut varied = 0;
        let mut curled = 0;
        for i in 0..400 {
            // Points within about ±1.5 km of the camera, at heights through the layer.
            let x = ((i * 37) % 61) as f64 * 50.0 - 1500.0;
            let z = ((i * 53) % 59) as f64 * 50.0 - 1450.0;
            let height = (i % 7) as f64 * 200.0;
            let taps = [0, 1].map(|a| {
                let h = [x, z][a];
                weather_taps(
                    (h + layer.weather_offset_m[a] + layer.skew[a] * height)
                        / layer.weather_scale_m,
                    weather.size,
                )
            });
            let direct = weather_coverage(&weather, &layer, [x, z], height);
            if direct > 0.0 && direct < 1.0 {
                varied += 1;
            }
            if weather_map_holds(origin, size, [taps[0][0].0, taps[1][0].0]) {
                inside += 1;
                let [cached, warp @ ..] = read_map(&map, origin, size, taps);
                // Only rounding may differ: both sides sum the same four products in f64.
                assert!(
                    (cached - direct).abs() < 1e-12,
                    "{cached} vs {direct} at {x}, {z}"
                );
                let direct_warp = shape_warp(&weather, &layer, [x, z], height);
                for (c, d) in warp.iter().zip(direct_warp) {
                    let d = d / layer.shape_scale_m;
                    assert!(
                        (c - d).abs() < 1e-12,
                        "warp {warp:?} vs {direct_warp:?} at {x}, {z}"
                    );
                }
                if warp.iter().any(|w| w.abs() > 0.05) {
                    curled += 1;
                }
            }
        }
        // The test means something: most points fall in the map, and the coverage and the warp
        // vary there.
        assert!(inside > 300, "{inside}");
        assert!(varied > 50, "{varied}");
        assert!(curled > 50, "{curled}");
    }

    #[test]
    fn the_map_is_centred_on_the_camera_and_scrolls_with_the_wind() {
        let weather = weather();
        let mut layer = layer();
        let size = 16;
        let n = f64::from(weather.size);
        let texel_m = layer.weather_scale_m / n;
        // The camera's look-up (horizontal 0, at the base) has its first tap inside, with room
        // for half the map on every side.
        let origin = weather_map_origin(&layer, weather.size, size);
        let camera = [0, 1].map(|a| {
            weather_taps(
                layer.weather_offset_m[a] / layer.weather_scale_m,
                weather.size,
            )[0]
            .0
        });
        for a in 0..2 {
            let local = camera[a] - origin[a];
            assert!((7..=8).contains(&local), "{local}");
        }
        // After a week of wind at 10 m/s east (6048 km), the origin is still the camera's
        // texel minus half the map, and the offset stays below one period.
        let week_m = 10.0 * 7.0 * 86_400.0;
        layer.set_noise_origin([123_456.7 - week_m, -98_765.4]);
        assert!(
            layer.weather_offset_m[0] >= 0.0 && layer.weather_offset_m[0] < layer.weather_scale_m
        );
        let moved = weather_map_origin(&layer, weather.size, size);
        let expected = ((123_456.7 - week_m) / texel_m).rem_euclid(n).round() as i64 - 8;
        assert_eq!(moved[0], expected);
        // One texel of drift moves the origin by one texel (modulo the period's wrap).
        layer.set_noise_origin([123_456.7 - week_m - texel_m, -98_765.4]);
        let step = weather_map_origin(&layer, weather.size, size);
        assert_eq!((moved[0] - step[0]).rem_euclid(weather.size as i64), 1);
    }

    #[test]
    fn coverage_one_and_zero_fill_the_map() {
        let weather = weather();
        let mut layer = layer();
        layer.far_count = 0;
        layer.coverage = 1.0;
        let origin = weather_map_origin(&layer, weather.size, 8);
        assert!(
            build_weather_map(&weather, &layer, origin, 8)
                .iter()
                .all(|&[k, ..]| k == 1.0)
        );
        layer.coverage = 0.0;
        assert!(
            build_weather_map(&weather, &layer, origin, 8)
                .iter()
                .all(|&[k, ..]| k == 0.0)
        );
    }

    #[test]
    fn a_growing_layer_reads_its_columns_cover_instead_of_the_noise() {
        use crate::reference::render::{
            LayerGrowth, OVERCAST_COVERAGE, PATCH_COVERAGE, growth_coverage, local_coverage,
        };
        let weather = weather();
        // An 8 x 8 grid over the 32-texel noise: 4 texels per column along each axis.
        let mut cover = vec![0.0f32; 64];
        cover[3 + 8 * 2] = 1.0;
        cover[4 + 8 * 2] = 0.125;
        let mut layer = MarchLayer {
            coverage: 0.5,
            ..MarchLayer::default()
        };
        layer.growth = Some(LayerGrowth {
            size: [8, 8],
            slice: 0,
            cover: cover.into(),
        });
        let kappa =
            |layer: &MarchLayer, x: i64, y: i64| weather_texel_coverage(&weather, layer, [x, y]);
        for y in 0..32 {
            for x in 0..32 {
                let expected = match (x / 4, y / 4) {
                    (3, 2) => PATCH_COVERAGE,
                    (4, 2) => 0.5 * PATCH_COVERAGE,
                    _ => 0.0,
                };
                assert_eq!(kappa(&layer, x, y), expected, "texel ({x}, {y})");
                // Texels wrap with the noise, and the grid with them.
                assert_eq!(kappa(&layer, x - 32, y + 64), expected);
            }
        }
        // Without the automaton the same texels read the noise: the weather's pattern differs.
        let noise = MarchLayer {
            growth: None,
            ..layer.clone()
        };
        assert!((0..32).any(|x| kappa(&noise, x, 9) != kappa(&layer, x, 9)));
        // Coverage 0 clears even the automaton's clouds; above OVERCAST_COVERAGE it closes.
        assert_eq!(growth_coverage(0.0, 1.0), 0.0);
        assert_eq!(growth_coverage(1.0, 0.0), 1.0);
        // Between them it blends toward overcast as the weather noise's clouds do where the
        // noise is clear.
        let closing = 0.5 * (OVERCAST_COVERAGE + 1.0);
        assert_eq!(growth_coverage(closing, 0.0), local_coverage(closing, 0.0));
        // Halfway from OVERCAST_COVERAGE to 1 the blend is halfway to overcast.
        assert!((growth_coverage(closing, 0.0) - 0.5).abs() < 1e-12);
        // A grid finer than the noise reads the column under the texel's first corner.
        let fine = LayerGrowth {
            size: [64, 64],
            slice: 0,
            cover: (0..64 * 64).map(|i| (i % 64) as f32 / 64.0).collect(),
        };
        assert_eq!(fine.cover_at([5, 0], 32), 10.0 / 64.0);
        // A cover shorter than its grid reads 0 past its end (never out of bounds).
        let short = LayerGrowth {
            cover: vec![1.0; 3].into(),
            ..fine
        };
        assert_eq!(short.cover_at([31, 31], 32), 0.0);
    }
}
