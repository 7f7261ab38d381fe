//! Checks a rendered frame against the same frame rendered without clouds: CI's test that the
//! Bern demo shows sky, terrain and clouds.
//!
//! ```text
//! cargo run --example frame_check -- WITH_CLOUDS.png WITHOUT_CLOUDS.png
//! cargo run --example frame_check -- --same A.png B.png
//! ```
//!
//! With `--same` it checks instead that two frames show the same picture (mean absolute
//! difference below 2/255 per channel): CI's test that the Bern photo overlay at full opacity
//! shows the photo.
//!
//! The sky band (the top fifth of the frame) must differ: clouds are drawn there (mean absolute
//! difference above 4/255 per channel). The near terrain (the bottom tenth) must not differ: the
//! march stops at the ground in front of the camera (mean absolute difference below 1/255, and
//! no pixel further than 3/255 off). Both frames must have sky and terrain: the top band is
//! brighter than the bottom one and neither is uniform. Exits 0 on success, 1 with a message on
//! failure, 2 on bad arguments or unreadable files.

use std::process::ExitCode;

use image::RgbImage;

/// Mean absolute difference per channel (0–255) and the largest, over rows `rows` of both
/// images.
fn difference(a: &RgbImage, b: &RgbImage, rows: std::ops::Range<u32>) -> (f64, u8) {
    let (mut sum, mut max, mut count) = (0.0, 0u8, 0u64);
    for y in rows {
        for x in 0..a.width() {
            for c in 0..3 {
                let d = a.get_pixel(x, y)[c].abs_diff(b.get_pixel(x, y)[c]);
                sum += f64::from(d);
                max = max.max(d);
                count += 1;
            }
        }
    }
    (sum / count.max(1) as f64, max)
}

/// Mean and standard deviation of the luminance-ish channel mean over rows `rows`.
fn statistics(image: &RgbImage, rows: std::ops::Range<u32>) -> (f64, f64) {
    let values: Vec<f64> = rows
        .flat_map(|y| (0..image.width()).map(move |x| (x, y)))
        .map(|(x, y)| {
            let p = image.get_pixel(x, y);
            (f64::from(p[0]) + f64::from(p[1]) + f64::from(p[2])) / 3.0
        })
        .collect();
    let n = values.len().max(1) as f64;
    let mean = values.iter().sum::<f64>() / n;
    let variance = values.iter().map(|v| (v - mean).powi(2)).sum::<f64>() / n;
    (mean, variance.sqrt())
}

fn run(with_path: &str, without_path: &str) -> Result<Result<String, String>, String> {
    let load = |path: &str| {
        image::open(path)
            .map(|i| i.to_rgb8())
            .map_err(|e| format!("cannot read {path}: {e}"))
    };
    let (with, without) = (load(with_path)?, load(without_path)?);
    if with.dimensions() != without.dimensions() || with.height() < 10 {
        return Err(format!(
            "{with_path} and {without_path} must have the same size of at least 10 rows"
        ));
    }
    let h = with.height();
    let sky = 0..h / 5;
    let ground = h - h / 10..h;
    let (sky_diff, _) = difference(&with, &without, sky.clone());
    let (ground_diff, ground_max) = difference(&with, &without, ground.clone());
    let (sky_mean, sky_spread) = statistics(&without, sky.clone());
    let (ground_mean, ground_spread) = statistics(&without, ground.clone());
    let (cloudy_sky_mean, cloudy_sky_spread) = statistics(&with, sky);
    let report = format!(
        "sky: mean |Δ| {sky_diff:.2}/255 (clear mean {sky_mean:.1}, cloudy mean \
         {cloudy_sky_mean:.1} ± {cloudy_sky_spread:.1}); near terrain: mean |Δ| \
         {ground_diff:.2}/255, max {ground_max}/255 (mean {ground_mean:.1} ± {ground_spread:.1})"
    );
    let mut failures = Vec::new();
    if sky_diff <= 4.0 {
        failures.push("no clouds in the sky band");
    }
    if ground_diff >= 1.0 || ground_max > 3 {
        failures.push("the near terrain changed with the clouds");
    }
    if sky_mean <= ground_mean {
        failures.push("the top band is not brighter than the bottom one: no sky over terrain");
    }
    if sky_spread + cloudy_sky_spread == 0.0 || ground_spread == 0.0 {
        failures.push("a uniform band: no real sky or terrain");
    }
    Ok(if failures.is_empty() {
        Ok(report)
    } else {
        Err(format!("{}; {report}", failures.join("; ")))
    })
}

/// `--same`: the two frames match.
fn same(a_path: &str, b_path: &str) -> Result<Result<String, String>, String> {
    let load = |path: &str| {
        image::open(path)
            .map(|i| i.to_rgb8())
            .map_err(|e| format!("cannot read {path}: {e}"))
    };
    let (a, b) = (load(a_path)?, load(b_path)?);
    if a.dimensions() != b.dimensions() {
        return Err(format!("{a_path} and {b_path} differ in size"));
    }
    let (mean, max) = difference(&a, &b, 0..a.height());
    let report = format!("mean |Δ| {mean:.2}/255, max {max}/255");
    Ok(if mean < 2.0 {
        Ok(report)
    } else {
        Err(format!("the frames differ: {report}"))
    })
}

/// Compares two headless frames (see the module docs).
#[derive(clap::Parser)]
struct Args {
    /// Check that the two frames match instead (mean difference under 2/255).
    #[arg(long)]
    same: bool,
    /// The frame with clouds (with `--same`: the first frame).
    with_clouds: String,
    /// The same view without clouds (with `--same`: the second frame).
    without_clouds: String,
}

fn main() -> ExitCode {
    let args = <Args as clap::Parser>::parse();
    let result = if args.same {
        same(&args.with_clouds, &args.without_clouds)
    } else {
        run(&args.with_clouds, &args.without_clouds)
    };
    match result {
        Ok(Ok(report)) => {
            println!("frame_check: ok: {report}");
            ExitCode::SUCCESS
        }
        Ok(Err(failure)) => {
            eprintln!("frame_check: FAILED: {failure}");
            ExitCode::from(1)
        }
        Err(message) => {
            eprintln!("frame_check: {message}");
            ExitCode::from(2)
        }
    }
}
