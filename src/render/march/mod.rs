//! The volumetric ray-march: one fullscreen pass per camera with [`VolumetricClouds`](crate::render::VolumetricClouds).
//!
//! For each pixel the entry shader (`march.wgsl`) builds the view ray, ends it at scene geometry
//! using the depth prepass (reverse-Z, infinite far plane: depth 0 is sky), and calls
//! `march_clouds` from the shader library `clouds.wgsl`, which marches only the intervals where
//! the ray crosses a layer shell around the planet, lights each sample with a light march toward
//! the sun and the δ-Eddington diffuse light, and integrates with Hillaire's energy-conserving
//! step. Then `march_haze` (`haze.wgsl`, see [`crate::render::haze`]) marches the haze along the
//! same ray and stacks it in front of and behind the clouds. The result `(L, T)` is blended onto
//! the HDR main texture as `scene · T + L`, before tonemapping ([`crate::render::composite`]).
//! The algorithm and its sources are documented in [`crate::reference::render`], the f64 CPU
//! twin the GPU output is tested against.
//!
//! # What a frame costs
//!
//! Layers with zero coverage or density are not sent to the GPU; with no visible layer and no
//! haze the pass does not run at all ([`CloudPassStats`] counts the views it marched). The pass
//! runs after the main (opaque and transparent) passes and before post-processing, like Bevy's
//! volumetric fog; transparent objects are therefore covered by clouds in front of the opaque
//! depth behind them.
//!
//! At [`VolumetricClouds::resolution_scale`](crate::render::VolumetricClouds::resolution_scale) below 1 the march renders `(L, T)` and the
//! distance each ray stopped at into targets of the reduced size, and the depth-aware upsample
//! of [`crate::render::composite`] composites them ([`CloudPassStats::views_upsampled`]
//! counts these views).
//!
//! With light shafts, a second entry of the same shader (`shafts`, same bindings) runs first at
//! [`VolumetricClouds::light_shaft_resolution_scale`](crate::render::VolumetricClouds::light_shaft_resolution_scale): it marches the haze along each ray,
//! reads the cloud shadow map at every sample and writes the ray's two shaft factors
//! ([`crate::reference::haze::ShaftFactors`]) and its end distance. The march reads them back at
//! binding 11 with the upsample's weights, so the full-resolution haze reads no shadow map
//! ([`CloudPassStats::views_with_shafts`] counts these views).
//!
//! # Inputs, from one source
//!
//! [`march_inputs`] turns a camera, its [`VolumetricClouds`](crate::render::VolumetricClouds) settings, the sun and the
//! [`CloudLayer`](crate::layers::CloudLayer)s into the reference's
//! [`MarchSettings`](crate::reference::render::MarchSettings) and
//! [`MarchLayer`](crate::reference::render::MarchLayer)s (f64), and the
//! GPU structs are converted from those with `From`. The CPU reference renderer and the GPU
//! therefore see the same numbers, rounded to f32 only at the end. A layer with rain
//! ([`CloudLayer::rain_mm_per_h`](crate::layers::CloudLayer::rain_mm_per_h)) brings a second layer under it, from the ground to its base:
//! the rain shafts (see `rain_shaft`). A layer's far coverages
//! ([`CloudLayer::far_coverage`](crate::layers::CloudLayer::far_coverage)) become [`MarchLayer::far`](crate::reference::render::MarchLayer::far), relative to the camera.

use std::borrow::Cow;

use bevy::{
    asset::{embedded_asset, load_embedded_asset},
    core_pipeline::FullscreenShader,
    prelude::*,
    render::{
        ExtractSchedule, Render, RenderApp, RenderStartup, RenderSystems,
        render_asset::RenderAssets,
        render_resource::{
            binding_types::{
                sampler, storage_buffer_read_only, texture_2d, texture_2d_array, texture_3d,
                uniform_buffer,
            },
            *,
        },
        renderer::{RenderAdapter, RenderDevice, RenderQueue},
        texture::GpuImage,
        view::ViewUniform,
    },
    shader::load_shader_library,
};

use super::{
    composite::{
        COMPOSITE_BLEND, DepthLayouts, LOW_RES_COLOUR_FORMAT, LOW_RES_DISTANCE_FORMAT,
        SHAFT_FORMAT, depth_binding, depth_shader_defs,
    },
    haze::{CloudShadowFrame, GpuHazeUniforms},
    noise::CloudNoiseTextures,
    view::{
        CloudViewBuffers, GpuCloudLayer, GpuCloudUniforms, clear_history_resets,
        extract_cloud_views,
    },
    weather_map::{CloudWeatherMapPipeline, assign_weather_map, planned_weather_map_size},
};
use crate::reference::blue_noise::{BLUE_NOISE_SIZE, blue_noise_map};

pub use super::view::{CloudPassStats, CloudSun, ExtractedCloudView, march_inputs};

/// The march's part of [`super::CloudRenderPlugin::build`]: the shader libraries and the
/// per-view extraction (the main-world data every camera shares is registered by the plugin).
pub(super) fn build(app: &mut App) {
    if app.get_sub_app(RenderApp).is_none() {
        return;
    }
    load_shader_library!(app, "parameters.wgsl");
    load_shader_library!(app, "textures.wgsl");
    load_shader_library!(app, "geometry.wgsl");
    load_shader_library!(app, "density.wgsl");
    load_shader_library!(app, "light.wgsl");
    load_shader_library!(app, "shadow.wgsl");
    load_shader_library!(app, "clouds.wgsl");
    embedded_asset!(app, "march.wgsl");
    app.sub_app_mut(RenderApp)
        .init_resource::<CloudPassStats>()
        .add_systems(
            ExtractSchedule,
            (
                extract_cloud_views,
                clear_history_resets.after(extract_cloud_views),
            ),
        );
}

/// Why this GPU cannot march clouds, if it cannot: the march reads its layers from storage
/// buffers in a fragment shader.
pub(super) fn unsupported(render_app: &SubApp) -> Option<&'static str> {
    let adapter = render_app.world().resource::<RenderAdapter>();
    let fragment_storage = adapter
        .get_downlevel_capabilities()
        .flags
        .contains(DownlevelFlags::VERTEX_STORAGE | DownlevelFlags::COMPUTE_SHADERS);
    let limits = render_app.world().resource::<RenderDevice>().limits();
    (!fragment_storage || limits.max_storage_buffers_per_shader_stage == 0)
        .then_some("the GPU has no storage buffers in fragment shaders")
}

/// The march's part of [`super::CloudRenderPlugin::finish`], on a GPU that can run it: its
/// pipeline, the view buffers, and the pass after the main pass.
pub(super) fn finish(render_app: &mut SubApp) {
    render_app
        .init_resource::<SpecializedRenderPipelines<CloudMarchPipeline>>()
        .add_systems(RenderStartup, init_cloud_march_pipeline)
        .add_systems(
            Render,
            prepare_cloud_view_buffers.in_set(RenderSystems::PrepareResources),
        );
}

#[allow(clippy::too_many_arguments)]
fn prepare_cloud_view_buffers(
    mut commands: Commands,
    views: Query<(Entity, &ExtractedCloudView)>,
    shadow: Option<Res<CloudShadowFrame>>,
    images: Res<RenderAssets<GpuImage>>,
    noise: Option<Res<CloudNoiseTextures>>,
    weather_map: Option<Res<CloudWeatherMapPipeline>>,
    pipeline_cache: Res<PipelineCache>,
    device: Res<RenderDevice>,
    queue: Res<RenderQueue>,
) {
    // The layers read a weather map only once its pass can fill it.
    let map_ready = weather_map.is_some_and(|p| p.get(&pipeline_cache).is_some());
    for (entity, view) in &views {
        let mut gpu_layers: Vec<GpuCloudLayer> =
            view.layers.iter().map(GpuCloudLayer::from).collect();
        let layer_count = gpu_layers.len() as u32;
        let map_size = noise.as_deref().filter(|_| map_ready).and_then(|noise| {
            planned_weather_map_size(view.weather_map_size, gpu_layers.len(), &device.limits())
                .map(|size| (noise.recipe.weather_size, size))
        });
        if let Some((noise_size, size)) = map_size {
            assign_weather_map(&mut gpu_layers, &view.layers, noise_size, size);
        }
        if gpu_layers.is_empty() {
            // Haze alone: a storage binding may not be empty; this layer is never read.
            gpu_layers.push(GpuCloudLayer::default());
        }
        // The cloud shadow map, for the light shafts and the sun of far samples; only once its
        // image is on the GPU (the pass binds a white stand-in otherwise, which would read as
        // "no cloud anywhere").
        let map = shadow.as_deref().filter(|m| images.get(m.image).is_some());
        let frame = map.map(|m| m.relative_to(view.camera_m));
        let mut uniforms = UniformBuffer::from(
            GpuCloudUniforms::new(&view.settings, layer_count, frame.as_ref())
                .with_upsampling(&view.upsampling),
        );
        uniforms.set_label(Some("cloud_march_uniforms"));
        uniforms.write_buffer(&device, &queue);
        let mut layers = StorageBuffer::from(gpu_layers);
        layers.set_label(Some("cloud_march_layers"));
        layers.write_buffer(&device, &queue);
        let shafts = view.shaft_resolution_scale.is_some() && map.is_some();
        let mut haze = UniformBuffer::from(GpuHazeUniforms::new(
            &view.haze,
            view.settings.ambient_top,
            shafts,
        ));
        haze.set_label(Some("cloud_haze_uniforms"));
        haze.write_buffer(&device, &queue);
        commands.entity(entity).insert(CloudViewBuffers {
            uniforms,
            layers,
            haze,
            shadow_map: map.map(|m| m.image),
            shafts,
            weather_map: map_size.map(|(_, size)| (size, layer_count)),
        });
    }
}

/// Layouts, sampler and shader of the march pass.
#[derive(Resource)]
pub(crate) struct CloudMarchPipeline {
    pub(crate) layouts: DepthLayouts,
    fullscreen: FullscreenShader,
    shader: Handle<Shader>,
    /// The ray-start jitter's blue noise ([`blue_noise_map`]), `R32Float`.
    pub(crate) blue_noise: TextureView,
}

/// What a march pipeline is specialised on.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub(crate) struct CloudMarchPipelineKey {
    /// Format of the view's main texture.
    pub format: TextureFormat,
    /// MSAA sample count of the view (the depth prepass is multisampled when > 1).
    pub samples: u32,
    /// March into the targets ([`LOW_RES_COLOUR_FORMAT`], [`LOW_RES_DISTANCE_FORMAT`]) for the
    /// upsample or the temporal accumulation, instead of blending onto the view (the shader's
    /// `LOW_RES` def; the targets are at full size when only the accumulation needs them).
    pub low_res: bool,
    /// The light-shaft pass (entry `shafts`, into a [`SHAFT_FORMAT`] target) instead of the
    /// march.
    pub shafts: bool,
}

fn march_layout(label: &'static str, multisampled: bool) -> BindGroupLayoutDescriptor {
    BindGroupLayoutDescriptor::new(
        label,
        &BindGroupLayoutEntries::sequential(
            ShaderStages::FRAGMENT,
            (
                uniform_buffer::<ViewUniform>(true),
                depth_binding(multisampled),
                uniform_buffer::<GpuCloudUniforms>(false),
                storage_buffer_read_only::<GpuCloudLayer>(false),
                texture_3d(TextureSampleType::Float { filterable: true }),
                texture_3d(TextureSampleType::Float { filterable: true }),
                texture_2d(TextureSampleType::Float { filterable: true }),
                sampler(SamplerBindingType::Filtering),
                uniform_buffer::<GpuHazeUniforms>(false),
                texture_2d(TextureSampleType::Float { filterable: true }),
                texture_2d(TextureSampleType::Float { filterable: false }),
                texture_2d(TextureSampleType::Float { filterable: false }),
                texture_2d_array(TextureSampleType::Float { filterable: false }),
                texture_2d_array(TextureSampleType::Float { filterable: false }),
            ),
        ),
    )
}

fn init_cloud_march_pipeline(
    mut commands: Commands,
    asset_server: Res<AssetServer>,
    fullscreen: Res<FullscreenShader>,
    device: Res<RenderDevice>,
    queue: Res<RenderQueue>,
) {
    let bytes: Vec<u8> = blue_noise_map()
        .iter()
        .flat_map(|v| v.to_le_bytes())
        .collect();
    let blue_noise = device
        .create_texture_with_data(
            &queue,
            &TextureDescriptor {
                label: Some("cloud_blue_noise"),
                size: Extent3d {
                    width: BLUE_NOISE_SIZE,
                    height: BLUE_NOISE_SIZE,
                    depth_or_array_layers: 1,
                },
                mip_level_count: 1,
                sample_count: 1,
                dimension: TextureDimension::D2,
                format: TextureFormat::R32Float,
                usage: TextureUsages::TEXTURE_BINDING,
                view_formats: &[],
            },
            TextureDataOrder::LayerMajor,
            &bytes,
        )
        .create_view(&TextureViewDescriptor::default());
    commands.insert_resource(CloudMarchPipeline {
        layouts: DepthLayouts::new(
            march_layout,
            "cloud_march_layout",
            "cloud_march_layout_multisampled",
        ),
        fullscreen: fullscreen.clone(),
        shader: load_embedded_asset!(asset_server.as_ref(), "march.wgsl"),
        blue_noise,
    });
}

impl SpecializedRenderPipeline for CloudMarchPipeline {
    type Key = CloudMarchPipelineKey;

    fn specialize(&self, key: Self::Key) -> RenderPipelineDescriptor {
        let multisampled = key.samples > 1;
        let mut shader_defs = depth_shader_defs(multisampled);
        shader_defs.push("WEATHER_MAP".into());
        let (entry, targets) = if key.shafts {
            ("shafts", vec![Some(ColorTargetState::from(SHAFT_FORMAT))])
        } else if key.low_res {
            shader_defs.push("LOW_RES".into());
            (
                "fragment",
                vec![
                    Some(ColorTargetState::from(LOW_RES_COLOUR_FORMAT)),
                    Some(ColorTargetState::from(LOW_RES_DISTANCE_FORMAT)),
                ],
            )
        } else {
            (
                "fragment",
                vec![Some(ColorTargetState {
                    format: key.format,
                    blend: Some(COMPOSITE_BLEND),
                    write_mask: ColorWrites::ALL,
                })],
            )
        };
        RenderPipelineDescriptor {
            label: Some(Cow::Borrowed(if key.shafts {
                "cloud_shaft_pipeline"
            } else {
                "cloud_march_pipeline"
            })),
            layout: vec![self.layouts.get(multisampled).clone()],
            vertex: self.fullscreen.to_vertex_state(),
            fragment: Some(FragmentState {
                shader: self.shader.clone(),
                shader_defs,
                entry_point: Some(Cow::Borrowed(entry)),
                targets,
            }),
            multisample: MultisampleState {
                // The reduced-resolution targets are single-sampled.
                count: if key.low_res || key.shafts {
                    1
                } else {
                    key.samples
                },
                ..default()
            },
            ..default()
        }
    }
}
