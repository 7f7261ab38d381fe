//! Light in f64 (Hillaire 2016; Wrenninge 2013; Pérez Martín 2022, "Cloud Lighting"). WGSL twin:
//! `src/render/march/light.wgsl`.
//!
//! At each sample the source term is `σs (E_sun · Σᵢ bⁱ e^(−aⁱ τ) p(cⁱ g) + L_ambient(height))`:
//! `τ` is the optical depth toward the sun from a short light march to the exit of the layer
//! shell ([`sun_optical_depth`]), the sum over octaves is Wrenninge 2013's multiple-scattering
//! approximation ([`multiple_scattering`], Pérez Martín 2022 "Multiple Scattering Approximation":
//! a = 0.3, b = 0.75, c = 0.5, N = 4), `p` the dual-lobe Henyey-Greenstein phase
//! ([`dual_lobe_phase`], Hillaire 2016) and the ambient sky radiance is interpolated between the
//! bottom and top of the layer (Pérez Martín 2022, "Day / Night Cycle"). Each step integrates the source
//! against the transmittance across the step analytically (Hillaire 2016, "Physically Based Sky,
//! Atmosphere and Cloud Rendering in Frostbite"): `∫₀^dt e^(−σt x) S dx =
//! S dt (1 − e^(−σt dt)) / (σt dt)`, with the last factor from [`mean_step_transmittance`], which
//! stays exact as `σt → 0` instead of clamping `σt`.

use super::{
    CloudTextures, MarchLayer, MarchSettings, add, altitude_along_ray, dot, ground_distance,
    horizontal_axes, intersect_altitude_sphere, layer_is_active, saturate, scale, total_extinction,
};

/// Most multiple-scattering octaves evaluated; larger [`MarchSettings::octaves`] are clamped.
pub const MAX_SCATTERING_OCTAVES: u32 = 8;

/// Most light-march steps; larger [`MarchSettings::light_steps`] are clamped.
pub const MAX_LIGHT_STEPS: u32 = 64;

/// Below this optical thickness [`mean_step_transmittance`] uses its Taylor series. The WGSL twin
/// uses 0.1 with five terms (f32: `1 − e^(−x)` loses digits as `x → 0`); here `expm1` is exact
/// and the series only avoids `0 / 0`.
pub const SERIES_LIMIT: f64 = 1e-5;

/// The WGSL twin's `SERIES_LIMIT`: in f32, without `expm1`, the series takes over at a larger
/// optical thickness (five terms keep it exact to f32 there).
pub const WGSL_SERIES_LIMIT: f64 = 0.1;

/// Largest Henyey-Greenstein asymmetry magnitude used: at |g| = 1 the lobe is a Dirac peak and
/// its denominator vanishes.
pub const MAX_PHASE_G: f64 = 0.999;

/// Henyey-Greenstein phase function, 1/sr: `(1 − g²) / (4π (1 + g² − 2g cos θ)^1.5)`, `g`
/// clamped to `±MAX_PHASE_G` so the peak stays finite. WGSL twin: `henyey_greenstein`.
pub fn henyey_greenstein(cos_theta: f64, g: f64) -> f64 {
    let g = g.clamp(-MAX_PHASE_G, MAX_PHASE_G);
    let denominator = (1.0 + g * g - 2.0 * g * cos_theta).max(1e-12);
    (1.0 - g * g) / (4.0 * std::f64::consts::PI * denominator * denominator.sqrt())
}

/// Dual-lobe phase (Hillaire 2016, after Schneider 2015's silver lining): a forward lobe
/// blended with a backward one, `(1 − blend) HG(g_forward) + blend HG(g_back)`, 1/sr. WGSL twin:
/// `dual_lobe_phase`.
pub fn dual_lobe_phase(cos_theta: f64, g_forward: f64, g_back: f64, blend: f64) -> f64 {
    let blend = saturate(blend);
    (1.0 - blend) * henyey_greenstein(cos_theta, g_forward)
        + blend * henyey_greenstein(cos_theta, g_back)
}

/// Wrenninge 2013 ("Oz: the great and volumetric") multiple-scattering approximation, 1/sr:
/// `Σᵢ bⁱ e^(−aⁱ τ) p(cⁱ g)` over [`MarchSettings::octaves`] octaves, the sun transmittance
/// through optical depth `optical_depth` weighted by the dual-lobe phase at `cos_theta` (seed
/// 002, "Multiple Scattering Approximation", Figure 45). Each octave lets more light through
/// (a < 1) with a flatter phase (c < 1), standing in for light scattered more than once. Octave 0
/// is single scattering. WGSL twin: `multiple_scattering`.
pub fn multiple_scattering(settings: &MarchSettings, optical_depth: f64, cos_theta: f64) -> f64 {
    let octaves = settings.octaves.clamp(1, MAX_SCATTERING_OCTAVES);
    let (mut a, mut b, mut c) = (1.0, 1.0, 1.0);
    let mut sum = 0.0;
    for _ in 0..octaves {
        let phase = dual_lobe_phase(
            cos_theta,
            c * settings.phase_g_forward,
            c * settings.phase_g_back,
            settings.phase_blend,
        );
        sum += b * (-a * optical_depth).exp() * phase;
        a *= settings.ms_attenuation;
        b *= settings.ms_contribution;
        c *= settings.ms_eccentricity;
    }
    sum
}

/// Length of the light march from a point at `altitude_m` toward a sun at `mu_sun = dot(sun,
/// local up)`: the distance to where the ray leaves the shell of every active layer that holds
/// the point (through the top, or through the base when the sun is low), the longest of them.
/// Negative when the ground blocks the sun (the point is in the planet's shadow). 0 outside
/// every layer. WGSL twin: `light_march_distance`.
pub fn light_march_distance(
    layers: &[MarchLayer],
    planet_radius_m: f64,
    altitude_m: f64,
    mu_sun: f64,
) -> f64 {
    if ground_distance(altitude_m, mu_sun, planet_radius_m).is_finite() {
        return -1.0;
    }
    let mut distance: f64 = 0.0;
    for layer in layers.iter().filter(|layer| layer_is_active(layer)) {
        if !(altitude_m >= layer.base_m && altitude_m <= layer.top_m) {
            continue;
        }
        let outer = intersect_altitude_sphere(altitude_m, mu_sun, planet_radius_m, layer.top_m);
        let inner = intersect_altitude_sphere(altitude_m, mu_sun, planet_radius_m, layer.base_m);
        let through_base = if inner[0] >= 0.0 {
            inner[0]
        } else {
            f64::INFINITY
        };
        distance = distance.max(outer[1].max(0.0).min(through_base));
    }
    distance
}

/// The cosine of the sun's zenith angle at `position_m` (relative to a camera at
/// `camera_altitude_m` with local vertical `up`), whose altitude is `altitude_m`: the local up
/// there is `(A·up + p) / (R + alt)`. WGSL twin: `point_mu_sun`.
pub(in crate::reference) fn point_mu_sun(
    settings: &MarchSettings,
    camera_altitude_m: f64,
    up: [f64; 3],
    position_m: [f64; 3],
    altitude_m: f64,
) -> f64 {
    let radius = settings.planet_radius_m;
    let sun = settings.sun_direction;
    (((radius + camera_altitude_m) * dot(sun, up) + dot(sun, position_m)) / (radius + altitude_m))
        .clamp(-1.0, 1.0)
}

/// How far, in shadow-map texels, a far sample's own light march goes before the cloud shadow
/// map takes over ([`MarchSettings::sun_from_shadow_map_m`]): the map's texels blur a cloud's
/// edge, and the sample's light depends most on the cloud right next to it. WGSL twin:
/// `SHADOW_MAP_NEAR_TEXELS`.
pub const SHADOW_MAP_NEAR_TEXELS: f64 = 4.0;

/// Most light-march steps over those first texels (fewer than a full light march: the saving).
/// WGSL twin: `SHADOW_MAP_NEAR_STEPS`.
pub const SHADOW_MAP_NEAR_STEPS: u32 = 2;

/// Optical depth toward the sun from the point `position_m` (relative to a camera at
/// `camera_altitude_m` with local vertical `up`) at `altitude_m`, by a light march of
/// `steps` steps (at most [`MAX_LIGHT_STEPS`]; the march uses [`MarchSettings::light_steps`])
/// over [`light_march_distance`], or over the first `max_distance_m` metres of it; negative when
/// the ground blocks the sun.
///
/// Step boundaries lie at `D (k / n)²`: short steps near the point, where the self-shadowing
/// detail is, long ones far away. Each step samples the point `offset` (0–1) of the way through
/// it; the march uses [`LIGHT_SAMPLE_OFFSET`], the midpoints, whatever the view ray's jitter. A
/// homogeneous layer is integrated exactly whatever the offset. Altitudes along the light ray come from [`altitude_along_ray`] relative to
/// the point. The footprint of a light sample is at least its step length, so long steps read
/// coarse mips. Only the shells that hold the point are marched; shadows cast by a separate
/// higher layer are left to the cloud shadow map. WGSL twin: `sun_optical_depth`.
pub fn sun_optical_depth(
    textures: &CloudTextures,
    settings: &MarchSettings,
    layers: &[MarchLayer],
    camera_altitude_m: f64,
    up: [f64; 3],
    position_m: [f64; 3],
    altitude_m: f64,
    footprint_m: f64,
    max_distance_m: f64,
    steps: u32,
    offset: f64,
) -> f64 {
    let radius = settings.planet_radius_m;
    let sun = settings.sun_direction;
    let mu_sun = point_mu_sun(settings, camera_altitude_m, up, position_m, altitude_m);
    let distance = light_march_distance(layers, radius, altitude_m, mu_sun);
    if distance < 0.0 {
        return -1.0;
    }
    let distance = distance.min(max_distance_m);
    let steps = light_step_count(
        steps,
        distance,
        footprint_m,
        settings.light_steps_per_footprint,
    );
    if steps == 0 || distance == 0.0 {
        return 0.0;
    }
    let axes = horizontal_axes(up);
    let n = f64::from(steps);
    let mut optical_depth = 0.0;
    for k in 0..steps {
        let s0 = distance * (f64::from(k) / n).powi(2);
        let s1 = distance * (f64::from(k + 1) / n).powi(2);
        let ds = s1 - s0;
        let s = s0 + offset * ds;
        let point = add(position_m, scale(sun, s));
        let altitude = altitude_along_ray(altitude_m, mu_sun, s, radius);
        let horizontal = [dot(point, axes[0]), dot(point, axes[1])];
        let extinction = total_extinction(
            textures,
            layers,
            horizontal,
            altitude,
            footprint_m.max(ds),
            true,
        );
        optical_depth += extinction * ds;
    }
    optical_depth
}

/// Where each light-march step is sampled, as a fraction of the step: its midpoint, every
/// frame. The view samples are jittered ([`ray_start_jitter`]) and the temporal accumulation
/// averages them, but averaging the light march over offsets averages `e^(−τ)`, not `τ`: where
/// the optical depth toward the sun changes with the offset, the mean of the transmittances is
/// brighter than the transmittance of the mean (Jensen's inequality), a bias that shows most
/// under a low sun. WGSL twin: `LIGHT_SAMPLE_OFFSET`.
pub const LIGHT_SAMPLE_OFFSET: f64 = 0.5;

/// Light path over which a light march takes its [`MarchSettings::light_steps`], metres: a
/// longer path (a low sun's, kilometres through the layer) takes proportionally more steps, up
/// to [`MAX_LIGHT_STEPS`], so its far steps stay short against the clouds they cross.
/// Half the default shape-noise period: a 4° sun's path through a 1 km layer (14 km) takes 7
/// times the steps. WGSL twin: `LIGHT_STEP_SPAN_M`.
pub const LIGHT_STEP_SPAN_M: f64 = 2_000.0;

/// Steps of a light march `distance_m` long from a sample whose footprint is `footprint_m`:
/// `steps` over [`LIGHT_STEP_SPAN_M`] or less, and in proportion beyond (rounded), but those
/// extra steps no more than `per_footprint` per footprint
/// ([`MarchSettings::light_steps_per_footprint`]; not a positive number, or a footprint of 0:
/// no limit); at most [`MAX_LIGHT_STEPS`]. WGSL twin: `light_step_count` (which takes
/// `per_footprint` from its uniforms, as f32).
pub fn light_step_count(steps: u32, distance_m: f64, footprint_m: f64, per_footprint: f64) -> u32 {
    let mut scaled = (f64::from(steps) * distance_m / LIGHT_STEP_SPAN_M + 0.5).floor();
    if per_footprint > 0.0 && per_footprint.is_finite() && footprint_m > 0.0 {
        scaled = scaled.min((per_footprint * distance_m / footprint_m).floor());
    }
    // NaN (and negatives) add no steps.
    let scaled = if scaled >= 0.0 {
        scaled.min(f64::from(MAX_LIGHT_STEPS)) as u32
    } else {
        0
    };
    steps.max(scaled).min(MAX_LIGHT_STEPS)
}

/// Mean transmittance across a step of optical thickness `x = σt·dt`, `(1 − e^(−x)) / x =
/// −expm1(−x) / x`: the factor of Hillaire 2016's energy-conserving step integral
/// `S·dt·f(x)`. Exact as `x → 0` (series `1 − x/2 + x²/6`, no clamped division, no `0 / 0` at
/// `σt = 0`) and `1 / x` for large `x` (no overflow, finite at `x = ∞`: 0). WGSL twin:
/// `mean_step_transmittance` (series below 0.1 there, since f32 has no `expm1`).
pub fn mean_step_transmittance(x: f64) -> f64 {
    let x = x.max(0.0);
    if x < SERIES_LIMIT {
        1.0 - x * (0.5 - x / 6.0)
    } else {
        -(-x).exp_m1() / x
    }
}

/// Offset of the first sample within each step, 0–1: blue noise at `pixel`, animated per frame
/// ([`blue_noise_jitter`](crate::reference::blue_noise::blue_noise_jitter)), when
/// [`MarchSettings::jitter`] is on (against banding, Pérez Martín 2022 "Banding Reduction"), the step
/// midpoint 0.5 when off. WGSL twin: `ray_start_jitter`.
pub fn ray_start_jitter(settings: &MarchSettings, pixel: [f64; 2]) -> f64 {
    if settings.jitter {
        crate::reference::blue_noise::blue_noise_jitter(pixel, settings.frame_index)
    } else {
        0.5
    }
}
