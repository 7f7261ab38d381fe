//! Prints what the crate makes of forecast files at one instant, as one JSON object: the
//! interpolated weather, the sun, and the cloud layers the mapping derives.
//!
//! ```text
//! cargo run --release --example weather_probe -- FILE [FAR_FILE...] --at RFC3339_INSTANT
//! ```
//!
//! Keys: `time` (RFC 3339, UTC), `place`, `low_cover`, `mid_cover`, `high_cover`, `total_cover`
//! (fractions 0–1), `precipitation_mm_per_h`, `wind_speed_m_s`, `wind_direction_deg`,
//! `sun_elevation_deg`, `sun_azimuth_deg` (clockwise from north), `layers` (an array of
//! `{kind, base_m, top_m, coverage, density}`, heights above ground, density in 1/m), `far` (the
//! same weather values for each far file, with its place), and `warnings`. A value the forecast
//! does not have is `null`, never 0.
//!
//! A file that cannot be read exits with status 2 and one line on stderr naming the file, the
//! key and the index.
//!
//! ```text
//! cargo run --release --example weather_probe -- FILE --bench
//! ```
//!
//! instead times the parser and the sampler on FILE and prints one JSON object: `file_bytes`,
//! `steps` (time steps in the file), `parse_ms_median` (median of 101 parses from memory) and
//! `sample_ns_median` (median over 101 batches of 1000 samples at instants spread over the data;
//! a sample fills a fixed-size `WeatherState` and does not allocate).

use std::process::ExitCode;

use bevy_cloudscape::{
    scene::UtcInstant,
    sky::{Observer, SolarOptions, solar_position},
    weather::{Forecast, Sampler, WeatherState, layers_for_weather},
};
use serde_json::{Value, json};

/// What the crate makes of a forecast at an instant, as JSON.
#[derive(clap::Parser)]
#[command(group = clap::ArgGroup::new("mode").required(true).args(["at", "bench"]))]
struct Args {
    /// The near forecast file (meteoblue or Open-Meteo JSON).
    near: String,
    /// Forecasts of far places, blended in toward their place.
    far: Vec<String>,
    /// The instant to sample, UTC (RFC 3339).
    #[arg(long)]
    at: Option<UtcInstant>,
    /// Time the parse and the sampling of the near file instead.
    #[arg(long)]
    bench: bool,
}

/// `null` for a value the forecast does not have. An f32 is written with its shortest decimal
/// form (0.44, not 0.4399999976158142).
fn number(value: Option<f32>) -> Value {
    value
        .filter(|v| v.is_finite())
        .and_then(|v| v.to_string().parse::<f64>().ok())
        .map_or(Value::Null, |v| json!(v))
}

fn weather_json(state: &WeatherState) -> serde_json::Map<String, Value> {
    let mut object = serde_json::Map::new();
    for (key, value) in [
        ("low_cover", state.low_cover()),
        ("mid_cover", state.mid_cover()),
        ("high_cover", state.high_cover()),
        ("total_cover", state.total_cover()),
        ("precipitation_mm_per_h", state.precipitation_mm_per_h()),
        ("wind_speed_m_s", state.wind_speed_m_s()),
        ("wind_direction_deg", state.wind_direction_deg()),
    ] {
        object.insert(key.into(), number(value));
    }
    object
}

fn sample(forecast: &Forecast, at: UtcInstant, warnings: &mut Vec<String>) -> WeatherState {
    let mut sampler = Sampler::new();
    let state = sampler.sample(forecast, at);
    while let Some(warning) = sampler.take_warning() {
        warnings.push(format!("{}: {warning}", forecast.place.name));
    }
    warnings.extend(
        forecast
            .warnings
            .iter()
            .map(|w| format!("{}: {w}", forecast.place.name)),
    );
    state
}

fn run(args: &Args, at: UtcInstant) -> Result<Value, String> {
    let load = |path: &str| Forecast::from_path(path, None).map_err(|e| e.to_string());
    let near = load(&args.near)?;
    let far = args
        .far
        .iter()
        .map(|path| load(path))
        .collect::<Result<Vec<_>, _>>()?;

    let mut warnings = Vec::new();
    let state = sample(&near, at, &mut warnings);
    let sun = solar_position(&Observer::from(&near.place), at, &SolarOptions::default());
    let (layers, mapping_warnings) = layers_for_weather(&state, near.place.elevation_m as f32);
    warnings.extend(mapping_warnings.iter().map(ToString::to_string));

    let mut object = serde_json::Map::new();
    object.insert("time".into(), json!(at.to_rfc3339()));
    object.insert("place".into(), json!(near.place.name));
    object.extend(weather_json(&state));
    object.insert("sun_elevation_deg".into(), json!(sun.elevation_deg));
    object.insert("sun_azimuth_deg".into(), json!(sun.azimuth_deg));
    object.insert(
        "layers".into(),
        layers
            .iter()
            .map(|layer| {
                json!({
                    "kind": layer.kind.name(),
                    "base_m": number(Some(layer.base_m)),
                    "top_m": number(Some(layer.top_m)),
                    "coverage": number(Some(layer.coverage)),
                    "density": number(Some(layer.density)),
                })
            })
            .collect(),
    );
    object.insert(
        "far".into(),
        far.iter()
            .map(|forecast| {
                let state = sample(forecast, at, &mut warnings);
                let mut entry = weather_json(&state);
                entry.insert("place".into(), json!(forecast.place.name));
                Value::Object(entry)
            })
            .collect(),
    );
    object.insert("warnings".into(), json!(warnings));
    Ok(Value::Object(object))
}

/// Median of `values` (sorted in place).
fn median(values: &mut [f64]) -> f64 {
    values.sort_by(f64::total_cmp);
    values[values.len() / 2]
}

fn bench(path: &str) -> Result<Value, String> {
    use std::time::Instant;
    let bytes = std::fs::read(path).map_err(|e| format!("{path}: {e}"))?;
    let forecast = Forecast::from_slice(&bytes, None).map_err(|e| format!("{path}: {e}"))?;
    let mut parse_ms: Vec<f64> = (0..101)
        .map(|_| {
            let start = Instant::now();
            let parsed = Forecast::from_slice(std::hint::black_box(&bytes), None);
            let elapsed = start.elapsed().as_secs_f64() * 1e3;
            std::hint::black_box(parsed.is_ok());
            elapsed
        })
        .collect();
    let times = &forecast.times;
    let (first, last) = match (times.first(), times.last()) {
        (Some(first), Some(last)) => (first.unix_seconds() as f64, last.unix_seconds() as f64),
        _ => return Err(format!("{path}: no time steps")),
    };
    let mut sampler = Sampler::new();
    let mut sample_ns: Vec<f64> = (0..101)
        .map(|batch| {
            let start = Instant::now();
            for k in 0..1000 {
                let u = ((batch * 1000 + k) as f64 * 0.618_034).fract();
                let state = sampler.sample_unix_seconds(&forecast, first + u * (last - first));
                std::hint::black_box(&state);
            }
            start.elapsed().as_secs_f64() * 1e9 / 1000.0
        })
        .collect();
    Ok(json!({
        "file_bytes": bytes.len(),
        "steps": times.len(),
        "parse_ms_median": median(&mut parse_ms),
        "sample_ns_median": median(&mut sample_ns),
    }))
}

fn main() -> ExitCode {
    let args = <Args as clap::Parser>::parse();
    let result = match args.at {
        Some(at) => run(&args, at),
        None => bench(&args.near),
    };
    match result {
        Ok(value) => {
            println!("{value}");
            ExitCode::SUCCESS
        }
        Err(message) => {
            eprintln!("weather_probe: {message}");
            ExitCode::from(2)
        }
    }
}
