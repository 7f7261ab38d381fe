//! The cloud ray-march in f64: the CPU twin of `src/render/march/clouds.wgsl`.
//!
//! Every public function here has a WGSL function of the same name in the shader, and each points
//! at the other. The GPU march is tested against this module, so a change to a formula must be
//! made in both places. It is also the engine of the CPU queries a game asks ("is the camera in a
//! cloud?"): [`density_at`], [`transmittance_to_sun`] and [`is_in_cloud`].
//!
//! # Geometry
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
//!
//! # Density (Pérez Martín 2022, "Density Model"; Schneider 2015)
//!
//! [`layer_density`]: the height fraction in the layer picks a density from the layer's
//! profile (Aetherius' shape-altering curve, piecewise linear here); the weather noise sets a
//! local coverage ([`local_coverage`] per weather texel, filtered by [`weather_coverage`]); the
//! base noise (Perlin-Worley carved by Worley fBm,
//! [`base_shape`]) times the profile is remapped by that coverage; the detail noise erodes the
//! edges, wispy at the bottom and billowy at the top ([`detail_erosion`]). The result, 0–1, scales
//! the layer's extinction. [`MarchLayer::shape_strength`] blends the noise in: at 0 a layer is a
//! homogeneous slab whose density is the profile shaped by coverage only, which has a closed form
//! ([`homogeneous_slab`]).
//!
//! # Light (Hillaire 2016; Wrenninge 2013; Pérez Martín 2022, "Cloud Lighting")
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
//!
//! # Textures
//!
//! [`CloudTextures`] holds exactly the texels the GPU samples: the base and detail noise of
//! [`super::noise`] rounded to multiples of `2^-11` and stored as half floats (`Rgba16Float`,
//! [`super::noise::quantize_noise`]), with mip levels box-filtered from the rounded level above
//! and rounded again, and the weather noise quantised to `Rgba8Unorm` bytes. Sampling is
//! trilinear with repeat addressing and linear mip interpolation, texel centres at
//! `(i + 0.5) / n`, as a `linear`/`linear`/`linear`, `repeat` sampler does. The only differences
//! from the GPU are then f32 against f64 and the GPU's filtering precision.
//!
//! That precision is why the 3D noise is stored as half floats. The coverage and erosion remaps
//! amplify small differences in the filtered noise (the coverage ramp about sevenfold, the
//! carving of heaps inside cloudy patches fourfold more), and lavapipe (llvmpipe, the software
//! Vulkan of the test machines) filters `Rgba8Unorm` in 8-bit fixed point and rounds the result to
//! 1/255 (measured: up to 1.5/255 from the exact trilinear value, 0.35/255 on average). Half
//! floats are filtered in float. The weather noise stays in bytes: the shader filters the local
//! coverage itself from four texel loads, exactly as [`weather_coverage`] does. Single rays can
//! still differ by a few per cent where a cheap sample flips between zero and non-zero, so
//! compare images, not single rays.

use super::noise::{
    NoiseRecipe, downsample_3d, generate_base, generate_detail, generate_weather, mip_level_count,
    mip_size, quantize_noise, quantize_unorm8,
};
use super::shadow::ShadowMapImage;

/// Earth's mean radius in metres, the default [`MarchSettings::planet_radius_m`].
pub const EARTH_RADIUS_M: f64 = 6_371_000.0;

/// Most far-coverage entries a layer carries ([`MarchLayer::far`]). WGSL twin:
/// `MAX_FAR_COVERAGES`.
pub const MAX_FAR_COVERAGES: usize = 2;

/// Where the blend toward a far place's coverage starts, as a fraction of the way from the near
/// place to the far one: the near forecast holds unchanged over the first 30 % (the foreground),
/// and the far forecast is complete at the far place and beyond ([`layer_coverage`]). WGSL twin:
/// `FAR_BLEND_START`.
pub const FAR_BLEND_START: f64 = 0.3;

/// Most profile control points a layer carries ([`MarchLayer::profile`]).
pub const MAX_PROFILE_POINTS: usize = 8;

/// Most multiple-scattering octaves evaluated; larger [`MarchSettings::octaves`] are clamped.
pub const MAX_SCATTERING_OCTAVES: u32 = 8;

/// Most primary steps per interval; larger [`MarchSettings::primary_steps`] are clamped.
pub const MAX_PRIMARY_STEPS: u32 = 1024;

/// Most light-march steps; larger [`MarchSettings::light_steps`] are clamped.
pub const MAX_LIGHT_STEPS: u32 = 64;

/// Sub-steps covered by one cheap, base-only sample while the march looks for cloud (the long
/// stride of Schneider 2015's two-level stepping, Pérez Martín 2022 "Optimization": "Dynamic Steps with
/// Density").
pub const CHEAP_STRIDE: u32 = 4;

/// Consecutive empty full-detail samples after which the march goes back to cheap strides.
pub const EMPTY_STEPS_TO_CHEAP: u32 = 4;

/// Largest optical thickness one primary step integrates from a single sample: a denser step
/// is marched again in parts this thick, from the cloud's edge (see the march's `step`).
pub const MAX_STEP_OPTICAL_DEPTH: f64 = 1.0;

/// Most cloudy parts a dense primary step is marched in; the last reaches the step's end.
/// Empty parts do not count (see [`MAX_PARTS`]).
pub const MAX_SUBSTEPS: u32 = 8;

/// Most parts, cloudy or empty, a dense primary step is marched in.
pub const MAX_PARTS: u32 = 32;

/// A primary step thinner than this (optical thickness at its sample) counts as clear for the
/// edge search of the dense step after it.
pub const CLEAR_STEP_OPTICAL_DEPTH: f64 = 0.1;

/// Weight of the thin-parts march of a dense primary step of optical thickness `x` (against
/// one sample for the whole step): 0 up to [`MAX_STEP_OPTICAL_DEPTH`], 1 from twice that, and
/// linear between. WGSL twin: `dense_step_weight`.
pub fn dense_step_weight(x: f64) -> f64 {
    saturate(x / MAX_STEP_OPTICAL_DEPTH - 1.0)
}

/// Bisections that locate a cloud's edge between the last clear point and a dense step's
/// sample: the edge is found to 1/64 of that span.
pub const EDGE_SEARCH_STEPS: u32 = 6;

/// Extinction (1/m), scattering (1/m) and the ambient source (scattering × sky radiance, RGB)
/// of the medium at one point.
#[derive(Clone, Copy, Debug, Default)]
struct Medium {
    extinction: f64,
    scattering: f64,
    ambient: [f64; 3],
}

/// Fraction of the scattering albedo that full precipitation removes: a raining layer
/// ([`MarchLayer::precipitation`] = 1) scatters half of what it extinguishes. An artistic
/// darkening (rain clouds look dark mostly because they are thick), kept in one place.
pub const PRECIPITATION_ABSORPTION: f64 = 0.5;

/// Most detail erosion applied, so the erosion remap `(d − e) / (1 − e)` never divides by zero.
pub const MAX_DETAIL_EROSION: f64 = 0.9;

/// Height fraction over which the detail erosion turns from wispy (at the base) to billowy: seed
/// 002 blends with `saturate(height_fraction * 5)`, i.e. over the bottom fifth.
pub const DETAIL_TRANSITION_HEIGHT: f64 = 0.2;

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

/// Weights of the three Worley fBm channels (G, B, A) of the base texture in the low-frequency
/// fBm that carves the Perlin-Worley channel (Pérez Martín 2022, Figure 36: 0.625, 0.25, 0.125). The
/// detail fBm weighs its R, G, B channels the same way.
pub const FBM_WEIGHTS: [f64; 3] = [0.625, 0.25, 0.125];

/// Returned by [`intersect_altitude_sphere`] for both distances when the ray misses the sphere.
/// Negative, so callers that keep only `t ≥ 0` treat a miss like a sphere behind the camera.
pub const NO_HIT: f64 = -1.0;

// ---------------------------------------------------------------------------------------------
// Parameters
// ---------------------------------------------------------------------------------------------

/// Settings of one march, the f64 mirror of the shader's `CloudUniforms` (the layout and the Rust
/// `ShaderType` mirror are documented in `clouds.wgsl`).
///
/// Vectors are in world space (Bevy: y up, so the default up is `[0, 1, 0]`). Radiances are in
/// the units of [`MarchSettings::sun_illuminance`] per steradian (lux → cd/m²); the view exposure
/// is applied by the caller (on the GPU, the entry shader multiplies the result by it).
#[derive(Clone, Debug, PartialEq)]
pub struct MarchSettings {
    /// Radius of the ground sphere, metres. Default [`EARTH_RADIUS_M`].
    pub planet_radius_m: f64,
    /// Camera altitude above the ground sphere, metres, computed in f64. Default 0. Used by the
    /// CPU queries ([`density_at`], …); [`march_clouds`] takes the altitude as an argument, as
    /// its WGSL twin does (the entry shader passes this uniform).
    pub camera_altitude_m: f64,
    /// Unit vector from the planet centre through the camera. Default `[0, 1, 0]`. Used like
    /// [`MarchSettings::camera_altitude_m`].
    pub camera_up: [f64; 3],
    /// Unit vector toward the sun. Default: 60° above the horizon toward −z,
    /// `[0, sin 60°, −cos 60°]`.
    pub sun_direction: [f64; 3],
    /// Sun illuminance reaching the clouds, RGB lux, already attenuated by the atmosphere (0 at
    /// night). Default 100 000 lux, white.
    pub sun_illuminance: [f64; 3],
    /// Sky radiance lighting the top of the clouds, RGB cd/m². Default `[4000, 5000, 6500]`.
    pub ambient_top: [f64; 3],
    /// Sky radiance lighting the bottom of the clouds, RGB cd/m²: less sky reaches under a
    /// cloud. Default `[1400, 1700, 2200]`.
    pub ambient_bottom: [f64; 3],
    /// Primary steps across each interval where the ray crosses cloud layers, clamped to
    /// `1..=MAX_PRIMARY_STEPS`. Default 64.
    pub primary_steps: u32,
    /// Steps of the light march toward the sun, clamped to `0..=MAX_LIGHT_STEPS` (0: no
    /// self-shadowing), over a light path up to [`LIGHT_STEP_SPAN_M`] long; more over a longer
    /// one ([`light_step_count`]). Default 6.
    pub light_steps: u32,
    /// Growth of the primary step length with distance, per metre: a step at distance `t` is
    /// `1 + step_growth · t` times as long as one at the camera (Pérez Martín 2022, "Dynamic Steps Over
    /// Distance"). 0 gives uniform steps in each interval. Default 0.001 (steps at 10 km are 11
    /// times those at the camera).
    pub step_growth: f64,
    /// The march stops once the view transmittance falls to this value (Pérez Martín 2022; Schneider
    /// 2015). 0 marches to the end. Default 0.01.
    pub transmittance_cutoff: f64,
    /// Multiple-scattering octaves (Wrenninge 2013), clamped to `1..=MAX_SCATTERING_OCTAVES`;
    /// 1 is single scattering. Default 4 (Pérez Martín 2022).
    pub octaves: u32,
    /// Extinction attenuation `a` per octave (Wrenninge 2013). Default 0.3 (Pérez Martín 2022).
    pub ms_attenuation: f64,
    /// Contribution `b` per octave (Wrenninge 2013). Default 0.75 (Pérez Martín 2022).
    pub ms_contribution: f64,
    /// Phase eccentricity attenuation `c` per octave (Wrenninge 2013). Default 0.5 (Pérez Martín 2022).
    pub ms_eccentricity: f64,
    /// Asymmetry of the forward Henyey-Greenstein lobe (Hillaire 2016). Default 0.8.
    pub phase_g_forward: f64,
    /// Asymmetry of the backward lobe, negative. Default −0.3.
    pub phase_g_back: f64,
    /// Weight of the backward lobe, 0–1 (the forward lobe gets `1 − blend`). Default 0.2.
    pub phase_blend: f64,
    /// Angle one pixel subtends, radians: the footprint of a sample at distance `t` is
    /// `t · pixel_angle_rad`, and the noise mip level follows it (Pérez Martín 2022, "LODs Over
    /// Distance"). Default 0.001 (a 60° field of view over about 1000 pixels).
    pub pixel_angle_rad: f64,
    /// Jitter the ray start per pixel with blue noise ([`ray_start_jitter`]).
    /// Default true.
    pub jitter: bool,
    /// Frame counter that animates the jitter. Default 0.
    pub frame_index: u32,
    /// From this distance along the view ray on, metres, a cloud sample light-marches only the
    /// first [`SHADOW_MAP_NEAR_TEXELS`] texels of the cloud shadow map toward the sun, in at most
    /// [`SHADOW_MAP_NEAR_STEPS`] steps, and takes the rest of its optical depth from the map
    /// ([`ShadowMapImage::sun_optical_depth`] at the end of that march), where the map covers it.
    /// Infinity (the default): always the full light march. The map is the `shadow` argument of
    /// [`march_clouds`] (on the GPU, the bound map).
    pub sun_from_shadow_map_m: f64,
    /// Shortest primary step, metres: a short interval (a thin layer, a fog bank) gets fewer
    /// than [`MarchSettings::primary_steps`] steps ([`interval_steps`]). 0 (the default): always
    /// `primary_steps`.
    pub min_step_m: f64,
    /// Most of a long light march's extra steps ([`light_step_count`]) per footprint of the
    /// sample it starts from (`t · pixel_angle_rad`): the sample's density is filtered over its
    /// footprint, so light steps much shorter than it resample the same blur. Never fewer than
    /// [`MarchSettings::light_steps`]. Infinity (the default), 0 or less, or NaN: no limit.
    pub light_steps_per_footprint: f64,
}

impl Default for MarchSettings {
    fn default() -> Self {
        let elevation = 60.0_f64.to_radians();
        Self {
            planet_radius_m: EARTH_RADIUS_M,
            camera_altitude_m: 0.0,
            camera_up: [0.0, 1.0, 0.0],
            sun_direction: [0.0, elevation.sin(), -elevation.cos()],
            sun_illuminance: [100_000.0; 3],
            ambient_top: [4000.0, 5000.0, 6500.0],
            ambient_bottom: [1400.0, 1700.0, 2200.0],
            primary_steps: 64,
            light_steps: 6,
            step_growth: 0.001,
            transmittance_cutoff: 0.01,
            octaves: 4,
            ms_attenuation: 0.3,
            ms_contribution: 0.75,
            ms_eccentricity: 0.5,
            phase_g_forward: 0.8,
            phase_g_back: -0.3,
            phase_blend: 0.2,
            pixel_angle_rad: 0.001,
            jitter: true,
            frame_index: 0,
            sun_from_shadow_map_m: f64::INFINITY,
            min_step_m: 0.0,
            light_steps_per_footprint: f64::INFINITY,
        }
    }
}

/// One cloud layer as the march sees it, the f64 mirror of the shader's `CloudLayerGpu`.
///
/// Filled from the crate's `CloudLayer` (or by hand). Horizontal offsets and skew are in the
/// noise's horizontal axes ([`horizontal_axes`]: world x and z when up is +y).
#[derive(Clone, Debug, PartialEq)]
pub struct MarchLayer {
    /// Bottom of the layer, metres above the ground. Default 1500.
    pub base_m: f64,
    /// Top of the layer, metres above the ground; a layer with `top_m <= base_m` is empty.
    /// Default 3000.
    pub top_m: f64,
    /// Fraction of the sky covered, 0–1: 0 gives no cloud at all (and costs nothing), 1
    /// overcast. Default 0.5.
    pub coverage: f64,
    /// Extinction coefficient of the densest cloud, 1/m. Default 0.05.
    pub extinction: f64,
    /// Metres per period of the weather noise (coverage pattern). Default 20 000.
    pub weather_scale_m: f64,
    /// Metres per period of the base shape noise. Default 8000.
    pub shape_scale_m: f64,
    /// Metres per period of the detail noise. Default 1200.
    pub detail_scale_m: f64,
    /// Strength of the detail erosion, clamped to `0..=MAX_DETAIL_EROSION`. Default 0.35
    /// (Pérez Martín 2022's factor).
    pub detail_erosion: f64,
    /// How much the base and detail noise shape the cloud, 0–1: 0 is a homogeneous slab whose
    /// density is the profile shaped by coverage only. Default 1.
    pub shape_strength: f64,
    /// Precipitation darkening, 0–1: lowers the scattering albedo by up to
    /// [`PRECIPITATION_ABSORPTION`]. Default 0.
    pub precipitation: f64,
    /// How much the local coverage `κ` sets the clouds' height, 0–1 (dimensionless): the
    /// profile is read at the height fraction over [`coverage_height_scale`] of the patch fill
    /// ([`patch_fill`]), so where the weather thins out toward a cloud's edge its top comes
    /// down, and the cloud rounds into a dome instead of standing as a wall at the edge of the
    /// coverage. 0: every cloud reaches
    /// the layer's top. Values outside 0–1 are clamped, NaN reads 0. Default 0.
    pub coverage_height: f64,
    /// Offset added to horizontal positions before the weather look-up, metres. The CPU
    /// accumulates wind and the camera position in f64 and wraps them by the weather period
    /// ([`MarchLayer::set_noise_origin`]), so f32 never sees a large number. Default 0.
    pub weather_offset_m: [f64; 2],
    /// Offset of the base-noise look-up, metres, wrapped by [`MarchLayer::shape_scale_m`].
    /// Default 0.
    pub shape_offset_m: [f64; 2],
    /// Offset of the detail-noise look-up, metres, wrapped by [`MarchLayer::detail_scale_m`].
    /// Default 0.
    pub detail_offset_m: [f64; 2],
    /// Offset of the broad shape warp's look-up ([`shape_warp`]), metres, wrapped by its period
    /// [`BROAD_WARP_PERIODS`] · [`MarchLayer::shape_scale_m`]. Default 0.
    pub warp_offset_m: [f64; 2],
    /// Displacement added to the weather look-up per metre above the base (Pérez Martín 2022, "Wind and
    /// Skew"). Like the offsets, a look-up moved by `+d` shows the pattern moved by `−d`: for
    /// clouds whose tops lean downwind set it to `−skew · wind direction` (unit). Default 0.
    pub skew: [f64; 2],
    /// Profile control points `(height_fraction, density)`, both 0–1, sorted by height; only the
    /// first [`MarchLayer::profile_points`] are used. Default: a cumulus-like
    /// `(0, 0), (0.1, 1), (0.6, 0.8), (1, 0)`.
    pub profile: [[f64; 2]; MAX_PROFILE_POINTS],
    /// Number of profile points used, `0..=MAX_PROFILE_POINTS`; 0 means density 1 at every
    /// height. Default 4.
    pub profile_points: u32,
    /// Coverage toward far places ([`layer_coverage`]): per entry `[a_x, a_z, offset,
    /// coverage]`, where `dot(horizontal, a) + offset` is the fraction of the way from the near
    /// place to the far one (`a` is the near-to-far vector over its squared length, along the
    /// noise axes; the offset is the camera's fraction). Only the first
    /// [`MarchLayer::far_count`] are used. Default: none.
    pub far: [[f64; 4]; MAX_FAR_COVERAGES],
    /// Entries of [`MarchLayer::far`] used, `0..=MAX_FAR_COVERAGES`. Default 0.
    pub far_count: u32,
}

impl Default for MarchLayer {
    fn default() -> Self {
        let mut layer = Self {
            base_m: 1500.0,
            top_m: 3000.0,
            coverage: 0.5,
            extinction: 0.05,
            weather_scale_m: 20_000.0,
            shape_scale_m: 8000.0,
            detail_scale_m: 1200.0,
            detail_erosion: 0.35,
            shape_strength: 1.0,
            precipitation: 0.0,
            coverage_height: 0.0,
            weather_offset_m: [0.0; 2],
            shape_offset_m: [0.0; 2],
            detail_offset_m: [0.0; 2],
            warp_offset_m: [0.0; 2],
            skew: [0.0; 2],
            profile: [[0.0; 2]; MAX_PROFILE_POINTS],
            profile_points: 0,
            far: [[0.0; 4]; MAX_FAR_COVERAGES],
            far_count: 0,
        };
        layer.set_profile(&[[0.0, 0.0], [0.1, 1.0], [0.6, 0.8], [1.0, 0.0]]);
        layer
    }
}

impl MarchLayer {
    /// Sets the profile from up to [`MAX_PROFILE_POINTS`] `(height_fraction, density)` points
    /// (extra points are ignored). The caller sorts them by height.
    pub fn set_profile(&mut self, points: &[[f64; 2]]) {
        let count = points.len().min(MAX_PROFILE_POINTS);
        self.profile = [[0.0; 2]; MAX_PROFILE_POINTS];
        self.profile[..count].copy_from_slice(&points[..count]);
        self.profile_points = count as u32;
    }

    /// Sets the weather, shape, detail and warp offsets from one horizontal noise origin in metres,
    /// f64, along the noise axes: the camera's horizontal position *minus* the distance the wind
    /// has carried the layer (a look-up at `x + d` shows the pattern at `x − d`, so subtracting
    /// the drift makes the clouds move downwind). Each offset is wrapped by its own
    /// period with [`wrap_noise_offset`]; the noise then sees `origin + position relative to the
    /// camera`, exactly periodic, through offsets smaller than one period.
    pub fn set_noise_origin(&mut self, origin_m: [f64; 2]) {
        self.weather_offset_m = wrap_noise_offset(origin_m, self.weather_scale_m);
        self.shape_offset_m = wrap_noise_offset(origin_m, self.shape_scale_m);
        self.detail_offset_m = wrap_noise_offset(origin_m, self.detail_scale_m);
        self.warp_offset_m = wrap_noise_offset(origin_m, BROAD_WARP_PERIODS * self.shape_scale_m);
    }
}

/// `offset` wrapped into `[0, period_m)` per axis with a true modulo (`x − p·floor(x / p)`, seed
/// 000 §5.3), so a negative or huge f64 offset (a week of wind) becomes a number below one period
/// that f32 holds to a few millimetres. A non-positive or non-finite period returns 0.
pub fn wrap_noise_offset(offset_m: [f64; 2], period_m: f64) -> [f64; 2] {
    if !(period_m > 0.0 && period_m.is_finite()) {
        return [0.0; 2];
    }
    offset_m.map(|x| {
        let wrapped = x - period_m * (x / period_m).floor();
        // Rounding can land exactly on the period; keep the half-open range.
        if wrapped >= period_m || !wrapped.is_finite() {
            0.0
        } else {
            wrapped
        }
    })
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

// ---------------------------------------------------------------------------------------------
// Textures
// ---------------------------------------------------------------------------------------------

/// A 3D `Rgba16Float` texture with its full mip chain, as the GPU holds the base and detail
/// noise: values on the grid of [`quantize_noise`].
#[derive(Clone, Debug, PartialEq)]
pub struct NoiseTexture3d {
    /// Texels per side of level 0.
    pub size: u32,
    /// The mip levels, level 0 first, each `side³` texels, x fastest, then y, then z; level `n`
    /// has side [`mip_size`] applied `n` times. Every value is a multiple of `2^-11`
    /// ([`quantize_noise`]), held exactly as `f32`.
    pub levels: Vec<Vec<[f32; 4]>>,
}

impl NoiseTexture3d {
    /// Rounds `level0` (`size³` texels in `[0, 1]`) with [`quantize_noise`] and builds the mips
    /// as the GPU does: each level is [`downsample_3d`] of the *rounded* level above, rounded
    /// again.
    pub fn from_level0(level0: &[[f64; 4]], size: u32) -> Self {
        let quantise = |texels: &[[f64; 4]]| -> Vec<[f32; 4]> {
            texels
                .iter()
                .map(|t| t.map(|v| quantize_noise(v) as f32))
                .collect()
        };
        let mut levels = vec![quantise(level0)];
        let mut side = size;
        for _ in 1..mip_level_count(size) {
            let above: Vec<[f64; 4]> = levels
                .last()
                .expect("level 0 exists")
                .iter()
                .map(|t| t.map(f64::from))
                .collect();
            levels.push(quantise(&downsample_3d(&above, side)));
            side = mip_size(side);
        }
        Self { size, levels }
    }

    /// Side of mip `level`.
    pub fn level_size(&self, level: usize) -> u32 {
        (0..level).fold(self.size, |s, _| mip_size(s))
    }

    /// Trilinear sample of one level at `uvw` (texture units, period 1, repeat addressing).
    fn sample_level(&self, level: usize, uvw: [f64; 3]) -> [f64; 4] {
        let n = self.level_size(level);
        let texels = &self.levels[level];
        let axes = uvw.map(|c| filter_taps(c, n));
        let mut sum = [0.0; 4];
        for corner in 0..8_usize {
            let pick = |axis: usize| axes[axis][(corner >> axis) & 1];
            let (x, y, z) = (pick(0), pick(1), pick(2));
            let weight = x.1 * y.1 * z.1;
            let index = x.0 as usize + n as usize * (y.0 as usize + n as usize * z.0 as usize);
            let texel = texels[index];
            for (s, t) in sum.iter_mut().zip(texel) {
                *s += weight * f64::from(t);
            }
        }
        sum
    }

    /// Trilinear sample with linear interpolation between mip levels, like `textureSampleLevel`
    /// on a `linear`/`linear`/`linear`, `repeat` sampler: `lod` is clamped to the chain.
    pub fn sample(&self, uvw: [f64; 3], lod: f64) -> [f64; 4] {
        let last = (self.levels.len() - 1) as f64;
        let lod = if lod.is_nan() {
            0.0
        } else {
            lod.clamp(0.0, last)
        };
        let lower = lod.floor();
        let fraction = lod - lower;
        let a = self.sample_level(lower as usize, uvw);
        if fraction == 0.0 {
            return a;
        }
        let b = self.sample_level(lower as usize + 1, uvw);
        std::array::from_fn(|c| a[c] + (b[c] - a[c]) * fraction)
    }
}

/// A 2D `Rgba8Unorm` texture with one level, as the GPU holds the weather noise.
#[derive(Clone, Debug, PartialEq)]
pub struct NoiseTexture2d {
    /// Texels per side.
    pub size: u32,
    /// `size²` texels, x fastest.
    pub texels: Vec<[u8; 4]>,
}

impl NoiseTexture2d {
    /// Quantises `texels` (`size²` values in `[0, 1]`) to bytes.
    pub fn from_texels(texels: &[[f64; 4]], size: u32) -> Self {
        Self {
            size,
            texels: texels.iter().map(|t| t.map(quantize_unorm8)).collect(),
        }
    }

    /// Bilinear sample at `uv` (texture units, repeat addressing), level 0. The density model
    /// does not filter the noise itself: it filters the local coverage of each texel
    /// ([`weather_coverage`]).
    pub fn sample(&self, uv: [f64; 2]) -> [f64; 4] {
        let n = self.size;
        let axes = uv.map(|c| filter_taps(c, n));
        let mut sum = [0.0; 4];
        for corner in 0..4_usize {
            let x = axes[0][corner & 1];
            let y = axes[1][corner >> 1];
            let texel = self.texels[x.0 as usize + n as usize * y.0 as usize];
            for (s, t) in sum.iter_mut().zip(texel) {
                *s += x.1 * y.1 * unorm8(t);
            }
        }
        sum
    }
}

/// The value an `Rgba8Unorm` byte reads as.
fn unorm8(byte: u8) -> f64 {
    f64::from(byte) / 255.0
}

/// The two texels (wrapped index, weight) a linear filter reads along one axis for coordinate
/// `c` (texture units) on `n` texels: texel centres at `(i + 0.5) / n`, repeat addressing.
fn filter_taps(c: f64, n: u32) -> [(u32, f64); 2] {
    let x = c * f64::from(n) - 0.5;
    let floor = x.floor();
    let weight = x - floor;
    let n = i64::from(n);
    let i0 = (floor as i64).rem_euclid(n);
    let i1 = (i0 + 1).rem_euclid(n);
    [(i0 as u32, 1.0 - weight), (i1 as u32, weight)]
}

/// The noise textures a march samples, byte for byte what the GPU holds (see the module docs).
#[derive(Clone, Debug, PartialEq)]
pub struct CloudTextures {
    /// Base shape (R Perlin-Worley, G/B/A Worley fBm), with mips.
    pub base: NoiseTexture3d,
    /// Detail (R/G/B Worley fBm), with mips.
    pub detail: NoiseTexture3d,
    /// Weather noise (R coverage Perlin-Worley; G variation; B/A curl), one level.
    pub weather: NoiseTexture2d,
}

impl CloudTextures {
    /// Generates the textures of `recipe` at its sizes with [`super::noise`]. Costly at the
    /// default 128³ (seconds in a release build); tests use small sizes.
    pub fn from_recipe(recipe: &NoiseRecipe) -> Self {
        Self {
            base: NoiseTexture3d::from_level0(
                &generate_base(recipe, recipe.base_size),
                recipe.base_size,
            ),
            detail: NoiseTexture3d::from_level0(
                &generate_detail(recipe, recipe.detail_size),
                recipe.detail_size,
            ),
            weather: NoiseTexture2d::from_texels(
                &generate_weather(recipe, recipe.weather_size),
                recipe.weather_size,
            ),
        }
    }
}

// ---------------------------------------------------------------------------------------------
// Small vector helpers (plain arrays: this module does not depend on Bevy)
// ---------------------------------------------------------------------------------------------

pub(super) fn dot(a: [f64; 3], b: [f64; 3]) -> f64 {
    a[0] * b[0] + a[1] * b[1] + a[2] * b[2]
}

pub(super) fn cross(a: [f64; 3], b: [f64; 3]) -> [f64; 3] {
    [
        a[1] * b[2] - a[2] * b[1],
        a[2] * b[0] - a[0] * b[2],
        a[0] * b[1] - a[1] * b[0],
    ]
}

pub(super) fn scale(a: [f64; 3], s: f64) -> [f64; 3] {
    a.map(|c| c * s)
}

pub(super) fn add(a: [f64; 3], b: [f64; 3]) -> [f64; 3] {
    [a[0] + b[0], a[1] + b[1], a[2] + b[2]]
}

pub(super) fn normalize(a: [f64; 3]) -> [f64; 3] {
    let length = dot(a, a).sqrt();
    if length > 0.0 {
        scale(a, 1.0 / length)
    } else {
        a
    }
}

fn lerp(a: f64, b: f64, t: f64) -> f64 {
    a + (b - a) * t
}

fn saturate(x: f64) -> f64 {
    x.clamp(0.0, 1.0)
}

/// `x > 0`, false for NaN: `!is_positive(x)` rejects zero, negative and NaN alike.
pub(super) fn is_positive(x: f64) -> bool {
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

// ---------------------------------------------------------------------------------------------
// Density
// ---------------------------------------------------------------------------------------------

/// The layer's profile at `height_fraction` (0 base, 1 top): piecewise linear between its
/// points, the end values held beyond them, 1 with no points. Aetherius' shape-altering curve
/// (Pérez Martín 2022, "Density Model"), baked to at most [`MAX_PROFILE_POINTS`] points. WGSL twin:
/// `profile_density`.
pub fn profile_density(layer: &MarchLayer, height_fraction: f64) -> f64 {
    let count = (layer.profile_points as usize).min(MAX_PROFILE_POINTS);
    if count == 0 {
        return 1.0;
    }
    let points = &layer.profile[..count];
    let h = height_fraction;
    if h <= points[0][0] {
        return points[0][1];
    }
    for pair in points.windows(2) {
        let ([h0, d0], [h1, d1]) = (pair[0], pair[1]);
        if h <= h1 {
            let span = h1 - h0;
            return if span > 0.0 {
                lerp(d0, d1, (h - h0) / span)
            } else {
                d1
            };
        }
    }
    points[count - 1][1]
}

/// Range of the weather noise's coverage channel that [`local_coverage`] stretches to 0–1: about
/// its 3rd and 98th percentiles for the default noise recipe (measured on 128² texels: median
/// 0.72), so coverage reads as a fraction of the sky.
pub const WEATHER_COVERAGE_RANGE: [f64; 2] = [0.4, 0.95];

/// Width, in stretched weather units, of the ramp from clear to full local coverage at the edge
/// of a cloud field in [`local_coverage`]: narrow gives sharp-edged fields, wide gives soft ones.
pub const COVERAGE_EDGE_WIDTH: f64 = 0.25;

/// Layer coverage from which [`local_coverage`] blends toward overcast, reaching 1 everywhere at
/// coverage 1 (the weather pattern alone would leave its lowest values clear).
pub const OVERCAST_COVERAGE: f64 = 0.9;

/// Local coverage in the middle of a cloudy patch while the layer is broken: the base shape must
/// exceed `1 − PATCH_COVERAGE` (times the profile) to hold cloud, so the shape noise carves
/// separate heaps out of each patch instead of filling it from edge to edge.
///
/// For the default noise recipe the base shape spans 0.63–0.98 between its 5th and 90th
/// percentiles (median 0.84, measured on the 128³ texels), so a threshold of 0.75 leaves about
/// two thirds of a patch cloudy at the profile's peak and less toward its ends.
pub const PATCH_COVERAGE: f64 = 0.25;

/// How much more of the map the cloudy patches cover than the layer's coverage, up to
/// [`BROKEN_PATCH_AREA`]. The carving inside the patches takes the cloudy fraction of the sky back
/// down, so that it follows the coverage.
pub const PATCH_AREA_GAIN: f64 = 2.5;

/// Most of the map the cloudy patches cover while the layer is broken (below
/// [`CLOSING_COVERAGE`]). The clear quarter keeps the weather pattern in view at every coverage:
/// without it the patches merge from coverage 0.4 on and only the shape noise, which repeats
/// every [`MarchLayer::shape_scale_m`], structures the sky, so its repeats line up along grazing
/// rays into streaks toward the horizon.
pub const BROKEN_PATCH_AREA: f64 = 0.75;

/// Layer coverage from which the peak of the local coverage rises from [`PATCH_COVERAGE`] to 1
/// and the patches spread from [`BROKEN_PATCH_AREA`] to the whole map (both reached at coverage
/// 1), so that the heaps merge and the layer closes to overcast.
pub const CLOSING_COVERAGE: f64 = 0.75;

/// Local coverage `κ`, 0–1, from the layer's `coverage` (0–1) and the weather noise's coverage
/// channel `weather` (0–1): where the weather map makes clouds form and how much of the shape
/// noise becomes cloud there (Pérez Martín 2022, "Density Model").
///
/// The weather value is stretched over [`WEATHER_COVERAGE_RANGE`] to `w`. Cloudy patches cover
/// about `area = min(PATCH_AREA_GAIN · coverage, BROKEN_PATCH_AREA)` of the map: the patch field
/// ramps from 0 at `w = 1 − area` to 1 over [`COVERAGE_EDGE_WIDTH`]. Inside a patch `κ` reaches
/// the peak [`PATCH_COVERAGE`]. From [`CLOSING_COVERAGE`] to coverage 1 the peak rises to 1 and
/// the area to the whole map; above [`OVERCAST_COVERAGE`] `κ` blends to 1 everywhere. Coverage
/// 0 gives exactly 0 everywhere and coverage 1 exactly 1 (overcast). WGSL twin:
/// `local_coverage`.
pub fn local_coverage(coverage: f64, weather: f64) -> f64 {
    if !is_positive(coverage) {
        return 0.0;
    }
    let [low, high] = WEATHER_COVERAGE_RANGE;
    let w = saturate((weather - low) / (high - low));
    let closing = saturate((coverage - CLOSING_COVERAGE) / (1.0 - CLOSING_COVERAGE));
    let area = lerp(
        (PATCH_AREA_GAIN * coverage).min(BROKEN_PATCH_AREA),
        1.0,
        closing,
    );
    let field = saturate((w - (1.0 - area)) / COVERAGE_EDGE_WIDTH);
    let peak = lerp(PATCH_COVERAGE, 1.0, closing);
    let overcast = saturate((coverage - OVERCAST_COVERAGE) / (1.0 - OVERCAST_COVERAGE));
    (field * peak).max(overcast)
}

/// How full a patch is where the local coverage is `κ`: `saturate(κ / PATCH_COVERAGE)`, 1 from
/// the middle of a broken layer's patch up. It scales the density, so the carved heaps are as
/// dense as a full layer's clouds, and it sets how high the profile reaches
/// ([`coverage_height_scale`]), so the heaps stand tallest in the middle of their patch.
/// WGSL twin: `patch_fill`.
pub fn patch_fill(kappa: f64) -> f64 {
    saturate(kappa / PATCH_COVERAGE)
}

/// Local coverage `κ` of weather texel `texel` (an index along the noise axes, not wrapped: the
/// texel at the camera is near `weather_offset_m / weather_scale_m · n`): [`local_coverage`] of
/// the texel's coverage channel and of the layer's coverage ([`layer_coverage`]) at the texel's
/// centre, `(texel + 0.5) · weather_scale_m / n − weather_offset_m` from the camera. A coverage
/// of 1 there is overcast without reading the texel. The weather-map pass stores exactly these
/// values (see [`super::weather_map`]). WGSL twin: `weather_texel_coverage`.
pub fn weather_texel_coverage(
    weather: &NoiseTexture2d,
    layer: &MarchLayer,
    texel: [i64; 2],
) -> f64 {
    let n = weather.size.max(1);
    let texel_m = layer.weather_scale_m / f64::from(n);
    let centre = [0, 1].map(|a| (texel[a] as f64 + 0.5) * texel_m - layer.weather_offset_m[a]);
    let coverage = layer_coverage(layer, centre);
    if coverage >= 1.0 {
        return 1.0;
    }
    let n = i64::from(n);
    let [x, y] = texel.map(|i| i.rem_euclid(n) as usize);
    local_coverage(coverage, unorm8(weather.texels[x + n as usize * y][0]))
}

/// The weather texel `(index, weight)` pairs a bilinear look-up of coordinate `c` (texture
/// units) on `n` texels reads along one axis: texel centres at `(i + 0.5) / n`, indices not
/// wrapped. WGSL twin: the first lines of `weather_coverage`.
pub fn weather_taps(c: f64, n: u32) -> [(i64, f64); 2] {
    let x = c * f64::from(n) - 0.5;
    let floor = x.floor();
    let weight = x - floor;
    let i0 = floor as i64;
    [(i0, 1.0 - weight), (i0 + 1, weight)]
}

/// The weather texels and weights, per axis ([`weather_taps`]), of a layer's weather look-up at
/// `horizontal_m` (relative to the camera, along the noise axes) and `height_above_base_m` on
/// `n` texels: `(horizontal + weather_offset + skew · height) / weather_scale`. WGSL twin: the
/// first lines of `weather_coverage` and `shape_warp`.
fn weather_look_up(
    n: u32,
    layer: &MarchLayer,
    horizontal_m: [f64; 2],
    height_above_base_m: f64,
) -> [[(i64, f64); 2]; 2] {
    [0, 1].map(|a| {
        let uv =
            (horizontal_m[a] + layer.weather_offset_m[a] + layer.skew[a] * height_above_base_m)
                / layer.weather_scale_m;
        weather_taps(uv, n)
    })
}

/// Local coverage `κ`, 0–1, of a layer at `horizontal_m` (relative to the camera, along the noise
/// axes) and `height_above_base_m`: the bilinear filter of [`weather_texel_coverage`] over the
/// four weather texels around the look-up `(horizontal + weather_offset + skew · height) /
/// weather_scale`.
///
/// The coverage remap is applied per texel and then filtered (rather than filtering the noise
/// and then remapping), so the GPU can cache the texel values in its weather map and read them
/// with the same four taps: inside the map and outside it the result is the same function. The
/// weather noise varies slowly against the remap (κ changes by 0.06 per texel at the median
/// edge texel of the default noise), so the two orders differ little. WGSL twin:
/// `weather_coverage`.
pub fn weather_coverage(
    weather: &NoiseTexture2d,
    layer: &MarchLayer,
    horizontal_m: [f64; 2],
    height_above_base_m: f64,
) -> f64 {
    let n = weather.size.max(1);
    let taps = weather_look_up(n, layer, horizontal_m, height_above_base_m);
    let mut kappa = 0.0;
    for corner in 0..4_usize {
        let (x, wx) = taps[0][corner & 1];
        let (y, wy) = taps[1][corner >> 1];
        if wx * wy > 0.0 {
            kappa += wx * wy * weather_texel_coverage(weather, layer, [x, y]);
        }
    }
    kappa
}

/// Largest displacement of the base-shape look-up by the fine warp, as a fraction of
/// [`MarchLayer::shape_scale_m`] (500 m at the default 4 km period): see [`shape_warp`].
///
/// The base shape repeats every period, and a ray that grazes a layer crosses tens of periods. Its
/// optical depth then depends on its lateral position alone, the same in every period, and the
/// repeats add up to streaks that run toward the vanishing point. Displacing each period by a
/// different amount breaks that sum. An eighth of a period removed the streaks in the `showcase`
/// renders while the heaps kept round shapes; a quarter swirled and sheared them visibly.
pub const SHAPE_WARP: f64 = 0.125;

/// Largest displacement of the base-shape look-up by the broad warp, as a fraction of
/// [`MarchLayer::shape_scale_m`] (2 km at the default 4 km period): see [`shape_warp`].
///
/// The fine warp follows the weather noise's curl, which varies over a few hundred metres; an
/// eighth of a period is as far as it can displace the shape before it tears the heaps apart,
/// and that left a fan of streaks toward the vanishing point where a view looks along a noise
/// axis over tens of kilometres of cloud (the fine look-up's slope reaches 1.8 at an eighth of
/// a period and 7 at half a period, folding the shape over itself). The broad warp varies over
/// [`BROAD_WARP_PERIODS`] shape periods: it reaches 0.42 of a period with a slope of 0.63 at
/// its steepest (unit test `the_broad_warp_displaces_far_without_folding_the_shape`), so
/// consecutive periods along a ray are displaced by different amounts while no heap folds.
pub const SHAPE_WARP_BROAD: f64 = 0.5;

/// Period of the broad warp ([`SHAPE_WARP_BROAD`]), in shape periods (128 km at the default
/// 4 km): the weather noise's curl looked up over this period, so its finest octave (a sixteenth
/// of the weather noise) spans two shape periods.
pub const BROAD_WARP_PERIODS: f64 = 32.0;

/// The weather noise's curl (channels B and A, each `0.5 + 0.5 · curl / range`) as `2c − 1`
/// per axis, −1 to 1, filtered bilinearly from the four weather texels of `taps`
/// ([`weather_taps`] per axis). WGSL twin: `curl_look_up`.
fn curl_look_up(weather: &NoiseTexture2d, taps: [[(i64, f64); 2]; 2]) -> [f64; 2] {
    let size = i64::from(weather.size.max(1));
    let mut curl = [0.0; 2];
    for corner in 0..4_usize {
        let (x, wx) = taps[0][corner & 1];
        let (y, wy) = taps[1][corner >> 1];
        let texel = weather.texels[(x.rem_euclid(size) + size * y.rem_euclid(size)) as usize];
        for (c, channel) in curl.iter_mut().zip([texel[2], texel[3]]) {
            *c += wx * wy * (2.0 * unorm8(channel) - 1.0);
        }
    }
    curl
}

/// Displacement of the base-shape look-up at a point, metres along the noise axes: the sum of
/// two warps, both from the weather noise's curl ([`curl_look_up`]).
///
/// - The fine warp, `±`[`SHAPE_WARP`] of the shape period, is looked up where
///   [`weather_coverage`] looks (the same four texels): it varies over the weather period, which
///   is not a multiple of the shape period, so consecutive repeats of the shape are displaced
///   differently.
/// - The broad warp, `±`[`SHAPE_WARP_BROAD`] of the shape period, is looked up over
///   [`BROAD_WARP_PERIODS`] shape periods at `(horizontal + warp_offset) / period`, without
///   skew: it varies slowly, so it displaces far apart repeats by up to a period without
///   shearing any one heap.
///
/// Both are periodic in their look-up's period, and the wrapped offsets keep them continuous.
/// Neither depends on the camera, so the view ray, the light march and the shadow map see the
/// same shapes. WGSL twin: `shape_warp`.
pub fn shape_warp(
    weather: &NoiseTexture2d,
    layer: &MarchLayer,
    horizontal_m: [f64; 2],
    height_above_base_m: f64,
) -> [f64; 2] {
    let n = weather.size.max(1);
    let fine = curl_look_up(
        weather,
        weather_look_up(n, layer, horizontal_m, height_above_base_m),
    );
    let broad_period = BROAD_WARP_PERIODS * layer.shape_scale_m;
    let broad = curl_look_up(
        weather,
        [0, 1].map(|a| weather_taps((horizontal_m[a] + layer.warp_offset_m[a]) / broad_period, n)),
    );
    [0, 1].map(|a| (SHAPE_WARP * fine[a] + SHAPE_WARP_BROAD * broad[a]) * layer.shape_scale_m)
}

/// The fraction of the layer's thickness the profile is stretched over where a cloudy patch is
/// filled to `f` (0–1, the [`patch_fill`] of the local coverage), for
/// [`MarchLayer::coverage_height`] `s`: `1 − s · (1 − f)²`. 1 in a full patch or at `s = 0`. At
/// `s = 1` it is `f (2 − f)`: a cloud's top falls steeply at the edge of its patch and levels
/// off toward the middle, a rounded dome rather than the cone a linear `f` would give (a half
/// full patch reaches three quarters of the way up). Never below `f`, so positive wherever `f`
/// is. WGSL twin: `coverage_height_scale`.
pub fn coverage_height_scale(coverage_height: f64, fill: f64) -> f64 {
    let s = if coverage_height.is_nan() {
        0.0
    } else {
        coverage_height.clamp(0.0, 1.0)
    };
    let gap = 1.0 - fill;
    1.0 - s * gap * gap
}

/// Linear remap of `value` from `[old_min, old_max]` to `[new_min, new_max]` (Pérez Martín 2022, Figure
/// 30). WGSL twin: `remap`.
pub fn remap(value: f64, old_min: f64, old_max: f64, new_min: f64, new_max: f64) -> f64 {
    new_min + (value - old_min) / (old_max - old_min) * (new_max - new_min)
}

/// The billowy base shape from a base-texture sample: the Perlin-Worley channel R carved by the
/// low-frequency Worley fBm of G, B, A (weights [`FBM_WEIGHTS`]),
/// `saturate(remap(R, fbm − 1, 1, 0, 1))` (Pérez Martín 2022, Figure 36; Schneider 2015). WGSL twin:
/// `base_shape`.
pub fn base_shape(sample: [f64; 4]) -> f64 {
    let fbm = sample[1] * FBM_WEIGHTS[0] + sample[2] * FBM_WEIGHTS[1] + sample[3] * FBM_WEIGHTS[2];
    saturate(remap(sample[0], fbm - 1.0, 1.0, 0.0, 1.0))
}

/// Detail erosion amount, 0–1, from a detail-texture sample at `height_fraction`: the detail
/// fBm (R, G, B weighted by [`FBM_WEIGHTS`]) near the base and its inverse above
/// [`DETAIL_TRANSITION_HEIGHT`], so the bottoms erode into wisps and the tops into billows
/// (Pérez Martín 2022, Figure 36: `lerp(fbm, 1 − fbm, saturate(h · 5))`; Schneider 2015). WGSL twin:
/// `detail_erosion`.
pub fn detail_erosion(sample: [f64; 4], height_fraction: f64) -> f64 {
    let fbm = sample[0] * FBM_WEIGHTS[0] + sample[1] * FBM_WEIGHTS[1] + sample[2] * FBM_WEIGHTS[2];
    lerp(
        fbm,
        1.0 - fbm,
        saturate(height_fraction / DETAIL_TRANSITION_HEIGHT),
    )
}

/// Mip level for a sample whose footprint is `footprint_m` on a texture whose texels are
/// `texel_m` apart: `log2(footprint / texel)`, at least 0 (Pérez Martín 2022, "LODs Over Distance").
/// WGSL twin: `texture_lod`.
pub fn texture_lod(footprint_m: f64, texel_m: f64) -> f64 {
    (footprint_m / texel_m).max(1.0).log2()
}

/// Extinction coefficient, 1/m, of one layer at a point: `horizontal_m` are its coordinates
/// along [`horizontal_axes`] relative to the camera, metres, `altitude_m` its altitude above the
/// ground; `footprint_m` picks the mip levels ([`texture_lod`]). `with_detail = false` is the
/// cheap base-only density of the two-level march: never smaller than the full one, so it finds
/// every cloud the full density would.
///
/// Pérez Martín 2022's model ("Density Model"; Schneider 2015): the profile at the height fraction times
/// the base shape (looked up displaced by [`shape_warp`]), remapped by the local coverage `κ`
/// as `saturate(remap(shape · profile, 1 − κ, 1, 0, 1)) · fill`, with `fill` the
/// [`patch_fill`] of `κ`, then eroded by the detail, `saturate(remap(d, erosion, 1, 0, 1))`. The shape and the erosion are blended in by
/// [`MarchLayer::shape_strength`]; at 0 there is no noise and a layer of coverage 1 is exactly
/// its profile. Coverage 0 returns exactly 0. WGSL twin: `layer_density`.
pub fn layer_density(
    textures: &CloudTextures,
    layer: &MarchLayer,
    horizontal_m: [f64; 2],
    altitude_m: f64,
    footprint_m: f64,
    with_detail: bool,
) -> f64 {
    let inside = altitude_m >= layer.base_m && altitude_m <= layer.top_m;
    if !layer_is_active(layer) || !inside {
        return 0.0;
    }
    let height_above_base = altitude_m - layer.base_m;
    let height_fraction = height_above_base / (layer.top_m - layer.base_m);
    let kappa = weather_coverage(&textures.weather, layer, horizontal_m, height_above_base);
    if !is_positive(kappa) {
        return 0.0;
    }
    let fill = patch_fill(kappa);
    let profile = profile_density(
        layer,
        height_fraction / coverage_height_scale(layer.coverage_height, fill),
    );
    if !is_positive(profile) {
        return 0.0;
    }
    let strength = saturate(layer.shape_strength);
    let mut shape = 1.0;
    if strength > 0.0 {
        let warp = shape_warp(&textures.weather, layer, horizontal_m, height_above_base);
        let uvw = [
            (horizontal_m[0] + layer.shape_offset_m[0] + warp[0]) / layer.shape_scale_m,
            altitude_m / layer.shape_scale_m,
            (horizontal_m[1] + layer.shape_offset_m[1] + warp[1]) / layer.shape_scale_m,
        ];
        let texel_m = layer.shape_scale_m / f64::from(textures.base.size);
        let sample = textures.base.sample(uvw, texture_lod(footprint_m, texel_m));
        shape = lerp(1.0, base_shape(sample), strength);
    }
    let covered = saturate(remap(shape * profile, 1.0 - kappa, 1.0, 0.0, 1.0)) * fill;
    let erosion_strength = layer.detail_erosion.clamp(0.0, MAX_DETAIL_EROSION) * strength;
    if !with_detail || !is_positive(erosion_strength) || !is_positive(covered) {
        return covered * layer.extinction;
    }
    let uvw = [
        (horizontal_m[0] + layer.detail_offset_m[0]) / layer.detail_scale_m,
        altitude_m / layer.detail_scale_m,
        (horizontal_m[1] + layer.detail_offset_m[1]) / layer.detail_scale_m,
    ];
    let texel_m = layer.detail_scale_m / f64::from(textures.detail.size);
    let sample = textures
        .detail
        .sample(uvw, texture_lod(footprint_m, texel_m));
    let erosion = erosion_strength * detail_erosion(sample, height_fraction);
    saturate(remap(covered, erosion, 1.0, 0.0, 1.0)) * layer.extinction
}

/// Sum of [`layer_density`] over `layers` at one point: the extinction every sample of the march,
/// the light march and the shadow map sees. WGSL twin: `total_extinction`.
pub fn total_extinction(
    textures: &CloudTextures,
    layers: &[MarchLayer],
    horizontal_m: [f64; 2],
    altitude_m: f64,
    footprint_m: f64,
    with_detail: bool,
) -> f64 {
    layers
        .iter()
        .map(|layer| {
            layer_density(
                textures,
                layer,
                horizontal_m,
                altitude_m,
                footprint_m,
                with_detail,
            )
        })
        .sum()
}

/// Scattering albedo of a layer: 1 (cloud droplets barely absorb) lowered by precipitation
/// ([`PRECIPITATION_ABSORPTION`]). WGSL twin: `scattering_albedo`.
pub fn scattering_albedo(layer: &MarchLayer) -> f64 {
    1.0 - PRECIPITATION_ABSORPTION * saturate(layer.precipitation)
}

// ---------------------------------------------------------------------------------------------
// Light
// ---------------------------------------------------------------------------------------------

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
pub(super) fn point_mu_sun(
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
/// ([`blue_noise_jitter`](super::blue_noise::blue_noise_jitter)), when
/// [`MarchSettings::jitter`] is on (against banding, Pérez Martín 2022 "Banding Reduction"), the step
/// midpoint 0.5 when off. WGSL twin: `ray_start_jitter`.
pub fn ray_start_jitter(settings: &MarchSettings, pixel: [f64; 2]) -> f64 {
    if settings.jitter {
        super::blue_noise::blue_noise_jitter(pixel, settings.frame_index)
    } else {
        0.5
    }
}

// ---------------------------------------------------------------------------------------------
// The march
// ---------------------------------------------------------------------------------------------

/// Primary steps across an interval `span_m` metres long: [`MarchSettings::primary_steps`]
/// (clamped to `1..=MAX_PRIMARY_STEPS`), but no more than one per
/// [`MarchSettings::min_step_m`] (plus one). WGSL twin: `interval_steps`.
pub fn interval_steps(settings: &MarchSettings, span_m: f64) -> u32 {
    let steps = settings.primary_steps.clamp(1, MAX_PRIMARY_STEPS);
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
    sun_on: bool,
    jitter: f64,
    /// Optical depth from the camera so far: summed, not multiplied into the transmittance,
    /// so thin media keep their precision (a product of many `e^(−x)` drifts in f32).
    optical_depth: f64,
    /// `e^(−optical_depth)`.
    transmittance: f64,
    radiance: [f64; 3],
    /// The last cloudy step's source over its extinction, `S / σt`: the radiance a medium like
    /// it would add beyond the point where the march stops early (see [`Ray::march_interval`]).
    tail: [f64; 3],
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
                    *a += sigma_s * lerp(settings.ambient_bottom[c], settings.ambient_top[c], h);
                }
                medium.extinction += sigma;
                medium.scattering += sigma_s;
            }
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
    /// the step's sample, each sampled at its jittered point, at most [`MAX_SUBSTEPS`] (the last
    /// reaching `tb`), until the transmittance cut-off.
    ///
    /// Between `x` = 1 and 2 × [`MAX_STEP_OPTICAL_DEPTH`] the result is the one-sample step and
    /// the parts mixed in proportion ([`dense_step_weight`]), so it is continuous in the
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
        let length = MAX_STEP_OPTICAL_DEPTH / medium.extinction;
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
            let t = from + self.jitter * (to - from);
            let medium = self.medium(t);
            if is_positive(medium.extinction) {
                self.integrate(t, to - from, &medium);
                cloudy += 1;
                if self.transmittance <= self.settings.transmittance_cutoff {
                    break;
                }
            }
            from = to;
        }
        if let Some(one) = one {
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
            ambient,
        } = *medium;
        let altitude = self.altitude(t);
        let footprint = t * settings.pixel_angle_rad;
        let mut sun = 0.0;
        if self.sun_on {
            let position = scale(self.direction, t);
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
                )
            };
            // A far sample marches only the first texels toward the sun and reads the rest of
            // the way from the shadow map, where the map covers it.
            let from_map = self
                .shadow
                .filter(|_| t >= settings.sun_from_shadow_map_m)
                .and_then(|map| {
                    let near = SHADOW_MAP_NEAR_TEXELS * map.frame.texel_m();
                    let mu_sun = point_mu_sun(
                        settings,
                        self.camera_altitude_m,
                        self.up,
                        position,
                        altitude,
                    );
                    let end = add(position, scale(settings.sun_direction, near));
                    let end_altitude =
                        altitude_along_ray(altitude, mu_sun, near, settings.planet_radius_m);
                    let far = map.sun_optical_depth(end, end_altitude)?;
                    let near_depth =
                        light_march(near, settings.light_steps.min(SHADOW_MAP_NEAR_STEPS));
                    Some(if near_depth < 0.0 {
                        near_depth
                    } else {
                        near_depth + far
                    })
                });
            let optical_depth =
                from_map.unwrap_or_else(|| light_march(f64::INFINITY, settings.light_steps));
            if optical_depth >= 0.0 {
                sun = multiple_scattering(settings, optical_depth, self.cos_sun);
            }
        }
        // Hillaire 2016: ∫ T(x) S dx over the step = T · S · dt · (1 − e^(−σt dt)) / (σt dt).
        let x = extinction * dt;
        let weight = self.transmittance * dt * mean_step_transmittance(x);
        for (((radiance, tail), illuminance), ambient) in self
            .radiance
            .iter_mut()
            .zip(&mut self.tail)
            .zip(settings.sun_illuminance)
            .zip(ambient)
        {
            let source = scattering * illuminance * sun + ambient;
            *radiance += weight * source;
            *tail = source / extinction;
        }
        let before = self.transmittance;
        self.optical_depth += x;
        self.transmittance = (-self.optical_depth).exp();
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
    fn march_interval(&mut self, start: f64, end: f64) -> bool {
        let settings = self.settings;
        let steps = interval_steps(settings, end - start);
        let growth = settings.step_growth.max(0.0);
        let beta = growth * (end - start) / (1.0 + growth * start);
        let n = f64::from(steps);
        let boundary = |k: u32| start + (end - start) * step_warp(f64::from(k) / n, beta);
        let cutoff = settings.transmittance_cutoff;
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
                if self.transmittance <= cutoff {
                    // Stopping early drops the light the rest of the medium would scatter
                    // toward the camera, up to `T · S / σt` (1 % of a uniform medium's radiance
                    // at a cut-off of 0.01: half the contrast of a target at the visibility
                    // distance in fog). Add it as if the medium went on like the last step, and
                    // let nothing behind show through.
                    for (radiance, tail) in self.radiance.iter_mut().zip(self.tail) {
                        *radiance += self.transmittance * tail;
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
/// stopped at the ground), each in [`MarchSettings::primary_steps`] steps that grow with
/// distance; cheap base-only samples stride through empty space and full-detail samples light
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
        cos_sun: dot(direction, settings.sun_direction).clamp(-1.0, 1.0),
        sun_on: settings.sun_illuminance.iter().any(|&e| e > 0.0),
        jitter: saturate(jitter),
        optical_depth: 0.0,
        transmittance: 1.0,
        radiance: [0.0; 3],
        tail: [0.0; 3],
        opacity_distance: 0.0,
        opacity: 0.0,
    };
    let mut t = 0.0;
    for _ in 0..=2 * layers.len() {
        let [start, end] = next_cloud_interval(layers, radius, camera_altitude_m, mu, t, t_end);
        if !is_positive(end - start) || !ray.march_interval(start, end) {
            break;
        }
        t = end;
    }
    MarchResult {
        radiance: ray.radiance,
        transmittance: ray.transmittance,
        distance_m: ray.distance(),
    }
}

// ---------------------------------------------------------------------------------------------
// CPU queries
// ---------------------------------------------------------------------------------------------

/// Altitude above the ground of `position_m`, a point relative to the camera.
pub(super) fn altitude_of(settings: &MarchSettings, position_m: [f64; 3]) -> f64 {
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
/// point, 0 in the planet's shadow, 1 outside every layer. Single scattering only: the
/// multiple-scattering octaves are a lighting approximation, not a transmittance.
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
    );
    if optical_depth < 0.0 {
        0.0
    } else {
        (-optical_depth).exp()
    }
}

/// Closed form of the march for a homogeneous slab: `layer` with coverage 1, shape strength 0
/// and a flat profile of 1 (constant extinction `σ` from base to top), seen from a camera below
/// it looking straight up along [`MarchSettings::camera_up`], lit by the sun and the ambient sky.
///
/// With `u` the height above the base, `H` the thickness, `μs = dot(sun, up) > 0`, `σs = albedo
/// · σ`, and the light march reaching the top along the sun (`(H − u) / μs` in the plane-parallel
/// limit): `T = e^(−σH)` and
/// `L = Σᵢ bⁱ pᵢ E σs ∫₀^H e^(−σu) e^(−aⁱ σ (H − u) / μs) du + σs ∫₀^H e^(−σu) A(u) du` with
/// `A` linear from the bottom to the top ambient. With `k = aⁱ / μs` the first integral is
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
    // Σᵢ bⁱ pᵢ ∫ e^(−σu) e^(−aⁱσ(H−u)/μs) du, times σ.
    let mut sun = 0.0;
    if mu_sun > 0.0 {
        let octaves = settings.octaves.clamp(1, MAX_SCATTERING_OCTAVES);
        let (mut a, mut b, mut c) = (1.0, 1.0, 1.0);
        for _ in 0..octaves {
            let phase = dual_lobe_phase(
                mu_sun,
                c * settings.phase_g_forward,
                c * settings.phase_g_back,
                settings.phase_blend,
            );
            let k = a / mu_sun;
            let integral = if k >= 1.0 {
                transmittance * x * f(x * (k - 1.0))
            } else {
                (-k * x).exp() * x * f(x * (1.0 - k))
            };
            sun += b * phase * integral;
            a *= settings.ms_attenuation;
            b *= settings.ms_contribution;
            c *= settings.ms_eccentricity;
        }
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
fn ambient_gradient_integral(x: f64) -> f64 {
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

#[cfg(test)]
mod tests {
    use super::*;
    use std::sync::OnceLock;

    /// Small textures (the default recipe's channels at 16³, 8³ and 32²): the march samples them
    /// exactly as it would the full-size ones, and a debug build generates them in a blink.
    fn textures() -> &'static CloudTextures {
        static TEXTURES: OnceLock<CloudTextures> = OnceLock::new();
        TEXTURES.get_or_init(|| {
            CloudTextures::from_recipe(&NoiseRecipe {
                base_size: 16,
                detail_size: 8,
                weather_size: 32,
                ..NoiseRecipe::default()
            })
        })
    }

    const UP: [f64; 3] = [0.0, 1.0, 0.0];

    /// A homogeneous slab from 1000 to 2000 m: coverage 1, no noise, flat profile.
    fn slab(extinction: f64) -> MarchLayer {
        let mut layer = MarchLayer {
            base_m: 1000.0,
            top_m: 2000.0,
            coverage: 1.0,
            extinction,
            shape_strength: 0.0,
            ..MarchLayer::default()
        };
        layer.set_profile(&[[0.0, 1.0], [1.0, 1.0]]);
        layer
    }

    /// Sun at `elevation_deg` above the horizon toward −z, one octave, no cut-off, no jitter.
    fn slab_settings(steps: u32, elevation_deg: f64) -> MarchSettings {
        let e = elevation_deg.to_radians();
        MarchSettings {
            primary_steps: steps,
            sun_direction: [0.0, e.sin(), -e.cos()],
            octaves: 1,
            transmittance_cutoff: 0.0,
            jitter: false,
            ..MarchSettings::default()
        }
    }

    fn march_up(settings: &MarchSettings, layers: &[MarchLayer]) -> MarchResult {
        march_clouds(
            textures(),
            settings,
            layers,
            settings.camera_altitude_m,
            UP,
            UP,
            f64::INFINITY,
            0.5,
            None,
        )
    }

    fn relative_error(a: f64, b: f64) -> f64 {
        if a == b {
            0.0
        } else {
            (a - b).abs() / a.abs().max(b.abs())
        }
    }

    fn assert_sane(result: &MarchResult, what: &str) {
        assert!(
            result.transmittance.is_finite() && (0.0..=1.0).contains(&result.transmittance),
            "{what}: transmittance {}",
            result.transmittance
        );
        for c in result.radiance {
            assert!(
                c.is_finite() && c >= 0.0,
                "{what}: radiance {:?}",
                result.radiance
            );
        }
    }

    #[test]
    fn mean_step_transmittance_is_stable_at_both_ends() {
        assert_eq!(mean_step_transmittance(0.0), 1.0);
        assert_eq!(mean_step_transmittance(-1.0), 1.0);
        for x in [1e-300_f64, 1e-12, 1e-6, 9.99e-6, 1e-5, 1e-3, 0.1, 1.0, 10.0] {
            // Reference: the series to many terms for small x, the direct form for large.
            let reference = if x < 0.01 {
                1.0 - x / 2.0 + x * x / 6.0 - x.powi(3) / 24.0 + x.powi(4) / 120.0
            } else {
                (1.0 - (-x).exp()) / x
            };
            let value = mean_step_transmittance(x);
            assert!(
                relative_error(value, reference) < 1e-13,
                "f({x}) = {value}, expected {reference}"
            );
        }
        assert_eq!(mean_step_transmittance(1e4), 1e-4);
        assert_eq!(mean_step_transmittance(1e300), 1e-300);
        assert_eq!(mean_step_transmittance(f64::INFINITY), 0.0);
        for x in [0.05, 0.099_999, 0.1, 0.5] {
            let direct = mean_step_transmittance(x) - (-x).exp();
            assert!(
                relative_error(ambient_gradient_integral(x), direct) < 1e-12,
                "{x}"
            );
        }
        assert!(relative_error(ambient_gradient_integral(1e-9), 0.5e-9) < 1e-9);
    }

    #[test]
    fn sphere_intersections_are_exact_in_simple_cases() {
        let r = EARTH_RADIUS_M;
        // Straight up from the ground to 1000 m: the far root is 1000 m, the near one through
        // the planet.
        assert_eq!(
            intersect_altitude_sphere(0.0, 1.0, r, 1000.0),
            [-(2.0 * r + 1000.0), 1000.0]
        );
        // Straight down from 3000 m to 1000 m.
        let [near, far] = intersect_altitude_sphere(3000.0, -1.0, r, 1000.0);
        assert_eq!(near, 2000.0);
        assert!((far - (2.0 * r + 4000.0)).abs() < 1e-6);
        // Horizontal from the ground: √((R + a)² − R²).
        let [_, far] = intersect_altitude_sphere(0.0, 0.0, r, 1000.0);
        let expected = ((r + 1000.0_f64).powi(2) - r * r).sqrt();
        assert!(relative_error(far, expected) < 1e-14);
        // Camera exactly on the sphere: one root is exactly 0.
        assert_eq!(intersect_altitude_sphere(1000.0, 0.3, r, 1000.0)[1], 0.0);
        assert_eq!(intersect_altitude_sphere(1000.0, -0.3, r, 1000.0)[0], 0.0);
        assert_eq!(
            intersect_altitude_sphere(1000.0, 0.0, r, 1000.0),
            [0.0, 0.0]
        );
        // Above the sphere looking up: both roots behind the camera.
        assert!(intersect_altitude_sphere(5000.0, 0.5, r, 1000.0)[1] < 0.0);
        // A horizontal ray from 5000 m passes over the sphere at 1000 m.
        assert_eq!(
            intersect_altitude_sphere(5000.0, 0.0, r, 1000.0),
            [NO_HIT, NO_HIT]
        );
        // Tangent from above: mu = −√(1 − ((R + a)/(R + h))²), a double root at the tangent
        // point; nudged up, a miss; nudged down, two close roots. No NaN anywhere.
        let (h, a) = (5000.0, 1000.0);
        let mu_tangent = -(1.0 - ((r + a) / (r + h)).powi(2)).sqrt();
        let distance = ((r + h).powi(2) - (r + a).powi(2)).sqrt();
        for mu in [mu_tangent, mu_tangent + 1e-12, mu_tangent - 1e-12] {
            let roots = intersect_altitude_sphere(h, mu, r, a);
            assert!(roots.iter().all(|t| t.is_finite()), "{roots:?}");
            if roots != [NO_HIT, NO_HIT] {
                assert!(
                    relative_error(roots[0], distance) < 1e-3,
                    "{roots:?} vs {distance}"
                );
            }
        }
    }

    #[test]
    fn altitude_along_ray_matches_the_direct_formula() {
        let r = EARTH_RADIUS_M;
        for (h, mu, t) in [
            (0.0, 1.0, 1234.5),
            (1500.0, 0.0, 50_000.0),
            (400_000.0, -0.8, 300_000.0),
            (10.0, -0.001, 7000.0),
        ] {
            let a = r + h;
            let direct = ((a + t * mu).powi(2) + t * t * (1.0 - mu * mu)).sqrt() - r;
            let stable = altitude_along_ray(h, mu, t, r);
            assert!(
                (stable - direct).abs() < 1e-6,
                "h {h} mu {mu} t {t}: {stable} vs {direct}"
            );
        }
        assert_eq!(altitude_along_ray(1000.0, 1.0, 500.0, r), 1500.0);
        assert_eq!(altitude_along_ray(1000.0, 0.3, 0.0, r), 1000.0);
    }

    #[test]
    fn shells_and_intervals_cover_the_right_distances() {
        let r = EARTH_RADIUS_M;
        // From the ground straight up through [1000, 2000]: one piece.
        let [first, second] = shell_segments(0.0, 1.0, r, 1000.0, 2000.0);
        assert!(first[1] <= first[0]);
        assert_eq!(second, [1000.0, 2000.0]);
        // Inside the layer looking down: the part above the base.
        let [first, _] = shell_segments(1500.0, -1.0, r, 1000.0, 2000.0);
        assert_eq!(first, [0.0, 500.0]);
        // Two disjoint layers and one overlapping the first: two merged intervals.
        let mut low = slab(0.01);
        low.top_m = 1500.0;
        let mut overlap = slab(0.01);
        overlap.base_m = 1400.0;
        overlap.top_m = 2000.0;
        let mut high = slab(0.01);
        high.base_m = 8000.0;
        high.top_m = 9000.0;
        let layers = [high.clone(), low, overlap];
        let first = next_cloud_interval(&layers, r, 0.0, 1.0, 0.0, f64::INFINITY);
        assert_eq!(first, [1000.0, 2000.0]);
        let second = next_cloud_interval(&layers, r, 0.0, 1.0, first[1], f64::INFINITY);
        assert_eq!(second, [8000.0, 9000.0]);
        let none = next_cloud_interval(&layers, r, 0.0, 1.0, second[1], f64::INFINITY);
        assert!(none[1] <= none[0]);
        // The scene ends the ray inside the first interval.
        assert_eq!(
            next_cloud_interval(&layers, r, 0.0, 1.0, 0.0, 1200.0),
            [1000.0, 1200.0]
        );
        // Inactive layers are ignored.
        let mut empty = high.clone();
        empty.coverage = 0.0;
        let none = next_cloud_interval(&[empty], r, 0.0, 1.0, 0.0, f64::INFINITY);
        assert!(none[1] <= none[0]);
        // The ground stops a downward ray from space before the far side of the planet.
        assert!(ground_distance(400_000.0, -1.0, r) == 400_000.0);
        assert!(ground_distance(0.0, -0.5, r) == 0.0);
        assert!(ground_distance(0.0, 0.0, r).is_infinite());
        assert!(ground_distance(0.0, 0.5, r).is_infinite());
    }

    #[test]
    fn homogeneous_slab_matches_the_closed_form() {
        // τ = 2 through the slab: the regime where a step's source term varies most.
        let layer = slab(0.002);
        let mut worst = [0.0_f64; 4];
        for elevation in [90.0, 60.0, 30.0] {
            for growth in [0.0, 0.001] {
                for (index, steps) in [8, 32, 128, 512].into_iter().enumerate() {
                    let settings = MarchSettings {
                        step_growth: growth,
                        ..slab_settings(steps, elevation)
                    };
                    let marched = march_up(&settings, std::slice::from_ref(&layer));
                    let exact = homogeneous_slab(&settings, &layer);
                    let t_error = relative_error(marched.transmittance, exact.transmittance);
                    assert!(t_error < 1e-12, "T: {marched:?} vs {exact:?}");
                    let d_error = relative_error(marched.distance_m, exact.distance_m);
                    assert!(d_error < 0.01, "distance: {marched:?} vs {exact:?}");
                    for c in 0..3 {
                        let error = relative_error(marched.radiance[c], exact.radiance[c]);
                        worst[index] = worst[index].max(error);
                        assert!(
                            error < 0.005,
                            "sun {elevation}°, growth {growth}, {steps} steps, channel {c}: \
                             {} vs {} ({:.3} %)",
                            marched.radiance[c],
                            exact.radiance[c],
                            error * 100.0
                        );
                    }
                }
            }
        }
        let worst = worst.map(|e| format!("{e:.2e}"));
        println!("largest relative error of L at 8, 32, 128, 512 steps: {worst:?}");
    }

    /// Height of the highest cloudy point above `horizontal_m`, as a fraction of the layer
    /// (0 when the column is clear), found on a 1 000-point grid.
    fn cloud_top_fraction(layer: &MarchLayer, horizontal_m: [f64; 2]) -> f64 {
        let thickness = layer.top_m - layer.base_m;
        (0..=1000)
            .rev()
            .map(|i| f64::from(i) / 1000.0)
            .find(|&h| {
                let altitude = layer.base_m + h * thickness;
                layer_density(textures(), layer, horizontal_m, altitude, 0.0, false) > 0.0
            })
            .unwrap_or(0.0)
    }

    #[test]
    fn the_shape_noise_carves_heaps_out_of_the_middle_of_a_patch() {
        // At the densest height of a broken cumulus layer (the profile's peak, a tenth of the way
        // up), in the middle of its cloudy patches (patch fill 1), the shape noise must leave
        // clear air between heaps: a patch filled from edge to edge is a wall of cloud, not
        // cumulus. It must not carve the patch away either.
        let layer = cumulus(0.5);
        let altitude = layer.base_m + 0.1 * (layer.top_m - layer.base_m);
        let (mut full, mut clear) = (0, 0);
        for i in 0..80 {
            for j in 0..80 {
                let x = [f64::from(i) * 173.0, f64::from(j) * 211.0 - 7_000.0];
                let kappa =
                    weather_coverage(&textures().weather, &layer, x, altitude - layer.base_m);
                if patch_fill(kappa) < 1.0 {
                    continue;
                }
                full += 1;
                if layer_density(textures(), &layer, x, altitude, 0.0, true) == 0.0 {
                    clear += 1;
                }
            }
        }
        let fraction = f64::from(clear) / f64::from(full);
        println!("{clear} of {full} points in full patches are clear ({fraction:.3})");
        assert!(full > 500, "only {full} points in full patches");
        assert!(
            (0.1..0.9).contains(&fraction),
            "{clear} of {full} points in full patches are clear"
        );
    }

    /// Lateral streak contrast of `periods` consecutive periods of the base shape, starting
    /// `first_period` periods from the origin, along lines that run along the noise's x axis:
    /// the spread of the differences between neighbouring lines (the fine structure streaks are
    /// made of) for the mean over the periods, against the mean spread of single periods. 1
    /// means the repeats add up to streaks as strong as one period's structure; `1/√periods`
    /// means the periods are independent. `warp` scales both warps (0: none).
    ///
    /// A grazing ray crosses many periods. Unwarped, the optical depth of each period along a
    /// line is the same function of the line's lateral position, so the sum over periods keeps
    /// the lateral contrast of one period: the line pattern of a single period, drawn toward
    /// the vanishing point. The warps displace each period differently, so the fine lateral
    /// structure decorrelates and averages out. Coverage 1 and a flat profile leave the shape
    /// as the only structure. The base noise has 64 texels (125 m), finer than the shared test
    /// textures' 500 m, because a warp of a few hundred metres cannot decorrelate structure
    /// that coarse.
    fn lateral_streak_ratio(first_period: usize, periods: usize, warp: f64) -> f64 {
        let textures = fine_textures();
        let mut layer = MarchLayer {
            coverage: 1.0,
            ..MarchLayer::default()
        };
        layer.set_profile(&[[0.0, 1.0], [1.0, 1.0]]);
        let altitude = 0.5 * (layer.base_m + layer.top_m);
        let period = layer.shape_scale_m;
        let (lines, samples) = (64, 64);
        // Mean base-only extinction of period k along the line at lateral position z, with the
        // warp scaled by `warp`: the shape looked up as `layer_density` does.
        let depth = |k: usize, z: f64| -> f64 {
            (0..samples)
                .map(|i| {
                    let x = (k as f64 + (i as f64 + 0.5) / samples as f64) * period;
                    if warp == 1.0 {
                        return layer_density(textures, &layer, [x, z], altitude, 0.0, false);
                    }
                    let w = shape_warp(&textures.weather, &layer, [x, z], 0.0).map(|d| d * warp);
                    let uvw = [(x + w[0]) / period, altitude / period, (z + w[1]) / period];
                    base_shape(textures.base.sample(uvw, 0.0))
                })
                .sum::<f64>()
                / samples as f64
        };
        // Differences between neighbouring lines, 125 m apart (periodic across the period).
        let fine_structure = |k: usize| -> Vec<f64> {
            let profile: Vec<f64> = (0..lines)
                .map(|j| depth(k, j as f64 / lines as f64 * period))
                .collect();
            (0..lines)
                .map(|j| profile[(j + 1) % lines] - profile[j])
                .collect()
        };
        let rms = |values: &[f64]| -> f64 {
            (values.iter().map(|v| v * v).sum::<f64>() / values.len() as f64).sqrt()
        };
        let per_period: Vec<Vec<f64>> = (first_period..first_period + periods)
            .map(fine_structure)
            .collect();
        let summed: Vec<f64> = (0..lines)
            .map(|j| per_period.iter().map(|p| p[j]).sum::<f64>() / periods as f64)
            .collect();
        let single = per_period.iter().map(|p| rms(p)).sum::<f64>() / periods as f64;
        let ratio = rms(&summed) / single;
        println!(
            "warp x{warp}, periods {first_period}..{}: lateral fine structure of one period \
             {single:.2e}, of the mean {:.2e}, ratio {ratio:.3}",
            first_period + periods,
            rms(&summed)
        );
        assert!(single > 0.0, "the shape noise must vary across the lines");
        ratio
    }

    /// Textures with a 64-texel base noise (125 m texels at an 8 km shape period) and a
    /// 128-texel weather noise, fine enough to resolve the warps.
    fn fine_textures() -> &'static CloudTextures {
        static FINE: OnceLock<CloudTextures> = OnceLock::new();
        FINE.get_or_init(|| {
            CloudTextures::from_recipe(&NoiseRecipe {
                base_size: 64,
                detail_size: 8,
                weather_size: 128,
                ..NoiseRecipe::default()
            })
        })
    }

    /// Largest displacement and steepest slope, both in shape periods per shape period, of a
    /// curl warp of `amplitude` periods looked up over `look_up_periods` shape periods, from
    /// central differences on a grid of an eighth of a period over the look-up's whole period.
    /// A slope of 1 folds the shape over itself.
    fn curl_warp_extent(amplitude: f64, look_up_periods: f64) -> (f64, f64) {
        let weather = &fine_textures().weather;
        let n = weather.size;
        let warp = |x: f64, z: f64| -> [f64; 2] {
            let taps = [x, z].map(|c| weather_taps(c / look_up_periods, n));
            curl_look_up(weather, taps).map(|c| c * amplitude)
        };
        let (steps_per_period, h) = (8.0, 1e-3 * look_up_periods);
        let cells = (look_up_periods * steps_per_period).round() as usize;
        let (mut largest, mut steepest) = (0.0_f64, 0.0_f64);
        for i in 0..cells {
            for j in 0..cells {
                let (x, z) = (i as f64 / steps_per_period, j as f64 / steps_per_period);
                let w = warp(x, z);
                largest = largest.max(w[0].abs()).max(w[1].abs());
                let (dx0, dx1) = (warp(x + h, z), warp(x - h, z));
                let (dz0, dz1) = (warp(x, z + h), warp(x, z - h));
                for a in 0..2 {
                    steepest = steepest
                        .max(((dx0[a] - dx1[a]) / (2.0 * h)).abs())
                        .max(((dz0[a] - dz1[a]) / (2.0 * h)).abs());
                }
            }
        }
        (largest, steepest)
    }

    #[test]
    fn the_broad_warp_displaces_far_without_folding_the_shape() {
        // The broad warp must reach close to half a period somewhere, so that repeats move by a
        // whole feature of the shape, and stay below a slope of 1 everywhere. The fine warp at
        // the same amplitude (the weather look-up of the default 20 km layer, 2.5 shape periods)
        // is printed for comparison: it would fold the shape.
        let (largest, steepest) = curl_warp_extent(SHAPE_WARP_BROAD, BROAD_WARP_PERIODS);
        let (_, fine_steepest) = curl_warp_extent(SHAPE_WARP_BROAD, 2.5);
        println!(
            "broad warp: largest {largest:.3} periods, steepest slope {steepest:.3}; the fine \
             warp's look-up at the same amplitude: steepest slope {fine_steepest:.2}"
        );
        assert!(
            largest > 0.4 && largest <= SHAPE_WARP_BROAD,
            "largest {largest}"
        );
        assert!(
            steepest < 1.0,
            "the broad warp folds the shape: slope {steepest}"
        );
    }

    #[test]
    fn the_shape_warp_keeps_repeats_of_the_shape_from_adding_up_to_streaks() {
        // Ten periods along a line, the path of a ray that grazes a layer for 80 km, in three
        // places: without the warp the mean keeps all of one period's lateral structure (ratio
        // 1); ten independent periods would leave 1/√10 = 0.32.
        let unwarped = lateral_streak_ratio(0, 10, 0.0);
        assert!(unwarped > 0.99, "no warp, no decorrelation: {unwarped:.3}");
        for first in [0, 10, 25] {
            let ratio = lateral_streak_ratio(first, 10, 1.0);
            assert!(
                ratio < 0.5,
                "repeats of the shape from period {first} add up to streaks: ratio {ratio:.3}"
            );
        }
    }

    #[test]
    fn clouds_come_down_toward_the_edge_of_the_coverage() {
        // No shape noise: the cloud is the profile remapped by κ. Along a line across the
        // weather pattern, at full coverage height each column's top comes down by the factor
        // κ (2 − κ) against the same layer at coverage height 0.
        let layer = |coverage_height| MarchLayer {
            coverage: 0.2,
            shape_strength: 0.0,
            coverage_height,
            ..MarchLayer::default()
        };
        let (domed, walled) = (layer(1.0), layer(0.0));
        let (mut partial, mut full) = (0, 0);
        for i in 0..400 {
            let x = [f64::from(i) * 50.0, 1_234.0];
            let kappa = weather_coverage(&textures().weather, &domed, x, 0.0);
            let (domed_top, walled_top) = (
                cloud_top_fraction(&domed, x),
                cloud_top_fraction(&walled, x),
            );
            if !is_positive(kappa) {
                assert_eq!((domed_top, walled_top), (0.0, 0.0), "clear at {x:?}");
                continue;
            }
            // With no noise a point is cloudy where the profile exceeds 1 − κ, and κ is the same
            // at every height (no skew): the domed column is the walled one squeezed by
            // f (2 − f), f the patch fill.
            assert!(walled_top > 0.0, "cloudy at κ = {kappa}");
            let fill = patch_fill(kappa);
            let squeeze = fill * (2.0 - fill);
            // Below κ = 0.1 the cloudy stretch of the column is narrower than the grid.
            let tolerance = if kappa > 0.1 { 2e-3 } else { 0.05 };
            assert!(
                (domed_top - squeeze * walled_top).abs() < tolerance,
                "top {domed_top} against {squeeze} · {walled_top} at κ = {kappa}"
            );
            if fill < 0.9 {
                partial += 1;
            } else {
                full += 1;
            }
        }
        // The line crosses both the middle of cloudy patches and their edges.
        assert!(
            partial > 20 && full > 20,
            "{partial} edge and {full} middle columns"
        );
    }

    #[test]
    fn coverage_height_scale_is_clamped_and_never_below_the_coverage() {
        assert_eq!(coverage_height_scale(0.0, 0.3), 1.0);
        assert!((coverage_height_scale(1.0, 0.3) - 0.51).abs() < 1e-12);
        assert!((coverage_height_scale(0.5, 0.3) - 0.755).abs() < 1e-12);
        assert!((coverage_height_scale(7.0, 0.3) - 0.51).abs() < 1e-12);
        for kappa in [1e-9, 0.01, 0.2, 0.7, 0.999] {
            assert!(coverage_height_scale(1.0, kappa) >= kappa);
        }
        assert_eq!(coverage_height_scale(-1.0, 0.3), 1.0);
        assert_eq!(coverage_height_scale(f64::NAN, 0.3), 1.0);
        assert_eq!(coverage_height_scale(1.0, 1.0), 1.0);
    }

    #[test]
    fn homogeneous_slab_with_octaves_matches_the_closed_form() {
        let layer = slab(0.002);
        let settings = MarchSettings {
            octaves: 4,
            ..slab_settings(128, 90.0)
        };
        let marched = march_up(&settings, std::slice::from_ref(&layer));
        let exact = homogeneous_slab(&settings, &layer);
        for c in 0..3 {
            assert!(relative_error(marched.radiance[c], exact.radiance[c]) < 0.005);
        }
    }

    #[test]
    fn tiny_extinction_keeps_full_precision() {
        // σ = 1e-9 /m over 1 km: τ = 1e-6. L is σ times a constant up to the physical
        // self-attenuation of the light on its way in and out, a relative (1 + 1/μs) τ / 2 ≈
        // 1.1e-6 here; at σ = 1e-12 that term is 1e-9. So 1000 L(1e-12) / L(1e-9) − 1 must be
        // exactly that physical term (from the closed form) to 1e-9, and each L must match
        // the closed form to 1e-9: no precision is lost (a clamped σ, or `1 − e^(−x)` in the
        // integrator, would lose it all).
        let settings = slab_settings(64, 60.0);
        let one = march_up(&settings, &[slab(1e-9)]);
        let tiny = march_up(&settings, &[slab(1e-12)]);
        let exact_one = homogeneous_slab(&settings, &slab(1e-9));
        let exact_tiny = homogeneous_slab(&settings, &slab(1e-12));
        for c in 0..3 {
            assert!(one.radiance[c] > 0.0);
            assert!(relative_error(one.radiance[c], exact_one.radiance[c]) < 1e-9);
            assert!(
                relative_error(tiny.radiance[c], exact_tiny.radiance[c]) < 1e-9,
                "{tiny:?} {exact_tiny:?}"
            );
            let nonlinearity = 1000.0 * tiny.radiance[c] / one.radiance[c] - 1.0;
            let expected = 1000.0 * exact_tiny.radiance[c] / exact_one.radiance[c] - 1.0;
            assert!(
                nonlinearity > 0.0 && nonlinearity < 2e-6,
                "L not proportional to σ: {nonlinearity}"
            );
            assert!(
                (nonlinearity - expected).abs() < 1e-9,
                "{nonlinearity} vs {expected}"
            );
        }
        assert!(relative_error(1.0 - one.transmittance, 1e-6) < 1e-6);
        assert!(relative_error(1.0 - tiny.transmittance, 1e-9) < 1e-6);
    }

    #[test]
    fn huge_extinction_is_finite_and_opaque() {
        for steps in [8, 64, 512] {
            let settings = slab_settings(steps, 60.0);
            let result = march_up(&settings, &[slab(1e4)]);
            assert_sane(&result, "σ = 1e4");
            assert_eq!(result.transmittance, 0.0);
            assert!(result.radiance.iter().all(|&c| c > 0.0));
            let exact = homogeneous_slab(&settings, &slab(1e4));
            assert_eq!(exact.transmittance, 0.0);
            assert!(exact.radiance.iter().all(|c| c.is_finite()));
        }
    }

    #[test]
    fn overlapping_layers_add_their_extinction() {
        let settings = slab_settings(64, 60.0);
        let both = march_up(&settings, &[slab(0.001), slab(0.0015)]);
        let single = march_up(&settings, &[slab(0.0025)]);
        assert!(relative_error(both.transmittance, single.transmittance) < 1e-12);
        for c in 0..3 {
            assert!(relative_error(both.radiance[c], single.radiance[c]) < 1e-12);
        }
    }

    /// A cumulus-like noisy layer at 1500–3000 m.
    fn cumulus(coverage: f64) -> MarchLayer {
        MarchLayer {
            coverage,
            ..MarchLayer::default()
        }
    }

    #[test]
    fn coverage_zero_gives_exactly_clear_sky() {
        let settings = MarchSettings::default();
        for layers in [vec![cumulus(0.0)], vec![], vec![cumulus(0.0), slab(0.0)]] {
            for direction in [UP, normalize([1.0, 0.1, 0.0]), normalize([0.0, -0.2, 1.0])] {
                for altitude in [0.0, 2000.0, 400_000.0] {
                    let result = march_clouds(
                        textures(),
                        &settings,
                        &layers,
                        altitude,
                        UP,
                        direction,
                        f64::INFINITY,
                        0.3,
                        None,
                    );
                    assert_eq!(result, MarchResult::CLEAR);
                }
            }
        }
        assert_eq!(local_coverage(0.0, 1.0), 0.0);
        assert_eq!(local_coverage(1.0, 0.0), 1.0);
    }

    #[test]
    fn coverage_one_is_overcast() {
        let settings = MarchSettings::default();
        let layer = cumulus(1.0);
        // Every point at the profile peak is cloud, wherever it is.
        for x in [0.0, 1234.0, -5678.0, 40_000.0] {
            for z in [0.0, 777.0, -9_000.0] {
                let position = [x, 1500.0 + 0.1 * 1500.0, z];
                assert!(
                    density_at(
                        textures(),
                        &settings,
                        std::slice::from_ref(&layer),
                        position
                    ) > 0.0
                );
            }
        }
        let result = march_up(&settings, &[layer]);
        assert_sane(&result, "overcast");
        assert!(result.transmittance < 0.01);
    }

    /// The hard cases of DESIGN.md ("Hard cases that must stay finite and correct").
    #[test]
    fn hard_cases_stay_finite() {
        let r = EARTH_RADIUS_M;
        let week_of_wind = 7.0 * 86_400.0 * 30.0;
        let mut windy = cumulus(0.5);
        windy.set_noise_origin([week_of_wind * 0.6 + 1.3e6, -week_of_wind * 0.8 - 4.2e5]);
        for offset in [
            windy.weather_offset_m,
            windy.shape_offset_m,
            windy.detail_offset_m,
        ] {
            assert!(
                offset.iter().all(|o| (0.0..20_000.0).contains(o)),
                "{offset:?}"
            );
        }
        let mut thin_base = slab(0.01);
        thin_base.base_m = 0.0;
        thin_base.top_m = 300.0;
        let layer_sets: Vec<Vec<MarchLayer>> = vec![
            vec![cumulus(0.5)],
            vec![cumulus(1.0)],
            vec![cumulus(0.0), cumulus(0.3)],
            vec![windy],
            vec![slab(1e4)],
            vec![thin_base, cumulus(0.7)],
        ];
        // Camera altitudes: ground, exactly on the base and the top, inside, in space.
        let altitudes = [0.0, 1500.0, 3000.0, 2200.0, 400_000.0, 1e-9];
        let elevations = [90.0, 30.0, 0.0, -0.5, -30.0, -90.0];
        for layers in &layer_sets {
            for &altitude in &altitudes {
                // Directions: up, down, horizontal, tangent to the base and top spheres.
                let mut mus = vec![1.0, -1.0, 0.0, 0.3, -0.05];
                for shell in [1500.0, 3000.0, 0.0] {
                    if altitude > shell {
                        mus.push(-(1.0 - ((r + shell) / (r + altitude)).powi(2)).sqrt());
                    }
                }
                for &mu in &mus {
                    let direction = [(1.0 - mu * mu).max(0.0).sqrt(), mu, 0.0];
                    for &elevation in &elevations {
                        // Sun at the given elevation, and once straight along the view ray.
                        let e: f64 = f64::to_radians(elevation);
                        for sun in [[e.cos(), e.sin(), 0.0], direction] {
                            let settings = MarchSettings {
                                camera_altitude_m: altitude,
                                sun_direction: sun,
                                primary_steps: 16,
                                light_steps: 3,
                                ..MarchSettings::default()
                            };
                            for t_max in [f64::INFINITY, 1e-3, 0.0, 2500.0] {
                                let result = march_clouds(
                                    textures(),
                                    &settings,
                                    layers,
                                    altitude,
                                    UP,
                                    direction,
                                    t_max,
                                    0.999,
                                    None,
                                );
                                let what = format!(
                                    "alt {altitude} mu {mu} sun {elevation}° t_max {t_max}"
                                );
                                assert_sane(&result, &what);
                            }
                        }
                    }
                }
            }
        }
    }

    #[test]
    fn sun_below_the_horizon_leaves_only_ambient() {
        let layer = slab(0.002);
        let lit = march_up(&slab_settings(64, 30.0), std::slice::from_ref(&layer));
        let night = MarchSettings {
            sun_illuminance: [0.0; 3],
            ..slab_settings(64, 30.0)
        };
        let ambient_only = march_up(&night, std::slice::from_ref(&layer));
        // At 1-2 km the sun 10° below the horizon is behind the Earth: only the sky lights it.
        let below = march_up(&slab_settings(64, -10.0), std::slice::from_ref(&layer));
        for c in 0..3 {
            assert!(relative_error(below.radiance[c], ambient_only.radiance[c]) < 1e-12);
            assert!(lit.radiance[c] > below.radiance[c]);
        }
    }

    #[test]
    fn wrapped_wind_offsets_keep_the_same_clouds() {
        let settings = MarchSettings::default();
        let mut near = cumulus(0.5);
        near.weather_scale_m = 20_000.0;
        near.shape_scale_m = 8000.0;
        near.detail_scale_m = 1000.0;
        let mut far = near.clone();
        let origin = [1234.5, -678.25];
        near.set_noise_origin(origin);
        // A week of 30 m/s wind later, plus whole common periods (1280 km: the weather's 20 km,
        // the shape's 8 km and the broad warp's 256 km): the same noise.
        let periods = (7.0 * 86_400.0 * 30.0 / 1_280_000.0_f64).round() * 1_280_000.0;
        far.set_noise_origin([origin[0] + periods, origin[1] - periods]);
        for (a, b) in [
            (near.weather_offset_m, far.weather_offset_m),
            (near.shape_offset_m, far.shape_offset_m),
            (near.detail_offset_m, far.detail_offset_m),
            (near.warp_offset_m, far.warp_offset_m),
        ] {
            assert!(
                (a[0] - b[0]).abs() < 1e-6 && (a[1] - b[1]).abs() < 1e-6,
                "{a:?} {b:?}"
            );
        }
        for position in [[0.0, 2000.0, 0.0], [300.0, 2500.0, -1200.0]] {
            let a = density_at(textures(), &settings, std::slice::from_ref(&near), position);
            let b = density_at(textures(), &settings, std::slice::from_ref(&far), position);
            assert!((a - b).abs() <= 1e-9 * a.abs().max(1e-12), "{a} vs {b}");
        }
        assert_eq!(
            wrap_noise_offset([-1.0, 20_000.0], 20_000.0),
            [19_999.0, 0.0]
        );
        assert_eq!(wrap_noise_offset([5.0, 5.0], 0.0), [0.0, 0.0]);
    }

    #[test]
    fn cpu_queries_answer_in_cloud_and_sunlight() {
        let layer = slab(0.002);
        let layers = std::slice::from_ref(&layer);
        let inside = MarchSettings {
            camera_altitude_m: 1500.0,
            sun_direction: UP,
            ..MarchSettings::default()
        };
        assert!(is_in_cloud(textures(), &inside, layers, [0.0; 3]));
        assert_eq!(density_at(textures(), &inside, layers, [0.0; 3]), 0.002);
        // 500 m of cloud above the camera, sun at the zenith: e^(−1).
        let t = transmittance_to_sun(textures(), &inside, layers, [0.0; 3]);
        assert!(relative_error(t, (-1.0_f64).exp()) < 1e-12, "{t}");
        let below = MarchSettings {
            camera_altitude_m: 500.0,
            ..inside.clone()
        };
        assert!(!is_in_cloud(textures(), &below, layers, [0.0; 3]));
        assert!(is_in_cloud(textures(), &below, layers, [0.0, 600.0, 0.0]));
        assert_eq!(
            transmittance_to_sun(textures(), &below, layers, [0.0; 3]),
            1.0
        );
        // Sun below the horizon at ground level: the planet's shadow.
        let night = MarchSettings {
            sun_direction: normalize([1.0, -0.1, 0.0]),
            ..below
        };
        assert_eq!(
            transmittance_to_sun(textures(), &night, layers, [0.0; 3]),
            0.0
        );
    }

    #[test]
    fn textures_sample_like_a_repeating_trilinear_sampler() {
        let base = &textures().base;
        let n = base.size;
        // At a texel centre level 0 returns the texel itself.
        let texel = base.levels[0][(3 + n * (5 + n * 7)) as usize].map(f64::from);
        let centre = [3.5, 5.5, 7.5].map(|c| c / f64::from(n));
        assert_eq!(base.sample(centre, 0.0), texel);
        // Repeat addressing, negative coordinates included.
        for uvw in [[0.01, 0.5, 0.99], [0.3, 0.7, 0.2]] {
            let a = base.sample(uvw, 0.7);
            let b = base.sample([uvw[0] - 3.0, uvw[1] + 2.0, uvw[2] - 1.0], 0.7);
            for c in 0..4 {
                assert!((a[c] - b[c]).abs() < 1e-12);
            }
        }
        // The last mip is one texel; lod beyond the chain clamps to it.
        let last = base.levels.last().unwrap()[0].map(f64::from);
        let sampled = base.sample([0.123, 0.456, 0.789], 99.0);
        for c in 0..4 {
            assert!(
                (sampled[c] - last[c]).abs() < 1e-12,
                "{sampled:?} against {last:?}"
            );
        }
        assert_eq!(base.levels.len(), 5);
        // Mips are the box filter of the rounded level above, rounded again.
        let level1 = &base.levels[1];
        let above: Vec<[f64; 4]> = base.levels[0].iter().map(|t| t.map(f64::from)).collect();
        let expected: Vec<[f32; 4]> = downsample_3d(&above, n)
            .iter()
            .map(|t| t.map(|v| quantize_noise(v) as f32))
            .collect();
        assert_eq!(level1, &expected);
        // Every texel of every level lies on the grid the GPU stores.
        for v in base
            .levels
            .iter()
            .flatten()
            .flatten()
            .map(|v| f64::from(*v))
        {
            assert_eq!(quantize_noise(v), v, "{v} is off the grid");
        }
        // Halfway between two texel centres of the weather texture: their mean.
        let weather = &textures().weather;
        let m = f64::from(weather.size);
        let a = weather.texels[4].map(unorm8);
        let b = weather.texels[5].map(unorm8);
        let mid = weather.sample([5.0 / m, 0.5 / m]);
        for c in 0..4 {
            assert!((mid[c] - 0.5 * (a[c] + b[c])).abs() < 1e-12);
        }
    }

    /// Fraction of 200 vertical columns through a noisy layer of `coverage` that hold cloud.
    fn cloudy_fraction(coverage: f64) -> f64 {
        let settings = MarchSettings {
            primary_steps: 24,
            light_steps: 2,
            ..MarchSettings::default()
        };
        let total = 200;
        let mut cloudy = 0;
        for i in 0..total {
            let mut layer = cumulus(coverage);
            layer.set_noise_origin([f64::from(i) * 997.0, f64::from(i % 13) * 1531.0]);
            let result = march_clouds(
                textures(),
                &settings,
                &[layer],
                0.0,
                UP,
                UP,
                f64::INFINITY,
                0.5,
                None,
            );
            assert_sane(&result, "cumulus");
            if result.transmittance < 0.99 {
                cloudy += 1;
            }
        }
        f64::from(cloudy) / f64::from(total)
    }

    #[test]
    fn coverage_sets_the_cloudy_fraction() {
        let fractions = [0.2, 0.5, 0.8].map(cloudy_fraction);
        println!("cloudy fraction at coverage 0.2, 0.5, 0.8: {fractions:?}");
        assert!(fractions[0] < fractions[1] && fractions[1] < fractions[2]);
        assert!((0.05..0.4).contains(&fractions[0]), "{fractions:?}");
        assert!((0.3..0.7).contains(&fractions[1]), "{fractions:?}");
        assert!((0.6..0.95).contains(&fractions[2]), "{fractions:?}");
    }

    #[test]
    fn short_intervals_get_fewer_steps() {
        let settings = MarchSettings {
            primary_steps: 48,
            min_step_m: 20.0,
            ..MarchSettings::default()
        };
        // 355 m of fog seen 25° up from the ground: 18 steps of 20 m, not 48 of 7 m.
        assert_eq!(interval_steps(&settings, 355.0), 18);
        assert_eq!(interval_steps(&settings, 5_000.0), 48);
        assert_eq!(interval_steps(&settings, 1.0), 1);
        assert_eq!(interval_steps(&settings, 0.0), 48);
        assert_eq!(interval_steps(&settings, f64::INFINITY), 48);
        let off = MarchSettings {
            min_step_m: 0.0,
            ..settings.clone()
        };
        assert_eq!(interval_steps(&off, 355.0), 48);
        // A homogeneous slab still matches its closed form with the floor on.
        let layer = slab(0.002);
        let floored = MarchSettings {
            min_step_m: 100.0,
            ..slab_settings(64, 60.0)
        };
        let marched = march_up(&floored, std::slice::from_ref(&layer));
        let exact = homogeneous_slab(&floored, &layer);
        assert!(relative_error(marched.radiance[1], exact.radiance[1]) < 0.005);
    }

    #[test]
    fn phase_and_jitter_stay_in_range() {
        for g in [-1.0, -0.3, 0.0, 0.8, 1.0] {
            for cos in [-1.0, 0.0, 1.0] {
                let p = henyey_greenstein(cos, g);
                assert!(p.is_finite() && p > 0.0, "HG({cos}, {g}) = {p}");
            }
        }
        // An isotropic lobe is 1 / 4π.
        assert!((henyey_greenstein(0.3, 0.0) - 1.0 / (4.0 * std::f64::consts::PI)).abs() < 1e-15);
        let on = MarchSettings::default();
        for x in 0..64 {
            for frame in [0, 1, 63, 1000] {
                let pixel = [f64::from(x) * 37.0 + 0.5, f64::from(x) * -11.0 + 0.5];
                let j = ray_start_jitter(
                    &MarchSettings {
                        frame_index: frame,
                        ..on.clone()
                    },
                    pixel,
                );
                assert!((0.0..1.0).contains(&j));
            }
        }
        let off = MarchSettings {
            jitter: false,
            ..MarchSettings::default()
        };
        assert_eq!(ray_start_jitter(&off, [3.0, 4.0]), 0.5);
        assert_eq!(step_warp(0.37, 0.0), 0.37);
        assert!((step_warp(1.0, 5.0) - 1.0).abs() < 1e-15);
        assert!((step_warp(0.5, 3.0) - 1.0 / 3.0).abs() < 1e-15);
    }

    /// Jitter-mean luminance of a ray looking along +x through a band of cloud whose near wall
    /// is `wall_m` away, with a low sun behind the camera lighting the wall's face: the mean
    /// over 64 evenly spaced jitters, which the temporal accumulation converges to.
    fn wall_radiance(textures: &CloudTextures, wall_m: f64, steps: u32) -> f64 {
        let settings = MarchSettings {
            primary_steps: steps,
            camera_altitude_m: 1500.0,
            sun_direction: [-10f64.to_radians().cos(), 10f64.to_radians().sin(), 0.0],
            ..MarchSettings::default()
        };
        let mut layer = slab(0.05);
        layer.coverage = 0.5;
        layer.weather_scale_m = 32_000.0;
        // The band's near edge is at u = 0.25 of the period: the look-up u = (x + offset) / scale
        // reaches it at x = wall_m.
        layer.weather_offset_m = [0.25 * 32_000.0 - wall_m, 0.0];
        let jitters = 64;
        (0..jitters)
            .map(|i| {
                let jitter = (f64::from(i) + 0.5) / f64::from(jitters);
                let result = march_clouds(
                    textures,
                    &settings,
                    std::slice::from_ref(&layer),
                    1500.0,
                    UP,
                    [1.0, 0.0, 0.0],
                    f64::INFINITY,
                    jitter,
                    None,
                );
                result.radiance.iter().sum::<f64>() / 3.0
            })
            .sum::<f64>()
            / f64::from(jitters)
    }

    /// A dense cloud wall, opaque within a fraction of a step, looks the same whatever the step
    /// grid's phase against it, and as bright as with 1024 steps. Where the cheap stride's sample
    /// falls short of the wall, the next one finds cloud and the detail march backs up a stride;
    /// the dense step then finds the wall's edge and marches from it in thin parts. Without the
    /// back-up the march skipped part of a stride behind the wall with a probability that
    /// depends on the phase, which drew horizontal bands on cumulus walls.
    #[test]
    fn cloud_walls_look_the_same_whatever_the_step_phase() {
        let flat = NoiseTexture3d::from_level0(&[[0.5; 4]], 1);
        let n = 1024u32;
        // A band of full local coverage over texels 256..768 (16 km at 31 m per texel).
        let texels: Vec<[f64; 4]> = (0..n * n)
            .map(|i| {
                let x = i % n;
                let w = if (256..768).contains(&x) { 1.0 } else { 0.0 };
                [w, 0.0, 0.0, 0.0]
            })
            .collect();
        let textures = CloudTextures {
            base: flat.clone(),
            detail: flat,
            weather: NoiseTexture2d::from_texels(&texels, n),
        };
        // The wall swept over 4 km, several strides of the 48-step grid there.
        let radiance: Vec<f64> = (0..=40)
            .map(|i| wall_radiance(&textures, 6_000.0 + 100.0 * f64::from(i), 48))
            .collect();
        let converged = wall_radiance(&textures, 8_000.0, 1024);
        // Departure from the straight line through the sweep (the steps grow with distance, so
        // a slow trend is expected), relative to the mean.
        let count = radiance.len() as f64;
        let mean = radiance.iter().sum::<f64>() / count;
        let mean_x = (count - 1.0) / 2.0;
        let slope = radiance
            .iter()
            .enumerate()
            .map(|(i, r)| (i as f64 - mean_x) * (r - mean))
            .sum::<f64>()
            / radiance
                .iter()
                .enumerate()
                .map(|(i, _)| (i as f64 - mean_x).powi(2))
                .sum::<f64>();
        let worst = radiance
            .iter()
            .enumerate()
            .map(|(i, r)| (r - mean - slope * (i as f64 - mean_x)).abs())
            .fold(0.0, f64::max)
            / mean;
        eprintln!(
            "wall radiance over the sweep: {radiance:.4?}; worst departure {worst:.4}; \
             converged {converged:.4}, mean {mean:.4}"
        );
        assert!(mean > 0.0);
        // Measured: 0.78 % departure, the mean 1.2 % below 1024 steps. Session 5 measured, with
        // one sample per dense step, 2.4 % departure and a mean about 55 % too dark (the sample
        // lies anywhere up to a step deep in the cloud); without the stride back-up, 23 %.
        assert!(
            worst < 0.05,
            "the wall's brightness follows the step grid: {worst}"
        );
        let bias = (mean - converged).abs() / converged;
        assert!(
            bias < 0.05,
            "the wall's mean brightness {mean} against {converged} converged"
        );
    }

    /// The march is continuous in the density where a step turns dense, even at a cloud's
    /// sharp edge: there the one-sample step and the thin parts from the edge see different
    /// parts of the step, and they are mixed between optical thickness 1 and 2
    /// ([`dense_step_weight`]). So a density that rounds differently on the GPU changes the
    /// light a little, not a lot. Dense steps in a homogeneous slab also match its closed form.
    #[test]
    fn dense_steps_are_continuous_in_the_density() {
        // 16 steps through the 1 km slab, about 62.5 m long (x = 1 at σ = 0.016 /m). The cloud
        // begins sharply at a height inside a step, over a range of heights: wherever a step's
        // sample is clear and the next one's is dense, the next step searches back for the edge.
        let settings = MarchSettings {
            step_growth: 0.0,
            ..slab_settings(16, 20.0)
        };
        let radiance = |extinction: f64, edge: f64| {
            let mut layer = slab(extinction);
            layer.set_profile(&[[0.0, 0.0], [edge, 0.0], [edge + 1e-5, 1.0], [1.0, 1.0]]);
            march_up(&settings, std::slice::from_ref(&layer)).radiance[1]
        };
        let step_m = 1000.0 / 16.0;
        for x in [MAX_STEP_OPTICAL_DEPTH, 2.0 * MAX_STEP_OPTICAL_DEPTH] {
            let sigma = x / step_m;
            let jump = (0..12)
                .map(|i| {
                    let edge = 0.25 + 0.01 * f64::from(i);
                    let below = radiance(sigma * (1.0 - 1e-9), edge);
                    let above = radiance(sigma * (1.0 + 1e-9), edge);
                    relative_error(above, below)
                })
                .fold(0.0, f64::max);
            eprintln!("x = {x}: largest jump {jump:.2e}");
            assert!(jump < 1e-6, "the light jumps at x = {x}: {jump}");
        }
        // Dense steps (x = 4: all parts) still integrate the slab as the closed form does.
        // It is opaque (τ = 64), so the light seen from below is the ambient sky's at its base.
        let layer = slab(4.0 / step_m);
        let marched = march_up(&settings, std::slice::from_ref(&layer));
        let exact = homogeneous_slab(&settings, &layer);
        let error = relative_error(marched.radiance[1], exact.radiance[1]);
        eprintln!(
            "x = 4: L {:.6e} against {:.6e} closed form",
            marched.radiance[1], exact.radiance[1]
        );
        assert!(error < 0.005, "{marched:?} vs {exact:?}");
    }

    /// A low sun's light march: its path through the layer is many kilometres long, so it takes
    /// more steps ([`light_step_count`]), sampled at the steps' midpoints
    /// ([`LIGHT_SAMPLE_OFFSET`]), and comes close to a converged light march. A far sample
    /// (a footprint of hundreds of metres) takes fewer of those extra steps
    /// ([`MarchSettings::light_steps_per_footprint`]) for little more error.
    #[test]
    fn a_low_suns_light_march_converges_over_its_offsets() {
        let none = f64::INFINITY;
        assert_eq!(light_step_count(8, 1_000.0, 0.0, none), 8);
        assert_eq!(light_step_count(8, LIGHT_STEP_SPAN_M, 0.0, none), 8);
        assert_eq!(light_step_count(8, 7.0 * LIGHT_STEP_SPAN_M, 0.0, none), 56);
        assert_eq!(light_step_count(8, 1e12, 0.0, none), MAX_LIGHT_STEPS);
        assert_eq!(light_step_count(0, 1e4, 0.0, none), 0);
        assert_eq!(light_step_count(8, f64::NAN, 0.0, none), 8);
        assert_eq!(light_step_count(500, 1.0, 0.0, none), MAX_LIGHT_STEPS);
        // One extra step per 500 m footprint over 14 km: 28, not 56; never below 8.
        assert_eq!(light_step_count(8, 7.0 * LIGHT_STEP_SPAN_M, 500.0, 1.0), 28);
        assert_eq!(
            light_step_count(8, 7.0 * LIGHT_STEP_SPAN_M, 5_000.0, 1.0),
            8
        );
        assert_eq!(light_step_count(8, 7.0 * LIGHT_STEP_SPAN_M, 0.0, 1.0), 56);
        for no_limit in [0.0, -1.0, f64::NAN, none] {
            assert_eq!(
                light_step_count(8, 7.0 * LIGHT_STEP_SPAN_M, 500.0, no_limit),
                56
            );
        }

        // Cumulus 1.5–3 km under a sun 4° high: light paths up to 21 km through the layer, from
        // 192 points 1.7–2.9 km up.
        let e = 4f64.to_radians();
        let settings = MarchSettings {
            sun_direction: [0.0, e.sin(), -e.cos()],
            ..MarchSettings::default()
        };
        let layers = [MarchLayer {
            coverage: 0.6,
            ..MarchLayer::default()
        }];
        // Mean |error| against 64 steps of: 8 midpoint steps, 8 steps averaged over 16 offsets,
        // and 24 steps whose extra steps are limited to one per 350 m footprint (with the
        // steps that took, and the steps without the limit).
        let (mut midpoint_error, mut mean_error, mut limited_error) = (0.0, 0.0, 0.0);
        let (mut limited_steps, mut full_steps, mut count) = (0.0, 0.0, 0.0);
        let footprint = 350.0;
        for i in 0..192 {
            let position = [
                173.0 * f64::from(i),
                1_700.0 + 6.25 * f64::from(i),
                311.0 * f64::from(i),
            ];
            let altitude = altitude_of(&settings, position);
            let depth = |steps: u32, offset: f64, footprint: f64, per_footprint: f64| {
                let settings = MarchSettings {
                    light_steps_per_footprint: per_footprint,
                    ..settings
                };
                sun_optical_depth(
                    textures(),
                    &settings,
                    &layers,
                    0.0,
                    UP,
                    position,
                    altitude,
                    footprint,
                    f64::INFINITY,
                    steps,
                    offset,
                )
            };
            let converged = (-depth(MAX_LIGHT_STEPS, 0.5, 0.0, none)).exp();
            let jitters = 16;
            let mean = (0..jitters)
                .map(|j| (-depth(8, (f64::from(j) + 0.5) / f64::from(jitters), 0.0, none)).exp())
                .sum::<f64>()
                / f64::from(jitters);
            mean_error += (mean - converged).abs();
            midpoint_error += ((-depth(8, LIGHT_SAMPLE_OFFSET, 0.0, none)).exp() - converged).abs();
            // Far samples: the limited march against 64 steps at the same footprint (the same
            // mips).
            let far = (-depth(MAX_LIGHT_STEPS, 0.5, footprint, none)).exp();
            let limited = (-depth(24, LIGHT_SAMPLE_OFFSET, footprint, 1.0)).exp();
            limited_error += (limited - far).abs();
            let mu = point_mu_sun(&settings, 0.0, UP, position, altitude);
            let distance = light_march_distance(&layers, settings.planet_radius_m, altitude, mu);
            limited_steps += f64::from(light_step_count(24, distance, footprint, 1.0));
            full_steps += f64::from(light_step_count(24, distance, footprint, none));
            count += converged;
        }
        let (error, mean_error) = (midpoint_error / count, mean_error / count);
        let limited_error = limited_error / count;
        eprintln!(
            "light transmittance: midpoints off by {error:.4}, mean over offsets {mean_error:.4} \
             (of the mean); 24 steps limited to one per {footprint} m footprint: {:.1} steps \
             instead of {:.1}, off by {limited_error:.4}",
            limited_steps / 192.0,
            full_steps / 192.0
        );
        // Measured: midpoints 0.53 %, mean over offsets 0.57 %; limited: 32.0 steps instead of
        // 53.2, off by 1.37 %.
        assert!(
            error < 0.01,
            "light transmittance off by {error} on average"
        );
        assert!(
            limited_steps < 0.7 * full_steps,
            "the limit saved too few steps: {limited_steps} of {full_steps}"
        );
        assert!(
            limited_error < 0.02,
            "the limited light march is off by {limited_error} on average"
        );
    }
}
