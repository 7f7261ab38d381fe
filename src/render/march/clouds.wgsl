#define_import_path bevy_cloudscape::clouds

// f32 has no infinity literal: "no distance" / "the sky" is FAR_AWAY (Rust: f64::INFINITY).
// Pass it, or any larger value, as `t_max` for sky pixels.
#import bevy_cloudscape::composite::{FAR_AWAY, NO_HIT, ground_distance}
#import bevy_cloudscape::cloud_parameters::{cloud_layers, clouds}
#import bevy_cloudscape::cloud_geometry::{
    altitude_along_ray, cloud_layer_count, horizontal_axes, layer_is_active, next_cloud_interval,
    saturate, step_warp,
}
#import bevy_cloudscape::cloud_density::{
    layer_density, profile_column, scattering_albedo, total_extinction,
}
#import bevy_cloudscape::cloud_light::{
    LIGHT_SAMPLE_OFFSET, SHADOW_MAP_NEAR_STEPS, SHADOW_MAP_NEAR_TEXELS, SampleSource,
    flash_source, higher_layers_optical_depth, mean_step_transmittance, peak_spread_phase, point_mu_sun, sample_source,
    sun_optical_depth,
}
#import bevy_cloudscape::cloud_shadow::{map_sun_optical_depth, shadow_map_covers, shadow_map_uv}

// The cloud ray-march: one view ray through the layers, in steps that grow with distance, each
// sample lit by a light march toward the sun and integrated with Hillaire 2016's
// energy-conserving step. A shader library: the entry shader imports it, declares @binding(0)
// `view: View` and @binding(1) the depth prepass, builds one ray per pixel and calls
// `march_clouds`.
//
// CPU twin: `src/reference/render/march.rs` (f64 there, f32 here; the private per-ray helpers
// are methods of its `Ray`). The march is split by concern into shader libraries, each the twin
// of one file in `src/reference/render/` with functions of the same names, and the GPU output is
// tested against them, so change both together:
// - `parameters.wgsl`: the uniforms and the layers (`parameters.rs`);
// - `textures.wgsl`: the textures and their bindings (`textures.rs`);
// - `geometry.wgsl`: shell geometry on a curved planet (`geometry.rs`);
// - `density.wgsl`: the density model (`density.rs`);
// - `light.wgsl`: the light march, the phase and multiple scattering (`light.rs`);
// - this file: the march (`march.rs`);
// - `shadow.wgsl`: the cloud shadow map's columns and reading the map (`src/reference/shadow.rs`).
// The module docs there explain the geometry, the density model and the lighting, with their
// sources:
// - Hillaire 2016, "Physically Based Sky, Atmosphere and Cloud Rendering in Frostbite";
// - Joseph, Wiscombe & Weinman 1976, "The Delta-Eddington Approximation for Radiative Flux
//   Transfer" (the diffuse light);
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

// Rust: the constants of the same names in reference/render/march.rs; see their docs there.
const MAX_PRIMARY_STEPS: u32 = 1024u;
const CHEAP_STRIDE: u32 = 4u;
const EMPTY_STEPS_TO_CHEAP: u32 = 4u;
const MAX_STEP_OPTICAL_DEPTH: f32 = 2.0;
const PART_OFFSET_THIN: f32 = 1e-3;
const MAX_SUBSTEPS: u32 = 8u;
const MAX_PARTS: u32 = 32u;
// Light steps past the cut-off: a quarter, at least 4 (Rust: `PAST_CUTOFF_LIGHT_STEP_DIVISOR`,
// `PAST_CUTOFF_MIN_LIGHT_STEPS`).
const PAST_CUTOFF_LIGHT_STEP_DIVISOR: u32 = 4u;
const PAST_CUTOFF_MIN_LIGHT_STEPS: u32 = 4u;
// Below this view transmittance the light steps fall in proportion to it (Rust:
// `FULL_LIGHT_STEPS_TRANSMITTANCE`).
const FULL_LIGHT_STEPS_TRANSMITTANCE: f32 = 0.25;
const CLEAR_STEP_OPTICAL_DEPTH: f32 = 0.1;
// A view ray within about 32 degrees of the sun takes every light step, one 60 degrees or more
// away the share `light_steps_away_from_sun` (Rust: `TOWARD_SUN_COS`, `AWAY_FROM_SUN_COS`).
const TOWARD_SUN_COS: f32 = 0.85;
const AWAY_FROM_SUN_COS: f32 = 0.5;
const EDGE_SEARCH_STEPS: u32 = 6u;
// Rust: `AWAY_FROM_SUN_CUTOFF_GAIN`.
const AWAY_FROM_SUN_CUTOFF_GAIN: f32 = 5.0;
// Rust: `SHADOW_MAP_MIN_SUN_MU` (sin 10 degrees).
const SHADOW_MAP_MIN_SUN_MU: f32 = 0.17364817766693033;
// Rust: `SHADOW_MAP_FULL_SUN_MU` (sin 12 degrees).
const SHADOW_MAP_FULL_SUN_MU: f32 = 0.20791169081775931;
// Rust: `SHADOW_MAP_BLEND_COS`.
const SHADOW_MAP_BLEND_COS: f32 = 0.8;

// The view transmittance a ray stops at: the cut-off within about 32 degrees of the sun,
// AWAY_FROM_SUN_CUTOFF_GAIN times it from 60 degrees on, linear between, at most 1; the cut-off
// itself for a ray that ends at a scene object (t_max below FAR_AWAY). Rust:
// `ray_transmittance_cutoff`.
fn ray_transmittance_cutoff(cutoff: f32, cos_sun: f32, t_max: f32) -> f32 {
    if t_max < FAR_AWAY {
        return cutoff;
    }
    return min(cutoff * mix(AWAY_FROM_SUN_CUTOFF_GAIN, 1.0, toward_sun(cos_sun)), 1.0);
}

// How far a view ray at `cos_sun` is toward the sun: 0 from AWAY_FROM_SUN_COS out, 1 within
// TOWARD_SUN_COS, linear between. Rust: `toward_sun`.
fn toward_sun(cos_sun: f32) -> f32 {
    return saturate((cos_sun - AWAY_FROM_SUN_COS) / (TOWARD_SUN_COS - AWAY_FROM_SUN_COS));
}

// How much of a sample's optical depth toward the sun comes from the cloud shadow map: none on a
// view ray within about 32 degrees of the sun nor under a sun below 10 degrees, all of it from
// SHADOW_MAP_BLEND_COS out under a sun from 12 degrees up, the product of two linear shares
// between. Rust: `shadow_map_share`.
fn shadow_map_share(cos_sun: f32, mu_sun: f32) -> f32 {
    if !(mu_sun >= SHADOW_MAP_MIN_SUN_MU) {
        return 0.0;
    }
    return saturate((TOWARD_SUN_COS - cos_sun) / (TOWARD_SUN_COS - SHADOW_MAP_BLEND_COS))
        * saturate((mu_sun - SHADOW_MAP_MIN_SUN_MU) / (SHADOW_MAP_FULL_SUN_MU - SHADOW_MAP_MIN_SUN_MU));
}

// GPU only: the light march is deferred. A sample's source needs its light march toward the
// sun, but nothing else the view march does depends on it (the source enters the radiance
// linearly), so `integrate_step` queues the sample with its weights in the radiance and
// `light_queued_samples` lights the queue in one loop: after the view march, or before a step
// when the queue could overflow. Pixels then run their light marches together instead of each
// at its own cloudy steps, which is what costs on SIMD hardware. The CPU twin lights each sample
// at once; the sums are the same up to f32 rounding.
// Size of the queue: a multiple of the most samples a step can queue (the one-sample step and
// MAX_SUBSTEPS parts).
const LIGHT_QUEUE_SIZE: u32 = LIGHT_QUEUE_STEPS * (MAX_SUBSTEPS + 1u);
const LIGHT_QUEUE_STEPS: u32 = 6u;
// No queued sample (a tail that names none).
const NO_SAMPLE: u32 = 0xffffffffu;

// A sample waiting for its light march.
struct QueuedSample {
    // Medium.ambient without multiple scattering, which alone reads it; with it
    // Medium.sky_light_top, which alone that reads (the queue's private memory is what costs).
    ambient: vec3<f32>,
    // Medium.sky_light_bottom.
    sky_light_bottom: vec3<f32>,
    // Distance along the view ray, m.
    t: f32,
    scattering: f32,
    column_above: f32,
    column_below: f32,
    extinction: f32,
    // Medium.halo_share.
    halo_share: f32,
    // The view ray's optical depth from the camera to the sample (Rust:
    // `SampleLights::view_optical_depth`).
    view_depth: f32,
    // Coefficients of the source's direct and scaled parts in the radiance (the scaled part's
    // also in `scaled_radiance`).
    weight: f32,
    scaled_weight: f32,
    // Light-march steps (`light_steps_at`).
    light_steps: u32,
}

var<private> light_queue: array<QueuedSample, LIGHT_QUEUE_SIZE>;
var<private> queued: u32;

// One ray's constants and state. Rust: `Ray`.
struct MarchRay {
    camera_altitude_m: f32,
    up: vec3<f32>,
    mu: f32,
    direction: vec3<f32>,
    horizontal_direction: vec2<f32>,
    cos_sun: f32,
    // The light steps of the ray's samples before `light_steps_at` (`ray_light_steps`).
    light_steps: u32,
    sun_on: bool,
    jitter: f32,
    // Optical depth so far, summed rather than multiplying exp(-x) into the transmittance,
    // which drifts by an ulp per step in f32.
    optical_depth: f32,
    // exp(-optical_depth).
    transmittance: f32,
    radiance: vec3<f32>,
    // The last cloudy step's source over its extinction, what a medium like it would add beyond
    // an early stop (Rust: `Ray::tail` and `Ray::scaled_tail`): here the queued samples it is
    // made of, each with its share (a dense step mixes two); NO_SAMPLE for none.
    tail_a: u32,
    tail_b: u32,
    tail_share_a: f32,
    tail_share_b: f32,
    // The part of `radiance` seen through the scaled medium (Rust: `Ray::scaled_radiance`).
    scaled_radiance: vec3<f32>,
    // Sum of (opacity a step adds) * (its distance), and sum of opacity (Rust: `Ray::add_opacity`).
    opacity_distance: f32,
    opacity: f32,
    // The view transmittance the ray stops at (`ray_transmittance_cutoff`).
    cutoff: f32,
    // The phase at cos_sun for light the forward peak has turned (`peak_spread_phase`).
    spread_phase: f32,
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

// Rust: `Ray::scaled_transmittance`.
fn scaled_transmittance(ray: ptr<function, MarchRay>) -> f32 {
    return exp(-(1.0 - clouds.forward_fraction) * (*ray).optical_depth);
}

// The transmittance the early exit compares with the cut-off: the scaled medium's with multiple
// scattering. Rust: `Ray::cutoff_transmittance`.
fn cutoff_transmittance(ray: ptr<function, MarchRay>) -> f32 {
    if clouds.multiple_scattering != 0u {
        return scaled_transmittance(ray);
    }
    return (*ray).transmittance;
}

// The light of what lies behind the medium scattered in the phase's forward peak, B (T* - T): B
// the scaled medium's mean glow along the ray where the ray ends on the ground or a scene object
// inside it, the sky above or the ground below otherwise. Rust: `Ray::add_background` (its docs say why).
fn add_background(ray: ptr<function, MarchRay>, t_end: f32) {
    if clouds.multiple_scattering == 0u || !((*ray).transmittance > 0.0) || !((*ray).optical_depth > 0.0) {
        return;
    }
    let scaled = scaled_transmittance(ray);
    let gain = scaled - (*ray).transmittance;
    var background = mix(clouds.ambient_bottom.xyz, clouds.ambient_top.xyz, saturate(0.5 + 0.5 * (*ray).mu));
    var inside = false;
    if t_end < FAR_AWAY {
        let altitude = ray_altitude(ray, t_end);
        for (var i = 0u; i < cloud_layer_count(); i++) {
            inside = inside || (layer_is_active(i) && altitude >= cloud_layers[i].base_m && altitude <= cloud_layers[i].top_m);
        }
    }
    if inside {
        background = (*ray).scaled_radiance / max(1.0 - scaled, 1e-6);
    }
    (*ray).radiance += gain * background;
}

// Rust: `Ray::altitude`.
fn ray_altitude(ray: ptr<function, MarchRay>, t: f32) -> f32 {
    return altitude_along_ray((*ray).camera_altitude_m, (*ray).mu, t, clouds.planet_radius_m);
}

// Cheap base-only extinction of every layer at distance t. Rust: `Ray::cheap_extinction`.
fn cheap_extinction(ray: ptr<function, MarchRay>, t: f32) -> f32 {
    return cheap_or_full_extinction(ray, t, false);
}

// The extinction of every layer at distance t, base-only or (`with_detail`) full detail.
fn cheap_or_full_extinction(ray: ptr<function, MarchRay>, t: f32, with_detail: bool) -> f32 {
    let altitude = ray_altitude(ray, t);
    let horizontal = (*ray).horizontal_direction * t;
    return total_extinction(horizontal, altitude, t * clouds.pixel_angle_rad, with_detail);
}

// Extinction, scattering and ambient source of the medium at one point. Rust: `Medium`.
struct Medium {
    extinction: f32,
    scattering: f32,
    // Vertical optical depths of the column up to the layer tops and down to the bases.
    column_above: f32,
    column_below: f32,
    // The height-graded sky light of the single-scattering light.
    ambient: vec3<f32>,
    // The layers' sky-light factors at the point, weighted by their scattering (Rust:
    // `Medium::sky_light`).
    sky_light_top: vec3<f32>,
    sky_light_bottom: vec3<f32>,
    // The layers' halo shares at the point, weighted by their scattering (Rust:
    // `Medium::halo_share`).
    halo_share: f32,
}

// The medium at distance t, full detail. Rust: `Ray::medium`.
fn ray_medium(ray: ptr<function, MarchRay>, t: f32) -> Medium {
    let altitude = ray_altitude(ray, t);
    let horizontal = (*ray).horizontal_direction * t;
    let footprint = t * clouds.pixel_angle_rad;
    var medium = Medium(0.0, 0.0, 0.0, 0.0, vec3<f32>(0.0), vec3<f32>(0.0), vec3<f32>(0.0), 0.0);
    let count = cloud_layer_count();
    for (var i = 0u; i < count; i++) {
        let sigma = layer_density(i, horizontal, altitude, footprint, true);
        if sigma > 0.0 {
            let sigma_s = sigma * scattering_albedo(i);
            // Ambient sky light grows from the base to the top (Pérez Martín 2022, "Day / Night Cycle").
            let height = saturate((altitude - cloud_layers[i].base_m) / (cloud_layers[i].top_m - cloud_layers[i].base_m));
            medium.ambient += sigma_s * mix(clouds.ambient_bottom.xyz * cloud_layers[i].sky_light_bottom.xyz, clouds.ambient_top.xyz * cloud_layers[i].sky_light_top.xyz, height);
            medium.sky_light_top += sigma_s * cloud_layers[i].sky_light_top.xyz;
            medium.sky_light_bottom += sigma_s * cloud_layers[i].sky_light_bottom.xyz;
            medium.extinction += sigma;
            medium.scattering += sigma_s;
            medium.halo_share += sigma_s * cloud_layers[i].halo_share;
            // The column of a cloud at full density above and below (Rust: `Ray::medium`).
            let full = cloud_layers[i].extinction * (cloud_layers[i].top_m - cloud_layers[i].base_m);
            let below = profile_column(i, height);
            medium.column_above += full * (profile_column(i, 1.0) - below);
            medium.column_below += full * below;
        }
    }
    if medium.scattering > 0.0 {
        medium.sky_light_top /= medium.scattering;
        medium.sky_light_bottom /= medium.scattering;
        medium.halo_share /= medium.scattering;
    }
    return medium;
}

// Weight of the thin-parts march of a dense step of optical thickness x: 0 up to
// MAX_STEP_OPTICAL_DEPTH, 1 from twice that, linear between. Rust: `dense_step_weight`.
fn dense_step_weight(x: f32) -> f32 {
    return saturate(x / MAX_STEP_OPTICAL_DEPTH - 1.0);
}

// Where in a part of a dense step the part samples its medium: the depth that splits the
// part's transmittance-weighted length at u. Rust: `part_offset`.
fn part_offset(u: f32, sigma: f32, len: f32) -> f32 {
    let x = sigma * len;
    if !(x > PART_OFFSET_THIN) {
        return u * len;
    }
    return clamp(-log(1.0 - u * (1.0 - exp(-x))) / sigma, 0.0, len);
}

// One full-detail step over [ta, tb] sampled at the jittered point; returns its optical
// thickness there (0: no cloud). A
// dense step (optical thickness above MAX_STEP_OPTICAL_DEPTH at its sample) finds the cloud's
// edge after clear_from (negative: inside a cloud, no search) and marches from it in thin parts
// (each sampled at the part_offset of the jitter),
// mixed with the one-sample step by dense_step_weight so the result is continuous in the
// density. Rust: `Ray::step`.
fn march_step(ray: ptr<function, MarchRay>, ta: f32, tb: f32, clear_from: f32) -> f32 {
    let dt = tb - ta;
    let t = ta + (*ray).jitter * dt;
    let medium = ray_medium(ray, t);
    if !(medium.extinction > 0.0) {
        return 0.0;
    }
    if queued + MAX_SUBSTEPS + 1u > LIGHT_QUEUE_SIZE {
        light_queued_samples(ray);
    }
    let x = medium.extinction * dt;
    let weight = dense_step_weight(x);
    if !(weight > 0.0) {
        integrate_step(ray, t, dt, medium, 1.0);
        return x;
    }
    // The one-sample step, mixed in below the full weight: its sample is queued with its share
    // of the radiance, the parts' with theirs (`weight`), and the rest is mixed below.
    let amount = 1.0 - weight;
    var one = *ray;
    if weight < 1.0 {
        integrate_step(&one, t, dt, medium, amount);
    }
    var begin = ta;
    if clear_from >= 0.0 && clear_from < t {
        var lo = clear_from;
        var hi = t;
        for (var i = 0u; i < EDGE_SEARCH_STEPS; i++) {
            let mid = 0.5 * (lo + hi);
            // The extinction alone (`ray_medium`'s, without the rest of the medium).
            if cheap_or_full_extinction(ray, mid, true) > 0.0 {
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
        let ts = begin + part_offset((*ray).jitter, medium.extinction, to - begin);
        let part = ray_medium(ray, ts);
        if part.extinction > 0.0 {
            integrate_step(ray, ts, to - begin, part, weight);
            cloudy += 1u;
            if cutoff_transmittance(ray) <= (*ray).cutoff {
                break;
            }
        }
        begin = to;
    }
    if weight < 1.0 {
        (*ray).optical_depth = mix((*ray).optical_depth, one.optical_depth, amount);
        (*ray).transmittance = exp(-(*ray).optical_depth);
        (*ray).opacity_distance = mix((*ray).opacity_distance, one.opacity_distance, amount);
        (*ray).opacity = mix((*ray).opacity, one.opacity, amount);
        // The tail: the last cloudy part's and the one-sample step's, mixed; the one-sample
        // step's alone when no part found cloud (Rust: `Ray::step`).
        if cloudy == 0u {
            (*ray).tail_a = one.tail_a;
            (*ray).tail_share_a = 1.0;
            (*ray).tail_b = NO_SAMPLE;
        } else {
            (*ray).tail_share_a = weight;
            (*ray).tail_b = one.tail_a;
            (*ray).tail_share_b = amount;
        }
    }
    return x;
}

// The light steps of a view ray's samples (before `light_steps_at`) at `cos_sun`: all of
// light_steps within TOWARD_SUN_COS, the share `away_share` (0-1, clamped on the CPU) from
// AWAY_FROM_SUN_COS on, linear between, rounded down after adding the ray's jitter (0-1) so the
// accumulated frames change smoothly with the angle, at least 1 (0 for 0). Rust: `ray_light_steps`.
fn ray_light_steps(light_steps: u32, cos_sun: f32, away_share: f32, jitter: f32) -> u32 {
    let share = away_share + (1.0 - away_share) * toward_sun(cos_sun);
    if light_steps == 0u {
        return 0u;
    }
    return clamp(u32(floor(f32(light_steps) * share + jitter)), 1u, light_steps);
}

// The light steps of a sample from the view ray's transmittance and cut-off transmittance
// before it: a quarter of them, at least PAST_CUTOFF_MIN_LIGHT_STEPS (or all when there are
// fewer), past the true medium's cut-off; with an early exit, in proportion to the cut-off
// transmittance below FULL_LIGHT_STEPS_TRANSMITTANCE if that is fewer. Rust: `light_steps_at`.
fn light_steps_at(light_steps: u32, transmittance: f32, cutoff_transmittance: f32, cutoff: f32) -> u32 {
    let fewest = min(light_steps, PAST_CUTOFF_MIN_LIGHT_STEPS);
    var steps = light_steps;
    if transmittance <= cutoff {
        steps = max(light_steps / PAST_CUTOFF_LIGHT_STEP_DIVISOR, fewest);
    }
    if cutoff > 0.0 && cutoff_transmittance < FULL_LIGHT_STEPS_TRANSMITTANCE {
        let share = cutoff_transmittance / FULL_LIGHT_STEPS_TRANSMITTANCE;
        steps = min(steps, max(u32(ceil(f32(light_steps) * share)), fewest));
    }
    return steps;
}

// Integrates the medium sampled at t over a step dt long: the analytic integral across the
// step, and the sample queued for its light march with its weights times `share` (its step's
// share of a dense step's mix, 1 otherwise). Rust: `Ray::integrate`.
fn integrate_step(ray: ptr<function, MarchRay>, t: f32, dt: f32, medium: Medium, share: f32) {
    let extinction = medium.extinction;
    // Hillaire 2016: the integral of T S over the step is T S dt (1 - exp(-x)) / x, once
    // through the true medium and once through the scaled one.
    let scaled = 1.0 - clouds.forward_fraction;
    let x = extinction * dt;
    let weight = (*ray).transmittance * dt * mean_step_transmittance(x);
    let scaled_weight = exp(-scaled * (*ray).optical_depth) * dt * mean_step_transmittance(scaled * x);
    // Deep in the cloud, and past the true medium's cut-off, fewer light steps.
    let light_steps = light_steps_at((*ray).light_steps, (*ray).transmittance, cutoff_transmittance(ray), (*ray).cutoff);
    let ambient = select(medium.ambient, medium.sky_light_top, clouds.multiple_scattering != 0u);
    light_queue[queued] = QueuedSample(ambient, medium.sky_light_bottom, t, medium.scattering, medium.column_above, medium.column_below, extinction, medium.halo_share, (*ray).optical_depth, share * weight, share * scaled_weight, light_steps);
    (*ray).tail_a = queued;
    (*ray).tail_share_a = 1.0;
    (*ray).tail_b = NO_SAMPLE;
    queued += 1u;
    let before = (*ray).transmittance;
    (*ray).optical_depth += x;
    (*ray).transmittance = exp(-(*ray).optical_depth);
    add_opacity(ray, before - (*ray).transmittance, t);
}

// Adds the light beyond an early stop, transmittance * tail + scaled transmittance * scaled
// tail (Rust: `Ray::march_interval`), to the weights of the queued samples the tail is made of.
// The scaled part also lands in `scaled_radiance`, which nothing reads once the march stops.
fn add_tail(ray: ptr<function, MarchRay>) {
    let direct = (*ray).transmittance;
    let scaled = scaled_transmittance(ray) / (1.0 - clouds.forward_fraction);
    add_tail_share((*ray).tail_a, (*ray).tail_share_a, direct, scaled);
    add_tail_share((*ray).tail_b, (*ray).tail_share_b, direct, scaled);
}

// `add_tail` for one queued sample k (NO_SAMPLE: none) with its share of the tail.
fn add_tail_share(k: u32, share: f32, direct: f32, scaled: f32) {
    if k < queued {
        let per_extinction = share / light_queue[k].extinction;
        light_queue[k].weight += per_extinction * direct;
        light_queue[k].scaled_weight += per_extinction * scaled;
    }
}

// Runs the queued samples' light marches, adds their light to the radiance and empties the queue.
fn light_queued_samples(ray: ptr<function, MarchRay>) {
    for (var i = 0u; i < queued; i++) {
        let sample = light_queue[i];
        let source = light_sample(ray, sample);
        (*ray).radiance += sample.weight * source.direct + sample.scaled_weight * source.scaled;
        (*ray).scaled_radiance += sample.scaled_weight * source.scaled;
    }
    queued = 0u;
    (*ray).tail_a = NO_SAMPLE;
    (*ray).tail_b = NO_SAMPLE;
}

// A queued sample's source: its light march toward the sun, then the source (Rust: the light
// half of `Ray::integrate`).
fn light_sample(ray: ptr<function, MarchRay>, sample: QueuedSample) -> SampleSource {
    let t = sample.t;
    let altitude = ray_altitude(ray, t);
    let footprint = t * clouds.pixel_angle_rad;
    let position = (*ray).direction * t;
    let mu_sun = point_mu_sun((*ray).camera_altitude_m, (*ray).up, position, altitude);
    let light_steps = sample.light_steps;
    var optical_depth = -1.0;
    var above = 0.0;
    if (*ray).sun_on {
        // A far sample marches only the first texels toward the sun and reads the rest of the
        // way from the shadow map, where the map covers it and may light it; within five
        // degrees of where the map may light it, mixed with the full light march (Rust:
        // `Ray::integrate`).
        let near = SHADOW_MAP_NEAR_TEXELS * clouds.shadow_map_range_m.z;
        let end = position + clouds.sun_direction.xyz * near;
        let uv = shadow_map_uv(end);
        var share = 0.0;
        if t >= clouds.sun_from_shadow_map_m && shadow_map_covers(uv) {
            share = shadow_map_share((*ray).cos_sun, mu_sun);
        }
        var from_map = -1.0;
        if share > 0.0 {
            let end_altitude = altitude_along_ray(altitude, mu_sun, near, clouds.planet_radius_m);
            from_map = sun_optical_depth((*ray).camera_altitude_m, (*ray).up, position, altitude, footprint, near, min(light_steps, SHADOW_MAP_NEAR_STEPS), LIGHT_SAMPLE_OFFSET, (*ray).jitter);
            if from_map >= 0.0 {
                from_map += map_sun_optical_depth(uv, end_altitude);
            }
        }
        if share < 1.0 {
            optical_depth = sun_optical_depth((*ray).camera_altitude_m, (*ray).up, position, altitude, footprint, FAR_AWAY, light_steps, LIGHT_SAMPLE_OFFSET, (*ray).jitter);
            // Then the layers above the sample's own (the map holds them already).
            if optical_depth >= 0.0 {
                above = higher_layers_optical_depth((*ray).up, position, altitude, mu_sun, footprint, light_steps);
                optical_depth += above;
            }
            if share > 0.0 {
                if optical_depth >= 0.0 && from_map >= 0.0 {
                    optical_depth = mix(optical_depth, from_map, share);
                    above = (1.0 - share) * above;
                } else {
                    optical_depth = -1.0;
                    above = 0.0;
                }
            }
        } else {
            optical_depth = from_map;
        }
    }
    var source = sample_source(sample.scattering, sample.column_above, sample.column_below, sample.ambient, sample.ambient, sample.sky_light_bottom, optical_depth, above, mu_sun, (*ray).cos_sun, (*ray).spread_phase, (*ray).mu, sample.halo_share, sample.view_depth);
    // A lightning flash's light, diffuse (Rust: `Ray::integrate`).
    source.scaled += vec3<f32>(sample.scattering * flash_source(position, sample.extinction));
    return source;
}

// How many of a ray's steps the interval [start_m, end_m] calls for: its length over the step's
// growth at its middle (the midpoint rule for the integral of dt / (1 + step_growth t)), in f32
// on both sides. Rust: `interval_measure`.
fn interval_measure(start_m: f32, end_m: f32) -> f32 {
    let growth = max(clouds.step_growth, 0.0);
    return (end_m - start_m) / (1.0 + growth * (0.5 * (start_m + end_m)));
}

// Primary steps across an interval span_m long whose measure is `measure`, of a ray whose
// intervals' measures add up to `total`: the interval's share of primary_steps, in proportion
// to its measure and rounded up (all of them for the only interval), but no more than one per
// min_step_m (plus one). The counts are computed in f32 on both sides. Rust: `interval_steps`.
fn interval_steps(span_m: f32, measure: f32, total: f32) -> u32 {
    let budget = clamp(clouds.primary_steps, 1u, MAX_PRIMARY_STEPS);
    var steps = budget;
    if measure > 0.0 && total > measure {
        steps = clamp(u32(ceil(f32(budget) * (measure / total))), 1u, budget);
    }
    if !(clouds.min_step_m > 0.0) || !(span_m > 0.0) {
        return steps;
    }
    let fit = min(span_m / clouds.min_step_m, f32(MAX_PRIMARY_STEPS));
    return min(steps, u32(fit) + 1u);
}

// The interval's steps (`interval_steps`) over [start, end], growing with distance, with two-level stepping
// (Schneider 2015; Pérez Martín 2022 "Optimization"); false once the cut-off is reached.
// Rust: `Ray::march_interval`.
fn march_interval(ray: ptr<function, MarchRay>, start: f32, end: f32, total: f32) -> bool {
    let steps = interval_steps(end - start, interval_measure(start, end), total);
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
            if cutoff_transmittance(ray) <= (*ray).cutoff {
                // The light the rest of the medium would add, as if it went on like the last
                // step; nothing behind shows through (Rust: `Ray::march_interval`).
                add_tail(ray);
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
// where the ray crosses active layers (stopped at the ground), at most 2 * layers + 1 of them,
// which share primary_steps in proportion to their lengths.
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
    let cos_sun = clamp(dot(direction, clouds.sun_direction.xyz), -1.0, 1.0);
    var ray = MarchRay(
        h,
        up,
        mu,
        direction,
        vec2<f32>(dot(direction, axes.x), dot(direction, axes.z)),
        cos_sun,
        ray_light_steps(clouds.light_steps, cos_sun, clouds.light_steps_away_from_sun, saturate(jitter)),
        any(sun > vec3<f32>(0.0)),
        saturate(jitter),
        0.0,
        1.0,
        vec3<f32>(0.0),
        NO_SAMPLE,
        NO_SAMPLE,
        0.0,
        0.0,
        vec3<f32>(0.0),
        0.0,
        0.0,
        ray_transmittance_cutoff(clouds.transmittance_cutoff, cos_sun, t_max),
        peak_spread_phase(cos_sun),
    );
    queued = 0u;
    // The primary steps are a budget for the whole ray, shared by its intervals.
    let intervals = 2u * cloud_layer_count() + 1u;
    var total = 0.0;
    var t = 0.0;
    for (var i = 0u; i < intervals; i++) {
        let interval = next_cloud_interval(h, mu, t, t_end);
        if !(interval.y - interval.x > 0.0) {
            break;
        }
        total += interval_measure(interval.x, interval.y);
        t = interval.y;
    }
    t = 0.0;
    for (var i = 0u; i < intervals; i++) {
        let interval = next_cloud_interval(h, mu, t, t_end);
        if !(interval.y - interval.x > 0.0) || !march_interval(&ray, interval.x, interval.y, total) {
            break;
        }
        t = interval.y;
    }
    light_queued_samples(&ray);
    add_background(&ray, t_end);
    var distance = FAR_AWAY;
    if ray.opacity > 0.0 {
        distance = ray.opacity_distance / ray.opacity;
    }
    var colour = vec4<f32>(ray.radiance, ray.transmittance);
    if clouds.clear_air != 0u {
        colour = fade_into_air(colour, mix(clear_air_transmittance(h, mu, distance), 1.0, sun_disc_share(cos_sun)));
    }
    return CloudMarch(colour, distance);
}

// Rust: the constants of the same names in reference/haze.rs and (CLEAR_AIR_STEPS)
// reference/render/march.rs.
const CLEAR_AIR_RAYLEIGH_EXTINCTION_PER_M: f32 = 1.16e-5;
const CLEAR_AIR_MIE_EXTINCTION_PER_M: f32 = 4.4e-6;
const RAYLEIGH_SCALE_HEIGHT_M: f32 = 8000.0;
const MIE_SCALE_HEIGHT_M: f32 = 1200.0;
const CLEAR_AIR_STEPS: u32 = 12u;
const SUN_DISC_NO_FADE_DEG: f32 = 1.0;
const SUN_DISC_FULL_FADE_DEG: f32 = 2.0;

// 1 within SUN_DISC_NO_FADE_DEG of the sun, 0 from SUN_DISC_FULL_FADE_DEG on, linear in the
// cosine between: the sun's disc behind a cloud is no air light. Rust: `sun_disc_share`.
fn sun_disc_share(cos_sun: f32) -> f32 {
    let inner = cos(radians(SUN_DISC_NO_FADE_DEG));
    let outer = cos(radians(SUN_DISC_FULL_FADE_DEG));
    return saturate((cos_sun - outer) / (inner - outer));
}

// Transmittance of the clear air along the view ray from the camera (altitude h, mu) to
// distance_m, midpoints of CLEAR_AIR_STEPS steps with boundaries at distance_m (k/n)^2; 1 for
// FAR_AWAY (no cloud). Rust: `clear_air_transmittance`.
fn clear_air_transmittance(h: f32, mu: f32, distance_m: f32) -> f32 {
    if !(distance_m > 0.0 && distance_m < FAR_AWAY) {
        return 1.0;
    }
    let n = f32(CLEAR_AIR_STEPS);
    var optical_depth = 0.0;
    for (var k = 0u; k < CLEAR_AIR_STEPS; k++) {
        let u0 = f32(k) / n;
        let u1 = f32(k + 1u) / n;
        let s0 = distance_m * u0 * u0;
        let s1 = distance_m * u1 * u1;
        let altitude = altitude_along_ray(h, mu, 0.5 * (s0 + s1), clouds.planet_radius_m);
        optical_depth += clear_air_extinction(altitude) * (s1 - s0);
    }
    return exp(-optical_depth);
}

// Extinction of clean air at an altitude (below the ground: the ground's), 1/m. Rust:
// `clear_air_extinction` in reference/haze.rs.
fn clear_air_extinction(altitude_m: f32) -> f32 {
    let z = max(altitude_m, 0.0);
    return CLEAR_AIR_RAYLEIGH_EXTINCTION_PER_M * exp(-z / RAYLEIGH_SCALE_HEIGHT_M)
        + CLEAR_AIR_MIE_EXTINCTION_PER_M * exp(-z / MIE_SCALE_HEIGHT_M);
}

// (L, T) seen through clear air of transmittance `air`: (air L, 1 - air (1 - T)). Rust:
// `fade_into_air`.
fn fade_into_air(colour: vec4<f32>, air_in: f32) -> vec4<f32> {
    let air = saturate(air_in);
    return vec4<f32>(air * colour.rgb, 1.0 - air * (1.0 - colour.a));
}
