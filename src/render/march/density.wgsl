#define_import_path bevy_cloudscape::cloud_density

// The density model of the cloud march (Pérez Martín 2022, "Density Model"; Schneider 2015). A
// shader library of the cloud march (see `clouds.wgsl`).
//
// CPU twin: `src/reference/render/density.rs`. Every function here has a Rust function of the
// same name there (f64 there, f32 here), and each points at the other; its module docs explain
// the model.

#import bevy_cloudscape::cloud_parameters::{MAX_PROFILE_POINTS, cloud_layers}
#import bevy_cloudscape::cloud_textures::{
    base_noise, detail_noise, growth_cover, sample_base_noise, sample_detail_noise, weather_noise,
}
#ifdef WEATHER_MAP
#import bevy_cloudscape::cloud_textures::weather_map
#endif
#import bevy_cloudscape::cloud_geometry::{
    cloud_layer_count, layer_coverage, layer_is_active, saturate, wrap_texel,
}

// Rust: the constants of the same names in reference/render/density.rs; see their docs there.
const PRECIPITATION_ABSORPTION: f32 = 0.5;
const MAX_DETAIL_EROSION: f32 = 0.9;
const DETAIL_TRANSITION_HEIGHT: f32 = 0.2;
const FBM_WEIGHTS: vec3<f32> = vec3<f32>(0.625, 0.25, 0.125);
const WEATHER_COVERAGE_RANGE: vec2<f32> = vec2<f32>(0.4, 0.95);
const COVERAGE_EDGE_WIDTH: f32 = 0.25;
const OVERCAST_COVERAGE: f32 = 0.9;
const PATCH_COVERAGE: f32 = 0.25;
const PATCH_AREA_GAIN: f32 = 2.5;
const BROKEN_PATCH_AREA: f32 = 0.75;
const CLOSING_COVERAGE: f32 = 0.75;
const GROWTH_FULL_COVER: f32 = 0.25;
const SHAPE_WARP: f32 = 0.125;
const SHAPE_WARP_BROAD: f32 = 0.5;
const BROAD_WARP_PERIODS: f32 = 32.0;

// The profile of layer `index` (of `cloud_layers`) integrated from the base up to a height
// fraction. Rust: `profile_column`.
fn profile_column(index: u32, height_fraction_in: f32) -> f32 {
    let h = saturate(height_fraction_in);
    let count = min(cloud_layers[index].profile_count, MAX_PROFILE_POINTS);
    if count == 0u {
        return h;
    }
    // Read from the buffer rather than from a copy of the array made per call (a value's array
    // cannot be indexed dynamically).
    var previous = cloud_layers[index].profile[0].xy;
    var total = previous.y * max(min(h, previous.x), 0.0);
    for (var i = 1u; i < count; i++) {
        let pair = cloud_layers[index].profile[i >> 1u];
        let point = select(pair.xy, pair.zw, (i & 1u) == 1u);
        if h <= previous.x {
            return total;
        }
        let top = min(h, point.x);
        if top > previous.x {
            var end = point.y;
            if point.x > previous.x {
                end = mix(previous.y, point.y, (top - previous.x) / (point.x - previous.x));
            }
            total += 0.5 * (previous.y + end) * (top - previous.x);
        }
        previous = point;
    }
    return total + previous.y * max(h - previous.x, 0.0);
}

// Piecewise-linear profile of layer `index` at a height fraction, end values held, 1 with no
// points. Rust: `profile_density`.
fn profile_density(index: u32, height_fraction: f32) -> f32 {
    let count = min(cloud_layers[index].profile_count, MAX_PROFILE_POINTS);
    if count == 0u {
        return 1.0;
    }
    let first = cloud_layers[index].profile[0].xy;
    if height_fraction <= first.x {
        return first.y;
    }
    var previous = first;
    for (var i = 1u; i < count; i++) {
        let pair = cloud_layers[index].profile[i >> 1u];
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

// Local coverage of weather texel `texel` (not wrapped): `local_coverage` of its coverage channel
// and of the layer coverage at the texel centre. The weather-map pass stores exactly this.
// Rust: `weather_texel_coverage`.
fn weather_texel_coverage(index: u32, texel: vec2<i32>) -> f32 {
    let size = vec2<i32>(textureDimensions(weather_noise));
    let texel_m = cloud_layers[index].weather_scale_m / f32(size.x);
    let centre = (vec2<f32>(texel) + 0.5) * texel_m - cloud_layers[index].weather_offset_m.xy;
    let coverage = layer_coverage(index, centre);
    if coverage >= 1.0 {
        return 1.0;
    }
    let wrapped = wrap_texel(texel, size);
    if cloud_layers[index].growth.x > 0.0 {
        // The automaton's column under the texel (Rust: `LayerGrowth::cover_at`).
        let columns = vec2<u32>(cloud_layers[index].growth.zw);
        let column = min((vec2<u32>(wrapped) * columns) / vec2<u32>(size), columns - 1u);
        let cover = textureLoad(growth_cover, vec2<i32>(column), i32(cloud_layers[index].growth.y), 0).x;
        return growth_coverage(coverage, cover);
    }
    return local_coverage(coverage, textureLoad(weather_noise, wrapped, 0).x);
}

// Local coverage of a growing layer: the column's cloud fraction times the patch peak of
// `local_coverage`, blending to 1 above OVERCAST_COVERAGE; 0 at coverage 0. Rust:
// `growth_coverage`.
fn growth_coverage(coverage: f32, cover: f32) -> f32 {
    if !(coverage > 0.0) {
        return 0.0;
    }
    let closing = saturate((coverage - CLOSING_COVERAGE) / (1.0 - CLOSING_COVERAGE));
    let peak = mix(PATCH_COVERAGE, 1.0, closing);
    let overcast = saturate((coverage - OVERCAST_COVERAGE) / (1.0 - OVERCAST_COVERAGE));
    return max(saturate(cover / GROWTH_FULL_COVER) * peak, overcast);
}

// The skewed weather look-up in texel units, texel centres at integers:
// (horizontal + offset + skew * height) / scale * size - 0.5. Rust: `weather_look_up`.
fn weather_look_up(index: u32, horizontal_m: vec2<f32>, height_above_base_m: f32) -> vec2<f32> {
    let size = f32(textureDimensions(weather_noise).x);
    let uv = (horizontal_m + cloud_layers[index].weather_offset_m.xy + cloud_layers[index].weather_offset_m.zw * height_above_base_m)
        / cloud_layers[index].weather_scale_m;
    return uv * size - 0.5;
}

// The weather at the skewed weather look-up `x` (`weather_look_up`): x the local coverage, the
// bilinear filter of `weather_texel_coverage` over the four texels around the look-up, filtered
// here from texel values rather than by a sampler (the coverage ramp multiplies errors by about
// 7, and hardware filtering is not exact: lavapipe rounds filtered Rgba8Unorm to 1/255); y and z
// the shape warp in shape periods, the same filter of `texel_shape_warp`; w is 1 where the
// march read the four texels from its weather map, 0 where it computed them (outside the map,
// and in the passes that bind none). Rust: `weather_coverage` and `shape_warp`.
fn weather_sample(index: u32, x: vec2<f32>) -> vec4<f32> {
    let cell = floor(x);
    let weight = x - cell;
    let texel = vec2<i32>(cell);
#ifdef WEATHER_MAP
    let map = cloud_layers[index].weather_map;
    let local = texel - vec2<i32>(map.xy);
    let last = i32(map.w) - 2;
    if map.w >= 2.0 && all(local >= vec2<i32>(0)) && all(local <= vec2<i32>(last)) {
        let slice = i32(map.z);
        let t00 = textureLoad(weather_map, local, slice, 0).xyz;
        let t10 = textureLoad(weather_map, local + vec2<i32>(1, 0), slice, 0).xyz;
        let t01 = textureLoad(weather_map, local + vec2<i32>(0, 1), slice, 0).xyz;
        let t11 = textureLoad(weather_map, local + vec2<i32>(1, 1), slice, 0).xyz;
        return vec4<f32>(mix(mix(t00, t10, weight.x), mix(t01, t11, weight.x), weight.y), 1.0);
    }
#endif
    let k00 = weather_texel_coverage(index, texel);
    let k10 = weather_texel_coverage(index, texel + vec2<i32>(1, 0));
    let k01 = weather_texel_coverage(index, texel + vec2<i32>(0, 1));
    let k11 = weather_texel_coverage(index, texel + vec2<i32>(1, 1));
    let kappa = mix(mix(k00, k10, weight.x), mix(k01, k11, weight.x), weight.y);
    return vec4<f32>(kappa, 0.0, 0.0, 0.0);
}

// Local coverage of a layer at `horizontal_m`, `height_above_base_m` up (`weather_sample`).
// Rust: `weather_coverage`.
fn weather_coverage(index: u32, horizontal_m: vec2<f32>, height_above_base_m: f32) -> f32 {
    return weather_sample(index, weather_look_up(index, horizontal_m, height_above_base_m)).x;
}

// The weather noise's curl (B, A) as 2c - 1 per axis, filtered bilinearly from texel loads at
// texel coordinate `x` (texel centres at integers). Rust: `curl_look_up`.
fn curl_look_up(x: vec2<f32>) -> vec2<f32> {
    let size = vec2<i32>(textureDimensions(weather_noise));
    let cell = floor(x);
    let weight = x - cell;
    let t0 = wrap_texel(vec2<i32>(cell), size);
    let t1 = wrap_texel(t0 + vec2<i32>(1), size);
    let c00 = textureLoad(weather_noise, t0, 0).zw;
    let c10 = textureLoad(weather_noise, vec2<i32>(t1.x, t0.y), 0).zw;
    let c01 = textureLoad(weather_noise, vec2<i32>(t0.x, t1.y), 0).zw;
    let c11 = textureLoad(weather_noise, t1, 0).zw;
    return 2.0 * mix(mix(c00, c10, weight.x), mix(c01, c11, weight.x), weight.y) - 1.0;
}

// The broad curl's look-up, in weather-noise texel units (texel centres at integers), for the
// weather look-up `x` (`weather_look_up`): the skewed horizontal point of `x` plus the warp
// offset, over BROAD_WARP_PERIODS shape periods. Affine in `x`, axis by axis. Rust:
// `broad_look_up`.
fn broad_look_up(index: u32, x: vec2<f32>) -> vec2<f32> {
    let size = f32(textureDimensions(weather_noise).x);
    let skewed_m = (x + 0.5) * (cloud_layers[index].weather_scale_m / size) - cloud_layers[index].weather_offset_m.xy;
    return (skewed_m + cloud_layers[index].warp_offset_m) / (BROAD_WARP_PERIODS * cloud_layers[index].shape_scale_m) * size - 0.5;
}

// The shape warp at weather texel `texel` (not wrapped), in shape periods: SHAPE_WARP of the
// weather noise's curl there plus SHAPE_WARP_BROAD of the broad curl at the texel's centre. The
// weather-map pass stores exactly this. Rust: `texel_shape_warp`.
fn texel_shape_warp(index: u32, texel: vec2<i32>) -> vec2<f32> {
    let fine = curl_look_up(vec2<f32>(texel));
    let broad = curl_look_up(broad_look_up(index, vec2<f32>(texel)));
    return SHAPE_WARP * fine + SHAPE_WARP_BROAD * broad;
}

// Displacement (metres) of the base-shape look-up at the weather look-up `x`, computed where
// the weather map does not hold it: the bilinear filter of `texel_shape_warp` over the four
// texels around `x`. The fine curl's filter is `curl_look_up` of `x`. The broad curl is bilinear
// over its own texels and its look-up affine in `x`, so where the four texel centres share a
// broad cell (nine in ten along each axis at the default periods) the filter of their broad
// curls is the broad curl at `x` itself, one look-up instead of four. Rust: `shape_warp`.
fn shape_warp(index: u32, x: vec2<f32>) -> vec2<f32> {
    let cell = floor(x);
    let fine = curl_look_up(x);
    let b0 = broad_look_up(index, cell);
    let b1 = broad_look_up(index, cell + 1.0);
    var broad: vec2<f32>;
    if all(floor(b0) == floor(b1)) {
        broad = curl_look_up(broad_look_up(index, x));
    } else {
        let weight = x - cell;
        let c00 = curl_look_up(b0);
        let c10 = curl_look_up(vec2<f32>(b1.x, b0.y));
        let c01 = curl_look_up(vec2<f32>(b0.x, b1.y));
        let c11 = curl_look_up(b1);
        broad = mix(mix(c00, c10, weight.x), mix(c01, c11, weight.x), weight.y);
    }
    return (SHAPE_WARP * fine + SHAPE_WARP_BROAD * broad) * cloud_layers[index].shape_scale_m;
}

// Extinction (1/m) of layer `index` (of `cloud_layers`) at horizontal coordinates
// `horizontal_m` (along `horizontal_axes`, relative to the camera) and `altitude_m`;
// `footprint_m` picks the mips;
// `with_detail = false` is the cheap base-only density (never below the full one).
// Rust: `layer_density`.
fn layer_density(index: u32, horizontal_m: vec2<f32>, altitude_m: f32, footprint_m: f32, with_detail: bool) -> f32 {
    let inside = altitude_m >= cloud_layers[index].base_m && altitude_m <= cloud_layers[index].top_m;
    if !layer_is_active(index) || !inside {
        return 0.0;
    }
    let height_above_base = altitude_m - cloud_layers[index].base_m;
    let height_fraction = height_above_base / (cloud_layers[index].top_m - cloud_layers[index].base_m);
    let look_up = weather_look_up(index, horizontal_m, height_above_base);
    let weather = weather_sample(index, look_up);
    let kappa = weather.x;
    if !(kappa > 0.0) {
        return 0.0;
    }
    let fill = patch_fill(kappa);
    let profile = profile_density(index, height_fraction / coverage_height_scale(cloud_layers[index].coverage_height, fill));
    if !(profile > 0.0) {
        return 0.0;
    }
    let strength = saturate(cloud_layers[index].shape_strength);
    var shape = 1.0;
    if strength > 0.0 {
        var warp = weather.yz * cloud_layers[index].shape_scale_m;
        if weather.w == 0.0 {
            warp = shape_warp(index, look_up);
        }
        let uvw = vec3<f32>(horizontal_m.x + cloud_layers[index].noise_offset_m.x + warp.x, altitude_m, horizontal_m.y + cloud_layers[index].noise_offset_m.y + warp.y)
            / cloud_layers[index].shape_scale_m;
        let texel_m = cloud_layers[index].shape_scale_m / f32(textureDimensions(base_noise).x);
        shape = mix(1.0, base_shape(sample_base_noise(uvw, texture_lod(footprint_m, texel_m))), strength);
    }
    let covered = saturate(remap(shape * profile, 1.0 - kappa, 1.0, 0.0, 1.0)) * fill;
    let erosion_strength = clamp(cloud_layers[index].detail_erosion, 0.0, MAX_DETAIL_EROSION) * strength;
    if !with_detail || !(erosion_strength > 0.0) || !(covered > 0.0) {
        return covered * cloud_layers[index].extinction;
    }
    let uvw = vec3<f32>(horizontal_m.x + cloud_layers[index].noise_offset_m.z, altitude_m, horizontal_m.y + cloud_layers[index].noise_offset_m.w)
        / cloud_layers[index].detail_scale_m;
    let texel_m = cloud_layers[index].detail_scale_m / f32(textureDimensions(detail_noise).x);
    let erosion = erosion_strength * detail_erosion(sample_detail_noise(uvw, texture_lod(footprint_m, texel_m)), height_fraction);
    return saturate(remap(covered, erosion, 1.0, 0.0, 1.0)) * cloud_layers[index].extinction;
}

// Sum of `layer_density` over the layers at one point. Rust: `total_extinction`.
fn total_extinction(horizontal_m: vec2<f32>, altitude_m: f32, footprint_m: f32, with_detail: bool) -> f32 {
    var extinction = 0.0;
    for (var i = 0u; i < cloud_layer_count(); i++) {
        extinction += layer_density(i, horizontal_m, altitude_m, footprint_m, with_detail);
    }
    return extinction;
}

// Rust: `scattering_albedo`.
fn scattering_albedo(index: u32) -> f32 {
    return 1.0 - PRECIPITATION_ABSORPTION * saturate(cloud_layers[index].precipitation);
}
