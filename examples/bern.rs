//! The Bern demo: a week of bundled forecasts over the real terrain around Bern, seen from the
//! Gurten (north-north-east over the city toward Solothurn) or from the Bantiger (south-west
//! toward Fribourg), with the sun where it really is at the scene time.
//!
//! ```text
//! cargo run --release --example bern                        # a window, keyboard controls
//! cargo run --release --example bern --features inspector   # a window with egui panels
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
//! With `--features inspector` an egui window offers the same and more: **Live** mode (a time
//! slider over the near forecast, "now", play/pause, 1×/60×/3600×) and **Play** mode (sliders for
//! low, mid and high cover, precipitation, showers, wind and time of day, which drive the layers
//! through the crate's own weather mapping), the frame rate and the cloud passes' GPU times, the
//! photo overlay's settings, and an inspector for every `CloudLayer` and the camera's
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
//! | `--no-clouds` | no `VolumetricClouds` on the camera: the same frame without clouds (CI compares the two) | clouds on |
//! | `--log-frame-times` | log the frame time and the cloud passes' GPU times every second | off |
//! | `--no-cloud-shadows` | turn the cloud shadow map off (to compare, or to time its cost) | on |
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

mod common;

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
    terrain::{Dem, Summit, TangentPlane, TerrainMesh, TerrainSettings},
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
/// Frames between two time-lapse images, for the atmosphere LUTs to follow the sun and the
/// clouds' temporal accumulation (a blend of 0.1) to settle on the new time.
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

    let mut clock = SceneClock::at(options.time);
    clock.paused = args.headless;
    let mut app = App::new();
    app.add_plugins((
        common::default_plugins(&args, "bevy_cloudscape: Bern"),
        CloudscapePlugin,
    ))
    // The atmosphere's environment map lights the terrain instead.
    .insert_resource(GlobalAmbientLight::NONE)
    .insert_resource(clock)
    .insert_resource(ViewState {
        viewpoint: options.viewpoint,
        free: false,
        azimuth_deg: options.azimuth_deg,
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
    .add_systems(Update, (apply_view, update_photo_overlay));

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
                follow_headless_shots.before(CloudscapeSystems::Clock),
                wait_for_forecasts.after(CloudscapeSystems::Layers),
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
        #[cfg(not(feature = "inspector"))]
        app.add_systems(Startup, spawn_help_overlay.after(spawn_scene))
            .add_systems(Update, update_help_overlay);
        #[cfg(feature = "inspector")]
        app.add_plugins(panel::PanelPlugin);
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
    app.insert_resource(CloudShadows {
        enabled: options.cloud_shadows,
        ..default()
    })
    .insert_resource(options)
    .insert_resource(args)
    .run()
}

// ---------------------------------------------------------------------------------------------
// Options

/// What the command line asked for beyond [`ExampleArgs`].
#[derive(Resource, Debug, Clone)]
struct BernOptions {
    viewpoint: Viewpoint,
    /// Scene time at start-up (and of the first headless image).
    time: UtcInstant,
    /// Headless time-lapse length; `None` for a single image.
    shots: Option<u32>,
    /// Scene time between time-lapse images, seconds.
    step_s: i64,
    photos: Option<PathBuf>,
    photo_opacity: f32,
    photo_wiper: f32,
    dem: PathBuf,
    /// Camera exposure, EV100.
    ev100: f32,
    /// Cast cloud shadows on the terrain.
    cloud_shadows: bool,
    /// Log frame and render-pass times every second.
    log_frame_times: bool,
    /// Render clouds (false: the camera has no `VolumetricClouds`).
    clouds: bool,
    /// `--azimuth`: the view direction, degrees clockwise from north.
    azimuth_deg: Option<f32>,
}

/// The Bern demo; the flags are explained at the top of `examples/bern.rs`.
#[derive(clap::Parser)]
struct Cli {
    /// The viewpoint: gurten or bantiger.
    #[arg(long, default_value = "gurten")]
    camera: Viewpoint,
    /// The scene time at start-up, UTC (RFC 3339).
    #[arg(long, default_value = DEFAULT_TIME)]
    time: UtcInstant,
    /// Render without a window and write PNG images.
    #[arg(long)]
    headless: bool,
    /// Where the headless image goes [default: `bern.png`; a time-lapse: the folder `bern_frames`].
    #[arg(long)]
    out: Option<PathBuf>,
    /// Headless image width, pixels.
    #[arg(long, default_value_t = 1280, value_parser = clap::value_parser!(u32).range(1..))]
    width: u32,
    /// Headless image height, pixels.
    #[arg(long, default_value_t = 720, value_parser = clap::value_parser!(u32).range(1..))]
    height: u32,
    /// A headless time-lapse of this many images, `--step` apart.
    #[arg(long, value_parser = clap::value_parser!(u32).range(1..))]
    frames: Option<u32>,
    /// Scene time between time-lapse images: 30s, 10m, 2h or 1d (negative runs backwards).
    #[arg(long, default_value = "10m", value_parser = parse_duration_s, allow_hyphen_values = true)]
    step: i64,
    /// Frames before the first headless image.
    #[arg(long, default_value_t = DEFAULT_WARMUP, value_parser = clap::value_parser!(u32).range(1..))]
    warmup: u32,
    /// A folder of photos to compare with (`DIR/gurten/2021-05-03T14-00.jpg`, …).
    #[arg(long)]
    photos: Option<PathBuf>,
    /// Opacity of the photo over the view, 0 to 1.
    #[arg(long, default_value_t = 0.5, value_parser = parse_fraction)]
    photo_opacity: f32,
    /// Where the photo's wiper stands, 0 (left) to 1 (right).
    #[arg(long, default_value_t = 1.0, value_parser = parse_fraction)]
    photo_wiper: f32,
    /// An elevation model (ESRI ASCII grid or `GeoTIFF` in degrees) [default: the bundled one].
    #[arg(long)]
    dem: Option<PathBuf>,
    /// Camera exposure, EV100.
    #[arg(long, default_value_t = DEFAULT_EV100, value_parser = parse_finite, allow_hyphen_values = true)]
    ev100: f32,
    /// The view direction, degrees clockwise from north [default: the viewpoint's].
    #[arg(long, value_parser = parse_finite, allow_hyphen_values = true)]
    azimuth: Option<f32>,
    /// No cloud shadows on the terrain.
    #[arg(long)]
    no_cloud_shadows: bool,
    /// No clouds (the camera has no `VolumetricClouds`).
    #[arg(long)]
    no_clouds: bool,
    /// Log frame and render-pass times every second.
    #[arg(long)]
    log_frame_times: bool,
}

impl Cli {
    /// The capture settings and the demo's options the command line asks for.
    fn options(self) -> Result<(ExampleArgs, BernOptions), String> {
        if self.frames.is_some() && !self.headless {
            return Err("--frames makes a headless time-lapse: add --headless".into());
        }
        let default_out = if self.frames.is_some() {
            "bern_frames"
        } else {
            "bern.png"
        };
        let args = ExampleArgs {
            headless: self.headless,
            out: self.out.unwrap_or_else(|| PathBuf::from(default_out)),
            frames: self.warmup,
            size: UVec2::new(self.width, self.height),
        };
        let options = BernOptions {
            viewpoint: self.camera,
            time: self.time,
            shots: self.frames,
            step_s: self.step,
            photos: self.photos,
            photo_opacity: self.photo_opacity,
            photo_wiper: self.photo_wiper,
            dem: self.dem.unwrap_or_else(|| {
                FileAssetReader::get_base_path()
                    .join("assets")
                    .join(DEM_ASSET)
            }),
            ev100: self.ev100,
            cloud_shadows: !self.no_cloud_shadows,
            log_frame_times: self.log_frame_times,
            clouds: !self.no_clouds,
            azimuth_deg: self.azimuth,
        };
        Ok((args, options))
    }
}

fn parse_finite(text: &str) -> Result<f32, String> {
    text.parse::<f32>()
        .ok()
        .filter(|x| x.is_finite())
        .ok_or_else(|| format!("{text:?} is not a number"))
}

fn parse_fraction(text: &str) -> Result<f32, String> {
    text.parse::<f32>()
        .ok()
        .filter(|x| (0.0..=1.0).contains(x))
        .ok_or_else(|| format!("{text:?} is not a number from 0 to 1"))
}

/// `30s`, `10m`, `2h`, `1d` (optionally negative, to run backwards) in seconds.
fn parse_duration_s(text: &str) -> Result<i64, String> {
    let error = || format!("{text:?} is not a duration such as 30s, 10m, 1h or 1d");
    let unit = text.chars().last().ok_or_else(error)?;
    let scale = match unit {
        's' => 1,
        'm' => 60,
        'h' => 3600,
        'd' => 86_400,
        _ => return Err(error()),
    };
    let number: i64 = text[..text.len() - 1].parse().map_err(|_| error())?;
    number.checked_mul(scale).ok_or_else(error)
}

// ---------------------------------------------------------------------------------------------
// Viewpoints

/// The two summits of Thomann 2021 §4.4, each with the far place whose weather shows on its horizon.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, Default)]
enum Viewpoint {
    #[default]
    Gurten,
    Bantiger,
}

impl Viewpoint {
    const ALL: [Self; 2] = [Self::Gurten, Self::Bantiger];

    fn name(self) -> &'static str {
        match self {
            Self::Gurten => "Gurten",
            Self::Bantiger => "Bantiger",
        }
    }

    /// The name on the command line and of the photo folder.
    fn key(self) -> &'static str {
        match self {
            Self::Gurten => "gurten",
            Self::Bantiger => "bantiger",
        }
    }

    fn summit(self) -> Summit {
        match self {
            Self::Gurten => Summit::GURTEN,
            Self::Bantiger => Summit::BANTIGER,
        }
    }

    /// View direction, degrees clockwise from north: over Bern toward the far place (Solothurn
    /// lies at 13° from Bern, Fribourg at 234°).
    fn azimuth_deg(self) -> f32 {
        match self {
            Self::Gurten => 20.0,
            Self::Bantiger => 225.0,
        }
    }

    fn far_place(self) -> &'static str {
        match self {
            Self::Gurten => "Solothurn",
            Self::Bantiger => "Fribourg",
        }
    }

    fn far_forecast(self) -> &'static str {
        match self {
            Self::Gurten => "weather/solothurn.json",
            Self::Bantiger => "weather/fribourg.json",
        }
    }
}

impl std::str::FromStr for Viewpoint {
    type Err = String;

    fn from_str(text: &str) -> Result<Self, String> {
        Self::ALL
            .into_iter()
            .find(|v| v.key().eq_ignore_ascii_case(text))
            .ok_or_else(|| format!("{text:?} is neither gurten nor bantiger"))
    }
}

/// Which view the camera shows.
#[derive(Resource, Debug, Clone, Copy, PartialEq)]
struct ViewState {
    viewpoint: Viewpoint,
    /// The free-fly camera is on.
    free: bool,
    /// `--azimuth`: look this way instead of the view's own direction, degrees clockwise from
    /// north (cleared when another view is picked).
    azimuth_deg: Option<f32>,
}

/// The terrain, kept on the CPU to put cameras on it.
#[derive(Resource)]
struct Terrain {
    plane: TangentPlane,
    mesh: Option<TerrainMesh>,
    /// Why there is no mesh.
    error: Option<String>,
}

/// How far below the summit the ground must have fallen where the camera stands, metres.
const BROW_DROP_M: f32 = 8.0;
/// The farthest the camera walks from the summit to find the brow, metres.
const MAX_BROW_DISTANCE_M: f64 = 1_000.0;

/// The camera on a summit, looking along the view's azimuth.
///
/// It stands on the brow of the hill in the view direction (the first point where the ground
/// has fallen [`BROW_DROP_M`] below the top), with the eye [`EYE_HEIGHT_M`] above the ground:
/// from the top itself, the rounded summit (the terrain pins it with a flat quad some 250 m
/// across) hides the valley below, just as it would hide Bern from a walker on the Gurten's top.
fn viewpoint_transform(view: &ViewState, terrain: &Terrain) -> Transform {
    let summit = view.viewpoint.summit();
    let [x, _, z] = terrain
        .plane
        .to_scene(summit.latitude_deg, summit.longitude_deg, 0.0);
    let azimuth = view
        .azimuth_deg
        .unwrap_or(view.viewpoint.azimuth_deg())
        .to_radians();
    // +X east, −Z north.
    let ahead = Vec2::new(azimuth.sin(), -azimuth.cos()).as_dvec2();
    let (position, ground) = match &terrain.mesh {
        Some(mesh) => {
            let top = mesh.height_at_scene(x, z).unwrap_or(summit.altitude_m);
            (0..=(MAX_BROW_DISTANCE_M / 25.0) as u32)
                .map(|step| {
                    let p = DVec2::new(x, z) + ahead * f64::from(step) * 25.0;
                    (p, mesh.height_at_scene(p.x, p.y))
                })
                .find_map(|(p, h)| h.filter(|h| *h <= top - BROW_DROP_M).map(|h| (p, h)))
                .unwrap_or((DVec2::new(x, z), top))
        }
        // On flat fallback ground the camera keeps the summit's height, so the view stays
        // alike.
        None => (DVec2::new(x, z), summit.altitude_m),
    };
    let pitch = PITCH_DEG.to_radians();
    let forward = Vec3::new(
        azimuth.sin() * pitch.cos(),
        pitch.sin(),
        -azimuth.cos() * pitch.cos(),
    );
    Transform::from_xyz(position.x as f32, ground + EYE_HEIGHT_M, position.y as f32)
        .looking_to(forward, Vec3::Y)
}

// ---------------------------------------------------------------------------------------------
// Scene

fn terrain_settings() -> TerrainSettings {
    TerrainSettings::default()
}

/// Reads the DEM and builds the terrain mesh; a failure is logged and leaves flat ground.
fn load_terrain(mut commands: Commands, options: Res<BernOptions>) {
    let origin = GeoOrigin::default();
    let plane = TangentPlane::new(
        origin.latitude_deg,
        origin.longitude_deg,
        origin.elevation_m,
    );
    let started = Instant::now();
    let built = Dem::from_path(&options.dem)
        .map_err(|e| e.to_string())
        .and_then(|dem| {
            TerrainMesh::build(&dem, &plane, &terrain_settings())
                .map_err(|e| format!("{}: {e}", options.dem.display()))
        });
    let (mesh, error) = match built {
        Ok(mesh) => {
            info!(
                "terrain: {} triangles, {} water triangles, built in {:.2} s",
                mesh.triangle_count(),
                mesh.stats.water_triangles,
                started.elapsed().as_secs_f64()
            );
            (Some(mesh), None)
        }
        Err(e) => {
            error!("cannot use the terrain: {e}; showing flat ground at {BERN_GROUND_M} m");
            (None, Some(e))
        }
    };
    commands.insert_resource(Terrain { plane, mesh, error });
}

/// Handles of both far forecasts, so switching views swaps them without reloading.
#[derive(Resource)]
struct FarForecasts([Handle<Forecast>; 2]);

fn spawn_scene(
    mut commands: Commands,
    asset_server: Res<AssetServer>,
    terrain: Res<Terrain>,
    view: Res<ViewState>,
    options: Res<BernOptions>,
    mut meshes: ResMut<Assets<Mesh>>,
    mut materials: ResMut<Assets<StandardMaterial>>,
    mut media: ResMut<Assets<ScatteringMedium>>,
) {
    // The planet's centre defaults to one radius below the origin: scene y is height above sea
    // level, as for the terrain.
    commands.spawn((
        Name::new("atmosphere"),
        Atmosphere::earth(media.add(ScatteringMedium::earth(256, 256))),
    ));
    // Sunlight above the air; the crate aims it and the atmosphere attenuates it.
    commands.spawn((
        Name::new("sun"),
        DirectionalLight {
            illuminance: lux::RAW_SUNLIGHT,
            ..default()
        },
        Sun::default(),
    ));
    spawn_ground(&mut commands, &terrain, &mut meshes, &mut materials);

    // The layers' altitudes count from Bern's ground, on the terrain's planet, which curves
    // around the scene origin.
    commands.insert_resource(CloudWorld {
        ground_height_m: BERN_GROUND_M,
        planet_radius_m: terrain_settings()
            .planet_radius_m
            .unwrap_or(CloudWorld::EARTH.planet_radius_m as f64) as f32,
        anchor: PlanetAnchor::Geocentric,
        ..default()
    });
    let camera = commands
        .spawn((
            Name::new("camera"),
            Camera3d::default(),
            Projection::Perspective(PerspectiveProjection {
                fov: FOV_DEG.to_radians(),
                ..default()
            }),
            viewpoint_transform(&view, &terrain),
            AtmosphereSettings {
                // The terrain reaches 60 km (the Alps); haze it all the way, not only the
                // default 32 km.
                aerial_view_lut_max_distance: 60_000.0,
                ..default()
            },
            AtmosphereEnvironmentMapLight::default(),
            Exposure {
                ev100: options.ev100,
            },
            Tonemapping::AcesFitted,
            Bloom::NATURAL,
            VolumetricClouds::MEDIUM,
            MainCamera,
            // Headless, the camera renders to an image: UI goes there too.
            IsDefaultUiCamera,
        ))
        .id();
    if !options.clouds {
        // The depth prepass and HDR that `VolumetricClouds` brought stay: only the clouds go.
        commands.entity(camera).remove::<VolumetricClouds>();
    }
    if let Some(error) = &terrain.error {
        commands.spawn((
            Node {
                position_type: PositionType::Absolute,
                top: px(8),
                left: px(8),
                right: px(8),
                padding: UiRect::all(px(6)),
                ..default()
            },
            BackgroundColor(Color::srgba(0.3, 0.0, 0.0, 0.7)),
            Text::new(format!(
                "Terrain unavailable: {error}\nShowing flat ground at {BERN_GROUND_M} m."
            )),
            TextFont {
                font_size: FontSize::Px(14.0),
                ..default()
            },
            TextColor(Color::WHITE),
            UiTargetCamera(camera),
        ));
    }

    let far: [Handle<Forecast>; 2] =
        Viewpoint::ALL.map(|viewpoint| asset_server.load(viewpoint.far_forecast()));
    commands.insert_resource(WeatherSource::load(
        &asset_server,
        NEAR_FORECAST,
        [view.viewpoint.far_forecast().into()],
    ));
    commands.insert_resource(FarForecasts(far));
    spawn_weather_layers(&mut commands);
}

fn spawn_ground(
    commands: &mut Commands,
    terrain: &Terrain,
    meshes: &mut Assets<Mesh>,
    materials: &mut Assets<StandardMaterial>,
) {
    let Some(mesh) = &terrain.mesh else {
        commands.spawn((
            Name::new("flat ground"),
            Mesh3d(meshes.add(Plane3d::default().mesh().size(120_000.0, 120_000.0))),
            MeshMaterial3d(materials.add(StandardMaterial {
                base_color: Color::srgb(0.25, 0.35, 0.18),
                perceptual_roughness: 0.9,
                ..default()
            })),
            Transform::from_xyz(0.0, BERN_GROUND_M, 0.0),
        ));
        return;
    };
    // The crate's mesh arrays are Bevy's attributes as they are; its colours are linear RGBA,
    // which is what Bevy expects of vertex colours.
    let ground = Mesh::new(
        PrimitiveTopology::TriangleList,
        RenderAssetUsages::RENDER_WORLD,
    )
    .with_inserted_attribute(Mesh::ATTRIBUTE_POSITION, mesh.positions.clone())
    .with_inserted_attribute(Mesh::ATTRIBUTE_NORMAL, mesh.normals.clone())
    .with_inserted_attribute(Mesh::ATTRIBUTE_COLOR, mesh.colors.clone())
    .with_inserted_indices(Indices::U32(mesh.indices.clone()));
    commands.spawn((
        Name::new("terrain"),
        Mesh3d(meshes.add(ground)),
        MeshMaterial3d(materials.add(StandardMaterial {
            // White, so the vertex colours are the albedo.
            base_color: Color::WHITE,
            perceptual_roughness: 0.9,
            ..default()
        })),
    ));
    let water = &mesh.water;
    if water.indices.is_empty() {
        return;
    }
    let surface = Mesh::new(
        PrimitiveTopology::TriangleList,
        RenderAssetUsages::RENDER_WORLD,
    )
    .with_inserted_attribute(Mesh::ATTRIBUTE_POSITION, water.positions.clone())
    .with_inserted_attribute(Mesh::ATTRIBUTE_NORMAL, water.normals.clone())
    .with_inserted_indices(Indices::U32(water.indices.clone()));
    commands.spawn((
        Name::new("lakes"),
        Mesh3d(meshes.add(surface)),
        MeshMaterial3d(materials.add(StandardMaterial {
            base_color: Color::srgb(0.03, 0.09, 0.16),
            perceptual_roughness: 0.12,
            ..default()
        })),
    ));
}

// ---------------------------------------------------------------------------------------------
// Views and the clock

/// Whether an egui widget has the keyboard (then the scene's keys stay quiet).
#[derive(Resource, Default, PartialEq)]
struct UiCapturesKeyboard(bool);

fn view_keys(
    keys: Res<ButtonInput<KeyCode>>,
    captured: Res<UiCapturesKeyboard>,
    mut view: ResMut<ViewState>,
) {
    if captured.0 {
        return;
    }
    let mut next = *view;
    if keys.just_pressed(KeyCode::Digit1) {
        next = ViewState {
            viewpoint: Viewpoint::Gurten,
            free: false,
            azimuth_deg: None,
        };
    }
    if keys.just_pressed(KeyCode::Digit2) {
        next = ViewState {
            viewpoint: Viewpoint::Bantiger,
            free: false,
            azimuth_deg: None,
        };
    }
    if keys.just_pressed(KeyCode::KeyF) {
        next.free = !next.free;
    }
    view.set_if_neq(next);
}

/// Puts the camera on its summit (or hands it to the free-fly controller) and swaps the far
/// forecast, whenever the view changes.
fn apply_view(
    mut commands: Commands,
    view: Res<ViewState>,
    terrain: Res<Terrain>,
    far: Res<FarForecasts>,
    mut source: ResMut<WeatherSource>,
    mut cameras: Query<(Entity, &mut Transform, Option<&mut VolumetricClouds>), With<MainCamera>>,
) {
    if !view.is_changed() {
        return;
    }
    let index = Viewpoint::ALL
        .iter()
        .position(|v| *v == view.viewpoint)
        .unwrap_or(0);
    source.far = vec![FarForecast {
        forecast: far.0[index].clone(),
    }];
    for (camera, mut transform, clouds) in &mut cameras {
        // Another viewpoint (or the free camera's start) is a camera cut: the clouds'
        // temporal accumulation starts over instead of fading the old view out.
        if let Some(mut clouds) = clouds {
            clouds.reset_history = true;
        }
        if view.free {
            // Metres per second: the scene is 100 km across.
            commands.entity(camera).insert(FreeCamera {
                walk_speed: 100.0,
                run_speed: 1500.0,
                ..default()
            });
        } else {
            // Removing the state too makes the controller start from the new pose next time.
            commands
                .entity(camera)
                .remove::<(FreeCamera, FreeCameraState)>();
            *transform = viewpoint_transform(&view, &terrain);
        }
    }
}

fn clock_keys(
    keys: Res<ButtonInput<KeyCode>>,
    captured: Res<UiCapturesKeyboard>,
    mut clock: ResMut<SceneClock>,
) {
    if captured.0 {
        return;
    }
    if keys.just_pressed(KeyCode::Space) {
        if clock.mode == ClockMode::WallClock {
            // Pausing the wall clock means holding the current instant.
            let now = clock.unix_seconds();
            clock.set_unix_seconds(now);
            clock.paused = true;
        } else {
            clock.paused = !clock.paused;
        }
    }
    let faster = keys.any_just_pressed([KeyCode::Equal, KeyCode::NumpadAdd]);
    let slower = keys.any_just_pressed([KeyCode::Minus, KeyCode::NumpadSubtract]);
    if faster || slower {
        let current = CLOCK_SPEEDS
            .iter()
            .position(|s| *s >= clock.speed)
            .unwrap_or(CLOCK_SPEEDS.len() - 1);
        let next = if faster {
            (current + 1).min(CLOCK_SPEEDS.len() - 1)
        } else {
            current.saturating_sub(1)
        };
        clock.speed = CLOCK_SPEEDS[next];
    }
    for (key, hours) in [(KeyCode::ArrowLeft, -1.0), (KeyCode::ArrowRight, 1.0)] {
        if keys.just_pressed(key) {
            let t = clock.unix_seconds() + hours * 3600.0;
            clock.set_unix_seconds(t);
        }
    }
}

/// The near forecast, once loaded.
fn near_forecast<'a>(
    source: &WeatherSource,
    forecasts: &'a Assets<Forecast>,
) -> Option<&'a Forecast> {
    source.near.as_ref().and_then(|h| forecasts.get(h))
}

/// The scene time in the forecast's local time and in UTC, e.g.
/// `2021-05-03 16:00 CEST (14:00 UTC)`.
fn time_label(unix_seconds: f64, forecast: Option<&Forecast>) -> String {
    let instant = UtcInstant::from_unix_seconds(unix_seconds.floor() as i64);
    let utc = instant.to_civil();
    let Some(forecast) = forecast.filter(|f| f.utc_offset_s != 0) else {
        return format!(
            "{:04}-{:02}-{:02} {:02}:{:02} UTC",
            utc.year, utc.month, utc.day, utc.hour, utc.minute
        );
    };
    let local = instant
        .saturating_add_seconds(i64::from(forecast.utc_offset_s))
        .to_civil();
    let zone = forecast
        .timezone_abbreviation
        .clone()
        .unwrap_or_else(|| format!("UTC{:+}", f64::from(forecast.utc_offset_s) / 3600.0));
    format!(
        "{:04}-{:02}-{:02} {:02}:{:02} {zone} ({:02}:{:02} UTC)",
        local.year, local.month, local.day, local.hour, local.minute, utc.hour, utc.minute
    )
}

/// One line of what a forecast says now: cover per band, precipitation, wind.
fn weather_label(state: &WeatherState) -> String {
    let percent = |v: Option<f32>| v.map_or("-".into(), |v| format!("{:.0}%", v * 100.0));
    let number = |v: Option<f32>, digits: usize| v.map_or("-".into(), |v| format!("{v:.digits$}"));
    format!(
        "low {} mid {} high {}, rain {} mm/h, wind {} m/s from {} deg",
        percent(state.low_cover()),
        percent(state.mid_cover()),
        percent(state.high_cover()),
        number(state.precipitation_mm_per_h(), 1),
        number(state.wind_speed_m_s(), 1),
        number(state.wind_direction_deg(), 0),
    )
}

fn clock_label(clock: &SceneClock) -> String {
    match clock.mode {
        ClockMode::WallClock => "live (wall clock)".into(),
        ClockMode::Manual if clock.paused => "paused".into(),
        ClockMode::Manual => format!("x{}", clock.speed),
    }
}

#[cfg(not(feature = "inspector"))]
#[derive(Component)]
struct HelpText;

/// The keys and the scene state in a corner (the inspector feature has egui panels instead).
#[cfg(not(feature = "inspector"))]
fn spawn_help_overlay(mut commands: Commands) {
    commands.spawn((
        Node {
            position_type: PositionType::Absolute,
            left: px(8),
            bottom: px(8),
            padding: UiRect::all(px(6)),
            ..default()
        },
        BackgroundColor(Color::srgba(0.0, 0.0, 0.0, 0.45)),
        Text::default(),
        TextFont {
            font_size: FontSize::Px(14.0),
            ..default()
        },
        TextColor(Color::WHITE),
        HelpText,
    ));
}

#[cfg(not(feature = "inspector"))]
fn update_help_overlay(
    clock: Res<SceneClock>,
    view: Res<ViewState>,
    source: Res<WeatherSource>,
    forecasts: Res<Assets<Forecast>>,
    current: Res<CurrentWeather>,
    overlay: Res<PhotoOverlay>,
    mut text: Single<&mut Text, With<HelpText>>,
) {
    let forecast = near_forecast(&source, &forecasts);
    let mut lines = vec![format!(
        "{} view -> {}{}   {}   {}",
        view.viewpoint.name(),
        view.viewpoint.far_place(),
        if view.free { " (free camera)" } else { "" },
        time_label(clock.unix_seconds(), forecast),
        clock_label(&clock),
    )];
    for place in current.near.iter().chain(current.far.iter().flatten()) {
        lines.push(format!(
            "{}: {}",
            place.place.name,
            weather_label(&place.state)
        ));
    }
    if !overlay.status.is_empty() {
        lines.push(format!("photo: {}", overlay.status));
    }
    lines.push(
        "1 Gurten  2 Bantiger  F free camera (WASD QE, right mouse looks)  \
         Space pause  +/- speed  Left/Right -/+1 h  P photo  [ ] wiper"
            .into(),
    );
    let content = lines.join("\n");
    if text.0 != content {
        text.0 = content;
    }
}

// ---------------------------------------------------------------------------------------------
// Headless

/// Each time-lapse image shows `--time` plus `--step` per image.
fn follow_headless_shots(
    progress: Res<HeadlessProgress>,
    options: Res<BernOptions>,
    mut clock: ResMut<SceneClock>,
) {
    let offset_s = options.step_s.saturating_mul(i64::from(progress.shot));
    let t = options.time.saturating_add_seconds(offset_s).unix_seconds() as f64;
    if clock.unix_seconds() != t {
        clock.set_unix_seconds(t);
    }
}

/// Holds the capture until the forecasts have loaded (or failed: then the frame shows what the
/// layers have, and the log says why).
fn wait_for_forecasts(
    mut progress: ResMut<HeadlessProgress>,
    source: Res<WeatherSource>,
    server: Res<AssetServer>,
) {
    if progress.ready {
        return;
    }
    let settled = |handle: &Handle<Forecast>| {
        matches!(
            server.load_state(handle.id()),
            LoadState::Loaded | LoadState::Failed(_)
        )
    };
    if source.near.iter().all(settled) && source.far.iter().all(|far| settled(&far.forecast)) {
        progress.ready = true;
    }
}

// ---------------------------------------------------------------------------------------------
// Photo overlay (Thomann 2021 §7.3)

/// Photos found under `--photos`, per viewpoint, sorted by time.
#[derive(Resource, Default)]
struct Photos {
    by_view: [Vec<(UtcInstant, PathBuf)>; 2],
    /// Where each view's photos are looked for.
    folders: [PathBuf; 2],
    /// What was found, for the panel.
    summary: String,
}

/// How the photo overlay is drawn.
#[derive(Resource, Debug, Clone)]
struct PhotoOverlay {
    visible: bool,
    /// 0 (transparent) to 1.
    opacity: f32,
    /// Fraction of the view's width, from the left, that shows the photo.
    wiper: f32,
    /// The photo loaded now.
    shown: Option<PathBuf>,
    shown_size: Vec2,
    /// What the overlay shows, or why it shows nothing.
    status: String,
}

impl Default for PhotoOverlay {
    fn default() -> Self {
        Self {
            visible: false,
            opacity: 0.5,
            wiper: 1.0,
            shown: None,
            shown_size: Vec2::ONE,
            status: String::new(),
        }
    }
}

#[derive(Component)]
struct PhotoNode;

/// Reads `DIR/<view>/YYYY-MM-DDTHH-MM.jpg` names; anything else in the folders is ignored.
fn scan_photos(dir: &Path) -> Photos {
    let mut photos = Photos::default();
    if !dir.is_dir() {
        photos.summary = format!("no photo folder {}", dir.display());
        return photos;
    }
    let mut summary = Vec::new();
    for (index, viewpoint) in Viewpoint::ALL.into_iter().enumerate() {
        let folder = dir.join(viewpoint.key());
        photos.folders[index].clone_from(&folder);
        let Ok(entries) = std::fs::read_dir(&folder) else {
            summary.push(format!("no folder {}", folder.display()));
            continue;
        };
        let list = &mut photos.by_view[index];
        list.extend(entries.flatten().filter_map(|entry| {
            let path = entry.path();
            let extension = path.extension()?.to_str()?.to_ascii_lowercase();
            if !matches!(extension.as_str(), "jpg" | "jpeg" | "png") {
                return None;
            }
            Some((photo_time(path.file_stem()?.to_str()?)?, path))
        }));
        list.sort();
        summary.push(format!("{}: {} photos", viewpoint.key(), list.len()));
    }
    photos.summary = summary.join(", ");
    photos
}

/// `2021-05-03T14-00` (UTC; colons are not allowed in file names everywhere).
fn photo_time(stem: &str) -> Option<UtcInstant> {
    let (date, time) = stem.split_once(['T', 't'])?;
    let mut date = date.split('-').map(str::parse::<u32>);
    let mut time = time.split('-').map(str::parse::<u8>);
    let (year, month, day) = (date.next()?.ok()?, date.next()?.ok()?, date.next()?.ok()?);
    let (hour, minute) = (time.next()?.ok()?, time.next()?.ok()?);
    let second = time.next().and_then(Result::ok).unwrap_or(0);
    UtcInstant::from_civil(
        i32::try_from(year).ok()?,
        u8::try_from(month).ok()?,
        u8::try_from(day).ok()?,
        hour,
        minute,
        second,
    )
}

fn spawn_photo_overlay(
    mut commands: Commands,
    options: Res<BernOptions>,
    mut overlay: ResMut<PhotoOverlay>,
) {
    let Some(dir) = &options.photos else {
        return;
    };
    let photos = scan_photos(dir);
    info!("photos: {}", photos.summary);
    overlay.status.clone_from(&photos.summary);
    commands.insert_resource(photos);
    commands.spawn((
        Node {
            position_type: PositionType::Absolute,
            left: px(0),
            top: px(0),
            width: percent(100),
            height: percent(100),
            ..default()
        },
        ImageNode::default(),
        Visibility::Hidden,
        PhotoNode,
    ));
}

fn photo_keys(
    keys: Res<ButtonInput<KeyCode>>,
    captured: Res<UiCapturesKeyboard>,
    mut overlay: ResMut<PhotoOverlay>,
) {
    if captured.0 {
        return;
    }
    if keys.just_pressed(KeyCode::KeyP) {
        overlay.visible = !overlay.visible;
    }
    for (key, step) in [(KeyCode::BracketLeft, -0.1), (KeyCode::BracketRight, 0.1)] {
        if keys.just_pressed(key) {
            overlay.wiper = (overlay.wiper + step).clamp(0.0, 1.0);
        }
    }
}

fn load_photo(path: &Path) -> Result<Image, String> {
    let bytes = std::fs::read(path).map_err(|e| format!("{}: {e}", path.display()))?;
    let extension = path
        .extension()
        .and_then(|e| e.to_str())
        .unwrap_or_default();
    Image::from_buffer(
        &bytes,
        ImageType::Extension(extension),
        CompressedImageFormats::NONE,
        true,
        ImageSampler::Default,
        RenderAssetUsages::RENDER_WORLD,
    )
    .map_err(|e| format!("{}: {e}", path.display()))
}

/// Shows the photo of the current view nearest to the scene time.
fn update_photo_overlay(
    clock: Res<SceneClock>,
    view: Res<ViewState>,
    photos: Option<Res<Photos>>,
    mut overlay: ResMut<PhotoOverlay>,
    mut images: ResMut<Assets<Image>>,
    node: Option<Single<(&mut ImageNode, &mut Node, &mut Visibility), With<PhotoNode>>>,
) {
    let (Some(photos), Some(node)) = (photos, node) else {
        return;
    };
    let (mut image_node, mut layout, mut visibility) = node.into_inner();
    let index = Viewpoint::ALL
        .iter()
        .position(|v| *v == view.viewpoint)
        .unwrap_or(0);
    let now = clock.unix_seconds() as i64;
    let nearest = photos.by_view[index]
        .iter()
        .min_by_key(|(time, _)| (time.unix_seconds() - now).abs());
    let mut status = String::new();
    let mut show = false;
    match nearest {
        None if photos.by_view.iter().all(Vec::is_empty) => status.clone_from(&photos.summary),
        None => {
            status = format!(
                "no photos named like 2021-05-03T14-00.jpg in {}",
                photos.folders[index].display()
            );
        }
        Some((time, path)) => {
            if overlay.shown.as_ref() != Some(path) {
                overlay.shown = Some(path.clone());
                match load_photo(path) {
                    Ok(image) => {
                        overlay.shown_size = image.size_f32();
                        image_node.image = images.add(image);
                    }
                    Err(e) => {
                        warn!("photo overlay: {e}");
                        image_node.image = Handle::default();
                        overlay.shown_size = Vec2::ZERO;
                    }
                }
            }
            if overlay.shown_size == Vec2::ZERO {
                status = format!("cannot read {}", path.display());
            } else {
                show = overlay.visible;
                let minutes = (time.unix_seconds() - now) as f64 / 60.0;
                status = format!(
                    "{} ({minutes:+.0} min from the scene time)",
                    path.file_name().unwrap_or_default().to_string_lossy()
                );
            }
        }
    }
    if overlay.status != status {
        overlay.status = status;
    }
    // The wiper crops the photo and its node together, so the photo stays registered with the
    // view underneath.
    let wiper = overlay.wiper.clamp(0.0, 1.0);
    let rect = Rect::new(0.0, 0.0, overlay.shown_size.x * wiper, overlay.shown_size.y);
    let color = Color::srgba(1.0, 1.0, 1.0, overlay.opacity.clamp(0.0, 1.0));
    if image_node.rect != Some(rect) || image_node.color != color {
        image_node.rect = Some(rect);
        image_node.color = color;
    }
    layout.width = percent(wiper * 100.0);
    visibility.set_if_neq(if show && wiper > 0.0 {
        Visibility::Inherited
    } else {
        Visibility::Hidden
    });
}

// ---------------------------------------------------------------------------------------------
// egui panels

#[cfg(feature = "inspector")]
mod panel {
    //! The live/play window (Thomann 2021's requirements, §2.4 UI mock-ups), performance numbers,
    //! the photo overlay's settings, and an inspector for the layers and the camera's clouds.

    use bevy::{
        diagnostic::{DiagnosticsStore, FrameTimeDiagnosticsPlugin},
        ecs::component::Mutable,
        render::diagnostic::RenderDiagnosticsPlugin,
    };
    use bevy_cloudscape::weather::{Variable, WeatherMapping};
    use bevy_egui::{
        EguiContext, EguiContexts, EguiPlugin, EguiPrimaryContextPass, PrimaryEguiContext, egui,
    };
    use bevy_inspector_egui::{DefaultInspectorConfigPlugin, bevy_inspector};

    use super::*;

    pub struct PanelPlugin;

    impl Plugin for PanelPlugin {
        fn build(&self, app: &mut App) {
            app.add_plugins((
                EguiPlugin::default(),
                DefaultInspectorConfigPlugin,
                FrameTimeDiagnosticsPlugin::default(),
                RenderDiagnosticsPlugin,
            ))
            .init_resource::<PanelState>()
            .add_systems(
                EguiPrimaryContextPass,
                (control_window, inspector_window).chain(),
            )
            .add_systems(Update, drive_play_layers.after(CloudscapeSystems::Layers));
        }
    }

    /// Live: the forecasts drive the layers. Play: the sliders do.
    #[derive(Clone, Copy, Debug, PartialEq, Eq, Default)]
    enum Mode {
        #[default]
        Live,
        Play,
    }

    /// The play mode's weather, in forecast units.
    #[derive(Clone, Debug, PartialEq)]
    struct PlayWeather {
        low_cover: f32,
        mid_cover: f32,
        high_cover: f32,
        precipitation_mm_per_h: f32,
        /// The precipitation falls as showers (convective), which brings cumulonimbus.
        showers: bool,
        wind_speed_m_s: f32,
        /// Where the wind blows from, degrees clockwise from north.
        wind_from_deg: f32,
    }

    impl Default for PlayWeather {
        fn default() -> Self {
            Self {
                low_cover: 0.4,
                mid_cover: 0.0,
                high_cover: 0.2,
                precipitation_mm_per_h: 0.0,
                showers: false,
                wind_speed_m_s: 3.0,
                wind_from_deg: 270.0,
            }
        }
    }

    impl PlayWeather {
        /// Starts from what the forecast says now, so switching to play changes nothing yet.
        fn from_state(state: &WeatherState) -> Self {
            let fallback = Self::default();
            Self {
                low_cover: state.low_cover().unwrap_or(fallback.low_cover),
                mid_cover: state.mid_cover().unwrap_or(fallback.mid_cover),
                high_cover: state.high_cover().unwrap_or(fallback.high_cover),
                precipitation_mm_per_h: state.precipitation_mm_per_h().unwrap_or(0.0),
                showers: state
                    .get(Variable::ConvectivePrecipitation)
                    .is_some_and(|v| v > 0.0),
                wind_speed_m_s: state.wind_speed_m_s().unwrap_or(fallback.wind_speed_m_s),
                wind_from_deg: state.wind_direction_deg().unwrap_or(fallback.wind_from_deg),
            }
        }

        /// A forecast state holding these values.
        fn to_state(&self, time: UtcInstant) -> WeatherState {
            let mut state = WeatherState::empty(time);
            let convective = if self.showers {
                self.precipitation_mm_per_h
            } else {
                0.0
            };
            for (variable, value) in [
                (Variable::LowCover, self.low_cover),
                (Variable::MidCover, self.mid_cover),
                (Variable::HighCover, self.high_cover),
                (
                    Variable::TotalCover,
                    self.low_cover.max(self.mid_cover).max(self.high_cover),
                ),
                (Variable::Precipitation, self.precipitation_mm_per_h),
                (Variable::ConvectivePrecipitation, convective),
                (Variable::WindSpeed, self.wind_speed_m_s),
                (
                    Variable::WindDirection,
                    self.wind_from_deg.rem_euclid(360.0),
                ),
            ] {
                state.values[variable as usize] = Some(value);
            }
            state
        }
    }

    #[derive(Resource, Default)]
    struct PanelState {
        mode: Mode,
        play: PlayWeather,
    }

    fn control_window(
        mut contexts: EguiContexts,
        mut panel: ResMut<PanelState>,
        mut clock: ResMut<SceneClock>,
        mut view: ResMut<ViewState>,
        mut overlay: ResMut<PhotoOverlay>,
        mut captured: ResMut<UiCapturesKeyboard>,
        mut layers: Query<&mut CloudLayer, With<LayerSlot>>,
        options: Res<BernOptions>,
        source: Res<WeatherSource>,
        forecasts: Res<Assets<Forecast>>,
        current: Res<CurrentWeather>,
        diagnostics: Res<DiagnosticsStore>,
    ) -> Result {
        let ctx = contexts.ctx_mut()?;
        let forecast = near_forecast(&source, &forecasts);
        egui::Window::new("Bern")
            .default_pos([12.0, 12.0])
            .show(ctx, |ui| {
                ui.spacing_mut().slider_width = 220.0;
                let mut next_view = *view;
                ui.horizontal(|ui| {
                    ui.label("View:");
                    for viewpoint in Viewpoint::ALL {
                        let label = format!("{} -> {}", viewpoint.name(), viewpoint.far_place());
                        if ui
                            .selectable_label(
                                next_view.viewpoint == viewpoint && !next_view.free,
                                label,
                            )
                            .clicked()
                        {
                            next_view = ViewState {
                                viewpoint,
                                free: false,
                                azimuth_deg: None,
                            };
                        }
                    }
                    ui.checkbox(&mut next_view.free, "free camera (F)");
                });
                view.set_if_neq(next_view);
                ui.separator();

                let mut mode = panel.mode;
                ui.horizontal(|ui| {
                    ui.selectable_value(&mut mode, Mode::Live, "Live");
                    ui.selectable_value(&mut mode, Mode::Play, "Play");
                });
                if mode != panel.mode {
                    switch_mode(&mut panel, mode, &current, &mut layers);
                }
                ui.label(time_label(clock.unix_seconds(), forecast));
                match panel.mode {
                    Mode::Live => live_controls(ui, &mut clock, forecast, &current),
                    Mode::Play => {
                        let mut play = panel.play.clone();
                        play_controls(ui, &mut play, &mut clock, forecast);
                        if play != panel.play {
                            panel.play = play;
                        }
                    }
                }
                ui.separator();

                if options.photos.is_some() {
                    let mut settings = overlay.clone();
                    ui.horizontal(|ui| {
                        ui.checkbox(&mut settings.visible, "photo overlay");
                        ui.add(egui::Slider::new(&mut settings.opacity, 0.0..=1.0).text("opacity"));
                    });
                    ui.add(egui::Slider::new(&mut settings.wiper, 0.0..=1.0).text("wiper"));
                    ui.label(&settings.status);
                    if settings.visible != overlay.visible
                        || settings.opacity != overlay.opacity
                        || settings.wiper != overlay.wiper
                    {
                        *overlay = settings;
                    }
                    ui.separator();
                }

                let fps = diagnostics
                    .get(&FrameTimeDiagnosticsPlugin::FPS)
                    .and_then(|fps| fps.smoothed());
                ui.label(fps.map_or("FPS: -".into(), |fps| format!("FPS: {fps:.1}")));
                // The cloud passes time themselves ("cloud_march", "cloud_noise"); GPU times
                // appear where the device has timestamp queries.
                for diagnostic in diagnostics.iter() {
                    let path = diagnostic.path().as_str();
                    if path.starts_with("render/cloud")
                        && let Some(value) = diagnostic.smoothed()
                    {
                        ui.label(format!("{path}: {value:.2} {}", diagnostic.suffix));
                    }
                }
            });
        captured.set_if_neq(UiCapturesKeyboard(ctx.egui_wants_keyboard_input()));
        Ok(())
    }

    /// Play mode takes the layers off the forecast; live mode gives them back.
    fn switch_mode(
        panel: &mut PanelState,
        mode: Mode,
        current: &CurrentWeather,
        layers: &mut Query<&mut CloudLayer, With<LayerSlot>>,
    ) {
        panel.mode = mode;
        if mode == Mode::Play
            && let Some(near) = &current.near
        {
            panel.play = PlayWeather::from_state(&near.state);
        }
        for mut layer in layers.iter_mut() {
            layer.weather_driven = mode == Mode::Live;
        }
    }

    fn live_controls(
        ui: &mut egui::Ui,
        clock: &mut SceneClock,
        forecast: Option<&Forecast>,
        current: &CurrentWeather,
    ) {
        if let Some((start, end)) = forecast.and_then(|f| Some((f.start()?, f.end()?))) {
            let (start, end) = (start.unix_seconds() as f64, end.unix_seconds() as f64);
            let mut t = clock.unix_seconds().clamp(start, end);
            let slider = egui::Slider::new(&mut t, start..=end)
                .show_value(false)
                .step_by(600.0)
                .text("forecast time");
            if ui.add(slider).changed() {
                clock.set_unix_seconds(t);
            }
        } else {
            ui.label("loading the forecast…");
        }
        ui.horizontal(|ui| {
            if ui.button("now").clicked() {
                clock.mode = ClockMode::WallClock;
            }
            let running = clock.mode == ClockMode::WallClock || !clock.paused;
            if ui.button(if running { "pause" } else { "play" }).clicked() {
                let t = clock.unix_seconds();
                clock.set_unix_seconds(t);
                clock.paused = running;
            }
            for speed in CLOCK_SPEEDS {
                if ui
                    .selectable_label(clock.speed == speed, format!("{speed}x"))
                    .clicked()
                {
                    clock.speed = speed;
                }
            }
            if clock.mode == ClockMode::WallClock {
                ui.label("live: the wall clock");
            }
        });
        for place in current.near.iter().chain(current.far.iter().flatten()) {
            ui.label(format!(
                "{}: {}",
                place.place.name,
                weather_label(&place.state)
            ));
        }
    }

    fn play_controls(
        ui: &mut egui::Ui,
        play: &mut PlayWeather,
        clock: &mut SceneClock,
        forecast: Option<&Forecast>,
    ) {
        ui.add(egui::Slider::new(&mut play.low_cover, 0.0..=1.0).text("low cover"));
        ui.add(egui::Slider::new(&mut play.mid_cover, 0.0..=1.0).text("mid cover"));
        ui.add(egui::Slider::new(&mut play.high_cover, 0.0..=1.0).text("high cover"));
        ui.add(
            egui::Slider::new(&mut play.precipitation_mm_per_h, 0.0..=20.0)
                .text("precipitation, mm/h"),
        );
        ui.checkbox(&mut play.showers, "as showers (cumulonimbus)");
        ui.add(egui::Slider::new(&mut play.wind_speed_m_s, 0.0..=30.0).text("wind, m/s"));
        ui.add(egui::Slider::new(&mut play.wind_from_deg, 0.0..=360.0).text("wind from, degrees"));
        // Time of day in the forecast's local time, on the scene's current date.
        let offset = forecast.map_or(0.0, |f| f64::from(f.utc_offset_s));
        let local = clock.unix_seconds() + offset;
        let midnight = local - local.rem_euclid(86_400.0);
        let mut hours = (local - midnight) / 3600.0;
        let slider = egui::Slider::new(&mut hours, 0.0..=23.99)
            .step_by(0.25)
            .text("time of day, h");
        if ui.add(slider).changed() {
            clock.set_unix_seconds(midnight + hours * 3600.0 - offset);
        }
        ui.horizontal(|ui| {
            let running = clock.mode == ClockMode::WallClock || !clock.paused;
            if ui.button(if running { "pause" } else { "play" }).clicked() {
                let t = clock.unix_seconds();
                clock.set_unix_seconds(t);
                clock.paused = running;
            }
            ui.label(clock_label(clock));
        });
    }

    /// In play mode, writes the sliders' weather onto the layers through the same mapping the
    /// forecasts go through, so a slider value looks like that forecast value would.
    fn drive_play_layers(
        panel: Res<PanelState>,
        clock: Res<SceneClock>,
        mapping: Option<Res<WeatherMapping>>,
        mut layers: Query<(&LayerSlot, &mut CloudLayer)>,
    ) {
        if panel.mode != Mode::Play {
            return;
        }
        let rules = mapping.map_or_else(WeatherMapping::default, |m| *m);
        let mapped = rules.map(&panel.play.to_state(clock.instant()), BERN_GROUND_M);
        for (slot, mut layer) in &mut layers {
            // `apply` leaves layers that are not weather-driven alone: map a driven copy.
            let mut updated = CloudLayer {
                weather_driven: true,
                ..layer.clone()
            };
            mapped.apply(*slot, &mut updated);
            updated.weather_driven = false;
            if updated != *layer {
                *layer = updated;
            }
        }
    }

    /// Every `CloudLayer` and the camera's `VolumetricClouds`, editable.
    fn inspector_window(world: &mut World) {
        let Ok(context) = world
            .query_filtered::<&mut EguiContext, With<PrimaryEguiContext>>()
            .single(world)
        else {
            return;
        };
        let mut context = context.clone();
        let layers: Vec<(Entity, String)> = world
            .query::<(Entity, &CloudLayer, Option<&Name>)>()
            .iter(world)
            .map(|(entity, layer, name)| {
                let name = name.map_or_else(|| format!("{entity}"), |n| n.to_string());
                (
                    entity,
                    format!("{name} ({}, {:.0}%)", layer.kind, layer.coverage * 100.0),
                )
            })
            .collect();
        let cameras: Vec<Entity> = world
            .query_filtered::<Entity, With<VolumetricClouds>>()
            .iter(world)
            .collect();
        let ctx = context.get_mut();
        let right = ctx.content_rect().right();
        egui::Window::new("Inspector")
            .default_open(false)
            .pivot(egui::Align2::RIGHT_TOP)
            .default_pos([right - 12.0, 12.0])
            .show(ctx, |ui| {
                egui::ScrollArea::vertical().show(ui, |ui| {
                    ui.label("Weather-driven layers are rewritten by the forecast; untick weather_driven to keep edits.");
                    for (entity, name) in &layers {
                        egui::CollapsingHeader::new(name)
                            .id_salt(entity)
                            .show(ui, |ui| edit_component::<CloudLayer>(world, *entity, ui));
                    }
                    for camera in &cameras {
                        egui::CollapsingHeader::new("camera: VolumetricClouds")
                            .id_salt(camera)
                            .show(ui, |ui| {
                                edit_component::<VolumetricClouds>(world, *camera, ui);
                            });
                    }
                });
            });
    }

    /// Edits one component through reflection, writing it back only when changed.
    fn edit_component<C: Component<Mutability = Mutable> + Reflect + Clone>(
        world: &mut World,
        entity: Entity,
        ui: &mut egui::Ui,
    ) {
        let Some(mut value) = world.get::<C>(entity).cloned() else {
            return;
        };
        if bevy_inspector::ui_for_value(&mut value, ui, world)
            && let Some(mut component) = world.get_mut::<C>(entity)
        {
            *component = value;
        }
    }
}
