//! `--live-refresh` (crate feature `live`): the frame time across live forecast refreshes. A
//! server on the loopback address answers each download with the bundled Open-Meteo forecast
//! after [`REPLY_DELAY`]; the live forecast refreshes every [`REFRESH`] while the bench scene
//! renders with `MEDIUM`. Each frame's time goes to `live_refresh.csv` with whether a download
//! was under way and whether the frame stored a new forecast, and the medians of the three kinds
//! of frame are printed: a refresh should cost the frame nothing that the other frames' spread
//! does not cover.

use std::{
    io::{BufRead, BufReader, Write},
    net::TcpListener,
    time::{Duration, Instant},
};

use bevy::prelude::*;
use bevy_cloudscape::prelude::*;
use bevy_cloudscape::weather::{LiveForecast, LiveForecasts};

use super::{Args, CloudRig, bench_rig, bench_scenes, wait_for_pipelines};

/// How long the server holds each reply: a download is under way for this long at least.
const REPLY_DELAY: Duration = Duration::from_millis(300);
/// Time between downloads.
const REFRESH: Duration = Duration::from_secs(1);
/// Frames timed.
const FRAMES: u32 = 300;
/// Frames rendered before the live forecast is added.
const WARM_UP_FRAMES: u32 = 30;

/// Serves the bundled Open-Meteo forecast on 127.0.0.1 after [`REPLY_DELAY`]; returns its URL.
fn start_server() -> Result<String, String> {
    let listener =
        TcpListener::bind("127.0.0.1:0").map_err(|e| format!("cannot listen on loopback: {e}"))?;
    let url = format!(
        "http://{}/v1/forecast",
        listener.local_addr().map_err(|e| e.to_string())?
    );
    let body = include_str!("../../assets/weather/bern_open_meteo.json");
    std::thread::spawn(move || {
        for mut stream in listener.incoming().flatten() {
            std::thread::spawn(move || {
                let mut reader = BufReader::new(stream.try_clone().unwrap());
                let mut line = String::new();
                while reader.read_line(&mut line).is_ok_and(|n| n > 2) {
                    line.clear();
                }
                std::thread::sleep(REPLY_DELAY);
                let _ = write!(
                    stream,
                    "HTTP/1.1 200 OK\r\nContent-Type: application/json\r\n\
                     Content-Length: {}\r\nConnection: close\r\n\r\n{body}",
                    body.len()
                );
            });
        }
    });
    Ok(url)
}

/// The `q` quantile (0–1) of `times`, the nearest rank.
fn quantile(mut times: Vec<f64>, q: f64) -> Option<f64> {
    times.sort_by(f64::total_cmp);
    let last = times.len().checked_sub(1)?;
    times.get((q * last as f64).round() as usize).copied()
}

/// Times [`FRAMES`] frames across live forecast refreshes into `OUT/live_refresh.csv`.
pub(crate) fn time_live_refresh(args: &Args) -> Result<(), String> {
    let url = start_server()?;
    let mut rig = bench_rig(args, args.size())?;
    let scene = bench_scenes()
        .into_iter()
        .find(|s| s.name == "cumulus_noon")
        .ok_or("no cumulus_noon scene")?;
    rig.set_scene(&scene);
    let camera = rig.camera;
    rig.app
        .world()
        .entity_mut(camera)
        .insert(VolumetricClouds::MEDIUM);
    // The first frames make the noise and fill the accumulation: not what is measured.
    wait_for_pipelines(&mut rig);
    for _ in 0..WARM_UP_FRAMES {
        rig.app.update();
    }
    let live = LiveForecast::url(url)
        .named("Bern (loopback)")
        .with_refresh(REFRESH)
        .with_retry(REFRESH, Duration::from_secs(10));
    let world = rig.app.world();
    let handle = world.resource_scope(|world, mut feeds: Mut<LiveForecasts>| {
        feeds.add(world.resource::<Assets<Forecast>>(), live)
    });
    world.insert_resource(WeatherSource {
        near: Some(handle.clone()),
        far: Vec::new(),
    });
    let status = |rig: &mut CloudRig| {
        rig.app
            .world()
            .resource::<LiveForecasts>()
            .status(&handle)
            .cloned()
            .unwrap_or_default()
    };
    let mut csv = String::from("frame,ms,downloading,stored\n");
    let (mut idle, mut downloading, mut stored) = (Vec::new(), Vec::new(), Vec::new());
    for frame in 0..FRAMES {
        let before = status(&mut rig);
        let start = Instant::now();
        rig.app.update();
        let ms = start.elapsed().as_secs_f64() * 1000.0;
        let after = status(&mut rig);
        let new = after.downloads > before.downloads;
        let busy = before.downloading || after.downloading;
        csv.push_str(&format!(
            "{frame},{ms:.3},{},{}\n",
            u8::from(busy),
            u8::from(new)
        ));
        if new {
            stored.push(ms);
        } else if busy {
            downloading.push(ms);
        } else {
            idle.push(ms);
        }
    }
    let downloads = status(&mut rig).downloads;
    if downloads < 2 {
        return Err(format!("only {downloads} downloads in {FRAMES} frames"));
    }
    let path = args.out.join("live_refresh.csv");
    std::fs::write(&path, &csv).map_err(|e| format!("cannot write {}: {e}", path.display()))?;
    let show = |v: &[f64]| {
        quantile(v.to_vec(), 0.5).map_or_else(
            || "none".into(),
            |m| format!("{m:.1} ms ({} frames)", v.len()),
        )
    };
    let spread = |q| quantile(idle.clone(), q).unwrap_or(f64::NAN);
    println!(
        "live refresh, {}x{}, MEDIUM, {downloads} downloads: median frame {} with no download \
         (quartiles {:.1} and {:.1} ms), {} while one is under way, {} on the frames that store \
         one; wrote {}",
        args.width,
        args.height,
        show(&idle),
        spread(0.25),
        spread(0.75),
        show(&downloading),
        show(&stored),
        path.display()
    );
    Ok(())
}
