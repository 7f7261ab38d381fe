// The Bern demo's ground at the scale of a pixel: the terrain mesh carries its land cover per
// vertex (meadow, forest on slopes, rock, snow; about 200 m apart), and this extension of the
// standard material adds what lies between the vertices, from the fragment's world position:
// a patchwork of fields with hedges between them, woods scattered over open ground, and relief
// shading of knolls and hollows. Every addition fades out where a pixel covers more ground than
// it can show (`fwidth` of the position), toward its mean, so the far land keeps its colour and
// does not shimmer. Rust side: `examples/bern/terrain.rs` (`LandCover`).

#import bevy_pbr::{
    pbr_fragment::pbr_input_from_standard_material,
    pbr_functions::alpha_discard,
}
#ifdef PREPASS_PIPELINE
#import bevy_pbr::{
    prepass_io::{VertexOutput, FragmentOutput},
    pbr_deferred_functions::deferred_output,
}
#else
#import bevy_pbr::{
    forward_io::{VertexOutput, FragmentOutput},
    pbr_functions::{apply_pbr_lighting, main_pass_post_lighting_processing},
}
#endif

struct LandCover {
    // Mean width of a field, m.
    field_size_m: f32,
    // Share of open ground under woods, 0-1.
    wood_share: f32,
    // Height of the knolls and hollows, m.
    relief_m: f32,
    // Width of the hedges and tree lines between fields, m.
    hedge_m: f32,
    // Linear albedo of a wood seen from above: the terrain palette's forest (rgb).
    wood: vec4<f32>,
    // Linear albedo of snow (rgb).
    snow: vec4<f32>,
    // Height where snow is half-way in on level ground, m above sea level (world y).
    snow_line_m: f32,
    // Width of the snow's transition around the snow line, m.
    snow_transition_m: f32,
}

@group(#{MATERIAL_BIND_GROUP}) @binding(100) var<uniform> land: LandCover;

// Mean width of a wood, m.
const WOOD_SIZE_M: f32 = 900.0;
// Width of the patches of moister and drier grass, m.
const GRASS_M: f32 = 30.0;
// Width of a tree crown, m.
const CROWN_M: f32 = 8.0;
// Wavelength of the longest relief octave, m.
const RELIEF_WAVELENGTH_M: f32 = 150.0;
// How much lower snow lies on a slope facing north than on level ground, and higher on one
// facing south, m: the shaded side keeps it longer.
const SNOW_ASPECT_M: f32 = 150.0;
// Height of the snow line's patches (drifts, gullies, sunny knolls), m, and their size.
const SNOW_PATCH_M: f32 = 120.0;
const SNOW_PATCH_SIZE_M: f32 = 1500.0;

// Chris Wellons' lowbias32 finaliser of the mixed lattice coordinates.
fn hash(c: vec2<i32>, seed: u32) -> u32 {
    var x = bitcast<u32>(c.x) * 0x8da6b343u + bitcast<u32>(c.y) * 0xd8163841u + seed * 0xcb1ab31fu;
    x ^= x >> 16u;
    x *= 0x7feb352du;
    x ^= x >> 15u;
    x *= 0x846ca68bu;
    x ^= x >> 16u;
    return x;
}

// A uniform number in [0, 1) from a hash.
fn unit(h: u32) -> f32 {
    return f32(h >> 8u) / 16777216.0;
}

// Smooth value noise in [0, 1] at `p` (lattice units).
fn value_noise(p: vec2<f32>, seed: u32) -> f32 {
    let i = vec2<i32>(floor(p));
    let f = fract(p);
    let u = f * f * (3.0 - 2.0 * f);
    let a = unit(hash(i, seed));
    let b = unit(hash(i + vec2<i32>(1, 0), seed));
    let c = unit(hash(i + vec2<i32>(0, 1), seed));
    let d = unit(hash(i + vec2<i32>(1, 1), seed));
    return mix(mix(a, b, u.x), mix(c, d, u.x), u.y);
}

// Three octaves of value noise, each half the wavelength and amplitude, in [0, 1].
fn fbm(p: vec2<f32>, seed: u32) -> f32 {
    return (4.0 * value_noise(p, seed) + 2.0 * value_noise(2.03 * p, seed + 1u)
        + value_noise(4.07 * p, seed + 2u)) / 7.0;
}

// The field around `p` (metres): x the distance to its edge (half the gap between the nearest
// and the second-nearest field centre), m; y a number in [0, 1) that names the field.
fn field(p: vec2<f32>) -> vec2<f32> {
    let q = p / land.field_size_m;
    let cell = vec2<i32>(floor(q));
    var first = 1e9;
    var second = 1e9;
    var id = 0u;
    for (var y = -1; y <= 1; y++) {
        for (var x = -1; x <= 1; x++) {
            let c = cell + vec2<i32>(x, y);
            let h = hash(c, 11u);
            let centre = vec2<f32>(c) + 0.1 + 0.8 * vec2<f32>(unit(h), unit(hash(c, 12u)));
            let d = length(q - centre);
            if d < first {
                second = first;
                first = d;
                id = h;
            } else if d < second {
                second = d;
            }
        }
    }
    return vec2<f32>(0.5 * (second - first) * land.field_size_m, unit(id * 747796405u + 1u));
}

// The albedo factor of a field named `u` (0-1) on meadow: pasture, young crops, rape in flower,
// bare soil, mown meadow. Their mean over many fields is about 1.
fn field_tint(u: f32) -> vec3<f32> {
    if u < 0.45 {
        return vec3<f32>(0.8 + 0.5 * u);
    } else if u < 0.65 {
        return vec3<f32>(1.35, 1.2, 0.9);
    } else if u < 0.7 {
        return vec3<f32>(2.4, 1.6, 0.7);
    } else if u < 0.85 {
        return vec3<f32>(0.75, 0.35, 1.3);
    }
    return vec3<f32>(1.15, 1.1, 1.25);
}

// The ground's height above the mesh at `p`, m (relief_m times a field of mean 0).
fn relief(p: vec2<f32>) -> f32 {
    return land.relief_m * (2.0 * fbm(p / RELIEF_WAVELENGTH_M, 21u) - 1.0);
}

@fragment
fn fragment(in: VertexOutput, @builtin(front_facing) is_front: bool) -> FragmentOutput {
    var pbr_input = pbr_input_from_standard_material(in, is_front);
    let p = in.world_position.xz;
    // Ground a pixel covers, m: the geometric mean of its two sides, so a field seen at a
    // grazing angle, squeezed in depth but wide across, stays until its area is a pixel's.
    let footprint = max(sqrt(length(dpdx(p)) * length(dpdy(p))), 1e-3);
    let colour = pbr_input.material.base_color.rgb;
    // Open ground: the vertex colour's meadow (bright green), not its forest, rock or snow.
    let luminance = dot(colour, vec3<f32>(0.2126, 0.7152, 0.0722));
    let green = colour.g - max(colour.r, colour.b);
    let open = smoothstep(0.08, 0.16, luminance) * smoothstep(0.02, 0.08, green);
    // Fields and hedges, faded toward their mean where pixels cover several fields.
    let f = field(p);
    let fields_shown = open * (1.0 - smoothstep(0.1, 0.4, footprint / land.field_size_m));
    var tint = mix(vec3<f32>(1.0), field_tint(f.y), fields_shown);
    let hedge = (1.0 - smoothstep(0.5 * land.hedge_m, land.hedge_m, f.x))
        * (1.0 - smoothstep(0.5, 2.0, footprint / land.hedge_m));
    tint = mix(tint, land.wood.rgb / max(colour, vec3<f32>(1e-4)), 0.8 * open * hedge);
    // Woods over open ground: kept at every distance (they are as large as several vertices),
    // their edges as soft as a pixel.
    let wood_noise = fbm(p / WOOD_SIZE_M, 31u);
    let edge = 0.3 * max(footprint, 10.0) / WOOD_SIZE_M;
    // The noise's level that about `wood_share` of the ground lies above (between shares of
    // 0.1 and 0.4, within 0.01 of the measured quantiles).
    let level = 0.72 - 0.44 * land.wood_share;
    let wood = open * smoothstep(level - edge, level + edge, wood_noise);
    tint = mix(tint, land.wood.rgb / max(colour, vec3<f32>(1e-4)), wood);
    // Grass in every field: moister and drier, mown and standing patches, in four octaves from
    // GRASS_M down to tufts, each faded where a pixel covers it.
    var patches = 0.0;
    var scale = GRASS_M;
    var amplitude = 0.5;
    for (var octave = 0u; octave < 4u; octave++) {
        let shown = 1.0 - smoothstep(0.25, 1.0, footprint / scale);
        patches += amplitude * shown * (value_noise(p / scale, 51u + octave) - 0.5);
        scale *= 0.23;
        amplitude *= 0.7;
    }
    tint *= 1.0 + 0.8 * patches * open * (1.0 - wood);
    // Tree crowns in every wood, the mesh's and these: light and shade a crown apart, faded
    // where a pixel covers several crowns.
    let forest = max(wood, 1.0 - open) * (1.0 - smoothstep(0.5, 2.0, footprint / CROWN_M));
    tint *= mix(1.0, 0.55 + 0.9 * value_noise(p / CROWN_M, 41u), forest);
    // Snow above the snow line, lower on slopes facing north (world -z) and higher on those
    // facing south, sliding off faces steeper than about 45 degrees (the terrain palette's
    // rule), in patches along the line.
    let n = normalize(in.world_normal);
    let run = length(n.xz);
    let steepness = run / max(n.y, 1e-3);
    let north = select(0.0, -n.z / run, run > 1e-4) * smoothstep(0.05, 0.3, steepness);
    let half = 0.5 * max(land.snow_transition_m, 1.0);
    let height = in.world_position.y + SNOW_ASPECT_M * north
        + SNOW_PATCH_M * (2.0 * fbm(p / SNOW_PATCH_SIZE_M, 61u) - 1.0);
    let snow = smoothstep(land.snow_line_m - half, land.snow_line_m + half, height)
        * (1.0 - smoothstep(0.9, 1.4, steepness));
    let albedo = mix(colour * tint, land.snow.rgb, snow);
    pbr_input.material.base_color = vec4<f32>(albedo, pbr_input.material.base_color.a);
    // Knolls and hollows: the normal of the relief, faded where a pixel covers its wavelength.
    let e = RELIEF_WAVELENGTH_M / 16.0;
    let slope = vec2<f32>(relief(p + vec2<f32>(e, 0.0)) - relief(p - vec2<f32>(e, 0.0)),
        relief(p + vec2<f32>(0.0, e)) - relief(p - vec2<f32>(0.0, e))) / (2.0 * e);
    let relief_shown = 1.0 - smoothstep(0.05, 0.25, footprint / RELIEF_WAVELENGTH_M);
    pbr_input.N = normalize(pbr_input.N - vec3<f32>(slope.x, 0.0, slope.y) * relief_shown);
    pbr_input.material.base_color = alpha_discard(pbr_input.material, pbr_input.material.base_color);
#ifdef PREPASS_PIPELINE
    let out = deferred_output(in, pbr_input);
#else
    var out: FragmentOutput;
    out.color = apply_pbr_lighting(pbr_input);
    out.color = main_pass_post_lighting_processing(pbr_input, out.color);
#endif
    return out;
}
