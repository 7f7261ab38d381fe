// Cloud shadow map: one texel per line along the sun, holding the fraction of direct sunlight
// that reaches the ground on that line through every cloud layer (red), and where down the line
// the cloud starts and its optical depth reaches 1 and 4 (green, blue, alpha). The texel layout is the one
// Bevy's `DirectionalLightTexture` projects with, so the map lights every `StandardMaterial`
// directly. Rust side: `src/render/shadow/mod.rs`; CPU twin: `src/reference/shadow.rs`.

#import bevy_cloudscape::cloud_shadow::shadow_column

// Written by `GpuShadowUniforms` (Rust); `render/contract.rs` holds the two layouts equal.
struct ShadowUniforms {
    // Centre of the map relative to the camera the layer uniforms were built for, m.
    centre_m: vec4<f32>,
    // Half the extent along the light's local x and y axes, m (perpendicular to the sun).
    axis_x_m: vec4<f32>,
    axis_y_m: vec4<f32>,
    // Texels per side.
    size: u32,
    // Samples per layer interval.
    steps: u32,
    // The texel's shorter side, m: picks the noise mips.
    footprint_m: f32,
    // This pass marches the rows row_offset + k * row_stride (Rust: `MapRows`).
    row_stride: u32,
    // xy: (bottom, top) of the layers, m (Rust: `ShadowMapFrame::cloud_range_m`).
    cloud_range_m: vec4<f32>,
    row_offset: u32,
    pad_a: u32,
    pad_b: u32,
    pad_c: u32,
}

@group(0) @binding(0) var shadow_map: texture_storage_2d<rgba16float, write>;
@group(0) @binding(1) var<uniform> shadow: ShadowUniforms;

@compute @workgroup_size(8, 8, 1)
fn generate_shadow(@builtin(global_invocation_id) id: vec3<u32>) {
    let texel = vec2<u32>(id.x, shadow.row_offset + id.y * shadow.row_stride);
    if texel.x >= shadow.size || texel.y >= shadow.size {
        return;
    }
    // Texel (i, j) is the line through centre + (1 - 2u) axis_x + (2v - 1) axis_y
    // (Rust: `ShadowMapFrame::texel_position`).
    let uv = (vec2<f32>(texel) + 0.5) / f32(shadow.size);
    let position = shadow.centre_m.xyz + (1.0 - 2.0 * uv.x) * shadow.axis_x_m.xyz
        + (2.0 * uv.y - 1.0) * shadow.axis_y_m.xyz;
    // (T to the ground, the cloud's top, the knots). Rust: `cloud_shadow_map_texels`.
    let column = shadow_column(position, shadow.steps, shadow.footprint_m, shadow.cloud_range_m.x);
    textureStore(shadow_map, vec2<i32>(texel), column);
}
