//! Runs the automaton of every layer with [`CloudGrowth`] on the GPU and hands its clouds to the
//! weather.
//!
//! Main world ([`run_cloud_growth`], after [`crate::CloudscapeSystems::Layers`]): each growing
//! layer gets a [`GrowthRun`] that counts the steps due from the [`SceneClock`]
//! ([`CloudGrowth::steps_per_hour`], at most [`MAX_STEPS_PER_FRAME`] a frame; a run starts
//! from [`CloudGrowth::initial_grid`], so a new sky opens at its coverage) and, with
//! [`CloudGrowth::follow_coverage`], sets the probabilities of this frame's steps from the
//! covered fraction last read back ([`GrowthSteering`]). The layers share one `R32Float` array
//! image, one slice each ([`GrowthCoverImage`]), read back (Bevy's [`Readback`]) after the
//! frames that stepped, so [`GrowthRun::growth`] holds the same cover on the CPU: the CPU twin
//! (cloud queries, the sky light) draws the clouds the GPU draws, one frame later.
//!
//! Render world ([`run_growth_jobs`]): one [`GrowthCompute`] per layer steps the cells and
//! writes the column cover into the layer's slice, which the march, the shadow map and the
//! weather map read (`growth_cover`, binding 13).

use std::sync::Arc;

use bevy::{
    asset::RenderAssetUsages,
    platform::collections::HashMap,
    prelude::*,
    render::{
        Extract,
        gpu_readback::{Readback, ReadbackComplete},
        render_asset::RenderAssets,
        render_resource::{
            Extent3d, TextureDimension, TextureFormat, TextureUsages, TextureView,
            TextureViewDescriptor, TextureViewDimension,
        },
        renderer::{RenderDevice, RenderQueue},
        texture::{FallbackImage, GpuImage},
    },
};

use super::GrowthCompute;
use crate::{
    layers::{CloudGrowth, CloudLayer, GrowthSteering},
    reference::{
        growth::{GrowthGrid, probability_threshold},
        render::LayerGrowth,
    },
    scene::SceneClock,
};

/// Most automaton steps one frame runs. The steering sets each step's probabilities from the
/// cover after the step before (Bevy's read-back), so a run steps once and waits for that cover
/// before its next step; steps due meanwhile wait for the next frames. A run therefore takes at
/// most one step per read-back: with a read-back that returns within `k` frames, `fps / k`
/// steps a second, and a clock faster than that many steps per
/// [`CloudGrowth::steps_per_hour`] leaves the automaton behind.
pub const MAX_STEPS_PER_FRAME: u32 = 1;

/// Most steps a run keeps due (two hours at the default rate): they run one per read-back in
/// the frames after a jump of the scene time; a longer jump drops the rest.
pub const MAX_STEPS_DUE: f64 = 240.0;

/// The image that holds every growing layer's column cover: `R32Float`, `side²` texels per
/// slice, one slice per layer (main world; its id is extracted for the passes).
#[derive(Resource, Clone, Debug)]
pub(crate) struct GrowthCoverImage {
    /// The array image.
    handle: Handle<Image>,
    /// Texels per side of every slice: the largest grid's.
    side: u32,
    /// Slices: one per growing layer.
    slices: u32,
}

impl GrowthCoverImage {
    fn new(images: &mut Assets<Image>, side: u32, slices: u32) -> Self {
        let mut image = Image::new_fill(
            Extent3d {
                width: side,
                height: side,
                depth_or_array_layers: slices,
            },
            TextureDimension::D2,
            &0f32.to_le_bytes(),
            TextureFormat::R32Float,
            RenderAssetUsages::RENDER_WORLD,
        );
        image.texture_descriptor.usage |= TextureUsages::STORAGE_BINDING | TextureUsages::COPY_SRC;
        image.texture_view_descriptor = Some(TextureViewDescriptor {
            dimension: Some(TextureViewDimension::D2Array),
            ..default()
        });
        Self {
            handle: images.add(image),
            side,
            slices,
        }
    }
}

/// The steps one frame runs on a layer's automaton.
#[derive(Clone, Debug, PartialEq)]
pub(crate) struct GrowthJob {
    /// Index of the first step (the random numbers' step key).
    first_step: u32,
    /// Steps to run.
    steps: u32,
    /// Per column, the humidity and activation thresholds of these steps.
    columns: Arc<[[u32; 2]]>,
    /// The evaporation threshold of these steps.
    extinction: u32,
}

#[doc(hidden)]
/// A growing layer's automaton as the main world keeps it (added and removed with
/// [`CloudGrowth`]).
#[derive(Component, Clone, Debug)]
pub struct GrowthRun {
    /// The settings it runs with, sanitized.
    config: CloudGrowth,
    /// Changes when the grid starts over (a new grid size or seed).
    epoch: u64,
    /// Per column, the noise maker's humidity and activation fields as thresholds at
    /// probability 1 ([`CloudGrowth::columns`]).
    fields: Arc<[[u32; 2]]>,
    /// Steps run since the start.
    steps_done: u64,
    /// Steps due and not run yet (fractions carry to the next frame).
    steps_due: f64,
    /// The scene time of the last frame, seconds.
    last_s: f64,
    steering: GrowthSteering,
    /// The layer's clouds for the CPU twin, and its slice of the cover image.
    growth: LayerGrowth,
    /// This frame's steps.
    job: Option<GrowthJob>,
    /// The cells the run starts from, in the frame it starts.
    initial: Option<Arc<[u32]>>,
    /// A step ran whose cover has not been read back yet.
    awaiting_cover: bool,
}

impl GrowthRun {
    /// The layer's clouds: grid, slice and the cover last read back.
    #[must_use]
    pub fn growth(&self) -> &LayerGrowth {
        &self.growth
    }

    /// The covered fraction of the cover last read back, 0–1
    /// ([`covered_share`](crate::layers::covered_share)).
    #[must_use]
    pub fn covered(&self) -> f32 {
        crate::layers::covered_share(&self.growth.cover)
    }

    /// Whether a step ran whose cover has not been read back yet (no step runs until it is).
    #[must_use]
    pub fn awaits_cover(&self) -> bool {
        self.awaiting_cover
    }

    /// Whether the automaton has caught up with the scene time: no step due and none waiting
    /// for its cover.
    #[must_use]
    pub fn is_idle(&self) -> bool {
        !self.awaiting_cover && self.steps_due < 1.0
    }

    /// Automaton steps run since the layer started growing.
    #[must_use]
    pub fn steps_done(&self) -> u64 {
        self.steps_done
    }
}

/// On the entity of a cover read-back: the epoch of each slice's run when it was asked for.
#[derive(Component)]
struct CoverReadback {
    epochs: Vec<u64>,
    side: u32,
    slices: u32,
}

fn columns_at(fields: &[[u32; 2]], humidity: f32, activation: f32) -> Arc<[[u32; 2]]> {
    let scale =
        |one: u32, p: f32| ((u64::from(one) * u64::from(probability_threshold(p))) >> 24) as u32;
    fields
        .iter()
        .map(|[hum, act]| [scale(*hum, humidity), scale(*act, activation)])
        .collect()
}

/// Counts each growing layer's steps due, sets their probabilities and keeps the cover image
/// and its read-backs (see the [module docs](self)).
#[allow(clippy::type_complexity)]
pub(crate) fn run_cloud_growth(
    mut commands: Commands,
    clock: Option<Res<SceneClock>>,
    time: Res<Time>,
    mut layers: Query<(Entity, &CloudLayer, &CloudGrowth, Option<&mut GrowthRun>)>,
    stale: Query<Entity, (With<GrowthRun>, Without<CloudGrowth>)>,
    cover: Option<Res<GrowthCoverImage>>,
    mut images: ResMut<Assets<Image>>,
    mut epochs: Local<u64>,
) {
    for entity in &stale {
        commands.entity(entity).remove::<GrowthRun>();
    }
    let now_s = clock.map_or(time.elapsed_secs_f64(), |c| c.unix_seconds());
    let mut entries: Vec<_> = layers.iter_mut().collect();
    entries.sort_by_key(|(entity, ..)| *entity);
    if entries.is_empty() {
        if cover.is_some() {
            commands.remove_resource::<GrowthCoverImage>();
        }
        return;
    }
    let configs: Vec<CloudGrowth> = entries.iter().map(|(_, _, g, _)| g.sanitized()).collect();
    let side = configs
        .iter()
        .map(|c| c.grid[0].max(c.grid[1]))
        .max()
        .unwrap_or(1);
    let slices = entries.len() as u32;
    let cover = match cover {
        Some(cover) if cover.side == side && cover.slices == slices => cover.clone(),
        _ => {
            let cover = GrowthCoverImage::new(&mut images, side, slices);
            commands.insert_resource(cover.clone());
            cover
        }
    };
    let mut stepped = false;
    let mut read_epochs = Vec::with_capacity(entries.len());
    for (slice, ((entity, layer, growth, run), config)) in
        entries.into_iter().zip(configs).enumerate()
    {
        if config != *growth {
            warn_once!(
                "bevy_cloudscape: a CloudGrowth has values out of range; it runs with them \
                 clamped (grid 8-1024 x 8-1024 x 1-64 cells, probabilities 0-1, steps per hour \
                 0-36000, NaN the default)"
            );
        }
        let slice = slice as u32;
        let mut fresh = None;
        let run = match run {
            Some(run) if run.config.grid == config.grid && run.config.seed == config.seed => {
                let run = run.into_inner();
                run.initial = None;
                run
            }
            _ => {
                *epochs += 1;
                let initial = config.initial_grid(layer.coverage);
                fresh.insert(GrowthRun {
                    fields: config.columns(1.0, 1.0).into(),
                    config: config.clone(),
                    epoch: *epochs,
                    steps_done: 0,
                    steps_due: 0.0,
                    last_s: now_s,
                    steering: GrowthSteering::default(),
                    growth: LayerGrowth {
                        size: [config.grid[0], config.grid[1]],
                        slice,
                        cover: initial.smoothed_cover().into(),
                    },
                    job: None,
                    initial: Some(initial.cells.into()),
                    awaiting_cover: false,
                })
            }
        };
        if run.config.humidity != config.humidity || run.config.activation != config.activation {
            run.fields = config.columns(1.0, 1.0).into();
        }
        run.config = config;
        run.growth.slice = slice;
        // Scene time forward adds steps; backward (a scrub) adds none.
        let elapsed = now_s - run.last_s;
        run.last_s = now_s;
        if elapsed > 0.0 && elapsed.is_finite() {
            run.steps_due += elapsed / 3600.0 * f64::from(run.config.steps_per_hour);
        }
        run.steps_due = run.steps_due.min(MAX_STEPS_DUE);
        let steps = if run.awaiting_cover {
            0
        } else {
            (run.steps_due.floor() as u32).min(MAX_STEPS_PER_FRAME)
        };
        run.job = (steps > 0).then(|| {
            run.steps_due -= f64::from(steps);
            let c = &run.config;
            let p = if c.follow_coverage {
                run.steering
                    .probabilities(layer.coverage, run.covered(), &run.config)
            } else {
                crate::layers::GrowthProbabilities {
                    humidity: c.humidity_probability,
                    activation: c.activation_probability,
                    extinction: c.extinction_probability,
                }
            };
            let job = GrowthJob {
                first_step: run.steps_done as u32,
                steps,
                columns: columns_at(&run.fields, p.humidity, p.activation),
                extinction: probability_threshold(p.extinction),
            };
            run.steps_done += u64::from(steps);
            job
        });
        stepped |= run.job.is_some();
        run.awaiting_cover |= run.job.is_some();
        read_epochs.push(run.epoch);
        if let Some(run) = fresh {
            commands.entity(entity).insert(run);
        }
    }
    if stepped {
        commands
            .spawn((
                Readback::texture(cover.handle.clone()),
                CoverReadback {
                    epochs: read_epochs,
                    side: cover.side,
                    slices: cover.slices,
                },
            ))
            .observe(read_growth_cover);
    }
}

/// Takes a read-back of the cover image into each run it was asked for (a run restarted since
/// keeps its own), then drops the read-back.
fn read_growth_cover(
    event: On<ReadbackComplete>,
    mut commands: Commands,
    readbacks: Query<&CoverReadback>,
    mut runs: Query<&mut GrowthRun>,
) {
    let entity = event.event_target();
    commands.entity(entity).despawn();
    let Ok(readback) = readbacks.get(entity) else {
        return;
    };
    let side = readback.side as usize;
    // Bevy's read-back pads each row to wgpu's copy alignment.
    let row = RenderDevice::align_copy_bytes_per_row(side * 4);
    if event.data.len() < row * side * readback.slices as usize {
        return;
    }
    for mut run in &mut runs {
        let slice = run.growth.slice as usize;
        if readback.epochs.get(slice) != Some(&run.epoch) {
            continue;
        }
        let [nx, ny] = run.growth.size.map(|n| n as usize);
        let mut cover = Vec::with_capacity(nx * ny);
        for y in 0..ny {
            let start = (slice * side + y) * row;
            cover.extend(
                event.data[start..start + 4 * nx]
                    .chunks_exact(4)
                    .map(|b| f32::from_le_bytes([b[0], b[1], b[2], b[3]])),
            );
        }
        run.growth.cover = cover.into();
        run.awaiting_cover = false;
    }
}

#[doc(hidden)]
/// This frame's growing layers, for the render world.
#[derive(Resource, Default)]
pub struct ExtractedGrowth {
    /// The cover image, when a layer grows.
    pub image: Option<AssetId<Image>>,
    layers: Vec<ExtractedGrowthLayer>,
}

struct ExtractedGrowthLayer {
    entity: Entity,
    epoch: u64,
    grid: [u32; 3],
    seed: u32,
    slice: u32,
    job: Option<GrowthJob>,
    initial: Option<Arc<[u32]>>,
}

pub(crate) fn extract_cloud_growth(
    mut commands: Commands,
    runs: Extract<Query<(Entity, &GrowthRun)>>,
    cover: Extract<Option<Res<GrowthCoverImage>>>,
) {
    commands.insert_resource(ExtractedGrowth {
        image: cover.as_ref().map(|c| c.handle.id()),
        layers: runs
            .iter()
            .map(|(entity, run)| ExtractedGrowthLayer {
                entity,
                epoch: run.epoch,
                grid: run.config.grid,
                seed: run.config.seed,
                slice: run.growth.slice,
                job: run.job.clone(),
                initial: run.initial.clone(),
            })
            .collect(),
    });
}

/// The render world's automata, by main-world layer.
#[derive(Resource, Default)]
pub(crate) struct GrowthComputes(HashMap<Entity, RenderGrowth>);

struct RenderGrowth {
    epoch: u64,
    compute: GrowthCompute,
    /// The image and slice the cover was last written to.
    written: Option<(AssetId<Image>, u32)>,
}

/// Runs this frame's steps of every growing layer and writes the cover of those that stepped
/// (or moved to another image or slice).
pub(crate) fn run_growth_jobs(
    extracted: Option<Res<ExtractedGrowth>>,
    mut computes: ResMut<GrowthComputes>,
    device: Res<RenderDevice>,
    queue: Res<RenderQueue>,
    images: Res<RenderAssets<GpuImage>>,
) {
    let Some(extracted) = extracted else {
        computes.0.clear();
        return;
    };
    computes
        .0
        .retain(|entity, _| extracted.layers.iter().any(|l| l.entity == *entity));
    let image = extracted.image.and_then(|id| Some((id, images.get(id)?)));
    for layer in &extracted.layers {
        let fresh = computes
            .0
            .get(&layer.entity)
            .is_none_or(|r| r.epoch != layer.epoch);
        if fresh {
            let mut grid = GrowthGrid::new(layer.grid);
            if let Some(initial) = layer
                .initial
                .as_ref()
                .filter(|c| c.len() == grid.cells.len())
            {
                grid.cells.copy_from_slice(initial);
            }
            let columns = vec![[0, 0]; (layer.grid[0] * layer.grid[1]) as usize];
            computes.0.insert(
                layer.entity,
                RenderGrowth {
                    epoch: layer.epoch,
                    compute: GrowthCompute::new(&device, &grid, &columns),
                    written: None,
                },
            );
        }
        let Some(run) = computes.0.get_mut(&layer.entity) else {
            continue;
        };
        if let Some(job) = &layer.job {
            run.compute.set_columns(&queue, &job.columns);
            run.compute.step(
                &device,
                &queue,
                layer.seed,
                job.extinction,
                job.first_step,
                job.steps,
            );
            run.written = None;
        }
        let Some((id, gpu)) = image else {
            continue;
        };
        if layer.slice >= gpu.texture_descriptor.size.depth_or_array_layers
            || run.written == Some((id, layer.slice))
        {
            continue;
        }
        let view = gpu.texture.create_view(&TextureViewDescriptor {
            label: Some("cloud growth cover slice"),
            dimension: Some(TextureViewDimension::D2),
            base_array_layer: layer.slice,
            array_layer_count: Some(1),
            ..default()
        });
        run.compute.write_cover(&device, &queue, &view);
        run.written = Some((id, layer.slice));
    }
}

/// The cover array the passes bind (`growth_cover`, binding 13): the growing layers' image, or
/// a stand-in no layer reads.
pub(crate) fn growth_cover_view<'a>(
    extracted: Option<&ExtractedGrowth>,
    images: &'a RenderAssets<GpuImage>,
    fallback: &'a FallbackImage,
) -> &'a TextureView {
    extracted
        .and_then(|e| e.image)
        .and_then(|id| images.get(id))
        .map_or(&fallback.d2_array.texture_view, |image| &image.texture_view)
}
