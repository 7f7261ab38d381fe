//! The march of one view ray in f64: the intervals where it crosses the layers, in steps that grow
//! with distance, with Schneider 2015's two-level stepping, dense steps marched again in thin parts
//! and Hillaire 2016's energy-conserving integral across each step. WGSL twin:
//! `src/render/march/clouds.wgsl`, the library whose `march_clouds` the entry shader
//! `march.wgsl` calls.

#[cfg(doc)]
use super::ray_start_jitter;
use super::{
    CloudColumn, CloudTextures, EddingtonPhase, LIGHT_SAMPLE_OFFSET, MarchLayer, MarchSettings,
    SHADOW_MAP_NEAR_STEPS, SHADOW_MAP_NEAR_TEXELS, SampleLights, add, altitude_along_ray, dot,
    eddington_phase, flash_source, ground_distance, higher_layers_optical_depth, horizontal_axes,
    is_positive, layer_density, layer_is_active, lerp, mean_step_transmittance,
    next_cloud_interval, peak_spread_phase, point_mu_sun, profile_column, sample_source, saturate,
    scale, scattering_albedo, step_warp, sun_optical_depth, total_extinction,
};
use crate::reference::haze::clear_air_extinction;
#[cfg(doc)]
use crate::reference::haze::{
    CLEAR_AIR_MIE_EXTINCTION_PER_M, CLEAR_AIR_RAYLEIGH_EXTINCTION_PER_M, MIE_SCALE_HEIGHT_M,
    RAYLEIGH_SCALE_HEIGHT_M,
};
use crate::reference::shadow::ShadowMapImage;

/// Most primary steps per interval; larger [`MarchSettings::primary_steps`] are clamped.
pub const MAX_PRIMARY_STEPS: u32 = 1024;

/// Sub-steps covered by one cheap, base-only sample while the march looks for cloud (the long
/// stride of Schneider 2015's two-level stepping, Pérez Martín 2022 "Optimization": "Dynamic Steps with
/// Density").
pub const CHEAP_STRIDE: u32 = 4;

/// Consecutive empty full-detail samples after which the march goes back to cheap strides.
pub const EMPTY_STEPS_TO_CHEAP: u32 = 4;

/// Largest optical thickness one primary step integrates from a single sample: a denser step
/// is marched again in parts this thick, from the cloud's edge (see the march's `step`).
pub const MAX_STEP_OPTICAL_DEPTH: f64 = 2.0;

/// Most cloudy parts a dense primary step is marched in; the last reaches the step's end.
/// Empty parts do not count (see [`MAX_PARTS`]).
pub const MAX_SUBSTEPS: u32 = 8;

/// Most parts, cloudy or empty, a dense primary step is marched in.
pub const MAX_PARTS: u32 = 32;

/// How many times fewer light steps a sample past the cut-off takes (see `light_steps_at`).
pub const PAST_CUTOFF_LIGHT_STEP_DIVISOR: u32 = 4;

/// The fewest light steps a sample past the cut-off, or deep enough in the cloud
/// ([`FULL_LIGHT_STEPS_TRANSMITTANCE`]), takes, unless the preset takes fewer.
pub const PAST_CUTOFF_MIN_LIGHT_STEPS: u32 = 4;

/// Below this view transmittance (the one the early exit compares with the cut-off), a
/// sample's light steps fall in proportion to it, down to [`PAST_CUTOFF_MIN_LIGHT_STEPS`]: the
/// sample's light reaches the camera times that transmittance, so an error in its sun's
/// optical depth counts for that much less. With an early exit only (a cut-off of 0 keeps
/// every light step, as the converged reference does). See `light_steps_at`.
pub const FULL_LIGHT_STEPS_TRANSMITTANCE: f64 = 0.25;

/// A view ray within about 32° of the sun (the cosine of the angle at least this) takes all of
/// [`MarchSettings::light_steps`] ([`ray_light_steps`]).
pub const TOWARD_SUN_COS: f64 = 0.85;

/// A view ray 60° or more from the sun (the cosine at most this) takes the share
/// [`MarchSettings::light_steps_away_from_sun`] of [`MarchSettings::light_steps`]
/// ([`ray_light_steps`]).
pub const AWAY_FROM_SUN_COS: f64 = 0.5;

/// How many times [`MarchSettings::transmittance_cutoff`] a view ray 60° or more from the sun
/// ([`AWAY_FROM_SUN_COS`]) stops at ([`ray_transmittance_cutoff`]). Away from the sun the phase
/// function's forward peak sends no light toward the camera, so what lies beyond a cut-off is
/// the δ-scaled diffuse and sky light, which the tail added at the stop (the medium going on
/// like the last step) carries; toward the sun the glow of a backlit cloud's depths does not
/// follow the last step. What it costs and saves: `docs/performance.md`.
pub const AWAY_FROM_SUN_CUTOFF_GAIN: f64 = 5.0;

/// The view transmittance at which a ray stops: [`MarchSettings::transmittance_cutoff`] within
/// about 32° of the sun ([`TOWARD_SUN_COS`]), [`AWAY_FROM_SUN_CUTOFF_GAIN`] times it from 60° on
/// ([`AWAY_FROM_SUN_COS`]), linear between, at most 1; 0 stays 0. Only for a ray that ends in
/// the sky (`t_max` at [`FAR_AWAY`](crate::reference::composite::FAR_AWAY) or beyond): the
/// tail takes the medium on without end, so a ray to a scene object keeps the cut-off, and the
/// object seen through fog at a few percent contrast stays seen. WGSL twin:
/// `ray_transmittance_cutoff`.
pub fn ray_transmittance_cutoff(cutoff: f64, cos_sun: f64, t_max: f64) -> f64 {
    if t_max < crate::reference::composite::FAR_AWAY {
        return cutoff;
    }
    (cutoff * lerp(AWAY_FROM_SUN_CUTOFF_GAIN, 1.0, toward_sun(cos_sun))).min(1.0)
}

/// How far a view ray at `cos_sun` is toward the sun: 0 from [`AWAY_FROM_SUN_COS`] out, 1
/// within [`TOWARD_SUN_COS`], linear between. [`ray_light_steps`] computes the same ramp in f32,
/// as the GPU counts its steps. WGSL twin: `toward_sun`.
pub fn toward_sun(cos_sun: f64) -> f64 {
    saturate((cos_sun - AWAY_FROM_SUN_COS) / (TOWARD_SUN_COS - AWAY_FROM_SUN_COS))
}

/// The sun's elevation, as the sine at the sample, below which a sample takes its sun from the
/// light march even where the cloud shadow map could give it ([`shadow_map_share`]): the map
/// holds each sun line's optical depth against altitude, and the long, nearly level sun lines
/// of a low sun cross several clouds between its knots. Sin 10°: the lowest sun at which the
/// map kept `MEDIUM` within its 5 % of the converged march in the bench's sunset view.
pub const SHADOW_MAP_MIN_SUN_MU: f64 = 0.173_648_177_666_930_33;

/// The sun's elevation, as the sine at the sample, from which the cloud shadow map gives all
/// of the optical depth it may give (sin 12°). Between [`SHADOW_MAP_MIN_SUN_MU`] and here its
/// share grows with the sine ([`shadow_map_share`]), so the clouds do not change at once, all
/// over the sky, at the instant the sun passes 10°.
pub const SHADOW_MAP_FULL_SUN_MU: f64 = 0.207_911_690_817_759_31;

/// Where the cloud shadow map has taken over from the light march on every view ray, as the
/// cosine of the angle to the sun (about 36.9°). Between [`TOWARD_SUN_COS`] (31.8°) and here a
/// sample's optical depth toward the sun is the light march's and the map's mixed in
/// proportion to the angle ([`shadow_map_share`]): a switch at one angle drew a ring around the
/// sun on the clouds, where the two differ.
pub const SHADOW_MAP_BLEND_COS: f64 = 0.8;

/// How much of a sample's optical depth toward the sun comes from the cloud shadow map
/// ([`MarchSettings::sun_from_shadow_map_m`]), 0–1, where the map covers the sample: none on a
/// view ray within about 32° of the sun ([`TOWARD_SUN_COS`]), whose forward-scattering peak
/// turns the map's blur of a thin, backlit edge into its brightest error, nor under a sun
/// lower than [`SHADOW_MAP_MIN_SUN_MU`]; all of it from [`SHADOW_MAP_BLEND_COS`] out under a
/// sun from [`SHADOW_MAP_FULL_SUN_MU`] up; between, the product of two shares that grow
/// linearly, with the cosine and with the sun's sine. WGSL twin: `shadow_map_share`.
pub fn shadow_map_share(cos_sun: f64, mu_sun: f64) -> f64 {
    // NaN counts as a low sun.
    if mu_sun.is_nan() || mu_sun < SHADOW_MAP_MIN_SUN_MU {
        return 0.0;
    }
    saturate((TOWARD_SUN_COS - cos_sun) / (TOWARD_SUN_COS - SHADOW_MAP_BLEND_COS))
        * saturate(
            (mu_sun - SHADOW_MAP_MIN_SUN_MU) / (SHADOW_MAP_FULL_SUN_MU - SHADOW_MAP_MIN_SUN_MU),
        )
}

/// A primary step thinner than this (optical thickness at its sample) counts as clear for the
/// edge search of the dense step after it.
pub const CLEAR_STEP_OPTICAL_DEPTH: f64 = 0.1;

/// Weight of the thin-parts march of a dense primary step of optical thickness `x` (against
/// one sample for the whole step): 0 up to [`MAX_STEP_OPTICAL_DEPTH`], 1 from twice that, and
/// linear between. WGSL twin: `dense_step_weight`.
pub fn dense_step_weight(x: f64) -> f64 {
    saturate(x / MAX_STEP_OPTICAL_DEPTH - 1.0)
}

/// Where in a part of a dense step, `length` metres long at extinction `sigma` (1/m), the part
/// samples its medium for a jitter `u` (0–1): the point whose depth splits the part's
/// transmittance-weighted length (`∫ e^(−σs) ds`) at `u`, `−ln(1 − u (1 − e^(−σℓ))) / σ`.
/// Averaged over jitters, one sample there integrates a homogeneous part exactly; a uniform
/// offset would weigh the part's far end, which the camera sees through `e^(−σℓ)`, as much as its
/// near end. Uniform where the part is optically thin. WGSL twin: `part_offset`.
pub fn part_offset(u: f64, sigma: f64, length: f64) -> f64 {
    let x = sigma * length;
    if x.is_nan() || x <= PART_OFFSET_THIN {
        return u * length;
    }
    (-(u * (-x).exp_m1()).ln_1p() / sigma).clamp(0.0, length)
}

/// Optical thickness below which [`part_offset`] places the sample uniformly: the weighted
/// offset is `u − u (1 − u) x / 2 + O(x²)` of the part, so the two differ there by at most
/// `x / 8` of it.
pub const PART_OFFSET_THIN: f64 = 1e-3;

/// Bisections that locate a cloud's edge between the last clear point and a dense step's
/// sample: the edge is found to 1/64 of that span.
pub const EDGE_SEARCH_STEPS: u32 = 6;

/// Extinction (1/m), scattering (1/m), the column around the point and the height-graded
/// ambient source of the simple light (scattering × sky radiance, RGB) of the medium at one
/// point.
#[derive(Clone, Copy, Debug, Default)]
struct Medium {
    extinction: f64,
    scattering: f64,
    column: CloudColumn,
    ambient: [f64; 3],
    /// The sky-light factors of the layers at the point, weighted by their scattering
    /// ([`SampleLights::sky_light`]); divided by `scattering` once summed.
    sky_light: [[f64; 3]; 2],
    /// The layers' [`MarchLayer::halo_share`] at the point, weighted by their scattering
    /// ([`SampleLights::halo_share`]); divided by `scattering` once summed.
    halo_share: f64,
}

/// What a ray sees: in-scattered radiance and view transmittance, composited as
/// `scene · transmittance + radiance`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct MarchResult {
    /// Radiance scattered toward the camera, RGB, in the units of
    /// [`MarchSettings::sun_illuminance`] per steradian, before exposure.
    pub radiance: [f64; 3],
    /// Fraction of the light behind the clouds that reaches the camera, 0–1.
    pub transmittance: f64,
    /// Where along the ray the medium hides what is behind it, metres: the mean distance of the
    /// steps weighted by the opacity each adds (`T_before − T_after`); infinity when the ray met
    /// no medium. The haze in front of this distance veils the clouds and the haze behind it is
    /// veiled by them ([`crate::reference::haze::composite`]).
    pub distance_m: f64,
}

impl MarchResult {
    /// Empty sky: no radiance, transmittance 1.
    pub const CLEAR: Self = Self {
        radiance: [0.0; 3],
        transmittance: 1.0,
        distance_m: f64::INFINITY,
    };
}

/// How many of a ray's steps an interval from `start_m` to `end_m` calls for, in metres of
/// steps at the camera: its length over the step's growth at its middle,
/// `(end − start) / (1 + step_growth · (start + end) / 2)`, the midpoint rule for
/// `∫ dt / (1 + step_growth · t)`. Steps grow with distance, so a far interval needs fewer per
/// metre than a near one. Computed in f32, as on the GPU. WGSL twin: `interval_measure`.
pub fn interval_measure(settings: &MarchSettings, start_m: f64, end_m: f64) -> f32 {
    let (start, end) = (start_m as f32, end_m as f32);
    let growth = (settings.step_growth as f32).max(0.0);
    (end - start) / (1.0 + growth * (0.5 * (start + end)))
}

/// Primary steps across an interval `span_m` metres long whose [`interval_measure`] is
/// `measure`, of a ray whose intervals' measures add up to `total`: the interval's share of
/// [`MarchSettings::primary_steps`] (clamped to `1..=MAX_PRIMARY_STEPS`), in proportion to its
/// measure and rounded up (all of them for the only interval), so that the steps are a budget per
/// ray however many layers it crosses and a near interval is not starved by a long far one; but
/// no more than one per [`MarchSettings::min_step_m`] (plus one). The counts are computed in f32,
/// as on the GPU. WGSL twin: `interval_steps`.
pub fn interval_steps(settings: &MarchSettings, span_m: f64, measure: f32, total: f32) -> u32 {
    let budget = settings.primary_steps.clamp(1, MAX_PRIMARY_STEPS);
    let mut steps = budget;
    if measure > 0.0 && total > measure {
        steps = ((budget as f32 * (measure / total)).ceil() as u32).clamp(1, budget);
    }
    if !is_positive(settings.min_step_m) || !is_positive(span_m) {
        return steps;
    }
    let fit = (span_m / settings.min_step_m).min(f64::from(MAX_PRIMARY_STEPS)) as f32;
    steps.min(fit as u32 + 1)
}

/// One ray's state and constants, shared by the steps of [`march_clouds`].
#[derive(Clone)]
struct Ray<'a> {
    textures: &'a CloudTextures,
    /// The cloud shadow map, for far samples' sun ([`MarchSettings::sun_from_shadow_map_m`]).
    shadow: Option<&'a ShadowMapImage>,
    settings: &'a MarchSettings,
    layers: &'a [MarchLayer],
    camera_altitude_m: f64,
    up: [f64; 3],
    mu: f64,
    direction: [f64; 3],
    horizontal_direction: [f64; 2],
    /// Cosine of the angle between the view ray and the sun, for the phase function.
    cos_sun: f64,
    /// The view transmittance the ray stops at ([`ray_transmittance_cutoff`]).
    cutoff: f64,
    /// The light steps of the ray's samples before `light_steps_at` ([`ray_light_steps`]).
    light_steps: u32,
    /// The δ-Eddington constants of the settings' phase.
    phase: EddingtonPhase,
    /// The phase at `cos_sun` for light the forward peak has turned ([`peak_spread_phase`]).
    spread_phase: f64,
    sun_on: bool,
    jitter: f64,
    /// Optical depth from the camera so far: summed, not multiplied into the transmittance,
    /// so thin media keep their precision (a product of many `e^(−x)` drifts in f32).
    optical_depth: f64,
    /// `e^(−optical_depth)`.
    transmittance: f64,
    radiance: [f64; 3],
    /// The last cloudy step's source seen through the true medium over its extinction, `S /
    /// σt`: with [`Ray::scaled_tail`], the radiance a medium like it would add beyond the point
    /// where the march stops early (see [`Ray::march_interval`]).
    tail: [f64; 3],
    /// The same for the source seen through the scaled medium, over the scaled extinction
    /// `(1 − f) σt`.
    scaled_tail: [f64; 3],
    /// The part of [`Ray::radiance`] seen through the scaled medium.
    scaled_radiance: [f64; 3],
    /// Σ (opacity a step adds) · (its distance), and Σ opacity: [`MarchResult::distance_m`].
    opacity_distance: f64,
    opacity: f64,
}

impl Ray<'_> {
    fn altitude(&self, t: f64) -> f64 {
        altitude_along_ray(
            self.camera_altitude_m,
            self.mu,
            t,
            self.settings.planet_radius_m,
        )
    }

    fn horizontal(&self, t: f64) -> [f64; 2] {
        self.horizontal_direction.map(|c| c * t)
    }

    /// Records that the medium at distance `t` hid `opacity` more of what is behind it.
    fn add_opacity(&mut self, opacity: f64, t: f64) {
        self.opacity_distance += opacity * t;
        self.opacity += opacity;
    }

    /// The transmittance of the δ-scaled medium so far, `e^(−(1 − f) τ)`.
    fn scaled_transmittance(&self) -> f64 {
        (-(1.0 - self.phase.forward_fraction) * self.optical_depth).exp()
    }

    /// The transmittance the early exit compares with the cut-off: with multiple scattering
    /// the scaled medium's, which lets the light scattered in the phase's forward peak through
    /// far deeper into a cloud than the true medium lets the direct light (`e^(−(1 − f) τ)`
    /// against `e^(−τ)`: a backlit cloud's glow and the sky behind it still show at `T` = 1 %).
    /// WGSL twin: `cutoff_transmittance`.
    fn cutoff_transmittance(&self) -> f64 {
        if self.settings.multiple_scattering {
            self.scaled_transmittance()
        } else {
            self.transmittance
        }
    }

    /// Adds the light of what lies behind the medium scattered in the phase's forward peak,
    /// once the ray is marched: the scaled medium lets `e^(−(1 − f) τ)` of it through, the true
    /// one (which the compositor applies to the scene) `e^(−τ)`, so the ray gains `B (e^(−(1 −
    /// f) τ) − e^(−τ))`. The peak is tens of degrees wide, so `B` is the mean radiance around
    /// the ray's end, not the scene's pixel. Where the ray ends on a scene object or the ground
    /// inside a cloud or fog (`t_end` finite, within the shell of a layer), `B` is the mean glow
    /// of the scaled medium along the ray, its radiance over its opacity `1 − e^(−(1 − f) τ)`:
    /// in a uniform medium the light in front of the object is then `1 − e^(−τ)` of the
    /// medium's glow, so a black object at the visibility distance keeps Koschmieder's
    /// contrast. Elsewhere `B` is the sky above for a
    /// ray looking up and the ground below for one looking down
    /// ([`MarchSettings::ambient_top`], [`MarchSettings::ambient_bottom`]), blended by the
    /// view's cosine. Nothing without [`MarchSettings::multiple_scattering`], after an early
    /// stop (nothing behind shows through) or without cloud on the ray.
    fn add_background(&mut self, t_end: f64) {
        if !self.settings.multiple_scattering
            || !is_positive(self.transmittance)
            || !is_positive(self.optical_depth)
        {
            return;
        }
        let scaled = self.scaled_transmittance();
        let gain = scaled - self.transmittance;
        let scaled_opacity = -(-(1.0 - self.phase.forward_fraction) * self.optical_depth).exp_m1();
        let altitude = self.altitude(t_end);
        let inside = t_end.is_finite()
            && self.layers.iter().any(|layer| {
                layer_is_active(layer) && altitude >= layer.base_m && altitude <= layer.top_m
            });
        let behind = saturate(0.5 + 0.5 * self.mu);
        for c in 0..3 {
            let background = if inside {
                self.scaled_radiance[c] / scaled_opacity
            } else {
                lerp(
                    self.settings.ambient_bottom[c],
                    self.settings.ambient_top[c],
                    behind,
                )
            };
            self.radiance[c] += gain * background;
        }
    }

    /// [`MarchResult::distance_m`] of the march so far.
    fn distance(&self) -> f64 {
        if is_positive(self.opacity) {
            self.opacity_distance / self.opacity
        } else {
            f64::INFINITY
        }
    }

    /// Sum of the cheap (base-only) extinction of every layer at distance `t`.
    fn cheap_extinction(&self, t: f64) -> f64 {
        let altitude = self.altitude(t);
        let horizontal = self.horizontal(t);
        let footprint = t * self.settings.pixel_angle_rad;
        total_extinction(
            self.textures,
            self.layers,
            horizontal,
            altitude,
            footprint,
            false,
        )
    }

    /// The medium at distance `t`, full detail: extinction, scattering and the ambient source.
    fn medium(&self, t: f64) -> Medium {
        let settings = self.settings;
        let altitude = self.altitude(t);
        let horizontal = self.horizontal(t);
        let footprint = t * settings.pixel_angle_rad;
        let mut medium = Medium::default();
        for layer in self.layers {
            let sigma = layer_density(self.textures, layer, horizontal, altitude, footprint, true);
            if sigma > 0.0 {
                let sigma_s = sigma * scattering_albedo(layer);
                // Ambient sky light grows from the base to the top of the layer (Pérez Martín 2022,
                // "Day / Night Cycle").
                let h = saturate((altitude - layer.base_m) / (layer.top_m - layer.base_m));
                for (c, a) in medium.ambient.iter_mut().enumerate() {
                    *a += sigma_s
                        * lerp(
                            settings.ambient_bottom[c] * layer.sky_light_bottom[c],
                            settings.ambient_top[c] * layer.sky_light_top[c],
                            h,
                        );
                    medium.sky_light[0][c] += sigma_s * layer.sky_light_top[c];
                    medium.sky_light[1][c] += sigma_s * layer.sky_light_bottom[c];
                }
                medium.extinction += sigma;
                medium.scattering += sigma_s;
                medium.halo_share += sigma_s * layer.halo_share;
                // The column of a cloud at full density above and below (a cloud's edge is
                // thin, the cloud behind it is not).
                let thickness = layer.top_m - layer.base_m;
                let full = layer.extinction * thickness;
                let below = profile_column(layer, h);
                medium.column.above += full * (profile_column(layer, 1.0) - below);
                medium.column.below += full * below;
            }
        }
        if medium.scattering > 0.0 {
            for factor in medium.sky_light.iter_mut().flatten() {
                *factor /= medium.scattering;
            }
            medium.halo_share /= medium.scattering;
        }
        medium
    }

    /// One full-detail step over `[ta, tb]`, sampled at the jittered point; returns the optical
    /// thickness `x` of the step at that point (0: no cloud).
    ///
    /// A dense step, whose optical thickness `x` at that point exceeds [`MAX_STEP_OPTICAL_DEPTH`],
    /// is marched again in parts: the light of a dense cloud comes from its first metres, which
    /// one long step would sample anywhere along its length. `clear_from` is where the search
    /// for the cloud's edge starts: the sample of the step before when that step was clear or
    /// thinner than [`CLEAR_STEP_OPTICAL_DEPTH`], or the start of the march's detail run, and
    /// `None` inside a cloud. The edge is then searched for between it and
    /// this step's sample by [`EDGE_SEARCH_STEPS`] bisections. From the edge (or from `ta`
    /// inside a cloud) the march takes parts of optical thickness [`MAX_STEP_OPTICAL_DEPTH`] at
    /// the step's sample, each sampled at the [`part_offset`] of the jitter, at most
    /// [`MAX_SUBSTEPS`] (the last reaching `tb`), until the transmittance cut-off.
    ///
    /// Between `x` = [`MAX_STEP_OPTICAL_DEPTH`] and twice that the result is the one-sample
    /// step and the parts mixed in proportion ([`dense_step_weight`]), so it is continuous in the
    /// density: a step whose density lies at the threshold gives the same light whichever side
    /// of it rounding puts the density (the GPU's 8-bit noise against the reference's f64).
    fn step(&mut self, ta: f64, tb: f64, clear_from: Option<f64>) -> f64 {
        let dt = tb - ta;
        let t = ta + self.jitter * dt;
        let medium = self.medium(t);
        if !is_positive(medium.extinction) {
            return 0.0;
        }
        let x = medium.extinction * dt;
        let weight = dense_step_weight(x);
        if !is_positive(weight) {
            self.integrate(t, dt, &medium);
            return x;
        }
        // The one-sample step, kept to mix in below the full weight.
        let one = (weight < 1.0).then(|| {
            let mut one = self.clone();
            one.integrate(t, dt, &medium);
            one
        });
        let mut from = ta;
        if let Some(clear) = clear_from.filter(|&c| c < t) {
            let (mut lo, mut hi) = (clear, t);
            for _ in 0..EDGE_SEARCH_STEPS {
                let mid = 0.5 * (lo + hi);
                if is_positive(self.medium(mid).extinction) {
                    hi = mid;
                } else {
                    lo = mid;
                }
            }
            from = lo;
        }
        let step_extinction = medium.extinction;
        let length = MAX_STEP_OPTICAL_DEPTH / step_extinction;
        let mut cloudy = 0;
        for i in 0..MAX_PARTS {
            if !is_positive(tb - from) {
                break;
            }
            // Empty parts (the clear gap after a wisp the search found) do not count toward
            // MAX_SUBSTEPS; the last part reaches tb.
            let to = if i + 1 == MAX_PARTS || cloudy + 1 >= MAX_SUBSTEPS {
                tb
            } else {
                (from + length).min(tb)
            };
            let t = from + part_offset(self.jitter, step_extinction, to - from);
            let medium = self.medium(t);
            if is_positive(medium.extinction) {
                self.integrate(t, to - from, &medium);
                cloudy += 1;
                if self.cutoff_transmittance() <= self.cutoff {
                    break;
                }
            }
            from = to;
        }
        if let Some(one) = one {
            // Parts that found no cloud leave the tail to the one-sample step.
            if cloudy == 0 {
                self.tail = one.tail;
                self.scaled_tail = one.scaled_tail;
            }
            self.mix_with(&one, 1.0 - weight);
        }
        x
    }

    /// Moves what the march has gathered a fraction `amount` (0–1) of the way toward `other`'s:
    /// optical depth, radiance, tail and opacity, linearly.
    fn mix_with(&mut self, other: &Ray<'_>, amount: f64) {
        self.optical_depth = lerp(self.optical_depth, other.optical_depth, amount);
        self.transmittance = (-self.optical_depth).exp();
        for c in 0..3 {
            self.radiance[c] = lerp(self.radiance[c], other.radiance[c], amount);
            self.tail[c] = lerp(self.tail[c], other.tail[c], amount);
            self.scaled_tail[c] = lerp(self.scaled_tail[c], other.scaled_tail[c], amount);
            self.scaled_radiance[c] =
                lerp(self.scaled_radiance[c], other.scaled_radiance[c], amount);
        }
        self.opacity_distance = lerp(self.opacity_distance, other.opacity_distance, amount);
        self.opacity = lerp(self.opacity, other.opacity, amount);
    }

    /// Integrates `medium`, sampled at `t`, over a step `dt` long: the light toward the sun,
    /// the source, and the analytic integral across the step.
    fn integrate(&mut self, t: f64, dt: f64, medium: &Medium) {
        let settings = self.settings;
        let Medium {
            extinction,
            scattering,
            column,
            ambient,
            sky_light,
            halo_share,
        } = *medium;
        let altitude = self.altitude(t);
        let footprint = t * settings.pixel_angle_rad;
        let position = scale(self.direction, t);
        let mu_sun = point_mu_sun(
            settings,
            self.camera_altitude_m,
            self.up,
            position,
            altitude,
        );
        let mut sun_optical_depth_at = None;
        let mut sun_above_depth = 0.0;
        let light_steps = light_steps_at(
            self.light_steps,
            self.transmittance,
            self.cutoff_transmittance(),
            self.cutoff,
        );
        if self.sun_on {
            let light_march = |max_distance: f64, steps: u32| {
                sun_optical_depth(
                    self.textures,
                    settings,
                    self.layers,
                    self.camera_altitude_m,
                    self.up,
                    position,
                    altitude,
                    footprint,
                    max_distance,
                    steps,
                    LIGHT_SAMPLE_OFFSET,
                    self.jitter,
                )
            };
            // A far sample marches only the first texels toward the sun and reads the rest of
            // the way from the shadow map, where the map covers it and may light it.
            let share = if t >= settings.sun_from_shadow_map_m {
                shadow_map_share(self.cos_sun, mu_sun)
            } else {
                0.0
            };
            let from_map = self.shadow.filter(|_| share > 0.0).and_then(|map| {
                let near = SHADOW_MAP_NEAR_TEXELS * map.frame.texel_m();
                let end = add(position, scale(settings.sun_direction, near));
                let end_altitude =
                    altitude_along_ray(altitude, mu_sun, near, settings.planet_radius_m);
                let far = map.sun_optical_depth(end, end_altitude)?;
                let near_depth = light_march(near, light_steps.min(SHADOW_MAP_NEAR_STEPS));
                Some(if near_depth < 0.0 {
                    near_depth
                } else {
                    near_depth + far
                })
            });
            // A full light march then crosses the layers above the sample's own (the map holds
            // them already): the optical depth and that part of it.
            let marched = || {
                let own = light_march(f64::INFINITY, light_steps);
                if own < 0.0 {
                    return (own, 0.0);
                }
                let above = higher_layers_optical_depth(
                    self.textures,
                    settings,
                    self.layers,
                    self.up,
                    position,
                    altitude,
                    mu_sun,
                    footprint,
                    light_steps,
                );
                (own + above, above)
            };
            let (optical_depth, above) = match from_map {
                Some(depth) if share >= 1.0 => (depth, 0.0),
                // Between the two, each in proportion (the ground blocks both or neither).
                Some(depth) => match marched() {
                    (marched_depth, marched_above) if depth >= 0.0 && marched_depth >= 0.0 => (
                        lerp(marched_depth, depth, share),
                        (1.0 - share) * marched_above,
                    ),
                    _ => (-1.0, 0.0),
                },
                None => marched(),
            };
            sun_above_depth = above;
            if optical_depth >= 0.0 {
                sun_optical_depth_at = Some(optical_depth);
            }
        }
        let mut source = sample_source(
            settings,
            &self.phase,
            scattering,
            column,
            ambient,
            &SampleLights {
                sun_optical_depth: sun_optical_depth_at,
                mu_sun,
                cos_sun: self.cos_sun,
                spread_phase: self.spread_phase,
                mu_view: self.mu,
                sun_above_depth,
                sky_light,
                halo_share,
                view_optical_depth: self.optical_depth,
            },
        );
        let flash = flash_source(settings, &self.phase, position, extinction);
        if flash > 0.0 {
            for c in 0..3 {
                source.scaled[c] += scattering * flash;
            }
        }
        // Hillaire 2016: ∫ T(x) S dx over the step = T · S · dt · (1 − e^(−σt dt)) / (σt dt),
        // once through the true medium and once through the scaled one.
        let scaled = 1.0 - self.phase.forward_fraction;
        let x = extinction * dt;
        let weight = self.transmittance * dt * mean_step_transmittance(x);
        let scaled_weight =
            (-scaled * self.optical_depth).exp() * dt * mean_step_transmittance(scaled * x);
        let before = self.transmittance;
        self.optical_depth += x;
        self.transmittance = (-self.optical_depth).exp();
        for c in 0..3 {
            self.radiance[c] += weight * source.direct[c] + scaled_weight * source.scaled[c];
            self.scaled_radiance[c] += scaled_weight * source.scaled[c];
            self.tail[c] = source.direct[c] / extinction;
            self.scaled_tail[c] = source.scaled[c] / (scaled * extinction);
        }
        self.add_opacity(before - self.transmittance, t);
    }

    /// Marches `[start, end]` in `primary_steps` steps growing with distance, with
    /// Schneider 2015's two-level stepping; returns false once the transmittance cut-off is hit
    /// (after adding the tail estimate and setting the transmittance to 0).
    ///
    /// Cheap samples, one per [`CHEAP_STRIDE`] steps, look for cloud. One that finds some sends
    /// the march back a stride, to the start of the stride that holds the last cheap sample that
    /// found none (but never onto a step already marched), and on in full detail at least to the
    /// end of the stride that found cloud; after [`EMPTY_STEPS_TO_CHEAP`] empty steps it strides
    /// again.
    /// Backing up makes the first detail sample in a cloud lie uniformly within one step of its
    /// edge whatever the grid's phase, so the mean over jitters has no pattern tied to the grid.
    fn march_interval(&mut self, start: f64, end: f64, total: f32) -> bool {
        let settings = self.settings;
        let measure = interval_measure(settings, start, end);
        let steps = interval_steps(settings, end - start, measure, total);
        let growth = settings.step_growth.max(0.0);
        let beta = growth * (end - start) / (1.0 + growth * start);
        let n = f64::from(steps);
        let boundary = |k: u32| start + (end - start) * step_warp(f64::from(k) / n, beta);
        let cutoff = self.cutoff;
        let mut k = 0;
        let mut cheap = true;
        let mut empty = 0;
        // The first step not yet marched in detail: a back-up never marches a step twice.
        let mut unmarched = 0;
        // The end of the stride whose cheap sample found cloud: detail goes on at least to here.
        let mut detail_until = 0;
        // Where the next dense step's edge search starts (see `step`); `None` inside a cloud.
        let mut clear_from = None;
        for _ in 0..march_passes(steps) {
            if k >= steps {
                break;
            }
            if cheap {
                let k2 = (k + CHEAP_STRIDE).min(steps);
                let (ta, tb) = (boundary(k), boundary(k2));
                if self.cheap_extinction(ta + self.jitter * (tb - ta)) > 0.0 {
                    // Cloud ahead. It may begin anywhere after the last cheap sample that found
                    // none, in the stride before this one: march from there in full detail.
                    cheap = false;
                    empty = 0;
                    detail_until = k2;
                    k = k.saturating_sub(CHEAP_STRIDE).max(unmarched);
                    clear_from = Some(boundary(k));
                } else {
                    k = k2;
                }
                continue;
            }
            let (ta, tb) = (boundary(k), boundary(k + 1));
            let x = self.step(ta, tb, clear_from);
            // A thin step counts as clear for the next one's edge search (it may count its last
            // part twice, less than CLEAR_STEP_OPTICAL_DEPTH): whether a wisp's density rounds
            // to zero then changes little.
            clear_from = (x < CLEAR_STEP_OPTICAL_DEPTH).then_some(ta + self.jitter * (tb - ta));
            if x > 0.0 {
                empty = 0;
                if self.cutoff_transmittance() <= cutoff {
                    // Stopping early drops the light the rest of the medium would scatter
                    // toward the camera, up to `T · S / σt` (1 % of a uniform medium's radiance
                    // at a cut-off of 0.01: half the contrast of a target at the visibility
                    // distance in fog). Add it as if the medium went on like the last step, and
                    // let nothing behind show through.
                    let scaled = self.scaled_transmittance();
                    for c in 0..3 {
                        self.radiance[c] +=
                            self.transmittance * self.tail[c] + scaled * self.scaled_tail[c];
                    }
                    self.add_opacity(self.transmittance, boundary(k + 1));
                    self.transmittance = 0.0;
                    return false;
                }
            } else {
                empty += 1;
                if empty >= EMPTY_STEPS_TO_CHEAP && k + 1 >= detail_until {
                    cheap = true;
                }
            }
            k += 1;
            unmarched = k;
        }
        true
    }
}

/// Loop passes that always finish an interval of `steps` steps in the march (`march_interval`): a
/// cheap pass advances a stride or switches to detail, which backs up at most one stride and then
/// advances past the stride that found cloud; so detail passes number at most `steps` plus one
/// stride per switch, and switches at most `steps / CHEAP_STRIDE + 1`. The WGSL twin's loop guard
/// is the same bound.
pub const fn march_passes(steps: u32) -> u32 {
    4 * steps + 4 * CHEAP_STRIDE + 2
}

/// Marches one view ray through the cloud layers: the in-scattered radiance and the view
/// transmittance, composited as `scene · T + L`.
///
/// The camera is at `camera_altitude_m` above the ground with local vertical `up`; `direction`
/// is the unit view ray (world space), `t_max` the distance to the scene along it (infinity for
/// the sky), `jitter` the offset of each sample within its step, 0–1 ([`ray_start_jitter`]).
/// The ray visits only the intervals where it crosses active layers ([`next_cloud_interval`],
/// stopped at the ground), which share [`MarchSettings::primary_steps`] in proportion to their
/// lengths ([`interval_steps`]), in steps that grow with distance; cheap base-only samples stride through empty space and full-detail samples light
/// the cloud (Pérez Martín 2022, "Optimization"); the march stops once the transmittance reaches
/// [`MarchSettings::transmittance_cutoff`]. At most `2 · layers + 1` intervals are visited.
/// `shadow` is the cloud shadow map, read for the sun of samples beyond
/// [`MarchSettings::sun_from_shadow_map_m`]. WGSL twin: `march_clouds`.
#[allow(clippy::too_many_arguments)]
pub fn march_clouds(
    textures: &CloudTextures,
    settings: &MarchSettings,
    layers: &[MarchLayer],
    camera_altitude_m: f64,
    up: [f64; 3],
    direction: [f64; 3],
    t_max: f64,
    jitter: f64,
    shadow: Option<&ShadowMapImage>,
) -> MarchResult {
    let radius = settings.planet_radius_m;
    let mu = dot(direction, up).clamp(-1.0, 1.0);
    let t_end = t_max.min(ground_distance(camera_altitude_m, mu, radius));
    if !is_positive(t_end) {
        return MarchResult::CLEAR;
    }
    let axes = horizontal_axes(up);
    let cos_sun = dot(direction, settings.sun_direction).clamp(-1.0, 1.0);
    let phase = eddington_phase(settings);
    let mut ray = Ray {
        textures,
        shadow,
        settings,
        layers,
        camera_altitude_m,
        up,
        mu,
        direction,
        horizontal_direction: [dot(direction, axes[0]), dot(direction, axes[1])],
        cos_sun,
        light_steps: ray_light_steps(
            settings.light_steps,
            cos_sun,
            settings.light_steps_away_from_sun,
            saturate(jitter),
        ),
        cutoff: ray_transmittance_cutoff(settings.transmittance_cutoff, cos_sun, t_max),
        phase,
        spread_phase: peak_spread_phase(settings, &phase, cos_sun),
        sun_on: settings.sun_illuminance.iter().any(|&e| e > 0.0),
        jitter: saturate(jitter),
        optical_depth: 0.0,
        transmittance: 1.0,
        radiance: [0.0; 3],
        tail: [0.0; 3],
        scaled_tail: [0.0; 3],
        scaled_radiance: [0.0; 3],
        opacity_distance: 0.0,
        opacity: 0.0,
    };
    // The primary steps are a budget for the whole ray, shared by its intervals.
    let mut total = 0.0;
    let mut t = 0.0;
    for _ in 0..=2 * layers.len() {
        let [start, end] = next_cloud_interval(layers, radius, camera_altitude_m, mu, t, t_end);
        if !is_positive(end - start) {
            break;
        }
        total += interval_measure(settings, start, end);
        t = end;
    }
    let mut t = 0.0;
    for _ in 0..=2 * layers.len() {
        let [start, end] = next_cloud_interval(layers, radius, camera_altitude_m, mu, t, t_end);
        if !is_positive(end - start) || !ray.march_interval(start, end, total) {
            break;
        }
        t = end;
    }
    ray.add_background(t_end);
    let result = MarchResult {
        radiance: ray.radiance,
        transmittance: ray.transmittance,
        distance_m: ray.distance(),
    };
    if settings.clear_air {
        let air = clear_air_transmittance(camera_altitude_m, mu, result.distance_m, radius);
        fade_into_air(result, lerp(air, 1.0, sun_disc_share(cos_sun)))
    } else {
        result
    }
}

/// Within this angle of the sun, degrees, a view ray's clouds do not fade into the air
/// ([`sun_disc_share`]). WGSL twin: `SUN_DISC_NO_FADE_DEG`.
pub const SUN_DISC_NO_FADE_DEG: f64 = 1.0;

/// From this angle of the sun on, degrees, a view ray's clouds fade into the air in full
/// ([`sun_disc_share`]). WGSL twin: `SUN_DISC_FULL_FADE_DEG`.
pub const SUN_DISC_FULL_FADE_DEG: f64 = 2.0;

/// How much of the clear air's fade ([`fade_into_air`]) a view ray at `cos_sun` (the cosine of
/// its angle to the sun) is spared: 1 within [`SUN_DISC_NO_FADE_DEG`] of the sun, 0 from
/// [`SUN_DISC_FULL_FADE_DEG`] on, linear in the cosine between. The fade shows what lies behind
/// a cloud in place of the air's light in front of it, which holds for the sky but not for the
/// sun's disc (0.53° across), thousands of times brighter: faded, a cloud in front of the sun
/// would let the disc through. WGSL twin: `sun_disc_share`.
pub fn sun_disc_share(cos_sun: f64) -> f64 {
    let inner = SUN_DISC_NO_FADE_DEG.to_radians().cos();
    let outer = SUN_DISC_FULL_FADE_DEG.to_radians().cos();
    saturate((cos_sun - outer) / (inner - outer))
}

/// Steps of [`clear_air_transmittance`]'s midpoint rule. WGSL twin: `CLEAR_AIR_STEPS`.
pub const CLEAR_AIR_STEPS: u32 = 12;

/// Transmittance of the clear air at 550 nm along a view ray from a camera `camera_altitude_m`
/// above the ground (`mu` the cosine of the ray's angle to the vertical) to `distance_m`:
/// `e^(−τ)`, with `τ` the integral of the Rayleigh and Mie extinction of clean air
/// ([`clear_air_extinction`]: [`CLEAR_AIR_RAYLEIGH_EXTINCTION_PER_M`] and
/// [`CLEAR_AIR_MIE_EXTINCTION_PER_M`], falling off with altitude over [`RAYLEIGH_SCALE_HEIGHT_M`]
/// and [`MIE_SCALE_HEIGHT_M`]), by
/// the midpoint rule over [`CLEAR_AIR_STEPS`] steps with boundaries at `d (k/n)²` (short near
/// the camera, where a rising ray's air is densest) on the curved planet. 1 for a
/// distance that is not positive and finite (no cloud). Computed in f32 on the GPU. WGSL twin:
/// `clear_air_transmittance`.
pub fn clear_air_transmittance(
    camera_altitude_m: f64,
    mu: f64,
    distance_m: f64,
    planet_radius_m: f64,
) -> f64 {
    if !(distance_m > 0.0 && distance_m.is_finite()) {
        return 1.0;
    }
    let n = f64::from(CLEAR_AIR_STEPS);
    let optical_depth: f64 = (0..CLEAR_AIR_STEPS)
        .map(|k| {
            let s0 = distance_m * (f64::from(k) / n).powi(2);
            let s1 = distance_m * (f64::from(k + 1) / n).powi(2);
            let s = 0.5 * (s0 + s1);
            clear_air_extinction(altitude_along_ray(
                camera_altitude_m,
                mu,
                s,
                planet_radius_m,
            )) * (s1 - s0)
        })
        .sum();
    (-optical_depth).exp()
}

/// The clouds of `result` seen through clear air of transmittance `air` in front of them,
/// which lets through `air` of their light and adds `1 − air` of the light behind them in
/// place of what they hide: radiance `air · L`, transmittance `1 − air · (1 − T)`. The air's
/// own light in front of the clouds is taken to be that share of the light behind them (the
/// sky or the scene, which carries the air's light to its own distance): exact for clouds in
/// front of a distant horizon, whose radiance is the air light of a long path (Koschmieder
/// 1924). So distant clouds thin into the sky and the far hills as a photograph shows them.
/// The composite `scene · T + L` does the rest. Where what lies behind is far brighter than
/// the air, this shows it through the cloud: the sun's disc, which [`march_clouds`] spares
/// ([`sun_disc_share`]). WGSL twin: `fade_into_air`.
pub fn fade_into_air(result: MarchResult, air: f64) -> MarchResult {
    let air = air.clamp(0.0, 1.0);
    MarchResult {
        radiance: result.radiance.map(|l| air * l),
        transmittance: 1.0 - air * (1.0 - result.transmittance),
        distance_m: result.distance_m,
    }
}

/// The light steps of a view ray's samples (before `light_steps_at`) for a ray at `cos_sun`
/// (the cosine of its angle to the sun): all of `light_steps` within about 32° of the sun
/// ([`TOWARD_SUN_COS`]), the share `away_share` (clamped to 0–1, NaN: 1) of them from 60° on
/// ([`AWAY_FROM_SUN_COS`]), linear between, at least 1 (0 for 0). The share is rounded down
/// after adding `jitter` (0–1, the ray's [`ray_start_jitter`](super::ray_start_jitter); 0.5 rounds to the nearest): an
/// integer count that changed at fixed angles would draw rings around the sun where the light
/// march's error jumps, and with the jitter the frames that the temporal accumulation averages
/// take the counts on either side in proportion, so the mean count, and the light, changes
/// continuously with the angle. An error in a
/// sample's sun optical depth changes its light in proportion to the phase function toward the
/// camera, which away from the sun is a small share of what it is near it: there the sky light
/// and the diffuse light, which the optical depth changes far less, carry the sample, and fewer
/// light steps cost the image little. Computed in f32 on both sides. WGSL twin: `ray_light_steps`.
pub fn ray_light_steps(light_steps: u32, cos_sun: f64, away_share: f64, jitter: f64) -> u32 {
    let away = away_from_sun_share(away_share);
    let toward = ((cos_sun as f32 - AWAY_FROM_SUN_COS as f32)
        / (TOWARD_SUN_COS as f32 - AWAY_FROM_SUN_COS as f32))
        .clamp(0.0, 1.0);
    let share = away + (1.0 - away) * toward;
    if light_steps == 0 {
        return 0;
    }
    ((light_steps as f32 * share + jitter as f32).floor() as u32).clamp(1, light_steps)
}

/// [`MarchSettings::light_steps_away_from_sun`] as [`ray_light_steps`] reads it, in f32: clamped
/// to 0–1, NaN 1 (every light step). The GPU's uniform holds this value.
pub fn away_from_sun_share(away_share: f64) -> f32 {
    if away_share.is_nan() {
        1.0
    } else {
        away_share.clamp(0.0, 1.0) as f32
    }
}

/// The light steps of a sample, from the view ray's `transmittance` and `cutoff_transmittance`
/// before it ([`Ray::cutoff_transmittance`]) and the early exit's `cutoff`:
///
/// - past the true medium's cut-off (`transmittance <= cutoff`), a quarter of `light_steps`
///   (at least 4). There the march goes on only for the δ-scaled light of multiple scattering
///   (see [`Ray::cutoff_transmittance`]), and the light march is most of a sample's cost;
/// - with an early exit (`cutoff > 0`) and `cutoff_transmittance` below
///   [`FULL_LIGHT_STEPS_TRANSMITTANCE`], `light_steps` times their ratio, rounded up (at least
///   4), if that is fewer;
/// - all of `light_steps` otherwise.
///
/// WGSL twin: `light_steps_at`.
pub(crate) fn light_steps_at(
    light_steps: u32,
    transmittance: f64,
    cutoff_transmittance: f64,
    cutoff: f64,
) -> u32 {
    let fewest = light_steps.min(PAST_CUTOFF_MIN_LIGHT_STEPS);
    let mut steps = light_steps;
    if transmittance <= cutoff {
        steps = (light_steps / PAST_CUTOFF_LIGHT_STEP_DIVISOR).max(fewest);
    }
    if cutoff > 0.0 && cutoff_transmittance < FULL_LIGHT_STEPS_TRANSMITTANCE {
        let share = cutoff_transmittance / FULL_LIGHT_STEPS_TRANSMITTANCE;
        steps = steps.min(((f64::from(light_steps) * share).ceil() as u32).max(fewest));
    }
    steps
}
