#define_import_path bevy_cloudscape::haze

// Haze and light shafts: the air along the view ray, lit by the sun through the cloud shadow map.
// A shader library imported by `march.wgsl`, which binds @binding(8) (and the clouds library's
// shadow map at @binding(9)).
// CPU twin: `src/reference/haze.rs` (same names; its module docs give the model and sources).
// Rust side: `src/render/haze/mod.rs`.

#import bevy_cloudscape::clouds::{
    clouds, intersect_altitude_sphere, ground_distance, altitude_along_ray, henyey_greenstein,
    mean_step_transmittance, shadow_map_uv, shadow_map_covers, sample_shadow_map,
}

// 32 bytes. Mirror in Rust: `GpuHazeUniforms` (`HazeSettings` is the f64 source).
struct HazeUniforms {
    // Extinction at the ground, 1/m; 0: no haze.
    extinction_per_m: f32,
    // Height over which the density falls by e, m.
    scale_height_m: f32,
    albedo: f32,
    // Henyey-Greenstein asymmetry of the sun's scattering.
    asymmetry: f32,
    // Steps along the view ray.
    steps: u32,
    // 1: read the sun's transmittance from the shadow map (light shafts); 0: use
    // `sun_transmittance` everywhere.
    shafts: u32,
    sun_transmittance: f32,
    // The fraction of the sky's diffuse light the clouds let through to the haze.
    ambient_transmittance: f32,
}

// The cloud shadow map and its frame are the clouds library's (binding 9, `clouds.shadow_map_*`).
@group(0) @binding(8) var<uniform> haze: HazeUniforms;

// Rust: the constants of the same names in reference/haze.rs.
const MAX_HAZE_STEPS: u32 = 128u;
const HAZE_TOP_SCALE_HEIGHTS: f32 = 8.0;

// The haze in front of the clouds and behind them: rgb radiance, a transmittance. The back
// part's radiance is relative to the clouds' distance. Rust: `HazeResult`.
struct HazeResult {
    front: vec4<f32>,
    back: vec4<f32>,
}

// The sun's transmittance through the clouds at `position_m` (relative to the camera).
// Rust: `ShadowMapImage::ground_transmittance`, or `HazeSettings::sun_transmittance` without
// shafts and beyond the map.
fn sun_visibility(position_m: vec3<f32>) -> f32 {
    if haze.shafts == 0u {
        return haze.sun_transmittance;
    }
    // Beyond the map, the clouds' mean shade (Rust: `march_haze`).
    let uv = shadow_map_uv(position_m);
    if !shadow_map_covers(uv) {
        return haze.sun_transmittance;
    }
    return sample_shadow_map(uv).r;
}

// Marches the haze along one view ray, split at the clouds' distance `split_m`.
// Rust: `march_haze` (whose docs explain the arguments).
fn march_haze(h: f32, up: vec3<f32>, direction: vec3<f32>, t_max: f32, split_m: f32, jitter: f32) -> HazeResult {
    var result = HazeResult(vec4<f32>(0.0, 0.0, 0.0, 1.0), vec4<f32>(0.0, 0.0, 0.0, 1.0));
    if !(haze.extinction_per_m > 0.0) || !(haze.scale_height_m > 0.0) {
        return result;
    }
    let radius = clouds.planet_radius_m;
    let mu = clamp(dot(direction, up), -1.0, 1.0);
    let roots = intersect_altitude_sphere(h, mu, radius, HAZE_TOP_SCALE_HEIGHTS * haze.scale_height_m);
    if roots.y < 0.0 {
        return result;
    }
    let start = max(roots.x, 0.0);
    let end = min(roots.y, min(t_max, ground_distance(h, mu, radius)));
    if !(end - start > 0.0) {
        return result;
    }
    let cos_sun = clamp(dot(direction, clouds.sun_direction.xyz), -1.0, 1.0);
    let sun = clouds.sun_illuminance.xyz * henyey_greenstein(cos_sun, haze.asymmetry);
    let ambient = 0.5 * (clouds.ambient_top.xyz + clouds.ambient_bottom.xyz) * haze.ambient_transmittance;
    let steps = clamp(haze.steps, 1u, MAX_HAZE_STEPS);
    let n = f32(steps);
    let span = end - start;
    var radiance_front = vec3<f32>(0.0);
    var radiance_back = vec3<f32>(0.0);
    var depth_front = 0.0;
    var depth_back = 0.0;
    for (var k = 0u; k < steps; k++) {
        let u0 = f32(k) / n;
        let u1 = f32(k + 1u) / n;
        let ta = start + span * u0 * u0;
        let tb = start + span * u1 * u1;
        let dt = tb - ta;
        let t = ta + jitter * dt;
        let altitude = altitude_along_ray(h, mu, t, radius);
        let sigma = haze.extinction_per_m * exp(-max(altitude, 0.0) / haze.scale_height_m);
        let x = sigma * dt;
        let weight = exp(-(depth_front + depth_back)) * dt * mean_step_transmittance(x) * sigma * haze.albedo;
        let source = sun * sun_visibility(direction * t) + ambient;
        if t >= split_m {
            radiance_back += weight * source;
            depth_back += x;
        } else {
            radiance_front += weight * source;
            depth_front += x;
        }
    }
    let front_t = exp(-depth_front);
    var back = vec3<f32>(0.0);
    if front_t > 0.0 {
        back = radiance_back / front_t;
    }
    result.front = vec4<f32>(radiance_front, front_t);
    result.back = vec4<f32>(back, exp(-depth_back));
    return result;
}

// Haze in front, then the clouds (rgb L, a T), then the haze behind. Rust: `composite`.
fn composite_haze(hazy: HazeResult, cloud: vec4<f32>) -> vec4<f32> {
    let f = hazy.front;
    let b = hazy.back;
    return vec4<f32>(f.rgb + f.a * (cloud.rgb + cloud.a * b.rgb), f.a * cloud.a * b.a);
}
