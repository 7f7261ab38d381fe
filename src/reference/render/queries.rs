//! The CPU queries a game asks ("is the camera in a cloud?"), and the closed form of the march
//! through a homogeneous slab that the march is tested against. CPU only: no WGSL twin.

use super::{
    CloudTextures, MarchLayer, MarchResult, MarchSettings, altitude_of, dot, dual_lobe_phase,
    higher_layers_optical_depth, horizontal_axes, layer_is_active, mean_step_transmittance,
    point_mu_sun, scattering_albedo, sun_optical_depth, total_extinction,
};

/// Cloud extinction coefficient, 1/m, at `position_m` (world-space metres relative to the
/// camera; `[0, 0, 0]` is the camera), summed over the layers, at full detail and the finest mip.
/// Greater than 0 exactly where the GPU draws cloud. For "is the camera in a cloud?" see
/// [`is_in_cloud`].
pub fn density_at(
    textures: &CloudTextures,
    settings: &MarchSettings,
    layers: &[MarchLayer],
    position_m: [f64; 3],
) -> f64 {
    let altitude = altitude_of(settings, position_m);
    let axes = horizontal_axes(settings.camera_up);
    let horizontal = [dot(position_m, axes[0]), dot(position_m, axes[1])];
    total_extinction(textures, layers, horizontal, altitude, 0.0, true)
}

/// Whether `position_m` (relative to the camera) is inside cloud: [`density_at`] > 0.
pub fn is_in_cloud(
    textures: &CloudTextures,
    settings: &MarchSettings,
    layers: &[MarchLayer],
    position_m: [f64; 3],
) -> bool {
    density_at(textures, settings, layers, position_m) > 0.0
}

/// Fraction of direct sunlight reaching `position_m` (relative to the camera) through the
/// clouds, 0–1: `e^(−τ)` of the light march ([`sun_optical_depth`]) of the layers that hold the
/// point and of the layers wholly above them ([`higher_layers_optical_depth`]), 0 in the
/// planet's shadow, 1 outside every layer: the direct beam, without the light scattered toward
/// it.
pub fn transmittance_to_sun(
    textures: &CloudTextures,
    settings: &MarchSettings,
    layers: &[MarchLayer],
    position_m: [f64; 3],
) -> f64 {
    let altitude = altitude_of(settings, position_m);
    let optical_depth = sun_optical_depth(
        textures,
        settings,
        layers,
        settings.camera_altitude_m,
        settings.camera_up,
        position_m,
        altitude,
        0.0,
        f64::INFINITY,
        settings.light_steps,
        0.5,
        0.5,
    );
    if optical_depth < 0.0 {
        return 0.0;
    }
    // Inside a layer's shell, the layers wholly above it shade it too.
    let inside = layers
        .iter()
        .any(|layer| layer_is_active(layer) && altitude >= layer.base_m && altitude <= layer.top_m);
    let above = if inside {
        let mu_sun = point_mu_sun(
            settings,
            settings.camera_altitude_m,
            settings.camera_up,
            position_m,
            altitude,
        );
        higher_layers_optical_depth(
            textures,
            settings,
            layers,
            settings.camera_up,
            position_m,
            altitude,
            mu_sun,
            0.0,
            settings.light_steps,
        )
    } else {
        0.0
    };
    (-(optical_depth + above)).exp()
}

/// Closed form of the march for a homogeneous slab: `layer` with coverage 1, shape strength 0
/// and a flat profile of 1 (constant extinction `σ` from base to top), seen from a camera below
/// it looking straight up along [`MarchSettings::camera_up`], lit by the sun and the ambient sky,
/// with [`MarchSettings::multiple_scattering`] off (whose value it ignores).
///
/// With `u` the height above the base, `H` the thickness, `μs = dot(sun, up) > 0`, `σs = albedo
/// · σ`, and the light march reaching the top along the sun (`(H − u) / μs` in the plane-parallel
/// limit): `T = e^(−σH)` and
/// `L = p E σs ∫₀^H e^(−σu) e^(−σ (H − u) / μs) du + σs ∫₀^H e^(−σu) A(u) du` with
/// `A` linear from the bottom to the top ambient. With `k = 1 / μs` the first integral is
/// `e^(−σH) H f(σH (k − 1))` for `k ≥ 1` and `e^(−kσH) H f(σH (1 − k))` otherwise, and the second
/// is `albedo (A_b (1 − e^(−σH)) + (A_t − A_b)(f(σH) − e^(−σH)))`, `f` being
/// [`mean_step_transmittance`] and the last difference a series for small `σH`: stable for
/// `σ → 0` and huge `σ`.
///
/// Exact on the curved planet for a sun at the zenith (the light ray is radial); for a lower sun
/// the curvature of the top sphere over the light path changes `τ` by about `(H tan θs)² / 2R`
/// metres, negligible for kilometre-thick slabs. Returns [`MarchResult::CLEAR`] for an inactive
/// layer and no sun term when the sun is at or below the horizon.
pub fn homogeneous_slab(settings: &MarchSettings, layer: &MarchLayer) -> MarchResult {
    if !layer_is_active(layer) {
        return MarchResult::CLEAR;
    }
    let sigma = layer.extinction;
    let thickness = layer.top_m - layer.base_m;
    let x = sigma * thickness;
    let albedo = scattering_albedo(layer);
    let transmittance = (-x).exp();
    let mu_sun = dot(settings.sun_direction, settings.camera_up).clamp(-1.0, 1.0);
    let f = mean_step_transmittance;
    // p ∫ e^(−σu) e^(−σ(H−u)/μs) du, times σ.
    let mut sun = 0.0;
    if mu_sun > 0.0 {
        let phase = dual_lobe_phase(
            mu_sun,
            settings.phase_g_forward,
            settings.phase_g_back,
            settings.phase_blend,
        );
        let k = 1.0 / mu_sun;
        let integral = if k >= 1.0 {
            transmittance * x * f(x * (k - 1.0))
        } else {
            (-k * x).exp() * x * f(x * (1.0 - k))
        };
        sun = phase * integral;
    }
    let ambient_shape = ambient_gradient_integral(x);
    let opacity = -(-x).exp_m1();
    let radiance = std::array::from_fn(|c| {
        let (bottom, top) = (settings.ambient_bottom[c], settings.ambient_top[c]);
        albedo
            * (settings.sun_illuminance[c] * sun
                + bottom * opacity
                + (top - bottom) * ambient_shape)
    });
    // The opacity-weighted mean depth into the slab, `H (1/x − 1/(eˣ − 1))`, a series for small x.
    let depth = if x < 1e-3 {
        thickness * (0.5 - x / 12.0)
    } else {
        thickness * (1.0 / x - 1.0 / x.exp_m1())
    };
    MarchResult {
        radiance,
        transmittance,
        distance_m: layer.base_m - settings.camera_altitude_m.min(layer.base_m) + depth,
    }
}

/// `f(x) − e^(−x)` with `f` = [`mean_step_transmittance`]: the ambient-gradient term of
/// [`homogeneous_slab`], `∫₀¹ x s e^(−x s) ds`. Both terms tend to 1 as `x → 0`, so small `x` uses
/// the series `Σₙ (−1)ⁿ⁺¹ n xⁿ / (n + 1)!` (`x/2 − x²/3 + x³/8 − …`).
pub(super) fn ambient_gradient_integral(x: f64) -> f64 {
    if x < 0.1 {
        let mut term = 1.0;
        let mut sum = 0.0;
        for n in 1..=10_i32 {
            // term = (−x)ⁿ / (n + 1)!
            term *= -x / f64::from(n + 1);
            sum -= f64::from(n) * term;
        }
        sum
    } else {
        mean_step_transmittance(x) - (-x).exp()
    }
}
