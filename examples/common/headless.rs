//! A headless app we pump by hand: `DefaultPlugins` minus winit (and minus pipelined rendering,
//! so the render world stays reachable), synchronous pipeline compilation, a camera target
//! image, and blocking readback of any texture. The GPU tests and the tool examples share it.
//!
//! Modelled on Bevy 0.19's `examples/app/externally_driven_headless_renderer.rs`: we own the
//! update loop and poll the device after every frame, so a readback after `update` sees that
//! frame's work.

use std::path::Path;
use std::sync::{Mutex, MutexGuard};

use bevy::{
    app::{AppLabel, SubApps},
    prelude::*,
    render::{
        RenderApp,
        pipelined_rendering::PipelinedRenderingPlugin,
        render_asset::RenderAssets,
        render_resource::{
            Buffer, BufferDescriptor, BufferUsages, CommandEncoderDescriptor, Extent3d, MapMode,
            Origin3d, PollType, TexelCopyBufferInfo, TexelCopyBufferLayout, TexelCopyTextureInfo,
            Texture, TextureAspect, TextureFormat,
        },
        renderer::{RenderDevice, RenderQueue},
        texture::GpuImage,
    },
};

use super::render_target_image;

/// lavapipe uses every core for one device; apps in one process (parallel tests) take turns.
static GPU: Mutex<()> = Mutex::new(());

/// A headless app rendering its camera(s) into [`Headless::target`].
pub struct Headless {
    apps: SubApps,
    /// The camera target image.
    pub target: Handle<Image>,
    /// Target size in pixels.
    pub size: UVec2,
    _gpu: MutexGuard<'static, ()>,
}

/// Linear RGBA pixels, row-major from the top-left.
pub struct Pixels {
    pub size: UVec2,
    pub rgba: Vec<[f32; 4]>,
}

impl Pixels {
    /// The pixel at column `x`, row `y` (row 0 at the top).
    pub fn at(&self, x: u32, y: u32) -> [f32; 4] {
        self.rgba[(y * self.size.x + x) as usize]
    }

    /// Rec. 709 luminance of a pixel.
    pub fn luminance(&self, x: u32, y: u32) -> f32 {
        let [r, g, b, _] = self.at(x, y);
        0.2126 * r + 0.7152 * g + 0.0722 * b
    }

    /// Mean luminance over the pixels `[x0, x1) × [y0, y1)`.
    pub fn mean_luminance(&self, x0: u32, x1: u32, y0: u32, y1: u32) -> f32 {
        let mut sum = 0.0;
        for y in y0..y1 {
            for x in x0..x1 {
                sum += self.luminance(x, y);
            }
        }
        sum / ((x1 - x0) * (y1 - y0)) as f32
    }

    /// Writes the pixels as an sRGB PNG, scaling linear values by `scale` first.
    pub fn save_png(&self, path: impl AsRef<Path>, scale: f32) {
        let path = path.as_ref();
        if let Some(dir) = path.parent() {
            std::fs::create_dir_all(dir).expect("create output folder");
        }
        let bytes: Vec<u8> = self
            .rgba
            .iter()
            .flat_map(|p| [0, 1, 2].map(|c| (linear_to_srgb(p[c] * scale) * 255.0 + 0.5) as u8))
            .collect();
        image::RgbImage::from_raw(self.size.x, self.size.y, bytes)
            .expect("buffer matches size")
            .save(path)
            .expect("write png");
    }
}

fn linear_to_srgb(v: f32) -> f32 {
    let v = v.clamp(0.0, 1.0);
    if v <= 0.003_130_8 {
        v * 12.92
    } else {
        1.055 * v.powf(1.0 / 2.4) - 0.055
    }
}

/// `Rgba16Float` texels (8 bytes each: four little-endian half floats) as RGBA values.
pub fn rgba16float_texels(bytes: &[u8]) -> Vec<[f32; 4]> {
    bytes
        .chunks_exact(8)
        .map(|t| std::array::from_fn(|c| f16_to_f32(u16::from_le_bytes([t[2 * c], t[2 * c + 1]]))))
        .collect()
}

/// IEEE 754 binary16 to f32 (the HDR target is `Rgba16Float`).
pub fn f16_to_f32(bits: u16) -> f32 {
    let sign = if bits & 0x8000 != 0 { -1.0 } else { 1.0 };
    let exponent = i32::from((bits >> 10) & 0x1f);
    let mantissa = f32::from(bits & 0x3ff);
    match exponent {
        0 => sign * mantissa * 2f32.powi(-24),
        31 if mantissa == 0.0 => sign * f32::INFINITY,
        31 => f32::NAN,
        e => sign * (1.0 + mantissa / 1024.0) * 2f32.powi(e - 15),
    }
}

/// Blocks until the device has finished all submitted work.
fn wait_for_gpu(device: &RenderDevice) {
    device
        .wgpu_device()
        .poll(PollType::Wait {
            submission_index: None,
            timeout: None,
        })
        .expect("device poll");
}

/// Maps a `MAP_READ` buffer for reading and waits until it is mapped.
fn map_blocking(device: &RenderDevice, buffer: &Buffer) {
    buffer.slice(..).map_async(MapMode::Read, |result| {
        result.expect("map readback buffer");
    });
    wait_for_gpu(device);
}

impl Headless {
    /// Builds the app, lets `setup` add plugins and systems, and creates a `W×H` target image of
    /// `format`. Apps take turns on the GPU: this waits until no other `Headless` is alive, so
    /// drop one before making the next on the same thread. Use `Rgba16Float` for linear values
    /// (the camera then needs `Tonemapping::None` to keep them linear).
    pub fn new(size: UVec2, format: TextureFormat, setup: impl FnOnce(&mut App)) -> Self {
        let gpu = GPU.lock().unwrap_or_else(|poisoned| poisoned.into_inner());
        let mut app = App::new();
        // The global log subscriber can be set once per process; later apps go without.
        static LOGGING: std::sync::atomic::AtomicBool = std::sync::atomic::AtomicBool::new(false);
        let first = !LOGGING.swap(true, std::sync::atomic::Ordering::SeqCst);
        let plugins = super::windowless_default_plugins().disable::<PipelinedRenderingPlugin>();
        app.add_plugins(if first {
            plugins.set(bevy::log::LogPlugin {
                level: bevy::log::Level::WARN,
                ..default()
            })
        } else {
            plugins.disable::<bevy::log::LogPlugin>()
        });
        let target = app
            .world_mut()
            .resource_mut::<Assets<Image>>()
            .add(render_target_image(size, format));
        setup(&mut app);
        app.finish();
        app.cleanup();
        Self {
            apps: std::mem::take(app.sub_apps_mut()),
            target,
            size,
            _gpu: gpu,
        }
    }

    /// The main world.
    pub fn world(&mut self) -> &mut World {
        self.apps.main.world_mut()
    }

    /// The render world.
    pub fn render_world(&mut self) -> &mut World {
        self.apps
            .sub_apps
            .get_mut(&RenderApp.intern())
            .expect("render app present: pipelined rendering is disabled")
            .world_mut()
    }

    /// Runs one frame and waits until the GPU has finished it.
    pub fn update(&mut self) {
        self.apps.update();
        wait_for_gpu(self.render_world().resource::<RenderDevice>());
    }

    /// Runs `frames` frames.
    pub fn run_frames(&mut self, frames: u32) {
        for _ in 0..frames {
            self.update();
        }
    }

    /// Copies mip `mip` of a texture back to the CPU, tightly packed (rows, then layers/slices).
    pub fn read_texture(&mut self, texture: &Texture, mip: u32) -> Vec<u8> {
        let world = self.render_world();
        let device = world.resource::<RenderDevice>();
        let queue = world.resource::<RenderQueue>();
        let size = texture.size().mip_level_size(mip, texture.dimension());
        let texel_bytes = texture
            .format()
            .block_copy_size(None)
            .expect("uncompressed colour format");
        let row_bytes = size.width * texel_bytes;
        let padded_row = RenderDevice::align_copy_bytes_per_row(row_bytes as usize) as u32;
        let rows = size.height * size.depth_or_array_layers;
        let buffer = device.create_buffer(&BufferDescriptor {
            label: Some("test readback"),
            size: u64::from(padded_row * rows),
            usage: BufferUsages::COPY_DST | BufferUsages::MAP_READ,
            mapped_at_creation: false,
        });
        let mut encoder = device.create_command_encoder(&CommandEncoderDescriptor::default());
        encoder.copy_texture_to_buffer(
            TexelCopyTextureInfo {
                texture,
                mip_level: mip,
                origin: Origin3d::ZERO,
                aspect: TextureAspect::All,
            },
            TexelCopyBufferInfo {
                buffer: &buffer,
                layout: TexelCopyBufferLayout {
                    offset: 0,
                    bytes_per_row: Some(padded_row),
                    rows_per_image: Some(size.height),
                },
            },
            Extent3d { ..size },
        );
        queue.submit([encoder.finish()]);
        map_blocking(device, &buffer);
        let mapped = buffer.slice(..).get_mapped_range();
        let mut out = Vec::with_capacity((row_bytes * rows) as usize);
        for row in 0..rows {
            let start = (row * padded_row) as usize;
            out.extend_from_slice(&mapped[start..start + row_bytes as usize]);
        }
        drop(mapped);
        buffer.unmap();
        out
    }

    /// Copies `size` bytes of a buffer from `offset` back to the CPU. The buffer needs
    /// `COPY_SRC` usage.
    pub fn read_buffer(&mut self, buffer: &Buffer, offset: u64, size: u64) -> Vec<u8> {
        let world = self.render_world();
        let device = world.resource::<RenderDevice>();
        let queue = world.resource::<RenderQueue>();
        let staging = device.create_buffer(&BufferDescriptor {
            label: Some("test buffer readback"),
            size,
            usage: BufferUsages::COPY_DST | BufferUsages::MAP_READ,
            mapped_at_creation: false,
        });
        let mut encoder = device.create_command_encoder(&CommandEncoderDescriptor::default());
        encoder.copy_buffer_to_buffer(buffer, offset, &staging, 0, size);
        queue.submit([encoder.finish()]);
        map_blocking(device, &staging);
        let bytes = staging.slice(..).get_mapped_range().to_vec();
        staging.unmap();
        bytes
    }

    /// Reads a GPU image (a render-world copy of a main-world `Image` asset).
    pub fn read_image(&mut self, image: &Handle<Image>, mip: u32) -> (TextureFormat, Vec<u8>) {
        let texture = self
            .render_world()
            .resource::<RenderAssets<GpuImage>>()
            .get(image)
            .expect("image uploaded to the GPU")
            .texture
            .clone();
        let format = texture.format();
        (format, self.read_texture(&texture, mip))
    }

    /// Reads the camera target as linear RGBA (`Rgba16Float`, `Rgba32Float` or 8-bit sRGB).
    pub fn read_target(&mut self) -> Pixels {
        let target = self.target.clone();
        let (format, bytes) = self.read_image(&target, 0);
        let rgba = match format {
            TextureFormat::Rgba16Float => rgba16float_texels(&bytes),
            TextureFormat::Rgba32Float => bytes
                .chunks_exact(16)
                .map(|p| {
                    std::array::from_fn(|c| {
                        f32::from_le_bytes([p[4 * c], p[4 * c + 1], p[4 * c + 2], p[4 * c + 3]])
                    })
                })
                .collect(),
            TextureFormat::Rgba8UnormSrgb => bytes
                .chunks_exact(4)
                .map(|p| {
                    std::array::from_fn(|c| match c {
                        3 => f32::from(p[c]) / 255.0,
                        _ => srgb_to_linear(f32::from(p[c]) / 255.0),
                    })
                })
                .collect(),
            other => panic!("read_target: unsupported target format {other:?}"),
        };
        Pixels {
            size: self.size,
            rgba,
        }
    }
}

fn srgb_to_linear(v: f32) -> f32 {
    if v <= 0.040_45 {
        v / 12.92
    } else {
        ((v + 0.055) / 1.055).powf(2.4)
    }
}
