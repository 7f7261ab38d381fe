// Depth-aware upsample of a reduced-resolution cloud march (march.wgsl with LOW_RES): each
// full-resolution pixel blends the four nearest low-resolution (L, T) texels with bilinear
// weights times `depth_weight` (`composite.wgsl`) of where the rays end (`view_ray_end`: the
// scene or the ground sphere), so a pixel of near geometry takes only texels that were stopped
// at similar geometry, cloud in front of the sky does not bleed over a hill's edge, and the sky
// does not bleed below the horizon of a scene with no ground of its own. The output is blended
// as `scene * T + L`, like the full-resolution march.
// A second entry, `copy`, composites a full-resolution image as it is (the temporal history,
// `temporal.wgsl`).
// CPU twin: `upsample` in `src/reference/composite.rs`. Rust side:
// `src/render/composite/mod.rs`.

#import bevy_cloudscape::view_depth::{view, depth_prepass}
#import bevy_core_pipeline::fullscreen_vertex_shader::FullscreenVertexOutput
#import bevy_cloudscape::composite::{
    FAR_AWAY, ViewGround, footprint, footprint_texel, upsample_weights, uv_to_ndc,
    surface_distance, star_light, moon_light, view_direction, view_ray_end,
}

@group(0) @binding(2) var low_colour: texture_2d<f32>;
@group(0) @binding(3) var low_distance: texture_2d<f32>;
@group(0) @binding(4) var<uniform> ground: ViewGround;

// This pixel's view ray: its world direction and where it ends (`view_ray_end`), m.
struct PixelRay {
    direction: vec3<f32>,
    distance: f32,
}

fn pixel_ray(in: FullscreenVertexOutput) -> PixelRay {
    let depth = textureLoad(depth_prepass, vec2<i32>(in.position.xy), 0);
    let ndc = uv_to_ndc(in.uv);
    let direction = view_direction(view.view_from_clip, view.world_from_view, ndc);
    return PixelRay(direction, view_ray_end(ground, direction, surface_distance(view.view_from_clip, ndc, depth)));
}

@fragment
fn fragment(in: FullscreenVertexOutput) -> @location(0) vec4<f32> {
    let ray = pixel_ray(in);
    let size = vec2<i32>(textureDimensions(low_colour));
    let f = footprint(in.uv, size);
    var taps = vec4<f32>(0.0);
    for (var k = 0; k < 4; k++) {
        taps[k] = textureLoad(low_distance, footprint_texel(f, k, size), 0).x;
    }
    let weights = upsample_weights(f, taps, ray.distance);
    var sum = vec4<f32>(0.0);
    for (var k = 0; k < 4; k++) {
        sum += weights[k] * textureLoad(low_colour, footprint_texel(f, k, size), 0);
    }
    return with_stars(sum, ray);
}

// (L, T) with the stars and the moon behind the clouds added where the pixel sees the sky: the composite
// `scene * T + L` then shows them through the clouds' transmittance, over the scene's sky.
fn with_stars(colour: vec4<f32>, ray: PixelRay) -> vec4<f32> {
    if ray.distance < FAR_AWAY {
        return colour;
    }
    let sky = star_light(ground, ray.direction) + moon_light(ground, ray.direction);
    return vec4<f32>(colour.rgb + colour.a * view.exposure * sky, colour.a);
}

// The full-resolution (L, T) at this pixel, composited as it is, with the stars.
@fragment
fn copy(in: FullscreenVertexOutput) -> @location(0) vec4<f32> {
    let colour = textureLoad(low_colour, vec2<i32>(in.position.xy), 0);
    // Without stars and moon the pixel's ray is not needed.
    if !(ground.stars.x > 0.0) && !(ground.moon_sun.w > 0.0) {
        return colour;
    }
    return with_stars(colour, pixel_ray(in));
}
