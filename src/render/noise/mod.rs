//! Tileable 3D cloud noise, generated on the GPU by a compute pass.
//!
//! Three textures feed the cloud ray-march (Pérez Martín 2022, "Cloud textures"):
//!
//! - **base**, 3D `Rgba16Float`, 128³ by default: Perlin-Worley and three Worley fBm octaves
//!   sets that shape the clouds;
//! - **detail**, 3D `Rgba16Float`, 32³: three Worley fBm that erode the edges;
//! - **weather**, 2D `Rgba8Unorm`, 256²: coverage noise and curl for the weather maps.
//!
//! The formulas, channel recipes and tiling are documented in [`crate::reference::noise`], the
//! f64 CPU twin the GPU output is tested against. Both 3D textures carry a full mip chain (a
//! 2×2×2 box filter, computed on the GPU) so distant samples can read coarser levels, and are
//! bound with a trilinear, repeating sampler.
//!
//! # When it runs
//!
//! Once, in the render-graph schedule before any camera renders, after the pipelines compile; then
//! only when [`CloudNoiseSettings`] change. Frames in between cost nothing: no dispatch, no
//! upload. [`CloudNoiseTextures::generation`] counts completed generations.
//!
//! # Cost
//!
//! The default textures take 19.47 MB of GPU memory with mips (base 19.17 MB, detail 0.30 MB,
//! at 8 bytes a texel) plus 0.26 MB for the weather noise. Generation is a compute pass that runs
//! once, and again only when [`CloudNoiseSettings`] change.
//!
//! # Platform limits
//!
//! It needs compute shaders and writable 3D storage textures. Where the device lacks them the
//! plugin logs a warning and does nothing, and the cloud passes that need the textures stay off.

use std::borrow::Cow;

use bevy::{
    asset::{embedded_asset, load_embedded_asset},
    core_pipeline::schedule::camera_driver,
    prelude::*,
    render::{
        Render, RenderApp, RenderStartup, RenderSystems,
        diagnostic::RecordDiagnostics,
        extract_resource::{ExtractResource, ExtractResourcePlugin},
        render_resource::{
            binding_types::{texture_3d, texture_storage_2d, texture_storage_3d, uniform_buffer},
            *,
        },
        renderer::{
            RenderAdapter, RenderContext, RenderDevice, RenderGraph, RenderGraphSystems,
            RenderQueue,
        },
    },
};

use crate::reference::noise::{FBM_SLOT_COUNT, NoiseRecipe, mip_level_count};

/// The recipe of the cloud-noise textures: sizes, seed, and the frequency, octaves and
/// persistence of every channel. Changing it regenerates the textures on the GPU.
///
/// Defaults: base 128³, detail 32³, weather 256², seed 0 (see [`NoiseRecipe`]).
#[derive(Resource, Reflect, Clone, Debug, PartialEq, Default, Deref, DerefMut, ExtractResource)]
#[reflect(Resource, Default)]
pub struct CloudNoiseSettings(pub NoiseRecipe);

/// Generates the cloud-noise textures; part of [`crate::CloudscapePlugin`].
#[derive(Debug, Default, Clone, Copy)]
pub struct CloudNoisePlugin;

impl Plugin for CloudNoisePlugin {
    fn build(&self, app: &mut App) {
        embedded_asset!(app, "noise.wgsl");
        app.init_resource::<CloudNoiseSettings>()
            .register_type::<CloudNoiseSettings>()
            .add_plugins(ExtractResourcePlugin::<CloudNoiseSettings>::default());
    }

    fn finish(&self, app: &mut App) {
        let Some(render_app) = app.get_sub_app_mut(RenderApp) else {
            return;
        };
        if let Err(reason) = check_device(render_app.world()) {
            warn!("bevy_cloudscape: cloud noise disabled, so clouds will not render: {reason}");
            return;
        }
        render_app
            .add_systems(RenderStartup, init_cloud_noise_pipelines)
            .add_systems(
                Render,
                prepare_cloud_noise_textures.in_set(RenderSystems::PrepareResources),
            )
            .add_systems(
                RenderGraph,
                generate_cloud_noise
                    .in_set(RenderGraphSystems::Render)
                    .before(camera_driver),
            );
    }
}

/// Whether the device can run the noise pass, and why not.
fn check_device(world: &World) -> Result<(), String> {
    let adapter = world.resource::<RenderAdapter>();
    if !adapter
        .get_downlevel_capabilities()
        .flags
        .contains(DownlevelFlags::COMPUTE_SHADERS)
    {
        return Err("the GPU has no compute shaders".into());
    }
    for format in [NOISE_3D_FORMAT, NOISE_2D_FORMAT] {
        if !adapter
            .get_texture_format_features(format)
            .allowed_usages
            .contains(TextureUsages::STORAGE_BINDING)
        {
            return Err(format!("the GPU cannot write {format:?} storage textures"));
        }
    }
    // The device, unlike the adapter, honours WGPU_SETTINGS_PRIO limits.
    let limits = world.resource::<RenderDevice>().limits();
    if limits.max_storage_textures_per_shader_stage == 0 {
        return Err("the GPU allows no storage textures in compute shaders".into());
    }
    Ok(())
}

/// Texel format of the base and detail noise: half floats, so that the sampler filters in float.
///
/// The coverage and erosion remaps multiply small differences in the filtered noise many times
/// over, and filtering `Rgba8Unorm` is not exact on every GPU (lavapipe filters it in 8-bit fixed
/// point and rounds the result to 1/255). Half floats are filtered in float. The shader rounds
/// each value to a multiple of `2^-11` before it writes
/// ([`crate::reference::noise::quantize_noise`]), eight times finer than bytes and exactly a half
/// float, so the stored texels do not depend on how the GPU converts f32 to f16 and the march
/// and its CPU twin sample the same values.
pub(crate) const NOISE_3D_FORMAT: TextureFormat = TextureFormat::Rgba16Float;

/// Texel format of the weather noise. The march filters the weather noise itself from texel
/// loads, so bytes lose nothing there.
pub(crate) const NOISE_2D_FORMAT: TextureFormat = TextureFormat::Rgba8Unorm;

/// The noise uniform, laid out as `NoiseParams` in `noise.wgsl` (160 bytes, 16-byte fields).
/// fBm slot `s` is lane `s % 4` of the `_{s / 4}` vectors ([`NoiseRecipe::fbm_slots`]).
#[derive(ShaderType, Clone, Debug)]
pub(crate) struct GpuNoiseParams {
    seed: u32,
    _padding0: u32,
    _padding1: u32,
    _padding2: u32,
    frequencies_0: UVec4,
    frequencies_1: UVec4,
    frequencies_2: UVec4,
    octaves_0: UVec4,
    octaves_1: UVec4,
    octaves_2: UVec4,
    persistences_0: Vec4,
    persistences_1: Vec4,
    persistences_2: Vec4,
}

impl From<&NoiseRecipe> for GpuNoiseParams {
    fn from(recipe: &NoiseRecipe) -> Self {
        let slots = recipe.fbm_slots();
        let lanes = |f: &dyn Fn(usize) -> u32, group: usize| {
            UVec4::from_array(std::array::from_fn(|lane| f(group * 4 + lane)))
        };
        let persistences = |group: usize| {
            Vec4::from_array(std::array::from_fn(|lane| {
                slots[group * 4 + lane].persistence as f32
            }))
        };
        const _: () = assert!(FBM_SLOT_COUNT == 12, "NoiseParams holds 3 × 4 slots");
        Self {
            seed: recipe.seed,
            _padding0: 0,
            _padding1: 0,
            _padding2: 0,
            frequencies_0: lanes(&|s| slots[s].frequency, 0),
            frequencies_1: lanes(&|s| slots[s].frequency, 1),
            frequencies_2: lanes(&|s| slots[s].frequency, 2),
            octaves_0: lanes(&|s| slots[s].octaves, 0),
            octaves_1: lanes(&|s| slots[s].octaves, 1),
            octaves_2: lanes(&|s| slots[s].octaves, 2),
            persistences_0: persistences(0),
            persistences_1: persistences(1),
            persistences_2: persistences(2),
        }
    }
}

/// Bind group layouts and pipelines of the four entry points of `noise.wgsl`.
#[derive(Resource)]
struct CloudNoisePipelines {
    generate_3d_layout: BindGroupLayoutDescriptor,
    generate_2d_layout: BindGroupLayoutDescriptor,
    downsample_layout: BindGroupLayoutDescriptor,
    generate_base: CachedComputePipelineId,
    generate_detail: CachedComputePipelineId,
    generate_weather: CachedComputePipelineId,
    downsample: CachedComputePipelineId,
}

fn init_cloud_noise_pipelines(
    mut commands: Commands,
    asset_server: Res<AssetServer>,
    pipeline_cache: Res<PipelineCache>,
) {
    let storage_3d = || texture_storage_3d(NOISE_3D_FORMAT, StorageTextureAccess::WriteOnly);
    let generate_3d_layout = BindGroupLayoutDescriptor::new(
        "cloud_noise_generate_3d_layout",
        &BindGroupLayoutEntries::with_indices(
            ShaderStages::COMPUTE,
            (
                (0, uniform_buffer::<GpuNoiseParams>(false)),
                (1, storage_3d()),
            ),
        ),
    );
    let generate_2d_layout = BindGroupLayoutDescriptor::new(
        "cloud_noise_generate_2d_layout",
        &BindGroupLayoutEntries::with_indices(
            ShaderStages::COMPUTE,
            (
                (0, uniform_buffer::<GpuNoiseParams>(false)),
                (
                    2,
                    texture_storage_2d(NOISE_2D_FORMAT, StorageTextureAccess::WriteOnly),
                ),
            ),
        ),
    );
    let downsample_layout = BindGroupLayoutDescriptor::new(
        "cloud_noise_downsample_layout",
        &BindGroupLayoutEntries::with_indices(
            ShaderStages::COMPUTE,
            (
                (1, storage_3d()),
                (
                    3,
                    texture_3d(TextureSampleType::Float { filterable: false }),
                ),
            ),
        ),
    );
    let shader = load_embedded_asset!(asset_server.as_ref(), "noise.wgsl");
    let queue = |label: &'static str, layout: &BindGroupLayoutDescriptor| {
        pipeline_cache.queue_compute_pipeline(ComputePipelineDescriptor {
            label: Some(Cow::Borrowed(label)),
            layout: vec![layout.clone()],
            shader: shader.clone(),
            entry_point: Some(Cow::Borrowed(label)),
            ..default()
        })
    };
    let pipelines = CloudNoisePipelines {
        generate_base: queue("generate_base", &generate_3d_layout),
        generate_detail: queue("generate_detail", &generate_3d_layout),
        generate_weather: queue("generate_weather", &generate_2d_layout),
        downsample: queue("downsample_3d", &downsample_layout),
        generate_3d_layout,
        generate_2d_layout,
        downsample_layout,
    };
    commands.insert_resource(pipelines);
}

#[doc(hidden)]
/// One noise texture on the GPU.
#[derive(Clone)]
pub struct CloudNoiseTexture {
    /// The texture, with its full mip chain for 3D textures.
    pub texture: Texture,
    /// A view of every mip level, for sampling.
    pub view: TextureView,
}

#[doc(hidden)]
/// The cloud-noise textures in the render world, for the passes that sample them.
///
/// Inserted when the first generation has been submitted (which waits for the pipelines to
/// compile); when the settings change, the new textures replace these only once they are filled,
/// so a pass never samples a half-made texture.
#[derive(Resource, Clone)]
pub struct CloudNoiseTextures {
    /// Base shape noise, 3D.
    pub base: CloudNoiseTexture,
    /// Detail erosion noise, 3D.
    pub detail: CloudNoiseTexture,
    /// Weather (coverage and curl) noise, 2D.
    pub weather: CloudNoiseTexture,
    /// Trilinear, mip-linear, repeating sampler for all three.
    pub sampler: Sampler,
    /// The recipe the textures were made from.
    pub recipe: NoiseRecipe,
    /// How many times textures have been generated since start-up: 1 after the first
    /// generation, rising by one per settings change. Frames without a change leave it alone.
    pub generation: u64,
}

/// Work recorded by [`prepare_cloud_noise_textures`] for [`generate_cloud_noise`] to submit,
/// with the new textures, which replace [`CloudNoiseTextures`] only once they are filled.
#[derive(Resource)]
struct PendingCloudNoise {
    textures: CloudNoiseTextures,
    base: BindGroup,
    detail: BindGroup,
    weather: BindGroup,
    base_size: u32,
    detail_size: u32,
    weather_size: u32,
    /// One bind group per mip level ≥ 1, with that level's size.
    base_mips: Vec<(BindGroup, u32)>,
    detail_mips: Vec<(BindGroup, u32)>,
}

/// Largest side the recipe's textures may have on this device, or why the recipe is unusable.
fn validate_recipe(recipe: &NoiseRecipe, limits: &WgpuLimits) -> Result<(), String> {
    for (name, size, max) in [
        (
            "base_size",
            recipe.base_size,
            limits.max_texture_dimension_3d,
        ),
        (
            "detail_size",
            recipe.detail_size,
            limits.max_texture_dimension_3d,
        ),
        (
            "weather_size",
            recipe.weather_size,
            limits.max_texture_dimension_2d,
        ),
    ] {
        if size == 0 || size > max {
            return Err(format!(
                "{name} = {size} must be between 1 and {max} on this GPU"
            ));
        }
    }
    Ok(())
}

fn prepare_cloud_noise_textures(
    mut commands: Commands,
    settings: Option<Res<CloudNoiseSettings>>,
    existing: Option<Res<CloudNoiseTextures>>,
    pending: Option<Res<PendingCloudNoise>>,
    pipelines: Option<Res<CloudNoisePipelines>>,
    pipeline_cache: Res<PipelineCache>,
    device: Res<RenderDevice>,
    queue: Res<RenderQueue>,
    mut rejected: Local<Option<NoiseRecipe>>,
) {
    let (Some(settings), Some(pipelines)) = (settings, pipelines) else {
        return;
    };
    let recipe = &settings.0;
    let current = pending
        .as_ref()
        .map(|p| &p.textures.recipe)
        .or(existing.as_ref().map(|t| &t.recipe));
    if current == Some(recipe) || rejected.as_ref() == Some(recipe) {
        return;
    }
    if let Err(reason) = validate_recipe(recipe, &device.limits()) {
        // Keep the last good textures; warn once per rejected recipe, not every frame.
        warn!("bevy_cloudscape: CloudNoiseSettings rejected, keeping the previous noise: {reason}");
        *rejected = Some(recipe.clone());
        return;
    }
    *rejected = None;

    let mut params = UniformBuffer::from(GpuNoiseParams::from(recipe));
    params.set_label(Some("cloud_noise_params"));
    params.write_buffer(&device, &queue);
    let make_texture = |label: &'static str, size: u32, dimension: TextureDimension| {
        let (depth, mips, format) = match dimension {
            TextureDimension::D3 => (size, mip_level_count(size), NOISE_3D_FORMAT),
            _ => (1, 1, NOISE_2D_FORMAT),
        };
        let texture = device.create_texture(&TextureDescriptor {
            label: Some(label),
            size: Extent3d {
                width: size,
                height: size,
                depth_or_array_layers: depth,
            },
            mip_level_count: mips,
            sample_count: 1,
            dimension,
            format,
            usage: TextureUsages::STORAGE_BINDING
                | TextureUsages::TEXTURE_BINDING
                | TextureUsages::COPY_SRC,
            view_formats: &[],
        });
        let view = texture.create_view(&TextureViewDescriptor::default());
        CloudNoiseTexture { texture, view }
    };
    let base = make_texture("cloud_noise_base", recipe.base_size, TextureDimension::D3);
    let detail = make_texture(
        "cloud_noise_detail",
        recipe.detail_size,
        TextureDimension::D3,
    );
    let weather = make_texture(
        "cloud_noise_weather",
        recipe.weather_size,
        TextureDimension::D2,
    );

    let mip_view = |texture: &Texture, level: u32| {
        texture.create_view(&TextureViewDescriptor {
            base_mip_level: level,
            mip_level_count: Some(1),
            ..default()
        })
    };
    let generate_layout = pipeline_cache.get_bind_group_layout(&pipelines.generate_3d_layout);
    let generate = |texture: &CloudNoiseTexture, label: &'static str| {
        device.create_bind_group(
            label,
            &generate_layout,
            &BindGroupEntries::with_indices(((0, &params), (1, &mip_view(&texture.texture, 0)))),
        )
    };
    let downsample_layout = pipeline_cache.get_bind_group_layout(&pipelines.downsample_layout);
    let mips = |texture: &CloudNoiseTexture, size: u32| -> Vec<(BindGroup, u32)> {
        (1..mip_level_count(size))
            .map(|level| {
                (
                    device.create_bind_group(
                        "cloud_noise_downsample",
                        &downsample_layout,
                        &BindGroupEntries::with_indices((
                            (1, &mip_view(&texture.texture, level)),
                            (3, &mip_view(&texture.texture, level - 1)),
                        )),
                    ),
                    (size >> level).max(1),
                )
            })
            .collect()
    };
    let generation = existing.map_or(0, |t| t.generation) + 1;
    let sampler = device.create_sampler(&SamplerDescriptor {
        label: Some("cloud_noise_sampler"),
        address_mode_u: AddressMode::Repeat,
        address_mode_v: AddressMode::Repeat,
        address_mode_w: AddressMode::Repeat,
        mag_filter: FilterMode::Linear,
        min_filter: FilterMode::Linear,
        mipmap_filter: MipmapFilterMode::Linear,
        ..default()
    });
    let pending = PendingCloudNoise {
        base: generate(&base, "cloud_noise_generate_base"),
        detail: generate(&detail, "cloud_noise_generate_detail"),
        weather: device.create_bind_group(
            "cloud_noise_generate_weather",
            &pipeline_cache.get_bind_group_layout(&pipelines.generate_2d_layout),
            &BindGroupEntries::with_indices(((0, &params), (2, &weather.view))),
        ),
        base_size: recipe.base_size,
        detail_size: recipe.detail_size,
        weather_size: recipe.weather_size,
        base_mips: mips(&base, recipe.base_size),
        detail_mips: mips(&detail, recipe.detail_size),
        textures: CloudNoiseTextures {
            base,
            detail,
            weather,
            sampler,
            recipe: recipe.clone(),
            generation,
        },
    };
    commands.insert_resource(pending);
}

/// Submits the pending generation once all four pipelines are compiled. Runs in the render-graph
/// schedule before the camera driver, so the first camera that samples the noise sees it.
fn generate_cloud_noise(
    mut commands: Commands,
    pending: Option<Res<PendingCloudNoise>>,
    pipelines: Option<Res<CloudNoisePipelines>>,
    pipeline_cache: Res<PipelineCache>,
    mut ctx: RenderContext,
) {
    let (Some(pending), Some(pipelines)) = (pending, pipelines) else {
        return;
    };
    let (Some(base), Some(detail), Some(weather), Some(downsample)) = (
        pipeline_cache.get_compute_pipeline(pipelines.generate_base),
        pipeline_cache.get_compute_pipeline(pipelines.generate_detail),
        pipeline_cache.get_compute_pipeline(pipelines.generate_weather),
        pipeline_cache.get_compute_pipeline(pipelines.downsample),
    ) else {
        return;
    };

    let diagnostics = ctx.diagnostic_recorder();
    let diagnostics = diagnostics.as_deref();
    let time_span = diagnostics.time_span(ctx.command_encoder(), "cloud_noise");
    let encoder = ctx.command_encoder();
    encoder.push_debug_group("cloud_noise");
    {
        let mut pass = encoder.begin_compute_pass(&ComputePassDescriptor {
            label: Some("cloud_noise"),
            timestamp_writes: None,
        });
        let groups_3d = |size: u32| size.div_ceil(4);
        for (pipeline, bind_group, size, mips) in [
            (base, &pending.base, pending.base_size, &pending.base_mips),
            (
                detail,
                &pending.detail,
                pending.detail_size,
                &pending.detail_mips,
            ),
        ] {
            pass.set_pipeline(pipeline);
            pass.set_bind_group(0, bind_group, &[]);
            let n = groups_3d(size);
            pass.dispatch_workgroups(n, n, n);
            // Each level reads the one above it, so the chain runs in order; wgpu inserts the
            // barrier between dispatches that write and then read a mip.
            pass.set_pipeline(downsample);
            for (mip_bind_group, mip_size) in mips {
                pass.set_bind_group(0, mip_bind_group, &[]);
                let n = groups_3d(*mip_size);
                pass.dispatch_workgroups(n, n, n);
            }
        }
        pass.set_pipeline(weather);
        pass.set_bind_group(0, &pending.weather, &[]);
        let n = pending.weather_size.div_ceil(8);
        pass.dispatch_workgroups(n, n, 1);
    }
    encoder.pop_debug_group();
    time_span.end(ctx.command_encoder());

    commands.insert_resource(pending.textures.clone());
    commands.remove_resource::<PendingCloudNoise>();
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn params_lanes_follow_slot_order() {
        let recipe = NoiseRecipe::default();
        let slots = recipe.fbm_slots();
        let params = GpuNoiseParams::from(&recipe);
        assert_eq!(params.frequencies_0.x, slots[0].frequency);
        assert_eq!(params.octaves_1.y, slots[5].octaves);
        assert_eq!(params.frequencies_2.w, slots[11].frequency);
        assert_eq!(params.persistences_2.z, slots[10].persistence as f32);
        // The WGSL struct is 160 bytes; encase must agree or the shader reads garbage.
        assert_eq!(GpuNoiseParams::min_size().get(), 160);
    }

    #[test]
    fn recipe_sizes_are_validated() {
        let limits = WgpuLimits::downlevel_defaults();
        assert!(validate_recipe(&NoiseRecipe::default(), &limits).is_ok());
        let zero = NoiseRecipe {
            detail_size: 0,
            ..default()
        };
        assert!(
            validate_recipe(&zero, &limits)
                .unwrap_err()
                .contains("detail_size")
        );
        let huge = NoiseRecipe {
            base_size: limits.max_texture_dimension_3d + 1,
            ..default()
        };
        assert!(
            validate_recipe(&huge, &limits)
                .unwrap_err()
                .contains("base_size")
        );
    }
}
