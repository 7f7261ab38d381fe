#define_import_path bevy_cloudscape::clouds

// f32 has no infinity literal: "no distance" / "the sky" is FAR_AWAY (Rust: f64::INFINITY).
// Pass it, or any larger value, as `t_max` for sky pixels.
#import bevy_cloudscape::composite::{
    FAR_AWAY, NO_HIT, intersect_altitude_sphere, ground_distance,
}

// The cloud ray-march: shell geometry on a curved planet, Pérez Martín 2022's density model, the light
// march toward the sun and Hillaire 2016's energy-conserving integration. A shader library: the
// entry shader imports it, declares @binding(0) `view: View` and @binding(1) the depth prepass,
// builds one ray per pixel and calls `march_clouds`.
//
// CPU twin: `src/reference/render.rs`. Every function here has a Rust function of the same name
// there (f64 there, f32 here; the private per-ray helpers are methods of its `Ray`) and the GPU
// output is tested against it, so change both together. The module docs there explain the
// geometry, the density model and the lighting, with their sources:
// - Hillaire 2016, "Physically Based Sky, Atmosphere and Cloud Rendering in Frostbite";
// - Wrenninge 2013, "Oz: the great and volumetric" (multiple-scattering octaves);
// - Schneider 2015, "The real-time volumetric cloudscapes of Horizon Zero Dawn";
// - Pérez Martín 2022 (Aetherius): "Density Model", "Cloud Lighting", "Multiple Scattering
//   Approximation", "Atmosphere", "Optimization".
//
// Units: metres, 1/m for extinction, radians. All positions are relative to the camera and
// distances along a ray come from the camera altitude and mu = dot(direction, up), never from
// positions near the planet centre, so f32 keeps centimetres where it matters.
//
// Output of `march_clouds`: vec4(in-scattered radiance RGB, view transmittance), composited as
// `scene * T + L`. Radiance is in the units of `sun_illuminance` per steradian (lux -> cd/m^2)
// *before exposure*: the entry shader multiplies it by the view's exposure.

// Per-view uniforms, written by `GpuCloudUniforms` (render/march/mod.rs) from `MarchSettings`
// (reference/render.rs, the f64 source of the same values). Every scalar group fills 16 bytes
// before the first vec4, so the layout is the same under WGSL's uniform rules and encase;
// `render::contract` checks size and field order.
struct CloudUniforms {
    // Radius of the ground sphere, m.
    planet_radius_m: f32,
    // Camera altitude above the ground sphere, m (computed on the CPU in f64).
    camera_altitude_m: f32,
    // Angle a pixel subtends, rad: a sample at distance t stands for t * pixel_angle_rad metres.
    pixel_angle_rad: f32,
    // A primary step at distance t is (1 + step_growth * t) times one at the camera; 1/m.
    step_growth: f32,
    // Primary steps across each interval of layers the ray crosses.
    primary_steps: u32,
    // Light-march steps toward the sun (0: no self-shadowing).
    light_steps: u32,
    // Multiple-scattering octaves (1: single scattering).
    octaves: u32,
    // Number of layers in `cloud_layers` (inactive ones may be left out by the CPU or not).
    layer_count: u32,
    // The march stops once the view transmittance is at or below this.
    transmittance_cutoff: f32,
    // Wrenninge 2013 octave factors a, b, c (Pérez Martín 2022: 0.3, 0.75, 0.5).
    ms_attenuation: f32,
    ms_contribution: f32,
    ms_eccentricity: f32,
    // Dual-lobe Henyey-Greenstein: forward and backward asymmetry, weight of the back lobe.
    phase_g_forward: f32,
    phase_g_back: f32,
    phase_blend: f32,
    // Blue-noise jitter of the ray start: 0 off (step midpoints), 1 on.
    jitter: u32,
    // Frame counter that animates the jitter.
    frame_index: u32,
    // From this distance on, m, cloud samples read the sun's optical depth from the shadow map
    // where it covers them (Rust: `MarchSettings::sun_from_shadow_map_m`; FAR_AWAY: never).
    sun_from_shadow_map_m: f32,
    // 1 when `cloud_shadow_map` and the shadow_map_* fields hold a map, 0 otherwise.
    shadow_map: u32,
    // Shortest primary step, m (Rust: `MarchSettings::min_step_m`; 0: always primary_steps).
    min_step_m: f32,
    // Temporal upsampling: where this frame's reduced-resolution rays pass through their
    // texels, in uv from the texels' centres (Rust: `reference::composite::sample_offset`
    // over the march's size). 0 at full resolution and without the accumulation.
    sample_offset_uv: vec2<f32>,
    // Most extra light steps per view-sample footprint (Rust:
    // `MarchSettings::light_steps_per_footprint`; 0: no limit).
    light_steps_per_footprint: f32,
    pad_b: u32,
    // xyz: unit vector from the planet centre through the camera.
    camera_up: vec4<f32>,
    // xyz: unit vector toward the sun, world space.
    sun_direction: vec4<f32>,
    // rgb: sun illuminance at the clouds, lux, already attenuated by the atmosphere.
    sun_illuminance: vec4<f32>,
    // rgb: ambient sky radiance at the top and at the bottom of a layer, cd/m^2.
    ambient_top: vec4<f32>,
    ambient_bottom: vec4<f32>,
    // The shadow map's centre relative to the camera, m, and its half-extent axes divided by
    // their squared length, 1/m (Rust: `ShadowMapImage::uv`).
    shadow_map_centre_m: vec4<f32>,
    shadow_map_axis_x: vec4<f32>,
    shadow_map_axis_y: vec4<f32>,
    // xy: (bottom, top) of the layers the map holds, m (Rust: `ShadowMapFrame::cloud_range_m`);
    // z: the side of a texel, m (`ShadowMapFrame::texel_m`).
    shadow_map_range_m: vec4<f32>,
}

// One cloud layer of the storage buffer, written by `GpuCloudLayer` (render/march/mod.rs) from
// `MarchLayer` (reference/render.rs); `render::contract` checks size and field order.
//
// Offsets are wrapped by their own period on the CPU in f64 (`MarchLayer::set_noise_origin`), so
// they stay below one period. Horizontal coordinates are along `horizontal_axes(up)`.
struct CloudLayerGpu {
    base_m: f32,
    top_m: f32,
    coverage: f32,
    extinction: f32,
    weather_scale_m: f32,
    shape_scale_m: f32,
    detail_scale_m: f32,
    detail_erosion: f32,
    shape_strength: f32,
    precipitation: f32,
    profile_count: u32,
    far_count: u32,
    // Rust: `MarchLayer::coverage_height`.
    coverage_height: f32,
    // Rust: `MarchLayer::warp_offset_m`.
    warp_offset_m: vec2<f32>,
    weather_offset_m: vec4<f32>,
    noise_offset_m: vec4<f32>,
    profile: array<vec4<f32>, 4>,
    // Coverage toward far places: dot(horizontal, xy) + z is the fraction of the way from the
    // near place to the far one, w the far coverage (Rust: `MarchLayer::far`).
    far: array<vec4<f32>, 2>,
    // The layer's slice of the weather map (Rust: `reference::weather_map`): xy the weather
    // texel at map texel (0, 0), z the array slice, w the side in texels (< 2: no map).
    weather_map: vec4<f32>,
}

@group(0) @binding(2) var<uniform> clouds: CloudUniforms;
@group(0) @binding(3) var<storage, read> cloud_layers: array<CloudLayerGpu>;
// Rgba16Float with full mips: R Perlin-Worley, G/B/A Worley fBm (reference/noise.rs).
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
#ifdef WEATHER_MAP
// R32Float array, one slice per layer: `weather_texel_coverage` around the camera, written each
// frame by the weather-map pass (src/render/weather_map/). Bound by the march pass only (binding
// 12; 11 belongs to march.wgsl), which defines WEATHER_MAP.
@group(0) @binding(12) var weather_map: texture_2d_array<f32>;
#endif

// Rust: the constants of the same names; see their docs there.
const MAX_PROFILE_POINTS: u32 = 8u;
const MAX_FAR_COVERAGES: u32 = 2u;
const FAR_BLEND_START: f32 = 0.3;
const MAX_SCATTERING_OCTAVES: u32 = 8u;
const MAX_PRIMARY_STEPS: u32 = 1024u;
const MAX_LIGHT_STEPS: u32 = 64u;
// Where each light-march step is sampled: its midpoint, whatever the view ray's jitter (an
// average of e^-tau over offsets is biased bright). Rust: `LIGHT_SAMPLE_OFFSET`.
const LIGHT_SAMPLE_OFFSET: f32 = 0.5;
const LIGHT_STEP_SPAN_M: f32 = 2000.0;
const CHEAP_STRIDE: u32 = 4u;
const EMPTY_STEPS_TO_CHEAP: u32 = 4u;
const MAX_STEP_OPTICAL_DEPTH: f32 = 1.0;
const MAX_SUBSTEPS: u32 = 8u;
const MAX_PARTS: u32 = 32u;
const CLEAR_STEP_OPTICAL_DEPTH: f32 = 0.1;
const EDGE_SEARCH_STEPS: u32 = 6u;
const PRECIPITATION_ABSORPTION: f32 = 0.5;
const MAX_DETAIL_EROSION: f32 = 0.9;
const DETAIL_TRANSITION_HEIGHT: f32 = 0.2;
const MAX_PHASE_G: f32 = 0.999;
const FBM_WEIGHTS: vec3<f32> = vec3<f32>(0.625, 0.25, 0.125);
const WEATHER_COVERAGE_RANGE: vec2<f32> = vec2<f32>(0.4, 0.95);
const COVERAGE_EDGE_WIDTH: f32 = 0.25;
const OVERCAST_COVERAGE: f32 = 0.9;
const PATCH_COVERAGE: f32 = 0.25;
const PATCH_AREA_GAIN: f32 = 2.5;
const BROKEN_PATCH_AREA: f32 = 0.75;
const CLOSING_COVERAGE: f32 = 0.75;
const SHAPE_WARP: f32 = 0.125;
const SHAPE_WARP_BROAD: f32 = 0.5;
const BROAD_WARP_PERIODS: f32 = 32.0;
// Below this optical thickness `mean_step_transmittance` uses its series (Rust: SERIES_LIMIT,
// 1e-5 there because f64 has expm1).
const SERIES_LIMIT: f32 = 0.1;
const PI: f32 = 3.141592653589793;
// Rust: the constants of the same names in reference/blue_noise.rs.
const GOLDEN_RATIO_CONJUGATE: f32 = 0.6180339887498949;
const JITTER_FRAME_PERIOD: u32 = 256u;

fn saturate(x: f32) -> f32 {
    return clamp(x, 0.0, 1.0);
}

// ---------------------------------------------------------------------------------------------
// Geometry
// ---------------------------------------------------------------------------------------------

// Altitude at distance t along the ray: h + s / (A + sqrt(A^2 + s)), A = R + h,
// s = 2 A mu t + t^2, without subtracting two planet radii. Rust: `altitude_along_ray`.
fn altitude_along_ray(h: f32, mu: f32, t: f32, planet_radius: f32) -> f32 {
    let a = planet_radius + h;
    let s = 2.0 * a * mu * t + t * t;
    return h + s / (a + sqrt(max(a * a + s, 0.0)));
}

// The parts of a ray inside the shell [base, top]: xy and zw are segments [start, end] (empty
// when end <= start), not clipped to the ground or the scene. Rust: `shell_segments`.
fn shell_segments(h: f32, mu: f32, planet_radius: f32, base: f32, top: f32) -> vec4<f32> {
    let outer = intersect_altitude_sphere(h, mu, planet_radius, top);
    let inner = intersect_altitude_sphere(h, mu, planet_radius, base);
    let near_start = max(outer.x, 0.0);
    return vec4<f32>(near_start, min(inner.x, outer.y), max(inner.y, near_start), outer.y);
}

// Number of layers to read: the uniform's count, never past the buffer.
fn cloud_layer_count() -> u32 {
    return min(clouds.layer_count, arrayLength(&cloud_layers));
}

// Largest coverage anywhere: the layer's own or a far one. Rust: `max_coverage`.
fn max_coverage(layer: CloudLayerGpu) -> f32 {
    var coverage = layer.coverage;
    for (var i = 0u; i < min(layer.far_count, MAX_FAR_COVERAGES); i++) {
        coverage = max(coverage, layer.far[i].w);
    }
    return coverage;
}

// Coverage at `horizontal_m`, blended toward each far place by a smoothstep of the fraction of
// the way there, from FAR_BLEND_START to 1. Rust: `layer_coverage`.
fn layer_coverage(layer: CloudLayerGpu, horizontal_m: vec2<f32>) -> f32 {
    var coverage = layer.coverage;
    for (var i = 0u; i < min(layer.far_count, MAX_FAR_COVERAGES); i++) {
        let far = layer.far[i];
        let s = dot(horizontal_m, far.xy) + far.z;
        let t = saturate((s - FAR_BLEND_START) / (1.0 - FAR_BLEND_START));
        coverage += t * t * (3.0 - 2.0 * t) * (far.w - layer.coverage);
    }
    return saturate(coverage);
}

// Rust: `layer_is_active`.
fn layer_is_active(layer: CloudLayerGpu) -> bool {
    return max_coverage(layer) > 0.0 && layer.extinction > 0.0 && layer.top_m > layer.base_m;
}

// Next interval [start, end] at or after t_from where the ray is inside an active layer, the
// pieces of every layer merged, clipped to t_max; start >= end when none. Rust:
// `next_cloud_interval`.
fn next_cloud_interval(h: f32, mu: f32, t_from: f32, t_max: f32) -> vec2<f32> {
    let count = cloud_layer_count();
    let radius = clouds.planet_radius_m;
    var start = FAR_AWAY;
    for (var i = 0u; i < count; i++) {
        let layer = cloud_layers[i];
        if !layer_is_active(layer) {
            continue;
        }
        let s = shell_segments(h, mu, radius, layer.base_m, layer.top_m);
        if s.y > s.x && s.y > t_from {
            start = min(start, max(s.x, t_from));
        }
        if s.w > s.z && s.w > t_from {
            start = min(start, max(s.z, t_from));
        }
    }
    if !(start < t_max) {
        return vec2<f32>(t_max);
    }
    // Grow the end over every piece that starts inside; each pass adds one piece at least.
    var end = start;
    for (var guard = 0u; guard <= 2u * count; guard++) {
        var grown = false;
        for (var i = 0u; i < count; i++) {
            let layer = cloud_layers[i];
            if !layer_is_active(layer) {
                continue;
            }
            let s = shell_segments(h, mu, radius, layer.base_m, layer.top_m);
            if s.y > s.x && s.y > t_from && s.x <= end && s.y > end {
                end = s.y;
                grown = true;
            }
            if s.w > s.z && s.w > t_from && s.z <= end && s.w > end {
                end = s.w;
                grown = true;
            }
        }
        if !grown {
            break;
        }
    }
    return vec2<f32>(start, min(end, t_max));
}

// Horizontal noise axes perpendicular to up: world +x and +z when up is +y. Rust:
// `horizontal_axes` (returns [x, z]).
struct HorizontalAxes {
    x: vec3<f32>,
    z: vec3<f32>,
}

fn horizontal_axes(up: vec3<f32>) -> HorizontalAxes {
    var x = cross(up, vec3<f32>(0.0, 0.0, 1.0));
    if dot(x, x) < 1e-6 {
        x = cross(up, vec3<f32>(1.0, 0.0, 0.0));
    }
    x = normalize(x);
    return HorizontalAxes(x, cross(x, up));
}

// expm1 and log1p, accurate near 0 where exp(x) - 1 and log(1 + x) lose digits in f32 (the Rust
// twin uses f64's exp_m1 and ln_1p).
fn expm1_stable(x: f32) -> f32 {
    if abs(x) < 1e-2 {
        return x * (1.0 + x * (0.5 + x * (1.0 / 6.0 + x / 24.0)));
    }
    return exp(x) - 1.0;
}

fn log1p_stable(x: f32) -> f32 {
    if abs(x) < 1e-2 {
        return x * (1.0 - x * (0.5 - x * (1.0 / 3.0 - x * 0.25)));
    }
    return log(1.0 + x);
}

// Boundary k of n in an interval lies at start + (end - start) * step_warp(k / n, beta),
// beta = g (end - start) / (1 + g start): steps (1 + g t) times as long as at the camera.
// step_warp = ((1 + beta)^u - 1) / beta = expm1(u log1p(beta)) / beta. Rust: `step_warp`.
fn step_warp(u: f32, beta: f32) -> f32 {
    if beta <= 1e-6 {
        return u;
    }
    return expm1_stable(u * log1p_stable(beta)) / beta;
}

// ---------------------------------------------------------------------------------------------
// Density (Pérez Martín 2022, "Density Model"; Schneider 2015)
// ---------------------------------------------------------------------------------------------

// Piecewise-linear profile at a height fraction, end values held, 1 with no points.
// Rust: `profile_density`.
fn profile_density(layer: CloudLayerGpu, height_fraction: f32) -> f32 {
    let count = min(layer.profile_count, MAX_PROFILE_POINTS);
    if count == 0u {
        return 1.0;
    }
    // A local copy: arrays held by value cannot be indexed dynamically.
    var packed = layer.profile;
    let first = packed[0].xy;
    if height_fraction <= first.x {
        return first.y;
    }
    var previous = first;
    for (var i = 1u; i < count; i++) {
        let pair = packed[i >> 1u];
        let point = select(pair.xy, pair.zw, (i & 1u) == 1u);
        if height_fraction <= point.x {
            let span = point.x - previous.x;
            if span > 0.0 {
                return mix(previous.y, point.y, (height_fraction - previous.x) / span);
            }
            return point.y;
        }
        previous = point;
    }
    return previous.y;
}

// Local coverage from the layer coverage and the weather channel: patches over
// min(PATCH_AREA_GAIN * coverage, BROKEN_PATCH_AREA) of the map, PATCH_COVERAGE in their middle
// (both rising to 1 from CLOSING_COVERAGE), 0 everywhere at coverage 0, 1 everywhere at
// coverage 1. Rust: `local_coverage`.
fn local_coverage(coverage: f32, weather: f32) -> f32 {
    if !(coverage > 0.0) {
        return 0.0;
    }
    let w = saturate((weather - WEATHER_COVERAGE_RANGE.x) / (WEATHER_COVERAGE_RANGE.y - WEATHER_COVERAGE_RANGE.x));
    let closing = saturate((coverage - CLOSING_COVERAGE) / (1.0 - CLOSING_COVERAGE));
    let area = mix(min(PATCH_AREA_GAIN * coverage, BROKEN_PATCH_AREA), 1.0, closing);
    let field = saturate((w - (1.0 - area)) / COVERAGE_EDGE_WIDTH);
    let peak = mix(PATCH_COVERAGE, 1.0, closing);
    let overcast = saturate((coverage - OVERCAST_COVERAGE) / (1.0 - OVERCAST_COVERAGE));
    return max(field * peak, overcast);
}

// How full a patch is: 1 from the middle of a broken layer's patch up. Rust: `patch_fill`.
fn patch_fill(kappa: f32) -> f32 {
    return saturate(kappa / PATCH_COVERAGE);
}

// How far the profile is stretched up the layer where a patch is filled to `fill`:
// 1 - s * (1 - fill)^2, with s the layer's coverage height clamped to 0-1 (NaN: 0). Rust:
// `coverage_height_scale`.
fn coverage_height_scale(coverage_height: f32, fill: f32) -> f32 {
    var s = 0.0;
    if coverage_height > 0.0 {
        s = min(coverage_height, 1.0);
    }
    let gap = 1.0 - fill;
    return 1.0 - s * gap * gap;
}

// Rust: `remap`.
fn remap(value: f32, old_min: f32, old_max: f32, new_min: f32, new_max: f32) -> f32 {
    return new_min + (value - old_min) / (old_max - old_min) * (new_max - new_min);
}

// Perlin-Worley carved by the low-frequency Worley fBm (Pérez Martín 2022, Figure 36). Rust: `base_shape`.
fn base_shape(sample: vec4<f32>) -> f32 {
    let fbm = dot(sample.yzw, FBM_WEIGHTS);
    return saturate(remap(sample.x, fbm - 1.0, 1.0, 0.0, 1.0));
}

// Detail fBm near the base (wisps), its inverse higher up (billows). Rust: `detail_erosion`.
fn detail_erosion(sample: vec4<f32>, height_fraction: f32) -> f32 {
    let fbm = dot(sample.xyz, FBM_WEIGHTS);
    return mix(fbm, 1.0 - fbm, saturate(height_fraction / DETAIL_TRANSITION_HEIGHT));
}

// Mip level for a footprint on texels texel_m apart. Rust: `texture_lod`.
fn texture_lod(footprint_m: f32, texel_m: f32) -> f32 {
    return log2(max(footprint_m / texel_m, 1.0));
}

// Rust: `NoiseTexture3d::sample` (base), with an explicit level: the march picks mips by
// distance (Pérez Martín 2022, "LODs Over Distance").
fn sample_base_noise(uvw: vec3<f32>, lod: f32) -> vec4<f32> {
    return textureSampleLevel(base_noise, noise_sampler, uvw, lod);
}

// Rust: `NoiseTexture3d::sample` (detail).
fn sample_detail_noise(uvw: vec3<f32>, lod: f32) -> vec4<f32> {
    return textureSampleLevel(detail_noise, noise_sampler, uvw, lod);
}

// Local coverage of weather texel `texel` (not wrapped): `local_coverage` of its coverage channel
// and of the layer coverage at the texel centre. The weather-map pass stores exactly this.
// Rust: `weather_texel_coverage`.
fn weather_texel_coverage(layer: CloudLayerGpu, texel: vec2<i32>) -> f32 {
    let size = vec2<i32>(textureDimensions(weather_noise));
    let texel_m = layer.weather_scale_m / f32(size.x);
    let centre = (vec2<f32>(texel) + 0.5) * texel_m - layer.weather_offset_m.xy;
    let coverage = layer_coverage(layer, centre);
    if coverage >= 1.0 {
        return 1.0;
    }
    // True modulo on integers, so negative indices repeat too.
    let wrapped = (texel % size + size) % size;
    return local_coverage(coverage, textureLoad(weather_noise, wrapped, 0).x);
}

// The skewed weather look-up in texel units, texel centres at integers:
// (horizontal + offset + skew * height) / scale * size - 0.5. Rust: `weather_look_up`.
fn weather_look_up(layer: CloudLayerGpu, horizontal_m: vec2<f32>, height_above_base_m: f32) -> vec2<f32> {
    let size = f32(textureDimensions(weather_noise).x);
    let uv = (horizontal_m + layer.weather_offset_m.xy + layer.weather_offset_m.zw * height_above_base_m)
        / layer.weather_scale_m;
    return uv * size - 0.5;
}

// Local coverage of a layer at `horizontal_m`, `height_above_base_m` up: the bilinear filter of
// `weather_texel_coverage` over the four texels around the skewed weather look-up, filtered here
// from texel values rather than by a sampler (the coverage ramp multiplies errors by about 7, and
// hardware filtering is not exact: lavapipe rounds filtered Rgba8Unorm to 1/255). The march reads
// the four values from its weather map when the map holds them; elsewhere, and in the passes that
// bind no map, it computes them. Rust: `weather_coverage`.
fn weather_coverage(layer: CloudLayerGpu, horizontal_m: vec2<f32>, height_above_base_m: f32) -> f32 {
    let x = weather_look_up(layer, horizontal_m, height_above_base_m);
    let cell = floor(x);
    let weight = x - cell;
    let texel = vec2<i32>(cell);
#ifdef WEATHER_MAP
    let map = layer.weather_map;
    let local = texel - vec2<i32>(map.xy);
    let last = i32(map.w) - 2;
    if map.w >= 2.0 && all(local >= vec2<i32>(0)) && all(local <= vec2<i32>(last)) {
        let slice = i32(map.z);
        let k00 = textureLoad(weather_map, local, slice, 0).x;
        let k10 = textureLoad(weather_map, local + vec2<i32>(1, 0), slice, 0).x;
        let k01 = textureLoad(weather_map, local + vec2<i32>(0, 1), slice, 0).x;
        let k11 = textureLoad(weather_map, local + vec2<i32>(1, 1), slice, 0).x;
        return mix(mix(k00, k10, weight.x), mix(k01, k11, weight.x), weight.y);
    }
#endif
    let k00 = weather_texel_coverage(layer, texel);
    let k10 = weather_texel_coverage(layer, texel + vec2<i32>(1, 0));
    let k01 = weather_texel_coverage(layer, texel + vec2<i32>(0, 1));
    let k11 = weather_texel_coverage(layer, texel + vec2<i32>(1, 1));
    return mix(mix(k00, k10, weight.x), mix(k01, k11, weight.x), weight.y);
}

// The weather noise's curl (B, A) as 2c - 1 per axis, filtered bilinearly from texel loads at
// texel coordinate `x` (texel centres at integers). Rust: `curl_look_up`.
fn curl_look_up(x: vec2<f32>) -> vec2<f32> {
    let size = vec2<i32>(textureDimensions(weather_noise));
    let cell = floor(x);
    let weight = x - cell;
    // True modulo on integers, so negative indices repeat too.
    let t0 = (vec2<i32>(cell) % size + size) % size;
    let t1 = (t0 + vec2<i32>(1)) % size;
    let c00 = textureLoad(weather_noise, t0, 0).zw;
    let c10 = textureLoad(weather_noise, vec2<i32>(t1.x, t0.y), 0).zw;
    let c01 = textureLoad(weather_noise, vec2<i32>(t0.x, t1.y), 0).zw;
    let c11 = textureLoad(weather_noise, t1, 0).zw;
    return 2.0 * mix(mix(c00, c10, weight.x), mix(c01, c11, weight.x), weight.y) - 1.0;
}

// Displacement (metres) of the base-shape look-up, so repeats of the shape do not add up to
// streaks along grazing rays: the fine warp, +-SHAPE_WARP of the shape period from the curl at
// the look-up `weather_coverage` uses, plus the broad warp, +-SHAPE_WARP_BROAD of the period
// from the curl over BROAD_WARP_PERIODS shape periods (no skew). Rust: `shape_warp`.
fn shape_warp(layer: CloudLayerGpu, horizontal_m: vec2<f32>, height_above_base_m: f32) -> vec2<f32> {
    let fine = curl_look_up(weather_look_up(layer, horizontal_m, height_above_base_m));
    let size = f32(textureDimensions(weather_noise).x);
    let broad_uv = (horizontal_m + layer.warp_offset_m) / (BROAD_WARP_PERIODS * layer.shape_scale_m);
    let broad = curl_look_up(broad_uv * size - 0.5);
    return (SHAPE_WARP * fine + SHAPE_WARP_BROAD * broad) * layer.shape_scale_m;
}

// Extinction (1/m) of one layer at horizontal coordinates `horizontal_m` (along
// `horizontal_axes`, relative to the camera) and `altitude_m`; `footprint_m` picks the mips;
// `with_detail = false` is the cheap base-only density (never below the full one).
// Rust: `layer_density`.
fn layer_density(layer: CloudLayerGpu, horizontal_m: vec2<f32>, altitude_m: f32, footprint_m: f32, with_detail: bool) -> f32 {
    let inside = altitude_m >= layer.base_m && altitude_m <= layer.top_m;
    if !layer_is_active(layer) || !inside {
        return 0.0;
    }
    let height_above_base = altitude_m - layer.base_m;
    let height_fraction = height_above_base / (layer.top_m - layer.base_m);
    let kappa = weather_coverage(layer, horizontal_m, height_above_base);
    if !(kappa > 0.0) {
        return 0.0;
    }
    let fill = patch_fill(kappa);
    let profile = profile_density(layer, height_fraction / coverage_height_scale(layer.coverage_height, fill));
    if !(profile > 0.0) {
        return 0.0;
    }
    let strength = saturate(layer.shape_strength);
    var shape = 1.0;
    if strength > 0.0 {
        let warp = shape_warp(layer, horizontal_m, height_above_base);
        let uvw = vec3<f32>(horizontal_m.x + layer.noise_offset_m.x + warp.x, altitude_m, horizontal_m.y + layer.noise_offset_m.y + warp.y)
            / layer.shape_scale_m;
        let texel_m = layer.shape_scale_m / f32(textureDimensions(base_noise).x);
        shape = mix(1.0, base_shape(sample_base_noise(uvw, texture_lod(footprint_m, texel_m))), strength);
    }
    let covered = saturate(remap(shape * profile, 1.0 - kappa, 1.0, 0.0, 1.0)) * fill;
    let erosion_strength = clamp(layer.detail_erosion, 0.0, MAX_DETAIL_EROSION) * strength;
    if !with_detail || !(erosion_strength > 0.0) || !(covered > 0.0) {
        return covered * layer.extinction;
    }
    let uvw = vec3<f32>(horizontal_m.x + layer.noise_offset_m.z, altitude_m, horizontal_m.y + layer.noise_offset_m.w)
        / layer.detail_scale_m;
    let texel_m = layer.detail_scale_m / f32(textureDimensions(detail_noise).x);
    let erosion = erosion_strength * detail_erosion(sample_detail_noise(uvw, texture_lod(footprint_m, texel_m)), height_fraction);
    return saturate(remap(covered, erosion, 1.0, 0.0, 1.0)) * layer.extinction;
}

// Sum of `layer_density` over the layers at one point. Rust: `total_extinction`.
fn total_extinction(horizontal_m: vec2<f32>, altitude_m: f32, footprint_m: f32, with_detail: bool) -> f32 {
    var extinction = 0.0;
    for (var i = 0u; i < cloud_layer_count(); i++) {
        extinction += layer_density(cloud_layers[i], horizontal_m, altitude_m, footprint_m, with_detail);
    }
    return extinction;
}

// Rust: `scattering_albedo`.
fn scattering_albedo(layer: CloudLayerGpu) -> f32 {
    return 1.0 - PRECIPITATION_ABSORPTION * saturate(layer.precipitation);
}

// ---------------------------------------------------------------------------------------------
// Light (Hillaire 2016; Wrenninge 2013; Pérez Martín 2022 "Cloud Lighting")
// ---------------------------------------------------------------------------------------------

// Rust: `henyey_greenstein`.
fn henyey_greenstein(cos_theta: f32, g_in: f32) -> f32 {
    let g = clamp(g_in, -MAX_PHASE_G, MAX_PHASE_G);
    let denominator = max(1.0 + g * g - 2.0 * g * cos_theta, 1e-12);
    return (1.0 - g * g) / (4.0 * PI * denominator * sqrt(denominator));
}

// Rust: `dual_lobe_phase`.
fn dual_lobe_phase(cos_theta: f32, g_forward: f32, g_back: f32, blend_in: f32) -> f32 {
    let blend = saturate(blend_in);
    return (1.0 - blend) * henyey_greenstein(cos_theta, g_forward) + blend * henyey_greenstein(cos_theta, g_back);
}

// Wrenninge 2013: sum over octaves of b^i exp(-a^i tau) p(c^i g). Rust: `multiple_scattering`.
fn multiple_scattering(optical_depth: f32, cos_theta: f32) -> f32 {
    let octaves = clamp(clouds.octaves, 1u, MAX_SCATTERING_OCTAVES);
    var a = 1.0;
    var b = 1.0;
    var c = 1.0;
    var sum = 0.0;
    for (var i = 0u; i < octaves; i++) {
        let phase = dual_lobe_phase(cos_theta, c * clouds.phase_g_forward, c * clouds.phase_g_back, clouds.phase_blend);
        sum += b * exp(-a * optical_depth) * phase;
        a *= clouds.ms_attenuation;
        b *= clouds.ms_contribution;
        c *= clouds.ms_eccentricity;
    }
    return sum;
}

// Distance to the exit of the shells that hold the point, toward the sun; negative when the
// ground blocks the sun. Rust: `light_march_distance`.
fn light_march_distance(altitude_m: f32, mu_sun: f32) -> f32 {
    let radius = clouds.planet_radius_m;
    if ground_distance(altitude_m, mu_sun, radius) < FAR_AWAY {
        return -1.0;
    }
    var distance = 0.0;
    let count = cloud_layer_count();
    for (var i = 0u; i < count; i++) {
        let layer = cloud_layers[i];
        if !layer_is_active(layer) || !(altitude_m >= layer.base_m && altitude_m <= layer.top_m) {
            continue;
        }
        let outer = intersect_altitude_sphere(altitude_m, mu_sun, radius, layer.top_m);
        let inner = intersect_altitude_sphere(altitude_m, mu_sun, radius, layer.base_m);
        let through_base = select(FAR_AWAY, inner.x, inner.x >= 0.0);
        distance = max(distance, min(max(outer.y, 0.0), through_base));
    }
    return distance;
}

// Local up at the point is (A up + p) / (R + alt); only its dot with the sun is needed.
// Rust: `point_mu_sun`.
fn point_mu_sun(h: f32, up: vec3<f32>, position_m: vec3<f32>, altitude_m: f32) -> f32 {
    let radius = clouds.planet_radius_m;
    let sun = clouds.sun_direction.xyz;
    return clamp(((radius + h) * dot(sun, up) + dot(sun, position_m)) / (radius + altitude_m), -1.0, 1.0);
}

// Steps of a light march distance_m long from a sample whose footprint is footprint_m:
// light_steps over LIGHT_STEP_SPAN_M or less, in proportion beyond (rounded), but those extra
// steps no more than clouds.light_steps_per_footprint per footprint (0: no limit); at most
// MAX_LIGHT_STEPS. Rust: `light_step_count`.
fn light_step_count(light_steps: u32, distance_m: f32, footprint_m: f32) -> u32 {
    var scaled = floor(f32(light_steps) * distance_m / LIGHT_STEP_SPAN_M + 0.5);
    let per_footprint = clouds.light_steps_per_footprint;
    if per_footprint > 0.0 && footprint_m > 0.0 {
        scaled = min(scaled, floor(per_footprint * distance_m / footprint_m));
    }
    // NaN (and negatives) add no steps.
    let extra = select(0u, u32(min(scaled, f32(MAX_LIGHT_STEPS))), scaled >= 0.0);
    return min(max(light_steps, extra), MAX_LIGHT_STEPS);
}

// Optical depth toward the sun from `position_m` (relative to the camera at altitude h with
// vertical up) at `altitude_m`: light_steps steps with boundaries at D (k/n)^2, each sampled
// `offset` (0-1; the march passes LIGHT_SAMPLE_OFFSET) of the way through; negative when the
// ground blocks the sun. Rust: `sun_optical_depth`.
fn sun_optical_depth(h: f32, up: vec3<f32>, position_m: vec3<f32>, altitude_m: f32, footprint_m: f32, max_distance_m: f32, light_steps: u32, offset: f32) -> f32 {
    let radius = clouds.planet_radius_m;
    let sun = clouds.sun_direction.xyz;
    let mu_sun = point_mu_sun(h, up, position_m, altitude_m);
    let full_distance = light_march_distance(altitude_m, mu_sun);
    if full_distance < 0.0 {
        return -1.0;
    }
    let distance = min(full_distance, max_distance_m);
    let steps = light_step_count(light_steps, distance, footprint_m);
    if steps == 0u || distance == 0.0 {
        return 0.0;
    }
    let axes = horizontal_axes(up);
    let n = f32(steps);
    var optical_depth = 0.0;
    for (var k = 0u; k < steps; k++) {
        let u0 = f32(k) / n;
        let u1 = f32(k + 1u) / n;
        let s0 = distance * u0 * u0;
        let s1 = distance * u1 * u1;
        let ds = s1 - s0;
        let s = s0 + offset * ds;
        let point = position_m + sun * s;
        let altitude = altitude_along_ray(altitude_m, mu_sun, s, radius);
        let horizontal = vec2<f32>(dot(point, axes.x), dot(point, axes.z));
        optical_depth += total_extinction(horizontal, altitude, max(footprint_m, ds), true) * ds;
    }
    return optical_depth;
}

// (1 - exp(-x)) / x, the mean transmittance across a step of optical thickness x: Hillaire
// 2016's energy-conserving step integral is S dt f(x). A series below SERIES_LIMIT (no 0/0 at
// sigma = 0, no lost digits as x -> 0), 1/x for large x. Rust: `mean_step_transmittance`.
fn mean_step_transmittance(x_in: f32) -> f32 {
    let x = max(x_in, 0.0);
    if x < SERIES_LIMIT {
        return 1.0 - x * (0.5 - x * (1.0 / 6.0 - x * (1.0 / 24.0 - x / 120.0)));
    }
    return (1.0 - exp(-x)) / x;
}

// fract(map[pixel mod size] + 0.618... * (frame mod 256)): the blue-noise map (an R32Float
// texture of the values `reference::blue_noise::blue_noise_map` makes) animated per frame.
// Rust: `blue_noise_jitter`.
fn blue_noise_jitter(pixel: vec2<f32>, frame: u32) -> f32 {
    let size = vec2<i32>(textureDimensions(blue_noise));
    let texel = ((vec2<i32>(floor(pixel)) % size) + size) % size;
    let sum = textureLoad(blue_noise, texel, 0).r + GOLDEN_RATIO_CONJUGATE * f32(frame % JITTER_FRAME_PERIOD);
    return sum - floor(sum);
}

// Sample offset within each step: blue noise when jitter is on, the midpoint 0.5 when off.
// Rust: `ray_start_jitter`.
fn ray_start_jitter(pixel: vec2<f32>) -> f32 {
    if clouds.jitter != 0u {
        return blue_noise_jitter(pixel, clouds.frame_index);
    }
    return 0.5;
}

// ---------------------------------------------------------------------------------------------
// The march
// ---------------------------------------------------------------------------------------------

// One ray's constants and state. Rust: `Ray`.
struct MarchRay {
    camera_altitude_m: f32,
    up: vec3<f32>,
    mu: f32,
    direction: vec3<f32>,
    horizontal_direction: vec2<f32>,
    cos_sun: f32,
    sun_on: bool,
    jitter: f32,
    // Optical depth so far, summed rather than multiplying exp(-x) into the transmittance,
    // which drifts by an ulp per step in f32.
    optical_depth: f32,
    // exp(-optical_depth).
    transmittance: f32,
    radiance: vec3<f32>,
    // The last cloudy step's source over its extinction: what a medium like it would add beyond
    // an early stop (Rust: `Ray::tail`).
    tail: vec3<f32>,
    // Sum of (opacity a step adds) * (its distance), and sum of opacity (Rust: `Ray::add_opacity`).
    opacity_distance: f32,
    opacity: f32,
}

// What a view ray sees of the clouds. Rust: `MarchResult`.
struct CloudMarch {
    // rgb in-scattered radiance (before exposure), a view transmittance.
    colour: vec4<f32>,
    // Opacity-weighted mean distance of the cloud, m; FAR_AWAY without cloud
    // (Rust: `MarchResult::distance_m`).
    distance: f32,
}

// Rust: `Ray::add_opacity`.
fn add_opacity(ray: ptr<function, MarchRay>, opacity: f32, t: f32) {
    (*ray).opacity_distance += opacity * t;
    (*ray).opacity += opacity;
}

// Rust: `Ray::altitude`.
fn ray_altitude(ray: ptr<function, MarchRay>, t: f32) -> f32 {
    return altitude_along_ray((*ray).camera_altitude_m, (*ray).mu, t, clouds.planet_radius_m);
}

// Cheap base-only extinction of every layer at distance t. Rust: `Ray::cheap_extinction`.
fn cheap_extinction(ray: ptr<function, MarchRay>, t: f32) -> f32 {
    let altitude = ray_altitude(ray, t);
    let horizontal = (*ray).horizontal_direction * t;
    return total_extinction(horizontal, altitude, t * clouds.pixel_angle_rad, false);
}

// Extinction, scattering and ambient source of the medium at one point. Rust: `Medium`.
struct Medium {
    extinction: f32,
    scattering: f32,
    ambient: vec3<f32>,
}

// The medium at distance t, full detail. Rust: `Ray::medium`.
fn ray_medium(ray: ptr<function, MarchRay>, t: f32) -> Medium {
    let altitude = ray_altitude(ray, t);
    let horizontal = (*ray).horizontal_direction * t;
    let footprint = t * clouds.pixel_angle_rad;
    var medium = Medium(0.0, 0.0, vec3<f32>(0.0));
    let count = cloud_layer_count();
    for (var i = 0u; i < count; i++) {
        let layer = cloud_layers[i];
        let sigma = layer_density(layer, horizontal, altitude, footprint, true);
        if sigma > 0.0 {
            let sigma_s = sigma * scattering_albedo(layer);
            // Ambient sky light grows from the base to the top (Pérez Martín 2022, "Day / Night Cycle").
            let height = saturate((altitude - layer.base_m) / (layer.top_m - layer.base_m));
            medium.ambient += sigma_s * mix(clouds.ambient_bottom.xyz, clouds.ambient_top.xyz, height);
            medium.extinction += sigma;
            medium.scattering += sigma_s;
        }
    }
    return medium;
}

// Weight of the thin-parts march of a dense step of optical thickness x: 0 up to
// MAX_STEP_OPTICAL_DEPTH, 1 from twice that, linear between. Rust: `dense_step_weight`.
fn dense_step_weight(x: f32) -> f32 {
    return saturate(x / MAX_STEP_OPTICAL_DEPTH - 1.0);
}

// One full-detail step over [ta, tb] sampled at the jittered point; returns its optical
// thickness there (0: no cloud). A
// dense step (optical thickness above MAX_STEP_OPTICAL_DEPTH at its sample) finds the cloud's
// edge after clear_from (negative: inside a cloud, no search) and marches from it in thin parts,
// mixed with the one-sample step by dense_step_weight so the result is continuous in the
// density. Rust: `Ray::step`.
fn march_step(ray: ptr<function, MarchRay>, ta: f32, tb: f32, clear_from: f32) -> f32 {
    let dt = tb - ta;
    let t = ta + (*ray).jitter * dt;
    let medium = ray_medium(ray, t);
    if !(medium.extinction > 0.0) {
        return 0.0;
    }
    let x = medium.extinction * dt;
    let weight = dense_step_weight(x);
    if !(weight > 0.0) {
        integrate_step(ray, t, dt, medium);
        return x;
    }
    // The one-sample step, mixed in below the full weight.
    var one = *ray;
    if weight < 1.0 {
        integrate_step(&one, t, dt, medium);
    }
    var begin = ta;
    if clear_from >= 0.0 && clear_from < t {
        var lo = clear_from;
        var hi = t;
        for (var i = 0u; i < EDGE_SEARCH_STEPS; i++) {
            let mid = 0.5 * (lo + hi);
            if ray_medium(ray, mid).extinction > 0.0 {
                hi = mid;
            } else {
                lo = mid;
            }
        }
        begin = lo;
    }
    let part_length = MAX_STEP_OPTICAL_DEPTH / medium.extinction;
    var cloudy = 0u;
    for (var i = 0u; i < MAX_PARTS; i++) {
        if !(begin < tb) {
            break;
        }
        var to = min(begin + part_length, tb);
        if i + 1u == MAX_PARTS || cloudy + 1u >= MAX_SUBSTEPS {
            to = tb;
        }
        let ts = begin + (*ray).jitter * (to - begin);
        let part = ray_medium(ray, ts);
        if part.extinction > 0.0 {
            integrate_step(ray, ts, to - begin, part);
            cloudy += 1u;
            if (*ray).transmittance <= clouds.transmittance_cutoff {
                break;
            }
        }
        begin = to;
    }
    if weight < 1.0 {
        let amount = 1.0 - weight;
        (*ray).optical_depth = mix((*ray).optical_depth, one.optical_depth, amount);
        (*ray).transmittance = exp(-(*ray).optical_depth);
        (*ray).radiance = mix((*ray).radiance, one.radiance, amount);
        (*ray).tail = mix((*ray).tail, one.tail, amount);
        (*ray).opacity_distance = mix((*ray).opacity_distance, one.opacity_distance, amount);
        (*ray).opacity = mix((*ray).opacity, one.opacity, amount);
    }
    return x;
}

// Integrates the medium sampled at t over a step dt long: the light toward the sun, the source
// and the analytic integral across the step. Rust: `Ray::integrate`.
fn integrate_step(ray: ptr<function, MarchRay>, t: f32, dt: f32, medium: Medium) {
    let altitude = ray_altitude(ray, t);
    let footprint = t * clouds.pixel_angle_rad;
    let extinction = medium.extinction;
    let scattering = medium.scattering;
    let ambient = medium.ambient;
    var sun = 0.0;
    if (*ray).sun_on {
        let position = (*ray).direction * t;
        // A far sample marches only the first texels toward the sun and reads the rest of the
        // way from the shadow map, where the map covers it (Rust: `Ray::step`).
        var optical_depth = 0.0;
        let near = SHADOW_MAP_NEAR_TEXELS * clouds.shadow_map_range_m.z;
        let end = position + clouds.sun_direction.xyz * near;
        let uv = shadow_map_uv(end);
        if t >= clouds.sun_from_shadow_map_m && shadow_map_covers(uv) {
            let mu_sun = point_mu_sun((*ray).camera_altitude_m, (*ray).up, position, altitude);
            let end_altitude = altitude_along_ray(altitude, mu_sun, near, clouds.planet_radius_m);
            optical_depth = sun_optical_depth((*ray).camera_altitude_m, (*ray).up, position, altitude, footprint, near, min(clouds.light_steps, SHADOW_MAP_NEAR_STEPS), LIGHT_SAMPLE_OFFSET);
            if optical_depth >= 0.0 {
                optical_depth += map_sun_optical_depth(uv, end_altitude);
            }
        } else {
            optical_depth = sun_optical_depth((*ray).camera_altitude_m, (*ray).up, position, altitude, footprint, FAR_AWAY, clouds.light_steps, LIGHT_SAMPLE_OFFSET);
        }
        if optical_depth >= 0.0 {
            sun = multiple_scattering(optical_depth, (*ray).cos_sun);
        }
    }
    // Hillaire 2016: the integral of T S over the step is T S dt (1 - exp(-x)) / x.
    let x = extinction * dt;
    let weight = (*ray).transmittance * dt * mean_step_transmittance(x);
    let source = scattering * clouds.sun_illuminance.xyz * sun + ambient;
    (*ray).radiance += weight * source;
    (*ray).tail = source / extinction;
    let before = (*ray).transmittance;
    (*ray).optical_depth += x;
    (*ray).transmittance = exp(-(*ray).optical_depth);
    add_opacity(ray, before - (*ray).transmittance, t);
}

// Primary steps across an interval span_m long: primary_steps, but no more than one per
// min_step_m (plus one). The count is computed in f32 on both sides. Rust: `interval_steps`.
fn interval_steps(span_m: f32) -> u32 {
    let steps = clamp(clouds.primary_steps, 1u, MAX_PRIMARY_STEPS);
    if !(clouds.min_step_m > 0.0) || !(span_m > 0.0) {
        return steps;
    }
    let fit = min(span_m / clouds.min_step_m, f32(MAX_PRIMARY_STEPS));
    return min(steps, u32(fit) + 1u);
}

// primary_steps steps over [start, end], growing with distance, with two-level stepping
// (Schneider 2015; Pérez Martín 2022 "Optimization"); false once the cut-off is reached.
// Rust: `Ray::march_interval`.
fn march_interval(ray: ptr<function, MarchRay>, start: f32, end: f32) -> bool {
    let steps = interval_steps(end - start);
    let growth = max(clouds.step_growth, 0.0);
    let beta = growth * (end - start) / (1.0 + growth * start);
    let n = f32(steps);
    let span = end - start;
    var k = 0u;
    var cheap = true;
    var empty = 0u;
    // The first step not yet marched in detail: a back-up never marches a step twice.
    var unmarched = 0u;
    // The end of the stride whose cheap sample found cloud: detail goes on at least to here.
    var detail_until = 0u;
    // Where the next dense step's edge search starts; negative inside a cloud (Rust: `clear_from`).
    var clear_from = NO_HIT;
    // Rust: `march_passes`.
    for (var guard = 0u; guard < 4u * steps + 4u * CHEAP_STRIDE + 2u; guard++) {
        if k >= steps {
            break;
        }
        if cheap {
            let k2 = min(k + CHEAP_STRIDE, steps);
            let ta = start + span * step_warp(f32(k) / n, beta);
            let tb = start + span * step_warp(f32(k2) / n, beta);
            if cheap_extinction(ray, ta + (*ray).jitter * (tb - ta)) > 0.0 {
                // Cloud ahead. It may begin anywhere after the last cheap sample that found
                // none, in the stride before this one: march from there in full detail.
                cheap = false;
                empty = 0u;
                detail_until = k2;
                k = max(select(0u, k - CHEAP_STRIDE, k >= CHEAP_STRIDE), unmarched);
                clear_from = start + span * step_warp(f32(k) / n, beta);
            } else {
                k = k2;
            }
            continue;
        }
        let ta = start + span * step_warp(f32(k) / n, beta);
        let tb = start + span * step_warp(f32(k + 1u) / n, beta);
        let x = march_step(ray, ta, tb, clear_from);
        // A thin step counts as clear for the next one's edge search (Rust: `march_interval`).
        clear_from = select(NO_HIT, ta + (*ray).jitter * (tb - ta), x < CLEAR_STEP_OPTICAL_DEPTH);
        if x > 0.0 {
            empty = 0u;
            if (*ray).transmittance <= clouds.transmittance_cutoff {
                // The light the rest of the medium would add, as if it went on like the last
                // step; nothing behind shows through (Rust: `Ray::march_interval`).
                (*ray).radiance += (*ray).transmittance * (*ray).tail;
                add_opacity(ray, (*ray).transmittance, tb);
                (*ray).transmittance = 0.0;
                return false;
            }
        } else {
            empty += 1u;
            if empty >= EMPTY_STEPS_TO_CHEAP && k + 1u >= detail_until {
                cheap = true;
            }
        }
        k += 1u;
        unmarched = k;
    }
    return true;
}

// Marches one view ray: the in-scattered radiance, the view transmittance and the cloud's distance.
// h: camera altitude above the ground (m); up: unit local vertical at the camera; direction: unit
// view ray (world); t_max: distance to the scene along the ray (FAR_AWAY or more for the sky);
// jitter: sample offset within each step, 0-1 (`ray_start_jitter`). Visits only the intervals
// where the ray crosses active layers (stopped at the ground), at most 2 * layers + 1 of them.
// Radiance is before exposure. Rust: `march_clouds`.
fn march_clouds(h: f32, up: vec3<f32>, direction: vec3<f32>, t_max: f32, jitter: f32) -> CloudMarch {
    let radius = clouds.planet_radius_m;
    let mu = clamp(dot(direction, up), -1.0, 1.0);
    let t_end = min(t_max, ground_distance(h, mu, radius));
    if !(t_end > 0.0) {
        return CloudMarch(vec4<f32>(0.0, 0.0, 0.0, 1.0), FAR_AWAY);
    }
    let axes = horizontal_axes(up);
    let sun = clouds.sun_illuminance.xyz;
    var ray = MarchRay(
        h,
        up,
        mu,
        direction,
        vec2<f32>(dot(direction, axes.x), dot(direction, axes.z)),
        clamp(dot(direction, clouds.sun_direction.xyz), -1.0, 1.0),
        any(sun > vec3<f32>(0.0)),
        saturate(jitter),
        0.0,
        1.0,
        vec3<f32>(0.0),
        vec3<f32>(0.0),
        0.0,
        0.0,
    );
    var t = 0.0;
    let intervals = 2u * cloud_layer_count() + 1u;
    for (var i = 0u; i < intervals; i++) {
        let interval = next_cloud_interval(h, mu, t, t_end);
        if !(interval.y - interval.x > 0.0) || !march_interval(&ray, interval.x, interval.y) {
            break;
        }
        t = interval.y;
    }
    var distance = FAR_AWAY;
    if ray.opacity > 0.0 {
        distance = ray.opacity_distance / ray.opacity;
    }
    return CloudMarch(vec4<f32>(ray.radiance, ray.transmittance), distance);
}

// ---------------------------------------------------------------------------------------------
// Cloud shadows (CPU twin: src/reference/shadow.rs)
// ---------------------------------------------------------------------------------------------

// Rust: the constants of the same names in reference/shadow.rs.
const MAX_SHADOW_STEPS: u32 = 64u;
const SHADOW_KNOT_DEPTHS: array<f32, 2> = array<f32, 2>(1.0, 4.0);
const SHADOW_MAP_NEAR_TEXELS: f32 = 4.0;
const SHADOW_MAP_NEAR_STEPS: u32 = 2u;

// Altitude above the ground of a point relative to the camera. Rust: `altitude_of`.
fn altitude_of(position_m: vec3<f32>) -> f32 {
    let distance = length(position_m);
    if distance == 0.0 {
        return clouds.camera_altitude_m;
    }
    let mu = clamp(dot(position_m, clouds.camera_up.xyz) / distance, -1.0, 1.0);
    return altitude_along_ray(clouds.camera_altitude_m, mu, distance, clouds.planet_radius_m);
}

// The sun line through a point: where it meets the ground on the sun's side (its lowest point if
// it misses the ground), marched up from there. Rust: the set-up of `visit_sun_line`.
struct SunLine {
    origin: vec3<f32>,
    origin_altitude: f32,
    origin_mu: f32,
}

fn sun_line(position_m: vec3<f32>) -> SunLine {
    let radius = clouds.planet_radius_m;
    let sun = clouds.sun_direction.xyz;
    let altitude = altitude_of(position_m);
    let mu = point_mu_sun(clouds.camera_altitude_m, clouds.camera_up.xyz, position_m, altitude);
    // Light travels along -sun and reaches the far root first.
    let ground = intersect_altitude_sphere(altitude, mu, radius, 0.0);
    var start = ground.y;
    if ground.x == NO_HIT && ground.y == NO_HIT {
        start = -(radius + altitude) * mu;
    }
    let origin_altitude = altitude_along_ray(altitude, mu, start, radius);
    return SunLine(
        position_m + sun * start,
        origin_altitude,
        clamp(((radius + altitude) * mu + start) / (radius + origin_altitude), -1.0, 1.0),
    );
}

// The knots of the optical depth down one sun line: vec4(e^-tau, top, altitude where the depth
// from the top reaches SHADOW_KNOT_DEPTHS.x, .y); `bottom_m` for a clear line. Two passes over
// `steps` midpoint samples per layer interval (full detail, mips for `footprint_m`): the whole
// depth and the cloud's top and bottom, then the knots. Rust: `shadow_column` in
// reference/shadow.rs (whose `shadow_optical_depth` is the first pass).
fn shadow_column(position_m: vec3<f32>, steps: u32, footprint_m: f32, bottom_m: f32) -> vec4<f32> {
    let line = sun_line(position_m);
    let radius = clouds.planet_radius_m;
    let sun = clouds.sun_direction.xyz;
    let axes = horizontal_axes(clouds.camera_up.xyz);
    let n = clamp(steps, 1u, MAX_SHADOW_STEPS);
    let count = cloud_layer_count();
    var total = 0.0;
    var top = -FAR_AWAY;
    var lowest = FAR_AWAY;
    var below = 0.0;
    var knots = vec2<f32>(0.0);
    var previous_altitude = 0.0;
    var previous_depth = 0.0;
    for (var pass_index = 0u; pass_index < 2u; pass_index++) {
        if pass_index == 1u {
            if !(total > 0.0) {
                return vec4<f32>(1.0, bottom_m, bottom_m, bottom_m);
            }
            // The depth from the top rises from (lowest, total) to (top, 0).
            knots = vec2<f32>(lowest);
            previous_altitude = lowest;
            previous_depth = total;
        }
        var t = 0.0;
        for (var i = 0u; i <= 2u * count; i++) {
            let interval = next_cloud_interval(line.origin_altitude, line.origin_mu, t, FAR_AWAY);
            if !(interval.y > interval.x) || !(interval.y < FAR_AWAY) {
                break;
            }
            let dt = (interval.y - interval.x) / f32(n);
            for (var k = 0u; k < n; k++) {
                let s = interval.x + (f32(k) + 0.5) * dt;
                let point = line.origin + sun * s;
                let altitude = altitude_along_ray(line.origin_altitude, line.origin_mu, s, radius);
                let horizontal = vec2<f32>(dot(point, axes.x), dot(point, axes.z));
                let x = total_extinction(horizontal, altitude, footprint_m, true) * dt;
                if !(x > 0.0) {
                    continue;
                }
                if pass_index == 0u {
                    total += x;
                    top = max(top, altitude_along_ray(line.origin_altitude, line.origin_mu, s + 0.5 * dt, radius));
                    lowest = min(lowest, altitude_along_ray(line.origin_altitude, line.origin_mu, s - 0.5 * dt, radius));
                    continue;
                }
                let depth = total - below - 0.5 * x;
                below += x;
                knots = cross_knots(knots, previous_altitude, previous_depth, altitude, depth);
                previous_altitude = altitude;
                previous_depth = depth;
            }
            t = interval.y;
        }
    }
    knots = cross_knots(knots, previous_altitude, previous_depth, top, 0.0);
    return vec4<f32>(exp(-total), top, knots.x, knots.y);
}

// The knots that lie between the points (altitude a, depth da) and (b, db) of a rising sun line.
// Rust: the `cross` closure of `shadow_column`.
fn cross_knots(knots: vec2<f32>, a: f32, da: f32, b: f32, db: f32) -> vec2<f32> {
    var result = knots;
    for (var j = 0u; j < 2u; j++) {
        let level = SHADOW_KNOT_DEPTHS[j];
        if da >= level && db < level {
            result[j] = a + (da - level) / (da - db) * (b - a);
        }
    }
    return result;
}

// ---------------------------------------------------------------------------------------------
// Reading the cloud shadow map (Rust: `ShadowMapImage` in reference/shadow.rs)
// ---------------------------------------------------------------------------------------------

// Rust: `ShadowMapImage::uv`.
fn shadow_map_uv(position_m: vec3<f32>) -> vec2<f32> {
    let q = position_m - clouds.shadow_map_centre_m.xyz;
    return vec2<f32>(0.5 * (1.0 - dot(q, clouds.shadow_map_axis_x.xyz)), 0.5 * (1.0 + dot(q, clouds.shadow_map_axis_y.xyz)));
}

// Whether a shadow map is bound and covers `uv`.
fn shadow_map_covers(uv: vec2<f32>) -> bool {
    return clouds.shadow_map != 0u && all(uv >= vec2<f32>(0.0)) && all(uv <= vec2<f32>(1.0));
}

// The filtered texel on the sun line through `position_m`. Rust: `ShadowMapImage::sample`.
fn sample_shadow_map(uv: vec2<f32>) -> vec4<f32> {
    return textureSampleLevel(cloud_shadow_map, noise_sampler, uv, 0.0);
}

// Optical depth toward the sun from the point at `altitude_m` on a sun line whose texel is
// `texel` (e^-tau, top, knot 1, knot 2): linear in altitude through (top, 0), (knot 1, min(1, tau)),
// (knot 2, min(4, tau)), (bottom, tau). Rust: `ShadowMapFrame::column_optical_depth`.
fn column_optical_depth(texel: vec4<f32>, altitude_m: f32) -> f32 {
    let total = -log(clamp(texel.x, 1e-7, 1.0));
    let z = vec4<f32>(texel.y, texel.z, texel.w, clouds.shadow_map_range_m.x);
    let tau = vec4<f32>(0.0, min(SHADOW_KNOT_DEPTHS[0], total), min(SHADOW_KNOT_DEPTHS[1], total), total);
    if !(altitude_m < z.x) {
        return 0.0;
    }
    for (var i = 0u; i < 3u; i++) {
        if altitude_m >= z[i + 1u] {
            var f = 1.0;
            if z[i] > z[i + 1u] {
                f = (z[i] - altitude_m) / (z[i] - z[i + 1u]);
            }
            return tau[i] + f * (tau[i + 1u] - tau[i]);
        }
    }
    return total;
}

// The sun's optical depth at `altitude_m` on the sun line at map coordinates `uv`: the four
// nearest texels decoded, then blended bilinearly (wrapping like the CPU twin).
// Rust: `ShadowMapImage::sun_optical_depth`.
fn map_sun_optical_depth(uv: vec2<f32>, altitude_m: f32) -> f32 {
    let size = vec2<i32>(textureDimensions(cloud_shadow_map));
    let p = uv * vec2<f32>(size) - 0.5;
    let base = floor(p);
    let f = p - base;
    let i0 = vec2<i32>(base);
    var sum = 0.0;
    for (var k = 0u; k < 4u; k++) {
        let offset = vec2<i32>(i32(k & 1u), i32(k >> 1u));
        let texel = ((i0 + offset) % size + size) % size;
        let w = select(1.0 - f.x, f.x, offset.x == 1) * select(1.0 - f.y, f.y, offset.y == 1);
        sum += w * column_optical_depth(textureLoad(cloud_shadow_map, texel, 0), altitude_m);
    }
    return sum;
}
