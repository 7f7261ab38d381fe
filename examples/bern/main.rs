//! The Bern demo: a week of bundled forecasts over the real terrain around Bern, seen from the
//! Gurten (north-north-east over the city toward Solothurn) or from the Bantiger (south-west
//! toward Fribourg), with the sun where it really is at the scene time.
//!
//! ```text
//! cargo run --release --example bern                        # a window with panels and keys
//! cargo run --release --example bern -- --headless --camera gurten \
//!     --time 2021-05-03T14:00:00Z --out bern.png            # one frame, no window
//! cargo run --release --example bern -- --headless --camera bantiger \
//!     --time 2021-05-03T04:00:00Z --frames 96 --step 10m --out frames   # a time-lapse
//! ```
//!
//! # Controls (window)
//!
//! | key | does |
//! |---|---|
//! | `1`, `2` | Gurten view (far forecast Solothurn), Bantiger view (far forecast Fribourg) |
//! | `F` | free-fly camera on/off: `W` `A` `S` `D` move, `E` `Q` up and down, `Shift` runs, hold the right mouse button (or toggle with `M`) to look around, the wheel changes speed |
//! | `Space` | pause or run the scene clock |
//! | `+`, `-` | clock speed 1×, 60×, 3600× |
//! | `←`, `→` | one hour back or forward |
//! | `P`, `[`, `]` | photo overlay on/off, move its wiper left or right (with `--photos`) |
//!
//! An egui window offers the same and more: **Live** mode (a time slider over the near forecast,
//! "now", play/pause, 1×/60×/3600×) and **Play** mode (the weather presets, and sliders for low,
//! mid and high cover, precipitation, showers, wind, visibility, fog, temperature and time of
//! day, which drive the layers through the crate's own weather mapping), the transition time of
//! every change, a checkbox that lets the low clouds form and dissolve (`CloudGrowth`, as
//! `--growth`), the frame rate and the cloud passes' GPU times, the photo overlay's settings,
//! and an inspector for every `CloudLayer` (and its `CloudGrowth`) and the camera's
//! `VolumetricClouds`.
//!
//! # Flags
//!
//! | flag | meaning | default |
//! |---|---|---|
//! | `--camera gurten\|bantiger` | the view | `gurten` |
//! | `--time RFC3339` | scene time, e.g. `2021-05-03T14:00:00Z`; the clock runs from there at 1× (paused when headless) | `2021-05-03T14:00:00Z` |
//! | `--headless` | render without a window and write a PNG to `--out` | off |
//! | `--out PATH` | the PNG; with `--frames`, a folder of `frame_000.png`, `frame_001.png`, … | `bern.png`, `bern_frames` |
//! | `--width W`, `--height H` | headless image size, pixels | 1280 × 720 |
//! | `--frames N`, `--step D` | headless time-lapse: `N` images `D` apart (`30s`, `10m`, `1h`, `1d`) | one image, `10m` |
//! | `--warmup N` | frames rendered before the first image (the clouds' temporal accumulation settles in about 20) | 24 |
//! | `--photos DIR` | photos to compare with, see below | none |
//! | `--photo-opacity X` | opacity of the photo overlay, 0–1 | 0.5 |
//! | `--photo-wiper X` | fraction of the width, from the left, that shows the photo | 1 |
//! | `--ev100 EV` | camera exposure | 14 (sunlit scenes; Bevy's atmosphere example uses 13) |
//! | `--azimuth DEG` | look this way from the view's hill, degrees clockwise from north (toward a low sun for light shafts) | the view's own: Gurten 20°, Bantiger 225° |
//! | `--pitch DEG` | look this far above the horizon, degrees, −89 to 89 (up toward a high sun for its halo) | the view's own, a few degrees up |
//! | `--fov DEG` | the camera's vertical field of view, degrees, 0.5–120 (a few degrees: a telephoto, for the moon's phase) | 50 |
//! | `--no-clouds` | no `VolumetricClouds` on the camera: the same frame without clouds (CI compares the two) | clouds on |
//! | `--log-frame-times` | log the frame time and the cloud passes' GPU times every second | off |
//! | `--growth` | the low clouds grow with the cloud-growth automaton: they form and dissolve as the low cover changes | off |
//! | `--no-cloud-shadows` | turn the cloud shadow map off (to compare, or to time its cost) | on |
//! | `--no-sky-light` | the camera's environment and ambient light stay the clear sky's (`CloudSkyLight` off; CI compares frames with and without clouds so) | on |
//! | `--look` | headless: render the look board (`docs/look.md`), nine views of the week's weathers, into the folder `--out` and tile them into `board.png` there | off |
//! | `--dem PATH` | elevation file (ESRI ASCII grid or `GeoTIFF`, WGS 84 degrees) | `assets/terrain/bern_globe30s.asc` |
//!
//! A bad flag exits with status 2 and a message. Without a display, run with `--headless`.
//!
//! # Your own data
//!
//! - **Forecasts**: replace `assets/weather/bern.json` (near), `solothurn.json` and
//!   `fribourg.json` (far) with meteoblue or Open-Meteo JSON for the same places; a file
//!   replaced while the demo runs is reloaded.
//! - **Terrain**: `--dem` takes any ESRI ASCII grid or `GeoTIFF` in geographic degrees that covers
//!   Bern. If it cannot be read the error (file and line) is logged and shown on screen, and the
//!   demo goes on over flat ground at 540 m.
//! - **Photos** (Thomann 2021 §7.3, the Roundshot overlay): `--photos DIR` reads
//!   `DIR/gurten/YYYY-MM-DDTHH-MM.jpg` and `DIR/bantiger/…` (`.jpg`, `.jpeg` or `.png`; the time
//!   is UTC, e.g. `gurten/2021-05-03T14-00.jpg`). The photo nearest the scene time is drawn over
//!   the view, left of a wiper, with the chosen opacity. Missing folders or photos are reported,
//!   never fatal.

#[path = "../common/mod.rs"]
mod common;

mod cli;
mod headless;
mod look;
mod panels;
mod photos;
mod scene;
mod terrain;
mod view;
mod viewpoint;

use cli::*;
use headless::*;
use photos::*;
use scene::*;
use terrain::*;
use view::*;
use viewpoint::*;

use std::{
    path::{Path, PathBuf},
    time::Instant,
};

use bevy::{
    asset::{LoadState, RenderAssetUsages, io::file::FileAssetReader},
    camera::Exposure,
    camera_controller::free_camera::{FreeCamera, FreeCameraPlugin, FreeCameraState},
    core_pipeline::tonemapping::Tonemapping,
    image::{CompressedImageFormats, ImageSampler, ImageType},
    light::{
        Atmosphere, AtmosphereEnvironmentMapLight, atmosphere::ScatteringMedium, light_consts::lux,
    },
    math::DVec2,
    mesh::{Indices, PrimitiveTopology},
    pbr::AtmosphereSettings,
    post_process::bloom::Bloom,
    prelude::*,
    text::FontSize,
};
use bevy_cloudscape::{
    prelude::*,
    terrain::{Dem, Summit, TangentPlane, TerrainMesh, TerrainPalette, TerrainSettings},
    weather::{FarForecast, WeatherState},
};
use common::{ExampleArgs, HeadlessCapturePlugin, HeadlessProgress, HeadlessShots, MainCamera};

/// Height of Bern above sea level, metres: the ground the cloud layers' altitudes count from.
const BERN_GROUND_M: f32 = 540.0;
/// The bundled elevation model, under the asset folder.
const DEM_ASSET: &str = "terrain/bern_globe30s.asc";
/// The near forecast, under the asset folder.
const NEAR_FORECAST: &str = "weather/bern.json";
/// An afternoon of fair-weather cumulus in the bundled week (16:00 CEST on Monday 3 May 2021).
const DEFAULT_TIME: &str = "2021-05-03T14:00:00Z";
/// Eye height above the ground, metres.
const EYE_HEIGHT_M: f32 = 1.7;
/// Vertical field of view, degrees: 79° across at 16:9, like a 21 mm lens on full frame.
const FOV_DEG: f32 = 50.0;
/// The views look slightly down, into the valley.
const PITCH_DEG: f32 = -2.0;
/// Clock speeds the keys and the panel step through: real time, a minute and an hour per second.
const CLOCK_SPEEDS: [f64; 3] = [1.0, 60.0, 3600.0];
/// Camera exposure, EV100 (`--ev100`).
const DEFAULT_EV100: f32 = 14.0;
/// Frames between two time-lapse images for the atmosphere LUTs to follow the sun; the capture
/// also waits for the clouds' temporal accumulation to converge on the new time.
const SETTLE_FRAMES: u32 = 16;
/// Frames before the first headless image when `--warmup` is not given: the pipelines and LUTs
/// need a few, and the clouds' temporal accumulation about twenty to settle.
const DEFAULT_WARMUP: u32 = 24;

fn main() -> AppExit {
    let (args, options) = match <Cli as clap::Parser>::parse().options() {
        Ok(parsed) => parsed,
        Err(message) => {
            eprintln!("bern: {message}");
            return AppExit::from_code(2);
        }
    };
    // winit panics without a display; say what to do instead.
    if cfg!(target_os = "linux") && !args.headless && std::env::var_os("DISPLAY").is_none() {
        eprintln!(
            "bern: no display (DISPLAY is not set). Render to a file instead:\n  \
             cargo run --example bern -- --headless --camera gurten --out bern.png"
        );
        return AppExit::from_code(2);
    }

    let mut clock = if options.live {
        // The scene time is now, as the live forecasts are.
        SceneClock::default()
    } else {
        SceneClock::at(options.time)
    };
    clock.paused = args.headless && !options.live;
    let mut app = App::new();
    app.add_plugins((
        common::default_plugins(&args, "bevy_cloudscape: Bern"),
        CloudscapePlugin,
        MaterialPlugin::<TerrainMaterial>::default(),
    ))
    // The atmosphere's environment map lights the terrain instead.
    .insert_resource(GlobalAmbientLight::NONE)
    .insert_resource(clock)
    .insert_resource(ViewState {
        azimuth_deg: options.azimuth_deg,
        pitch_deg: options.pitch_deg,
        ..ViewState::on(options.viewpoint)
    })
    .insert_resource(PhotoOverlay {
        visible: options.photos.is_some(),
        opacity: options.photo_opacity,
        wiper: options.photo_wiper,
        ..default()
    })
    .init_resource::<UiCapturesKeyboard>()
    .add_systems(
        Startup,
        (load_terrain, spawn_scene, spawn_photo_overlay).chain(),
    )
    .add_systems(
        Update,
        (
            apply_view,
            update_photo_overlay,
            follow_snow_line.after(CloudscapeSystems::Layers),
        ),
    );

    if args.headless {
        let mut progress = HeadlessProgress::default();
        progress.ready = false;
        app.insert_resource(HeadlessShots {
            count: options.shots.unwrap_or(1),
            settle_frames: SETTLE_FRAMES,
        })
        .insert_resource(progress)
        .add_plugins(HeadlessCapturePlugin)
        .add_systems(
            Update,
            (
                follow_headless_shots
                    .run_if(|options: Res<BernOptions>| !options.look)
                    .before(CloudscapeSystems::Clock),
                look::follow_look_shots
                    .run_if(|options: Res<BernOptions>| options.look)
                    .before(apply_view)
                    .before(CloudscapeSystems::Clock),
                cut_transitions.before(CloudscapeSystems::Layers),
                wait_for_forecasts.after(CloudscapeSystems::Layers),
                wait_for_growth
                    .after(wait_for_forecasts)
                    .after(CloudscapeSystems::Sun),
            ),
        );
    } else {
        app.add_plugins(FreeCameraPlugin).add_systems(
            Update,
            (
                view_keys.before(apply_view),
                clock_keys.before(CloudscapeSystems::Clock),
                photo_keys.before(update_photo_overlay),
            ),
        );
        app.add_plugins(panels::PanelPlugin);
    }
    if options.log_frame_times {
        use bevy::{
            diagnostic::{FrameTimeDiagnosticsPlugin, LogDiagnosticsPlugin},
            render::diagnostic::RenderDiagnosticsPlugin,
        };
        // The inspector panel adds the first two already.
        if !app.is_plugin_added::<FrameTimeDiagnosticsPlugin>() {
            app.add_plugins(FrameTimeDiagnosticsPlugin::default());
        }
        if !app.is_plugin_added::<RenderDiagnosticsPlugin>() {
            app.add_plugins(RenderDiagnosticsPlugin);
        }
        app.add_plugins(LogDiagnosticsPlugin::default());
    }
    let board = options.look.then(|| args.out.clone());
    let exit = app
        .insert_resource(CloudShadows {
            enabled: options.cloud_shadows,
            ..default()
        })
        .insert_resource(options)
        .insert_resource(args)
        .run();
    match board
        .filter(|_| exit.is_success())
        .map(|folder| look::write_board(&folder))
    {
        Some(Ok(path)) => {
            println!("bern: the look board is {}", path.display());
            exit
        }
        Some(Err(message)) => {
            eprintln!("bern: {message}");
            AppExit::from_code(1)
        }
        None => exit,
    }
}
