#define_import_path bevy_cloudscape::cloud_shadow

// Cloud shadows: the column of the cloud shadow map along one sun line (`shadow_column`, run by
// the shadow-map pass, `src/render/shadow/shadow.wgsl`), and reading the map back (the march's
// far samples, the haze). A shader library of the cloud march (see `clouds.wgsl`).
//
// CPU twin: `src/reference/shadow.rs` (same names; its module docs explain the map).

#import bevy_cloudscape::composite::{FAR_AWAY, NO_HIT, intersect_altitude_sphere}
#import bevy_cloudscape::cloud_parameters::clouds
#import bevy_cloudscape::cloud_textures::{cloud_shadow_map, noise_sampler}
#import bevy_cloudscape::cloud_geometry::{
    altitude_along_ray, altitude_of, cloud_layer_count, horizontal_axes, next_cloud_interval,
    wrap_texel,
}
#import bevy_cloudscape::cloud_density::total_extinction
#import bevy_cloudscape::cloud_light::point_mu_sun

// ---------------------------------------------------------------------------------------------
// Cloud shadows (CPU twin: src/reference/shadow.rs)
// ---------------------------------------------------------------------------------------------

// Rust: the constants of the same names in reference/shadow.rs.
const MAX_SHADOW_STEPS: u32 = 64u;
const SHADOW_KNOT_DEPTHS: array<f32, 2> = array<f32, 2>(1.0, 4.0);

// The sun line through a point: where it meets the ground on the sun's side (its lowest point if
// it misses the ground), marched up from there. Rust: the set-up of `visit_sun_line`.
struct SunLine {
    origin: vec3<f32>,
    origin_altitude: f32,
    origin_mu: f32,
}

fn sun_line(position_m: vec3<f32>) -> SunLine {
    let radius = clouds.planet_radius_m;
    let sun = clouds.sun_direction.xyz;
    let altitude = altitude_of(position_m);
    let mu = point_mu_sun(clouds.camera_altitude_m, clouds.camera_up.xyz, position_m, altitude);
    // Light travels along -sun and reaches the far root first.
    let ground = intersect_altitude_sphere(altitude, mu, radius, 0.0);
    var start = ground.y;
    if ground.x == NO_HIT && ground.y == NO_HIT {
        start = -(radius + altitude) * mu;
    }
    let origin_altitude = altitude_along_ray(altitude, mu, start, radius);
    return SunLine(
        position_m + sun * start,
        origin_altitude,
        clamp(((radius + altitude) * mu + start) / (radius + origin_altitude), -1.0, 1.0),
    );
}

// The knots of the optical depth down one sun line: vec4(e^-tau, top, altitude where the depth
// from the top reaches SHADOW_KNOT_DEPTHS.x, .y); `bottom_m` for a clear line. Two passes over
// `steps` midpoint samples per layer interval (full detail, mips for `footprint_m`): the whole
// depth and the cloud's top and bottom, then the knots. Rust: `shadow_column` in
// reference/shadow.rs (whose `shadow_optical_depth` is the first pass).
fn shadow_column(position_m: vec3<f32>, steps: u32, footprint_m: f32, bottom_m: f32) -> vec4<f32> {
    let line = sun_line(position_m);
    let radius = clouds.planet_radius_m;
    let sun = clouds.sun_direction.xyz;
    let axes = horizontal_axes(clouds.camera_up.xyz);
    let n = clamp(steps, 1u, MAX_SHADOW_STEPS);
    let count = cloud_layer_count();
    var total = 0.0;
    var top = -FAR_AWAY;
    var lowest = FAR_AWAY;
    var below = 0.0;
    var knots = vec2<f32>(0.0);
    var previous_altitude = 0.0;
    var previous_depth = 0.0;
    for (var pass_index = 0u; pass_index < 2u; pass_index++) {
        if pass_index == 1u {
            if !(total > 0.0) {
                return vec4<f32>(1.0, bottom_m, bottom_m, bottom_m);
            }
            // The depth from the top rises from (lowest, total) to (top, 0).
            knots = vec2<f32>(lowest);
            previous_altitude = lowest;
            previous_depth = total;
        }
        var t = 0.0;
        for (var i = 0u; i <= 2u * count; i++) {
            let interval = next_cloud_interval(line.origin_altitude, line.origin_mu, t, FAR_AWAY);
            if !(interval.y > interval.x) || !(interval.y < FAR_AWAY) {
                break;
            }
            let dt = (interval.y - interval.x) / f32(n);
            for (var k = 0u; k < n; k++) {
                let s = interval.x + (f32(k) + 0.5) * dt;
                let point = line.origin + sun * s;
                let altitude = altitude_along_ray(line.origin_altitude, line.origin_mu, s, radius);
                let horizontal = vec2<f32>(dot(point, axes.x), dot(point, axes.z));
                let x = total_extinction(horizontal, altitude, footprint_m, true) * dt;
                if !(x > 0.0) {
                    continue;
                }
                if pass_index == 0u {
                    total += x;
                    top = max(top, altitude_along_ray(line.origin_altitude, line.origin_mu, s + 0.5 * dt, radius));
                    lowest = min(lowest, altitude_along_ray(line.origin_altitude, line.origin_mu, s - 0.5 * dt, radius));
                    continue;
                }
                let depth = total - below - 0.5 * x;
                below += x;
                knots = cross_knots(knots, previous_altitude, previous_depth, altitude, depth);
                previous_altitude = altitude;
                previous_depth = depth;
            }
            t = interval.y;
        }
    }
    knots = cross_knots(knots, previous_altitude, previous_depth, top, 0.0);
    return vec4<f32>(exp(-total), top, knots.x, knots.y);
}

// The knots that lie between the points (altitude a, depth da) and (b, db) of a rising sun line.
// Rust: the `cross` closure of `shadow_column`.
fn cross_knots(knots: vec2<f32>, a: f32, da: f32, b: f32, db: f32) -> vec2<f32> {
    var result = knots;
    for (var j = 0u; j < 2u; j++) {
        let level = SHADOW_KNOT_DEPTHS[j];
        if da >= level && db < level {
            result[j] = a + (da - level) / (da - db) * (b - a);
        }
    }
    return result;
}

// ---------------------------------------------------------------------------------------------
// Reading the cloud shadow map (Rust: `ShadowMapImage` in reference/shadow.rs)
// ---------------------------------------------------------------------------------------------

// Rust: `ShadowMapImage::uv`.
fn shadow_map_uv(position_m: vec3<f32>) -> vec2<f32> {
    let q = position_m - clouds.shadow_map_centre_m.xyz;
    return vec2<f32>(0.5 * (1.0 - dot(q, clouds.shadow_map_axis_x.xyz)), 0.5 * (1.0 + dot(q, clouds.shadow_map_axis_y.xyz)));
}

// Whether a shadow map is bound and covers `uv`.
fn shadow_map_covers(uv: vec2<f32>) -> bool {
    return clouds.shadow_map != 0u && all(uv >= vec2<f32>(0.0)) && all(uv <= vec2<f32>(1.0));
}

// The filtered texel on the sun line through `position_m`. Rust: `ShadowMapImage::sample`.
fn sample_shadow_map(uv: vec2<f32>) -> vec4<f32> {
    return textureSampleLevel(cloud_shadow_map, noise_sampler, uv, 0.0);
}

// Optical depth toward the sun from the point at `altitude_m` on a sun line whose texel is
// `texel` (e^-tau, top, knot 1, knot 2): linear in altitude through (top, 0), (knot 1, min(1, tau)),
// (knot 2, min(4, tau)), (bottom, tau). Rust: `ShadowMapFrame::column_optical_depth`.
fn column_optical_depth(texel: vec4<f32>, altitude_m: f32) -> f32 {
    let total = -log(clamp(texel.x, 1e-7, 1.0));
    let z = vec4<f32>(texel.y, texel.z, texel.w, clouds.shadow_map_range_m.x);
    let tau = vec4<f32>(0.0, min(SHADOW_KNOT_DEPTHS[0], total), min(SHADOW_KNOT_DEPTHS[1], total), total);
    if !(altitude_m < z.x) {
        return 0.0;
    }
    for (var i = 0u; i < 3u; i++) {
        if altitude_m >= z[i + 1u] {
            var f = 1.0;
            if z[i] > z[i + 1u] {
                f = (z[i] - altitude_m) / (z[i] - z[i + 1u]);
            }
            return tau[i] + f * (tau[i + 1u] - tau[i]);
        }
    }
    return total;
}

// The sun's optical depth at `altitude_m` on the sun line at map coordinates `uv`: the four
// nearest texels decoded, then blended bilinearly (wrapping like the CPU twin).
// Rust: `ShadowMapImage::sun_optical_depth`.
fn map_sun_optical_depth(uv: vec2<f32>, altitude_m: f32) -> f32 {
    let size = vec2<i32>(textureDimensions(cloud_shadow_map));
    let p = uv * vec2<f32>(size) - 0.5;
    let base = floor(p);
    let f = p - base;
    let i0 = vec2<i32>(base);
    var sum = 0.0;
    for (var k = 0u; k < 4u; k++) {
        let offset = vec2<i32>(i32(k & 1u), i32(k >> 1u));
        let texel = wrap_texel(i0 + offset, size);
        let w = select(1.0 - f.x, f.x, offset.x == 1) * select(1.0 - f.y, f.y, offset.y == 1);
        sum += w * column_optical_depth(textureLoad(cloud_shadow_map, texel, 0), altitude_m);
    }
    return sum;
}
