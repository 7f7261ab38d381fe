#define_import_path bevy_cloudscape::composite

// The view rays of a fullscreen pass and the depth-aware upsample's weights, shared by
// `upsample.wgsl` (the reduced-resolution march), `temporal.wgsl` (the temporal accumulation) and
// `march.wgsl` (its rays, and the reduced-resolution light-shaft factors).
// Also the geometry on the curved planet that the march, the haze and the upsample share: the
// sphere intersection, the ground and where a view ray ends.
// CPU twin: `src/reference/composite.rs` (same names; its module docs explain the weights); the
// geometry's is in `src/reference/render/geometry.rs`, `ray_end`'s in `composite.rs`.
// Rust side: `src/render/composite/mod.rs`.

// The distance a ray that meets no geometry (the sky) is stopped at, m. Rust: `FAR_AWAY`.
const FAR_AWAY: f32 = 3.0e38;
// Distances within this fraction of each other count as the same surface (weight e^-1).
// Rust: `DEPTH_TOLERANCE`.
const DEPTH_TOLERANCE: f32 = 0.05;
// Below this total weight no texel saw the pixel's surface. Rust: `MIN_WEIGHT_SUM`.
const MIN_WEIGHT_SUM: f32 = 1e-4;
// What `intersect_altitude_sphere` returns for a ray that misses the sphere. Rust: `NO_HIT`.
const NO_HIT: f32 = -1.0;

// Where the ground sphere is for a view: the camera's local vertical (xyz) and altitude above
// the ground (w, m), and the planet's radius (m). Written by `GpuViewGround` (Rust;
// `render/contract.rs` holds the layouts equal).
struct ViewGround {
    camera_up_altitude: vec4<f32>,
    planet_radius_m: f32,
    // The star field (`star_light`): celestial coordinates from world directions; then x the
    // illuminance of a magnitude-0 star outside the atmosphere (lux; 0: no stars), y a star's
    // spot's standard deviation (rad), z the full-resolution view's pixel angle (rad); and the
    // field's seed.
    celestial_from_world: mat3x3<f32>,
    stars: vec4<f32>,
    star_seed: u32,
    // The moon's disc (`moon_light`): xyz toward its centre, w its radius (rad); xyz from the
    // moon toward the sun, w the radiance per unit of shading (cd/m^2; 0: no disc).
    moon: vec4<f32>,
    moon_sun: vec4<f32>,
}

// ---------------------------------------------------------------------------------------------
// Geometry on the curved planet (the march's shells, the ground the rays end at)
// ---------------------------------------------------------------------------------------------

// Distances (near, far) along a ray to the sphere at `sphere_altitude` above the ground, for a
// camera at altitude `h` with mu = dot(direction, up); (NO_HIT, NO_HIT) on a miss. With
// A = R + h: t^2 + 2bt + c = 0, b = A mu, c = (h - alt)(2R + h + alt); discriminant
// (alt - h)(2R + alt + h) + b^2; stable roots q = -(b + sign(b) sqrt(disc)) and c / q.
// Rust: `intersect_altitude_sphere`.
fn intersect_altitude_sphere(h: f32, mu: f32, planet_radius: f32, sphere_altitude: f32) -> vec2<f32> {
    let b = (planet_radius + h) * mu;
    let c = (h - sphere_altitude) * (2.0 * planet_radius + h + sphere_altitude);
    let discriminant = (sphere_altitude - h) * (2.0 * planet_radius + sphere_altitude + h) + b * b;
    if !(discriminant >= 0.0) {
        return vec2<f32>(NO_HIT);
    }
    let q = -(b + select(-1.0, 1.0, b >= 0.0) * sqrt(discriminant));
    if q == 0.0 {
        return vec2<f32>(0.0);
    }
    let r = c / q;
    return vec2<f32>(min(q, r), max(q, r));
}

// Distance to the ground sphere ahead, FAR_AWAY if the ray does not go into the ground (tangent
// rays graze; a camera below the ground sphere is not stopped). Rust: `ground_distance`.
fn ground_distance(h: f32, mu: f32, planet_radius: f32) -> f32 {
    let t = intersect_altitude_sphere(h, mu, planet_radius, 0.0);
    return select(FAR_AWAY, t.x, t.x >= 0.0 && t.y > t.x);
}

// Where the view ray along `direction` from a camera at altitude `h` with local vertical `up`
// ends: the scene at `t_max` (FAR_AWAY: none) or the ground sphere, whichever is nearer. The
// upsample and the temporal accumulation weigh texels by it, so the planet's ground, which
// the depth prepass does not hold, is a surface apart from the sky above the horizon.
// Rust: `ray_end_m`.
fn ray_end(h: f32, up: vec3<f32>, direction: vec3<f32>, t_max: f32, planet_radius: f32) -> f32 {
    let mu = clamp(dot(direction, up), -1.0, 1.0);
    return min(t_max, ground_distance(h, mu, planet_radius));
}

// `ray_end` for a view whose ground is `ground`.
fn view_ray_end(ground: ViewGround, direction: vec3<f32>, t_max: f32) -> f32 {
    return ray_end(ground.camera_up_altitude.w, ground.camera_up_altitude.xyz, direction, t_max, ground.planet_radius_m);
}

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
    return footprint_offset(uv, size, vec2<f32>(0.0));
}

// The footprint of an image whose texels were sampled `offset` texels from their centres (the
// temporal upsampling). Rust: `upsample_offset`.
fn footprint_offset(uv: vec2<f32>, size: vec2<i32>, offset: vec2<f32>) -> Footprint {
    let position = uv * vec2<f32>(size) - 0.5 - offset;
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

// Normalised weights of the four texels of `f` (texel k: `footprint_texel(f, k, size)`) whose
// rays stopped at `taps_m`, for a pixel whose ray stops at `pixel_m`: bilinear times
// `depth_weight`, or, where no texel saw this pixel's surface, the texel nearest in distance
// alone (the first of equals). Rust: `upsample_weights`.
fn upsample_weights(f: Footprint, taps_m: vec4<f32>, pixel_m: f32) -> vec4<f32> {
    var taps = taps_m;
    var weights = vec4<f32>(0.0);
    var nearest = 0;
    for (var k = 0; k < 4; k++) {
        weights[k] = footprint_weight(f, k) * depth_weight(taps[k], pixel_m);
        if abs(taps[k] - pixel_m) < abs(taps[nearest] - pixel_m) {
            nearest = k;
        }
    }
    let sum = dot(weights, vec4<f32>(1.0));
    if sum < MIN_WEIGHT_SUM {
        var one = vec4<f32>(0.0);
        one[nearest] = 1.0;
        return one;
    }
    return weights / sum;
}

// NDC of a fullscreen triangle's `uv` (origin top left).
fn uv_to_ndc(uv: vec2<f32>) -> vec2<f32> {
    return vec2<f32>(uv.x * 2.0 - 1.0, 1.0 - uv.y * 2.0);
}

// The unit world direction of the view ray through `ndc`. Built in view space and rotated, not
// as a near-plane point minus the camera in world space: a camera 8 km from the origin holds
// its world position to a millimetre in f32, which against a 0.1 m near plane turns the
// directions by up to half a degree, in blocks. Rust (the test rig): `CloudRig`'s `ray`.
fn view_direction(view_from_clip: mat4x4<f32>, world_from_view: mat4x4<f32>, ndc: vec2<f32>) -> vec3<f32> {
    // Bevy's reverse-Z puts the near plane at NDC depth 1; the far plane is at infinity.
    let near_view = view_from_clip * vec4<f32>(ndc, 1.0, 1.0);
    return normalize((world_from_view * vec4<f32>(near_view.xyz / near_view.w, 0.0)).xyz);
}

// How far the view ray through `ndc` goes before it meets the depth prepass's `depth`: the
// length of the surface's view-space position, or FAR_AWAY for depth 0 (the sky).
fn surface_distance(view_from_clip: mat4x4<f32>, ndc: vec2<f32>, depth: f32) -> f32 {
    if depth <= 0.0 {
        return FAR_AWAY;
    }
    let surface_view = view_from_clip * vec4<f32>(ndc, depth, 1.0);
    return length(surface_view.xyz / surface_view.w);
}

// ---------------------------------------------------------------------------------------------
// The stars behind the clouds
// ---------------------------------------------------------------------------------------------

// Rust: the constants of the same names in `src/sky/stars.rs`.
const STAR_CELLS: u32 = 39u;
const FAINTEST_MAGNITUDE: f32 = 6.5;
const EXTINCTION_MAG_PER_AIRMASS: f32 = 0.2;
const STAR_CELL_MARGIN: f32 = 0.15;
const PI: f32 = 3.141592653589793;

// The visual air mass at `sin_elevation` above the horizon (Kasten & Young 1989). Rust:
// `sky::light::air_mass`.
fn air_mass(sin_elevation: f32) -> f32 {
    let elevation_deg = degrees(asin(sin_elevation));
    return 1.0 / (sin_elevation + 0.50572 * pow(elevation_deg + 6.07995, -1.6364));
}

// The radiance (cd/m^2, linear RGB, before exposure) of the moon's disc along the world
// direction `direction` (unit): Lommel-Seeliger shading mu0 / (mu0 + mu) of the sunlit part,
// the rim blended over one pixel, dimmed by the air mass; 0 without a disc or below the
// horizon. Rust: `MoonDisc::radiance` (with `shading` and `coverage`).
fn moon_light(ground: ViewGround, direction: vec3<f32>) -> vec3<f32> {
    let sin_elevation = dot(direction, ground.camera_up_altitude.xyz);
    if !(ground.moon_sun.w > 0.0) || !(sin_elevation > 0.0) {
        return vec3<f32>(0.0);
    }
    let m = ground.moon.xyz;
    let radius = ground.moon.w;
    let angle = acos(clamp(dot(direction, m), -1.0, 1.0));
    let pixel = ground.stars.z;
    var coverage = select(0.0, 1.0, angle <= radius);
    if pixel > 0.0 {
        coverage = saturate((radius - angle) / pixel + 0.5);
    }
    if !(coverage > 0.0) {
        return vec3<f32>(0.0);
    }
    var p = (direction - m * dot(direction, m)) / sin(radius);
    let rho = length(p);
    if rho > 1.0 {
        p = p / rho;
    }
    let mu = sqrt(max(1.0 - dot(p, p), 0.0));
    let mu0 = dot(p - m * mu, ground.moon_sun.xyz);
    if !(mu0 > 0.0) {
        return vec3<f32>(0.0);
    }
    let extinction = pow(10.0, -0.4 * EXTINCTION_MAG_PER_AIRMASS * air_mass(sin_elevation));
    return vec3<f32>(ground.moon_sun.w * mu0 / (mu0 + mu) * coverage * extinction);
}

// Rust: `star_hash`.
fn star_hash(value: u32) -> u32 {
    var x = value;
    x ^= x >> 16u;
    x *= 0x7feb352du;
    x ^= x >> 15u;
    x *= 0x846ca68bu;
    x ^= x >> 16u;
    return x;
}

// The k-th random number of a cell's hash h, in (0, 1). Rust: `unit`.
fn star_unit(h: u32, k: u32) -> f32 {
    return (f32(star_hash(h + k) >> 8u) + 0.5) / 16777216.0;
}

// The radiance (cd/m^2, linear RGB, before exposure) of the star field along the world direction
// `direction` (unit): the star of the celestial cube-map cell the direction falls in, a Gaussian
// spot, dimmed by the air mass. 0 without stars or below the horizon. Rust: `star_radiance`
// (with `star_cell` and `cell_star`).
fn star_light(ground: ViewGround, direction: vec3<f32>) -> vec3<f32> {
    let sin_elevation = dot(direction, ground.camera_up_altitude.xyz);
    if !(ground.stars.x > 0.0) || !(sin_elevation > 0.0) {
        return vec3<f32>(0.0);
    }
    let c = normalize(ground.celestial_from_world * direction);
    let d = abs(c);
    var face = 0u;
    var major = vec3<f32>(1.0, 0.0, 0.0);
    var u = vec3<f32>(0.0, 1.0, 0.0);
    var v = vec3<f32>(0.0, 0.0, 1.0);
    var ab = vec2<f32>(c.y, c.z) / d.x;
    if d.x >= d.y && d.x >= d.z {
        face = select(0u, 1u, c.x < 0.0);
        major = vec3<f32>(sign(c.x), 0.0, 0.0);
    } else if d.y >= d.z {
        face = select(2u, 3u, c.y < 0.0);
        major = vec3<f32>(0.0, sign(c.y), 0.0);
        u = vec3<f32>(0.0, 0.0, 1.0);
        v = vec3<f32>(1.0, 0.0, 0.0);
        ab = vec2<f32>(c.z, c.x) / d.y;
    } else {
        face = select(4u, 5u, c.z < 0.0);
        major = vec3<f32>(0.0, 0.0, sign(c.z));
        u = vec3<f32>(1.0, 0.0, 0.0);
        v = vec3<f32>(0.0, 1.0, 0.0);
        ab = vec2<f32>(c.x, c.y) / d.z;
    }
    let n = f32(STAR_CELLS);
    let cell = min(vec2<u32>(floor(0.5 * (atan(ab) * (4.0 / PI) + 1.0) * n)), vec2<u32>(STAR_CELLS - 1u));
    let index = (face * STAR_CELLS + cell.y) * STAR_CELLS + cell.x;
    let h = star_hash(ground.star_seed ^ star_hash(index));
    let inner = 1.0 - 2.0 * STAR_CELL_MARGIN;
    let s = -1.0 + 2.0 * (vec2<f32>(cell) + STAR_CELL_MARGIN + inner * vec2<f32>(star_unit(h, 0u), star_unit(h, 1u))) / n;
    let place = tan(s * (PI / 4.0));
    let star = normalize(major + u * place.x + v * place.y);
    let magnitude = FAINTEST_MAGNITUDE + 2.0 * log2(star_unit(h, 2u)) * 0.30102999566398120;
    let mass = air_mass(sin_elevation);
    let sigma = ground.stars.y;
    let offset = c - star;
    let spot = exp(-dot(offset, offset) / (2.0 * sigma * sigma)) / (2.0 * PI * sigma * sigma);
    let lux = ground.stars.x * pow(10.0, -0.4 * (magnitude + EXTINCTION_MAG_PER_AIRMASS * mass));
    let colour = mix(vec3<f32>(0.80, 0.88, 1.0), vec3<f32>(1.0, 0.80, 0.60), star_unit(h, 3u));
    return colour / dot(colour, vec3<f32>(0.2126, 0.7152, 0.0722)) * (lux * spot);
}
