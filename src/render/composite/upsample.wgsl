// Depth-aware upsample of a reduced-resolution cloud march (march.wgsl with LOW_RES): each
// full-resolution pixel blends the four nearest low-resolution (L, T) texels with bilinear
// weights times `depth_weight` (`composite.wgsl`), so a pixel of near geometry takes only texels
// that were stopped at similar geometry, and cloud in front of the sky does not bleed over a
// hill's edge. The output is blended as `scene * T + L`, like the full-resolution march.
// A second entry, `copy`, composites a full-resolution image as it is (the temporal history,
// `temporal.wgsl`).
// CPU twin: `upsample` in `src/reference/composite.rs`. Rust side:
// `src/render/composite/mod.rs`.

#import bevy_render::view::View
#import bevy_core_pipeline::fullscreen_vertex_shader::FullscreenVertexOutput
#import bevy_cloudscape::composite::{
    FAR_AWAY, MIN_WEIGHT_SUM, depth_weight, footprint, footprint_texel, footprint_weight,
}

@group(0) @binding(0) var<uniform> view: View;
#ifdef MULTISAMPLED
@group(0) @binding(1) var depth_prepass: texture_depth_multisampled_2d;
#else
@group(0) @binding(1) var depth_prepass: texture_depth_2d;
#endif
@group(0) @binding(2) var low_colour: texture_2d<f32>;
@group(0) @binding(3) var low_distance: texture_2d<f32>;

fn surface_distance(in: FullscreenVertexOutput) -> f32 {
    let depth = textureLoad(depth_prepass, vec2<i32>(in.position.xy), 0);
    if depth <= 0.0 {
        return FAR_AWAY;
    }
    let ndc = vec2<f32>(in.uv.x * 2.0 - 1.0, 1.0 - in.uv.y * 2.0);
    let surface_view = view.view_from_clip * vec4<f32>(ndc, depth, 1.0);
    return length(surface_view.xyz / surface_view.w);
}

@fragment
fn fragment(in: FullscreenVertexOutput) -> @location(0) vec4<f32> {
    let distance = surface_distance(in);
    let size = vec2<i32>(textureDimensions(low_colour));
    let f = footprint(in.uv, size);
    var sum = vec4<f32>(0.0);
    var weight_sum = 0.0;
    var nearest = vec4<f32>(0.0, 0.0, 0.0, 1.0);
    var nearest_gap = FAR_AWAY;
    for (var k = 0; k < 4; k++) {
        let texel = footprint_texel(f, k, size);
        let colour = textureLoad(low_colour, texel, 0);
        let tap_distance = textureLoad(low_distance, texel, 0).x;
        let weight = footprint_weight(f, k) * depth_weight(tap_distance, distance);
        sum += weight * colour;
        weight_sum += weight;
        let gap = abs(tap_distance - distance);
        if gap < nearest_gap {
            nearest_gap = gap;
            nearest = colour;
        }
    }
    // No tap saw this pixel's surface (a thin object between texels): take the closest in depth.
    if weight_sum < MIN_WEIGHT_SUM {
        return nearest;
    }
    return sum / weight_sum;
}

// The full-resolution (L, T) at this pixel, composited as it is.
@fragment
fn copy(in: FullscreenVertexOutput) -> @location(0) vec4<f32> {
    return textureLoad(low_colour, vec2<i32>(in.position.xy), 0);
}
