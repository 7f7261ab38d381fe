//! Compositing the clouds over the scene, and reading images rendered at a reduced resolution
//! back at full resolution.
//!
//! The march's output `(L, T)` (in-scattered radiance and view transmittance) is blended onto
//! the view's HDR main texture as `scene · T + L` (a fixed blend state), before tonemapping.
//!
//! Two images may be rendered at a reduced resolution, each with the distance its rays were
//! stopped at:
//!
//! - the march itself, at [`VolumetricClouds::resolution_scale`] below 1
//!   (`CloudLowResTargets`); the upsample pass (`upsample.wgsl`) composites it;
//! - the light-shaft factors, at [`VolumetricClouds::light_shaft_resolution_scale`]
//!   (`CloudShaftTarget`, see [`crate::render::haze`]); the march reads them.
//!
//! Both are read with the same depth-aware weights (the shader library `composite.wgsl`), so
//! values from rays that stopped at other geometry (the sky beside a hill) do not bleed over the
//! edges of near geometry. The weights and their CPU twin are documented in
//! [`crate::reference::composite`].
//!
//! # Temporal accumulation
//!
//! With [`VolumetricClouds::temporal_blend`] below 1 and jitter on (every preset), the march
//! always writes its targets (at any resolution scale), and `temporal.wgsl` blends them into a
//! full-resolution history (`CloudHistory`, two `HISTORY_FORMAT` textures that swap each
//! frame, and two `HISTORY_DISTANCE_FORMAT` ones of where each pixel's ray ended): the new
//! frame at the pixel (upsampled as above) is mixed with the history found where the pixel's
//! content was last frame, clamped to the new frame's 3 × 3 neighbourhood, where that history
//! saw the surface this pixel's ray ends at
//! ([`history_matches`](crate::reference::composite::history_matches)); elsewhere (the sky
//! coming out from behind a near object) the pixel takes the new frame alone, and where only
//! the filter's reach crosses another surface, the history's 2 × 2 nearest texels.
//! Reprojection uses the clouds' distance (the second channel of the distance target) and last
//! frame's camera (`ViewPose::clip_from_relative`, composed in f64 relative to this frame's
//! camera); the history is read with a Lanczos-3 filter, and a pixel whose content moved takes
//! more of the new frame ([`moving_blend`]), so reprojecting every frame does not blur what the
//! camera turns past. The `copy` entry of `upsample.wgsl` then composites the new history onto
//! the view. The history starts over when the view's size changes, when a frame was skipped, and
//! when the camera's [`VolumetricClouds::reset_history`] is set (a camera cut). The method and
//! the CPU twin of its arithmetic are in [`crate::reference::composite`].
//!
//! At a reduced resolution the accumulation also upsamples ([`TemporalUpsampling`]): each
//! frame the march's rays go through the centre of another of the full-resolution pixels each
//! texel stands for, and only the pixel a ray went through takes the new value (the others keep
//! their history), so a still view converges to the full resolution rather than to a blurred
//! upsample.
//!
//! The GPU test `temporal_accumulation_converges_and_follows_the_camera` checks that a still
//! view converges toward the mean of many jittered frames and that a turning camera's history
//! follows it, and `a_turning_camera_leaves_no_trail_behind_a_near_object` that a black pole
//! held in front of a turning camera stays clear of clouds and leaves no trail in the sky it
//! uncovers.
//!
//! [`VolumetricClouds::temporal_blend`]: super::VolumetricClouds::temporal_blend
//! [`moving_blend`]: crate::reference::composite::moving_blend
//! [`VolumetricClouds::reset_history`]: super::VolumetricClouds::reset_history
//!
//! [`VolumetricClouds::resolution_scale`]: super::VolumetricClouds::resolution_scale
//! [`VolumetricClouds::light_shaft_resolution_scale`]: super::VolumetricClouds::light_shaft_resolution_scale

use std::borrow::Cow;

use bevy::{
    asset::{embedded_asset, load_embedded_asset},
    core_pipeline::FullscreenShader,
    diagnostic::FrameCount,
    math::{DMat4, DQuat, DVec3},
    platform::collections::HashMap,
    prelude::*,
    render::{
        render_resource::{
            binding_types::{
                sampler, texture_2d, texture_depth_2d, texture_depth_2d_multisampled,
                uniform_buffer,
            },
            *,
        },
        renderer::{RenderDevice, RenderQueue},
        texture::{CachedTexture, TextureCache},
        view::{ExtractedView, ViewTarget, ViewUniform},
    },
    shader::{ShaderDefVal, load_shader_library},
};

use super::view::ExtractedCloudView;
pub use super::view::{TemporalUpsampling, low_res_size};
use crate::{reference::composite::hit_blend, sky::stars::StarSky};

/// Loads `composite.wgsl` (the shader library of the upsample weights) and `upsample.wgsl`.
pub(crate) fn load_composite_shaders(app: &mut App) {
    load_shader_library!(app, "composite.wgsl");
    load_shader_library!(app, "view_depth.wgsl");
    embedded_asset!(app, "upsample.wgsl");
    embedded_asset!(app, "temporal.wgsl");
}

/// Format of the reduced-resolution `(L, T)` target.
pub(crate) const LOW_RES_COLOUR_FORMAT: TextureFormat = TextureFormat::Rgba16Float;
/// Format of the reduced-resolution target of distances, metres: where each ray was stopped,
/// and where its content lies (the clouds' opacity-weighted distance, or the scene's if nearer)
/// for the temporal accumulation's reprojection.
pub(crate) const LOW_RES_DISTANCE_FORMAT: TextureFormat = TextureFormat::Rg32Float;
/// Format of the temporal accumulation's history of `(L, T)`, at the view's full resolution.
pub(crate) const HISTORY_FORMAT: TextureFormat = TextureFormat::Rgba16Float;
/// Format of the history's ray ends, metres (32-bit: the sky's is `FAR_AWAY`): where each
/// history pixel's ray stopped, so that a pixel keeps only the history of the surface it sees
/// now (`history_matches`).
pub(crate) const HISTORY_DISTANCE_FORMAT: TextureFormat = TextureFormat::R32Float;
/// Format of the light-shaft factors: the factor below the lowest cloud base, the factor above
/// it, and the distance the ray was stopped at (metres, so 32-bit).
pub(crate) const SHAFT_FORMAT: TextureFormat = TextureFormat::Rgba32Float;

/// The depth prepass binding, multisampled or not.
pub(crate) fn depth_binding(multisampled: bool) -> BindGroupLayoutEntryBuilder {
    if multisampled {
        texture_depth_2d_multisampled()
    } else {
        texture_depth_2d()
    }
}

/// A bind group layout in its two forms, for a single-sampled and for a multisampled depth
/// prepass (the shaders' `MULTISAMPLED` def).
#[derive(Clone)]
pub(crate) struct DepthLayouts {
    single: BindGroupLayoutDescriptor,
    multisampled: BindGroupLayoutDescriptor,
}

impl DepthLayouts {
    /// Both forms of `layout(label, multisampled)`.
    pub(crate) fn new(
        layout: fn(&'static str, bool) -> BindGroupLayoutDescriptor,
        label: &'static str,
        label_multisampled: &'static str,
    ) -> Self {
        Self {
            single: layout(label, false),
            multisampled: layout(label_multisampled, true),
        }
    }

    /// The form for a view whose depth prepass is (or is not) multisampled.
    pub(crate) fn get(&self, multisampled: bool) -> &BindGroupLayoutDescriptor {
        if multisampled {
            &self.multisampled
        } else {
            &self.single
        }
    }
}

/// The shader defs of a pass reading a (multisampled or not) depth prepass.
pub(crate) fn depth_shader_defs(multisampled: bool) -> Vec<ShaderDefVal> {
    if multisampled {
        vec!["MULTISAMPLED".into()]
    } else {
        Vec::new()
    }
}

/// `scene · T + L`: the fragment returns `(L, T)`.
pub(crate) const COMPOSITE_BLEND: BlendState = BlendState {
    color: BlendComponent {
        src_factor: BlendFactor::One,
        dst_factor: BlendFactor::SrcAlpha,
        operation: BlendOperation::Add,
    },
    alpha: BlendComponent {
        src_factor: BlendFactor::Zero,
        dst_factor: BlendFactor::One,
        operation: BlendOperation::Add,
    },
};

fn upsample_layout(label: &'static str, multisampled: bool) -> BindGroupLayoutDescriptor {
    BindGroupLayoutDescriptor::new(
        label,
        &BindGroupLayoutEntries::sequential(
            ShaderStages::FRAGMENT,
            (
                uniform_buffer::<ViewUniform>(true),
                depth_binding(multisampled),
                texture_2d(TextureSampleType::Float { filterable: false }),
                texture_2d(TextureSampleType::Float { filterable: false }),
                uniform_buffer::<GpuViewGround>(false),
            ),
        ),
    )
}

/// Creates [`CloudUpsamplePipeline`] (render world, at start-up).
pub(crate) fn init_cloud_upsample_pipeline(
    mut commands: Commands,
    asset_server: Res<AssetServer>,
    fullscreen: Res<FullscreenShader>,
) {
    commands.insert_resource(CloudUpsamplePipeline {
        layouts: DepthLayouts::new(
            upsample_layout,
            "cloud_upsample_layout",
            "cloud_upsample_layout_multisampled",
        ),
        fullscreen: fullscreen.clone(),
        shader: load_embedded_asset!(asset_server.as_ref(), "upsample.wgsl"),
    });
}

/// Layouts and shader of the depth-aware upsample that composites a reduced-resolution march.
#[derive(Resource)]
pub(crate) struct CloudUpsamplePipeline {
    pub(crate) layouts: DepthLayouts,
    fullscreen: FullscreenShader,
    shader: Handle<Shader>,
}

/// What an upsample pipeline is specialised on.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub(crate) struct CloudUpsampleKey {
    /// Format of the view's main texture.
    pub format: TextureFormat,
    /// MSAA sample count of the view.
    pub samples: u32,
    /// Composite a full-resolution image as it is (the temporal history; entry `copy`) instead
    /// of upsampling.
    pub copy: bool,
}

impl SpecializedRenderPipeline for CloudUpsamplePipeline {
    type Key = CloudUpsampleKey;

    fn specialize(&self, key: Self::Key) -> RenderPipelineDescriptor {
        let multisampled = key.samples > 1;
        let shader_defs = depth_shader_defs(multisampled);
        RenderPipelineDescriptor {
            label: Some(Cow::Borrowed(if key.copy {
                "cloud_history_composite_pipeline"
            } else {
                "cloud_upsample_pipeline"
            })),
            layout: vec![self.layouts.get(multisampled).clone()],
            vertex: self.fullscreen.to_vertex_state(),
            fragment: Some(FragmentState {
                shader: self.shader.clone(),
                shader_defs,
                entry_point: Some(Cow::Borrowed(if key.copy { "copy" } else { "fragment" })),
                targets: vec![Some(ColorTargetState {
                    format: key.format,
                    blend: Some(COMPOSITE_BLEND),
                    write_mask: ColorWrites::ALL,
                })],
            }),
            multisample: MultisampleState {
                count: key.samples,
                ..default()
            },
            ..default()
        }
    }
}

/// The temporal accumulation's uniform, laid out as `TemporalUniforms` in `temporal.wgsl`
/// (96 bytes).
#[derive(ShaderType, Clone, Debug, Default)]
pub(crate) struct GpuTemporalUniforms {
    /// Last frame's clip space from a point relative to this frame's camera.
    pub previous_clip_from_relative: Mat4,
    /// Weight of the new frame, 0–1, for a pixel the march's ray went through this frame: the
    /// view's blend, or its [`hit_blend`] when the march runs at a reduced resolution.
    pub blend: f32,
    /// 1 when the history holds last frame of this view.
    pub valid: u32,
    /// [`TemporalUpsampling::offset_texels`].
    pub sample_offset: Vec2,
    /// [`TemporalUpsampling::factor`].
    pub upsampling_factor: u32,
    /// [`TemporalUpsampling::uv_scale`].
    pub uv_scale: Vec2,
}

/// Where the ground sphere is for a view, laid out as `ViewGround` in `composite.wgsl`: the
/// upsample and the temporal accumulation end each pixel's ray at the scene or the ground
/// sphere, whichever is nearer ([`crate::reference::composite::ray_end_m`]), as the march does
/// for the texels they read; and the stars and the moon's disc the upsample draws behind the
/// clouds.
#[derive(ShaderType, Clone, Debug, Default)]
pub(crate) struct GpuViewGround {
    /// The camera's local vertical (xyz, unit) and its altitude above the ground (w, m).
    pub camera_up_altitude: Vec4,
    /// The planet's radius, m.
    pub planet_radius_m: f32,
    /// Celestial coordinates from world directions ([`crate::sky::stars::StarSky`]).
    pub celestial_from_world: Mat3,
    /// x: the illuminance of a magnitude-0 star outside the atmosphere, lux (0: no stars); y:
    /// the standard deviation of a star's spot, rad; z: the full-resolution view's pixel angle,
    /// rad; w: 0.
    pub stars: Vec4,
    /// The star field's seed.
    pub star_seed: u32,
    /// The moon's disc ([`crate::sky::moon::disc::MoonDisc`]): xyz the unit vector toward its
    /// centre, w its radius, rad.
    pub moon: Vec4,
    /// xyz the unit vector from the moon toward the sun; w the disc's radiance per unit of
    /// shading, cd/m² (0: no disc).
    pub moon_sun: Vec4,
}

/// Where a view's camera was and how it projected, for the next frame's reprojection.
#[derive(Clone, Copy, Debug, PartialEq)]
pub(crate) struct ViewPose {
    /// The camera's world position, m (f64: a camera far from the origin keeps its precision).
    pub position: DVec3,
    /// The camera's world rotation.
    pub rotation: DQuat,
    /// The projection.
    pub clip_from_view: DMat4,
}

impl ViewPose {
    /// The pose of a camera with `world_from_view` and `clip_from_view`.
    pub fn new(world_from_view: &GlobalTransform, clip_from_view: Mat4) -> Self {
        let (_, rotation, translation) = world_from_view.to_scale_rotation_translation();
        Self {
            position: translation.as_dvec3(),
            rotation: rotation.as_dquat(),
            clip_from_view: clip_from_view.as_dmat4(),
        }
    }

    /// This (last frame's) pose's clip space from a point relative to a camera now at
    /// `camera_m`: `clip_from_view · R⁻¹ · (x + camera_m − position)`, composed in f64. The
    /// matrix [`crate::reference::composite::reproject`] takes.
    pub fn clip_from_relative(&self, camera_m: DVec3) -> DMat4 {
        self.clip_from_view
            * DMat4::from_quat(self.rotation.inverse())
            * DMat4::from_translation(camera_m - self.position)
    }
}

/// Layouts, sampler and shader of the temporal accumulation (`temporal.wgsl`).
#[derive(Resource)]
pub(crate) struct CloudTemporalPipeline {
    pub(crate) layouts: DepthLayouts,
    pub(crate) sampler: Sampler,
    fullscreen: FullscreenShader,
    shader: Handle<Shader>,
}

fn temporal_layout(label: &'static str, multisampled: bool) -> BindGroupLayoutDescriptor {
    BindGroupLayoutDescriptor::new(
        label,
        &BindGroupLayoutEntries::sequential(
            ShaderStages::FRAGMENT,
            (
                uniform_buffer::<ViewUniform>(true),
                depth_binding(multisampled),
                texture_2d(TextureSampleType::Float { filterable: false }),
                texture_2d(TextureSampleType::Float { filterable: false }),
                texture_2d(TextureSampleType::Float { filterable: true }),
                sampler(SamplerBindingType::Filtering),
                uniform_buffer::<GpuTemporalUniforms>(false),
                uniform_buffer::<GpuViewGround>(false),
                texture_2d(TextureSampleType::Float { filterable: false }),
            ),
        ),
    )
}

/// Creates [`CloudTemporalPipeline`] (render world, at start-up).
pub(crate) fn init_cloud_temporal_pipeline(
    mut commands: Commands,
    asset_server: Res<AssetServer>,
    fullscreen: Res<FullscreenShader>,
    device: Res<RenderDevice>,
) {
    let sampler = device.create_sampler(&SamplerDescriptor {
        label: Some("cloud_history_sampler"),
        mag_filter: FilterMode::Linear,
        min_filter: FilterMode::Linear,
        ..default()
    });
    commands.insert_resource(CloudTemporalPipeline {
        layouts: DepthLayouts::new(
            temporal_layout,
            "cloud_temporal_layout",
            "cloud_temporal_layout_multisampled",
        ),
        sampler,
        fullscreen: fullscreen.clone(),
        shader: load_embedded_asset!(asset_server.as_ref(), "temporal.wgsl"),
    });
}

impl SpecializedRenderPipeline for CloudTemporalPipeline {
    /// The view's MSAA sample count (the depth prepass is multisampled when > 1).
    type Key = u32;

    fn specialize(&self, samples: Self::Key) -> RenderPipelineDescriptor {
        let multisampled = samples > 1;
        RenderPipelineDescriptor {
            label: Some(Cow::Borrowed("cloud_temporal_pipeline")),
            layout: vec![self.layouts.get(multisampled).clone()],
            vertex: self.fullscreen.to_vertex_state(),
            fragment: Some(FragmentState {
                shader: self.shader.clone(),
                shader_defs: depth_shader_defs(multisampled),
                entry_point: Some(Cow::Borrowed("temporal_resolve")),
                targets: vec![
                    Some(ColorTargetState::from(HISTORY_FORMAT)),
                    Some(ColorTargetState::from(HISTORY_DISTANCE_FORMAT)),
                ],
            }),
            ..default()
        }
    }
}

/// The temporal accumulation of a view: the history it reads (last frame's) and the one it
/// writes, and the uniform.
#[derive(Component)]
pub(crate) struct CloudHistory {
    /// Last frame's history.
    pub read: CachedTexture,
    /// This frame's history, which is also what gets composited.
    pub write: CachedTexture,
    /// Where the rays of last frame's history ended ([`HISTORY_DISTANCE_FORMAT`]).
    pub read_distance: CachedTexture,
    /// Where this frame's rays end.
    pub write_distance: CachedTexture,
    /// The reprojection and blend.
    pub uniforms: UniformBuffer<GpuTemporalUniforms>,
}

/// What the accumulation remembers of a view between frames (render world).
#[derive(Clone, Copy, Debug)]
pub(crate) struct HistoryState {
    pose: ViewPose,
    size: UVec2,
    frame: u32,
}

/// The reduced-resolution targets of a view that marches below full resolution.
#[derive(Component)]
pub(crate) struct CloudLowResTargets {
    /// `(L, T)`, [`LOW_RES_COLOUR_FORMAT`].
    pub colour: CachedTexture,
    /// Where each ray was stopped, metres ([`LOW_RES_DISTANCE_FORMAT`]).
    pub distance: CachedTexture,
    /// Where the view's ground sphere is, for the full-resolution pixels' ray ends.
    pub ground: UniformBuffer<GpuViewGround>,
}

/// The light-shaft factors of a view with light shafts ([`SHAFT_FORMAT`]), at
/// [`VolumetricClouds::light_shaft_resolution_scale`](super::VolumetricClouds::light_shaft_resolution_scale).
#[derive(Component)]
pub(crate) struct CloudShaftTarget {
    /// Per texel: the factor below the lowest cloud base, the factor above it, the distance the
    /// ray was stopped at (metres), 0.
    pub factors: CachedTexture,
}

/// Creates or drops each view's composite targets (render world, every frame): the march's
/// reduced-resolution (or accumulation) targets, the temporal history and the light-shaft
/// target.
#[allow(clippy::too_many_arguments)]
pub(crate) fn prepare_composite_targets(
    mut commands: Commands,
    mut cache: ResMut<TextureCache>,
    device: Res<RenderDevice>,
    queue: Res<RenderQueue>,
    frame: Res<FrameCount>,
    mut states: Local<HashMap<Entity, HistoryState>>,
    views: Query<(Entity, &ViewTarget, &ExtractedView, &ExtractedCloudView)>,
    stars: Option<Res<StarSky>>,
) {
    let stars = stars.map_or_else(StarSky::default, |s| *s);
    // Views that are gone start over if they come back.
    states.retain(|entity, _| views.contains(*entity));
    for (entity, target, extracted, view) in &views {
        let full = target.main_texture().size();
        let full = UVec2::new(full.width, full.height);
        let mut texture = |label: &'static str, format: TextureFormat, size: UVec2| {
            cache.get(
                &device,
                TextureDescriptor {
                    label: Some(label),
                    size: Extent3d {
                        width: size.x,
                        height: size.y,
                        depth_or_array_layers: 1,
                    },
                    mip_level_count: 1,
                    sample_count: 1,
                    dimension: TextureDimension::D2,
                    format,
                    usage: TextureUsages::RENDER_ATTACHMENT | TextureUsages::TEXTURE_BINDING,
                    view_formats: &[],
                },
            )
        };
        let mut entity_commands = commands.entity(entity);
        // The temporal accumulation marches into the targets too, at any scale.
        if let Some(blend) = view.temporal_blend {
            let pose = ViewPose::new(&extracted.world_from_view, extracted.clip_from_view);
            let previous = states.insert(
                entity,
                HistoryState {
                    pose,
                    size: full,
                    frame: frame.0,
                },
            );
            let valid = previous
                .filter(|p| {
                    !view.reset_history && p.size == full && p.frame.wrapping_add(1) == frame.0
                })
                .map(|p| p.pose);
            let mut uniforms = UniformBuffer::from(GpuTemporalUniforms {
                previous_clip_from_relative: valid
                    .map_or(DMat4::IDENTITY, |p| p.clip_from_relative(pose.position))
                    .as_mat4(),
                blend: hit_blend(f64::from(blend), view.upsampling.factor) as f32,
                valid: u32::from(valid.is_some()),
                sample_offset: view.upsampling.offset_texels,
                upsampling_factor: view.upsampling.factor,
                uv_scale: view.upsampling.uv_scale,
            });
            uniforms.set_label(Some("cloud_temporal_uniforms"));
            uniforms.write_buffer(&device, &queue);
            let first = texture("cloud_history_1", HISTORY_FORMAT, full);
            let second = texture("cloud_history_2", HISTORY_FORMAT, full);
            let first_distance = texture("cloud_history_distance_1", HISTORY_DISTANCE_FORMAT, full);
            let second_distance =
                texture("cloud_history_distance_2", HISTORY_DISTANCE_FORMAT, full);
            let ((read, read_distance), (write, write_distance)) = if frame.0.is_multiple_of(2) {
                ((second, second_distance), (first, first_distance))
            } else {
                ((first, first_distance), (second, second_distance))
            };
            entity_commands.insert(CloudHistory {
                read,
                write,
                read_distance,
                write_distance,
                uniforms,
            });
        } else {
            states.remove(&entity);
            entity_commands.remove::<CloudHistory>();
        }
        if view.resolution_scale < 1.0 || view.temporal_blend.is_some() {
            let size = view.upsampling.size;
            let colour = texture("cloud_low_res_colour", LOW_RES_COLOUR_FORMAT, size);
            let distance = texture("cloud_low_res_distance", LOW_RES_DISTANCE_FORMAT, size);
            let settings = &view.settings;
            let up = settings.camera_up.map(|c| c as f32);
            let mut ground = UniformBuffer::from(GpuViewGround {
                camera_up_altitude: Vec4::new(
                    up[0],
                    up[1],
                    up[2],
                    settings.camera_altitude_m as f32,
                ),
                planet_radius_m: settings.planet_radius_m as f32,
                celestial_from_world: stars.celestial_from_scene,
                stars: Vec4::new(
                    stars.zero_magnitude_lux,
                    // The march's pixel angle is the full-resolution view's.
                    (crate::sky::stars::STAR_BLUR_PIXELS * settings.pixel_angle_rad) as f32,
                    settings.pixel_angle_rad as f32,
                    0.0,
                ),
                star_seed: stars.seed,
                moon: stars.moon.map_or(Vec4::ZERO, |disc| {
                    disc.direction.extend(disc.radius_rad).as_vec4()
                }),
                moon_sun: stars.moon.map_or(Vec4::ZERO, |disc| {
                    disc.toward_sun.extend(disc.lux_per_sr).as_vec4()
                }),
            });
            ground.set_label(Some("cloud_view_ground"));
            ground.write_buffer(&device, &queue);
            entity_commands.insert(CloudLowResTargets {
                colour,
                distance,
                ground,
            });
        } else {
            entity_commands.remove::<CloudLowResTargets>();
        }
        match view.shaft_resolution_scale {
            Some(scale) => {
                let factors = texture(
                    "cloud_shaft_factors",
                    SHAFT_FORMAT,
                    low_res_size(full, scale),
                );
                entity_commands.insert(CloudShaftTarget { factors });
            }
            None => {
                entity_commands.remove::<CloudShaftTarget>();
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn reduced_sizes_round_up_and_never_vanish() {
        assert_eq!(
            low_res_size(UVec2::new(1280, 720), 0.5),
            UVec2::new(640, 360)
        );
        assert_eq!(
            low_res_size(UVec2::new(1281, 721), 0.25),
            UVec2::new(321, 181)
        );
        assert_eq!(low_res_size(UVec2::new(1, 1), 0.25), UVec2::ONE);
        assert_eq!(low_res_size(UVec2::new(0, 3), 0.5), UVec2::new(1, 2));
    }

    #[test]
    fn the_upsampling_offsets_only_an_accumulating_reduced_march() {
        assert_eq!(GpuTemporalUniforms::min_size().get(), 96);
        let size = UVec2::new(160, 90);
        // Full resolution, or no accumulation: the rays stay at the texel centres.
        for (accumulates, scale) in [(true, 1.0), (false, 0.5)] {
            let up = TemporalUpsampling::new(accumulates, size, scale, 1);
            assert_eq!((up.factor, up.offset_uv), (1, Vec2::ZERO));
        }
        // Half resolution: frame 1 goes through the lower right pixel of each 2 × 2, a quarter
        // texel (half a pixel) right of and below the centre.
        let up = TemporalUpsampling::new(true, size, 0.5, 1);
        assert_eq!(up.factor, 2);
        assert_eq!(up.offset_texels, Vec2::splat(0.25));
        assert_eq!(up.offset_uv, Vec2::new(0.25 / 80.0, 0.25 / 45.0));
        assert_eq!((up.size, up.uv_scale), (UVec2::new(80, 45), Vec2::ONE));
        // A quarter of 90 rows is not whole: 23 texels of 4 pixels each, the last reaching two
        // pixels past the bottom edge, so every pixel is one texel's sample point once a cycle.
        let up = TemporalUpsampling::new(true, size, 0.25, 0);
        assert_eq!((up.factor, up.size), (4, UVec2::new(40, 23)));
        assert_eq!(up.uv_scale, Vec2::new(1.0, 92.0 / 90.0));
        assert_eq!(
            up.offset_uv,
            up.offset_texels * Vec2::new(4.0 / 160.0, 4.0 / 90.0)
        );
    }
}
