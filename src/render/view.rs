//! The extracted view the cloud passes share: what a camera's march needs from the main world
//! ([`march_inputs`]), extracted each frame ([`ExtractedCloudView`]), and the GPU structs and
//! buffers it is written to (`GpuCloudUniforms`, `GpuCloudLayer`, `CloudViewBuffers`).
//! The march, composite, weather-map and shadow passes read it; it imports none of them.

use bevy::{
    diagnostic::FrameCount,
    light::Atmosphere,
    math::DVec3,
    prelude::*,
    render::{Extract, MainWorld, render_resource::*, sync_world::RenderEntity},
};

use super::{
    VolumetricClouds,
    growth::GrowthRun,
    haze::{GpuHazeUniforms, Haze, haze_settings},
};
use crate::{
    layers::{CloudKind, CloudLayer, LayerDrift},
    reference::composite::{sample_offset, upsampled_march_size, upsampling_factor},
    reference::{
        haze::HazeSettings,
        render::{LayerGrowth, MAX_FAR_COVERAGES, MAX_PROFILE_POINTS, MarchLayer, MarchSettings},
        shadow::ShadowMapFrame,
    },
    sky::{Sun, light},
    world::CloudWorld,
};

#[doc(hidden)]
/// The sun as the clouds see it.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct CloudSun {
    /// Unit vector toward the sun, world space.
    pub direction: Vec3,
    /// Illuminance of the light, RGB lux, as set on the `DirectionalLight` (colour ×
    /// illuminance).
    pub illuminance_rgb: [f64; 3],
    /// Whether to attenuate the light through the air with [`light::sun_transmittance_rgb`]
    /// (true when the scene has Bevy's `Atmosphere`, which expects sunlight above the air).
    pub through_atmosphere: bool,
}

impl CloudSun {
    /// The sun among `lights` (`(light, transform, has Sun)`): the light with
    /// [`Sun`] wins, otherwise the first directional light; `None` without one.
    pub fn pick<'a>(
        lights: impl IntoIterator<Item = (&'a DirectionalLight, &'a GlobalTransform, bool)>,
        through_atmosphere: bool,
    ) -> Option<Self> {
        lights
            .into_iter()
            .max_by_key(|(_, _, is_sun)| *is_sun)
            .map(|(light, transform, _)| {
                let colour = light.color.to_linear();
                let e = f64::from(light.illuminance);
                Self {
                    direction: -transform.forward().as_vec3(),
                    illuminance_rgb: [
                        f64::from(colour.red) * e,
                        f64::from(colour.green) * e,
                        f64::from(colour.blue) * e,
                    ],
                    through_atmosphere,
                }
            })
    }
}

/// Night-sky radiance (airglow and starlight), cd/m², so clouds at night are very dark but
/// neither black nor noise (about 10⁻⁴ cd/m² for a moonless sky; Leinert et al. 1998).
const NIGHT_SKY_RADIANCE: [f64; 3] = [0.6e-4, 0.8e-4, 1.2e-4];
/// Albedo of the ground that lights cloud bases from below.
pub(crate) const GROUND_ALBEDO: f64 = 0.2;

#[doc(hidden)]
/// One layer as [`march_inputs`] takes it: the layer, its wind drift and the clouds of its
/// growth automaton. Made from `(layer, drift)` or, as the systems query them,
/// `(layer, drift, run)`.
#[derive(Clone, Copy, Debug)]
pub struct LayerInput<'a> {
    /// The layer.
    pub layer: &'a CloudLayer,
    /// How far the wind has carried it (none: not at all).
    pub drift: Option<&'a LayerDrift>,
    /// Its clouds from the growth automaton (none: the weather noise's).
    pub growth: Option<&'a LayerGrowth>,
}

impl<'a> From<(&'a CloudLayer, Option<&'a LayerDrift>)> for LayerInput<'a> {
    fn from((layer, drift): (&'a CloudLayer, Option<&'a LayerDrift>)) -> Self {
        Self {
            layer,
            drift,
            growth: None,
        }
    }
}

impl<'a>
    From<(
        &'a CloudLayer,
        Option<&'a LayerDrift>,
        Option<&'a GrowthRun>,
    )> for LayerInput<'a>
{
    fn from(
        (layer, drift, run): (
            &'a CloudLayer,
            Option<&'a LayerDrift>,
            Option<&'a GrowthRun>,
        ),
    ) -> Self {
        Self {
            layer,
            drift,
            growth: run.map(GrowthRun::growth),
        }
    }
}

/// What the systems that build march inputs read of each layer ([`LayerInput`]).
pub(crate) type LayerInputData = (
    &'static CloudLayer,
    Option<&'static LayerDrift>,
    Option<&'static GrowthRun>,
);

#[doc(hidden)]
/// The march inputs for one camera: f64 settings and the visible layers, from the same numbers
/// the CPU reference renders with.
///
/// `camera` is the camera's world transform, `pixel_angle_rad` the angle one pixel subtends,
/// `layers` each layer with its wind drift. Invisible layers ([`CloudLayer::is_visible`]) are
/// left out.
pub fn march_inputs<'a>(
    world: &CloudWorld,
    settings: &VolumetricClouds,
    camera: &GlobalTransform,
    pixel_angle_rad: f64,
    sun: Option<&CloudSun>,
    layers: impl IntoIterator<Item = impl Into<LayerInput<'a>>>,
    frame_index: u32,
) -> (MarchSettings, Vec<MarchLayer>) {
    let settings = &settings.sanitized();
    let world = &world.sanitized();
    let radius = f64::from(world.planet_radius_m);
    let position = camera.translation().as_dvec3();
    let (up, camera_altitude_m) = world.camera_up_and_altitude(position);

    let mut march_layers = Vec::new();
    for input in layers {
        let input: LayerInput = input.into();
        let layer = input.layer.sanitized();
        if !layer.is_visible() {
            continue;
        }
        let drift = input.drift.copied().unwrap_or_default();
        let mut march = march_layer(world, &layer, &drift, position);
        march.growth = input.growth.cloned();
        if let Some(rain) = rain_shaft(&layer, &march) {
            march_layers.push(rain);
        }
        march_layers.push(march);
    }

    let mut march = MarchSettings {
        planet_radius_m: radius,
        camera_altitude_m,
        camera_up: up.to_array(),
        phase_g_forward: f64::from(world.phase_g_forward),
        phase_g_back: f64::from(world.phase_g_back),
        phase_blend: f64::from(world.phase_blend),
        pixel_angle_rad,
        frame_index,
        ..settings.march_knobs()
    };

    let lowest_base = march_layers
        .iter()
        .map(|l| l.base_m)
        .fold(f64::INFINITY, f64::min);
    let cloud_altitude_asl = f64::from(world.ground_height_m) + lowest_base.max(0.0);
    match sun {
        Some(sun) if sun.direction.is_finite() && sun.direction.length_squared() > 0.0 => {
            let direction = sun.direction.as_dvec3().normalize();
            let elevation_deg = direction.dot(up).clamp(-1.0, 1.0).asin().to_degrees();
            let transmittance = if sun.through_atmosphere {
                light::sun_transmittance_rgb(elevation_deg, cloud_altitude_asl)
            } else {
                [1.0; 3]
            };
            // Under Bevy's atmosphere the light shines through twilight (`sky::twilight_share`)
            // and the march takes it off each sample in the Earth's shadow
            // (`light_march_distance`), so high cloud stays lit after sunset; without one the
            // light goes with the sun's disc at the camera's horizon.
            let visible = if sun.through_atmosphere {
                1.0
            } else {
                f64::from(crate::sky::sun_visibility(elevation_deg))
            };
            // The fade into what lies behind a cloud takes that for the air's light, which it
            // is where Bevy's atmosphere draws the sky and the aerial perspective; a plain
            // background (a clear colour, black) is not, and would tint far clouds with it.
            march.clear_air = sun.through_atmosphere;
            march.sun_direction = direction.to_array();
            march.sun_illuminance =
                std::array::from_fn(|c| sun.illuminance_rgb[c] * transmittance[c] * visible);
            let sky =
                light::sky_radiance_rgb(sun.illuminance_rgb, elevation_deg, cloud_altitude_asl);
            let sin_h = elevation_deg.to_radians().sin().max(0.0);
            march.ambient_top = std::array::from_fn(|c| sky[c] + NIGHT_SKY_RADIANCE[c]);
            // Light reflected by the ground under the clouds: sun and sky on a Lambertian
            // ground, radiance albedo · E / π.
            march.ambient_bottom = std::array::from_fn(|c| {
                GROUND_ALBEDO * (march.sun_illuminance[c] * sin_h + sky[c] * std::f64::consts::PI)
                    / std::f64::consts::PI
                    + NIGHT_SKY_RADIANCE[c]
            });
        }
        _ => {
            march.sun_direction = up.to_array();
            march.sun_illuminance = [0.0; 3];
            march.ambient_top = NIGHT_SKY_RADIANCE;
            march.ambient_bottom = NIGHT_SKY_RADIANCE;
        }
    }
    crate::reference::render::sky_light_under_layers(&march, &mut march_layers);
    (march, march_layers)
}

/// One layer's march parameters, with noise offsets from the camera position plus wind drift,
/// wrapped in f64 by each noise period. `layer` is sanitized ([`CloudLayer::sanitize`]), so its
/// values are taken as they are.
fn march_layer(
    world: &CloudWorld,
    layer: &CloudLayer,
    drift: &LayerDrift,
    camera: DVec3,
) -> MarchLayer {
    let mut march = MarchLayer {
        base_m: f64::from(layer.base_m),
        top_m: f64::from(layer.top_m),
        coverage: f64::from(layer.coverage),
        extinction: f64::from(layer.density),
        weather_scale_m: f64::from(layer.weather_map_scale_m),
        shape_scale_m: f64::from(world.shape_scale_m),
        detail_scale_m: f64::from(world.detail_scale_m),
        detail_erosion: f64::from(world.detail_erosion),
        shape_strength: f64::from(layer.shape_noise),
        precipitation: f64::from(layer.precipitation),
        coverage_height: f64::from(layer.coverage_height),
        // Ice-crystal veils make the 22° halo.
        halo_share: if layer.kind == CloudKind::Cirrostratus {
            f64::from(world.halo_share)
        } else {
            0.0
        },
        ..default()
    };
    // Noise axes are world +X (east) and +Z (south) at the camera; drift is [east, north] and
    // world drift is (east, −north). A look-up at `x − drift` shows the pattern carried to `x`,
    // so the origin is the camera minus the drift.
    march.set_noise_origin([camera.x - drift.offset_m[0], camera.z + drift.offset_m[1]]);
    let [east, north] = layer.wind_m_s;
    let wind = Vec2::new(east, -north);
    // Tops lean downwind: the look-up at height z goes upwind by skew · z.
    let skew = if wind.length_squared() > 0.0 && layer.skew.is_finite() {
        -wind.normalize() * layer.skew
    } else {
        Vec2::ZERO
    };
    march.skew = [f64::from(skew.x), f64::from(skew.y)];
    // The profile curve, sampled at evenly spaced heights including both ends.
    let last = (MAX_PROFILE_POINTS - 1) as f32;
    let points: Vec<[f64; 2]> = (0..MAX_PROFILE_POINTS)
        .map(|i| {
            let h = i as f32 / last;
            [f64::from(h), f64::from(layer.profile.evaluate(h))]
        })
        .collect();
    march.set_profile(&points);
    march_far_coverage(&mut march, layer, camera);
    march
}

/// The rain falling from a raining layer as a layer of its own, from the ground to the cloud
/// base: where the cloud has coverage, extinction
/// [`rain_extinction_per_m`](crate::layers::rain::rain_extinction_per_m) of its rain rate, no
/// shape noise (straight shafts), the cloud's weather pattern (and far coverages), and a
/// scattering albedo of one half (the diffracted half of the extinction goes straight on). Seen
/// from afar these are the grey shafts under showers; from inside, the rain's haze. `None` for a
/// dry layer or one on the ground.
fn rain_shaft(layer: &CloudLayer, cloud: &MarchLayer) -> Option<MarchLayer> {
    let extinction = crate::layers::rain::rain_extinction_per_m(layer.rain_mm_per_h);
    if !(extinction > 0.0 && cloud.base_m > 0.0) {
        return None;
    }
    let mut rain = MarchLayer {
        base_m: 0.0,
        top_m: cloud.base_m,
        extinction: f64::from(extinction),
        shape_strength: 0.0,
        detail_erosion: 0.0,
        precipitation: 1.0,
        halo_share: 0.0,
        skew: [0.0; 2],
        // The rain falls from the whole cloud base, however high the cloud above it reaches.
        coverage_height: 0.0,
        ..cloud.clone()
    };
    rain.set_profile(&[]);
    Some(rain)
}

/// Fills [`MarchLayer::far`] from the layer's far coverages. Along the noise axes (x east, z
/// south) a point `p` relative to the camera is the fraction `dot(p + c − from, a)` of the way
/// from the near place to the far one, with `a = (to − from) / |to − from|²` and `c` the camera:
/// the f64 part `dot(c − from, a)` becomes the offset.
fn march_far_coverage(march: &mut MarchLayer, layer: &CloudLayer, camera: DVec3) {
    let usable = layer.far_coverage.iter().filter(|far| far.is_usable());
    let mut count = 0;
    for (slot, far) in march.far.iter_mut().zip(usable) {
        let axes = |[east, north]: [f32; 2]| [f64::from(east), -f64::from(north)];
        let (from, to) = (axes(far.from_m), axes(far.to_m));
        let d = [to[0] - from[0], to[1] - from[1]];
        let length_sq = d[0] * d[0] + d[1] * d[1];
        let a = [d[0] / length_sq, d[1] / length_sq];
        let offset = (camera.x - from[0]) * a[0] + (camera.z - from[1]) * a[1];
        *slot = [a[0], a[1], offset, f64::from(far.coverage.clamp(0.0, 1.0))];
        count += 1;
    }
    march.far_count = count;
}

/// Per-view uniforms, laid out as `CloudUniforms` in `parameters.wgsl` (288 bytes).
#[derive(ShaderType, Clone, Debug, Default)]
pub(crate) struct GpuCloudUniforms {
    planet_radius_m: f32,
    camera_altitude_m: f32,
    pixel_angle_rad: f32,
    step_growth: f32,
    primary_steps: u32,
    light_steps: u32,
    multiple_scattering: u32,
    layer_count: u32,
    transmittance_cutoff: f32,
    forward_fraction: f32,
    scaled_asymmetry: f32,
    forward_cap: f32,
    phase_g_forward: f32,
    phase_g_back: f32,
    phase_blend: f32,
    jitter: u32,
    frame_index: u32,
    sun_from_shadow_map_m: f32,
    shadow_map: u32,
    min_step_m: f32,
    sample_offset_uv: Vec2,
    march_uv_scale: Vec2,
    light_steps_per_footprint: f32,
    light_steps_away_from_sun: f32,
    clear_air: u32,
    light_step_optical_depth: f32,
    camera_up: Vec4,
    sun_direction: Vec4,
    sun_illuminance: Vec4,
    ambient_top: Vec4,
    ambient_bottom: Vec4,
    shadow_map_centre_m: Vec4,
    shadow_map_axis_x: Vec4,
    shadow_map_axis_y: Vec4,
    shadow_map_range_m: Vec4,
    flash: Vec4,
    peak_caps: Vec4,
    peak_spread: Vec4,
}

// The peak's caps fill `peak_caps.xyz` and its angle's cosine `w`.
const _: () = assert!(crate::reference::render::PEAK_ORDERS <= 3);

/// f32 has no infinity the shader can compare safely: "never" is this (WGSL: `FAR_AWAY`).
const FAR_AWAY: f32 = crate::reference::composite::FAR_AWAY as f32;

/// `axis / |axis|²`: what a dot product with turns a position into the map's local coordinate.
fn inverse_axis(axis: [f64; 3]) -> Vec4 {
    let v = DVec3::from_array(axis);
    let length_squared = v.length_squared();
    if length_squared > 0.0 {
        (v / length_squared).as_vec3().extend(0.0)
    } else {
        Vec4::ZERO
    }
}

/// A limit the shader reads as "0: no limit": the value where it is positive and below
/// [`FAR_AWAY`], 0 for anything else (NaN, 0 or less, infinity).
fn limit_or_none(limit: f64) -> f32 {
    if limit > 0.0 && limit < f64::from(FAR_AWAY) {
        limit as f32
    } else {
        0.0
    }
}

fn vec4(xyz: [f64; 3]) -> Vec4 {
    Vec4::new(xyz[0] as f32, xyz[1] as f32, xyz[2] as f32, 0.0)
}

impl GpuCloudUniforms {
    /// The uniforms for `settings` with `layer_count` layers in the storage buffer, and the
    /// cloud shadow map's frame (relative to the view's camera) when one is bound.
    pub fn new(settings: &MarchSettings, layer_count: u32, map: Option<&ShadowMapFrame>) -> Self {
        let sun_from_map = match map {
            Some(_) if settings.sun_from_shadow_map_m < f64::from(FAR_AWAY) => {
                settings.sun_from_shadow_map_m.max(0.0) as f32
            }
            _ => FAR_AWAY,
        };
        let phase = crate::reference::render::eddington_phase(settings);
        Self {
            planet_radius_m: settings.planet_radius_m as f32,
            camera_altitude_m: settings.camera_altitude_m as f32,
            pixel_angle_rad: settings.pixel_angle_rad as f32,
            step_growth: settings.step_growth as f32,
            primary_steps: settings.primary_steps,
            light_steps: settings.light_steps,
            multiple_scattering: u32::from(settings.multiple_scattering),
            layer_count,
            transmittance_cutoff: settings.transmittance_cutoff as f32,
            forward_fraction: phase.forward_fraction as f32,
            scaled_asymmetry: phase.scaled_asymmetry as f32,
            forward_cap: phase.forward_cap as f32,
            phase_g_forward: settings.phase_g_forward as f32,
            phase_g_back: settings.phase_g_back as f32,
            phase_blend: settings.phase_blend as f32,
            jitter: u32::from(settings.jitter),
            frame_index: settings.frame_index,
            sun_from_shadow_map_m: sun_from_map,
            shadow_map: u32::from(map.is_some()),
            min_step_m: settings.min_step_m as f32,
            sample_offset_uv: Vec2::ZERO,
            march_uv_scale: Vec2::ONE,
            light_steps_per_footprint: limit_or_none(settings.light_steps_per_footprint),
            light_steps_away_from_sun: crate::reference::render::away_from_sun_share(
                settings.light_steps_away_from_sun,
            ),
            clear_air: u32::from(settings.clear_air),
            light_step_optical_depth: limit_or_none(settings.light_step_optical_depth),
            camera_up: vec4(settings.camera_up),
            sun_direction: vec4(settings.sun_direction),
            sun_illuminance: vec4(settings.sun_illuminance),
            ambient_top: vec4(settings.ambient_top),
            ambient_bottom: vec4(settings.ambient_bottom),
            shadow_map_centre_m: map.map_or(Vec4::ZERO, |m| vec4(m.centre_m)),
            shadow_map_axis_x: map.map_or(Vec4::ZERO, |m| inverse_axis(m.axis_x_m)),
            shadow_map_axis_y: map.map_or(Vec4::ZERO, |m| inverse_axis(m.axis_y_m)),
            shadow_map_range_m: map.map_or(Vec4::ZERO, |m| {
                let [bottom, top] = m.cloud_range_m;
                Vec4::new(bottom as f32, top as f32, m.texel_m() as f32, 0.0)
            }),
            flash: vec4(settings.flash_position_m).with_w(if settings.flash_intensity_cd > 0.0 {
                settings.flash_intensity_cd as f32
            } else {
                0.0
            }),
            peak_caps: {
                let mut caps = [0.0; 4];
                for (slot, cap) in caps.iter_mut().zip(phase.peak_caps) {
                    *slot = cap as f32;
                }
                caps[3] = phase.forward_peak_cos as f32;
                Vec4::from_array(caps)
            },
            peak_spread: Vec4::from_array(phase.peak_spread.map(|t| t as f32)),
        }
    }

    /// These uniforms with the temporal upsampling's offset of this frame's rays, in uv
    /// ([`TemporalUpsampling::offset_uv`]), and the screen's uv per march uv
    /// ([`TemporalUpsampling::uv_scale`]).
    pub(crate) fn with_upsampling(mut self, upsampling: &TemporalUpsampling) -> Self {
        self.sample_offset_uv = upsampling.offset_uv;
        self.march_uv_scale = upsampling.uv_scale;
        self
    }
}

/// One layer, laid out as `CloudLayerGpu` in `parameters.wgsl` (256 bytes).
#[derive(ShaderType, Clone, Debug, Default)]
pub(crate) struct GpuCloudLayer {
    base_m: f32,
    top_m: f32,
    coverage: f32,
    extinction: f32,
    weather_scale_m: f32,
    shape_scale_m: f32,
    detail_scale_m: f32,
    detail_erosion: f32,
    shape_strength: f32,
    precipitation: f32,
    profile_count: u32,
    far_count: u32,
    coverage_height: f32,
    halo_share: f32,
    warp_offset_m: Vec2,
    weather_offset_m: Vec4,
    noise_offset_m: Vec4,
    profile: [Vec4; 4],
    far: [Vec4; MAX_FAR_COVERAGES],
    weather_map: Vec4,
    growth: Vec4,
    sky_light_top: Vec4,
    sky_light_bottom: Vec4,
}

impl GpuCloudLayer {
    /// Points the layer at slice `slice` of a weather map of side `size` texels whose texel
    /// `(0, 0)` is weather texel `origin` ([`crate::reference::weather_map::weather_map_origin`]).
    /// Without a call the layer has no map and the march computes its coverage at every sample.
    pub(crate) fn set_weather_map(&mut self, origin: [i64; 2], slice: u32, size: u32) {
        self.weather_map = Vec4::new(
            origin[0] as f32,
            origin[1] as f32,
            slice as f32,
            size as f32,
        );
    }
}

impl From<&MarchLayer> for GpuCloudLayer {
    fn from(layer: &MarchLayer) -> Self {
        let rgb = |v: [f64; 3]| Vec4::new(v[0] as f32, v[1] as f32, v[2] as f32, 0.0);
        let p = |i: usize| layer.profile[i].map(|v| v as f32);
        let pair = |i: usize| {
            let (a, b) = (p(2 * i), p(2 * i + 1));
            Vec4::new(a[0], a[1], b[0], b[1])
        };
        Self {
            base_m: layer.base_m as f32,
            top_m: layer.top_m as f32,
            coverage: layer.coverage as f32,
            extinction: layer.extinction as f32,
            weather_scale_m: layer.weather_scale_m as f32,
            shape_scale_m: layer.shape_scale_m as f32,
            detail_scale_m: layer.detail_scale_m as f32,
            detail_erosion: layer.detail_erosion as f32,
            shape_strength: layer.shape_strength as f32,
            precipitation: layer.precipitation as f32,
            profile_count: layer.profile_points,
            far_count: layer.far_count.min(MAX_FAR_COVERAGES as u32),
            coverage_height: layer.coverage_height as f32,
            halo_share: layer.halo_share as f32,
            warp_offset_m: Vec2::new(layer.warp_offset_m[0] as f32, layer.warp_offset_m[1] as f32),
            weather_offset_m: Vec4::new(
                layer.weather_offset_m[0] as f32,
                layer.weather_offset_m[1] as f32,
                layer.skew[0] as f32,
                layer.skew[1] as f32,
            ),
            noise_offset_m: Vec4::new(
                layer.shape_offset_m[0] as f32,
                layer.shape_offset_m[1] as f32,
                layer.detail_offset_m[0] as f32,
                layer.detail_offset_m[1] as f32,
            ),
            profile: std::array::from_fn(pair),
            far: layer
                .far
                .map(|f| Vec4::new(f[0] as f32, f[1] as f32, f[2] as f32, f[3] as f32)),
            weather_map: Vec4::ZERO,
            growth: layer.growth.as_ref().map_or(Vec4::ZERO, |growth| {
                Vec4::new(
                    1.0,
                    growth.slice as f32,
                    growth.size[0].max(1) as f32,
                    growth.size[1].max(1) as f32,
                )
            }),
            sky_light_top: rgb(layer.sky_light_top),
            sky_light_bottom: rgb(layer.sky_light_bottom),
        }
    }
}

#[doc(hidden)]
/// The clouds of one view, extracted each frame; absent when the view has no visible layer.
#[derive(Component, Clone, Debug)]
pub struct ExtractedCloudView {
    /// The march settings (f64, as the CPU reference uses them).
    pub settings: MarchSettings,
    /// The visible layers.
    pub layers: Vec<MarchLayer>,
    /// [`VolumetricClouds::resolution_scale`], sanitized.
    pub resolution_scale: f32,
    /// The haze along the view's rays.
    pub haze: HazeSettings,
    /// [`VolumetricClouds::light_shaft_resolution_scale`] (sanitized) when the view draws light
    /// shafts (haze, and [`VolumetricClouds::light_shafts`] on); `None` otherwise.
    pub shaft_resolution_scale: Option<f32>,
    /// [`VolumetricClouds::effective_temporal_blend`]: the temporal accumulation's weight of
    /// the new frame, `None` when it is off.
    pub temporal_blend: Option<f32>,
    /// World position of the camera, m (places the cloud shadow map for the light shafts).
    pub camera_m: DVec3,
    /// [`VolumetricClouds::weather_map_size`].
    pub weather_map_size: u32,
    /// Where this frame's reduced-resolution rays pass through their texels (none without the
    /// temporal accumulation or at full resolution).
    pub upsampling: TemporalUpsampling,
    /// [`VolumetricClouds::reset_history`]: the temporal accumulation starts over this frame.
    pub reset_history: bool,
}

/// How many times the march pass ran, for diagnostics and tests (render world).
#[derive(Resource, Debug, Default, Clone, Copy)]
pub struct CloudPassStats {
    /// Views marched since start-up.
    pub views_marched: u64,
    /// Of those, views marched at a reduced resolution and upsampled.
    pub views_upsampled: u64,
    /// Of those, views whose light shafts ran (the reduced-resolution shaft pass).
    pub views_with_shafts: u64,
    /// Of those, views blended into their temporal history.
    pub views_accumulated: u64,
    /// Of those, views whose weather map was rebuilt ([`super::weather_map`]).
    pub views_with_weather_map: u64,
}

pub(crate) fn extract_cloud_views(
    mut commands: Commands,
    cameras: Extract<
        Query<(
            RenderEntity,
            &Camera,
            &VolumetricClouds,
            &GlobalTransform,
            &Projection,
        )>,
    >,
    layers: Extract<Query<LayerInputData>>,
    lights: Extract<Query<(&DirectionalLight, &GlobalTransform, Has<Sun>)>>,
    atmospheres: Extract<Query<(), With<Atmosphere>>>,
    frame: Extract<Res<FrameCount>>,
    haze: Extract<Option<Res<Haze>>>,
    world: Extract<Option<Res<CloudWorld>>>,
    stars: Extract<Option<Res<crate::sky::stars::StarSky>>>,
    lightning: Extract<Option<Res<crate::lightning::ActiveFlash>>>,
) {
    // The stars are drawn by the cloud composite: a clear night sky runs it for them alone.
    let stars = stars.as_deref().is_some_and(|s| s.zero_magnitude_lux > 0.0);
    let sun = CloudSun::pick(lights.iter(), !atmospheres.is_empty());
    let earth = CloudWorld::default();
    let world = world.as_deref().unwrap_or(&earth);
    let clear = Haze::default();
    let haze = haze.as_deref().unwrap_or(&clear);
    for (entity, camera, settings, transform, projection) in &cameras {
        let settings = &settings.sanitized();
        let mut entity_commands = commands.entity(entity);
        let height = camera
            .physical_viewport_size()
            .map_or(1, |size| size.y.max(1));
        let pixel_angle = match projection {
            Projection::Perspective(p) => f64::from(p.fov) / f64::from(height),
            // An orthographic or custom camera: one milliradian, the footprint of a 60° view
            // over a thousand pixels.
            _ => 1.0e-3,
        };
        let (mut march, march_layers) = march_inputs(
            world,
            settings,
            transform,
            pixel_angle,
            sun.as_ref(),
            layers.iter(),
            frame.0,
        );
        // A lightning flash lights the clouds from within (`crate::lightning`).
        if let Some(flash) = lightning.as_deref().and_then(|l| l.flash) {
            let offset = flash.position.as_dvec3() - transform.translation().as_dvec3();
            march.flash_position_m = offset.to_array();
            march.flash_intensity_cd = f64::from(flash.intensity_cd);
        }
        let haze = haze_settings(haze, settings, &march, &march_layers, GROUND_ALBEDO);
        // No cloud, no haze and no stars: the pass does not run.
        if !camera.is_active || (march_layers.is_empty() && !haze.is_active() && !stars) {
            entity_commands.remove::<ExtractedCloudView>();
            continue;
        }
        entity_commands.insert(ExtractedCloudView {
            settings: march,
            layers: march_layers,
            // `settings` is sanitized: both scales are in their documented ranges.
            resolution_scale: settings.resolution_scale,
            shaft_resolution_scale: (haze.shafts && haze.is_active())
                .then_some(settings.light_shaft_resolution_scale),
            temporal_blend: settings.effective_temporal_blend(),
            haze,
            camera_m: transform.translation().as_dvec3(),
            weather_map_size: settings.weather_map_size,
            // The march's targets are sized from the whole render target.
            upsampling: TemporalUpsampling::new(
                settings.effective_temporal_blend().is_some(),
                camera.physical_target_size().unwrap_or(UVec2::ONE),
                settings.resolution_scale,
                frame.0,
            ),
            reset_history: settings.reset_history,
        });
    }
}

/// Sets [`VolumetricClouds::reset_history`] back to false in the main world once
/// [`extract_cloud_views`] has seen it, so a reset lasts one frame.
pub(crate) fn clear_history_resets(mut main_world: ResMut<MainWorld>) {
    let mut cameras = main_world.query::<&mut VolumetricClouds>();
    for mut settings in cameras.iter_mut(&mut main_world) {
        if settings.reset_history {
            settings.reset_history = false;
        }
    }
}

/// The uniform and layer buffers of one view, written each frame.
#[derive(Component)]
pub(crate) struct CloudViewBuffers {
    pub(crate) uniforms: UniformBuffer<GpuCloudUniforms>,
    pub(crate) layers: StorageBuffer<Vec<GpuCloudLayer>>,
    pub(crate) haze: UniformBuffer<GpuHazeUniforms>,
    /// The shadow map the haze reads, if it reads one.
    pub(crate) shadow_map: Option<AssetId<Image>>,
    /// Whether the shaft pass runs (light shafts on, haze, and a shadow map to read).
    pub(crate) shafts: bool,
    /// The weather map's (side, slices) when the layers read one.
    pub(crate) weather_map: Option<(u32, u32)>,
}

/// The temporal upsampling of a view that accumulates frames
/// ([`VolumetricClouds::temporal_blend`](super::VolumetricClouds::temporal_blend)) and marches
/// at a reduced resolution: each frame the march's rays go through the centre of another of the
/// `k × k` full-resolution pixels each texel stands for, and the accumulation blends each pixel
/// in on the frame its ray came through ([`crate::reference::composite`], "Temporal
/// upsampling"). A still view then converges to the full resolution in `k²` frames' worth of
/// samples per pixel.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct TemporalUpsampling {
    /// `k`, the [`upsampling_factor`]; 1 (no offset) without the accumulation or at full
    /// resolution.
    pub factor: u32,
    /// The march's image, texels: `⌈size / k⌉` with the upsampling, so that each texel stands
    /// for exactly `k × k` pixels whatever the view's size (the last row and column of texels
    /// may reach past the view's edge); [`low_res_size`] without it.
    pub size: UVec2,
    /// The view's uv per march uv (`size · k / view size`, at least 1): the march's image
    /// covers the view and the pixels past its edge. 1 without the upsampling.
    pub uv_scale: Vec2,
    /// Where this frame's rays pass through their texels, in texels from the centre
    /// ([`sample_offset`]).
    pub offset_texels: Vec2,
    /// The same in the view's uv (`offset_texels · k / view size`).
    pub offset_uv: Vec2,
}

impl TemporalUpsampling {
    /// The upsampling of frame `frame` of a view whose target is `size` pixels, marched at
    /// `scale` (the march's image size is [`TemporalUpsampling::size`], the size
    /// `CloudLowResTargets` get), accumulating when `accumulates`.
    pub fn new(accumulates: bool, size: UVec2, scale: f32, frame: u32) -> Self {
        let low = low_res_size(size, scale);
        let factor = if accumulates {
            upsampling_factor(size.to_array(), low.to_array())
        } else {
            1
        };
        if factor == 1 {
            return Self {
                factor,
                size: low,
                uv_scale: Vec2::ONE,
                offset_texels: Vec2::ZERO,
                offset_uv: Vec2::ZERO,
            };
        }
        let march = UVec2::from(upsampled_march_size(size.to_array(), factor));
        let [x, y] = sample_offset(frame, factor);
        let offset_texels = Vec2::new(x as f32, y as f32);
        let texel_uv = factor as f32 / size.max(UVec2::ONE).as_vec2();
        Self {
            factor,
            size: march,
            uv_scale: march.as_vec2() * texel_uv,
            offset_texels,
            offset_uv: offset_texels * texel_uv,
        }
    }
}

#[doc(hidden)]
/// Size of a reduced-resolution image for a view of `size` pixels at `scale`: each side
/// rounded up, at least 1.
pub fn low_res_size(size: UVec2, scale: f32) -> UVec2 {
    (size.as_vec2() * scale).ceil().as_uvec2().max(UVec2::ONE)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::layers::{CloudKind, FarCoverage};
    use crate::reference::render::layer_coverage;

    /// Noise small enough for a debug build to make in a blink, for the CPU marches here.
    fn small_textures() -> crate::reference::render::CloudTextures {
        crate::reference::render::CloudTextures::from_recipe(
            &crate::reference::noise::NoiseRecipe {
                base_size: 8,
                detail_size: 8,
                weather_size: 16,
                ..Default::default()
            },
        )
    }

    /// The CPU twin's march of one ray from the camera of `march` along `direction`, ending at
    /// `t_max` (m), with a jitter of 0.5.
    fn march_ray(
        textures: &crate::reference::render::CloudTextures,
        march: &MarchSettings,
        layers: &[MarchLayer],
        direction: [f64; 3],
        t_max: f64,
    ) -> crate::reference::render::MarchResult {
        crate::reference::render::march_clouds(
            textures,
            march,
            layers,
            march.camera_altitude_m,
            march.camera_up,
            direction,
            t_max,
            0.5,
            None,
        )
    }

    /// The march inputs of `layer` alone for a default camera setup at `camera`, no sun.
    fn inputs(layer: &CloudLayer, camera: &GlobalTransform) -> (MarchSettings, Vec<MarchLayer>) {
        march_inputs(
            &CloudWorld::default(),
            &VolumetricClouds::default(),
            camera,
            1e-3,
            None,
            [(layer, None)],
            0,
        )
    }

    #[test]
    fn a_camera_far_out_in_a_flat_world_sees_the_clouds_as_at_the_origin() {
        let layer = CloudLayer::default();
        let at = |world: &CloudWorld, x: f32, z: f32| {
            march_inputs(
                world,
                &VolumetricClouds::default(),
                &GlobalTransform::from_xyz(x, 2.0, z),
                1e-3,
                None,
                [(&layer, None)],
                0,
            )
            .0
        };
        let flat = CloudWorld::default();
        let origin = at(&flat, 0.0, 0.0);
        for (x, z) in [(1.0e6, -1.0e6), (-1.0e6, 3.0e5)] {
            let far = at(&flat, x, z);
            assert!((far.camera_altitude_m - 2.0).abs() < 1e-3, "{x} {z}");
            assert_eq!(far.camera_up, origin.camera_up);
        }
        // On a globe the same camera 1 000 km out is about 78 km above the curved ground
        // (sqrt(R² + d²) − R) and its up tilts by d / R.
        let globe = CloudWorld {
            anchor: crate::world::PlanetAnchor::Geocentric,
            ..default()
        };
        let far = at(&globe, 1.0e6, 0.0);
        let r = f64::from(globe.planet_radius_m);
        let expected = (r * r + 1.0e12_f64 + 4.0 * r + 4.0).sqrt() - r;
        assert!(
            (far.camera_altitude_m - expected).abs() < 1.0,
            "{}",
            far.camera_altitude_m
        );
        assert!(far.camera_up[0] > 0.15);
    }

    #[test]
    fn gpu_structs_match_the_shader_layout() {
        assert_eq!(GpuCloudUniforms::min_size().get(), 304);
        assert_eq!(GpuCloudLayer::min_size().get(), 256);
    }

    #[test]
    fn far_coverage_blends_toward_the_far_place() {
        // Near place at the origin, far place 20 km north (scene −z); the camera 2 km east.
        let layer = CloudLayer {
            coverage: 0.1,
            far_coverage: vec![FarCoverage {
                from_m: [0.0, 0.0],
                to_m: [0.0, 20_000.0],
                coverage: 0.9,
            }],
            ..CloudLayer::new(CloudKind::Cumulus)
        };
        let camera = GlobalTransform::from_xyz(2_000.0, 5.0, 0.0);
        let (_, layers) = inputs(&layer, &camera);
        let march = &layers[0];
        assert_eq!(march.far_count, 1);
        // Horizontal offsets are relative to the camera along (east, south).
        let at = |east: f64, north: f64| layer_coverage(march, [east - 2_000.0, -north]);
        assert!(
            (at(0.0, 0.0) - 0.1).abs() < 1e-6,
            "near place keeps its own"
        );
        assert!(
            (at(5_000.0, 5_900.0) - 0.1).abs() < 1e-6,
            "foreground unchanged"
        );
        assert!((at(-3_000.0, 20_000.0) - 0.9).abs() < 1e-6, "far place");
        assert!((at(0.0, 40_000.0) - 0.9).abs() < 1e-6, "beyond it");
        assert!(
            (at(0.0, -20_000.0) - 0.1).abs() < 1e-6,
            "behind the near place"
        );
        let mut last = 0.0;
        for k in 0..=20 {
            let c = at(0.0, f64::from(k) * 1_000.0);
            assert!(c >= last, "monotonic toward the far place");
            last = c;
        }
        // A clear near sky with a cloudy far place still uploads the layer.
        let clear_here = CloudLayer {
            coverage: 0.0,
            ..layer.clone()
        };
        assert!(clear_here.is_visible());
        let (_, layers) = inputs(&clear_here, &camera);
        assert_eq!(layers.len(), 1);
    }

    /// Just after sunset under Bevy's atmosphere (the sun 1° down) a cumulus 1.5–3 km up is
    /// still above the Earth's shadow (which reaches 1.4° below the horizon at 2 km) and is lit,
    /// reddened; a stratus a few hundred metres up is in the shadow and gets no sun. Without an
    /// atmosphere the light goes at sunset for every cloud.
    #[test]
    fn clouds_above_the_earths_shadow_keep_the_sun_after_sunset() {
        let textures = small_textures();
        let below = -1.0_f32.to_radians();
        let sun = |through_atmosphere, lux| CloudSun {
            direction: Vec3::new(0.0, below.sin(), -below.cos()),
            illuminance_rgb: [lux; 3],
            through_atmosphere,
        };
        // Toward the sun's azimuth, 20° up: the layer's radiance.
        let seen = |kind: CloudKind, through_atmosphere: bool, lux: f64| {
            let layer = CloudLayer {
                coverage: 1.0,
                ..CloudLayer::new(kind)
            };
            let (march, layers) = march_inputs(
                &CloudWorld::default(),
                &VolumetricClouds {
                    jitter: false,
                    ..VolumetricClouds::default()
                },
                &GlobalTransform::from_xyz(0.0, 2.0, 0.0),
                1e-3,
                Some(&sun(through_atmosphere, lux)),
                [(&layer, None)],
                0,
            );
            let up = 20.0_f64.to_radians();
            let result = march_ray(
                &textures,
                &march,
                &layers,
                [0.0, up.sin(), -up.cos()],
                f64::INFINITY,
            );
            (march, result.radiance)
        };
        let (lit, cumulus) = seen(CloudKind::Cumulus, true, 100_000.0);
        assert!(lit.sun_illuminance[0] > lit.sun_illuminance[2], "reddened");
        let (_, cumulus_bare) = seen(CloudKind::Cumulus, false, 100_000.0);
        // With no sun a cloud has only the night sky's glow, about 10⁻⁴ cd/m².
        assert!(
            cumulus[0] > 100.0 * cumulus_bare[0],
            "{cumulus:?} against {cumulus_bare:?}"
        );
        // The stratus under the atmosphere is as dark as with no sun at all.
        let (_, stratus) = seen(CloudKind::Stratus, true, 100_000.0);
        let (_, stratus_dark) = seen(CloudKind::Stratus, true, 0.0);
        assert!(
            (stratus[0] - stratus_dark[0]).abs() <= 1e-9 * stratus_dark[0],
            "{stratus:?} against {stratus_dark:?}"
        );
    }

    #[test]
    fn rain_falls_as_shafts_under_raining_layers() {
        let layer = CloudLayer {
            coverage: 1.0,
            rain_mm_per_h: 1.0,
            ..CloudLayer::new(CloudKind::Stratus)
        };
        let camera = GlobalTransform::from_xyz(0.0, 2.0, 0.0);
        let (march, layers) = inputs(&layer, &camera);
        assert_eq!(layers.len(), 2, "the rain shaft and the cloud");
        let rain = &layers[0];
        assert_eq!((rain.base_m, rain.top_m), (0.0, f64::from(layer.base_m)));
        let sigma = f64::from(crate::layers::rain::rain_extinction_per_m(1.0));
        assert!((rain.extinction - sigma).abs() < 1e-12);
        // A level ray under the cloud base through 3 km of rain: Beer–Lambert, the rain alone
        // (the clear air in front of it is `clear_air_transmittance`'s test).
        let march = MarchSettings {
            clear_air: false,
            ..march
        };
        let textures = small_textures();
        let result = march_ray(&textures, &march, &layers, [1.0, 0.0, 0.0], 3_000.0);
        let expected = (-sigma * 3_000.0).exp();
        assert!(
            (result.transmittance - expected).abs() < 1e-3 * expected,
            "{} vs {expected}",
            result.transmittance
        );
        // A dry layer adds nothing.
        let dry = CloudLayer {
            rain_mm_per_h: 0.0,
            ..layer
        };
        let (_, layers) = inputs(&dry, &camera);
        assert_eq!(layers.len(), 1);
    }
}
