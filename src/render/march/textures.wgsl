#define_import_path bevy_cloudscape::cloud_textures

// The textures the cloud march reads, and their bindings: the noise, the cloud shadow map, the
// blue noise and the weather map. A shader library of the cloud march (see `clouds.wgsl`).
//
// CPU twin: `src/reference/render/textures.rs` (`CloudTextures`, the same texels, and
// `NoiseTexture3d::sample`, the twin of the sampling here). The shadow map's and the blue noise's
// texels come from `src/reference/shadow.rs` and `src/reference/blue_noise.rs`.

// Rgba16Float with full mips: R Perlin-Worley, G/B/A Worley fBm (reference/noise/mod.rs).
@group(0) @binding(4) var base_noise: texture_3d<f32>;
// Rgba16Float with full mips: R/G/B Worley fBm, A unused.
@group(0) @binding(5) var detail_noise: texture_3d<f32>;
// Rgba8Unorm, one mip: R coverage Perlin-Worley, G variation, B/A curl. Read with textureLoad
// (`weather_texel_coverage`).
@group(0) @binding(6) var weather_noise: texture_2d<f32>;
// linear / linear / linear-mip, repeat.
@group(0) @binding(7) var noise_sampler: sampler;
// The cloud shadow map (Rgba16Float: T to the ground, optical depths of the levels; see
// reference/shadow.rs), or a white texture when `clouds.shadow_map` is 0. Bound by the march
// pass only (binding 9; 8 belongs to haze.wgsl).
@group(0) @binding(9) var cloud_shadow_map: texture_2d<f32>;
// R32Float, BLUE_NOISE_SIZE², the ray-start jitter's blue noise (reference/blue_noise.rs). Bound
// by the march pass only (binding 10).
@group(0) @binding(10) var blue_noise: texture_2d<f32>;
// R32Float array, one slice per growing layer (`CloudLayerGpu::growth`): each column's cloud
// fraction from the growth automaton (src/render/growth/), a 1x1 stand-in without one. Bound by
// every pass that reads the weather (binding 13).
@group(0) @binding(13) var growth_cover: texture_2d_array<f32>;
#ifdef WEATHER_MAP
// R32Float array, one slice per layer: `weather_texel_coverage` around the camera, written each
// frame by the weather-map pass (src/render/weather_map/). Bound by the march pass only (binding
// 12; 11 belongs to march.wgsl), which defines WEATHER_MAP.
@group(0) @binding(12) var weather_map: texture_2d_array<f32>;
#endif

// Rust: `NoiseTexture3d::sample` (base), with an explicit level: the march picks mips by
// distance (Pérez Martín 2022, "LODs Over Distance").
fn sample_base_noise(uvw: vec3<f32>, lod: f32) -> vec4<f32> {
    return textureSampleLevel(base_noise, noise_sampler, uvw, lod);
}

// Rust: `NoiseTexture3d::sample` (detail).
fn sample_detail_noise(uvw: vec3<f32>, lod: f32) -> vec4<f32> {
    return textureSampleLevel(detail_noise, noise_sampler, uvw, lod);
}
