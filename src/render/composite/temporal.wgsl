// Temporal accumulation of the cloud march: blends this frame's march (at the march's
// resolution, read with the depth-aware upsample's weights) into a full-resolution history of
// (L, T), found where this pixel's content was last frame and clamped to the new frame's 3 x 3
// neighbourhood. Writes the new history; `upsample.wgsl`'s `copy` entry then composites it.
// CPU twin: `reproject` and `temporal_resolve` in `src/reference/composite.rs` (whose module docs
// explain the method). Rust side: `src/render/composite/mod.rs`.

#import bevy_cloudscape::view_depth::{view, depth_prepass}
#import bevy_core_pipeline::fullscreen_vertex_shader::FullscreenVertexOutput
#import bevy_cloudscape::composite::{
    FAR_AWAY, ViewGround, footprint_offset, footprint_texel, upsample_weights, uv_to_ndc,
    view_direction, surface_distance, view_ray_end,
}

// Written by `GpuTemporalUniforms` (Rust); `render/contract.rs` holds the two layouts equal.
struct TemporalUniforms {
    // Last frame's clip space from a point relative to this frame's camera (world axes).
    previous_clip_from_relative: mat4x4<f32>,
    // Weight of the new frame, 0-1, for a pixel this frame's march went through (Rust:
    // `hit_blend`).
    blend: f32,
    // 1: the history holds last frame of this view; 0: start over.
    valid: u32,
    // Where this frame's march rays passed through their texels, in texels from the centre
    // (Rust: `sample_offset`).
    sample_offset: vec2<f32>,
    // Full-resolution pixels per march texel along an axis (Rust: `upsampling_factor`); 1: the
    // march is at full resolution and every pixel takes the new frame.
    upsampling_factor: u32,
    // The view's uv per march uv (Rust: `TemporalUpsampling::uv_scale`): with the upsampling
    // each march texel stands for exactly upsampling_factor^2 pixels, and the march's image
    // may reach past the view's edge; 1 otherwise.
    uv_scale: vec2<f32>,
}

// This frame's march: (L, T), and (where the ray stopped, where its content lies) in metres.
@group(0) @binding(2) var march_colour: texture_2d<f32>;
@group(0) @binding(3) var march_distance: texture_2d<f32>;
@group(0) @binding(4) var history: texture_2d<f32>;
@group(0) @binding(5) var history_sampler: sampler;
@group(0) @binding(6) var<uniform> temporal: TemporalUniforms;
@group(0) @binding(7) var<uniform> ground: ViewGround;
// Where the rays of last frame's history ended, m (Rust: `HISTORY_DISTANCE_FORMAT`).
@group(0) @binding(8) var history_distance: texture_2d<f32>;

// The new history and where this pixel's ray ends, for next frame's `history_matches`.
struct TemporalOutput {
    @location(0) colour: vec4<f32>,
    @location(1) distance: vec4<f32>,
}

const PI: f32 = 3.141592653589793;
// Rust: `HISTORY_SNAP_TEXELS` in reference/composite.rs.
const HISTORY_SNAP_TEXELS: f32 = 1e-3;
// Rust: `HISTORY_DEPTH_RATIO`.
const HISTORY_DEPTH_RATIO: f32 = 2.0;

// Rust: `history_read_snaps`. Whether a history read at `position` (texel units, centres at
// integers) is the nearest texel itself rather than the Lanczos filter around it.
fn history_read_snaps(position: vec2<f32>) -> bool {
    return all(abs(position - round(position)) <= vec2<f32>(HISTORY_SNAP_TEXELS));
}

// Rust: `history_matches`. Whether a history texel whose ray ended at history_end may be kept by
// a pixel whose ray ends at end: the same surface, not a near object and what lies behind it.
fn history_matches(history_end: f32, end: f32) -> bool {
    return max(history_end, end) <= HISTORY_DEPTH_RATIO * min(history_end, end);
}

// How much of the history around uv saw the surface this pixel's ray ends at: 0 when one of
// the 2 x 2 texels a bilinear read takes did not (the history is another surface's), 1 when
// those did but one of the 6 x 6 the Lanczos filter reads did not (its lobes would reach across
// the edge, and a pixel the march does not visit would take a little of the other surface
// every frame: read the 2 x 2 alone), 2 when all did. A read that snaps to a texel
// (`sample_history`: a still camera's) reads that texel alone, and only it is checked.
fn history_surface(uv: vec2<f32>, end: f32) -> u32 {
    let size = vec2<i32>(textureDimensions(history_distance));
    let position = uv * vec2<f32>(size) - 0.5;
    if history_read_snaps(position) {
        let texel = clamp(vec2<i32>(round(position)), vec2<i32>(0), size - 1);
        return select(0u, 2u, history_matches(textureLoad(history_distance, texel, 0).x, end));
    }
    let base = vec2<i32>(floor(position));
    var surface = 2u;
    for (var j = -2; j <= 3; j++) {
        for (var i = -2; i <= 3; i++) {
            let texel = clamp(base + vec2<i32>(i, j), vec2<i32>(0), size - 1);
            if !history_matches(textureLoad(history_distance, texel, 0).x, end) {
                if i >= 0 && i <= 1 && j >= 0 && j <= 1 {
                    return 0u;
                }
                surface = 1u;
            }
        }
    }
    return surface;
}

// Rust: `moving_blend`. The new frame's weight for a pixel whose content moved `motion_px`
// full-resolution pixels since last frame.
fn moving_blend(alpha: f32, motion_px: f32) -> f32 {
    return clamp(alpha * (1.0 + motion_px), 0.0, 1.0);
}

// Rust: `reproject`.
fn reproject(direction: vec3<f32>, distance: f32) -> vec3<f32> {
    var point = vec4<f32>(direction * distance, 1.0);
    if distance >= FAR_AWAY {
        point = vec4<f32>(direction, 0.0);
    }
    let clip = temporal.previous_clip_from_relative * point;
    if clip.w <= 0.0 {
        return vec3<f32>(0.0, 0.0, 0.0);
    }
    let ndc = clip.xy / clip.w;
    let uv = vec2<f32>(0.5 * ndc.x + 0.5, 0.5 - 0.5 * ndc.y);
    let inside = all(uv >= vec2<f32>(0.0)) && all(uv <= vec2<f32>(1.0));
    return vec3<f32>(uv, select(0.0, 1.0, inside));
}

// Rust: `lanczos3_weights`. The weights of the texels at base - 2 ..= base + 3 for a point at
// `base + fraction`, summing to 1.
fn lanczos3_weights(fraction: f32) -> array<f32, 6> {
    var weights = array<f32, 6>();
    var sum = 0.0;
    for (var i = 0; i < 6; i++) {
        let x = abs(f32(i - 2) - fraction);
        var w = 0.0;
        if x < 1e-4 {
            w = 1.0;
        } else if x < 3.0 {
            let p = PI * x;
            w = 3.0 * sin(p) * sin(p / 3.0) / (p * p);
        }
        weights[i] = w;
        sum += w;
    }
    for (var i = 0; i < 6; i++) {
        weights[i] /= sum;
    }
    return weights;
}

// The history at `uv` with a Lanczos-3 filter (a sinc windowed to three texels either side):
// reprojecting every frame resamples the history every frame, and the loss compounds, so the
// filter must keep detail a few pixels across. After 60 frames of a camera turning 0.7 pixel a
// frame at a blend of 0.1, a 4-pixel cosine is 50 % off with Catmull-Rom (4 taps) and 19 % with
// this filter (`lanczos3_keeps_detail_through_a_turning_camera`). 6 x 6 texels in 5 x 5
// bilinear reads: the middle two of each axis, both weights positive, merged into one read at
// their weighted position. The negative lobes can overshoot; the neighbourhood clamp after it
// bounds that, and the physical range at the end.
fn sample_history(uv: vec2<f32>) -> vec4<f32> {
    let size = vec2<f32>(textureDimensions(history));
    let position = uv * size - 0.5;
    // On a texel centre the filter is that texel: one read, where a still camera's history
    // always lands.
    let nearest = round(position);
    if history_read_snaps(position) {
        let texel = clamp(vec2<i32>(nearest), vec2<i32>(0), vec2<i32>(size) - 1);
        return textureLoad(history, texel, 0);
    }
    let base = floor(position);
    let f = position - base;
    let lx = lanczos3_weights(f.x);
    let ly = lanczos3_weights(f.y);
    let mx = lx[2] + lx[3];
    let my = ly[2] + ly[3];
    // Per axis, the five reads' offsets from `base` (texels) and weights: texels -2 and -1, the
    // merged pair 0 and 1, then 2 and 3.
    let ox = array<f32, 5>(-2.0, -1.0, lx[3] / max(mx, 1e-6), 2.0, 3.0);
    let oy = array<f32, 5>(-2.0, -1.0, ly[3] / max(my, 1e-6), 2.0, 3.0);
    let wx = array<f32, 5>(lx[0], lx[1], mx, lx[4], lx[5]);
    let wy = array<f32, 5>(ly[0], ly[1], my, ly[4], ly[5]);
    var sum = vec4<f32>(0.0);
    for (var j = 0; j < 5; j++) {
        for (var i = 0; i < 5; i++) {
            let at = (base + 0.5 + vec2<f32>(ox[i], oy[j])) / size;
            sum += wx[i] * wy[j] * textureSampleLevel(history, history_sampler, at, 0.0);
        }
    }
    // Radiance is never negative and transmittance within 0-1; the lobes' overshoot at a hard
    // edge would otherwise leave a pixel the march did not visit (temporal upsampling: no
    // clamp) just below 0.
    return clamp(sum, vec4<f32>(0.0), vec4<f32>(FAR_AWAY, FAR_AWAY, FAR_AWAY, 1.0));
}

@fragment
fn temporal_resolve(in: FullscreenVertexOutput) -> TemporalOutput {
    // This pixel's ray and where it stops.
    let ndc = uv_to_ndc(in.uv);
    let depth = textureLoad(depth_prepass, vec2<i32>(in.position.xy), 0);
    let direction = view_direction(view.view_from_clip, view.world_from_view, ndc);
    let distance = view_ray_end(ground, direction, surface_distance(view.view_from_clip, ndc, depth));

    // The new frame at this pixel, upsampled; where its content lies, from the tap that counts
    // most.
    let size = vec2<i32>(textureDimensions(march_colour));
    // Where this pixel lies on the march's image (Rust: `march_uv`).
    let march_uv = in.uv / temporal.uv_scale;
    let f = footprint_offset(march_uv, size, temporal.sample_offset);
    var taps = vec4<f32>(0.0);
    var contents = vec4<f32>(0.0);
    for (var k = 0; k < 4; k++) {
        let tap = textureLoad(march_distance, footprint_texel(f, k, size), 0).xy;
        taps[k] = tap.x;
        contents[k] = tap.y;
    }
    let weights = upsample_weights(f, taps, distance);
    var strongest = 0;
    for (var k = 1; k < 4; k++) {
        if weights[k] > weights[strongest] {
            strongest = k;
        }
    }
    let content = contents[strongest];

    // How closely this frame's ray went through this pixel: 1 for the pixel it went through,
    // 0 for its neighbours (Rust: `hit_proximity`); 1 at full resolution.
    let centre = clamp(vec2<i32>(march_uv * vec2<f32>(size)), vec2<i32>(0), size - 1);
    var proximity = 1.0;
    if temporal.upsampling_factor > 1u {
        let sample_uv = (vec2<f32>(centre) + 0.5 + temporal.sample_offset) / vec2<f32>(size) * temporal.uv_scale;
        let near = max(vec2<f32>(0.0), 1.0 - abs((in.uv - sample_uv) * view.viewport.zw));
        proximity = near.x * near.y;
    }

    // Rust: `temporal_upsample_resolve`; the history only where it saw what this pixel sees
    // (Rust: `history_matches`). A pixel this frame's rays did not go through (proximity 0:
    // with the upsampling, 15 in 16) keeps its history as it is, so it reads neither the new
    // frame's colour nor its neighbourhood: the same result for less than half the reads.
    let end = vec4<f32>(distance, 0.0, 0.0, 0.0);
    let previous = reproject(direction, content);
    var surface = 0u;
    if temporal.valid != 0u && previous.z != 0.0 {
        surface = history_surface(previous.xy, distance);
    }
    var old = vec4<f32>(0.0);
    if surface != 0u {
        if surface == 2u {
            old = sample_history(previous.xy);
        } else {
            old = textureSampleLevel(history, history_sampler, previous.xy, 0.0);
        }
        if !(proximity > 0.0) {
            return TemporalOutput(old, end);
        }
    }

    var current = vec4<f32>(0.0);
    for (var k = 0; k < 4; k++) {
        current += weights[k] * textureLoad(march_colour, footprint_texel(f, k, size), 0);
    }
    if surface == 0u {
        return TemporalOutput(current, end);
    }

    // The new frame's range around this pixel, at the march's resolution.
    var lo = current;
    var hi = current;
    for (var dy = -1; dy <= 1; dy++) {
        for (var dx = -1; dx <= 1; dx++) {
            let texel = clamp(centre + vec2<i32>(dx, dy), vec2<i32>(0), size - 1);
            let colour = textureLoad(march_colour, texel, 0);
            lo = min(lo, colour);
            hi = max(hi, colour);
        }
    }
    let kept = mix(old, clamp(old, lo, hi), proximity);
    let motion = length((previous.xy - in.uv) * view.viewport.zw);
    let alpha = moving_blend(temporal.blend, motion) * proximity;
    return TemporalOutput(mix(kept, current, alpha), end);
}
