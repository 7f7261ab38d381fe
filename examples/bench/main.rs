//! Speed against error: renders fixed cloud scenes with every quality preset and with a
//! converged reference, and reports the time and the error of each.
//!
//! ```text
//! cargo run --release --example bench -- [--width W] [--height H] [--frames N] [--out DIR] [--scene NAME] [--presets LIST] [--reference-steps N] [--no-jitter] [--effects-only] [--error-budget]
//! cargo run --release --example bench -- --time-only [--gpu-spans] [--presets LIST] [--sizes WxH,...] [--layers N,...] [--set FIELD=VALUE] [--scene NAME] [--out DIR]
//! cargo run --release --example bench -- --growth [--frames N] [--out DIR]
//! cargo run --release --example bench -- --truth [--presets LIST] [--set FIELD=VALUE] [--out DIR]
//! ```
//!
//! `--truth` marches each preset through the three cumulus scenes that Mitsuba 3 path-traced from
//! the crate's own density field (`validation/mitsuba/`) on the CPU twin and writes its error
//! against the truth to `truth.csv` (see `truth.rs`); the full run measures it too.
//!
//! `--growth` times one step of the cloud-growth automaton (`render::growth`) at 64 × 64 × 16,
//! the seed's 100 × 100 × 10, 128 × 128 × 16 and 256 × 256 × 16 cells, into `growth.csv`.
//!
//! Scenes: cumulus at noon, overcast stratus, sunset behind altocumulus, the camera inside a
//! cumulus layer, a grazing view to the horizon, and a cirrostratus veil with the sun in view
//! (`examples/common/scenes.rs`, `bench_scenes`). Presets:
//! `LOW`, `MEDIUM`, `HIGH`, `ULTRA`; the reference marches 512 steps per ray with 64 light
//! steps, no jitter and no early exit, at full resolution.
//!
//! Outputs in `DIR` (default `bench/`):
//! - `bench.csv`: `scene,preset,width,height,ms_per_frame,ref_ms_per_frame,rel_rmse,max_abs_err,nan_count`.
//!   `ms_per_frame` is the cost of the cloud pass: the median frame time with the clouds minus
//!   the median frame time of the same view with no visible layer (the pass then does not run),
//!   so what the engine does anyway cancels out; it includes the temporal accumulation's pass.
//!   Presets that accumulate jittered frames are measured once a still view has settled: until
//!   the first frame weighs under 1 % in each pixel's running average, each pixel taking its
//!   own sample once in the temporal upsampling's cycle (`--no-jitter` turns jitter and
//!   accumulation off). Errors compare the linear luminance of the composite `grey · T + L`
//!   over a mid-grey background with the reference's (relative RMSE:
//!   `sqrt(mean(Δ²)) / mean(reference)`; max: largest `|Δ|`).
//! - `bench.svg`: error (relative RMSE, vertical, log scale 10⁻⁴ to 1) against time relative
//!   to the reference (horizontal, log scale 10⁻³ to 1), a colour per preset and a marker per
//!   scene, with a legend.
//! - With `--docs DIR`: `DIR/performance.md` (the tables of the CSV files, with `peer.csv` from
//!   `bench/peer/compare.sh` when the run's folder has one, and the command) and
//!   `DIR/images/bench.svg`; `--from-csv RUN --docs DIR` writes them from a run's CSV files
//!   (the crate's own run is in `docs/bench/`).
//! - `images/SCENE_PRESET.png`: each render beside the reference, and a third panel with the
//!   difference of their linear luminance, `|Δ| / mean(reference)`, white at 20 % and above.
//! - `truth.csv`: `scene,preset,jitters,rel_rmse,mean_error`, each preset against the
//!   path-traced truth (`--truth`); `performance.md` tabulates it with the base-to-top ratio, and
//!   the plot puts each truth scene at the preset's median time ratio over the bench scenes.
//! - `effects.csv`: `effect,scene,ms_with,ms_without,ratio`, the median whole-frame time with
//!   and without each optional effect (the cloud shadow map at 256², haze, light shafts, rain,
//!   fog, temporal accumulation, the weather map; see `measure_effects`), on the cumulus scene
//!   with `MEDIUM`.
//!
//! The log gives each preset's time and error, and which share of the squared error the worst
//! 1 % of pixels carry (near 1 when a few pixels hold the error, near 0.01 when it is spread
//! evenly). `--scene NAME` measures only that scene and writes only its images. `--reference-steps
//! N` sets the reference's primary steps (default 512, at most 1024); with any other count the
//! 512-step reference is measured against it as one more row, `REFERENCE_512`: how far the
//! default has converged.
//!
//! `--error-budget` instead prints, for the cumulus and sunset scenes, the error of `HIGH` with one
//! knob changed at a time, on the CPU reference renderer (48×27, small noise, no jitter) against
//! 512 primary and 64 light steps: which knob the error comes from.
//!
//! On software Vulkan (lavapipe) the times are CPU times: compare the ratios, not the
//! milliseconds.

#[path = "../common/mod.rs"]
mod common;
#[cfg(feature = "live")]
mod live;
mod report;
mod truth;

use std::{
    path::PathBuf,
    process::ExitCode,
    time::{Duration, Instant},
};

use bevy::{prelude::*, render::render_resource::PipelineCache};
use bevy_cloudscape::prelude::*;
use bevy_cloudscape::{
    reference::render::{CloudTextures, MAX_PRIMARY_STEPS, march_clouds},
    render::march::{CloudSun, march_inputs},
};
use common::scenes::{
    CloudRig, Scene, layer, looking, luminance, save_strip, showcase_scenes, small_recipe,
    sun_direction,
};
use report::{Row, performance_md, plot, to_csv};
use truth::TruthRow;

/// Speed against error of the presets (see the module docs).
#[derive(clap::Parser)]
struct Args {
    /// Image width, pixels.
    #[arg(long, default_value_t = 160, value_parser = clap::value_parser!(u32).range(1..))]
    width: u32,
    /// Image height, pixels.
    #[arg(long, default_value_t = 88, value_parser = clap::value_parser!(u32).range(1..))]
    height: u32,
    /// Frames timed per measurement (the median is kept).
    #[arg(long, default_value_t = 5, value_parser = clap::value_parser!(u32).range(1..))]
    frames: u32,
    /// Folder the CSV files, the plot and the images go to.
    #[arg(long, default_value = "bench")]
    out: PathBuf,
    /// Turn the presets' ray jitter off, to separate its noise from the bias of fewer steps.
    #[arg(long)]
    no_jitter: bool,
    /// Measure only the optional effects (`effects.csv`), not the presets.
    #[arg(long)]
    effects_only: bool,
    /// Print where the error comes from ([`error_budget`]) instead of timing anything.
    #[arg(long)]
    error_budget: bool,
    /// Measure only the bench scene of this name (and no effects).
    #[arg(long, value_parser = scene_name)]
    scene: Option<String>,
    /// Also write `DIR/performance.md` and its plot `DIR/images/bench.svg` from this run
    /// (`--docs docs` for the crate's own).
    #[arg(long, value_name = "DIR")]
    docs: Option<PathBuf>,
    /// Measure nothing: read `bench.csv` and `effects.csv` from this folder (a run's `--out`)
    /// and write the `--docs` files from them.
    #[arg(long, value_name = "DIR", requires = "docs")]
    from_csv: Option<PathBuf>,
    /// Measure only these presets (comma-separated: LOW, MEDIUM, HIGH, ULTRA).
    #[arg(long, value_delimiter = ',', value_parser = preset_name)]
    presets: Vec<String>,
    /// Time the presets only: no reference, no error, no effects, no images. Writes
    /// `times.csv` (`scene,preset,width,height,layers,ms_per_frame`) and prints it.
    #[arg(long)]
    time_only: bool,
    /// With `--time-only`, the numbers of layers to time each preset with (comma-separated, each
    /// 1–16): copies of the scene's layer stacked one above the other.
    #[arg(long, value_delimiter = ',', default_value = "1", requires = "time_only",
          value_parser = clap::value_parser!(u32).range(1..=16))]
    layers: Vec<u32>,
    /// With `--time-only`, the image sizes to time each preset at (comma-separated `WxH`);
    /// default `--width`×`--height`.
    #[arg(long, value_delimiter = ',', requires = "time_only", value_parser = image_size)]
    sizes: Vec<UVec2>,
    /// Change one knob of every measured preset (`FIELD=VALUE`, a field of `VolumetricClouds`,
    /// repeatable): what the knob costs and what it changes.
    #[arg(long = "set", value_name = "FIELD=VALUE", value_parser = knob)]
    knobs: Vec<(String, String)>,
    /// With `--time-only`, a knob set to time against each selected preset in the same run
    /// (`NAME:FIELD=VALUE FIELD=VALUE …`, fields of `VolumetricClouds`, repeatable). Each of
    /// `--rounds` rounds times the preset and then every variant in turn, and the median of the
    /// rounds is kept: the machine's speed drifts between runs (by a sixth on lavapipe) more than
    /// many knobs change the cost, and a drift within the run falls on every variant alike.
    /// Writes `variants.csv` (see [`time_variants`]) and prints it.
    #[arg(long = "variant", value_name = "NAME:FIELD=VALUE ...", value_parser = variant,
          requires = "time_only")]
    variants: Vec<Variant>,
    /// Rounds of `--variant` timing; the median is kept.
    #[arg(long, default_value_t = 3, value_parser = clap::value_parser!(u32).range(1..))]
    rounds: u32,
    /// Keep each scene's reference image in this folder and reuse it when it is there (named
    /// by scene, size and reference steps): for runs that change only the presets.
    #[arg(long, value_name = "DIR")]
    reference_cache: Option<PathBuf>,
    /// With `--time-only`, also print each cloud pass's mean GPU time over the timed frames
    /// (Bevy's render diagnostics, `render/clouds/PASS/elapsed_gpu`): where the cost goes.
    /// Appended to `spans.csv` (`scene,preset,width,height,layers,shadows,knobs,pass,ms`;
    /// `knobs` the `--set` values, space-separated).
    #[arg(long, requires = "time_only")]
    gpu_spans: bool,
    /// Turn the cloud shadow map on ([`CloudShadows::default`], as a game's plugin has it), for
    /// the presets and the reference alike: the shadow pass, the light shafts and the presets'
    /// sun from the map then count in the time and the error. Off by default.
    #[arg(long)]
    shadows: bool,
    /// Time one step of the cloud-growth automaton at several grid sizes instead (writes
    /// `growth.csv`: `width,length,depth,cells,ms_per_step,ms_per_cover`).
    #[arg(long)]
    growth: bool,
    /// Time frames across live forecast refreshes instead (crate feature `live`: `cargo run
    /// --features live --example bench -- --live-refresh`): a loopback server answers each
    /// download after 300 ms, the forecast refreshes every second, and each frame's time goes
    /// to `live_refresh.csv` (`frame,ms,downloading,stored`) with the medians printed.
    #[arg(long)]
    live_refresh: bool,
    /// Measure only each preset against the path-traced truth: the Mitsuba cumulus scenes of
    /// `validation/mitsuba/`, marched by the CPU twin with the preset's knobs (`--set` too),
    /// into `truth.csv` (the full run measures it too).
    #[arg(long)]
    truth: bool,
    /// Primary steps of the reference.
    #[arg(long, default_value_t = REFERENCE_STEPS,
          value_parser = clap::value_parser!(u32).range(1..=i64::from(MAX_PRIMARY_STEPS)))]
    reference_steps: u32,
}

impl Args {
    /// The image size, pixels.
    fn size(&self) -> UVec2 {
        UVec2::new(self.width, self.height)
    }
}

/// A `--scene` value: the name of one of [`bench_scenes`].
fn scene_name(name: &str) -> Result<String, String> {
    let names: Vec<_> = bench_scenes().iter().map(|s| s.name).collect();
    if names.contains(&name) {
        Ok(name.to_owned())
    } else {
        Err(format!("{name:?} is not one of {names:?}"))
    }
}

/// A `--presets` value: the name of one of [`presets`].
fn preset_name(name: &str) -> Result<String, String> {
    let names: Vec<_> = presets().iter().map(|(n, _)| *n).collect();
    if names.contains(&name) {
        Ok(name.to_owned())
    } else {
        Err(format!("{name:?} is not one of {names:?}"))
    }
}

/// A `--sizes` value: `WxH`.
fn image_size(text: &str) -> Result<UVec2, String> {
    let (w, h) = text
        .split_once('x')
        .ok_or_else(|| format!("{text:?} is not WxH"))?;
    let side = |v: &str| match v.parse::<u32>() {
        Ok(n) if n > 0 => Ok(n),
        _ => Err(format!("{text:?}: {v:?} is not a positive width or height")),
    };
    Ok(UVec2::new(side(w)?, side(h)?))
}

/// A `--set` value: `FIELD=VALUE`.
fn knob(text: &str) -> Result<(String, String), String> {
    text.split_once('=')
        .map(|(f, v)| (f.trim().to_owned(), v.trim().to_owned()))
        .ok_or_else(|| format!("{text:?} is not FIELD=VALUE"))
}

/// A `--variant`: a name and the knobs it sets on top of the preset and `--set`.
#[derive(Clone, Debug)]
struct Variant {
    name: String,
    knobs: Vec<(String, String)>,
}

/// A `--variant` value: `NAME:FIELD=VALUE FIELD=VALUE …` (no [`SHADOW_KNOB`] fields: the shadow
/// map is the rig's, shared by every variant).
fn variant(text: &str) -> Result<Variant, String> {
    let (name, knobs) = text
        .split_once(':')
        .ok_or_else(|| format!("{text:?} is not NAME:FIELD=VALUE ..."))?;
    let name = name.trim();
    if name.is_empty() || name.contains(',') {
        return Err(format!(
            "{text:?}: the name before ':' must be non-empty, without commas"
        ));
    }
    let knobs = knobs
        .split_whitespace()
        .map(knob)
        .collect::<Result<Vec<_>, _>>()?;
    if knobs.is_empty() {
        return Err(format!("{text:?} sets no knob"));
    }
    if let Some((field, _)) = knobs.iter().find(|(f, _)| f.starts_with(SHADOW_KNOB)) {
        return Err(format!(
            "{text:?}: {field} belongs to the shadow map, which every variant shares (use --set)"
        ));
    }
    Ok(Variant {
        name: name.to_owned(),
        knobs,
    })
}

/// The prefix of a `--set` knob that changes [`CloudShadows`] rather than the preset.
const SHADOW_KNOB: &str = "shadows.";

/// `settings` with the `--set` knobs applied, through reflection (those of [`SHADOW_KNOB`] go to
/// [`with_shadow_knobs`]).
fn with_knobs(
    mut settings: VolumetricClouds,
    knobs: &[(String, String)],
) -> Result<VolumetricClouds, String> {
    let ours = knobs
        .iter()
        .filter(|(f, _)| !f.starts_with(SHADOW_KNOB))
        .map(|(f, v)| (f.as_str(), v.as_str()));
    set_fields(&mut settings, ours, "VolumetricClouds")?;
    Ok(settings)
}

/// The cloud shadow map's settings with the `--set shadows.FIELD=VALUE` knobs applied.
fn with_shadow_knobs(
    mut shadows: CloudShadows,
    knobs: &[(String, String)],
) -> Result<CloudShadows, String> {
    let ours = knobs
        .iter()
        .filter_map(|(f, v)| Some((f.strip_prefix(SHADOW_KNOB)?, v.as_str())));
    set_fields(&mut shadows, ours, "CloudShadows")?;
    Ok(shadows)
}

/// Sets each `(FIELD, VALUE)` on `target` (a `kind`) through reflection.
fn set_fields<'a, T: bevy::reflect::Reflect>(
    target: &mut T,
    knobs: impl Iterator<Item = (&'a str, &'a str)>,
    kind: &str,
) -> Result<(), String> {
    use bevy::reflect::GetPath;
    for (field, value) in knobs {
        let bad = |e: &dyn std::fmt::Display| format!("--set {field}={value}: {e}");
        if let Ok(v) = target.path_mut::<f32>(field) {
            *v = value.parse().map_err(|e| bad(&e))?;
        } else if let Ok(v) = target.path_mut::<u32>(field) {
            *v = value.parse().map_err(|e| bad(&e))?;
        } else if let Ok(v) = target.path_mut::<bool>(field) {
            *v = value.parse().map_err(|e| bad(&e))?;
        } else {
            return Err(bad(&format!("no such f32, u32 or bool field of {kind}")));
        }
    }
    Ok(())
}

/// Primary steps per interval of the converged reference (`--reference-steps`).
const REFERENCE_STEPS: u32 = 512;

/// The converged reference: `steps` primary steps per interval, 64 light steps, no jitter, no
/// early exit.
fn reference_settings(steps: u32) -> VolumetricClouds {
    VolumetricClouds {
        primary_steps: steps,
        light_steps: 64,
        transmittance_cutoff: 0.0,
        jitter: false,
        min_step_m: 0.0,
        ..VolumetricClouds::ULTRA
    }
}

fn presets() -> [(&'static str, VolumetricClouds); 4] {
    [
        ("LOW", VolumetricClouds::LOW),
        ("MEDIUM", VolumetricClouds::MEDIUM),
        ("HIGH", VolumetricClouds::HIGH),
        ("ULTRA", VolumetricClouds::ULTRA),
    ]
}

/// The six bench scenes: the showcase four, a grazing view along the horizon, and a veil of
/// cirrostratus with the sun in the view (an optically thin layer, whose rays never reach the
/// early exit).
fn bench_scenes() -> Vec<Scene> {
    let mut scenes = showcase_scenes();
    let mut grazing = showcase_scenes().remove(0);
    grazing.name = "grazing_horizon";
    grazing.camera = Transform::from_xyz(0.0, 2.0, 0.0)
        .looking_to(Vec3::new(0.0, 1.5f32.to_radians().tan(), -1.0), Vec3::Y);
    scenes.push(grazing);
    let mut veil = showcase_scenes().remove(0);
    veil.name = "cirrostratus_halo";
    veil.camera = looking(Vec3::new(0.0, 2.0, 0.0), 35.0, 150.0);
    veil.sun_deg = (35.0, 150.0);
    veil.layers = vec![layer(CloudKind::Cirrostratus, 1.0)];
    scenes.push(veil);
    scenes
}

/// Renders frames until no render pipeline is waiting to compile (at most
/// [`PIPELINE_WAIT_FRAMES`]). On software Vulkan a compile runs on the same CPU cores as the
/// "GPU", so a frame timed while one is under way comes out several times too slow.
fn wait_for_pipelines(rig: &mut CloudRig) {
    for _ in 0..PIPELINE_WAIT_FRAMES {
        let waiting = rig
            .app
            .render_world()
            .resource::<PipelineCache>()
            .waiting_pipelines()
            .count();
        if waiting == 0 {
            return;
        }
        rig.app.update();
    }
    eprintln!(
        "bench: render pipelines still compiling after {PIPELINE_WAIT_FRAMES} frames; the \
         timing includes their compile"
    );
}

/// Most frames [`wait_for_pipelines`] renders.
const PIPELINE_WAIT_FRAMES: u32 = 600;

/// The median wall time of `frames` frames, once the pipelines are compiled; the render
/// diagnostics ([`print_gpu_spans`]) then hold these frames only.
fn median_frame_time(rig: &mut CloudRig, frames: u32) -> Duration {
    wait_for_pipelines(rig);
    clear_gpu_spans(rig);
    let mut times: Vec<Duration> = (0..frames)
        .map(|_| {
            let start = Instant::now();
            rig.app.update();
            start.elapsed()
        })
        .collect();
    times.sort();
    times[times.len() / 2]
}

/// The composite over a mid-grey background, and its linear luminance.
const BACKGROUND: f32 = 0.25;

struct Measured {
    ms: f64,
    composite: Vec<[f32; 3]>,
    nan_count: usize,
}

fn measure(
    rig: &mut CloudRig,
    scene: &Scene,
    settings: &VolumetricClouds,
    frames: u32,
    converge: bool,
) -> Measured {
    let mut baseline_scene = Scene {
        settings: settings.clone(),
        layers: scene
            .layers
            .iter()
            .map(|l| CloudLayer {
                coverage: 0.0,
                ..l.clone()
            })
            .collect(),
        ..scene.clone()
    };
    rig.set_scene(&baseline_scene);
    rig.app.run_frames(2);
    let baseline = median_frame_time(rig, frames);

    baseline_scene.layers.clone_from(&scene.layers);
    rig.set_scene(&baseline_scene);
    // With temporal accumulation the error is that of the settled image a still view shows.
    // Timing alone needs no converged image.
    let settle = if converge {
        common::accumulation_frames_until(settings, 0.01).max(2)
    } else {
        2
    };
    let (radiance, transmittance) = rig.render(settle);
    let with_clouds = median_frame_time(rig, frames);

    let nan_count = radiance
        .iter()
        .zip(&transmittance)
        .filter(|(l, t)| !(l.iter().all(|v| v.is_finite()) && t.is_finite()))
        .count();
    let composite = radiance
        .iter()
        .zip(&transmittance)
        .map(|(l, t)| l.map(|v| v + BACKGROUND * t))
        .collect();
    Measured {
        ms: (with_clouds.as_secs_f64() - baseline.as_secs_f64()).max(0.0) * 1e3,
        composite,
        nan_count,
    }
}

/// What each optional effect costs: the median whole-frame time with the effect and without it
/// (CSV `effect,scene,ms_with,ms_without,ratio`), each on the cumulus scene with `MEDIUM`:
///
/// - `cloud_shadows`: the shadow map pass ([`CloudShadows::default`], 256²);
/// - `haze`: haze at 20 km visibility, light shafts off (the clouds' mean shade), against none;
/// - `light_shafts`: that haze reading the shadow map (shafts on), against shafts off, with
///   the shadow map on in both;
/// - `sun_from_shadow_map`: `MEDIUM` (samples' sun from the shadow map where it may light them)
///   against `MEDIUM` with the full light march everywhere, the map on in both;
/// - `rain`: 3 mm/h from the cumulus (a rain-shaft layer under it and the particles), against
///   none;
/// - `fog`: a fog layer at 1 km visibility (coverage 1, 150 m deep), against none;
/// - `temporal_accumulation`: `MEDIUM`'s accumulation of jittered frames (blend 0.1), against
///   each frame alone (blend 1);
/// - `weather_map`: `MEDIUM`'s weather map (512² per layer, rebuilt each frame) against each
///   sample computing its coverage (a ratio below 1 is a saving).
fn measure_effects(rig: &mut CloudRig, frames: u32) -> String {
    let base = Scene {
        settings: VolumetricClouds::MEDIUM,
        ..showcase_scenes().remove(0)
    };
    let mut csv = String::from("effect,scene,ms_with,ms_without,ratio\n");
    // Sets the rig up for one side of a comparison and times it.
    let time = |rig: &mut CloudRig, scene: &Scene, shadows: bool, haze: Haze| {
        rig.set_scene(scene);
        rig.app.world().resource_mut::<CloudShadows>().enabled = shadows;
        rig.app.world().insert_resource(haze);
        rig.app.run_frames(2);
        median_frame_time(rig, frames).as_secs_f64() * 1e3
    };
    let mut row = |effect: &str, with: f64, without: f64| {
        csv.push_str(&format!(
            "{effect},{},{with:.3},{without:.3},{:.3}\n",
            base.name,
            with / without
        ));
    };
    // The base scene with other settings.
    let medium_with = |settings: VolumetricClouds| Scene {
        settings,
        ..base.clone()
    };
    let clear = Haze::default();
    let hazy = Haze::with_visibility(20_000.0);
    let with = time(rig, &base, true, clear.clone());
    let without = time(rig, &base, false, clear.clone());
    row("cloud_shadows", with, without);

    let flat = medium_with(VolumetricClouds {
        light_shafts: false,
        ..VolumetricClouds::MEDIUM
    });
    let with = time(rig, &flat, false, hazy.clone());
    let without = time(rig, &flat, false, clear.clone());
    row("haze", with, without);

    let with = time(rig, &base, true, hazy.clone());
    let without = time(rig, &flat, true, hazy);
    row("light_shafts", with, without);

    // MEDIUM's samples read their sun from the shadow map; against the full light march
    // everywhere, both with the map on (a ratio below 1 is a saving).
    let marched = medium_with(VolumetricClouds {
        sun_from_shadow_map_m: f32::INFINITY,
        ..VolumetricClouds::MEDIUM
    });
    let with = time(rig, &base, true, clear.clone());
    let without = time(rig, &marched, true, clear.clone());
    row("sun_from_shadow_map", with, without);

    let mut raining = base.clone();
    raining.layers[0].rain_mm_per_h = 3.0;
    let with = time(rig, &raining, false, clear.clone());
    let without = time(rig, &base, false, clear.clone());
    row("rain", with, without);

    let mut foggy = base.clone();
    let mut fog = LayerSlot::Fog.initial_layer();
    fog.coverage = 1.0;
    fog.density = 3.912 / 1_000.0;
    foggy.layers.push(fog);
    let with = time(rig, &foggy, false, clear.clone());
    let without = time(rig, &base, false, clear.clone());
    row("fog", with, without);

    let alone = medium_with(VolumetricClouds {
        temporal_blend: 1.0,
        ..VolumetricClouds::MEDIUM
    });
    let with = time(rig, &base, false, clear.clone());
    let without = time(rig, &alone, false, clear.clone());
    row("temporal_accumulation", with, without);

    let unmapped = medium_with(VolumetricClouds {
        weather_map_size: 0,
        ..VolumetricClouds::MEDIUM
    });
    let with = time(rig, &base, false, clear.clone());
    let without = time(rig, &unmapped, false, clear);
    row("weather_map", with, without);
    csv
}

/// (relative RMSE, largest absolute difference) of linear luminance.
fn errors(image: &[[f32; 3]], reference: &[[f32; 3]]) -> (f64, f64) {
    let lum = |pixels: &[[f32; 3]]| pixels.iter().map(luminance).collect::<Vec<f64>>();
    errors_of(&lum(image), &lum(reference))
}

/// (relative RMSE, largest absolute difference) of two images of one value per pixel.
fn errors_of(image: &[f64], reference: &[f64]) -> (f64, f64) {
    let n = reference.len() as f64;
    let mean = reference.iter().sum::<f64>() / n;
    let (mut sum, mut max) = (0.0, 0.0f64);
    for (a, b) in image.iter().zip(reference) {
        let d = a - b;
        sum += d * d;
        max = max.max(d.abs());
    }
    ((sum / n).sqrt() / mean.max(f64::MIN_POSITIVE), max)
}

/// Relative difference at which the difference panel turns white.
const DIFFERENCE_WHITE: f64 = 0.2;

/// The difference panel of a bench strip: each pixel's `|Δ|` of linear luminance over the
/// reference's mean, as grey (white at [`DIFFERENCE_WHITE`]), and the share of the summed `Δ²`
/// that the worst 1 % of pixels carry (1 when the error sits in a few pixels, 0.01 when it is
/// spread evenly).
fn difference_map(image: &[[f32; 3]], reference: &[[f32; 3]]) -> (Vec<[f32; 3]>, f64) {
    let mean = reference.iter().map(luminance).sum::<f64>() / reference.len().max(1) as f64;
    let relative: Vec<f64> = image
        .iter()
        .zip(reference)
        .map(|(a, b)| (luminance(a) - luminance(b)).abs() / mean.max(f64::MIN_POSITIVE))
        .collect();
    let mut squares: Vec<f64> = relative.iter().map(|d| d * d).collect();
    squares.sort_by(|a, b| b.total_cmp(a));
    let total: f64 = squares.iter().sum();
    let worst = squares.len().div_ceil(100);
    let share = squares[..worst].iter().sum::<f64>() / total.max(f64::MIN_POSITIVE);
    let panel = relative
        .iter()
        .map(|d| [(d / DIFFERENCE_WHITE).min(1.0) as f32; 3])
        .collect();
    (panel, share)
}

/// Where `scene`'s error comes from: the CPU reference at 48×27 (no GPU, small noise, no jitter)
/// with primary steps, light steps, cut-off and step growth changed one at a time, each against
/// 512 primary and 64 light steps. Prints relative RMSE and mean bias of `L · 10⁻⁴ + 0.25 T`.
fn error_budget(scene: &Scene) {
    let textures = CloudTextures::from_recipe(&small_recipe());
    let (w, h) = (48u32, 27u32);
    // The rig's camera and sun.
    let fov = 60f32.to_radians();
    let sun = CloudSun {
        direction: sun_direction(scene.sun_deg),
        illuminance_rgb: [100_000.0; 3],
        through_atmosphere: false,
    };
    // The image marched with every ray's samples `jitter` of the way through their steps.
    let image = |primary: u32, light: u32, cutoff: f32, growth: f32, jitter: f64| -> Vec<f64> {
        let settings = VolumetricClouds {
            primary_steps: primary,
            light_steps: light,
            transmittance_cutoff: cutoff,
            step_growth: growth,
            jitter: false,
            ..VolumetricClouds::MEDIUM
        };
        let (march, layers) = march_inputs(
            &CloudWorld::default(),
            &settings,
            &GlobalTransform::from(scene.camera),
            f64::from(fov) / f64::from(h),
            Some(&sun),
            scene.layers.iter().map(|layer| (layer, None)),
            0,
        );
        let t = (0.5 * fov).tan();
        (0..h)
            .flat_map(|y| (0..w).map(move |x| (x, y)))
            .map(|(x, y)| {
                let ndc = Vec2::new(
                    (x as f32 + 0.5) / w as f32 * 2.0 - 1.0,
                    1.0 - (y as f32 + 0.5) / h as f32 * 2.0,
                );
                let local = Vec3::new(ndc.x * t * w as f32 / h as f32, ndc.y * t, -1.0);
                let direction = (scene.camera.rotation * local).normalize();
                let r = march_clouds(
                    &textures,
                    &march,
                    &layers,
                    march.camera_altitude_m,
                    march.camera_up,
                    direction.as_dvec3().to_array(),
                    f64::INFINITY,
                    jitter,
                    None,
                );
                let l = r.radiance.map(|v| v as f32);
                luminance(&l) * 1e-4 + 0.25 * r.transmittance
            })
            .collect()
    };
    // The mean over `JITTERS` evenly spaced jitters: what the temporal accumulation of jittered
    // frames converges to.
    const JITTERS: u32 = 16;
    let jitter_mean = |primary: u32, light: u32, cutoff: f32, growth: f32| -> Vec<f64> {
        let mut sum = vec![0.0; (w * h) as usize];
        for i in 0..JITTERS {
            let jitter = (f64::from(i) + 0.5) / f64::from(JITTERS);
            for (s, v) in sum
                .iter_mut()
                .zip(image(primary, light, cutoff, growth, jitter))
            {
                *s += v / f64::from(JITTERS);
            }
        }
        sum
    };
    let reference = image(512, 64, 0.0, 2.0e-5, 0.5);
    let mean = reference.iter().sum::<f64>() / reference.len() as f64;
    println!("{}: against 512 primary and 64 light steps", scene.name);
    let (low, high, ultra) = (
        VolumetricClouds::LOW,
        VolumetricClouds::HIGH,
        VolumetricClouds::ULTRA,
    );
    let (hp, hl, hc, hg) = (
        high.primary_steps,
        high.light_steps,
        high.transmittance_cutoff,
        high.step_growth,
    );
    let rows: [(&str, u32, u32, f32, f32, bool); 11] = [
        ("512 primary, 16 light", 512, 16, 0.0, hg, false),
        ("512 primary, 32 light", 512, 32, 0.0, hg, false),
        ("HIGH", hp, hl, hc, hg, false),
        ("HIGH, jitter mean", hp, hl, hc, hg, true),
        ("HIGH, 32 light", hp, 32, hc, hg, false),
        ("HIGH, twice the primary", 2 * hp, hl, hc, hg, false),
        ("HIGH, twice the primary, mean", 2 * hp, hl, hc, hg, true),
        ("HIGH, no cut-off", hp, hl, 0.0, hg, false),
        ("HIGH, even steps", hp, hl, hc, 0.0, false),
        (
            "ULTRA, jitter mean",
            ultra.primary_steps,
            ultra.light_steps,
            ultra.transmittance_cutoff,
            ultra.step_growth,
            true,
        ),
        (
            "LOW steps, jitter mean",
            low.primary_steps,
            low.light_steps,
            low.transmittance_cutoff,
            low.step_growth,
            true,
        ),
    ];
    for (name, primary, light, cutoff, growth, mean_of_jitters) in rows {
        let test = if mean_of_jitters {
            jitter_mean(primary, light, cutoff, growth)
        } else {
            image(primary, light, cutoff, growth, 0.5)
        };
        let (rel_rmse, _) = errors_of(&test, &reference);
        let bias = (test.iter().sum::<f64>() - reference.iter().sum::<f64>())
            / reference.len() as f64
            / mean;
        println!(
            "{name:>24}: relative RMSE {:6.2} %, bias {:+6.2} %",
            100.0 * rel_rmse,
            100.0 * bias
        );
    }
}

/// With `--docs DIR`: `DIR/performance.md` and `DIR/images/bench.svg` for `rows` and the
/// `effects` CSV, with the command line that measured them.
fn write_docs(
    args: &Args,
    rows: &[Row],
    truth: &[TruthRow],
    effects: &str,
    times: Option<&str>,
    peer: Option<&str>,
) -> Result<(), String> {
    let Some(dir) = &args.docs else {
        return Ok(());
    };
    let images = dir.join("images");
    std::fs::create_dir_all(&images)
        .map_err(|e| format!("cannot create {}: {e}", images.display()))?;
    plot(rows, truth, &images.join("bench.svg"))?;
    // The build that measured: a debug build's CPU work per frame is slower, not its GPU's.
    let cargo = if cfg!(debug_assertions) {
        "cargo run --example bench --"
    } else {
        "cargo run --release --example bench --"
    };
    let command = match &args.from_csv {
        Some(from) => format!(
            "{cargo} --from-csv {} --docs {}",
            from.display(),
            dir.display()
        ),
        None => std::iter::once(cargo.to_owned())
            .chain(std::env::args().skip(1))
            .collect::<Vec<_>>()
            .join(" "),
    };
    let path = dir.join("performance.md");
    std::fs::write(
        &path,
        performance_md(
            rows,
            truth,
            effects,
            times,
            peer,
            &command,
            "images/bench.svg",
        ),
    )
    .map_err(|e| format!("cannot write {}: {e}", path.display()))
}

/// Each selected preset (with the `--set` knobs) against the path-traced truth, written to
/// `truth.csv` in `--out`.
fn measure_truth(args: &Args) -> Result<Vec<TruthRow>, String> {
    let presets = selected_presets(args)
        .map(|(name, settings)| {
            let mut settings = with_knobs(settings, &args.knobs)?;
            settings.jitter &= !args.no_jitter;
            Ok((name, settings))
        })
        .collect::<Result<Vec<_>, String>>()?;
    let rows = truth::measure(&presets)?;
    let path = args.out.join("truth.csv");
    std::fs::write(&path, truth::to_csv(&rows))
        .map_err(|e| format!("cannot write {}: {e}", path.display()))?;
    Ok(rows)
}

/// The presets `--presets` names, all of them without it.
fn selected_presets(args: &Args) -> impl Iterator<Item = (&'static str, VolumetricClouds)> {
    presets()
        .into_iter()
        .filter(|(name, _)| args.presets.is_empty() || args.presets.iter().any(|p| p == name))
}

/// The reference of `scene`: from `--reference-cache` when it holds it, measured (and stored
/// there) otherwise. A cached file is the time in ms, then the composite, as little-endian f64
/// and f32.
fn cached_reference(args: &Args, rig: &mut CloudRig, scene: &Scene) -> Result<Measured, String> {
    let settings = reference_settings(args.reference_steps);
    let Some(dir) = &args.reference_cache else {
        return Ok(measure(rig, scene, &settings, args.frames, true));
    };
    // The shadow knobs change the reference's ground shadows: they name it too.
    let shadow_knobs: String = args
        .knobs
        .iter()
        .filter_map(|(f, v)| Some(format!("_{}{v}", f.strip_prefix(SHADOW_KNOB)?)))
        .collect();
    let path = dir.join(format!(
        "{}_{}x{}_{}{}.bin",
        scene.name,
        args.width,
        args.height,
        args.reference_steps,
        if args.shadows {
            format!("_shadows{shadow_knobs}")
        } else {
            String::new()
        }
    ));
    let pixels = (args.width * args.height) as usize;
    if let Ok(bytes) = std::fs::read(&path)
        && bytes.len() == 8 + 12 * pixels
    {
        let ms = f64::from_le_bytes(bytes[..8].try_into().expect("8 bytes"));
        let values: Vec<f32> = bytes[8..]
            .chunks_exact(4)
            .map(|b| f32::from_le_bytes(b.try_into().expect("4 bytes")))
            .collect();
        let composite: Vec<[f32; 3]> = values.chunks_exact(3).map(|c| [c[0], c[1], c[2]]).collect();
        let nan_count = composite
            .iter()
            .filter(|p| !p.iter().all(|v| v.is_finite()))
            .count();
        return Ok(Measured {
            ms,
            composite,
            nan_count,
        });
    }
    let measured = measure(rig, scene, &settings, args.frames, true);
    let mut bytes = measured.ms.to_le_bytes().to_vec();
    for value in measured.composite.iter().flatten() {
        bytes.extend_from_slice(&value.to_le_bytes());
    }
    std::fs::create_dir_all(dir)
        .and_then(|()| std::fs::write(&path, bytes))
        .map_err(|e| format!("cannot write {}: {e}", path.display()))?;
    Ok(measured)
}

/// `--time-only`: the cloud pass's cost of each selected preset in each selected scene, at each
/// of `--sizes` and with each of `--layers` layer counts, appended to `times.csv` (written with
/// its header when absent).
/// Grid sizes the growth bench times: the seed's default field (Rosa 2013 §5.1.1: 100 × 100 ×
/// 10) and powers of two up to the 256 × 256 × 16 a layer's weather map would use.
const GROWTH_SIZES: [[u32; 3]; 4] = [[64, 64, 16], [100, 100, 10], [128, 128, 16], [256, 256, 16]];

/// Times one automaton step per grid size: `--frames` × 4 steps submitted at once and read back,
/// less a read-back alone, over the steps (the median of five such runs); then the same for the
/// cover pass each step is followed by (`GrowthCompute::write_cover`).
fn time_growth(args: &Args) -> Result<(), String> {
    use bevy::render::{
        render_resource::TextureViewDescriptor,
        renderer::{RenderDevice, RenderQueue},
    };
    use bevy_cloudscape::{
        reference::growth::{GrowthGrid, probability_threshold},
        render::growth::GrowthCompute,
    };
    let mut app = common::headless::Headless::new(
        UVec2::splat(2),
        bevy::render::render_resource::TextureFormat::Rgba8UnormSrgb,
        |_| {},
    );
    let device = app.render_world().resource::<RenderDevice>().clone();
    let queue = app.render_world().resource::<RenderQueue>().clone();
    let columns = [[probability_threshold(0.3), probability_threshold(0.001)]];
    let extinction = probability_threshold(0.02);
    let steps = 4 * args.frames;
    let mut csv = String::from("width,length,depth,cells,ms_per_step,ms_per_cover\n");
    for size in GROWTH_SIZES {
        let grid = GrowthGrid::new(size);
        let mut gpu = GrowthCompute::new(&device, &grid, &columns);
        let mut step = 0;
        let mut run = |gpu: &mut GrowthCompute, app: &mut common::headless::Headless, n: u32| {
            let start = std::time::Instant::now();
            gpu.step(&device, &queue, 1, extinction, step, n);
            step += n;
            app.read_buffer(gpu.cells(), 0, 4);
            start.elapsed().as_secs_f64() * 1000.0
        };
        run(&mut gpu, &mut app, 4);
        let mut per_step: Vec<f64> = (0..5)
            .map(|_| {
                let readback = run(&mut gpu, &mut app, 0);
                (run(&mut gpu, &mut app, steps) - readback).max(0.0) / f64::from(steps)
            })
            .collect();
        per_step.sort_by(f64::total_cmp);
        let ms = per_step[2];
        // The cover the weather reads after a step (column counts and their 5 x 5 mean).
        let texture = gpu.cover_texture(&device);
        let view = texture.create_view(&TextureViewDescriptor::default());
        let mut per_cover: Vec<f64> = (0..5)
            .map(|_| {
                let readback = run(&mut gpu, &mut app, 0);
                let start = std::time::Instant::now();
                for _ in 0..steps {
                    gpu.write_cover(&device, &queue, &view);
                }
                app.read_buffer(gpu.cells(), 0, 4);
                (start.elapsed().as_secs_f64() * 1000.0 - readback).max(0.0) / f64::from(steps)
            })
            .collect();
        per_cover.sort_by(f64::total_cmp);
        let cover_ms = per_cover[2];
        let cells = size.iter().product::<u32>();
        println!(
            "growth {}x{}x{} ({cells} cells): {ms:.3} ms per step, {cover_ms:.3} ms per cover",
            size[0], size[1], size[2]
        );
        csv.push_str(&format!(
            "{},{},{},{cells},{ms:.4},{cover_ms:.4}\n",
            size[0], size[1], size[2]
        ));
    }
    let path = args.out.join("growth.csv");
    std::fs::write(&path, &csv).map_err(|e| format!("cannot write {}: {e}", path.display()))?;
    print!("{csv}");
    Ok(())
}

/// A rig of `size` with the render diagnostics when `--gpu-spans` reads them and the cloud
/// shadow map as `--shadows` says.
fn bench_rig(args: &Args, size: UVec2) -> Result<CloudRig, String> {
    let mut rig = if args.gpu_spans {
        CloudRig::with_gpu_spans(size, Msaa::Off, default())
    } else {
        CloudRig::new(size, Msaa::Off, default())
    };
    let shadows = CloudShadows {
        enabled: args.shadows,
        ..with_shadow_knobs(CloudShadows::default(), &args.knobs)?
    };
    *rig.app.world().resource_mut::<CloudShadows>() = shadows;
    Ok(rig)
}

/// The sizes `--time-only` times at: `--sizes`, or `--width`×`--height`.
fn timed_sizes(args: &Args) -> Vec<UVec2> {
    if args.sizes.is_empty() {
        vec![args.size()]
    } else {
        args.sizes.clone()
    }
}

/// The bench scenes `--time-only` times: `--scene`'s, or all of them.
fn timed_scenes(args: &Args) -> impl Iterator<Item = Scene> + '_ {
    bench_scenes()
        .into_iter()
        .filter(|s| args.scene.as_deref().is_none_or(|name| name == s.name))
}

/// The CSV at `path` to append rows to: its text, or `header` alone when it is absent or empty.
fn appended_csv(path: &std::path::Path, header: &str) -> String {
    match std::fs::read_to_string(path) {
        Ok(text) if !text.trim().is_empty() => text,
        _ => format!("{header}\n"),
    }
}

fn time_only(args: &Args) -> Result<(), String> {
    let path = args.out.join("times.csv");
    let mut csv = appended_csv(&path, "scene,preset,width,height,layers,ms_per_frame");
    let spans_path = args.out.join("spans.csv");
    let mut spans_csv = appended_csv(
        &spans_path,
        "scene,preset,width,height,layers,shadows,knobs,pass,ms",
    );
    let knobs: Vec<String> = args.knobs.iter().map(|(k, v)| format!("{k}={v}")).collect();
    let knobs = knobs.join(" ");
    for size in timed_sizes(args) {
        let mut rig = bench_rig(args, size)?;
        for scene in timed_scenes(args) {
            for &count in &args.layers {
                let stacked = Scene {
                    layers: stacked_layers(&scene.layers, count),
                    ..scene.clone()
                };
                for (preset, settings) in selected_presets(args) {
                    let mut settings = with_knobs(settings, &args.knobs)?;
                    settings.jitter &= !args.no_jitter;
                    let measured = measure(&mut rig, &stacked, &settings, args.frames, false);
                    if args.gpu_spans {
                        for (pass, ms) in print_gpu_spans(&mut rig, preset) {
                            spans_csv.push_str(&format!(
                                "{},{preset},{},{},{count},{},{knobs},{pass},{ms:.3}\n",
                                scene.name, size.x, size.y, args.shadows
                            ));
                        }
                    }
                    let line = format!(
                        "{},{preset},{},{},{count},{:.3}",
                        scene.name, size.x, size.y, measured.ms
                    );
                    eprintln!("{line}");
                    csv.push_str(&line);
                    csv.push('\n');
                }
            }
        }
    }
    std::fs::write(&path, &csv).map_err(|e| format!("cannot write {}: {e}", path.display()))?;
    if args.gpu_spans {
        std::fs::write(&spans_path, &spans_csv)
            .map_err(|e| format!("cannot write {}: {e}", spans_path.display()))?;
    }
    print!("{csv}");
    Ok(())
}

/// `--time-only` with `--variant`: each selected preset (with the `--set` knobs) and each
/// variant of it timed in turn, `--rounds` times, in each selected scene at each of `--sizes`,
/// with one layer. Appends to `variants.csv`
/// (`scene,preset,width,height,variant,knobs,rounds,ms_per_frame,march_ms,ratio`):
/// `ms_per_frame` the median over the rounds of the cloud cost (as in `times.csv`), `march_ms`
/// the median of the march pass's GPU time with `--gpu-spans` (empty without), and `ratio` the
/// variant's `march_ms` (`ms_per_frame` without spans) over the preset's. The preset's own row
/// is the variant `preset`.
fn time_variants(args: &Args) -> Result<(), String> {
    const MARCH_SPAN: &str = "render/clouds/cloud_march";
    let path = args.out.join("variants.csv");
    let mut csv = appended_csv(
        &path,
        "scene,preset,width,height,variant,knobs,rounds,ms_per_frame,march_ms,ratio",
    );
    let own = Variant {
        name: "preset".into(),
        knobs: Vec::new(),
    };
    let variants: Vec<&Variant> = std::iter::once(&own).chain(&args.variants).collect();
    for size in timed_sizes(args) {
        let mut rig = bench_rig(args, size)?;
        for scene in timed_scenes(args) {
            for (preset, settings) in selected_presets(args) {
                let preset_settings = with_knobs(settings, &args.knobs)?;
                // Per variant: the cloud cost and the march's span of each round.
                let mut times = vec![(Vec::new(), Vec::new()); variants.len()];
                for round in 0..args.rounds {
                    for (variant, (costs, marches)) in variants.iter().zip(&mut times) {
                        let mut settings = with_knobs(preset_settings.clone(), &variant.knobs)?;
                        settings.jitter &= !args.no_jitter;
                        let measured = measure(&mut rig, &scene, &settings, args.frames, false);
                        costs.push(measured.ms);
                        if args.gpu_spans {
                            let spans = print_gpu_spans(&mut rig, preset);
                            if let Some((_, ms)) = spans.iter().find(|(p, _)| p == MARCH_SPAN) {
                                marches.push(*ms);
                            }
                        }
                        eprintln!(
                            "variant,{},{preset},{},round {},{:.3} ms",
                            scene.name,
                            variant.name,
                            round + 1,
                            measured.ms
                        );
                    }
                }
                let medians: Vec<(f64, Option<f64>)> = times
                    .into_iter()
                    .map(|(costs, marches)| {
                        // Every round timed the march, or the column stays empty.
                        let march = (marches.len() == costs.len())
                            .then(|| report::median(marches))
                            .flatten();
                        (report::median(costs).unwrap_or(f64::NAN), march)
                    })
                    .collect();
                let (own_cost, own_march) = medians[0];
                for (variant, (cost, march)) in variants.iter().zip(&medians) {
                    let ratio = match (march, own_march) {
                        (Some(m), Some(o)) => m / o,
                        _ => cost / own_cost,
                    };
                    let knobs: Vec<String> = variant
                        .knobs
                        .iter()
                        .map(|(k, v)| format!("{k}={v}"))
                        .collect();
                    csv.push_str(&format!(
                        "{},{preset},{},{},{},{},{},{cost:.3},{},{ratio:.3}\n",
                        scene.name,
                        size.x,
                        size.y,
                        variant.name,
                        knobs.join(" "),
                        args.rounds,
                        march.map_or(String::new(), |m| format!("{m:.3}")),
                    ));
                }
            }
        }
    }
    std::fs::write(&path, &csv).map_err(|e| format!("cannot write {}: {e}", path.display()))?;
    print!("{csv}");
    Ok(())
}

/// Forgets the render diagnostics' history, so the next [`print_gpu_spans`] averages only the
/// frames after this.
fn clear_gpu_spans(rig: &mut CloudRig) {
    if let Some(mut store) = rig
        .app
        .world()
        .get_resource_mut::<bevy::diagnostic::DiagnosticsStore>()
    {
        for diagnostic in store.iter_mut() {
            diagnostic.clear_history();
        }
    }
}

/// Prints the mean GPU time of each cloud pass since [`clear_gpu_spans`] (stderr:
/// `gpu_span,PRESET,PASS,ms`) and returns them as `(pass, ms)`.
fn print_gpu_spans(rig: &mut CloudRig, preset: &str) -> Vec<(String, f64)> {
    let world = rig.app.world();
    let Some(store) = world.get_resource::<bevy::diagnostic::DiagnosticsStore>() else {
        return Vec::new();
    };
    let mut spans: Vec<(String, f64)> = store
        .iter()
        .filter_map(|d| {
            let path = d.path().as_str();
            let pass = path.strip_suffix("/elapsed_gpu")?;
            let ms = d.average()?;
            pass.contains("cloud").then(|| (pass.to_owned(), ms))
        })
        .collect();
    spans.sort_by(|a, b| a.0.cmp(&b.0));
    if spans.is_empty() {
        eprintln!("gpu_span,{preset}: no GPU spans (does the device have timestamp queries?)");
    }
    for (pass, ms) in &spans {
        eprintln!("gpu_span,{preset},{pass},{ms:.3}");
    }
    spans
}

/// `count` copies of `layers` stacked one above the other, 100 m apart.
fn stacked_layers(layers: &[CloudLayer], count: u32) -> Vec<CloudLayer> {
    (0..count)
        .flat_map(|i| {
            layers.iter().map(move |l| {
                let lift = i as f32 * (l.top_m - l.base_m + 100.0);
                CloudLayer {
                    base_m: l.base_m + lift,
                    top_m: l.top_m + lift,
                    ..l.clone()
                }
            })
        })
        .collect()
}

fn run(args: &Args) -> Result<(), String> {
    if let Some(dir) = &args.from_csv {
        let read = |name: &str| {
            let path = dir.join(name);
            std::fs::read_to_string(&path)
                .map(|text| (path.clone(), text))
                .map_err(|e| format!("cannot read {}: {e}", path.display()))
        };
        let (csv_path, csv) = read("bench.csv")?;
        let (_, effects) = read("effects.csv")?;
        let times = read("times.csv").ok().map(|(_, text)| text);
        let peer = read("peer.csv").ok().map(|(_, text)| text);
        let truth = match read("truth.csv") {
            Ok((path, text)) => truth::from_csv(&path, &text)?,
            Err(_) => Vec::new(),
        };
        return write_docs(
            args,
            &report::from_csv(&csv_path, &csv)?,
            &truth,
            &effects,
            times.as_deref(),
            peer.as_deref(),
        );
    }
    if args.error_budget {
        for scene in showcase_scenes() {
            if matches!(scene.name, "cumulus_noon" | "sunset_behind_clouds") {
                error_budget(&scene);
            }
        }
        return Ok(());
    }
    std::fs::create_dir_all(args.out.join("images"))
        .map_err(|e| format!("cannot create {}: {e}", args.out.display()))?;
    if args.time_only && !args.variants.is_empty() {
        return time_variants(args);
    }
    if args.time_only {
        return time_only(args);
    }
    if args.growth {
        return time_growth(args);
    }
    if args.live_refresh {
        #[cfg(feature = "live")]
        return live::time_live_refresh(args);
        #[cfg(not(feature = "live"))]
        return Err("--live-refresh needs the crate's live feature: \
             cargo run --features live --example bench -- --live-refresh"
            .into());
    }
    if args.truth {
        measure_truth(args)?;
        return Ok(());
    }
    let mut rig = bench_rig(args, args.size())?;
    if args.effects_only {
        let effects = measure_effects(&mut rig, args.frames);
        let path = args.out.join("effects.csv");
        std::fs::write(&path, &effects)
            .map_err(|e| format!("cannot write {}: {e}", path.display()))?;
        print!("{effects}");
        return Ok(());
    }
    let mut rows = Vec::new();
    let scenes = bench_scenes()
        .into_iter()
        .filter(|s| args.scene.as_deref().is_none_or(|name| name == s.name));
    for scene in scenes {
        let reference = cached_reference(args, &mut rig, &scene)?;
        eprintln!("{}: reference {:.1} ms", scene.name, reference.ms);
        rows.push(Row {
            scene: scene.name.into(),
            preset: "REFERENCE".into(),
            width: args.width,
            height: args.height,
            ms: reference.ms,
            ref_ms: reference.ms,
            rel_rmse: 0.0,
            max_abs: 0.0,
            nan_count: reference.nan_count,
        });
        // Against a finer reference, the default one is measured too: how far it is converged.
        let default_reference = (args.reference_steps != REFERENCE_STEPS)
            .then(|| ("REFERENCE_512", reference_settings(REFERENCE_STEPS)));
        for (preset, settings) in selected_presets(args).chain(default_reference) {
            let mut settings = with_knobs(settings, &args.knobs)?;
            settings.jitter &= !args.no_jitter;
            let measured = measure(&mut rig, &scene, &settings, args.frames, true);
            let (rel_rmse, max_abs) = errors(&measured.composite, &reference.composite);
            let (difference, worst_share) =
                difference_map(&measured.composite, &reference.composite);
            eprintln!(
                "{}: {preset} {:.1} ms ({:.1} % of the reference), relative RMSE {:.2} % \
                 (the worst 1 % of pixels carry {:.0} % of it squared)",
                scene.name,
                measured.ms,
                100.0 * measured.ms / reference.ms.max(1e-9),
                100.0 * rel_rmse,
                100.0 * worst_share
            );
            save_strip(
                &args
                    .out
                    .join("images")
                    .join(format!("{}_{preset}.png", scene.name)),
                args.size(),
                &[&measured.composite, &reference.composite, &difference],
            );
            rows.push(Row {
                scene: scene.name.into(),
                preset: preset.into(),
                width: args.width,
                height: args.height,
                ms: measured.ms,
                ref_ms: reference.ms,
                rel_rmse,
                max_abs,
                nan_count: measured.nan_count,
            });
        }
    }
    if args.scene.is_some() {
        return Ok(());
    }
    let csv = to_csv(&rows);
    let truth = measure_truth(args)?;
    let effects = measure_effects(&mut rig, args.frames);
    let effects_path = args.out.join("effects.csv");
    std::fs::write(&effects_path, &effects)
        .map_err(|e| format!("cannot write {}: {e}", effects_path.display()))?;
    eprint!("{effects}");
    let csv_path = args.out.join("bench.csv");
    std::fs::write(&csv_path, &csv)
        .map_err(|e| format!("cannot write {}: {e}", csv_path.display()))?;
    plot(&rows, &truth, &args.out.join("bench.svg"))?;
    print!("{csv}");
    let times = std::fs::read_to_string(args.out.join("times.csv")).ok();
    let peer = std::fs::read_to_string(args.out.join("peer.csv")).ok();
    write_docs(
        args,
        &rows,
        &truth,
        &effects,
        times.as_deref(),
        peer.as_deref(),
    )
}

fn main() -> ExitCode {
    match run(&<Args as clap::Parser>::parse()) {
        Ok(()) => ExitCode::SUCCESS,
        Err(message) => {
            eprintln!("bench: {message}");
            ExitCode::from(2)
        }
    }
}
