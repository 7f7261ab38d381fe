//! The crate's lunar position against a published ephemeris: `PyEphem` (`validation/moon/`, which
//! says how the table is made), at 1 000 random places and instants between 1900 and 2100.

use super::*;

/// The committed table, relative to the crate root.
const TABLE: &str = "validation/moon/ephem_moon.csv";
/// The columns the table must have, in order.
const HEADER: &str = "unix_s,latitude_deg,longitude_deg,elevation_m,altitude_deg,azimuth_deg,\
                      illuminated_fraction,distance_km";
/// The largest angle on the sky between the crate's moon and the ephemeris's, degrees (the
/// validation target).
const TOLERANCE_DEG: f64 = 0.1;
/// The largest difference in illuminated fraction (the validation target: the phase within 2 %).
const PHASE_TOLERANCE: f64 = 0.02;
/// The largest relative difference in distance: 1 % moves the moon's parallax (at most about
/// 1°) by 0.01°, a tenth of [`TOLERANCE_DEG`].
const DISTANCE_TOLERANCE: f64 = 0.01;

/// One row of the table.
#[derive(Debug, Clone, Copy)]
struct Case {
    unix_s: f64,
    observer: Observer,
    altitude_deg: f64,
    azimuth_deg: f64,
    illuminated_fraction: f64,
    distance_km: f64,
}

/// The cases of `text` (the contents of `file`); an error names the file, the row (1 is the
/// header) and what is wrong.
fn parse_table(file: &str, text: &str) -> Result<Vec<Case>, String> {
    crate::reference::table::parse_table(file, text, HEADER, 8, |_, values| {
        let &[unix_s, lat, lon, h, altitude, azimuth, fraction, distance] = values else {
            unreachable!("the reader checks the field count");
        };
        if !(-90.0..=90.0).contains(&lat) || !(0.0..=1.0).contains(&fraction) || distance <= 0.0 {
            return Err(format!(
                "latitude {lat}, illuminated fraction {fraction} or distance {distance} out of range"
            ));
        }
        Ok(Case {
            unix_s,
            observer: Observer {
                latitude_deg: lat,
                longitude_deg: lon,
                elevation_m: h,
            },
            altitude_deg: altitude,
            azimuth_deg: azimuth,
            illuminated_fraction: fraction,
            distance_km: distance,
        })
    })
}

fn table() -> Vec<Case> {
    crate::reference::table::read_committed(TABLE, parse_table)
}

/// The angle between two directions given as elevation and azimuth, degrees.
fn separation_deg((e1, a1): (f64, f64), (e2, a2): (f64, f64)) -> f64 {
    let [x1, y1, z1] = super::super::solar::direction_enu(e1, a1);
    let [x2, y2, z2] = super::super::solar::direction_enu(e2, a2);
    (x1 * x2 + y1 * y2 + z1 * z2)
        .clamp(-1.0, 1.0)
        .acos()
        .to_degrees()
}

#[test]
fn moon_matches_ephem() {
    let cases = table();
    assert_eq!(cases.len(), 1000, "{TABLE}");
    let options = SolarOptions {
        refraction: false,
        ..SolarOptions::default()
    };
    let (mut sky, mut phase, mut distance) = (0.0_f64, 0.0_f64, 0.0_f64);
    for case in &cases {
        let moon = lunar_position_unix_seconds(&case.observer, case.unix_s, &options);
        let angle = separation_deg(
            (moon.geometric_elevation_deg, moon.azimuth_deg),
            (case.altitude_deg, case.azimuth_deg),
        );
        let fraction = (moon.illuminated_fraction - case.illuminated_fraction).abs();
        let range = (moon.distance_km / case.distance_km - 1.0).abs();
        assert!(
            angle <= TOLERANCE_DEG && fraction <= PHASE_TOLERANCE && range <= DISTANCE_TOLERANCE,
            "{case:?}: {moon:?} is {angle:.4}° away, fraction off by {fraction:.4}, distance \
             by {:.3} %",
            100.0 * range
        );
        sky = sky.max(angle);
        phase = phase.max(fraction);
        distance = distance.max(range);
    }
    println!(
        "moon against PyEphem over {} cases: largest angle on the sky {sky:.4}° (target \
         {TOLERANCE_DEG}°), illuminated fraction {phase:.4} (target {PHASE_TOLERANCE}), distance \
         {:.3} %",
        cases.len(),
        100.0 * distance
    );
}

#[test]
fn the_moon_waxes_after_new_moon_and_is_full_half_a_month_later() {
    // The new moon of 2024-04-08 18:21 UTC (the total solar eclipse) and the full moon of
    // 2024-04-23 23:49 UTC (PyEphem's `next_new_moon` and `next_full_moon`: 18:20:49 and
    // 23:48:56).
    let bern = Observer {
        latitude_deg: 46.95,
        longitude_deg: 7.44,
        elevation_m: 540.0,
    };
    let options = SolarOptions::default();
    let new = lunar_position_unix_seconds(&bern, 1_712_600_460.0, &options);
    let full = lunar_position_unix_seconds(&bern, 1_713_916_140.0, &options);
    let waxing = lunar_position_unix_seconds(&bern, 1_713_000_000.0, &options);
    assert!(new.illuminated_fraction < 0.001, "{new:?}");
    assert!(full.illuminated_fraction > 0.99, "{full:?}");
    assert!(
        waxing.waxing && waxing.illuminated_fraction > 0.1 && waxing.illuminated_fraction < 0.9
    );
    // The disc's radius lies between the apogee's and the perigee's (406 700 and 356 500 km).
    let radius = |distance_km: f64| (MOON_RADIUS_KM / distance_km).asin().to_degrees();
    assert!(
        (radius(406_700.0)..=radius(356_500.0)).contains(&full.radius_deg()),
        "{}",
        full.radius_deg()
    );
    let [east, north, up] = full.direction_enu();
    assert!(((east * east + north * north + up * up).sqrt() - 1.0).abs() < 1e-12);
}

#[test]
fn stays_finite_at_the_poles_and_far_dates() {
    for latitude_deg in [-90.0, 0.0, 90.0] {
        for unix_s in [-7.0e10, 0.0, 1.0e10] {
            let observer = Observer {
                latitude_deg,
                longitude_deg: 180.0,
                elevation_m: 0.0,
            };
            let moon = lunar_position_unix_seconds(&observer, unix_s, &SolarOptions::default());
            assert!(
                moon.elevation_deg.is_finite()
                    && moon.azimuth_deg.is_finite()
                    && (0.0..=1.0).contains(&moon.illuminated_fraction),
                "{latitude_deg}, {unix_s}: {moon:?}"
            );
        }
    }
}

#[test]
fn a_broken_moon_table_names_the_file_and_row() {
    let row = "0,46.9,7.4,540,10,180,0.5,384400";
    assert_eq!(
        parse_table("m.csv", &format!("{HEADER}\n{row}\n")).map(|c| c.len()),
        Ok(1)
    );
    let cases = [
        ("", "m.csv: empty"),
        ("a,b\n", "m.csv: row 1: header"),
        (
            &format!("{HEADER}\n{row}\n0,1,2\n"),
            "m.csv: row 3: 3 fields",
        ),
        (
            &format!("{HEADER}\n0,46.9,7.4,540,x,180,0.5,384400\n"),
            "m.csv: row 2: \"x\" is not a number",
        ),
        (
            &format!("{HEADER}\n0,46.9,7.4,540,10,180,1.5,384400\n"),
            "m.csv: row 2: latitude 46.9, illuminated fraction 1.5",
        ),
    ];
    for (text, expected) in cases {
        let error = parse_table("m.csv", text).expect_err(text);
        assert!(error.starts_with(expected), "{error:?} for {text:?}");
    }
}
