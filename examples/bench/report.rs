//! What the bench writes from its measurements: `bench.csv`, the speed-against-error plot and
//! `docs/performance.md`, all from the same rows, so the documented figures are the CSV's.

use std::path::Path;

use plotters::prelude::*;

use crate::truth::{TruthRow, base_to_top_error};

/// One measured preset (or the reference) in one scene: a row of `bench.csv`.
#[derive(Clone, Debug, PartialEq)]
pub struct Row {
    pub scene: String,
    pub preset: String,
    pub width: u32,
    pub height: u32,
    /// The cloud pass's cost, ms per frame (median with clouds minus median without).
    pub ms: f64,
    /// The reference's cost in the same scene, ms per frame.
    pub ref_ms: f64,
    /// Relative RMSE of the linear luminance against the reference.
    pub rel_rmse: f64,
    /// Largest absolute luminance difference.
    pub max_abs: f64,
    /// Pixels that were NaN or infinite.
    pub nan_count: usize,
}

impl Row {
    /// The cost as a share of the reference's.
    pub fn time_ratio(&self) -> f64 {
        self.ms / self.ref_ms.max(1e-9)
    }
}

/// The header of `bench.csv`.
pub const BENCH_HEADER: &str =
    "scene,preset,width,height,ms_per_frame,ref_ms_per_frame,rel_rmse,max_abs_err,nan_count";

/// `rows` as `bench.csv`.
pub fn to_csv(rows: &[Row]) -> String {
    let mut csv = format!("{BENCH_HEADER}\n");
    for r in rows {
        csv.push_str(&format!(
            "{},{},{},{},{:.3},{:.3},{:.5},{:.5},{}\n",
            r.scene,
            r.preset,
            r.width,
            r.height,
            r.ms,
            r.ref_ms,
            r.rel_rmse,
            r.max_abs,
            r.nan_count
        ));
    }
    csv
}

/// One data row of a CSV file being read: what its fields' parse errors name.
pub struct CsvRow<'a> {
    file: &'a Path,
    /// 1-based line number.
    line: usize,
}

impl CsvRow<'_> {
    /// An error naming the file and the row.
    pub fn error(&self, what: &str) -> String {
        format!("{}: row {}: {what}", self.file.display(), self.line)
    }

    /// A finite number.
    pub fn number(&self, text: &str) -> Result<f64, String> {
        text.parse::<f64>()
            .ok()
            .filter(|v| v.is_finite())
            .ok_or_else(|| self.error(&format!("{text:?} is not a number")))
    }

    /// A whole number.
    pub fn whole<T: std::str::FromStr>(&self, text: &str) -> Result<T, String> {
        text.parse()
            .map_err(|_| self.error(&format!("{text:?} is not a whole number")))
    }
}

/// The rows of the CSV `text` read from `file`: the first line must be `header`, each other
/// non-empty line has `N` fields, which `parse` turns into a row. An error names the file and
/// the row.
pub fn read_csv<T, const N: usize>(
    file: &Path,
    text: &str,
    header: &str,
    parse: impl Fn(&CsvRow, [&str; N]) -> Result<T, String>,
) -> Result<Vec<T>, String> {
    let mut lines = text.lines();
    if lines.next().map(str::trim) != Some(header) {
        return Err(format!("{}: row 1 is not {header:?}", file.display()));
    }
    lines
        .enumerate()
        .filter(|(_, line)| !line.trim().is_empty())
        .map(|(i, line)| {
            let row = CsvRow { file, line: i + 2 };
            let fields: Vec<&str> = line.split(',').collect();
            let fields: [&str; N] = fields
                .as_slice()
                .try_into()
                .map_err(|_| row.error(&format!("{} fields, expected {N}", fields.len())))?;
            parse(&row, fields)
        })
        .collect()
}

/// The rows of a `bench.csv` read from `file`; an error names the file and the row.
pub fn from_csv(file: &Path, text: &str) -> Result<Vec<Row>, String> {
    read_csv(
        file,
        text,
        BENCH_HEADER,
        |row,
         [
            scene,
            preset,
            width,
            height,
            ms,
            ref_ms,
            rel_rmse,
            max_abs,
            nan_count,
        ]| {
            Ok(Row {
                scene: scene.to_owned(),
                preset: preset.to_owned(),
                width: row.whole(width)?,
                height: row.whole(height)?,
                ms: row.number(ms)?,
                ref_ms: row.number(ref_ms)?,
                rel_rmse: row.number(rel_rmse)?,
                max_abs: row.number(max_abs)?,
                nan_count: row.whole(nan_count)?,
            })
        },
    )
}

/// Each distinct item of `items`, in the order they first appear.
fn first_seen<'a>(items: impl IntoIterator<Item = &'a str>) -> Vec<&'a str> {
    let mut seen: Vec<&str> = Vec::new();
    for item in items {
        if !seen.contains(&item) {
            seen.push(item);
        }
    }
    seen
}

/// A Markdown table with a row per scene and a column per preset; `cell` gives each cell's text
/// (`None`: a dash).
fn push_grid(
    md: &mut String,
    scenes: &[&str],
    presets: &[&str],
    cell: impl Fn(&str, &str) -> Option<String>,
) {
    md.push_str(&format!("| scene | {} |\n", presets.join(" | ")));
    md.push_str(&format!("|---|{}\n", "---|".repeat(presets.len())));
    for scene in scenes {
        let cells: Vec<String> = presets
            .iter()
            .map(|preset| cell(scene, preset).unwrap_or_else(|| "–".into()))
            .collect();
        md.push_str(&format!("| {scene} | {} |\n", cells.join(" | ")));
    }
}

/// The colour of a preset in the plot.
fn preset_colour(preset: &str) -> RGBColor {
    match preset {
        "LOW" => RGBColor(210, 50, 40),
        "MEDIUM" => RGBColor(220, 160, 0),
        "HIGH" => RGBColor(40, 160, 70),
        "ULTRA" => RGBColor(50, 100, 220),
        _ => RGBColor(90, 90, 90),
    }
}

/// One point of the plot: a preset in a scene, at a time ratio and an error.
struct Point<'a> {
    scene: String,
    preset: &'a str,
    at: (f64, f64),
}

/// The median of `values` (`None` when empty).
pub(crate) fn median(mut values: Vec<f64>) -> Option<f64> {
    values.sort_by(f64::total_cmp);
    let n = values.len();
    (n > 0).then(|| 0.5 * (values[(n - 1) / 2] + values[n / 2]))
}

/// The marker of the `index`th scene at `at` (filled, then hollow shapes; eight kinds).
fn marker<DB: DrawingBackend, C: Into<ShapeStyle>>(
    index: usize,
    at: (i32, i32),
    colour: C,
) -> DynElement<'static, DB, (i32, i32)> {
    let style: ShapeStyle = colour.into();
    let filled = style.filled();
    let line = style.stroke_width(2);
    let (x, y) = at;
    match index % 8 {
        0 => Circle::new((x, y), 5, filled).into_dyn(),
        1 => TriangleMarker::new((x, y), 6, filled).into_dyn(),
        2 => Rectangle::new([(x - 4, y - 4), (x + 4, y + 4)], filled).into_dyn(),
        3 => Cross::new((x, y), 5, line).into_dyn(),
        4 => Circle::new((x, y), 5, line).into_dyn(),
        5 => TriangleMarker::new((x, y), 6, line).into_dyn(),
        6 => Rectangle::new([(x - 4, y - 4), (x + 4, y + 4)], line).into_dyn(),
        _ => Circle::new((x, y), 3, filled).into_dyn(),
    }
}

/// The speed-against-error plot of `rows` (the presets, not the reference) and `truth` as an
/// SVG at `path`: log–log axes of the cloud pass's time as a share of the reference's and of the
/// relative RMSE, one colour per preset, one marker per scene. The bench scenes' error is against
/// the converged march; the path-traced truth scenes' (`truth`, named "… (Mitsuba)") against the
/// truth, at the preset's median time ratio over the bench scenes.
pub fn plot(rows: &[Row], truth: &[TruthRow], path: &Path) -> Result<(), String> {
    let error = |e: &dyn std::fmt::Display| format!("cannot draw {}: {e}", path.display());
    let measured: Vec<&Row> = rows
        .iter()
        .filter(|r| !r.preset.starts_with("REFERENCE"))
        .collect();
    let mut points: Vec<Point> = measured
        .iter()
        .map(|r| Point {
            scene: r.scene.clone(),
            preset: &r.preset,
            at: (r.time_ratio(), r.rel_rmse),
        })
        .collect();
    for t in truth {
        let ratios = measured
            .iter()
            .filter(|r| r.preset == t.preset)
            .map(|r| r.time_ratio())
            .collect();
        if let Some(ratio) = median(ratios) {
            points.push(Point {
                scene: format!("{} (Mitsuba)", t.scene),
                preset: &t.preset,
                at: (ratio, t.rel_rmse),
            });
        }
    }
    let scenes = first_seen(points.iter().map(|p| p.scene.as_str()));
    let presets = first_seen(points.iter().map(|p| p.preset));
    let root = SVGBackend::new(path, (800, 560)).into_drawing_area();
    root.fill(&WHITE).map_err(|e| error(&e))?;
    let size = measured
        .first()
        .map_or(String::new(), |r| format!(", {}×{}", r.width, r.height));
    let mut chart = ChartBuilder::on(&root)
        .caption(format!("Speed against error{size}"), ("sans-serif", 22))
        .margin(12)
        .x_label_area_size(48)
        .y_label_area_size(64)
        .build_cartesian_2d((1e-3f64..1.0f64).log_scale(), (1e-4f64..1.0f64).log_scale())
        .map_err(|e| error(&e))?;
    chart
        .configure_mesh()
        .x_desc("cloud pass time / reference's time")
        .y_desc("relative RMSE of luminance (Mitsuba scenes: against the path-traced truth)")
        .x_label_formatter(&|x| format!("{x:.0e}"))
        .y_label_formatter(&|y| format!("{y:.0e}"))
        .draw()
        .map_err(|e| error(&e))?;
    for p in &points {
        let colour = preset_colour(p.preset);
        let scene = scenes.iter().position(|s| *s == p.scene).unwrap_or(0);
        let at = (p.at.0.clamp(1e-3, 1.0), p.at.1.clamp(1e-4, 1.0));
        chart
            .draw_series(std::iter::once(
                EmptyElement::at(at) + marker(scene, (0, 0), colour),
            ))
            .map_err(|e| error(&e))?;
    }
    for preset in &presets {
        let colour = preset_colour(preset);
        chart
            .draw_series(std::iter::empty::<Circle<(f64, f64), i32>>())
            .map_err(|e| error(&e))?
            .label(*preset)
            .legend(move |(x, y)| Rectangle::new([(x, y - 5), (x + 10, y + 5)], colour.filled()));
    }
    for (index, scene) in scenes.iter().enumerate() {
        chart
            .draw_series(std::iter::empty::<Circle<(f64, f64), i32>>())
            .map_err(|e| error(&e))?
            .label(*scene)
            .legend(move |(x, y)| marker(index, (x + 5, y), BLACK));
    }
    chart
        .configure_series_labels()
        .position(SeriesLabelPosition::UpperRight)
        .background_style(WHITE.mix(0.85))
        .border_style(BLACK)
        .draw()
        .map_err(|e| error(&e))?;
    root.present().map_err(|e| error(&e))
}

/// `docs/performance.md` for `rows` and the `effects` CSV, measured with `command`; the plot is
/// at `plot` (relative to the document).
pub fn performance_md(
    rows: &[Row],
    truth: &[TruthRow],
    effects: &str,
    times: Option<&str>,
    peer: Option<&str>,
    command: &str,
    plot: &str,
) -> String {
    let measured = || rows.iter().filter(|r| !r.preset.starts_with("REFERENCE"));
    let scenes = first_seen(measured().map(|r| r.scene.as_str()));
    let presets = first_seen(measured().map(|r| r.preset.as_str()));
    let size = rows
        .first()
        .map_or(String::new(), |r| format!("{}×{}", r.width, r.height));
    let mut md = format!(
        "# Performance\n\n\
         Written by the `bench` example from its CSV files; do not edit by hand. Regenerate \
         with\n\n```sh\n{command}\n```\n\nfrom the CSV files of a run (`docs/bench/README.md` \
         has the commands that made the crate's own: with the cloud shadow map on, as a \
         game's plugin has it, so `MEDIUM` reads most samples' sun from the map).\n\n\
         Each cell is the relative RMSE of the linear luminance against a converged reference \
         march (512 primary steps per ray and 64 light steps, no jitter, no early exit, full \
         resolution), at the cloud pass's time as a share of the reference's, at {size}. \
         Presets that accumulate jittered frames are measured once the accumulation has \
         settled. The times are from software Vulkan (lavapipe) when no GPU is named: CPU \
         times, to be compared as ratios within this run, not as milliseconds. \
         `examples/bench/main.rs` documents every column.\n\n## Speed against error\n\n"
    );
    push_grid(&mut md, &scenes, &presets, |scene, preset| {
        rows.iter()
            .find(|r| r.scene == scene && r.preset == preset)
            .map(|r| {
                format!(
                    "{:.2} % at {:.1} %",
                    100.0 * r.rel_rmse,
                    100.0 * r.time_ratio()
                )
            })
    });
    if !truth.is_empty() {
        push_truth_table(&mut md, truth);
    }
    md.push_str(&format!(
        "\n![Speed against error of the presets]({plot})\n"
    ));
    if let Some(times) = times {
        md.push_str(
            "\n## Cost at game resolutions\n\nThe cloud pass's cost in milliseconds per frame \
             (`ms_per_frame`: the median frame time with the clouds minus the median without \
             them) at each size and number of stacked layers (`times.csv`, written by \
             `--time-only` runs; their commands are in `docs/bench/README.md`). Lavapipe: \
             compare the rows with each other, not with a GPU's milliseconds.\n\n",
        );
        push_csv_table(&mut md, times);
    }
    if let Some(peer) = peer {
        md.push_str(
            "\n## Against the peer crate\n\nThe cloud cost of `bevy-volumetric-clouds` 0.2 \
             (Bevy 0.18; its clouds on minus off, the same view and window) beside each preset's \
             `ms_per_frame` on `cumulus_noon`, measured on one machine in one run of \
             `bench/peer/compare.sh` (`peer.csv`; `bench/peer/README.md`). `share_of_peer` is \
             the preset's cost over the peer's.\n\n",
        );
        push_csv_table(&mut md, peer);
    }
    if effects.lines().next().is_some() {
        md.push_str(
            "\n## What each effect costs\n\nThe median whole-frame time with each optional \
             effect over the median without it, on `cumulus_noon` with `MEDIUM` \
             (`effects.csv`).\n\n",
        );
        push_csv_table(&mut md, effects);
    }
    md
}

/// The presets against the path-traced truth (`truth.csv`): each scene's relative RMSE and mean
/// brightness error, and the base-to-top ratio's error.
fn push_truth_table(md: &mut String, truth: &[TruthRow]) {
    let scenes = first_seen(truth.iter().map(|r| r.scene.as_str()));
    let presets = first_seen(truth.iter().map(|r| r.preset.as_str()));
    let jitters = truth.iter().map(|r| r.jitters).max().unwrap_or(1);
    let subpixels = bevy_cloudscape::reference::truth::SUBPIXELS.pow(2);
    md.push_str(&format!(
        "\n## Against the path-traced truth\n\nEach preset's march of the three cumulus scenes \
         that Mitsuba 3 path-traced from the crate's own density field (`validation/mitsuba/`, \
         `validation/README.md`): the CPU twin, which the GPU march is tested against, with the \
         preset's steps and knobs, each pixel the mean over {subpixels} points of its area (as \
         Mitsuba's box filter averages it) and {jitters} jitter offsets (as the temporal \
         accumulation averages them) (`truth.csv`). Each cell is the relative RMSE of \
         the luminance against Mitsuba's image and, in brackets, the mean brightness's error; \
         the last row is the error of the ratio of the base's mean brightness (from below) to \
         the top's (from above).\n\n"
    ));
    push_grid(md, &scenes, &presets, |scene, preset| {
        truth
            .iter()
            .find(|r| r.scene == scene && r.preset == preset)
            .map(|r| {
                format!(
                    "{:.1} % ({:+.1} %)",
                    100.0 * r.rel_rmse,
                    100.0 * r.mean_error
                )
            })
    });
    let ratios: Vec<String> = presets
        .iter()
        .map(|preset| {
            base_to_top_error(truth, preset)
                .map_or("–".into(), |e| format!("{:+.1} %", 100.0 * e))
        })
        .collect();
    md.push_str(&format!("| base / top | {} |\n", ratios.join(" | ")));
}

/// `csv` (a header line, then rows) as a Markdown table.
fn push_csv_table(md: &mut String, csv: &str) {
    let mut lines = csv.lines().filter(|l| !l.trim().is_empty());
    let Some(header) = lines.next() else {
        return;
    };
    let columns: Vec<&str> = header.split(',').collect();
    md.push_str(&format!("| {} |\n", columns.join(" | ")));
    md.push_str(&format!("|{}\n", "---|".repeat(columns.len())));
    for line in lines {
        md.push_str(&format!(
            "| {} |\n",
            line.split(',').collect::<Vec<_>>().join(" | ")
        ));
    }
}
