//! Heterogeneous cumulus against Mitsuba 3 (`validation/mitsuba/`): the crate's own density
//! field, exported on a grid, path-traced with unlimited bounces, against the CPU twin's march of
//! the same field. `cargo test --lib export_mitsuba_volumes -- --ignored` writes the grid and the
//! scenes; `validation/.venv/bin/python validation/mitsuba/render_cumulus.py` renders them.

use super::*;
use std::fmt::Write as _;

/// The committed scene description and the folder of the renders, relative to the crate root.
const FOLDER: &str = "validation/mitsuba";
/// The grid, written next to the scenes (not committed: the export makes it again).
const VOLUME: &str = "validation/mitsuba/volumes/cumulus.vol";
/// Image size of every scene, pixels.
const WIDTH: u32 = 32;
const HEIGHT: u32 = 18;
/// Horizontal field of view, degrees.
const FOV_DEG: f64 = 50.0;
/// Sky radiance per unit sun irradiance, 1/sr (as in the DISORT decks).
const SKY: f64 = 0.05;
/// The grid: x and z over ±`HALF_WIDTH_M`, y over the layer, cells of this size.
const HALF_WIDTH_M: f64 = 12_000.0;
const CELL_M: f64 = 100.0;
const CELL_Y_M: f64 = 50.0;
/// The base-to-top ratio the validation asks of `HIGH`.
const RATIO_TARGET: f64 = 0.15;

/// A scene: camera position and view direction (world, y up), sun direction (toward the sun).
struct Scene {
    name: &'static str,
    camera: [f64; 3],
    forward: [f64; 3],
    sun: [f64; 3],
}

fn direction(elevation_deg: f64, toward: [f64; 2]) -> [f64; 3] {
    let e = elevation_deg.to_radians();
    [toward[0] * e.cos(), e.sin(), toward[1] * e.cos()]
}

fn scenes() -> [Scene; 3] {
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

/// The cumulus: smooth shapes (no detail noise, which a 100 m grid cannot hold), 1.5–3 km.
fn cumulus() -> MarchLayer {
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

/// The twin's settings for a scene: a flat planet, the sun and sky of the scene, many steps.
fn scene_settings(scene: &Scene) -> MarchSettings {
    MarchSettings {
        planet_radius_m: 1e10,
        camera_altitude_m: 0.0,
        sun_direction: scene.sun,
        sun_illuminance: [1.0; 3],
        ambient_top: [SKY; 3],
        ambient_bottom: [0.0; 3],
        primary_steps: 256,
        light_steps: 16,
        step_growth: 0.0,
        transmittance_cutoff: 0.0,
        jitter: false,
        ..MarchSettings::default()
    }
}

/// The view ray through pixel `(i, j)` (row 0 at the top), as Mitsuba's `look_at` camera with a
/// horizontal field of view.
fn pixel_direction(scene: &Scene, i: u32, j: u32) -> [f64; 3] {
    let f = scene.forward;
    let norm = |v: [f64; 3]| scale(v, 1.0 / dot(v, v).sqrt());
    let right = norm([-f[2], 0.0, f[0]]);
    let up = [
        right[1] * f[2] - right[2] * f[1],
        right[2] * f[0] - right[0] * f[2],
        right[0] * f[1] - right[1] * f[0],
    ];
    let tan_x = (0.5 * FOV_DEG).to_radians().tan();
    let tan_y = tan_x * f64::from(HEIGHT) / f64::from(WIDTH);
    let x = (2.0 * (f64::from(i) + 0.5) / f64::from(WIDTH) - 1.0) * tan_x;
    let y = (1.0 - 2.0 * (f64::from(j) + 0.5) / f64::from(HEIGHT)) * tan_y;
    norm(add(add(f, scale(right, x)), scale(up, y)))
}

/// The twin's image of a scene: radiance per unit sun irradiance, with the sky behind the
/// clouds (`T · L`) and the black ground.
fn crate_image(scene: &Scene) -> Vec<f64> {
    let settings = scene_settings(scene);
    let layer = cumulus();
    let mut image = Vec::with_capacity((WIDTH * HEIGHT) as usize);
    for j in 0..HEIGHT {
        for i in 0..WIDTH {
            let direction = pixel_direction(scene, i, j);
            let result = march_clouds(
                textures(),
                &settings,
                std::slice::from_ref(&layer),
                scene.camera[1],
                UP,
                direction,
                f64::INFINITY,
                0.5,
                None,
            );
            let behind = if direction[1] > 0.0 { SKY } else { 0.0 };
            image.push(result.radiance[1] + result.transmittance * behind);
        }
    }
    image
}

/// Writes the grid (Mitsuba's `.vol`: the twin's extinction at each cell centre, 1/m) and the
/// scenes (`scenes.json`) the render script reads.
#[test]
#[ignore = "writes validation/mitsuba/volumes/cumulus.vol and scenes.json; run by hand"]
fn export_mitsuba_volumes() {
    let root = std::path::Path::new(env!("CARGO_MANIFEST_DIR"));
    let layer = cumulus();
    let settings = scene_settings(&scenes()[0]);
    let nx = (2.0 * HALF_WIDTH_M / CELL_M) as u32;
    let ny = ((layer.top_m - layer.base_m) / CELL_Y_M) as u32;
    let mut bytes = Vec::new();
    bytes.extend_from_slice(b"VOL");
    bytes.push(3);
    for value in [1_i32, nx as i32, ny as i32, nx as i32, 1] {
        bytes.extend_from_slice(&value.to_le_bytes());
    }
    let lower = [-HALF_WIDTH_M, layer.base_m, -HALF_WIDTH_M];
    let upper = [HALF_WIDTH_M, layer.top_m, HALF_WIDTH_M];
    for value in lower.iter().chain(&upper) {
        bytes.extend_from_slice(&(*value as f32).to_le_bytes());
    }
    for k in 0..nx {
        for j in 0..ny {
            for i in 0..nx {
                let position = [
                    lower[0] + (f64::from(i) + 0.5) * CELL_M,
                    lower[1] + (f64::from(j) + 0.5) * CELL_Y_M,
                    lower[2] + (f64::from(k) + 0.5) * CELL_M,
                ];
                let sigma = density_at(
                    textures(),
                    &settings,
                    std::slice::from_ref(&layer),
                    position,
                );
                bytes.extend_from_slice(&(sigma as f32).to_le_bytes());
            }
        }
    }
    let volume = root.join(VOLUME);
    std::fs::create_dir_all(volume.parent().unwrap()).unwrap();
    std::fs::write(&volume, bytes).unwrap();
    let mut json = String::from("{\n");
    let _ = writeln!(
        json,
        "  \"width\": {WIDTH}, \"height\": {HEIGHT}, \"fov_deg\": {FOV_DEG}, \"sky\": {SKY},"
    );
    let _ = writeln!(
        json,
        "  \"phase\": {{\"g_forward\": {}, \"g_back\": {}, \"back_weight\": {}}},",
        settings.phase_g_forward, settings.phase_g_back, settings.phase_blend
    );
    let _ = writeln!(
        json,
        "  \"volume\": \"volumes/cumulus.vol\", \"lower\": {lower:?}, \"upper\": {upper:?},"
    );
    json += "  \"scenes\": [\n";
    let all = scenes();
    for (n, scene) in all.iter().enumerate() {
        let target = add(scene.camera, scene.forward);
        let _ = writeln!(
            json,
            "    {{\"name\": \"{}\", \"origin\": {:?}, \"target\": {:?}, \"sun\": {:?}}}{}",
            scene.name,
            scene.camera,
            target,
            scene.sun,
            if n + 1 < all.len() { "," } else { "" }
        );
    }
    json += "  ]\n}\n";
    std::fs::write(root.join(FOLDER).join("scenes.json"), json).unwrap();
}

/// Mitsuba's image of `name` (`validation/mitsuba/<name>.csv`: one row per image row); an error
/// names the file and the row.
fn mitsuba_image(name: &str) -> Result<Vec<f64>, String> {
    let file = format!("{FOLDER}/{name}.csv");
    let path = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join(&file);
    let text =
        std::fs::read_to_string(&path).map_err(|e| format!("{file}: cannot be read ({e})"))?;
    parse_image(&file, &text)
}

/// The radiances of `text` (the contents of `file`), [`WIDTH`] per row, [`HEIGHT`] rows.
fn parse_image(file: &str, text: &str) -> Result<Vec<f64>, String> {
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

/// Each scene's relative RMSE of luminance against Mitsuba, the means of the twin and of
/// Mitsuba, and a printable report; computed once for the tests that read it.
fn comparison() -> &'static (Vec<(f64, f64, f64)>, String) {
    static COMPARISON: std::sync::OnceLock<(Vec<(f64, f64, f64)>, String)> =
        std::sync::OnceLock::new();
    COMPARISON.get_or_init(compare)
}

/// [`comparison`], marched anew.
fn compare() -> (Vec<(f64, f64, f64)>, String) {
    let mut report = String::new();
    let mut figures = Vec::new();
    for scene in scenes() {
        let ours = crate_image(&scene);
        // The twin's image next to the target, for a look (`target/validation/`).
        let dump = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("target/validation");
        let _ = std::fs::create_dir_all(&dump);
        let rows: Vec<String> = ours
            .chunks(WIDTH as usize)
            .map(|row| {
                row.iter()
                    .map(|v| format!("{v:.6e}"))
                    .collect::<Vec<_>>()
                    .join(",")
            })
            .collect();
        let _ = std::fs::write(
            dump.join(format!("{}.csv", scene.name)),
            rows.join("\n") + "\n",
        );
        let truth = mitsuba_image(scene.name).unwrap_or_else(|e| panic!("{e}"));
        let mean = truth.iter().sum::<f64>() / truth.len() as f64;
        let mse = ours
            .iter()
            .zip(&truth)
            .map(|(a, b)| (a - b).powi(2))
            .sum::<f64>()
            / truth.len() as f64;
        let rmse = mse.sqrt() / mean;
        let our_mean = ours.iter().sum::<f64>() / ours.len() as f64;
        figures.push((rmse, our_mean, mean));
        let _ = writeln!(
            report,
            "{}: relative RMSE {:.1} %, mean {:.4} against {:.4} ({:+.1} %)",
            scene.name,
            100.0 * rmse,
            our_mean,
            mean,
            100.0 * (our_mean / mean - 1.0)
        );
    }
    (figures, report)
}

/// The twin's mean brightness of the clouds' base (the view from below) over their top (from
/// above) against Mitsuba's: within 15 %, the validation target. `-- --nocapture` prints each
/// scene's relative RMSE of luminance, whose target (10 %, for `HIGH`) the light does not meet
/// yet (`validation/README.md` has the figures).
#[test]
fn cumulus_base_to_top_ratio_matches_mitsuba() {
    let (figures, report) = comparison();
    let ratio = (figures[0].1 / figures[1].1) / (figures[0].2 / figures[1].2);
    println!(
        "{report}base / top {:+.1} % from Mitsuba's",
        100.0 * (ratio - 1.0)
    );
    assert!(
        (ratio - 1.0).abs() <= RATIO_TARGET,
        "base / top {:+.1} % from Mitsuba's\n{report}",
        100.0 * (ratio - 1.0)
    );
}

/// Each scene's mean brightness within the base-to-top target (15 %) of Mitsuba's: a broken
/// field's thin edges lit like the top of a solid deck (the full column below every sample)
/// made the views from below and above a third too bright.
#[test]
fn cumulus_mean_brightness_matches_mitsuba() {
    let (figures, report) = comparison();
    for (scene, &(_, ours, truth)) in scenes().iter().zip(figures) {
        assert!(
            (ours / truth - 1.0).abs() <= RATIO_TARGET,
            "{}: mean {ours:.4} against Mitsuba's {truth:.4}\n{report}",
            scene.name
        );
    }
}

#[test]
fn a_broken_mitsuba_image_names_the_file_and_row() {
    let error = mitsuba_image("no_such_scene").expect_err("a missing file");
    assert!(
        error.starts_with("validation/mitsuba/no_such_scene.csv: cannot be read"),
        "{error}"
    );
    let row = vec!["0.1"; WIDTH as usize].join(",");
    let good = format!("{row}\n").repeat(HEIGHT as usize);
    assert_eq!(
        parse_image("m.csv", &good).map(|i| i.len()),
        Ok((WIDTH * HEIGHT) as usize)
    );
    let short = format!("{row}\n").repeat(HEIGHT as usize - 1);
    let nan = good.replacen("0.1", "NaN", 1);
    let narrow = good.replacen(",0.1", "", 1);
    for (text, expected) in [
        (short.as_str(), "m.csv: 17 rows, expected 18"),
        (nan.as_str(), "m.csv: row 1: not 32 radiances"),
        (narrow.as_str(), "m.csv: row 1: 31 values, expected 32"),
    ] {
        assert_eq!(parse_image("m.csv", text).unwrap_err(), expected);
    }
}
