//! Scene pieces and the headless mode shared by the examples (and by the GPU tests, which include
//! this file), so no example copies them.
#![allow(
    dead_code,
    reason = "each example uses only part of the shared helpers"
)]

pub mod headless;
pub mod scenes;

use std::path::PathBuf;

use bevy_cloudscape::render::VolumetricClouds;

use bevy::{
    asset::RenderAssetUsages,
    camera::{Exposure, RenderTarget},
    core_pipeline::tonemapping::Tonemapping,
    light::{Atmosphere, atmosphere::ScatteringMedium, light_consts::lux},
    pbr::AtmosphereSettings,
    prelude::*,
    render::{
        RenderPlugin,
        render_resource::{Extent3d, TextureDimension, TextureFormat, TextureUsages},
        view::screenshot::{Screenshot, ScreenshotCaptured},
    },
    window::ExitCondition,
    winit::WinitPlugin,
};

/// What a running example needs of its command line: the headless capture's settings.
#[derive(Debug, Clone, Resource)]
pub struct ExampleArgs {
    /// Render without a window and write one PNG.
    pub headless: bool,
    /// Where the headless frame goes.
    pub out: PathBuf,
    /// Frames to run before the capture (pipelines and atmosphere LUTs need a few).
    pub frames: u32,
    /// Headless image size in pixels.
    pub size: UVec2,
}

/// The command-line options every example understands; flatten it into an example's own
/// `clap::Parser` with `#[command(flatten)]`.
#[derive(clap::Args, Debug, Clone)]
pub struct CommonArgs {
    /// Render without a window and write one PNG.
    #[arg(long)]
    pub headless: bool,
    /// Where the headless frame goes [default: EXAMPLE.png].
    #[arg(long, value_name = "PATH.png")]
    pub out: Option<PathBuf>,
    /// Frames to run before the headless capture, at least (pipelines and atmosphere LUTs need
    /// a few; the capture also waits until the clouds' temporal accumulation has converged).
    #[arg(long, default_value_t = 8, value_parser = clap::value_parser!(u32).range(1..))]
    pub frames: u32,
    /// Headless image width, pixels.
    #[arg(long, default_value_t = 1280, value_parser = clap::value_parser!(u32).range(1..))]
    pub width: u32,
    /// Headless image height, pixels.
    #[arg(long, default_value_t = 720, value_parser = clap::value_parser!(u32).range(1..))]
    pub height: u32,
}

impl CommonArgs {
    /// The options as the running `example` uses them.
    pub fn for_example(&self, example: &str) -> ExampleArgs {
        ExampleArgs {
            headless: self.headless,
            out: self
                .out
                .clone()
                .unwrap_or_else(|| PathBuf::from(format!("{example}.png"))),
            frames: self.frames,
            size: UVec2::new(self.width, self.height),
        }
    }
}

/// `DefaultPlugins` with no window, no winit and synchronous pipeline compilation: the base of
/// every headless run (the examples' `--headless` and the test harness).
pub fn windowless_default_plugins() -> PluginGroupBuilder {
    let plugins = DefaultPlugins
        .set(WindowPlugin {
            primary_window: None,
            exit_condition: ExitCondition::DontExit,
            ..default()
        })
        .set(RenderPlugin {
            synchronous_pipeline_compilation: true,
            ..default()
        })
        .disable::<WinitPlugin>();
    // The crate's `live` feature turns on Bevy's web asset sources, whose plugin warns that web
    // paths are loadable; the examples load no asset from the web, only the live forecasts.
    #[cfg(feature = "live")]
    let plugins = plugins.set(bevy::asset::io::web::WebAssetPlugin {
        silence_startup_warning: true,
    });
    plugins
}

/// `DefaultPlugins` set up for a window, or for a headless run that owns no window and compiles
/// pipelines synchronously so the captured frame is complete.
pub fn default_plugins(args: &ExampleArgs, title: &str) -> PluginGroupBuilder {
    let plugins = if args.headless {
        windowless_default_plugins().add(bevy::app::ScheduleRunnerPlugin::run_loop(
            std::time::Duration::ZERO,
        ))
    } else {
        DefaultPlugins.set(WindowPlugin {
            primary_window: Some(Window {
                title: title.into(),
                ..default()
            }),
            ..default()
        })
    };
    // The crate's `live` feature turns on Bevy's web asset sources, whose plugin warns that web
    // paths are loadable; the examples load no asset from the web, only the live forecasts.
    #[cfg(feature = "live")]
    let plugins = if args.headless {
        plugins
    } else {
        plugins.set(bevy::asset::io::web::WebAssetPlugin {
            silence_startup_warning: true,
        })
    };
    plugins
}

use bevy::app::PluginGroupBuilder;

/// Makes the camera marked [`MainCamera`] render into an image and, after
/// [`ExampleArgs::frames`] frames, writes that image to [`ExampleArgs::out`] and exits.
///
/// An example that needs more inserts [`HeadlessShots`] (a time-lapse: several images, with
/// frames in between for the scene to change and settle) and holds [`HeadlessProgress::ready`]
/// at false until its assets have loaded; it reads [`HeadlessProgress::shot`] to know which
/// image the scene should show.
pub struct HeadlessCapturePlugin;

/// Marks the camera the headless capture reads.
#[derive(Component)]
pub struct MainCamera;

/// How many images the headless capture writes. Default: one.
#[derive(Resource, Debug, Clone)]
pub struct HeadlessShots {
    /// Images to write. One goes to [`ExampleArgs::out`]; more go into the folder
    /// [`ExampleArgs::out`] as `frame_000.png`, `frame_001.png`, …
    pub count: u32,
    /// Frames between two shots, for the scene to settle after it changed (LUTs, layers); at
    /// least the clouds' [`accumulation_frames`].
    pub settle_frames: u32,
}

impl Default for HeadlessShots {
    fn default() -> Self {
        Self {
            count: 1,
            settle_frames: 3,
        }
    }
}

/// Where the headless capture stands.
#[derive(Resource, Debug)]
pub struct HeadlessProgress {
    /// While false the capture waits, and the warm-up frames are not counted: set it once the
    /// scene is complete (e.g. its assets have loaded). Default true.
    pub ready: bool,
    /// The shot the scene should show now, counted from 0; it advances in `Last` on the frame
    /// an image is taken, so the next frame can change the scene.
    pub shot: u32,
    frames: u32,
    written: u32,
    /// A progress bar on the terminal for time-lapses (indicatif draws nothing when stderr is
    /// not a terminal, as in CI).
    bar: Option<indicatif::ProgressBar>,
}

impl Default for HeadlessProgress {
    fn default() -> Self {
        Self {
            ready: true,
            shot: 0,
            frames: 0,
            written: 0,
            bar: None,
        }
    }
}

#[derive(Resource)]
struct CaptureTarget(Handle<Image>);

impl Plugin for HeadlessCapturePlugin {
    fn build(&self, app: &mut App) {
        app.init_resource::<HeadlessShots>()
            .init_resource::<HeadlessProgress>()
            .add_systems(PostStartup, redirect_camera_to_image)
            // In `Last`, after everything that changes the scene this frame, so the image shows
            // the frame's final state.
            .add_systems(Last, capture_after_frames);
    }
}

fn redirect_camera_to_image(
    mut commands: Commands,
    args: Res<ExampleArgs>,
    mut images: ResMut<Assets<Image>>,
    cameras: Query<Entity, With<MainCamera>>,
) {
    let target = images.add(render_target_image(
        args.size,
        TextureFormat::Rgba8UnormSrgb,
    ));
    for camera in &cameras {
        commands
            .entity(camera)
            .insert(RenderTarget::Image(target.clone().into()));
    }
    commands.insert_resource(CaptureTarget(target));
}

/// Frames the clouds' temporal accumulation needs before a capture shows a converged image:
/// until the first frame's weight in each pixel's running average is under 5 % (the first
/// frame is the same view, only blurred by the upsample, so what is left of it no longer
/// shows), each pixel taking a new sample once in the temporal upsampling's `k²` frames with
/// the weight `hit_blend` (`k²` times the visits that takes; 128 frames for the default blend
/// at quarter resolution). 0 without accumulation.
pub fn accumulation_frames(clouds: &VolumetricClouds) -> u32 {
    accumulation_frames_until(clouds, 0.05)
}

/// Frames until the first frame's weight in each pixel's running average is under
/// `first_weight` (0–1; see [`accumulation_frames`]). 0 without accumulation.
pub fn accumulation_frames_until(clouds: &VolumetricClouds, first_weight: f32) -> u32 {
    let Some(blend) = clouds.effective_temporal_blend() else {
        return 0;
    };
    let k = (1.0 / clouds.sanitized().resolution_scale).round() as u32;
    bevy_cloudscape::reference::composite::settle_frames(
        f64::from(blend),
        k,
        f64::from(first_weight),
    )
}

fn capture_after_frames(
    mut commands: Commands,
    args: Res<ExampleArgs>,
    shots: Res<HeadlessShots>,
    mut progress: ResMut<HeadlessProgress>,
    target: Res<CaptureTarget>,
    clouds: Query<&VolumetricClouds, With<MainCamera>>,
    cpu_noise: Option<Res<bevy_cloudscape::query::CpuCloudTextures>>,
) {
    let count = shots.count.max(1);
    if !progress.ready || progress.shot >= count {
        return;
    }
    // A storm places its flashes with the CPU noise once it is made: wait for it, so the
    // images are the same every run.
    if cpu_noise.is_some_and(|noise| !noise.is_ready()) {
        return;
    }
    progress.frames += 1;
    // Every image waits for the clouds to converge on what changed (the first one's warm-up
    // counts toward it): a time-lapse step can change the whole sky.
    let converged = clouds.iter().map(accumulation_frames).fold(1, u32::max);
    let due = if progress.shot == 0 {
        converged.max(args.frames)
    } else {
        converged.max(shots.settle_frames)
    };
    if progress.frames < due {
        return;
    }
    progress.frames = 0;
    let out = if count == 1 {
        args.out.clone()
    } else {
        if progress.shot == 0 {
            if let Err(e) = std::fs::create_dir_all(&args.out) {
                error!("cannot create {}: {e}", args.out.display());
                commands.write_message(AppExit::error());
                return;
            }
            let bar = indicatif::ProgressBar::new(u64::from(count));
            if let Ok(style) = indicatif::ProgressStyle::with_template(
                "{bar:40} {pos}/{len} frames, {elapsed} elapsed, about {eta} left",
            ) {
                bar.set_style(style);
            }
            progress.bar = Some(bar);
        }
        args.out.join(format!("frame_{:03}.png", progress.shot))
    };
    progress.shot += 1;
    commands.spawn(Screenshot::image(target.0.clone())).observe(
        move |captured: On<ScreenshotCaptured>,
              mut progress: ResMut<HeadlessProgress>,
              mut exit: MessageWriter<AppExit>| {
            match captured
                .image
                .clone()
                .try_into_dynamic()
                .map_err(|e| e.to_string())
                .and_then(|img| img.to_rgb8().save(&out).map_err(|e| e.to_string()))
            {
                Ok(()) => {
                    progress.written += 1;
                    match &progress.bar {
                        Some(bar) if !bar.is_hidden() => bar.inc(1),
                        _ => info!("wrote {} ({}/{count})", out.display(), progress.written),
                    }
                    if progress.written == count {
                        if let Some(bar) = &progress.bar {
                            bar.finish();
                        }
                        exit.write(AppExit::Success);
                    }
                }
                Err(e) => {
                    error!("cannot write {}: {e}", out.display());
                    exit.write(AppExit::error());
                }
            }
        },
    );
}

/// An image a camera can render into and tests can copy back.
pub fn render_target_image(size: UVec2, format: TextureFormat) -> Image {
    let mut image = Image::new_uninit(
        Extent3d {
            width: size.x,
            height: size.y,
            depth_or_array_layers: 1,
        },
        TextureDimension::D2,
        format,
        RenderAssetUsages::RENDER_WORLD,
    );
    image.texture_descriptor.usage |=
        TextureUsages::RENDER_ATTACHMENT | TextureUsages::COPY_SRC | TextureUsages::TEXTURE_BINDING;
    image
}

/// Sun elevation of the sky scene, degrees above the horizon.
pub const SKY_SCENE_SUN_ELEVATION_DEG: f32 = 25.0;
/// Sun azimuth of the sky scene, degrees clockwise from the camera's view direction.
pub const SKY_SCENE_SUN_AZIMUTH_DEG: f32 = 30.0;
/// Vertical field of view of the sky scene camera, degrees.
pub const SKY_SCENE_FOV_DEG: f32 = 60.0;

/// Unit vector toward the sun of the sky scene, in world space (camera looks along -Z).
pub fn sky_scene_sun_direction() -> Vec3 {
    let (el, az) = (
        SKY_SCENE_SUN_ELEVATION_DEG.to_radians(),
        SKY_SCENE_SUN_AZIMUTH_DEG.to_radians(),
    );
    Vec3::new(az.sin() * el.cos(), el.sin(), -az.cos() * el.cos())
}

/// Spawns the sky scene: Bevy's `Atmosphere` for an Earth-sized planet, a sun (a
/// `DirectionalLight` with the illuminance of sunlight above the atmosphere), and a 200 km ground
/// plane at y = 0. The camera comes from [`sky_scene_camera`].
pub fn spawn_sky_scene(
    mut commands: Commands,
    mut meshes: ResMut<Assets<Mesh>>,
    mut materials: ResMut<Assets<StandardMaterial>>,
    mut media: ResMut<Assets<ScatteringMedium>>,
) {
    commands.spawn(Atmosphere::earth(
        media.add(ScatteringMedium::earth(256, 256)),
    ));
    commands.spawn((
        DirectionalLight {
            illuminance: lux::RAW_SUNLIGHT,
            ..default()
        },
        Transform::default().looking_to(-sky_scene_sun_direction(), Vec3::Y),
    ));
    commands.spawn((
        Mesh3d(meshes.add(Plane3d::default().mesh().size(200_000.0, 200_000.0))),
        MeshMaterial3d(materials.add(StandardMaterial {
            base_color: Color::srgb(0.32, 0.42, 0.22),
            perceptual_roughness: 0.9,
            ..default()
        })),
    ));
}

/// Pitch of the sky scene camera, degrees above the horizon.
pub const SKY_SCENE_PITCH_DEG: f32 = 12.0;

/// The sky scene's camera: 1.8 m above the ground, looking [`SKY_SCENE_PITCH_DEG`] above the
/// horizon along -Z, with the exposure Bevy's atmosphere example uses for raw sunlight.
pub fn sky_scene_camera() -> impl Bundle {
    (
        Camera3d::default(),
        Projection::Perspective(PerspectiveProjection {
            fov: SKY_SCENE_FOV_DEG.to_radians(),
            ..default()
        }),
        Transform::from_xyz(0.0, 1.8, 0.0).looking_to(
            Vec3::new(0.0, SKY_SCENE_PITCH_DEG.to_radians().tan(), -1.0),
            Vec3::Y,
        ),
        AtmosphereSettings::default(),
        Exposure { ev100: 13.0 },
        Tonemapping::AcesFitted,
        MainCamera,
    )
}
