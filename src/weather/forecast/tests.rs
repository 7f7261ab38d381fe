//! Tests of reading forecast files.

use super::*;

/// Fixtures are included relative to this file so the tests find them from any crate root.
macro_rules! fixture {
    ($name:literal) => {
        include_bytes!(concat!("../../../tests/fixtures/weather/", $name)).as_slice()
    };
}

macro_rules! asset {
    ($name:literal) => {
        include_bytes!(concat!("../../../assets/weather/", $name)).as_slice()
    };
}

fn parse(bytes: &[u8]) -> Forecast {
    match Forecast::from_slice(bytes, None) {
        Ok(forecast) => forecast,
        Err(error) => panic!("{error}"),
    }
}

fn utc(text: &str) -> UtcInstant {
    text.parse().unwrap()
}

/// 2021-05-03 12:00–17:00 CEST, the fixtures' hours, in UTC.
fn fixture_times() -> Vec<UtcInstant> {
    (0..6)
        .map(|i| UtcInstant::from_unix_seconds(1_620_036_000 + 3600 * i))
        .collect()
}

fn close(a: Option<f32>, b: f32, tolerance: f32) -> bool {
    a.is_some_and(|a| (a - b).abs() <= tolerance)
}

#[test]
fn merged_meteoblue_with_every_extra_block() {
    let forecast = parse(fixture!("meteoblue_basic-1h_clouds-1h.json"));
    assert_eq!(forecast.format, Some(ForecastFormat::Meteoblue));
    assert_eq!(
        forecast.place,
        Place {
            name: "Bern".into(),
            latitude_deg: 46.95,
            longitude_deg: 7.45,
            elevation_m: 540.0,
        }
    );
    assert_eq!(forecast.times, fixture_times());
    assert_eq!(forecast.times[0].to_string(), "2021-05-03T10:00:00Z");
    assert_eq!(forecast.utc_offset_s, 7200);
    assert_eq!(forecast.timezone_abbreviation.as_deref(), Some("CEST"));
    assert_eq!(forecast.model_run, Some(utc("2021-05-03T00:00:00Z")));
    assert!(forecast.warnings.is_empty(), "{:?}", forecast.warnings);

    // Percent → fraction, nulls kept as gaps.
    assert_eq!(
        forecast.series(Variable::LowCover).unwrap(),
        &[Some(0.1), Some(0.3), Some(0.6), None, Some(1.0), Some(0.9)]
    );
    assert_eq!(forecast.series(Variable::Precipitation).unwrap()[0], None);
    assert_eq!(
        forecast.series(Variable::Precipitation).unwrap()[2],
        Some(0.27)
    );
    assert_eq!(
        forecast.series(Variable::SunshineDuration).unwrap()[1],
        Some(3000.0)
    );
    assert_eq!(
        forecast.series(Variable::SeaLevelPressure).unwrap()[0],
        Some(101_550.0)
    );
    assert_eq!(
        forecast.series(Variable::RelativeHumidity).unwrap()[0],
        Some(0.55)
    );
    assert_eq!(
        forecast.series(Variable::FogProbability).unwrap()[2],
        Some(0.03)
    );
    assert_eq!(
        forecast.series(Variable::WindDirection).unwrap()[0],
        Some(350.0)
    );
    assert_eq!(
        forecast.pictocode.as_deref().unwrap(),
        &[Some(4), Some(7), Some(31), None, Some(23), Some(33)]
    );
    assert_eq!(forecast.is_daylight.as_deref().unwrap()[0], Some(true));
    assert!(forecast.series(Variable::ConvectiveCloudBase).is_none());

    // Profile packages: levels sorted from the ground up, fields per level.
    let pressures: Vec<f32> = forecast
        .pressure_levels
        .iter()
        .map(|level| level.pressure_hpa)
        .collect();
    assert_eq!(pressures, [850.0, 500.0]);
    let level = forecast.pressure_level(850.0).unwrap();
    assert_eq!(level.height_m.as_ref().unwrap()[0], Some(1520.0));
    assert_eq!(level.cloud_cover.as_ref().unwrap()[2], Some(0.5));
    let upper = forecast.pressure_level(500.0).unwrap();
    assert_eq!(upper.wind_speed_m_s.as_ref().unwrap()[3], None);
    assert!(upper.height_m.is_none());
}

#[test]
fn iso_times_and_imperial_units_convert_to_the_same_forecast() {
    let reference = parse(fixture!("meteoblue_basic-1h_clouds-1h.json"));
    let iso = parse(fixture!("meteoblue_iso8601.json"));
    assert_eq!(iso.times, reference.times);
    assert_eq!(iso.timezone_abbreviation.as_deref(), Some("CEST"));
    for (variable, tolerance) in [
        (Variable::Temperature, 0.05),
        (Variable::WindSpeed, 0.02),
        (Variable::Precipitation, 0.01),
        (Variable::ConvectivePrecipitation, 0.01),
        (Variable::LowCover, 0.0),
    ] {
        let (a, b) = (
            iso.series(variable).unwrap(),
            reference.series(variable).unwrap(),
        );
        for (i, (a, b)) in a.iter().zip(b).enumerate() {
            match (a, b) {
                (Some(a), Some(b)) => {
                    assert!((a - b).abs() <= tolerance, "{variable:?}[{i}]: {a} vs {b}");
                }
                (None, None) => {}
                _ => panic!("{variable:?}[{i}]: {a:?} vs {b:?}"),
            }
        }
    }
    assert!(iso.pressure_levels.is_empty());
}

#[test]
fn utc_timestamps_and_knots() {
    let forecast = parse(fixture!("meteoblue_timestamp_utc.json"));
    assert_eq!(forecast.times, fixture_times());
    // 6.8 kn = 3.498 m/s.
    assert!(close(
        forecast.series(Variable::WindSpeed).unwrap()[0],
        3.498,
        0.001
    ));
    assert_eq!(forecast.utc_offset_s, 0);
}

#[test]
fn single_packages_and_three_hourly_blocks() {
    let basic = parse(fixture!("meteoblue_basic-1h.json"));
    assert!(basic.series(Variable::LowCover).is_none());
    assert!(basic.series(Variable::Visibility).is_none());
    // 7.8 mph = 3.487 m/s.
    assert!(close(
        basic.series(Variable::WindSpeed).unwrap()[0],
        3.487,
        0.001
    ));
    assert!(basic.pictocode.is_some());

    let clouds = parse(fixture!("meteoblue_clouds-1h.json"));
    assert!(clouds.series(Variable::WindSpeed).is_none());
    assert_eq!(clouds.series(Variable::HighCover).unwrap()[0], Some(0.1));

    let three_hourly = parse(fixture!("meteoblue_basic-3h.json"));
    assert_eq!(three_hourly.len(), 3);
    assert_eq!(
        three_hourly.times[1].unix_seconds() - three_hourly.times[0].unix_seconds(),
        10_800
    );
}

#[test]
fn open_meteo_single_location() {
    let forecast = parse(fixture!("open_meteo.json"));
    assert_eq!(forecast.format, Some(ForecastFormat::OpenMeteo));
    assert_eq!(forecast.place.elevation_m, 540.0);
    assert_eq!(forecast.place.name, "");
    assert_eq!(forecast.times, fixture_times()[..4]);
    assert_eq!(forecast.utc_offset_s, 7200);
    assert_eq!(forecast.series(Variable::TotalCover).unwrap()[2], None);
    // 12.6 km/h = 3.5 m/s.
    assert!(close(
        forecast.series(Variable::WindSpeed).unwrap()[0],
        3.5,
        1e-5
    ));
    assert_eq!(
        forecast.series(Variable::ConvectivePrecipitation).unwrap()[1],
        Some(0.3)
    );
    assert_eq!(
        forecast.series(Variable::ConvectiveCloudTop).unwrap()[1],
        Some(4200.0)
    );
    assert_eq!(forecast.wmo_weather_code.as_deref().unwrap()[1], Some(80));
    // 0.7 cm of snow = 1 mm of water out of 2 mm: half falls as snow.
    assert_eq!(
        forecast.series(Variable::SnowFraction).unwrap(),
        &[Some(0.0), Some(0.0), None, Some(0.5)]
    );
    let pressures: Vec<f32> = forecast
        .pressure_levels
        .iter()
        .map(|level| level.pressure_hpa)
        .collect();
    assert_eq!(pressures, [850.0, 700.0]);
    assert!(close(
        forecast
            .pressure_level(850.0)
            .unwrap()
            .wind_speed_m_s
            .as_ref()
            .unwrap()[0],
        25.0 / 3.6,
        1e-5
    ));
    assert_eq!(
        forecast
            .pressure_level(700.0)
            .unwrap()
            .cloud_cover
            .as_ref()
            .unwrap()[3],
        Some(0.9)
    );
    assert_eq!(forecast.warnings.len(), 1, "{:?}", forecast.warnings);
    assert!(forecast.warnings[0].contains("wind_speed_500hPa"));
}

#[test]
fn open_meteo_unixtime_and_imperial_units() {
    let forecast = parse(fixture!("open_meteo_unixtime.json"));
    assert_eq!(forecast.times[0], utc("2021-05-03T12:00:00Z"));
    assert!(close(
        forecast.series(Variable::Temperature).unwrap()[2],
        15.0,
        1e-4
    ));
    assert!(close(
        forecast.series(Variable::Precipitation).unwrap()[2],
        2.032,
        1e-4
    ));
    assert!(close(
        forecast.series(Variable::WindSpeed).unwrap()[2],
        5.990,
        1e-3
    ));
    assert!(close(
        forecast.series(Variable::Visibility).unwrap()[2],
        8000.1,
        0.1
    ));
}

#[test]
fn open_meteo_multi_location_array() {
    let bytes = fixture!("open_meteo_multi.json");
    let first = parse(bytes);
    assert_eq!(first.place.latitude_deg, 46.94);
    assert!(first.warnings.iter().any(|w| w.contains("2 locations")));
    let all = Forecast::all_from_slice(bytes, None).unwrap();
    assert_eq!(all.len(), 2);
    assert_eq!(all[1].place.elevation_m, 432.0);
    assert_eq!(all[1].series(Variable::LowCover).unwrap()[0], Some(0.9));
    assert!(
        all[1]
            .warnings
            .iter()
            .any(|w| w.starts_with("[1].hourly.wind_speed_500hPa"))
    );
}

#[test]
fn format_hints() {
    let meteoblue = fixture!("meteoblue_basic-1h.json");
    assert!(Forecast::from_slice(meteoblue, Some(ForecastFormat::Meteoblue)).is_ok());
    let error = Forecast::from_slice(meteoblue, Some(ForecastFormat::OpenMeteo)).unwrap_err();
    assert!(
        matches!(error, ForecastError::UnknownFormat { .. }),
        "{error}"
    );
    let open_meteo = fixture!("open_meteo.json");
    let error = Forecast::from_slice(open_meteo, Some(ForecastFormat::Meteoblue)).unwrap_err();
    assert!(
        matches!(error, ForecastError::UnknownFormat { .. }),
        "{error}"
    );
}

#[test]
fn byte_order_mark_and_whitespace_are_accepted() {
    let mut bytes = b"\xEF\xBB\xBF\n  ".to_vec();
    bytes.extend_from_slice(fixture!("meteoblue_clouds-1h.json"));
    assert_eq!(parse(&bytes).len(), 6);
}

/// What a bad fixture must give: the variant (by name), the key and the index.
fn expect_error(bytes: &[u8], variant: &str, key: Option<&str>, index: Option<usize>) {
    let error = Forecast::from_slice(bytes, None).unwrap_err();
    let debug = format!("{error:?}");
    assert!(
        debug.starts_with(variant),
        "expected {variant}, got {error:?}"
    );
    assert_eq!(error.key(), key, "{error}");
    assert_eq!(error.index(), index, "{error}");
    let text = error.clone().with_file("forecast.json").to_string();
    assert!(text.starts_with("forecast.json: "), "{text}");
    if let Some(key) = key {
        assert!(text.contains(key), "{text}");
    }
    if let Some(index) = index {
        assert!(text.contains(&index.to_string()), "{text}");
    }
}

#[test]
fn bad_files_give_typed_errors_naming_key_and_index() {
    expect_error(
        fixture!("bad_length_mismatch.json"),
        "LengthMismatch",
        Some("data_1h.lowclouds"),
        None,
    );
    expect_error(
        fixture!("bad_unknown_unit.json"),
        "UnknownUnit",
        Some("units.windspeed"),
        None,
    );
    expect_error(
        fixture!("bad_empty_time.json"),
        "EmptyTime",
        Some("data_1h.time"),
        None,
    );
    expect_error(
        fixture!("bad_times_not_increasing.json"),
        "TimesNotIncreasing",
        Some("data_1h.time"),
        Some(3),
    );
    expect_error(
        fixture!("bad_duplicate_time.json"),
        "DuplicateTime",
        Some("data_1h.time"),
        Some(4),
    );
    expect_error(
        fixture!("bad_nan_cover.json"),
        "NonFiniteLiteral",
        Some("data_1h.midclouds"),
        Some(2),
    );
    expect_error(
        fixture!("bad_negative_cover.json"),
        "InvalidCover",
        Some("data_1h.highclouds"),
        Some(1),
    );
    expect_error(
        fixture!("bad_cover_above_100.json"),
        "CoverAbove100",
        Some("data_1h.totalcloudcover"),
        Some(4),
    );
    expect_error(
        fixture!("bad_open_meteo_error.json"),
        "ApiError",
        None,
        None,
    );
    expect_error(
        fixture!("bad_missing_key.json"),
        "MissingKey",
        Some("metadata.latitude"),
        None,
    );
    expect_error(
        fixture!("bad_time_string.json"),
        "BadTime",
        Some("data_1h.time"),
        Some(2),
    );
    expect_error(
        fixture!("bad_unknown_format.json"),
        "UnknownFormat",
        None,
        None,
    );
    expect_error(
        fixture!("bad_negative_precipitation.json"),
        "OutOfRange",
        Some("data_1h.precipitation"),
        Some(5),
    );
    expect_error(
        fixture!("bad_open_meteo_length_mismatch.json"),
        "LengthMismatch",
        Some("[1].hourly.wind_speed_10m"),
        None,
    );
    let error = Forecast::from_slice(fixture!("bad_broken_json.json"), None).unwrap_err();
    let ForecastError::Json { line, path, .. } = &error else {
        panic!("{error:?}");
    };
    assert!(*line > 1 && path.is_some(), "{error}");
    let error = Forecast::from_slice(fixture!("bad_open_meteo_error.json"), None).unwrap_err();
    assert!(error.to_string().contains("cloud_covr"), "{error}");
}

#[test]
fn inline_bad_cases() {
    let case = |text: &str| Forecast::from_slice(text.as_bytes(), None).unwrap_err();
    assert!(matches!(case(""), ForecastError::Json { line: 1, .. }));
    assert!(matches!(case("[]"), ForecastError::EmptyDocument { .. }));
    assert!(matches!(case("42"), ForecastError::Json { .. }));
    // A string where a cover belongs: broken JSON that still names the key and index.
    let error = case(
        r#"{"metadata": {"latitude": 1, "longitude": 2}, "units": {},
            "data_1h": {"time": ["2021-05-03 00:00"], "lowclouds": ["NaN"]}}"#,
    );
    assert_eq!(error.key(), Some("data_1h.lowclouds"));
    assert_eq!(error.index(), Some(0));
    // A cover without its unit category.
    let error = case(
        r#"{"metadata": {"latitude": 1, "longitude": 2, "utc_timeoffset": 0}, "units": {},
            "data_1h": {"time": ["2021-05-03 00:00"], "lowclouds": [3]}}"#,
    );
    assert_eq!(error.key(), Some("units.cloudcover"), "{error}");
    // Local times without an offset anywhere.
    let error = case(
        r#"{"metadata": {"latitude": 1, "longitude": 2}, "units": {},
            "data_1h": {"time": ["2021-05-03 00:00"]}}"#,
    );
    assert_eq!(error.key(), Some("metadata.utc_timeoffset"), "{error}");
    // Latitude out of range.
    let error = case(
        r#"{"metadata": {"latitude": 91, "longitude": 2}, "units": {},
            "data_1h": {"time": [0]}}"#,
    );
    assert!(matches!(error, ForecastError::OutOfRange { .. }), "{error}");
    // An unknown time unit, an error object from meteoblue, a null time.
    let error = case(
        r#"{"metadata": {"latitude": 1, "longitude": 2}, "units": {"time": "DD.MM.YYYY"},
            "data_1h": {"time": [0]}}"#,
    );
    assert_eq!(error.key(), Some("units.time"));
    assert!(matches!(
        case(r#"{"error_message": "API key invalid"}"#),
        ForecastError::ApiError { reason, .. } if reason == "API key invalid"
    ));
    let error = case(r#"{"latitude": 1, "longitude": 2, "hourly": {"time": [0, null]}}"#);
    assert_eq!((error.key(), error.index()), (Some("hourly.time"), Some(1)));
}

#[test]
fn from_path_names_the_file_and_the_place() {
    let directory =
        std::env::temp_dir().join(format!("cloudscape_forecast_{}", std::process::id()));
    std::fs::create_dir_all(&directory).unwrap();
    let good = directory.join("bern_open_meteo.json");
    std::fs::write(&good, asset!("bern_open_meteo.json")).unwrap();
    let forecast = Forecast::from_path(&good, None).unwrap();
    assert_eq!(forecast.place.name, "bern_open_meteo");

    let bad = directory.join("bad.json");
    std::fs::write(&bad, fixture!("bad_cover_above_100.json")).unwrap();
    let error = Forecast::from_path(&bad, None).unwrap_err();
    assert_eq!(error.file(), Some(bad.as_path()));
    assert!(error.to_string().starts_with(&bad.display().to_string()));

    let missing = directory.join("missing.json");
    let error = Forecast::from_path(&missing, None).unwrap_err();
    assert!(matches!(error, ForecastError::Io { .. }) && error.file() == Some(missing.as_path()));
    std::fs::remove_dir_all(&directory).unwrap();

    struct Failing;
    impl Read for Failing {
        fn read(&mut self, _: &mut [u8]) -> std::io::Result<usize> {
            Err(std::io::Error::other("disk on fire"))
        }
    }
    let error = Forecast::from_reader(Failing, None).unwrap_err();
    assert!(error.to_string().contains("disk on fire"));
    assert!(Forecast::from_reader(fixture!("open_meteo.json"), None).is_ok());
}

#[test]
fn bundled_forecasts_parse() {
    let start = utc("2021-05-02T22:00:00Z");
    let end = utc("2021-05-09T22:00:00Z");
    for (bytes, name, latitude, longitude, elevation) in [
        (asset!("bern.json"), "Bern", 46.948, 7.447, 540.0),
        (asset!("solothurn.json"), "Solothurn", 47.208, 7.537, 432.0),
        (asset!("fribourg.json"), "Fribourg", 46.806, 7.162, 610.0),
    ] {
        let forecast = parse(bytes);
        assert_eq!(forecast.place.name, name);
        assert_eq!(
            (
                forecast.place.latitude_deg,
                forecast.place.longitude_deg,
                forecast.place.elevation_m
            ),
            (latitude, longitude, elevation)
        );
        assert_eq!(forecast.len(), 169);
        assert_eq!((forecast.start(), forecast.end()), (Some(start), Some(end)));
        for variable in Variable::ALL {
            let has = forecast.series(variable).is_some();
            // meteoblue has no convective cloud base or top, nor a lightning potential.
            let expected = !matches!(
                variable,
                Variable::ConvectiveCloudBase
                    | Variable::ConvectiveCloudTop
                    | Variable::LightningPotential
            );
            assert_eq!(has, expected, "{name} {variable:?}");
        }
        assert!(forecast.warnings.is_empty(), "{:?}", forecast.warnings);
    }
    assert_eq!(
        parse(asset!("solothurn.json"))
            .series(Variable::Precipitation)
            .unwrap()[0],
        None
    );

    let open_meteo = parse(asset!("bern_open_meteo.json"));
    assert_eq!(open_meteo.len(), 169);
    assert_eq!(
        (open_meteo.start(), open_meteo.end()),
        (Some(start), Some(end))
    );
    assert_eq!(open_meteo.pressure_levels.len(), 4);
    let top = open_meteo.pressure_level(300.0).unwrap();
    assert_eq!(top.wind_speed_m_s.as_ref().unwrap()[168], None);
    assert!(top.wind_speed_m_s.as_ref().unwrap()[162].is_some());
}

#[test]
fn open_meteo_lightning_potential_is_read_in_joules_per_kilogram() {
    let json =
        br#"{"latitude": 46.9, "longitude": 7.4, "elevation": 540.0, "utc_offset_seconds": 0,
        "hourly_units": {"time": "iso8601", "lightning_potential": "J/kg"},
        "hourly": {"time": ["2021-05-07T14:00", "2021-05-07T15:00", "2021-05-07T16:00"],
                   "lightning_potential": [0.0, 12.5, null]}}"#;
    let forecast = Forecast::from_reader(&json[..], None).unwrap();
    assert_eq!(
        forecast.series(Variable::LightningPotential).unwrap(),
        &[Some(0.0), Some(12.5), None]
    );
    // A negative index is out of range.
    let bad = br#"{"latitude": 46.9, "longitude": 7.4, "elevation": 540.0, "utc_offset_seconds": 0,
        "hourly_units": {"time": "iso8601", "lightning_potential": "J/kg"},
        "hourly": {"time": ["2021-05-07T14:00"], "lightning_potential": [-3.0]}}"#;
    assert!(Forecast::from_reader(&bad[..], None).is_err());
}

/// xorshift64 (Marsaglia 2003): a deterministic stream for the mutation test.
struct XorShift(u64);

impl XorShift {
    fn next(&mut self) -> u64 {
        self.0 ^= self.0 << 13;
        self.0 ^= self.0 >> 7;
        self.0 ^= self.0 << 17;
        self.0
    }

    fn below(&mut self, n: usize) -> usize {
        (self.next() % n.max(1) as u64) as usize
    }
}

/// Replacement pieces that reach the parser's checks rather than only its syntax errors.
const TOKENS: [&[u8]; 24] = [
    b"null",
    b"NaN",
    b"-5",
    b"101",
    b"1e400",
    b"\"x\"",
    b"[]",
    b"{}",
    b"true",
    b",",
    b":",
    b"]",
    b"}",
    b"\"",
    b"0",
    b"-",
    "é".as_bytes(),
    b"\xFF",
    b"\"2021-13-45 99:99\"",
    b"99999999999999999999",
    b"-0.0",
    b"\"kmh\"",
    b"\"ISO8601\"",
    b"1620036000",
];

fn mutate(rng: &mut XorShift, original: &[u8]) -> Vec<u8> {
    let mut bytes = original.to_vec();
    for _ in 0..=rng.below(3) {
        let at = rng.below(bytes.len());
        match rng.below(7) {
            0 => {
                let byte = rng.next() as u8;
                bytes[at] = byte;
            }
            1 => {
                let end = (at + 1 + rng.below(8)).min(bytes.len());
                bytes.drain(at..end);
            }
            2 => {
                let token = TOKENS[rng.below(TOKENS.len())];
                bytes.splice(at..at, token.iter().copied());
            }
            3 => {
                // Replace a whole number (value-level mutation).
                let start = (at..bytes.len()).find(|&i| bytes[i].is_ascii_digit());
                if let Some(start) = start {
                    let end = (start..bytes.len())
                        .find(|&i| !(bytes[i].is_ascii_digit() || bytes[i] == b'.'))
                        .unwrap_or(bytes.len());
                    let token = TOKENS[rng.below(TOKENS.len())];
                    bytes.splice(start..end, token.iter().copied());
                }
            }
            4 => bytes.truncate(at),
            5 => {
                let end = (at + rng.below(40)).min(bytes.len());
                let copy = bytes[at..end].to_vec();
                let to = rng.below(bytes.len());
                bytes.splice(to..to, copy);
            }
            _ => {
                let punctuation = b"{}[],:\"0123456789 -.eE";
                bytes[at] = punctuation[rng.below(punctuation.len())];
            }
        }
        if bytes.is_empty() {
            break;
        }
    }
    bytes
}

/// Checks the invariants a parsed forecast promises, then samples it everywhere.
fn check_forecast(forecast: &Forecast) {
    assert!(!forecast.times.is_empty());
    assert!(forecast.times.windows(2).all(|w| w[0] < w[1]));
    for variable in Variable::ALL {
        if let Some(series) = forecast.series(variable) {
            assert_eq!(series.len(), forecast.len());
            for value in series.iter().flatten() {
                assert!(value.is_finite());
                if variable.unit() == "fraction 0-1" {
                    assert!((0.0..=1.0).contains(value), "{variable:?} {value}");
                }
            }
        }
    }
    let mut sampler = crate::weather::Sampler::new();
    let (start, end) = (
        forecast.times[0].unix_seconds(),
        forecast.end().unwrap().unix_seconds(),
    );
    for t in [
        start - 7200,
        start,
        (start + end) / 2,
        end,
        end + 1,
        i64::MIN,
        i64::MAX,
    ] {
        let state = sampler.sample(forecast, UtcInstant::from_unix_seconds(t));
        for value in state.values.iter().flatten() {
            assert!(value.is_finite());
        }
        let _ = sampler.take_warning();
    }
}

#[test]
fn thousands_of_mutations_never_panic() {
    let mut rng = XorShift(0x9E37_79B9_7F4A_7C15);
    let mut outcomes = std::collections::BTreeMap::<String, usize>::new();
    let inputs: [(&[u8], usize); 4] = [
        (fixture!("meteoblue_basic-1h_clouds-1h.json"), 2500),
        (fixture!("open_meteo_multi.json"), 1000),
        (fixture!("meteoblue_timestamp_utc.json"), 500),
        (asset!("bern.json"), 200),
    ];
    for (original, count) in inputs {
        for _ in 0..count {
            let bytes = mutate(&mut rng, original);
            let result = std::panic::catch_unwind(|| {
                let parsed = Forecast::all_from_slice(&bytes, None);
                if let Ok(forecasts) = &parsed {
                    forecasts.iter().for_each(check_forecast);
                }
                parsed
            });
            let outcome = match result {
                Ok(Ok(_)) => "ok".to_owned(),
                Ok(Err(error)) => {
                    // Every message is one line and never empty.
                    let text = error.to_string();
                    assert!(!text.is_empty() && !text.contains('\n'), "{text}");
                    format!("{error:?}")
                        .split([' ', '{'])
                        .next()
                        .unwrap()
                        .to_owned()
                }
                Err(_) => panic!("panicked on input:\n{}", String::from_utf8_lossy(&bytes)),
            };
            *outcomes.entry(outcome).or_default() += 1;
        }
    }
    eprintln!("mutation outcomes: {outcomes:?}");
    // The mutations reach well past the JSON syntax check.
    assert!(
        outcomes.get("ok").copied().unwrap_or(0) > 100,
        "{outcomes:?}"
    );
    assert!(outcomes.len() >= 8, "{outcomes:?}");
}
