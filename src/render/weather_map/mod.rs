//! The weather map: per view, each cloud layer's local coverage and the weather noise's curl on
//! the weather noise's texels around the camera, one slice of an `Rgba32Float` array per layer.
//!
//! # What it caches
//!
//! The density model reads a layer's local coverage `κ` as the bilinear filter of four weather
//! texels' values (`weather_coverage` in `density.wgsl`). Each value needs the layer's coverage at
//! the texel (the blend toward far places) and the coverage remap of the weather noise
//! ([`weather_texel_coverage`](crate::reference::render::weather_texel_coverage)). A compute
//! pass (`weather_map.wgsl`) writes them once per frame for a square of
//! [`VolumetricClouds::weather_map_size`]² texels centred on the camera; the march reads the four
//! values from the map where it holds them and computes them itself elsewhere, so the map
//! changes what a sample costs and not what it sees. Each texel also holds the weather noise's
//! two curl channels there, which the fine shape warp filters over the same four texels
//! (`shape_warp`), so a sample inside the map reads four texels instead of eight. The CPU twin is
//! [`crate::reference::weather_map`].
//!
//! # Scrolling with the wind
//!
//! Map texels are weather-noise texels, not a resampling of them: the map's origin is the
//! weather texel under the camera minus half the side
//! ([`weather_map_origin`]). That texel comes
//! from the layer's weather offset, which the CPU accumulates in f64 (camera position and wind
//! drift, [`LayerDrift`](crate::layers::LayerDrift)) and wraps by the weather period, so the map
//! moves by whole texels as the wind blows and the fraction of a texel stays in the look-up. A
//! week of wind loses no precision, and the map never blurs or shimmers as it scrolls.
//!
//! # Cost
//!
//! One thread per texel and layer each frame: 512² × layers by default, each reading one weather
//! texel. Each slice takes `16 × size²` bytes (4 MiB at the default 512). A layer with no coverage is not sent to the GPU and gets no slice.
//!
//! [`VolumetricClouds::weather_map_size`]: super::VolumetricClouds::weather_map_size

use std::borrow::Cow;

use bevy::{
    asset::{embedded_asset, load_embedded_asset},
    prelude::*,
    render::{
        render_asset::RenderAssets,
        render_resource::{
            binding_types::{
                storage_buffer_read_only, texture_2d, texture_2d_array, texture_storage_2d_array,
                uniform_buffer,
            },
            *,
        },
        renderer::{RenderDevice, RenderQueue},
        texture::{FallbackImage, GpuImage},
    },
};

use super::{
    noise::CloudNoiseTextures,
    view::{CloudViewBuffers, GpuCloudLayer},
};
use crate::reference::{
    render::MarchLayer,
    weather_map::{MAX_WEATHER_MAP_SIZE, weather_map_origin},
};

/// Texel format of the weather map: the local coverage, 0–1, and the weather noise's two curl
/// channels as read, 0–1 (the fourth channel unused).
pub(crate) const WEATHER_MAP_FORMAT: TextureFormat = TextureFormat::Rgba32Float;

/// Registers `weather_map.wgsl`.
pub(crate) fn load_weather_map_shader(app: &mut App) {
    embedded_asset!(app, "weather_map.wgsl");
}

/// The pass's uniforms, laid out as `WeatherMapUniforms` in `weather_map.wgsl` (16 bytes).
#[derive(ShaderType, Clone, Copy, Debug, Default)]
pub(crate) struct GpuWeatherMapUniforms {
    size: u32,
    slices: u32,
    pad0: u32,
    pad1: u32,
}

/// Layout and compute pipeline of the weather-map pass.
#[derive(Resource)]
pub(crate) struct CloudWeatherMapPipeline {
    layout: BindGroupLayoutDescriptor,
    pipeline: CachedComputePipelineId,
}

impl CloudWeatherMapPipeline {
    /// The compiled pipeline, once the cache has it.
    pub fn get<'a>(&self, cache: &'a PipelineCache) -> Option<&'a ComputePipeline> {
        cache.get_compute_pipeline(self.pipeline)
    }
}

/// Queues the weather-map pipeline (render startup).
pub(crate) fn init_cloud_weather_map_pipeline(
    mut commands: Commands,
    asset_server: Res<AssetServer>,
    pipeline_cache: Res<PipelineCache>,
) {
    // The bindings `weather_map.wgsl` declares, with the numbers `parameters.wgsl` gives the
    // layers (3) and `textures.wgsl` the weather noise (6).
    let layout = BindGroupLayoutDescriptor::new(
        "cloud_weather_map_layout",
        &BindGroupLayoutEntries::with_indices(
            ShaderStages::COMPUTE,
            (
                (
                    0,
                    texture_storage_2d_array(WEATHER_MAP_FORMAT, StorageTextureAccess::WriteOnly),
                ),
                (1, uniform_buffer::<GpuWeatherMapUniforms>(false)),
                (3, storage_buffer_read_only::<GpuCloudLayer>(false)),
                (6, texture_2d(TextureSampleType::Float { filterable: true })),
                (
                    13,
                    texture_2d_array(TextureSampleType::Float { filterable: false }),
                ),
            ),
        ),
    );
    let pipeline = pipeline_cache.queue_compute_pipeline(ComputePipelineDescriptor {
        label: Some(Cow::Borrowed("cloud_weather_map_pipeline")),
        layout: vec![layout.clone()],
        shader: load_embedded_asset!(asset_server.as_ref(), "weather_map.wgsl"),
        entry_point: Some(Cow::Borrowed("build_weather_map")),
        ..default()
    });
    commands.insert_resource(CloudWeatherMapPipeline { layout, pipeline });
}

/// The side a view's weather map gets, texels: `requested` clamped to the device's largest 2D
/// texture and [`MAX_WEATHER_MAP_SIZE`]; `None` (no map) below 2 texels, without layers, or with
/// more layers than a texture array holds.
pub(crate) fn planned_weather_map_size(
    requested: u32,
    layer_count: usize,
    limits: &WgpuLimits,
) -> Option<u32> {
    let size = requested
        .min(MAX_WEATHER_MAP_SIZE)
        .min(limits.max_texture_dimension_2d);
    let slices_fit = layer_count <= limits.max_texture_array_layers as usize;
    (size >= 2 && layer_count > 0 && slices_fit).then_some(size)
}

/// Points each GPU layer at its slice (its index) of a weather map of side `size`, on a weather
/// noise of `noise_size` texels per side.
pub(crate) fn assign_weather_map(
    gpu_layers: &mut [GpuCloudLayer],
    layers: &[MarchLayer],
    noise_size: u32,
    size: u32,
) {
    for (slice, (gpu, layer)) in gpu_layers.iter_mut().zip(layers).enumerate() {
        gpu.set_weather_map(
            weather_map_origin(layer, noise_size, size),
            slice as u32,
            size,
        );
    }
}

#[doc(hidden)]
/// A view's weather map: the texture array the march reads (binding 12), and this frame's
/// dispatch when the map is on.
#[derive(Component)]
pub struct CloudWeatherMap {
    texture: Texture,
    /// The whole array, as the march binds it.
    pub view: TextureView,
    size: u32,
    slices: u32,
    job: Option<BindGroup>,
}

impl CloudWeatherMap {
    fn new(device: &RenderDevice, size: u32, slices: u32) -> Self {
        let texture = device.create_texture(&TextureDescriptor {
            label: Some("cloud_weather_map"),
            size: Extent3d {
                width: size,
                height: size,
                depth_or_array_layers: slices,
            },
            mip_level_count: 1,
            sample_count: 1,
            dimension: TextureDimension::D2,
            format: WEATHER_MAP_FORMAT,
            // Copies back for tests and debugging.
            usage: TextureUsages::STORAGE_BINDING
                | TextureUsages::TEXTURE_BINDING
                | TextureUsages::COPY_SRC,
            view_formats: &[],
        });
        let view = texture.create_view(&TextureViewDescriptor {
            label: Some("cloud_weather_map_view"),
            dimension: Some(TextureViewDimension::D2Array),
            ..default()
        });
        Self {
            texture,
            view,
            size,
            slices,
            job: None,
        }
    }

    /// Records this frame's pass, if the map is on: `size²` threads per layer. Returns whether it
    /// ran.
    pub fn dispatch(&self, encoder: &mut CommandEncoder, pipeline: &ComputePipeline) -> bool {
        let Some(bind_group) = &self.job else {
            return false;
        };
        let mut pass = encoder.begin_compute_pass(&ComputePassDescriptor {
            label: Some("cloud_weather_map"),
            timestamp_writes: None,
        });
        pass.set_pipeline(pipeline);
        pass.set_bind_group(0, bind_group, &[]);
        let groups = self.size.div_ceil(8);
        pass.dispatch_workgroups(groups, groups, self.slices);
        true
    }

    /// Texels per side of each slice (1 for the stand-in of a view without a map).
    pub fn size(&self) -> u32 {
        self.size
    }

    /// The texture array.
    pub fn texture(&self) -> &Texture {
        &self.texture
    }
}

/// Gives every marched view its weather map (a 1×1 stand-in when the map is off, so the march's
/// binding is always filled) and this frame's bind group. The texture is kept while its size and
/// slice count stay the same.
pub(crate) fn prepare_weather_maps(
    mut commands: Commands,
    mut views: Query<(Entity, &CloudViewBuffers, Option<&mut CloudWeatherMap>)>,
    pipeline: Option<Res<CloudWeatherMapPipeline>>,
    noise: Option<Res<CloudNoiseTextures>>,
    pipeline_cache: Res<PipelineCache>,
    device: Res<RenderDevice>,
    queue: Res<RenderQueue>,
    growth: Option<Res<crate::render::growth::ExtractedGrowth>>,
    images: Res<RenderAssets<GpuImage>>,
    fallback: Res<FallbackImage>,
) {
    let growth_cover =
        crate::render::growth::growth_cover_view(growth.as_deref(), &images, &fallback);
    for (entity, buffers, existing) in &mut views {
        let (size, slices) = buffers.weather_map.unwrap_or((1, 1));
        let mut fresh = None;
        let map = match existing {
            Some(map) if map.size == size && map.slices == slices => map.into_inner(),
            _ => fresh.insert(CloudWeatherMap::new(&device, size, slices)),
        };
        map.job = None;
        if let (Some(_), Some(pipeline), Some(noise), Some(layers)) = (
            buffers.weather_map,
            pipeline.as_deref(),
            noise.as_deref(),
            buffers.layers.binding(),
        ) {
            let mut uniforms = UniformBuffer::from(GpuWeatherMapUniforms {
                size,
                slices,
                ..default()
            });
            uniforms.set_label(Some("cloud_weather_map_uniforms"));
            uniforms.write_buffer(&device, &queue);
            if let Some(uniforms) = uniforms.binding() {
                map.job = Some(device.create_bind_group(
                    "cloud_weather_map_bind_group",
                    &pipeline_cache.get_bind_group_layout(&pipeline.layout),
                    &BindGroupEntries::with_indices((
                        (0, &map.view),
                        (1, uniforms),
                        (3, layers),
                        (6, &noise.weather.view),
                        (13, growth_cover),
                    )),
                ));
            }
        }
        if let Some(map) = fresh {
            commands.entity(entity).insert(map);
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn uniform_layout_matches_the_shader() {
        assert_eq!(GpuWeatherMapUniforms::min_size().get(), 16);
    }

    #[test]
    fn the_planned_size_respects_the_device() {
        let limits = WgpuLimits::downlevel_defaults();
        assert_eq!(planned_weather_map_size(512, 3, &limits), Some(512));
        // Downlevel devices hold 2048-texel textures.
        assert_eq!(planned_weather_map_size(8192, 1, &limits), Some(2048));
        assert_eq!(planned_weather_map_size(1, 3, &limits), None);
        assert_eq!(planned_weather_map_size(0, 3, &limits), None);
        assert_eq!(planned_weather_map_size(512, 0, &limits), None);
        assert_eq!(planned_weather_map_size(512, 10_000, &limits), None);
    }
}
