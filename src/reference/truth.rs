//! The path-traced truth of heterogeneous cumulus (`validation/mitsuba/`): the scenes, the
//! crate's own density field that Mitsuba 3 renders, and the CPU twin's image of the same scenes
//! with any march settings. The library's tests compare the twin's converged march with it; the
//! `bench` example compares each preset's march.
//!
//! `cargo test --lib export_mitsuba_volumes -- --ignored` writes the grid and `scenes.json`;
//! `validation/.venv/bin/python validation/mitsuba/render_cumulus.py` renders them into the
//! committed `validation/mitsuba/<scene>.csv` (`validation/README.md`).

use std::sync::OnceLock;

use super::noise::NoiseRecipe;
use super::render::{CloudTextures, MarchLayer, MarchSettings, march_clouds};

/// The committed scene description and the folder of the renders, relative to the crate root.
pub const FOLDER: &str = "validation/mitsuba";
/// Image width of every scene, pixels.
pub const WIDTH: u32 = 32;
/// Image height of every scene, pixels.
pub const HEIGHT: u32 = 18;
/// Horizontal field of view, degrees.
pub const FOV_DEG: f64 = 50.0;
/// Sky radiance per unit sun irradiance, 1/sr (as in the DISORT decks): the sky behind the
/// clouds and the sky light on their tops.
pub const SKY: f64 = 0.05;

/// A scene: camera position and view direction (world, y up, metres), direction toward the sun.
#[derive(Clone, Copy, Debug)]
pub struct Scene {
    /// Name of the scene and of its committed image (`<name>.csv`).
    pub name: &'static str,
    /// Camera position, metres.
    pub camera: [f64; 3],
    /// Unit view direction.
    pub forward: [f64; 3],
    /// Unit direction toward the sun.
    pub sun: [f64; 3],
}

fn direction(elevation_deg: f64, toward: [f64; 2]) -> [f64; 3] {
    let e = elevation_deg.to_radians();
    [toward[0] * e.cos(), e.sin(), toward[1] * e.cos()]
}

/// The three scenes: noon cumulus from below and from above, and backlit near a low sun.
pub fn scenes() -> [Scene; 3] {
    [
        Scene {
            name: "below",
            camera: [0.0, 0.0, 0.0],
            forward: direction(70.0, [1.0, 0.0]),
            sun: direction(50.0, [0.0, -1.0]),
        },
        Scene {
            name: "above",
            camera: [0.0, 5_000.0, 0.0],
            forward: direction(-60.0, [1.0, 0.0]),
            sun: direction(50.0, [0.0, -1.0]),
        },
        Scene {
            name: "backlit",
            camera: [0.0, 0.0, 0.0],
            forward: direction(40.0, [0.0, -1.0]),
            sun: direction(20.0, [0.0, -1.0]),
        },
    ]
}

/// The noise the exported field was made from: the default recipe's channels at 16³, 8³ and
/// 32² (the march samples them exactly as it would the full-size ones, and a debug build makes
/// them in a blink).
pub fn textures() -> &'static CloudTextures {
    static TEXTURES: OnceLock<CloudTextures> = OnceLock::new();
    TEXTURES.get_or_init(|| {
        CloudTextures::from_recipe(&NoiseRecipe {
            base_size: 16,
            detail_size: 8,
            weather_size: 32,
            ..NoiseRecipe::default()
        })
    })
}

/// The cumulus: smooth shapes (no detail noise, which the 100 m grid cannot hold), 1.5–3 km.
pub fn cumulus() -> MarchLayer {
    MarchLayer {
        base_m: 1_500.0,
        top_m: 3_000.0,
        coverage: 0.55,
        extinction: 0.04,
        weather_scale_m: 12_000.0,
        shape_scale_m: 6_000.0,
        detail_erosion: 0.0,
        ..MarchLayer::default()
    }
}

/// `march` (the steps and the other knobs of a preset) in `scene`: a flat planet, the camera
/// altitude, the scene's sun at unit irradiance, the sky [`SKY`] above and black ground below.
pub fn in_scene(scene: &Scene, march: MarchSettings) -> MarchSettings {
    MarchSettings {
        planet_radius_m: 1e10,
        camera_altitude_m: scene.camera[1],
        sun_direction: scene.sun,
        sun_illuminance: [1.0; 3],
        ambient_top: [SKY; 3],
        ambient_bottom: [0.0; 3],
        ..march
    }
}

/// The validation's own march of `scene`: many steps, no early exit, no jitter.
pub fn converged_settings(scene: &Scene) -> MarchSettings {
    in_scene(
        scene,
        MarchSettings {
            primary_steps: 256,
            light_steps: 16,
            step_growth: 0.0,
            transmittance_cutoff: 0.0,
            jitter: false,
            ..MarchSettings::default()
        },
    )
}

/// Sub-pixel rays per axis of each pixel of [`crate_image`]: Mitsuba's film (a box filter)
/// averages each pixel's radiance over its whole area, which at 32 × 18 pixels holds the edges of
/// many clouds, so the twin's pixel is the mean over a stratified grid of this many rays squared.
pub const SUBPIXELS: u32 = 2;

/// The view ray through the point `(x, y)` of the image, in pixels from its top-left corner
/// (`(i + ½, j + ½)` is the centre of pixel `(i, j)`, row 0 at the top), as Mitsuba's `look_at`
/// camera with a horizontal field of view.
pub fn pixel_direction(scene: &Scene, x: f64, y: f64) -> [f64; 3] {
    let f = scene.forward;
    let norm = |v: [f64; 3]| {
        let length = (v[0] * v[0] + v[1] * v[1] + v[2] * v[2]).sqrt();
        v.map(|c| c / length)
    };
    let right = norm([-f[2], 0.0, f[0]]);
    let up = [
        right[1] * f[2] - right[2] * f[1],
        right[2] * f[0] - right[0] * f[2],
        right[0] * f[1] - right[1] * f[0],
    ];
    let tan_x = (0.5 * FOV_DEG).to_radians().tan();
    let tan_y = tan_x * f64::from(HEIGHT) / f64::from(WIDTH);
    let x = (2.0 * x / f64::from(WIDTH) - 1.0) * tan_x;
    let y = (1.0 - 2.0 * y / f64::from(HEIGHT)) * tan_y;
    norm(std::array::from_fn(|c| f[c] + x * right[c] + y * up[c]))
}

/// The twin's image of `scene` marched with `settings` (made by [`in_scene`]): radiance per unit
/// sun irradiance, with the sky behind the clouds (`T · L`) and the black ground, row by row.
/// Each pixel is the mean over a stratified grid of [`SUBPIXELS`]² points on its area, as
/// Mitsuba's box filter averages it. With [`MarchSettings::jitter`] the rays take the sample
/// offsets `(k + ½) / jitters` (`k` from 0), as a still view's temporal accumulation averages its
/// jittered frames: `lcm(SUBPIXELS², jitters)` rays, ray `r` through sub-pixel `r mod SUBPIXELS²`
/// with offset `r mod jitters`, so every offset and every sub-pixel counts the same; without it
/// one ray per sub-pixel at the steps' midpoints.
pub fn crate_image(scene: &Scene, settings: &MarchSettings, jitters: u32) -> Vec<f64> {
    let layer = cumulus();
    let n = if settings.jitter { jitters.max(1) } else { 1 };
    let grid = SUBPIXELS * SUBPIXELS;
    let gcd = |mut a: u32, mut b: u32| {
        while b != 0 {
            (a, b) = (b, a % b);
        }
        a
    };
    let rays = grid / gcd(grid, n) * n;
    let mut image = Vec::with_capacity((WIDTH * HEIGHT) as usize);
    for j in 0..HEIGHT {
        for i in 0..WIDTH {
            let mut sum = 0.0;
            for r in 0..rays {
                let (sx, sy) = ((r % grid) % SUBPIXELS, (r % grid) / SUBPIXELS);
                let x = f64::from(i) + (f64::from(sx) + 0.5) / f64::from(SUBPIXELS);
                let y = f64::from(j) + (f64::from(sy) + 0.5) / f64::from(SUBPIXELS);
                let direction = pixel_direction(scene, x, y);
                let behind = if direction[1] > 0.0 { SKY } else { 0.0 };
                let jitter = (f64::from(r % n) + 0.5) / f64::from(n);
                let result = march_clouds(
                    textures(),
                    settings,
                    std::slice::from_ref(&layer),
                    scene.camera[1],
                    [0.0, 1.0, 0.0],
                    direction,
                    f64::INFINITY,
                    jitter,
                    None,
                );
                sum += result.radiance[1] + result.transmittance * behind;
            }
            image.push(sum / f64::from(rays));
        }
    }
    image
}

/// Mitsuba's image of the scene `name` (`validation/mitsuba/<name>.csv` under `root`, the crate
/// root: one row per image row); an error names the file and the row.
pub fn truth_image(root: &std::path::Path, name: &str) -> Result<Vec<f64>, String> {
    let file = format!("{FOLDER}/{name}.csv");
    let text = std::fs::read_to_string(root.join(&file))
        .map_err(|e| format!("{file}: cannot be read ({e})"))?;
    parse_image(&file, &text)
}

/// The radiances of `text` (the contents of `file`), [`WIDTH`] per row, [`HEIGHT`] rows, each
/// finite and not negative; an error names the file and the row.
pub fn parse_image(file: &str, text: &str) -> Result<Vec<f64>, String> {
    let mut image = Vec::new();
    for (row, line) in text.lines().enumerate() {
        let values: Vec<f64> = line
            .split(',')
            .map(|v| {
                v.trim()
                    .parse::<f64>()
                    .ok()
                    .filter(|v| v.is_finite() && *v >= 0.0)
            })
            .collect::<Option<_>>()
            .ok_or_else(|| format!("{file}: row {}: not {WIDTH} radiances", row + 1))?;
        if values.len() != WIDTH as usize {
            return Err(format!(
                "{file}: row {}: {} values, expected {WIDTH}",
                row + 1,
                values.len()
            ));
        }
        image.extend(values);
    }
    if image.len() != (WIDTH * HEIGHT) as usize {
        return Err(format!(
            "{file}: {} rows, expected {HEIGHT}",
            image.len() / WIDTH as usize
        ));
    }
    Ok(image)
}

/// How an image compares with the truth.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Comparison {
    /// Root-mean-square difference over the truth's mean.
    pub relative_rmse: f64,
    /// Mean of the image.
    pub mean: f64,
    /// Mean of the truth.
    pub truth_mean: f64,
}

impl Comparison {
    /// `ours` against `truth`, pixel by pixel (the same length).
    pub fn of(ours: &[f64], truth: &[f64]) -> Self {
        let n = truth.len().max(1) as f64;
        let truth_mean = truth.iter().sum::<f64>() / n;
        let mse = ours
            .iter()
            .zip(truth)
            .map(|(a, b)| (a - b).powi(2))
            .sum::<f64>()
            / n;
        Self {
            relative_rmse: mse.sqrt() / truth_mean,
            mean: ours.iter().sum::<f64>() / ours.len().max(1) as f64,
            truth_mean,
        }
    }

    /// The image's mean over the truth's, minus 1.
    pub fn mean_error(&self) -> f64 {
        self.mean / self.truth_mean - 1.0
    }
}

/// The mean brightness of the base (the view from `below`) over the top (from `above`), the
/// image's over the truth's, minus 1.
pub fn base_to_top_error(below: &Comparison, above: &Comparison) -> f64 {
    (below.mean / above.mean) / (below.truth_mean / above.truth_mean) - 1.0
}
