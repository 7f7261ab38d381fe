// The weather map: each layer's local coverage and shape warp per weather texel around the
// camera, one array slice per layer, which the march reads instead of recomputing the coverage
// and the warp's curl look-ups at every sample.
// Rust side: `src/render/weather_map/mod.rs`; CPU twin: `src/reference/weather_map.rs`.

#import bevy_cloudscape::cloud_parameters::cloud_layers
#import bevy_cloudscape::cloud_density::{texel_shape_warp, weather_texel_coverage}

// Written by `GpuWeatherMapUniforms` (Rust); `render/contract.rs` holds the two layouts equal.
struct WeatherMapUniforms {
    // Texels per side of every slice.
    size: u32,
    // Slices written: the view's layers, in the order of `cloud_layers`.
    slices: u32,
    pad0: u32,
    pad1: u32,
}

@group(0) @binding(0) var weather_map_out: texture_storage_2d_array<rgba32float, write>;
@group(0) @binding(1) var<uniform> map: WeatherMapUniforms;

// Texel (i, j) of slice s holds weather texel origin + (i, j) of layer s, where the origin is the
// layer's `weather_map.xy`: its local coverage and its shape warp in shape periods
// (`texel_shape_warp`). Rust: `build_weather_map`.
@compute @workgroup_size(8, 8, 1)
fn build_weather_map(@builtin(global_invocation_id) id: vec3<u32>) {
    if id.x >= map.size || id.y >= map.size || id.z >= map.slices {
        return;
    }
    let texel = vec2<i32>(cloud_layers[id.z].weather_map.xy) + vec2<i32>(id.xy);
    let kappa = weather_texel_coverage(id.z, texel);
    let warp = texel_shape_warp(id.z, texel);
    textureStore(weather_map_out, vec2<i32>(id.xy), i32(id.z), vec4<f32>(kappa, warp, 0.0));
}
