//! The cloud-growth automaton on the GPU: one compute dispatch per step over a grid of cells,
//! ping-ponging two storage buffers (`growth.wgsl`). The rules and the CPU twin that gives the
//! same bits are in [`crate::reference::growth`].
//!
//! [`GrowthCompute`] owns the pipeline and the buffers, steps them on a [`RenderDevice`] and
//! [`RenderQueue`] and writes each column's cloud fraction into a texture; the GPU tests and the
//! bench drive it directly. [`CloudRenderPlugin`](super::CloudRenderPlugin) runs one for every
//! layer with a [`CloudGrowth`](crate::layers::CloudGrowth) and hands its cover to the weather
//! (one step per read-back of its cover: [`MAX_STEPS_PER_FRAME`], [`MAX_STEPS_DUE`]).

use bevy::render::{
    render_resource::{
        BindGroup, BindGroupEntries, BindGroupLayout, BindGroupLayoutEntries, Buffer,
        BufferDescriptor, BufferInitDescriptor, BufferUsages, CommandEncoderDescriptor,
        ComputePassDescriptor, ComputePipeline, Extent3d, PipelineCompilationOptions,
        PipelineLayoutDescriptor, RawComputePipelineDescriptor, ShaderModule,
        ShaderModuleDescriptor, ShaderSource, ShaderStages, ShaderType, StorageTextureAccess,
        Texture, TextureDescriptor, TextureDimension, TextureFormat, TextureUsages, TextureView,
        UniformBuffer,
        binding_types::{
            storage_buffer_read_only_sized, storage_buffer_sized, texture_storage_2d,
            uniform_buffer,
        },
    },
    renderer::{RenderDevice, RenderQueue},
};

use crate::reference::growth::{ACT, CLD, GrowthGrid, HUM, step_key};

mod run;

#[doc(hidden)]
pub use run::{ExtractedGrowth, GrowthRun};
pub(crate) use run::{
    GrowthComputes, extract_cloud_growth, growth_cover_view, run_cloud_growth, run_growth_jobs,
};
pub use run::{MAX_STEPS_DUE, MAX_STEPS_PER_FRAME};

/// The step's uniforms, laid out as `GrowthUniforms` in `growth.wgsl` (32 bytes).
#[derive(ShaderType, Clone, Copy, Debug, Default)]
pub(crate) struct GpuGrowthUniforms {
    size: bevy::math::UVec3,
    extinction: u32,
    keys: bevy::math::UVec3,
    per_column: u32,
}

/// The compute pipeline of `entry` in `growth.wgsl` with the one bind group `layout`.
fn compute_pipeline(
    device: &RenderDevice,
    module: &ShaderModule,
    layout: &BindGroupLayout,
    entry: &'static str,
) -> ComputePipeline {
    let pipeline_layout = device.create_pipeline_layout(&PipelineLayoutDescriptor {
        label: Some(entry),
        bind_group_layouts: &[Some(layout)],
        immediate_size: 0,
    });
    device.create_compute_pipeline(&RawComputePipelineDescriptor {
        label: Some(entry),
        layout: Some(&pipeline_layout),
        module,
        entry_point: Some(entry),
        compilation_options: PipelineCompilationOptions::default(),
        cache: None,
    })
}

/// Threads per workgroup along x and y (`@workgroup_size(8, 8, 1)`).
const WORKGROUP: u32 = 8;

/// The automaton's pipeline and buffers on one device.
pub struct GrowthCompute {
    size: [u32; 3],
    pipeline: ComputePipeline,
    layout: BindGroupLayout,
    counts_pipeline: ComputePipeline,
    counts_layout: BindGroupLayout,
    cover_pipeline: ComputePipeline,
    cover_layout: BindGroupLayout,
    /// Cloud cells per column (`u32`, x fastest), between the two passes of `write_cover`.
    counts: Buffer,
    cells: [Buffer; 2],
    columns: Buffer,
    per_column: bool,
    /// Which of `cells` holds the current bits.
    current: usize,
}

impl GrowthCompute {
    /// The pipeline, and the grid of `grid.size` cells holding `grid.cells`; `columns` are each
    /// column's humidity and activation thresholds (one entry for every column, or one per
    /// column, x fastest), as [`GrowthGrid::step`] takes them.
    ///
    /// # Panics
    ///
    /// When `columns` is empty or holds neither one entry nor one per column.
    #[must_use]
    pub fn new(device: &RenderDevice, grid: &GrowthGrid, columns: &[[u32; 2]]) -> Self {
        let size = grid.size;
        let column_count = (size[0] * size[1]) as usize;
        assert!(
            columns.len() == 1 || columns.len() == column_count,
            "one threshold pair, or one per column"
        );
        let bytes =
            |cells: &[u32]| -> Vec<u8> { cells.iter().flat_map(|c| c.to_le_bytes()).collect() };
        let cell_bytes = (grid.cells.len() * 4) as u64;
        let storage = BufferUsages::STORAGE | BufferUsages::COPY_SRC | BufferUsages::COPY_DST;
        let cells = [
            device.create_buffer_with_data(&BufferInitDescriptor {
                label: Some("cloud growth cells a"),
                contents: &bytes(&grid.cells),
                usage: storage,
            }),
            device.create_buffer(&BufferDescriptor {
                label: Some("cloud growth cells b"),
                size: cell_bytes,
                usage: storage,
                mapped_at_creation: false,
            }),
        ];
        let flat: Vec<u32> = columns.iter().flatten().copied().collect();
        let columns_buffer = device.create_buffer_with_data(&BufferInitDescriptor {
            label: Some("cloud growth columns"),
            contents: &bytes(&flat),
            usage: BufferUsages::STORAGE | BufferUsages::COPY_DST,
        });
        let layout = device.create_bind_group_layout(
            "cloud growth layout",
            &BindGroupLayoutEntries::sequential(
                ShaderStages::COMPUTE,
                (
                    storage_buffer_read_only_sized(false, None),
                    storage_buffer_sized(false, None),
                    storage_buffer_read_only_sized(false, None),
                    uniform_buffer::<GpuGrowthUniforms>(false),
                ),
            ),
        );
        let module = device.create_and_validate_shader_module(ShaderModuleDescriptor {
            label: Some("growth.wgsl"),
            source: ShaderSource::Wgsl(include_str!("growth.wgsl").into()),
        });
        let pipeline = compute_pipeline(device, &module, &layout, "grow");
        let counts_layout = device.create_bind_group_layout(
            "cloud growth counts layout",
            &BindGroupLayoutEntries::with_indices(
                ShaderStages::COMPUTE,
                (
                    (0, storage_buffer_read_only_sized(false, None)),
                    (3, uniform_buffer::<GpuGrowthUniforms>(false)),
                    (5, storage_buffer_sized(false, None)),
                ),
            ),
        );
        let cover_layout = device.create_bind_group_layout(
            "cloud growth cover layout",
            &BindGroupLayoutEntries::with_indices(
                ShaderStages::COMPUTE,
                (
                    (3, uniform_buffer::<GpuGrowthUniforms>(false)),
                    (
                        4,
                        texture_storage_2d(
                            TextureFormat::R32Float,
                            StorageTextureAccess::WriteOnly,
                        ),
                    ),
                    (5, storage_buffer_sized(false, None)),
                ),
            ),
        );
        let counts_pipeline = compute_pipeline(device, &module, &counts_layout, "column_counts");
        let counts = device.create_buffer(&BufferDescriptor {
            label: Some("cloud growth column counts"),
            size: u64::from(size[0] * size[1]) * 4,
            usage: BufferUsages::STORAGE,
            mapped_at_creation: false,
        });
        let cover_pipeline = compute_pipeline(device, &module, &cover_layout, "column_cover");
        Self {
            size,
            pipeline,
            layout,
            counts_pipeline,
            counts_layout,
            cover_pipeline,
            cover_layout,
            counts,
            cells,
            columns: columns_buffer,
            per_column: columns.len() > 1,
            current: 0,
        }
    }

    /// Runs steps `first_step .. first_step + steps` with `seed` and the evaporation threshold
    /// `extinction`, one dispatch each, and submits them.
    pub fn step(
        &mut self,
        device: &RenderDevice,
        queue: &RenderQueue,
        seed: u32,
        extinction: u32,
        first_step: u32,
        steps: u32,
    ) {
        let mut encoder = device.create_command_encoder(&CommandEncoderDescriptor {
            label: Some("cloud growth"),
        });
        // One uniform buffer per step, so every dispatch of the submission sees its own step.
        let mut keep: Vec<(UniformBuffer<GpuGrowthUniforms>, BindGroup)> = Vec::new();
        for step in first_step..first_step + steps {
            let mut uniforms = UniformBuffer::from(GpuGrowthUniforms {
                size: self.size.into(),
                extinction,
                keys: [HUM, ACT, CLD].map(|bit| step_key(seed, step, bit)).into(),
                per_column: u32::from(self.per_column),
            });
            uniforms.write_buffer(device, queue);
            let (from, to) = (self.current, 1 - self.current);
            let Some(binding) = uniforms.binding() else {
                return;
            };
            let bind_group = device.create_bind_group(
                "cloud growth bind group",
                &self.layout,
                &BindGroupEntries::sequential((
                    self.cells[from].as_entire_binding(),
                    self.cells[to].as_entire_binding(),
                    self.columns.as_entire_binding(),
                    binding,
                )),
            );
            {
                let mut pass = encoder.begin_compute_pass(&ComputePassDescriptor {
                    label: Some("cloud growth step"),
                    timestamp_writes: None,
                });
                pass.set_pipeline(&self.pipeline);
                pass.set_bind_group(0, &*bind_group, &[]);
                pass.dispatch_workgroups(
                    self.size[0].div_ceil(WORKGROUP),
                    self.size[1].div_ceil(WORKGROUP),
                    self.size[2],
                );
            }
            keep.push((uniforms, bind_group));
            self.current = to;
        }
        queue.submit([encoder.finish()]);
    }

    /// Replaces the columns' thresholds (as [`GrowthCompute::new`] takes them; the same count
    /// as there, or the call is ignored) for the steps that follow.
    pub fn set_columns(&self, queue: &RenderQueue, columns: &[[u32; 2]]) {
        let expected = if self.per_column {
            (self.size[0] * self.size[1]) as usize
        } else {
            1
        };
        if columns.len() != expected {
            return;
        }
        let bytes: Vec<u8> = columns
            .iter()
            .flatten()
            .flat_map(|c| c.to_le_bytes())
            .collect();
        queue.write_buffer(&self.columns, 0, &bytes);
    }

    /// Writes the cloud the weather reads ([`GrowthGrid::smoothed_cover`], bit for bit) into
    /// `cover`, an `R32Float` view of at least `size[0] × size[1]` texels, and submits it.
    pub fn write_cover(&self, device: &RenderDevice, queue: &RenderQueue, cover: &TextureView) {
        let mut uniforms = UniformBuffer::from(GpuGrowthUniforms {
            size: self.size.into(),
            ..Default::default()
        });
        uniforms.write_buffer(device, queue);
        let Some(binding) = uniforms.binding() else {
            return;
        };
        let counts_group = device.create_bind_group(
            "cloud growth counts bind group",
            &self.counts_layout,
            &BindGroupEntries::with_indices((
                (0, self.cells[self.current].as_entire_binding()),
                (3, binding.clone()),
                (5, self.counts.as_entire_binding()),
            )),
        );
        let cover_group = device.create_bind_group(
            "cloud growth cover bind group",
            &self.cover_layout,
            &BindGroupEntries::with_indices((
                (3, binding),
                (4, cover),
                (5, self.counts.as_entire_binding()),
            )),
        );
        let mut encoder = device.create_command_encoder(&CommandEncoderDescriptor {
            label: Some("cloud growth cover"),
        });
        {
            let mut pass = encoder.begin_compute_pass(&ComputePassDescriptor {
                label: Some("cloud growth cover"),
                timestamp_writes: None,
            });
            let groups = [
                self.size[0].div_ceil(WORKGROUP),
                self.size[1].div_ceil(WORKGROUP),
            ];
            pass.set_pipeline(&self.counts_pipeline);
            pass.set_bind_group(0, &*counts_group, &[]);
            pass.dispatch_workgroups(groups[0], groups[1], 1);
            pass.set_pipeline(&self.cover_pipeline);
            pass.set_bind_group(0, &*cover_group, &[]);
            pass.dispatch_workgroups(groups[0], groups[1], 1);
        }
        queue.submit([encoder.finish()]);
    }

    /// A texture [`GrowthCompute::write_cover`] can write on its own: `R32Float`, one texel per
    /// column, that can be copied back (the bench and the tests read it).
    #[must_use]
    pub fn cover_texture(&self, device: &RenderDevice) -> Texture {
        device.create_texture(&TextureDescriptor {
            label: Some("cloud growth cover"),
            size: Extent3d {
                width: self.size[0],
                height: self.size[1],
                depth_or_array_layers: 1,
            },
            mip_level_count: 1,
            sample_count: 1,
            dimension: TextureDimension::D2,
            format: TextureFormat::R32Float,
            usage: TextureUsages::STORAGE_BINDING | TextureUsages::COPY_SRC,
            view_formats: &[],
        })
    }

    /// The buffer that holds the current bits (`u32` per cell, [`GrowthGrid::cells`] order).
    #[must_use]
    pub fn cells(&self) -> &Buffer {
        &self.cells[self.current]
    }

    /// Cells along x, y and z.
    #[must_use]
    pub const fn size(&self) -> [u32; 3] {
        self.size
    }
}
