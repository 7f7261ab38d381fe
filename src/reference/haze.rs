//! Haze and light shafts: the air between the camera and the clouds, lit by the sun through the
//! gaps in the clouds.
//!
//! # The medium
//!
//! Haze is the aerosol the forecast's visibility speaks of. Koschmieder's law gives the
//! extinction at the ground from the meteorological visibility `V` (a 2 % contrast threshold):
//! `σ = ln 50 / V = 3.912 / V` (Koschmieder 1924; WMO-No. 8). The clear air that Bevy's
//! atmosphere already draws accounts for [`CLEAR_AIR_EXTINCTION_PER_M`] of it, so the haze adds
//! the rest ([`haze_extinction_for_visibility`]). Its density falls off exponentially with
//! height above the ground (scale height `H`, about 1.2 km for the boundary-layer aerosol),
//! `σ(z) = σ₀ e^(−z/H)`, and stops at [`HAZE_TOP_SCALE_HEIGHTS`] scale heights, where it is
//! three ten-thousandths of its ground value.
//!
//! # Light
//!
//! A haze particle scatters a fraction `albedo` of what it intercepts, with a Henyey-Greenstein
//! phase of asymmetry `g` (continental aerosol: albedo about 0.9, `g` about 0.7). It is lit by
//!
//! - the sun, dimmed by the clouds above it: with light shafts on, the fraction read from the
//!   cloud shadow map (the transmittance along a sample's sun line through every layer;
//!   [`crate::reference::shadow`]), so shadowed air is dark and the air in a gap is bright: the
//!   crepuscular rays. The GPU does not read the map at every sample of every pixel: a pass at a
//!   reduced resolution reduces each ray to two [`ShaftFactors`] ([`shaft_factors`]), the mean
//!   sunlit fraction below the lowest cloud base and above it, and the march lights its samples
//!   with those ([`HazeSun::Shafts`]); [`HazeSun::PerSample`] is what they approximate. With
//!   shafts off, with no shadow map, and beyond the map's extent, one number for the whole
//!   view, [`mean_sun_transmittance`]: the clouds' average shade;
//! - the sky and the ground: the radiance of the sky above ([`HazeSettings::sky_radiance`]: the
//!   open sky's share of the clear sky, and the clouds' bases, lit by the sun and the sky
//!   through them) and the ground-reflected light below, times the fraction of diffuse light the
//!   clouds let through ([`mean_diffuse_transmittance`]), each by the share of the haze's phase
//!   function that brings light from it through the haze toward the camera;
//! - the haze itself: the rest of the phase brings light from directions along which the haze is
//!   opaque, the haze's own light, so each scattering passes on that share again
//!   ([`haze_light_shares`]). It brightens the air near the horizon most, where forward
//!   scattering brings light from along the nearly level directions the haze is opaque along.
//!   `validation/README.md` ("Haze against Mitsuba") compares it with a path-traced haze.
//!
//! # Integration
//!
//! [`march_haze`] marches the part of the view ray inside the haze (clipped to the scene and the
//! ground) in `steps` steps whose boundaries follow `t₁ (k/n)²`: short near the camera, where the
//! shafts are sharp, long far away, where the haze thins with height. Each step uses the same
//! energy-conserving integral as the clouds (Hillaire 2016), `T S dt (1 − e^(−x))/x`, and the
//! summed optical depth. The ray is split at the clouds' distance
//! ([`MarchResult::distance_m`](super::render::MarchResult::distance_m)) into the haze in front
//! of the clouds and behind them, and [`composite`] stacks the three media:
//! `L = L_front + T_front (L_clouds + T_clouds L_back)`, `T = T_front T_clouds T_back`. So haze
//! veils distant clouds (aerial perspective) and clouds hide the haze behind them.
//!
//! WGSL twin: `src/render/haze/haze.wgsl`.

use super::render::{
    MAX_PHASE_G, MarchResult, MarchSettings, altitude_along_ray, dot, ground_distance,
    henyey_greenstein, intersect_altitude_sphere, mean_step_transmittance, scale,
    sky_light_under_clouds,
};
use super::shadow::ShadowMapImage;

/// Koschmieder's constant, `ln 50`: extinction × visibility for a 2 % contrast threshold.
pub const KOSCHMIEDER_CONSTANT: f64 = 3.912;

/// Extinction of clean air near sea level at 550 nm, 1/m, that Bevy's atmosphere already draws:
/// [`CLEAR_AIR_RAYLEIGH_EXTINCTION_PER_M`] plus [`CLEAR_AIR_MIE_EXTINCTION_PER_M`]. A visibility
/// of 245 km or more adds no haze.
pub const CLEAR_AIR_EXTINCTION_PER_M: f64 =
    CLEAR_AIR_RAYLEIGH_EXTINCTION_PER_M + CLEAR_AIR_MIE_EXTINCTION_PER_M;

/// Rayleigh extinction of clean air at sea level and 550 nm, 1/m (Bucholtz 1995, "Rayleigh-
/// scattering calculations for the terrestrial atmosphere"). WGSL twin:
/// `CLEAR_AIR_RAYLEIGH_EXTINCTION_PER_M`.
pub const CLEAR_AIR_RAYLEIGH_EXTINCTION_PER_M: f64 = 1.16e-5;

/// Mie (aerosol) extinction of clean air at sea level, 1/m: the scattering plus absorption of
/// Bevy's default Earth atmosphere. WGSL twin: `CLEAR_AIR_MIE_EXTINCTION_PER_M`.
pub const CLEAR_AIR_MIE_EXTINCTION_PER_M: f64 = 4.4e-6;

/// Scale height of the air's Rayleigh extinction, m (Bevy's default Earth atmosphere). WGSL
/// twin: `RAYLEIGH_SCALE_HEIGHT_M`.
pub const RAYLEIGH_SCALE_HEIGHT_M: f64 = 8000.0;

/// Scale height of the clean air's Mie extinction, m (Bevy's default Earth atmosphere). WGSL
/// twin: `MIE_SCALE_HEIGHT_M`.
pub const MIE_SCALE_HEIGHT_M: f64 = 1200.0;

/// Extinction of clean air at `altitude_m` above the ground (below it: the ground's), 1/m at
/// 550 nm: the Rayleigh and Mie parts, each falling off exponentially with its scale height.
/// WGSL twin: `clear_air_extinction`.
pub fn clear_air_extinction(altitude_m: f64) -> f64 {
    let z = altitude_m.max(0.0);
    CLEAR_AIR_RAYLEIGH_EXTINCTION_PER_M * (-z / RAYLEIGH_SCALE_HEIGHT_M).exp()
        + CLEAR_AIR_MIE_EXTINCTION_PER_M * (-z / MIE_SCALE_HEIGHT_M).exp()
}

/// The haze stops this many scale heights above the ground (`e^(−8)`: 0.03 % of its ground
/// density).
pub const HAZE_TOP_SCALE_HEIGHTS: f64 = 8.0;

/// Most steps of [`march_haze`] and [`shaft_factors`]. WGSL twin: `MAX_HAZE_STEPS`.
pub const MAX_HAZE_STEPS: u32 = 128;

/// [`HazeSettings::shaft_steps`] per [`HazeSettings::steps`] in the views of the plugin: the
/// shaft pass runs on a sixteenth of the pixels (at the default quarter resolution), so four
/// times the samples still cost a quarter of reading the map at every march sample.
pub const SHAFT_STEPS_PER_HAZE_STEP: u32 = 4;

/// Haze extinction at the ground, 1/m, for a meteorological visibility of `visibility_m`
/// metres: `3.912 / V` less the clear air's [`CLEAR_AIR_EXTINCTION_PER_M`], never negative.
/// A visibility that is not a positive number (NaN, 0, negative) gives 0: no haze rather than
/// a wall (callers warn about bad data; the weather mapping never passes it).
pub fn haze_extinction_for_visibility(visibility_m: f64) -> f64 {
    if visibility_m.is_nan() || visibility_m <= 0.0 {
        return 0.0;
    }
    (KOSCHMIEDER_CONSTANT / visibility_m - CLEAR_AIR_EXTINCTION_PER_M).max(0.0)
}

/// The haze of one view, the f64 mirror of the shader's `HazeUniforms`.
#[derive(Clone, Debug, PartialEq)]
pub struct HazeSettings {
    /// Extinction at the ground, 1/m. 0: no haze (the default).
    pub extinction_per_m: f64,
    /// Height over which the density falls by `e`, metres. Default 1200.
    pub scale_height_m: f64,
    /// Single-scattering albedo, 0–1. Default 0.9.
    pub albedo: f64,
    /// Henyey-Greenstein asymmetry of the sun's scattering, −1–1. Default 0.7.
    pub asymmetry: f64,
    /// Steps along the view ray, clamped to `1..=MAX_HAZE_STEPS`. Default 16.
    pub steps: u32,
    /// Light shafts: light the haze through the cloud shadow map. Default true.
    pub shafts: bool,
    /// Steps of [`shaft_factors`] along the view ray, clamped to `1..=MAX_HAZE_STEPS`: the
    /// shaft pass runs on few pixels, so it can afford more samples than the march, which
    /// keeps the noise of its jittered samples down. Default 64.
    pub shaft_steps: u32,
    /// The sun's transmittance through the clouds used without shafts or without a map, 0–1
    /// ([`mean_sun_transmittance`]). Default 1.
    pub sun_transmittance: f64,
    /// The fraction of the sky's diffuse light that gets through the clouds, 0–1
    /// ([`mean_diffuse_transmittance`]): it dims the ground's light on the haze. Default 1.
    pub ambient_transmittance: f64,
    /// The mean radiance of the sky above the haze, clouds included, RGB, in the units of
    /// [`MarchSettings::ambient_top`] ([`sky_above_clouds`]: the open sky's share of the clear
    /// sky's light plus the light the clouds' bases send down). `None`: no clouds above, the
    /// clear sky's `ambient_top`. Default `None`.
    pub sky_radiance: Option<[f64; 3]>,
}

impl Default for HazeSettings {
    fn default() -> Self {
        Self {
            extinction_per_m: 0.0,
            scale_height_m: 1200.0,
            albedo: 0.9,
            asymmetry: 0.7,
            steps: 16,
            shafts: true,
            shaft_steps: 64,
            sun_transmittance: 1.0,
            ambient_transmittance: 1.0,
            sky_radiance: None,
        }
    }
}

impl HazeSettings {
    /// The mean radiance of the sky above the haze ([`HazeSettings::sky_radiance`]), where the
    /// clear sky's is `ambient_top`.
    pub fn sky_radiance_or(&self, ambient_top: [f64; 3]) -> [f64; 3] {
        self.sky_radiance.unwrap_or(ambient_top)
    }

    /// Whether there is haze to march: a positive, finite extinction and scale height.
    pub fn is_active(&self) -> bool {
        self.extinction_per_m.is_finite()
            && self.extinction_per_m > 0.0
            && self.scale_height_m.is_finite()
            && self.scale_height_m > 0.0
    }

    /// Altitude above the ground where the haze stops, metres.
    pub fn top_m(&self) -> f64 {
        HAZE_TOP_SCALE_HEIGHTS * self.scale_height_m
    }

    /// Extinction at `altitude_m` above the ground, 1/m.
    pub fn extinction_at(&self, altitude_m: f64) -> f64 {
        self.extinction_per_m * (-altitude_m.max(0.0) / self.scale_height_m).exp()
    }

    /// The haze's optical depth from `altitude_m` straight up to [`HazeSettings::top_m`] and
    /// straight down to the ground, `[τ_above, τ_below]`: the integrals of
    /// [`HazeSettings::extinction_at`]. `[0, 0]` for haze that is not active. WGSL twin:
    /// `haze_column`.
    pub fn column(&self, altitude_m: f64) -> [f64; 2] {
        if !self.is_active() {
            return [0.0; 2];
        }
        let h = self.scale_height_m;
        let z = altitude_m.clamp(0.0, self.top_m());
        let depth =
            |from: f64, to: f64| self.extinction_per_m * h * ((-from / h).exp() - (-to / h).exp());
        [depth(z, self.top_m()), depth(0.0, z)]
    }

    /// The altitude whose [`HazeSettings::column`] gives a view ray's light shares
    /// ([`haze_light_shares`]), for a ray from `camera_altitude_m` with elevation sine `mu`: the
    /// camera's, raised by the scale height times `mu` on a climbing ray, since the haze a
    /// climbing ray sees thins a scale height up and most of its light comes from below that.
    /// WGSL twin: `shares_altitude`.
    pub fn shares_altitude(&self, camera_altitude_m: f64, mu: f64) -> f64 {
        camera_altitude_m + self.scale_height_m * mu.clamp(0.0, 1.0)
    }
}

/// The average fraction of sunlight that gets through the clouds over the whole view, 0–1, for
/// haze without a shadow map: the product over `layers` of `1 − c (1 − e^(−σ h / μs))`, where `c`
/// is the layer's coverage, `σ` its extinction, `h` its thickness and `μs` the sine of the sun's
/// elevation (at least 0.05, a grazing path through a layer ~20 times its thickness). A cloud
/// fraction `c` shades the air by its own slant transmittance, the gaps not at all.
pub fn mean_sun_transmittance(layers: &[super::render::MarchLayer], mu_sun: f64) -> f64 {
    let mu = mu_sun.max(0.05);
    mean_layer_transmittance(layers, |tau| (-tau / mu).exp())
}

/// The product over the active `layers` of `1 − c (1 − t(τ))`: the light a layer of coverage `c`
/// lets through when its clouds, of vertical optical thickness `τ = σ h`, pass `t(τ)` of it and
/// its gaps all of it.
fn mean_layer_transmittance(
    layers: &[super::render::MarchLayer],
    cloud: impl Fn(f64) -> f64,
) -> f64 {
    layers
        .iter()
        .filter(|layer| super::render::layer_is_active(layer))
        .map(|layer| {
            let tau = layer.extinction * (layer.top_m - layer.base_m);
            1.0 - layer.coverage.clamp(0.0, 1.0) * (1.0 - cloud(tau))
        })
        .product::<f64>()
        .clamp(0.0, 1.0)
}

/// Asymmetry of cloud droplets' scattering for [`mean_diffuse_transmittance`] (about 0.85 for
/// visible light).
pub const CLOUD_ASYMMETRY: f64 = 0.85;

/// The fraction of the sky's diffuse light that reaches the air under the clouds, 0–1: the
/// product over `layers` of `1 − c + c T_d`, where `c` is the coverage and `T_d` the diffuse
/// transmittance of a non-absorbing cloud of vertical optical thickness `τ = σ h`,
/// `1 / (1 + ¾ (1 − g) τ)` (the two-stream result; Bohren 1987, "Multiple scattering of light
/// and some of its observable consequences"), with `g` = [`CLOUD_ASYMMETRY`]. A thick deck still
/// lets a quarter or so through, as overcast days show.
pub fn mean_diffuse_transmittance(layers: &[super::render::MarchLayer]) -> f64 {
    mean_layer_transmittance(layers, cloud_diffuse_transmittance)
}

/// The diffuse transmittance of a non-absorbing cloud of vertical optical thickness `tau`,
/// `1 / (1 + ¾ (1 − g) τ)` with `g` = [`CLOUD_ASYMMETRY`] (the two-stream result; Bohren 1987,
/// "Multiple scattering of light and some of its observable consequences"): the share of the
/// light on its top, beam and diffuse alike, that leaves through its base.
pub fn cloud_diffuse_transmittance(tau: f64) -> f64 {
    1.0 / (1.0 + 0.75 * (1.0 - CLOUD_ASYMMETRY) * tau)
}

/// The mean radiance of the sky above air under `layers`, RGB ([`HazeSettings::sky_radiance`]):
/// the open share of the clear sky's [`MarchSettings::ambient_top`] plus the light the clouds'
/// bases send down, the sun's and the sky's that crossed them, with the ground's light (albedo
/// `ground_albedo`) reflected back down ([`sky_light_under_clouds`]: the diffuse flux under a
/// deck, within 10 % of DISORT's). The clear sky's `ambient_top` without clouds.
pub fn sky_above_clouds(
    settings: &MarchSettings,
    layers: &[super::render::MarchLayer],
    ground_albedo: f64,
) -> [f64; 3] {
    let light = sky_light_under_clouds(settings, layers, ground_albedo);
    std::array::from_fn(|c| (1.0 - light.cover) * settings.ambient_top[c] + light.cloud_radiance[c])
}

/// The haze along one view ray: the part in front of the clouds and the part behind them.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct HazeResult {
    /// Between the camera and the clouds' distance.
    pub front: MarchResult,
    /// Beyond the clouds' distance, up to the scene.
    pub back: MarchResult,
}

/// The distances `[start, end]` where the view ray is inside the haze, clipped to `[0, t_max]`
/// and to the ground; `end <= start` when it misses.
pub fn haze_interval(
    haze: &HazeSettings,
    planet_radius_m: f64,
    camera_altitude_m: f64,
    mu: f64,
    t_max: f64,
) -> [f64; 2] {
    let [near, far] =
        intersect_altitude_sphere(camera_altitude_m, mu, planet_radius_m, haze.top_m());
    let t_end = t_max.min(ground_distance(camera_altitude_m, mu, planet_radius_m));
    if far < 0.0 {
        return [0.0, 0.0];
    }
    [near.max(0.0), far.min(t_end)]
}

/// Where the haze's sun light comes from in [`march_haze`].
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum HazeSun<'a> {
    /// One number for the whole view, [`HazeSettings::sun_transmittance`]: the clouds' mean
    /// shade (no light shafts).
    Mean,
    /// Light shafts as the GPU draws them: the ray's [`ShaftFactors`], from the
    /// reduced-resolution shaft pass ([`shaft_factors`], upsampled).
    Shafts(ShaftFactors),
    /// Light shafts read from the shadow map at every haze sample: what the factors
    /// approximate, for tests (no GPU twin).
    PerSample(&'a ShadowMapImage),
}

/// The light shafts along one view ray, as two numbers: the mean fraction of sunlight that
/// reaches the haze below the lowest cloud base, and above it, each weighted by how much that
/// haze contributes to the pixel (its scattering coefficient times the haze transmittance from
/// the camera). Below the cloud base no cloud lies between the haze and the camera (for a
/// camera below the clouds), so there the factor gives exactly the radiance that reading the
/// map at the same samples gives ([`HazeSun::PerSample`] with [`HazeSettings::shaft_steps`] =
/// [`HazeSettings::steps`]); above it, the clouds' distance splits the
/// haze into front and back, and the factor spreads the sunlit fraction evenly over both.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ShaftFactors {
    /// Mean sun transmittance of the haze below `split_altitude_m`, 0–1.
    pub below: f64,
    /// Mean sun transmittance of the haze at and above `split_altitude_m`, 0–1.
    pub above: f64,
    /// The lowest cloud base, metres above the ground (the shadow map's
    /// [`cloud_range_m`](super::shadow::ShadowMapFrame::cloud_range_m)`[0]`).
    pub split_altitude_m: f64,
}

/// One step of the haze march over `[start_m, end_m]`: its sample distance, altitude and optical
/// thickness, and the transmittance from the start of the haze to the step.
struct HazeStep {
    t: f64,
    altitude_m: f64,
    optical_depth: f64,
    start_m: f64,
    end_m: f64,
    transmittance: f64,
}

impl HazeStep {
    /// The weight of the step's in-scattered light per unit source: the transmittance up to it
    /// times the energy-conserving step integral ([`scattered_share`]).
    fn weight(&self) -> f64 {
        self.transmittance * scattered_share(self.optical_depth)
    }
}

/// The share of the light entering a uniform stretch of optical thickness `x` that it scatters,
/// `1 − e^(−x)`, as `x (1 − e^(−x)) / x` (exact as `x` → 0): the energy-conserving step
/// integral `σ dt (1 − e^(−x)) / x` of a step.
fn scattered_share(x: f64) -> f64 {
    x * mean_step_transmittance(x)
}

/// The share of a haze step over `[start_m, end_m]` in front of the clouds' distance `split_m`
/// (0–1; 1 for a split at or beyond the step's end, or NaN). A step the split falls inside is
/// cut there, so the front haze changes continuously as the clouds' distance moves across it and
/// does not flip whole steps between front and back with the sample's jitter. WGSL twin:
/// `front_share`.
fn front_share(start_m: f64, end_m: f64, split_m: f64) -> f64 {
    if split_m.is_nan() || split_m >= end_m {
        1.0
    } else if split_m <= start_m {
        0.0
    } else {
        (split_m - start_m) / (end_m - start_m)
    }
}

/// The `steps` steps of the haze along one view ray (see the module docs), or none where the ray
/// misses the haze. Shared by [`march_haze`] and [`shaft_factors`].
fn haze_steps(
    settings: &MarchSettings,
    haze: &HazeSettings,
    steps: u32,
    camera_altitude_m: f64,
    mu: f64,
    t_max: f64,
    jitter: f64,
) -> Vec<HazeStep> {
    if !haze.is_active() {
        return Vec::new();
    }
    let radius = settings.planet_radius_m;
    let [start, end] = haze_interval(haze, radius, camera_altitude_m, mu, t_max);
    if !super::render::is_positive(end - start) {
        return Vec::new();
    }
    let steps = steps.clamp(1, MAX_HAZE_STEPS);
    let n = f64::from(steps);
    let jitter = jitter.clamp(0.0, 1.0);
    let mut total_depth = 0.0_f64;
    (0..steps)
        .map(|k| {
            let u0 = f64::from(k) / n;
            let u1 = f64::from(k + 1) / n;
            let ta = start + (end - start) * u0 * u0;
            let tb = start + (end - start) * u1 * u1;
            let dt = tb - ta;
            let t = ta + jitter * dt;
            let altitude_m = altitude_along_ray(camera_altitude_m, mu, t, radius);
            let sigma = haze.extinction_at(altitude_m);
            let x = sigma * dt;
            let transmittance = (-total_depth).exp();
            total_depth += x;
            HazeStep {
                t,
                altitude_m,
                optical_depth: x,
                start_m: ta,
                end_m: tb,
                transmittance,
            }
        })
        .collect()
}

/// The [`ShaftFactors`] of one view ray: [`HazeSettings::shaft_steps`] haze samples (the same
/// as [`march_haze`]'s where that equals [`HazeSettings::steps`]) read the sun's transmittance
/// from `map`, or [`HazeSettings::sun_transmittance`] beyond it, and are averaged with their
/// weights below and above the lowest cloud base. A part the ray does not reach gets the mean shade. WGSL twin:
/// `shaft_factors`, run by the reduced-resolution shaft pass (`march.wgsl`'s `shafts` entry).
#[allow(clippy::too_many_arguments)]
pub fn shaft_factors(
    settings: &MarchSettings,
    haze: &HazeSettings,
    camera_altitude_m: f64,
    up: [f64; 3],
    direction: [f64; 3],
    t_max: f64,
    jitter: f64,
    map: &ShadowMapImage,
) -> ShaftFactors {
    let split_altitude_m = map.frame.cloud_range_m[0];
    let mu = dot(direction, up).clamp(-1.0, 1.0);
    // [below, above]: weighted sun transmittance and weight.
    let mut lit = [0.0; 2];
    let mut weight = [0.0; 2];
    let steps = haze_steps(
        settings,
        haze,
        haze.shaft_steps,
        camera_altitude_m,
        mu,
        t_max,
        jitter,
    );
    for step in steps {
        let sun = map
            .ground_transmittance(scale(direction, step.t))
            .unwrap_or(haze.sun_transmittance);
        let part = usize::from(step.altitude_m >= split_altitude_m);
        lit[part] += step.weight() * sun;
        weight[part] += step.weight();
    }
    let mean = |part: usize| {
        if weight[part] > 0.0 {
            (lit[part] / weight[part]).clamp(0.0, 1.0)
        } else {
            haze.sun_transmittance
        }
    };
    ShaftFactors {
        below: mean(0),
        above: mean(1),
        split_altitude_m,
    }
}

/// Directions around the view ray at each angle of [`haze_light_shares`]' quadrature, over half
/// the circle (the other half mirrors it). WGSL twin: `LIGHT_SHARE_AZIMUTHS`.
pub const LIGHT_SHARE_AZIMUTHS: u32 = 8;

/// Angles from the view ray in [`haze_light_shares`]' quadrature (points of equal phase
/// probability). WGSL twin: `LIGHT_SHARE_ANGLES`.
pub const LIGHT_SHARE_ANGLES: u32 = 16;

/// Where the light that a haze particle scatters along a view ray comes from, for a ray of
/// elevation sine `mu` (positive looking up), a Henyey-Greenstein phase of asymmetry `g` and the
/// haze's column `[τ_above, τ_below]` ([`HazeSettings::column`] at
/// [`HazeSettings::shares_altitude`]): the shares of the phase,
/// `∫ p(d · v) w(d) dΩ` over the directions `d` the light comes from, of
///
/// - the sky seen through the haze above: `w = e^(−τ(d))` where `d` points up;
/// - the ground seen through the haze below: `w = e^(−τ(d))` where `d` points down;
/// - the haze itself, where it is opaque: `w = 1 − e^(−τ(d))`,
///
/// with `τ(d)` the column above over the sine of `d`'s elevation, or the column below over its
/// opposite. They add up to 1. The aerosol scatters mostly forward, so light comes mostly from
/// where the camera looks: air seen well above the horizon passes on mostly the sky's light,
/// air seen below it mostly the ground's, and air seen level mostly the haze's own, since a
/// vertically thin haze is opaque along nearly level directions. [`march_haze`] takes that last
/// share as light about as bright as the haze's, so each scattering passes on `albedo` times it
/// again: the haze's light is its single scattering times `1 / (1 − albedo · haze share)`.
///
/// The quadrature takes [`LIGHT_SHARE_ANGLES`] angles `Θ` from the ray at the midpoints of
/// equal phase probability and [`LIGHT_SHARE_AZIMUTHS`] directions around it at each. With no
/// haze column (`[0, 0]`) and isotropic scattering the sky's share is one half at every
/// elevation. WGSL twin: `haze_light_shares`.
pub fn haze_light_shares(mu: f64, g: f64, column: [f64; 2]) -> [f64; 3] {
    let g = g.clamp(-MAX_PHASE_G, MAX_PHASE_G);
    let sin_e = mu.clamp(-1.0, 1.0);
    let cos_e = (1.0 - sin_e * sin_e).max(0.0).sqrt();
    let (n, m) = (
        f64::from(LIGHT_SHARE_ANGLES),
        f64::from(LIGHT_SHARE_AZIMUTHS),
    );
    let mut shares = [0.0; 3];
    for k in 0..LIGHT_SHARE_ANGLES {
        let cos_theta = phase_quantile((f64::from(k) + 0.5) / n, g);
        let sin_theta = (1.0 - cos_theta * cos_theta).max(0.0).sqrt();
        for j in 0..LIGHT_SHARE_AZIMUTHS {
            let phi = std::f64::consts::PI * (f64::from(j) + 0.5) / m;
            let mu_d = cos_theta * sin_e + sin_theta * cos_e * phi.cos();
            let (side, depth) = if mu_d > 0.0 {
                (0, column[0] / mu_d)
            } else if mu_d < 0.0 {
                (1, column[1] / -mu_d)
            } else {
                (1, f64::INFINITY)
            };
            let clear = (-depth).exp();
            shares[side] += clear;
            shares[2] += 1.0 - clear;
        }
    }
    shares.map(|share| share / (n * m))
}

/// The cosine of the angle from the forward direction below which the Henyey-Greenstein phase of
/// asymmetry `g` scatters the share `1 − u` of its light: the inverse of its distribution.
fn phase_quantile(u: f64, g: f64) -> f64 {
    if g.abs() < 1e-3 {
        return 2.0 * u - 1.0;
    }
    let root = (1.0 - g * g) / (1.0 - g + 2.0 * g * u);
    ((1.0 + g * g - root * root) / (2.0 * g)).clamp(-1.0, 1.0)
}

/// Marches the haze along one view ray (see the module docs). The camera is at
/// `camera_altitude_m` with local vertical `up`; `direction` is the unit view ray, `t_max` the
/// distance to the scene (infinity for the sky), `split_m` the clouds' distance (infinity
/// without clouds), `jitter` the sample offset within each step (0–1). `sun` says how the
/// clouds shade the haze's sunlight; with [`HazeSettings::shafts`] off it is always the mean
/// shade. Radiance is in the units of the sun's illuminance per steradian, before exposure.
/// WGSL twin: `march_haze`.
#[allow(clippy::too_many_arguments)]
pub fn march_haze(
    settings: &MarchSettings,
    haze: &HazeSettings,
    camera_altitude_m: f64,
    up: [f64; 3],
    direction: [f64; 3],
    t_max: f64,
    split_m: f64,
    jitter: f64,
    sun: HazeSun<'_>,
) -> HazeResult {
    let mu = dot(direction, up).clamp(-1.0, 1.0);
    let steps = haze_steps(
        settings,
        haze,
        haze.steps,
        camera_altitude_m,
        mu,
        t_max,
        jitter,
    );
    let cos_sun = dot(direction, settings.sun_direction).clamp(-1.0, 1.0);
    // Where the light scattered toward the camera comes from: the sky, the ground, or the haze
    // itself, whose light each scattering passes on again; for the haze about a scale height
    // along a climbing ray, where most of its light comes from.
    let [from_sky, from_ground, from_haze] = haze_light_shares(
        mu,
        haze.asymmetry,
        haze.column(haze.shares_altitude(camera_altitude_m, mu)),
    );
    let gain = 1.0 / (1.0 - haze.albedo.clamp(0.0, 1.0) * from_haze).max(1e-3);
    let phase = henyey_greenstein(cos_sun, haze.asymmetry) * gain;
    // The sky above and the ground below, each by its share of the phase.
    let sky = haze.sky_radiance_or(settings.ambient_top);
    let ambient: [f64; 3] = std::array::from_fn(|c| {
        gain * (from_sky * sky[c]
            + from_ground * settings.ambient_bottom[c] * haze.ambient_transmittance)
    });
    let sun = if haze.shafts { sun } else { HazeSun::Mean };
    // [front, back]: radiance and optical depth.
    let mut radiance = [[0.0; 3]; 2];
    let mut optical_depth = [0.0; 2];
    for step in steps {
        let visible = match sun {
            HazeSun::Mean => haze.sun_transmittance,
            HazeSun::Shafts(factors) if step.altitude_m < factors.split_altitude_m => factors.below,
            HazeSun::Shafts(factors) => factors.above,
            // Beyond the map, the clouds' mean shade.
            HazeSun::PerSample(map) => map
                .ground_transmittance(scale(direction, step.t))
                .unwrap_or(haze.sun_transmittance),
        };
        // The step's front part and its back part, each with its own step integral
        // `x (1 − e^−x) / x` behind the transmittance up to it.
        let front = step.optical_depth * front_share(step.start_m, step.end_m, split_m);
        let parts = [front, step.optical_depth - front];
        let weights = [
            step.transmittance * scattered_share(front),
            step.transmittance * (-front).exp() * scattered_share(parts[1]),
        ];
        for part in 0..2 {
            let weight = weights[part] * haze.albedo;
            for (c, value) in radiance[part].iter_mut().enumerate() {
                *value += weight * (settings.sun_illuminance[c] * visible * phase + ambient[c]);
            }
            optical_depth[part] += parts[part];
        }
    }
    // The back part's radiance was weighted by the transmittance from the camera; stated
    // relative to the clouds' distance it is divided by the front's transmittance.
    let front_t = (-optical_depth[0]).exp();
    let back_radiance = if front_t > 0.0 {
        radiance[1].map(|l| l / front_t)
    } else {
        [0.0; 3]
    };
    HazeResult {
        front: MarchResult {
            radiance: radiance[0],
            transmittance: front_t,
            distance_m: f64::INFINITY,
        },
        back: MarchResult {
            radiance: back_radiance,
            transmittance: (-optical_depth[1]).exp(),
            distance_m: f64::INFINITY,
        },
    }
}

/// Stacks the haze in front of the clouds, the clouds, and the haze behind them:
/// `L = L_f + T_f (L_c + T_c L_b)`, `T = T_f T_c T_b`. WGSL twin: `composite_haze`.
pub fn composite(haze: &HazeResult, clouds: &MarchResult) -> MarchResult {
    let (front, back) = (&haze.front, &haze.back);
    MarchResult {
        radiance: std::array::from_fn(|c| {
            front.radiance[c]
                + front.transmittance
                    * (clouds.radiance[c] + clouds.transmittance * back.radiance[c])
        }),
        transmittance: front.transmittance * clouds.transmittance * back.transmittance,
        distance_m: clouds.distance_m,
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::reference::shadow::ShadowMapFrame;

    const UP: [f64; 3] = [0.0, 1.0, 0.0];

    /// [`march_haze`] to the sky from `altitude` m, jitter 0.5, default march settings.
    fn sky_ray(
        haze: &HazeSettings,
        altitude: f64,
        direction: [f64; 3],
        split_m: f64,
        sun: HazeSun<'_>,
    ) -> HazeResult {
        let settings = MarchSettings::default();
        march_haze(
            &settings,
            haze,
            altitude,
            UP,
            direction,
            f64::INFINITY,
            split_m,
            0.5,
            sun,
        )
    }

    /// A horizontal ray from 2 m above the ground, facing −z (north), sun behind the camera.
    fn level_view(haze: &HazeSettings, t_max: f64) -> HazeResult {
        let settings = MarchSettings {
            sun_direction: [0.0, 0.5_f64.sqrt(), 0.5_f64.sqrt()],
            ..MarchSettings::default()
        };
        march_haze(
            &settings,
            haze,
            2.0,
            UP,
            [0.0, 0.0, -1.0],
            t_max,
            f64::INFINITY,
            0.5,
            HazeSun::Mean,
        )
    }

    #[test]
    fn koschmieder_extinction_from_visibility() {
        let sigma = haze_extinction_for_visibility(20_000.0);
        assert!((sigma - (3.912 / 20_000.0 - CLEAR_AIR_EXTINCTION_PER_M)).abs() < 1e-15);
        // Clear air adds nothing; bad values add nothing.
        assert_eq!(haze_extinction_for_visibility(300_000.0), 0.0);
        for bad in [f64::NAN, 0.0, -5.0] {
            assert_eq!(haze_extinction_for_visibility(bad), 0.0, "{bad}");
        }
        // Monotonic: lower visibility, thicker haze.
        assert!(haze_extinction_for_visibility(5_000.0) > haze_extinction_for_visibility(10_000.0));
    }

    #[test]
    fn a_black_target_at_the_visibility_keeps_two_percent_contrast() {
        // Koschmieder's definition, with the haze's own share of the 3.912 / V (the clear air's
        // share is Bevy's): against the horizon sky, a black target at V shows the contrast
        // e^(−σ V) of the whole air, here the haze part of it.
        let visibility = 10_000.0;
        let haze = HazeSettings {
            extinction_per_m: KOSCHMIEDER_CONSTANT / visibility,
            // So thick a layer that the 2 m ray sees a uniform medium.
            scale_height_m: 1.0e7,
            steps: 64,
            ..HazeSettings::default()
        };
        let target = level_view(&haze, visibility).front;
        let horizon = level_view(&haze, f64::INFINITY).front;
        // Contrast of a black target against the horizon: (L_h − L_t) / L_h.
        let contrast = (horizon.radiance[1] - target.radiance[1]) / horizon.radiance[1];
        assert!((contrast - 0.02).abs() < 0.002, "contrast {contrast}");
        assert!((target.transmittance - 0.02).abs() < 1e-3, "{target:?}");
    }

    #[test]
    fn uniform_haze_matches_the_closed_form() {
        let haze = HazeSettings {
            extinction_per_m: 1e-4,
            scale_height_m: 1.0e9,
            steps: 32,
            ..HazeSettings::default()
        };
        let settings = MarchSettings {
            sun_direction: [0.0, 0.5_f64.sqrt(), 0.5_f64.sqrt()],
            ..MarchSettings::default()
        };
        let d = 5_000.0;
        let result = level_view(&haze, d).front;
        let cos = dot([0.0, 0.0, -1.0], settings.sun_direction);
        // The source of every sample: the level ray's shares of the phase at the camera (2 m up).
        let [sky, ground, own] = haze_light_shares(0.0, haze.asymmetry, haze.column(2.0));
        let source = haze.albedo / (1.0 - haze.albedo * own)
            * (settings.sun_illuminance[0] * henyey_greenstein(cos, haze.asymmetry)
                + sky * settings.ambient_top[0]
                + ground * settings.ambient_bottom[0]);
        let transmittance = (-haze.extinction_per_m * d).exp();
        let exact = source * (1.0 - transmittance);
        assert!((result.transmittance - transmittance).abs() < 1e-9);
        assert!(
            ((result.radiance[0] - exact) / exact).abs() < 1e-3,
            "{} vs {exact}",
            result.radiance[0]
        );
    }

    #[test]
    fn splitting_at_the_clouds_composites_to_the_whole_ray() {
        let haze = HazeSettings {
            extinction_per_m: 2e-4,
            steps: 24,
            ..HazeSettings::default()
        };
        let direction = [0.0, 0.1, -0.995];
        let whole = sky_ray(&haze, 500.0, direction, f64::INFINITY, HazeSun::Mean);
        let split = sky_ray(&haze, 500.0, direction, 4_000.0, HazeSun::Mean);
        // With clear "clouds" (T = 1, L = 0), the split composites to the unsplit ray.
        let joined = composite(&split, &MarchResult::CLEAR);
        assert!(split.back.transmittance < 1.0 && split.front.transmittance < 1.0);
        assert!((joined.transmittance - whole.front.transmittance).abs() < 1e-12);
        for c in 0..3 {
            let (a, b) = (joined.radiance[c], whole.front.radiance[c]);
            assert!(((a - b) / b).abs() < 1e-12, "{a} vs {b}");
        }
        // An opaque cloud hides the haze behind it and is veiled by the haze in front.
        let cloud = MarchResult {
            radiance: [1000.0; 3],
            transmittance: 0.0,
            distance_m: 4_000.0,
        };
        let seen = composite(&split, &cloud);
        assert_eq!(seen.transmittance, 0.0);
        let expected = split.front.radiance[0] + split.front.transmittance * 1000.0;
        assert!((seen.radiance[0] - expected).abs() < 1e-9);
    }

    #[test]
    fn the_front_haze_follows_the_clouds_distance_not_the_jitter() {
        // Rain-thick haze along a level ray, an opaque cloud 6 km away: the haze in front of it
        // is the haze of the first 6 km whatever the sample's offset in the step the cloud's
        // distance falls in, and it grows smoothly as the cloud moves away.
        let haze = HazeSettings {
            extinction_per_m: 6.5e-4,
            scale_height_m: 1.0e7,
            steps: 12,
            ..HazeSettings::default()
        };
        let settings = MarchSettings::default();
        let front = |split_m: f64, jitter: f64| {
            march_haze(
                &settings,
                &haze,
                2.0,
                UP,
                [0.0, 0.0, -1.0],
                100_000.0,
                split_m,
                jitter,
                HazeSun::Mean,
            )
            .front
        };
        // The uniform medium's closed form: T = e^(−σ d), L ∝ 1 − T. The step integral is
        // exact in a uniform medium; the tolerance covers only the ray's rise over the curved
        // ground, which thins the haze by under 10⁻⁴ within 100 km.
        let exact = |d: f64| 1.0 - (-6.5e-4 * d).exp();
        let unit = front(f64::INFINITY, 0.5).radiance[1] / exact(100_000.0);
        for (split, jitter) in [
            (6_000.0, 0.02),
            (6_000.0, 0.5),
            (6_000.0, 0.98),
            (5_990.0, 0.5),
            (6_010.0, 0.5),
        ] {
            let seen = front(split, jitter);
            assert!(
                (seen.radiance[1] / unit / exact(split) - 1.0).abs() < 1e-4,
                "cloud at {split} m, jitter {jitter}: {} against {}",
                seen.radiance[1] / unit,
                exact(split)
            );
            assert!(
                (seen.transmittance / (1.0 - exact(split)) - 1.0).abs() < 1e-4,
                "{} against {}",
                seen.transmittance,
                1.0 - exact(split)
            );
        }
        // Continuous in the distance: a cloud 20 m farther lets more haze in front.
        assert!(front(6_010.0, 0.5).radiance[1] > front(5_990.0, 0.5).radiance[1]);
    }

    /// A 40 km map, 16 texels a side, whose column `i` (from world +x to −x) has the sun's
    /// transmittance `column(i)`; clouds from 1 to 2 km.
    fn column_shadow_map(column: impl Fn(u32) -> f64) -> ShadowMapImage {
        let size = 16;
        let frame = ShadowMapFrame {
            centre_m: [0.0, 0.0, 0.0],
            axis_x_m: [-20_000.0, 0.0, 0.0],
            axis_y_m: [0.0, 0.0, 20_000.0],
            size,
            cloud_range_m: [1000.0, 2000.0],
        };
        let texels = (0..size * size)
            .map(|index| [column(index % size), 0.0, 0.0, 0.0])
            .collect();
        ShadowMapImage { frame, texels }
    }

    #[test]
    fn shadowed_air_is_darker_than_sunlit_air() {
        // Looking down the shadow line, the shaft of lit air is brighter.
        // The half toward world −x is in full cloud shadow, the other half lit.
        let map = column_shadow_map(|i| if i < 8 { 0.0 } else { 1.0 });
        // Texel u lies at centre + (1 − 2u) axis_x and axis_x points to −x, so u < 0.5 (the
        // shadowed half) is world −x.
        assert_eq!(map.ground_transmittance([-10_000.0, 0.0, 0.0]), Some(0.0));
        assert_eq!(map.ground_transmittance([10_000.0, 0.0, 0.0]), Some(1.0));
        assert_eq!(map.ground_transmittance([50_000.0, 0.0, 0.0]), None);
        let haze = HazeSettings {
            extinction_per_m: 1e-4,
            ..HazeSettings::default()
        };
        let settings = MarchSettings::default();
        for per_sample in [true, false] {
            let look = |direction: [f64; 3]| {
                let sun = if per_sample {
                    HazeSun::PerSample(&map)
                } else {
                    let factors = shaft_factors(
                        &settings,
                        &haze,
                        10.0,
                        UP,
                        direction,
                        f64::INFINITY,
                        0.5,
                        &map,
                    );
                    HazeSun::Shafts(factors)
                };
                sky_ray(&haze, 10.0, direction, f64::INFINITY, sun).front
            };
            let shadowed = look([-0.9, 0.0, -0.436]);
            let lit = look([0.9, 0.0, -0.436]);
            assert!(
                lit.radiance[1] > 1.5 * shadowed.radiance[1],
                "per sample {per_sample}: lit {lit:?} shadowed {shadowed:?}"
            );
            // Same air, same transmittance: only the light differs.
            assert!((lit.transmittance - shadowed.transmittance).abs() < 1e-12);
        }
        // Without shafts both see the mean transmittance.
        let flat = HazeSettings {
            shafts: false,
            sun_transmittance: 0.5,
            ..haze
        };
        let a = sky_ray(
            &flat,
            10.0,
            [0.9, 0.0, -0.436],
            f64::INFINITY,
            HazeSun::PerSample(&map),
        );
        let b = sky_ray(
            &flat,
            10.0,
            [-0.9, 0.0, -0.436],
            f64::INFINITY,
            HazeSun::PerSample(&map),
        );
        assert!((a.front.radiance[1] - b.front.radiance[1]).abs() < 1e-9);
    }

    #[test]
    fn shaft_factors_give_the_per_sample_shafts_where_clouds_do_not_split_the_haze() {
        // Rays that cross the shadow line, read per sample and through the two factors. With as
        // many shaft steps as march steps the factors are weighted means of the same samples,
        // so wherever the clouds' distance does not fall among the haze samples of one altitude
        // class (no cloud on the ray; a cloud just above the base) the radiance is the same.
        // Stripes of shadow and light 5 km wide.
        let map = column_shadow_map(|i| f64::from((i / 2) % 2));
        let haze = HazeSettings {
            extinction_per_m: 2e-4,
            shaft_steps: 16,
            ..HazeSettings::default()
        };
        let settings = MarchSettings::default();
        let direction = [0.8, 0.1, -0.3];
        let direction = scale(direction, 1.0 / dot(direction, direction).sqrt());
        let factors = shaft_factors(
            &settings,
            &haze,
            10.0,
            UP,
            direction,
            f64::INFINITY,
            0.3,
            &map,
        );
        assert!(factors.below > 0.05 && factors.below < 0.95, "{factors:?}");
        assert_eq!(factors.split_altitude_m, 1000.0);
        // The cloud base at the start of the first haze step sampled above it: every step of
        // each altitude class lies wholly on one side of the clouds.
        let steps = haze_steps(
            &settings,
            &haze,
            haze.steps,
            10.0,
            direction[1],
            f64::INFINITY,
            0.3,
        );
        let base_step = steps
            .iter()
            .find(|step| step.altitude_m >= 1000.0)
            .unwrap()
            .start_m;
        for split in [f64::INFINITY, base_step] {
            let march = |sun| {
                march_haze(
                    &settings,
                    &haze,
                    10.0,
                    UP,
                    direction,
                    f64::INFINITY,
                    split,
                    0.3,
                    sun,
                )
            };
            let per_sample = march(HazeSun::PerSample(&map));
            let shafts = march(HazeSun::Shafts(factors));
            for (a, b) in [
                (per_sample.front, shafts.front),
                (per_sample.back, shafts.back),
            ] {
                for c in 0..3 {
                    assert!(
                        (a.radiance[c] - b.radiance[c]).abs() <= 1e-12 * a.radiance[c].max(1.0),
                        "split {split}: {a:?} vs {b:?}"
                    );
                }
                assert_eq!(a.transmittance, b.transmittance);
            }
        }
        // The lit and shadowed air sit on the same ray: the factor lies strictly between.
        let flat = march_haze(
            &settings,
            &haze,
            10.0,
            UP,
            direction,
            f64::INFINITY,
            f64::INFINITY,
            0.3,
            HazeSun::Shafts(ShaftFactors {
                below: 0.0,
                ..factors
            }),
        );
        let shafts = march_haze(
            &settings,
            &haze,
            10.0,
            UP,
            direction,
            f64::INFINITY,
            f64::INFINITY,
            0.3,
            HazeSun::Shafts(factors),
        );
        assert!(shafts.front.radiance[1] > flat.front.radiance[1]);
    }

    #[test]
    fn mean_sun_transmittance_follows_coverage_and_thickness() {
        use super::super::render::MarchLayer;
        let layer = |coverage: f64, extinction: f64| MarchLayer {
            base_m: 1000.0,
            top_m: 2000.0,
            coverage,
            extinction,
            ..MarchLayer::default()
        };
        assert_eq!(mean_sun_transmittance(&[], 1.0), 1.0);
        let overcast = mean_sun_transmittance(&[layer(1.0, 0.05)], 1.0);
        assert!(overcast < 1e-6, "{overcast}");
        let half = mean_sun_transmittance(&[layer(0.5, 0.05)], 1.0);
        assert!((half - 0.5).abs() < 1e-6, "{half}");
        let thin = mean_sun_transmittance(&[layer(1.0, 1e-4)], 1.0);
        assert!((thin - (-0.1_f64).exp()).abs() < 1e-9, "{thin}");
        // A low sun crosses more cloud.
        assert!(mean_sun_transmittance(&[layer(1.0, 1e-4)], 0.2) < thin);
        // Diffuse light gets through thick cloud far better than the direct beam.
        assert_eq!(mean_diffuse_transmittance(&[]), 1.0);
        let deck = mean_diffuse_transmittance(&[layer(1.0, 0.05)]);
        assert!(
            (deck - 1.0 / (1.0 + 0.75 * 0.15 * 50.0)).abs() < 1e-12,
            "{deck}"
        );
        assert!(deck > 0.1 && overcast < 1e-6);
        assert!(mean_diffuse_transmittance(&[layer(0.5, 0.05)]) > deck);
    }

    #[test]
    fn hard_cases_stay_finite() {
        let settings = MarchSettings::default();
        for extinction in [0.0, 1e-12, 1e-4, 1e3, f64::INFINITY, f64::NAN] {
            for altitude in [-10.0, 0.0, 2.0, 9_599.0, 9_600.0, 50_000.0] {
                for direction in [
                    [0.0, 1.0, 0.0],
                    [0.0, -1.0, 0.0],
                    [0.0, 0.0, -1.0],
                    [0.0, 1e-7, -1.0],
                    [0.0, -0.05, -0.9987],
                ] {
                    for t_max in [0.0, 1.0, 1e5, f64::INFINITY] {
                        let haze = HazeSettings {
                            extinction_per_m: extinction,
                            ..HazeSettings::default()
                        };
                        let r = march_haze(
                            &settings,
                            &haze,
                            altitude,
                            UP,
                            direction,
                            t_max,
                            3_000.0,
                            0.99,
                            HazeSun::Mean,
                        );
                        for part in [r.front, r.back] {
                            assert!(
                                (0.0..=1.0).contains(&part.transmittance),
                                "{extinction} {altitude} {direction:?} {t_max}: {part:?}"
                            );
                            assert!(part.radiance.iter().all(|l| l.is_finite() && *l >= 0.0));
                        }
                    }
                }
            }
        }
    }

    /// The committed Mitsuba haze table (`validation/haze/`), relative to the crate root.
    const MITSUBA_HAZE: &str = "validation/haze/mitsuba_haze.csv";
    const MITSUBA_HAZE_HEADER: &str = "sun,sky,elevation_deg,azimuth_deg,radiance";

    /// One view of the path-traced haze: the sun's irradiance (at 45° up, toward −z), the sky's
    /// radiance above the haze, the view's elevation and azimuth from the sun's, degrees, and
    /// Mitsuba's radiance.
    #[derive(Clone, Copy, Debug)]
    struct HazeView {
        sun: f64,
        sky: f64,
        elevation_deg: f64,
        azimuth_deg: f64,
        radiance: f64,
    }

    fn parse_haze_table(file: &str, text: &str) -> Result<Vec<HazeView>, String> {
        crate::reference::table::parse_table(file, text, MITSUBA_HAZE_HEADER, 5, |_, v| {
            let &[sun, sky, elevation_deg, azimuth_deg, radiance] = v else {
                unreachable!("the reader checks the field count");
            };
            if sun < 0.0 || sky < 0.0 || radiance < 0.0 {
                return Err("a negative light or radiance".to_owned());
            }
            if !(-90.0..=90.0).contains(&elevation_deg) {
                return Err(format!("elevation {elevation_deg}° out of range"));
            }
            Ok(HazeView {
                sun,
                sky,
                elevation_deg,
                azimuth_deg,
                radiance,
            })
        })
    }

    /// The haze the Mitsuba table path-traced (`validation/haze/make_haze.py`): ground extinction
    /// 10⁻⁴ /m, scale height 1 200 m, albedo 0.9, asymmetry 0.7, over a black ground, seen
    /// from 300 m up on a flat planet; marched in the most steps, with the sky behind it.
    fn mitsuba_haze_radiance(view: &HazeView) -> f64 {
        let sun_elevation = 45f64.to_radians();
        let settings = MarchSettings {
            planet_radius_m: 1e10,
            camera_altitude_m: 300.0,
            sun_direction: [0.0, sun_elevation.sin(), -sun_elevation.cos()],
            sun_illuminance: [view.sun; 3],
            ambient_top: [view.sky; 3],
            ambient_bottom: [0.0; 3],
            ..MarchSettings::default()
        };
        let haze = HazeSettings {
            extinction_per_m: 1e-4,
            scale_height_m: 1200.0,
            albedo: 0.9,
            asymmetry: 0.7,
            steps: MAX_HAZE_STEPS,
            shafts: false,
            ..HazeSettings::default()
        };
        let (e, a) = (
            view.elevation_deg.to_radians(),
            view.azimuth_deg.to_radians(),
        );
        let direction = [e.cos() * a.sin(), e.sin(), -e.cos() * a.cos()];
        let result = march_haze(
            &settings,
            &haze,
            300.0,
            [0.0, 1.0, 0.0],
            direction,
            f64::INFINITY,
            f64::INFINITY,
            0.5,
            HazeSun::Mean,
        );
        // The sky behind the haze (the black ground below), as the compositor adds the scene.
        let behind = if view.elevation_deg > 0.0 {
            view.sky
        } else {
            0.0
        };
        result.front.radiance[1] + result.front.transmittance * behind
    }

    /// Every view of the path-traced haze against the twin, printed (`cargo test --lib
    /// haze_against_mitsuba -- --nocapture`), and the largest relative difference of the sky's
    /// light and of the sun's over every view.
    fn haze_comparison() -> (String, [f64; 2]) {
        let views = crate::reference::table::read_committed(MITSUBA_HAZE, parse_haze_table);
        let mut report =
            String::from("sun, sky, elevation, azimuth: Mitsuba, twin (twin / Mitsuba − 1)\n");
        let mut worst = [0.0_f64; 2];
        for view in &views {
            let ours = mitsuba_haze_radiance(view);
            let error = ours / view.radiance - 1.0;
            report += &format!(
                "{} {} {:>5}° {:>4}°: {:.5} {:.5} ({:+.1} %)\n",
                view.sun,
                view.sky,
                view.elevation_deg,
                view.azimuth_deg,
                view.radiance,
                ours,
                100.0 * error
            );
            let light = usize::from(view.sun > 0.0);
            worst[light] = worst[light].max(error.abs());
        }
        (report, worst)
    }

    /// The haze against the path-traced truth (`validation/README.md`, "Haze against
    /// Mitsuba"): the sky's light and the sun's at every view within the validation's target for
    /// an optically thin medium (`THIN_MEDIUM_TOLERANCE`: the haze's vertical optical depth is
    /// 0.12, below the thinnest DISORT deck's 0.5). Single scattering alone leaves the sun's light near the horizon
    /// far too dark, and a sky and ground light taken as one isotropic mean leaves the air seen
    /// below the horizon far too bright.
    #[test]
    fn haze_against_mitsuba() {
        let (report, [sky, sun]) = haze_comparison();
        println!(
            "{report}largest: sky {:.1} %, sun {:.1} %",
            100.0 * sky,
            100.0 * sun
        );
        let target = crate::reference::table::THIN_MEDIUM_TOLERANCE;
        assert!(
            sky <= target,
            "sky light {:.1} % off\n{report}",
            100.0 * sky
        );
        assert!(sun <= target, "sunlight {:.1} % off\n{report}", 100.0 * sun);
    }

    #[test]
    fn a_broken_haze_table_names_the_file_and_row() {
        let good = format!("{MITSUBA_HAZE_HEADER}\n1,0,5,90,0.02\n");
        assert_eq!(parse_haze_table("h.csv", &good).map(|v| v.len()), Ok(1));
        for (text, expected) in [
            (String::new(), "h.csv: empty"),
            ("a\n".to_owned(), "h.csv: row 1: header"),
            (format!("{MITSUBA_HAZE_HEADER}\n"), "h.csv: no cases"),
            (
                format!("{MITSUBA_HAZE_HEADER}\n1,0,5,90,x\n"),
                "h.csv: row 2: \"x\" is not a number",
            ),
            (
                format!("{MITSUBA_HAZE_HEADER}\n1,0,5,90\n"),
                "h.csv: row 2: 4 fields",
            ),
            (
                format!("{MITSUBA_HAZE_HEADER}\n1,0,5,90,0.1\n1,0,95,90,0.1\n"),
                "h.csv: row 3: elevation 95",
            ),
            (
                format!("{MITSUBA_HAZE_HEADER}\n1,0,5,90,-0.1\n"),
                "h.csv: row 2: a negative",
            ),
        ] {
            let error = parse_haze_table("h.csv", &text).expect_err(&text);
            assert!(error.starts_with(expected), "{error:?} for {text:?}");
        }
    }

    /// [`haze_light_shares`]: the three shares add up to 1; without a haze column there is no
    /// haze share, isotropic scattering takes one half from the sky at every elevation, and
    /// looking straight up the sky's share is the Henyey-Greenstein phase's forward hemisphere,
    /// `(1 − g²) / (2g) (1 / (1 − g) − 1 / √(1 + g²))` (to the quadrature's resolution); in a
    /// haze the sky's share grows with the elevation, and rays near the horizon take more of the
    /// haze's own light than steep ones.
    #[test]
    fn the_haze_light_shares_split_the_phase() {
        for mu in [-1.0, -0.5, 0.0, 0.3, 1.0] {
            let [sky, ground, haze] = haze_light_shares(mu, 0.0, [0.0, 0.0]);
            assert!(
                (sky - 0.5).abs() < 1e-9 && (ground - 0.5).abs() < 1e-9 && haze == 0.0,
                "{mu}"
            );
        }
        for g in [0.3_f64, 0.7, 0.9] {
            let forward =
                (1.0 - g * g) / (2.0 * g) * (1.0 / (1.0 - g) - 1.0 / (1.0 + g * g).sqrt());
            let [sky, _, _] = haze_light_shares(1.0, g, [0.0, 0.0]);
            // Straight up the sky's share is a step in the phase's angle, which the quadrature's
            // angles resolve to half an angle's weight.
            assert!(
                (sky - forward).abs() <= 0.5 / f64::from(LIGHT_SHARE_ANGLES),
                "{g}: {sky} vs {forward}"
            );
        }
        let column = [0.1, 0.03];
        let mut last_sky = 0.0;
        for k in -10..=10 {
            let shares = haze_light_shares(0.1 * f64::from(k), 0.7, column);
            assert!(
                (shares.iter().sum::<f64>() - 1.0).abs() < 1e-9,
                "{k}: {shares:?}"
            );
            assert!(shares[0] > last_sky, "{k}: {shares:?}");
            last_sky = shares[0];
        }
        // Near the horizon the haze is opaque along the directions forward scattering brings
        // light from; looking steeply up or down it is not.
        let own = |mu: f64| haze_light_shares(mu, 0.7, column)[2];
        assert!(
            own(0.0) > own(0.8) && own(0.0) > own(-0.8),
            "{} {} {}",
            own(0.0),
            own(0.8),
            own(-0.8)
        );
    }
}
