//! The parameters of a march in f64: [`MarchSettings`] and [`MarchLayer`], the source of the
//! shaders' uniforms. WGSL twin: `src/render/march/parameters.wgsl` (`CloudUniforms` and
//! `CloudLayerGpu`, written from these by the `ShaderType` mirrors in `src/render/view.rs`).

use super::BROAD_WARP_PERIODS;
#[cfg(doc)]
use super::{
    LIGHT_STEP_SPAN_M, PRECIPITATION_ABSORPTION, SHADOW_MAP_NEAR_STEPS, SHADOW_MAP_NEAR_TEXELS,
    coverage_height_scale, density_at, flash_source, horizontal_axes, interval_steps,
    layer_coverage, light_step_count, march_clouds, optically_thin_light_steps, patch_fill,
    ray_light_steps, ray_start_jitter, sample_source, shape_warp,
};
#[cfg(doc)]
use crate::reference::shadow::ShadowMapImage;

/// Earth's mean radius in metres, the default [`MarchSettings::planet_radius_m`].
pub const EARTH_RADIUS_M: f64 = 6_371_000.0;

/// Most far-coverage entries a layer carries ([`MarchLayer::far`]). WGSL twin:
/// `MAX_FAR_COVERAGES`.
pub const MAX_FAR_COVERAGES: usize = 2;

/// Most profile control points a layer carries ([`MarchLayer::profile`]).
pub const MAX_PROFILE_POINTS: usize = 8;

/// Settings of one march, the f64 mirror of the shader's `CloudUniforms` (the layout and the Rust
/// `ShaderType` mirror are documented in `parameters.wgsl`).
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
    /// Light scattered more than once ([`sample_source`]): the δ-Eddington diffuse field of the
    /// sun and the sky. Off: single scattering and a sky light growing with height in the
    /// layer. Default true.
    pub multiple_scattering: bool,
    /// Fade the clouds into what lies behind them by the transmittance of the clear air between
    /// the camera and the clouds ([`clear_air_transmittance`](super::clear_air_transmittance)):
    /// the aerial perspective that veils distant clouds. The renderer turns it on for a scene
    /// with Bevy's `Atmosphere` and a sun or moon light
    /// ([`march_inputs`](crate::render::view::march_inputs)), whose sky
    /// and aerial perspective are the air's light that the fade shows in place of the cloud;
    /// the validation against DISORT and Mitsuba, whose scenes have no air, leaves it off.
    /// Default false.
    pub clear_air: bool,
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
    /// ([`ShadowMapImage::sun_optical_depth`] at the end of that march), where the map covers it
    /// and may light it ([`shadow_map_share`](super::shadow_map_share)). Infinity (the
    /// default): always the full light march. The map is the `shadow` argument of
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
    /// Most optical depth one light-march step may span where the layers its path reaches are
    /// at their peak extinction ([`optically_thin_light_steps`]): an optically thin path (a
    /// veil of cirrostratus) takes fewer than [`MarchSettings::light_steps`]. Infinity (the
    /// default), 0 or less, or NaN: no limit.
    pub light_step_optical_depth: f64,
    /// Share of [`MarchSettings::light_steps`] a view ray 60° or more from the sun takes, 0–1
    /// (all of them within about 32° of it, linear between: [`ray_light_steps`]). Default 1:
    /// every ray takes them all.
    pub light_steps_away_from_sun: f64,
    /// Where a lightning flash lights the clouds from within ([`flash_source`]), relative to the
    /// camera, metres. Default 0.
    pub flash_position_m: [f64; 3],
    /// The flash's luminous intensity, candela (lumens per steradian, the same units as
    /// [`MarchSettings::sun_illuminance`] times square metres); 0 (the default): no flash.
    pub flash_intensity_cd: f64,
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
            multiple_scattering: true,
            clear_air: false,
            phase_g_forward: 0.8,
            phase_g_back: -0.3,
            phase_blend: 0.2,
            pixel_angle_rad: 0.001,
            jitter: true,
            frame_index: 0,
            sun_from_shadow_map_m: f64::INFINITY,
            min_step_m: 0.0,
            light_steps_per_footprint: f64::INFINITY,
            light_step_optical_depth: f64::INFINITY,
            light_steps_away_from_sun: 1.0,
            flash_position_m: [0.0; 3],
            flash_intensity_cd: 0.0,
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
    /// Share of the layer's scattered light in the 22° halo of its ice crystals, 0–1
    /// ([`halo_phase`](super::halo_phase)): the phase is `(1 − share)` times the dual lobe plus
    /// `share` times the halo's ring. Values outside 0–1 are clamped, NaN reads 0. Default 0.
    pub halo_share: f64,
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
    /// The clouds of the growth automaton, which replace the weather noise's pattern
    /// ([`weather_texel_coverage`](super::weather_texel_coverage)). Default: none.
    pub growth: Option<LayerGrowth>,
    /// The sky light on this layer's top, as a factor per RGB channel on
    /// [`MarchSettings::ambient_top`]: 1 under an open sky; under separate layers above it the
    /// light they let through, sky and scattered sun ([`sky_light_under_layers`](super::sky_light_under_layers)). Default 1.
    pub sky_light_top: [f64; 3],
    /// The light from below on this layer, as a factor per RGB channel on
    /// [`MarchSettings::ambient_bottom`]: 1 under an open sky; under separate layers above it the
    /// share of the ground's light left ([`sky_light_under_layers`](super::sky_light_under_layers)). Default 1.
    pub sky_light_bottom: [f64; 3],
}

/// A layer's clouds from the cloud-growth automaton ([`crate::reference::growth`]): how much of
/// each column of its grid holds cloud. The grid spans one period of the weather noise, so
/// weather texel `(i, j)` (wrapped) reads column `(i · size[0] / n, j · size[1] / n)` of an
/// `n`-texel noise.
#[derive(Clone, Debug, PartialEq)]
pub struct LayerGrowth {
    /// Columns along the two noise axes, each at least 1.
    pub size: [u32; 2],
    /// The layer's slice of the GPU's growth-cover array (WGSL: `growth_cover`).
    pub slice: u32,
    /// Each column's cloud fraction, 0–1, x fastest: `size[0] · size[1]` values
    /// ([`GrowthGrid::smoothed_cover`](crate::reference::growth::GrowthGrid::smoothed_cover)); a
    /// shorter slice reads 0 past its end.
    pub cover: std::sync::Arc<[f32]>,
}

impl LayerGrowth {
    /// The cover of the column under weather texel `wrapped` (already wrapped into `0..n`) of
    /// an `n`-texel weather noise. WGSL: the growth branch of `weather_texel_coverage`.
    pub fn cover_at(&self, wrapped: [usize; 2], n: u32) -> f64 {
        let n = u64::from(n.max(1));
        let [x, y] = [0, 1].map(|a| {
            let size = u64::from(self.size[a].max(1));
            ((wrapped[a] as u64 * size) / n).min(size - 1) as usize
        });
        self.cover
            .get(x + self.size[0].max(1) as usize * y)
            .map_or(0.0, |&c| f64::from(c))
    }
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
            halo_share: 0.0,
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
            growth: None,
            sky_light_top: [1.0; 3],
            sky_light_bottom: [1.0; 3],
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
