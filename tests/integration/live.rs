//! Live forecasts (crate feature `live`) against an HTTP server on the loopback address that the
//! test starts itself: good replies, a server error, a cut-off body, a page that is not a
//! forecast, a reply that is held back. Never the internet.

use std::{
    io::{BufRead, BufReader, Write},
    net::{TcpListener, TcpStream},
    sync::{
        Arc, Mutex,
        atomic::{AtomicBool, AtomicU32, Ordering},
        mpsc,
    },
    time::Duration,
};

use bevy::prelude::*;
use bevy_cloudscape::prelude::*;
use bevy_cloudscape::weather::{
    LiveForecast, LiveForecastError, LiveForecasts, LiveStatus, MIN_REFRESH,
};

use crate::weather::{low_cover, update_until};

/// What the server does with one request.
enum Reply {
    /// 200 with this JSON body.
    Json(String),
    /// This status with a short text body.
    Status(u16),
    /// 200 that announces the whole body but sends only its first half, then closes.
    CutOff(String),
    /// 200 with an HTML page.
    Html,
    /// Holds the request until the receiver gets a message (or 10 s pass), then sends the body.
    Held(mpsc::Receiver<()>, String),
}

/// A one-thread HTTP/1.1 server on 127.0.0.1 that answers each request with the next reply of
/// its script (the last one again once the script is used up).
struct Server {
    url: String,
    requests: Arc<AtomicU32>,
    released: Arc<AtomicBool>,
}

impl Server {
    fn start(script: Vec<Reply>) -> Self {
        let listener = TcpListener::bind("127.0.0.1:0").unwrap();
        // A query with a key, which no message may show.
        let url = format!(
            "http://{}/v1/forecast?apikey=SECRET",
            listener.local_addr().unwrap()
        );
        let requests = Arc::new(AtomicU32::new(0));
        let released = Arc::new(AtomicBool::new(false));
        let script = Arc::new(Mutex::new(script));
        {
            let requests = requests.clone();
            let released = released.clone();
            std::thread::spawn(move || {
                for stream in listener.incoming() {
                    let Ok(stream) = stream else { continue };
                    let reply = {
                        let mut script = script.lock().unwrap();
                        if script.len() > 1 {
                            script.remove(0)
                        } else {
                            match script.first() {
                                Some(Reply::Json(body)) => Reply::Json(body.clone()),
                                Some(Reply::Status(code)) => Reply::Status(*code),
                                _ => Reply::Status(503),
                            }
                        }
                    };
                    requests.fetch_add(1, Ordering::SeqCst);
                    let released = released.clone();
                    std::thread::spawn(move || answer(stream, reply, &released));
                }
            });
        }
        Self {
            url,
            requests,
            released,
        }
    }
}

fn answer(mut stream: TcpStream, reply: Reply, released: &AtomicBool) {
    // Read the request head.
    let mut reader = BufReader::new(stream.try_clone().unwrap());
    let mut line = String::new();
    while reader.read_line(&mut line).is_ok_and(|n| n > 2) {
        line.clear();
    }
    let ok = |body: &str| {
        format!(
            "HTTP/1.1 200 OK\r\nContent-Type: application/json\r\nContent-Length: {}\r\n\
             Connection: close\r\n\r\n{body}",
            body.len()
        )
    };
    let text = match reply {
        Reply::Json(body) => ok(&body),
        Reply::Status(code) => {
            format!("HTTP/1.1 {code} Oops\r\nContent-Length: 5\r\nConnection: close\r\n\r\noops!")
        }
        Reply::CutOff(body) => {
            let whole = ok(&body);
            whole[..whole.len() - body.len() / 2].to_owned()
        }
        Reply::Html => {
            let page = "<html><body>Service temporarily unavailable</body></html>";
            format!(
                "HTTP/1.1 200 OK\r\nContent-Type: text/html\r\nContent-Length: {}\r\n\
                 Connection: close\r\n\r\n{page}",
                page.len()
            )
        }
        Reply::Held(gate, body) => {
            let _ = gate.recv_timeout(Duration::from_secs(10));
            released.store(true, Ordering::SeqCst);
            ok(&body)
        }
    };
    let _ = stream.write_all(text.as_bytes());
    let _ = stream.flush();
}

/// The bundled Open-Meteo Bern forecast with every low cloud cover set to `percent`.
fn open_meteo_with_low_clouds(percent: f64) -> String {
    let text = include_str!("../../assets/weather/bern_open_meteo.json");
    let mut json: serde_json::Value = serde_json::from_str(text).unwrap();
    for value in json["hourly"]["cloud_cover_low"].as_array_mut().unwrap() {
        *value = serde_json::json!(percent);
    }
    json.to_string()
}

/// A headless app with the cloud plugins at a time inside the bundled forecast, fed by a live
/// forecast from `server` that refreshes and retries after `MIN_REFRESH`, a second.
fn live_app(server: &Server, timeout: Duration) -> (App, Handle<Forecast>) {
    let mut app = App::new();
    app.add_plugins((
        MinimalPlugins,
        bevy::asset::AssetPlugin::default(),
        CloudscapePlugin,
    ));
    app.insert_resource(SceneClock::at("2021-05-04T10:00:00Z".parse().unwrap()));
    app.finish();
    app.cleanup();
    let live = LiveForecast::url(&server.url)
        .named("Bern (test server)")
        .with_refresh(MIN_REFRESH)
        .with_retry(MIN_REFRESH, timeout);
    let world = app.world_mut();
    let handle = world.resource_scope(|world, mut feeds: Mut<LiveForecasts>| {
        feeds.add(world.resource::<Assets<Forecast>>(), live)
    });
    app.insert_resource(WeatherSource {
        near: Some(handle.clone()),
        far: Vec::new(),
    });
    (app, handle)
}

fn status(app: &App, handle: &Handle<Forecast>) -> LiveStatus {
    app.world()
        .resource::<LiveForecasts>()
        .status(handle)
        .cloned()
        .unwrap()
}

#[test]
fn a_live_forecast_refreshes_and_every_failure_keeps_the_last_good_one() {
    let server = Server::start(vec![
        Reply::Json(open_meteo_with_low_clouds(20.0)),
        Reply::Status(500),
        Reply::Status(500),
        Reply::CutOff(open_meteo_with_low_clouds(90.0)),
        Reply::Html,
        Reply::Json(open_meteo_with_low_clouds(60.0)),
    ]);
    // Refreshed a second after a good download, retried a second after a failure (the least
    // either may be).
    let (mut app, handle) = live_app(&server, Duration::from_secs(5));
    let limit = Duration::from_secs(20);

    update_until(&mut app, limit, |app| low_cover(app).is_some());
    assert_eq!(low_cover(&app), Some(0.2));
    assert_eq!(status(&app, &handle).downloads, 1);
    let name = &app
        .world()
        .resource::<Assets<Forecast>>()
        .get(&handle)
        .unwrap()
        .place
        .name;
    assert!(!name.is_empty());

    // Each failure is counted, keeps the forecast, and is said once per reason.
    let mut seen = Vec::new();
    for failures in 1..=4 {
        update_until(&mut app, limit, |app| {
            status(app, &handle).failures == failures
        });
        assert_eq!(low_cover(&app), Some(0.2), "after failure {failures}");
        seen.push(status(&app, &handle).last_error.unwrap());
    }
    assert_eq!(seen[0], LiveForecastError::Status { status: 500 });
    assert_eq!(seen[1], seen[0]);
    assert!(
        matches!(seen[2], LiveForecastError::Download(_)),
        "a cut-off body: {:?}",
        seen[2]
    );
    assert!(
        matches!(seen[3], LiveForecastError::Forecast(_)),
        "an HTML page: {:?}",
        seen[3]
    );
    for error in &seen {
        assert!(!error.to_string().contains("SECRET"), "{error}");
    }
    let after_failures = status(&app, &handle);
    assert_eq!(after_failures.failures_in_a_row, 4);
    assert_eq!(
        after_failures.warnings, 3,
        "the second 500 is not said again"
    );

    // The next good reply replaces the forecast.
    update_until(&mut app, limit, |app| low_cover(app) == Some(0.6));
    let recovered = status(&app, &handle);
    assert_eq!((recovered.downloads, recovered.failures_in_a_row), (2, 0));
    assert_eq!(recovered.last_error, None);
    assert!(server.requests.load(Ordering::SeqCst) >= 6);
}

#[test]
fn a_held_reply_does_not_hold_up_the_frames_and_a_timeout_keeps_the_last_good() {
    let (release, gate) = mpsc::channel();
    let (_never, stuck) = mpsc::channel();
    let server = Server::start(vec![
        Reply::Held(gate, open_meteo_with_low_clouds(30.0)),
        Reply::Held(stuck, open_meteo_with_low_clouds(80.0)),
        Reply::Json(open_meteo_with_low_clouds(50.0)),
    ]);
    let (mut app, handle) = live_app(&server, Duration::from_secs(1));

    // While the server holds its reply, frames go on: a download on the main thread would not
    // return from the first of these updates until the server lets go (after 10 s at most).
    update_until(&mut app, Duration::from_secs(5), |app| {
        status(app, &handle).downloading && server.requests.load(Ordering::SeqCst) == 1
    });
    for _ in 0..20 {
        app.update();
    }
    assert!(!server.released.load(Ordering::SeqCst), "frames waited");
    assert_eq!(low_cover(&app), None, "nothing yet");
    release.send(()).unwrap();
    update_until(&mut app, Duration::from_secs(10), |app| {
        low_cover(app) == Some(0.3)
    });

    // The next reply never comes: after the timeout (1 s) the download counts as failed and
    // the forecast stays; the retry gets the third reply.
    update_until(&mut app, Duration::from_secs(10), |app| {
        status(app, &handle).failures == 1
    });
    assert_eq!(
        status(&app, &handle).last_error,
        Some(LiveForecastError::Timeout(Duration::from_secs(1)))
    );
    assert_eq!(low_cover(&app), Some(0.3));
    update_until(&mut app, Duration::from_secs(10), |app| {
        low_cover(app) == Some(0.5)
    });
}
