#define_import_path bevy_cloudscape::haze

// Haze and light shafts: the air along the view ray, lit by the sun through the cloud shadow map.
// A shader library imported by `march.wgsl`, which binds @binding(8) (and the shadow map of
// `textures.wgsl` at @binding(9)).
// CPU twin: `src/reference/haze.rs` (same names; its module docs give the model and sources).
// Rust side: `src/render/haze/mod.rs`.

#import bevy_cloudscape::cloud_parameters::clouds
#import bevy_cloudscape::cloud_geometry::altitude_along_ray
#import bevy_cloudscape::cloud_light::{henyey_greenstein, mean_step_transmittance, MAX_PHASE_G, PI}
#import bevy_cloudscape::cloud_shadow::{shadow_map_uv, shadow_map_covers, sample_shadow_map}
#import bevy_cloudscape::composite::{intersect_altitude_sphere, ground_distance}

// Written by `GpuHazeUniforms` (Rust; `HazeSettings` is the f64 source); `render/contract.rs`
// holds the two layouts equal.
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
    // 1: the shaft pass ran and `march.wgsl` reads its factors (light shafts); 0: use
    // `sun_transmittance` everywhere.
    shafts: u32,
    sun_transmittance: f32,
    // The fraction of the sky's diffuse light the clouds let through to the haze (the ground's
    // light on it is dimmed by it).
    ambient_transmittance: f32,
    // Steps of the shaft pass along the view ray.
    shaft_steps: u32,
    // rgb: the mean radiance of the sky above the haze, clouds included (Rust:
    // `HazeSettings::sky_radiance_or`).
    sky_radiance: vec4<f32>,
}

// The cloud shadow map and its frame are the march's (binding 9 of `textures.wgsl`,
// `clouds.shadow_map_*`).
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

// Where the view ray is inside the haze: [start, end] (end <= start: it misses).
// Rust: `haze_interval`.
fn haze_span(h: f32, mu: f32, t_max: f32) -> vec2<f32> {
    let radius = clouds.planet_radius_m;
    let roots = intersect_altitude_sphere(h, mu, radius, HAZE_TOP_SCALE_HEIGHTS * haze.scale_height_m);
    if roots.y < 0.0 {
        return vec2<f32>(0.0);
    }
    return vec2<f32>(max(roots.x, 0.0), min(roots.y, min(t_max, ground_distance(h, mu, radius))));
}

// Whether there is haze to march. Rust: `HazeSettings::is_active`.
fn haze_active() -> bool {
    return haze.extinction_per_m > 0.0 && haze.scale_height_m > 0.0;
}

// Step k of the haze march over `span`: sample distance, altitude, optical depth and the step's
// ends.
// Rust: `haze_steps`.
struct HazeStep {
    t: f32,
    altitude: f32,
    optical_depth: f32,
    start: f32,
    end: f32,
}

// The share of the light entering a uniform stretch of optical thickness x that it scatters,
// x (1 - e^-x) / x: the step integral. Rust: `scattered_share`.
fn scattered_share(x: f32) -> f32 {
    return x * mean_step_transmittance(x);
}

fn haze_step(k: u32, n: f32, span: vec2<f32>, h: f32, mu: f32, jitter: f32) -> HazeStep {
    let u0 = f32(k) / n;
    let u1 = f32(k + 1u) / n;
    let ta = span.x + (span.y - span.x) * u0 * u0;
    let tb = span.x + (span.y - span.x) * u1 * u1;
    let dt = tb - ta;
    let t = ta + jitter * dt;
    let altitude = altitude_along_ray(h, mu, t, clouds.planet_radius_m);
    let sigma = haze.extinction_per_m * exp(-max(altitude, 0.0) / haze.scale_height_m);
    let x = sigma * dt;
    return HazeStep(t, altitude, x, ta, tb);
}

// The light shafts of one view ray: the mean sun transmittance from the cloud shadow map of the
// haze below the lowest cloud base (x) and above it (y), weighted by each sample's share of the
// pixel; the mean shade beyond the map and for a part the ray does not reach. Run by the
// reduced-resolution shaft pass (`march.wgsl`'s `shafts` entry). Rust: `shaft_factors`.
fn shaft_factors(h: f32, up: vec3<f32>, direction: vec3<f32>, t_max: f32, jitter: f32) -> vec2<f32> {
    var lit = vec2<f32>(0.0);
    var weight = vec2<f32>(0.0);
    let mu = clamp(dot(direction, up), -1.0, 1.0);
    let span = haze_span(h, mu, t_max);
    if haze_active() && span.y - span.x > 0.0 {
        let steps = clamp(haze.shaft_steps, 1u, MAX_HAZE_STEPS);
        let n = f32(steps);
        var depth = 0.0;
        for (var k = 0u; k < steps; k++) {
            let step = haze_step(k, n, span, h, mu, jitter);
            let w = exp(-depth) * scattered_share(step.optical_depth);
            depth += step.optical_depth;
            // Beyond the map, the clouds' mean shade.
            var sun = haze.sun_transmittance;
            let uv = shadow_map_uv(direction * step.t);
            if shadow_map_covers(uv) {
                sun = sample_shadow_map(uv).r;
            }
            if step.altitude < clouds.shadow_map_range_m.x {
                lit.x += w * sun;
                weight.x += w;
            } else {
                lit.y += w * sun;
                weight.y += w;
            }
        }
    }
    let mean = vec2<f32>(haze.sun_transmittance);
    return select(mean, clamp(lit / max(weight, vec2<f32>(1e-30)), vec2<f32>(0.0), vec2<f32>(1.0)), weight > vec2<f32>(0.0));
}

// The share of a haze step over [start, end] in front of the clouds' distance `split` (0-1; 1
// for a split at or beyond its end, or NaN). Rust: `front_share`.
fn front_share(start: f32, end: f32, split: f32) -> f32 {
    if !(split < end) {
        return 1.0;
    }
    if !(split > start) {
        return 0.0;
    }
    return (split - start) / (end - start);
}

// Rust: the constants of the same names in reference/haze.rs.
const LIGHT_SHARE_ANGLES: u32 = 16u;
const LIGHT_SHARE_AZIMUTHS: u32 = 8u;

// The altitude whose haze column gives a view ray's light shares: the camera's, raised by the
// scale height times the elevation sine on a climbing ray. Rust: `HazeSettings::shares_altitude`.
fn shares_altitude(h: f32, mu: f32) -> f32 {
    return h + haze.scale_height_m * clamp(mu, 0.0, 1.0);
}

// The haze's optical depth from `altitude_m` straight up out of it and straight down to the
// ground, for active haze. Rust: `HazeSettings::column`.
fn haze_column(altitude_m: f32) -> vec2<f32> {
    let h = haze.scale_height_m;
    let top = HAZE_TOP_SCALE_HEIGHTS * h;
    let z = clamp(altitude_m, 0.0, top);
    let at_z = exp(-z / h);
    return haze.extinction_per_m * h * vec2<f32>(at_z - exp(-top / h), 1.0 - at_z);
}

// The cosine of the angle from the forward direction below which the Henyey-Greenstein phase of
// asymmetry g scatters the share 1 - u of its light. Rust: `phase_quantile`.
fn phase_quantile(u: f32, g: f32) -> f32 {
    if abs(g) < 1e-3 {
        return 2.0 * u - 1.0;
    }
    let root = (1.0 - g * g) / (1.0 - g + 2.0 * g * u);
    return clamp((1.0 + g * g - root * root) / (2.0 * g), -1.0, 1.0);
}

// Where the light a haze particle scatters along a view ray of elevation sine `mu` comes from:
// the shares of the phase of the sky (x), the ground (y) and the haze itself (z), for the
// haze's column at the camera. Rust: `haze_light_shares` (its docs give the model).
fn haze_light_shares(mu: f32, g_in: f32, column: vec2<f32>) -> vec3<f32> {
    let g = clamp(g_in, -MAX_PHASE_G, MAX_PHASE_G);
    let sin_e = clamp(mu, -1.0, 1.0);
    let cos_e = sqrt(max(1.0 - sin_e * sin_e, 0.0));
    let n = f32(LIGHT_SHARE_ANGLES);
    let m = f32(LIGHT_SHARE_AZIMUTHS);
    var shares = vec3<f32>(0.0);
    for (var k = 0u; k < LIGHT_SHARE_ANGLES; k++) {
        let cos_theta = phase_quantile((f32(k) + 0.5) / n, g);
        let sin_theta = sqrt(max(1.0 - cos_theta * cos_theta, 0.0));
        for (var j = 0u; j < LIGHT_SHARE_AZIMUTHS; j++) {
            let phi = PI * (f32(j) + 0.5) / m;
            let mu_d = cos_theta * sin_e + sin_theta * cos_e * cos(phi);
            var clear = 0.0;
            if mu_d > 0.0 {
                clear = exp(-column.x / mu_d);
                shares.x += clear;
            } else if mu_d < 0.0 {
                clear = exp(-column.y / -mu_d);
                shares.y += clear;
            }
            shares.z += 1.0 - clear;
        }
    }
    return shares / (n * m);
}

// Marches the haze along one view ray, split at the clouds' distance `split_m`. `shafts` holds
// the ray's shaft factors below and above the lowest cloud base (both the mean shade without
// shafts). Rust: `march_haze` (whose docs explain the arguments).
fn march_haze(h: f32, up: vec3<f32>, direction: vec3<f32>, t_max: f32, split_m: f32, jitter: f32, shafts: vec2<f32>) -> HazeResult {
    var result = HazeResult(vec4<f32>(0.0, 0.0, 0.0, 1.0), vec4<f32>(0.0, 0.0, 0.0, 1.0));
    let mu = clamp(dot(direction, up), -1.0, 1.0);
    let span = haze_span(h, mu, t_max);
    if !haze_active() || !(span.y - span.x > 0.0) {
        return result;
    }
    let cos_sun = clamp(dot(direction, clouds.sun_direction.xyz), -1.0, 1.0);
    // Where the light scattered toward the camera comes from: the sky, the ground, or the haze
    // itself, whose light each scattering passes on again (Rust: `march_haze`).
    let shares = haze_light_shares(mu, haze.asymmetry, haze_column(shares_altitude(h, mu)));
    let gain = 1.0 / max(1.0 - saturate(haze.albedo) * shares.z, 1e-3);
    let sun = clouds.sun_illuminance.xyz * (henyey_greenstein(cos_sun, haze.asymmetry) * gain);
    // The sky above and the ground below, each by its share of the phase.
    let ambient = gain * (shares.x * haze.sky_radiance.xyz + shares.y * clouds.ambient_bottom.xyz * haze.ambient_transmittance);
    let steps = clamp(haze.steps, 1u, MAX_HAZE_STEPS);
    let n = f32(steps);
    var radiance_front = vec3<f32>(0.0);
    var radiance_back = vec3<f32>(0.0);
    var depth_front = 0.0;
    var depth_back = 0.0;
    for (var k = 0u; k < steps; k++) {
        let step = haze_step(k, n, span, h, mu, jitter);
        let visible = select(shafts.y, shafts.x, step.altitude < clouds.shadow_map_range_m.x);
        let source = sun * visible + ambient;
        // The step's front part and its back part (Rust: `march_haze`).
        let before = exp(-(depth_front + depth_back)) * haze.albedo;
        let front = step.optical_depth * front_share(step.start, step.end, split_m);
        let back = step.optical_depth - front;
        radiance_front += before * scattered_share(front) * source;
        radiance_back += before * exp(-front) * scattered_share(back) * source;
        depth_front += front;
        depth_back += back;
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
