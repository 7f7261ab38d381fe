// Entry shader of the cloud march: one fullscreen triangle per view. It builds each pixel's view
// ray, ends it at scene geometry from the depth prepass, and calls `march_clouds` from the
// `bevy_cloudscape::clouds` library (bindings 2-7 live there) and `march_haze` from
// `bevy_cloudscape::haze` (bindings 8-9). The output (L, T) is blended as
// `scene * T + L` by the pipeline's blend state. With LOW_RES it runs at a reduced resolution
// into its own targets instead, and `upsample.wgsl` composites. Rust side:
// `src/render/march/mod.rs`.

#import bevy_render::view::View
#import bevy_core_pipeline::fullscreen_vertex_shader::FullscreenVertexOutput
#import bevy_cloudscape::clouds::{clouds, march_clouds, ray_start_jitter, FAR_AWAY}
#import bevy_cloudscape::haze::{march_haze, composite_haze}

@group(0) @binding(0) var<uniform> view: View;
#ifdef MULTISAMPLED
@group(0) @binding(1) var depth_prepass: texture_depth_multisampled_2d;
#else
@group(0) @binding(1) var depth_prepass: texture_depth_2d;
#endif

#ifdef LOW_RES
// At a reduced resolution the pass writes (L, T) and, for the depth-aware upsample
// (`upsample.wgsl`), the distance the ray was stopped at.
struct MarchOutput {
    @location(0) colour: vec4<f32>,
    @location(1) distance: vec4<f32>,
}
#endif

#ifdef LOW_RES
@fragment
fn fragment(in: FullscreenVertexOutput) -> MarchOutput {
    // This pixel's centre falls on one full-resolution pixel; the ray ends at its depth.
    let full_pixel = min(in.uv * view.viewport.zw, view.viewport.zw - 1.0);
    let depth = textureLoad(depth_prepass, vec2<i32>(full_pixel), 0);
#else
@fragment
fn fragment(in: FullscreenVertexOutput) -> @location(0) vec4<f32> {
    let depth = textureLoad(depth_prepass, vec2<i32>(in.position.xy), 0);
#endif
    let pixel = in.position.xy;
    // Bevy's reverse-Z puts the near plane at NDC depth 1; the far plane is at infinity.
    let ndc = vec2<f32>(in.uv.x * 2.0 - 1.0, 1.0 - in.uv.y * 2.0);
    let near_world = view.world_from_clip * vec4<f32>(ndc, 1.0, 1.0);
    let direction = normalize(near_world.xyz / near_world.w - view.world_position);

    // Depth 0 is the sky: march to infinity. Otherwise the ray ends at the surface, whose
    // distance is the length of its view-space position.
    var t_max = FAR_AWAY;
    if depth > 0.0 {
        let surface_view = view.view_from_clip * vec4<f32>(ndc, depth, 1.0);
        t_max = length(surface_view.xyz / surface_view.w);
    }

    // The clouds, then the haze in front of and behind them (`haze.wgsl`).
    let jitter = ray_start_jitter(pixel);
    let cloud = march_clouds(clouds.camera_altitude_m, clouds.camera_up.xyz, direction, t_max, jitter);
    let hazy = march_haze(clouds.camera_altitude_m, clouds.camera_up.xyz, direction, t_max, cloud.distance, jitter);
    let result = composite_haze(hazy, cloud.colour);
#ifdef LOW_RES
    return MarchOutput(vec4<f32>(result.rgb * view.exposure, result.a), vec4<f32>(t_max));
#else
    return vec4<f32>(result.rgb * view.exposure, result.a);
#endif
}
