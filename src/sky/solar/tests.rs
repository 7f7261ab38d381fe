//! Tests of the solar position algorithm.

use super::*;

/// Reda & Andreas (2004), Table A5.1 worked example: 2003-10-17 12:30:30 local time at
/// UTC−7, 39.742476° N, 105.1786° W, 1830.14 m, 820 mbar, 11 °C, ΔT = 67 s.
fn worked_example() -> Spa {
    let observer = Observer {
        latitude_deg: 39.742_476,
        longitude_deg: -105.1786,
        elevation_m: 1830.14,
    };
    let options = SolarOptions {
        pressure_hpa: 820.0,
        temperature_c: 11.0,
        delta_t_s: Some(67.0),
        refraction: true,
    };
    let at = UtcInstant::from_civil(2003, 10, 17, 19, 30, 30).unwrap();
    spa(&observer, julian_day(at.unix_seconds() as f64), &options)
}

#[test]
fn julian_day_of_worked_example() {
    let at = UtcInstant::from_civil(2003, 10, 17, 19, 30, 30).unwrap();
    assert!((julian_day(at.unix_seconds() as f64) - 2_452_930.312_847).abs() < 1e-6);
}

#[test]
fn worked_example_intermediates_match_the_paper() {
    let spa = worked_example();
    let check = |name: &str, got: f64, expected: f64, tolerance: f64| {
        assert!(
            (got - expected).abs() <= tolerance,
            "{name}: got {got}, paper {expected}"
        );
    };
    check("L", spa.heliocentric_longitude_deg, 24.018_261_691_7, 1e-6);
    check("B", spa.heliocentric_latitude_deg, -0.000_101_121_9, 1e-8);
    check(
        "R",
        spa.position.earth_sun_distance_au,
        0.996_542_297_4,
        1e-8,
    );
    check("Δψ", spa.nutation_longitude_deg, -0.003_998_40, 1e-7);
    check("Δε", spa.nutation_obliquity_deg, 0.001_666_57, 1e-7);
    check("ε", spa.true_obliquity_deg, 23.440_465, 1e-6);
    check("λ", spa.apparent_longitude_deg, 204.008_551_928_1, 1e-6);
    check("α", spa.position.right_ascension_deg, 202.227_41, 1e-5);
    check("δ", spa.position.declination_deg, -9.314_34, 1e-5);
    check("H", spa.observer_hour_angle_deg, 11.105_900, 1e-5);
    check("α'", spa.topocentric_right_ascension_deg, 202.227_04, 1e-5);
    check("δ'", spa.topocentric_declination_deg, -9.316_179, 1e-5);
    check("H'", spa.position.hour_angle_deg, 11.106_27, 1e-5);
    check("e", spa.position.elevation_deg, 39.888_378, 1e-5);
}

#[test]
fn worked_example_zenith_and_azimuth() {
    // The paper: topocentric zenith 50.11162°, azimuth 194.34024° (5 decimals given).
    let position = worked_example().position;
    let zenith_error = (position.zenith_deg - 50.111_62).abs();
    let azimuth_error = (position.azimuth_deg - 194.340_24).abs();
    assert!(
        zenith_error < 1e-5,
        "zenith {} (error {zenith_error})",
        position.zenith_deg
    );
    assert!(
        azimuth_error < 1e-5,
        "azimuth {} (error {azimuth_error})",
        position.azimuth_deg
    );
}

/// Latitude of Bern (Zytglogge area), as in the bundled forecast.
const BERN: Observer = Observer {
    latitude_deg: 46.948,
    longitude_deg: 7.447,
    elevation_m: 540.0,
};

/// The position at local transit (topocentric hour angle 0) on the UTC day of `day`, found by
/// bisection on the signed hour angle.
fn transit(observer: &Observer, day: UtcInstant, options: &SolarOptions) -> SolarPosition {
    // Transit is near 12:00 local mean solar time: 12 h − longitude / 15° per hour, ± 17 min.
    let guess = day.unix_seconds() as f64 + (12.0 - observer.longitude_deg / 15.0) * 3600.0;
    let signed_hour_angle = |t: f64| {
        let h = solar_position_unix_seconds(observer, t, options).hour_angle_deg;
        if h > 180.0 { h - 360.0 } else { h }
    };
    let (mut before, mut after) = (guess - 3600.0, guess + 3600.0);
    while after - before > 0.01 {
        let middle = 0.5 * (before + after);
        if signed_hour_angle(middle) < 0.0 {
            before = middle;
        } else {
            after = middle;
        }
    }
    solar_position_unix_seconds(observer, before, options)
}

#[test]
fn bern_noon_elevation_at_equinoxes_and_solstices() {
    // Noon elevation = 90° − |latitude − declination| for the sun on the meridian. Expected
    // declinations at Bern's noon (about 11:20 UTC) in 2021, from the event instants
    // published by the US Naval Observatory (Earth's seasons 2021): March equinox 03-20 09:37,
    // June solstice 06-21 03:32, September equinox 09-22 19:21, December solstice 12-21 15:59
    // UTC. At an equinox the declination is 0 and moves by sin ε · dλ/dt ≈ 0.3958°/day in
    // March and 0.3918°/day in September (sun's longitude moving 0.995°/day and 0.985°/day);
    // at a solstice it is ±ε = ±23.4366° (mean obliquity 2021) and stationary (< 0.001° per
    // day).
    //
    // Tolerance 0.006°: nutation in obliquity (not in the expected values) ≤ 0.0026°, the
    // topocentric parallax lowers the elevation by 8.8″·cos(e) ≤ 0.0024°, the linear
    // declination rates are good to 0.003°/day over ≤ 0.34 day ≤ 0.001°.
    let options = SolarOptions {
        refraction: false,
        ..SolarOptions::default()
    };
    let day = |month, day| UtcInstant::from_civil(2021, month, day, 0, 0, 0).unwrap();
    let hours = |from: UtcInstant, to: f64| (to - from.unix_seconds() as f64) / 86_400.0;
    let cases = [
        (
            day(3, 20),
            UtcInstant::from_civil(2021, 3, 20, 9, 37, 0).unwrap(),
            0.3958,
            0.0,
        ),
        (
            day(9, 22),
            UtcInstant::from_civil(2021, 9, 22, 19, 21, 0).unwrap(),
            -0.3918,
            0.0,
        ),
        (
            day(6, 21),
            UtcInstant::from_civil(2021, 6, 21, 3, 32, 0).unwrap(),
            0.0,
            23.4366,
        ),
        (
            day(12, 21),
            UtcInstant::from_civil(2021, 12, 21, 15, 59, 0).unwrap(),
            0.0,
            -23.4366,
        ),
    ];
    for (date, event, rate_deg_per_day, solstice_declination) in cases {
        let noon = transit(&BERN, date, &options);
        let noon_time = date.unix_seconds() as f64 + (12.0 - BERN.longitude_deg / 15.0) * 3600.0;
        let expected_declination =
            solstice_declination + rate_deg_per_day * hours(event, noon_time);
        let expected = 90.0 - (BERN.latitude_deg - expected_declination).abs();
        let error = noon.geometric_elevation_deg - expected;
        assert!(
            error.abs() < 0.006,
            "{date}: elevation {} expected {expected} (error {error})",
            noon.geometric_elevation_deg
        );
        assert!(
            (noon.declination_deg - expected_declination).abs() < 0.004,
            "{date}: declination {} expected {expected_declination}",
            noon.declination_deg
        );
        // On the meridian the sun is due south.
        assert!(
            (noon.azimuth_deg - 180.0).abs() < 1e-3,
            "azimuth {}",
            noon.azimuth_deg
        );
    }
}

/// Sun's declination and Greenwich hour angle at 0 h UT from J. L. Wahl, "Sun and Polaris
/// Ephemeris for Land Surveyors", cadastral.com (1999 and 2013 editions; "verified by spot
/// checks with the Astronomical Almanac"): degrees, minutes, seconds.
struct Ephemeris {
    at: UtcInstant,
    declination: (f64, f64, f64),
    gha: (f64, f64, f64),
}

fn dms((degrees, minutes, seconds): (f64, f64, f64)) -> f64 {
    degrees.signum() * (degrees.abs() + minutes / 60.0 + seconds / 3600.0)
}

/// Elevation and azimuth (clockwise from north) from declination and GHA by the standard
/// navigational triangle, geocentric, no refraction.
fn from_ephemeris(observer: &Observer, declination: f64, gha: f64) -> (f64, f64) {
    let lha = (gha + observer.longitude_deg).to_radians();
    let (phi, delta) = (observer.latitude_deg.to_radians(), declination.to_radians());
    let elevation = (phi.sin() * delta.sin() + phi.cos() * delta.cos() * lha.cos()).asin();
    let azimuth = (-delta.cos() * lha.sin())
        .atan2(delta.sin() * phi.cos() - delta.cos() * phi.sin() * lha.cos());
    (elevation.to_degrees(), wrap_degrees(azimuth.to_degrees()))
}

fn check_against_ephemeris(observer: &Observer, ephemeris: &Ephemeris) -> SolarPosition {
    let options = SolarOptions {
        refraction: false,
        ..SolarOptions::default()
    };
    let position = solar_position(observer, ephemeris.at, &options);
    let declination = dms(ephemeris.declination);
    let gha = dms(ephemeris.gha);
    // Tables are for UT1; we pass UTC, which differed by < 0.8 s (≤ 0.0033° of GHA).
    assert!(
        (position.declination_deg - declination).abs() < 0.0005,
        "declination {} table {declination}",
        position.declination_deg
    );
    let gha_error = (position.greenwich_hour_angle_deg - gha + 180.0).rem_euclid(360.0) - 180.0;
    assert!(
        gha_error.abs() < 0.004,
        "GHA {} table {gha}",
        position.greenwich_hour_angle_deg
    );
    // Elevation: + parallax ≤ 0.0024°; azimuth error grows as 1 / cos(elevation).
    let (elevation, azimuth) = from_ephemeris(observer, declination, gha);
    assert!(
        (position.geometric_elevation_deg - elevation).abs() < 0.008,
        "elevation {} expected {elevation}",
        position.geometric_elevation_deg
    );
    let azimuth_error = (position.azimuth_deg - azimuth + 180.0).rem_euclid(360.0) - 180.0;
    assert!(
        azimuth_error.abs() < 0.005 / elevation.to_radians().cos(),
        "azimuth {} expected {azimuth}",
        position.azimuth_deg
    );
    position
}

#[test]
fn southern_hemisphere_sydney() {
    // 2013-01-01 0 h UT (11:00 AEDT): Dec −23° 00′ 08.9″, GHA 179° 08′ 29.6″.
    let sydney = Observer {
        latitude_deg: -33.8688,
        longitude_deg: 151.2093,
        elevation_m: 20.0,
    };
    let position = check_against_ephemeris(
        &sydney,
        &Ephemeris {
            at: UtcInstant::from_civil(2013, 1, 1, 0, 0, 0).unwrap(),
            declination: (-23.0, 0.0, 8.9),
            gha: (179.0, 8.0, 29.6),
        },
    );
    // Late morning in southern summer (two hours before transit): high in the north-east.
    assert!(position.elevation_deg > 55.0 && position.elevation_deg < 70.0);
    assert!(position.azimuth_deg > 0.0 && position.azimuth_deg < 90.0);
}

#[test]
fn high_latitude_midnight_sun_longyearbyen() {
    // 1999-08-01 0 h UT (02:00 local): Dec +18° 10′ 51.9″, GHA 178° 24′ 39.3″. At 78.2° N the
    // sun stays up all night in early August, low in the north.
    let longyearbyen = Observer {
        latitude_deg: 78.2232,
        longitude_deg: 15.6267,
        elevation_m: 10.0,
    };
    let position = check_against_ephemeris(
        &longyearbyen,
        &Ephemeris {
            at: UtcInstant::from_civil(1999, 8, 1, 0, 0, 0).unwrap(),
            declination: (18.0, 10.0, 51.9),
            gha: (178.0, 24.0, 39.3),
        },
    );
    assert!(position.elevation_deg > 5.0 && position.elevation_deg < 8.0);
    assert!(position.azimuth_deg > 330.0 || position.azimuth_deg < 30.0);
}

#[test]
fn more_ephemeris_days() {
    // Bern on 1999-01-01 (Dec −23° 03′ 09.3″, GHA 179° 12′ 41.8″) and 1999-09-21
    // (Dec +0° 57′ 52.8″, GHA 181° 39′ 14.4″): the sun is below the horizon at 0 h UT, which
    // exercises the night side.
    for ephemeris in [
        Ephemeris {
            at: UtcInstant::from_civil(1999, 1, 1, 0, 0, 0).unwrap(),
            declination: (-23.0, 3.0, 9.3),
            gha: (179.0, 12.0, 41.8),
        },
        Ephemeris {
            at: UtcInstant::from_civil(1999, 9, 21, 0, 0, 0).unwrap(),
            declination: (0.0, 57.0, 52.8),
            gha: (181.0, 39.0, 14.4),
        },
    ] {
        let position = check_against_ephemeris(&BERN, &ephemeris);
        assert!(position.elevation_deg < -40.0);
        assert_eq!(position.elevation_deg, position.geometric_elevation_deg);
    }
}

#[test]
fn refraction_lifts_the_sun_near_the_horizon_only() {
    // Sunrise at Bern on 2021-05-03 is near 04:10 UTC: find the instant the geometric
    // elevation crosses +0.5° by bisection.
    let options = SolarOptions::default();
    let day = UtcInstant::from_civil(2021, 5, 3, 0, 0, 0)
        .unwrap()
        .unix_seconds() as f64;
    let elevation =
        |t: f64| solar_position_unix_seconds(&BERN, t, &options).geometric_elevation_deg;
    let (mut before, mut after) = (day + 3.0 * 3600.0, day + 6.0 * 3600.0);
    while after - before > 1.0 {
        let middle = 0.5 * (before + after);
        if elevation(middle) < 0.5 {
            before = middle;
        } else {
            after = middle;
        }
    }
    let low = solar_position_unix_seconds(&BERN, after, &options);
    let lift = low.elevation_deg - low.geometric_elevation_deg;
    // Bennett's refraction at 0.5° apparent altitude is about 0.4° (24′) at 1013 hPa, 15 °C.
    assert!(lift > 0.3 && lift < 0.5, "lift {lift}");
    let noon = solar_position(
        &BERN,
        UtcInstant::from_civil(2021, 5, 3, 11, 20, 0).unwrap(),
        &options,
    );
    assert!(noon.elevation_deg - noon.geometric_elevation_deg < 0.02);
}

#[test]
fn direction_is_a_unit_vector_in_east_north_up() {
    let east = direction_enu(0.0, 90.0);
    assert!((east[0] - 1.0).abs() < 1e-12 && east[1].abs() < 1e-12 && east[2].abs() < 1e-12);
    let up = direction_enu(90.0, 123.0);
    assert!((up[2] - 1.0).abs() < 1e-12);
    let south_low = direction_enu(10.0, 180.0);
    assert!(south_low[1] < 0.0 && south_low[2] > 0.0);
    let position = solar_position(
        &BERN,
        UtcInstant::from_civil(2021, 5, 3, 15, 0, 0).unwrap(),
        &SolarOptions::default(),
    );
    let [e, n, u] = position.direction_enu();
    assert!(((e * e + n * n + u * u).sqrt() - 1.0).abs() < 1e-12);
    // Afternoon: the sun is in the south-west.
    assert!(e < 0.0 && n < 0.0 && u > 0.0);
}

#[test]
fn stays_finite_at_the_poles_and_far_dates() {
    for latitude_deg in [-90.0, -89.999, 0.0, 89.999, 90.0] {
        for year in [-1000, 1900, 2021, 3000] {
            let observer = Observer {
                latitude_deg,
                longitude_deg: 0.0,
                elevation_m: 0.0,
            };
            let at = UtcInstant::from_civil(year, 6, 21, 12, 0, 0).unwrap();
            let position = solar_position(&observer, at, &SolarOptions::default());
            assert!(position.zenith_deg.is_finite() && position.azimuth_deg.is_finite());
            assert!((0.0..360.0).contains(&position.azimuth_deg));
        }
    }
}

#[test]
fn delta_t_estimates_are_close_to_measured_values() {
    // Measured ΔT (IERS): 1960.0 33.2 s, 1980.0 50.5 s, 2000.0 63.8 s, 2003.8 64.5 s,
    // 2020.0 69.4 s.
    for (year, measured, tolerance) in [
        (1960.0, 33.2, 1.0),
        (1980.0, 50.5, 1.0),
        (2000.0, 63.8, 0.5),
        (2003.8, 64.5, 0.5),
        (2020.0, 69.4, 3.0),
    ] {
        let estimate = estimate_delta_t_s(year);
        assert!(
            (estimate - measured).abs() < tolerance,
            "{year}: {estimate}"
        );
    }
}
