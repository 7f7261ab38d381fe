//! Geometry in f64: the cloud layers' shells on a curved planet and the intervals a ray marches
//! through them, and the small vector helpers of the march. WGSL twin:
//! `src/render/march/geometry.wgsl` (`intersect_altitude_sphere` and `ground_distance` are in
//! `src/render/composite/composite.wgsl`, which the upsample shares).
//!
//! The planet is a sphere of radius [`MarchSettings::planet_radius_m`] and every cloud layer a
//! spherical shell around its centre, between [`MarchLayer::base_m`] and [`MarchLayer::top_m`]
//! above the ground (Pérez Martín 2022, "Atmosphere": concentric spheres, and a ground sphere that stops
//! the ray). All positions are **relative to the camera** and every distance along a ray is
//! computed from the camera altitude `h` and `mu = dot(direction, up)`, never from absolute
//! positions near the planet centre: in f32 a radius of 6 371 km resolves only half a metre, and a
//! difference of two squared radii loses as much, which is what decides whether a camera sits on
//! a layer boundary or a grazing ray touches a shell.
//!
//! - [`intersect_altitude_sphere`]: the distances along a ray to the sphere at an altitude, from
//!   the discriminant written as `(alt − h)(2R + alt + h) + (R + h)² mu²` (no difference of two
//!   squared radii) and the stable quadratic (`q = −(b + sign(b)·√disc)`, roots `q` and `c / q`).
//! - [`altitude_along_ray`]: `alt = h + s / (A + √(A² + s))` with `A = R + h` and
//!   `s = 2 A mu t + t²`, the altitude at distance `t` without cancelling two planet radii.
//! - [`shell_segments`] clips a ray to one shell (up to two pieces: through the shell, below its
//!   base, and back up), [`ground_distance`] stops it at the ground, and
//!   [`next_cloud_interval`] merges the pieces of every layer, so the march visits only the
//!   intervals where some layer is, in order, whatever the camera altitude.

use super::{MAX_FAR_COVERAGES, MarchLayer, MarchSettings};

/// Returned by [`intersect_altitude_sphere`] for both distances when the ray misses the sphere.
/// Negative, so callers that keep only `t ≥ 0` treat a miss like a sphere behind the camera.
pub const NO_HIT: f64 = -1.0;

/// Where the blend toward a far place's coverage starts, as a fraction of the way from the near
/// place to the far one: the near forecast holds unchanged over the first 30 % (the foreground),
/// and the far forecast is complete at the far place and beyond ([`layer_coverage`]). WGSL twin:
/// `FAR_BLEND_START`.
pub const FAR_BLEND_START: f64 = 0.3;

// ---------------------------------------------------------------------------------------------
// Small vector helpers (plain arrays: this module does not depend on Bevy)
// ---------------------------------------------------------------------------------------------

pub(in crate::reference) fn dot(a: [f64; 3], b: [f64; 3]) -> f64 {
    a[0] * b[0] + a[1] * b[1] + a[2] * b[2]
}

pub(in crate::reference) fn cross(a: [f64; 3], b: [f64; 3]) -> [f64; 3] {
    [
        a[1] * b[2] - a[2] * b[1],
        a[2] * b[0] - a[0] * b[2],
        a[0] * b[1] - a[1] * b[0],
    ]
}

pub(in crate::reference) fn scale(a: [f64; 3], s: f64) -> [f64; 3] {
    a.map(|c| c * s)
}

pub(in crate::reference) fn add(a: [f64; 3], b: [f64; 3]) -> [f64; 3] {
    [a[0] + b[0], a[1] + b[1], a[2] + b[2]]
}

pub(in crate::reference) fn normalize(a: [f64; 3]) -> [f64; 3] {
    let length = dot(a, a).sqrt();
    if length > 0.0 {
        scale(a, 1.0 / length)
    } else {
        a
    }
}

pub(super) fn lerp(a: f64, b: f64, t: f64) -> f64 {
    a + (b - a) * t
}

pub(super) fn saturate(x: f64) -> f64 {
    x.clamp(0.0, 1.0)
}

/// `x > 0`, false for NaN: `!is_positive(x)` rejects zero, negative and NaN alike.
pub(in crate::reference) fn is_positive(x: f64) -> bool {
    x > 0.0
}

// ---------------------------------------------------------------------------------------------
// Geometry
// ---------------------------------------------------------------------------------------------

/// Distances `[near, far]` (sorted) along a ray to the sphere at `sphere_altitude_m` above the
/// ground, for a camera at `camera_altitude_m` whose ray makes `mu = dot(direction, up)` with the
/// local vertical; `[NO_HIT, NO_HIT]` when the ray misses. Negative distances are behind the
/// camera.
///
/// With `A = R + h` the ray is `|A·up + t·d|² = (R + alt)²`, i.e. `t² + 2bt + c = 0` with
/// `b = A mu` and `c = (h − alt)(2R + h + alt)`: a product of the small altitude difference, so
/// a camera on or near the sphere keeps its precision. The discriminant
/// `(alt − h)(2R + alt + h) + A² mu²` and the stable quadratic `q = −(b + sign(b)·√disc)`, roots
/// `q` and `c / q`, avoid subtracting nearly equal numbers (Pérez Martín 2022, "Atmosphere", done in
/// camera-relative form). A tangent ray (`disc = 0`) returns a double root; `q = 0` happens only
/// for a tangent ray from a camera on the sphere, whose double root is 0. WGSL twin:
/// `intersect_altitude_sphere`.
pub fn intersect_altitude_sphere(
    camera_altitude_m: f64,
    mu: f64,
    planet_radius_m: f64,
    sphere_altitude_m: f64,
) -> [f64; 2] {
    let h = camera_altitude_m;
    let a = planet_radius_m + h;
    let b = a * mu;
    let c = (h - sphere_altitude_m) * (2.0 * planet_radius_m + h + sphere_altitude_m);
    let discriminant =
        (sphere_altitude_m - h) * (2.0 * planet_radius_m + sphere_altitude_m + h) + b * b;
    if discriminant.is_nan() || discriminant < 0.0 {
        return [NO_HIT, NO_HIT];
    }
    let sign = if b >= 0.0 { 1.0 } else { -1.0 };
    let q = -(b + sign * discriminant.sqrt());
    if q == 0.0 {
        return [0.0, 0.0];
    }
    let (t0, t1) = (q, c / q);
    [t0.min(t1), t0.max(t1)]
}

/// Altitude above the ground, metres, of the point at distance `distance_m` along a ray from a
/// camera at `camera_altitude_m` with `mu = dot(direction, up)`.
///
/// `|A·up + t·d| − R` written as `h + s / (A + √(A² + s))` with `A = R + h`, `s = 2 A mu t + t²`:
/// the difference of two radii of 6 371 km becomes a quotient of small numbers, so the altitude
/// keeps its precision in f32. WGSL twin: `altitude_along_ray`.
pub fn altitude_along_ray(
    camera_altitude_m: f64,
    mu: f64,
    distance_m: f64,
    planet_radius_m: f64,
) -> f64 {
    let a = planet_radius_m + camera_altitude_m;
    let s = 2.0 * a * mu * distance_m + distance_m * distance_m;
    camera_altitude_m + s / (a + (a * a + s).max(0.0).sqrt())
}

/// Distance along the ray to the ground sphere, or infinity where the ray does not go into the
/// ground ahead. A tangent ray grazes without being stopped; a camera on the ground looking down
/// is stopped at once; a camera below the ground sphere (negative altitude) is not stopped.
/// WGSL twin: `ground_distance` (which returns its `FAR_AWAY`, 3e38, for infinity).
pub fn ground_distance(camera_altitude_m: f64, mu: f64, planet_radius_m: f64) -> f64 {
    let [t0, t1] = intersect_altitude_sphere(camera_altitude_m, mu, planet_radius_m, 0.0);
    if t0 >= 0.0 && t1 > t0 {
        t0
    } else {
        f64::INFINITY
    }
}

/// The parts of a ray inside the shell `[base_m, top_m]`: two segments `[start, end]` of
/// distance (an empty one has `end <= start`), not clipped to the ground or the scene.
///
/// Inside the outer sphere `[o0, o1]` and outside the inner sphere: before its near root or
/// after its far root. A miss is `NO_HIT` for both roots, which makes the formulas give the
/// right answer without a branch. WGSL twin: `shell_segments` (a `vec4`: first segment in `xy`).
pub fn shell_segments(
    camera_altitude_m: f64,
    mu: f64,
    planet_radius_m: f64,
    base_m: f64,
    top_m: f64,
) -> [[f64; 2]; 2] {
    let outer = intersect_altitude_sphere(camera_altitude_m, mu, planet_radius_m, top_m);
    let inner = intersect_altitude_sphere(camera_altitude_m, mu, planet_radius_m, base_m);
    let near_start = outer[0].max(0.0);
    [
        [near_start, inner[0].min(outer[1])],
        [inner[1].max(near_start), outer[1]],
    ]
}

/// Largest coverage of a layer anywhere: its own or a far one. WGSL twin: `max_coverage`.
pub fn max_coverage(layer: &MarchLayer) -> f64 {
    let count = (layer.far_count as usize).min(MAX_FAR_COVERAGES);
    layer.far[..count]
        .iter()
        .map(|far| far[3])
        .fold(layer.coverage, f64::max)
}

/// Coverage of a layer at `horizontal_m` (relative to the camera, along the noise axes): its
/// own, blended toward each far entry by a smoothstep of the fraction of the way to the far
/// place, from [`FAR_BLEND_START`] to 1 (see [`crate::layers::FarCoverage`]), clamped to 0–1.
/// WGSL twin: `layer_coverage`.
pub fn layer_coverage(layer: &MarchLayer, horizontal_m: [f64; 2]) -> f64 {
    let count = (layer.far_count as usize).min(MAX_FAR_COVERAGES);
    let mut coverage = layer.coverage;
    for far in &layer.far[..count] {
        let s = horizontal_m[0] * far[0] + horizontal_m[1] * far[1] + far[2];
        let t = saturate((s - FAR_BLEND_START) / (1.0 - FAR_BLEND_START));
        coverage += t * t * (3.0 - 2.0 * t) * (far[3] - layer.coverage);
    }
    saturate(coverage)
}

/// Whether a layer can hold any cloud: positive coverage somewhere ([`max_coverage`]) and
/// extinction and a positive, finite thickness. Inactive layers are skipped everywhere and cost
/// nothing. WGSL twin: `layer_is_active`.
pub fn layer_is_active(layer: &MarchLayer) -> bool {
    max_coverage(layer) > 0.0
        && layer.extinction > 0.0
        && layer.top_m > layer.base_m
        && (layer.top_m - layer.base_m).is_finite()
}

/// The next interval `[start, end]` of distance at or after `t_from` where the ray is inside at
/// least one active layer, clipped to `t_max`: the union of every layer's [`shell_segments`],
/// overlapping and touching pieces merged, so overlapping layers are marched once.
/// `start >= end` when nothing is left. WGSL twin: `next_cloud_interval`.
pub fn next_cloud_interval(
    layers: &[MarchLayer],
    planet_radius_m: f64,
    camera_altitude_m: f64,
    mu: f64,
    t_from: f64,
    t_max: f64,
) -> [f64; 2] {
    let segments = || {
        layers
            .iter()
            .filter(|layer| layer_is_active(layer))
            .flat_map(|layer| {
                shell_segments(
                    camera_altitude_m,
                    mu,
                    planet_radius_m,
                    layer.base_m,
                    layer.top_m,
                )
            })
            .filter(|s| s[1] > s[0] && s[1] > t_from)
    };
    let start = segments()
        .map(|s| s[0].max(t_from))
        .fold(f64::INFINITY, f64::min);
    if !is_positive(t_max - start) {
        return [t_max, t_max];
    }
    // Grow the end over every piece that starts inside the interval; each pass adds at least one
    // piece, so 2 · layers + 1 passes are enough.
    let mut end = start;
    for _ in 0..=2 * layers.len() {
        let mut grown = false;
        for s in segments() {
            if s[0] <= end && s[1] > end {
                end = s[1];
                grown = true;
            }
        }
        if !grown {
            break;
        }
    }
    [start, end.min(t_max)]
}

/// The horizontal axes of the noise, `[x, z]`, orthonormal and perpendicular to `up`: with up
/// = +y they are world +x and +z, so noise offsets are world x/z offsets. `x` is `up × ẑ`
/// normalised (`up × x̂` when up is along z). WGSL twin: `horizontal_axes`.
pub fn horizontal_axes(up: [f64; 3]) -> [[f64; 3]; 2] {
    let mut x = cross(up, [0.0, 0.0, 1.0]);
    if dot(x, x) < 1e-6 {
        x = cross(up, [1.0, 0.0, 0.0]);
    }
    let x = normalize(x);
    [x, cross(x, up)]
}

/// Steps of an interval grow with distance: boundary `k` of `n` lies at
/// `start + (end − start) · step_warp(k / n, β)` with `β = g (end − start) / (1 + g · start)`,
/// which makes each step `1 + g·t` times the length it would have at the camera (a geometric
/// sequence). `step_warp(u, β) = ((1 + β)^u − 1) / β = expm1(u · ln1p(β)) / β`, written so it
/// stays accurate for small `β` and equals `u` at `β = 0`. WGSL twin: `step_warp` (which takes
/// `β ≤ 1e-6` as 0, an error below 1.3e-7 of the interval, and has its own f32 `expm1`/`log1p`).
pub fn step_warp(u: f64, beta: f64) -> f64 {
    if beta <= 1e-12 {
        return u;
    }
    (u * beta.ln_1p()).exp_m1() / beta
}

/// Altitude above the ground of `position_m`, a point relative to the camera.
pub(in crate::reference) fn altitude_of(settings: &MarchSettings, position_m: [f64; 3]) -> f64 {
    let distance = dot(position_m, position_m).sqrt();
    if distance == 0.0 {
        return settings.camera_altitude_m;
    }
    let mu = (dot(position_m, settings.camera_up) / distance).clamp(-1.0, 1.0);
    altitude_along_ray(
        settings.camera_altitude_m,
        mu,
        distance,
        settings.planet_radius_m,
    )
}
