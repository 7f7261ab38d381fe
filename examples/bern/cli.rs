//! The command line: clap options and what they mean for the demo.

use super::*;

/// What the command line asked for beyond [`ExampleArgs`].
#[derive(Resource, Debug, Clone)]
pub(crate) struct BernOptions {
    pub(crate) viewpoint: Viewpoint,
    /// Scene time at start-up (and of the first headless image).
    pub(crate) time: UtcInstant,
    /// Headless time-lapse length; `None` for a single image.
    pub(crate) shots: Option<u32>,
    /// Scene time between time-lapse images, seconds.
    pub(crate) step_s: i64,
    pub(crate) photos: Option<PathBuf>,
    pub(crate) photo_opacity: f32,
    pub(crate) photo_wiper: f32,
    pub(crate) dem: PathBuf,
    /// Camera exposure, EV100.
    pub(crate) ev100: f32,
    /// Cast cloud shadows on the terrain.
    pub(crate) cloud_shadows: bool,
    /// Whether the camera's sky light follows the clouds above it (`CloudSkyLight`).
    pub(crate) sky_light: bool,
    /// Log frame and render-pass times every second.
    pub(crate) log_frame_times: bool,
    /// Render clouds (false: the camera has no `VolumetricClouds`).
    pub(crate) clouds: bool,
    /// `--azimuth`: the view direction, degrees clockwise from north.
    pub(crate) azimuth_deg: Option<f32>,
    /// `--pitch`: the view's angle above the horizon, degrees (negative: down).
    pub(crate) pitch_deg: Option<f32>,
    /// `--fov`: the camera's vertical field of view, degrees.
    pub(crate) fov_deg: f32,
    /// `--growth`: the low clouds grow with the automaton (`CloudGrowth`).
    pub(crate) growth: bool,
    /// `--look`: the headless shots are the look board's views ([`look::BOARD`]).
    pub(crate) look: bool,
    /// `--live`: Open-Meteo forecasts, refreshed hourly, at the wall clock's time.
    pub(crate) live: bool,
    /// `--open-meteo-url`: where `--live` asks.
    #[cfg_attr(not(feature = "live"), allow(dead_code))]
    pub(crate) open_meteo_url: String,
}

/// The Bern demo; the flags are explained at the top of `examples/bern.rs`.
#[derive(clap::Parser)]
pub(crate) struct Cli {
    /// The viewpoint: gurten or bantiger.
    #[arg(long, default_value = "gurten")]
    pub(crate) camera: Viewpoint,
    /// The scene time at start-up, UTC (RFC 3339).
    #[arg(long, default_value = DEFAULT_TIME)]
    pub(crate) time: UtcInstant,
    /// Render without a window and write PNG images.
    #[arg(long)]
    pub(crate) headless: bool,
    /// Where the headless image goes [default: `bern.png`; a time-lapse: the folder `bern_frames`].
    #[arg(long)]
    pub(crate) out: Option<PathBuf>,
    /// Headless image width, pixels.
    #[arg(long, default_value_t = 1280, value_parser = clap::value_parser!(u32).range(1..))]
    pub(crate) width: u32,
    /// Headless image height, pixels.
    #[arg(long, default_value_t = 720, value_parser = clap::value_parser!(u32).range(1..))]
    pub(crate) height: u32,
    /// A headless time-lapse of this many images, `--step` apart.
    #[arg(long, value_parser = clap::value_parser!(u32).range(1..))]
    pub(crate) frames: Option<u32>,
    /// Scene time between time-lapse images: 30s, 10m, 2h or 1d (negative runs backwards).
    #[arg(long, default_value = "10m", value_parser = parse_duration_s, allow_hyphen_values = true)]
    pub(crate) step: i64,
    /// Frames before the first headless image.
    #[arg(long, default_value_t = DEFAULT_WARMUP, value_parser = clap::value_parser!(u32).range(1..))]
    pub(crate) warmup: u32,
    /// A folder of photos to compare with (`DIR/gurten/2021-05-03T14-00.jpg`, …).
    #[arg(long)]
    pub(crate) photos: Option<PathBuf>,
    /// Opacity of the photo over the view, 0 to 1.
    #[arg(long, default_value_t = 0.5, value_parser = parse_fraction)]
    pub(crate) photo_opacity: f32,
    /// Where the photo's wiper stands, 0 (left) to 1 (right).
    #[arg(long, default_value_t = 1.0, value_parser = parse_fraction)]
    pub(crate) photo_wiper: f32,
    /// An elevation model (ESRI ASCII grid or `GeoTIFF` in degrees) [default: the bundled one].
    #[arg(long)]
    pub(crate) dem: Option<PathBuf>,
    /// Camera exposure, EV100.
    #[arg(long, default_value_t = DEFAULT_EV100, value_parser = parse_finite, allow_hyphen_values = true)]
    pub(crate) ev100: f32,
    /// The view direction, degrees clockwise from north [default: the viewpoint's].
    #[arg(long, value_parser = parse_finite, allow_hyphen_values = true)]
    pub(crate) azimuth: Option<f32>,
    /// The view's angle above the horizon, degrees, −89 to 89 (negative: down) [default: the
    /// viewpoint's, a few degrees up].
    #[arg(long, value_parser = parse_pitch, allow_hyphen_values = true)]
    pub(crate) pitch: Option<f32>,
    /// The camera's vertical field of view, degrees, 0.5 to 120 (small: a telephoto, for the
    /// moon's phase).
    #[arg(long, default_value_t = FOV_DEG, value_parser = parse_fov)]
    pub(crate) fov: f32,
    /// No cloud shadows on the terrain.
    #[arg(long)]
    pub(crate) no_cloud_shadows: bool,
    /// No clouds (the camera has no `VolumetricClouds`).
    #[arg(long)]
    pub(crate) no_clouds: bool,
    /// The camera's sky light stays the clear sky's (`CloudSkyLight` off).
    #[arg(long)]
    pub(crate) no_sky_light: bool,
    /// Log frame and render-pass times every second.
    #[arg(long)]
    pub(crate) log_frame_times: bool,
    /// Grow the low clouds with the cloud-growth automaton (they form and dissolve as the
    /// forecast's low cover rises and falls).
    #[arg(long)]
    pub(crate) growth: bool,
    /// Render the look board (`docs/look.md`): nine views of the bundled week, one weather
    /// each, into the folder `--out` (`frame_000.png`, …) and tiled into `board.png` there.
    /// Headless only; `--camera`, `--time`, `--azimuth`, `--pitch`, `--ev100` and `--frames` are the
    /// board's.
    #[arg(long, conflicts_with_all = ["frames", "photos"])]
    pub(crate) look: bool,
    /// Live forecasts: Bern's and the far places' from Open-Meteo, downloaded now and refreshed
    /// hourly, with the scene time the wall clock's (`--time` is ignored). Needs the crate's
    /// `live` feature (`cargo run --features live --example bern -- --live`) and the internet.
    #[arg(long, conflicts_with_all = ["look", "frames"])]
    pub(crate) live: bool,
    /// With `--live`: the server with Open-Meteo's forecast API to ask (a self-hosted
    /// Open-Meteo, a test server).
    #[arg(
        long,
        default_value = "https://api.open-meteo.com/v1/forecast",
        requires = "live"
    )]
    pub(crate) open_meteo_url: String,
}

impl Cli {
    /// The capture settings and the demo's options the command line asks for.
    pub(crate) fn options(self) -> Result<(ExampleArgs, BernOptions), String> {
        if self.frames.is_some() && !self.headless {
            return Err("--frames makes a headless time-lapse: add --headless".into());
        }
        if self.live && !cfg!(feature = "live") {
            return Err("--live needs the crate's live feature: \
                 cargo run --features live --example bern -- --live"
                .into());
        }
        if self.look && !self.headless {
            return Err("--look renders the board headless: add --headless".into());
        }
        let default_out = if self.look {
            "look"
        } else if self.frames.is_some() {
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
            shots: if self.look {
                Some(look::BOARD.len() as u32)
            } else {
                self.frames
            },
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
            sky_light: !self.no_sky_light,
            log_frame_times: self.log_frame_times,
            clouds: !self.no_clouds,
            azimuth_deg: self.azimuth,
            pitch_deg: self.pitch,
            fov_deg: self.fov,
            growth: self.growth,
            look: self.look,
            live: self.live,
            open_meteo_url: self.open_meteo_url,
        };
        Ok((args, options))
    }
}

pub(crate) fn parse_finite(text: &str) -> Result<f32, String> {
    text.parse::<f32>()
        .ok()
        .filter(|x| x.is_finite())
        .ok_or_else(|| format!("{text:?} is not a number"))
}

pub(crate) fn parse_pitch(text: &str) -> Result<f32, String> {
    text.parse::<f32>()
        .ok()
        .filter(|x| (-89.0..=89.0).contains(x))
        .ok_or_else(|| format!("{text:?} is not an angle from -89 to 89 degrees"))
}

pub(crate) fn parse_fov(text: &str) -> Result<f32, String> {
    text.parse::<f32>()
        .ok()
        .filter(|x| (0.5..=120.0).contains(x))
        .ok_or_else(|| format!("{text:?} is not a field of view from 0.5 to 120 degrees"))
}

pub(crate) fn parse_fraction(text: &str) -> Result<f32, String> {
    text.parse::<f32>()
        .ok()
        .filter(|x| (0.0..=1.0).contains(x))
        .ok_or_else(|| format!("{text:?} is not a number from 0 to 1"))
}

/// `30s`, `10m`, `2h`, `1d` (optionally negative, to run backwards) in seconds.
pub(crate) fn parse_duration_s(text: &str) -> Result<i64, String> {
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
