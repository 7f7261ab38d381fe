//! Tests of sampling forecasts.

use super::*;
use crate::scene::{Place, UtcInstant};
use crate::weather::forecast::{Forecast, Variable};

const HOUR: i64 = 3600;
const T0: i64 = 1_620_000_000; // 2021-05-03T00:00:00Z

fn at(seconds_after_t0: i64) -> UtcInstant {
    UtcInstant::from_unix_seconds(T0 + seconds_after_t0)
}

/// An hourly forecast built in code with the given series.
fn hourly(steps: usize, series: &[(Variable, Vec<Option<f32>>)]) -> Forecast {
    let times = (0..steps as i64).map(|i| at(i * HOUR)).collect();
    let mut forecast = Forecast::new(Place::default(), times);
    for (variable, values) in series {
        forecast.series[*variable as usize] = Some(values.clone());
    }
    forecast
}

fn some(values: &[f32]) -> Vec<Option<f32>> {
    values.iter().copied().map(Some).collect()
}

/// The midpoint of two stored `f32` values, as sampling computes it (in `f64`).
fn midpoint(a: f32, b: f32) -> f32 {
    f64::midpoint(f64::from(a), f64::from(b)) as f32
}

#[test]
fn half_hour_values_are_exact_midpoints() {
    let forecast = hourly(
        3,
        &[
            (Variable::LowCover, some(&[0.2, 0.6, 0.1])),
            (Variable::Temperature, some(&[10.0, 13.0, 12.0])),
        ],
    );
    let mut sampler = Sampler::new();
    let state = sampler.sample(&forecast, at(HOUR / 2));
    assert_eq!(state.low_cover(), Some(midpoint(0.2, 0.6)));
    assert_eq!(state.temperature_c(), Some(11.5));
    let state = sampler.sample(&forecast, at(HOUR + HOUR / 2));
    assert_eq!(state.low_cover(), Some(midpoint(0.6, 0.1)));
    assert_eq!(state.temperature_c(), Some(12.5));
    // On a stamp the value is the stamp's.
    assert_eq!(sampler.sample(&forecast, at(HOUR)).low_cover(), Some(0.6));
    assert!(state.bridged.is_empty() && state.missing.is_empty() && state.clamped.is_none());
}

#[test]
fn half_hours_of_the_bundled_forecast_are_midpoints() {
    let forecast =
        Forecast::from_slice(include_bytes!("../../../assets/weather/bern.json"), None).unwrap();
    let mut sampler = Sampler::new();
    for i in 0..forecast.len() - 1 {
        let middle = forecast.times[i].saturating_add_seconds(HOUR / 2);
        let state = sampler.sample(&forecast, middle);
        for variable in [
            Variable::LowCover,
            Variable::MidCover,
            Variable::HighCover,
            Variable::Temperature,
        ] {
            let series = forecast.series(variable).unwrap();
            let expected = f64::midpoint(
                f64::from(series[i].unwrap()),
                f64::from(series[i + 1].unwrap()),
            );
            assert!(
                (f64::from(state.get(variable).unwrap()) - expected).abs() < 1e-5,
                "{variable:?} at {middle}"
            );
        }
    }
}

#[test]
fn wind_turns_through_north_not_south() {
    let forecast = hourly(
        2,
        &[
            (Variable::WindSpeed, some(&[5.0, 5.0])),
            (Variable::WindDirection, some(&[350.0, 10.0])),
        ],
    );
    let direction = |seconds| forecast.sample(at(seconds)).wind_direction_deg().unwrap();
    let angular_error = |a: f32, b: f32| ((a - b + 180.0).rem_euclid(360.0) - 180.0).abs();
    assert!(
        angular_error(direction(HOUR / 2), 0.0) < 1e-3,
        "{}",
        direction(HOUR / 2)
    );
    // A quarter of the way is close to (not exactly) a quarter of the angle: vectors, not angles,
    // are interpolated.
    assert!(
        angular_error(direction(HOUR / 4), 355.0) < 0.1,
        "{}",
        direction(HOUR / 4)
    );
    assert!(
        angular_error(direction(3 * HOUR / 4), 5.0) < 0.1,
        "{}",
        direction(3 * HOUR / 4)
    );
    // The speed is interpolated as a scalar: the turn does not weaken the wind.
    assert_eq!(forecast.sample(at(HOUR / 2)).wind_speed_m_s(), Some(5.0));
    for step in 0..=60 {
        let d = direction(step * 60);
        assert!(
            (0.0..360.0).contains(&d) && (d >= 349.9 || d <= 10.1),
            "{d}"
        );
    }

    // The other way round, 10° → 350°, also passes through north.
    let back = hourly(
        2,
        &[
            (Variable::WindSpeed, some(&[5.0, 5.0])),
            (Variable::WindDirection, some(&[10.0, 350.0])),
        ],
    );
    let d = back.sample(at(HOUR / 2)).wind_direction_deg().unwrap();
    assert!(angular_error(d, 0.0) < 1e-3, "{d}");
}

#[test]
fn calm_and_opposite_winds_keep_a_sensible_direction() {
    // A calm step does not drag the direction: it is the other step's.
    let calm = hourly(
        2,
        &[
            (Variable::WindSpeed, some(&[0.0, 4.0])),
            (Variable::WindDirection, some(&[90.0, 270.0])),
        ],
    );
    let state = calm.sample(at(HOUR / 2));
    assert!((state.wind_direction_deg().unwrap() - 270.0).abs() < 1e-3);
    assert_eq!(state.wind_speed_m_s(), Some(2.0));
    // Exactly opposite equal winds cancel: the nearer step's direction is held.
    let opposite = hourly(
        2,
        &[
            (Variable::WindSpeed, some(&[3.0, 3.0])),
            (Variable::WindDirection, some(&[90.0, 270.0])),
        ],
    );
    assert_eq!(
        opposite.sample(at(HOUR / 2 - 1)).wind_direction_deg(),
        Some(90.0)
    );
    assert_eq!(
        opposite.sample(at(HOUR / 2)).wind_direction_deg(),
        Some(270.0)
    );
    // Direction without speed: unit vectors.
    let no_speed = hourly(2, &[(Variable::WindDirection, some(&[300.0, 20.0]))]);
    let d = no_speed.sample(at(HOUR / 2)).wind_direction_deg().unwrap();
    assert!((d - 340.0).abs() < 1e-3, "{d}");
}

#[test]
fn wind_velocity_points_downwind() {
    let west_wind = hourly(
        1,
        &[
            (Variable::WindSpeed, some(&[5.0])),
            (Variable::WindDirection, some(&[270.0])),
        ],
    );
    let [east, north] = west_wind.sample(at(0)).wind_velocity_m_s().unwrap();
    assert!((east - 5.0).abs() < 1e-5 && north.abs() < 1e-5);
}

#[test]
fn precipitation_is_an_amount_over_the_preceding_step() {
    // Stamped amounts: 01:00 holds 00:00–01:00, 02:00 holds 01:00–02:00, …
    let forecast = hourly(
        4,
        &[
            (
                Variable::Precipitation,
                vec![None, Some(2.0), Some(4.0), Some(0.0)],
            ),
            (
                Variable::SunshineDuration,
                vec![None, Some(1800.0), Some(0.0), Some(3600.0)],
            ),
        ],
    );
    let rate = |seconds| forecast.sample(at(seconds)).precipitation_mm_per_h();
    // In the middle of a step the rate is that step's amount per hour, exactly.
    assert_eq!(rate(HOUR / 2), Some(2.0));
    assert_eq!(rate(HOUR + HOUR / 2), Some(4.0));
    assert_eq!(rate(2 * HOUR + HOUR / 2), Some(0.0));
    // On a stamp it is halfway between the two steps it separates: continuous, no jump.
    assert_eq!(rate(HOUR), Some(3.0));
    assert_eq!(rate(2 * HOUR), Some(2.0));
    // Sunshine: the fraction of the step that was sunny.
    assert_eq!(
        forecast
            .sample(at(HOUR / 2))
            .get(Variable::SunshineDuration),
        Some(0.5)
    );
    // The first stamp's backward-looking value is null, so the rate before 00:30 has no data
    // on one side: missing, never a silent zero.
    let first = forecast.sample(at(0));
    assert_eq!(first.precipitation_mm_per_h(), None);
    assert!(first.missing.contains(Variable::Precipitation));
    assert_eq!(rate(HOUR / 2 - 1), None);

    // Amounts are kept up to the smoothing at step edges: integrating the rate over
    // 01:00–03:00 gives 3.75 mm against the stamped 4 + 0 mm (the 3 mm/h at 01:00 borrows from
    // the wetter step before).
    let mut total = 0.0;
    let samples: i32 = 3600;
    for i in 0..samples {
        let t = HOUR + (2 * HOUR * i64::from(i)) / i64::from(samples);
        total += f64::from(rate(t).unwrap()) * 2.0 / f64::from(samples);
    }
    assert!((total - 4.0).abs() < 0.3, "{total}");

    // Three-hourly steps: 3 mm over 3 h is 1 mm/h, 6 mm over 3 h is 2 mm/h.
    let times = vec![at(0), at(3 * HOUR), at(6 * HOUR)];
    let mut three_hourly = Forecast::new(Place::default(), times);
    three_hourly.series[Variable::Precipitation as usize] = Some(some(&[3.0, 3.0, 6.0]));
    assert_eq!(
        three_hourly
            .sample(at(HOUR + 1800))
            .precipitation_mm_per_h(),
        Some(1.0)
    );
    assert_eq!(
        three_hourly
            .sample(at(4 * HOUR + 1800))
            .precipitation_mm_per_h(),
        Some(2.0)
    );
    assert_eq!(
        three_hourly.sample(at(6 * HOUR)).precipitation_mm_per_h(),
        Some(2.0)
    );
}

#[test]
fn short_gaps_are_bridged_and_long_gaps_reported() {
    let mut values = some(&[0.0; 12]);
    values[1] = Some(0.1);
    values[2] = None; // one null: bridged from 01:00 to 03:00 (2 h)
    values[3] = Some(0.3);
    values[5] = None; // two nulls: 04:00 to 07:00 is 3 h, bridged
    values[6] = None;
    values[4] = Some(0.4);
    values[7] = Some(0.7);
    values[8] = None; // three nulls: 07:00 to 11:00 is 4 h, too long
    values[9] = None;
    values[10] = None;
    values[11] = Some(1.0);
    let forecast = hourly(12, &[(Variable::LowCover, values)]);
    let mut sampler = Sampler::new();

    let state = sampler.sample(&forecast, at(2 * HOUR));
    assert!((state.low_cover().unwrap() - 0.2).abs() < 1e-6);
    assert!(state.bridged.contains(Variable::LowCover));
    assert_eq!(sampler.take_warning(), None);

    let state = sampler.sample(&forecast, at(5 * HOUR + 1800));
    assert!((state.low_cover().unwrap() - 0.55).abs() < 1e-6);
    assert!(state.bridged.contains(Variable::LowCover));

    let state = sampler.sample(&forecast, at(9 * HOUR));
    assert_eq!(state.low_cover(), None);
    assert!(state.missing.contains(Variable::LowCover));
    assert!(
        matches!(sampler.take_warning(), Some(SampleWarning::Gap { missing, .. }) if missing.contains(Variable::LowCover))
    );
    // Once per gap, not per frame.
    let _ = sampler.sample(&forecast, at(9 * HOUR + 60));
    assert_eq!(sampler.take_warning(), None);

    // A sampler that does not bridge at all.
    let mut strict = Sampler::with_max_bridge_s(0.0);
    assert_eq!(strict.sample(&forecast, at(2 * HOUR)).low_cover(), None);
    assert_eq!(
        strict.sample(&forecast, at(3 * HOUR)).low_cover(),
        Some(0.3)
    );
}

#[test]
fn instants_outside_the_data_are_clamped_with_one_warning() {
    let forecast = hourly(3, &[(Variable::TotalCover, some(&[0.1, 0.5, 0.9]))]);
    let mut sampler = Sampler::new();
    let before = sampler.sample(&forecast, at(-10 * HOUR));
    assert_eq!(before.clamped, Some(DataEdge::Start));
    assert_eq!(before.total_cover(), Some(0.1));
    assert_eq!(before.time, at(-10 * HOUR));
    let warning = sampler.take_warning().unwrap();
    assert!(matches!(
        warning,
        SampleWarning::OutsideData {
            edge: DataEdge::Start,
            ..
        }
    ));
    assert!(
        warning.to_string().contains("before the forecast starts"),
        "{warning}"
    );
    // Many frames later, still outside: no new warning.
    for frame in 0..100 {
        let state = sampler.sample(&forecast, at(-10 * HOUR + frame));
        assert_eq!(state.clamped, Some(DataEdge::Start));
        assert_eq!(sampler.take_warning(), None);
    }
    // Inside again, then past the end: one warning for the new excursion.
    assert_eq!(sampler.sample(&forecast, at(HOUR)).clamped, None);
    assert_eq!(sampler.take_warning(), None);
    let after = sampler.sample(&forecast, at(30 * HOUR));
    assert_eq!(
        (after.clamped, after.total_cover()),
        (Some(DataEdge::End), Some(0.9))
    );
    let warning = sampler.take_warning().unwrap();
    assert!(
        warning.to_string().contains("after the forecast ends"),
        "{warning}"
    );
    assert_eq!(sampler.take_warning(), None);
    let _ = sampler.sample(&forecast, at(31 * HOUR));
    assert_eq!(sampler.take_warning(), None);
    // reset() forgets what was said.
    sampler.reset();
    let _ = sampler.sample(&forecast, at(31 * HOUR));
    assert!(sampler.take_warning().is_some());
}

#[test]
fn cursor_and_binary_search_agree() {
    let forecast = Forecast::from_slice(
        include_bytes!("../../../assets/weather/fribourg.json"),
        None,
    )
    .unwrap();
    let (start, end) = (
        forecast.times[0].unix_seconds(),
        forecast.end().unwrap().unix_seconds(),
    );
    let mut sampler = Sampler::new();
    // Sequential frames (the cursor path), then random jumps.
    let mut t = start - 600;
    while t < end + 600 {
        let instant = UtcInstant::from_unix_seconds(t);
        assert_eq!(
            sampler.sample(&forecast, instant),
            forecast.sample(instant),
            "{instant}"
        );
        t += 97;
    }
    let mut state = 0x2545_F491_4F6C_DD1D_u64;
    for _ in 0..2000 {
        state ^= state << 13;
        state ^= state >> 7;
        state ^= state << 17;
        let span = (end - start + 7200) as u64;
        let instant = UtcInstant::from_unix_seconds(start - 3600 + (state % span) as i64);
        assert_eq!(
            sampler.sample(&forecast, instant),
            forecast.sample(instant),
            "{instant}"
        );
    }
    // Fractional seconds interpolate smoothly between whole ones.
    let a = sampler.sample_unix_seconds(&forecast, (start + 1800) as f64);
    let b = sampler.sample_unix_seconds(&forecast, (start + 1800) as f64 + 0.5);
    assert!((a.low_cover().unwrap() - b.low_cover().unwrap()).abs() < 1e-3);
}

#[test]
fn codes_flags_and_upper_air() {
    let forecast = Forecast::from_slice(
        include_bytes!("../../../assets/weather/bern_open_meteo.json"),
        None,
    )
    .unwrap();
    let start = forecast.times[0];
    let mut sampler = Sampler::new();
    let state = sampler.sample(&forecast, start.saturating_add_seconds(20 * 60));
    assert_eq!(
        state.wmo_weather_code,
        forecast.wmo_weather_code.as_ref().unwrap()[0]
    );
    let later = sampler.sample(&forecast, start.saturating_add_seconds(40 * 60));
    assert_eq!(
        later.wmo_weather_code,
        forecast.wmo_weather_code.as_ref().unwrap()[1]
    );
    assert!(state.is_daylight.is_some());
    for pressure in STANDARD_LEVELS_HPA {
        let level = state.level(pressure).unwrap();
        assert!(
            level.wind_speed_m_s.is_some() && level.height_m.is_some(),
            "{level:?}"
        );
    }
    // The 300 hPa series ends in nulls (past the model horizon): missing at the end.
    let end = sampler.sample(&forecast, forecast.end().unwrap());
    assert_eq!(end.level(300.0).unwrap().wind_speed_m_s, None);
    assert!(end.level(850.0).unwrap().wind_speed_m_s.is_some());
    let index = forecast
        .pressure_levels
        .iter()
        .position(|level| level.pressure_hpa == 500.0)
        .unwrap();
    assert_eq!(
        sampler.sample_level(&forecast, index, start),
        Some(*state_at(&forecast, start).level(500.0).unwrap())
    );
    assert_eq!(sampler.sample_level(&forecast, 99, start), None);
}

fn state_at(forecast: &Forecast, instant: UtcInstant) -> WeatherState {
    forecast.sample(instant)
}

#[test]
fn the_bundled_week_reads_as_described() {
    let bern =
        Forecast::from_slice(include_bytes!("../../../assets/weather/bern.json"), None).unwrap();
    let local = |day: u8, hour: u8| {
        // CEST = UTC+2.
        UtcInstant::from_civil(2021, 5, day, hour, 0, 0)
            .unwrap()
            .saturating_add_seconds(-2 * HOUR)
    };
    let state = |day, hour| bern.sample(local(day, hour));
    // Monday: clear morning, afternoon cumulus.
    assert!(state(3, 8).low_cover().unwrap() < 0.05);
    assert!(state(3, 15).low_cover().unwrap() > 0.3);
    // Tuesday: cirrus first, then altostratus, then rain.
    assert!(state(4, 11).high_cover().unwrap() > 0.4 && state(4, 11).mid_cover().unwrap() < 0.2);
    assert!(state(4, 18).mid_cover().unwrap() > 0.7);
    assert!(state(4, 23).precipitation_mm_per_h().unwrap() > 0.5);
    // Wednesday: overcast.
    assert!(state(5, 12).total_cover().unwrap() > 0.9);
    // Thursday: foggy morning.
    let fog = state(6, 7);
    assert_eq!(fog.pictocode, Some(16));
    assert!(fog.fog_probability().unwrap() > 0.6 && fog.visibility_m().unwrap() < 1000.0);
    // Friday: afternoon thunderstorm.
    let storm = state(7, 16);
    assert!(matches!(storm.pictocode, Some(10..=12 | 27..=30)));
    assert!(storm.convective_precipitation_mm_per_h().unwrap() > 1.0);
}

#[test]
fn degenerate_forecasts_do_not_panic() {
    let empty = Forecast::new(Place::default(), Vec::new());
    let state = Sampler::new().sample(&empty, at(0));
    assert_eq!(state, WeatherState::empty(at(0)));

    // Series shorter than the times, unsorted times, a lone step, NaN instants.
    let mut odd = hourly(3, &[(Variable::LowCover, some(&[0.5]))]);
    odd.series[Variable::Precipitation as usize] = Some(some(&[1.0, 2.0, 3.0, 4.0, 5.0]));
    let mut sampler = Sampler::new();
    for t in [-HOUR, 0, HOUR / 2, HOUR, 5 * HOUR] {
        let _ = sampler.sample(&odd, at(t));
    }
    odd.times.reverse();
    for t in [-HOUR, 0, HOUR / 2, HOUR, 5 * HOUR] {
        let _ = sampler.sample(&odd, at(t));
    }
    let _ = sampler.sample_unix_seconds(&odd, f64::NAN);
    let _ = sampler.sample_unix_seconds(&odd, f64::INFINITY);
    let lone = hourly(1, &[(Variable::Precipitation, some(&[2.0]))]);
    assert_eq!(lone.sample(at(0)).precipitation_mm_per_h(), Some(2.0));
}

#[test]
fn variable_sets() {
    let mut set = VariableSet::EMPTY;
    assert!(set.is_empty());
    set.insert(Variable::WindSpeed);
    set.insert(Variable::LowCover);
    set.insert(Variable::LowCover);
    assert_eq!(set.len(), 2);
    assert!(set.contains(Variable::WindSpeed) && !set.contains(Variable::MidCover));
    assert_eq!(set.to_string(), "low_cover, wind_speed");
    assert_eq!(Variable::ALL.len(), Variable::COUNT);
    for (i, variable) in Variable::ALL.iter().enumerate() {
        assert_eq!(*variable as usize, i);
    }
}
