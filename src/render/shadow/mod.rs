//! Cloud shadows: a shadow map of the clouds along the real sun, applied to every
//! `StandardMaterial` through Bevy's `DirectionalLightTexture`.
//!
//! # What it computes
//!
//! Each frame a compute pass (`shadow.wgsl`) fills an orthographic map along the sun direction,
//! centred near the first camera with [`VolumetricClouds`]: each texel holds the fraction of
//! direct sunlight that reaches the ground on its sun line through every [`CloudLayer`]
//! (`e^(−τ)`, marched through the same density model as the clouds you see, with the same wind
//! drift). [`crate::reference::shadow`] is its f64 CPU twin and documents the geometry and the
//! approximations. Shadows therefore fall away from the sun by `h / tan(elevation)`, move with
//! the wind and the sun, and are soft where clouds are thin.
//!
//! # How geometry receives it
//!
//! Bevy 0.19 can modulate a directional light by a texture projected along the light
//! (`DirectionalLightTexture`, a "light cookie"): the PBR shader multiplies **only that light's
//! direct term** by the texture's red channel, for every mesh lit by `StandardMaterial`
//! (terrain, buildings, props), with no change to any material. The projection is exactly an
//! orthographic map along the sun whose frame is the light's `Transform`: its rotation is the
//! sun's, its translation the map centre, its x/y scale half the map extent. So the plugin:
//!
//! - gives the sun light (the one with [`Sun`], else the first directional
//!   light) a `DirectionalLightTexture` with the map's image, tiled;
//! - moves that light's translation over the camera, snapped to whole texels in the light's
//!   plane (so the shadows do not shimmer as the camera moves) and lifted 1000 km toward the sun
//!   (Bevy also treats a light texture as a decal box around the light; up there it touches no
//!   geometry), and sets its scale to half the map's extent along each axis (a directional
//!   light's translation and scale do not change its lighting or its shadow cascades, which use
//!   the rotation only). Each axis is fitted to the sky the map covers: a disc
//!   [`CloudShadows::extent_m`] across under the camera, from the ground to the highest cloud
//!   top, seen along the sun. With a low sun the axis in the sun's vertical plane shrinks to a
//!   few kilometres, so its texels stay tens of metres apart across the cloud;
//! - writes the map into the image on the GPU each frame.
//!
//! The alternatives were worse: a material extension reaches only the materials it wraps, and a
//! screen-space pass after lighting cannot tell the direct sun from sky light and reflections,
//! so it darkens ambient light too. The light texture needs the `pbr_light_textures` Bevy
//! feature (enabled by this crate) and texture binding arrays; where the GPU lacks them Bevy
//! ignores light textures, and the plugin logs a warning once.
//!
//! Outside the map the texture tiles; make [`CloudShadows::extent_m`] cover the ground you
//! look at (the default 40 km covers the Bern views to the horizon haze).
//!
//! # What a frame costs
//!
//! One dispatch of `resolution² / update_frames` threads, each marching `steps` samples per
//! layer it crosses, twice (the whole optical depth first, then where it crosses the knots):
//! [`CloudShadows::update_frames`] spreads the map over that many frames, a row in every
//! `update_frames` each frame, while the map stays where it is; a frame that places it anew
//! marches it whole.
//! With no visible layer, with the sun at or below the horizon, or with the shadows disabled, no
//! pass runs: the map is set to 1 (no shadow) once, with an upload, and left alone
//! ([`CloudShadowStats`] counts both).

use std::borrow::Cow;

use bevy::{
    asset::{RenderAssetUsages, embedded_asset, load_embedded_asset},
    core_pipeline::schedule::camera_driver,
    image::ImageSampler,
    light::{Atmosphere, DirectionalLightTexture},
    math::DVec3,
    prelude::*,
    render::{
        Extract, ExtractSchedule, Render, RenderApp, RenderStartup, RenderSystems,
        diagnostic::RecordDiagnostics,
        extract_resource::{ExtractResource, ExtractResourcePlugin},
        render_asset::RenderAssets,
        render_resource::{
            binding_types::{
                sampler, storage_buffer_read_only, texture_2d, texture_2d_array, texture_3d,
                texture_storage_2d, uniform_buffer,
            },
            *,
        },
        renderer::{
            RenderAdapter, RenderContext, RenderDevice, RenderGraph, RenderGraphSystems,
            RenderQueue,
        },
        texture::{FallbackImage, GpuImage},
    },
};

use super::{
    VolumetricClouds,
    haze::CloudShadowFrame,
    noise::CloudNoiseTextures,
    view::{CloudSun, GpuCloudLayer, GpuCloudUniforms, LayerInput, LayerInputData, march_inputs},
};
use crate::{
    CloudscapeSystems,
    layers::CloudLayer,
    reference::{
        render::{MarchLayer, MarchSettings},
        shadow::{MAX_SHADOW_STEPS, ShadowMapFrame},
    },
    sky::Sun,
    world::CloudWorld,
};

/// Settings of the cloud shadow map. Live-editable; changing the resolution makes a new map.
#[derive(Resource, Reflect, Clone, Debug, PartialEq, ExtractResource)]
#[reflect(Resource, Default)]
pub struct CloudShadows {
    /// Cast cloud shadows. Default true.
    pub enabled: bool,
    /// Texels per side of the map, 16–4096. Default 256 (156 m texels over 40 km: a 1 km
    /// cumulus shadow spans six).
    pub resolution: u32,
    /// Width of the ground the map covers, metres: a disc centred under the camera, and the sky
    /// above it up to the highest cloud top. Default 40 000.
    pub extent_m: f32,
    /// Samples per layer along each sun line, 1–64. Default 12.
    pub steps: u32,
    /// Frames over which the map is marched anew, 1–16: each frame marches every
    /// `update_frames`-th row of texels, the next row each frame, so no texel is more than that
    /// many frames old and the pass costs that many times less. The clouds drift and change
    /// over seconds, far slower than a few frames. A new placement of the map (the camera
    /// moved by a texel, the sun moved, another size or extent, a layer appeared or went) marches
    /// it whole that frame. Default 4; 1 marches every texel every frame.
    pub update_frames: u32,
}

impl Default for CloudShadows {
    fn default() -> Self {
        Self {
            enabled: true,
            resolution: 256,
            extent_m: 40_000.0,
            steps: 12,
            update_frames: 4,
        }
    }
}

impl CloudShadows {
    /// The settings clamped to what the pass supports: resolution 16–4096, steps 1–64, a
    /// positive finite extent (else the default), update frames 1–16.
    pub fn sanitized(&self) -> Self {
        Self {
            enabled: self.enabled,
            resolution: self.resolution.clamp(16, 4096),
            extent_m: if self.extent_m.is_finite() && self.extent_m > 0.0 {
                self.extent_m
            } else {
                Self::default().extent_m
            },
            steps: self.steps.clamp(1, MAX_SHADOW_STEPS),
            update_frames: self.update_frames.clamp(1, MAX_UPDATE_FRAMES),
        }
    }
}

/// The shadow map's image (main world), made by the plugin and given to the sun light as its
/// `DirectionalLightTexture`. `Rgba16Float`: red the transmittance to the ground (what Bevy's
/// light texture reads), green, blue and alpha where down the sun line the cloud starts and its
/// optical depth reaches 1 and 4
/// ([`cloud_shadow_map_texels`](crate::reference::shadow::cloud_shadow_map_texels)).
#[derive(Resource, Clone, Debug)]
pub struct CloudShadowMap {
    /// The image the GPU pass writes.
    pub image: Handle<Image>,
    /// Its texels per side.
    pub resolution: u32,
}

/// What the shadow pass did (render world), for diagnostics and tests.
#[derive(Resource, Debug, Default, Clone, Copy)]
pub struct CloudShadowStats {
    /// Frames in which the map was marched.
    pub passes: u64,
    /// Rows of texels marched, over all passes (a whole map is `resolution` rows;
    /// [`CloudShadows::update_frames`]).
    pub rows: u64,
    /// Times the map was reset to "no shadow" (night, no layers, disabled) without a pass.
    pub clears: u64,
}

/// The shadow map's part of [`super::CloudRenderPlugin::build`].
pub(super) fn build(app: &mut App) {
    app.init_resource::<CloudShadows>()
        .register_type::<CloudShadows>();
    // Without a renderer (a server, a test of the weather alone) there is nothing to shade.
    if app.get_sub_app(RenderApp).is_none() {
        return;
    }
    app.add_plugins(ExtractResourcePlugin::<CloudShadows>::default())
        .add_systems(Update, place_cloud_shadow_map.after(CloudscapeSystems::Sun));
    embedded_asset!(app, "shadow.wgsl");
    app.sub_app_mut(RenderApp)
        .init_resource::<CloudShadowStats>()
        .init_resource::<ExtractedCloudShadow>()
        .add_systems(ExtractSchedule, extract_cloud_shadow);
}

/// The shadow map's part of [`super::CloudRenderPlugin::finish`]: the compute pass, where the GPU
/// can run it.
pub(super) fn finish(app: &mut App) {
    let Some(render_app) = app.get_sub_app_mut(RenderApp) else {
        return;
    };
    let device = render_app.world().resource::<RenderDevice>();
    let adapter = render_app.world().resource::<RenderAdapter>();
    if !bevy::pbr::decal::clustered::clustered_decals_are_usable(device, adapter) {
        warn!(
            "bevy_cloudscape: this GPU has no texture binding arrays, so Bevy ignores light \
             textures and cloud shadows will not show on the ground"
        );
    }
    if device.limits().max_storage_textures_per_shader_stage == 0
        || !adapter
            .get_downlevel_capabilities()
            .flags
            .contains(DownlevelFlags::COMPUTE_SHADERS)
    {
        warn!("bevy_cloudscape: cloud shadows disabled: the GPU has no compute storage textures");
        return;
    }
    render_app
        .init_resource::<ShadowMapState>()
        .add_systems(RenderStartup, init_cloud_shadow_pipeline)
        .add_systems(
            Render,
            prepare_cloud_shadow.in_set(RenderSystems::PrepareBindGroups),
        )
        .add_systems(
            RenderGraph,
            generate_cloud_shadow
                .in_set(RenderGraphSystems::Render)
                .before(camera_driver),
        );
}

/// The camera the map follows: the active camera with [`VolumetricClouds`] of lowest order.
fn shadow_camera<'a>(
    cameras: impl IntoIterator<Item = (&'a Camera, &'a VolumetricClouds, &'a GlobalTransform)>,
) -> Option<(&'a VolumetricClouds, &'a GlobalTransform)> {
    cameras
        .into_iter()
        .filter(|(camera, _, _)| camera.is_active)
        .min_by_key(|(camera, _, _)| camera.order)
        .map(|(_, settings, transform)| (settings, transform))
}

/// The map's texel format: half floats, for the optical depths of the levels.
pub(crate) const SHADOW_MAP_FORMAT: TextureFormat = TextureFormat::Rgba16Float;

/// A texel of no shadow, as `Rgba16Float` bytes: transmittance 1, optical depths 0.
const NO_SHADOW_TEXEL: [u8; 8] = {
    let one = 0x3c00_u16.to_le_bytes();
    [one[0], one[1], 0, 0, 0, 0, 0, 0]
};

/// A new map image, filled with no shadow.
fn new_shadow_image(resolution: u32) -> Image {
    let mut image = Image::new_fill(
        Extent3d {
            width: resolution,
            height: resolution,
            depth_or_array_layers: 1,
        },
        TextureDimension::D2,
        &NO_SHADOW_TEXEL,
        SHADOW_MAP_FORMAT,
        RenderAssetUsages::RENDER_WORLD,
    );
    image.texture_descriptor.usage |= TextureUsages::STORAGE_BINDING | TextureUsages::COPY_SRC;
    image.sampler = ImageSampler::linear();
    image
}

/// Makes the map image, hands it to the sun light, and places the light's frame on the camera.
fn place_cloud_shadow_map(
    mut commands: Commands,
    settings: Res<CloudShadows>,
    map: Option<ResMut<CloudShadowMap>>,
    images: Option<ResMut<Assets<Image>>>,
    mut lights: Query<
        (
            Entity,
            &mut Transform,
            Has<Sun>,
            Option<&DirectionalLightTexture>,
        ),
        With<DirectionalLight>,
    >,
    cameras: Query<(&Camera, &VolumetricClouds, &GlobalTransform)>,
    layers: Query<&CloudLayer>,
    world: Option<Res<CloudWorld>>,
) {
    let Some(mut images) = images else {
        return;
    };
    let settings = settings.sanitized();
    let sun = lights
        .iter()
        .max_by_key(|(_, _, is_sun, _)| *is_sun)
        .map(|(entity, ..)| entity);
    let Some((entity, mut transform, _, texture)) = sun.and_then(|e| lights.get_mut(e).ok()) else {
        return;
    };
    let ours = |texture: Option<&DirectionalLightTexture>, image: &Handle<Image>| {
        texture.is_some_and(|t| t.image == *image)
    };
    if !settings.enabled {
        if let Some(map) = &map
            && ours(texture, &map.image)
        {
            commands.entity(entity).remove::<DirectionalLightTexture>();
        }
        return;
    }
    let image = match map {
        Some(map) if map.resolution == settings.resolution => map.image.clone(),
        Some(mut map) => {
            images.remove(&map.image);
            map.image = images.add(new_shadow_image(settings.resolution));
            map.resolution = settings.resolution;
            map.image.clone()
        }
        None => {
            let image = images.add(new_shadow_image(settings.resolution));
            commands.insert_resource(CloudShadowMap {
                image: image.clone(),
                resolution: settings.resolution,
            });
            image
        }
    };
    if !ours(texture, &image) {
        commands.entity(entity).insert(DirectionalLightTexture {
            image: image.clone(),
            tiled: true,
        });
    }
    let Some((_, camera)) = shadow_camera(cameras.iter()) else {
        return;
    };
    // The map's frame: the light's rotation, each axis scaled to fit the slab of sky the map
    // covers, centred on that slab snapped to whole texels in the light's plane.
    let world = world.as_deref().cloned().unwrap_or_default().sanitized();
    let (up, camera_altitude_m) = world.camera_up_and_altitude(camera.translation().as_dvec3());
    let top_m = layers
        .iter()
        .map(CloudLayer::sanitized)
        .filter(CloudLayer::is_visible)
        .map(|layer| layer.top_m)
        .fold(0.0_f32, f32::max);
    let up = up.as_vec3();
    let rotation = transform.rotation;
    let (x, y, z) = (rotation * Vec3::X, rotation * Vec3::Y, rotation * Vec3::Z);
    let half = Vec2::new(
        fitted_half_extent(settings.extent_m, top_m, x.dot(up)),
        fitted_half_extent(settings.extent_m, top_m, y.dot(up)),
    );
    let texel = 2.0 * half / settings.resolution as f32;
    let snap = |v: f32, texel: f32| (v / texel).round() * texel;
    // The slab's middle: over the ground under the camera, half way up to the highest top.
    let c = camera.translation() + up * (0.5 * top_m - camera_altitude_m as f32);
    transform.translation = x * snap(c.dot(x), texel.x)
        + y * snap(c.dot(y), texel.y)
        + z * (c.dot(z) + LIGHT_TEXTURE_LIFT_M);
    transform.scale = half.extend(1.0);
}

/// Half the map's extent along one of its axes, metres: the half-width of the slab of sky it
/// covers (a disc `extent_m` across on the ground, from the ground up to `top_m`) seen along the
/// sun, for an axis whose dot product with the local vertical is `vertical`. With the sun high
/// both axes span half the extent; with it low the axis in the sun's vertical plane spans far
/// less (`extent_m / 2 · sin(elevation) + top_m / 2 · cos(elevation)`), so its texels stay fine
/// across the cloud instead of a few stretched over kilometres of ground. Rounded up to a step
/// of 2^(1/8), so a sun in motion changes the map's frame (and its texel grid) rarely; never
/// above half the extent.
fn fitted_half_extent(extent_m: f32, top_m: f32, vertical: f32) -> f32 {
    const STEPS_PER_OCTAVE: f32 = 8.0;
    let limit = 0.5 * extent_m;
    if !vertical.is_finite() {
        return limit;
    }
    let c = vertical.abs().min(1.0);
    let needed = limit * (1.0 - c * c).sqrt() + 0.5 * top_m.max(0.0) * c;
    if needed.is_nan() || needed <= 0.0 || needed >= limit {
        return limit;
    }
    let octaves = ((limit / needed).log2() * STEPS_PER_OCTAVE).floor() / STEPS_PER_OCTAVE;
    limit / octaves.exp2()
}

/// How far toward the sun the light's translation sits above the camera, metres.
///
/// Bevy also registers a light texture as a clustered decal: a box around the light's
/// translation, ±scale thick along the light's z, which paints the texture onto surfaces inside
/// it. At the camera that box would print the map as a thin stripe across the terrain; 1000 km
/// toward the sun it meets no scene geometry. The projection along the sun is the same from
/// there, and f32 keeps the texel position to about 6 cm at that distance.
const LIGHT_TEXTURE_LIFT_M: f32 = 1.0e6;

/// One frame's shadow work, extracted from the main world.
#[derive(Clone, Debug)]
enum ShadowJob {
    /// March the map.
    March {
        image: AssetId<Image>,
        settings: Box<MarchSettings>,
        layers: Vec<MarchLayer>,
        frame: ShadowMapFrame,
        steps: u32,
        /// [`CloudShadows::update_frames`], sanitized.
        update_frames: u32,
        /// What places the map's texels in the world and what they hold: a change marches
        /// the whole map.
        placement: Box<MapPlacement>,
    },
    /// No shadow anywhere (night, no visible layer): make the map 1 if it is not.
    Clear { image: AssetId<Image> },
}

#[derive(Resource, Default)]
struct ExtractedCloudShadow(Option<ShadowJob>);

/// Most frames [`CloudShadows::update_frames`] spreads the map over.
const MAX_UPDATE_FRAMES: u32 = 16;

/// Where the map's texels lie in the world (the sun light's snapped centre and axes), how many
/// and how finely marched, the layers' altitudes and how many layers: while these hold, a texel
/// marched a few frames ago still holds its sun line ([`MapPlacement::holds`]).
#[derive(Clone, Debug, PartialEq)]
struct MapPlacement {
    /// The light's world translation (the map centre, snapped to texels).
    centre: Vec3,
    /// The light's x and y axes (half the map's extent each) and its z axis.
    axes: [Vec3; 3],
    size: u32,
    steps: u32,
    cloud_range_m: [f64; 2],
    layers: usize,
}

/// How far a sun line of the map may move, in texels, before its texel must be marched again.
const MAP_SHIFT_TEXELS: f32 = 0.25;

impl MapPlacement {
    /// Whether texels marched at `self` still hold the sun lines of `now`: the same centre,
    /// size, steps, layers and cloud range, and axes that moved no sun line through the clouds
    /// by [`MAP_SHIFT_TEXELS`] or more (a sun that moves with the clock turns them a little
    /// each frame).
    fn holds(&self, now: &Self) -> bool {
        if (
            self.centre,
            self.size,
            self.steps,
            self.cloud_range_m,
            self.layers,
        ) != (
            now.centre,
            now.size,
            now.steps,
            now.cloud_range_m,
            now.layers,
        ) {
            return false;
        }
        let texel = 2.0 * self.axes[0].length().min(self.axes[1].length()) / self.size as f32;
        let tilt = (self.axes[2].normalize_or_zero() - now.axes[2].normalize_or_zero()).length();
        let moved = (self.axes[0] - now.axes[0]).length()
            + (self.axes[1] - now.axes[1]).length()
            + tilt * self.cloud_range_m[1].abs() as f32;
        moved < MAP_SHIFT_TEXELS * texel
    }
}

#[doc(hidden)]
/// The inputs of the shadow map, from the same numbers the view march uses: the march settings
/// and visible layers relative to `camera` (the camera the map follows), and the map's frame from
/// the sun `light`'s transform (rotation, map centre, half-extent scale). `None` when no pass is
/// needed: no visible layer, or the sun at or below the horizon. The CPU twin of the pass
/// ([`crate::reference::shadow::cloud_shadow_map`]) takes these.
pub fn shadow_inputs<'a>(
    world: &CloudWorld,
    settings: &CloudShadows,
    clouds: &VolumetricClouds,
    camera: &GlobalTransform,
    light: &GlobalTransform,
    sun: Option<&CloudSun>,
    layers: impl IntoIterator<Item = impl Into<LayerInput<'a>>>,
) -> Option<(MarchSettings, Vec<MarchLayer>, ShadowMapFrame)> {
    let settings = settings.sanitized();
    let (march, march_layers) = march_inputs(world, clouds, camera, 1.0e-3, sun, layers, 0);
    let up = DVec3::from_array(march.camera_up);
    let toward_sun = DVec3::from_array(march.sun_direction);
    let daylight = march.sun_illuminance.iter().any(|&e| e > 0.0) && toward_sun.dot(up) > 0.0;
    if march_layers.is_empty() || !daylight {
        return None;
    }
    let matrix = light.affine().matrix3;
    // The light sits far up the sun line (`LIGHT_TEXTURE_LIFT_M`); slide the centre back along
    // the light's z into the plane through the camera: the same sun line, small numbers.
    let z = matrix.z_axis.as_dvec3().normalize_or_zero();
    let centre = light.translation().as_dvec3() - camera.translation().as_dvec3();
    let frame = ShadowMapFrame {
        centre_m: (centre - z * centre.dot(z)).to_array(),
        axis_x_m: matrix.x_axis.as_dvec3().to_array(),
        axis_y_m: matrix.y_axis.as_dvec3().to_array(),
        size: settings.resolution,
        cloud_range_m: [
            march_layers
                .iter()
                .map(|l| l.base_m)
                .fold(f64::INFINITY, f64::min),
            march_layers
                .iter()
                .map(|l| l.top_m)
                .fold(f64::NEG_INFINITY, f64::max),
        ],
    };
    Some((march, march_layers, frame))
}

fn extract_cloud_shadow(
    mut commands: Commands,
    mut extracted: ResMut<ExtractedCloudShadow>,
    settings: Extract<Option<Res<CloudShadows>>>,
    map: Extract<Option<Res<CloudShadowMap>>>,
    cameras: Extract<Query<(&Camera, &VolumetricClouds, &GlobalTransform)>>,
    layers: Extract<Query<LayerInputData>>,
    lights: Extract<
        Query<(
            &DirectionalLight,
            &GlobalTransform,
            Has<Sun>,
            Option<&DirectionalLightTexture>,
        )>,
    >,
    atmospheres: Extract<Query<(), With<Atmosphere>>>,
    world: Extract<Option<Res<CloudWorld>>>,
) {
    extracted.0 = None;
    // Set again below when the map is marched this frame (the light shafts read it).
    commands.remove_resource::<CloudShadowFrame>();
    let (Some(settings), Some(map)) = (settings.as_deref(), map.as_deref()) else {
        return;
    };
    let image = map.image.id();
    let clear = Some(ShadowJob::Clear { image });
    // The light that carries the map.
    let Some((light, light_transform)) = lights
        .iter()
        .filter(|(.., texture)| texture.is_some_and(|t| t.image == map.image))
        .map(|(light, transform, ..)| (light, transform))
        .next()
    else {
        extracted.0 = clear;
        return;
    };
    let Some((clouds, camera)) = shadow_camera(cameras.iter()) else {
        extracted.0 = clear;
        return;
    };
    let sun = CloudSun::pick([(light, light_transform, true)], !atmospheres.is_empty());
    extracted.0 = match shadow_inputs(
        world.as_deref().unwrap_or(&CloudWorld::default()),
        settings,
        clouds,
        camera,
        light_transform,
        sun.as_ref(),
        layers.iter(),
    ) {
        Some((march, layers, frame)) if settings.enabled && frame.size == map.resolution => {
            commands.insert_resource(CloudShadowFrame {
                image,
                frame,
                camera_m: camera.translation().as_dvec3(),
            });
            let sanitized = settings.sanitized();
            let matrix = light_transform.affine().matrix3;
            let placement = MapPlacement {
                centre: light_transform.translation(),
                axes: [
                    matrix.x_axis.into(),
                    matrix.y_axis.into(),
                    matrix.z_axis.into(),
                ],
                size: frame.size,
                steps: sanitized.steps,
                cloud_range_m: frame.cloud_range_m,
                layers: layers.len(),
            };
            Some(ShadowJob::March {
                image,
                settings: Box::new(march),
                layers,
                frame,
                steps: sanitized.steps,
                update_frames: sanitized.update_frames,
                placement: Box::new(placement),
            })
        }
        _ => clear,
    };
}

/// The shadow uniform, laid out as `ShadowUniforms` in `shadow.wgsl` (96 bytes).
#[derive(ShaderType, Clone, Debug, Default)]
pub(crate) struct GpuShadowUniforms {
    centre_m: Vec4,
    axis_x_m: Vec4,
    axis_y_m: Vec4,
    size: u32,
    steps: u32,
    footprint_m: f32,
    /// This pass marches the rows `row_offset + k · row_stride`.
    row_stride: u32,
    cloud_range_m: Vec4,
    row_offset: u32,
    _pad_a: u32,
    _pad_b: u32,
    _pad_c: u32,
}

impl GpuShadowUniforms {
    fn new(frame: &ShadowMapFrame, steps: u32, rows: MapRows) -> Self {
        let v = |a: [f64; 3]| Vec4::new(a[0] as f32, a[1] as f32, a[2] as f32, 0.0);
        Self {
            centre_m: v(frame.centre_m),
            axis_x_m: v(frame.axis_x_m),
            axis_y_m: v(frame.axis_y_m),
            size: frame.size,
            steps,
            footprint_m: frame.fine_texel_m() as f32,
            row_stride: rows.stride,
            cloud_range_m: Vec4::new(
                frame.cloud_range_m[0] as f32,
                frame.cloud_range_m[1] as f32,
                0.0,
                0.0,
            ),
            row_offset: rows.offset,
            _pad_a: 0,
            _pad_b: 0,
            _pad_c: 0,
        }
    }
}

#[derive(Resource)]
struct CloudShadowPipeline {
    layout: BindGroupLayoutDescriptor,
    pipeline: CachedComputePipelineId,
}

fn init_cloud_shadow_pipeline(
    mut commands: Commands,
    asset_server: Res<AssetServer>,
    pipeline_cache: Res<PipelineCache>,
) {
    let layout = BindGroupLayoutDescriptor::new(
        "cloud_shadow_layout",
        &BindGroupLayoutEntries::with_indices(
            ShaderStages::COMPUTE,
            (
                (
                    0,
                    texture_storage_2d(SHADOW_MAP_FORMAT, StorageTextureAccess::WriteOnly),
                ),
                (1, uniform_buffer::<GpuShadowUniforms>(false)),
                (2, uniform_buffer::<GpuCloudUniforms>(false)),
                (3, storage_buffer_read_only::<GpuCloudLayer>(false)),
                (4, texture_3d(TextureSampleType::Float { filterable: true })),
                (5, texture_3d(TextureSampleType::Float { filterable: true })),
                (6, texture_2d(TextureSampleType::Float { filterable: true })),
                (7, sampler(SamplerBindingType::Filtering)),
                // The growing layers' cover (`textures.wgsl`).
                (
                    13,
                    texture_2d_array(TextureSampleType::Float { filterable: false }),
                ),
            ),
        ),
    );
    let pipeline = pipeline_cache.queue_compute_pipeline(ComputePipelineDescriptor {
        label: Some(Cow::Borrowed("cloud_shadow_pipeline")),
        layout: vec![layout.clone()],
        shader: load_embedded_asset!(asset_server.as_ref(), "shadow.wgsl"),
        entry_point: Some(Cow::Borrowed("generate_shadow")),
        ..default()
    });
    commands.insert_resource(CloudShadowPipeline { layout, pipeline });
}

/// Whether the map holds shadows (a pass ran since the last clear).
#[derive(Resource, Default)]
struct ShadowMapState {
    dirty: Option<AssetId<Image>>,
    /// The image and placement of the last whole pass, and the rows the last pass marched:
    /// the next pass marches the next rows while that placement holds.
    last: Option<(AssetId<Image>, MapPlacement, MapRows)>,
}

/// The rows of the map a pass marches: `offset`, `offset + stride`, … below the map's size.
#[derive(Clone, Copy, Debug, PartialEq)]
struct MapRows {
    offset: u32,
    stride: u32,
}

impl MapRows {
    const ALL: Self = Self {
        offset: 0,
        stride: 1,
    };

    /// The rows after `last` (None: the whole map) of a map marched over `update_frames`
    /// frames.
    fn next(last: Option<Self>, update_frames: u32) -> Self {
        let stride = update_frames.clamp(1, MAX_UPDATE_FRAMES);
        match last {
            Some(last) if stride > 1 => Self {
                offset: (last.offset + 1) % stride,
                stride,
            },
            _ => Self::ALL,
        }
    }

    /// How many rows of a map `size` texels high these are.
    fn count(self, size: u32) -> u32 {
        size.saturating_sub(self.offset).div_ceil(self.stride)
    }
}

/// This frame's dispatch, made by [`prepare_cloud_shadow`].
#[derive(Resource)]
struct PreparedCloudShadow {
    bind_group: BindGroup,
    size: u32,
    rows: MapRows,
    /// The placement of the last whole pass (this one's when it is whole).
    placement: MapPlacement,
    image: AssetId<Image>,
}

fn prepare_cloud_shadow(
    mut commands: Commands,
    extracted: Res<ExtractedCloudShadow>,
    pipeline: Option<Res<CloudShadowPipeline>>,
    noise: Option<Res<CloudNoiseTextures>>,
    images: Res<RenderAssets<GpuImage>>,
    pipeline_cache: Res<PipelineCache>,
    device: Res<RenderDevice>,
    queue: Res<RenderQueue>,
    growth: Option<Res<crate::render::growth::ExtractedGrowth>>,
    fallback: Res<FallbackImage>,
    mut state: ResMut<ShadowMapState>,
    mut stats: ResMut<CloudShadowStats>,
) {
    commands.remove_resource::<PreparedCloudShadow>();
    match &extracted.0 {
        None => {}
        Some(ShadowJob::Clear { image }) => {
            if state.dirty != Some(*image) {
                return;
            }
            let Some(gpu) = images.get(*image) else {
                return;
            };
            let size = gpu.texture.size();
            let ones = NO_SHADOW_TEXEL.repeat((size.width * size.height) as usize);
            queue.write_texture(
                gpu.texture.as_image_copy(),
                &ones,
                TexelCopyBufferLayout {
                    offset: 0,
                    bytes_per_row: Some(size.width * NO_SHADOW_TEXEL.len() as u32),
                    rows_per_image: Some(size.height),
                },
                size,
            );
            state.dirty = None;
            state.last = None;
            stats.clears += 1;
        }
        Some(ShadowJob::March {
            image,
            settings,
            layers,
            frame,
            steps,
            update_frames,
            placement,
        }) => {
            let (Some(pipeline), Some(noise), Some(gpu)) = (pipeline, noise, images.get(*image))
            else {
                return;
            };
            if gpu.texture.size().width != frame.size {
                return;
            }
            let gpu_layers: Vec<GpuCloudLayer> = layers.iter().map(GpuCloudLayer::from).collect();
            let mut cloud_uniforms = UniformBuffer::from(GpuCloudUniforms::new(
                settings,
                gpu_layers.len() as u32,
                None,
            ));
            cloud_uniforms.write_buffer(&device, &queue);
            let mut layer_buffer = StorageBuffer::from(gpu_layers);
            layer_buffer.write_buffer(&device, &queue);
            // The next rows while the map stays where it was, else the whole map.
            let (previous, whole) = match &state.last {
                Some((last_image, whole, rows))
                    if last_image == image && whole.holds(placement.as_ref()) =>
                {
                    (Some(*rows), whole.clone())
                }
                _ => (None, placement.as_ref().clone()),
            };
            let rows = MapRows::next(previous, *update_frames);
            let mut shadow_uniforms =
                UniformBuffer::from(GpuShadowUniforms::new(frame, *steps, rows));
            shadow_uniforms.write_buffer(&device, &queue);
            let (Some(cloud_uniforms), Some(layer_buffer), Some(shadow_uniforms)) = (
                cloud_uniforms.binding(),
                layer_buffer.binding(),
                shadow_uniforms.binding(),
            ) else {
                return;
            };
            let growth_cover =
                crate::render::growth::growth_cover_view(growth.as_deref(), &images, &fallback);
            let bind_group = device.create_bind_group(
                "cloud_shadow_bind_group",
                &pipeline_cache.get_bind_group_layout(&pipeline.layout),
                &BindGroupEntries::with_indices((
                    (0, &gpu.texture_view),
                    (1, shadow_uniforms),
                    (2, cloud_uniforms),
                    (3, layer_buffer),
                    (4, &noise.base.view),
                    (5, &noise.detail.view),
                    (6, &noise.weather.view),
                    (7, &noise.sampler),
                    (13, growth_cover),
                )),
            );
            commands.insert_resource(PreparedCloudShadow {
                bind_group,
                size: frame.size,
                rows,
                placement: whole,
                image: *image,
            });
        }
    }
}

/// Dispatches the shadow pass before any camera renders, so every view this frame is lit by it.
fn generate_cloud_shadow(
    prepared: Option<Res<PreparedCloudShadow>>,
    pipeline: Option<Res<CloudShadowPipeline>>,
    pipeline_cache: Res<PipelineCache>,
    mut state: ResMut<ShadowMapState>,
    mut stats: ResMut<CloudShadowStats>,
    mut ctx: RenderContext,
) {
    let (Some(prepared), Some(pipeline)) = (prepared, pipeline) else {
        return;
    };
    let Some(compute) = pipeline_cache.get_compute_pipeline(pipeline.pipeline) else {
        return;
    };
    let diagnostics = ctx.diagnostic_recorder();
    let diagnostics = diagnostics.as_deref();
    let time_span = diagnostics.time_span(ctx.command_encoder(), "cloud_shadow");
    let encoder = ctx.command_encoder();
    encoder.push_debug_group("cloud_shadow");
    {
        let mut pass = encoder.begin_compute_pass(&ComputePassDescriptor {
            label: Some("cloud_shadow"),
            timestamp_writes: None,
        });
        pass.set_pipeline(compute);
        pass.set_bind_group(0, &prepared.bind_group, &[]);
        let rows = prepared.rows.count(prepared.size);
        pass.dispatch_workgroups(prepared.size.div_ceil(8), rows.div_ceil(8), 1);
    }
    encoder.pop_debug_group();
    time_span.end(ctx.command_encoder());
    state.dirty = Some(prepared.image);
    state.last = Some((prepared.image, prepared.placement.clone(), prepared.rows));
    stats.passes += 1;
    stats.rows += u64::from(prepared.rows.count(prepared.size));
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn uniform_layout_matches_the_shader() {
        assert_eq!(GpuShadowUniforms::min_size().get(), 96);
    }

    #[test]
    fn settings_are_sanitized() {
        let wild = CloudShadows {
            enabled: true,
            resolution: 1,
            extent_m: f32::NAN,
            steps: 1000,
            update_frames: 0,
        }
        .sanitized();
        assert_eq!(wild.resolution, 16);
        assert_eq!(wild.extent_m, CloudShadows::default().extent_m);
        assert_eq!(wild.steps, MAX_SHADOW_STEPS);
        assert_eq!(wild.update_frames, 1);
        let many = CloudShadows {
            update_frames: 1000,
            ..default()
        };
        assert_eq!(many.sanitized().update_frames, MAX_UPDATE_FRAMES);
    }

    /// A placement holds while the sun turns its sun lines by less than a quarter texel, and not
    /// after the map's centre moves by a texel.
    #[test]
    fn a_placement_holds_while_its_sun_lines_stay_in_their_texels() {
        // 40 km over 256 texels: 156 m texels; clouds up to 3 km.
        let placement = |angle: f32, centre: Vec3| {
            let rotation = Quat::from_rotation_x(-1.0 - angle);
            MapPlacement {
                centre,
                axes: [
                    rotation * Vec3::X * 20_000.0,
                    rotation * Vec3::Y * 20_000.0,
                    rotation * Vec3::Z,
                ],
                size: 256,
                steps: 12,
                cloud_range_m: [1_500.0, 3_000.0],
                layers: 1,
            }
        };
        let base = placement(0.0, Vec3::ZERO);
        assert!(base.holds(&base));
        // The sun turning 1e-6 rad moves the 20 km y axis by 2 cm: holds. 1e-3 rad moves it by
        // 20 m and the sun lines at the cloud tops by 3 m, under a quarter of a 156 m texel;
        // 2e-3 rad twice that, over it.
        assert!(base.holds(&placement(1e-6, Vec3::ZERO)));
        assert!(base.holds(&placement(1e-3, Vec3::ZERO)));
        assert!(!base.holds(&placement(2e-3, Vec3::ZERO)));
        assert!(!base.holds(&placement(0.0, Vec3::new(156.25, 0.0, 0.0))));
        let more_layers = MapPlacement {
            layers: 2,
            ..base.clone()
        };
        assert!(!base.holds(&more_layers));
    }

    /// Over `update_frames` passes of an unmoved map every row is marched exactly once; a pass
    /// after a move (no previous rows) marches them all.
    #[test]
    fn amortized_passes_march_every_row_once_per_cycle() {
        let size = 10;
        for update_frames in [1, 3, 4, 16] {
            let mut marched = vec![0; size as usize];
            let mut rows = MapRows::next(None, update_frames);
            assert_eq!(rows, MapRows::ALL, "the first pass marches the whole map");
            for _ in 0..update_frames {
                rows = MapRows::next(Some(rows), update_frames);
                let mut count = 0;
                for row in (rows.offset..size).step_by(rows.stride as usize) {
                    marched[row as usize] += 1;
                    count += 1;
                }
                assert_eq!(count, rows.count(size), "{update_frames}: {rows:?}");
            }
            assert!(
                marched.iter().all(|&n| n == 1),
                "{update_frames}: {marched:?}"
            );
        }
    }

    #[test]
    fn map_axes_fit_the_sky_seen_along_the_sun() {
        let (extent, top) = (40_000.0, 3_000.0);
        // Sun overhead: both axes horizontal, half the extent each.
        assert_eq!(fitted_half_extent(extent, top, 0.0), 20_000.0);
        // Sun 4° up: the axis in the sun's vertical plane is cos 4° vertical; it spans the ground
        // disc foreshortened by sin 4° plus the cloud's height, rounded up by at most 2^(1/8).
        let elevation = 4.0_f32.to_radians();
        let needed = 20_000.0 * elevation.sin() + 1_500.0 * elevation.cos();
        let half = fitted_half_extent(extent, top, elevation.cos());
        assert!(
            half >= needed && half <= needed * 2.0_f32.powf(0.125),
            "{half} for {needed}"
        );
        // The other axis stays horizontal.
        assert_eq!(fitted_half_extent(extent, top, 0.0), 20_000.0);
        // A small change of the sun keeps the same frame.
        let nearby = fitted_half_extent(extent, top, 4.05_f32.to_radians().cos());
        assert_eq!(nearby, half);
        // Nonsense falls back to the whole extent.
        assert_eq!(fitted_half_extent(extent, top, f32::NAN), 20_000.0);
        assert_eq!(fitted_half_extent(extent, f32::NAN, 1.0), 20_000.0);
    }

    #[test]
    fn no_shadow_job_at_night_or_without_layers() {
        let clouds = VolumetricClouds::default();
        let camera = GlobalTransform::from_xyz(0.0, 500.0, 0.0);
        let light = GlobalTransform::from(Transform::from_scale(Vec3::new(2e4, 2e4, 1.0)));
        let layer = CloudLayer::default();
        let day = CloudSun {
            direction: Vec3::new(0.0, 0.5, 0.8).normalize(),
            illuminance_rgb: [1e5; 3],
            through_atmosphere: false,
        };
        let night = CloudSun {
            direction: Vec3::new(0.0, -0.2, 0.9).normalize(),
            ..day
        };
        let settings = CloudShadows::default();
        let run = |sun: &CloudSun, layers: &[CloudLayer]| {
            shadow_inputs(
                &CloudWorld::default(),
                &settings,
                &clouds,
                &camera,
                &light,
                Some(sun),
                layers.iter().map(|l| (l, None)),
            )
        };
        assert!(run(&day, std::slice::from_ref(&layer)).is_some());
        assert!(run(&night, std::slice::from_ref(&layer)).is_none());
        assert!(run(&day, &[]).is_none());
        let (_, _, frame) = run(&day, std::slice::from_ref(&layer)).unwrap();
        assert_eq!(frame.centre_m, [0.0, -500.0, 0.0]);
        assert_eq!(frame.axis_x_m, [2e4, 0.0, 0.0]);
    }
}
