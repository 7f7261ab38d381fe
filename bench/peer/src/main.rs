//! Times the peer crate `bevy-volumetric-clouds` 0.2 (Bevy 0.18) in a window of a given size.
//!
//! ```text
//! cargo run --release --manifest-path bench/peer/Cargo.toml -- \
//!     [--width W] [--height H] [--frames N] [--warmup N] [--clouds on|off]
//! ```
//!
//! The view is the one of bevy_cloudscape's bench: the camera 2 m above the ground, pitched up
//! 20°, the sun 45° above the horizon, one cumulus-like layer at 50 % coverage. With
//! `--clouds on` the peer's `CloudsPlugin` draws the clouds; with `--clouds off` the plugin is not
//! added and the rest of the scene (camera, sun light, window) is the same, so the difference of
//! the two medians is what the clouds cost.
//!
//! After `--warmup` frames (counted from the moment no render pipeline is still compiling), the
//! wall-clock time between successive `Update`s is recorded for `--frames` frames, and the
//! median, in milliseconds, is printed on stdout as one line,
//! `peer,<on|off>,<W>,<H>,<median_ms>`; then the app exits. Everything else goes to stderr.
//!
//! The peer's API, as in its v0.2.0 sources (github.com/evroon/bevy-volumetric-clouds):
//! - `bevy_volumetric_clouds::CloudsPlugin` (`src/lib.rs`) inserts `CloudsConfig::default()`,
//!   spawns six sky planes with its cloud material around the one camera, and spawns its own
//!   sun: a `DirectionalLight` of `FULL_DAYLIGHT` lux at `(1, 1, 0)` looking at the origin
//!   (`setup_daylight` in `src/skybox.rs`), 45° above the horizon.
//! - `bevy_volumetric_clouds::config::CloudsConfig` (`src/config.rs`), a resource; inserting one
//!   after the plugin replaces the default. Its `clouds_coverage` is the coverage (0 clear, 1
//!   overcast; 0.5 by default), its one layer spans `clouds_bottom_height` 1250 m to
//!   `clouds_top_height` 2400 m (cumulus-like), `sun_dir` is the direction towards the sun, which
//!   the plugin does not take from the light.
//! - No camera component: the plugin uses the one `Camera` there is (`Single`), with a
//!   perspective projection; its examples give the camera `Hdr`.
//!
//! Peer limitations that shape the numbers (read in its sources, see the README):
//! the clouds are always marched into a 1920×1080 image (`src/images.rs`; `render_resolution`
//! of `CloudsConfig` is not passed to the shader), by a compute dispatch of 1920×1920 threads
//! (`src/compute.rs`), whatever the window's size; the sky planes then sample it per pixel.

use std::time::{Duration, Instant};

use bevy::{
    light::light_consts::lux::FULL_DAYLIGHT,
    prelude::*,
    render::{
        MainWorld, RenderApp,
        render_resource::{CachedPipelineState, PipelineCache},
        view::Hdr,
    },
    window::{PresentMode, PrimaryWindow, WindowResolution},
};
use bevy_volumetric_clouds::{CloudsPlugin, config::CloudsConfig};

/// How long the render pipelines may take to compile before the run is given up.
const PIPELINE_TIMEOUT: Duration = Duration::from_secs(300);

const USAGE: &str = "usage: peer_bench [--width W] [--height H] [--frames N] [--warmup N] \
                     [--clouds on|off]";

/// The command line.
#[derive(Clone, Copy, Debug)]
struct Args {
    /// Window width, physical pixels.
    width: u32,
    /// Window height, physical pixels.
    height: u32,
    /// Frames timed (the median is kept).
    frames: u32,
    /// Frames rendered before the timing starts, once the pipelines are ready.
    warmup: u32,
    /// Whether the peer's clouds are added.
    clouds: bool,
}

impl Default for Args {
    fn default() -> Self {
        Self {
            width: 1920,
            height: 1080,
            frames: 300,
            warmup: 120,
            clouds: true,
        }
    }
}

/// Parses `std::env::args`; `Err` holds the message to print.
fn parse_args() -> Result<Args, String> {
    let mut args = Args::default();
    let mut it = std::env::args().skip(1);
    while let Some(flag) = it.next() {
        if flag == "--help" || flag == "-h" {
            return Err(USAGE.to_owned());
        }
        let value = it
            .next()
            .ok_or_else(|| format!("{flag} needs a value\n{USAGE}"))?;
        let positive = |name: &str| match value.parse::<u32>() {
            Ok(n) if n > 0 => Ok(n),
            _ => Err(format!("{name} must be a positive integer, not {value:?}")),
        };
        match flag.as_str() {
            "--width" => args.width = positive("--width")?,
            "--height" => args.height = positive("--height")?,
            "--frames" => args.frames = positive("--frames")?,
            "--warmup" => {
                args.warmup = value
                    .parse()
                    .map_err(|_| format!("--warmup must be an integer, not {value:?}"))?;
            }
            "--clouds" => {
                args.clouds = match value.as_str() {
                    "on" => true,
                    "off" => false,
                    _ => return Err(format!("--clouds must be on or off, not {value:?}")),
                };
            }
            _ => return Err(format!("unknown argument {flag:?}\n{USAGE}")),
        }
    }
    Ok(args)
}

/// The direction towards the sun: the peer's own light, at `(1, 1, 0)` looking at the origin.
fn sun_towards() -> Vec3 {
    Vec3::new(1.0, 1.0, 0.0).normalize()
}

/// Written by the render world each frame: whether no pipeline is waiting to compile, and
/// whether one has failed.
#[derive(Resource, Default)]
struct PipelinesReady {
    ready: bool,
    failed: bool,
}

/// The timing state.
#[derive(Resource)]
struct Bench {
    args: Args,
    started: Instant,
    /// Frames rendered since the pipelines were last seen ready.
    warm: u32,
    /// The time of each timed `Update`: `frames + 1` of them give `frames` intervals.
    stamps: Vec<Instant>,
    done: bool,
}

fn main() -> AppExit {
    let args = match parse_args() {
        Ok(args) => args,
        Err(message) => {
            eprintln!("{message}");
            return AppExit::error();
        }
    };

    let mut app = App::new();
    app.add_plugins(DefaultPlugins.set(WindowPlugin {
        primary_window: Some(Window {
            title: format!(
                "peer bench: bevy-volumetric-clouds, clouds {}",
                if args.clouds { "on" } else { "off" }
            ),
            resolution: WindowResolution::new(args.width, args.height)
                .with_scale_factor_override(1.0),
            present_mode: PresentMode::AutoNoVsync,
            resizable: false,
            ..default()
        }),
        ..default()
    }))
    .insert_resource(Bench {
        args,
        started: Instant::now(),
        warm: 0,
        stamps: Vec::with_capacity(args.frames as usize + 1),
        done: false,
    })
    .init_resource::<PipelinesReady>()
    .add_systems(Startup, setup)
    .add_systems(Update, time_frames);

    if args.clouds {
        // The plugin inserts `CloudsConfig::default()` when it is added; this one replaces it.
        // The default is already one layer from 1250 m to 2400 m at coverage 0.5; the coverage
        // is set anyway, and the sun direction is set to the plugin's own light's (the default
        // `sun_dir`, (-0.7, 0.5, 0.75), is 26° high and not where the light is).
        let sun = sun_towards();
        app.add_plugins(CloudsPlugin).insert_resource(CloudsConfig {
            clouds_coverage: 0.5,
            sun_dir: Vec4::new(sun.x, sun.y, sun.z, 0.0),
            ..default()
        });
    }

    app.sub_app_mut(RenderApp)
        .add_systems(ExtractSchedule, report_pipelines);

    app.run()
}

fn setup(mut commands: Commands, bench: Res<Bench>) {
    // 2 m up, looking north (−Z) and 20° up: `looking(Vec3::new(0.0, 2.0, 0.0), 20.0, 0.0)` of
    // bevy_cloudscape's `examples/common/scenes.rs`.
    let pitch = 20f32.to_radians();
    let forward = Vec3::new(0.0, pitch.sin(), -pitch.cos());
    commands.spawn((
        Camera3d::default(),
        // As the peer's examples; the same camera with the clouds off.
        Hdr,
        // bevy_cloudscape's bench renders without MSAA.
        Msaa::Off,
        Transform::from_xyz(0.0, 2.0, 0.0).looking_to(forward, Vec3::Y),
    ));
    if !bench.args.clouds {
        // The light `CloudsPlugin` spawns itself (`setup_daylight`), so both runs have the same
        // one sun.
        commands.spawn((
            Transform::from_translation(sun_towards()).looking_at(Vec3::ZERO, Vec3::Y),
            DirectionalLight {
                illuminance: FULL_DAYLIGHT,
                ..default()
            },
        ));
    }
}

/// In the render world's extract: whether every pipeline queued so far has compiled.
fn report_pipelines(mut main_world: ResMut<MainWorld>, pipelines: Res<PipelineCache>) {
    let ready = pipelines.waiting_pipelines().count() == 0;
    // A pipeline whose shader is not loaded yet is in `Err` but still waiting; one in `Err` once
    // nothing waits has failed for good.
    let failed = ready
        && pipelines
            .pipelines()
            .any(|p| matches!(p.state, CachedPipelineState::Err(_)));
    if let Some(mut state) = main_world.get_resource_mut::<PipelinesReady>() {
        state.ready = ready;
        state.failed = failed;
    }
}

fn time_frames(
    mut bench: ResMut<Bench>,
    pipelines: Res<PipelinesReady>,
    window: Single<&Window, With<PrimaryWindow>>,
    mut exit: MessageWriter<AppExit>,
) {
    if bench.done {
        return;
    }
    let now = Instant::now();
    if pipelines.failed {
        eprintln!("peer_bench: a render pipeline failed to compile (see the log); no timing");
        bench.done = true;
        exit.write(AppExit::error());
        return;
    }
    if bench.stamps.is_empty() {
        // Warming up: frames count only while nothing is compiling, so frames that skip the
        // clouds because their pipelines are not ready are not timed.
        if !pipelines.ready {
            bench.warm = 0;
            if now.duration_since(bench.started) > PIPELINE_TIMEOUT {
                eprintln!(
                    "peer_bench: pipelines still compiling after {} s; giving up",
                    PIPELINE_TIMEOUT.as_secs()
                );
                bench.done = true;
                exit.write(AppExit::error());
            }
            return;
        }
        if bench.warm < bench.args.warmup {
            bench.warm += 1;
            return;
        }
        let (w, h) = (window.physical_width(), window.physical_height());
        if (w, h) != (bench.args.width, bench.args.height) {
            eprintln!(
                "peer_bench: warning: the window is {w}×{h}, not the {}×{} asked for \
                 (larger than the screen?)",
                bench.args.width, bench.args.height
            );
        }
    }
    bench.stamps.push(now);
    if bench.stamps.len() <= bench.args.frames as usize {
        return;
    }
    let mut ms: Vec<f64> = bench
        .stamps
        .windows(2)
        .map(|pair| pair[1].duration_since(pair[0]).as_secs_f64() * 1e3)
        .collect();
    ms.sort_by(f64::total_cmp);
    let n = ms.len();
    let median = if n % 2 == 1 {
        ms[n / 2]
    } else {
        0.5 * (ms[n / 2 - 1] + ms[n / 2])
    };
    let args = bench.args;
    println!(
        "peer,{},{},{},{median:.3}",
        if args.clouds { "on" } else { "off" },
        args.width,
        args.height
    );
    bench.done = true;
    exit.write(AppExit::Success);
}
