//! The clouds' render node: per view, the pipelines of its passes and the passes in order (the
//! weather map, the light shafts, the march, then the temporal accumulation and the composite,
//! or the upsample). Each pass's pipeline, targets and shaders live in its own module
//! ([`super::march`], [`super::composite`], [`super::weather_map`]); this module is the only one
//! that uses them together.

use bevy::{
    core_pipeline::prepass::ViewPrepassTextures,
    ecs::query::QueryItem,
    prelude::*,
    render::{
        diagnostic::RecordDiagnostics,
        render_asset::RenderAssets,
        render_resource::*,
        renderer::{RenderContext, ViewQuery},
        texture::{FallbackImage, GpuImage},
        view::{ViewTarget, ViewUniformOffset, ViewUniforms},
    },
};

use super::{
    composite::{
        CloudHistory, CloudLowResTargets, CloudShaftTarget, CloudTemporalPipeline,
        CloudUpsampleKey, CloudUpsamplePipeline, DepthLayouts,
    },
    march::{CloudMarchPipeline, CloudMarchPipelineKey},
    noise::CloudNoiseTextures,
    view::{CloudPassStats, CloudViewBuffers, ExtractedCloudView},
    weather_map::{CloudWeatherMap, CloudWeatherMapPipeline},
};

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

pub(super) fn prepare_cloud_march_pipelines(
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
pub(super) fn march_cloud_layers(
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
    growth: Option<Res<super::growth::ExtractedGrowth>>,
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
    let growth_cover = super::growth::growth_cover_view(growth.as_deref(), &images, &fallback);
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
                growth_cover,
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
