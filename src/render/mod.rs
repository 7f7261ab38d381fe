//! GPU passes, in the order a frame runs them, and the camera settings that opt into them. Each
//! pass is a leaf module; what they share, the extracted view of a camera with its GPU structs
//! and buffers, is in `view`.
//!
//! - [`noise`]: a compute pass that fills the tileable cloud-noise textures once, and again only
//!   when [`noise::CloudNoiseSettings`] change.
//! - [`weather_map`]: a compute pass per camera that caches each layer's local coverage on the
//!   weather noise's texels around the camera, for the march to read.
//! - [`march`]: a fullscreen pass per camera with [`VolumetricClouds`] that ray-marches the
//!   [`CloudLayer`](crate::layers::CloudLayer)s, stops at scene geometry and composites the clouds
//!   over the scene in HDR. In a scene with Bevy's `Atmosphere` the clear air in front of each
//!   cloud veils it: the cloud keeps the air's transmittance to it of its light and opacity, so
//!   distant clouds fade into the sky and the hills behind them (aerial perspective;
//!   [`clear_air_transmittance`](crate::reference::render::clear_air_transmittance)).
//! - [`haze`]: the haze the forecast's visibility gives, marched in the same pass after the
//!   clouds, with light shafts: a pass at a reduced resolution reads the cloud shadow map along
//!   each view ray first, and the march reads its factors back.
//! - [`composite`]: the blend of the clouds onto the scene, and the depth-aware upsample of what
//!   was rendered at a reduced resolution (the march at a `resolution_scale` below 1, the shaft
//!   factors).
//! - [`shadow`]: a compute pass that fills the cloud shadow map along the sun each frame, which
//!   Bevy's PBR lighting applies to the sun's direct light on every `StandardMaterial`.

pub mod composite;
#[cfg(test)]
mod contract;
#[doc(hidden)]
pub mod growth;
pub mod haze;
pub mod march;
mod node;
pub mod noise;
pub mod shadow;
pub mod sky_light;
#[doc(hidden)]
pub mod view;
pub mod weather_map;

use bevy::{
    camera::Hdr,
    core_pipeline::{Core3dSystems, prepass::DepthPrepass, schedule::Core3d},
    prelude::*,
    render::{
        ExtractSchedule, Render, RenderApp, RenderStartup, RenderSystems,
        render_resource::SpecializedRenderPipelines,
    },
};

/// Every GPU pass of the clouds; part of [`crate::CloudscapePlugin`]. It adds
/// [`noise::CloudNoisePlugin`] unless the app has it already (the noise textures alone are
/// useful without clouds), then the march with its weather map, haze and composite, and the
/// cloud shadow map. On a GPU that cannot run a pass it warns once and leaves that pass out.
#[derive(Debug, Default, Clone, Copy)]
pub struct CloudRenderPlugin;

/// The main-world data every camera's passes share: the camera component, the world and haze
/// resources, the layers' drift with the wind and the sky light under the clouds. Registered
/// with or without a renderer (a server, a test of the weather alone), so the layers still drift.
fn scene_data(app: &mut App) {
    app.register_type::<VolumetricClouds>()
        .register_type::<crate::layers::CloudGrowth>()
        .register_type::<crate::world::CloudWorld>()
        .init_resource::<crate::world::CloudWorld>()
        .register_type::<crate::layers::LayerDrift>()
        .register_type::<haze::Haze>()
        .init_resource::<haze::Haze>()
        .register_type::<sky_light::CloudSkyLight>()
        .add_systems(
            Update,
            (
                crate::layers::drift_cloud_layers
                    .after(crate::CloudscapeSystems::Layers)
                    .before(crate::CloudscapeSystems::Sun),
                sky_light::light_the_scene_under_the_clouds.after(crate::CloudscapeSystems::Sun),
            ),
        );
}

impl Plugin for CloudRenderPlugin {
    fn build(&self, app: &mut App) {
        if !app.is_plugin_added::<noise::CloudNoisePlugin>() {
            app.add_plugins(noise::CloudNoisePlugin);
        }
        scene_data(app);
        march::build(app);
        if app.get_sub_app(RenderApp).is_some() {
            haze::load_haze_shader(app);
            composite::load_composite_shaders(app);
            weather_map::load_weather_map_shader(app);
        }
        shadow::build(app);
        if app.get_sub_app(RenderApp).is_some() {
            app.add_plugins(bevy::render::extract_resource::ExtractResourcePlugin::<
                crate::sky::stars::StarSky,
            >::default());
        }
        if let Some(render_app) = app.get_sub_app_mut(RenderApp) {
            render_app
                .init_resource::<growth::GrowthComputes>()
                .add_systems(ExtractSchedule, growth::extract_cloud_growth)
                .add_systems(
                    Render,
                    growth::run_growth_jobs.in_set(RenderSystems::PrepareResources),
                );
            app.add_systems(
                Update,
                growth::run_cloud_growth
                    .after(crate::CloudscapeSystems::Layers)
                    .before(crate::CloudscapeSystems::Sun),
            );
        }
    }

    fn finish(&self, app: &mut App) {
        if let Some(render_app) = app.get_sub_app_mut(RenderApp) {
            if let Some(reason) = march::unsupported(render_app) {
                warn!("bevy_cloudscape: volumetric clouds disabled: {reason}");
            } else {
                march::finish(render_app);
                render_app
                    .add_systems(
                        Render,
                        node::prepare_cloud_march_pipelines.in_set(RenderSystems::Prepare),
                    )
                    .add_systems(
                        Core3d,
                        node::march_cloud_layers
                            .after(Core3dSystems::MainPass)
                            .before(Core3dSystems::EarlyPostProcess),
                    )
                    .init_resource::<SpecializedRenderPipelines<composite::CloudUpsamplePipeline>>()
                    .init_resource::<SpecializedRenderPipelines<composite::CloudTemporalPipeline>>()
                    .add_systems(
                        RenderStartup,
                        (
                            composite::init_cloud_upsample_pipeline,
                            composite::init_cloud_temporal_pipeline,
                            weather_map::init_cloud_weather_map_pipeline,
                        ),
                    )
                    .add_systems(
                        Render,
                        (
                            composite::prepare_composite_targets
                                .in_set(RenderSystems::PrepareResources),
                            weather_map::prepare_weather_maps
                                .in_set(RenderSystems::PrepareBindGroups),
                        ),
                    );
            }
        }
        shadow::finish(app);
    }
}

/// Named quality presets of [`VolumetricClouds`], as [`VolumetricClouds::quality`] tells them;
/// `Custom` once a knob differs from every preset.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Reflect)]
pub enum CloudQuality {
    /// [`VolumetricClouds::LOW`].
    Low,
    /// [`VolumetricClouds::MEDIUM`].
    #[default]
    Medium,
    /// [`VolumetricClouds::HIGH`].
    High,
    /// [`VolumetricClouds::ULTRA`].
    Ultra,
    /// Hand-tuned knobs.
    Custom,
}

/// Put on a 3D camera to render volumetric clouds for it. It brings a depth prepass (the march
/// stops at scene geometry) and HDR (the clouds are composited before tonemapping).
///
/// Start from a preset ([`VolumetricClouds::MEDIUM`] is the default) and change knobs; every
/// knob is live-editable. These are quality knobs only: what the clouds are (the planet, the
/// noise scales, the phase function) is the [`CloudWorld`](crate::world::CloudWorld) resource,
/// shared by every camera.
#[derive(Component, Debug, Clone, PartialEq, Reflect)]
#[reflect(Component, Default)]
#[require(DepthPrepass, Hdr, sky_light::CloudSkyLight)]
pub struct VolumetricClouds {
    /// Steps along each view ray (1–1024): a budget for the whole ray, which the intervals where
    /// it crosses layers share in proportion to the steps each calls for (its length over
    /// [`VolumetricClouds::step_growth`] at its middle, so a near interval gets more per metre
    /// than a far one), and a ray through several layers costs no more steps than one through a
    /// single layer. Default 192 (`LOW` 160, `HIGH` 384, `ULTRA` 768).
    pub primary_steps: u32,
    /// Steps of the light march toward the sun from each sample (0–64; 0 = unshadowed), over
    /// a light path up to 2 km long; a longer path (a low sun's) takes proportionally more, up
    /// to 64. With an early exit ([`VolumetricClouds::transmittance_cutoff`] above 0), samples
    /// deep in a cloud take fewer: in proportion to the view transmittance once it is below
    /// 0.25 (never fewer than 4), as their light counts for that much less. Default 14 (`LOW`
    /// 12, `HIGH` 24, `ULTRA` 32).
    pub light_steps: u32,
    /// How fast steps grow with distance from the camera, 1/m: a step at distance `d` is
    /// `1 + step_growth · d` times longer than one at the camera. 0 keeps steps even.
    pub step_growth: f32,
    /// The march stops once the view transmittance falls below this (0–1). With
    /// [`VolumetricClouds::multiple_scattering`] that is the δ-scaled medium's transmittance
    /// `e^(−(1 − f) τ)` (`f` the phase's forward fraction), which carries a backlit cloud's glow
    /// and the sky behind a thin cloud: the true medium's `e^(−τ)` reaches the cut-off several
    /// times sooner and drops them. A ray 60° or more from the sun that ends in the sky stops at
    /// five times this (linearly more from about 32° on): away from the sun what lies beyond is
    /// diffuse light, which the light added at the stop carries. 0 marches every ray to its end
    /// with every light step ([`VolumetricClouds::light_steps`]). Default 0.01 (`LOW` 0.03, `ULTRA`
    /// 0.002).
    pub transmittance_cutoff: f32,
    /// Light scattered more than once: the δ-Eddington diffuse field of the sun and the sky in
    /// each cloud (validated against DISORT, `validation/README.md`). Off, the clouds get
    /// single scattering and a sky light that grows with height in the layer: cheaper by a few
    /// operations per sample, and far too dark inside thick clouds. Default true.
    pub multiple_scattering: bool,
    /// Jitter the ray start per pixel and frame (blue noise, animated with the golden ratio) to
    /// trade banding for fine noise, which [`VolumetricClouds::temporal_blend`] averages away.
    /// Default true.
    pub jitter: bool,
    /// Fraction of the view's resolution the march runs at, per axis (0.25–1). Below 1 the
    /// clouds are marched into a smaller image and upsampled with depth awareness, so they do
    /// not bleed over the edges of near geometry; 0.5 marches a quarter of the pixels. With the
    /// temporal accumulation on ([`VolumetricClouds::temporal_blend`]) each frame's rays go
    /// through another of the pixels each texel stands for, and a still view converges to the
    /// full resolution ([`composite::TemporalUpsampling`]), whatever the view's size. Default
    /// 0.25: a sixteenth of the rays (`ULTRA`: 1).
    pub resolution_scale: f32,
    /// Steps of the haze march along each view ray (1–128; [`haze`]). Default 12 (`LOW` 8,
    /// `HIGH` 16, `ULTRA` 48). Costs nothing while [`haze::Haze`] is clear.
    pub haze_steps: u32,
    /// Light shafts: the haze is lit through the cloud shadow map, so rays of light fall through
    /// the gaps in the clouds. A pass at
    /// [`VolumetricClouds::light_shaft_resolution_scale`] marches the haze along each view ray
    /// reading the map, and the march takes the mean sunlit fraction from it ([`haze`]). Needs
    /// [`shadow::CloudShadows`] on. Default true (`LOW` false: the haze uses the clouds' mean
    /// shade instead).
    pub light_shafts: bool,
    /// Temporal accumulation: the weight of each new frame in a running average of the jittered
    /// frames (0.02–1; 1 turns it off), reprojected through the camera's motion and clamped to
    /// the new frame's neighbourhood ([`composite`]). A still view at full resolution averages
    /// about `2 / blend` frames, which turns the jitter's noise into a converged image; at a
    /// reduced resolution each pixel takes its own sample once in `k²` frames (`k = 1 /
    /// resolution_scale`) with the weight `1 − (1 − blend)^k` and averages several of them (about
    /// 5 at the default blend and a quarter of the resolution)
    /// ([`crate::reference::composite::hit_blend`]). A pixel whose content moved takes
    /// `blend · (1 + pixels moved)`, so a turning camera's history blurs less. Only with
    /// [`VolumetricClouds::jitter`] on: without it every frame samples the same points.
    /// Default 0.1.
    pub temporal_blend: f32,
    /// Fraction of the view's resolution the light-shaft pass runs at, per axis (0.125–1).
    /// Shafts are soft, so a quarter of the resolution per axis (a sixteenth of the rays) keeps
    /// them; a depth-aware upsample keeps them off the edges of near geometry. Default 0.25
    /// (`ULTRA` 0.5).
    pub light_shaft_resolution_scale: f32,
    /// From this distance along the view ray on, metres, cloud samples light-march only the first
    /// four shadow-map texels toward the sun, in at most four steps, and read the rest of the
    /// way from the cloud shadow map ([`shadow::CloudShadows`]): that is four density samples
    /// instead of [`VolumetricClouds::light_steps`]. Only where the map covers the sample and
    /// may light it: not on view rays within about 32° of the sun (from there to 37° its
    /// sun's optical depth mixes the light march's and the map's in proportion to the angle, so
    /// the change draws no ring around the sun), where the phase function's
    /// forward peak turns the map's blur of thin, backlit edges (its texels are 156 m across
    /// the sun at the default 40 km and 256²) into the brightest error, and not under a sun
    /// below 10° (mixed in the same way while the sun climbs to 12°), whose long, nearly level
    /// sun lines cross several clouds between the map's knots (the cloud top and the altitudes
    /// of optical depths 1 and 4). Without a map
    /// (shadows off, night) the light march runs everywhere. It saves where a ray's samples
    /// take more than four light steps. Default 0 (every such sample; `HIGH` and `ULTRA`
    /// `f32::INFINITY`: never).
    pub sun_from_shadow_map_m: f32,
    /// Shortest primary step, metres: a short interval (a thin layer, a fog bank the camera
    /// looks up through) is marched in fewer than [`VolumetricClouds::primary_steps`] steps, one
    /// per `min_step_m`. Steps finer than the detail noise's texels (700 m / 32 = 22 m by
    /// default) add little. Default 40 m (`HIGH` 20 m, `ULTRA` 5 m); 0 always marches every
    /// primary step.
    pub min_step_m: f32,
    /// Most extra light-march steps per pixel footprint. A low sun's light path through a
    /// layer is kilometres long, so it takes [`VolumetricClouds::light_steps`] per 2 km of
    /// path, up to 64; a far sample's density is filtered over its footprint (the distance
    /// times the angle of a pixel of the march, hundreds of metres far away), so light steps
    /// much shorter than that resample the same blur. Those extra steps stop at this many per
    /// footprint (never fewer than `light_steps`), which matters most at sunset, where light
    /// paths are longest. `f32::INFINITY`, 0 or less, or NaN: no limit. Default 2 (`ULTRA` no
    /// limit).
    pub light_steps_per_footprint: f32,
    /// Most optical depth one light-march step spans where the layers its path reaches are at
    /// their peak extinction. A light path whose length times those peak extinctions is small
    /// takes fewer than [`VolumetricClouds::light_steps`] (at least 1), since a few steps give
    /// its transmittance as well as many: a veil of cirrostratus takes two to six instead of
    /// all of them, and a thick cloud never reaches the limit
    /// ([`optically_thin_light_steps`](crate::reference::render::optically_thin_light_steps)).
    /// NaN, 0 or less, or infinity: no limit. Default 0.125 (`ULTRA` no limit).
    pub light_step_optical_depth: f32,
    /// Share of [`VolumetricClouds::light_steps`] a view ray 60° or more from the sun takes
    /// (0–1): within about 32° of the sun a ray takes all of them, and linearly fewer between.
    /// Away from the sun the phase function sends a sample's direct sunlight toward the camera
    /// weakly, and its sky light and diffuse light, which depend far less on the sun's optical
    /// depth, carry it, so an error in that depth costs the image little there. 1: every ray
    /// takes every light step. Default 0.3 (`HIGH` 0.5, `ULTRA` 1).
    pub light_steps_away_from_sun: f32,
    /// Side of each layer's weather map, in weather-noise texels ([`weather_map`]): the march
    /// reads a layer's local coverage and the fine warp's curl from the map within
    /// `weather_map_size / 2` texels of the camera (12 km for cumulus at the default 512) and
    /// computes them at each sample farther out. The image is the same either way; the map saves
    /// the coverage arithmetic and half the weather-noise reads near the camera for one compute
    /// thread per texel and layer each frame, and `16 × weather_map_size²` bytes of GPU memory
    /// per layer. Clamped to the device's largest texture (at most 8192); below 2 turns the map
    /// off. Default 512.
    pub weather_map_size: u32,
    /// Set to true to make the temporal accumulation start over this frame: the frame is
    /// marched as if there were no history, which drops what the previous frames showed. Use it
    /// at a camera cut (a jump to another viewpoint, other layers): otherwise the old view's
    /// history is reprojected into the new one and fades over about `1 / temporal_blend`
    /// frames, clamped only to the new frame's noisy neighbourhood. The plugin sets it back to
    /// false once the frame is extracted, like `TemporalAntiAliasing::reset`. Default false.
    pub reset_history: bool,
}

impl VolumetricClouds {
    /// The cheapest: [`VolumetricClouds::MEDIUM`]'s quarter resolution, shortest step and sun
    /// from the shadow map with 160 primary and 12 light steps (about 4 for rays 60° or more
    /// from the sun), 8 haze steps, no light shafts, and rays that stop at a view transmittance
    /// of 0.03 (three times `MEDIUM`'s: most of a ray's cost lies in the cloud past its first
    /// cloudy step, and the light beyond the stop is added as if the medium went on). Measured
    /// time and error: `docs/performance.md`.
    pub const LOW: Self = Self {
        primary_steps: 160,
        light_steps: 12,
        transmittance_cutoff: 0.03,
        haze_steps: 8,
        light_shafts: false,
        ..Self::MEDIUM
    };
    /// The default balance of speed and quality: a quarter of the resolution per axis with
    /// temporal upsampling, 192 primary and 14 light steps (about 4 for rays 60° or more from the
    /// sun, at most two extra light steps per pixel footprint) and a 40 m shortest primary step
    /// on a sixteenth of the rays. Each
    /// frame the rays go through another pixel of their 4 × 4 block, and the accumulation
    /// assembles the full resolution over sixteen frames ([`composite::TemporalUpsampling`]). A
    /// still view converges close to a full-resolution march; while the camera moves the clouds
    /// are softer, each pixel taking new data only every sixteenth frame. It keeps multiple
    /// scattering: it costs arithmetic only, and dropping it darkens the clouds, most in
    /// overcast. Where the cloud shadow map may light a sample (rays away from the sun, a sun
    /// 10° or more up) the sample takes four light steps and the rest of its sun from the map
    /// ([`VolumetricClouds::sun_from_shadow_map_m`]). Measured time and error:
    /// `docs/performance.md`.
    pub const MEDIUM: Self = Self {
        primary_steps: 192,
        light_steps: 14,
        step_growth: 2.0e-5,
        transmittance_cutoff: 0.01,
        multiple_scattering: true,
        jitter: true,
        resolution_scale: 0.25,
        haze_steps: 12,
        light_shafts: true,
        temporal_blend: 0.1,
        light_shaft_resolution_scale: 0.25,
        sun_from_shadow_map_m: 0.0,
        min_step_m: 40.0,
        light_steps_per_footprint: 2.0,
        light_step_optical_depth: crate::reference::render::LIGHT_STEP_OPTICAL_DEPTH as f32,
        light_steps_away_from_sun: 0.3,
        weather_map_size: crate::reference::weather_map::DEFAULT_WEATHER_MAP_SIZE,
        reset_history: false,
    };
    /// More steps for close-ups and stills: [`VolumetricClouds::MEDIUM`]'s quarter resolution
    /// with 384 primary and 24 light steps (12 for rays 60° or more from the sun), a 20 m
    /// shortest primary step, 16 haze steps, and every sample's sun from the light march.
    /// Measured time and error: `docs/performance.md`.
    pub const HIGH: Self = Self {
        primary_steps: 384,
        light_steps: 24,
        haze_steps: 16,
        min_step_m: 20.0,
        light_steps_away_from_sun: 0.5,
        sun_from_shadow_map_m: f32::INFINITY,
        ..Self::MEDIUM
    };
    /// Many steps: screenshots and references. 768 primary and 32 light steps, every sample's
    /// sun from the light march, 5 m shortest step, early exit at a view transmittance of 0.002.
    pub const ULTRA: Self = Self {
        primary_steps: 768,
        light_steps: 32,
        resolution_scale: 1.0,
        transmittance_cutoff: 0.002,
        haze_steps: 48,
        light_shaft_resolution_scale: 0.5,
        min_step_m: 5.0,
        light_steps_per_footprint: f32::INFINITY,
        light_step_optical_depth: f32::INFINITY,
        light_steps_away_from_sun: 1.0,
        sun_from_shadow_map_m: f32::INFINITY,
        ..Self::MEDIUM
    };
}

impl VolumetricClouds {
    /// The knobs of these settings that the march itself reads (steps, growth, cut-off, multiple
    /// scattering, jitter, the shortest step and the light-step limits) as the CPU twin's
    /// settings, everything else at the defaults of
    /// [`MarchSettings`](crate::reference::render::MarchSettings): what the renderer extracts
    /// for a view before it adds the view, the world and the sun, and what a CPU march of a
    /// preset starts from (the bench's ground-truth scenes).
    #[doc(hidden)]
    #[must_use]
    pub fn march_knobs(&self) -> crate::reference::render::MarchSettings {
        use crate::reference::render::MarchSettings;
        MarchSettings {
            primary_steps: self.primary_steps,
            light_steps: self.light_steps,
            step_growth: f64::from(self.step_growth.max(0.0)),
            transmittance_cutoff: f64::from(self.transmittance_cutoff.clamp(0.0, 1.0)),
            multiple_scattering: self.multiple_scattering,
            jitter: self.jitter,
            min_step_m: if self.min_step_m.is_finite() {
                f64::from(self.min_step_m.max(0.0))
            } else {
                0.0
            },
            light_steps_away_from_sun: f64::from(self.light_steps_away_from_sun),
            sun_from_shadow_map_m: if self.sun_from_shadow_map_m.is_nan() {
                f64::INFINITY
            } else {
                f64::from(self.sun_from_shadow_map_m.max(0.0))
            },
            light_steps_per_footprint: f64::from(self.light_steps_per_footprint),
            light_step_optical_depth: f64::from(self.light_step_optical_depth),
            ..MarchSettings::default()
        }
    }

    /// The preset these settings are, or [`CloudQuality::Custom`] when a knob differs from every
    /// preset ([`VolumetricClouds::reset_history`] aside).
    #[must_use]
    pub fn quality(&self) -> CloudQuality {
        let knobs = Self {
            reset_history: false,
            ..self.clone()
        };
        [
            (Self::LOW, CloudQuality::Low),
            (Self::MEDIUM, CloudQuality::Medium),
            (Self::HIGH, CloudQuality::High),
            (Self::ULTRA, CloudQuality::Ultra),
        ]
        .into_iter()
        .find_map(|(preset, quality)| (preset == knobs).then_some(quality))
        .unwrap_or(CloudQuality::Custom)
    }

    /// The settings of a preset; [`VolumetricClouds::MEDIUM`] for [`CloudQuality::Custom`].
    #[must_use]
    pub const fn preset(quality: CloudQuality) -> Self {
        match quality {
            CloudQuality::Low => Self::LOW,
            CloudQuality::High => Self::HIGH,
            CloudQuality::Ultra => Self::ULTRA,
            CloudQuality::Medium | CloudQuality::Custom => Self::MEDIUM,
        }
    }

    /// A cleaned copy that the renderer can trust; see [`VolumetricClouds::sanitize`].
    #[must_use]
    pub fn sanitized(&self) -> Self {
        let mut clean = self.clone();
        clean.sanitize();
        clean
    }

    /// Cleans the settings in place so that the renderer can trust them. The renderer draws
    /// the cleaned copy, and a `warn!` names each field it changes (once per camera and field).
    /// Each field is fixed as follows, and anything not listed is kept:
    ///
    /// - `primary_steps`: clamped to 1–1024; `light_steps`: at most 64;
    ///   `haze_steps`: clamped to 1–128;
    ///   `weather_map_size`: at most 8192.
    /// - `step_growth`: a negative or non-finite value becomes 0 (even steps).
    /// - `transmittance_cutoff`: clamped to 0–1; NaN becomes the default 0.01.
    /// - `resolution_scale`: clamped to 0.25–1; NaN becomes 1.
    /// - `light_shaft_resolution_scale`: clamped to 0.125–1; NaN becomes 0.25.
    /// - `temporal_blend`: clamped to 0.02–1; NaN becomes 1 (no accumulation).
    /// - `sun_from_shadow_map_m`: NaN becomes `f32::INFINITY` (never); a negative value 0.
    /// - `min_step_m`: a negative or non-finite value becomes 0 (every primary step marched).
    /// - `light_steps_away_from_sun`: clamped to 0–1; NaN becomes 1 (every light step).
    ///
    /// `light_steps_per_footprint` and `light_step_optical_depth` take any value (NaN, 0 or
    /// less, or infinity: no limit).
    pub fn sanitize(&mut self) {
        use crate::clean::{clamp_or, non_negative};
        use crate::reference::{
            haze::MAX_HAZE_STEPS,
            render::{MAX_LIGHT_STEPS, MAX_PRIMARY_STEPS},
            weather_map::MAX_WEATHER_MAP_SIZE,
        };
        let defaults = Self::MEDIUM;

        self.primary_steps = self.primary_steps.clamp(1, MAX_PRIMARY_STEPS);
        self.light_steps = self.light_steps.min(MAX_LIGHT_STEPS);
        self.haze_steps = self.haze_steps.clamp(1, MAX_HAZE_STEPS);
        self.weather_map_size = self.weather_map_size.min(MAX_WEATHER_MAP_SIZE);
        self.step_growth = non_negative(self.step_growth);
        self.transmittance_cutoff = clamp_or(
            self.transmittance_cutoff,
            0.0,
            1.0,
            defaults.transmittance_cutoff,
        );
        self.resolution_scale = clamp_or(self.resolution_scale, 0.25, 1.0, 1.0);
        self.light_shaft_resolution_scale =
            clamp_or(self.light_shaft_resolution_scale, 0.125, 1.0, 0.25);
        self.temporal_blend = clamp_or(self.temporal_blend, 0.02, 1.0, 1.0);
        self.sun_from_shadow_map_m = if self.sun_from_shadow_map_m.is_nan() {
            f32::INFINITY
        } else {
            self.sun_from_shadow_map_m.max(0.0)
        };
        self.min_step_m = non_negative(self.min_step_m);
        self.light_steps_away_from_sun = clamp_or(self.light_steps_away_from_sun, 0.0, 1.0, 1.0);
    }
}

impl VolumetricClouds {
    #[doc(hidden)]
    /// [`VolumetricClouds::temporal_blend`] as the accumulation uses it: `None` (off) without
    /// jitter, at 1 or more, or when not a number; otherwise at least 0.02.
    #[must_use]
    pub fn effective_temporal_blend(&self) -> Option<f32> {
        (self.jitter && self.temporal_blend < 1.0).then(|| self.temporal_blend.max(0.02))
    }
}

impl Default for VolumetricClouds {
    fn default() -> Self {
        Self::MEDIUM
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// `field` set to each of `given` is cleaned to the matching `used`.
    fn check<T: Copy + std::fmt::Debug + PartialEq>(
        field: impl Fn(&mut VolumetricClouds) -> &mut T,
        cases: &[(T, T)],
    ) {
        for &(given, used) in cases {
            let mut clouds = VolumetricClouds::default();
            *field(&mut clouds) = given;
            let mut clean = clouds.sanitized();
            assert_eq!(*field(&mut clean), used, "{given:?}");
        }
    }

    #[test]
    fn quality_names_the_preset_the_knobs_are() {
        for quality in [
            CloudQuality::Low,
            CloudQuality::Medium,
            CloudQuality::High,
            CloudQuality::Ultra,
        ] {
            let mut clouds = VolumetricClouds::preset(quality);
            assert_eq!(clouds.quality(), quality);
            clouds.reset_history = true;
            assert_eq!(clouds.quality(), quality, "a reset is not a knob");
        }
        let custom = VolumetricClouds {
            primary_steps: 100,
            ..default()
        };
        assert_eq!(custom.quality(), CloudQuality::Custom);
    }

    #[test]
    fn sanitizing_repairs_every_field() {
        let nan = f32::NAN;
        let inf = f32::INFINITY;
        check(|c| &mut c.primary_steps, &[(0, 1), (5000, 1024), (64, 64)]);
        check(|c| &mut c.light_steps, &[(0, 0), (65, 64)]);
        check(|c| &mut c.haze_steps, &[(0, 1), (500, 128)]);
        check(|c| &mut c.weather_map_size, &[(0, 0), (10_000, 8192)]);
        check(
            |c| &mut c.step_growth,
            &[(-1.0, 0.0), (nan, 0.0), (inf, 0.0)],
        );
        check(
            |c| &mut c.transmittance_cutoff,
            &[(nan, 0.01), (-1.0, 0.0), (2.0, 1.0)],
        );
        check(
            |c| &mut c.resolution_scale,
            &[(nan, 1.0), (0.1, 0.25), (3.0, 1.0)],
        );
        check(
            |c| &mut c.light_shaft_resolution_scale,
            &[(nan, 0.25), (0.0, 0.125), (2.0, 1.0)],
        );
        check(
            |c| &mut c.temporal_blend,
            &[(nan, 1.0), (0.0, 0.02), (5.0, 1.0)],
        );
        check(
            |c| &mut c.sun_from_shadow_map_m,
            &[(nan, inf), (-5.0, 0.0), (inf, inf)],
        );
        check(
            |c| &mut c.min_step_m,
            &[(-5.0, 0.0), (nan, 0.0), (inf, 0.0)],
        );
        check(
            |c| &mut c.light_steps_away_from_sun,
            &[(nan, 1.0), (-1.0, 0.0), (2.0, 1.0), (0.5, 0.5)],
        );
    }
}
