#define_import_path bevy_cloudscape::composite

// The depth-aware upsample's weights, shared by `upsample.wgsl` (the reduced-resolution march)
// and `march.wgsl` (the reduced-resolution light-shaft factors).
// CPU twin: `src/reference/composite.rs` (same names; its module docs explain the weights).
// Rust side: `src/render/composite/mod.rs`.

// The distance a ray that meets no geometry (the sky) is stopped at, m. Rust: `FAR_AWAY`.
const FAR_AWAY: f32 = 3.0e38;
// Distances within this fraction of each other count as the same surface (weight e^-1).
// Rust: `DEPTH_TOLERANCE`.
const DEPTH_TOLERANCE: f32 = 0.05;
// Below this total weight no texel saw the pixel's surface. Rust: `MIN_WEIGHT_SUM`.
const MIN_WEIGHT_SUM: f32 = 1e-4;

// How much a texel whose ray stopped at `tap_m` counts for a pixel whose ray stops at
// `pixel_m`, before the bilinear weight. Rust: `depth_weight`.
fn depth_weight(tap_m: f32, pixel_m: f32) -> f32 {
    let gap = abs(tap_m - pixel_m);
    let scale = DEPTH_TOLERANCE * max(min(tap_m, pixel_m), 1e-3);
    return exp(-gap / scale);
}

// The four texels of a `size` image around `uv` (0-1) and their bilinear weights: texel k is
// `base + (k & 1, k >> 1)`, clamped to the image. Rust: the loop in `upsample`.
struct Footprint {
    base: vec2<i32>,
    fraction: vec2<f32>,
}

fn footprint(uv: vec2<f32>, size: vec2<i32>) -> Footprint {
    let position = uv * vec2<f32>(size) - 0.5;
    let base = floor(position);
    return Footprint(vec2<i32>(base), position - base);
}

fn footprint_texel(f: Footprint, k: i32, size: vec2<i32>) -> vec2<i32> {
    return clamp(f.base + vec2<i32>(k & 1, k >> 1), vec2<i32>(0), size - 1);
}

fn footprint_weight(f: Footprint, k: i32) -> f32 {
    let offset = vec2<i32>(k & 1, k >> 1);
    return select(1.0 - f.fraction.x, f.fraction.x, offset.x == 1)
        * select(1.0 - f.fraction.y, f.fraction.y, offset.y == 1);
}
