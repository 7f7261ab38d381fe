// Entry shader of the cloud march: one fullscreen triangle per view. It builds each pixel's view
// ray, ends it at scene geometry from the depth prepass, and calls `march_clouds` from the
// `bevy_cloudscape::clouds` library (bindings 2-7, 9, 10 and 12 live in the libraries it imports,
// `parameters.wgsl` and `textures.wgsl`) and `march_haze` from
// `bevy_cloudscape::haze` (binding 8). The output (L, T) is blended as
// `scene * T + L` by the pipeline's blend state. With LOW_RES it runs at a reduced resolution
// into its own targets instead, and `composite/upsample.wgsl` composites.
//
// A second entry, `shafts`, is the light-shaft pass: it runs first, at a reduced resolution,
// and writes each ray's shaft factors (`shaft_factors` in `haze.wgsl`) and the distance its ray
// was stopped at; `fragment` reads them back at binding 11 with the depth-aware upsample's
// weights. Rust side: `src/render/march/mod.rs`.

#import bevy_cloudscape::view_depth::{view, depth_prepass}
#import bevy_core_pipeline::fullscreen_vertex_shader::FullscreenVertexOutput
#import bevy_cloudscape::cloud_parameters::clouds
#import bevy_cloudscape::cloud_light::ray_start_jitter
#import bevy_cloudscape::clouds::march_clouds
#import bevy_cloudscape::haze::{march_haze, composite_haze, shaft_factors, haze}
#import bevy_cloudscape::composite::{
    footprint, footprint_texel, upsample_weights, uv_to_ndc, view_direction, surface_distance,
    ray_end,
}


// The shaft pass's output (x: factor below the lowest cloud base, y: above, z: where the ray
// was stopped, m); a 1x1 stand-in when the view has no shafts (`haze.shafts` is then 0) and
// while the shaft pass itself runs.
@group(0) @binding(11) var shaft_texture: texture_2d<f32>;

#ifdef LOW_RES
// At a reduced resolution, and for the temporal accumulation, the pass writes (L, T) and, for
// the depth-aware upsample (`upsample.wgsl`, `temporal.wgsl`), the distance the ray was stopped
// at and the distance of its content.
struct MarchOutput {
    @location(0) colour: vec4<f32>,
    @location(1) distance: vec4<f32>,
}
#endif

// The view ray through the fullscreen triangle's `uv`, and where it ends (the scene's depth, or
// FAR_AWAY for the sky).
struct ViewRay {
    direction: vec3<f32>,
    t_max: f32,
}

fn view_ray(uv: vec2<f32>, depth: f32) -> ViewRay {
    let ndc = uv_to_ndc(uv);
    return ViewRay(
        view_direction(view.view_from_clip, view.world_from_view, ndc),
        surface_distance(view.view_from_clip, ndc, depth),
    );
}

// The depth at the full-resolution pixel under a reduced-resolution pixel's centre.
fn depth_under(uv: vec2<f32>) -> f32 {
    let full_pixel = min(uv * view.viewport.zw, view.viewport.zw - 1.0);
    return textureLoad(depth_prepass, vec2<i32>(full_pixel), 0);
}

// The light-shaft pass (reduced resolution): the ray's shaft factors and its end.
@fragment
fn shafts(in: FullscreenVertexOutput) -> @location(0) vec4<f32> {
    let ray = view_ray(in.uv, depth_under(in.uv));
    let jitter = ray_start_jitter(in.position.xy);
    let h = clouds.camera_altitude_m;
    let up = clouds.camera_up.xyz;
    let factors = shaft_factors(h, up, ray.direction, ray.t_max, jitter);
    return vec4<f32>(factors, ray_end(h, up, ray.direction, ray.t_max, clouds.planet_radius_m), 0.0);
}

// This pixel's shaft factors: the shaft pass's texels around `uv`, weighted for the distance
// their rays were stopped at (`distance`: `ray_end`) like the upsample (Rust:
// `reference::composite::upsample`). The clouds' mean shade without shafts.
fn upsampled_shafts(uv: vec2<f32>, distance: f32) -> vec2<f32> {
    if haze.shafts == 0u {
        return vec2<f32>(haze.sun_transmittance);
    }
    let size = vec2<i32>(textureDimensions(shaft_texture));
    let f = footprint(uv, size);
    var taps = vec4<f32>(0.0);
    for (var k = 0; k < 4; k++) {
        taps[k] = textureLoad(shaft_texture, footprint_texel(f, k, size), 0).z;
    }
    let weights = upsample_weights(f, taps, distance);
    var sum = vec2<f32>(0.0);
    for (var k = 0; k < 4; k++) {
        sum += weights[k] * textureLoad(shaft_texture, footprint_texel(f, k, size), 0).xy;
    }
    return sum;
}

#ifdef LOW_RES
@fragment
fn fragment(in: FullscreenVertexOutput) -> MarchOutput {
    // The ray goes through this frame's sample point of the texel (the temporal upsampling's
    // offset, 0 without it), which falls on one full-resolution pixel; it ends at its depth.
    let uv = in.uv * clouds.march_uv_scale + clouds.sample_offset_uv;
    let depth = depth_under(uv);
#else
@fragment
fn fragment(in: FullscreenVertexOutput) -> @location(0) vec4<f32> {
    let uv = in.uv;
    let depth = textureLoad(depth_prepass, vec2<i32>(in.position.xy), 0);
#endif
    let pixel = in.position.xy;
    let ray = view_ray(uv, depth);
    let direction = ray.direction;
    let t_max = ray.t_max;

    // The clouds, then the haze in front of and behind them (`haze.wgsl`).
    let jitter = ray_start_jitter(pixel);
    let cloud = march_clouds(clouds.camera_altitude_m, clouds.camera_up.xyz, direction, t_max, jitter);
    let up = clouds.camera_up.xyz;
    let end = ray_end(clouds.camera_altitude_m, up, direction, t_max, clouds.planet_radius_m);
    let shafts = upsampled_shafts(uv, end);
    let hazy = march_haze(clouds.camera_altitude_m, clouds.camera_up.xyz, direction, t_max, cloud.distance, jitter, shafts);
    let result = composite_haze(hazy, cloud.colour);
#ifdef LOW_RES
    // Where the ray stopped, at the scene or the ground sphere (the upsample's depth weights),
    // and where its content lies (the temporal accumulation's reprojection): the clouds, or the
    // scene in front of them.
    return MarchOutput(vec4<f32>(result.rgb * view.exposure, result.a), vec4<f32>(end, min(cloud.distance, t_max), 0.0, 0.0));
#else
    return vec4<f32>(result.rgb * view.exposure, result.a);
#endif
}
