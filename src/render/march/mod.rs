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
    core_pipeline::{
        Core3dSystems, FullscreenShader, prepass::ViewPrepassTextures, schedule::Core3d,
    },
    ecs::query::QueryItem,
    prelude::*,
    render::{
        ExtractSchedule, Render, RenderApp, RenderStartup, RenderSystems,
        diagnostic::RecordDiagnostics,
        render_asset::RenderAssets,
        render_resource::{
            binding_types::{
                sampler, storage_buffer_read_only, texture_2d, texture_2d_array, texture_3d,
                uniform_buffer,
            },
            *,
        },
        renderer::{RenderAdapter, RenderContext, RenderDevice, RenderQueue, ViewQuery},
        texture::{FallbackImage, GpuImage},
        view::{ViewTarget, ViewUniform, ViewUniformOffset, ViewUniforms},
    },
    shader::load_shader_library,
};

use super::{
    composite::{
        COMPOSITE_BLEND, CloudHistory, CloudLowResTargets, CloudShaftTarget, CloudTemporalPipeline,
        CloudUpsampleKey, CloudUpsamplePipeline, DepthLayouts, LOW_RES_COLOUR_FORMAT,
        LOW_RES_DISTANCE_FORMAT, SHAFT_FORMAT, depth_binding, depth_shader_defs,
    },
    haze::{CloudShadowFrame, GpuHazeUniforms},
    noise::CloudNoiseTextures,
    view::{
        CloudViewBuffers, GpuCloudLayer, GpuCloudUniforms, clear_history_resets,
        extract_cloud_views,
    },
    weather_map::{
        CloudWeatherMap, CloudWeatherMapPipeline, assign_weather_map, planned_weather_map_size,
    },
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
            (
                prepare_cloud_march_pipelines.in_set(RenderSystems::Prepare),
                prepare_cloud_view_buffers.in_set(RenderSystems::PrepareResources),
            ),
        )
        .add_systems(
            Core3d,
            march_cloud_layers
                .after(Core3dSystems::MainPass)
                .before(Core3dSystems::EarlyPostProcess),
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
        let mut haze = UniformBuffer::from(GpuHazeUniforms::new(&view.haze, shafts));
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
    layouts: DepthLayouts,
    fullscreen: FullscreenShader,
    shader: Handle<Shader>,
    /// The ray-start jitter's blue noise ([`blue_noise_map`]), `R32Float`.
    blue_noise: TextureView,
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

/// The specialised pipelines of a view: the march, the upsample when the view marches at a
/// reduced resolution, and the shaft pass when it draws light shafts.
#[derive(Component)]
pub(crate) struct CloudMarchPipelineId {
    /// The march.
    pub march: CachedRenderPipelineId,
    /// The upsample, for a reduced resolution.
    pub upsample: Option<CachedRenderPipelineId>,
    /// The light-shaft pass.
    pub shafts: Option<CachedRenderPipelineId>,
    /// The temporal accumulation and the composite of its history.
    pub temporal: Option<(CachedRenderPipelineId, CachedRenderPipelineId)>,
}

fn prepare_cloud_march_pipelines(
    mut commands: Commands,
    pipeline_cache: Res<PipelineCache>,
    mut pipelines: ResMut<SpecializedRenderPipelines<CloudMarchPipeline>>,
    mut upsample_pipelines: ResMut<SpecializedRenderPipelines<CloudUpsamplePipeline>>,
    mut temporal_pipelines: ResMut<SpecializedRenderPipelines<CloudTemporalPipeline>>,
    pipeline: Option<Res<CloudMarchPipeline>>,
    upsample: Option<Res<CloudUpsamplePipeline>>,
    temporal: Option<Res<CloudTemporalPipeline>>,
    views: Query<(Entity, &ViewTarget, &Msaa, &ExtractedCloudView)>,
) {
    let (Some(pipeline), Some(upsample), Some(temporal)) = (pipeline, upsample, temporal) else {
        return;
    };
    for (entity, target, msaa, view) in &views {
        let key = CloudMarchPipelineKey {
            format: target.main_texture_format(),
            samples: msaa.samples(),
            // The temporal accumulation reads the march from the targets too.
            low_res: view.resolution_scale < 1.0 || view.temporal_blend.is_some(),
            shafts: false,
        };
        let march = pipelines.specialize(&pipeline_cache, &pipeline, key);
        let composite = |copy| CloudUpsampleKey {
            format: key.format,
            samples: key.samples,
            copy,
        };
        let accumulate = view.temporal_blend.is_some();
        let upsample_id = (key.low_res && !accumulate)
            .then(|| upsample_pipelines.specialize(&pipeline_cache, &upsample, composite(false)));
        let temporal_ids = accumulate.then(|| {
            (
                temporal_pipelines.specialize(&pipeline_cache, &temporal, key.samples),
                upsample_pipelines.specialize(&pipeline_cache, &upsample, composite(true)),
            )
        });
        let shafts = view.shaft_resolution_scale.is_some().then(|| {
            let key = CloudMarchPipelineKey {
                low_res: false,
                shafts: true,
                ..key
            };
            pipelines.specialize(&pipeline_cache, &pipeline, key)
        });
        commands.entity(entity).insert(CloudMarchPipelineId {
            march,
            upsample: upsample_id,
            shafts,
            temporal: temporal_ids,
        });
    }
}

type MarchViewQuery = (
    &'static ViewTarget,
    &'static ViewPrepassTextures,
    &'static ViewUniformOffset,
    &'static CloudViewBuffers,
    &'static CloudMarchPipelineId,
    &'static Msaa,
    Option<&'static CloudLowResTargets>,
    Option<&'static CloudShaftTarget>,
    Option<&'static CloudHistory>,
    &'static CloudWeatherMap,
);

/// How the march's output reaches the view.
enum Finish<'a> {
    /// The march blends onto the view itself.
    Direct,
    /// The march writes the reduced-resolution targets; the upsample composites them.
    Upsample {
        targets: &'a CloudLowResTargets,
        pipeline: &'a RenderPipeline,
    },
    /// The march writes the targets; the temporal pass blends them into the history, which is
    /// then composited.
    Temporal {
        targets: &'a CloudLowResTargets,
        history: &'a CloudHistory,
        resolve: &'a RenderPipeline,
        composite: &'a RenderPipeline,
    },
}

/// One fullscreen triangle into `attachments`, timed on the GPU as `label` (Bevy's render
/// diagnostics, `render/clouds/LABEL/elapsed_gpu`).
fn fullscreen_pass(
    ctx: &mut RenderContext,
    label: &'static str,
    attachments: &[Option<RenderPassColorAttachment<'_>>],
    pipeline: &RenderPipeline,
    bind_group: &BindGroup,
    view_offset: u32,
) {
    let diagnostics = ctx.diagnostic_recorder();
    let diagnostics = diagnostics.as_deref();
    let time_span = diagnostics.time_span(ctx.command_encoder(), label);
    let mut pass = ctx
        .command_encoder()
        .begin_render_pass(&RenderPassDescriptor {
            label: Some(label),
            color_attachments: attachments,
            depth_stencil_attachment: None,
            timestamp_writes: None,
            occlusion_query_set: None,
            multiview_mask: None,
        });
    pass.set_pipeline(pipeline);
    pass.set_bind_group(0, bind_group, &[view_offset]);
    pass.draw(0..3, 0..1);
    drop(pass);
    time_span.end(ctx.command_encoder());
}

/// An attachment cleared to `value` and stored.
fn clear(view: &TextureView, value: LinearRgba) -> RenderPassColorAttachment<'_> {
    RenderPassColorAttachment {
        view,
        depth_slice: None,
        resolve_target: None,
        ops: Operations {
            load: LoadOp::Clear(value.into()),
            store: StoreOp::Store,
        },
    }
}

#[allow(clippy::too_many_arguments)]
fn march_cloud_layers(
    view: ViewQuery<MarchViewQuery, With<ExtractedCloudView>>,
    pipeline: Option<Res<CloudMarchPipeline>>,
    upsample: Option<Res<CloudUpsamplePipeline>>,
    temporal: Option<Res<CloudTemporalPipeline>>,
    weather_map_pipeline: Option<Res<CloudWeatherMapPipeline>>,
    noise: Option<Res<CloudNoiseTextures>>,
    view_uniforms: Res<ViewUniforms>,
    pipeline_cache: Res<PipelineCache>,
    images: Res<RenderAssets<GpuImage>>,
    fallback: Res<FallbackImage>,
    mut stats: ResMut<CloudPassStats>,
    mut ctx: RenderContext,
) {
    let (
        target,
        prepass,
        view_offset,
        buffers,
        pipeline_ids,
        msaa,
        low_res,
        shaft_target,
        history,
        weather_map,
    ): QueryItem<MarchViewQuery> = view.into_inner();
    let (
        Some(pipeline),
        Some(upsample),
        Some(temporal),
        Some(noise),
        Some(view_binding),
        Some(depth),
        Some(render_pipeline),
    ) = (
        pipeline,
        upsample,
        temporal,
        noise,
        view_uniforms.uniforms.binding(),
        prepass.depth_view(),
        pipeline_cache.get_render_pipeline(pipeline_ids.march),
    )
    else {
        return;
    };
    let (Some(uniforms), Some(layers), Some(haze)) = (
        buffers.uniforms.binding(),
        buffers.layers.binding(),
        buffers.haze.binding(),
    ) else {
        return;
    };
    // The shadow map for the light shafts and far samples; white (never read) without one.
    let shadow_map = buffers
        .shadow_map
        .and_then(|id| images.get(id))
        .map_or(&fallback.d2.texture_view, |image| &image.texture_view);
    // The targets and pipelines of the view's way to the screen; while those of a changed
    // setting are not ready, the frame waits.
    let finish = match (
        low_res,
        history,
        pipeline_ids.upsample,
        pipeline_ids.temporal,
    ) {
        (None, None, None, None) => Finish::Direct,
        (Some(targets), None, Some(id), None) => {
            let Some(pipeline) = pipeline_cache.get_render_pipeline(id) else {
                return;
            };
            Finish::Upsample { targets, pipeline }
        }
        (Some(targets), Some(history), None, Some((resolve, composite))) => {
            let (Some(resolve), Some(composite)) = (
                pipeline_cache.get_render_pipeline(resolve),
                pipeline_cache.get_render_pipeline(composite),
            ) else {
                return;
            };
            Finish::Temporal {
                targets,
                history,
                resolve,
                composite,
            }
        }
        _ => return,
    };
    // The light-shaft pass: its target and pipeline. The uniforms promise the march its
    // factors, so without them (not ready yet) the frame waits.
    let shafts = if buffers.shafts {
        let (Some(shaft_target), Some(id)) = (shaft_target, pipeline_ids.shafts) else {
            return;
        };
        let Some(shaft_pipeline) = pipeline_cache.get_render_pipeline(id) else {
            return;
        };
        Some((shaft_target, shaft_pipeline))
    } else {
        None
    };
    let multisampled = msaa.samples() > 1;
    let device = ctx.render_device().clone();
    let pick =
        |layouts: &DepthLayouts| pipeline_cache.get_bind_group_layout(layouts.get(multisampled));
    // Binding 11 is the shaft pass's output for the march, and a stand-in for the shaft pass
    // itself (a texture may not be read and written in one pass).
    let march_layout = pick(&pipeline.layouts);
    let march_bind_group = |label: &'static str, shaft_view: &TextureView| {
        device.create_bind_group(
            label,
            &march_layout,
            &BindGroupEntries::sequential((
                view_binding.clone(),
                depth,
                uniforms.clone(),
                layers.clone(),
                &noise.base.view,
                &noise.detail.view,
                &noise.weather.view,
                &noise.sampler,
                haze.clone(),
                shadow_map,
                &pipeline.blue_noise,
                shaft_view,
                &weather_map.view,
            )),
        )
    };
    let stand_in = &fallback.d2.texture_view;
    let bind_group = march_bind_group(
        "cloud_march_bind_group",
        shafts.map_or(stand_in, |(target, _)| &target.factors.default_view),
    );
    let shaft_bind_group = shafts.map(|_| march_bind_group("cloud_shaft_bind_group", stand_in));
    // Where the ground sphere is, for the full-resolution pixels of the upsample and the
    // accumulation.
    let ground = match &finish {
        Finish::Direct => None,
        Finish::Upsample { targets, .. } | Finish::Temporal { targets, .. } => {
            let Some(ground) = targets.ground.binding() else {
                return;
            };
            Some(ground)
        }
    };
    let upsample_layout = pick(&upsample.layouts);
    let upsample_bind_group = |label: &'static str, colour: &TextureView, distance, ground| {
        device.create_bind_group(
            label,
            &upsample_layout,
            &BindGroupEntries::sequential((view_binding.clone(), depth, colour, distance, ground)),
        )
    };
    let temporal_bind_group = match &finish {
        Finish::Temporal {
            targets, history, ..
        } => {
            let (Some(temporal_uniforms), Some(ground)) =
                (history.uniforms.binding(), ground.clone())
            else {
                return;
            };
            Some(device.create_bind_group(
                "cloud_temporal_bind_group",
                &pick(&temporal.layouts),
                &BindGroupEntries::sequential((
                    view_binding.clone(),
                    depth,
                    &targets.colour.default_view,
                    &targets.distance.default_view,
                    &history.read.default_view,
                    &temporal.sampler,
                    temporal_uniforms,
                    ground,
                    &history.read_distance.default_view,
                )),
            ))
        }
        _ => None,
    };

    let diagnostics = ctx.diagnostic_recorder();
    let diagnostics = diagnostics.as_deref();
    // The whole of a view's cloud passes, and each pass within it.
    let time_span = diagnostics.time_span(ctx.command_encoder(), "clouds");
    ctx.command_encoder().push_debug_group("clouds");
    if let Some(compute) = weather_map_pipeline
        .as_deref()
        .and_then(|p| p.get(&pipeline_cache))
    {
        let span = diagnostics.time_span(ctx.command_encoder(), "cloud_weather_map");
        if weather_map.dispatch(ctx.command_encoder(), compute) {
            stats.views_with_weather_map += 1;
        }
        span.end(ctx.command_encoder());
    }
    let offset = view_offset.offset;
    if let (Some((shaft_target, shaft_pipeline)), Some(shaft_bind_group)) =
        (shafts, &shaft_bind_group)
    {
        let attachment = clear(&shaft_target.factors.default_view, LinearRgba::NONE);
        fullscreen_pass(
            &mut ctx,
            "cloud_shafts",
            &[Some(attachment)],
            shaft_pipeline,
            shaft_bind_group,
            offset,
        );
        stats.views_with_shafts += 1;
    }
    let march_attachments = match &finish {
        Finish::Upsample { targets, .. } | Finish::Temporal { targets, .. } => vec![
            Some(clear(
                &targets.colour.default_view,
                LinearRgba::new(0.0, 0.0, 0.0, 1.0),
            )),
            Some(clear(&targets.distance.default_view, LinearRgba::NONE)),
        ],
        Finish::Direct => vec![Some(target.get_color_attachment())],
    };
    fullscreen_pass(
        &mut ctx,
        "cloud_march",
        &march_attachments,
        render_pipeline,
        &bind_group,
        offset,
    );
    // What the upsample shader composites onto the view: the march's targets, or the history
    // the temporal pass has just written (with the march's distances either way).
    let composite = match (&finish, &temporal_bind_group) {
        (Finish::Upsample { targets, pipeline }, _) => {
            stats.views_upsampled += 1;
            Some((
                "cloud_upsample",
                &targets.colour,
                &targets.distance,
                *pipeline,
            ))
        }
        (
            Finish::Temporal {
                targets,
                history,
                resolve,
                composite,
            },
            Some(temporal_group),
        ) => {
            let attachments = [
                Some(clear(&history.write.default_view, LinearRgba::NONE)),
                Some(clear(
                    &history.write_distance.default_view,
                    LinearRgba::NONE,
                )),
            ];
            fullscreen_pass(
                &mut ctx,
                "cloud_temporal",
                &attachments,
                resolve,
                temporal_group,
                offset,
            );
            stats.views_accumulated += 1;
            Some((
                "cloud_history_composite",
                &history.write,
                &targets.distance,
                *composite,
            ))
        }
        _ => None,
    };
    if let Some((label, colour, distance, pipeline)) = composite
        && let Some(ground) = ground
    {
        let group =
            upsample_bind_group(label, &colour.default_view, &distance.default_view, ground);
        let attachment = target.get_color_attachment();
        fullscreen_pass(
            &mut ctx,
            label,
            &[Some(attachment)],
            pipeline,
            &group,
            offset,
        );
    }
    ctx.command_encoder().pop_debug_group();
    time_span.end(ctx.command_encoder());
    stats.views_marched += 1;
}
