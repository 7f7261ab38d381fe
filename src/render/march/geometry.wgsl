#define_import_path bevy_cloudscape::cloud_geometry

// Geometry of the cloud march: the layers' shells on a curved planet and the intervals a ray
// marches through them. A shader library of the cloud march (see `clouds.wgsl`).
//
// CPU twin: `src/reference/render/geometry.rs`. Every function here has a Rust function of the
// same name there (f64 there, f32 here), and each points at the other; its module docs explain
// the geometry. `intersect_altitude_sphere` and `ground_distance` are in `composite.wgsl`, which
// the upsample shares.

#import bevy_cloudscape::composite::{FAR_AWAY, intersect_altitude_sphere}
#import bevy_cloudscape::cloud_parameters::{CloudLayerGpu, MAX_FAR_COVERAGES, cloud_layers, clouds}

// Rust: the constant of the same name in reference/render/geometry.rs; see its docs there.
const FAR_BLEND_START: f32 = 0.3;

fn saturate(x: f32) -> f32 {
    return clamp(x, 0.0, 1.0);
}

// `texel` wrapped into a texture of `size` texels, as Rust's `rem_euclid` (negative indices
// repeat too). A power-of-two size (every default texture) wraps with a mask: the same value
// for any sign, and far cheaper where the GPU is a CPU (software Vulkan scalarises vector
// integer division, and the march wraps a dozen texels per density sample).
fn wrap_texel(texel: vec2<i32>, size: vec2<i32>) -> vec2<i32> {
    if all((size & (size - 1)) == vec2<i32>(0)) {
        return texel & (size - 1);
    }
    return (texel % size + size) % size;
}

// Altitude at distance t along the ray: h + s / (A + sqrt(A^2 + s)), A = R + h,
// s = 2 A mu t + t^2, without subtracting two planet radii. Rust: `altitude_along_ray`.
fn altitude_along_ray(h: f32, mu: f32, t: f32, planet_radius: f32) -> f32 {
    let a = planet_radius + h;
    let s = 2.0 * a * mu * t + t * t;
    return h + s / (a + sqrt(max(a * a + s, 0.0)));
}

// The parts of a ray inside the shell [base, top]: xy and zw are segments [start, end] (empty
// when end <= start), not clipped to the ground or the scene. Rust: `shell_segments`.
fn shell_segments(h: f32, mu: f32, planet_radius: f32, base: f32, top: f32) -> vec4<f32> {
    let outer = intersect_altitude_sphere(h, mu, planet_radius, top);
    let inner = intersect_altitude_sphere(h, mu, planet_radius, base);
    let near_start = max(outer.x, 0.0);
    return vec4<f32>(near_start, min(inner.x, outer.y), max(inner.y, near_start), outer.y);
}

// Number of layers to read: the uniform's count, never past the buffer.
fn cloud_layer_count() -> u32 {
    return min(clouds.layer_count, arrayLength(&cloud_layers));
}

// Largest coverage anywhere: the layer's own or a far one. Rust: `max_coverage`.
fn max_coverage(index: u32) -> f32 {
    var coverage = cloud_layers[index].coverage;
    for (var i = 0u; i < min(cloud_layers[index].far_count, MAX_FAR_COVERAGES); i++) {
        coverage = max(coverage, cloud_layers[index].far[i].w);
    }
    return coverage;
}

// Coverage at `horizontal_m`, blended toward each far place by a smoothstep of the fraction of
// the way there, from FAR_BLEND_START to 1. Rust: `layer_coverage`.
fn layer_coverage(index: u32, horizontal_m: vec2<f32>) -> f32 {
    var coverage = cloud_layers[index].coverage;
    for (var i = 0u; i < min(cloud_layers[index].far_count, MAX_FAR_COVERAGES); i++) {
        let far = cloud_layers[index].far[i];
        let s = dot(horizontal_m, far.xy) + far.z;
        let t = saturate((s - FAR_BLEND_START) / (1.0 - FAR_BLEND_START));
        coverage += t * t * (3.0 - 2.0 * t) * (far.w - cloud_layers[index].coverage);
    }
    return saturate(coverage);
}

// Rust: `layer_is_active`.
fn layer_is_active(index: u32) -> bool {
    return max_coverage(index) > 0.0 && cloud_layers[index].extinction > 0.0 && cloud_layers[index].top_m > cloud_layers[index].base_m;
}

// Next interval [start, end] at or after t_from where the ray is inside an active layer, the
// pieces of every layer merged, clipped to t_max; start >= end when none. Rust:
// `next_cloud_interval`.
fn next_cloud_interval(h: f32, mu: f32, t_from: f32, t_max: f32) -> vec2<f32> {
    let count = cloud_layer_count();
    let radius = clouds.planet_radius_m;
    var start = FAR_AWAY;
    for (var i = 0u; i < count; i++) {
        if !layer_is_active(i) {
            continue;
        }
        let s = shell_segments(h, mu, radius, cloud_layers[i].base_m, cloud_layers[i].top_m);
        if s.y > s.x && s.y > t_from {
            start = min(start, max(s.x, t_from));
        }
        if s.w > s.z && s.w > t_from {
            start = min(start, max(s.z, t_from));
        }
    }
    if !(start < t_max) {
        return vec2<f32>(t_max);
    }
    // Grow the end over every piece that starts inside; each pass adds one piece at least.
    var end = start;
    for (var guard = 0u; guard <= 2u * count; guard++) {
        var grown = false;
        for (var i = 0u; i < count; i++) {
            if !layer_is_active(i) {
                continue;
            }
            let s = shell_segments(h, mu, radius, cloud_layers[i].base_m, cloud_layers[i].top_m);
            if s.y > s.x && s.y > t_from && s.x <= end && s.y > end {
                end = s.y;
                grown = true;
            }
            if s.w > s.z && s.w > t_from && s.z <= end && s.w > end {
                end = s.w;
                grown = true;
            }
        }
        if !grown {
            break;
        }
    }
    return vec2<f32>(start, min(end, t_max));
}

// Horizontal noise axes perpendicular to up: world +x and +z when up is +y. Rust:
// `horizontal_axes` (returns [x, z]).
struct HorizontalAxes {
    x: vec3<f32>,
    z: vec3<f32>,
}

fn horizontal_axes(up: vec3<f32>) -> HorizontalAxes {
    var x = cross(up, vec3<f32>(0.0, 0.0, 1.0));
    if dot(x, x) < 1e-6 {
        x = cross(up, vec3<f32>(1.0, 0.0, 0.0));
    }
    x = normalize(x);
    return HorizontalAxes(x, cross(x, up));
}

// expm1 and log1p, accurate near 0 where exp(x) - 1 and log(1 + x) lose digits in f32 (the Rust
// twin uses f64's exp_m1 and ln_1p).
fn expm1_stable(x: f32) -> f32 {
    if abs(x) < 1e-2 {
        return x * (1.0 + x * (0.5 + x * (1.0 / 6.0 + x / 24.0)));
    }
    return exp(x) - 1.0;
}

fn log1p_stable(x: f32) -> f32 {
    if abs(x) < 1e-2 {
        return x * (1.0 - x * (0.5 - x * (1.0 / 3.0 - x * 0.25)));
    }
    return log(1.0 + x);
}

// Boundary k of n in an interval lies at start + (end - start) * step_warp(k / n, beta),
// beta = g (end - start) / (1 + g start): steps (1 + g t) times as long as at the camera.
// step_warp = ((1 + beta)^u - 1) / beta = expm1(u log1p(beta)) / beta. Rust: `step_warp`.
fn step_warp(u: f32, beta: f32) -> f32 {
    if beta <= 1e-6 {
        return u;
    }
    return expm1_stable(u * log1p_stable(beta)) / beta;
}

// Altitude above the ground of a point relative to the camera. Rust: `altitude_of`.
fn altitude_of(position_m: vec3<f32>) -> f32 {
    let distance = length(position_m);
    if distance == 0.0 {
        return clouds.camera_altitude_m;
    }
    let mu = clamp(dot(position_m, clouds.camera_up.xyz) / distance, -1.0, 1.0);
    return altitude_along_ray(clouds.camera_altitude_m, mu, distance, clouds.planet_radius_m);
}
