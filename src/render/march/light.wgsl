#define_import_path bevy_cloudscape::cloud_light

// Light of the cloud march (Joseph, Wiscombe & Weinman 1976; Toon et al. 1989; Nakajima & Tanaka
// 1988; Hillaire 2016): the phase, the delta-Eddington source, the light march toward the sun,
// the step integral and the ray-start jitter. A shader library of the cloud march (see `clouds.wgsl`).
//
// CPU twin: `src/reference/render/light.rs`. Every function here has a Rust function of the same
// name there (f64 there, f32 here), and each points at the other; its module docs explain the
// lighting. `blue_noise_jitter`'s twin is in `src/reference/blue_noise.rs`.

#import bevy_cloudscape::composite::{FAR_AWAY, ground_distance, intersect_altitude_sphere}
#import bevy_cloudscape::cloud_parameters::{cloud_layers, clouds}
#import bevy_cloudscape::cloud_textures::blue_noise
#import bevy_cloudscape::cloud_geometry::{
    HorizontalAxes, altitude_along_ray, cloud_layer_count, horizontal_axes, layer_is_active,
    saturate, wrap_texel,
}
#import bevy_cloudscape::cloud_density::{layer_density, total_extinction}

// Rust: the constants of the same names in reference/render/light.rs; see their docs there.
const MIN_DIFFUSE_MU_SUN: f32 = 0.02;
// Orders of scattering within the forward peak after the first. Rust: `PEAK_ORDERS`.
const PEAK_ORDERS: u32 = 2u;
// Angles `clouds.peak_spread` holds. Rust: `PEAK_SPREAD_ANGLES`.
const PEAK_SPREAD_ANGLES: u32 = 4u;
// Azimuths `peak_spread_phase` averages over. Rust: `PEAK_SPREAD_AZIMUTHS`.
const PEAK_SPREAD_AZIMUTHS: u32 = 8u;
// The quadrature two-stream's cosine 1/sqrt(3). Rust: `QUADRATURE_MU`.
const QUADRATURE_MU: f32 = 0.5773502691896258;
const MAX_LIGHT_STEPS: u32 = 64u;
// Where each light-march step is sampled: its midpoint, whatever the view ray's jitter (an
// average of e^-tau over offsets is biased bright). Rust: `LIGHT_SAMPLE_OFFSET`.
const LIGHT_SAMPLE_OFFSET: f32 = 0.5;
const LIGHT_STEP_SPAN_M: f32 = 2000.0;
const MAX_PHASE_G: f32 = 0.999;
const SHADOW_MAP_NEAR_TEXELS: f32 = 4.0;
const SHADOW_MAP_NEAR_STEPS: u32 = 4u;
const HIGHER_LAYER_STEP_DIVISOR: u32 = 4u;
// Below this optical thickness `mean_step_transmittance` uses its series (Rust: SERIES_LIMIT,
// 1e-5 there because f64 has expm1).
const SERIES_LIMIT: f32 = 0.1;
const PI: f32 = 3.141592653589793;
// Rust: the constants of the same names in reference/blue_noise.rs.
const GOLDEN_RATIO_CONJUGATE: f32 = 0.6180339887498949;
const JITTER_FRAME_PERIOD: u32 = 256u;

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

// Rust: the constants of the same names in reference/render/light.rs.
const HALO_ANGLE_DEG: f32 = 21.84;
const HALO_EDGE_DEG: f32 = 0.53;
const HALO_FADE_DEG: f32 = 1.5;

// The 22-degree halo's ring as a phase function, 1/sr, normalized over the sphere. Rust:
// `halo_phase`.
fn halo_phase(cos_theta: f32) -> f32 {
    let theta = acos(clamp(cos_theta, -1.0, 1.0));
    let theta0 = radians(HALO_ANGLE_DEG);
    let edge = radians(HALO_EDGE_DEG);
    let fade = radians(HALO_FADE_DEG);
    var ring = max((theta - (theta0 - edge)) / edge, 0.0);
    if theta >= theta0 {
        ring = exp(-(theta - theta0) / fade);
    }
    let ramp = (sin(theta0) - sin(theta0 - edge)) / edge - cos(theta0);
    let tail = fade * (sin(theta0) + fade * cos(theta0)) / (1.0 + fade * fade);
    return ring / (2.0 * PI * (ramp + tail));
}

// The light a sample sends toward the camera per metre of the view ray: `direct` is seen through
// the true medium, `scaled` through the delta-scaled one. Rust: `SampleSource`.
struct SampleSource {
    direct: vec3<f32>,
    scaled: vec3<f32>,
}

// Rust: `FLASH_MIN_DISTANCE_M`, `FLASH_LEAK_M`.
const FLASH_MIN_DISTANCE_M: f32 = 100.0;
const FLASH_LEAK_M: f32 = 3000.0;

// The light of the lightning flash (clouds.flash) per unit scattering at `position` (relative
// to the camera) in a medium of extinction `extinction`: the unscattered light near it, the
// diffusion approximation's far from it, leaking out over FLASH_LEAK_M. 0 without a flash.
// Rust: `flash_source`.
fn flash_source(position: vec3<f32>, extinction: f32) -> f32 {
    let intensity = clouds.flash.w;
    if !(intensity > 0.0) {
        return 0.0;
    }
    let d = max(length(position - clouds.flash.xyz), FLASH_MIN_DISTANCE_M);
    let sigma = max(extinction, 0.0);
    let reduced = (1.0 - clouds.scaled_asymmetry) * (1.0 - clouds.forward_fraction) * sigma;
    let carried = exp(-sigma * d) + 3.0 * reduced * d * (1.0 - exp(-reduced * d));
    return intensity / (4.0 * PI * d * d) * carried * exp(-d / FLASH_LEAK_M);
}

// The delta-Eddington source-function light with the single scattering split at the forward
// peak; `sun_depth` negative when the sun does not reach the sample, `sun_above_depth` its part
// in the layers above the sample's own; `sky_light_*` the sample's factors on the sky light;
// `halo_share` the share of its scattering in the 22-degree halo (Rust:
// `SampleLights::sun_above_depth`, `sky_light`, `halo_share`). Rust: `sample_source` (its docs
// give the equations).
fn sample_source(
    scattering: f32,
    column_above_in: f32,
    column_below_in: f32,
    ambient: vec3<f32>,
    sky_light_top: vec3<f32>,
    sky_light_bottom: vec3<f32>,
    sun_depth: f32,
    sun_above_depth: f32,
    mu_sun: f32,
    cos_sun: f32,
    spread_phase: f32,
    mu_view: f32,
    halo_share: f32,
    view_depth: f32,
) -> SampleSource {
    let dual = dual_lobe_phase(cos_sun, clouds.phase_g_forward, clouds.phase_g_back, clouds.phase_blend);
    var p = dual;
    var halo = 0.0;
    if halo_share > 0.0 {
        halo = min(halo_share, 1.0);
        p = (1.0 - halo) * p + halo * halo_phase(cos_sun);
    }
    let sun = clouds.sun_illuminance.xyz;
    var source = SampleSource(vec3<f32>(0.0), vec3<f32>(0.0));
    if clouds.multiple_scattering == 0u {
        var single = 0.0;
        if sun_depth >= 0.0 {
            single = p * exp(-sun_depth);
        }
        source.direct = scattering * sun * single + ambient;
        return source;
    }
    let f = clouds.forward_fraction;
    let g_star = clouds.scaled_asymmetry;
    let one_minus_g = (1.0 - g_star) * (1.0 - f);
    // Light reaches a sample through the nearest surface of its cloud, and the column below is
    // then the geometric mean of the full one and one filled as much as the sun's path (Rust:
    // `sample_source`).
    var column_above = column_above_in;
    var column_below = column_below_in;
    if sun_depth >= 0.0 {
        let capped = max(sun_depth - sun_above_depth, 0.0) * max(mu_sun, MIN_DIFFUSE_MU_SUN);
        if column_above > capped {
            column_below *= sqrt(capped / column_above);
            column_above = capped;
        }
    }
    let transport = 4.0 / 3.0 + one_minus_g * (column_above + column_below);
    let k = 0.25 / PI;
    var peak = 0.0;
    var wide = 0.0;
    var diffuse = 0.0;
    if sun_depth >= 0.0 {
        let mu0 = max(mu_sun, MIN_DIFFUSE_MU_SUN);
        let capped = min(p, clouds.forward_cap);
        let beam = exp(-(1.0 - f) * sun_depth);
        peak = ((p - capped) + (1.0 - halo) * peak_orders(cos_sun, sun_depth + max(view_depth, 0.0))) * exp(-sun_depth);
        // The scaled beam holds light the peak has turned already on the sun's path: it
        // scatters by the phase spread over the peak's angles.
        let turned_before = 1.0 - exp(-f * sun_depth);
        let spread = p + turned_before * (1.0 - halo) * (spread_phase - dual);
        wide = min(spread, clouds.forward_cap) * beam;
        let through = exp(-(1.0 - f) * (sun_depth + column_below / mu0));
        let constants = k * sun_diffuse_constants(mu0, through, transport);
        let c0 = constants.x;
        let c1 = constants.y;
        let i1 = c1 - 3.0 * mu0 * k * beam;
        let i0 = c0 - one_minus_g * c1 * column_above - 3.0 * mu0 * mu0 * k * beam;
        // Light going up: the flux the source-function integral leaves out. Both ways, what the
        // forward peak does to a grazing sun's beam, in the column's scattered part.
        let up = saturate(0.5 - 2.0 * mu_view);
        let reflected = k * reflection_deficit(mu0) * (1.0 - through) * up;
        let turned_by_peak = grazing_peak_factors(mu0);
        let turned = 1.0 - (1.0 - through) * (1.0 - mix(turned_by_peak.y, turned_by_peak.x, up));
        // The sun on the column's top, through the layers above.
        diffuse = turned * max(i0 + g_star * mu_view * i1 + reflected, 0.0) * exp(-(1.0 - f) * sun_above_depth);
    }
    let top = clouds.ambient_top.xyz * sky_light_top;
    let bottom = clouds.ambient_bottom.xyz * sky_light_bottom;
    let i1 = (top - bottom) / transport;
    let i0 = top - (2.0 / 3.0 + one_minus_g * column_above) * i1;
    let sky = max(i0 + g_star * mu_view * i1, vec3<f32>(0.0));
    source.direct = scattering * sun * peak;
    source.scaled = scattering * (sun * (wide + (1.0 - f) * diffuse) + (1.0 - f) * sky);
    return source;
}

// The share of the light a grazing beam (sun cosine mu0) loses to its forward peak that the
// peak turns upward. Rust: `peak_upward_share`.
fn peak_upward_share(mu0_in: f32) -> f32 {
    let mu0 = saturate(mu0_in);
    let tan_depression = mu0 / sqrt(max(1.0 - mu0 * mu0, 1e-12));
    var up = 0.0;
    for (var k = 0u; k < PEAK_SPREAD_ANGLES; k++) {
        let tan_theta = clouds.peak_spread[k];
        if tan_theta > tan_depression {
            up += acos(tan_depression / tan_theta);
        }
    }
    return up / (PI * f32(PEAK_SPREAD_ANGLES));
}

// The dual-lobe phase at cos_theta from the sun for light the forward peak has turned, averaged
// over the peak's angles and PEAK_SPREAD_AZIMUTHS azimuths. Rust: `peak_spread_phase`.
fn peak_spread_phase(cos_theta_in: f32) -> f32 {
    let cos_theta = clamp(cos_theta_in, -1.0, 1.0);
    let sin_theta = sqrt(max(1.0 - cos_theta * cos_theta, 0.0));
    var sum = 0.0;
    for (var k = 0u; k < PEAK_SPREAD_ANGLES; k++) {
        let tan_turn = clouds.peak_spread[k];
        let cos_turn = 1.0 / sqrt(1.0 + tan_turn * tan_turn);
        let sin_turn = tan_turn * cos_turn;
        for (var j = 0u; j < PEAK_SPREAD_AZIMUTHS; j++) {
            let azimuth = PI * (f32(j) + 0.5) / f32(PEAK_SPREAD_AZIMUTHS);
            sum += dual_lobe_phase(cos_theta * cos_turn + sin_theta * sin_turn * cos(azimuth), clouds.phase_g_forward, clouds.phase_g_back, clouds.phase_blend);
        }
    }
    return sum / f32(PEAK_SPREAD_ANGLES * PEAK_SPREAD_AZIMUTHS);
}

// How deep the light the forward peak turns out of a beam going down (sun cosine mu0) starts its
// diffusion, as the azimuth mean of mu' + 1/sqrt(3) (0 for light turned up). Rust:
// `peak_injection_depth`.
fn peak_injection_depth(mu0: f32) -> f32 {
    let sin_a = saturate(mu0);
    let cos_a = sqrt(max(1.0 - sin_a * sin_a, 0.0));
    var sum = 0.0;
    for (var k = 0u; k < PEAK_SPREAD_ANGLES; k++) {
        let tan_theta = clouds.peak_spread[k];
        let cos_theta = 1.0 / sqrt(1.0 + tan_theta * tan_theta);
        let along = sin_a * cos_theta;
        let across = cos_a * tan_theta * cos_theta;
        if across <= along {
            sum += along + QUADRATURE_MU;
        } else {
            let cos_c = -along / across;
            sum += ((along + QUADRATURE_MU) * acos(cos_c) + across * sqrt(max(1.0 - cos_c * cos_c, 0.0))) / PI;
        }
    }
    return sum / f32(PEAK_SPREAD_ANGLES);
}

// Factors on the sun's diffuse source for light going up (x) and down (y) from what the forward
// peak does to a grazing beam. Rust: `grazing_peak_factors`.
fn grazing_peak_factors(mu0: f32) -> vec2<f32> {
    let f = clouds.forward_fraction;
    let depth = (1.0 - f) + f * peak_injection_depth(mu0) / (mu0 + QUADRATURE_MU);
    let overhead = (1.0 - f) + f * peak_injection_depth(1.0) / (1.0 + QUADRATURE_MU);
    return vec2<f32>(1.0 - f * peak_upward_share(mu0), depth / overhead);
}

// The sun's diffuse field's (C0, C1) over k: C1 = (q - through (3 mu0^2 - 2 mu0)) / transport,
// C0 = q - 2 C1 / 3, with q Eddington's 3 mu0 (mu0 + 2/3) for the beam still passing through
// and the quadrature two-stream's 3 mu0 (mu0 + 1/sqrt 3), scaled to Eddington's at mu0 = 1, for
// the part scattered. Rust: `sun_diffuse_constants`.
fn sun_diffuse_constants(mu0: f32, through_in: f32, transport: f32) -> vec2<f32> {
    let through = saturate(through_in);
    let eddington = 3.0 * mu0 * (mu0 + 2.0 / 3.0);
    let scattered = 3.0 * mu0 * (mu0 + QUADRATURE_MU) * (5.0 / 3.0) / (1.0 + QUADRATURE_MU);
    let injected = through * eddington + (1.0 - through) * scattered;
    let c1 = (injected - through * (3.0 * mu0 * mu0 - 2.0 * mu0)) / transport;
    return vec2<f32>(injected - 2.0 / 3.0 * c1, c1);
}

// The orders after the first of the light scattered within the forward peak, over a path of
// optical depth path_depth (the sun's and the view's); 0 outside the peak. Rust: `peak_orders`.
fn peak_orders(cos_sun: f32, path_depth: f32) -> f32 {
    if cos_sun <= clouds.peak_caps.w || !(path_depth > 0.0) {
        return 0.0;
    }
    let forward = clamp(clouds.phase_g_forward, -MAX_PHASE_G, MAX_PHASE_G);
    let rate = clouds.forward_fraction * path_depth;
    var weight = 1.0;
    var g = forward;
    var sum = 0.0;
    for (var n = 0u; n < PEAK_ORDERS; n++) {
        weight *= rate / f32(n + 1u);
        g *= forward;
        let p = dual_lobe_phase(cos_sun, g, clouds.phase_g_back, clouds.phase_blend);
        sum += weight * max(p - clouds.peak_caps[n], 0.0);
    }
    return sum;
}

// How much more of the sun's diffuse source, in units of E / 4 pi, light going up takes so that
// a semi-infinite cloud sends out the light that enters it. Rust: `reflection_deficit`.
fn reflection_deficit(mu0_in: f32) -> f32 {
    let mu0 = clamp(mu0_in, MIN_DIFFUSE_MU_SUN, 1.0);
    let out = 4.0 * mu0 + 2.0 * mu0 * (3.0 * mu0 * mu0 - 1.0) * (1.0 - mu0 * log(1.0 + 1.0 / mu0));
    return out - (3.0 * mu0 * mu0 + 2.0 * mu0);
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
        if !layer_is_active(i) || !(altitude_m >= cloud_layers[i].base_m && altitude_m <= cloud_layers[i].top_m) {
            continue;
        }
        let outer = intersect_altitude_sphere(altitude_m, mu_sun, radius, cloud_layers[i].top_m);
        let inner = intersect_altitude_sphere(altitude_m, mu_sun, radius, cloud_layers[i].base_m);
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
// light_steps over LIGHT_STEP_SPAN_M or less, in proportion beyond (rounded down after adding
// the view ray's jitter, 0-1), but those extra steps no more than
// clouds.light_steps_per_footprint per footprint (0: no limit; rounded down); at most
// MAX_LIGHT_STEPS. Rust: `light_step_count`.
fn light_step_count(light_steps: u32, distance_m: f32, footprint_m: f32, jitter: f32) -> u32 {
    var scaled = floor(f32(light_steps) * distance_m / LIGHT_STEP_SPAN_M + jitter);
    let per_footprint = clouds.light_steps_per_footprint;
    if per_footprint > 0.0 && footprint_m > 0.0 {
        scaled = min(scaled, floor(per_footprint * distance_m / footprint_m));
    }
    // NaN (and negatives) add no steps.
    let extra = select(0u, u32(min(scaled, f32(MAX_LIGHT_STEPS))), scaled >= 0.0);
    return min(max(light_steps, extra), MAX_LIGHT_STEPS);
}

// The most light-march steps an optically thin path needs: its length times the summed peak
// extinction of the active layers whose shells its altitudes reach, over
// clouds.light_step_optical_depth (0: no limit), rounded down after adding the jitter, at
// least 1. Rust: `optically_thin_light_steps`.
fn optically_thin_light_steps(altitude_m: f32, mu_sun: f32, distance_m: f32, jitter: f32) -> u32 {
    let max_step_depth = clouds.light_step_optical_depth;
    if !(max_step_depth > 0.0) {
        return MAX_LIGHT_STEPS;
    }
    let radius = clouds.planet_radius_m;
    let end = altitude_along_ray(altitude_m, mu_sun, distance_m, radius);
    var low = min(altitude_m, end);
    let high = max(altitude_m, end);
    let lowest_at = -(radius + altitude_m) * mu_sun;
    if lowest_at > 0.0 && lowest_at < distance_m {
        low = min(low, altitude_along_ray(altitude_m, mu_sun, lowest_at, radius));
    }
    var peak = 0.0;
    let count = cloud_layer_count();
    for (var i = 0u; i < count; i++) {
        if layer_is_active(i) && cloud_layers[i].top_m >= low && cloud_layers[i].base_m <= high {
            peak += cloud_layers[i].extinction;
        }
    }
    let steps = floor(peak * distance_m / max_step_depth + jitter);
    if !(steps <= f32(MAX_LIGHT_STEPS)) {
        return MAX_LIGHT_STEPS;
    }
    return u32(max(steps, 1.0));
}

// The point s metres toward the sun from `position_m` (at `altitude_m`, the sun at `mu_sun`
// there): xy its coordinates along the horizontal `axes`, z its altitude. Rust: `sun_ray_point`.
fn sun_ray_point(axes: HorizontalAxes, position_m: vec3<f32>, altitude_m: f32, mu_sun: f32, s: f32) -> vec3<f32> {
    let point = position_m + clouds.sun_direction.xyz * s;
    let altitude = altitude_along_ray(altitude_m, mu_sun, s, clouds.planet_radius_m);
    return vec3<f32>(dot(point, axes.x), dot(point, axes.z), altitude);
}

// Optical depth toward the sun from `position_m` (relative to the camera at altitude h with
// vertical up) at `altitude_m`: light_steps steps with boundaries at D (k/n)^2, each sampled
// `offset` (0-1; the march passes LIGHT_SAMPLE_OFFSET) of the way through; negative when the
// ground blocks the sun. Only the shells that hold the point: the march adds
// `higher_layers_optical_depth` to a full light march. Rust: `sun_optical_depth`.
fn sun_optical_depth(h: f32, up: vec3<f32>, position_m: vec3<f32>, altitude_m: f32, footprint_m: f32, max_distance_m: f32, light_steps: u32, offset: f32, jitter: f32) -> f32 {
    let mu_sun = point_mu_sun(h, up, position_m, altitude_m);
    let full_distance = light_march_distance(altitude_m, mu_sun);
    if full_distance < 0.0 {
        return -1.0;
    }
    let distance = min(full_distance, max_distance_m);
    let steps = min(light_step_count(light_steps, distance, footprint_m, jitter), optically_thin_light_steps(altitude_m, mu_sun, distance, jitter));
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
        let point = sun_ray_point(axes, position_m, altitude_m, mu_sun, s);
        optical_depth += total_extinction(point.xy, point.z, max(footprint_m, ds), true) * ds;
    }
    return optical_depth;
}

// Optical depth toward the sun through every active layer whose base lies above `altitude_m`,
// each from its base to its top in light_steps / HIGHER_LAYER_STEP_DIVISOR (rounded up) equal
// steps sampled at their midpoints. Rust: `higher_layers_optical_depth`.
fn higher_layers_optical_depth(up: vec3<f32>, position_m: vec3<f32>, altitude_m: f32, mu_sun: f32, footprint_m: f32, light_steps: u32) -> f32 {
    let steps = (light_steps + HIGHER_LAYER_STEP_DIVISOR - 1u) / HIGHER_LAYER_STEP_DIVISOR;
    if steps == 0u {
        return 0.0;
    }
    let radius = clouds.planet_radius_m;
    let axes = horizontal_axes(up);
    let n = f32(steps);
    var optical_depth = 0.0;
    let count = cloud_layer_count();
    for (var i = 0u; i < count; i++) {
        if !layer_is_active(i) || !(cloud_layers[i].base_m > altitude_m) {
            continue;
        }
        // From inside both spheres the ray leaves each through its far root.
        let enter = intersect_altitude_sphere(altitude_m, mu_sun, radius, cloud_layers[i].base_m).y;
        let leave = intersect_altitude_sphere(altitude_m, mu_sun, radius, cloud_layers[i].top_m).y;
        if !(enter >= 0.0 && leave > enter) {
            continue;
        }
        let ds = (leave - enter) / n;
        for (var k = 0u; k < steps; k++) {
            let s = enter + (f32(k) + 0.5) * ds;
            let point = sun_ray_point(axes, position_m, altitude_m, mu_sun, s);
            optical_depth += layer_density(i, point.xy, point.z, max(footprint_m, ds), true) * ds;
        }
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
    let texel = wrap_texel(vec2<i32>(floor(pixel)), size);
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
