//! Each preset against the path-traced truth (`--truth`): the three cumulus scenes that Mitsuba 3
//! rendered from the crate's own density field (`validation/mitsuba/`,
//! `bevy_cloudscape::reference::truth`), marched by the CPU twin with the preset's march knobs.
//! `truth.csv`: `scene,preset,jitters,rel_rmse,mean_error`.

use std::path::Path;

use bevy_cloudscape::{
    prelude::VolumetricClouds,
    reference::truth::{self, Comparison},
};

/// Jitter offsets a jittered preset's image averages, as a still view's temporal accumulation
/// averages its frames.
pub const JITTERS: u32 = 8;

/// The header of `truth.csv`.
pub const TRUTH_HEADER: &str = "scene,preset,jitters,rel_rmse,mean_error";

/// One preset in one truth scene.
#[derive(Clone, Debug, PartialEq)]
pub struct TruthRow {
    pub scene: String,
    pub preset: String,
    /// Jitter offsets averaged (1: the preset does not jitter).
    pub jitters: u32,
    /// Relative RMSE of the luminance against Mitsuba's.
    pub rel_rmse: f64,
    /// The mean brightness over Mitsuba's, minus 1.
    pub mean_error: f64,
}

/// Marches every truth scene with each of `presets` on the CPU twin (one thread per scene) and
/// compares it with the committed Mitsuba image; an unreadable or malformed image is an error
/// naming the file and the row.
pub fn measure(presets: &[(&str, VolumetricClouds)]) -> Result<Vec<TruthRow>, String> {
    let root = Path::new(env!("CARGO_MANIFEST_DIR"));
    let scenes = truth::scenes();
    let truths = scenes
        .iter()
        .map(|scene| truth::truth_image(root, scene.name))
        .collect::<Result<Vec<_>, _>>()?;
    let mut rows = Vec::new();
    for (preset, settings) in presets {
        let knobs = settings.march_knobs();
        let jitters = if knobs.jitter { JITTERS } else { 1 };
        let images: Vec<Vec<f64>> = std::thread::scope(|scope| {
            let handles: Vec<_> = scenes
                .iter()
                .map(|scene| {
                    let settings = truth::in_scene(scene, knobs.clone());
                    scope.spawn(move || truth::crate_image(scene, &settings, jitters))
                })
                .collect();
            handles
                .into_iter()
                .map(|handle| handle.join().expect("a truth scene's march panicked"))
                .collect()
        });
        for ((scene, image), truth) in scenes.iter().zip(&images).zip(&truths) {
            let figure = Comparison::of(image, truth);
            eprintln!(
                "truth {}: {preset} relative RMSE {:.1} %, mean {:+.1} %",
                scene.name,
                100.0 * figure.relative_rmse,
                100.0 * figure.mean_error()
            );
            rows.push(TruthRow {
                scene: scene.name.into(),
                preset: (*preset).into(),
                jitters,
                rel_rmse: figure.relative_rmse,
                mean_error: figure.mean_error(),
            });
        }
    }
    Ok(rows)
}

/// `rows` as `truth.csv`.
pub fn to_csv(rows: &[TruthRow]) -> String {
    let mut csv = format!("{TRUTH_HEADER}\n");
    for r in rows {
        csv.push_str(&format!(
            "{},{},{},{:.5},{:.5}\n",
            r.scene, r.preset, r.jitters, r.rel_rmse, r.mean_error
        ));
    }
    csv
}

/// The rows of a `truth.csv` read from `file`; an error names the file and the row.
pub fn from_csv(file: &Path, text: &str) -> Result<Vec<TruthRow>, String> {
    crate::report::read_csv(
        file,
        text,
        TRUTH_HEADER,
        |row, [scene, preset, jitters, rel_rmse, mean_error]| {
            Ok(TruthRow {
                scene: scene.to_owned(),
                preset: preset.to_owned(),
                jitters: row.whole(jitters)?,
                rel_rmse: row.number(rel_rmse)?,
                mean_error: row.number(mean_error)?,
            })
        },
    )
}

/// The mean brightness of the base (`below`) over the top (`above`) of `preset`, over Mitsuba's,
/// minus 1; `None` without both scenes.
pub fn base_to_top_error(rows: &[TruthRow], preset: &str) -> Option<f64> {
    let find = |scene: &str| {
        rows.iter()
            .find(|r| r.scene == scene && r.preset == preset)
            .map(|r| 1.0 + r.mean_error)
    };
    Some(find("below")? / find("above")? - 1.0)
}
