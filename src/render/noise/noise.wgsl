// Tileable cloud noise: compute shaders that fill the base (3D), detail (3D) and weather (2D)
// noise textures and box-filter the 3D mip chains.
//
// CPU twin: `src/reference/noise/mod.rs`. Every function here has a Rust function of the same name
// there (f64 there, f32 here) and the GPU output is tested against it, so change both together.
// The module docs there explain the noises, the channel recipes and the tiling.
//
// Entry points and bindings (all in @group(0); a pipeline layout needs only its own rows):
//
// | entry point       | workgroup | @binding(0) params | @binding(1) noise_3d_out | @binding(2) noise_2d_out | @binding(3) downsample_source |
// |-------------------|-----------|--------------------|--------------------------|--------------------------|-------------------------------|
// | generate_base     | 4×4×4     | uniform            | level 0, write           |                          |                               |
// | generate_detail   | 4×4×4     | uniform            | level 0, write           |                          |                               |
// | generate_weather  | 8×8×1     | uniform            |                          | write                    |                               |
// | downsample_3d     | 4×4×4     |                    | mip n, write             |                          | mip n - 1, textureLoad        |
//
// - noise_3d_out: `texture_storage_3d<rgba16float, write>`, a view of one mip level. The size
//   written is `textureDimensions(noise_3d_out)` (textures are cubes; `.x` is the side).
// - noise_2d_out: `texture_storage_2d<rgba8unorm, write>` (square).
// - downsample_source: `texture_3d<f32>`, a view whose base mip is level n - 1 of the same
//   texture (read with level 0 of the view); wgpu tracks usage per mip, so mip n - 1 sampled and
//   mip n written in one dispatch is allowed.
// - Dispatch ceil(size / 4) workgroups per axis for 3D (ceil(size / 8) in x and y for 2D);
//   invocations outside the texture return early, so sizes need not be multiples of 4 or 8.
//
// Every value written lies in [0, 1]. Rgba8Unorm (weather) stores round(v * 255) (Rust:
// `quantize_unorm8`). Base and detail (Rgba16Float) are rounded here to multiples of 2^-11
// (`quantize_noise`), which half floats hold exactly, so the texels do not depend on how the
// GPU rounds f32 to f16.

// Uniform parameters, written by `GpuNoiseParams` (render/noise/mod.rs), every field 16-byte
// aligned so the layout is the same under WGSL's uniform rules and encase; `render::contract`
// checks size and field order.
//
// Slot s is lane s % 4 of the `_{s / 4}` fields and comes from `NoiseRecipe::fbm_slots()[s]`
// (frequency and octaves as they are, persistence as f32); the slots are the SLOT_* constants
// below, the same numbers as in Rust.
struct NoiseParams {
    // Seed of every noise; each slot mixes itself in with `noise_seed`.
    seed: u32,
    _padding0: u32,
    _padding1: u32,
    _padding2: u32,
    // fBm base frequency, cells per texture period (whole numbers so the textures tile).
    frequencies_0: vec4<u32>,
    frequencies_1: vec4<u32>,
    frequencies_2: vec4<u32>,
    // fBm octave counts.
    octaves_0: vec4<u32>,
    octaves_1: vec4<u32>,
    octaves_2: vec4<u32>,
    // fBm persistences (amplitude ratio between octaves).
    persistences_0: vec4<f32>,
    persistences_1: vec4<f32>,
    persistences_2: vec4<f32>,
}

@group(0) @binding(0) var<uniform> params: NoiseParams;
@group(0) @binding(1) var noise_3d_out: texture_storage_3d<rgba16float, write>;
@group(0) @binding(2) var noise_2d_out: texture_storage_2d<rgba8unorm, write>;
@group(0) @binding(3) var downsample_source: texture_3d<f32>;

// Rust: `FbmRecipe`.
struct FbmRecipe {
    frequency: u32,
    octaves: u32,
    persistence: f32,
}

// Rust: the constants of the same names; see their docs there.
const MAX_OCTAVES: u32 = 8u;
const MAX_FREQUENCY: u32 = 4096u;
const WEATHER_SLICE_Z: f32 = 0.6180339887498949;
const CURL_STEP_CELLS: f32 = 1.0 / 256.0;
const CURL_RANGE: f32 = 3.0;
const PERLIN_WORLEY_CONTRAST: f32 = 4.0;
const VARIATION_CONTRAST: f32 = 2.0;

const SLOT_BASE_PERLIN: u32 = 0u;
const SLOT_BASE_WORLEY: u32 = 1u;
const SLOT_BASE_G: u32 = 2u;
const SLOT_BASE_B: u32 = 3u;
const SLOT_BASE_A: u32 = 4u;
const SLOT_DETAIL_R: u32 = 5u;
const SLOT_DETAIL_G: u32 = 6u;
const SLOT_DETAIL_B: u32 = 7u;
const SLOT_WEATHER_PERLIN: u32 = 8u;
const SLOT_WEATHER_WORLEY: u32 = 9u;
const SLOT_WEATHER_VARIATION: u32 = 10u;
const SLOT_WEATHER_CURL: u32 = 11u;

// The fBm recipe of one slot. Rust: `NoiseRecipe::fbm_slots`.
fn fbm_slot(slot: u32) -> FbmRecipe {
    let lane = slot % 4u;
    var frequencies = params.frequencies_2;
    var octaves = params.octaves_2;
    var persistences = params.persistences_2;
    if slot < 4u {
        frequencies = params.frequencies_0;
        octaves = params.octaves_0;
        persistences = params.persistences_0;
    } else if slot < 8u {
        frequencies = params.frequencies_1;
        octaves = params.octaves_1;
        persistences = params.persistences_1;
    }
    return FbmRecipe(frequencies[lane], octaves[lane], persistences[lane]);
}

// Hash pcg4d (Jarzynski & Olano 2020, "Hash Functions for GPU Rendering"): an LCG step on each
// lane, then two rounds of cross-lane multiply-adds around an xorshift. u32 arithmetic wraps.
// Rust: `pcg4d`.
fn pcg4d(input: vec4<u32>) -> vec4<u32> {
    var v = input * 1664525u + 1013904223u;
    // Sequential: each lane uses the lanes already updated, as published.
    v.x += v.y * v.w;
    v.y += v.z * v.x;
    v.z += v.x * v.y;
    v.w += v.y * v.z;
    v ^= v >> vec4<u32>(16u);
    v.x += v.y * v.w;
    v.y += v.z * v.x;
    v.z += v.x * v.y;
    v.w += v.y * v.z;
    return v;
}

// [0, 1) from the top 24 bits, exact in f32. Rust: `hash_to_unit`.
fn hash_to_unit(hash: u32) -> f32 {
    return f32(hash >> 8u) * (1.0 / 16777216.0);
}

// Seed of one slot: slots spread by the golden-ratio constant. Rust: `noise_seed`.
fn noise_seed(seed: u32, slot: u32) -> u32 {
    return seed + slot * 0x9E3779B9u;
}

// True modulo of a lattice cell, cell - period * floor(cell / period), in [0, period) for
// negative cells too: WGSL's `%` keeps the dividend's sign (Thomann 2021 §5.3). Rust: `wrap_cell`.
fn wrap_cell(cell: i32, period: u32) -> u32 {
    let p = i32(period);
    let remainder = cell % p;
    return u32(select(remainder, remainder + p, remainder < 0));
}

// Rust: `lattice_hash`.
fn lattice_hash(cell: vec3<u32>, seed: u32) -> vec4<u32> {
    return pcg4d(vec4<u32>(cell, seed));
}

// Quintic fade 6t^5 - 15t^4 + 10t^3 (Perlin 2002). Rust: `fade`.
fn fade(t: f32) -> f32 {
    return t * t * t * (t * (t * 6.0 - 15.0) + 10.0);
}

// a + (b - a) t, written out rather than `mix` so it rounds as the Rust twin does.
// Rust: `lerp`.
fn lerp(a: f32, b: f32, t: f32) -> f32 {
    return a + (b - a) * t;
}

// The 12 cube-edge gradients of Perlin 2002, padded to 16 as Perlin pads them.
// Rust: `PERLIN_GRADIENTS`.
const PERLIN_GRADIENTS = array<vec3<f32>, 16>(
    vec3<f32>(1.0, 1.0, 0.0),
    vec3<f32>(-1.0, 1.0, 0.0),
    vec3<f32>(1.0, -1.0, 0.0),
    vec3<f32>(-1.0, -1.0, 0.0),
    vec3<f32>(1.0, 0.0, 1.0),
    vec3<f32>(-1.0, 0.0, 1.0),
    vec3<f32>(1.0, 0.0, -1.0),
    vec3<f32>(-1.0, 0.0, -1.0),
    vec3<f32>(0.0, 1.0, 1.0),
    vec3<f32>(0.0, -1.0, 1.0),
    vec3<f32>(0.0, 1.0, -1.0),
    vec3<f32>(0.0, -1.0, -1.0),
    vec3<f32>(1.0, 1.0, 0.0),
    vec3<f32>(-1.0, 1.0, 0.0),
    vec3<f32>(0.0, -1.0, 1.0),
    vec3<f32>(0.0, -1.0, -1.0),
);

// Gradient picked by the top 4 bits of the hash. Rust: `perlin_gradient`.
fn perlin_gradient(hash: u32) -> vec3<f32> {
    var gradients = PERLIN_GRADIENTS;
    return gradients[hash >> 28u];
}

// Dot of one corner's gradient with the vector from that corner to p; `corner` is 0 or 1 per
// axis, `lo`/`hi` the wrapped lattice indices, `f` p's offset in its cell.
// Rust: `perlin_corner`.
fn perlin_corner(lo: vec3<u32>, hi: vec3<u32>, f: vec3<f32>, corner: vec3<u32>, seed: u32) -> f32 {
    let index = select(lo, hi, corner == vec3<u32>(1u));
    let g = perlin_gradient(lattice_hash(index, seed).x);
    let d = f - vec3<f32>(corner);
    return g.x * d.x + g.y * d.y + g.z * d.z;
}

// Periodic improved Perlin noise (Perlin 2002) at p in cells, period in cells; about [-1, 1].
// Rust: `perlin_noise_3d`.
fn perlin_noise_3d(p: vec3<f32>, period: u32, seed: u32) -> f32 {
    let cell_floor = floor(p);
    let f = p - cell_floor;
    let cell = vec3<i32>(cell_floor);
    // Corners wrapped on integers so the lattice repeats (Thomann 2021 §5.3).
    let lo = vec3<u32>(wrap_cell(cell.x, period), wrap_cell(cell.y, period), wrap_cell(cell.z, period));
    let hi = vec3<u32>(
        wrap_cell(cell.x + 1, period),
        wrap_cell(cell.y + 1, period),
        wrap_cell(cell.z + 1, period),
    );
    let u = vec3<f32>(fade(f.x), fade(f.y), fade(f.z));
    let x00 = lerp(
        perlin_corner(lo, hi, f, vec3<u32>(0u, 0u, 0u), seed),
        perlin_corner(lo, hi, f, vec3<u32>(1u, 0u, 0u), seed),
        u.x,
    );
    let x10 = lerp(
        perlin_corner(lo, hi, f, vec3<u32>(0u, 1u, 0u), seed),
        perlin_corner(lo, hi, f, vec3<u32>(1u, 1u, 0u), seed),
        u.x,
    );
    let x01 = lerp(
        perlin_corner(lo, hi, f, vec3<u32>(0u, 0u, 1u), seed),
        perlin_corner(lo, hi, f, vec3<u32>(1u, 0u, 1u), seed),
        u.x,
    );
    let x11 = lerp(
        perlin_corner(lo, hi, f, vec3<u32>(0u, 1u, 1u), seed),
        perlin_corner(lo, hi, f, vec3<u32>(1u, 1u, 1u), seed),
        u.x,
    );
    return lerp(lerp(x00, x10, u.y), lerp(x01, x11, u.y), u.z);
}

// Periodic inverted Worley noise 1 - min(F1, 1) (Worley 1996) at p in cells, period in cells;
// in [0, 1], bright at feature points (Pérez Martín 2022, "billowy" cells). The 27-cell search is exact
// for the clamped F1. Rust: `worley_noise_3d`.
fn worley_noise_3d(p: vec3<f32>, period: u32, seed: u32) -> f32 {
    let cell_floor = floor(p);
    let f = p - cell_floor;
    let cell = vec3<i32>(cell_floor);
    var nearest_squared = 1.0;
    for (var dz = -1; dz <= 1; dz++) {
        for (var dy = -1; dy <= 1; dy++) {
            for (var dx = -1; dx <= 1; dx++) {
                let index = vec3<u32>(
                    wrap_cell(cell.x + dx, period),
                    wrap_cell(cell.y + dy, period),
                    wrap_cell(cell.z + dz, period),
                );
                let h = lattice_hash(index, seed);
                // Feature point relative to p's cell, minus p's offset: small numbers only.
                let d = vec3<f32>(
                    f32(dx) + hash_to_unit(h.x) - f.x,
                    f32(dy) + hash_to_unit(h.y) - f.y,
                    f32(dz) + hash_to_unit(h.z) - f.z,
                );
                nearest_squared = min(nearest_squared, d.x * d.x + d.y * d.y + d.z * d.z);
            }
        }
    }
    return 1.0 - sqrt(nearest_squared);
}

// Which noise `fbm_3d` sums. Rust: `Octave`.
const OCTAVE_PERLIN: u32 = 0u;
const OCTAVE_WORLEY: u32 = 1u;

// fBm (Pérez Martín 2022, Figure 28) at p in texture units: octave k has frequency * 2^k cells per
// period and amplitude persistence^k; normalised by the sum of amplitudes. Rust: `fbm_3d`.
fn fbm_3d(p: vec3<f32>, fbm: FbmRecipe, seed: u32, octave: u32) -> f32 {
    let octaves = clamp(fbm.octaves, 1u, MAX_OCTAVES);
    let persistence = clamp(fbm.persistence, 0.0, 1.0);
    var period = clamp(fbm.frequency, 1u, MAX_FREQUENCY);
    var sum = 0.0;
    var amplitude = 1.0;
    var total_amplitude = 0.0;
    for (var k = 0u; k < octaves; k++) {
        let q = p * f32(period);
        let octave_seed = seed + k;
        var value: f32;
        if octave == OCTAVE_PERLIN {
            value = perlin_noise_3d(q, period, octave_seed);
        } else {
            value = worley_noise_3d(q, period, octave_seed);
        }
        sum += amplitude * value;
        total_amplitude += amplitude;
        amplitude *= persistence;
        period *= 2u;
    }
    return sum / total_amplitude;
}

// Rust: `perlin_fbm_3d`.
fn perlin_fbm_3d(p: vec3<f32>, fbm: FbmRecipe, seed: u32) -> f32 {
    return fbm_3d(p, fbm, seed, OCTAVE_PERLIN);
}

// Rust: `worley_fbm_3d`.
fn worley_fbm_3d(p: vec3<f32>, fbm: FbmRecipe, seed: u32) -> f32 {
    return fbm_3d(p, fbm, seed, OCTAVE_WORLEY);
}

// Linear remap (Pérez Martín 2022, Figure 30). Rust: `remap`.
fn remap(value: f32, old_min: f32, old_max: f32, new_min: f32, new_max: f32) -> f32 {
    return new_min + (value - old_min) / (old_max - old_min) * (new_max - new_min);
}

// clamp(0.5 + 0.5 * contrast * value, 0, 1). Rust: `signed_to_unit`.
fn signed_to_unit(value: f32, contrast: f32) -> f32 {
    return clamp(0.5 + 0.5 * contrast * value, 0.0, 1.0);
}

// Perlin fBm dilated by Worley fBm: remap(perlin, 0, 1, worley, 1) (Pérez Martín 2022, "Cloud
// textures"; Schneider 2015). Rust: `perlin_worley`.
fn perlin_worley(p: vec3<f32>, perlin: FbmRecipe, worley: FbmRecipe, perlin_seed: u32, worley_seed: u32) -> f32 {
    let perlin_unit = signed_to_unit(perlin_fbm_3d(p, perlin, perlin_seed), PERLIN_WORLEY_CONTRAST);
    let worley_unit = worley_fbm_3d(p, worley, worley_seed);
    return clamp(remap(perlin_unit, 0.0, 1.0, worley_unit, 1.0), 0.0, 1.0);
}

// 2D curl (dψ/dy, -dψ/dx) of the Perlin fBm potential ψ on the weather slice, at p in texture
// units; central differences per octave in that octave's cells, scaled to base-octave cells.
// Rust: `curl_noise_2d`.
fn curl_noise_2d(p: vec2<f32>, fbm: FbmRecipe, seed: u32) -> vec2<f32> {
    let octaves = clamp(fbm.octaves, 1u, MAX_OCTAVES);
    let persistence = clamp(fbm.persistence, 0.0, 1.0);
    var period = clamp(fbm.frequency, 1u, MAX_FREQUENCY);
    let h = CURL_STEP_CELLS;
    var gradient = vec2<f32>(0.0);
    var amplitude = 1.0;
    var total_amplitude = 0.0;
    var cell_ratio = 1.0;
    for (var k = 0u; k < octaves; k++) {
        let cells = f32(period);
        let q = vec3<f32>(p * cells, WEATHER_SLICE_Z * cells);
        let octave_seed = seed + k;
        let d_dx = (perlin_noise_3d(q + vec3<f32>(h, 0.0, 0.0), period, octave_seed)
            - perlin_noise_3d(q - vec3<f32>(h, 0.0, 0.0), period, octave_seed)) / (2.0 * h);
        let d_dy = (perlin_noise_3d(q + vec3<f32>(0.0, h, 0.0), period, octave_seed)
            - perlin_noise_3d(q - vec3<f32>(0.0, h, 0.0), period, octave_seed)) / (2.0 * h);
        gradient += amplitude * cell_ratio * vec2<f32>(d_dx, d_dy);
        total_amplitude += amplitude;
        amplitude *= persistence;
        cell_ratio *= 2.0;
        period *= 2u;
    }
    return vec2<f32>(gradient.y, -gradient.x) / total_amplitude;
}

// (index + 0.5) / size, in [0, 1). Rust: `texel_centre`.
fn texel_centre(index: u32, size: u32) -> f32 {
    return (f32(index) + 0.5) / f32(size);
}

// Rust: `encode_curl`.
fn encode_curl(component: f32) -> f32 {
    return 0.5 + 0.5 * clamp(component / CURL_RANGE, -1.0, 1.0);
}

// R Perlin-Worley, G/B/A Worley fBm. Rust: `base_texel`.
fn base_texel(texel: vec3<u32>, size: u32) -> vec4<f32> {
    let p = vec3<f32>(texel_centre(texel.x, size), texel_centre(texel.y, size), texel_centre(texel.z, size));
    return vec4<f32>(
        perlin_worley(
            p,
            fbm_slot(SLOT_BASE_PERLIN),
            fbm_slot(SLOT_BASE_WORLEY),
            noise_seed(params.seed, SLOT_BASE_PERLIN),
            noise_seed(params.seed, SLOT_BASE_WORLEY),
        ),
        worley_fbm_3d(p, fbm_slot(SLOT_BASE_G), noise_seed(params.seed, SLOT_BASE_G)),
        worley_fbm_3d(p, fbm_slot(SLOT_BASE_B), noise_seed(params.seed, SLOT_BASE_B)),
        worley_fbm_3d(p, fbm_slot(SLOT_BASE_A), noise_seed(params.seed, SLOT_BASE_A)),
    );
}

// R/G/B Worley fBm, A = 1. Rust: `detail_texel`.
fn detail_texel(texel: vec3<u32>, size: u32) -> vec4<f32> {
    let p = vec3<f32>(texel_centre(texel.x, size), texel_centre(texel.y, size), texel_centre(texel.z, size));
    return vec4<f32>(
        worley_fbm_3d(p, fbm_slot(SLOT_DETAIL_R), noise_seed(params.seed, SLOT_DETAIL_R)),
        worley_fbm_3d(p, fbm_slot(SLOT_DETAIL_G), noise_seed(params.seed, SLOT_DETAIL_G)),
        worley_fbm_3d(p, fbm_slot(SLOT_DETAIL_B), noise_seed(params.seed, SLOT_DETAIL_B)),
        1.0,
    );
}

// R coverage Perlin-Worley, G Perlin fBm, B/A curl x/y, on the slice z = WEATHER_SLICE_Z.
// Rust: `weather_texel`.
fn weather_texel(texel: vec2<u32>, size: u32) -> vec4<f32> {
    let uv = vec2<f32>(texel_centre(texel.x, size), texel_centre(texel.y, size));
    let p = vec3<f32>(uv, WEATHER_SLICE_Z);
    let curl = curl_noise_2d(uv, fbm_slot(SLOT_WEATHER_CURL), noise_seed(params.seed, SLOT_WEATHER_CURL));
    return vec4<f32>(
        perlin_worley(
            p,
            fbm_slot(SLOT_WEATHER_PERLIN),
            fbm_slot(SLOT_WEATHER_WORLEY),
            noise_seed(params.seed, SLOT_WEATHER_PERLIN),
            noise_seed(params.seed, SLOT_WEATHER_WORLEY),
        ),
        signed_to_unit(
            perlin_fbm_3d(p, fbm_slot(SLOT_WEATHER_VARIATION), noise_seed(params.seed, SLOT_WEATHER_VARIATION)),
            VARIATION_CONTRAST,
        ),
        encode_curl(curl.x),
        encode_curl(curl.y),
    );
}

// Steps per unit of the base and detail noise's grid. Rust: `NOISE_LEVELS`.
const NOISE_LEVELS: f32 = 2048.0;

// A texel rounded to a multiple of 1 / NOISE_LEVELS, clamped to [0, 1]: exactly a half float.
// Rust: `quantize_noise`.
fn quantize_noise(value: vec4<f32>) -> vec4<f32> {
    return floor(saturate(value) * NOISE_LEVELS + 0.5) / NOISE_LEVELS;
}

// Level 0 of the base texture. Rust: `generate_base`.
@compute @workgroup_size(4, 4, 4)
fn generate_base(@builtin(global_invocation_id) id: vec3<u32>) {
    let size = textureDimensions(noise_3d_out);
    if any(id >= size) {
        return;
    }
    textureStore(noise_3d_out, id, quantize_noise(base_texel(id, size.x)));
}

// Level 0 of the detail texture. Rust: `generate_detail`.
@compute @workgroup_size(4, 4, 4)
fn generate_detail(@builtin(global_invocation_id) id: vec3<u32>) {
    let size = textureDimensions(noise_3d_out);
    if any(id >= size) {
        return;
    }
    textureStore(noise_3d_out, id, quantize_noise(detail_texel(id, size.x)));
}

// The weather noise texture. Rust: `generate_weather`.
@compute @workgroup_size(8, 8, 1)
fn generate_weather(@builtin(global_invocation_id) id: vec3<u32>) {
    let size = textureDimensions(noise_2d_out);
    if any(id.xy >= size) {
        return;
    }
    textureStore(noise_2d_out, id.xy, weather_texel(id.xy, size.x));
}

// One 3D mip step: 2×2×2 box average of mip n - 1 into mip n; source coordinates clamp to the
// last texel, so odd sizes average their last texel twice. Corners are summed in the same
// order as the Rust twin. Rust: `downsample_3d`.
@compute @workgroup_size(4, 4, 4)
fn downsample_3d(@builtin(global_invocation_id) id: vec3<u32>) {
    let size = textureDimensions(noise_3d_out);
    if any(id >= size) {
        return;
    }
    let last = textureDimensions(downsample_source) - vec3<u32>(1u);
    var sum = vec4<f32>(0.0);
    for (var corner = 0u; corner < 8u; corner++) {
        let offset = vec3<u32>(corner & 1u, (corner >> 1u) & 1u, corner >> 2u);
        sum += textureLoad(downsample_source, min(2u * id + offset, last), 0);
    }
    textureStore(noise_3d_out, id, quantize_noise(sum / 8.0));
}
